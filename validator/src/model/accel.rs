//! `VK_KHR_acceleration_structure` builds as far as micromaps are concerned:
//! KHR opacity micromaps (acceleration structures of type OPACITY_MICROMAP
//! built from a `VkAccelerationStructureGeometryMicromapDataKHR`), and
//! triangle geometry that references a micromap through the EXT or KHR
//! opacity attachment or the NV displacement attachment.

use ash::vk;
use ommcheck_vuids::khr;
use serde::{Deserialize, Serialize};

use crate::model::micromap::UsageCounts;
use crate::state::Handle;

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

/// `VkAccelerationStructureBuildGeometryInfoKHR`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct BuildGeometryInfo {
    pub s_type: i32,
    /// sTypes of the pNext chain.
    pub next: Vec<i32>,
    #[serde(rename = "type")]
    pub ty: i32,
    /// `VkBuildAccelerationStructureFlagsKHR` bits.
    pub flags: u32,
    pub mode: i32,
    pub src_acceleration_structure: Handle,
    pub dst_acceleration_structure: Handle,
    pub geometry_count: u32,
    /// `pGeometries` (None: NULL).
    pub geometries: Option<Vec<Geometry>>,
    /// `ppGeometries` (None: NULL; an element None: a NULL element).
    pub geometry_pointers: Option<Vec<Option<Geometry>>>,
    /// Device or host address, depending on the command.
    pub scratch_data: u64,
}

impl Default for BuildGeometryInfo {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_BUILD_GEOMETRY_INFO,
            next: Vec::new(),
            ty: ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
            flags: 0,
            mode: BUILD_ACCELERATION_STRUCTURE_MODE_BUILD,
            src_acceleration_structure: 0,
            dst_acceleration_structure: 0,
            geometry_count: 0,
            geometries: None,
            geometry_pointers: None,
            scratch_data: 0,
        }
    }
}

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
        if let Some(list) = &self.geometries {
            ("pGeometries", list.iter().enumerate().collect())
        } else if let Some(list) = &self.geometry_pointers {
            (
                "ppGeometries",
                list.iter()
                    .enumerate()
                    .filter_map(|(i, g)| g.as_ref().map(|g| (i, g)))
                    .collect(),
            )
        } else {
            ("pGeometries", Vec::new())
        }
    }
}

/// `VkAccelerationStructureGeometryKHR`, with the structures its pNext chain
/// and its `geometry` union carry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Geometry {
    pub s_type: i32,
    /// sTypes of pNext structures other than `micromap`.
    pub next: Vec<i32>,
    pub geometry_type: i32,
    /// The union member selected by `geometry_type`.
    pub geometry: GeometryData,
    /// `VkGeometryFlagsKHR` bits.
    pub flags: u32,
    /// `VkAccelerationStructureGeometryMicromapDataKHR` in the pNext chain.
    pub micromap: Option<GeometryMicromapData>,
}

impl Default for Geometry {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_GEOMETRY,
            next: Vec::new(),
            geometry_type: GEOMETRY_TYPE_TRIANGLES,
            geometry: GeometryData::Triangles(TrianglesData::default()),
            flags: 0,
            micromap: None,
        }
    }
}

/// The `geometry` union of `VkAccelerationStructureGeometryKHR`.
// Builds hold a handful of geometries; keeping the triangles inline keeps
// every construction plain.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum GeometryData {
    Triangles(TrianglesData),
    Aabbs(AabbsData),
    Instances(InstancesData),
    /// Nothing is read (micromap geometry uses the pNext structure).
    #[default]
    None,
}

/// `VkAccelerationStructureGeometryTrianglesDataKHR` and the attachments in its pNext chain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct TrianglesData {
    pub s_type: i32,
    /// sTypes of pNext structures other than the attachments below.
    pub next: Vec<i32>,
    pub vertex_format: i32,
    pub vertex_data: u64,
    pub vertex_stride: u64,
    pub max_vertex: u32,
    pub index_type: i32,
    pub index_data: u64,
    pub transform_data: u64,
    pub opacity_ext: Option<TrianglesOpacityMicromapExt>,
    pub opacity_khr: Option<TrianglesOpacityMicromapKhr>,
    pub displacement_nv: Option<TrianglesDisplacementMicromapNv>,
}

impl Default for TrianglesData {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_TRIANGLES_DATA,
            next: Vec::new(),
            vertex_format: vk::Format::R32G32B32_SFLOAT.as_raw(),
            vertex_data: 0,
            vertex_stride: 12,
            max_vertex: 0,
            index_type: INDEX_TYPE_NONE,
            index_data: 0,
            transform_data: 0,
            opacity_ext: None,
            opacity_khr: None,
            displacement_nv: None,
        }
    }
}

