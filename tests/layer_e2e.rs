//! The layer under the real Vulkan loader: `VK_LAYER_OMMCHECK_validation`
//! enabled by name in `ppEnabledLayerNames`, found through a manifest this
//! test writes, over the Khronos Mock ICD (the one driver here with
//! VK_EXT_opacity_micromap), lavapipe (acceleration structures that really
//! build) and stacked with the Khronos validation layer.
//!
//! Each scenario runs `omm-app` (src/bin/omm-app.rs) as a child process,
//! because the loader reads its environment once per process, and asserts
//! the exact list of message ids its messenger received. A test whose
//! OMMCHECK_TEST_* variable is absent fails in CI and skips elsewhere.
//!
//! What the Mock ICD makes decidable: it runs no command, reports every
//! property as 0 (the layer then keeps its spec-minimum limits) and returns
//! 0 from vkGetBufferDeviceAddress for every buffer. So parameters and
//! host builds (whose data the layer reads in mapped memory) are checked
//! here, but the contents of a device build never are: the layer cannot
//! tell which buffer a device address lies in, and says so once per device
//! (`OMMCHECK-layer-contents-not-checked`). Content checks at submission
//! are covered by the in-process chain tests (layer/tests/submit.rs).
//!
//! Over lavapipe, device builds really run and buffer device addresses are
//! real, so contents are decidable: a top-level build's instance flags
//! (omm-app's `tlas`) are checked whether the instance lies in memory the
//! app maps or, in memory it never maps, was written there by transfers
//! (known from the recorded commands at submission) or by a compute shader
//! (known only by reading it back from the device after execution).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ommcheck_tests::{loader_command, place_layer_manifest, prepared};
use serde_json::Value;
use VkLayer_ommcheck::LAYER_NAME;

const KHRONOS_VALIDATION: &str = "VK_LAYER_KHRONOS_validation";
const BOTH_USAGE_POINTERS: &str = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";
const DATA_IN_RANGE: &str = "OMMCHECK-build-triangle-data-in-range";
const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";
/// A core rule the Khronos layer checks and ommcheck does not (omm-app's
/// `--core-fault`).
const CORE_FAULT: &str = "VUID-VkBufferCreateInfo-size-00912";
const ALL_SEVERITIES: &str = "error,warning,info";

/// The directory holding the layer's manifest, written once per test
/// process. The library is the cdylib cargo builds for the dev-dependency
/// on ommcheck-layer: `target/<profile>/deps` beside this test binary
/// (`cargo build` also copies it one level up).
fn layer_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("layer-e2e");
        place_layer_manifest(&dir, LAYER_NAME, "ommcheck (tests/layer_e2e.rs)");
        dir
    })
}

/// One message the app's messenger received.
#[derive(Debug)]
struct Received {
    id: String,
    severity: String,
    phase: String,
    text: String,
}

/// What omm-app printed for one scenario.
#[derive(Debug)]
struct Run {
    messages: Vec<Received>,
    /// What omm-app wrote to stderr: the layer's messages of
    /// vkCreateInstance go there, since the app has no messenger yet.
    stderr: String,
    device_layers: BTreeSet<String>,
    /// The device layers in the order the loader inserted them: from the
    /// one nearest the driver up to the one nearest the application.
    inserted_from_driver: Vec<String>,
    results: Value,
}

impl Run {
    /// The ids received, sorted (each as often as it was received).
    fn ids(&self) -> Vec<&str> {
        let mut ids: Vec<&str> = self.messages.iter().map(|m| m.id.as_str()).collect();
        ids.sort_unstable();
        ids
    }

    fn count(&self, id: &str) -> usize {
        self.messages.iter().filter(|m| m.id == id).count()
    }
}

/// A scenario's driver, layers (in ppEnabledLayerNames order) and settings.
struct Scenario<'a> {
    name: &'a str,
    icd: &'a Path,
    layers: &'a [&'a str],
    /// Directories the loader also searches for layers (beside ommcheck's).
    layer_dirs: &'a [&'a Path],
    settings: &'a [(&'a str, &'a str)],
    core_fault: bool,
    /// The scenario's own arguments, after its name.
    args: &'a [&'a str],
}

impl<'a> Scenario<'a> {
    fn new(name: &'a str, icd: &'a Path) -> Self {
        Self {
            name,
            icd,
            layers: &[LAYER_NAME],
            layer_dirs: &[],
            settings: &[],
            core_fault: false,
            args: &[],
        }
    }

