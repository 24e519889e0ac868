//! `ommcheck trace`, run as a user would: the rays of
//! `tests/scenes/trace-4state-quad.json` and their exact outcomes, rays that
//! cannot be simulated, scenes whose calls have errors, and malformed rays.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::{json, Value};

const QUAD: &str = "tests/scenes/trace-4state-quad.json";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lives in the workspace")
        .to_path_buf()
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

/// `ommcheck trace PATH --format json`: the status, the output (`scenes`
/// and `summary`, as `check` lays them out) and stderr.
fn trace_json(path: &str) -> (i32, Value, String) {
    let (code, stdout, stderr) = ommcheck(&["trace", path, "--format", "json"]);
    let value: Value = serde_json::from_str(&stdout)
        .unwrap_or_else(|e| panic!("{e}: not JSON:\n{stdout}\n{stderr}"));
    assert_eq!(value["scenes"].as_array().map(Vec::len), Some(1), "{value}");
    (code, value, stderr)
}

/// A scene file in the temporary directory, removed when dropped.
struct TempScene(PathBuf);

impl TempScene {
    fn path(&self) -> &str {
        self.0.to_str().expect("a UTF-8 temporary path")
    }
}

impl Drop for TempScene {
    fn drop(&mut self) {
        std::fs::remove_file(&self.0).ok();
    }
}

/// The quad scene with its `rays` replaced (and `edit` applied), written to
/// a file of its own.
fn variant(name: &str, rays: Value, edit: impl FnOnce(&mut Value)) -> TempScene {
    let text = std::fs::read_to_string(root().join(QUAD)).unwrap();
    let mut scene: Value = serde_json::from_str(&text).unwrap();
    scene["rays"] = rays;
    scene.as_object_mut().unwrap().remove("$schema");
    edit(&mut scene);
    write(name, &scene.to_string())
}

fn write(name: &str, text: &str) -> TempScene {
    let path = std::env::temp_dir().join(format!("ommcheck-trace-{}-{name}", std::process::id()));
    std::fs::write(&path, text).unwrap();
    TempScene(path)
}

fn strings(value: &Value) -> Vec<&str> {
    value
        .as_array()
        .unwrap_or_else(|| panic!("not an array: {value}"))
        .iter()
        .map(|v| v.as_str().unwrap_or_default())
        .collect()
}

fn micro(ray: &Value) -> Vec<(u64, &str)> {
    ray["microTriangles"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["index"].as_u64().unwrap(),
                m["state"].as_str().unwrap_or("?"),
            )
        })
        .collect()
}

/// A ray's name, outcomes, decidedBy, micro-triangles with their states,
/// and whether it is ambiguous.
type Expected = (
    &'static str,
    &'static [&'static str],
    &'static str,
    &'static [(u64, &'static str)],
    bool,
);

/// A summary without the rule counts, whose values follow the checks.
fn without_rule_counts(summary: &Value) -> Value {
    let mut summary = summary.clone();
    if let Some(object) = summary.as_object_mut() {
        object.remove("rulesChecked");
        object.remove("rulesNotChecked");
    }
    summary
}

