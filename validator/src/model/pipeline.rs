//! Synchronization, pipelines, shaders, the commands that run them, and the
//! micromap feature and property structures, as far as micromaps are
//! concerned. Stage, access and create flags keep their raw 64-bit values.

use ash::vk;
use ommcheck_vuids::khr;
use serde::{Deserialize, Serialize};

use crate::model::Handle;

pub const STAGE_MICROMAP_BUILD: u64 = khr::PIPELINE_STAGE_2_MICROMAP_BUILD_BIT_EXT.as_raw();
pub const STAGE_ACCELERATION_STRUCTURE_BUILD: u64 =
    vk::PipelineStageFlags2::ACCELERATION_STRUCTURE_BUILD_KHR.as_raw();
pub const STAGE_ALL_GRAPHICS: u64 = vk::PipelineStageFlags2::ALL_GRAPHICS.as_raw();
pub const STAGE_ALL_COMMANDS: u64 = vk::PipelineStageFlags2::ALL_COMMANDS.as_raw();
/// Every `VK_PIPELINE_STAGE_2_*_SHADER_BIT` (and `PRE_RASTERIZATION_SHADERS`).
pub const STAGES_SHADER: u64 = vk::PipelineStageFlags2::VERTEX_SHADER.as_raw()
    | vk::PipelineStageFlags2::TESSELLATION_CONTROL_SHADER.as_raw()
    | vk::PipelineStageFlags2::TESSELLATION_EVALUATION_SHADER.as_raw()
    | vk::PipelineStageFlags2::GEOMETRY_SHADER.as_raw()
    | vk::PipelineStageFlags2::FRAGMENT_SHADER.as_raw()
    | vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw()
    | vk::PipelineStageFlags2::PRE_RASTERIZATION_SHADERS.as_raw()
    | vk::PipelineStageFlags2::RAY_TRACING_SHADER_KHR.as_raw()
    | vk::PipelineStageFlags2::TASK_SHADER_EXT.as_raw()
    | vk::PipelineStageFlags2::MESH_SHADER_EXT.as_raw()
    | vk::PipelineStageFlags2::SUBPASS_SHADER_HUAWEI.as_raw()
    | vk::PipelineStageFlags2::CLUSTER_CULLING_SHADER_HUAWEI.as_raw();

pub const ACCESS_SHADER_READ: u64 = vk::AccessFlags2::SHADER_READ.as_raw();
pub const ACCESS_MICROMAP_READ: u64 = khr::ACCESS_2_MICROMAP_READ_BIT_EXT.as_raw();
pub const ACCESS_MICROMAP_WRITE: u64 = khr::ACCESS_2_MICROMAP_WRITE_BIT_EXT.as_raw();

/// `VK_PIPELINE_CREATE(_2)_RAY_TRACING_OPACITY_MICROMAP_BIT_{EXT,KHR}` (one bit).
pub const CREATE_RAY_TRACING_OPACITY_MICROMAP: u64 =
    khr::PIPELINE_CREATE_2_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR.as_raw();
pub const CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_NV: u64 =
    khr::PIPELINE_CREATE_2_RAY_TRACING_DISPLACEMENT_MICROMAP_BIT_NV.as_raw();
pub const CREATE_DISALLOW_MIXED_SPECIAL_INDEX: u64 =
    khr::PIPELINE_CREATE_2_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_KHR.as_raw();
pub const CREATE_DISALLOW_OPACITY_MICROMAP_ARM: u64 =
    khr::PIPELINE_CREATE_2_DISALLOW_OPACITY_MICROMAP_BIT_ARM.as_raw();
pub const SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX: u32 =
    khr::SHADER_CREATE_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_EXT.as_raw();

/// `VK_STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR` (VK_KHR_device_address_commands,
/// extension 319, offset 4 in vk.xml; newer than ash 0.38).
pub const STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR: i32 = 1_000_318_004;

pub const SHADER_CODE_TYPE_SPIRV: i32 = vk::ShaderCodeTypeEXT::SPIRV.as_raw();

