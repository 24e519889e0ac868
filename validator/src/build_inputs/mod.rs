//! A build's inputs in memory, as an adaptor must read them: where each
//! starts, how far it reaches and what it is (the device-read plan,
//! [`ContentRead`]), the bytes an adaptor could read ([`KnownBytes`]), and
//! a device build as recorded ([`DeviceBuild`]), kept until its memory is
//! read at submission. The checks, the raw reader and the layer all plan
//! their reads from here; an indirect build's ranges, which decide how far
//! some inputs reach, are decoded in [`indirect`].

pub mod indirect;

use crate::model::accel::{
    index_size, BuildCommand, BuildGeometryInfo, BuildRangeInfo, GeometryData, Instance,
    InstancesData,
};
use crate::model::Handle;
use crate::model::{MicromapBuildInfo, MicromapTriangle, UsageCounts};
use crate::state::{HostMemory, State};
use crate::Bytes;
use indirect::IndirectRanges;

/// A device build command as recorded, in the owned model.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceBuild {
    /// `vkCmdBuildMicromapsEXT`'s `pInfos`.
    Micromaps(Vec<MicromapBuildInfo>),
    /// `vkCmdBuildAccelerationStructuresKHR`'s `pInfos` and `ppBuildRangeInfos`,
    /// or (`indirect`) `vkCmdBuildAccelerationStructuresIndirectKHR`'s
    /// `pInfos`, whose ranges are in device memory (None each, until
    /// decoded from the contents: [`indirect::resolve`]).
    AccelerationStructures {
        infos: Vec<BuildGeometryInfo>,
        ranges: Vec<Option<Vec<BuildRangeInfo>>>,
        indirect: bool,
        /// Where each info's range infos are in device memory (indirect
        /// builds; empty for direct ones).
        indirect_ranges: Vec<IndirectRanges>,
    },
}

/// Bytes of one buffer an adaptor could read: `bytes` are the buffer's
/// bytes from `offset` on (a window of it, or all of it from offset 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KnownBytes {
    pub buffer: Handle,
    pub offset: u64,
    pub bytes: Bytes,
}

/// How far a build reads from where a [`ContentRead`] starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extent {
    /// Exactly this many bytes, as the build's parameters give them.
    Bytes(u64),
    /// To the end of the buffer holding the start: micromap `data`, whose
    /// extent only the triangle entries give (and they may be wrong).
    ToBufferEnd,
    /// The parameters give more than 2^64 bytes.
    Overflow,
    /// To the end of the buffer holding the start, because the build
    /// range infos in device memory decide the extent (an indirect
    /// build's opacity indices and instances); an adaptor may cap it.
    RangesDecide,
}

/// What one build input is: the kind decides which reads a host build
/// takes from host memory and which a device build takes from buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadKind {
    /// A micromap build's (or micromap geometry's) `triangleArray`.
    TriangleArray,
    /// A micromap build's (or micromap geometry's) `data`.
    MicromapData,
    /// An opacity attachment's `indexBuffer`.
    OpacityIndices,
    /// A top-level build's instances.
    Instances,
    /// A top-level build's array of instance pointers (`arrayOfPointers`).
    InstancePointers,
    /// An indirect build's range infos (`pIndirectDeviceAddresses[i]`).
    BuildRanges,
}

/// Memory a build's content rules read: where it starts, how far, what it
/// is and which parameter names it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ContentRead {
    pub address: u64,
    pub extent: Extent,
    pub kind: ReadKind,
    pub location: String,
}

/// `VkAccelerationStructureInstanceKHR` and a pointer to one, in bytes.
pub const INSTANCE_SIZE: u64 = 64;
const POINTER_SIZE: u64 = 8;

/// The extent of `count` elements of `size` bytes at `stride`: `(count − 1)
/// × stride + size`; 0 bytes for no elements.
pub fn strided_extent(count: u64, stride: u64, size: u64) -> Extent {
    match count.checked_sub(1) {
        None => Extent::Bytes(0),
        Some(last) => last
            .checked_mul(stride)
            .and_then(|n| n.checked_add(size))
            .map_or(Extent::Overflow, Extent::Bytes),
    }
}

/// What a micromap build (or micromap geometry) at `at` reads: its
/// triangle array, one entry per triangle the usage counts give, and its
/// data to the end of the buffer.
fn micromap_reads(
    usage_counts: &UsageCounts,
    triangle_array: u64,
    stride: u64,
    data: u64,
    at: &str,
) -> [ContentRead; 2] {
    [
        ContentRead {
            address: triangle_array,
            extent: strided_extent(usage_counts.total(), stride, MicromapTriangle::SIZE),
            kind: ReadKind::TriangleArray,
            location: format!("{at}.triangleArray"),
        },
        ContentRead {
            address: data,
            extent: Extent::ToBufferEnd,
            kind: ReadKind::MicromapData,
            location: format!("{at}.data"),
        },
    ]
}

