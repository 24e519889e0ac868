//! `VK_KHR_acceleration_structure` builds as far as micromaps are concerned:
//! KHR opacity micromaps (acceleration structures of type OPACITY_MICROMAP
//! built from a `VkAccelerationStructureGeometryMicromapDataKHR`), and
//! triangle geometry that references a micromap through the EXT or KHR
//! opacity attachment or the NV displacement attachment.

use ash::vk;
use ommcheck_vuids::khr;
use serde::{Deserialize, Serialize};

use crate::model::array_or_pointers::ElementsRead;
use crate::model::Handle;

pub use crate::model::generated::{
    AabbsData, AccelerationStructureCreateInfo, BuildGeometryInfo, BuildRangeInfo,
    CopyAccelerationStructureInfo, CopyAccelerationStructureToMemoryInfo,
    CopyMemoryToAccelerationStructureInfo, Geometry, GeometryData, GeometryMicromapData,
    InstancesData, TrianglesData, TrianglesDisplacementMicromapNv, TrianglesOpacityMicromapExt,
    TrianglesOpacityMicromapKhr,
};

pub const ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL: i32 =
    vk::AccelerationStructureTypeKHR::TOP_LEVEL.as_raw();
pub const ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL: i32 =
    vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL.as_raw();
pub const ACCELERATION_STRUCTURE_TYPE_GENERIC: i32 =
    vk::AccelerationStructureTypeKHR::GENERIC.as_raw();
pub const ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP: i32 =
    khr::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR.as_raw();

pub const GEOMETRY_TYPE_TRIANGLES: i32 = vk::GeometryTypeKHR::TRIANGLES.as_raw();
pub const GEOMETRY_TYPE_AABBS: i32 = vk::GeometryTypeKHR::AABBS.as_raw();
pub const GEOMETRY_TYPE_INSTANCES: i32 = vk::GeometryTypeKHR::INSTANCES.as_raw();
pub const GEOMETRY_TYPE_MICROMAP: i32 = khr::GEOMETRY_TYPE_MICROMAP_KHR.as_raw();

pub const BUILD_ACCELERATION_STRUCTURE_MODE_BUILD: i32 =
    vk::BuildAccelerationStructureModeKHR::BUILD.as_raw();
pub const BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE: i32 =
    vk::BuildAccelerationStructureModeKHR::UPDATE.as_raw();

pub const INDEX_TYPE_UINT16: i32 = vk::IndexType::UINT16.as_raw();
pub const INDEX_TYPE_UINT32: i32 = vk::IndexType::UINT32.as_raw();
pub const INDEX_TYPE_NONE: i32 = vk::IndexType::NONE_KHR.as_raw();
pub const INDEX_TYPE_UINT8: i32 = vk::IndexType::UINT8_EXT.as_raw();

/// Which acceleration-structure build command a build came from; many
/// rules differ only in their VUID.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildCommand {
    /// `vkCmdBuildAccelerationStructuresKHR`
    Cmd,
    /// `vkCmdBuildAccelerationStructuresIndirectKHR`
    Indirect,
    /// `vkBuildAccelerationStructuresKHR` (addresses are host addresses)
    Host,
}

impl BuildCommand {
    pub fn function(self) -> &'static str {
        match self {
            BuildCommand::Cmd => "vkCmdBuildAccelerationStructuresKHR",
            BuildCommand::Indirect => "vkCmdBuildAccelerationStructuresIndirectKHR",
            BuildCommand::Host => "vkBuildAccelerationStructuresKHR",
        }
    }

    /// Whether the command's addresses are host addresses.
    pub fn reads_host_memory(self) -> bool {
        self == BuildCommand::Host
    }
}

/// Bytes of one index of `index_type`; None for NONE and for values that
/// are no index type.
pub fn index_size(index_type: i32) -> Option<u64> {
    match index_type {
        INDEX_TYPE_UINT8 => Some(1),
        INDEX_TYPE_UINT16 => Some(2),
        INDEX_TYPE_UINT32 => Some(4),
        _ => None,
    }
}

