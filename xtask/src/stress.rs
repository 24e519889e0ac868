//! `cargo xtask soak` and `cargo xtask threads`: `omm-stress`
//! (tests/src/bin/omm-stress.rs) through the system's Vulkan loader, the
//! layer and the project's fake driver (`layer/fake-icd`), all built in
//! release; the soak adds lavapipe where an installed Mesa has
//! acceleration structures (it installs nothing: `cargo xtask test` does).
//!
//! Both take `--prebuilt DIR`, a directory holding `omm-stress`,
//! `libVkLayer_ommcheck.so` and `libVkICD_ommcheck_fake.so` built in
//! release elsewhere, for a machine that cannot build (the device machine
//! has no crate registry); the manifests are then written into a
//! temporary directory.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde_json::{json, Value};

use crate::bench::{format_time, median, this_machine, OVERHEAD_CALLS};
use crate::Error;

/// The fake driver's library and manifest file names.
const FAKE_DRIVER_LIBRARY: &str = "libVkICD_ommcheck_fake.so";
const FAKE_DRIVER_MANIFEST: &str = "VkICD_ommcheck_fake.json";
const APP: &str = "omm-stress";

/// The thread counts `cargo xtask threads` measures.
pub const THREAD_COUNTS: [usize; 5] = [1, 2, 4, 8, 16];

/// The configurations `cargo xtask threads` measures: no layer, then
/// ommcheck at the params and at the content tier.
const TIERS: [Option<&str>; 3] = [None, Some("params"), Some("content")];

/// omm-stress, the layer's manifest directory and the fake driver's manifest.
pub struct Binaries {
    app: PathBuf,
    layer_dir: PathBuf,
    fake_driver: PathBuf,
    /// The manifests' directory is this process's own (`--prebuilt`),
    /// removed when done.
    temporary: bool,
}

impl Drop for Binaries {
    fn drop(&mut self) {
        if self.temporary {
            let _ = std::fs::remove_dir_all(&self.layer_dir);
        }
    }
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes the fake driver's manifest for `library` into `dir`; its
/// api_version lets the loader pass vkGetPhysicalDeviceProperties2 down.
fn write_fake_driver_manifest(dir: &Path, library: &Path) -> Result<PathBuf, Error> {
    let manifest = json!({
        "file_format_version": "1.0.1",
        "ICD": { "library_path": library, "api_version": "1.3.239" },
    });
    let path = dir.join(FAKE_DRIVER_MANIFEST);
    std::fs::write(&path, manifest.to_string()).map_err(io(&path))?;
    Ok(path)
}

impl Binaries {
    /// Builds the layer (its manifest into `target/stress/layer`), the fake
    /// driver and omm-stress in release.
    pub fn build(root: &Path) -> Result<Self, Error> {
        let target = crate::target_dir(root);
        let layer_dir = crate::layer::build(root, Some(target.join("stress").join("layer")))?;
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(&cargo)
            .current_dir(root)
            .args(["build", "--release", "-p", "ommcheck-fake-icd", "--lib"])
            .status()
            .map_err(|e| Error::Tool(format!("cargo build: could not start: {e}")))?;
        let status = if status.success() {
            Command::new(&cargo)
                .current_dir(root)
                .args(["build", "--release", "-p", "ommcheck-tests", "--bin", APP])
                .status()
                .map_err(|e| Error::Tool(format!("cargo build: could not start: {e}")))?
        } else {
            status
        };
        if !status.success() {
            return Err(Error::Tool(format!("cargo build failed ({status})")));
        }
        let release = target.join("release");
        let library = release.join(FAKE_DRIVER_LIBRARY);
        let library = library.canonicalize().map_err(io(&library))?;
        Ok(Self {
            app: release.join(APP),
            fake_driver: write_fake_driver_manifest(&layer_dir, &library)?,
            layer_dir,
            temporary: false,
        })
    }

    /// The binaries in `dir`, built elsewhere; the manifests go into a
    /// directory of this process's under the system's temporary directory.
    pub fn prebuilt(dir: &Path) -> Result<Self, Error> {
        let dir = dir.canonicalize().map_err(io(dir))?;
        let manifests =
            std::env::temp_dir().join(format!("ommcheck-stress-{}", std::process::id()));
        std::fs::create_dir_all(&manifests).map_err(io(&manifests))?;
        let layer = dir.join(crate::layer::library_file());
        let manifest = crate::layer::manifest(&layer, "https://example.invalid/ommcheck");
        let path = manifests.join(crate::layer::MANIFEST);
        std::fs::write(&path, manifest.to_string()).map_err(io(&path))?;
        Ok(Self {
            app: dir.join(APP),
            fake_driver: write_fake_driver_manifest(&manifests, &dir.join(FAKE_DRIVER_LIBRARY))?,
            layer_dir: manifests,
            temporary: true,
        })
    }

