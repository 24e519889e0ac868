//! Safe inputs for the acceleration-structure build commands
//! (`vkCmdBuildAccelerationStructuresKHR`, `vkBuildAccelerationStructuresKHR`),
//! written with the ash structures a program has.
//!
//! The ash structures hold raw pointers in public fields, which safe code
//! may set to anything, so these entry points never follow them: they read
//! the members that are values (types, flags, handles, addresses as numbers,
//! strides) and take what the pointers would point to as Rust values
//! beside them: the geometries through [`AccelerationStructureBuild`]'s
//! methods, an EXT attachment's usage counts as a slice, the build ranges
//! by value. Every `pNext` is ignored; the attachments a program chains
//! into a triangles geometry are given to [`TrianglesGeometry`] instead.
//! The checks are the ones the raw readers of [`crate::raw`] run: the
//! inputs become the same owned model ([`crate::model::accel`]).
//!
//! ```
//! use ash::vk;
//! use ommcheck::acceleration_builds::{AccelerationStructureBuild, TrianglesGeometry};
//! use ommcheck::fixture::{packed_triangles, usage_counts, Fixture};
//! use ommcheck::model::CommandBuffer;
//!
//! let mut f = Fixture::new();
//! let triangles = packed_triangles(2, 1, vk::OpacityMicromapFormatEXT::TYPE_4_STATE);
//! let micromap = f.micromap(&triangles);
//! let indices = f.input(&[0u32, 1]);
//! let opacity = vk::AccelerationStructureTrianglesOpacityMicromapEXT::default()
//!     .index_type(vk::IndexType::UINT32)
//!     .index_buffer(indices.at(0))
//!     .index_stride(4)
//!     .micromap(micromap);
//! // Indices 0 and 1 use each micromap triangle once: the micromap's own counts.
//! let usage = usage_counts(&triangles);
//! let geometry = TrianglesGeometry::new(&f.vertices(2)).opacity_ext(&opacity, &usage);
//! let range = vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(2);
//! let build = AccelerationStructureBuild::bottom_level(f.blas(), f.scratch()).triangles(geometry, range);
//! let report = f.cmd_build_acceleration_structures_from(&CommandBuffer::default(), &[build]);
//! report.assert_fully_checked();
//! assert!(report.is_empty(), "{report}");
//! ```

use ash::vk;
use ommcheck_vuids::khr;

use crate::checks::Validator;
use crate::model::accel::{
    BuildGeometryInfo, BuildRangeInfo, Geometry, GeometryData, GeometryMicromapData, TrianglesData,
    TrianglesOpacityMicromapExt, TrianglesOpacityMicromapKhr,
    ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
    GEOMETRY_TYPE_MICROMAP, GEOMETRY_TYPE_TRIANGLES,
};
use crate::model::{CommandBuffer, MicromapUsage, UsageCounts};
use crate::raw::accel::{address, scratch_address};
use crate::report::Report;

/// One `VkAccelerationStructureBuildGeometryInfoKHR` with its geometries
/// and its `ppBuildRangeInfos` element, held as values.
#[derive(Clone, Debug, PartialEq)]
pub struct AccelerationStructureBuild {
    info: BuildGeometryInfo,
    /// `ppBuildRangeInfos[i]`: None (NULL) until a geometry brings a range.
    ranges: Option<Vec<BuildRangeInfo>>,
}

impl AccelerationStructureBuild {
    /// The members of `info` that are values: `type`, `flags`, `mode`,
    /// `srcAccelerationStructure`, `dstAccelerationStructure` and
    /// `scratchData` (as a number). Its `pNext`, `geometryCount`,
    /// `pGeometries` and `ppGeometries` are not read: the geometries are
    /// added with [`Self::triangles`], [`Self::micromap_data`] and
    /// [`Self::geometry`], through `pGeometries`.
    pub fn new(info: &vk::AccelerationStructureBuildGeometryInfoKHR<'_>) -> Self {
        Self {
            info: BuildGeometryInfo {
                s_type: info.s_type.as_raw(),
                ty: info.ty.as_raw(),
                flags: info.flags.as_raw(),
                mode: info.mode.as_raw(),
                src_acceleration_structure: vk::Handle::as_raw(info.src_acceleration_structure),
                dst_acceleration_structure: vk::Handle::as_raw(info.dst_acceleration_structure),
                scratch_data: scratch_address(&info.scratch_data),
                geometries: Some(Vec::new()),
                ..BuildGeometryInfo::default()
            },
            ranges: None,
        }
    }

