//! `ommcheck draw` and `ommcheck stats --states`: each picture kind against
//! its reference PNG in tests/pictures/, and the states dump against the
//! simulator's lookups.
//!
//! A picture matches its reference when both have the same size and at
//! most [`MAX_DIFFERING`] of its pixels differ from the reference's by
//! more than [`CHANNEL_TOLERANCE`] in a channel: anti-aliasing may differ
//! by a step between renderer builds, a changed picture differs in whole
//! shapes. After a deliberate change, look at the pictures the failing
//! test wrote to target/pictures-actual/ and accept them:
//! `OMMCHECK_UPDATE_PICTURES=1 cargo test -p ommcheck --test pictures`.

#[path = "support/picture_scenes.rs"]
mod picture_scenes;

use std::path::{Path, PathBuf};

use ommcheck::draw::{self, Pick};
use ommcheck::scene::Scene;
use ommcheck::sim::index::MicroTriangle;
use ommcheck::sim::opacity::Slot;

/// The largest difference in one channel (of 255) a pixel may have and
/// still match.
const CHANNEL_TOLERANCE: u8 = 24;
/// The most pixels that may not match, as a fraction of all.
const MAX_DIFFERING: f64 = 0.002;

fn references() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/pictures")
}

/// Renders `picture` and compares it with the reference `name`.png, or
/// writes the reference when `OMMCHECK_UPDATE_PICTURES` is set (as `OMMCHECK_UPDATE_SCHEMA` does for the schema; the layer leaves `OMMCHECK_UPDATE_*` variables alone).
fn assert_matches_reference(picture: &draw::Picture, name: &str) {
    let png = picture.png().expect("the picture renders");
    let reference = references().join(format!("{name}.png"));
    if std::env::var_os("OMMCHECK_UPDATE_PICTURES").is_some() {
        std::fs::create_dir_all(references()).unwrap();
        std::fs::write(&reference, &png).unwrap();
        return;
    }
    let actual_dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/pictures-actual");
    let keep_actual = || {
        std::fs::create_dir_all(&actual_dir).unwrap();
        let path = actual_dir.join(format!("{name}.png"));
        std::fs::write(&path, &png).unwrap();
        path
    };
    let accept =
        "if the change is meant, accept it: OMMCHECK_UPDATE_PICTURES=1 cargo test -p ommcheck --test pictures";
    let Ok(expected) = std::fs::read(&reference) else {
        let path = keep_actual();
        panic!(
            "no reference {} (the picture is at {}); {accept}",
            reference.display(),
            path.display()
        );
    };
    let decode = |bytes: &[u8]| resvg::tiny_skia::Pixmap::decode_png(bytes).expect("a PNG");
    let (actual, expected) = (decode(&png), decode(&expected));
    let same_size = (actual.width(), actual.height()) == (expected.width(), expected.height());
    let differing = if same_size {
        actual
            .data()
            .chunks_exact(4)
            .zip(expected.data().chunks_exact(4))
            .filter(|(a, e)| {
                a.iter()
                    .zip(*e)
                    .any(|(a, e)| a.abs_diff(*e) > CHANNEL_TOLERANCE)
            })
            .count()
    } else {
        usize::MAX
    };
    let allowed = (MAX_DIFFERING * (expected.width() * expected.height()) as f64) as usize;
    if differing > allowed {
        let path = keep_actual();
        panic!(
            "{name}: {} (reference {}x{}, picture {}x{}); the picture is at {}, the reference at {}; {accept}",
            if same_size {
                format!("{differing} pixels differ by more than {CHANNEL_TOLERANCE}, {allowed} may")
            } else {
                "the sizes differ".to_string()
            },
            expected.width(),
            expected.height(),
            actual.width(),
            actual.height(),
            path.display(),
            reference.display()
        );
    }
}

fn micromap(name: &str, triangle: Option<u64>) -> Pick {
    Pick::Micromap {
        name: name.into(),
        triangle,
    }
}

