//! Drivers and layers for the tests that go through the real Vulkan loader
//! (`tests/drivers.rs`, and later the layer's end-to-end tests).
//!
//! No Debian binary package ships a driver with `VK_EXT_opacity_micromap`,
//! so the Khronos Mock ICD is built from the source package `vulkan-tools`
//! and cached under the target directory. lavapipe, a CPU driver that runs
//! acceleration-structure builds, comes from `mesa-vulkan-drivers` (on
//! bookworm from bookworm-backports: bookworm's own 22.3 has no acceleration
//! structures). The Khronos validation layer comes from
//! `vulkan-validationlayers`, for tests that stack it with ours.
//!
//! The tests learn where each one is from environment variables that
//! [`prepare`] returns; a test whose variable is absent skips locally and
//! fails in CI. In CI every step here must succeed; locally a failed step is
//! a warning.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::host::{apt_install, in_ci, is_root};
use crate::Error;

/// The Mock ICD's manifest (a file) for `VK_DRIVER_FILES`.
pub const MOCK_ICD_VAR: &str = "OMMCHECK_TEST_MOCK_ICD";
/// lavapipe's manifest (a file) for `VK_DRIVER_FILES`.
pub const LAVAPIPE_ICD_VAR: &str = "OMMCHECK_TEST_LAVAPIPE_ICD";
/// The directory holding `VkLayer_khronos_validation.json`, for
/// `VK_ADD_LAYER_PATH`.
pub const KHRONOS_LAYER_VAR: &str = "OMMCHECK_TEST_KHRONOS_LAYER";

/// Debian packages the driver tests need: the loader, the headers and CMake
/// package the Mock ICD's build finds, the build tools, xz for the source
/// tarball, and the Khronos validation layer.
const PACKAGES: &[&str] = &[
    "libvulkan1",
    "libvulkan-dev",
    "cmake",
    "g++",
    "make",
    "xz-utils",
    "vulkan-validationlayers",
];

const MOCK_MANIFEST: &str = "VkICD_mock_icd.json";
const MOCK_LIBRARY: &str = "libVkICD_mock_icd.so";
const KHRONOS_MANIFEST: &str = "VkLayer_khronos_validation.json";

/// Where distributions install driver and layer manifests (the loader's
/// default search path, without the per-user XDG directories).
const ICD_DIRS: &[&str] = &[
    "/usr/share/vulkan/icd.d",
    "/usr/local/share/vulkan/icd.d",
    "/etc/vulkan/icd.d",
];
const LAYER_DIRS: &[&str] = &[
    "/usr/share/vulkan/explicit_layer.d",
    "/usr/local/share/vulkan/explicit_layer.d",
    "/etc/vulkan/explicit_layer.d",
];

/// lavapipe gained `VK_KHR_acceleration_structure` in Mesa 24.1.
const LAVAPIPE_MIN_AS: (u32, u32) = (24, 1);

/// Prepares every driver and layer the loader tests use and returns the
/// environment variables that tell the tests where they are. With `install`
/// false nothing is installed with apt (what is missing is reported); the
/// Mock ICD is still built into the target directory when its tools are
/// present.
pub fn prepare(root: &Path, install: bool) -> Result<Vec<(&'static str, PathBuf)>, Error> {
    let mut vars = Vec::new();
    let mut failures = Vec::new();
    let release = OsRelease::read();

    step("packages", &mut failures, || packages(install));

    let work = step("target directory", &mut failures, || {
        let dir = target_dir(root)?.join("vulkan-drivers");
        Ok((format!("{}", dir.display()), dir))
    });
    let mut apt = work
        .as_ref()
        .map(|work| PrivateApt::new(work.join("apt"), &release));

    if let Some(path) = step("Mock ICD", &mut failures, || {
        let (work, apt) = work
            .as_ref()
            .zip(apt.as_mut())
            .ok_or("the target directory is unknown")?;
        mock_icd(work, apt)
    }) {
        vars.push((MOCK_ICD_VAR, path));
    }
    if let Some(path) = step("lavapipe", &mut failures, || {
        lavapipe(&release, apt.as_mut(), install)
    }) {
        vars.push((LAVAPIPE_ICD_VAR, path));
    }
    if let Some(path) = step("Khronos validation layer", &mut failures, khronos_layer) {
        vars.push((KHRONOS_LAYER_VAR, path));
    }

    for (name, value) in &vars {
        eprintln!("xtask: drivers: {name}={}", value.display());
    }
    if !failures.is_empty() {
        let failures = failures.join("; ");
        if in_ci() {
            return Err(Error::Tool(format!(
                "driver preparation failed: {failures}"
            )));
        }
        eprintln!(
            "xtask: warning: driver preparation incomplete ({failures}); \
             the tests that need it will be skipped"
        );
    }
    Ok(vars)
}