    fn run(&self) -> Run {
        let mut command = loader_command(env!("CARGO_BIN_EXE_omm-app"));
        command.arg(self.name).args(self.args);
        for layer in self.layers {
            command.args(["--layer", layer]);
        }
        if self.core_fault {
            command.arg("--core-fault");
        }
        // The layer's settings come from the scenario alone.
        for (var, _) in std::env::vars_os() {
            if var.to_string_lossy().starts_with("OMMCHECK_") {
                command.env_remove(var);
            }
        }
        let dirs = std::iter::once(layer_dir())
            .chain(self.layer_dirs.iter().copied())
            .map(Path::as_os_str)
            .collect::<Vec<_>>()
            .join(std::ffi::OsStr::new(":"));
        command
            .env("VK_DRIVER_FILES", self.icd)
            .env("VK_ADD_LAYER_PATH", dirs)
            .envs(self.settings.iter().copied());
        let output = command.output().expect("running omm-app");
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(
            output.status.success(),
            "omm-app {} failed ({}):\n{}{stdout}",
            self.name,
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
        let line: Value = serde_json::from_str(stdout.trim())
            .unwrap_or_else(|e| panic!("omm-app printed no JSON line ({e}): {stdout}"));
        let text = |v: &Value, key: &str| v[key].as_str().unwrap_or_default().to_owned();
        let messages = line["messages"]
            .as_array()
            .expect("messages")
            .iter()
            .map(|m| Received {
                id: text(m, "id"),
                severity: text(m, "severity"),
                phase: text(m, "phase"),
                text: text(m, "text"),
            })
            .collect();
        let inserted_from_driver: Vec<String> = line["device_layers"]
            .as_array()
            .expect("device_layers")
            .iter()
            .map(|l| l.as_str().expect("a layer name").to_owned())
            .collect();
        Run {
            messages,
            stderr: String::from_utf8_lossy(&output.stderr).into_owned(),
            device_layers: inserted_from_driver.iter().cloned().collect(),
            inserted_from_driver,
            results: line["results"].clone(),
        }
    }
}

/// Asserts the layer was in the device's call chain.
fn assert_layer_inserted(run: &Run) {
    assert!(
        run.device_layers.contains(LAYER_NAME),
        "the loader did not insert {LAYER_NAME}: {run:#?}"
    );
}

#[test]
fn host_builds_over_the_mock_icd_report_exactly_their_faults() {
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    for (scenario, expected) in [
        ("host-build-valid", &[][..]),
        ("host-build-usage-pointers", &[BOTH_USAGE_POINTERS][..]),
        // The data lies at the end of mapped memory, so the layer knows
        // where it ends; plain host memory would leave its end unknown.
        ("host-build-data-past-end", &[DATA_IN_RANGE][..]),
    ] {
        let run = Scenario {
            settings: &[("OMMCHECK_REPORT", ALL_SEVERITIES)],
            ..Scenario::new(scenario, &icd)
        }
        .run();
        assert_layer_inserted(&run);
        assert_eq!(run.ids(), expected, "{scenario}: {run:#?}");
        assert!(
            run.messages
                .iter()
                .all(|m| m.phase == "build" && m.severity == "error"),
            "{scenario}: {run:#?}"
        );
        // The messenger returned VK_FALSE: the call reached the driver.
        assert_eq!(run.results["build"], 0, "{scenario}: {run:#?}");
    }
}

#[test]
fn device_builds_over_the_mock_icd_report_parameters_at_recording() {
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    for (scenario, expected) in [
        ("device-build-valid", &[][..]),
        ("device-build-usage-pointers", &[BOTH_USAGE_POINTERS][..]),
    ] {
        // Errors and warnings only (the default). The contents the Mock
        // ICD keeps from the layer are the next test's: muted here.
        let run = Scenario {
            settings: &[("OMMCHECK_MESSAGE_ID_FILTER", CONTENTS_NOT_CHECKED)],
            ..Scenario::new(scenario, &icd)
        }
        .run();
        assert_layer_inserted(&run);
        assert_eq!(run.ids(), expected, "{scenario}: {run:#?}");
        assert!(run.messages.iter().all(|m| m.phase == "record"), "{run:#?}");
        assert_eq!(run.results["submits"], serde_json::json!([0, 0]));
    }
}

#[test]
fn device_build_contents_the_mock_cannot_show_are_reported_once_as_not_checked() {
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    // `histogram-mismatch` writes usage counts that disagree with the
    // triangle array (OMMCHECK-build-usage-counts-match-triangles) into a
    // mapped host-visible buffer. On a driver that returns buffer device
    // addresses the layer reads them at vkQueueSubmit; the Mock ICD returns
    // 0 for every buffer (asserted below, so a mock that changes this shows
    // up here), the app builds from stand-in addresses, and the layer can
    // only say, once per device over two submissions, that it did not
    // check, and at vkDestroyDevice that this held for both. A warning: at
    // the default report level (no OMMCHECK_REPORT) it is seen.
    for scenario in ["device-build-valid", "device-build-histogram-mismatch"] {
        let run = Scenario::new(scenario, &icd).run();
        assert_eq!(
            run.results["buffer_addresses"],
            serde_json::json!([0, 0]),
            "the Mock ICD now returns buffer device addresses: assert the content fault here"
        );
        assert_eq!(
            run.ids(),
            [CONTENTS_NOT_CHECKED, CONTENTS_NOT_CHECKED],
            "{scenario}: {run:#?}"
        );
        let said: Vec<(&str, &str)> = run
            .messages
            .iter()
            .map(|m| (m.severity.as_str(), m.phase.as_str()))
            .collect();
        assert_eq!(said, [("warning", "submit"), ("warning", "teardown")]);
        assert!(
            run.messages[1]
                .text
                .contains("the contents of 2 device builds"),
            "{run:#?}"
        );
        assert_eq!(run.results["submits"], serde_json::json!([0, 0]));
    }
}

/// Setting mistakes are not silent under the real loader: a misspelled
/// variable is reported at vkCreateInstance (on stderr, since omm-app
/// chains no messenger to its instance) with the setting it was likely
/// meant to be; correct settings draw no such warning. With information
/// reported, the settings in effect are listed with where each came from.
#[test]
fn a_misspelled_variable_is_reported_with_the_setting_it_was_meant_to_be() {
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    const SETTINGS_PROBLEM: &str = "OMMCHECK-layer-settings";
    const EFFECTIVE_SETTINGS: &str = "OMMCHECK-layer-effective-settings";
    let misspelled = Scenario {
        settings: &[("OMMCHECK_REPROT", ALL_SEVERITIES)],
        ..Scenario::new("host-build-valid", &icd)
    }
    .run();
    assert!(
        misspelled.stderr.contains(&format!("[ {SETTINGS_PROBLEM} ]"))
            && misspelled.stderr.contains(
                "the environment variable OMMCHECK_REPROT is not a setting of this layer; ignored; did you mean `OMMCHECK_REPORT`?"
            ),
        "{misspelled:#?}"
    );
    assert!(
        !misspelled.stderr.contains(EFFECTIVE_SETTINGS),
        "{misspelled:#?}"
    );
    let correct = Scenario {
        settings: &[("OMMCHECK_REPORT", ALL_SEVERITIES)],
        ..Scenario::new("host-build-valid", &icd)
    }
    .run();
    assert!(!correct.stderr.contains(SETTINGS_PROBLEM), "{correct:#?}");
    assert!(
        correct
            .stderr
            .contains(&format!("[ {EFFECTIVE_SETTINGS} ]"))
            && correct
                .stderr
                .contains(r#"report_flags = "error,warning,info" (environment OMMCHECK_REPORT)"#),
        "{correct:#?}"
    );
}

#[test]
fn a_blas_builds_on_lavapipe_alike_with_and_without_the_layer() {
    let Some(icd) = prepared("OMMCHECK_TEST_LAVAPIPE_ICD") else {
        return;
    };
    let without = Scenario {
        layers: &[],
        ..Scenario::new("blas", &icd)
    }
    .run();
    let with = Scenario {
        settings: &[("OMMCHECK_REPORT", ALL_SEVERITIES)],
        ..Scenario::new("blas", &icd)
    }
    .run();
    assert!(without.device_layers.is_empty(), "{without:#?}");
    assert_layer_inserted(&with);
    assert_eq!(without.results, with.results);
    assert!(with.messages.is_empty(), "{with:#?}");
    assert!(without.messages.is_empty(), "{without:#?}");
    let results = &with.results;
    assert_eq!(results["submit"], 0);
    let compacted = results["compacted_size"].as_u64().expect("a size");
    let built = results["build_sizes"][0].as_u64().expect("a size");
    assert!(
        0 < compacted && compacted <= built,
        "compacted {compacted} of {built}"
    );
    assert!(results["serialization_size"].as_u64() > Some(0));
    // Without VK_EXT_opacity_micromap the micromap commands do not resolve,
    // with the layer as without.
    assert_eq!(results["has_opacity_micromap"], false);
    assert_eq!(
        results["null_micromap_commands"],
        serde_json::json!([true, true, true])
    );
}

/// The ids in the layer's log file (`OMMCHECK_LOG_FILE`): what ommcheck
/// itself reported, whatever the Khronos layer reported beside it.
fn logged_ids(log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let mut ids: Vec<String> = text
        .lines()
        .filter_map(|line| {
            let (_, rest) = line.split_once("[ ")?;
            let (id, _) = rest.split_once(" ]")?;
            Some(id.to_owned())
        })
        .collect();
    ids.sort_unstable();
    ids
}

#[test]
fn ommcheck_stacks_with_the_khronos_validation_layer_in_either_order() {
    let (Some(icd), Some(khronos)) = (
        prepared("OMMCHECK_TEST_MOCK_ICD"),
        prepared("OMMCHECK_TEST_KHRONOS_LAYER"),
    ) else {
        return;
    };
    let logs = Path::new(env!("CARGO_TARGET_TMPDIR")).join("layer-e2e");
    std::fs::create_dir_all(&logs).expect("creating the log directory");
    for (order, layers) in [
        ("ommcheck-first", [LAYER_NAME, KHRONOS_VALIDATION]),
        ("khronos-first", [KHRONOS_VALIDATION, LAYER_NAME]),
    ] {
        for (scenario, expected) in [
            ("host-build-valid", &[][..]),
            ("host-build-usage-pointers", &[BOTH_USAGE_POINTERS][..]),
        ] {
            let log = logs.join(format!("{order}-{scenario}-{}.log", std::process::id()));
            let _ = std::fs::remove_file(&log);
            let log_setting = log.to_str().expect("a UTF-8 path");
            let run = Scenario {
                layers: &layers,
                layer_dirs: &[&khronos],
                settings: &[("OMMCHECK_LOG_FILE", log_setting)],
                core_fault: true,
                ..Scenario::new(scenario, &icd)
            }
            .run();
            let what = format!("{order} {scenario}: {run:#?}");
            let expected_layers: BTreeSet<String> = layers.iter().map(|l| l.to_string()).collect();
            assert_eq!(run.device_layers, expected_layers, "{what}");
            // ommcheck reported exactly its fault, and it reached the app
            // once: the Khronos layer (1.3.239) does not check it.
            assert_eq!(logged_ids(&log), expected, "{what}");
            assert_eq!(run.count(BOTH_USAGE_POINTERS), expected.len(), "{what}");
            assert!(
                !run.messages.iter().any(|m| m.id.starts_with("OMMCHECK-")),
                "{what}"
            );
            // The Khronos layer is active: it reports the core fault.
            assert_eq!(run.count(CORE_FAULT), 1, "{what}");
            // The app still works: the build and the buffer reached the driver.
            assert_eq!(run.results["build"], 0, "{what}");
            assert_eq!(run.results["core_fault"], 0, "{what}");
            let _ = std::fs::remove_file(&log);
        }
    }
}

#[test]
fn eight_threads_over_the_mock_icd_report_exactly_their_faults() {
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    // No duplicate limit: every finding must arrive, as often as made.
    let run = Scenario {
        settings: &[("OMMCHECK_DUPLICATE_LIMIT", "0")],
        ..Scenario::new("threads", &icd)
    }
    .run();
    assert_layer_inserted(&run);
    // omm-app exits 2 if its threads have not finished within 60 s (a
    // deadlock); it succeeded, so they did.
    let runs = run.results["threads"].as_u64().expect("threads") as usize
        * run.results["iterations"].as_u64().expect("iterations") as usize;
    assert!(runs > 0, "{run:#?}");
    assert_eq!(run.results["failed_calls"], 0, "{run:#?}");
    let mut counts = std::collections::BTreeMap::new();
    for message in &run.messages {
        *counts.entry(message.id.as_str()).or_insert(0usize) += 1;
    }
    // The Mock ICD's zero buffer addresses keep every device build's
    // contents from the layer: said once, then counted over all threads.
    let expected = std::collections::BTreeMap::from([
        (BOTH_USAGE_POINTERS, 2 * runs),
        ("VUID-VkAccelerationStructureCreateInfoKHR-type-11600", runs),
        (CONTENTS_NOT_CHECKED, 2),
    ]);
    assert_eq!(counts, expected, "{run:#?}");
    let (totals, during): (Vec<&Received>, Vec<&Received>) =
        run.messages.iter().partition(|m| m.phase == "teardown");
    assert!(during.iter().all(|m| m.phase == "threads"), "{run:#?}");
    // Each run submits two micromap builds and a structure build.
    assert_eq!(totals.len(), 1, "{run:#?}");
    assert!(
        totals[0]
            .text
            .contains(&format!("the contents of {} device builds", 3 * runs)),
        "{run:#?}"
    );
}

const INSTANCE_FLAGS: &str = "VUID-VkAccelerationStructureInstanceKHR-micromap-11580";
/// Where the one instance of omm-app's `tlas` build keeps its flags.
const INSTANCE_FLAGS_LOCATION: &str = "pInfos[0].pGeometries[0].geometry.instances.data[0].flags";
/// The ways `tlas` puts its instance where the build reads it (`--way`).
const INSTANCE_WAYS: [&str; 5] = ["copy", "update", "fill", "compute", "mapped"];
/// FORCE_OPACITY_MICROMAP_2_STATE in the high byte of the instance's
/// eighth word (its flags), as `tlas` without `--valid` writes it.
const FORCED_FLAGS_WORD: u64 = 0x10 << 24;
const SYNC_HAZARD: &str = "SYNC-HAZARD-WRITE-AFTER-WRITE";
/// The Khronos layer's synchronization validation, also between
/// submissions (its list separator is ':'), and no shader validation cache
/// (it would say, once per machine, that it found none to read).
const KHRONOS_SYNC_SETTINGS: [(&str, &str); 2] = [
    (
        "VK_LAYER_ENABLES",
        "VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT:\
         VALIDATION_CHECK_ENABLE_SYNCHRONIZATION_VALIDATION_QUEUE_SUBMIT",
    ),
    (
        "VK_LAYER_DISABLES",
        "VK_VALIDATION_FEATURE_DISABLE_SHADER_VALIDATION_CACHE_EXT",
    ),
];

/// omm-app's `tlas` arguments for `way`, valid or not.
fn tlas_args(way: &str, valid: bool) -> Vec<&str> {
    let mut args = vec!["--way", way];
    if valid {
        args.push("--valid");
    }
    args
}

/// Asserts what every `tlas` run returns, with or without layers: the
/// submission and the wait succeeded and the instance the build read is the
/// one the app meant, flags included.
fn assert_tlas_ran(run: &Run, valid: bool, what: &str) {
    let results = &run.results;
    assert_eq!(
        (&results["submit"], &results["wait"]),
        (&0.into(), &0.into()),
        "{what}"
    );
    assert_eq!(results["instance_written"], true, "{what}");
    let flags = if valid { 0 } else { FORCED_FLAGS_WORD };
    assert_eq!(results["instance_read_back"][13], flags, "{what}");
    assert!(results["compacted_size"].as_u64() > Some(0), "{what}");
}

/// Asserts `run` received exactly one finding of `id` about the instance's
/// flags, in `phase`, and nothing else.
fn assert_one_instance_finding(run: &Run, phase: &str, what: &str) {
    assert_eq!(run.ids(), [INSTANCE_FLAGS], "{what}");
    let message = &run.messages[0];
    assert_eq!(
        (message.severity.as_str(), message.phase.as_str()),
        ("error", phase),
        "{what}"
    );
    assert!(
        message.text.contains(INSTANCE_FLAGS_LOCATION),
        "{what}: the text names no {INSTANCE_FLAGS_LOCATION}"
    );
}

/// The top-level build reads its one instance from a buffer the app wrote
/// in one of five ways (omm-app's `tlas --way`); the instance's flags hold
/// FORCE_OPACITY_MICROMAP_2_STATE on a device without any micromap feature.
/// With the layer's defaults (GPU readback on), ommcheck reports it exactly
/// once. From memory the app keeps mapped it is known at vkQueueSubmit.
/// Written by transfers or a shader into memory the app never maps, the
/// layer copies the instances back before the build and checks them once
/// the submission completes (vkWaitForFences). The valid twin (flags 0) is
/// silent, at every severity, and the app reads back the same results with
/// the layer as without.
#[test]
fn a_top_level_builds_instance_flags_are_reported_once_however_the_instance_was_written() {
    let Some(icd) = prepared("OMMCHECK_TEST_LAVAPIPE_ICD") else {
        return;
    };
    for way in INSTANCE_WAYS {
        for valid in [false, true] {
            let args = tlas_args(way, valid);
            let without = Scenario {
                layers: &[],
                args: &args,
                ..Scenario::new("tlas", &icd)
            }
            .run();
            let with = Scenario {
                settings: &[("OMMCHECK_REPORT", ALL_SEVERITIES)],
                args: &args,
                ..Scenario::new("tlas", &icd)
            }
            .run();
            let what = format!("tlas {args:?}: {with:#?}");
            assert_layer_inserted(&with);
            assert_tlas_ran(&without, valid, &what);
            assert_eq!(with.results, without.results, "{what}");
            assert!(without.messages.is_empty(), "{without:#?}");
            if valid {
                assert!(with.messages.is_empty(), "{what}");
            } else {
                let phase = if way == "mapped" { "submit" } else { "wait" };
                assert_one_instance_finding(&with, phase, &what);
            }
        }
    }
}

/// With GPU readback off (OMMCHECK_GPU_READBACK=false) only what the host
/// can know is checked. Instances uploaded by vkCmdCopyBuffer from mapped
/// memory, or written by vkCmdUpdateBuffer and vkCmdFillBuffer, are known
/// from the recorded transfers and reported at vkQueueSubmit, as are
/// instances in mapped memory. Those a compute shader wrote cannot be known
/// from the host: the layer says once, at submission, that it did not check
/// the build's contents and names the setting that would, whether the
/// flags are valid or not.
#[test]
fn without_gpu_readback_instances_written_by_transfers_are_still_reported_at_submission() {
    let Some(icd) = prepared("OMMCHECK_TEST_LAVAPIPE_ICD") else {
        return;
    };
    for way in INSTANCE_WAYS {
        for valid in [false, true] {
            let args = tlas_args(way, valid);
            let run = Scenario {
                settings: &[
                    ("OMMCHECK_REPORT", ALL_SEVERITIES),
                    ("OMMCHECK_GPU_READBACK", "false"),
                ],
                args: &args,
                ..Scenario::new("tlas", &icd)
            }
            .run();
            let what = format!("tlas {args:?} without readback: {run:#?}");
            assert_layer_inserted(&run);
            assert_tlas_ran(&run, valid, &what);
            if way == "compute" {
                assert_eq!(run.ids(), [CONTENTS_NOT_CHECKED], "{what}");
                let message = &run.messages[0];
                assert_eq!(
                    (message.severity.as_str(), message.phase.as_str()),
                    ("warning", "submit"),
                    "{what}"
                );
                assert!(
                    message.text.to_ascii_lowercase().contains("gpu_readback"),
                    "{what}: the text names no setting gpu_readback"
                );
            } else if valid {
                assert!(run.messages.is_empty(), "{what}");
            } else {
                assert_one_instance_finding(&run, "submit", &what);
            }
        }
    }
}

/// `a` less each element of `b`, as often as it is in `b` (both sorted).
fn without_each(a: &[String], b: &[String]) -> Vec<String> {
    let mut rest = a.to_vec();
    for item in b {
        if let Some(at) = rest.iter().position(|x| x == item) {
            rest.remove(at);
        }
    }
    rest
}

/// The Khronos validation layer between ommcheck and the driver, with
/// synchronization validation on, sees every command ommcheck adds to the
/// app's command buffers (the readback's barriers and copies) and the
/// buffers and memory ommcheck creates. It reports exactly what it reports
/// without ommcheck: the one hazard the app plants (`--sync-fault`, which
/// shows synchronization validation is on) and nothing else. Its
/// synchronization validation (1.3.239) does not follow what builds read,
/// but it does follow transfers and dispatches: without omm-app's barrier
/// before the build it reports the shader that copies the instance back
/// (SYNC-HAZARD-READ-AFTER-WRITE), so a readback copy of the instances
/// without a barrier after their writer would be reported too. The
/// instance buffer lacks TRANSFER_SRC usage, which ommcheck's copy needs.
/// ommcheck still reports the instance's flags, and the app reads back the
/// same results.
#[test]
fn khronos_synchronization_validation_below_ommcheck_finds_nothing_in_what_ommcheck_adds() {
    let (Some(icd), Some(khronos)) = (
        prepared("OMMCHECK_TEST_LAVAPIPE_ICD"),
        prepared("OMMCHECK_TEST_KHRONOS_LAYER"),
    ) else {
        return;
    };
    let logs = Path::new(env!("CARGO_TARGET_TMPDIR")).join("layer-e2e");
    std::fs::create_dir_all(&logs).expect("creating the log directory");
    for way in INSTANCE_WAYS {
        let mut args = tlas_args(way, false);
        args.push("--sync-fault");
        let khronos_alone = Scenario {
            layers: &[KHRONOS_VALIDATION],
            layer_dirs: &[&khronos],
            settings: &KHRONOS_SYNC_SETTINGS,
            args: &args,
            ..Scenario::new("tlas", &icd)
        }
        .run();
        let log = logs.join(format!("tlas-{way}-{}.log", std::process::id()));
        let _ = std::fs::remove_file(&log);
        let mut settings = KHRONOS_SYNC_SETTINGS.to_vec();
        settings.push(("OMMCHECK_LOG_FILE", log.to_str().expect("a UTF-8 path")));
        // ppEnabledLayerNames lists layers from the application down: the
        // Khronos layer comes second, between ommcheck and the driver.
        let stacked = Scenario {
            layers: &[LAYER_NAME, KHRONOS_VALIDATION],
            layer_dirs: &[&khronos],
            settings: &settings,
            args: &args,
            ..Scenario::new("tlas", &icd)
        }
        .run();
        let what = format!("tlas {args:?}: alone {khronos_alone:#?}, stacked {stacked:#?}");
        // The loader builds the chain from the driver up.
        assert_eq!(
            stacked.inserted_from_driver,
            [KHRONOS_VALIDATION, LAYER_NAME],
            "{what}"
        );
        let ommcheck_ids = logged_ids(&log);
        let _ = std::fs::remove_file(&log);
        let owned =
            |run: &Run| -> Vec<String> { run.ids().into_iter().map(String::from).collect() };
        assert_eq!(owned(&khronos_alone), [SYNC_HAZARD], "{what}");
        assert_eq!(
            without_each(&owned(&stacked), &ommcheck_ids),
            owned(&khronos_alone),
            "{what}"
        );
        assert_eq!(ommcheck_ids, [INSTANCE_FLAGS], "{what}");
        assert_tlas_ran(&khronos_alone, false, &what);
        assert_eq!(stacked.results, khronos_alone.results, "{what}");
    }
}

/// vulkaninfo (Debian: vulkan-tools), an application that still uses
/// VK_EXT_debug_report, chains a debug-report callback to its
/// `VkInstanceCreateInfo`: the layer's warning about a bad setting reaches
/// it through the real loader, with the MessageID as the message code, and
/// the bad value does not silence it. Skips where vulkaninfo is missing.
#[test]
fn vulkaninfo_debug_report_callback_receives_a_bad_setting_warning() {
    const SETTINGS_PROBLEM: &str = "OMMCHECK-layer-settings";
    let Some(icd) = prepared("OMMCHECK_TEST_MOCK_ICD") else {
        return;
    };
    let output = match loader_command("vulkaninfo")
        .arg("--summary")
        .env("VK_DRIVER_FILES", &icd)
        .env("VK_ADD_LAYER_PATH", layer_dir())
        .env("VK_INSTANCE_LAYERS", LAYER_NAME)
        .env("OMMCHECK_REPORT", "errors,warnings")
        .output()
    {
        Ok(output) => output,
        Err(e) => {
            eprintln!("skipping: vulkaninfo: {e}");
            return;
        }
    };
    let stderr = String::from_utf8_lossy(&output.stderr);
    let code = ommcheck::report::message_id(SETTINGS_PROBLEM) as i32;
    let line = stderr
        .lines()
        .find(|line| line.starts_with("WARNING: [OMMCHECK] Code"))
        .unwrap_or_else(|| panic!("no debug-report message:\n{stderr}"));
    assert!(
        line.starts_with(&format!(
            "WARNING: [OMMCHECK] Code {code} : Validation Warning: [ {SETTINGS_PROBLEM} ]"
        )),
        "{line}"
    );
    assert!(
        line.contains("`errors` is not error, warning or info"),
        "{line}"
    );
}
