//! The feature structures the checks read: their scene form (every
//! `VkBool32` member by its spec name, under the structure's name in a
//! scene's `device.features`), the scene → model resolver, and the reader of
//! a chained structure into the model's flat `Features`
//! (`validator/src/device.rs`), appended to the generated files of
//! [`crate::structs`].
//!
//! vk.xml gives each structure's members and sType; [`FEATURES`] says which
//! members become which field of `Features`, which structures a scene
//! names, and where the ash structure is.

use std::fmt::Write as _;

use crate::registry::VkXml;
use crate::Error;

/// One feature structure.
pub struct FeatureStruct {
    /// The vk.xml name, which a scene uses as the key.
    pub vk: &'static str,
    /// The scene form's Rust name (+ `Desc`) and its member of `FeaturesDesc`.
    pub rust: &'static str,
    pub member: &'static str,
    /// The ash structure (`vk::...<'_>`, or `khr::...` for those ash lacks).
    pub ash: &'static str,
    /// Whether a scene names it; the Vulkan 1.2 and 1.3 structures are read
    /// from an application's chain only.
    pub scene: bool,
    /// Its members the checks read, with the field of `Features` each sets.
    pub fields: &'static [(&'static str, &'static str)],
}

/// Every feature structure, in the order scenes list them.
pub const FEATURES: &[FeatureStruct] = &[
    FeatureStruct {
        vk: "VkPhysicalDeviceOpacityMicromapFeaturesEXT",
        rust: "OpacityMicromapFeaturesExt",
        member: "opacity_micromap_ext",
        ash: "vk::PhysicalDeviceOpacityMicromapFeaturesEXT<'_>",
        scene: true,
        fields: &[
            ("micromap", "micromap_ext"),
            ("micromapCaptureReplay", "micromap_capture_replay"),
            ("micromapHostCommands", "micromap_host_commands"),
        ],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceOpacityMicromapFeaturesKHR",
        rust: "OpacityMicromapFeaturesKhr",
        member: "opacity_micromap_khr",
        ash: "khr::PhysicalDeviceOpacityMicromapFeaturesKHR",
        scene: true,
        fields: &[("micromap", "micromap_khr")],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceDisplacementMicromapFeaturesNV",
        rust: "DisplacementMicromapFeaturesNv",
        member: "displacement_micromap_nv",
        ash: "vk::PhysicalDeviceDisplacementMicromapFeaturesNV<'_>",
        scene: true,
        fields: &[("displacementMicromap", "displacement_micromap")],
    },
    FeatureStruct {
        vk: "VkPhysicalDevicePipelineOpacityMicromapFeaturesARM",
        rust: "PipelineOpacityMicromapFeaturesArm",
        member: "pipeline_opacity_micromap_arm",
        ash: "khr::PhysicalDevicePipelineOpacityMicromapFeaturesARM",
        scene: true,
        fields: &[("pipelineOpacityMicromap", "pipeline_opacity_micromap")],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceAccelerationStructureFeaturesKHR",
        rust: "AccelerationStructureFeatures",
        member: "acceleration_structure",
        ash: "vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'_>",
        scene: true,
        fields: &[
            ("accelerationStructure", "acceleration_structure"),
            (
                "accelerationStructureHostCommands",
                "acceleration_structure_host_commands",
            ),
        ],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceBufferDeviceAddressFeatures",
        rust: "BufferDeviceAddressFeatures",
        member: "buffer_device_address",
        ash: "vk::PhysicalDeviceBufferDeviceAddressFeatures<'_>",
        scene: true,
        fields: &[
            ("bufferDeviceAddress", "buffer_device_address"),
            (
                "bufferDeviceAddressMultiDevice",
                "buffer_device_address_multi_device",
            ),
        ],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceVulkan12Features",
        rust: "Vulkan12Features",
        member: "vulkan12",
        ash: "vk::PhysicalDeviceVulkan12Features<'_>",
        scene: false,
        fields: &[
            ("bufferDeviceAddress", "buffer_device_address"),
            (
                "bufferDeviceAddressMultiDevice",
                "buffer_device_address_multi_device",
            ),
        ],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceVulkan13Features",
        rust: "Vulkan13Features",
        member: "vulkan13",
        ash: "vk::PhysicalDeviceVulkan13Features<'_>",
        scene: false,
        fields: &[("synchronization2", "synchronization2")],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceSynchronization2Features",
        rust: "Synchronization2Features",
        member: "synchronization2",
        ash: "vk::PhysicalDeviceSynchronization2Features<'_>",
        scene: true,
        fields: &[("synchronization2", "synchronization2")],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceIndexTypeUint8Features",
        rust: "IndexTypeUint8Features",
        member: "index_type_uint8",
        ash: "vk::PhysicalDeviceIndexTypeUint8FeaturesKHR<'_>",
        scene: true,
        fields: &[("indexTypeUint8", "index_type_uint8")],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceRayQueryFeaturesKHR",
        rust: "RayQueryFeatures",
        member: "ray_query",
        ash: "vk::PhysicalDeviceRayQueryFeaturesKHR<'_>",
        scene: true,
        fields: &[("rayQuery", "ray_query")],
    },
    FeatureStruct {
        vk: "VkPhysicalDeviceRayTracingPipelineFeaturesKHR",
        rust: "RayTracingPipelineFeatures",
        member: "ray_tracing_pipeline",
        ash: "vk::PhysicalDeviceRayTracingPipelineFeaturesKHR<'_>",
        scene: true,
        fields: &[("rayTracingPipeline", "ray_tracing_pipeline")],
    },
];

