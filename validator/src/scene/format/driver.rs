//! A scene's `driverAnswers`: what the driver answered to the size queries
//! the application made, which rules comparing against those sizes need.

use schemars::JsonSchema;
use serde::Deserialize;

use super::UsageDesc;
use crate::model::names::{self, Value};
use crate::scene::args::HandleArg;

/// What the driver answered; absent, the rules that need an answer are not
/// decided.
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct DriverAnswersDesc {
    /// `vkGetMicromapBuildSizesEXT`'s answers, one per build shape.
    #[serde(default)]
    pub micromap_build_sizes: Vec<MicromapBuildSizesDesc>,
    /// The serialization sizes `VK_QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT`
    /// queries report, one per micromap.
    #[serde(default)]
    pub serialization_sizes: Vec<SerializationSizeDesc>,
    /// `vkGetDeviceMicromapCompatibilityEXT`'s answers, one per version of
    /// serialized data.
    #[serde(default)]
    pub micromap_compatibility: Vec<MicromapCompatibilityDesc>,
}

/// What `vkGetDeviceMicromapCompatibilityEXT` answers for serialized data
/// whose first 2 × VK_UUID_SIZE bytes are `versionData`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct MicromapCompatibilityDesc {
    /// The 32 bytes (driver UUID, then compatibility data), as 64 hex digits.
    pub version_data: String,
    /// True: VK_ACCELERATION_STRUCTURE_COMPATIBILITY_COMPATIBLE_KHR; false:
    /// VK_ACCELERATION_STRUCTURE_COMPATIBILITY_INCOMPATIBLE_KHR.
    pub compatible: bool,
}

/// A micromap's serialization size, as `vkWriteMicromapsPropertiesEXT` or
/// `vkCmdWriteMicromapsPropertiesEXT` report it.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct SerializationSizeDesc {
    /// The micromap, by name.
    pub micromap: HandleArg,
    pub size: u64,
}

/// The `VkMicromapBuildSizesInfoEXT` `vkGetMicromapBuildSizesEXT` returned
/// for builds of one shape: the members of `VkMicromapBuildInfoEXT` it
/// reads (type, flags, usage counts in the build's order), and the sizes.
/// It holds for host and device builds alike.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct MicromapBuildSizesDesc {
    /// Default VK_MICROMAP_TYPE_OPACITY_MICROMAP_EXT.
    #[serde(rename = "type")]
    pub ty: Option<Value<names::MicromapType>>,
    #[serde(default)]
    pub flags: Value<names::BuildMicromapFlags>,
    /// The build's usage counts, as its pUsageCounts or ppUsageCounts lists them.
    pub usage_counts: Vec<UsageDesc>,
    pub micromap_size: u64,
    pub build_scratch_size: u64,
    #[serde(default)]
    pub discardable: bool,
}
