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
    assert_eq!(ommcheck(&["vuid", "VUID-nope"]).0, 1);
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
}
