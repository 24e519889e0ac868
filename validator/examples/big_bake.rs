//! Writes a scene with a multi-GiB opacity micromap bake into the folder
//! given, to measure `ommcheck check` against reading the files once
//! (docs/cli.md, "Loading scene files"):
//!
//! - `big-bake.data.bin`: the micromap data, 4-state triangles at one level;
//! - `big-bake.triangles.bin`: the triangle array (`VkMicromapTriangleEXT`,
//!   8 bytes each), as a baker writes its descArray;
//! - `big-bake.json`: one `vkCmdBuildMicromapsEXT` whose infos each build a
//!   micromap of at most 2 GiB of that data (a triangle's `dataOffset` is
//!   32 bits), reading both files through buffers exactly their size, so
//!   the checker maps them.
//!
//! The files hold about `--gib` GiB together (default 4). The scene is
//! valid: `ommcheck check` reports nothing at any tier.
//!
//! `cargo run --release -p ommcheck --example big_bake -- DIR [--gib 4] [--level 3]`

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Triangles written per batch (each batch is one write of each file).
const BATCH: u64 = 1 << 16;
/// The most data one build reads, well under the 4 GiB a 32-bit
/// `dataOffset` reaches.
const DATA_PER_BUILD: u64 = 2 << 30;
const FORMAT: &str = "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT";
const INPUT: &str = r#"["VK_BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]"#;

fn main() {
    let mut args = std::env::args().skip(1);
    let mut dir = None;
    let mut gib = 4.0f64;
    let mut level = 3u32;
    while let Some(arg) = args.next() {
        let mut value = || {
            args.next()
                .unwrap_or_else(|| usage(&format!("{arg} needs a value")))
        };
        match arg.as_str() {
            "--gib" => {
                gib = value()
                    .parse()
                    .unwrap_or_else(|_| usage("--gib takes a number"))
            }
            "--level" => {
                level = value()
                    .parse()
                    .ok()
                    .filter(|l| (1..=12).contains(l))
                    .unwrap_or_else(|| usage("--level takes 1 to 12"))
            }
            _ if dir.is_none() && !arg.starts_with('-') => dir = Some(arg),
            _ => usage(&format!("unexpected `{arg}`")),
        }
    }
    let dir = dir.unwrap_or_else(|| usage("give the folder to write into"));
    let path = write(Path::new(&dir), gib, level).expect("write the bake");
    println!("{}", path.display());
}

fn usage(why: &str) -> ! {
    eprintln!("{why}\nusage: big_bake DIR [--gib G] [--level L]");
    std::process::exit(2)
}

/// One micro-triangle state per 2 bits, varied so the data is not one
/// repeated byte: a xorshift of the triangle index, so every run writes the
/// same files.
fn triangle_data(t: u64, out: &mut [u8]) {
    let mut x = t.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    for chunk in out.chunks_mut(8) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        chunk.copy_from_slice(&x.to_le_bytes()[..chunk.len()]);
    }
}

fn write(dir: &Path, gib: f64, level: u32) -> std::io::Result<std::path::PathBuf> {
    std::fs::create_dir_all(dir)?;
    // 2 bits per micro-triangle, 4^level micro-triangles.
    let data_per_triangle = (1u64 << (2 * level)) / 4;
    let total = (gib * f64::from(1u32 << 30)) as u64;
    let triangles = (total / (data_per_triangle + 8)).max(1);
    let per_build = DATA_PER_BUILD / data_per_triangle;

    let mut data = BufWriter::with_capacity(8 << 20, File::create(dir.join("big-bake.data.bin"))?);
    let mut array =
        BufWriter::with_capacity(8 << 20, File::create(dir.join("big-bake.triangles.bin"))?);
    let mut bytes = vec![0u8; (BATCH * data_per_triangle) as usize];
    let mut entries = Vec::with_capacity(8 * BATCH as usize);
    let mut t = 0;
    while t < triangles {
        let n = BATCH.min(triangles - t);
        entries.clear();
        for k in 0..n {
            let at = (k * data_per_triangle) as usize;
            triangle_data(t + k, &mut bytes[at..at + data_per_triangle as usize]);
            // dataOffset from the start of this triangle's build.
            let offset = ((t + k) % per_build) * data_per_triangle;
            entries.extend((offset as u32).to_le_bytes());
            entries.extend((level as u16).to_le_bytes());
            entries.extend(2u16.to_le_bytes()); // VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT
        }
        data.write_all(&bytes[..(n * data_per_triangle) as usize])?;
        array.write_all(&entries)?;
        t += n;
    }
    data.flush()?;
    array.flush()?;

    let builds = triangles.div_ceil(per_build);
    // Each micromap gets 256-byte aligned storage a little larger than what
    // it reads (storage has no contents: its size costs nothing).
    let storage_each = (per_build * (data_per_triangle + 8) + (1 << 16)).next_multiple_of(256);
    let scratch_each = 1u64 << 20;
    let mut calls = Vec::new();
    let mut infos = Vec::new();
    for b in 0..builds {
        let first = b * per_build;
        let count = per_build.min(triangles - first);
        calls.push(format!(
            r#"{{"call": "vkCreateMicromapEXT", "pCreateInfo": {{"buffer": "micromap-storage", "offset": {}, "size": {storage_each}, "type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT"}}, "pMicromap": "bake-{b}"}}"#,
            b * storage_each
        ));
        infos.push(format!(
            r#"{{"type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT", "mode": "VK_BUILD_MICROMAP_MODE_BUILD_EXT", "dstMicromap": "bake-{b}", "pUsageCounts": [{{"count": {count}, "subdivisionLevel": {level}, "format": "{FORMAT}"}}], "data": {{"buffer": "omm-data", "offset": {}}}, "scratchData": {{"buffer": "scratch", "offset": {}}}, "triangleArray": {{"buffer": "omm-triangles", "offset": {}}}, "triangleArrayStride": 8}}"#,
            first * data_per_triangle,
            b * scratch_each,
            first * 8
        ));
    }
    calls.push(format!(
        r#"{{"call": "vkCmdBuildMicromapsEXT", "pInfos": [{}]}}"#,
        infos.join(", ")
    ));
    let buffers = [
        format!(
            r#"{{"name": "omm-data", "size": {}, "usage": {INPUT}, "contents": {{"file": "big-bake.data.bin"}}}}"#,
            triangles * data_per_triangle
        ),
        format!(
            r#"{{"name": "omm-triangles", "size": {}, "usage": {INPUT}, "contents": {{"file": "big-bake.triangles.bin"}}}}"#,
            triangles * 8
        ),
        format!(
            r#"{{"name": "micromap-storage", "size": {}, "usage": "VK_BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT"}}"#,
            builds * storage_each
        ),
        format!(
            r#"{{"name": "scratch", "size": {}, "usage": ["VK_BUFFER_USAGE_STORAGE_BUFFER_BIT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]}}"#,
            builds * scratch_each
        ),
    ];
    let scene = format!(
        "{{\n\"description\": \"Generated by validator/examples/big_bake.rs: {triangles} 4-state level-{level} triangles ({} bytes of data, {} of triangle array) in {builds} builds.\",\n\"device\": {{\"limits\": {{\"maxOpacity4StateSubdivisionLevel\": 12}}}},\n\"buffers\": [\n{}\n],\n\"calls\": [\n{}\n]\n}}\n",
        triangles * data_per_triangle,
        triangles * 8,
        buffers.join(",\n"),
        calls.join(",\n")
    );
    let path = dir.join("big-bake.json");
    std::fs::write(&path, scene)?;
    Ok(path)
}
