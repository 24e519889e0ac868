//! Helpers shared by the integration tests.

pub mod shaders;

use std::path::PathBuf;
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

/// `program` with none of [`LOADER_VARS`] inherited and Mesa's implicit
/// device-select layer (installed with lavapipe; it has nothing to select
/// here) kept out.
pub fn loader_command(program: &str) -> Command {
    let mut command = Command::new(program);
    for var in LOADER_VARS {
        command.env_remove(var);
    }
    command.env("NODEVICE_SELECT", "1");
    command
}