/// Runs one step, printing one line with what it did or found and how long
/// it took. A failure is recorded and the step yields nothing.
fn step<T>(
    name: &str,
    failures: &mut Vec<String>,
    f: impl FnOnce() -> Result<(String, T), String>,
) -> Option<T> {
    let start = Instant::now();
    let result = f();
    let seconds = start.elapsed().as_secs_f64();
    match result {
        Ok((what, value)) => {
            eprintln!("xtask: drivers: {name}: {what} ({seconds:.1} s)");
            Some(value)
        }
        Err(why) => {
            eprintln!("xtask: drivers: {name}: FAILED: {why} ({seconds:.1} s)");
            failures.push(format!("{name}: {}", why.lines().next().unwrap_or("")));
            None
        }
    }
}

/// Runs a command with its output captured; on failure the error carries the
/// end of its output, which is where compilers and apt say what went wrong.
fn run_quiet(description: &str, command: &mut Command) -> Result<String, String> {
    let output = command
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{description}: could not start {command:?}: {e}"))?;
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    if output.status.success() {
        return Ok(stdout);
    }
    let all = format!("{stdout}{}", String::from_utf8_lossy(&output.stderr));
    let lines: Vec<&str> = all.lines().collect();
    let tail = lines[lines.len().saturating_sub(30)..].join("\n");
    Err(format!(
        "{description} failed ({}): {command:?}\n{tail}",
        output.status
    ))
}

/// `apt-get` run as root and without questions: directly when we are root,
/// else through sudo, which is given the variable as an argument because it
/// drops the environment it is started with.
fn apt_get_as_root() -> Command {
    if is_root() {
        let mut command = Command::new("apt-get");
        command.env("DEBIAN_FRONTEND", "noninteractive");
        command
    } else {
        let mut command = Command::new("sudo");
        command.args(["DEBIAN_FRONTEND=noninteractive", "apt-get"]);
        command
    }
}

fn installed_packages(packages: &[&str]) -> Result<BTreeSet<String>, String> {
    // dpkg-query exits 1 when a package is unknown but still prints the
    // others, so its status is not checked.
    let output = Command::new("dpkg-query")
        .args(["-W", "-f=${Package} ${db:Status-Status}\n"])
        .args(packages)
        .stderr(Stdio::null())
        .output()
        .map_err(|e| {
            format!(
                "no dpkg-query ({e}); install {} yourself",
                packages.join(" ")
            )
        })?;
    Ok(String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|l| l.strip_suffix(" installed"))
        .map(|p| p.split(':').next().unwrap_or(p).to_string())
        .collect())
}

fn packages(install: bool) -> Result<(String, ()), String> {
    let present = installed_packages(PACKAGES)?;
    let missing: Vec<&str> = PACKAGES
        .iter()
        .copied()
        .filter(|p| !present.contains(*p))
        .collect();
    if missing.is_empty() {
        return Ok((format!("all {} installed", PACKAGES.len()), ()));
    }
    if !install {
        return Err(format!(
            "not installed (--no-install): {}",
            missing.join(" ")
        ));
    }
    apt_install(&missing).map_err(|e| e.to_string())?;
    Ok((format!("installed {}", missing.join(" ")), ()))
}