    /// The one way to get them: prebuilt in `prebuilt`, else built here.
    pub fn get(root: &Path, prebuilt: Option<&Path>) -> Result<Self, Error> {
        match prebuilt {
            Some(dir) => Self::prebuilt(dir),
            None => Self::build(root),
        }
    }

    /// omm-stress with `args` over the fake driver and `more_drivers`, the
    /// layer enabled when `tier` is given (at that tier), no duplicate limit,
    /// and no `VK_*` or `OMMCHECK_*` variable of the caller's.
    fn command(&self, args: &[&str], more_drivers: &[PathBuf], tier: Option<&str>) -> Command {
        let mut command = Command::new(&self.app);
        command.args(args);
        for (var, _) in std::env::vars_os() {
            let name = var.to_string_lossy();
            if name.starts_with("VK_") || name.starts_with("OMMCHECK_") {
                command.env_remove(&var);
            }
        }
        let drivers = std::env::join_paths(
            std::iter::once(self.fake_driver.as_path())
                .chain(more_drivers.iter().map(PathBuf::as_path)),
        )
        .unwrap_or_default();
        command
            .env("NODEVICE_SELECT", "1")
            .env("VK_DRIVER_FILES", drivers)
            .env("VK_ADD_LAYER_PATH", &self.layer_dir)
            .env(VkLayer_ommcheck::settings::DUPLICATE_LIMIT, "0");
        if let Some(tier) = tier {
            command
                .args(["--layer", VkLayer_ommcheck::LAYER_NAME])
                .env(VkLayer_ommcheck::settings::TIER, tier);
        }
        command
    }
}

/// `cargo xtask soak [--submissions N] [--prebuilt DIR] [--without-lavapipe]`:
/// runs the soak, whose one line `soak: ...` goes to stdout; fails where
/// the soak failed (findings other than those planted, or the resident
/// memory at the end above 1.1 times its mark at 10% of the run). With
/// `lavapipe` (and lavapipe installed) every tenth submission is a
/// top-level build over lavapipe, whose own memory (about 65 MiB) then
/// sits in the process: a leak must be ten times larger to cross the bound.
pub fn soak(
    root: &Path,
    submissions: u64,
    prebuilt: Option<&Path>,
    lavapipe: bool,
) -> Result<(), Error> {
    let binaries = Binaries::get(root, prebuilt)?;
    let found = std::env::var_os(crate::drivers::LAVAPIPE_ICD_VAR)
        .map(PathBuf::from)
        .or_else(crate::drivers::installed_lavapipe);
    let lavapipe = found.filter(|_| lavapipe);
    match &lavapipe {
        Some(manifest) => eprintln!("xtask: soak: lavapipe: {}", manifest.display()),
        None => eprintln!(
            "xtask: soak: without lavapipe (--without-lavapipe, or none with acceleration \
             structures installed: `cargo xtask test` installs it); top-level builds left out"
        ),
    }
    let submissions = submissions.to_string();
    let mut args = vec!["soak", "--submissions", &submissions];
    if lavapipe.is_some() {
        args.push("--lavapipe");
    }
    let status = binaries
        .command(&args, lavapipe.as_slice(), Some("content"))
        .status()
        .map_err(|e| Error::Tool(format!("{}: could not start: {e}", binaries.app.display())))?;
    if status.success() {
        Ok(())
    } else {
        Err(Error::Tool(format!("the soak failed ({status})")))
    }
}

/// One `omm-stress overhead` process: each call's time per call.
fn overhead_run(
    binaries: &Binaries,
    threads: usize,
    iterations: u32,
    tier: Option<&str>,
) -> Result<[f64; 3], Error> {
    let (threads, iterations) = (threads.to_string(), iterations.to_string());
    let args = [
        "overhead",
        "--threads",
        &threads,
        "--iterations",
        &iterations,
    ];
    let output = binaries
        .command(&args, &[], tier)
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| Error::Tool(format!("{}: could not start: {e}", binaries.app.display())))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        return Err(Error::Tool(format!(
            "omm-stress {args:?} failed ({}): {stdout}",
            output.status
        )));
    }
    let value: Value = serde_json::from_str(stdout.trim())
        .map_err(|e| Error::Tool(format!("omm-stress overhead: {e}: {stdout}")))?;
    // The calls are valid: a finding would be timed too.
    if value["findings"] != 0 {
        return Err(Error::Tool(format!(
            "omm-stress overhead drew findings: {stdout}"
        )));
    }
    let mut ns = [0.0; 3];
    for (slot, (key, _)) in ns.iter_mut().zip(OVERHEAD_CALLS) {
        *slot = value["ns_per_call"][key]
            .as_f64()
            .ok_or_else(|| Error::Tool(format!("omm-stress overhead: no {key}: {stdout}")))?;
    }
    Ok(ns)
}

