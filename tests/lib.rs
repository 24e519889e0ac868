//! Helpers shared by the integration tests.

pub mod shaders;
pub mod vulkan;

use std::path::{Path, PathBuf};
use std::process::Command;

/// Whether the tests run in CI, where a missing driver or layer fails.
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// The path in `var` (one of the OMMCHECK_TEST_* variables `cargo xtask
/// test` sets); None (the test skips) when it is absent outside CI.
pub fn prepared(var: &str) -> Option<PathBuf> {
    match std::env::var_os(var) {
        Some(path) => {
            let path = PathBuf::from(path);
            assert!(
                path.exists(),
                "{var}={} does not exist; rerun `cargo xtask test`",
                path.display()
            );
            Some(path)
        }
        None => {
            assert!(
                !in_ci(),
                "{var} is not set in CI; `cargo xtask test` sets it"
            );
            eprintln!("skipping: {var} is not set; `cargo xtask test` prepares it and sets it");
            None
        }
    }
}

/// Variables that would make the loader look beyond what a scenario names.
pub const LOADER_VARS: &[&str] = &[
    "VK_ICD_FILENAMES",
    "VK_DRIVER_FILES",
    "VK_ADD_DRIVER_FILES",
    "VK_LOADER_DRIVERS_SELECT",
    "VK_LOADER_DRIVERS_DISABLE",
    "VK_LAYER_PATH",
    "VK_ADD_LAYER_PATH",
    "VK_INSTANCE_LAYERS",
    "VK_LOADER_LAYERS_ENABLE",
    "VK_LOADER_LAYERS_DISABLE",
];

/// `program` with none of [`LOADER_VARS`] inherited, Mesa's implicit
/// device-select layer (installed with lavapipe; it has nothing to select
/// here) kept out, and the layer's provenance store off.
pub fn loader_command(program: &str) -> Command {
    let mut command = Command::new(program);
    for var in LOADER_VARS {
        command.env_remove(var);
    }
    command.env("NODEVICE_SELECT", "1");
    // The layer's provenance store is on by default, under the home
    // directory: it would link one test's serializations to another's and
    // to earlier runs'. A test that wants a store sets its own.
    command.env("OMMCHECK_PROVENANCE_STORE", "off");
    command
}

/// The cdylib `name` (`VkLayer_ommcheck`, `VkICD_ommcheck_fake`) cargo
/// built for a dev-dependency of the running test binary: in
/// `target/<profile>/deps` beside it, or one level up; its absolute path.
pub fn built_library(name: &str) -> PathBuf {
    let file = format!(
        "{}{name}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let exe = std::env::current_exe().expect("the test binary's path");
    let deps = exe.parent().expect("the test binary's directory");
    let library = [deps, deps.parent().unwrap_or(deps)]
        .iter()
        .map(|dir| dir.join(&file))
        .find(|path| path.exists())
        .unwrap_or_else(|| panic!("{file} is neither in {} nor its parent; cargo builds it for a dev-dependency of this crate", deps.display()));
    library.canonicalize().expect("the library's absolute path")
}

/// Writes `manifest` into `dir` as `file` and returns its path. Written
/// aside and renamed: another test process may be reading it.
pub fn place_manifest(dir: &Path, file: &str, manifest: &serde_json::Value) -> PathBuf {
    std::fs::create_dir_all(dir).expect("creating the manifest directory");
    let aside = dir.join(format!("{file}.{}.tmp", std::process::id()));
    std::fs::write(&aside, manifest.to_string()).expect("writing the manifest");
    let path = dir.join(file);
    std::fs::rename(&aside, &path).expect("placing the manifest");
    path
}

/// Writes the manifest of the layer `name` that cargo built for the
/// dev-dependency on ommcheck-layer into `dir`, with the fields the loader
/// needs (`cargo xtask layer` writes the full manifest, with the settings).
pub fn place_layer_manifest(dir: &Path, name: &str, description: &str) {
    let manifest = serde_json::json!({
        "file_format_version": "1.2.0",
        "layer": {
            "name": name,
            "type": "GLOBAL",
            "library_path": built_library("VkLayer_ommcheck"),
            "api_version": "1.3.239",
            "implementation_version": "1",
            "description": description,
        }
    });
    place_manifest(dir, "VkLayer_ommcheck.json", &manifest);
}

/// Writes the manifest of the fake driver (`layer/fake-icd`) that cargo
/// built for the dev-dependency on ommcheck-fake-icd into `dir`; returns
/// its path, for `VK_DRIVER_FILES`. Its api_version lets the loader pass
/// `vkGetPhysicalDeviceProperties2` to the driver.
pub fn place_fake_driver_manifest(dir: &Path) -> PathBuf {
    let manifest = serde_json::json!({
        "file_format_version": "1.0.1",
        "ICD": {
            "library_path": built_library("VkICD_ommcheck_fake"),
            "api_version": "1.3.239",
        }
    });
    place_manifest(dir, "VkICD_ommcheck_fake.json", &manifest)
}
