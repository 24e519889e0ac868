//! Raw values of the Vulkan enums and bits the checks compare against, named
//! as in the specification. Values ash 0.38 has come from ash; the others
//! from the generated `ommcheck_vuids::khr`.

use ash::vk;
use ommcheck_vuids::khr;

pub const MICROMAP_TYPE_OPACITY_MICROMAP_EXT: i32 = vk::MicromapTypeEXT::OPACITY_MICROMAP.as_raw();
pub const MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV: i32 =
    khr::MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV.as_raw();

pub const BUILD_MICROMAP_MODE_BUILD_EXT: i32 = vk::BuildMicromapModeEXT::BUILD.as_raw();

pub const OPACITY_MICROMAP_FORMAT_2_STATE: u32 = 1;
pub const OPACITY_MICROMAP_FORMAT_4_STATE: u32 = 2;

/// `VkDisplacementMicromapFormatNV` values: 64 triangles in 64 bytes, 256 in
/// 128, 1024 in 128.
pub const DISPLACEMENT_MICROMAP_FORMATS_NV: [u32; 3] = [1, 2, 3];

/// `VkBuildMicromapFlagBitsEXT`: PREFER_FAST_TRACE | PREFER_FAST_BUILD | ALLOW_COMPACTION.
pub const BUILD_MICROMAP_FLAGS_ALL: u32 = 0x7;
pub const BUILD_MICROMAP_ALLOW_COMPACTION_BIT_EXT: u32 = 0x4;

pub const BUFFER_USAGE_STORAGE_BUFFER_BIT: u64 =
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw() as u64;
pub const BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT: u64 =
    khr::BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT.as_raw() as u64;
pub const BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT: u64 =
    khr::BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT.as_raw() as u64;
pub const BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR: u64 =
    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw() as u64;
pub const BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR: u64 =
    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR.as_raw() as u64;
pub const BUFFER_CREATE_SPARSE_RESIDENCY_BIT: u32 =
    vk::BufferCreateFlags::SPARSE_RESIDENCY.as_raw();

pub const STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT: i32 =
    vk::StructureType::MICROMAP_BUILD_INFO_EXT.as_raw();
