//! Findings that point precisely: the call, scene line and named objects
//! of a finding in JSON, findings caused by another folded into it, the
//! hint for a misplaced usage count, and objects a program names.

use std::path::Path;

use serde_json::Value;

use ommcheck::rules;
use ommcheck::scene::{CheckOptions, Scene, SceneReport};
use ommcheck::vuids::vuid::VkMicromapBuildInfoEXT as info_vuid;

const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes/corpus");

fn corpus_text(file: &str) -> String {
    std::fs::read_to_string(Path::new(CORPUS).join(file)).unwrap_or_else(|e| panic!("{file}: {e}"))
}

fn check_text(text: &str, path: &str) -> SceneReport {
    Scene::parse(text, path, Path::new(CORPUS))
        .and_then(|scene| scene.check(&CheckOptions::default()))
        .unwrap_or_else(|e| panic!("{e}"))
}

fn check_value(scene: &Value, path: &str) -> SceneReport {
    check_text(&serde_json::to_string_pretty(scene).expect("a scene"), path)
}

/// The micromap build of the corpus (a 512-byte input buffer whose
/// triangle array starts at 256: room for 32 entries, 2 written) with one
/// usage count of `count` level-1 4-state triangles.
fn build_with_count(count: u64) -> Value {
    build_with_counts(serde_json::json!([{
        "count": count,
        "subdivisionLevel": 1,
        "format": "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT"
    }]))
}

/// That build with the usage counts `counts`.
fn build_with_counts(counts: Value) -> Value {
    let text = corpus_text("ext-build/OMMCHECK-build-usage-counts-match-triangles.pass.json");
    let mut scene: Value = serde_json::from_str(&text).expect("JSON");
    scene["calls"][0]["pInfos"][0]["pUsageCounts"] = counts;
    scene
}

#[test]
fn zero_entries_past_the_triangles_written_fold_into_the_range_finding() {
    let report = check_value(&build_with_count(u64::from(u32::MAX)), "overrun.json");
    let ids = report.report.ids();
    let range: Vec<_> = report
        .report
        .with_rule(&rules::TRIANGLE_ARRAY_RANGE)
        .collect();
    assert_eq!(range.len(), 1, "{ids:?}");
    // The entries the 256 bytes from the array's start hold, less the two written.
    let entries = (512 - 256) / 8;
    assert_eq!(range[0].folded, entries - 2, "{}", range[0].message);
    assert!(
        range[0].message.contains(&format!(
            "and {} more triangles past the triangles written",
            entries - 2
        )),
        "{}",
        range[0].message
    );
    assert!(!report.report.contains(info_vuid::format_11657), "{ids:?}");
    let json = serde_json::to_value(range[0]).expect("JSON");
    assert_eq!(json["folded"], entries - 2);

    // An entry that is not zero bytes is no follow-on: still reported.
    let mut scene = build_with_count(u64::from(u32::MAX));
    scene["buffers"][0]["contents"]
        .as_array_mut()
        .expect("contents")
        .push(serde_json::json!({ "at": 256 + 8 * 5, "hex": "00 00 00 00 01 00 07 00" }));
    let report = check_value(&scene, "overrun-and-garbage.json");
    let formats: Vec<_> = report.report.with_rule(info_vuid::format_11657).collect();
    assert_eq!(formats.len(), 1, "{}", report.report);
    assert!(formats[0].location.ends_with("triangleArray[5].format"));
    let range = report.report.with_rule(&rules::TRIANGLE_ARRAY_RANGE).next();
    assert_eq!(range.map(|f| f.folded), Some(entries - 3));

    // The right count: nothing to report, nothing folded.
    let report = check_value(&build_with_count(2), "right.json");
    assert!(report.report.is_empty(), "{}", report.report);
}

#[test]
fn a_count_under_the_wrong_level_is_one_finding_with_a_hint() {
    let file = "ext-build/OMMCHECK-build-usage-counts-match-triangles.fail.json";
    let report = check_text(&corpus_text(file), file);
    let findings: Vec<_> = report
        .report
        .with_rule(&rules::HISTOGRAM_MISMATCH)
        .collect();
    assert_eq!(findings.len(), 1, "{}", report.report);
    let finding = findings[0];
    // The scene writes one of the two level-1 triangles' counts under level 2.
    assert_eq!(finding.hint.as_deref(), Some("Did you mean level 1?"));
    assert!(finding.message.starts_with("VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 2: the usage counts say 1, the triangle array holds 0"), "{}", finding.message);
    assert!(finding.message.contains("and VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 1: the usage counts say 1, the triangle array holds 2"), "{}", finding.message);
    assert_eq!(finding.folded, 1);
    let text = report.named_findings();
    assert!(
        text.contains("holds 2. Did you mean level 1? The Vulkan spec states:"),
        "{text}"
    );

    // Its valid twin: no finding, so no hint.
    let twin = "ext-build/OMMCHECK-build-usage-counts-match-triangles.pass.json";
    assert!(check_text(&corpus_text(twin), twin).report.is_empty());

    // Mismatches with no clear fix (the two level-1 triangles counted at
    // level 2, one under each format): each reported as before, no hint.
    let counts = serde_json::json!([
        { "count": 1, "subdivisionLevel": 2, "format": "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT" },
        { "count": 1, "subdivisionLevel": 2, "format": "VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT" }
    ]);
    let report = check_value(&build_with_counts(counts), "unclear.json");
    let findings: Vec<_> = report
        .report
        .with_rule(&rules::HISTOGRAM_MISMATCH)
        .collect();
    assert_eq!(findings.len(), 3, "{}", report.report);
    assert!(findings.iter().all(|f| f.hint.is_none() && f.folded == 0));
}