/// The scene's picture's SVG text, after checking it against its
/// reference, and its description (the captions).
fn drawn(scene: &Scene, pick: &Pick, reference: &str) -> (String, String) {
    let picture = draw::draw(scene, pick).unwrap_or_else(|e| panic!("{e}"));
    assert_matches_reference(&picture, reference);
    let desc = picture
        .svg
        .split_once("<desc>")
        .and_then(|(_, rest)| rest.split_once("</desc>"))
        .map(|(desc, _)| desc.to_string())
        .unwrap_or_default();
    (picture.svg, desc)
}

#[test]
fn one_micromap_triangle_is_numbered_in_the_spec_order() {
    let (svg, desc) = drawn(
        &Scene::example(),
        &micromap("foliage-omm", Some(2)),
        "micromap-triangle",
    );
    assert!(desc.contains("numbered in the specification"), "{desc}");
    assert!(
        !desc.contains("Downsampled"),
        "a level-3 triangle is drawn exactly"
    );
    // Its unknown states are hatched.
    assert!(svg.contains("url(#hatch-ut)"));
}

#[test]
fn a_whole_micromap_marks_the_triangle_whose_data_runs_past_the_end() {
    let (svg, desc) = drawn(
        &Scene::example(),
        &micromap("foliage-omm", None),
        "micromap-grid",
    );
    assert!(
        desc.contains(
            "Data past the end of the data the checker has (red outline, hatched red): triangle 3."
        ),
        "{desc}"
    );
    assert!(svg.contains("url(#hatch-past)"));
}

#[test]
fn a_geometry_shows_special_and_out_of_range_indices() {
    let pick = Pick::Geometry {
        name: "foliage-blas".into(),
        geometry: 0,
    };
    let (_, desc) = drawn(&Scene::example(), &pick, "geometry");
    // The example's index buffer: 0, 1, 2, 3, 4 (past the four triangles), -2.
    assert!(desc.contains("red X: 1 (triangle 4 selects 4)"), "{desc}");
    assert!(desc.contains("1 of -2"), "{desc}");
}

fn generated(name: &str, spec: &picture_scenes::Spec) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../target/picture-scenes")
        .join(name);
    Scene::load(&picture_scenes::write(&dir, name, spec)).unwrap()
}

#[test]
fn a_level_12_triangle_is_downsampled_by_the_stated_rule() {
    let scene = generated(
        "level12",
        &picture_scenes::Spec {
            level: 12,
            micromap_triangles: 1,
            geometry_triangles: 0,
            texture: 0,
        },
    );
    let (svg, desc) = drawn(&scene, &micromap("disc", Some(0)), "level-12");
    assert!(
        desc.contains("level 12 drawn at level 6: each cell holds 4096"),
        "{desc}"
    );
    // Bounded: 4096 cells, not 16M micro-triangles.
    assert!(svg.len() < 1 << 20, "{} bytes of SVG", svg.len());
}

/// The built-in example written to `name` in the CLI tests' folder: the
/// folder and the file.
fn example_file(name: &str) -> (PathBuf, PathBuf) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/pictures-cli");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join(name);
    std::fs::write(&scene, ommcheck::scene::EXAMPLE).unwrap();
    (dir, scene)
}

#[test]
fn draw_writes_svg_or_png_by_the_extension_and_names_what_is_missing() {
    let (dir, scene) = example_file("example.json");
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_ommcheck"))
            .arg("draw")
            .arg(&scene)
            .args(args)
            .output()
            .unwrap()
    };
    for extension in ["svg", "png"] {
        let out = dir.join(format!("grid.{extension}"));
        let _ = std::fs::remove_file(&out);
        let output = run(&["--micromap", "foliage-omm", "--out", out.to_str().unwrap()]);
        assert!(output.status.success(), "{output:?}");
        let bytes = std::fs::read(&out).unwrap();
        match extension {
            "svg" => assert!(bytes.starts_with(b"<svg")),
            _ => assert!(bytes.starts_with(b"\x89PNG")),
        }
    }
    let output = run(&["--micromap", "foliage-om", "--out", "x.png"]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("did you mean `foliage-omm`"), "{stderr}");
    let output = run(&["--micromap", "foliage-omm", "--out", "x.gif"]);
    assert_eq!(output.status.code(), Some(2));
}

