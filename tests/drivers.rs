//! The drivers and layers the real-loader tests use, each seen through the
//! system's Vulkan loader: the Khronos Mock ICD (the one driver here with
//! VK_EXT_opacity_micromap), lavapipe (acceleration structures that really
//! build, no opacity micromaps) and the Khronos validation layer.
//!
//! `cargo xtask test` prepares them and names them in OMMCHECK_TEST_MOCK_ICD,
//! OMMCHECK_TEST_LAVAPIPE_ICD and OMMCHECK_TEST_KHRONOS_LAYER. A test whose
//! variable is absent fails in CI and skips elsewhere.
//!
//! The loader reads its environment once per process and keeps what it
//! found, so each scenario runs `vk-probe` (src/bin/vk-probe.rs) as a child
//! process with its own environment and parses what it prints.

use std::collections::BTreeMap;
use std::path::Path;

use ommcheck_tests::{loader_command, prepared};

const OPACITY_MICROMAP: &str = "VK_EXT_opacity_micromap";
const ACCELERATION_STRUCTURE: &str = "VK_KHR_acceleration_structure";
const KHRONOS_VALIDATION: &str = "VK_LAYER_KHRONOS_validation";

#[derive(Debug, Default)]
struct Device {
    name: String,
    extensions: BTreeMap<String, u32>,
}

#[derive(Debug, Default)]
struct Probe {
    layers: Vec<String>,
    devices: Vec<Device>,
}

/// Runs vk-probe with `args` and the loader variables `env`, and parses its
/// output; panics with its stderr when it fails.
fn probe(args: &[&str], env: &[(&str, &Path)]) -> Probe {
    let mut command = loader_command(env!("CARGO_BIN_EXE_vk-probe"));
    command.args(args);
    command.envs(env.iter().copied());
    let output = command.output().expect("running vk-probe");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "vk-probe {args:?} with {env:?} failed ({}):\n{}{stdout}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
    let mut probe = Probe::default();
    for line in stdout.lines() {
        let fields: Vec<&str> = line.split('\t').collect();
        match fields.as_slice() {
            ["layer", name, _] => probe.layers.push(name.to_string()),
            ["device", i, what, rest @ ..] => {
                let i: usize = i.parse().expect("device index");
                if probe.devices.len() <= i {
                    probe.devices.resize_with(i + 1, Device::default);
                }
                let device = &mut probe.devices[i];
                match (*what, rest) {
                    ("name", [name]) => device.name = name.to_string(),
                    ("extension", [name, version]) => {
                        let version = version.parse().expect("extension spec version");
                        device.extensions.insert(name.to_string(), version);
                    }
                    ("api", [_]) => {}
                    _ => panic!("unexpected vk-probe line {line:?}"),
                }
            }
            _ => panic!("unexpected vk-probe line {line:?}"),
        }
    }
    probe
}

/// The one device a single-driver scenario must show.
fn only_device(probe: &Probe) -> &Device {
    assert_eq!(
        probe.devices.len(),
        1,
        "expected exactly one device: {probe:#?}"
    );
    &probe.devices[0]
}

#[test]
fn mock_icd_is_the_vulkan_mock_device_with_opacity_micromaps() {
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    let probe = probe(&["devices"], &[("VK_DRIVER_FILES", &icd)]);
    let device = only_device(&probe);
    assert_eq!(device.name, "Vulkan Mock Device");
    for extension in [OPACITY_MICROMAP, ACCELERATION_STRUCTURE] {
        assert!(
            device.extensions.contains_key(extension),
            "the Mock ICD lacks {extension}: {:?}",
            device.extensions.keys()
        );
    }
}

#[test]
fn lavapipe_has_acceleration_structures_but_no_opacity_micromaps() {
    let Some(icd) = prepared("OMMCHECK_TEST_LAVAPIPE_ICD") else {
        return;
    };
    let probe = probe(&["devices"], &[("VK_DRIVER_FILES", &icd)]);
    let device = only_device(&probe);
    assert!(
        device.name.starts_with("llvmpipe"),
        "not lavapipe: {:?}",
        device.name
    );
    assert!(
        device.extensions.contains_key(ACCELERATION_STRUCTURE),
        "lavapipe lacks {ACCELERATION_STRUCTURE}; it needs Mesa 24.1 or newer"
    );
    // No lavapipe release implements opacity micromaps; if one does, the
    // layer's tests can run against a driver that executes them.
    assert!(
        !device.extensions.contains_key(OPACITY_MICROMAP),
        "lavapipe now advertises {OPACITY_MICROMAP}"
    );
}

#[test]
fn khronos_validation_layer_is_found_in_its_directory() {
    let Some(dir) = prepared("OMMCHECK_TEST_KHRONOS_LAYER") else {
        return;
    };
    let added = probe(&["layers"], &[("VK_ADD_LAYER_PATH", &dir)]);
    assert!(
        added.layers.iter().any(|l| l == KHRONOS_VALIDATION),
        "VK_ADD_LAYER_PATH={}: {:?}",
        dir.display(),
        added.layers
    );
    // VK_LAYER_PATH replaces the loader's search path: the layer is found in
    // this directory and not from elsewhere.
    let only = probe(&["layers"], &[("VK_LAYER_PATH", &dir)]);
    assert!(only.layers.iter().any(|l| l == KHRONOS_VALIDATION));
    let empty = Path::new(env!("CARGO_TARGET_TMPDIR")).join("no-layers");
    std::fs::create_dir_all(&empty).expect("creating an empty layer directory");
    let none = probe(&["layers"], &[("VK_LAYER_PATH", &empty)]);
    assert!(
        !none.layers.iter().any(|l| l == KHRONOS_VALIDATION),
        "{:?}",
        none.layers
    );
}

#[test]
fn khronos_validation_layer_runs_over_the_mock_icd() {
    let (Some(icd), Some(dir)) = (
        prepared("OMMCHECK_TEST_MOCK_ICD"),
        prepared("OMMCHECK_TEST_KHRONOS_LAYER"),
    ) else {
        return;
    };
    let probe = probe(
        &["devices", "--layer", KHRONOS_VALIDATION],
        &[("VK_DRIVER_FILES", &icd), ("VK_ADD_LAYER_PATH", &dir)],
    );
    let device = only_device(&probe);
    assert_eq!(device.name, "Vulkan Mock Device");
    assert!(device.extensions.contains_key(OPACITY_MICROMAP));
}