/// The stage and access masks of one `VkMemoryBarrier2`,
/// `VkBufferMemoryBarrier2`, `VkImageMemoryBarrier2` or
/// `VkMemoryRangeBarrierKHR` (the members the micromap rules read).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct Barrier {
    pub src_stage_mask: u64,
    pub src_access_mask: u64,
    pub dst_stage_mask: u64,
    pub dst_access_mask: u64,
}

/// `VkDependencyInfo`, with the `VkMemoryRangeBarriersInfoKHR` of its pNext chain.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct DependencyInfo {
    pub memory_barriers: Vec<Barrier>,
    pub buffer_memory_barriers: Vec<Barrier>,
    pub image_memory_barriers: Vec<Barrier>,
    /// `VkMemoryRangeBarriersInfoKHR::pMemoryRangeBarriers` (empty: none chained).
    pub memory_range_barriers: Vec<Barrier>,
}

pub use super::generated::{SemaphoreSubmitInfo, SpecializationInfo, SpecializationMapEntry};

/// `VkSubmitInfo2`: the semaphore operations.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct SubmitInfo2 {
    pub wait_semaphore_infos: Vec<SemaphoreSubmitInfo>,
    pub signal_semaphore_infos: Vec<SemaphoreSubmitInfo>,
}

/// `VkMemoryMarkerInfoAMD` (`vkCmdWriteMarkerToMemoryAMD`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MemoryMarkerInfo {
    pub stage: u64,
    pub dst_address: u64,
    pub marker: u32,
}

/// One `VkSpecializationMapEntry` with the value it maps to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct SpecializationValue {
    pub constant_id: u32,
    /// The bytes of the value, little-endian (a `VkBool32` is 4 bytes).
    pub value: u64,
}

impl SpecializationValue {
    /// The value `entry` maps its constant to in `data`, where
    /// `[offset, offset + size)` lies inside `data` and holds at most 8
    /// bytes. Other entries break rules that are not micromap rules.
    pub fn of(entry: &SpecializationMapEntry, data: &[u8]) -> Option<Self> {
        let start = usize::try_from(entry.offset).ok()?;
        let size = usize::try_from(entry.size).ok().filter(|size| *size <= 8)?;
        let bytes = data.get(start..start.checked_add(size)?)?;
        Some(Self {
            constant_id: entry.constant_id,
            value: bytes
                .iter()
                .rev()
                .fold(0u64, |acc, byte| acc << 8 | u64::from(*byte)),
        })
    }

    /// The values of the entries of `info` that [`Self::of`] reads.
    pub fn all(info: &SpecializationInfo) -> Vec<Self> {
        info.map_entries
            .iter()
            .filter_map(|entry| Self::of(entry, &info.data))
            .collect()
    }
}

/// `VkPipelineShaderStageCreateInfo`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct ShaderStage {
    /// `VkShaderStageFlagBits`.
    pub stage: u32,
    /// A module created earlier (0 when the code is chained inline).
    pub module: Handle,
    /// `pName`: the entry point.
    pub name: String,
    /// The words of a `VkShaderModuleCreateInfo` chained to the stage.
    pub code: Option<Vec<u32>>,
    /// `pSpecializationInfo` (empty: NULL).
    pub specialization: Vec<SpecializationValue>,
}

/// `flags`, and the `VkPipelineCreateFlags2CreateInfo` of the pNext chain
/// that replaces it when present.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct PipelineCreateFlags {
    /// `VkPipelineCreateFlags`.
    pub flags: u32,
    /// `VkPipelineCreateFlags2CreateInfo::flags`, if chained.
    pub flags2: Option<u64>,
}

impl PipelineCreateFlags {
    /// The flags the pipeline is created with.
    pub fn effective(self) -> u64 {
        self.flags2.unwrap_or(u64::from(self.flags))
    }

    /// The member the effective flags come from, for locations.
    pub fn member(self) -> &'static str {
        if self.flags2.is_some() {
            "pNext<VkPipelineCreateFlags2CreateInfo>.flags"
        } else {
            "flags"
        }
    }
}

/// Which pipeline create-info structure a pipeline was created from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum PipelineKind {
    #[default]
    Compute,
    Graphics,
    RayTracingKhr,
    RayTracingNv,
}