/// The workspace's target directory as cargo resolves it (CARGO_TARGET_DIR,
/// `build.target-dir`, or `target/`), so CI caches the Mock ICD where it
/// caches the build.
fn target_dir(root: &Path) -> Result<PathBuf, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = run_quiet(
        "cargo metadata",
        Command::new(cargo).current_dir(root).args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
        ]),
    )?;
    let meta: serde_json::Value =
        serde_json::from_str(&out).map_err(|e| format!("cargo metadata: not JSON: {e}"))?;
    meta["target_directory"]
        .as_str()
        .map(PathBuf::from)
        .ok_or_else(|| "cargo metadata: no target_directory".into())
}

fn mkdir(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))
}

/// `/etc/os-release`, the two fields the steps need.
struct OsRelease {
    id: String,
    codename: String,
}

impl OsRelease {
    fn read() -> Self {
        let text = std::fs::read_to_string("/etc/os-release").unwrap_or_default();
        let field = |name: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(name)?.strip_prefix('='))
                .map(|v| v.trim().trim_matches('"').to_string())
                .unwrap_or_default()
        };
        OsRelease {
            id: field("ID"),
            codename: field("VERSION_CODENAME"),
        }
    }

    fn is_bookworm(&self) -> bool {
        self.id == "debian" && self.codename == "bookworm"
    }
}

/// An apt configuration of our own under the target directory, derived from
/// the machine's sources: the release's suites as they are, plus `deb-src`
/// for the release (the Mock ICD's source) and, on bookworm, `deb` for
/// bookworm-backports (lavapipe). Its lists and caches are private, so the
/// machine's apt configuration is never changed and no mirror is named in
/// the repository.
struct PrivateApt {
    dir: PathBuf,
    codename: String,
    backports: bool,
    updated: bool,
}

impl PrivateApt {
    fn new(dir: PathBuf, release: &OsRelease) -> Self {
        PrivateApt {
            dir,
            codename: release.codename.clone(),
            backports: release.is_bookworm(),
            updated: false,
        }
    }

    /// The options that point apt at this configuration.
    fn options(&self) -> Vec<String> {
        let d = self.dir.display();
        vec![
            "-o".into(),
            "Dir::Etc::SourceList=/dev/null".into(),
            "-o".into(),
            format!("Dir::Etc::SourceParts={d}/sources.list.d"),
            "-o".into(),
            format!("Dir::State::Lists={d}/lists"),
            "-o".into(),
            format!("Dir::Cache={d}/cache"),
        ]
    }

    /// Writes the sources and runs `apt-get update` once per run.
    fn update(&mut self) -> Result<(), String> {
        if self.updated {
            return Ok(());
        }
        if self.codename.is_empty() {
            return Err("/etc/os-release names no VERSION_CODENAME".into());
        }
        let sources = derive_sources(&system_sources()?, &self.codename, self.backports)?;
        let parts = self.dir.join("sources.list.d");
        for dir in [
            parts.clone(),
            self.dir.join("lists/partial"),
            self.dir.join("cache/archives/partial"),
        ] {
            mkdir(&dir)?;
        }
        let file = parts.join("ommcheck.sources");
        std::fs::write(&file, sources).map_err(|e| format!("writing {}: {e}", file.display()))?;
        run_quiet(
            "apt-get update (private sources)",
            Command::new("apt-get").args(self.options()).arg("update"),
        )?;
        self.updated = true;
        Ok(())
    }
}

/// One deb822 stanza: fields in order, values with their continuation lines.
#[derive(Clone, Debug, PartialEq)]
struct Stanza(Vec<(String, String)>);

impl Stanza {
    fn get(&self, name: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }

    fn set(&mut self, name: &str, value: &str) {
        match self
            .0
            .iter_mut()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
        {
            Some((_, v)) => *v = value.to_string(),
            None => self.0.push((name.to_string(), value.to_string())),
        }
    }

    fn words(&self, name: &str) -> Vec<&str> {
        self.get(name).unwrap_or("").split_whitespace().collect()
    }
}

