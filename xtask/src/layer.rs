//! `cargo xtask layer`: builds the Vulkan layer in release and writes its
//! manifest, `VkLayer_ommcheck.json`, naming the built library by its
//! absolute path; with `--install`, puts both into the user's Vulkan layer
//! directory, and `--uninstall` takes them out.
//!
//! This module needs nothing but serde_json, so `cargo xtask layer` builds
//! xtask without the test driver's dependencies (see the `driver` feature).

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::{json, Value};

/// The layer's settings, names and version, from the layer's own
/// dependency-free source file: the manifest is written from the same table
/// the layer parses its settings with, without building the layer in debug
/// for xtask.
#[path = "../../layer/src/setting_docs.rs"]
pub mod setting_docs;

use setting_docs::{API_VERSION, DOCUMENTED, LAYER_NAME, PRESETS};

/// The manifest's file name.
pub const MANIFEST: &str = "VkLayer_ommcheck.json";

/// The layer library's file name on this platform.
pub fn library_file() -> String {
    format!(
        "{}VkLayer_ommcheck{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    )
}

/// JSON text the settings table holds (defaults, preset values).
fn json_text(text: &str) -> Value {
    serde_json::from_str(text).expect("the settings table holds JSON literals")
}

/// The manifest of a layer library at `library_path`, whose documentation
/// is at `docs_url`.
pub fn manifest(library_path: &Path, docs_url: &str) -> Value {
    let settings: Vec<Value> = DOCUMENTED
        .iter()
        .map(|s| {
            let mut setting = json!({
                "key": s.key,
                "env": s.env,
                "label": s.label,
                "description": s.description,
                "type": s.kind,
                "default": json_text(s.default_json),
                "platforms": ["LINUX"],
            });
            if !s.flags.is_empty() {
                setting["flags"] = s
                    .flags
                    .iter()
                    .map(|(key, description)| {
                        json!({ "key": key, "label": key, "description": description })
                    })
                    .collect();
            }
            setting
        })
        .collect();
    let presets: Vec<Value> = PRESETS
        .iter()
        .map(|p| {
            json!({
                "label": p.label,
                "description": p.description,
                "platforms": ["LINUX"],
                "status": "STABLE",
                "settings": p
                    .settings
                    .iter()
                    .map(|(key, value)| json!({ "key": key, "value": json_text(value) }))
                    .collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "file_format_version": "1.2.0",
        "layer": {
            "name": LAYER_NAME,
            "type": "GLOBAL",
            "library_path": library_path.to_string_lossy(),
            "api_version": API_VERSION,
            "implementation_version": "1",
            "description": "ommcheck: validation of opacity micromap usage",
            "introduction": "Checks how an application uses VK_EXT_opacity_micromap and VK_KHR_opacity_micromap: the parameters of micromap and acceleration-structure calls, the objects they name, and the contents of the triangle arrays, micromap data and index buffers builds read. It reports in the Khronos validation layer's format and can run beside it.",
            "url": docs_url,
            // Built and tested on Linux only (the break action raises SIGTRAP).
            "platforms": ["LINUX"],
            // The loader and VK_EXT_layer_settings: the layer reports to
            // both kinds of callback and reads its settings from the
            // extension's structure, which the loader then does not pass
            // down to drivers that lack it.
            "instance_extensions": [
                { "name": "VK_EXT_debug_report", "spec_version": "10" },
                { "name": "VK_EXT_debug_utils", "spec_version": "2" },
                { "name": "VK_EXT_layer_settings", "spec_version": "2" },
            ],
            "features": { "presets": presets, "settings": settings },
        }
    })
}

/// What `cargo xtask layer` does besides building.
#[derive(Debug, Default, PartialEq)]
pub struct Options {
    /// Where the manifest goes (default `target/layer/`).
    pub out_dir: Option<PathBuf>,
    pub install: bool,
    pub uninstall: bool,
    /// Print [`USAGE`] instead.
    pub help: bool,
}

/// `cargo xtask layer --help`.
pub const USAGE: &str = "\
Build the Vulkan layer in release and write its manifest, VkLayer_ommcheck.json.

Usage: cargo xtask layer [--out-dir DIR] [--install | --uninstall]

Options:
  --out-dir DIR  the directory the manifest is written to (default: target/layer)
  --install      also copy the library and a manifest into the user's Vulkan
                 layer directory ($XDG_DATA_HOME/vulkan/explicit_layer.d, or
                 ~/.local/share/vulkan/explicit_layer.d), so that
                 VK_INSTANCE_LAYERS=VK_LAYER_OMMCHECK_validation finds it
  --uninstall    remove what --install put there (builds nothing)
  -h, --help     print this";

/// The options of `cargo xtask layer ARGS`; Err says what is wrong.
pub fn parse_args(args: &[OsString]) -> Result<Options, String> {
    let mut options = Options::default();
    let mut args = args.iter();
    while let Some(arg) = args.next() {
        match arg.to_str() {
            Some("--install") => options.install = true,
            Some("--uninstall") => options.uninstall = true,
            Some("--out-dir") => {
                let dir = args.next().ok_or("--out-dir needs a directory")?;
                options.out_dir = Some(PathBuf::from(dir));
            }
            Some("-h" | "--help") => options.help = true,
            _ => return Err(format!("unexpected argument {arg:?}\n\n{USAGE}")),
        }
    }
    if options.install && options.uninstall {
        return Err("--install and --uninstall exclude each other".into());
    }
    Ok(options)
}

/// Runs `cargo xtask layer` with `options`; returns the lines to print.
pub fn run(root: &Path, options: &Options) -> Result<Vec<String>, crate::Error> {
    let dir = user_layer_dir(
        std::env::var_os("XDG_DATA_HOME").map(PathBuf::from),
        std::env::var_os("HOME").map(PathBuf::from),
    );
    if options.uninstall {
        let dir = dir.ok_or_else(no_layer_dir)?;
        return uninstall(&dir);
    }
    let out_dir = build(root, options.out_dir.clone())?;
    let mut lines = vec![out_dir.display().to_string()];
    if options.install {
        let dir = dir.ok_or_else(no_layer_dir)?;
        let library = crate::target_dir(root).join("release").join(library_file());
        lines.extend(install(&library, &dir, &docs_url(root))?);
    }
    Ok(lines)
}

fn no_layer_dir() -> crate::Error {
    crate::Error::Tool("neither XDG_DATA_HOME nor HOME is set: no user layer directory".into())
}

/// The link to the layer's documentation in this checkout.
fn docs_url(root: &Path) -> String {
    format!("file://{}", root.join("docs").join("layer.md").display())
}

/// Builds the layer in release, writes the manifest into `out_dir`
/// (default `target/layer/`) and returns that directory.
pub fn build(root: &Path, out_dir: Option<PathBuf>) -> Result<PathBuf, crate::Error> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(root)
        .args(["build", "--release", "-p", "ommcheck-layer", "--lib"])
        .status()
        .map_err(|e| crate::Error::Tool(format!("cannot run cargo: {e}")))?;
    if !status.success() {
        return Err(crate::Error::Tool(format!("cargo build failed ({status})")));
    }
    let built = crate::target_dir(root).join("release").join(library_file());
    let library = built.canonicalize().map_err(|source| crate::Error::Io {
        path: built,
        source,
    })?;
    let out_dir = out_dir.unwrap_or_else(|| root.join("target").join("layer"));
    create_dir(&out_dir)?;
    write_manifest(&out_dir.join(MANIFEST), &library, &docs_url(root))?;
    Ok(out_dir)
}

fn create_dir(dir: &Path) -> Result<(), crate::Error> {
    std::fs::create_dir_all(dir).map_err(|source| crate::Error::Io {
        path: dir.to_path_buf(),
        source,
    })
}

fn write_manifest(path: &Path, library: &Path, docs_url: &str) -> Result<(), crate::Error> {
    let text = serde_json::to_string_pretty(&manifest(library, docs_url)).expect("a JSON value");
    std::fs::write(path, text + "\n").map_err(|source| crate::Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The directory the Vulkan loader searches for a user's explicit layers:
/// `$XDG_DATA_HOME/vulkan/explicit_layer.d`, or with XDG_DATA_HOME unset
/// or relative (the XDG rule: ignore it), `~/.local/share/vulkan/...`.
pub fn user_layer_dir(xdg_data_home: Option<PathBuf>, home: Option<PathBuf>) -> Option<PathBuf> {
    let data = xdg_data_home
        .filter(|dir| dir.is_absolute())
        .or_else(|| home.map(|home| home.join(".local").join("share")))?;
    Some(data.join("vulkan").join("explicit_layer.d"))
}

/// Copies `library` into `dir` and writes a manifest naming the copy;
/// returns what was written. The copy is written aside and renamed over
/// the old one, so a running application that has the old one mapped
/// keeps an intact file.
pub fn install(library: &Path, dir: &Path, docs_url: &str) -> Result<Vec<String>, crate::Error> {
    create_dir(dir)?;
    let installed = dir.join(library_file());
    let aside = dir.join(format!("{}.{}.tmp", library_file(), std::process::id()));
    std::fs::copy(library, &aside)
        .and_then(|_| std::fs::rename(&aside, &installed))
        .map_err(|source| crate::Error::Io {
            path: installed.clone(),
            source,
        })?;
    let manifest = dir.join(MANIFEST);
    write_manifest(&manifest, &installed, docs_url)?;
    Ok(vec![
        format!("installed {}", installed.display()),
        format!("installed {}", manifest.display()),
        format!("enable it with VK_INSTANCE_LAYERS={LAYER_NAME}"),
    ])
}

/// Removes what [`install`] put into `dir`; returns what was removed.
pub fn uninstall(dir: &Path) -> Result<Vec<String>, crate::Error> {
    let mut lines = Vec::new();
    for path in [dir.join(MANIFEST), dir.join(library_file())] {
        match std::fs::remove_file(&path) {
            Ok(()) => lines.push(format!("removed {}", path.display())),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => return Err(crate::Error::Io { path, source }),
        }
    }
    if lines.is_empty() {
        lines.push(format!("nothing of ommcheck's was in {}", dir.display()));
    }
    Ok(lines)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings<'a>(values: &'a Value, key: &str) -> Vec<&'a str> {
        values
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v[key].as_str().unwrap())
            .collect()
    }

    #[test]
    fn the_manifest_names_the_layer_and_its_settings() {
        let m = manifest(
            Path::new("/abs/libVkLayer_ommcheck.so"),
            "file:///d/layer.md",
        );
        assert_eq!(m["file_format_version"], "1.2.0");
        let layer = &m["layer"];
        assert_eq!(layer["name"], "VK_LAYER_OMMCHECK_validation");
        assert_eq!(layer["type"], "GLOBAL");
        assert_eq!(layer["api_version"], "1.3.281");
        assert_eq!(layer["library_path"], "/abs/libVkLayer_ommcheck.so");
        assert_eq!(layer["url"], "file:///d/layer.md");
        assert_eq!(layer["platforms"], json!(["LINUX"]));
        let settings = &layer["features"]["settings"];
        assert_eq!(
            strings(settings, "env"),
            [
                "OMMCHECK_REPORT",
                "OMMCHECK_DEBUG_ACTION",
                "OMMCHECK_MESSAGE_ID_FILTER",
                "OMMCHECK_DUPLICATE_LIMIT",
                "OMMCHECK_LOG_FILE",
                "OMMCHECK_PROFILE",
                "OMMCHECK_TIER",
                "OMMCHECK_BREAK_ON_ERROR",
                "OMMCHECK_GPU_READBACK",
                "OMMCHECK_GPU_READBACK_MAX_BYTES",
                "OMMCHECK_GPU_READBACK_INDIRECT_MAX_BYTES",
                "OMMCHECK_PROVENANCE_STORE",
                "OMMCHECK_PROVENANCE_STORE_MAX_BYTES",
            ]
        );
        assert_eq!(settings[0]["default"], json!(["error", "warning"]));
        assert_eq!(settings[1]["flags"][2]["key"], "break");
        assert_eq!(settings[3]["default"], 10);
        assert_eq!(settings[6]["type"], "ENUM");
        assert_eq!(
            strings(&settings[6]["flags"], "key"),
            ["params", "state", "content", "simulate"]
        );
        assert_eq!(
            strings(&layer["instance_extensions"], "name"),
            [
                "VK_EXT_debug_report",
                "VK_EXT_debug_utils",
                "VK_EXT_layer_settings"
            ]
        );
        let presets = &layer["features"]["presets"];
        assert_eq!(strings(presets, "label"), ["Fast", "Thorough"]);
        assert_eq!(
            presets[0]["settings"][0],
            json!({"key": "tier", "value": "params"})
        );
    }

    /// Every setting carries what vkconfig needs to show and write it.
    #[test]
    fn every_setting_has_type_default_and_description() {
        let m = manifest(Path::new("/l.so"), "file:///d");
        for setting in m["layer"]["features"]["settings"].as_array().unwrap() {
            for field in ["key", "env", "label", "description", "type", "default"] {
                assert!(!setting[field].is_null(), "{field} of {setting}");
            }
            let kind = setting["type"].as_str().unwrap();
            if kind == "FLAGS" || kind == "ENUM" {
                let flags = setting["flags"].as_array().expect("flags");
                assert!(flags.iter().all(|f| f["description"].is_string()));
                let keys = strings(&setting["flags"], "key");
                let defaults = match &setting["default"] {
                    Value::Array(values) => values.iter().map(|v| v.as_str().unwrap()).collect(),
                    value => vec![value.as_str().unwrap()],
                };
                assert!(defaults.iter().all(|d| keys.contains(d)), "{setting}");
            }
        }
    }

    /// The fields of Debian's VkLayer_khronos_validation.json that describe
    /// a layer (not its extensions' entry points, which ommcheck has none
    /// of) are all in ommcheck's manifest; compared when the package
    /// vulkan-validationlayers is installed.
    #[test]
    fn the_manifest_has_the_khronos_manifests_fields() {
        let path = Path::new("/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json");
        let Ok(text) = std::fs::read_to_string(path) else {
            eprintln!("skipping: {} is not installed", path.display());
            return;
        };
        let khronos: Value = serde_json::from_str(&text).unwrap();
        let ours = manifest(Path::new("/l.so"), "file:///d");
        let missing: Vec<&String> = khronos["layer"]
            .as_object()
            .unwrap()
            .keys()
            .filter(|key| *key != "device_extensions")
            .filter(|key| ours["layer"].get(key.as_str()).is_none())
            .collect();
        assert!(missing.is_empty(), "missing {missing:?}");
        for key in khronos["layer"]["features"].as_object().unwrap().keys() {
            assert!(!ours["layer"]["features"][key].is_null(), "features.{key}");
        }
    }

    #[test]
    fn arguments() {
        let args = |words: &[&str]| -> Vec<OsString> { words.iter().map(OsString::from).collect() };
        assert_eq!(parse_args(&[]), Ok(Options::default()));
        assert_eq!(
            parse_args(&args(&["--install", "--out-dir", "d"])),
            Ok(Options {
                out_dir: Some(PathBuf::from("d")),
                install: true,
                ..Options::default()
            })
        );
        assert!(parse_args(&args(&["--install", "--uninstall"])).is_err());
        assert!(parse_args(&args(&["--out-dir"])).is_err());
        assert!(parse_args(&args(&["--help"])).unwrap().help);
        assert!(USAGE.contains("--uninstall"));
        assert!(parse_args(&args(&["--bogus"]))
            .unwrap_err()
            .contains("--bogus"));
    }

    #[test]
    fn the_user_layer_directory_follows_xdg() {
        let home = Some(PathBuf::from("/home/u"));
        assert_eq!(
            user_layer_dir(Some("/x/data".into()), home.clone()),
            Some(PathBuf::from("/x/data/vulkan/explicit_layer.d"))
        );
        for xdg in [None, Some(PathBuf::from("relative"))] {
            assert_eq!(
                user_layer_dir(xdg, home.clone()),
                Some(PathBuf::from(
                    "/home/u/.local/share/vulkan/explicit_layer.d"
                ))
            );
        }
        assert_eq!(user_layer_dir(None, None), None);
    }

    /// Install and uninstall in a temporary XDG_DATA_HOME; where vulkaninfo
    /// (Debian: vulkan-tools) is installed, the loader lists the layer from
    /// there with no path variable set.
    #[test]
    fn install_puts_library_and_manifest_where_the_loader_looks() {
        let data_home =
            std::env::temp_dir().join(format!("ommcheck-install-{}", std::process::id()));
        let dir = user_layer_dir(Some(data_home.clone()), None).unwrap();
        let built = data_home.join(library_file());
        std::fs::create_dir_all(&data_home).unwrap();
        std::fs::write(&built, b"stand-in library").unwrap();
        let lines = install(&built, &dir, "file:///d").unwrap();
        assert_eq!(lines.len(), 3, "{lines:?}");
        let installed = dir.join(library_file());
        assert_eq!(std::fs::read(&installed).unwrap(), b"stand-in library");
        let written: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join(MANIFEST)).unwrap()).unwrap();
        assert_eq!(
            written["layer"]["library_path"],
            installed.to_string_lossy().as_ref()
        );
        // Installing again replaces both.
        install(&built, &dir, "file:///d").unwrap();
        // What the loader lists, or None without vulkaninfo.
        let listed = || {
            let mut vulkaninfo = Command::new("vulkaninfo");
            for var in ["VK_LAYER_PATH", "VK_ADD_LAYER_PATH", "VK_INSTANCE_LAYERS"] {
                vulkaninfo.env_remove(var);
            }
            match vulkaninfo
                .arg("--summary")
                .env("XDG_DATA_HOME", &data_home)
                .output()
            {
                Ok(output) => Some(String::from_utf8_lossy(&output.stdout).into_owned()),
                Err(e) => {
                    eprintln!("skipping the loader's listing: vulkaninfo: {e}");
                    None
                }
            }
        };
        if let Some(text) = listed() {
            assert!(
                text.contains(LAYER_NAME),
                "vulkaninfo did not list it:\n{text}"
            );
        }
        let removed = uninstall(&dir).unwrap();
        assert_eq!(removed.len(), 2, "{removed:?}");
        assert!(!dir.join(MANIFEST).exists() && !installed.exists());
        if let Some(text) = listed() {
            assert!(!text.contains(LAYER_NAME), "still listed:\n{text}");
        }
        assert!(uninstall(&dir).unwrap()[0].starts_with("nothing"));
        std::fs::remove_dir_all(&data_home).unwrap();
    }
}