/// What acceleration-structure build info `i` reads: each micromap
/// geometry's triangle array and data, each opacity attachment's indices
/// for its geometry's `primitiveCount`, and each instances geometry's
/// instances (or pointers) from `data + primitiveOffset`. Reads whose
/// extent needs a build range are left out where `ranges` has none.
pub fn geometry_reads(
    i: usize,
    info: &BuildGeometryInfo,
    ranges: Option<&Vec<BuildRangeInfo>>,
) -> Vec<ContentRead> {
    let mut reads = Vec::new();
    let (member, geometries) = info.geometry_entries();
    for (g, geometry) in geometries {
        let at = format!("pInfos[{i}].{member}[{g}]");
        if let Some(m) = &geometry.micromap {
            let data = format!("{at}.pNext<VkAccelerationStructureGeometryMicromapDataKHR>");
            reads.extend(micromap_reads(
                &m.usage_counts,
                m.triangle_array,
                m.triangle_array_stride,
                m.data,
                &data,
            ));
        }
        let Some(range) = ranges.and_then(|r| r.get(g)) else {
            continue;
        };
        let count = u64::from(range.primitive_count);
        match &geometry.geometry {
            GeometryData::Triangles(triangles) => {
                for buffer in triangles.opacity_index_buffers() {
                    let Some(size) = index_size(buffer.index_type) else {
                        continue; // NONE (or not an index type): no index buffer is read.
                    };
                    reads.push(ContentRead {
                        address: buffer.address,
                        extent: strided_extent(count, buffer.stride, size),
                        kind: ReadKind::OpacityIndices,
                        location: format!(
                            "{at}.geometry.triangles.pNext<{}>.indexBuffer",
                            buffer.structure
                        ),
                    });
                }
            }
            GeometryData::Instances(instances) => {
                let (size, kind) = if instances.array_of_pointers {
                    (POINTER_SIZE, ReadKind::InstancePointers)
                } else {
                    (INSTANCE_SIZE, ReadKind::Instances)
                };
                let Some(start) = instances
                    .data
                    .checked_add(u64::from(range.primitive_offset))
                else {
                    continue;
                };
                reads.push(ContentRead {
                    address: start,
                    extent: count
                        .checked_mul(size)
                        .map_or(Extent::Overflow, Extent::Bytes),
                    kind,
                    location: format!("{at}.geometry.instances.data"),
                });
            }
            _ => {}
        }
    }
    reads
}

impl DeviceBuild {
    pub(crate) fn command(indirect: bool) -> BuildCommand {
        if indirect {
            BuildCommand::Indirect
        } else {
            BuildCommand::Cmd
        }
    }

    /// The command that recorded the build.
    pub fn function(&self) -> &'static str {
        match self {
            DeviceBuild::Micromaps(_) => "vkCmdBuildMicromapsEXT",
            DeviceBuild::AccelerationStructures { indirect, .. } => {
                Self::command(*indirect).function()
            }
        }
    }

    /// The inputs whose place the build's parameters do not give (see
    /// [`UnplacedReads`]), by location.
    pub fn unplaced_reads(&self) -> UnplacedReads {
        let mut unplaced = UnplacedReads::default();
        let DeviceBuild::AccelerationStructures {
            infos,
            ranges,
            indirect_ranges,
            ..
        } = self
        else {
            return unplaced;
        };
        for (i, info) in infos.iter().enumerate() {
            let has_ranges =
                ranges.get(i).is_some_and(Option::is_some) || indirect_ranges.get(i).is_some();
            let (member, geometries) = info.geometry_entries();
            for (g, geometry) in geometries {
                let at = format!("pInfos[{i}].{member}[{g}].geometry");
                match &geometry.geometry {
                    GeometryData::Triangles(triangles) if !has_ranges => {
                        unplaced.without_ranges.extend(
                            triangles
                                .opacity_index_buffers()
                                .iter()
                                .filter(|b| b.address != 0 && index_size(b.index_type).is_some())
                                .map(|b| {
                                    format!("{at}.triangles.pNext<{}>.indexBuffer", b.structure)
                                }),
                        );
                    }
                    GeometryData::Instances(instances) if instances.data != 0 && !has_ranges => {
                        unplaced.without_ranges.push(format!("{at}.instances.data"));
                    }
                    _ => {}
                }
            }
        }
        unplaced
    }

    /// The memory the build's content rules read: micromap builds' and
    /// micromap geometries' triangle arrays and data, opacity attachments'
    /// index buffers (an index type of NONE reads none), top-level builds'
    /// instances (or pointers) and indirect builds' range infos (see
    /// [`indirect::indirect_reads`]). NULL addresses and empty
    /// reads are left out: the recording's rules report them.
    pub fn content_reads(&self) -> Vec<ContentRead> {
        let mut reads = Vec::new();
        match self {
            DeviceBuild::Micromaps(infos) => {
                for (i, info) in infos.iter().enumerate() {
                    reads.extend(micromap_reads(
                        &info.usage_counts,
                        info.triangle_array,
                        info.triangle_array_stride,
                        info.data,
                        &format!("pInfos[{i}]"),
                    ));
                }
            }
            DeviceBuild::AccelerationStructures {
                infos,
                ranges,
                indirect_ranges,
                ..
            } => {
                for (i, info) in infos.iter().enumerate() {
                    let info_ranges = ranges.get(i).and_then(Option::as_ref);
                    reads.extend(geometry_reads(i, info, info_ranges));
                    if let (None, Some(source)) = (info_ranges, indirect_ranges.get(i)) {
                        reads.extend(indirect::indirect_reads(i, info, source));
                    }
                }
            }
        }
        reads.retain(|read| read.address != 0 && read.extent != Extent::Bytes(0));
        reads
    }
}

