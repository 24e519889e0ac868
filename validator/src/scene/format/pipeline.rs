//! The calls a scene writes beyond micromap and acceleration-structure
//! objects: device creation and property queries (their micromap pNext
//! structures), shader modules, pipelines and shader objects (their create
//! flags and SPIR-V), binding them, the commands that run shaders, the
//! synchronization commands whose stage and access masks the micromap rules
//! read, vkCmdBeginQuery, and NV cluster acceleration-structure builds.

use schemars::JsonSchema;
use serde::Deserialize;

use super::{ChainStruct, CommandBufferArg, Contents, SpecializationInfoDesc};
use crate::model::names::{self, Value};
use crate::scene::args::{AddressArg, HandleArg};

/// `VkDeviceCreateInfo`: its pNext chain (the extensions and features the
/// calls run under are the scene's `device`; this call checks the chain).
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct DeviceCreateInfoDesc {
    #[serde(default)]
    pub p_next: Vec<ChainStruct>,
}

/// `VkPhysicalDeviceProperties2`: its pNext chain.
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct Properties2Desc {
    #[serde(default)]
    pub p_next: Vec<ChainStruct>,
}

params!(
    /// `vkCreateDevice(physicalDevice, pCreateInfo, pAllocator, pDevice)`.
    CreateDevice {
        #[serde(default)] physical_device: HandleArg,
        p_create_info: DeviceCreateInfoDesc,
    }
);

params!(
    /// `vkGetPhysicalDeviceProperties2(physicalDevice, pProperties)`.
    GetPhysicalDeviceProperties2 {
        #[serde(default)] physical_device: HandleArg,
        p_properties: Properties2Desc,
    }
);

/// `VkShaderModuleCreateInfo`: the SPIR-V words as contents (`u32`, `hex`,
/// `base64` or a `.spv` `file`); codeSize is their length in bytes.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct ShaderModuleCreateInfoDesc {
    pub p_code: Contents,
}

params!(
    /// `vkCreateShaderModule(device, pCreateInfo, pAllocator, pShaderModule)`.
    CreateShaderModule {
        #[serde(default)] device: HandleArg,
        p_create_info: ShaderModuleCreateInfoDesc,
        /// The name the new module gets.
        p_shader_module: String,
    }
);

/// A structure chained to `VkPipelineShaderStageCreateInfo`: a
/// `VkShaderModuleCreateInfo` with the code inline (module is then
/// VK_NULL_HANDLE); any other sType is passed over.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct StageChainDesc {
    pub s_type: Value<names::StructureType>,
    /// For VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO: the SPIR-V words.
    pub p_code: Option<Contents>,
}

/// `VkPipelineShaderStageCreateInfo`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct ShaderStageDesc {
    #[serde(default)]
    pub p_next: Vec<StageChainDesc>,
    pub stage: Value<names::ShaderStageFlags>,
    /// A shader module by the name vkCreateShaderModule gave it.
    #[serde(default)]
    pub module: HandleArg,
    /// The entry point (default "main").
    #[serde(default = "main_entry")]
    pub p_name: String,
    pub p_specialization_info: Option<SpecializationInfoDesc>,
}

fn main_entry() -> String {
    "main".into()
}

/// `VkComputePipelineCreateInfo`, `VkGraphicsPipelineCreateInfo`,
/// `VkRayTracingPipelineCreateInfoKHR` or `VkRayTracingPipelineCreateInfoNV`:
/// the members the micromap rules read. Other members of the structures
/// (layout, groups, states) may be written and are not read.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct PipelineCreateInfoDesc {
    /// `VkPipelineCreateFlags2CreateInfo` replaces `flags`;
    /// `VkPipelineLibraryCreateInfoKHR` gives a graphics pipeline's libraries.
    #[serde(default)]
    pub p_next: Vec<ChainStruct>,
    #[serde(default)]
    pub flags: Value<names::PipelineCreateFlags>,
    /// The one stage of a compute pipeline.
    pub stage: Option<ShaderStageDesc>,
    /// The stages of a graphics or ray-tracing pipeline.
    #[serde(default)]
    pub p_stages: Vec<ShaderStageDesc>,
    /// `VkRayTracingPipelineCreateInfoKHR::pLibraryInfo`.
    pub p_library_info: Option<super::PipelineLibraryCreateInfoDesc>,
}

