//! The state census (`ommcheck stats`, `Validator::micromap_stats`) against
//! a slow census that decodes every micro-triangle one by one with the
//! simulator's `state_at`, over random data, formats, levels, offsets and
//! data that ends early; the referenced weighting against a naive loop over
//! every geometry triangle; and the census of scenes as users see it.

use std::collections::BTreeMap;
use std::sync::Arc;

use ommcheck::inspect::stats::{census, Census, LISTED};
use ommcheck::model::accel::{
    BuildRangeInfo, INDEX_TYPE_NONE, INDEX_TYPE_UINT16, INDEX_TYPE_UINT32, INDEX_TYPE_UINT8,
};
use ommcheck::model::micromap::opacity_triangle_bytes;
use ommcheck::model::values::MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
use ommcheck::model::MicromapTriangle;
use ommcheck::scene::Scene;
use ommcheck::sim::census::StateCounts;
use ommcheck::sim::decode::MicromapContent;
use ommcheck::sim::opacity::{state_at, OpacityState};
use ommcheck::state::{
    AccelerationStructure, Buffer, BuildRecord, Micromap, OpacityAttachmentRecord,
    TriangleGeometryRecord,
};
use ommcheck::{Device, Validator};
use proptest::prelude::*;

/// Per (format name, level): triangles and their stored state counts, and
/// references and their referenced state counts.
type Levels = BTreeMap<(&'static str, u32), (u64, StateCounts, u64, StateCounts)>;

/// The states of entry `entry`'s micro-triangles, decoded one by one; None
/// when the census must not count it (format, level above 12, data past
/// the end).
fn slow_states(entry: &MicromapTriangle, data: &[u8]) -> Option<Vec<OpacityState>> {
    let (format, level) = (u32::from(entry.format), u32::from(entry.subdivision_level));
    if level > 12 {
        return None;
    }
    let size = opacity_triangle_bytes(format, level)? as usize;
    let start = entry.data_offset as usize;
    let block = data.get(start..start.checked_add(size)?)?;
    (0..1u32 << (2 * level))
        .map(|k| state_at(block, format, k))
        .collect()
}

fn format_name(format: u16) -> &'static str {
    if format == 1 {
        "2-state"
    } else {
        "4-state"
    }
}

fn slow_counts(states: &[OpacityState]) -> StateCounts {
    let mut counts = StateCounts::default();
    for state in states {
        *counts.get_mut(*state) += 1;
    }
    counts
}

/// The census of `triangles` over `data`, state by state.
fn slow_census(triangles: &[MicromapTriangle], data: &[u8], weights: &[u64]) -> (Levels, Census) {
    let mut levels = Levels::new();
    let mut out = Census {
        triangles: triangles.len() as u64,
        ..Census::default()
    };
    for (i, entry) in triangles.iter().enumerate() {
        let weight = weights.get(i).copied().unwrap_or(0);
        let Some(states) = slow_states(entry, data) else {
            out.not_counted.triangles += 1;
            if out.not_counted.listed.len() < LISTED {
                out.not_counted.listed.push(i as u64);
            }
            out.references.not_counted += weight;
            continue;
        };
        let counts = slow_counts(&states);
        let level = levels
            .entry((
                format_name(entry.format),
                u32::from(entry.subdivision_level),
            ))
            .or_default();
        level.0 += 1;
        level.1 += counts;
        level.2 += weight;
        for _ in 0..weight {
            level.3 += counts;
        }
        out.counted += 1;
        out.stored += counts;
        out.references.counted += weight;
        if states.iter().all(|s| *s == states[0]) {
            out.uniform.triangles += 1;
            *out.uniform.by_state.get_mut(states[0]) += 1;
            if out.uniform.listed.len() < LISTED {
                out.uniform
                    .listed
                    .push(ommcheck::inspect::stats::UniformTriangle {
                        index: i as u64,
                        state: states[0],
                    });
            }
        }
    }
    (levels, out)
}

