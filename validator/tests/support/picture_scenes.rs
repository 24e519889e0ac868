//! Scenes large enough to need the pictures' downsampling, written to a
//! folder: one micromap of 4-state triangles at any level, each holding a
//! wavy disc (opaque inside, unknown on a band along its edge, transparent
//! outside), and a BLAS geometry whose opacity indices select those
//! triangles in turn, every 97th triangle using a special index instead.
//! Used by the picture tests and by the measurement in docs/pictures.md
//! (`cargo run --release -p ommcheck --example picture_scenes -- DIR`).

use std::path::{Path, PathBuf};

use ommcheck::sim::index::MicroTriangle;

/// What to generate.
pub struct Spec {
    /// The micromap triangles' level.
    pub level: u32,
    /// How many micromap triangles.
    pub micromap_triangles: u32,
    /// How many geometry triangles (0: no BLAS).
    pub geometry_triangles: u32,
    /// With a BLAS: an alpha texture this many texels across and down
    /// (0: none), holding the discs the micromap triangles hold, with the
    /// geometry's triangles laid out on it two to a square.
    pub texture: u32,
}

/// How far `(u, v)` lies inside the wavy disc of micromap triangle `m`
/// (positive inside), and the width of the unknown band on its edge.
fn disc(u: f64, v: f64, m: u32) -> (f64, f64) {
    let (du, dv) = (u - 1.0 / 3.0, v - 1.0 / 3.0);
    let distance = (du * du + dv * dv).sqrt();
    let angle = dv.atan2(du);
    let edge = 0.22 + 0.06 * (5.0 * angle + f64::from(m)).sin();
    (edge - distance, 0.015)
}

/// The 4-state value of micro-triangle `k` at `level` of micromap triangle `m`.
fn state(k: u32, level: u32, m: u32) -> u8 {
    let corners = MicroTriangle::from_index(k, level)
        .expect("k < 4^level")
        .vertices(level);
    let (u, v) = (
        corners.iter().map(|c| c.0).sum::<f64>() / 3.0,
        corners.iter().map(|c| c.1).sum::<f64>() / 3.0,
    );
    let (inside, band) = disc(u, v, m);
    if inside > band {
        1 // opaque
    } else if inside > 0.0 {
        3 // unknown-opaque
    } else if inside > -band {
        2 // unknown-transparent
    } else {
        0 // transparent
    }
}

/// One triangle's 4-state data.
fn triangle_data(level: u32, m: u32) -> Vec<u8> {
    let count = 1u32 << (2 * level);
    let mut bytes = vec![0u8; (count as usize).div_ceil(4)];
    for k in 0..count {
        bytes[(k / 4) as usize] |= state(k, level, m) << (2 * (k % 4));
    }
    bytes
}

const INPUT: &str = r#"["VK_BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]"#;
const AS_INPUT: &str = r#"["VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]"#;
const FORMAT: &str = "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT";

