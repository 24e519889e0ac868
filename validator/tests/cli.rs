//! The `ommcheck` command line, run as a user would.

use std::process::Command;

fn ommcheck(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ommcheck"))
        .args(args)
        .output()
        .expect("ommcheck runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn json(args: &[&str]) -> serde_json::Value {
    let (code, stdout, stderr) = ommcheck(args);
    assert_eq!(code, 0, "{stderr}");
    serde_json::from_str(&stdout).expect("JSON output")
}

#[test]
fn index_from_barycentrics() {
    let v = json(&[
        "index", "--level", "2", "--uv", "0.3", "0.2", "--format", "json",
    ]);
    assert_eq!(v["index"], 7);
    assert_eq!(v["upright"], false);
    assert_eq!((v["i"].as_u64(), v["j"].as_u64()), (Some(1), Some(0)));
    // 0.3f + 0.2f lands within f32 ulps of the diagonal: 2 is possible too.
    assert_eq!(v["ambiguous"], serde_json::json!([2, 7]));
    let inside = json(&[
        "index", "--level", "2", "--uv", "0.1", "0.1", "--format", "json",
    ]);
    assert_eq!(inside["ambiguous"], serde_json::json!([]));
    // Exactly on the edge between micro-triangles 4 and 5: with no error
    // bound both touch the hit, and both are listed.
    let edge = json(&[
        "index", "--level", "2", "--uv", "0.25", "0.375", "--delta", "0", "--format", "json",
    ]);
    assert_eq!(edge["index"], 5);
    assert_eq!(edge["ambiguous"], serde_json::json!([4, 5]));
}

#[test]
fn index_to_vertices() {
    let v = json(&[
        "index", "--level", "12", "--index", "6990506", "--format", "json",
    ]);
    assert_eq!(v["upright"], false);
    assert_eq!(v["vertices"][0], serde_json::json!([0.5, 0.5]));
    assert!(v.get("ambiguous").is_none());
}

#[test]
fn index_rejects_bad_input_with_status_2() {
    assert_eq!(ommcheck(&["index", "--level", "13", "--index", "0"]).0, 2);
    assert_eq!(ommcheck(&["index", "--level", "1", "--index", "4"]).0, 2);
    assert_eq!(
        ommcheck(&["index", "--level", "1", "--uv", "NaN", "0"]).0,
        2
    );
}

#[test]
fn vuid_lookup() {
    let (code, stdout, _) = ommcheck(&["vuid", "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516"]);
    assert_eq!(code, 0);
    assert!(stdout.contains("Only one of pUsageCounts or ppUsageCounts"));
    assert!(stdout.contains("ommcheck:   enforced"), "{stdout}");
    assert!(stdout.contains("tier:       decided from the"), "{stdout}");
    assert!(
        stdout.contains("Khronos validation layer: checks it"),
        "{stdout}"
    );
    assert_eq!(ommcheck(&["vuid", "VUID-nope"]).0, 1);
}

#[test]
fn vuid_accepts_any_case_bare_numbers_and_our_ids() {
    let (code, lower, _) = ommcheck(&["vuid", "vuid-vkmicromapbuildinfoext-pusagecounts-07516"]);
    assert_eq!(code, 0);
    assert!(lower.starts_with("VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516\n"));

    // 11636 is stated once for every command that runs shaders.
    let (code, listed, _) = ommcheck(&["vuid", "11636"]);
    assert_eq!(code, 0);
    let ids: Vec<&str> = listed.lines().filter(|l| l.starts_with("VUID-")).collect();
    assert!(ids.len() > 10, "{listed}");
    assert!(ids.iter().all(|id| id.ends_with("-11636")));
    assert!(ids.contains(&"VUID-vkCmdTraceRaysKHR-micromap-11636"));

    let (code, own, _) = ommcheck(&["vuid", "ommcheck-build-usage-counts-match-triangles"]);
    assert_eq!(code, 0);
    assert!(own.starts_with("OMMCHECK-build-usage-counts-match-triangles\n"));
    assert!(own.contains("decided from the content tier up"), "{own}");
}

#[test]
fn unknown_vuids_get_a_did_you_mean() {
    let (code, stdout, stderr) =
        ommcheck(&["vuid", "VUID-VkMicromapBuildInfoEXT-pUsageCount-07516"]);
    assert_eq!(code, 1);
    assert!(stdout.is_empty());
    assert!(
        stderr.contains("did you mean `VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516`"),
        "{stderr}"
    );
}

#[test]
fn example_runs() {
    // The built-in example has errors on purpose: status 1, with its report.
    let (code, stdout, stderr) = ommcheck(&["check", "--example"]);
    assert_eq!(code, 1, "{stderr}");
    assert!(stdout.contains("Validation Error: [ OMMCHECK-build-triangle-data-in-range ]"));
    assert!(stdout.contains("[ OMMCHECK-build-usage-counts-match-triangles ]"));
    assert!(stdout.contains("[ OMMCHECK-attach-index-in-range ]"));
    assert!(stdout.contains("vkCmdBuildMicromapsEXT(): calls[1]: pInfos[0]"));
    // The stale histogram is one finding, with its fix.
    assert!(stdout.contains(
        "Did you mean VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT for 1 of these 3 triangles?"
    ));
    // Counts agree with their nouns.
    let last = stdout.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("1 scene, 4 calls: 3 errors, 0 warnings, 0 info; ")
            && last.ends_with(" rules checked, 0 not checked"),
        "{stdout}"
    );
}