/// Parses deb822 `.sources` text, dropping disabled stanzas.
fn parse_deb822(text: &str) -> Vec<Stanza> {
    let mut stanzas = Vec::new();
    let mut current: Vec<(String, String)> = Vec::new();
    let mut flush = |current: &mut Vec<(String, String)>| {
        if !current.is_empty() {
            stanzas.push(Stanza(std::mem::take(current)));
        }
    };
    for line in text.lines() {
        if line.trim().is_empty() {
            flush(&mut current);
        } else if line.starts_with('#') {
            continue;
        } else if line.starts_with([' ', '\t']) {
            if let Some((_, value)) = current.last_mut() {
                value.push('\n');
                value.push_str(line);
            }
        } else if let Some((name, value)) = line.split_once(':') {
            current.push((name.trim().to_string(), value.trim().to_string()));
        }
    }
    flush(&mut current);
    stanzas.retain(|s| {
        !s.get("Enabled")
            .is_some_and(|v| v.eq_ignore_ascii_case("no"))
    });
    stanzas
}

/// Parses one-line `sources.list` text into stanzas.
fn parse_one_line(text: &str) -> Vec<Stanza> {
    let mut stanzas = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some((kind, rest)) = line.split_once(char::is_whitespace) else {
            continue;
        };
        if kind != "deb" && kind != "deb-src" {
            continue;
        }
        let mut rest = rest.trim_start();
        let mut fields = vec![("Types".to_string(), kind.to_string())];
        if let Some(after) = rest.strip_prefix('[') {
            let Some((options, after)) = after.split_once(']') else {
                continue;
            };
            for option in options.split_whitespace() {
                let Some((key, value)) = option.split_once('=') else {
                    continue;
                };
                let name = match key {
                    "signed-by" => "Signed-By",
                    "arch" => "Architectures",
                    "trusted" => "Trusted",
                    _ => continue,
                };
                fields.push((name.to_string(), value.replace(',', " ")));
            }
            rest = after.trim_start();
        }
        let mut words = rest.split_whitespace();
        let (Some(uri), Some(suite)) = (words.next(), words.next()) else {
            continue;
        };
        fields.push(("URIs".into(), uri.into()));
        fields.push(("Suites".into(), suite.into()));
        fields.push(("Components".into(), words.collect::<Vec<_>>().join(" ")));
        stanzas.push(Stanza(fields));
    }
    stanzas
}

/// Every source the machine's apt uses.
fn system_sources() -> Result<Vec<Stanza>, String> {
    let mut stanzas = Vec::new();
    if let Ok(text) = std::fs::read_to_string("/etc/apt/sources.list") {
        stanzas.extend(parse_one_line(&text));
    }
    let dir = Path::new("/etc/apt/sources.list.d");
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| entries.filter_map(|e| Some(e.ok()?.path())).collect())
        .unwrap_or_default();
    files.sort();
    for file in files {
        let parse = match file.extension().and_then(|e| e.to_str()) {
            Some("sources") => parse_deb822,
            Some("list") => parse_one_line,
            _ => continue,
        };
        let text = std::fs::read_to_string(&file)
            .map_err(|e| format!("reading {}: {e}", file.display()))?;
        stanzas.extend(parse(&text));
    }
    Ok(stanzas)
}