/// Writes `name`.json and its binary files into `dir`; returns the scene's path.
/// The micromap is named `disc`, the BLAS `blas`.
pub fn write(dir: &Path, name: &str, spec: &Spec) -> PathBuf {
    std::fs::create_dir_all(dir).expect("create the folder");
    let (level, triangles, geometry) =
        (spec.level, spec.micromap_triangles, spec.geometry_triangles);
    let mut data = Vec::new();
    let mut entries = Vec::new();
    for m in 0..triangles {
        entries.push(format!(
            r#"{{"dataOffset": {}, "subdivisionLevel": {level}, "format": "{FORMAT}"}}"#,
            data.len()
        ));
        // Triangles alike but for their phase: eight patterns, repeated.
        data.extend(triangle_data(level, m % 8));
    }
    let data_file = format!("{name}.data.bin");
    std::fs::write(dir.join(&data_file), &data).expect("write the data");
    let mut buffers = vec![
        format!(
            r#"{{"name": "omm-data", "size": {}, "usage": {INPUT}, "contents": {{"file": "{data_file}"}}}}"#,
            data.len().max(4)
        ),
        format!(
            r#"{{"name": "omm-triangles", "size": {}, "usage": {INPUT}, "contents": {{"triangles": [{}]}}}}"#,
            8 * triangles.max(1),
            entries.join(", ")
        ),
        r#"{"name": "micromap-storage", "size": 65536, "usage": "VK_BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT"}"#.to_string(),
        r#"{"name": "scratch", "size": 65536, "usage": ["VK_BUFFER_USAGE_STORAGE_BUFFER_BIT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]}"#.to_string(),
    ];
    let mut calls = vec![
        r#"{"call": "vkCreateMicromapEXT", "pCreateInfo": {"buffer": "micromap-storage", "size": 65536, "type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT"}, "pMicromap": "disc"}"#.to_string(),
        format!(
            r#"{{"call": "vkCmdBuildMicromapsEXT", "pInfos": [{{"type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT", "mode": "VK_BUILD_MICROMAP_MODE_BUILD_EXT", "dstMicromap": "disc", "pUsageCounts": [{{"count": {triangles}, "subdivisionLevel": {level}, "format": "{FORMAT}"}}], "data": {{"buffer": "omm-data"}}, "scratchData": {{"buffer": "scratch"}}, "triangleArray": {{"buffer": "omm-triangles"}}, "triangleArrayStride": 8}}]}}"#
        ),
    ];
    if geometry > 0 {
        // Triangle t selects micromap triangle t mod the count; every 97th
        // a special index, -1 to -4 in turn.
        let mut index = Vec::with_capacity(4 * geometry as usize);
        let mut referenced = 0u32;
        for t in 0..geometry {
            let value = if t % 97 == 96 {
                (-1 - (t / 97 % 4) as i32) as u32
            } else {
                referenced += 1;
                t % triangles.max(1)
            };
            index.extend(value.to_le_bytes());
        }
        let index_file = format!("{name}.index.bin");
        std::fs::write(dir.join(&index_file), &index).expect("write the indices");
        buffers.push(format!(
            r#"{{"name": "omm-index", "size": {}, "usage": {AS_INPUT}, "contents": {{"file": "{index_file}"}}}}"#,
            index.len()
        ));
        buffers.push(format!(
            r#"{{"name": "vertices", "size": {}, "usage": {AS_INPUT}}}"#,
            36 * u64::from(geometry)
        ));
        buffers.push(
            r#"{"name": "blas-storage", "size": 65536, "usage": "VK_BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR"}"#
                .to_string(),
        );
        calls.push(r#"{"call": "vkCreateAccelerationStructureKHR", "pCreateInfo": {"buffer": "blas-storage", "size": 65536, "type": "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR"}, "pAccelerationStructure": "blas"}"#.to_string());
        calls.push(format!(
            r#"{{"call": "vkCmdBuildAccelerationStructuresKHR", "pInfos": [{{"type": "VK_ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL_KHR", "mode": "VK_BUILD_ACCELERATION_STRUCTURE_MODE_BUILD_KHR", "dstAccelerationStructure": "blas", "pGeometries": [{{"geometryType": "VK_GEOMETRY_TYPE_TRIANGLES_KHR", "geometry": {{"triangles": {{"pNext": [{{"sType": "VK_STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT", "indexType": "VK_INDEX_TYPE_UINT32", "indexBuffer": {{"buffer": "omm-index"}}, "indexStride": 4, "baseTriangle": 0, "pUsageCounts": [{{"count": {referenced}, "subdivisionLevel": {level}, "format": "{FORMAT}"}}], "micromap": "disc"}}], "vertexFormat": "VK_FORMAT_R32G32B32_SFLOAT", "vertexData": {{"buffer": "vertices"}}, "vertexStride": 12, "maxVertex": {}, "indexType": "VK_INDEX_TYPE_NONE_KHR"}}}}, "flags": 0}}], "scratchData": {{"buffer": "scratch"}}}}], "ppBuildRangeInfos": [[{{"primitiveCount": {geometry}}}]]}}"#,
            3 * geometry - 1
        ));
    }
    let textures = if geometry > 0 && spec.texture > 0 {
        let png = format!("{name}.alpha.png");
        std::fs::write(dir.join(&png), alpha_png(spec.texture, geometry, triangles))
            .expect("write the texture");
        format!(
            ",\n\"alphaTextures\": [{{\"accelerationStructure\": \"blas\", \"png\": \"{png}\", \"uvs\": [{}]}}]",
            uvs(geometry).join(", ")
        )
    } else {
        String::new()
    };
    let scene = format!(
        "{{\n\"description\": \"Generated by validator/tests/support/picture_scenes.rs: level {level}, {triangles} micromap triangles, {geometry} geometry triangles.\",\n\"buffers\": [\n{}\n],\n\"calls\": [\n{}\n]{textures}\n}}\n",
        buffers.join(",\n"),
        calls.join(",\n")
    );
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, scene).expect("write the scene");
    path
}

