//! The device a call is checked against: enabled extensions and features,
//! and limits from a profile.

use std::collections::BTreeSet;

use serde::{Deserialize, Serialize};

/// Extension names the checks look at.
pub mod ext {
    pub const EXT_OPACITY_MICROMAP: &str = "VK_EXT_opacity_micromap";
    pub const KHR_OPACITY_MICROMAP: &str = "VK_KHR_opacity_micromap";
    pub const NV_DISPLACEMENT_MICROMAP: &str = "VK_NV_displacement_micromap";
    pub const ARM_PIPELINE_OPACITY_MICROMAP: &str = "VK_ARM_pipeline_opacity_micromap";
    pub const KHR_ACCELERATION_STRUCTURE: &str = "VK_KHR_acceleration_structure";
    pub const KHR_RAY_QUERY: &str = "VK_KHR_ray_query";
    pub const KHR_RAY_TRACING_PIPELINE: &str = "VK_KHR_ray_tracing_pipeline";
    pub const KHR_DEVICE_ADDRESS_COMMANDS: &str = "VK_KHR_device_address_commands";
    pub const KHR_MAINTENANCE5: &str = "VK_KHR_maintenance5";
    pub const KHR_SYNCHRONIZATION2: &str = "VK_KHR_synchronization2";
    pub const EXT_SHADER_OBJECT: &str = "VK_EXT_shader_object";
    pub const NV_CLUSTER_ACCELERATION_STRUCTURE: &str = "VK_NV_cluster_acceleration_structure";
}

/// Enabled features (`VkPhysicalDevice*Features` members) the checks read.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Features {
    /// `VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromap`
    pub micromap_ext: bool,
    /// `VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromapCaptureReplay`
    pub micromap_capture_replay: bool,
    /// `VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromapHostCommands`
    pub micromap_host_commands: bool,
    /// `VkPhysicalDeviceOpacityMicromapFeaturesKHR::micromap`
    pub micromap_khr: bool,
    /// `VkPhysicalDeviceDisplacementMicromapFeaturesNV::displacementMicromap`
    pub displacement_micromap: bool,
    /// `VkPhysicalDevicePipelineOpacityMicromapFeaturesARM::pipelineOpacityMicromap`
    pub pipeline_opacity_micromap: bool,
    /// `VkPhysicalDeviceAccelerationStructureFeaturesKHR::accelerationStructure`
    pub acceleration_structure: bool,
    /// `VkPhysicalDeviceAccelerationStructureFeaturesKHR::accelerationStructureHostCommands`
    pub acceleration_structure_host_commands: bool,
    /// `VkPhysicalDeviceBufferDeviceAddressFeatures::bufferDeviceAddress`
    pub buffer_device_address: bool,
    /// `VkPhysicalDeviceBufferDeviceAddressFeatures::bufferDeviceAddressMultiDevice`
    pub buffer_device_address_multi_device: bool,
    /// `VkPhysicalDeviceSynchronization2Features::synchronization2`
    pub synchronization2: bool,
    /// `VkPhysicalDeviceIndexTypeUint8Features::indexTypeUint8`
    pub index_type_uint8: bool,
    /// `VkPhysicalDeviceRayQueryFeaturesKHR::rayQuery`
    pub ray_query: bool,
    /// `VkPhysicalDeviceRayTracingPipelineFeaturesKHR::rayTracingPipeline`
    pub ray_tracing_pipeline: bool,
}

impl Features {
    /// Every feature enabled.
    pub fn all() -> Self {
        Self {
            micromap_ext: true,
            micromap_capture_replay: true,
            micromap_host_commands: true,
            micromap_khr: true,
            displacement_micromap: true,
            pipeline_opacity_micromap: true,
            acceleration_structure: true,
            acceleration_structure_host_commands: true,
            buffer_device_address: true,
            buffer_device_address_multi_device: true,
            synchronization2: true,
            index_type_uint8: true,
            ray_query: true,
            ray_tracing_pipeline: true,
        }
    }
}

/// Device limits (`VkPhysicalDevice*Properties` members) the checks read.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Limits {
    /// EXT and KHR `maxOpacity2StateSubdivisionLevel`
    pub max_opacity2_state_subdivision_level: u32,
    /// EXT and KHR `maxOpacity4StateSubdivisionLevel`
    pub max_opacity4_state_subdivision_level: u32,
    /// KHR `maxOpacityLossy4StateSubdivisionLevel`
    pub max_opacity_lossy4_state_subdivision_level: u32,
    /// KHR `maxMicromapTriangles`
    pub max_micromap_triangles: u64,
    /// NV `maxDisplacementMicromapSubdivisionLevel`
    pub max_displacement_micromap_subdivision_level: u32,
    /// `VkPhysicalDeviceAccelerationStructurePropertiesKHR::minAccelerationStructureScratchOffsetAlignment`
    pub min_acceleration_structure_scratch_offset_alignment: u32,
}

impl Default for Limits {
    fn default() -> Self {
        Profile::SpecMinimum.limits()
    }
}

