//! Indirect device builds (`vkCmdBuildAccelerationStructuresIndirectKHR`):
//! their build range infos are in device memory, at
//! `pIndirectDeviceAddresses[i] + j × pIndirectStrides[i]`, one
//! `VkAccelerationStructureBuildRangeInfoKHR` per geometry. An adaptor
//! reads those records ([`ReadKind::BuildRanges`]) and, because the ranges
//! decide how far the opacity index buffers and instances reach, those
//! inputs from their start to the end of their buffer
//! ([`Extent::RangesDecide`]). Once the bytes are known the ranges are
//! decoded ([`resolve`]) and the build is checked as a direct build with
//! those ranges is; what the decoded ranges place outside the known bytes
//! is named, for the adaptor to report as not checked.

use super::{geometry_reads, strided_extent, ContentRead, DeviceBuild, Extent, ReadKind};
use crate::model::accel::{index_size, BuildGeometryInfo, BuildRangeInfo, GeometryData};

/// Where one info's build range infos are in device memory:
/// `pIndirectDeviceAddresses[i]` and `pIndirectStrides[i]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IndirectRanges {
    pub address: u64,
    pub stride: u64,
}

/// `VkAccelerationStructureBuildRangeInfoKHR`, in bytes: four `uint32_t`.
pub const RANGE_INFO_SIZE: u64 = 16;

/// What info `i` of an indirect build reads whose extent its range infos
/// decide, with the range infos themselves: the records (one per
/// geometry), each opacity attachment's index buffer and each instances
/// geometry's instances (or pointers) from their start to the end of their
/// buffer.
pub fn indirect_reads(
    i: usize,
    info: &BuildGeometryInfo,
    source: &IndirectRanges,
) -> Vec<ContentRead> {
    let (member, geometries) = info.geometry_entries();
    let mut reads = vec![ContentRead {
        address: source.address,
        extent: strided_extent(geometries.len() as u64, source.stride, RANGE_INFO_SIZE),
        kind: ReadKind::BuildRanges,
        location: format!("pIndirectDeviceAddresses[{i}]"),
    }];
    for (g, geometry) in geometries {
        let at = format!("pInfos[{i}].{member}[{g}].geometry");
        match &geometry.geometry {
            GeometryData::Triangles(triangles) => {
                reads.extend(
                    triangles
                        .opacity_index_buffers()
                        .iter()
                        .filter(|b| index_size(b.index_type).is_some())
                        .map(|b| ContentRead {
                            address: b.address,
                            extent: Extent::RangesDecide,
                            kind: ReadKind::OpacityIndices,
                            location: format!("{at}.triangles.pNext<{}>.indexBuffer", b.structure),
                        }),
                );
            }
            GeometryData::Instances(instances) => reads.push(ContentRead {
                address: instances.data,
                extent: Extent::RangesDecide,
                kind: if instances.array_of_pointers {
                    ReadKind::InstancePointers
                } else {
                    ReadKind::Instances
                },
                location: format!("{at}.instances.data"),
            }),
            _ => {}
        }
    }
    reads
}

/// An indirect build with its range infos decoded, and what could not be
/// read: range infos outside the known bytes, and inputs the decoded
/// ranges reach past them (one sentence each).
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    pub build: DeviceBuild,
    pub unread: Vec<String>,
}

/// Decodes the range infos of indirect build `build` from `read` (device
/// memory as known: `read(address, len)`), None for a build that is not
/// indirect. Each info's ranges are kept only where all its records were
/// read; every count and offset is bounded by the bytes read, so a range
/// pointing anywhere gives a sentence in `unread`, never a large read.
pub fn resolve<'a>(
    build: &DeviceBuild,
    read: impl Fn(u64, u64) -> Option<&'a [u8]>,
) -> Option<Resolved> {
    let DeviceBuild::AccelerationStructures {
        infos,
        ranges,
        indirect: true,
        indirect_ranges,
    } = build
    else {
        return None;
    };
    let mut unread = Vec::new();
    let mut decoded = ranges.clone();
    for (i, (info, source)) in infos.iter().zip(indirect_ranges).enumerate() {
        if decoded.get(i).is_some_and(Option::is_some) {
            continue;
        }
        let count = info.geometry_entries().1.len() as u64;
        let records: Option<Vec<BuildRangeInfo>> = (0..count)
            .map(|j| {
                let address = j
                    .checked_mul(source.stride)
                    .and_then(|at| source.address.checked_add(at))?;
                range_info(read(address, RANGE_INFO_SIZE)?)
            })
            .collect();
        let Some(records) = records else {
            unread.push(format!(
                "the build range infos of pInfos[{i}] ({count} records of {RANGE_INFO_SIZE} bytes at {:#x}, stride {})",
                source.address, source.stride
            ));
            continue;
        };
        for content in geometry_reads(i, info, Some(&records)) {
            if !matches!(
                content.kind,
                ReadKind::OpacityIndices | ReadKind::Instances | ReadKind::InstancePointers
            ) || content.address == 0
            {
                continue;
            }
            let covered = match content.extent {
                Extent::Bytes(0) => true,
                Extent::Bytes(len) => read(content.address, len).is_some(),
                _ => false,
            };
            if !covered {
                let len = match content.extent {
                    Extent::Bytes(1) => "1 byte".into(),
                    Extent::Bytes(len) => format!("{len} bytes"),
                    _ => "more than 2^64 bytes".into(),
                };
                unread.push(format!(
                    "{} ({len} from {:#x}, as the build range infos give them)",
                    content.location, content.address
                ));
            }
        }
        if let Some(slot) = decoded.get_mut(i) {
            *slot = Some(records);
        }
    }
    Some(Resolved {
        build: DeviceBuild::AccelerationStructures {
            infos: infos.clone(),
            ranges: decoded,
            indirect: true,
            indirect_ranges: indirect_ranges.clone(),
        },
        unread,
    })
}