    /// A bottom-level build (mode BUILD) into `dst` with scratch memory at
    /// `scratch` (a device address, or a host address for a host build).
    pub fn bottom_level(dst: vk::AccelerationStructureKHR, scratch: u64) -> Self {
        Self::of_type(ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL, dst, scratch)
    }

    /// A KHR opacity micromap build (type OPACITY_MICROMAP, mode BUILD)
    /// into `dst` with scratch memory at `scratch`; its geometry is added
    /// with [`Self::micromap_data`].
    pub fn opacity_micromap(dst: vk::AccelerationStructureKHR, scratch: u64) -> Self {
        Self::of_type(ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP, dst, scratch)
    }

    fn of_type(ty: i32, dst: vk::AccelerationStructureKHR, scratch: u64) -> Self {
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::from_raw(ty))
            .dst_acceleration_structure(dst)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: scratch,
            });
        Self::new(&info)
    }

    /// Adds a triangles geometry and its build range.
    pub fn triangles(
        self,
        geometry: TrianglesGeometry,
        range: vk::AccelerationStructureBuildRangeInfoKHR,
    ) -> Self {
        let TrianglesGeometry { data, flags } = geometry;
        let geometry = Geometry {
            geometry_type: GEOMETRY_TYPE_TRIANGLES,
            geometry: GeometryData::Triangles(data),
            flags,
            ..Geometry::default()
        };
        self.geometry(geometry, Some(BuildRangeInfo::from_members(&range)))
    }

    /// Adds a micromap geometry (`VK_GEOMETRY_TYPE_MICROMAP_KHR`) with
    /// `data` in its pNext chain: the members of `data` that are values,
    /// and `usage_counts` as its `pUsageCounts` (its own `pNext`,
    /// `usageCountsCount`, `pUsageCounts` and `ppUsageCounts` are not
    /// read). Micromap geometry has no build range (`ppBuildRangeInfos[i]`
    /// stays NULL).
    pub fn micromap_data(
        self,
        data: &khr::AccelerationStructureGeometryMicromapDataKHR,
        usage_counts: &[khr::MicromapUsageKHR],
    ) -> Self {
        let usages = usage_counts
            .iter()
            .map(|u| (u.count, u.subdivision_level, u.format.as_raw() as u32));
        let geometry = Geometry {
            geometry_type: GEOMETRY_TYPE_MICROMAP,
            geometry: GeometryData::None,
            micromap: Some(GeometryMicromapData {
                s_type: data.s_type.as_raw(),
                usage_counts: usage_array(usages),
                data: data.data,
                triangle_array: data.triangle_array,
                triangle_array_stride: data.triangle_array_stride,
                ..GeometryMicromapData::default()
            }),
            ..Geometry::default()
        };
        self.geometry(geometry, None)
    }

    /// Adds a geometry of the owned model (any geometry the API can
    /// express, valid or not) and, where given, its build range.
    pub fn geometry(mut self, geometry: Geometry, range: Option<BuildRangeInfo>) -> Self {
        self.info
            .geometries
            .get_or_insert_with(Vec::new)
            .push(geometry);
        self.info.geometry_count = self.info.geometry_count.saturating_add(1);
        if let Some(range) = range {
            self.ranges.get_or_insert_with(Vec::new).push(range);
        }
        self
    }

    /// The build as the owned model has it, with its build ranges.
    pub fn model(&self) -> (&BuildGeometryInfo, Option<&Vec<BuildRangeInfo>>) {
        (&self.info, self.ranges.as_ref())
    }
}

/// `pUsageCounts` holding `(count, subdivisionLevel, format)` entries.
fn usage_array(usages: impl Iterator<Item = (u32, u32, u32)>) -> UsageCounts {
    UsageCounts::array(
        usages
            .map(|(count, subdivision_level, format)| MicromapUsage {
                count,
                subdivision_level,
                format,
            })
            .collect(),
    )
}

/// A `VkAccelerationStructureGeometryTrianglesDataKHR` and the opacity
/// micromap attachments of its pNext chain, held as values.
#[derive(Clone, Debug, PartialEq)]
pub struct TrianglesGeometry {
    data: TrianglesData,
    /// The geometry's `VkGeometryFlagsKHR`.
    flags: u32,
}