pub const STRUCTURE_TYPE_BUILD_GEOMETRY_INFO: i32 =
    vk::StructureType::ACCELERATION_STRUCTURE_BUILD_GEOMETRY_INFO_KHR.as_raw();
pub const STRUCTURE_TYPE_GEOMETRY: i32 =
    vk::StructureType::ACCELERATION_STRUCTURE_GEOMETRY_KHR.as_raw();
pub const STRUCTURE_TYPE_TRIANGLES_DATA: i32 =
    vk::StructureType::ACCELERATION_STRUCTURE_GEOMETRY_TRIANGLES_DATA_KHR.as_raw();
pub const STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA: i32 =
    khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_GEOMETRY_MICROMAP_DATA_KHR.as_raw();
pub const STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_EXT: i32 =
    khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_EXT.as_raw();
pub const STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR: i32 =
    khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_OPACITY_MICROMAP_KHR.as_raw();
pub const STRUCTURE_TYPE_TRIANGLES_DISPLACEMENT_MICROMAP_NV: i32 =
    khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_TRIANGLES_DISPLACEMENT_MICROMAP_NV.as_raw();

impl BuildGeometryInfo {
    /// A build over `geometries` through `pGeometries`.
    pub fn with_geometries(ty: i32, geometries: Vec<Geometry>) -> Self {
        Self {
            ty,
            geometry_count: geometries.len() as u32,
            geometries: Some(geometries),
            ..Self::default()
        }
    }

    /// The member name and the geometries the implementation reads, with
    /// their indices: `pGeometries` when set, else the non-NULL elements of
    /// `ppGeometries`.
    pub fn geometry_entries(&self) -> (&'static str, Vec<(usize, &Geometry)>) {
        (self.geometry_member(), self.geometries_read().collect())
    }

    /// The member the geometries are read from: `pGeometries` when it is
    /// set (or neither is), else `ppGeometries`.
    pub fn geometry_member(&self) -> &'static str {
        if self.geometries.is_none() && self.geometry_pointers.is_some() {
            "ppGeometries"
        } else {
            "pGeometries"
        }
    }

    /// The geometries [`Self::geometry_entries`] lists, without collecting
    /// them (the checks walk them several times per call, and a valid call
    /// should not allocate).
    pub fn geometries_read(&self) -> ElementsRead<'_, Geometry> {
        ElementsRead::new(
            self.geometries.as_deref(),
            self.geometry_pointers.as_deref(),
        )
    }
}

/// An opacity micromap attachment's index buffer: the attachment's
/// structure name, `indexType`, `indexBuffer` and `indexStride`.
pub struct OpacityIndexBuffer {
    pub structure: &'static str,
    pub index_type: i32,
    pub address: u64,
    pub stride: u64,
}

impl TrianglesData {
    /// The index buffers of the EXT and KHR opacity attachments, EXT first.
    pub fn opacity_index_buffers(&self) -> Vec<OpacityIndexBuffer> {
        let ext = self.opacity_ext.as_ref().map(|a| OpacityIndexBuffer {
            structure: "VkAccelerationStructureTrianglesOpacityMicromapEXT",
            index_type: a.index_type,
            address: a.index_buffer,
            stride: a.index_stride,
        });
        let khr = self.opacity_khr.as_ref().map(|a| OpacityIndexBuffer {
            structure: "VkAccelerationStructureTrianglesOpacityMicromapKHR",
            index_type: a.index_type,
            address: a.index_buffer,
            stride: a.index_stride,
        });
        ext.into_iter().chain(khr).collect()
    }
}

/// `VkAccelerationStructureInstanceKHR`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Instance {
    pub transform: [f32; 12],
    pub instance_custom_index: u32,
    pub mask: u8,
    pub instance_shader_binding_table_record_offset: u32,
    /// `VkGeometryInstanceFlagsKHR` (8 bits).
    pub flags: u8,
    /// A device address of, or a handle to, a bottom-level acceleration structure.
    pub acceleration_structure_reference: u64,
}