/// One `VkAccelerationStructureBuildRangeInfoKHR` from its 16 bytes.
fn range_info(bytes: &[u8]) -> Option<BuildRangeInfo> {
    let word = |k: usize| -> Option<u32> {
        Some(u32::from_le_bytes(
            bytes.get(k * 4..k * 4 + 4)?.try_into().ok()?,
        ))
    };
    Some(BuildRangeInfo {
        primitive_count: word(0)?,
        primitive_offset: word(1)?,
        first_vertex: word(2)?,
        transform_offset: word(3)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::build_inputs::tests::instances_info;

    fn top_level(address: u64, stride: u64) -> DeviceBuild {
        DeviceBuild::AccelerationStructures {
            infos: vec![instances_info(false, 0x9000)],
            ranges: vec![None],
            indirect: true,
            indirect_ranges: vec![IndirectRanges { address, stride }],
        }
    }

    fn record(count: u32, offset: u32) -> Vec<u8> {
        [count, offset, 0, 0]
            .iter()
            .flat_map(|w| w.to_le_bytes())
            .collect()
    }

    #[test]
    fn the_range_infos_and_the_instances_to_the_buffer_end_are_read() {
        let reads = top_level(0x100, 32).content_reads();
        let shape: Vec<(u64, Extent, ReadKind)> = reads
            .iter()
            .map(|r| (r.address, r.extent, r.kind))
            .collect();
        assert_eq!(
            shape,
            [
                (0x100, Extent::Bytes(16), ReadKind::BuildRanges),
                (0x9000, Extent::RangesDecide, ReadKind::Instances),
            ]
        );
        assert_eq!(reads[0].location, "pIndirectDeviceAddresses[0]");
    }

    /// Device memory holding `ranges` at 0x100 and `instances` at 0x9000.
    fn reader<'a>(ranges: &'a [u8], instances: &'a [u8]) -> impl Fn(u64, u64) -> Option<&'a [u8]> {
        move |address, len| {
            let (base, bytes) = match address {
                0x100..=0x10f => (0x100, ranges),
                0x9000..=0x90bf => (0x9000, instances),
                _ => return None,
            };
            let from = usize::try_from(address - base).ok()?;
            bytes.get(from..from.checked_add(usize::try_from(len).ok()?)?)
        }
    }

    #[test]
    fn decoded_ranges_are_kept_and_reads_past_the_known_bytes_named() {
        let ranges = record(2, 64);
        let instances = vec![0u8; 192];
        let resolved =
            resolve(&top_level(0x100, 16), reader(&ranges, &instances)).expect("indirect");
        let DeviceBuild::AccelerationStructures { ranges: got, .. } = &resolved.build else {
            unreachable!()
        };
        assert_eq!(got[0].as_ref().map(|r| r[0].primitive_count), Some(2));
        assert!(resolved.unread.is_empty(), "{resolved:?}");

        // Three instances from offset 64 reach past the 192 bytes known.
        let ranges = record(3, 64);
        let resolved =
            resolve(&top_level(0x100, 16), reader(&ranges, &instances)).expect("indirect");
        assert_eq!(resolved.unread.len(), 1, "{resolved:?}");
        assert!(resolved.unread[0].starts_with(
            "pInfos[0].pGeometries[0].geometry.instances.data (192 bytes from 0x9040"
        ));

        // Range infos not read: the info keeps no ranges, and says so.
        let resolved = resolve(&top_level(0x200, u64::MAX), |_, _| None).expect("indirect");
        let DeviceBuild::AccelerationStructures { ranges: got, .. } = &resolved.build else {
            unreachable!()
        };
        assert_eq!(got[0], None);
        assert!(resolved.unread[0].starts_with("the build range infos of pInfos[0]"));
        assert!(resolve(&DeviceBuild::Micromaps(Vec::new()), |_, _| None).is_none());
    }

    /// Range infos at their largest place the instances far past anything
    /// read: decoded without a large read or allocation, and named.
    #[test]
    fn absurd_ranges_are_named_not_read() {
        let ranges = record(u32::MAX, u32::MAX);
        let instances = vec![0u8; 192];
        let resolved =
            resolve(&top_level(0x100, 16), reader(&ranges, &instances)).expect("indirect");
        assert_eq!(resolved.unread.len(), 1, "{resolved:?}");
        assert!(
            resolved.unread[0].contains(&format!("{} bytes", u64::from(u32::MAX) * 64)),
            "{resolved:?}"
        );
    }
}