#[test]
fn example_prints_the_scene_check_example_checks() {
    let (code, scene, stderr) = ommcheck(&["example"]);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(scene, ommcheck::scene::EXAMPLE);
    let path = std::env::temp_dir().join(format!("ommcheck-example-{}.json", std::process::id()));
    std::fs::write(&path, &scene).unwrap();
    let (code, from_file, _) = ommcheck(&["check", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    let (_, built_in, _) = ommcheck(&["check", "--example"]);
    assert_eq!(code, 1, "the example has errors on purpose");
    // The same findings; only the scene's name differs.
    assert_eq!(
        from_file.replace(path.to_str().unwrap(), ommcheck::scene::EXAMPLE_PATH),
        built_in
    );
}

#[test]
fn help_lists_each_command_in_one_line() {
    let (code, stdout, _) = ommcheck(&["--help"]);
    assert_eq!(code, 0);
    for line in [
        "  check    Check scene files and print a VUID report\n",
        "  trace    Check each scene's calls, then simulate each of its `rays`\n",
        "  example  Print the built-in example scene: `ommcheck example > scene.json`\n",
        "  vuid     Explain a rule: enforced or not, at which tier, and by the Khronos layer\n",
        "  draw     Draw a micromap or a BLAS geometry as SVG or PNG\n",
    ] {
        assert!(stdout.contains(line), "{line:?} missing from\n{stdout}");
    }
    let (_, vuid_help, _) = ommcheck(&["help", "vuid"]);
    assert!(
        vuid_help.contains("a bare number (07516: every VUID with it)"),
        "{vuid_help}"
    );
}

#[test]
fn a_mistyped_profile_name_gets_a_did_you_mean() {
    let (code, _, stderr) = ommcheck(&["check", "--example", "--profile", "spec-minimun"]);
    assert_eq!(code, 2);
    assert!(stderr.contains("did you mean `spec-minimum`?"), "{stderr}");
}

/// What a scene did not let the checker decide shows in `check`'s default
/// output: each not-checked information is printed, as every finding is
/// (the CLI filters no severity), and the last line counts the rules not
/// checked. The example without its buffers' contents decides none of its
/// content rules; with them it decides all.
#[test]
fn rules_not_checked_show_in_the_default_text_output() {
    let (code, example, stderr) = ommcheck(&["example"]);
    assert_eq!(code, 0, "{stderr}");
    let mut scene: serde_json::Value = serde_json::from_str(&example).expect("the example scene");
    for buffer in scene["buffers"].as_array_mut().expect("buffers") {
        buffer.as_object_mut().expect("a buffer").remove("contents");
    }
    let path =
        std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("example-without-contents.json");
    std::fs::write(&path, scene.to_string()).expect("writing the scene");
    let (code, stdout, stderr) = ommcheck(&["check", path.to_str().expect("a UTF-8 path")]);
    // No error is found: the example's faults are all in the contents.
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("Validation Information: [ OMMCHECK-not-checked-contents ]"),
        "{stdout}"
    );
    let last = stdout.trim_end().lines().last().expect("a summary line");
    assert!(
        last.contains(" rules checked, ") && !last.ends_with(" 0 not checked"),
        "{last}"
    );

    let (_, stdout, _) = ommcheck(&["check", "--example"]);
    assert!(!stdout.contains("OMMCHECK-not-checked-"), "{stdout}");
    assert!(stdout.trim_end().ends_with(" 0 not checked"), "{stdout}");
}

/// The repository's `tests/scenes/corpus/<dir>`.
fn corpus(dir: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/scenes/corpus")
        .join(dir)
}

#[test]
fn a_directory_is_checked_scene_by_scene_in_path_order() {
    let dir = corpus("ext-build");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    files.sort();
    assert!(files.len() > 4, "the corpus directory has scenes");
    let (code, stdout, stderr) = ommcheck(&["check", "--format", "json", dir.to_str().unwrap()]);
    assert!(code == 0 || code == 1, "{stderr}");
    let whole: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    // The same reports, in the same order, as naming each file.
    let mut args = vec!["check", "--format", "json"];
    args.extend(files.iter().map(|f| f.to_str().unwrap()));
    let (_, stdout, _) = ommcheck(&args);
    let one_by_one: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(whole, one_by_one);
    let paths: Vec<&str> = whole["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["path"].as_str().unwrap())
        .collect();
    let mut sorted = paths.clone();
    sorted.sort();
    assert_eq!(paths, sorted);
    assert_eq!(paths.len(), files.len());
}

#[test]
fn a_directory_without_scenes_is_an_error() {
    let empty = std::env::temp_dir().join(format!("ommcheck-empty-{}", std::process::id()));
    std::fs::create_dir_all(&empty).unwrap();
    let (code, _, stderr) = ommcheck(&["check", empty.to_str().unwrap()]);
    std::fs::remove_dir_all(&empty).unwrap();
    assert_eq!(code, 2);
    assert!(stderr.contains("no scene (.json) files"), "{stderr}");
}

/// A link from inside a directory back to it is not followed: the walk
/// ends, and the scene is checked once.
#[test]
fn a_link_back_up_the_directory_is_not_followed() {
    let dir = std::env::temp_dir().join(format!("ommcheck-loop-{}", std::process::id()));
    let inner = dir.join("inner");
    std::fs::create_dir_all(&inner).unwrap();
    let (_, example, _) = ommcheck(&["example"]);
    std::fs::write(inner.join("example.json"), example).unwrap();
    std::os::unix::fs::symlink(&dir, inner.join("up")).unwrap();
    let (code, stdout, stderr) = ommcheck(&["check", "--format", "json", dir.to_str().unwrap()]);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(code, 1, "the example has errors: {stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(report["scenes"].as_array().map(Vec::len), Some(1));
}