#[test]
fn the_states_dump_agrees_with_the_simulators_lookups() {
    let (_, path) = example_file("states-example.json");
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_ommcheck"))
        .args(["stats", "--states"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(output.status.success(), "{output:?}");
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    let micromap = &json["scenes"][0]["micromaps"][0];
    assert_eq!(micromap["name"], "foliage-omm");
    let triangles = micromap["triangles"].as_array().unwrap();
    assert_eq!(triangles.len(), 4);

    // Each state against the simulator's answer for a hit at the
    // micro-triangle's centroid.
    let scene = Scene::load(&path).unwrap();
    let (report, validator) = scene.check_into_validator(&Default::default()).unwrap();
    let handle = report.handle("foliage-omm").unwrap();
    let content = validator.state().micromaps[&handle]
        .built
        .as_ref()
        .and_then(|b| b.content.clone())
        .unwrap();
    for (m, triangle) in triangles.iter().enumerate() {
        let level = triangle["subdivisionLevel"].as_u64().unwrap() as u32;
        let states = triangle["states"].as_str().unwrap();
        let past_end = triangle["pastEnd"].as_u64().unwrap();
        assert_eq!(states.len() as u64 + past_end, 1 << (2 * level));
        for (k, digit) in states.chars().enumerate() {
            let corners = MicroTriangle::from_index(k as u32, level)
                .unwrap()
                .vertices(level);
            let u = corners.iter().map(|c| c.0).sum::<f64>() / 3.0;
            let v = corners.iter().map(|c| c.1).sum::<f64>() / 3.0;
            let simulated = content.states(Slot::Micromap(m as u64), u as f32, v as f32, 0.0);
            match simulated {
                Ok(set) => {
                    let value = *set.iter().next().unwrap() as u32;
                    assert_eq!(set.len(), 1);
                    assert_eq!(digit.to_digit(10), Some(value), "triangle {m}, index {k}");
                }
                // The simulator reads a triangle only when all its data is
                // there; the dump lists what there is.
                Err(_) => assert!(past_end > 0, "triangle {m}"),
            }
        }
    }
    // Triangle 3's 16 bytes start at 248 of the 256-byte data buffer: 8
    // bytes, 32 states of 2 bits, are there.
    let last = &triangles[3];
    let offset = last["dataOffset"].as_u64().unwrap();
    assert_eq!(
        last["states"].as_str().unwrap().len() as u64,
        (256 - offset) * 4
    );
}

/// `ommcheck trace --draw`: a ray's hit on the micromap triangle it read,
/// with the micro-triangles within its error bound outlined; a ray that
/// read no micromap triangle has no picture and says why.
#[test]
fn a_traced_ray_is_drawn_on_the_triangle_it_read() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/trace-4state-quad.json");
    let scene = Scene::load(&path).expect("the scene loads");
    let options = ommcheck::scene::CheckOptions {
        tier: ommcheck::Tier::Simulate,
        ..Default::default()
    };
    let trace = scene.trace(&options).expect("the scene traces");
    let drawable = draw::Drawable::run_with(&scene, &options).expect("the scene runs");
    let ray = |name: &str| {
        trace
            .rays
            .iter()
            .find(|r| r.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no ray {name}"))
    };
    let description = |picture: &draw::Picture| {
        picture
            .svg
            .split_once("<desc>")
            .and_then(|(_, rest)| rest.split_once("</desc>"))
            .map(|(desc, _)| desc.to_string())
            .unwrap_or_default()
    };
    // On a micro-edge: both neighbours are outlined.
    let edge = drawable
        .ray(ray("micro-edge"))
        .expect("a micromap ray draws");
    assert_matches_reference(&edge, "ray-micro-edge");
    let desc = description(&edge);
    assert!(
        desc.contains("2 micro-triangles lie within its error bound (outlined): 1, 2"),
        "{desc}"
    );
    // Inside one micro-triangle: that one alone.
    let unknown = drawable.ray(ray("unknown")).expect("a micromap ray draws");
    let desc = description(&unknown);
    assert!(
        desc.contains("micro-triangle 2 alone lies within its error bound")
            && desc.contains("u = 0.6, v = 0.2")
            && desc.contains("Outcome: non-opaque"),
        "{desc}"
    );
    // A special index reads no micromap triangle.
    let special = match drawable.ray(ray("special index")) {
        Ok(_) => panic!("a special index has no micromap triangle to draw"),
        Err(e) => e.to_string(),
    };
    assert!(
        special.contains("read no micromap triangle (special index)"),
        "{special}"
    );
}

/// `ommcheck trace --draw DIR [--draw-png]` writes one picture per ray that
/// read a micromap triangle and says on stderr why the others have none.
#[test]
fn trace_draw_writes_a_picture_per_micromap_ray() {
    let scene =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/trace-4state-quad.json");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/pictures-cli/rays");
    let _ = std::fs::remove_dir_all(&dir);
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_ommcheck"))
        .arg("trace")
        .arg(&scene)
        .arg("--draw")
        .arg(&dir)
        .arg("--draw-png")
        .output()
        .unwrap();
    assert!(output.status.success(), "{output:?}");
    let mut written: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    // Rays 0 to 6 read micromap triangle 0; 7 and 8 a special index, 9 has
    // micromaps off, 10 misses.
    let expected: Vec<String> = (0..7)
        .map(|i| format!("trace-4state-quad-ray{i}.png"))
        .collect();
    assert_eq!(written, expected);
    let png = std::fs::read(dir.join("trace-4state-quad-ray0.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("rays[10] not drawn: ray 10 'miss' read no micromap triangle"),
        "{stderr}"
    );
}

/// The `<g class="finding" data-target="TARGET">` marks of an SVG, with the
/// centre of the first polygon in each.
fn finding_marks(svg: &str) -> Vec<(String, (f64, f64))> {
    svg.split("<g class=\"finding\" data-target=\"")
        .skip(1)
        .map(|rest| {
            let (target, rest) = rest.split_once('"').unwrap();
            let points = rest
                .split_once("points=\"")
                .and_then(|(_, p)| p.split_once('"'))
                .map(|(p, _)| p)
                .unwrap();
            (target.to_string(), centre(points))
        })
        .collect()
}

/// The mean of a `points` attribute's points.
fn centre(points: &str) -> (f64, f64) {
    let xy: Vec<(f64, f64)> = points
        .split(' ')
        .map(|p| {
            let (x, y) = p.split_once(',').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect();
    let n = xy.len() as f64;
    (
        xy.iter().map(|p| p.0).sum::<f64>() / n,
        xy.iter().map(|p| p.1).sum::<f64>() / n,
    )
}

/// The centres of the polygons outlined in the data's red (a triangle whose
/// data runs past the end, a geometry triangle selecting past the micromap).
fn red_outlines(svg: &str) -> Vec<(f64, f64)> {
    svg.lines()
        .filter(|l| l.starts_with("<polygon") && l.contains("fill=\"none\" stroke=\"#d62828\""))
        .map(|l| {
            let points = l
                .split_once("points=\"")
                .unwrap()
                .1
                .split_once('"')
                .unwrap()
                .0;
            centre(points)
        })
        .collect()
}

fn near(a: (f64, f64), b: (f64, f64)) -> bool {
    (a.0 - b.0).abs() < 3.0 && (a.1 - b.1).abs() < 3.0
}

/// The example's three findings, each marked on its picture where it
/// points: micromap triangle 3 (its data past the buffer), the usage
/// counts' two disagreeing keys, geometry triangle 4 (its index past the
/// micromap). The marks sit on the shapes the data's own red marks are.
#[test]
fn findings_are_marked_where_they_point() {
    let source = draw::Source::example();
    let picture = |pick: &Pick, reference: &str| {
        let picture = draw::draw_source(&source, pick).unwrap_or_else(|e| panic!("{e}"));
        assert_matches_reference(&picture, reference);
        picture.svg
    };

    let grid = picture(&micromap("foliage-omm", None), "micromap-grid-findings");
    let marks = finding_marks(&grid);
    assert_eq!(marks.len(), 1, "{marks:?}");
    assert_eq!(marks[0].0, "micromap triangle 3");
    let red = red_outlines(&grid);
    assert_eq!(red.len(), 1, "triangle 3 alone runs past the data");
    assert!(near(marks[0].1, red[0]), "{marks:?} against {red:?}");
    assert!(grid.contains(
        "OMMCHECK-build-triangle-data-in-range at calls[1]: pInfos[0].triangleArray[3].dataOffset"
    ));

    // One triangle's picture carries the mark of its own findings only.
    let three = picture(
        &micromap("foliage-omm", Some(3)),
        "micromap-triangle-findings",
    );
    assert_eq!(finding_marks(&three).len(), 1);
    let none = draw::draw_source(&source, &micromap("foliage-omm", Some(0))).unwrap();
    assert!(finding_marks(&none.svg).is_empty());

    let geometry = picture(
        &Pick::Geometry {
            name: "foliage-blas".into(),
            geometry: 0,
        },
        "geometry-findings",
    );
    let marks = finding_marks(&geometry);
    assert_eq!(marks.len(), 1, "{marks:?}");
    assert_eq!(marks[0].0, "geometry triangle 4");
    let red = red_outlines(&geometry);
    assert!(
        red.iter().any(|r| near(*r, marks[0].1)),
        "the mark is not on the red X's triangle: {marks:?} against {red:?}"
    );

    let histogram = picture(
        &Pick::UsageCounts {
            name: "foliage-omm".into(),
        },
        "usage-counts",
    );
    let targets: Vec<String> = finding_marks(&histogram)
        .into_iter()
        .map(|(t, _)| t)
        .collect();
    assert_eq!(
        targets,
        [
            "usage counts VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT level 3",
            "usage counts VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 3"
        ]
    );
    let desc = histogram
        .split_once("<desc>")
        .and_then(|(_, rest)| rest.split_once("</desc>"))
        .unwrap()
        .0;
    assert!(
        desc.contains("VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT level 3: stated 3, counted 2; VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 3: stated 1, counted 2"),
        "{desc}"
    );

    // Without the scene's text, or told not to, nothing is marked.
    let plain = draw::draw(&Scene::example(), &micromap("foliage-omm", None)).unwrap();
    assert!(finding_marks(&plain.svg).is_empty());
}

/// `ommcheck draw` marks the findings unless told --no-findings, and draws
/// the usage counts with --usage-counts.
#[test]
fn draw_marks_findings_unless_told_not_to() {
    let (dir, scene) = example_file("marks-example.json");
    let out = dir.join("marks.svg");
    let run = |args: &[&str]| {
        let _ = std::fs::remove_file(&out);
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_ommcheck"))
            .arg("draw")
            .arg(&scene)
            .args(args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(output.status.success(), "{output:?}");
        std::fs::read_to_string(&out).unwrap()
    };
    let marked = run(&["--acceleration-structure", "foliage-blas"]);
    assert_eq!(finding_marks(&marked).len(), 1);
    let plain = run(&["--acceleration-structure", "foliage-blas", "--no-findings"]);
    assert!(finding_marks(&plain).is_empty());
    let histogram = run(&["--micromap", "foliage-omm", "--usage-counts"]);
    assert!(histogram.contains("usage counts against the triangle array"));
    assert_eq!(finding_marks(&histogram).len(), 2);
}

fn textured(name: &str, texture: u32) -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../target/picture-scenes")
        .join(name);
    picture_scenes::write(
        &dir,
        name,
        &picture_scenes::Spec {
            level: 2,
            micromap_triangles: 4,
            geometry_triangles: 18,
            texture,
        },
    )
}

/// A geometry over its alpha texture: the texture's greys under the
/// states, each triangle at its texture coordinates.
#[test]
fn a_geometry_is_drawn_over_its_alpha_texture() {
    let path = textured("textured", 96);
    let scene = Scene::load(&path).unwrap();
    let pick = Pick::Geometry {
        name: "blas".into(),
        geometry: 0,
    };
    let (svg, desc) = drawn(&scene, &pick, "geometry-texture");
    assert!(
        desc.contains("over the alpha texture textured.alpha.png (96 x 96 texels, its alpha channel drawn as 96 x 96 cells"),
        "{desc}"
    );
    // Transparent and opaque texels, and the states at 55% over them.
    assert!(svg.contains("fill=\"#ffffff\"/>") && svg.contains("fill=\"#2d2d2d\"/>"));
    assert!(svg.contains("fill-opacity=\"0.55\""));
    assert!(!desc.contains("Not drawn, without texture coordinates"));

    // Triangles without texture coordinates are left out and counted.
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let uvs = json["alphaTextures"][0]["uvs"].as_array_mut().unwrap();
    uvs.truncate(3 * 16 + 1);
    let short = path.with_file_name("textured-short.json");
    let caption_of = |json: &serde_json::Value| {
        std::fs::write(&short, json.to_string()).unwrap();
        let svg = draw::draw(&Scene::load(&short).unwrap(), &pick)
            .unwrap()
            .svg;
        svg.lines()
            .find(|l| l.starts_with("Not drawn, without texture coordinates"))
            .unwrap_or_else(|| panic!("{svg}"))
            .to_string()
    };
    assert_eq!(
        caption_of(&json),
        "Not drawn, without texture coordinates: 2 triangles (triangle 16: vertex 49 has no texture coordinate (uvs holds 49))."
    );
    // A coordinate far outside the texture is one it cannot place either.
    json["alphaTextures"][0]["uvs"][4] = serde_json::json!([1e300, 0.5]);
    assert_eq!(
        caption_of(&json),
        "Not drawn, without texture coordinates: 3 triangles (triangle 1: vertex 4's texture coordinate [1e300, 0.5] is outside [-64, 65])."
    );
}

/// A PNG whose header claims more texels than the bound is refused before
/// its image is allocated, and the picture says so.
#[test]
fn a_hostile_alpha_texture_is_refused() {
    let path = textured("hostile-texture", 8);
    let png = path.with_file_name("hostile-texture.alpha.png");
    let mut bytes = std::fs::read(&png).unwrap();
    bytes[16..24].copy_from_slice(&[0, 1, 0, 0, 0, 1, 0, 0]);
    std::fs::write(&png, bytes).unwrap();
    let error = match draw::draw(
        &Scene::load(&path).unwrap(),
        &Pick::Geometry {
            name: "blas".into(),
            geometry: 0,
        },
    ) {
        Ok(_) => panic!("a 65536 x 65536 texture was drawn"),
        Err(e) => e.to_string(),
    };
    assert!(error.contains("65536 x 65536 texels"), "{error}");
}

/// An alpha texture that names no acceleration structure of the scene is
/// refused with the name it meant, not skipped in silence.
#[test]
fn an_alpha_texture_of_a_misspelt_structure_is_refused() {
    let path = textured("misspelt-texture", 8);
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    json["alphaTextures"][0]["accelerationStructure"] = serde_json::json!("blsa");
    let misspelt = path.with_file_name("misspelt-texture-name.json");
    std::fs::write(&misspelt, json.to_string()).unwrap();
    let pick = Pick::Geometry {
        name: "blas".into(),
        geometry: 0,
    };
    let error = match draw::draw(&Scene::load(&misspelt).unwrap(), &pick) {
        Ok(_) => panic!("a texture of no structure was skipped"),
        Err(e) => e.to_string(),
    };
    assert!(
        error.contains("alphaTextures[0].accelerationStructure")
            && error.contains("did you mean `blas`?"),
        "{error}"
    );
    assert!(draw::draw(&Scene::load(&path).unwrap(), &pick).is_ok());
}