macro_rules! create_pipelines {
    ($($(#[$doc:meta])* $name:ident),* $(,)?) => {$(
        params!(
            $(#[$doc])*
            $name {
                #[serde(default)] device: HandleArg,
                #[serde(default)] deferred_operation: HandleArg,
                #[serde(default)] pipeline_cache: HandleArg,
                p_create_infos: Vec<PipelineCreateInfoDesc>,
                /// The names the new pipelines get, one per create info.
                p_pipelines: Vec<String>,
            }
        );
    )*};
}

create_pipelines!(
    /// `vkCreateComputePipelines(device, pipelineCache, createInfoCount, pCreateInfos, pAllocator, pPipelines)`.
    CreateComputePipelines,
    /// `vkCreateGraphicsPipelines(...)`.
    CreateGraphicsPipelines,
    /// `vkCreateRayTracingPipelinesKHR(device, deferredOperation, pipelineCache, ...)`.
    CreateRayTracingPipelinesKhr,
    /// `vkCreateRayTracingPipelinesNV(...)`.
    CreateRayTracingPipelinesNv,
);

/// `VkShaderCreateInfoEXT`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct ShaderCreateInfoDesc {
    #[serde(default)]
    pub flags: Value<names::ShaderCreateFlags>,
    pub stage: Value<names::ShaderStageFlags>,
    /// Default VK_SHADER_CODE_TYPE_SPIRV_EXT.
    pub code_type: Option<Value<names::ShaderCodeType>>,
    pub p_code: Contents,
    #[serde(default = "main_entry")]
    pub p_name: String,
    pub p_specialization_info: Option<SpecializationInfoDesc>,
}

params!(
    /// `vkCreateShadersEXT(device, createInfoCount, pCreateInfos, pAllocator, pShaders)`.
    CreateShaders {
        #[serde(default)] device: HandleArg,
        p_create_infos: Vec<ShaderCreateInfoDesc>,
        /// The names the new shader objects get, one per create info.
        p_shaders: Vec<String>,
    }
);

params!(
    /// `vkCmdBindPipeline(commandBuffer, pipelineBindPoint, pipeline)`.
    CmdBindPipeline {
        #[serde(default)] command_buffer: CommandBufferArg,
        pipeline_bind_point: Value<names::PipelineBindPoint>,
        pipeline: HandleArg,
    }
);

params!(
    /// `vkCmdBindShadersEXT(commandBuffer, stageCount, pStages, pShaders)`;
    /// a null shader unbinds its stage.
    CmdBindShaders {
        #[serde(default)] command_buffer: CommandBufferArg,
        p_stages: Vec<Value<names::ShaderStageFlags>>,
        p_shaders: Vec<HandleArg>,
    }
);

/// An acceleration structure a command's shaders statically use through a
/// descriptor (bound with descriptor sets, push descriptors or descriptor
/// buffers before the command; scenes name it here instead).
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct AccelerationStructureUseDesc {
    pub acceleration_structure: HandleArg,
    /// The shader stage that uses it (a `VK_SHADER_STAGE_*` bit).
    pub stage: Value<names::ShaderStageFlags>,
    /// Reached through `OpRayQueryProceedKHR` (default false: through
    /// `OpTraceRayKHR`).
    #[serde(default)]
    pub ray_query: bool,
}

/// Any command that runs shaders (`vkCmdDraw*`, `vkCmdDispatch*`,
/// `vkCmdTraceRays*`, `vkCmdExecuteGeneratedCommands*`,
/// `vkCmdSubpassShadingHUAWEI`): the command's own parameters may be
/// written and are not read (they are no micromap rules); what its shaders
/// reach is `accelerationStructures`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct RunShaders {
    #[serde(default)]
    pub command_buffer: CommandBufferArg,
    /// vkCmdExecuteGeneratedCommands*: the bind point of the commands it
    /// generates (default graphics).
    pub pipeline_bind_point: Option<Value<names::PipelineBindPoint>>,
    #[serde(default)]
    pub acceleration_structures: Vec<AccelerationStructureUseDesc>,
}

