//! The content tier checks runs of alike triangle-array entries in bulk
//! when the array is tightly packed (stride 8). Whatever the entries, the
//! findings must be those of the same entries at a wider stride, which go
//! through the rules one by one.

use std::collections::BTreeMap;

use ommcheck::model::accel::*;
use ommcheck::model::{MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts};
use ommcheck::{Finding, Tier, Validator};
use proptest::prelude::*;

use crate::fixtures::*;

/// Where the KHR micromap structure lives in the storage buffer.
const OMM_AS: u64 = 0xa1;

/// One kind of entry: alike ones form runs; the others draw findings.
fn template() -> impl Strategy<Value = MicromapTriangle> {
    let entry = |data_offset, subdivision_level, format| MicromapTriangle {
        data_offset,
        subdivision_level,
        format,
    };
    prop_oneof![
        6 => (0u32..3000, 0u16..=3, 1u16..=2).prop_map(move |(o, l, f)| entry(o, l, f)),
        // Above every level limit.
        1 => (0u32..3000, 13u16..=20).prop_map(move |(o, l)| entry(o, l, 2)),
        // No opacity format.
        1 => (0u32..3000, prop_oneof![Just(0u16), Just(3), Just(9)]).prop_map(move |(o, f)| entry(o, 2, f)),
        // Data past the end of the 64 KiB the build reads.
        1 => (65530u32..=65536).prop_map(move |o| entry(o, 2, 2)),
        1 => Just(entry(u32::MAX, 2, 2)),
    ]
}

/// An entry that differs from `alike` in one thing.
fn changed(alike: MicromapTriangle, change: u8) -> MicromapTriangle {
    match change {
        0 => MicromapTriangle {
            data_offset: 65535,
            ..alike
        },
        1 => MicromapTriangle {
            data_offset: u32::MAX,
            ..alike
        },
        2 => MicromapTriangle {
            subdivision_level: alike.subdivision_level + 1,
            ..alike
        },
        3 => MicromapTriangle {
            subdivision_level: 13,
            ..alike
        },
        4 => MicromapTriangle {
            format: 3 - alike.format.min(2),
            ..alike
        },
        _ => MicromapTriangle { format: 9, ..alike },
    }
}

/// Runs of alike entries (offsets 4 bytes apart, kept below the triangle
/// array at 0x1000 so no block reads the array itself), each possibly
/// broken by entries that differ from the run in one thing.
fn entries() -> impl Strategy<Value = Vec<MicromapTriangle>> {
    let breaks = prop::collection::vec((0usize..100, 0u8..6), 0..3);
    let run = (1usize..100, template(), breaks);
    prop::collection::vec(run, 0..5).prop_map(|runs| {
        let mut entries = Vec::new();
        for (length, alike, breaks) in runs {
            for i in 0..length {
                let step = if alike.data_offset < 4000 {
                    4 * i as u32
                } else {
                    0
                };
                let mut entry = MicromapTriangle {
                    data_offset: (alike.data_offset + step) % 4000
                        + alike.data_offset / 4000 * 4000,
                    ..alike
                };
                if let Some((_, change)) = breaks.iter().find(|(at, _)| *at == i) {
                    entry = changed(entry, *change);
                }
                entries.push(entry);
            }
        }
        entries
    })
}

/// The usage counts that describe `entries`.
fn usage_of(entries: &[MicromapTriangle]) -> UsageCounts {
    let mut counts: BTreeMap<(u32, u32), u32> = BTreeMap::new();
    for e in entries {
        *counts
            .entry((u32::from(e.format), u32::from(e.subdivision_level)))
            .or_default() += 1;
    }
    UsageCounts::array(
        counts
            .into_iter()
            .map(|((format, subdivision_level), count)| MicromapUsage {
                count,
                subdivision_level,
                format,
            })
            .collect(),
    )
}