/// `VkAccelerationStructureTrianglesOpacityMicromapEXT`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct TrianglesOpacityMicromapExt {
    pub s_type: i32,
    pub next: Vec<i32>,
    pub index_type: i32,
    pub index_buffer: u64,
    pub index_stride: u64,
    pub base_triangle: u32,
    pub usage_counts: UsageCounts,
    pub micromap: Handle,
}

impl Default for TrianglesOpacityMicromapExt {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_EXT,
            next: Vec::new(),
            index_type: INDEX_TYPE_UINT32,
            index_buffer: 0,
            index_stride: 4,
            base_triangle: 0,
            usage_counts: UsageCounts::default(),
            micromap: 0,
        }
    }
}

/// `VkAccelerationStructureTrianglesOpacityMicromapKHR`; `micromap` is an
/// acceleration structure of type OPACITY_MICROMAP.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct TrianglesOpacityMicromapKhr {
    pub s_type: i32,
    pub next: Vec<i32>,
    pub index_type: i32,
    pub index_buffer: u64,
    pub index_stride: u64,
    pub base_triangle: u32,
    pub micromap: Handle,
}

impl Default for TrianglesOpacityMicromapKhr {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR,
            next: Vec::new(),
            index_type: INDEX_TYPE_UINT32,
            index_buffer: 0,
            index_stride: 4,
            base_triangle: 0,
            micromap: 0,
        }
    }
}

/// `VkAccelerationStructureTrianglesDisplacementMicromapNV`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct TrianglesDisplacementMicromapNv {
    pub s_type: i32,
    pub next: Vec<i32>,
    pub displacement_bias_and_scale_format: i32,
    pub displacement_vector_format: i32,
    pub displacement_bias_and_scale_buffer: u64,
    pub displacement_bias_and_scale_stride: u64,
    pub displacement_vector_buffer: u64,
    pub displacement_vector_stride: u64,
    pub displaced_micromap_primitive_flags: u64,
    pub displaced_micromap_primitive_flags_stride: u64,
    pub index_type: i32,
    pub index_buffer: u64,
    pub index_stride: u64,
    pub base_triangle: u32,
    pub usage_counts: UsageCounts,
    pub micromap: Handle,
}

impl Default for TrianglesDisplacementMicromapNv {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_TRIANGLES_DISPLACEMENT_MICROMAP_NV,
            next: Vec::new(),
            displacement_bias_and_scale_format: vk::Format::R16G16_SFLOAT.as_raw(),
            displacement_vector_format: vk::Format::R16G16B16A16_SFLOAT.as_raw(),
            displacement_bias_and_scale_buffer: 0,
            displacement_bias_and_scale_stride: 0,
            displacement_vector_buffer: 0,
            displacement_vector_stride: 0,
            displaced_micromap_primitive_flags: 0,
            displaced_micromap_primitive_flags_stride: 0,
            index_type: INDEX_TYPE_UINT32,
            index_buffer: 0,
            index_stride: 4,
            base_triangle: 0,
            usage_counts: UsageCounts::default(),
            micromap: 0,
        }
    }
}

/// `VkAccelerationStructureGeometryAabbsDataKHR`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct AabbsData {
    pub data: u64,
    pub stride: u64,
}

/// `VkAccelerationStructureGeometryInstancesDataKHR`, with the instances
/// themselves where the checker can read them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct InstancesData {
    pub array_of_pointers: bool,
    pub data: u64,
    /// The instances read from `data` (None: not readable by the checker).
    pub instances: Option<Vec<Instance>>,
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

/// `VkAccelerationStructureGeometryMicromapDataKHR` (in a geometry's pNext
/// chain when `geometryType` is `VK_GEOMETRY_TYPE_MICROMAP_KHR`).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct GeometryMicromapData {
    pub s_type: i32,
    pub next: Vec<i32>,
    pub usage_counts: UsageCounts,
    pub data: u64,
    pub triangle_array: u64,
    pub triangle_array_stride: u64,
}

impl Default for GeometryMicromapData {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_GEOMETRY_MICROMAP_DATA,
            next: Vec::new(),
            usage_counts: UsageCounts::default(),
            data: 0,
            triangle_array: 0,
            triangle_array_stride: 8,
        }
    }
}

/// `VkAccelerationStructureBuildRangeInfoKHR`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct BuildRangeInfo {
    pub primitive_count: u32,
    pub primitive_offset: u32,
    pub first_vertex: u32,
    pub transform_offset: u32,
}