/// Inputs of a device build that the layer cannot learn the place of when
/// the build is recorded, by why.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct UnplacedReads {
    /// Inputs whose extent the build ranges decide, in infos that have
    /// neither ranges nor the address of their range infos in device
    /// memory (an indirect build given fewer `pIndirectDeviceAddresses`
    /// than infos): opacity attachments' index buffers and instances
    /// geometries' instances. (The instances behind an array of pointers
    /// are placed by the pointers' bytes: the adaptor decides whether it
    /// can read those when it must.)
    pub without_ranges: Vec<String>,
}

impl UnplacedReads {
    pub fn is_empty(&self) -> bool {
        self.without_ranges.is_empty()
    }
}

/// The instances of each instances geometry of `infos`, read from the
/// memory the checker knows (host memory the application described for a
/// host build, else the tracked buffers' contents) where it holds them
/// all: `primitiveCount` instances from `data + primitiveOffset`, or as
/// many pointers there and the instance each non-NULL pointer points to.
/// Geometries whose instances are not all readable keep None (their rules
/// are not decided). `host`: the build's addresses are host addresses, in
/// this memory.
pub fn read_instances(
    state: &State,
    infos: &mut [BuildGeometryInfo],
    ranges: &[Option<Vec<BuildRangeInfo>>],
    host: Option<HostMemory<'_>>,
) {
    let read = |address: u64, len: u64| match host {
        Some(host) => host.read(address, len),
        None => state.read_device(address, len),
    };
    for (i, info) in infos.iter_mut().enumerate() {
        let info_ranges = ranges.get(i).and_then(Option::as_ref);
        for (g, geometry) in info.geometries.iter_mut().flatten().enumerate() {
            let GeometryData::Instances(instances) = &mut geometry.geometry else {
                continue;
            };
            let Some(range) = info_ranges.and_then(|r| r.get(g)) else {
                continue;
            };
            instances.instances = instances_from(&read, instances, range);
        }
    }
}

fn instances_from<'a>(
    read: &impl Fn(u64, u64) -> Option<&'a [u8]>,
    instances: &InstancesData,
    range: &BuildRangeInfo,
) -> Option<Vec<Instance>> {
    let start = instances
        .data
        .checked_add(u64::from(range.primitive_offset))?;
    let count = u64::from(range.primitive_count);
    if !instances.array_of_pointers {
        // The bytes exist, so the count they give is bounded by them.
        let bytes = read(start, count.checked_mul(INSTANCE_SIZE)?)?;
        return Some(
            bytes
                .chunks_exact(INSTANCE_SIZE as usize)
                .filter_map(Instance::from_bytes)
                .collect(),
        );
    }
    let pointers = read(start, count.checked_mul(POINTER_SIZE)?)?;
    pointers
        .chunks_exact(POINTER_SIZE as usize)
        .map(|pointer| {
            let address = u64::from_le_bytes(pointer.try_into().ok()?);
            if address == 0 {
                return Some(Instance::default());
            }
            Instance::from_bytes(read(address, INSTANCE_SIZE)?)
        })
        .collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::accel::Geometry;

    /// A top-level info of one instances geometry at device address `data`.
    pub(crate) fn instances_info(pointers: bool, data: u64) -> BuildGeometryInfo {
        BuildGeometryInfo {
            geometry_count: 1,
            geometries: Some(vec![Geometry {
                geometry: GeometryData::Instances(InstancesData {
                    array_of_pointers: pointers,
                    data,
                    ..InstancesData::default()
                }),
                ..Geometry::default()
            }]),
            ..BuildGeometryInfo::default()
        }
    }
}