/// Squares across the texture for `geometry` triangles, two to a square.
fn squares_across(geometry: u32) -> u32 {
    (f64::from(geometry.div_ceil(2).max(1))).sqrt().ceil() as u32
}

/// The texture coordinates of the geometry's vertices `3t + k`: triangle
/// `2q` has vertex 0 at square `q`'s bottom-left corner, `2q + 1` at its
/// top-right, as the pictures' layout without a texture has them.
fn uvs(geometry: u32) -> Vec<String> {
    let n = squares_across(geometry);
    let s = 1.0 / f64::from(n);
    let mut out = Vec::with_capacity(3 * geometry as usize);
    for t in 0..geometry {
        let q = t / 2;
        let (x, y) = (f64::from(q % n) * s, f64::from(q / n) * s);
        let corners = if t % 2 == 0 {
            [(x, y + s), (x + s, y + s), (x, y)]
        } else {
            [(x + s, y), (x, y), (x + s, y + s)]
        };
        out.extend(corners.iter().map(|(u, v)| format!("[{u}, {v}]")));
    }
    out
}

/// A grey+alpha PNG of `size` x `size` texels whose alpha is the disc of
/// the micromap triangle each texel's geometry triangle selects (as the
/// bake would see it), 0 outside the triangles.
fn alpha_png(size: u32, geometry: u32, triangles: u32) -> Vec<u8> {
    let n = squares_across(geometry);
    let mut data = Vec::with_capacity(2 * (size as usize).pow(2));
    for py in 0..size {
        for px in 0..size {
            let (x, y) = (
                (f64::from(px) + 0.5) / f64::from(size) * f64::from(n),
                (f64::from(py) + 0.5) / f64::from(size) * f64::from(n),
            );
            let (col, row) = (x.floor() as u32, y.floor() as u32);
            let (a, b) = (x - x.floor(), y - y.floor());
            // Lower-left half: triangle 2q at barycentrics (a, 1 - b);
            // upper-right: 2q + 1 at (1 - a, b).
            let q = row * n + col;
            let (t, u, v) = if a <= b {
                (2 * q, a, 1.0 - b)
            } else {
                (2 * q + 1, 1.0 - a, b)
            };
            let alpha = if t < geometry {
                let (inside, band) = disc(u, v, (t % triangles.max(1)) % 8);
                (0.5 + inside / (2.0 * band)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            data.extend([96, (alpha * 255.0).round() as u8]);
        }
    }
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, size, size);
    encoder.set_color(png::ColorType::GrayscaleAlpha);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().expect("a PNG header");
    writer.write_image_data(&data).expect("the PNG's texels");
    writer.finish().expect("the PNG's end");
    out
}