#[test]
fn quad_rays_have_their_exact_outcomes() {
    let (code, out, stderr) = trace_json(QUAD);
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(out["scenes"][0]["path"], QUAD);
    assert_eq!(out["scenes"][0]["calls"], 4);
    assert_eq!(out["scenes"][0]["findings"], json!([]));
    assert!(out["summary"]["rulesChecked"].as_u64() > Some(0));
    assert_eq!(out["summary"]["rulesNotChecked"], 0);
    assert_eq!(
        without_rule_counts(&out["summary"]),
        json!({"scenes": 1, "calls": 4, "findings": 0, "errors": 0, "warnings": 0, "info": 0,
               "rays": 11, "simulated": 11, "notSimulated": 0})
    );
    let rays = out["scenes"][0]["rays"].as_array().unwrap();
    let expected: [Expected; 11] = [
        (
            "transparent",
            &["Ignored"],
            "micromap-state",
            &[(0, "Transparent")],
            false,
        ),
        (
            "opaque",
            &["Opaque"],
            "micromap-state",
            &[(1, "Opaque")],
            false,
        ),
        (
            "unknown",
            &["NonOpaque"],
            "micromap-state",
            &[(2, "UnknownTransparent")],
            false,
        ),
        (
            "unknown, instance 2-state",
            &["Ignored"],
            "micromap-state",
            &[(2, "UnknownTransparent")],
            false,
        ),
        (
            "unknown-opaque, ray 2-state",
            &["Opaque"],
            "micromap-state",
            &[(3, "UnknownOpaque")],
            false,
        ),
        (
            "micro-edge",
            &["Opaque", "NonOpaque"],
            "micromap-state",
            &[(1, "Opaque"), (2, "UnknownTransparent")],
            true,
        ),
        (
            "ray through the vertex buffer",
            &["Opaque"],
            "micromap-state",
            &[(1, "Opaque")],
            false,
        ),
        ("special index", &["NonOpaque"], "special-index", &[], false),
        (
            "special index, cull non-opaque",
            &["Ignored"],
            "special-index",
            &[],
            false,
        ),
        (
            "micromaps off",
            &["Opaque"],
            "micromaps-not-enabled",
            &[],
            false,
        ),
        ("miss", &[], "miss", &[], false),
    ];
    assert_eq!(rays.len(), expected.len());
    for (i, (ray, (name, outcomes, decided_by, micro_states, ambiguous))) in
        rays.iter().zip(expected).enumerate()
    {
        assert_eq!(ray["ray"], i);
        assert_eq!(ray["name"], name, "{ray}");
        assert_eq!(ray["simulated"], true, "{ray}");
        assert_eq!(ray["error"], Value::Null, "{ray}");
        assert_eq!(strings(&ray["outcomes"]), outcomes, "{name}");
        assert_eq!(ray["decidedBy"], decided_by, "{name}");
        assert_eq!(micro(ray), micro_states, "{name}");
        assert_eq!(ray["ambiguous"], ambiguous, "{name}");
        assert_eq!(ray["accelerationStructure"], "leaf-blas");
    }
    // The micromap slot, with the triangle's format and level.
    let slot = &rays[0]["slot"];
    assert_eq!(slot["kind"], "micromap");
    assert_eq!(slot["micromapTriangle"], 0);
    assert_eq!(slot["format"], "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT");
    assert_eq!(slot["subdivisionLevel"], 1);
    assert_eq!(rays[0]["rule"], "micromap state");
    assert_eq!(rays[0]["work"]["blocksDecoded"], 1);
    // The special index of triangle 1.
    let slot = &rays[7]["slot"];
    assert_eq!(slot["kind"], "special");
    assert_eq!(slot["specialIndex"], -4);
    assert_eq!(
        slot["specialName"],
        "VK_OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_UNKNOWN_OPAQUE_EXT"
    );
    assert_eq!(strings(&rays[7]["states"]), ["UnknownOpaque"]);
    // The ray read its vertices from the vertex buffer and hit at t = 1.
    let ray = &rays[6];
    assert!((ray["distance"].as_f64().unwrap() - 1.0).abs() < 1e-12);
    assert!((ray["u"].as_f64().unwrap() - 0.3).abs() < 1e-12);
    assert!(ray["work"]["bytesRead"].as_u64().unwrap() >= 36);
    // Micromaps off: nothing was read, the geometry's opaque bit decided.
    assert_eq!(rays[9]["slot"], Value::Null);
    assert_eq!(rays[9]["work"]["indicesRead"], 0);
    // A miss has no barycentrics.
    assert_eq!(rays[10]["u"], Value::Null);
    assert_eq!(rays[10]["rule"], "ray misses the triangle");
}

#[test]
fn quad_rays_as_text() {
    let (code, stdout, stderr) = ommcheck(&["trace", QUAD]);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.starts_with(&format!("== {QUAD} (4 calls, 11 rays)\nno findings\n")));
    assert!(
        stdout.contains("  work:            1 block decoded, "),
        "{stdout}"
    );
    let edge = stdout
        .split("\n\n")
        .find(|block| block.starts_with("rays[5] \"micro-edge\""))
        .unwrap_or_else(|| panic!("{stdout}"));
    for line in [
        "  hit:             (u, v) = (0.5, 0.25) ± ",
        "  outcomes:        Opaque, NonOpaque",
        "  decided by:      micromap state",
        "  slot:            micromap triangle 0 (VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT, level 1)",
        "  micro-triangles: 1 Opaque, 2 UnknownTransparent",
        "  ambiguous:       yes",
    ] {
        assert!(edge.contains(line), "{line:?} missing from\n{edge}");
    }
    assert!(stdout.contains("  slot:            special index -4 (VK_OPACITY_MICROMAP_SPECIAL_INDEX_FULLY_UNKNOWN_OPAQUE_EXT)"));
    assert!(stdout.contains("  hit:             ray hit at t = 1, (u, v) = (0.3, 0.3)"));
    let last = stdout.lines().last().unwrap_or_default();
    assert!(
        last.starts_with(
            "11 rays: 11 simulated, 0 not simulated; 1 scene, 4 calls: 0 errors, 0 warnings, 0 info; "
        ) && last.ends_with(" rules checked, 0 not checked"),
        "{last}"
    );
}

