//! Scenes whose buffer contents are large: a file far over the old 256 MiB
//! bound is mapped and checked at the offsets the build reads, a buffer
//! declared 2^40 bytes long costs only the bytes given, and a truncated
//! file gives findings, never a crash.
//!
//! The large files are sparse (a length set, a few bytes written), so the
//! tests write almost nothing to disk. Memory is measured twice: the heap
//! by the counting allocator of `support/peak_memory.rs`, and the resident
//! set (mapped and anonymous pages, which no allocator sees) by the
//! kernel's high-water mark, reset before each check. Both measurements
//! take turns through [`measure`], so one test's pages never count in
//! another's.

#![cfg(target_os = "linux")]

use std::fs::{File, OpenOptions};
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use ommcheck::scene::{CheckOptions, Scene, SceneError, SceneReport, StatsReport};

#[path = "support/peak_memory.rs"]
mod peak_memory;
use peak_memory::{measure, BOUND};

const MIB: u64 = 1 << 20;
const INPUT: &str = r#"["VK_BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]"#;
const TWO_STATE: u16 = 1;

/// A folder of this test binary's own, removed when dropped.
struct Folder(PathBuf);

impl Folder {
    fn new(name: &str) -> Folder {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("large-contents-{name}"));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).expect("create the test folder");
        Folder(dir)
    }
}

impl Drop for Folder {
    fn drop(&mut self) {
        std::fs::remove_dir_all(&self.0).ok();
    }
}

/// A `VkMicromapTriangleEXT`.
fn triangle(data_offset: u32, level: u16, format: u16) -> [u8; 8] {
    let mut entry = [0u8; 8];
    entry[..4].copy_from_slice(&data_offset.to_le_bytes());
    entry[4..6].copy_from_slice(&level.to_le_bytes());
    entry[6..].copy_from_slice(&format.to_le_bytes());
    entry
}

/// A sparse file `len` bytes long holding `pieces` at their offsets.
fn sparse_file(path: &Path, len: u64, pieces: &[(u64, &[u8])]) {
    let file = File::create(path).expect("create the file");
    file.set_len(len).expect("size the file");
    for (at, bytes) in pieces {
        file.write_all_at(bytes, *at).expect("write a piece");
    }
}

/// A scene of `buffers` (JSON objects) and one micromap build of `count`
/// 2-state level-3 triangles, `data` and `triangles` its addresses.
fn build_scene(buffers: &[String], count: u64, data: &str, triangles: &str) -> String {
    format!(
        r#"{{ "buffers": [{},
    {{"name": "micromap-storage", "size": 65536, "usage": "VK_BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT"}},
    {{"name": "scratch", "size": 65536, "usage": ["VK_BUFFER_USAGE_STORAGE_BUFFER_BIT", "VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT"]}}],
  "calls": [
    {{"call": "vkCreateMicromapEXT", "pCreateInfo": {{"buffer": "micromap-storage", "size": 65536, "type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT"}}, "pMicromap": "m"}},
    {{"call": "vkCmdBuildMicromapsEXT", "pInfos": [{{"type": "VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT", "mode": "VK_BUILD_MICROMAP_MODE_BUILD_EXT", "dstMicromap": "m",
      "pUsageCounts": [{{"count": {count}, "subdivisionLevel": 3, "format": "VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT"}}],
      "data": {data}, "scratchData": {{"buffer": "scratch"}}, "triangleArray": {triangles}, "triangleArrayStride": 8}}]}}]
}}"#,
        buffers.join(",\n    ")
    )
}