impl Instance {
    /// Bytes of a `VkAccelerationStructureInstanceKHR`.
    pub const SIZE: usize = 64;

    /// An instance from its 64 bytes as the API lays them out (None when
    /// fewer bytes are given).
    pub fn from_bytes(bytes: &[u8]) -> Option<Instance> {
        let word = |i: usize| -> Option<u32> {
            Some(u32::from_le_bytes(bytes.get(i..i + 4)?.try_into().ok()?))
        };
        let mut transform = [0f32; 12];
        for (k, t) in transform.iter_mut().enumerate() {
            *t = f32::from_bits(word(4 * k)?);
        }
        let custom_and_mask = word(48)?;
        let offset_and_flags = word(52)?;
        let reference = u64::from_le_bytes(bytes.get(56..64)?.try_into().ok()?);
        Some(Instance {
            transform,
            instance_custom_index: custom_and_mask & 0x00ff_ffff,
            mask: (custom_and_mask >> 24) as u8,
            instance_shader_binding_table_record_offset: offset_and_flags & 0x00ff_ffff,
            flags: (offset_and_flags >> 24) as u8,
            acceleration_structure_reference: reference,
        })
    }
}

pub const STRUCTURE_TYPE_GEOMETRY_MOTION_TRIANGLES_DATA_NV: i32 =
    vk::StructureType::ACCELERATION_STRUCTURE_GEOMETRY_MOTION_TRIANGLES_DATA_NV.as_raw();

/// What the original build of an acceleration structure chained to one
/// geometry as `VkAccelerationStructureTrianglesOpacityMicromapKHR`; update
/// builds must chain the same (11625-11629).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum KhrOpacityAttachment {
    /// No such structure (or not a triangles geometry).
    #[default]
    Absent,
    /// The structure with `micromap` VK_NULL_HANDLE.
    NullMicromap,
    /// The structure with this micromap.
    Micromap(Handle),
}

impl KhrOpacityAttachment {
    /// The attachment of one geometry.
    pub fn of(geometry: &Geometry) -> Self {
        match &geometry.geometry {
            GeometryData::Triangles(TrianglesData {
                opacity_khr: Some(khr),
                ..
            }) if khr.micromap == 0 => Self::NullMicromap,
            GeometryData::Triangles(TrianglesData {
                opacity_khr: Some(khr),
                ..
            }) => Self::Micromap(khr.micromap),
            _ => Self::Absent,
        }
    }
}

/// The KHR opacity attachments of an acceleration structure's original
/// (mode BUILD) build, by geometry index.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct OriginalAttachments {
    /// The original build's `flags`.
    pub flags: u32,
    /// Constructed by deserialization (`vkCmdCopyMemoryToAccelerationStructureKHR`)
    /// rather than by the build recorded here.
    pub deserialized: bool,
    pub geometries: Vec<KhrOpacityAttachment>,
}

/// `VkClusterAccelerationStructureIndexFormatFlagBitsNV`.
pub const CLUSTER_INDEX_FORMAT_8BIT_NV: u32 = 0x1;
pub const CLUSTER_INDEX_FORMAT_16BIT_NV: u32 = 0x2;
pub const CLUSTER_INDEX_FORMAT_32BIT_NV: u32 = 0x4;

/// The opacity-micromap members that
/// `VkClusterAccelerationStructureBuildTriangleClusterInfoNV` and
/// `VkClusterAccelerationStructureBuildTriangleClusterTemplateInfoNV` share.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct ClusterTriangleOpacity {
    /// The 4-bit `opacityMicromapIndexType`
    /// (`VkClusterAccelerationStructureIndexFormatFlagBitsNV`).
    pub opacity_micromap_index_type: u32,
    pub opacity_micromap_index_buffer_stride: u16,
    pub opacity_micromap_array: u64,
    pub opacity_micromap_index_buffer: u64,
}