impl PipelineKind {
    pub fn struct_name(self) -> &'static str {
        match self {
            PipelineKind::Compute => "VkComputePipelineCreateInfo",
            PipelineKind::Graphics => "VkGraphicsPipelineCreateInfo",
            PipelineKind::RayTracingKhr => "VkRayTracingPipelineCreateInfoKHR",
            PipelineKind::RayTracingNv => "VkRayTracingPipelineCreateInfoNV",
        }
    }
}

/// `VkComputePipelineCreateInfo`, `VkGraphicsPipelineCreateInfo`,
/// `VkRayTracingPipelineCreateInfoKHR` or `VkRayTracingPipelineCreateInfoNV`
/// (the entry point says which; a compute pipeline has one stage, `stage`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct PipelineCreateInfo {
    pub flags: PipelineCreateFlags,
    pub stages: Vec<ShaderStage>,
    /// `VkPipelineLibraryCreateInfoKHR::pLibraries`: `pLibraryInfo` of a
    /// ray-tracing pipeline, or the structure chained to a graphics
    /// pipeline. None: not given.
    pub libraries: Option<Vec<Handle>>,
}

/// What a shader's SPIR-V says about micromaps, once specialized.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
pub struct ShaderFacts {
    /// `OpacityMicromapIdKHR` declared on the entry point with a true operand
    /// (None: the code was not available to the checker).
    pub opacity_micromap_id: Option<bool>,
}

/// A created `VkPipeline`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PipelineRecord {
    pub kind: PipelineKind,
    /// Effective create flags (`VkPipelineCreateFlags2` bits).
    pub flags: u64,
    /// Each stage of the pipeline and of the libraries it links, with what its code says.
    pub stages: Vec<(u32, ShaderFacts)>,
}

/// `VkShaderCreateInfoEXT`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct ShaderCreateInfo {
    /// `VkShaderCreateFlagsEXT`.
    pub flags: u32,
    /// `VkShaderStageFlagBits`.
    pub stage: u32,
    /// `VkShaderCodeTypeEXT`.
    pub code_type: i32,
    /// `pCode` as SPIR-V words (for `VK_SHADER_CODE_TYPE_SPIRV_EXT`).
    pub code: Vec<u32>,
    pub name: String,
    pub specialization: Vec<SpecializationValue>,
}

impl Default for ShaderCreateInfo {
    fn default() -> Self {
        Self {
            flags: 0,
            stage: vk::ShaderStageFlags::COMPUTE.as_raw(),
            code_type: SHADER_CODE_TYPE_SPIRV,
            code: Vec::new(),
            name: "main".into(),
            specialization: Vec::new(),
        }
    }
}

/// A created `VkShaderEXT`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShaderObjectRecord {
    pub flags: u32,
    pub stage: u32,
    pub facts: ShaderFacts,
}

/// What an acceleration structure's last build the checker knows of put in
/// it, as the draw, dispatch and trace rules ask (for a top-level structure:
/// what the bottom-level structures its instances reference hold).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct MicromapGeometry {
    /// Some geometry chains a `VkAccelerationStructureTrianglesOpacityMicromapKHR`.
    pub opacity_khr: bool,
    /// Some geometry chains a `VkAccelerationStructureTrianglesOpacityMicromapEXT`.
    pub opacity_ext: bool,
    /// Some geometry's opacity index buffer holds both special indices and
    /// indices into its micromap (known only where the checker read it).
    pub mixed_special_indices: bool,
}

/// Which shader reaches an acceleration structure during a command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum AccessingShader {
    /// The stage (`VkShaderStageFlagBits`) of the bound pipeline.
    PipelineStage(u32),
    /// A bound `VkShaderEXT`.
    ShaderObject(Handle),
}

/// An acceleration-structure descriptor a command's shaders statically use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub struct AccelerationStructureAccess {
    pub acceleration_structure: Handle,
    /// Reached through `OpRayQueryProceedKHR` (else through a trace-ray instruction).
    pub ray_query: bool,
    pub shader: AccessingShader,
}

/// What is bound when a draw, dispatch or trace-rays command is recorded.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, rename_all = "camelCase")]
pub struct BoundWork {
    /// The pipeline bound to the command's bind point (0: none, shader objects).
    pub pipeline: Handle,
    pub accesses: Vec<AccelerationStructureAccess>,
}