/// `VkMemoryBarrier2`, `VkBufferMemoryBarrier2`, `VkImageMemoryBarrier2`
/// or `VkMemoryRangeBarrierKHR`: the masks (the other members may be
/// written and are not read).
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct BarrierDesc {
    #[serde(default)]
    pub src_stage_mask: Value<names::PipelineStageFlags2>,
    #[serde(default)]
    pub src_access_mask: Value<names::AccessFlags2>,
    #[serde(default)]
    pub dst_stage_mask: Value<names::PipelineStageFlags2>,
    #[serde(default)]
    pub dst_access_mask: Value<names::AccessFlags2>,
}

/// A structure chained to `VkDependencyInfo`: `VkMemoryRangeBarriersInfoKHR`
/// with its barriers; any other sType is passed over.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct DependencyChainDesc {
    pub s_type: Value<names::StructureType>,
    pub p_memory_range_barriers: Option<Vec<BarrierDesc>>,
}

/// `VkDependencyInfo`.
#[derive(Debug, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct DependencyInfoDesc {
    #[serde(default)]
    pub p_next: Vec<DependencyChainDesc>,
    #[serde(default)]
    pub p_memory_barriers: Vec<BarrierDesc>,
    #[serde(default)]
    pub p_buffer_memory_barriers: Vec<BarrierDesc>,
    #[serde(default)]
    pub p_image_memory_barriers: Vec<BarrierDesc>,
}

params!(
    /// `vkCmdPipelineBarrier2(commandBuffer, pDependencyInfo)`.
    CmdPipelineBarrier2 {
        #[serde(default)] command_buffer: CommandBufferArg,
        p_dependency_info: DependencyInfoDesc,
    }
);

params!(
    /// `vkCmdSetEvent2(commandBuffer, event, pDependencyInfo)`.
    CmdSetEvent2 {
        #[serde(default)] command_buffer: CommandBufferArg,
        #[serde(default)] event: HandleArg,
        p_dependency_info: DependencyInfoDesc,
    }
);

params!(
    /// `vkCmdWaitEvents2(commandBuffer, eventCount, pEvents, pDependencyInfos)`.
    CmdWaitEvents2 {
        #[serde(default)] command_buffer: CommandBufferArg,
        #[serde(default)] p_events: Vec<HandleArg>,
        p_dependency_infos: Vec<DependencyInfoDesc>,
    }
);

params!(
    /// `vkCmdResetEvent2(commandBuffer, event, stageMask)`.
    CmdResetEvent2 {
        #[serde(default)] command_buffer: CommandBufferArg,
        #[serde(default)] event: HandleArg,
        stage_mask: Value<names::PipelineStageFlags2>,
    }
);

params!(
    /// `vkCmdWriteTimestamp2(commandBuffer, stage, queryPool, query)`.
    CmdWriteTimestamp2 {
        #[serde(default)] command_buffer: CommandBufferArg,
        stage: Value<names::PipelineStageFlags2>,
        #[serde(default)] query_pool: HandleArg,
        #[serde(default)] query: u32,
    }
);

params!(
    /// `vkCmdWriteBufferMarker2AMD(commandBuffer, stage, dstBuffer, dstOffset, marker)`.
    CmdWriteBufferMarker2Amd {
        #[serde(default)] command_buffer: CommandBufferArg,
        stage: Value<names::PipelineStageFlags2>,
        #[serde(default)] dst_buffer: HandleArg,
        #[serde(default)] dst_offset: u64,
        #[serde(default)] marker: u32,
    }
);