/// `VkClusterAccelerationStructureBuildTriangleClusterInfoNV`: the members
/// the micromap checks read (the rest describe the cluster's geometry).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct ClusterBuildTriangleClusterInfo {
    pub cluster_id: u32,
    /// The 9-bit `triangleCount`.
    pub triangle_count: u32,
    #[serde(flatten)]
    pub opacity: ClusterTriangleOpacity,
}

/// `VkClusterAccelerationStructureBuildTriangleClusterTemplateInfoNV`: the
/// members the micromap checks read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct ClusterBuildTriangleClusterTemplateInfo {
    pub cluster_id: u32,
    /// The 9-bit `triangleCount`.
    pub triangle_count: u32,
    #[serde(flatten)]
    pub opacity: ClusterTriangleOpacity,
}

// Acceleration-structure objects: creation, size queries and copies, as far
// as KHR opacity micromaps (acceleration structures of type OPACITY_MICROMAP)
// are concerned.

pub const STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO: i32 =
    vk::StructureType::ACCELERATION_STRUCTURE_CREATE_INFO_KHR.as_raw();
pub const STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_2: i32 =
    khr::STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_2_KHR.as_raw();
pub const STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_INFO: i32 =
    vk::StructureType::COPY_ACCELERATION_STRUCTURE_INFO_KHR.as_raw();
pub const STRUCTURE_TYPE_COPY_ACCELERATION_STRUCTURE_TO_MEMORY_INFO: i32 =
    vk::StructureType::COPY_ACCELERATION_STRUCTURE_TO_MEMORY_INFO_KHR.as_raw();
pub const STRUCTURE_TYPE_COPY_MEMORY_TO_ACCELERATION_STRUCTURE_INFO: i32 =
    vk::StructureType::COPY_MEMORY_TO_ACCELERATION_STRUCTURE_INFO_KHR.as_raw();

/// sTypes that may extend `VkAccelerationStructureGeometryKHR` (vk.xml of
/// 1.4.360; ash 0.38 predates all but the micromap one, which comes from the
/// generated declarations).
pub const STRUCTURE_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_DATA_AMDX: i32 = 1_000_478_001;
pub const STRUCTURE_TYPE_GEOMETRY_LINEAR_SWEPT_SPHERES_DATA_NV: i32 = 1_000_429_009;
pub const STRUCTURE_TYPE_GEOMETRY_SPHERES_DATA_NV: i32 = 1_000_429_010;

/// `VK_GEOMETRY_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_AMDX` (vk.xml of 1.4.360).
pub const GEOMETRY_TYPE_DENSE_GEOMETRY_FORMAT_TRIANGLES_AMDX: i32 = 1_000_478_000;

/// `VkBuildAccelerationStructureFlagBitsKHR` bits the micromap rules name.
pub const BUILD_ALLOW_COMPACTION: u32 =
    vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION.as_raw();
pub const BUILD_PREFER_FAST_TRACE: u32 =
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE.as_raw();
pub const BUILD_PREFER_FAST_BUILD: u32 =
    vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_BUILD.as_raw();
pub const BUILD_ALLOW_OPACITY_MICROMAP_UPDATE: u32 =
    khr::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR.as_raw();
pub const BUILD_ALLOW_DISABLE_OPACITY_MICROMAPS: u32 =
    khr::BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_BIT_KHR.as_raw();
pub const BUILD_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_EXT: u32 =
    khr::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_BIT_EXT.as_raw();
pub const BUILD_MICROMAP_LOSSY: u32 =
    khr::BUILD_ACCELERATION_STRUCTURE_MICROMAP_LOSSY_BIT_KHR.as_raw();