/// A micromap feature or property structure whose sType rules are checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum MicromapStruct {
    OpacityMicromapFeaturesExt,
    OpacityMicromapFeaturesKhr,
    DisplacementMicromapFeaturesNv,
    PipelineOpacityMicromapFeaturesArm,
    OpacityMicromapPropertiesExt,
    OpacityMicromapPropertiesKhr,
    DisplacementMicromapPropertiesNv,
}

impl MicromapStruct {
    pub const ALL: [MicromapStruct; 7] = [
        MicromapStruct::OpacityMicromapFeaturesExt,
        MicromapStruct::OpacityMicromapFeaturesKhr,
        MicromapStruct::DisplacementMicromapFeaturesNv,
        MicromapStruct::PipelineOpacityMicromapFeaturesArm,
        MicromapStruct::OpacityMicromapPropertiesExt,
        MicromapStruct::OpacityMicromapPropertiesKhr,
        MicromapStruct::DisplacementMicromapPropertiesNv,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MicromapStruct::OpacityMicromapFeaturesExt => {
                "VkPhysicalDeviceOpacityMicromapFeaturesEXT"
            }
            MicromapStruct::OpacityMicromapFeaturesKhr => {
                "VkPhysicalDeviceOpacityMicromapFeaturesKHR"
            }
            MicromapStruct::DisplacementMicromapFeaturesNv => {
                "VkPhysicalDeviceDisplacementMicromapFeaturesNV"
            }
            MicromapStruct::PipelineOpacityMicromapFeaturesArm => {
                "VkPhysicalDevicePipelineOpacityMicromapFeaturesARM"
            }
            MicromapStruct::OpacityMicromapPropertiesExt => {
                "VkPhysicalDeviceOpacityMicromapPropertiesEXT"
            }
            MicromapStruct::OpacityMicromapPropertiesKhr => {
                "VkPhysicalDeviceOpacityMicromapPropertiesKHR"
            }
            MicromapStruct::DisplacementMicromapPropertiesNv => {
                "VkPhysicalDeviceDisplacementMicromapPropertiesNV"
            }
        }
    }

    /// The sType the structure must have.
    pub fn s_type(self) -> i32 {
        match self {
            MicromapStruct::OpacityMicromapFeaturesExt => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_FEATURES_EXT
            }
            MicromapStruct::OpacityMicromapFeaturesKhr => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_FEATURES_KHR
            }
            MicromapStruct::DisplacementMicromapFeaturesNv => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_DISPLACEMENT_MICROMAP_FEATURES_NV
            }
            MicromapStruct::PipelineOpacityMicromapFeaturesArm => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_OPACITY_MICROMAP_FEATURES_ARM
            }
            MicromapStruct::OpacityMicromapPropertiesExt => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_EXT
            }
            MicromapStruct::OpacityMicromapPropertiesKhr => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_OPACITY_MICROMAP_PROPERTIES_KHR
            }
            MicromapStruct::DisplacementMicromapPropertiesNv => {
                khr::STRUCTURE_TYPE_PHYSICAL_DEVICE_DISPLACEMENT_MICROMAP_PROPERTIES_NV
            }
        }
        .as_raw()
    }

    /// The structure whose expected sType is `s_type`, if it is one of these.
    pub fn from_s_type(s_type: i32) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.s_type() == s_type)
    }
}

/// One structure of a pNext chain: a micromap structure (with the sType it
/// was given) or any other structure (by its sType).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "camelCase")]
pub enum ChainedStruct {
    Micromap { which: MicromapStruct, s_type: i32 },
    Other(i32),
}

impl ChainedStruct {
    /// A micromap structure with its correct sType.
    pub fn micromap(which: MicromapStruct) -> Self {
        ChainedStruct::Micromap {
            which,
            s_type: which.s_type(),
        }
    }

    pub fn s_type(self) -> i32 {
        match self {
            ChainedStruct::Micromap { s_type, .. } | ChainedStruct::Other(s_type) => s_type,
        }
    }
}
