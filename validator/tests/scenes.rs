//! Scene files checked end to end: the scenes under the repository's
//! `tests/scenes/`, malformed scenes, the CLI's exit codes and JSON form, the
//! published JSON Schema, and the examples of `docs/scene-format.md`.

use std::path::{Path, PathBuf};
use std::process::Command;

use ommcheck::scene::{CheckOptions, Scene, SceneError};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lives in the workspace")
        .to_path_buf()
}

fn scene_path(name: &str) -> PathBuf {
    root().join("tests/scenes").join(name)
}

fn ids(name: &str) -> Vec<&'static str> {
    let scene = Scene::load(&scene_path(name)).unwrap_or_else(|e| panic!("{e}"));
    let report = scene
        .check(&CheckOptions::default())
        .unwrap_or_else(|e| panic!("{e}"));
    report.report.ids()
}

fn ommcheck(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ommcheck"))
        .current_dir(root())
        .args(args)
        .output()
        .expect("ommcheck runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn valid_scenes_have_no_findings() {
    for name in [
        "ext-quad-valid.json",
        "ext-quad-2state-level4-valid.json",
        "ext-4state-mixed-levels-valid.json",
        "khr-micromap-blas-valid.json",
    ] {
        assert_eq!(ids(name), Vec::<&str>::new(), "{name}");
    }
}

#[test]
fn failing_twins_report_their_rules() {
    assert_eq!(
        ids("ext-quad-mistakes.json"),
        [
            // The usage counts' level 2 that is level 3: one finding, with a hint.
            "OMMCHECK-build-usage-counts-match-triangles",
            "OMMCHECK-attach-index-in-range",
        ]
    );
    assert_eq!(
        ids("khr-micromap-blas-index-past-end.json"),
        ["VUID-vkCmdBuildAccelerationStructuresKHR-indexBuffer-11575"]
    );
}

#[test]
fn the_example_has_its_three_mistakes() {
    let report = Scene::example().check(&CheckOptions::default()).unwrap();
    let ids = report.report.ids();
    for id in [
        "OMMCHECK-build-triangle-data-in-range",
        "OMMCHECK-build-usage-counts-match-triangles",
        "OMMCHECK-attach-index-in-range",
    ] {
        assert!(ids.contains(&id), "{id} missing from {ids:?}");
    }
    assert!(report
        .findings
        .iter()
        .all(|f| f.location.starts_with("calls[")));
    let index_finding = report
        .findings
        .iter()
        .find(|f| f.rule.as_str() == "OMMCHECK-attach-index-in-range")
        .unwrap();
    assert!(index_finding.location.starts_with("calls[3]: pInfos[0]"));
}

#[test]
fn malformed_scenes_say_where() {
    let error = Scene::load(&scene_path("malformed/unknown-format.json")).unwrap_err();
    match &error {
        SceneError::Syntax {
            line,
            column,
            message,
            ..
        } => {
            assert_eq!((*line, *column), (11, 99));
            assert!(message.contains("VK_OPACITY_MICROMAP_FORMAT_8_STATE_EXT"));
            assert!(
                message.contains("did you mean `VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT`, `VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT`"),
                "{message}"
            );
        }
        other => panic!("{other}"),
    }
    assert!(error.to_string().contains("unknown-format.json:11:99: "));

    let error = Scene::load(&scene_path("malformed/trailing-comma.json")).unwrap_err();
    assert!(
        matches!(error, SceneError::Syntax { line: 4, .. }),
        "{error}"
    );

    let scene = Scene::load(&scene_path("malformed/unknown-buffer.json")).unwrap();
    match scene.check(&CheckOptions::default()).unwrap_err() {
        SceneError::Semantic {
            json_path, message, ..
        } => {
            assert_eq!(json_path, "calls[0].pInfos[0].scratchData.buffer");
            assert!(message.contains("unknown buffer `scrach`"), "{message}");
            assert!(message.contains("did you mean `scratch`?"), "{message}");
        }
        other => panic!("{other}"),
    }
}

#[test]
fn semantic_errors_for_names_contents_and_calls() {
    let cases = [
        (
            r#"{"calls": [{"call": "vkCmdBuildMicromapsEXT", "pInfos": [{"dstMicromap": "nope"}]}]}"#,
            "calls[0].pInfos[0].dstMicromap",
            "unknown micromap `nope`",
        ),
        (
            r#"{"buffers": [{"name": "b", "size": 4, "contents": {"hex": "0011223344"}}], "calls": []}"#,
            "buffers[0].contents",
            "end past the 4 bytes",
        ),
        (
            r#"{"buffers": [{"name": "b", "size": 4}, {"name": "b", "size": 4}], "calls": []}"#,
            "buffers[1].name",
            "already names a buffer",
        ),
        (
            // 2^62 bytes: more than the address space holds (2^40 is
            // accepted: tests/large_contents.rs).
            r#"{"buffers": [{"name": "b", "size": 4611686018427387904, "contents": {"u8": [1]}}], "calls": []}"#,
            "buffers[0].contents",
            "cannot reserve 4611686018427387904 bytes of address space",
        ),
        (
            r#"{"buffers": [{"name": "b", "size": 8, "contents": {"file": "missing.bin"}}], "calls": []}"#,
            "buffers[0].contents.file",
            "cannot read",
        ),
        (
            r#"{"buffers": [{"name": "b", "size": 8, "contents": {"u8": [1], "hex": "00"}}], "calls": []}"#,
            "buffers[0].contents",
            "exactly one of",
        ),
    ];
    for (text, path, needle) in cases {
        let scene =
            Scene::parse(text, "case.json", Path::new(".")).unwrap_or_else(|e| panic!("{e}"));
        match scene.check(&CheckOptions::default()) {
            Err(SceneError::Semantic {
                json_path, message, ..
            }) => {
                assert_eq!(json_path, path, "{text}");
                assert!(message.contains(needle), "{message}");
            }
            other => panic!("{text}: {other:?}"),
        }
    }
}

#[test]
fn syntax_errors_for_shapes() {
    let cases = [
        (
            r#"{"calls": [{"call": "vkBogus"}]}"#,
            "unknown call `vkBogus` (docs/scene-format.md lists the calls ommcheck reads)",
        ),
        (
            r#"{"calls": [{"call": "vkCmdBuildMicromapEXT"}]}"#,
            "unknown call `vkCmdBuildMicromapEXT`; did you mean `vkCmdBuildMicromapsEXT`, `vkBuildMicromapsEXT` or `vkCmdCopyMicromapEXT`? (docs",
        ),
        (
            r#"{"calls": [{"call": "vkCmdBuildMicromapsEXT", "pInfo": []}]}"#,
            "unknown field `pInfo`",
        ),
        (r#"{"calls": [{"pInfos": []}]}"#, "missing field `call`"),
        (
            r#"{"calls": [{"pInfos": [], "call": "vkCmdBuildMicromapsEXT", "x": 1}]}"#,
            "unknown field `x`",
        ),
        (
            r#"{"buffers": [{"name": "b", "size": 1, "usage": -1}], "calls": []}"#,
            "does not fit VkBufferUsageFlags2",
        ),
        (
            r#"{"calls": [{"call": "vkCreateMicromapEXT", "pMicromap": "m"}]}"#,
            "missing field `pCreateInfo`",
        ),
        (r#"{"calls": [], "bogus": 1}"#, "unknown field `bogus`"),
    ];
    for (text, needle) in cases {
        match Scene::parse(text, "case.json", Path::new(".")) {
            Err(SceneError::Syntax { message, .. }) => {
                assert!(message.contains(needle), "{text}: {message}")
            }
            other => panic!("{text}: {other:?}"),
        }
    }
}

#[test]
fn cli_exit_codes() {
    let valid = "tests/scenes/ext-quad-valid.json";
    let mistakes = "tests/scenes/ext-quad-mistakes.json";
    assert_eq!(ommcheck(&["check", valid]).0, 0);
    assert_eq!(ommcheck(&["check", valid, "--deny", "warnings"]).0, 0);
    let (code, stdout, _) = ommcheck(&["check", valid, mistakes]);
    assert_eq!(code, 1);
    assert!(stdout.contains("Validation Error: [ OMMCHECK-attach-index-in-range ]"));
    for malformed in [
        "tests/scenes/malformed/unknown-format.json",
        "tests/scenes/malformed/unknown-buffer.json",
        "tests/scenes/no-such-scene.json",
    ] {
        // A scene that cannot be read stops the run: nothing is checked.
        let (code, stdout, stderr) = ommcheck(&["check", valid, malformed]);
        assert_eq!(code, 2, "{malformed}");
        assert!(stdout.is_empty(), "{stdout}");
        assert!(
            stderr.contains(malformed.trim_start_matches("tests/scenes/")),
            "{stderr}"
        );
    }
    assert_eq!(ommcheck(&["check"]).0, 2);
    assert_eq!(
        ommcheck(&["check", valid, "--profile", "no-such-profile"]).0,
        2
    );
}

#[test]
fn cli_profile_override() {
    // Level 3 is within spec-minimum; a profile that allows only level 2
    // makes the valid quad fail.
    let dir = std::env::temp_dir().join(format!("ommcheck-profile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let profile = dir.join("level2.json");
    std::fs::write(&profile, r#"{"maxOpacity2StateSubdivisionLevel": 2}"#).unwrap();
    let valid = "tests/scenes/ext-quad-valid.json";
    let (code, stdout, _) = ommcheck(&["check", valid, "--profile", profile.to_str().unwrap()]);
    assert_eq!(code, 1, "{stdout}");
    assert!(stdout.contains("maxOpacity2StateSubdivisionLevel"));
    assert_eq!(ommcheck(&["check", valid, "--profile", "permissive"]).0, 0);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn cli_json_form() {
    let (code, stdout, _) = ommcheck(&[
        "check",
        "tests/scenes/ext-quad-valid.json",
        "tests/scenes/ext-quad-mistakes.json",
        "--format",
        "json",
    ]);
    assert_eq!(code, 1);
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("JSON output");
    assert_eq!(json["summary"]["scenes"], 2);
    assert_eq!(json["summary"]["errors"], 2);
    assert_eq!(json["summary"]["calls"], 8);
    // Both scenes give everything their calls read.
    assert_eq!(json["summary"]["rulesNotChecked"], 0);
    assert!(json["summary"]["rulesChecked"].as_u64().unwrap() > 0);
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes[0]["path"], "tests/scenes/ext-quad-valid.json");
    assert_eq!(scenes[0]["findings"], serde_json::json!([]));
    assert_eq!(scenes[1]["findings"][0]["hint"], "Did you mean level 3?");
    assert_eq!(scenes[1]["findings"][0]["folded"], 1);
    let finding = &scenes[1]["findings"][1];
    assert_eq!(finding["id"], "OMMCHECK-attach-index-in-range");
    assert_eq!(finding["severity"], "error");
    assert_eq!(finding["function"], "vkCmdBuildAccelerationStructuresKHR");
    assert!(finding["location"]
        .as_str()
        .unwrap()
        .starts_with("calls[3]: "));
    let objects = scenes[1]["objects"].as_array().unwrap();
    assert!(objects
        .iter()
        .any(|o| o["name"] == "foliage-omm" && o["type"] == "VkMicromapEXT"));
    // The finding's place in parts, and the micromap it involves by name.
    assert_eq!(finding["at"]["call"], 3);
    assert_eq!(
        finding["at"]["scene"],
        "tests/scenes/ext-quad-mistakes.json"
    );
    assert!(finding["at"]["line"].as_u64().is_some_and(|line| line > 1));
    assert!(finding["objects"]
        .as_array()
        .unwrap()
        .iter()
        .any(|o| o["name"] == "foliage-omm" && o["type"] == "VkMicromapEXT"));
}

/// `docs/scene.schema.json` is what the serde types generate. Set
/// `OMMCHECK_UPDATE_SCHEMA=1` to rewrite it.
#[test]
fn published_schema_is_current() {
    let path = root().join("docs/scene.schema.json");
    let generated = ommcheck::scene::schema();
    if std::env::var_os("OMMCHECK_UPDATE_SCHEMA").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let published = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        published == generated,
        "docs/scene.schema.json is stale: run `OMMCHECK_UPDATE_SCHEMA=1 cargo test -p ommcheck --test scenes published_schema_is_current` (or `ommcheck schema > docs/scene.schema.json`)"
    );
}

/// Every example of `docs/scene-format.md` parses and resolves: a
/// ```json block holding a whole scene is checked as it is; one holding a
/// call (`{"call": ...}`) is checked after the document's common scene
/// (the block tagged `json scene-prelude`).
#[test]
fn documented_examples_check() {
    let doc = std::fs::read_to_string(root().join("docs/scene-format.md")).unwrap();
    let mut prelude: Option<serde_json::Value> = None;
    let mut blocks: Vec<(String, String)> = Vec::new();
    let mut lines = doc.lines();
    while let Some(line) = lines.next() {
        let Some(info) = line.strip_prefix("```json") else {
            continue;
        };
        let body: Vec<&str> = lines
            .by_ref()
            .take_while(|l| !l.starts_with("```"))
            .collect();
        blocks.push((info.trim().to_string(), body.join("\n")));
    }
    for (info, body) in &blocks {
        if info == "scene-prelude" {
            prelude = Some(serde_json::from_str(body).unwrap_or_else(|e| panic!("prelude: {e}")));
        }
    }
    let prelude = prelude.expect("docs/scene-format.md has a `json scene-prelude` block");
    let mut calls_seen = std::collections::BTreeSet::new();
    for (info, body) in &blocks {
        if info == "no-check" {
            continue;
        }
        let value: serde_json::Value =
            serde_json::from_str(body).unwrap_or_else(|e| panic!("{e}\n{body}"));
        let scene_text = match value.get("call") {
            Some(call) => {
                calls_seen.insert(call.as_str().unwrap_or_default().to_string());
                let mut scene = prelude.clone();
                scene["calls"].as_array_mut().unwrap().push(value.clone());
                scene.to_string()
            }
            None => {
                for call in value["calls"].as_array().into_iter().flatten() {
                    calls_seen.insert(call["call"].as_str().unwrap_or_default().to_string());
                }
                body.clone()
            }
        };
        let scene = Scene::parse(&scene_text, "doc", &root().join("docs"))
            .unwrap_or_else(|e| panic!("{e}\n{body}"));
        scene
            .check(&CheckOptions::default())
            .unwrap_or_else(|e| panic!("{e}\n{body}"));
    }
    let execution_calls = ommcheck::scene::format::EXECUTION_CALL_NAMES;
    for call in ommcheck::scene::format::CALL_NAMES
        .into_iter()
        .chain(execution_calls)
    {
        assert!(
            calls_seen.contains(call),
            "docs/scene-format.md has no example of {call}"
        );
    }
    // The commands that run shaders share one form; one example of each
    // kind (draw, dispatch, trace) stands for them.
    for call in ["vkCmdDraw", "vkCmdDispatch", "vkCmdTraceRaysKHR"] {
        assert!(
            calls_seen.contains(call),
            "docs/scene-format.md has no example of {call}"
        );
    }
}

#[test]
fn cli_text_summary_counts_rules_checked_and_not() {
    let (code, stdout, _) = ommcheck(&["check", "tests/scenes/ext-quad-valid.json"]);
    assert_eq!(code, 0, "{stdout}");
    let last = stdout.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("1 scene, ") && last.ends_with(" rules checked, 0 not checked"),
        "{last}"
    );
}

/// `ommcheck stats` (its census is tested in `tests/stats.rs`).
#[test]
fn the_command_prints_text_and_json_and_refuses_unreadable_scenes() {
    let scene = "tests/scenes/ext-4state-mixed-levels-valid.json";
    let (code, text, _) = ommcheck(&["stats", scene]);
    assert_eq!(code, 0);
    assert!(
        text.starts_with(&format!(
            "== {scene} (4 calls, 1 micromap)\nmicromap 'foliage-omm'"
        )),
        "{text}"
    );
    assert!(
        text.ends_with("1 scene, 1 micromap: 4 of 4 triangles counted, 1 uniform\n"),
        "{text}"
    );
    let (code, json, stderr) = ommcheck(&["stats", scene, "--format", "json"]);
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(json["scenes"][0]["micromaps"][0]["name"], "foliage-omm");
    assert_eq!(json["scenes"][0]["micromaps"][0]["stored"]["opaque"], 27);
    assert_eq!(json["summary"]["counted"], 4);
    let (code, _, stderr) = ommcheck(&["stats", "tests/scenes/no-such-scene.json"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("no-such-scene.json"), "{stderr}");
}