/// Each (threads, configuration)'s times per call, one sample per round.
pub type Samples = BTreeMap<(usize, usize), Vec<[f64; 3]>>;

/// The markdown table of `cargo xtask threads`: per thread count and
/// call, the median time per call with no layer and at each tier, and the
/// layer's overhead (the tier's time less the no-layer time).
pub fn render_threads(samples: &Samples, rounds: usize, iterations: u32) -> String {
    let machine = this_machine();
    let mut out = format!(
        "`cargo xtask threads --rounds {rounds} --iterations {iterations}`: `omm-stress overhead` \
         through the Vulkan loader over the fake driver (`layer/fake-icd`). T threads at once, \
         each with its own command pool, command buffer and micromap, each time {iterations} \
         valid calls of each command (inputs in mapped memory); the time per call is each \
         thread's time over its calls, averaged over the threads; the median of {rounds} rounds \
         (one process per thread count and configuration, interleaved). Machine: {} ({} \
         logical cores).\n\n",
        machine.model, machine.cores
    );
    out.push_str(
        "| threads | call | no layer | `params` | `content` | `params` overhead | `content` overhead |\n\
         | ---: | --- | ---: | ---: | ---: | ---: | ---: |\n",
    );
    for threads in THREAD_COUNTS {
        for (call, (_, label)) in OVERHEAD_CALLS.iter().enumerate() {
            let median_of = |config: usize| {
                samples.get(&(threads, config)).map_or(f64::NAN, |runs| {
                    median(&runs.iter().map(|r| r[call]).collect::<Vec<_>>())
                })
            };
            let [none, params, content] = [0, 1, 2].map(median_of);
            let _ = writeln!(
                out,
                "| {threads} | {label} | {} | {} | {} | {} | {} |",
                format_time(none),
                format_time(params),
                format_time(content),
                format_time(params - none),
                format_time(content - none),
            );
        }
    }
    out
}

/// `cargo xtask threads [--rounds R] [--iterations N] [--prebuilt DIR]`:
/// the layer's per-call overhead at the params and content tiers against
/// the thread count; prints the markdown table.
pub fn threads(
    root: &Path,
    rounds: usize,
    iterations: u32,
    prebuilt: Option<&Path>,
) -> Result<(), Error> {
    let binaries = Binaries::get(root, prebuilt)?;
    let mut samples = Samples::new();
    for round in 0..rounds {
        for threads in THREAD_COUNTS {
            for (config, tier) in TIERS.iter().enumerate() {
                let ns = overhead_run(&binaries, threads, iterations, *tier)?;
                eprintln!(
                    "xtask: threads: round {round}, {threads} threads, {}: {ns:?} ns",
                    tier.unwrap_or("no layer")
                );
                samples.entry((threads, config)).or_default().push(ns);
            }
        }
    }
    print!("{}", render_threads(&samples, rounds, iterations));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_gives_medians_and_overheads_per_thread_count_and_call() {
        let mut samples = Samples::new();
        for threads in THREAD_COUNTS {
            for (config, base) in [(0, 10.0), (1, 110.0), (2, 310.0)] {
                let runs = [base, base + 2.0, base + 100.0]
                    .map(|ns| [ns * threads as f64, ns, 2.0 * ns])
                    .to_vec();
                samples.insert((threads, config), runs);
            }
        }
        let table = render_threads(&samples, 3, 1000);
        // One row per thread count and call, after the two header lines.
        let rows: Vec<&str> = table.lines().filter(|l| l.starts_with("| ")).collect();
        assert_eq!(
            rows.len(),
            2 + THREAD_COUNTS.len() * OVERHEAD_CALLS.len(),
            "{table}"
        );
        // 16 threads, vkCmdBuildMicromapsEXT: medians 192, 1.79 µs, 4.99 µs
        // (the middle run's), overheads 1.60 µs and 4.80 µs.
        assert!(
            table.contains("| 16 | `vkCmdBuildMicromapsEXT` | 192 ns | 1.79 µs | 4.99 µs | 1.60 µs | 4.80 µs |"),
            "{table}"
        );
        assert!(table.contains("--rounds 3 --iterations 1000"), "{table}");
    }
}