/// The private configuration: the machine's `deb` stanzas of `codename` and
/// its update suites (other vendors' repositories are left out, so their
/// state cannot break this), then `deb-src` of the stanza that carries the
/// release itself, then, when asked and not already configured, `deb` of
/// `<codename>-backports` from that same stanza.
fn derive_sources(system: &[Stanza], codename: &str, backports: bool) -> Result<String, String> {
    let of_release = |suite: &str| {
        suite == codename
            || suite
                .strip_prefix(codename)
                .is_some_and(|rest| rest.starts_with('-'))
    };
    let debs: Vec<&Stanza> = system
        .iter()
        .filter(|s| s.words("Types").contains(&"deb"))
        .filter(|s| s.words("Suites").iter().any(|suite| of_release(suite)))
        .collect();
    let main = debs
        .iter()
        .find(|s| s.words("Suites").contains(&codename))
        .ok_or_else(|| format!("no apt source for the release {codename} in /etc/apt"))?;
    let backports_suite = format!("{codename}-backports");
    let mut out: Vec<Stanza> = Vec::new();
    for stanza in &debs {
        let mut copy = (*stanza).clone();
        let suites: Vec<&str> = stanza
            .words("Suites")
            .into_iter()
            .filter(|s| of_release(s))
            .collect();
        copy.set("Types", "deb");
        copy.set("Suites", &suites.join(" "));
        out.push(copy);
    }
    let mut src = (*main).clone();
    src.set("Types", "deb-src");
    src.set("Suites", codename);
    out.push(src);
    let configured = debs
        .iter()
        .any(|s| s.words("Suites").contains(&backports_suite.as_str()));
    if backports && !configured {
        let mut bpo = (*main).clone();
        bpo.set("Types", "deb");
        bpo.set("Suites", &backports_suite);
        out.push(bpo);
    }
    let mut text = String::from("# Written by cargo xtask test from /etc/apt; do not edit.\n");
    for stanza in out {
        text.push('\n');
        for (name, value) in stanza.0 {
            let _ = writeln!(text, "{name}: {value}");
        }
    }
    Ok(text)
}

/// The Mock ICD, built once from the release's `vulkan-tools` source package
/// into `<target>/vulkan-drivers/mock-icd/`.
fn mock_icd(work: &Path, apt: &mut PrivateApt) -> Result<(String, PathBuf), String> {
    let out = work.join("mock-icd");
    let manifest = out.join(MOCK_MANIFEST);
    let library = out.join(MOCK_LIBRARY);
    if manifest.is_file() && library.is_file() {
        return Ok((format!("cached in {}", out.display()), manifest));
    }
    apt.update()?;

    // A fresh source directory each time, so a half-finished earlier attempt
    // cannot leave a second tarball or tree behind.
    let src = work.join("src");
    if src.exists() {
        std::fs::remove_dir_all(&src).map_err(|e| format!("removing {}: {e}", src.display()))?;
    }
    mkdir(&src)?;
    run_quiet(
        "apt-get source vulkan-tools",
        Command::new("apt-get")
            .current_dir(&src)
            .args(apt.options())
            .args(["source", "--download-only", "vulkan-tools"]),
    )?;
    let tarball = only_entry(&src, |name| name.contains(".orig.tar."))?;
    let version = tarball
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_prefix("vulkan-tools_"))
        .and_then(|n| n.split(".orig.tar.").next())
        .unwrap_or("?")
        .to_string();
    run_quiet(
        "unpacking vulkan-tools",
        Command::new("tar")
            .current_dir(&src)
            .arg("xf")
            .arg(&tarball),
    )?;
    let tree = std::fs::read_dir(&src)
        .map_err(|e| format!("reading {}: {e}", src.display()))?
        .filter_map(|e| Some(e.ok()?.path()))
        .find(|p| p.join("icd").is_dir())
        .ok_or_else(|| format!("no source tree with icd/ in {}", src.display()))?;

    let build = work.join("build");
    if build.exists() {
        std::fs::remove_dir_all(&build)
            .map_err(|e| format!("removing {}: {e}", build.display()))?;
    }
    // Only the ICD: the cube and vulkaninfo would need X11, Wayland and
    // glslang. Werror off: a newer compiler must not fail a release build.
    run_quiet(
        "cmake configure",
        Command::new("cmake")
            .arg("-S")
            .arg(&tree)
            .arg("-B")
            .arg(&build)
            .args([
                "-DCMAKE_BUILD_TYPE=Release",
                "-DBUILD_ICD=ON",
                "-DBUILD_CUBE=OFF",
                "-DBUILD_VULKANINFO=OFF",
                "-DBUILD_WERROR=OFF",
                "-DBUILD_TESTS=OFF",
            ]),
    )?;
    let jobs = std::thread::available_parallelism().map_or(2, |n| n.get());
    run_quiet(
        "building VkICD_mock_icd",
        Command::new("cmake")
            .arg("--build")
            .arg(&build)
            .args(["--target", "VkICD_mock_icd", "--parallel"])
            .arg(jobs.to_string()),
    )?;
    let built = find_file(&build, MOCK_LIBRARY)
        .ok_or_else(|| format!("the build made no {MOCK_LIBRARY} in {}", build.display()))?;
    // The upstream manifest names the library relatively; ours names it by
    // absolute path, so the manifest works from wherever a test reads it.
    let upstream = find_file(&build, MOCK_MANIFEST)
        .or_else(|| find_file(&tree.join("icd"), MOCK_MANIFEST))
        .ok_or_else(|| format!("no {MOCK_MANIFEST} in the build or the source"))?;
    let text = std::fs::read_to_string(&upstream)
        .map_err(|e| format!("reading {}: {e}", upstream.display()))?;
    let mut json: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", upstream.display()))?;

    mkdir(&out)?;
    let out = out
        .canonicalize()
        .map_err(|e| format!("resolving {}: {e}", out.display()))?;
    let library = out.join(MOCK_LIBRARY);
    let manifest = out.join(MOCK_MANIFEST);
    std::fs::copy(&built, &library)
        .map_err(|e| format!("copying {} to {}: {e}", built.display(), library.display()))?;
    let icd = json
        .get_mut("ICD")
        .and_then(|v| v.as_object_mut())
        .ok_or_else(|| format!("{}: no ICD object", upstream.display()))?;
    icd.insert(
        "library_path".into(),
        serde_json::Value::String(library.display().to_string()),
    );
    // Written under another name and renamed, so that the cache check never
    // sees a partial manifest.
    let partial = out.join(format!("{MOCK_MANIFEST}.partial"));
    let pretty = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    std::fs::write(&partial, pretty + "\n")
        .map_err(|e| format!("writing {}: {e}", partial.display()))?;
    std::fs::rename(&partial, &manifest)
        .map_err(|e| format!("renaming {}: {e}", partial.display()))?;
    Ok((
        format!("built from vulkan-tools {version} into {}", out.display()),
        manifest,
    ))
}