/// Built-in limit profiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Profile {
    /// Every limit at the minimum the specification requires of a device
    /// that supports the extension: what portable code may rely on.
    SpecMinimum,
    /// Every limit at the most any API allows (subdivision level 12, 2^32-1
    /// triangles): checks only what no device accepts.
    Permissive,
}

impl Profile {
    pub fn limits(self) -> Limits {
        match self {
            Profile::SpecMinimum => Limits {
                max_opacity2_state_subdivision_level: 3,
                max_opacity4_state_subdivision_level: 3,
                max_opacity_lossy4_state_subdivision_level: 3,
                max_micromap_triangles: 1 << 27,
                max_displacement_micromap_subdivision_level: 3,
                // The largest value the specification allows for this limit
                // (it is a power of two of at most 256), so portable code
                // aligns to it.
                min_acceleration_structure_scratch_offset_alignment: 256,
            },
            Profile::Permissive => Limits {
                max_opacity2_state_subdivision_level: 12,
                max_opacity4_state_subdivision_level: 12,
                max_opacity_lossy4_state_subdivision_level: 12,
                max_micromap_triangles: u64::from(u32::MAX),
                max_displacement_micromap_subdivision_level: 12,
                min_acceleration_structure_scratch_offset_alignment: 1,
            },
        }
    }

    /// The names [`Self::from_name`] accepts.
    pub const NAMES: [&'static str; 2] = ["spec-minimum", "permissive"];

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "spec-minimum" => Some(Profile::SpecMinimum),
            "permissive" => Some(Profile::Permissive),
            _ => None,
        }
    }
}

/// What the checks know about the device.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Device {
    /// Enabled device extensions.
    pub extensions: BTreeSet<String>,
    pub features: Features,
    pub limits: Limits,
    /// Physical devices in the device group (more than one: multi-device rules apply).
    pub physical_device_count: u32,
    /// The `VkDevice` handle calls must name; 0 when unknown (then any
    /// non-NULL handle is taken to be this device).
    pub handle: u64,
    /// Queues the device was created with (Σ `VkDeviceQueueCreateInfo::queueCount`).
    pub queue_count: u32,
}

impl Default for Device {
    fn default() -> Self {
        Self {
            extensions: BTreeSet::new(),
            features: Features::default(),
            limits: Limits::default(),
            physical_device_count: 1,
            handle: 0,
            queue_count: 1,
        }
    }
}

impl Device {
    /// A device with every micromap extension and feature enabled and the
    /// limits of `profile`: the usual starting point of a unit test.
    pub fn with_everything(profile: Profile) -> Self {
        Self {
            extensions: [
                ext::EXT_OPACITY_MICROMAP,
                ext::KHR_OPACITY_MICROMAP,
                ext::NV_DISPLACEMENT_MICROMAP,
                ext::ARM_PIPELINE_OPACITY_MICROMAP,
                ext::KHR_ACCELERATION_STRUCTURE,
                ext::KHR_RAY_QUERY,
                ext::KHR_RAY_TRACING_PIPELINE,
                ext::KHR_DEVICE_ADDRESS_COMMANDS,
                ext::KHR_MAINTENANCE5,
                ext::KHR_SYNCHRONIZATION2,
                ext::EXT_SHADER_OBJECT,
            ]
            .into_iter()
            .map(String::from)
            .collect(),
            features: Features::all(),
            limits: profile.limits(),
            physical_device_count: 1,
            handle: 0,
            queue_count: 1,
        }
    }

    pub fn has_extension(&self, name: &str) -> bool {
        self.extensions.contains(name)
    }

    /// Reads limits from a JSON object with the spec's member names, e.g.
    /// `{"maxOpacity2StateSubdivisionLevel": 12}`; missing members keep the
    /// values of `base`.
    pub fn limits_from_json(base: Profile, json: &str) -> Result<Limits, serde_json::Error> {
        let mut value = serde_json::to_value(base.limits())?;
        let overrides: serde_json::Map<String, serde_json::Value> = serde_json::from_str(json)?;
        if let Some(object) = value.as_object_mut() {
            for (key, v) in overrides {
                if !object.contains_key(&key) {
                    return Err(serde::de::Error::custom(format!("unknown limit `{key}`")));
                }
                object.insert(key, v);
            }
        }
        serde_json::from_value(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_json_overrides_a_profile() {
        let limits = Device::limits_from_json(
            Profile::SpecMinimum,
            r#"{"maxOpacity4StateSubdivisionLevel": 12}"#,
        )
        .unwrap();
        assert_eq!(limits.max_opacity4_state_subdivision_level, 12);
        assert_eq!(limits.max_opacity2_state_subdivision_level, 3);
        assert!(Device::limits_from_json(Profile::SpecMinimum, r#"{"maxBogus": 1}"#).is_err());
    }

    #[test]
    fn profiles_by_name() {
        assert_eq!(
            Profile::from_name("spec-minimum"),
            Some(Profile::SpecMinimum)
        );
        assert_eq!(
            Profile::from_name("permissive")
                .unwrap()
                .limits()
                .max_opacity2_state_subdivision_level,
            12
        );
        assert_eq!(Profile::from_name("x"), None);
        for name in Profile::NAMES {
            assert!(Profile::from_name(name).is_some(), "{name}");
        }
    }
}