impl TrianglesGeometry {
    /// The members of `triangles` that are values (formats, addresses as
    /// numbers, strides, `maxVertex`); its `pNext` is not read: attachments
    /// are added with [`Self::opacity_ext`] and [`Self::opacity_khr`].
    pub fn new(triangles: &vk::AccelerationStructureGeometryTrianglesDataKHR<'_>) -> Self {
        Self {
            data: TrianglesData {
                s_type: triangles.s_type.as_raw(),
                vertex_format: triangles.vertex_format.as_raw(),
                vertex_data: address(&triangles.vertex_data),
                vertex_stride: triangles.vertex_stride,
                max_vertex: triangles.max_vertex,
                index_type: triangles.index_type.as_raw(),
                index_data: address(&triangles.index_data),
                transform_data: address(&triangles.transform_data),
                ..TrianglesData::default()
            },
            flags: 0,
        }
    }

    /// The geometry's `flags` (`VkAccelerationStructureGeometryKHR::flags`).
    pub fn flags(mut self, flags: vk::GeometryFlagsKHR) -> Self {
        self.flags = flags.as_raw();
        self
    }

    /// Chains a `VkAccelerationStructureTrianglesOpacityMicromapEXT`: the
    /// members of `attachment` that are values, and `usage_counts` as its
    /// `pUsageCounts` (its `pNext`, `usageCountsCount`, `pUsageCounts` and
    /// `ppUsageCounts` are not read).
    pub fn opacity_ext(
        mut self,
        attachment: &vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>,
        usage_counts: &[vk::MicromapUsageEXT],
    ) -> Self {
        let usages = usage_counts
            .iter()
            .map(|u| (u.count, u.subdivision_level, u.format));
        self.data.opacity_ext = Some(TrianglesOpacityMicromapExt {
            s_type: attachment.s_type.as_raw(),
            index_type: attachment.index_type.as_raw(),
            index_buffer: address(&attachment.index_buffer),
            index_stride: attachment.index_stride,
            base_triangle: attachment.base_triangle,
            usage_counts: usage_array(usages),
            micromap: vk::Handle::as_raw(attachment.micromap),
            ..TrianglesOpacityMicromapExt::default()
        });
        self
    }

    /// Chains a `VkAccelerationStructureTrianglesOpacityMicromapKHR`
    /// (its `pNext` is not read).
    pub fn opacity_khr(
        mut self,
        attachment: &khr::AccelerationStructureTrianglesOpacityMicromapKHR,
    ) -> Self {
        self.data.opacity_khr = Some(TrianglesOpacityMicromapKhr {
            s_type: attachment.s_type.as_raw(),
            index_type: attachment.index_type.as_raw(),
            index_buffer: attachment.index_buffer,
            index_stride: attachment.index_stride,
            base_triangle: attachment.base_triangle,
            micromap: vk::Handle::as_raw(attachment.micromap),
            ..TrianglesOpacityMicromapKhr::default()
        });
        self
    }
}

/// The owned model of `builds`: infos and `ppBuildRangeInfos`.
fn models(
    builds: &[AccelerationStructureBuild],
) -> (Vec<BuildGeometryInfo>, Vec<Option<Vec<BuildRangeInfo>>>) {
    builds
        .iter()
        .map(|build| (build.info.clone(), build.ranges.clone()))
        .unzip()
}

impl Validator {
    /// Checks `vkCmdBuildAccelerationStructuresKHR(commandBuffer, infoCount,
    /// pInfos, ppBuildRangeInfos)` with one info per element of `builds`,
    /// as [`Self::cmd_build_acceleration_structures`] (the same checks the
    /// raw reader runs). Safe: no pointer is followed (see
    /// [`crate::acceleration_builds`]).
    pub fn cmd_build_acceleration_structures_from(
        &mut self,
        command_buffer: &CommandBuffer,
        builds: &[AccelerationStructureBuild],
    ) -> Report {
        let (infos, ranges) = models(builds);
        self.cmd_build_acceleration_structures(command_buffer, &infos, &ranges)
    }

    /// Checks `vkBuildAccelerationStructuresKHR(device, deferredOperation,
    /// infoCount, pInfos, ppBuildRangeInfos)` with one info per element of
    /// `builds`, as [`Self::build_acceleration_structures`]. The addresses
    /// are host addresses; the checks read host memory only where it was
    /// described ([`Self::describe_host_memory`]), never through the
    /// addresses themselves.
    pub fn build_acceleration_structures_from(
        &mut self,
        builds: &[AccelerationStructureBuild],
    ) -> Report {
        let (infos, ranges) = models(builds);
        self.build_acceleration_structures(&infos, &ranges)
    }
}