#[test]
fn flags_by_number_and_flags_not_modelled() {
    let path = variant(
        "flags.json",
        json!([
            // CullOpaqueKHR as a number drops the opaque hit.
            { "accelerationStructure": "leaf-blas", "triangle": 0,
              "hit": { "u": 0.3, "v": 0.3 }, "rayFlags": 64 },
            // FORCE_OPAQUE on the instance makes the unknown state opaque;
            // facing culling is listed as not modelled.
            { "accelerationStructure": "leaf-blas", "triangle": 0,
              "hit": { "u": 0.6, "v": 0.2 },
              "instanceFlags": "VK_GEOMETRY_INSTANCE_FORCE_OPAQUE_BIT_KHR",
              "rayFlags": "CullBackFacingTrianglesKHR | TerminateOnFirstHitKHR" },
            // DISABLE_OPACITY_MICROMAPS: the geometry is not opaque.
            { "accelerationStructure": "leaf-blas", "triangle": 0,
              "hit": { "u": 0.1, "v": 0.1 },
              "instanceFlags": ["VK_GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT_EXT"] },
            // A bit SPIR-V does not define: accepted, listed, ignored.
            { "accelerationStructure": "leaf-blas", "triangle": 0,
              "hit": { "u": 0.3, "v": 0.3 }, "rayFlags": "0x800" }
        ]),
        |_| {},
    );
    let (code, out, stderr) = trace_json(path.path());
    assert_eq!(code, 0, "{stderr}");
    let rays = out["scenes"][0]["rays"].as_array().unwrap();
    assert_eq!(strings(&rays[0]["outcomes"]), ["Ignored"]);
    assert_eq!(strings(&rays[0]["notModelled"]), Vec::<&str>::new());
    assert_eq!(strings(&rays[1]["outcomes"]), ["Opaque"]);
    assert_eq!(
        strings(&rays[1]["notModelled"]),
        ["CullBackFacingTrianglesKHR"]
    );
    assert_eq!(strings(&rays[2]["outcomes"]), ["NonOpaque"]);
    assert_eq!(rays[2]["decidedBy"], "disabled-by-instance-flag");
    assert_eq!(strings(&rays[3]["outcomes"]), ["Opaque"]);
    assert_eq!(strings(&rays[3]["notModelled"]), ["rayFlags 0x800"]);
}

#[test]
fn rays_that_cannot_be_simulated_exit_1_and_say_why() {
    let path = variant(
        "unsimulated.json",
        json!([
            { "accelerationStructure": "leaf-blas", "triangle": 0, "hit": { "u": 0.1, "v": 0.1 } },
            { "accelerationStructure": "leaf-blas", "triangle": 2, "hit": { "u": 0.1, "v": 0.1 } },
            { "accelerationStructure": "leaf-blas", "geometry": 1, "triangle": 0, "hit": { "u": 0.1, "v": 0.1 } },
            { "accelerationStructure": "unbuilt", "triangle": 0, "hit": { "u": 0.1, "v": 0.1 } },
            { "accelerationStructure": "leaf-blas", "triangle": 0, "hit": { "u": 1e300, "v": 0.1 } }
        ]),
        |scene| {
            scene["accelerationStructures"] = json!([
                { "name": "unbuilt", "type": "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR",
                  "buffer": "blas-storage", "offset": 0, "size": 4096 }
            ]);
        },
    );
    let (code, out, stderr) = trace_json(path.path());
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(out["summary"]["simulated"], 1);
    assert_eq!(out["summary"]["notSimulated"], 4);
    let rays = out["scenes"][0]["rays"].as_array().unwrap();
    assert_eq!(rays[0]["simulated"], true);
    let errors: Vec<&str> = rays[1..]
        .iter()
        .map(|r| {
            assert_eq!(r["simulated"], false);
            assert_eq!(r["outcomes"], json!([]));
            r["error"].as_str().unwrap()
        })
        .collect();
    assert!(
        errors[0].contains("triangle 2 is not below the build range's primitiveCount 2"),
        "{}",
        errors[0]
    );
    assert!(
        errors[1].contains("geometry 1 is past the build's 1 geometries"),
        "{}",
        errors[1]
    );
    assert!(
        errors[2].contains("`unbuilt` has no build the checker saw"),
        "{}",
        errors[2]
    );
    assert!(errors[3].contains("not finite"), "{}", errors[3]);
    assert!(
        stderr.contains(": rays[1] not simulated: triangle 2"),
        "{stderr}"
    );
    let (code, stdout, _) = ommcheck(&["trace", path.path()]);
    assert_eq!(code, 1);
    assert!(stdout.contains("  not simulated:   triangle 2 is not below"));
    assert!(stdout.contains("5 rays: 1 simulated, 4 not simulated"));
}