/// `VkMemoryMarkerInfoAMD`.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, rename_all = "camelCase")]
pub struct MemoryMarkerInfoDesc {
    pub stage: Value<names::PipelineStageFlags2>,
    #[serde(default)]
    pub dst_address: AddressArg,
    #[serde(default)]
    pub marker: u32,
}

params!(
    /// `vkCmdWriteMarkerToMemoryAMD(commandBuffer, pInfo)`.
    CmdWriteMarkerToMemoryAmd {
        #[serde(default)] command_buffer: CommandBufferArg,
        p_info: MemoryMarkerInfoDesc,
    }
);

/// `VkSubmitInfo2`: its semaphore operations and the command buffers it
/// runs (`docs/scene-format.md`, "Execution order").
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct SubmitInfo2Desc {
    #[serde(default)]
    pub p_wait_semaphore_infos: Vec<super::SemaphoreSubmitInfoDesc>,
    #[serde(default)]
    pub p_command_buffer_infos: Vec<super::CommandBufferSubmitInfoDesc>,
    #[serde(default)]
    pub p_signal_semaphore_infos: Vec<super::SemaphoreSubmitInfoDesc>,
}

params!(
    /// `vkQueueSubmit2(queue, submitCount, pSubmits, fence)`.
    QueueSubmit2 {
        #[serde(default)] queue: HandleArg,
        p_submits: Vec<SubmitInfo2Desc>,
        #[serde(default)] fence: HandleArg,
    }
);

params!(
    /// `vkCmdBeginQuery(commandBuffer, queryPool, query, flags)`.
    CmdBeginQuery {
        #[serde(default)] command_buffer: CommandBufferArg,
        query_pool: HandleArg,
        #[serde(default)] query: u32,
        #[serde(default)] flags: u32,
    }
);

params!(
    /// `vkCmdBeginQueryIndexedEXT(commandBuffer, queryPool, query, flags, index)`.
    CmdBeginQueryIndexed {
        #[serde(default)] command_buffer: CommandBufferArg,
        query_pool: HandleArg,
        #[serde(default)] query: u32,
        #[serde(default)] flags: u32,
        #[serde(default)] index: u32,
    }
);

/// `VkClusterAccelerationStructureBuildTriangleClusterInfoNV` or
/// `...TemplateInfoNV`: the opacity-micromap members (the geometry members
/// may be written and are not read).
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct ClusterTriangleInfoDesc {
    #[serde(default, rename = "clusterID")]
    pub cluster_id: u32,
    #[serde(default)]
    pub triangle_count: u32,
    #[serde(default)]
    pub opacity_micromap_index_type: Value<names::ClusterIndexFormat>,
    #[serde(default)]
    pub opacity_micromap_index_buffer_stride: u16,
    #[serde(default)]
    pub opacity_micromap_array: AddressArg,
    #[serde(default)]
    pub opacity_micromap_index_buffer: AddressArg,
}

/// `VkClusterAccelerationStructureInputInfoNV`: the members the micromap
/// rules read.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct ClusterInputInfoDesc {
    #[serde(default)]
    pub flags: Value<names::BuildAccelerationStructureFlags>,
    pub op_type: Value<names::ClusterOpType>,
}

/// `VkClusterAccelerationStructureCommandsInfoNV`: `input`, and the
/// elements the device reads at `srcInfosArray`, written inline.
#[derive(Debug, Deserialize, JsonSchema)]
#[serde(rename_all = "camelCase")]
pub struct ClusterCommandsInfoDesc {
    pub input: ClusterInputInfoDesc,
    #[serde(default)]
    pub src_infos_array: Vec<ClusterTriangleInfoDesc>,
}

params!(
    /// `vkCmdBuildClusterAccelerationStructureIndirectNV(commandBuffer, pCommandInfos)`.
    CmdBuildClusterAccelerationStructureIndirect {
        #[serde(default)] command_buffer: CommandBufferArg,
        p_command_infos: ClusterCommandsInfoDesc,
    }
);