/// The one entry of `dir` whose name passes `keep`.
fn only_entry(dir: &Path, keep: impl Fn(&str) -> bool) -> Result<PathBuf, String> {
    let found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("reading {}: {e}", dir.display()))?
        .filter_map(|e| Some(e.ok()?.path()))
        .filter(|p| p.file_name().and_then(|n| n.to_str()).is_some_and(&keep))
        .collect();
    match found.as_slice() {
        [one] => Ok(one.clone()),
        [] => Err(format!("nothing expected in {}", dir.display())),
        _ => Err(format!(
            "several candidates in {}: {found:?}",
            dir.display()
        )),
    }
}

/// The first file named `name` below `dir`, depth first.
fn find_file(dir: &Path, name: &str) -> Option<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| Some(e.ok()?.path()))
        .collect();
    entries.sort();
    for path in &entries {
        if path.is_file() && path.file_name().is_some_and(|n| n == name) {
            return Some(path.clone());
        }
    }
    entries
        .iter()
        .filter(|p| p.is_dir() && !p.is_symlink())
        .find_map(|p| find_file(p, name))
}

/// The installed version of a package, if any.
fn installed_version(package: &str) -> Option<String> {
    let out = Command::new("dpkg-query")
        .args(["-W", "-f=${db:Status-Status} ${Version}", package])
        .stderr(Stdio::null())
        .output()
        .ok()?;
    String::from_utf8_lossy(&out.stdout)
        .strip_prefix("installed ")
        .map(str::to_string)
}

/// Whether a Debian version of Mesa has lavapipe with acceleration
/// structures: upstream major.minor at least [`LAVAPIPE_MIN_AS`].
fn lavapipe_has_as(version: &str) -> bool {
    let upstream = version.split_once(':').map_or(version, |(_, v)| v);
    let mut parts = upstream.split(|c: char| !c.is_ascii_digit());
    let major = parts.next().and_then(|p| p.parse::<u32>().ok());
    let minor = parts.next().and_then(|p| p.parse::<u32>().ok());
    match (major, minor) {
        (Some(major), Some(minor)) => (major, minor) >= LAVAPIPE_MIN_AS,
        _ => false,
    }
}

