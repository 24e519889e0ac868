//! The seeded fault corpus (`ommcheck-faults`, whose accuracy `cargo xtask
//! accuracy` measures with the static checker) replayed through the layer
//! with every build input in device-local memory (issue 14): uploaded by
//! `vkCmdCopyBuffer` from staging with readback off (route 1), and written
//! by the fake GPU's shader stand-in with readback on (route 2).
//!
//! For every fault of every class the layer reports, as errors and
//! warnings, exactly the rule ids the static checker reports for the same
//! scene at the content tier; the faults that only the content tier
//! catches arrive from the contents (at `vkQueueSubmit` through route 1,
//! at `vkWaitForFences` through route 2), never at recording. Valid twins
//! draw no error or warning; nothing is reported as not checked.
//!
//! The sizes are the corpus's smaller workloads (4 and 64 triangles), so
//! the test takes seconds.

mod fake;
mod player;

use std::collections::BTreeSet;
use std::path::Path;

use ash::vk;
use ommcheck::scene::{CheckOptions, Scene};
use ommcheck::{Severity, Tier};
use ommcheck_faults::{corpus, SEED};
use player::{replay, Replayed, Route};
use serde_json::Value;

const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";

/// The largest workload replayed.
const MAX_TRIANGLES: usize = 64;

/// `scene` as the player runs it: its commands recorded into one command
/// buffer that is then submitted, so that the checker decides what the
/// layer decides at submission (a micromap a build attaches must have been
/// built by work that ran before, 11632).
fn as_submitted(scene: &Value) -> Value {
    const RECORDED: &str = "replayed";
    let mut scene = scene.clone();
    scene["commandBuffers"] = serde_json::json!([{ "name": RECORDED }]);
    let calls = scene["calls"]
        .as_array_mut()
        .expect("a corpus scene has calls");
    for call in calls.iter_mut() {
        let name = call["call"].as_str().unwrap_or_default();
        if name.starts_with("vkCmd") && call.get("commandBuffer").is_none() {
            call["commandBuffer"] = RECORDED.into();
        }
    }
    calls.push(serde_json::json!({
        "call": "vkQueueSubmit",
        "pSubmits": [{ "pCommandBuffers": [RECORDED] }]
    }));
    scene
}

/// The rule ids of the errors and warnings the static checker reports for
/// `scene`, recorded and submitted (`as_submitted`), at `tier`.
fn checker_ids(scene: &Value, tier: Tier) -> BTreeSet<String> {
    let scene = Scene::parse(
        &as_submitted(scene).to_string(),
        "fault corpus",
        Path::new("."),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let options = CheckOptions {
        tier,
        ..CheckOptions::default()
    };
    let report = scene.check(&options).unwrap_or_else(|e| panic!("{e}"));
    report
        .report
        .findings
        .iter()
        .filter(|f| f.severity != Severity::Info)
        .map(|f| f.rule.as_str().to_owned())
        .collect()
}

/// An error or warning about a rule: not information, nor the layer's
/// warning that it could not check contents (which `failures_of` checks
/// on its own), nor the core's not-checked causes, which the layer says as
/// warnings once per device where the checker gives them as information
/// (tests/chain.rs checks those).
fn is_finding(message: &&fake::Received) -> bool {
    message.severity != vk::DebugUtilsMessageSeverityFlagsEXT::INFO
        && message.id != CONTENTS_NOT_CHECKED
        && !message.id.starts_with("OMMCHECK-not-checked-")
}

fn ids<'a>(messages: impl Iterator<Item = &'a fake::Received>) -> BTreeSet<String> {
    messages.filter(is_finding).map(|m| m.id.clone()).collect()
}

/// The one class whose contents the layer cannot read back, and why: the
/// layer adds `VK_BUFFER_USAGE_TRANSFER_SRC_BIT` (which its copies need)
/// only to buffers created with a build-input usage, and this fault is a
/// data buffer created without one (its VUID is reported at recording).
/// The layer says so, naming the cause, rather than staying silent.
const UNREADABLE: (&str, Route, &str) = (
    "data buffer without build-input usage",
    Route::ShaderWrite,
    "lacks VK_BUFFER_USAGE_TRANSFER_SRC_BIT",
);

/// What went wrong with one replay, if anything.
fn failures_of(
    replayed: &Replayed,
    expected: &BTreeSet<String>,
    content_rule: Option<&str>,
    (class, route): (&str, Route),
) -> Vec<String> {
    let mut failures = Vec::new();
    let reported = ids(replayed.all());
    if &reported != expected {
        failures.push(format!("reported {reported:?}, the checker {expected:?}"));
    }
    let not_checked: Vec<&fake::Received> = replayed
        .all()
        .filter(|m| m.id == CONTENTS_NOT_CHECKED)
        .collect();
    let (unreadable_class, unreadable_route, cause) = UNREADABLE;
    let explained = (class, route) == (unreadable_class, unreadable_route)
        && not_checked.len() == 1
        && not_checked[0].text.contains(cause);
    if !not_checked.is_empty() && !explained {
        failures.push(format!("not checked: {not_checked:#?}"));
    }
    if let Some(rule) = content_rule {
        // Decided by the contents: from the shadows at submission (route
        // 1) or from the readback at completion (route 2), not before.
        let when = match route {
            Route::Upload => &replayed.at_submission,
            Route::ShaderWrite => &replayed.at_completion,
        };
        if !when.iter().any(|m| m.id == rule) {
            failures.push(format!("{rule} not reported when the contents are read"));
        }
        if replayed.at_recording.iter().any(|m| m.id == rule) {
            failures.push(format!("{rule} reported at recording"));
        }
    }
    failures
}

#[test]
fn every_corpus_fault_in_device_local_memory_is_reported_as_the_checker_reports_it() {
    let cases: Vec<_> = corpus(SEED)
        .into_iter()
        .filter(|case| case.size <= MAX_TRIANGLES)
        .collect();
    assert!(cases.len() >= 64, "{} cases", cases.len());
    let mut failures = Vec::new();
    let mut content_classes = BTreeSet::new();
    for case in &cases {
        let expected = checker_ids(&case.faulty, Tier::Content);
        assert!(
            expected.contains(case.rule),
            "the checker misses {} ({})",
            case.class,
            case.size
        );
        // A fault the state tier misses is decided by the contents.
        let content_rule =
            (!checker_ids(&case.faulty, Tier::State).contains(case.rule)).then_some(case.rule);
        if content_rule.is_some() {
            content_classes.insert(case.class);
        }
        assert_eq!(checker_ids(&case.twin, Tier::Content), BTreeSet::new());
        for route in [Route::Upload, Route::ShaderWrite] {
            let faulty = replay(&case.faulty, route);
            for failure in failures_of(&faulty, &expected, content_rule, (case.class, route)) {
                failures.push(format!(
                    "{} ({}) {route:?}: {failure}",
                    case.class, case.size
                ));
            }
            let twin = replay(&case.twin, route);
            for failure in failures_of(&twin, &BTreeSet::new(), None, ("valid twin", route)) {
                failures.push(format!(
                    "{} ({}) {route:?} valid twin: {failure}",
                    case.class, case.size
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    // The corpus plants content faults of 8 classes (docs/accuracy-costs.md).
    assert!(content_classes.len() >= 8, "{content_classes:?}");
    assert_eq!(fake::gpu::faults(), Vec::<String>::new());
}
