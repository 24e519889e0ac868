//! `VK_EXT_opacity_micromap` micromap objects: creation, copies,
//! serialization, property queries, build sizes and compatibility.

use ash::vk;
use serde::{Deserialize, Serialize};

use crate::model::Handle;

pub use crate::model::generated::{
    CopyMemoryToMicromapInfo, CopyMicromapInfo, CopyMicromapToMemoryInfo, MicromapCreateInfo,
};

pub const STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT: i32 =
    vk::StructureType::MICROMAP_CREATE_INFO_EXT.as_raw();
pub const STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT: i32 =
    vk::StructureType::COPY_MICROMAP_INFO_EXT.as_raw();
pub const STRUCTURE_TYPE_COPY_MICROMAP_TO_MEMORY_INFO_EXT: i32 =
    vk::StructureType::COPY_MICROMAP_TO_MEMORY_INFO_EXT.as_raw();
pub const STRUCTURE_TYPE_COPY_MEMORY_TO_MICROMAP_INFO_EXT: i32 =
    vk::StructureType::COPY_MEMORY_TO_MICROMAP_INFO_EXT.as_raw();
pub const STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT: i32 =
    vk::StructureType::MICROMAP_VERSION_INFO_EXT.as_raw();
pub const STRUCTURE_TYPE_MICROMAP_BUILD_SIZES_INFO_EXT: i32 =
    vk::StructureType::MICROMAP_BUILD_SIZES_INFO_EXT.as_raw();

/// `VK_MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT`, the only
/// `VkMicromapCreateFlagBitsEXT` bit.
pub const MICROMAP_CREATE_DEVICE_ADDRESS_CAPTURE_REPLAY_BIT_EXT: u32 =
    vk::MicromapCreateFlagsEXT::DEVICE_ADDRESS_CAPTURE_REPLAY.as_raw();

/// `VkCopyMicromapModeEXT`.
pub const COPY_MICROMAP_MODE_CLONE_EXT: i32 = vk::CopyMicromapModeEXT::CLONE.as_raw();
pub const COPY_MICROMAP_MODE_SERIALIZE_EXT: i32 = vk::CopyMicromapModeEXT::SERIALIZE.as_raw();
pub const COPY_MICROMAP_MODE_DESERIALIZE_EXT: i32 = vk::CopyMicromapModeEXT::DESERIALIZE.as_raw();
pub const COPY_MICROMAP_MODE_COMPACT_EXT: i32 = vk::CopyMicromapModeEXT::COMPACT.as_raw();

/// `VkQueryType` values the micromap commands write.
pub const QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT: i32 =
    vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT.as_raw();
pub const QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT: i32 =
    vk::QueryType::MICROMAP_COMPACTED_SIZE_EXT.as_raw();
pub const QUERY_TYPE_OCCLUSION: i32 = vk::QueryType::OCCLUSION.as_raw();

/// Every `VkQueryType` value of Vulkan 1.4.360 (`vk.xml`), for the
/// `queryType-parameter` rule; ash 0.38 predates some of them.
pub const QUERY_TYPES: [i32; 18] = [
    0,             // OCCLUSION
    1,             // PIPELINE_STATISTICS
    2,             // TIMESTAMP
    1_000_023_000, // RESULT_STATUS_ONLY_KHR
    1_000_028_004, // TRANSFORM_FEEDBACK_STREAM_EXT
    1_000_116_000, // PERFORMANCE_QUERY_KHR
    1_000_150_000, // ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR
    1_000_150_001, // ACCELERATION_STRUCTURE_SERIALIZATION_SIZE_KHR
    1_000_165_000, // ACCELERATION_STRUCTURE_COMPACTED_SIZE_NV
    1_000_173_000, // TIME_ELAPSED_QCOM
    1_000_210_000, // PERFORMANCE_QUERY_INTEL
    1_000_299_000, // VIDEO_ENCODE_FEEDBACK_KHR
    1_000_328_000, // MESH_PRIMITIVES_GENERATED_EXT
    1_000_382_000, // PRIMITIVES_GENERATED_EXT
    1_000_386_000, // ACCELERATION_STRUCTURE_SERIALIZATION_BOTTOM_LEVEL_POINTERS_KHR
    1_000_386_001, // ACCELERATION_STRUCTURE_SIZE_KHR
    1_000_396_000, // MICROMAP_SERIALIZATION_SIZE_EXT
    1_000_396_001, // MICROMAP_COMPACTED_SIZE_EXT
];