#[test]
fn json_findings_give_the_call_the_scene_line_and_the_objects_by_name() {
    let file = "blas-ext/OMMCHECK-attach-index-in-range.fail.json";
    let text = corpus_text(file);
    let report = check_text(&text, file);
    let finding = report
        .report
        .with_rule(&rules::INDEX_IN_RANGE)
        .next()
        .expect("the rule's finding");
    let json = serde_json::to_value(finding).expect("JSON");
    let scene: Value = serde_json::from_str(&text).expect("JSON");
    // The second call builds the BLAS; its object starts on the line before
    // its `"call"` member in this pretty-printed file.
    let call_line = text
        .lines()
        .position(|l| l.contains("\"call\": \"vkCmdBuildAccelerationStructuresKHR\""))
        .expect("the BLAS build");
    assert_eq!(json["at"]["call"], 1);
    assert_eq!(json["at"]["line"], call_line, "{json:#}");
    assert_eq!(json["at"]["scene"], file);
    let parameter = json["at"]["parameter"].as_str().expect("a parameter");
    assert!(
        parameter.starts_with("pInfos[0].pGeometries[0]."),
        "{parameter}"
    );
    assert_eq!(json["location"], format!("calls[1]: {parameter}"));
    // The location string is as before.
    assert_eq!(finding.parameter(), parameter);
    // The micromap attached and the structure built, by their scene names.
    let info = &scene["calls"][1]["pInfos"][0];
    let attached = &info["pGeometries"][0]["geometry"]["triangles"]["pNext"][0]["micromap"];
    let named = |ty: &str| {
        json["objects"]
            .as_array()
            .expect("objects")
            .iter()
            .find(|o| o["type"] == ty)
            .map(|o| o["name"].clone())
    };
    assert_eq!(named("VkMicromapEXT").as_ref(), Some(attached), "{json:#}");
    assert_eq!(
        named("VkAccelerationStructureKHR").as_ref(),
        Some(&info["dstAccelerationStructure"])
    );
    // The text quotes the one sentence of the statement an EXT attachment breaks.
    let text = report.named_findings();
    assert!(text.contains("The Vulkan spec states: Otherwise that triangle uses the opacity micromap information from micromap at that index plus baseTriangle. ("), "{text}");
    assert!(!text.contains("KHR: \""), "{text}");
    assert!(
        text.contains(&format!("\n    Scene: {file}:{call_line}")),
        "{text}"
    );
    assert!(json["specText"]
        .as_str()
        .is_some_and(|t| t.starts_with("EXT: ")));
    assert!(json["specQuote"]
        .as_str()
        .is_some_and(|t| t.starts_with("Otherwise")));
}

#[test]
fn the_static_api_names_the_objects_a_test_names() {
    use ash::vk;
    use ommcheck::fixture::Fixture;
    use ommcheck::model::{CommandBuffer, MicromapBuildInfo, MicromapUsage, UsageCounts};

    let mut f = Fixture::new();
    let disc = f.micromap_unbuilt(4096);
    f.name_object(disc, "disc");
    // A build of `disc` with triangles but NULL input addresses.
    let build = MicromapBuildInfo {
        dst_micromap: vk::Handle::as_raw(disc),
        usage_counts: UsageCounts::array(vec![MicromapUsage {
            count: 1,
            subdivision_level: 1,
            format: 2,
        }]),
        ..Default::default()
    };
    let report = f.cmd_build_micromaps(&CommandBuffer::default(), &[build]);
    assert!(!report.is_empty());
    let named: Vec<_> = report
        .findings
        .iter()
        .filter(|finding| finding.location.starts_with("pInfos[0]"))
        .collect();
    assert!(!named.is_empty(), "{report}");
    for finding in named {
        let json = serde_json::to_value(finding).expect("JSON");
        let objects = json["objects"].as_array().expect("objects");
        assert!(
            objects
                .iter()
                .any(|o| o["type"] == "VkMicromapEXT" && o["name"] == "disc"),
            "{json:#}"
        );
        assert!(finding.to_string().contains(&format!(
            "VkMicromapEXT 'disc' ({:#x})",
            vk::Handle::as_raw(disc)
        )));
        // The static API has no call index or scene.
        assert_eq!(json["at"]["call"], Value::Null);
        assert_eq!(json["at"]["parameter"], finding.location);
    }
}