/// A world whose input buffer holds `entries` at `stride` from
/// [`TRIANGLES_OFFSET`], checking at `tier`.
fn world_with_stride(entries: &[MicromapTriangle], stride: usize, tier: Tier) -> Validator {
    let mut v = validator_with(device(), &[]);
    let mut input = v.state_mut().buffers.get_mut(&INPUT).expect("the input");
    let mut bytes = input.contents.as_deref().expect("contents").to_vec();
    for (i, e) in entries.iter().enumerate() {
        let at = TRIANGLES_OFFSET as usize + i * stride;
        bytes[at..at + 8].copy_from_slice(&e.to_bytes());
    }
    input.contents = Some(bytes.into());
    // The guard re-indexes the buffer when dropped; it borrows the validator until then.
    drop(input);
    v.create_acceleration_structure2(
        &AccelerationStructureCreateInfo2 {
            address: STORAGE_ADDRESS + 0x8000,
            size: 0x1000,
            ..Default::default()
        },
        OMM_AS,
    );
    v.set_tier(tier);
    v
}

fn ext_findings(entries: &[MicromapTriangle], stride: usize, tier: Tier) -> Vec<Finding> {
    let mut v = world_with_stride(entries, stride, tier);
    let build = MicromapBuildInfo {
        usage_counts: usage_of(entries),
        triangle_array_stride: stride as u64,
        ..device_build()
    };
    v.cmd_build_micromaps(&command_buffer(), &[build]).findings
}

fn khr_findings(entries: &[MicromapTriangle], stride: usize, tier: Tier) -> Vec<Finding> {
    let mut v = world_with_stride(entries, stride, tier);
    let geometry = Geometry {
        geometry_type: GEOMETRY_TYPE_MICROMAP,
        geometry: GeometryData::None,
        micromap: Some(GeometryMicromapData {
            usage_counts: usage_of(entries),
            data: INPUT_ADDRESS,
            triangle_array: INPUT_ADDRESS + TRIANGLES_OFFSET,
            triangle_array_stride: stride as u64,
            ..Default::default()
        }),
        ..Default::default()
    };
    let build = BuildGeometryInfo {
        dst_acceleration_structure: OMM_AS,
        scratch_data: SCRATCH_ADDRESS,
        ..BuildGeometryInfo::with_geometries(
            ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            vec![geometry],
        )
    };
    v.cmd_build_acceleration_structures(&command_buffer(), &[build], &[None])
        .findings
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn packed_arrays_report_what_entry_by_entry_checks_report(entries in entries()) {
        for tier in [Tier::Content, Tier::Simulate] {
            let packed = ext_findings(&entries, 8, tier);
            prop_assert_eq!(&packed, &ext_findings(&entries, 16, tier), "EXT at {}", tier);
            let packed = khr_findings(&entries, 8, tier);
            prop_assert_eq!(&packed, &khr_findings(&entries, 24, tier), "KHR at {}", tier);
        }
    }
}

/// The generator makes runs long enough for the bulk check, and entries
/// that draw findings inside them.
#[test]
fn long_runs_with_faults_inside_report_each_fault() {
    let mut entries: Vec<MicromapTriangle> = (0..100)
        .map(|i| MicromapTriangle {
            data_offset: 4 * i,
            subdivision_level: 2,
            format: 2,
        })
        .collect();
    // Above the spec-minimum limit (3), with its data still in range.
    entries[40].subdivision_level = 4;
    entries[70].data_offset = 65535;
    for stride in [8, 16] {
        let findings = ext_findings(&entries, stride, Tier::Content);
        let at: Vec<&str> = findings
            .iter()
            .map(|f| f.location.as_str())
            .filter(|at| at.contains("triangleArray["))
            .collect();
        assert_eq!(
            at,
            [
                "pInfos[0].triangleArray[40].subdivisionLevel",
                "pInfos[0].triangleArray[70].dataOffset"
            ],
            "stride {stride}: {findings:#?}"
        );
    }
}
