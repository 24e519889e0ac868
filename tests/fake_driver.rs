//! The layer under the real Vulkan loader over the project's fake driver
//! (`layer/fake-icd`: the layer tests' fake driver as an ICD, whose GPU
//! holds real bytes, executes transfers and returns real buffer device
//! addresses, so the contents of device builds are checked, read back from
//! device-local memory after the submission completes). Each test runs
//! `omm-stress` (src/bin/omm-stress.rs) as a child process, because the
//! loader reads its environment once per process, with the layer and the
//! fake driver cargo built for this crate's dev-dependencies.
//!
//! - Threads: 1, 2, 4, 8 and 16 threads at once, each with its own command
//!   pool, command buffer, fence and micromap, record and submit faulty
//!   micromap builds; every thread's faults arrive exactly once each, named
//!   by that thread's command buffer, whichever thread's wait completed
//!   them; with and without a messenger callback that calls back into
//!   Vulkan (a vkGet* function, vkGetFenceStatus and a vkCmd* function). A
//!   deadlock fails the run: omm-stress's watchdog thread aborts the
//!   process if its threads have not finished within 300 s.
//! - A short soak (`cargo xtask soak` runs 10^5 submissions): 2,000
//!   submissions, with lavapipe's top-level builds where `cargo xtask test`
//!   prepared lavapipe; every planted fault is reported as often as made and
//!   the resident memory at the end stays within 1.1 times its 10% mark.
//!
//! Where the system has no Vulkan loader the tests skip, except in CI.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::OnceLock;

use ommcheck_tests::{in_ci, loader_command, place_fake_driver_manifest, place_layer_manifest};
use serde_json::Value;
use VkLayer_ommcheck::LAYER_NAME;

const BOTH_USAGE_POINTERS: &str = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";
const DATA_IN_RANGE: &str = "OMMCHECK-build-triangle-data-in-range";
/// The thread counts of issue 29.
const THREADS: [usize; 5] = [1, 2, 4, 8, 16];
/// Rounds per thread: each records one build of each fault.
const ROUNDS: u64 = 10;

/// The layer's manifest directory and the fake driver's manifest, written
/// once per test process.
fn manifests() -> &'static (PathBuf, PathBuf) {
    static PATHS: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    PATHS.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fake-driver");
        place_layer_manifest(&dir, LAYER_NAME, "ommcheck (tests/fake_driver.rs)");
        let icd = place_fake_driver_manifest(&dir);
        (dir, icd)
    })
}

/// Runs `omm-stress ARGS` through the layer over the fake driver (and the
/// drivers in `more_drivers`), with no duplicate limit so every finding
/// arrives; None (skip) where the system has no Vulkan loader, outside CI.
fn omm_stress(args: &[&str], more_drivers: &[&Path]) -> Option<Output> {
    let (layer_dir, icd) = manifests();
    let drivers =
        std::env::join_paths(std::iter::once(icd.as_path()).chain(more_drivers.iter().copied()))
            .expect("driver manifest paths");
    let mut command = loader_command(env!("CARGO_BIN_EXE_omm-stress"));
    for (var, _) in std::env::vars_os() {
        if var.to_string_lossy().starts_with("OMMCHECK_") {
            command.env_remove(var);
        }
    }
    let output = command
        .args(args)
        .args(["--layer", LAYER_NAME])
        .env("VK_DRIVER_FILES", drivers)
        .env("VK_ADD_LAYER_PATH", layer_dir)
        .env("OMMCHECK_DUPLICATE_LIMIT", "0")
        .output()
        .expect("running omm-stress");
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() && stderr.contains("no Vulkan loader") && !in_ci() {
        eprintln!("skipping: {stderr}");
        return None;
    }
    Some(output)
}