/// `VkAccelerationStructureBuildTypeKHR`: HOST, DEVICE, HOST_OR_DEVICE.
pub const ACCELERATION_STRUCTURE_BUILD_TYPES: [i32; 3] = [0, 1, 2];

/// `VK_UUID_SIZE`: `VkMicromapVersionInfoEXT::pVersionData` holds two UUIDs.
pub const UUID_SIZE: usize = 16;

/// `VkAllocationCallbacks`: each function pointer's value, 0 for NULL.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct AllocationCallbacks {
    pub pfn_allocation: u64,
    pub pfn_reallocation: u64,
    pub pfn_free: u64,
    pub pfn_internal_allocation: u64,
    pub pfn_internal_free: u64,
}

impl Default for AllocationCallbacks {
    /// Callbacks with the three required functions set and no internal ones.
    fn default() -> Self {
        Self {
            pfn_allocation: 0xa110c,
            pfn_reallocation: 0x4ea110c,
            pfn_free: 0xf4ee,
            pfn_internal_allocation: 0,
            pfn_internal_free: 0,
        }
    }
}

impl AllocationCallbacks {
    /// What makes the structure invalid, if anything: a required function
    /// that is NULL, or only one of the two internal notifications.
    pub fn defect(&self) -> Option<&'static str> {
        if self.pfn_allocation == 0 {
            Some("pfnAllocation is NULL")
        } else if self.pfn_reallocation == 0 {
            Some("pfnReallocation is NULL")
        } else if self.pfn_free == 0 {
            Some("pfnFree is NULL")
        } else if (self.pfn_internal_allocation == 0) != (self.pfn_internal_free == 0) {
            Some("only one of pfnInternalAllocation and pfnInternalFree is set")
        } else {
            None
        }
    }
}

/// A `micromapCount` with its `pMicromaps`; `None` is a NULL pointer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MicromapList {
    pub count: u32,
    pub handles: Option<Vec<Handle>>,
}

impl MicromapList {
    /// `pMicromaps` pointing at `handles`, `micromapCount` its length.
    pub fn of(handles: Vec<Handle>) -> Self {
        Self {
            count: u32::try_from(handles.len()).unwrap_or(u32::MAX),
            handles: Some(handles),
        }
    }
}

/// `VkMicromapVersionInfoEXT`; `version_data` holds the bytes `pVersionData`
/// points to (`None`: NULL).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MicromapVersionInfo {
    pub s_type: i32,
    pub next: Vec<i32>,
    pub version_data: Option<Vec<u8>>,
}

impl Default for MicromapVersionInfo {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT,
            next: Vec::new(),
            version_data: Some(vec![0; 2 * UUID_SIZE]),
        }
    }
}

/// `VkMicromapBuildSizesInfoEXT` as the application hands it in (its sizes
/// are outputs).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MicromapBuildSizesInfo {
    pub s_type: i32,
    pub next: Vec<i32>,
}

impl Default for MicromapBuildSizesInfo {
    fn default() -> Self {
        Self {
            s_type: STRUCTURE_TYPE_MICROMAP_BUILD_SIZES_INFO_EXT,
            next: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn allocation_callbacks_need_the_three_functions_and_both_or_no_notifications() {
        assert_eq!(AllocationCallbacks::default().defect(), None);
        let no_free = AllocationCallbacks {
            pfn_free: 0,
            ..Default::default()
        };
        assert_eq!(no_free.defect(), Some("pfnFree is NULL"));
        let half_internal = AllocationCallbacks {
            pfn_internal_free: 1,
            ..Default::default()
        };
        assert!(half_internal.defect().is_some());
        let both_internal = AllocationCallbacks {
            pfn_internal_allocation: 1,
            pfn_internal_free: 2,
            ..Default::default()
        };
        assert_eq!(both_internal.defect(), None);
    }

    #[test]
    fn query_types_include_the_micromap_ones() {
        assert!(QUERY_TYPES.contains(&QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT));
        assert!(QUERY_TYPES.contains(&QUERY_TYPE_MICROMAP_COMPACTED_SIZE_EXT));
        assert!(!QUERY_TYPES.contains(&3));
    }
}