/// Writes the scene of one buffer `omm` of `size` bytes with `contents`
/// (JSON) and a build of 4 triangles reading its data at `data_at` and its
/// triangle array at `array_at`; returns the scene's path.
fn one_buffer_scene(
    folder: &Folder,
    size: u64,
    contents: &str,
    data_at: u64,
    array_at: u64,
) -> PathBuf {
    let scene = build_scene(
        &[format!(
            r#"{{"name": "omm", "size": {size}, "usage": {INPUT}, "contents": {contents}}}"#
        )],
        4,
        &format!(r#"{{"buffer": "omm", "offset": {data_at}}}"#),
        &format!(r#"{{"buffer": "omm", "offset": {array_at}}}"#),
    );
    let path = folder.0.join("scene.json");
    std::fs::write(&path, scene).expect("write the scene");
    path
}

/// Asserts that triangle `index`'s 8 bytes of data at `offset` are found to
/// end past the `data_len` bytes from the build's `data` address on.
fn assert_data_past_end(findings: &[String], index: usize, offset: u64, data_len: u64) {
    let expected = format!(
        "OMMCHECK-build-triangle-data-in-range pInfos[0].triangleArray[{index}].dataOffset: [{offset}, {}) is past the end of the memory data points into ({data_len} bytes)",
        offset + 8
    );
    assert!(
        findings.iter().any(|f| f.starts_with(&expected)),
        "{expected}\nnot in {findings:#?}"
    );
}

/// What a check left: its report, the census of what the build read, and
/// the most memory it held beyond what was held before.
struct Measured {
    report: SceneReport,
    stats: StatsReport,
    heap: usize,
    /// The resident set's growth; None where the kernel's high-water mark
    /// cannot be reset (`/proc/self/clear_refs`).
    resident: Option<u64>,
}

/// `VmHWM` or `VmRSS` of this process, in bytes.
fn status_bytes(key: &str) -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line[key.len()..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}

/// Loads and checks the scene at `path`, and takes its census.
fn check(path: &Path) -> Result<Measured, SceneError> {
    let ((result, resident), heap) = measure(|| {
        // Writing 5 resets the high-water mark to the present resident set
        // (Linux 4.0 and later).
        let reset = std::fs::write("/proc/self/clear_refs", "5").is_ok();
        let before = status_bytes("VmRSS:");
        let result = Scene::load(path).and_then(|scene| {
            let report = scene.check(&CheckOptions::default())?;
            let stats = scene.stats()?;
            Ok((report, stats))
        });
        let peak = status_bytes("VmHWM:");
        let resident = match (reset, before, peak) {
            (true, Some(before), Some(peak)) => Some(peak.saturating_sub(before)),
            _ => None,
        };
        (result, resident)
    });
    result.map(|(report, stats)| Measured {
        report,
        stats,
        heap,
        resident,
    })
}

/// The findings as `RULE LOCATION: MESSAGE`, each location without the
/// call every scene here checks (the build, `calls[1]`).
fn described(report: &SceneReport) -> Vec<String> {
    report
        .findings
        .iter()
        .map(|f| {
            format!(
                "{} {}: {}",
                f.rule,
                f.location.trim_start_matches("calls[1]: "),
                f.message
            )
        })
        .collect()
}

fn assert_bounded(measured: &Measured, what: &str) {
    assert!(
        measured.heap < BOUND,
        "{what}: the check allocated {} bytes at its peak",
        measured.heap
    );
    if let Some(resident) = measured.resident {
        assert!(
            resident < BOUND as u64,
            "{what}: the resident set grew by {resident} bytes"
        );
    }
}

/// A 300 MiB buffer filled by a 300 MiB file (over the old 256 MiB bound):
/// accepted, mapped, and read where the build points: near its end.
#[test]
fn a_file_over_256_mib_is_checked_at_the_offsets_the_build_reads() {
    let folder = Folder::new("300mib");
    let size = 300 * MIB;
    let (data_at, array_at) = (280 * MIB, 299 * MIB);
    let mut array = Vec::new();
    array.extend(triangle(0, 3, TWO_STATE));
    array.extend(triangle(8, 3, TWO_STATE));
    // 4 bytes before the buffer's end: 8 bytes of data do not fit.
    array.extend(triangle((size - data_at - 4) as u32, 3, TWO_STATE));
    array.extend(triangle(16, 3, 7));
    // Triangle 0 all opaque (64 set bits), triangle 1 half (32).
    let data = [[0xffu8; 8], [0x0f; 8]].concat();
    sparse_file(
        &folder.0.join("big.bin"),
        size,
        &[(data_at, &data), (array_at, &array)],
    );
    let path = one_buffer_scene(&folder, size, r#"{"file": "big.bin"}"#, data_at, array_at);

    let measured = check(&path).unwrap_or_else(|e| panic!("{e}"));
    let findings = described(&measured.report);
    assert_data_past_end(&findings, 2, size - data_at - 4, size - data_at);
    assert!(
        findings.iter().any(|f| f.starts_with(
            "VUID-VkMicromapBuildInfoEXT-format-11657 pInfos[0].triangleArray[3].format: 7 is not"
        )),
        "{findings:#?}"
    );
    // Triangles 0 and 1 read their data from 280 MiB into the file (zeros
    // anywhere else would count no opaque micro-triangle).
    let stored = measured.stats.total.stored;
    assert_eq!((stored.opaque, stored.transparent), (96, 32));
    assert_bounded(&measured, "300 MiB file");
}

/// A buffer declared 2^40 bytes long with 3 MiB of file near its start
/// (off a page boundary, so copied) and 16 bytes placed 1 MiB before its
/// end: the bytes no piece gives read as zero without being allocated.
#[test]
fn a_buffer_declared_far_larger_than_its_pieces_costs_only_what_they_hold() {
    let folder = Folder::new("2pow40");
    let size = 1u64 << 40;
    let data_at = size - MIB;
    let mut array = Vec::new();
    array.extend(triangle(0, 3, TWO_STATE));
    array.extend(triangle(8, 3, TWO_STATE));
    // In the zeros between the pieces: all transparent.
    array.extend(triangle(4096, 3, TWO_STATE));
    // 4 bytes before the buffer's end.
    array.extend(triangle((MIB - 4) as u32, 3, TWO_STATE));
    // A file over several copy chunks, mostly a hole, so its copy into
    // place is tested to write only what differs from zero. At 256, not
    // on a page boundary: a file there cannot be mapped.
    sparse_file(
        &folder.0.join("start.bin"),
        3 * MIB,
        &[(0, &array), (2 * MIB + 5, &[1])],
    );
    let contents = format!(
        r#"[{{"at": 256, "file": "start.bin"}}, {{"at": {data_at}, "hex": "ffffffffffffffff 0f0f0f0f0f0f0f0f"}}]"#
    );
    let path = one_buffer_scene(&folder, size, &contents, data_at, 256);

    let measured = check(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_data_past_end(&described(&measured.report), 3, MIB - 4, MIB);
    let stored = measured.stats.total.stored;
    assert_eq!((stored.opaque, stored.transparent), (96, 32 + 64));
    assert_bounded(&measured, "2^40-byte buffer");
}

/// A 32 MiB file (every byte on disk) at a page boundary inside a 64 MiB
/// buffer, between two inline pieces: mapped where it is placed rather
/// than copied, the piece after it written over it, and the piece before
/// it in the file's last page (past the file's end) kept.
#[test]
fn a_file_inside_a_larger_buffer_is_mapped_where_it_is_placed() {
    let folder = Folder::new("inside");
    let (size, file_at) = (64 * MIB, 64 * 1024);
    let file_len = 32 * MIB + 100;
    let mut file = vec![0x5au8; file_len as usize];
    let data = 16 * MIB as usize;
    file[data..data + 8].fill(0xff); // triangle 0: all opaque
    file[data + 8..data + 16].fill(0); // triangle 1: what the piece after it writes
    let mut array = Vec::new();
    array.extend(triangle(data as u32, 3, TWO_STATE));
    array.extend(triangle(data as u32 + 8, 3, TWO_STATE));
    // 8 bytes past the file's end, in its last page: the piece before it.
    array.extend(triangle(file_len as u32 + 8, 3, TWO_STATE));
    array.extend(triangle((size - file_at - 4) as u32, 3, TWO_STATE));
    file[..array.len()].copy_from_slice(&array);
    std::fs::write(folder.0.join("inner.bin"), &file).unwrap();
    drop(file);
    let contents = format!(
        r#"[{{"at": {}, "hex": "ffffffffffffffff"}}, {{"at": {file_at}, "file": "inner.bin"}}, {{"at": {}, "hex": "0f0f0f0f0f0f0f0f"}}]"#,
        file_at + file_len + 8,
        file_at + data as u64 + 8
    );
    let path = one_buffer_scene(&folder, size, &contents, file_at, file_at);

    let measured = check(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_data_past_end(
        &described(&measured.report),
        3,
        size - file_at - 4,
        size - file_at,
    );
    let stored = measured.stats.total.stored;
    assert_eq!((stored.opaque, stored.transparent), (64 + 32 + 64, 32));
    // Copied, the file would add its 32 MiB to the resident set twice (the
    // check and the census each load the scene); mapped, only the pages
    // the build reads.
    if let Some(resident) = measured.resident {
        assert!(
            resident < 16 * MIB,
            "the resident set grew by {resident} bytes"
        );
    }
    assert_bounded(&measured, "file inside a buffer");
}

/// Contents larger than the address space: a scene error naming the
/// buffer, not an abort.
#[test]
fn contents_beyond_the_address_space_are_a_scene_error() {
    let folder = Folder::new("2pow62");
    let scene = build_scene(
        &[format!(
            r#"{{"name": "omm", "size": {}, "usage": {INPUT}, "contents": {{"at": 0, "u8": [1]}}}}"#,
            1u64 << 62
        )],
        1,
        r#"{"buffer": "omm"}"#,
        r#"{"buffer": "omm"}"#,
    );
    let path = folder.0.join("scene.json");
    std::fs::write(&path, scene).unwrap();
    match check(&path).map(|m| m.report) {
        Err(SceneError::Semantic {
            json_path, message, ..
        }) => {
            assert_eq!(json_path, "buffers[0].contents");
            assert!(message.contains("cannot reserve"), "{message}");
        }
        other => panic!(
            "expected a scene error, got {:?}",
            other.map(|r| r.findings)
        ),
    }
}

/// A bake whose triangle array file was cut short: the entries past the
/// cut read as zero (bytes no piece gives), and the build's findings point
/// at the first of them; the same file in a buffer of its own size gives a
/// triangle array that ends past the buffer. Neither is a crash.
#[test]
fn a_truncated_file_gives_findings_where_it_ends() {
    let folder = Folder::new("truncated");
    let count: u64 = 1 << 17; // 1 MiB of triangle array: mapped when whole
    let mut array = Vec::with_capacity(8 * count as usize);
    for t in 0..count {
        array.extend(triangle((t * 8) as u32, 3, TWO_STATE));
    }
    std::fs::write(folder.0.join("data.bin"), vec![0x5au8; 8 * count as usize]).unwrap();
    let cut = 1000u64;
    let whole = folder.0.join("triangles.bin");
    std::fs::write(&whole, &array).unwrap();
    let data = format!(
        r#"{{"name": "omm-data", "size": {}, "usage": {INPUT}, "contents": {{"file": "data.bin"}}}}"#,
        8 * count
    );
    let scene = |array_size: u64| {
        build_scene(
            &[
                data.clone(),
                format!(
                    r#"{{"name": "omm-triangles", "size": {array_size}, "usage": {INPUT}, "contents": {{"file": "triangles.bin"}}}}"#
                ),
            ],
            count,
            r#"{"buffer": "omm-data"}"#,
            r#"{"buffer": "omm-triangles"}"#,
        )
    };
    let path = folder.0.join("scene.json");
    std::fs::write(&path, scene(8 * count)).unwrap();
    let complete = check(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(described(&complete.report), Vec::<String>::new());

    OpenOptions::new()
        .write(true)
        .open(&whole)
        .and_then(|f| f.set_len(8 * cut + 3))
        .unwrap();
    let cut_short = check(&path).unwrap_or_else(|e| panic!("{e}"));
    let findings = described(&cut_short.report);
    // Entry 1000 has 3 of its bytes (a data offset), entry 1001 none: both
    // read format 0, which is no opacity format.
    assert!(
        findings.iter().any(|f| f.starts_with(&format!(
            "VUID-VkMicromapBuildInfoEXT-format-11657 pInfos[0].triangleArray[{cut}].format: 0 is not"
        ))),
        "{findings:#?}"
    );
    assert!(
        !findings
            .iter()
            .any(|f| f.contains(&format!("triangleArray[{}].", cut - 1))),
        "{findings:#?}"
    );

    std::fs::write(&path, scene(8 * cut + 3)).unwrap();
    let own_size = check(&path).unwrap_or_else(|e| panic!("{e}"));
    let findings = described(&own_size.report);
    assert!(
        findings.iter().any(|f| f.starts_with(&format!(
            "OMMCHECK-build-triangle-array-in-range pInfos[0].triangleArray: the {} bytes from triangleArray hold {cut} entries"
        , 8 * cut + 3)) && f.contains(&format!("entry {cut} lies past the end"))),
        "{findings:#?}"
    );
}