fn levels_of(census: &Census) -> Levels {
    census
        .levels
        .iter()
        .map(|l| {
            (
                (l.format, l.level),
                (l.triangles, l.stored, l.references, l.referenced),
            )
        })
        .collect()
}

/// Compares the census with the slow one, member by member.
fn assert_census_matches(
    triangles: &[MicromapTriangle],
    data_start: usize,
    data: Vec<u8>,
    weights: &[u64],
) -> Result<(), TestCaseError> {
    let (slow_levels, slow) =
        slow_census(triangles, data.get(data_start..).unwrap_or(&[]), weights);
    let content = MicromapContent::at(triangles.to_vec(), ommcheck::Bytes::from(data), data_start);
    let fast = census(&content, weights);
    prop_assert_eq!(levels_of(&fast), slow_levels);
    prop_assert_eq!(fast.triangles, slow.triangles);
    prop_assert_eq!(fast.counted, slow.counted);
    prop_assert_eq!(fast.stored, slow.stored);
    prop_assert_eq!(&fast.uniform, &slow.uniform);
    prop_assert_eq!(fast.not_counted.triangles, slow.not_counted.triangles);
    prop_assert_eq!(&fast.not_counted.listed, &slow.not_counted.listed);
    prop_assert_eq!(fast.references.counted, slow.references.counted);
    prop_assert_eq!(fast.references.not_counted, slow.references.not_counted);
    let referenced = fast
        .levels
        .iter()
        .fold(StateCounts::default(), |mut sum, l| {
            sum += l.referenced;
            sum
        });
    prop_assert_eq!(fast.referenced, referenced);
    Ok(())
}

/// Entries of formats 2-state, 4-state and a few invalid ones, levels 0 to
/// 8 and a few above 12, at any byte offset (past the data's end too).
fn entries(data_len: usize) -> impl Strategy<Value = Vec<MicromapTriangle>> {
    let format = prop_oneof![4 => Just(1u16), 4 => Just(2u16), 1 => Just(3u16)];
    let level = prop_oneof![12 => 0u16..=8, 1 => 13u16..=40];
    let offset = 0..(data_len as u32 + 64);
    prop::collection::vec(
        (offset, level, format).prop_map(|(data_offset, subdivision_level, format)| {
            MicromapTriangle {
                data_offset,
                subdivision_level,
                format,
            }
        }),
        0..12,
    )
}