/// lavapipe's manifest among the installed ICD manifests.
fn lavapipe_manifest() -> Option<PathBuf> {
    ICD_DIRS.iter().find_map(|dir| {
        let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
            .ok()?
            .filter_map(|e| Some(e.ok()?.path()))
            .filter(|p| {
                p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with("lvp_icd") && n.ends_with(".json"))
            })
            .collect();
        found.sort();
        // Prefer the machine's own architecture when several are installed.
        let arch = format!(".{}.json", std::env::consts::ARCH);
        found
            .iter()
            .find(|p| p.to_string_lossy().ends_with(&arch))
            .or(found.first())
            .cloned()
    })
}

/// lavapipe's manifest where the installed Mesa has acceleration
/// structures; None where it is missing or too old (installs nothing).
pub(crate) fn installed_lavapipe() -> Option<PathBuf> {
    installed_version("mesa-vulkan-drivers").filter(|v| lavapipe_has_as(v))?;
    lavapipe_manifest()
}

fn lavapipe(
    release: &OsRelease,
    apt: Option<&mut PrivateApt>,
    install: bool,
) -> Result<(String, PathBuf), String> {
    let found = |how: String| {
        let manifest = lavapipe_manifest().ok_or_else(|| {
            "mesa-vulkan-drivers is installed but no lvp_icd*.json was found".to_string()
        })?;
        Ok((format!("{how}, {}", manifest.display()), manifest))
    };
    let installed = installed_version("mesa-vulkan-drivers");
    if let Some(version) = installed.as_deref().filter(|v| lavapipe_has_as(v)) {
        return found(format!("mesa-vulkan-drivers {version} installed"));
    }
    let had = installed.map_or("not installed".into(), |v| format!("{v} installed"));
    if release.is_bookworm() {
        if !install {
            return Err(format!(
                "mesa-vulkan-drivers {had}, lacks acceleration structures; \
                 not installing it from bookworm-backports (--no-install)"
            ));
        }
        let apt = apt.ok_or("no private apt configuration")?;
        apt.update()?;
        // Only lists and the package database are read from our
        // configuration; packages are downloaded to the system's archive
        // cache, so nothing root-owned lands in the target directory.
        let mut command = apt_get_as_root();
        command
            .args(apt.options())
            .args([
                "-o",
                "Dir::Cache::Archives=/var/cache/apt/archives/",
                "-o",
                "Dir::Cache::pkgcache=",
                "-o",
                "Dir::Cache::srcpkgcache=",
            ])
            .args([
                "install",
                "-y",
                "--no-install-recommends",
                "-t",
                "bookworm-backports",
                "mesa-vulkan-drivers",
            ]);
        run_quiet("apt-get install -t bookworm-backports", &mut command)?;
        let now = installed_version("mesa-vulkan-drivers").unwrap_or_default();
        return found(format!(
            "installed mesa-vulkan-drivers {now} from bookworm-backports"
        ));
    }
    // Other releases: their own Mesa, when it is new enough.
    let candidate = Command::new("apt-cache")
        .args(["show", "--no-all-versions", "mesa-vulkan-drivers"])
        .output()
        .ok()
        .and_then(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .find_map(|l| l.strip_prefix("Version: "))
                .map(str::to_string)
        });
    match candidate {
        Some(v) if lavapipe_has_as(&v) => {
            if !install {
                return Err(format!(
                    "mesa-vulkan-drivers {had}; not installing {v} (--no-install)"
                ));
            }
            apt_install(&["mesa-vulkan-drivers"]).map_err(|e| e.to_string())?;
            found(format!("installed mesa-vulkan-drivers {v}"))
        }
        Some(v) => Err(format!(
            "skipped: {} {}'s mesa-vulkan-drivers {v} has no acceleration structures (needs Mesa {}.{})",
            release.id, release.codename, LAVAPIPE_MIN_AS.0, LAVAPIPE_MIN_AS.1
        )),
        None => Err("skipped: no mesa-vulkan-drivers package in this system's apt sources".into()),
    }
}