/// The structure's `VkBool32` members (every feature it declares) and its
/// sType's value and name.
fn members(vk: &VkXml, spec: &FeatureStruct) -> Result<(Vec<String>, i128, String), Error> {
    let aggregate = vk
        .aggregate(spec.vk)
        .ok_or_else(|| Error::Registry(format!("no structure {}", spec.vk)))?;
    let s_type = aggregate
        .members
        .iter()
        .find(|m| m.name == "sType")
        .and_then(|m| m.values.clone())
        .ok_or_else(|| Error::Registry(format!("{} has no sType", spec.vk)))?;
    let value = crate::structs::value_of(vk, &s_type)
        .ok_or_else(|| Error::Registry(format!("no enum value {s_type}")))?;
    let booleans: Vec<String> = aggregate
        .members
        .iter()
        .filter(|m| m.type_name == "VkBool32" && m.pointers.is_empty())
        .map(|m| m.name.clone())
        .collect();
    for (member, _) in spec.fields {
        if !booleans.iter().any(|b| b == member) {
            return Err(Error::Registry(format!(
                "{} has no VkBool32 member {member}",
                spec.vk
            )));
        }
    }
    Ok((booleans, value, s_type))
}

/// The scene forms, appended to `scene/format/generated.rs`.
pub fn render_scene_form(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::new();
    let mut keyed = String::new();
    for spec in FEATURES.iter().filter(|s| s.scene) {
        let (booleans, _, _) = members(vk, spec)?;
        let _ = writeln!(
            out,
            "/// `{}`: every feature it declares (absent: false).\n\
             #[derive(Debug, Default, Deserialize, Serialize, JsonSchema)]\n\
             #[serde(deny_unknown_fields, rename_all = \"camelCase\")]\npub struct {}Desc {{",
            spec.vk, spec.rust
        );
        for member in &booleans {
            let _ = writeln!(
                out,
                "    #[serde(default)]\n    pub {}: bool,",
                crate::khr::snake_case(member)
            );
        }
        out.push_str("}\n\n");
        let _ = writeln!(
            keyed,
            "    #[serde(rename = \"{}\", default)]\n    pub {}: {}Desc,",
            spec.vk, spec.member, spec.rust
        );
    }
    let _ = write!(
        out,
        "/// Enabled features, keyed by the spec's structure names.\n\
         #[derive(Debug, Default, Deserialize, Serialize, JsonSchema)]\n\
         #[serde(deny_unknown_fields)]\npub struct FeaturesDesc {{\n{keyed}}}\n\n"
    );
    Ok(out)
}

/// The resolver, appended to `scene/resolve/generated.rs`.
pub fn render_resolver() -> String {
    let mut out = String::from(
        "/// The features `d` enables; every feature of `features` the checks read\n\
         /// is set, so those a scene leaves out are disabled.\n\
         pub(in crate::scene) fn features(d: &scene::FeaturesDesc, features: &mut crate::device::Features) {\n",
    );
    for spec in FEATURES.iter().filter(|s| s.scene) {
        for (member, field) in spec.fields {
            let _ = writeln!(
                out,
                "    features.{field} = d.{}.{};",
                spec.member,
                crate::khr::snake_case(member)
            );
        }
    }
    out.push_str("}\n");
    out
}

/// The reader, appended to `raw/generated.rs`.
pub fn render_reader(vk: &VkXml) -> Result<String, Error> {
    let mut out = String::from(
        "/// Sets the features a structure of an application's pNext chain enables\n\
         /// (a feature one structure enables stays enabled); false where `s_type`\n\
         /// is no feature structure the checks read.\n///\n/// # Safety\n\
         /// `address` must point to a structure of the type `s_type` names.\n\
         pub(crate) unsafe fn read_features(s_type: i32, address: *const std::ffi::c_void, \
         features: &mut crate::device::Features) -> bool {\n    match s_type {\n",
    );
    for spec in FEATURES {
        let (_, value, name) = members(vk, spec)?;
        let _ = writeln!(
            out,
            "        // {name}\n        {value} => {{\n            \
             // SAFETY: the caller guarantees `address` points to a {}.\n            \
             let f = unsafe {{ &*address.cast::<{}>() }};",
            spec.vk, spec.ash
        );
        for (member, field) in spec.fields {
            let _ = writeln!(
                out,
                "            features.{field} |= f.{} != vk::FALSE;",
                crate::khr::snake_case(member)
            );
        }
        out.push_str("        }\n");
    }
    out.push_str("        _ => return false,\n    }\n    true\n}\n");
    Ok(out)
}
