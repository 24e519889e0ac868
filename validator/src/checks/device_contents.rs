//! Device builds whose memory contents are read when their command buffer
//! is submitted. A `vkCmdBuild*` command is checked when it is recorded, but
//! the memory it reads (triangle arrays, micromap data, index buffers) is
//! what it holds when the GPU runs the command: an adaptor such as the layer
//! keeps the build's model ([`DeviceBuild`]) and, at submission, hands the
//! bytes it could read back as buffer contents
//! ([`Validator::check_device_build_contents`]), which reports what those
//! contents add to the findings of the recording.

use std::sync::Arc;

use crate::Bytes;

use crate::checks::accel_build::{self, BuildCommand};
use crate::checks::device_indirect::{self, IndirectRanges};
use crate::checks::micromap_build;
use crate::checks::Validator;
use crate::model::accel::index_size;
use crate::model::accel::{
    BuildGeometryInfo, BuildRangeInfo, GeometryData, Instance, InstancesData,
};
use crate::model::Handle;
use crate::model::{CommandBuffer, MicromapBuildInfo, MicromapTriangle, UsageCounts};
use crate::report::Report;
use crate::sim::decode::MicromapContent;
use crate::state::State;

/// A device build command as recorded, in the owned model.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceBuild {
    /// `vkCmdBuildMicromapsEXT`'s `pInfos`.
    Micromaps(Vec<MicromapBuildInfo>),
    /// `vkCmdBuildAccelerationStructuresKHR`'s `pInfos` and `ppBuildRangeInfos`,
    /// or (`indirect`) `vkCmdBuildAccelerationStructuresIndirectKHR`'s
    /// `pInfos`, whose ranges are in device memory (None each, until
    /// decoded from the contents: [`device_indirect::resolve`]).
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
    fn command(indirect: bool) -> BuildCommand {
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
    /// [`device_indirect::indirect_reads`]). NULL addresses and empty
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
                        reads.extend(device_indirect::indirect_reads(i, info, source));
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
/// are not decided).
pub fn read_instances(
    state: &State,
    infos: &mut [BuildGeometryInfo],
    ranges: &[Option<Vec<BuildRangeInfo>>],
    host: bool,
) {
    let read = |address: u64, len: u64| {
        if host {
            state.read_host(address, len)
        } else {
            state.read_device(address, len)
        }
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

impl Validator {
    /// The rules of a recorded device build against the state as it is,
    /// without recording anything; with each micromap info's content as far
    /// as it could be read.
    /// `name_unread`: device memory still unreadable is reported as not
    /// checked (else it is the adaptor's to report).
    fn device_build_rules(
        &self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        name_unread: bool,
    ) -> (Report, Vec<Option<MicromapContent>>) {
        let mut ctx = self.ctx(build.function());
        ctx.device_contents_later = !name_unread;
        let contents = match build {
            DeviceBuild::Micromaps(infos) => {
                // The triangle counts were recorded with the builds.
                let mut triangle_counts = Vec::new();
                micromap_build::cmd_build_micromaps_rules(
                    &mut ctx,
                    command_buffer,
                    infos,
                    &mut triangle_counts,
                )
            }
            DeviceBuild::AccelerationStructures {
                infos,
                ranges,
                indirect,
                ..
            } => {
                // An indirect build's ranges are the GPU's to read: they
                // are known here only once read from device memory.
                let known = !indirect || ranges.iter().any(Option::is_some);
                let ranges = known.then_some(ranges.as_slice());
                accel_build::builds(&mut ctx, DeviceBuild::command(*indirect), infos, ranges);
                Vec::new()
            }
        };
        (ctx.finish(), contents)
    }

    /// Checks what a recorded device build reads, now that `contents` (a
    /// known window of bytes of each buffer, by handle) are known: the
    /// build's rules run with the contents and without, and the findings
    /// only the contents bring are reported (those of the recording were
    /// reported then). Top-level builds' instances are read from the
    /// contents. The contents are forgotten after the check, except what
    /// the builds made: each destination's recorded content (micromap
    /// triangles and data, shared with these bytes) is replaced, so later
    /// builds that attach it see what the GPU built.
    pub fn check_device_build_contents(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
    ) -> Report {
        self.device_build_contents(command_buffer, build, contents, false)
            .0
    }

    /// As [`Validator::check_device_build_contents`], and what an indirect
    /// build's range infos, decoded from `contents`, place outside them
    /// (see [`device_indirect::resolve`]): one sentence per input, for the
    /// adaptor to report as not checked. Empty for other builds.
    pub fn check_device_build_contents_unread(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
    ) -> (Report, Vec<String>) {
        self.device_build_contents(command_buffer, build, contents, false)
    }

    /// As [`Validator::check_device_build_contents`], and the memory of
    /// `build` that `contents` does not cover is reported as not checked
    /// (`OMMCHECK-not-checked-*`, naming the rules it skips), for an adaptor
    /// that does not report unread memory itself.
    pub fn check_device_build_contents_naming_unread(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
    ) -> Report {
        self.device_build_contents(command_buffer, build, contents, true)
            .0
    }

    fn device_build_contents(
        &mut self,
        command_buffer: &CommandBuffer,
        build: &DeviceBuild,
        contents: Vec<KnownBytes>,
        name_unread: bool,
    ) -> (Report, Vec<String>) {
        let mut previous = Vec::with_capacity(contents.len());
        for known in contents {
            if let Some(mut buffer) = self.state.buffers.get_mut(&known.buffer) {
                let old_offset = std::mem::replace(&mut buffer.contents_offset, known.offset);
                previous.push((
                    known.buffer,
                    buffer.contents.replace(known.bytes),
                    old_offset,
                ));
            }
        }
        // Only instances geometries read their instances from the contents:
        // other builds are checked as recorded, without a copy.
        let reads_instances = match build {
            DeviceBuild::AccelerationStructures { infos, .. } => infos.iter().any(|info| {
                info.geometries
                    .iter()
                    .flatten()
                    .any(|g| matches!(g.geometry, GeometryData::Instances(_)))
            }),
            DeviceBuild::Micromaps(_) => false,
        };
        let recorded = build;
        // An indirect build's ranges, decoded from the contents.
        let (resolved, unread) = match device_indirect::resolve(build, |address, len| {
            self.state.read_device(address, len)
        }) {
            Some(resolved) => (Some(resolved.build), resolved.unread),
            None => (None, Vec::new()),
        };
        let build = resolved.as_ref().unwrap_or(build);
        let with_instances;
        let build = match build {
            DeviceBuild::AccelerationStructures {
                infos,
                ranges,
                indirect,
                indirect_ranges,
            } if reads_instances => {
                let mut infos = infos.clone();
                read_instances(&self.state, &mut infos, ranges, false);
                with_instances = DeviceBuild::AccelerationStructures {
                    infos,
                    ranges: ranges.clone(),
                    indirect: *indirect,
                    indirect_ranges: indirect_ranges.clone(),
                };
                &with_instances
            }
            _ => build,
        };
        let (with, micromap_contents) = self.device_build_rules(command_buffer, build, name_unread);
        let built = self.built_contents(build, micromap_contents);
        // Restored in reverse, so a buffer named twice gets its first value back.
        for (handle, old, old_offset) in previous.into_iter().rev() {
            if let Some(mut buffer) = self.state.buffers.get_mut(&handle) {
                buffer.contents = old;
                buffer.contents_offset = old_offset;
            }
        }
        // The findings of the recording (the rules without the contents,
        // which name no unread memory) were reported then. Most builds
        // checked here have no finding at all; only where there are some
        // do the rules run again without the contents to leave those out.
        let findings = if with.findings.is_empty() {
            with.findings
        } else {
            let (without, _) = self.device_build_rules(command_buffer, recorded, false);
            with.findings
                .into_iter()
                .filter(|finding| !without.findings.contains(finding))
                .collect()
        };
        self.record_built_contents(built);
        let report = Report {
            findings,
            checked: with.checked,
        };
        (report, unread)
    }

    /// The content of each destination the build made, where it could be
    /// read from the contents known now: by micromap or acceleration
    /// structure handle.
    fn built_contents(
        &self,
        build: &DeviceBuild,
        micromap_contents: Vec<Option<MicromapContent>>,
    ) -> Vec<(Built, MicromapContent)> {
        match build {
            DeviceBuild::Micromaps(infos) => infos
                .iter()
                .zip(micromap_contents)
                .filter_map(|(info, content)| Some((Built::Micromap(info.dst_micromap), content?)))
                .collect(),
            DeviceBuild::AccelerationStructures { infos, .. } => infos
                .iter()
                .filter_map(|info| {
                    let content = info
                        .geometry_entries()
                        .1
                        .iter()
                        .find_map(|(_, g)| g.micromap.as_ref())
                        .and_then(|data| accel_build::micromap_content(&self.state, false, data))?;
                    Some((Built::Structure(info.dst_acceleration_structure), content))
                })
                .collect(),
        }
    }

    /// Replaces the recorded content of each destination the build made
    /// with what [`Validator::built_contents`] read, so later builds that
    /// attach it see what the GPU built.
    fn record_built_contents(&mut self, built: Vec<(Built, MicromapContent)>) {
        for (destination, content) in built {
            let record = match destination {
                Built::Micromap(handle) => self
                    .state
                    .micromaps
                    .get_mut(&handle)
                    .and_then(|m| m.built.as_mut()),
                Built::Structure(handle) => self
                    .state
                    .acceleration_structures
                    .get_mut(&handle)
                    .and_then(|s| s.built.as_mut()),
            };
            if let Some(record) = record {
                record.content = Some(Arc::new(content));
            }
        }
    }
}

/// A destination a device build made.
#[derive(Clone, Copy, Debug)]
enum Built {
    Micromap(Handle),
    Structure(Handle),
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::model::accel::{
        Geometry, TrianglesData, TrianglesOpacityMicromapExt, INDEX_TYPE_UINT32,
    };
    use crate::state::{Buffer, BuildRecord, Micromap};
    use crate::Device;

    /// A micromap of 2 triangles and a BLAS build whose EXT attachment reads
    /// two 32-bit indices from buffer 7 at device address 0x1000.
    fn validator_and_build() -> (Validator, DeviceBuild) {
        let mut validator = Validator::new(Device::default());
        let state = validator.state_mut();
        state.micromaps.insert(
            5,
            Micromap {
                built: Some(BuildRecord {
                    triangle_count: 2,
                    ..BuildRecord::default()
                }),
                ..Micromap::default()
            },
        );
        state.buffers.insert(
            7,
            Buffer {
                size: 8,
                device_address: Some(0x1000),
                ..Buffer::default()
            },
        );
        let triangles = TrianglesData {
            opacity_ext: Some(TrianglesOpacityMicromapExt {
                index_type: INDEX_TYPE_UINT32,
                index_buffer: 0x1000,
                index_stride: 4,
                micromap: 5,
                ..TrianglesOpacityMicromapExt::default()
            }),
            ..TrianglesData::default()
        };
        let info = BuildGeometryInfo {
            geometry_count: 1,
            geometries: Some(vec![Geometry {
                geometry: GeometryData::Triangles(triangles),
                ..Geometry::default()
            }]),
            ..BuildGeometryInfo::default()
        };
        let ranges = vec![Some(vec![BuildRangeInfo {
            primitive_count: 2,
            ..BuildRangeInfo::default()
        }])];
        let build = DeviceBuild::AccelerationStructures {
            infos: vec![info],
            ranges,
            indirect: false,
            indirect_ranges: Vec::new(),
        };
        (validator, build)
    }

    fn indices(values: [u32; 2]) -> Bytes {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    fn known(buffer: Handle, offset: u64, bytes: Bytes) -> Vec<KnownBytes> {
        vec![KnownBytes {
            buffer,
            offset,
            bytes,
        }]
    }

    #[test]
    fn the_index_buffer_is_read_for_its_primitive_count() {
        let (_, build) = validator_and_build();
        let reads = build.content_reads();
        assert_eq!(reads.len(), 1);
        assert_eq!(reads[0].address, 0x1000);
        assert_eq!(reads[0].extent, Extent::Bytes(8));
        assert_eq!(reads[0].kind, ReadKind::OpacityIndices);
        assert!(reads[0]
            .location
            .ends_with("pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer"));
    }

    #[test]
    fn micromap_builds_read_their_triangle_array_and_data_to_the_buffer_end() {
        let counts = crate::model::UsageCounts::array(vec![crate::model::MicromapUsage {
            count: 3,
            subdivision_level: 0,
            format: 1,
        }]);
        let build = DeviceBuild::Micromaps(vec![MicromapBuildInfo {
            usage_counts: counts,
            triangle_array: 0x2000,
            triangle_array_stride: 12,
            data: 0x3000,
            ..MicromapBuildInfo::default()
        }]);
        let reads = build.content_reads();
        assert_eq!(reads.len(), 2);
        // Two strides and the last entry's 8 bytes.
        assert_eq!(
            (reads[0].address, reads[0].extent),
            (0x2000, Extent::Bytes(32))
        );
        assert_eq!(
            (reads[1].address, reads[1].extent),
            (0x3000, Extent::ToBufferEnd)
        );
        assert_eq!(strided_extent(u64::MAX, u64::MAX, 8), Extent::Overflow);
    }

    /// A top-level info of one instances geometry at device address `data`.
    pub(crate) fn instances_info(pointers: bool, data: u64) -> BuildGeometryInfo {
        BuildGeometryInfo {
            geometry_count: 1,
            geometries: Some(vec![Geometry {
                geometry: GeometryData::Instances(InstancesData {
                    array_of_pointers: pointers,
                    data,
                    instances: None,
                }),
                ..Geometry::default()
            }]),
            ..BuildGeometryInfo::default()
        }
    }

    /// A top-level build of one instances geometry of `count` instances (or
    /// pointers) at device address 0x8000 + 64.
    fn top_level_build(pointers: bool, count: u32) -> DeviceBuild {
        let info = instances_info(pointers, 0x8000);
        DeviceBuild::AccelerationStructures {
            infos: vec![info],
            ranges: vec![Some(vec![BuildRangeInfo {
                primitive_count: count,
                primitive_offset: 64,
                ..BuildRangeInfo::default()
            }])],
            indirect: false,
            indirect_ranges: Vec::new(),
        }
    }

    fn instance_bytes(flags: u8, reference: u64) -> Vec<u8> {
        let mut bytes = vec![0u8; 64];
        bytes[55] = flags;
        bytes[56..].copy_from_slice(&reference.to_le_bytes());
        bytes
    }

    #[test]
    fn instances_are_read_from_the_primitive_offset_and_their_flags_checked() {
        let build = top_level_build(false, 2);
        let reads = build.content_reads();
        assert_eq!(reads.len(), 1);
        assert_eq!(
            (reads[0].address, reads[0].extent),
            (0x8040, Extent::Bytes(128))
        );
        assert_eq!(reads[0].kind, ReadKind::Instances);

        let mut validator = Validator::new(Device::default());
        validator.state_mut().buffers.insert(
            9,
            Buffer {
                size: 256,
                device_address: Some(0x8000),
                ..Buffer::default()
            },
        );
        let cb = CommandBuffer::default();
        // Only the instances' window is known: bytes 64..192 of the buffer.
        let mut window = instance_bytes(0, 0x1);
        window.extend(instance_bytes(0x10, 0x1)); // FORCE_OPACITY_MICROMAP_2_STATE
        let report =
            validator.check_device_build_contents(&cb, &build, known(9, 64, window.into()));
        let found: Vec<(&str, &str)> = report
            .findings
            .iter()
            .map(|f| (f.rule.as_str(), f.location.as_str()))
            .collect();
        assert_eq!(
            found,
            [(
                "VUID-VkAccelerationStructureInstanceKHR-micromap-11580",
                "pInfos[0].pGeometries[0].geometry.instances.data[1].flags"
            )],
            "{report:#?}"
        );
        let valid = instance_bytes(0, 0x1).repeat(2);
        let report = validator.check_device_build_contents(&cb, &build, known(9, 64, valid.into()));
        assert!(report.findings.is_empty(), "{report:#?}");
        // A window that misses the second instance decides nothing.
        let short = instance_bytes(0x10, 0x1);
        let report = validator.check_device_build_contents(&cb, &build, known(9, 64, short.into()));
        assert!(report.findings.is_empty(), "{report:#?}");
    }

    #[test]
    fn instance_pointers_are_followed_into_known_contents() {
        let build = top_level_build(true, 2);
        assert_eq!(build.content_reads()[0].extent, Extent::Bytes(16));
        let mut validator = Validator::new(Device::default());
        validator.state_mut().buffers.insert(
            9,
            Buffer {
                size: 512,
                device_address: Some(0x8000),
                ..Buffer::default()
            },
        );
        // Pointers at 0x8040: NULL and 0x8100; the instance at 0x8100.
        let mut bytes = vec![0u8; 512];
        bytes[72..80].copy_from_slice(&0x8100u64.to_le_bytes());
        bytes[256..320].copy_from_slice(&instance_bytes(0x20, 0x1));
        let cb = CommandBuffer::default();
        let report = validator.check_device_build_contents(&cb, &build, known(9, 0, bytes.into()));
        assert_eq!(
            report
                .findings
                .iter()
                .map(|f| f.location.as_str())
                .collect::<Vec<_>>(),
            ["pInfos[0].pGeometries[0].geometry.instances.data[1].flags"],
            "{report:#?}"
        );
    }

    #[test]
    fn only_findings_the_contents_bring_are_reported_and_contents_are_forgotten() {
        let (mut validator, build) = validator_and_build();
        let cb = CommandBuffer::default();
        let report =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 2])));
        let ids: Vec<&str> = report.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-attach-index-in-range"], "{report:#?}");
        assert_eq!(
            report.findings[0].function,
            "vkCmdBuildAccelerationStructuresKHR"
        );
        assert_eq!(validator.state().buffers[&7].contents, None);

        let valid =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 1])));
        assert!(valid.findings.is_empty(), "{valid:#?}");
    }

    /// A parameter fault the recording reported is not reported again
    /// beside what the contents bring, and not at all when they bring
    /// nothing.
    #[test]
    fn the_recordings_findings_are_not_reported_again() {
        let (mut validator, mut build) = validator_and_build();
        // Both usage-count pointers set (07335), each with no element.
        if let DeviceBuild::AccelerationStructures { infos, .. } = &mut build {
            for geometry in infos[0].geometries.iter_mut().flatten() {
                if let GeometryData::Triangles(t) = &mut geometry.geometry {
                    let counts = &mut t.opacity_ext.as_mut().expect("attached").usage_counts;
                    counts.array = Some(Vec::new());
                    counts.pointers = Some(Vec::new());
                }
            }
        }
        let cb = CommandBuffer::default();
        let recorded = validator.check_device_build_contents(&cb, &build, Vec::new());
        assert!(recorded.findings.is_empty(), "{recorded:#?}");
        let report =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 2])));
        let ids: Vec<&str> = report.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-attach-index-in-range"], "{report:#?}");
        let valid =
            validator.check_device_build_contents(&cb, &build, known(7, 0, indices([0, 1])));
        assert!(valid.findings.is_empty(), "{valid:#?}");
        // The fault is there: the rules report it where nothing filters it.
        let (all, _) = validator.device_build_rules(&cb, &build, false);
        assert!(
            all.findings.iter().any(|f| f.rule.as_str()
                == "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-pUsageCounts-07335"),
            "{all:#?}"
        );
    }

    #[test]
    fn unread_memory_is_named_only_when_asked() {
        let (mut validator, build) = validator_and_build();
        let cb = CommandBuffer::default();
        let silent = validator.check_device_build_contents(&cb, &build, Vec::new());
        assert!(silent.findings.is_empty(), "{silent:#?}");
        let named = validator.check_device_build_contents_naming_unread(&cb, &build, Vec::new());
        let ids: Vec<&str> = named.findings.iter().map(|f| f.rule.as_str()).collect();
        // The index buffer is unread, and micromap 5 is known only by its
        // triangle count.
        assert_eq!(
            ids,
            [
                "OMMCHECK-not-checked-contents",
                "OMMCHECK-not-checked-build-not-seen"
            ],
            "{named:#?}"
        );
        assert!(named.findings[0]
            .not_checked
            .contains(&(&crate::rules::INDEX_IN_RANGE).into()));
        let read = validator.check_device_build_contents_naming_unread(
            &cb,
            &build,
            known(7, 0, indices([0, 1])),
        );
        let ids: Vec<&str> = read.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(ids, ["OMMCHECK-not-checked-build-not-seen"], "{read:#?}");
    }
}