/// `VkAccelerationStructureCreateFlagBitsKHR` bits the micromap rules name.
pub const CREATE_MOTION_BIT_NV: u32 = vk::AccelerationStructureCreateFlagsKHR::MOTION_NV.as_raw();
pub const CREATE_DESCRIPTOR_BUFFER_CAPTURE_REPLAY_BIT_EXT: u32 =
    vk::AccelerationStructureCreateFlagsKHR::DESCRIPTOR_BUFFER_CAPTURE_REPLAY_EXT.as_raw();

/// `VkAccelerationStructureBuildTypeKHR`.
pub const BUILD_TYPE_HOST: i32 = vk::AccelerationStructureBuildTypeKHR::HOST.as_raw();
pub const BUILD_TYPE_DEVICE: i32 = vk::AccelerationStructureBuildTypeKHR::DEVICE.as_raw();

/// `VkCopyAccelerationStructureModeKHR`.
pub const COPY_MODE_CLONE: i32 = vk::CopyAccelerationStructureModeKHR::CLONE.as_raw();
pub const COPY_MODE_COMPACT: i32 = vk::CopyAccelerationStructureModeKHR::COMPACT.as_raw();
pub const COPY_MODE_SERIALIZE: i32 = vk::CopyAccelerationStructureModeKHR::SERIALIZE.as_raw();
pub const COPY_MODE_DESERIALIZE: i32 = vk::CopyAccelerationStructureModeKHR::DESERIALIZE.as_raw();

/// `VkAccelerationStructureCreateInfo2KHR` (`VK_KHR_device_address_commands`):
/// the structure lives in a device-address range instead of a buffer.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct AccelerationStructureCreateInfo2 {
    pub s_type: i32,
    pub next: Vec<i32>,
    pub create_flags: u32,
    /// `addressRange.address`
    pub address: u64,
    /// `addressRange.size`
    pub size: u64,
    /// `VkAddressCommandFlagsKHR` bits.
    pub address_flags: u32,
    #[serde(rename = "type")]
    pub ty: i32,
}

impl AccelerationStructureCreateInfo2 {
    /// The members of `info`, with no pNext chain (its pointer is not read).
    pub fn from_members(info: &khr::AccelerationStructureCreateInfo2KHR) -> Self {
        Self {
            s_type: info.s_type.as_raw(),
            next: Vec::new(),
            create_flags: info.create_flags.as_raw(),
            address: info.address_range.address,
            size: info.address_range.size,
            address_flags: info.address_flags.as_raw(),
            ty: info.ty.as_raw(),
        }
    }
}

impl Default for AccelerationStructureCreateInfo2 {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_ACCELERATION_STRUCTURE_CREATE_INFO_2,
            next: Vec::new(),
            create_flags: 0,
            address: 0,
            size: 0,
            address_flags: 0,
            ty: ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry(geometry_type: i32) -> Geometry {
        Geometry {
            geometry_type,
            ..Default::default()
        }
    }

    #[test]
    fn geometries_read_prefer_the_array_and_skip_null_pointers() {
        let pointers = BuildGeometryInfo {
            geometry_pointers: Some(vec![Some(geometry(1)), None, Some(geometry(3))]),
            ..Default::default()
        };
        assert_eq!(pointers.geometry_member(), "ppGeometries");
        let read: Vec<_> = pointers
            .geometries_read()
            .map(|(g, geometry)| (g, geometry.geometry_type))
            .collect();
        assert_eq!(read, [(0, 1), (2, 3)]);
        assert_eq!(pointers.geometry_entries().1.len(), 2);

        let both = BuildGeometryInfo {
            geometries: Some(vec![geometry(5)]),
            ..pointers
        };
        assert_eq!(both.geometry_member(), "pGeometries");
        let read: Vec<_> = both
            .geometries_read()
            .map(|(g, geometry)| (g, geometry.geometry_type))
            .collect();
        assert_eq!(read, [(0, 5)]);

        let neither = BuildGeometryInfo::default();
        assert_eq!(neither.geometry_member(), "pGeometries");
        assert_eq!(neither.geometries_read().count(), 0);
    }
}