fn khronos_layer() -> Result<(String, PathBuf), String> {
    let dir = LAYER_DIRS
        .iter()
        .map(PathBuf::from)
        .find(|d| d.join(KHRONOS_MANIFEST).is_file())
        .ok_or_else(|| {
            format!(
                "no {KHRONOS_MANIFEST} in {} (Debian: vulkan-validationlayers)",
                LAYER_DIRS.join(", ")
            )
        })?;
    let version = std::fs::read_to_string(dir.join(KHRONOS_MANIFEST))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
        .and_then(|j| j["layer"]["api_version"].as_str().map(str::to_string))
        .unwrap_or_else(|| "?".into());
    Ok((
        format!("{KHRONOS_MANIFEST} (API {version}) in {}", dir.display()),
        dir,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    const DEB822: &str = "\
Types: deb
# a comment
URIs: http://mirror.example/debian
Suites: bookworm bookworm-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: http://mirror.example/debian-security
Suites: bookworm-security
Components: main

Types: deb
URIs: https://vendor.example/apt
Suites: nodistro
Components: main

Types: deb
URIs: http://off.example/debian
Suites: bookworm
Components: main
Enabled: no
";

    #[test]
    fn deb822_sources_give_the_release_deb_src_and_backports() {
        let text = derive_sources(&parse_deb822(DEB822), "bookworm", true).unwrap();
        let stanzas = parse_deb822(&text);
        assert_eq!(stanzas.len(), 4, "{text}");
        assert!(!text.contains("vendor.example") && !text.contains("off.example"));
        assert_eq!(stanzas[0].get("Suites"), Some("bookworm bookworm-updates"));
        assert_eq!(stanzas[1].get("Suites"), Some("bookworm-security"));
        assert_eq!(stanzas[2].get("Types"), Some("deb-src"));
        assert_eq!(stanzas[2].get("Suites"), Some("bookworm"));
        assert_eq!(stanzas[2].get("URIs"), Some("http://mirror.example/debian"));
        assert_eq!(
            stanzas[2].get("Signed-By"),
            Some("/usr/share/keyrings/debian-archive-keyring.gpg")
        );
        assert_eq!(stanzas[3].get("Types"), Some("deb"));
        assert_eq!(stanzas[3].get("Suites"), Some("bookworm-backports"));
    }

    #[test]
    fn one_line_sources_and_existing_backports() {
        let list =
            "deb [arch=amd64 signed-by=/k.gpg] http://m.example/debian bookworm main contrib # x\n\
                    deb-src http://m.example/debian bookworm main\n\
                    deb http://m.example/debian bookworm-backports main\n";
        let text = derive_sources(&parse_one_line(list), "bookworm", true).unwrap();
        let stanzas = parse_deb822(&text);
        // The release, its backports as configured, and one deb-src; no
        // second backports stanza.
        assert_eq!(stanzas.len(), 3, "{text}");
        assert_eq!(stanzas[0].get("Signed-By"), Some("/k.gpg"));
        assert_eq!(stanzas[0].get("Architectures"), Some("amd64"));
        assert_eq!(stanzas[0].get("Components"), Some("main contrib"));
        assert_eq!(stanzas[2].get("Types"), Some("deb-src"));
    }

    #[test]
    fn a_machine_without_the_release_is_an_error() {
        let err = derive_sources(&parse_deb822(DEB822), "trixie", false).unwrap_err();
        assert!(err.contains("trixie"), "{err}");
    }

    #[test]
    fn lavapipe_versions() {
        assert!(!lavapipe_has_as("22.3.6-1+deb12u2"));
        assert!(!lavapipe_has_as("24.0.9-1"));
        assert!(lavapipe_has_as("24.1.0-1"));
        assert!(lavapipe_has_as("25.0.7-2~bpo12+1"));
        assert!(lavapipe_has_as("1:26.2.6-1"));
        assert!(!lavapipe_has_as("garbage"));
    }
}