#[test]
fn calls_with_errors_exit_1_and_are_reported_first() {
    // Usage counts that ask for more triangles than the triangle array
    // holds: an error in the calls; the rays are still simulated.
    let path = variant(
        "call-errors.json",
        json!([{ "accelerationStructure": "leaf-blas", "triangle": 0, "hit": { "u": 0.3, "v": 0.3 } }]),
        |scene| {
            scene["calls"][1]["pInfos"][0]["pUsageCounts"][0]["count"] = json!(2);
        },
    );
    let (code, out, _) = trace_json(path.path());
    assert_eq!(code, 1);
    assert!(out["summary"]["errors"].as_u64().unwrap() >= 1);
    assert!(strings(
        &out["scenes"][0]["findings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f["id"].clone())
            .collect::<Value>()
    )
    .contains(&"OMMCHECK-build-triangle-array-in-range"));
    assert_eq!(out["scenes"][0]["rays"][0]["simulated"], true);
    let (code, stdout, _) = ommcheck(&["trace", path.path()]);
    assert_eq!(code, 1);
    let findings_at = stdout
        .find("[ OMMCHECK-build-triangle-array-in-range ]")
        .unwrap();
    assert!(findings_at < stdout.find("rays[0]").unwrap());
}

#[test]
fn malformed_rays_exit_2_with_a_json_path() {
    let file = "tests/scenes/malformed/unknown-ray-structure.json";
    for command in ["trace", "check"] {
        let (code, stdout, stderr) = ommcheck(&[command, file]);
        assert_eq!(code, 2, "{command}");
        assert!(stdout.is_empty(), "{stdout}");
        assert!(
            stderr.contains(&format!(
                "{file}: rays[1].accelerationStructure: unknown acceleration structure `leaf-blass`"
            )),
            "{stderr}"
        );
        assert!(stderr.contains("`leaf-blas`"), "{stderr}");
    }
    let cases = [
        (
            json!([{ "accelerationStructure": "omm-data", "triangle": 0, "hit": { "u": 0.1, "v": 0.1 } }]),
            "rays[0].accelerationStructure: `omm-data` names a buffer",
        ),
        (
            json!([{ "accelerationStructure": "leaf-blas", "triangle": 0 }]),
            "rays[0]: a ray needs `hit`",
        ),
        (
            json!([{ "accelerationStructure": "leaf-blas", "triangle": 0,
                     "hit": { "u": 0.1, "v": 0.1 }, "ray": { "origin": [0, 0, 1], "direction": [0, 0, -1] } }]),
            "rays[0]: a ray gives `hit`",
        ),
        (
            json!([{ "accelerationStructure": "leaf-blas", "triangle": 0,
                     "hit": { "u": 0.1, "v": 0.1, "delta": -1 } }]),
            "rays[0].hit.delta: the error bound must be a non-negative number",
        ),
    ];
    for (i, (rays, needle)) in cases.into_iter().enumerate() {
        let path = variant(&format!("malformed-{i}.json"), rays, |_| {});
        let (code, _, stderr) = ommcheck(&["trace", path.path()]);
        assert_eq!(code, 2, "{needle}");
        assert!(stderr.contains(needle), "{needle}: {stderr}");
    }
    // Unknown flag names and members are shape errors, at a line and column.
    for (i, (ray, needle)) in [
        (
            r#"{"accelerationStructure": "b", "triangle": 0, "hit": {"u": 0, "v": 0}, "rayFlags": "OpaqueEXT"}"#,
            "unknown RayFlags name `OpaqueEXT`; did you mean `OpaqueKHR`",
        ),
        (
            r#"{"accelerationStructure": "b", "triangle": 0, "hit": {"u": 0, "v": 0}, "instanceFlags": "FORCE_OPAQUE"}"#,
            "unknown VkGeometryInstanceFlagsKHR name `FORCE_OPAQUE`",
        ),
        (
            r#"{"accelerationStructure": "b", "triangle": 0, "hit": {"u": 0, "v": 0, "w": 1}}"#,
            "unknown field `w`",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let path = write(
            &format!("shape-{i}.json"),
            &format!("{{\"calls\": [],\n\"rays\": [\n{ray}]}}"),
        );
        let (code, _, stderr) = ommcheck(&["trace", path.path()]);
        assert_eq!(code, 2, "{needle}");
        assert!(stderr.contains(&format!("-shape-{i}.json:3:")), "{stderr}");
        assert!(stderr.contains(needle), "{needle}: {stderr}");
    }
    assert_eq!(ommcheck(&["trace", "tests/scenes/no-such-scene.json"]).0, 2);
}

/// The example of `docs/scene-format.md` ("Tracing rays") has the outcomes
/// the document states.
#[test]
fn documented_example_traces_as_documented() {
    let doc = std::fs::read_to_string(root().join("docs/scene-format.md")).unwrap();
    let body: String = doc
        .split("```json trace-example\n")
        .nth(1)
        .and_then(|rest| rest.split("\n```").next())
        .expect("docs/scene-format.md has a `json trace-example` block")
        .to_string();
    let path = write("doc-example.json", &body);
    let (code, out, stderr) = trace_json(path.path());
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(out["scenes"][0]["findings"], json!([]));
    let rays = out["scenes"][0]["rays"].as_array().unwrap();
    assert_eq!(strings(&rays[0]["outcomes"]), ["NonOpaque"]);
    assert_eq!(strings(&rays[1]["outcomes"]), ["Ignored"]);
    assert_eq!(strings(&rays[2]["outcomes"]), ["Ignored", "Opaque"]);
    assert_eq!(micro(&rays[2]), [(1, "Opaque"), (2, "UnknownTransparent")]);
    assert_eq!(rays[2]["ambiguous"], true);
    assert_eq!(rays[2]["distance"], 1.0);
    assert!(doc.contains(
        r#""microTriangles": [{ "index": 1, "state": "Opaque" }, { "index": 2, "state": "UnknownTransparent" }]"#
    ));
}

#[test]
fn several_scenes_share_checks_layout() {
    let failing = variant(
        "several-failing.json",
        json!([{ "accelerationStructure": "leaf-blas", "triangle": 2, "hit": { "u": 0.1, "v": 0.1 } }]),
        |_| {},
    );
    let (code, stdout, stderr) = ommcheck(&["trace", QUAD, failing.path(), "--format", "json"]);
    assert_eq!(
        code, 1,
        "one ray of the second scene is not simulated: {stderr}"
    );
    let out: Value = serde_json::from_str(&stdout).unwrap();
    let scenes = out["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 2);
    assert_eq!(scenes[0]["path"], QUAD);
    assert_eq!(scenes[1]["path"], failing.path());
    assert_eq!(scenes[1]["rays"].as_array().unwrap().len(), 1);
    assert_eq!(
        without_rule_counts(&out["summary"]),
        json!({"scenes": 2, "calls": 8, "findings": 0, "errors": 0, "warnings": 0, "info": 0,
               "rays": 12, "simulated": 11, "notSimulated": 1})
    );
    // `check` has the same members: each scene's path, calls, objects and
    // findings, and the summary's scene, call and finding counts.
    let (_, checked, _) = ommcheck(&["check", QUAD, failing.path(), "--format", "json"]);
    let checked: Value = serde_json::from_str(&checked).unwrap();
    for member in ["path", "calls", "objects", "findings"] {
        assert_eq!(scenes[1][member], checked["scenes"][1][member], "{member}");
    }
    for (member, count) in checked["summary"].as_object().unwrap() {
        assert_eq!(&out["summary"][member], count, "{member}");
    }
    assert!(
        stderr.contains(&format!("{}: rays[0] not simulated", failing.path())),
        "{stderr}"
    );

    let (_, text, _) = ommcheck(&["trace", QUAD, failing.path()]);
    assert!(
        text.contains(&format!("== {} (4 calls, 1 ray)", failing.path())),
        "{text}"
    );
    let last = text.lines().last().unwrap_or_default();
    assert!(
        last.starts_with(
            "12 rays: 11 simulated, 1 not simulated; 2 scenes, 8 calls: 0 errors, 0 warnings, 0 info; "
        ) && last.ends_with(" rules checked, 0 not checked"),
        "{last}"
    );
}