/// Random bytes, with runs of 0x00, 0x55, 0xaa and 0xff so uniform
/// triangles occur.
fn data() -> impl Strategy<Value = Vec<u8>> {
    let byte = prop_oneof![3 => any::<u8>(), 1 => Just(0u8), 1 => Just(0x55u8), 1 => Just(0xaau8), 1 => Just(0xffu8)];
    let run = (byte, 1usize..600).prop_map(|(b, n)| vec![b; n]);
    prop::collection::vec(
        prop_oneof![run, prop::collection::vec(any::<u8>(), 1..64)],
        0..40,
    )
    .prop_map(|runs| runs.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn census_matches_decoding_every_state(
        (data, triangles, start) in data().prop_flat_map(|data| {
            let len = data.len();
            (Just(data), entries(len), 0..=len.min(9))
        }),
        weights in prop::collection::vec(0u64..4, 0..12),
    ) {
        assert_census_matches(&triangles, start, data, &weights)?;
    }
}

/// Triangles laid out as a baker lays them: mostly each right after the
/// one before, in stretches of one format and level (which the census
/// counts as one stream), now and then a gap, a step back, or another
/// format or level; weights mostly alike within a stretch.
fn laid_out_entries() -> impl Strategy<Value = (Vec<MicromapTriangle>, Vec<u64>)> {
    let shape = (prop_oneof![Just(1u16), Just(2u16)], 0u16..=6);
    let next = (
        prop_oneof![6 => Just(0u32), 1 => 1u32..40, 1 => Just(u32::MAX)],
        prop_oneof![5 => Just(false), 1 => Just(true)],
        prop_oneof![5 => Just(None), 1 => (0u64..3).prop_map(Some)],
    );
    (shape.clone(), prop::collection::vec((shape, next), 0..40)).prop_map(|(first, steps)| {
        let (mut shape, mut weight, mut end) = (first, 1u64, 0u32);
        let mut triangles = Vec::new();
        let mut weights = Vec::new();
        for (other_shape, (gap, switch, new_weight)) in steps {
            if switch {
                shape = other_shape;
            }
            weight = new_weight.unwrap_or(weight);
            // u32::MAX: back to the start of the data.
            let data_offset = if gap == u32::MAX { 0 } else { end + gap };
            let (format, subdivision_level) = shape;
            let size = opacity_triangle_bytes(u32::from(format), u32::from(subdivision_level))
                .unwrap_or(1) as u32;
            end = data_offset + size;
            triangles.push(MicromapTriangle {
                data_offset,
                subdivision_level,
                format,
            });
            weights.push(weight);
        }
        (triangles, weights)
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn runs_of_consecutive_triangles_count_as_each_triangle_does(
        (data, (triangles, weights)) in (data(), laid_out_entries()),
    ) {
        assert_census_matches(&triangles, 0, data, &weights)?;
    }
}

/// What one triangle of a long run holds.
#[derive(Clone, Debug)]
enum Block {
    /// Bytes from this seed.
    Random(u64),
    /// Every state alike (0 to 3, masked to the format).
    Uniform(u8),
    /// Uniform but for the byte at this position (modulo the size), flipped
    /// by this mask: the census's quick test lets most of these through.
    AlmostUniform(u8, usize, u8),
}

impl Block {
    fn bytes(&self, format: u16, size: usize) -> Vec<u8> {
        let repeat = |state: u8| {
            if format == 1 {
                (state & 1) * 0xff
            } else {
                (state & 3) * 0x55
            }
        };
        match *self {
            Block::Random(seed) => {
                let mut x = seed | 1;
                (0..size)
                    .map(|_| {
                        x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                        (x >> 56) as u8
                    })
                    .collect()
            }
            Block::Uniform(state) => vec![repeat(state); size],
            Block::AlmostUniform(state, at, flip) => {
                let mut bytes = vec![repeat(state); size];
                bytes[at % size] ^= flip;
                bytes
            }
        }
    }
}

/// A run of 1 to 150 triangles of one format and level (0 to 6), laid one
/// after the other, mostly random with uniform and almost uniform ones
/// among them: long enough for the census's groups of triangles.
fn long_run() -> impl Strategy<Value = (Vec<MicromapTriangle>, Vec<u8>)> {
    let block = prop_oneof![
        4 => any::<u64>().prop_map(Block::Random),
        1 => (0u8..4).prop_map(Block::Uniform),
        1 => (0u8..4, any::<usize>(), 1u8..=255).prop_map(|(s, at, flip)| Block::AlmostUniform(s, at, flip)),
    ];
    (1u16..=2, 0u16..=6, prop::collection::vec(block, 1..150)).prop_map(
        |(format, level, blocks)| {
            let size =
                opacity_triangle_bytes(u32::from(format), u32::from(level)).unwrap_or(1) as usize;
            let data: Vec<u8> = blocks.iter().flat_map(|b| b.bytes(format, size)).collect();
            let triangles = (0..blocks.len())
                .map(|m| MicromapTriangle {
                    data_offset: (m * size) as u32,
                    subdivision_level: level,
                    format,
                })
                .collect();
            (triangles, data)
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn long_runs_find_every_uniform_triangle(
        (triangles, data) in long_run(),
        weight in 0u64..3,
    ) {
        let weights = vec![weight; triangles.len()];
        assert_census_matches(&triangles, 0, data, &weights)?;
    }
}

#[test]
fn level_12_triangles_match_decoding_every_state() {
    // 2 MiB and 4 MiB of pseudo-random bytes (a 64-bit LCG), the 4-state
    // triangle one byte off alignment.
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    let data: Vec<u8> = (0..(6 << 20) + 1)
        .map(|_| {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (x >> 56) as u8
        })
        .collect();
    let triangles = [
        MicromapTriangle {
            data_offset: 0,
            subdivision_level: 12,
            format: 1,
        },
        MicromapTriangle {
            data_offset: (2 << 20) + 1,
            subdivision_level: 12,
            format: 2,
        },
    ];
    assert_census_matches(&triangles, 0, data, &[3, 1]).unwrap();
}

#[test]
fn stride_zero_micromaps_count_one_entry_for_every_triangle() {
    // 2^40 triangles reading one uniformly opaque 4-state level-3 block:
    // counted without visiting each.
    let content = MicromapContent::new(
        vec![MicromapTriangle {
            data_offset: 0,
            subdivision_level: 3,
            format: 2,
        }],
        ommcheck::Bytes::from(vec![0x55u8; 16]),
    )
    .repeating(1 << 40);
    let c = census(&content, &[5]);
    assert_eq!((c.triangles, c.counted), (1 << 40, 1 << 40));
    assert_eq!(c.stored, StateCounts::all(OpacityState::Opaque, 64 << 40));
    assert_eq!(c.referenced, StateCounts::all(OpacityState::Opaque, 5 * 64));
    assert_eq!(c.uniform.triangles, 1 << 40);
    assert_eq!(c.uniform.listed.len(), LISTED);
    assert_eq!(c.uniform.listed[LISTED - 1].index, LISTED as u64 - 1);
}

/// One geometry's opacity attachment: index type, stride, base triangle,
/// triangle count, the index values, and how many bytes of the index
/// buffer the checker knows.
#[derive(Clone, Debug)]
struct AttachmentCase {
    index_type: i32,
    stride: u64,
    base: u32,
    count: u32,
    values: Vec<i64>,
    known_bytes: usize,
}

fn index_size(index_type: i32) -> usize {
    match index_type {
        INDEX_TYPE_UINT8 => 1,
        INDEX_TYPE_UINT16 => 2,
        _ => 4,
    }
}

impl AttachmentCase {
    /// The index buffer's bytes: value `t` at `t · stride`, little-endian
    /// at the index width (-1..-5 as their unsigned casts).
    fn bytes(&self) -> Vec<u8> {
        let size = index_size(self.index_type);
        let stride = self.stride as usize;
        let mut bytes = vec![0u8; stride * self.values.len() + size];
        for (t, value) in self.values.iter().enumerate() {
            let raw = (*value as u64).to_le_bytes();
            bytes[t * stride..t * stride + size].copy_from_slice(&raw[..size]);
        }
        bytes.truncate(self.known_bytes.min(bytes.len()));
        bytes
    }
}

fn attachment_case() -> impl Strategy<Value = AttachmentCase> {
    let index_type = prop_oneof![
        Just(INDEX_TYPE_NONE),
        Just(INDEX_TYPE_UINT8),
        Just(INDEX_TYPE_UINT16),
        Just(INDEX_TYPE_UINT32)
    ];
    (index_type, 0u64..3, 0u32..4, 0u32..24).prop_flat_map(
        |(index_type, stride_kind, base, count)| {
            let size = index_size(index_type) as u64;
            let stride = [0, size, 2 * size + 1][stride_kind as usize];
            let value = prop_oneof![4 => 0i64..14, 1 => -5i64..=-1];
            let values = prop::collection::vec(value, count as usize);
            let known = 0usize..(count as usize * stride as usize + 8);
            (values, known).prop_map(move |(values, known_bytes)| AttachmentCase {
                index_type,
                stride,
                base,
                count,
                values,
                known_bytes,
            })
        },
    )
}

const MICROMAP: u64 = 7;
const BLAS: u64 = 9;

/// A validator that saw `triangles` built over `data` into an EXT micromap
/// and a bottom-level build whose geometries attach it as `attachments` say.
fn world(triangles: &[MicromapTriangle], data: &[u8], attachments: &[AttachmentCase]) -> Validator {
    let mut v = Validator::new(Device::default());
    let state = v.state_mut();
    let mut geometries = Vec::new();
    for (g, case) in attachments.iter().enumerate() {
        let address = 0x10_0000 * (g as u64 + 1);
        let bytes = case.bytes();
        state.buffers.insert(
            100 + g as u64,
            Buffer {
                size: bytes.len() as u64,
                device_address: Some(address),
                contents: Some(ommcheck::Bytes::from(bytes)),
                ..Default::default()
            },
        );
        geometries.push(Some(TriangleGeometryRecord {
            range: Some(BuildRangeInfo {
                primitive_count: case.count,
                ..Default::default()
            }),
            opacity: Some(OpacityAttachmentRecord {
                khr: false,
                index_type: case.index_type,
                index_buffer: address,
                index_stride: case.stride,
                base_triangle: case.base,
                micromap: MICROMAP,
            }),
            ..Default::default()
        }));
    }
    state.micromaps.insert(
        MICROMAP,
        Micromap {
            ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
            built: Some(BuildRecord {
                ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                triangle_count: triangles.len() as u64,
                content: Some(Arc::new(MicromapContent::new(
                    triangles.to_vec(),
                    ommcheck::Bytes::from(data.to_vec()),
                ))),
                ..Default::default()
            }),
            ..Default::default()
        },
    );
    state.acceleration_structures.insert(
        BLAS,
        AccelerationStructure {
            built: Some(BuildRecord {
                geometries,
                ..Default::default()
            }),
            ..Default::default()
        },
    );
    v
}

/// What the naive loop finds: per level the references and referenced
/// counts, and the special, -5, not counted and unread references.
#[derive(Debug, Default, PartialEq, Eq)]
struct NaiveReferences {
    levels: BTreeMap<(&'static str, u32), (u64, StateCounts)>,
    special: StateCounts,
    cluster_skip: u64,
    not_counted: u64,
    unread: u64,
}

/// Every geometry triangle's index read and followed on its own.
fn naive_references(
    triangles: &[MicromapTriangle],
    data: &[u8],
    attachments: &[AttachmentCase],
) -> NaiveReferences {
    let mut out = NaiveReferences::default();
    for case in attachments {
        let bytes = case.bytes();
        let size = index_size(case.index_type);
        let width = 8 * size as u32;
        for t in 0..u64::from(case.count) {
            let m = if case.index_type == INDEX_TYPE_NONE {
                t + u64::from(case.base)
            } else {
                let at = (t * case.stride) as usize;
                let Some(raw) = bytes.get(at..at + size) else {
                    out.unread += 1;
                    continue;
                };
                let value = raw.iter().rev().fold(0u64, |v, b| (v << 8) | u64::from(*b));
                let top = if width == 64 {
                    u64::MAX
                } else {
                    (1u64 << width) - 1
                };
                match top - value {
                    below @ 0..=3 => {
                        let state = [
                            OpacityState::Transparent,
                            OpacityState::Opaque,
                            OpacityState::UnknownTransparent,
                            OpacityState::UnknownOpaque,
                        ][below as usize];
                        *out.special.get_mut(state) += 1;
                        continue;
                    }
                    4 => {
                        out.cluster_skip += 1;
                        continue;
                    }
                    _ => value + u64::from(case.base),
                }
            };
            let states = triangles
                .get(m as usize)
                .and_then(|entry| Some((entry, slow_states(entry, data)?)));
            match states {
                Some((entry, states)) => {
                    let level = out
                        .levels
                        .entry((
                            format_name(entry.format),
                            u32::from(entry.subdivision_level),
                        ))
                        .or_default();
                    level.0 += 1;
                    level.1 += slow_counts(&states);
                }
                None => out.not_counted += 1,
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn referenced_counts_match_a_naive_loop_over_geometry_triangles(
        (data, triangles) in data().prop_flat_map(|data| {
            let len = data.len();
            (Just(data), entries(len))
        }),
        attachments in prop::collection::vec(attachment_case(), 0..4),
    ) {
        let v = world(&triangles, &data, &attachments);
        let report = v.micromap_stats();
        prop_assert_eq!(report.micromaps.len(), 1);
        let stats = &report.micromaps[0];
        prop_assert_eq!(stats.handle, MICROMAP);
        let naive = naive_references(&triangles, &data, &attachments);
        let fast = NaiveReferences {
            levels: stats
                .census
                .levels
                .iter()
                .filter(|l| l.references > 0)
                .map(|l| ((l.format, l.level), (l.references, l.referenced)))
                .collect(),
            special: stats.census.references.special,
            cluster_skip: stats.census.references.cluster_skip,
            not_counted: stats.census.references.not_counted,
            unread: stats.census.references.unread,
        };
        prop_assert_eq!(fast, naive);
        let refs = &stats.census.references;
        prop_assert_eq!(refs.attachments, attachments.len() as u64);
        let geometry_triangles: u64 = attachments.iter().map(|a| u64::from(a.count)).sum();
        prop_assert_eq!(refs.geometry_triangles, geometry_triangles);
        prop_assert_eq!(
            refs.counted + refs.special.total() + refs.cluster_skip + refs.not_counted + refs.unread,
            geometry_triangles
        );
        // The total is this one micromap's census.
        prop_assert_eq!(&report.total.references, refs);
        prop_assert_eq!(report.total.stored, stats.census.stored);
        prop_assert_eq!(report.total.referenced, stats.census.referenced);
    }
}

/// The census of a corpus scene as `ommcheck stats` prints it.
fn scene_stats(path: &str) -> ommcheck::scene::StatsReport {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path);
    let mut report = Scene::load(&path).unwrap().stats().unwrap();
    report.path = path
        .strip_prefix(concat!(env!("CARGO_MANIFEST_DIR"), "/../"))
        .unwrap_or(&path)
        .display()
        .to_string();
    report
}

#[test]
fn the_census_of_scenes_as_users_see_it() {
    for (name, path) in [
        (
            "ext-4state-mixed-levels",
            "tests/scenes/ext-4state-mixed-levels-valid.json",
        ),
        (
            "khr-micromap-blas",
            "tests/scenes/khr-micromap-blas-valid.json",
        ),
    ] {
        let report = scene_stats(path);
        insta::assert_snapshot!(format!("{name}.text"), report.text());
        insta::assert_json_snapshot!(format!("{name}.json"), report);
    }
}

#[test]
fn the_census_counts_what_the_scene_holds() {
    // The 4-state scene's data: level 0 `01` (opaque), level 1 `e4` (one
    // of each), level 2 `1b 55 aa ff` and level 3 `11 33 .. ff 01 23 .. ef`,
    // each referenced once; the other four geometry triangles use -1..-4.
    let report = scene_stats("tests/scenes/ext-4state-mixed-levels-valid.json");
    let census = &report.micromaps[0].stats.census;
    assert_eq!(report.micromaps[0].name.as_deref(), Some("foliage-omm"));
    let level_2 = census.levels.iter().find(|l| l.level == 2).unwrap();
    assert_eq!(level_2.stored.to_array(), [1, 5, 5, 5]);
    assert_eq!(census.stored.total(), 1 + 4 + 16 + 64);
    assert_eq!(census.referenced, census.stored);
    assert_eq!(census.references.special.to_array(), [1, 1, 1, 1]);
    assert_eq!(census.uniform.triangles, 1);
    assert_eq!(census.uniform.listed[0].index, 0);
}

#[test]
fn the_total_adds_every_micromap_and_attachments_naming_none() {
    let opaque_level_1 = |format: u16, byte: u8| {
        MicromapContent::new(
            vec![MicromapTriangle {
                data_offset: 0,
                subdivision_level: 1,
                format,
            }],
            ommcheck::Bytes::from(vec![byte]),
        )
    };
    let built = |content: Option<MicromapContent>, triangle_count: u64| BuildRecord {
        ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
        triangle_count,
        content: content.map(Arc::new),
        ..Default::default()
    };
    let mut v = Validator::new(Device::default());
    let state = v.state_mut();
    // EXT micromap 7: one 2-state level-1 triangle, 3 opaque of 4.
    state.micromaps.insert(
        7,
        Micromap {
            built: Some(built(Some(opaque_level_1(1, 0b0111)), 1)),
            ..Default::default()
        },
    );
    // EXT micromap 8: built, its contents unknown to the checker.
    state.micromaps.insert(
        8,
        Micromap {
            built: Some(built(None, 5)),
            ..Default::default()
        },
    );
    // KHR micromap 10: one 4-state level-1 triangle, all unknown-opaque.
    state.acceleration_structures.insert(
        10,
        AccelerationStructure {
            built: Some(built(Some(opaque_level_1(2, 0xff)), 1)),
            ..Default::default()
        },
    );
    // Index buffer of the attachment naming no micromap: -1, -2 (8-bit).
    state.buffers.insert(
        100,
        Buffer {
            size: 2,
            device_address: Some(0x1000),
            contents: Some(ommcheck::Bytes::from(vec![0xffu8, 0xfe])),
            ..Default::default()
        },
    );
    let attach = |khr, micromap, index_type, count| {
        Some(TriangleGeometryRecord {
            range: Some(BuildRangeInfo {
                primitive_count: count,
                ..Default::default()
            }),
            opacity: Some(OpacityAttachmentRecord {
                khr,
                index_type,
                index_buffer: 0x1000,
                index_stride: 1,
                base_triangle: 0,
                micromap,
            }),
            ..Default::default()
        })
    };
    state.acceleration_structures.insert(
        BLAS,
        AccelerationStructure {
            built: Some(BuildRecord {
                geometries: vec![
                    // Geometry triangles 0 and 1 select micromap triangles 0 and 1: 1 is past the end.
                    attach(false, 7, INDEX_TYPE_NONE, 2),
                    attach(true, 10, INDEX_TYPE_NONE, 1),
                    attach(false, 0, INDEX_TYPE_UINT8, 2),
                    attach(false, 8, INDEX_TYPE_NONE, 3),
                ],
                ..Default::default()
            }),
            ..Default::default()
        },
    );
    let report = v.micromap_stats();
    let kinds: Vec<_> = report
        .micromaps
        .iter()
        .map(|m| (m.handle, m.kind, m.content_known))
        .collect();
    assert_eq!(
        kinds,
        [
            (7, "VkMicromapEXT", true),
            (8, "VkMicromapEXT", false),
            (10, "VkAccelerationStructureKHR", true)
        ]
    );
    let [ext, unknown, khr] = &report.micromaps[..] else {
        panic!("three micromaps");
    };
    assert_eq!(ext.census.stored.to_array(), [1, 3, 0, 0]);
    assert_eq!(ext.census.references.counted, 1);
    assert_eq!(ext.census.references.not_counted, 1);
    assert_eq!((unknown.census.triangles, unknown.census.counted), (5, 0));
    assert_eq!(unknown.census.references.not_counted, 3);
    assert_eq!(khr.census.referenced.to_array(), [0, 0, 0, 4]);
    assert_eq!(
        khr.census.uniform.listed[0].state,
        OpacityState::UnknownOpaque
    );

    let total = &report.total;
    assert_eq!((total.triangles, total.counted), (7, 2));
    assert_eq!(total.stored.to_array(), [1, 3, 0, 4]);
    assert_eq!(total.referenced, total.stored);
    assert_eq!(total.levels.len(), 2);
    assert_eq!(total.uniform.triangles, 1);
    assert!(total.uniform.listed.is_empty());
    let refs = &total.references;
    assert_eq!((refs.attachments, refs.geometry_triangles), (4, 8));
    assert_eq!(refs.special.to_array(), [1, 1, 0, 0]);
    assert_eq!((refs.counted, refs.not_counted), (2, 4));
}