/// What `omm-stress threads` printed, its run asserted successful.
fn threads_run(threads: usize, reenter: bool) -> Option<Value> {
    let threads_arg = threads.to_string();
    let rounds_arg = ROUNDS.to_string();
    let mut args = vec![
        "threads",
        "--threads",
        &threads_arg,
        "--rounds",
        &rounds_arg,
    ];
    if reenter {
        args.push("--reenter");
    }
    let output = omm_stress(&args, &[])?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "omm-stress {args:?} failed ({}; an abort is its deadlock watchdog):\n{stderr}{stdout}",
        output.status,
    );
    // Nothing the fake GPU could not execute.
    assert!(!stderr.contains("GPU fault"), "{stderr}");
    Some(serde_json::from_str(stdout.trim()).expect("omm-stress printed a JSON line"))
}

/// Asserts each thread's command buffer drew exactly its planted findings,
/// each once per round, and no finding named anything else.
fn assert_each_thread_reported_once(run: &Value, threads: usize) {
    let expected = serde_json::json!({ BOTH_USAGE_POINTERS: ROUNDS, DATA_IN_RANGE: ROUNDS });
    let per_thread = run["per_thread"].as_array().expect("per_thread");
    assert_eq!(per_thread.len(), threads, "{run}");
    for (t, counts) in per_thread.iter().enumerate() {
        assert_eq!(counts, &expected, "thread {t} of {threads}: {run}");
    }
    assert_eq!(run["elsewhere"], serde_json::json!({}), "{run}");
}

#[test]
fn every_threads_faulty_builds_are_reported_exactly_once_at_1_to_16_threads() {
    for threads in THREADS {
        let Some(run) = threads_run(threads, false) else {
            return;
        };
        assert_each_thread_reported_once(&run, threads);
        assert_eq!(run["reentered"], 0, "{run}");
    }
}

/// The callback calls vkGetBufferDeviceAddress, vkGetFenceStatus (whose
/// intercept completes submissions) and vkCmdFillBuffer, each of which the
/// layer intercepts, for every message: at recording (inside
/// vkCmdBuildMicromapsEXT) and at completion (inside vkWaitForFences). A
/// layer that delivered while holding a device's lock would deadlock here.
#[test]
fn a_callback_calling_back_into_vulkan_neither_deadlocks_nor_loses_findings() {
    for threads in THREADS {
        let Some(run) = threads_run(threads, true) else {
            return;
        };
        assert_each_thread_reported_once(&run, threads);
        // Every message called back in.
        let messages = 2 * ROUNDS * threads as u64;
        assert_eq!(run["reentered"], messages, "{run}");
    }
}

#[test]
fn a_short_soak_reports_every_planted_fault_and_holds_its_memory() {
    let lavapipe = std::env::var_os("OMMCHECK_TEST_LAVAPIPE_ICD").map(PathBuf::from);
    let mut args = vec!["soak", "--submissions", "2000"];
    if lavapipe.is_some() {
        args.push("--lavapipe");
    }
    let drivers: Vec<&Path> = lavapipe.iter().map(PathBuf::as_path).collect();
    let Some(output) = omm_stress(&args, &drivers) else {
        return;
    };
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stdout}{stderr}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 1, "{stdout}");
    let line = lines[0];
    assert!(line.starts_with("soak: 2000 submissions ("), "{line}");
    assert!(line.ends_with(": passed"), "{line}");
    // The findings: "N findings (N expected)", N > 0.
    let findings = line
        .split(", ")
        .find(|part| part.ends_with("expected)"))
        .unwrap_or_else(|| panic!("no findings in {line}"));
    let (got, expected) = findings
        .split_once(" findings (")
        .unwrap_or_else(|| panic!("{findings}"));
    assert_eq!(format!("{got} expected)"), expected, "{line}");
    assert!(got.parse::<u64>().is_ok_and(|n| n > 0), "{line}");
    if lavapipe.is_some() {
        assert!(line.contains(", 200 TLAS over lavapipe)"), "{line}");
    }
    // Nothing the fake GPU could not execute.
    assert!(!stderr.contains("GPU fault"), "{stderr}");
}
