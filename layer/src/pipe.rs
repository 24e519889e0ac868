//! The table of the pipeline, shader, synchronization and shader-running
//! commands ([`crate::pipelines`], [`crate::sync`], [`crate::work`]): one
//! list gives each command's name, the next layer's function (resolved at
//! device creation, kept as an `Option`) and this layer's intercept.

#![allow(unsafe_code)]

use std::ffi::CStr;

use ash::vk;
use ommcheck::raw::pipeline::MemoryMarkerInfoAMD;

use crate::dispatch::next_fn;
use crate::intercept::as_void;
use crate::{pipelines, sync, work};

/// `vkCmdWriteMarkerToMemoryAMD`, newer than ash 0.38.
pub type PfnCmdWriteMarkerToMemoryAMD =
    unsafe extern "system" fn(vk::CommandBuffer, *const MemoryMarkerInfoAMD);

macro_rules! pipe_commands {
    ($($field:ident: $pfn:ty = $name:literal => $ours:path;)*) => {
        /// The next layer's functions for the commands of this table.
        pub struct PipeFns {
            $(pub $field: Option<$pfn>,)*
        }

        impl PipeFns {
            pub fn load(gdpa: vk::PFN_vkGetDeviceProcAddr, device: vk::Device) -> Self {
                Self {
                    $($field: next_fn!(gdpa, device, $name, $pfn),)*
                }
            }
        }

        /// This layer's function for a command of this table.
        pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
            $(if name == $name {
                return as_void($ours as $pfn);
            })*
            None
        }
    };
}

pipe_commands! {
    create_shader_module: vk::PFN_vkCreateShaderModule = c"vkCreateShaderModule" => pipelines::create_shader_module;
    destroy_shader_module: vk::PFN_vkDestroyShaderModule = c"vkDestroyShaderModule" => pipelines::destroy_shader_module;
    create_compute_pipelines: vk::PFN_vkCreateComputePipelines = c"vkCreateComputePipelines" => pipelines::create_compute_pipelines;
    create_graphics_pipelines: vk::PFN_vkCreateGraphicsPipelines = c"vkCreateGraphicsPipelines" => pipelines::create_graphics_pipelines;
    create_ray_tracing_pipelines_khr: vk::PFN_vkCreateRayTracingPipelinesKHR = c"vkCreateRayTracingPipelinesKHR" => pipelines::create_ray_tracing_pipelines_khr;
    create_ray_tracing_pipelines_nv: vk::PFN_vkCreateRayTracingPipelinesNV = c"vkCreateRayTracingPipelinesNV" => pipelines::create_ray_tracing_pipelines_nv;
    destroy_pipeline: vk::PFN_vkDestroyPipeline = c"vkDestroyPipeline" => pipelines::destroy_pipeline;
    create_shaders: vk::PFN_vkCreateShadersEXT = c"vkCreateShadersEXT" => pipelines::create_shaders;
    destroy_shader: vk::PFN_vkDestroyShaderEXT = c"vkDestroyShaderEXT" => pipelines::destroy_shader;

    cmd_pipeline_barrier2: vk::PFN_vkCmdPipelineBarrier2 = c"vkCmdPipelineBarrier2" => sync::cmd_pipeline_barrier2;
    cmd_pipeline_barrier2_khr: vk::PFN_vkCmdPipelineBarrier2 = c"vkCmdPipelineBarrier2KHR" => sync::cmd_pipeline_barrier2_khr;
    cmd_set_event2: vk::PFN_vkCmdSetEvent2 = c"vkCmdSetEvent2" => sync::cmd_set_event2;
    cmd_set_event2_khr: vk::PFN_vkCmdSetEvent2 = c"vkCmdSetEvent2KHR" => sync::cmd_set_event2_khr;
    cmd_wait_events2: vk::PFN_vkCmdWaitEvents2 = c"vkCmdWaitEvents2" => sync::cmd_wait_events2;
    cmd_wait_events2_khr: vk::PFN_vkCmdWaitEvents2 = c"vkCmdWaitEvents2KHR" => sync::cmd_wait_events2_khr;
    cmd_reset_event2: vk::PFN_vkCmdResetEvent2 = c"vkCmdResetEvent2" => sync::cmd_reset_event2;
    cmd_reset_event2_khr: vk::PFN_vkCmdResetEvent2 = c"vkCmdResetEvent2KHR" => sync::cmd_reset_event2_khr;
    cmd_write_timestamp2: vk::PFN_vkCmdWriteTimestamp2 = c"vkCmdWriteTimestamp2" => sync::cmd_write_timestamp2;
    cmd_write_timestamp2_khr: vk::PFN_vkCmdWriteTimestamp2 = c"vkCmdWriteTimestamp2KHR" => sync::cmd_write_timestamp2_khr;
    cmd_write_buffer_marker2_amd: vk::PFN_vkCmdWriteBufferMarker2AMD = c"vkCmdWriteBufferMarker2AMD" => sync::cmd_write_buffer_marker2_amd;
    cmd_write_marker_to_memory_amd: PfnCmdWriteMarkerToMemoryAMD = c"vkCmdWriteMarkerToMemoryAMD" => sync::cmd_write_marker_to_memory_amd;
    cmd_reset_query_pool: vk::PFN_vkCmdResetQueryPool = c"vkCmdResetQueryPool" => sync::cmd_reset_query_pool;
    reset_query_pool: vk::PFN_vkResetQueryPool = c"vkResetQueryPool" => sync::reset_query_pool;
    reset_query_pool_ext: vk::PFN_vkResetQueryPool = c"vkResetQueryPoolEXT" => sync::reset_query_pool_ext;

    create_descriptor_set_layout: vk::PFN_vkCreateDescriptorSetLayout = c"vkCreateDescriptorSetLayout" => work::create_descriptor_set_layout;
    destroy_descriptor_set_layout: vk::PFN_vkDestroyDescriptorSetLayout = c"vkDestroyDescriptorSetLayout" => work::destroy_descriptor_set_layout;
    allocate_descriptor_sets: vk::PFN_vkAllocateDescriptorSets = c"vkAllocateDescriptorSets" => work::allocate_descriptor_sets;
    free_descriptor_sets: vk::PFN_vkFreeDescriptorSets = c"vkFreeDescriptorSets" => work::free_descriptor_sets;
    update_descriptor_sets: vk::PFN_vkUpdateDescriptorSets = c"vkUpdateDescriptorSets" => work::update_descriptor_sets;
    cmd_bind_descriptor_sets: vk::PFN_vkCmdBindDescriptorSets = c"vkCmdBindDescriptorSets" => work::cmd_bind_descriptor_sets;
    cmd_bind_pipeline: vk::PFN_vkCmdBindPipeline = c"vkCmdBindPipeline" => work::cmd_bind_pipeline;
    cmd_bind_shaders: vk::PFN_vkCmdBindShadersEXT = c"vkCmdBindShadersEXT" => work::cmd_bind_shaders;

    cmd_draw: vk::PFN_vkCmdDraw = c"vkCmdDraw" => work::cmd_draw;
    cmd_draw_indexed: vk::PFN_vkCmdDrawIndexed = c"vkCmdDrawIndexed" => work::cmd_draw_indexed;
    cmd_draw_indirect: vk::PFN_vkCmdDrawIndirect = c"vkCmdDrawIndirect" => work::cmd_draw_indirect;
    cmd_draw_indexed_indirect: vk::PFN_vkCmdDrawIndexedIndirect = c"vkCmdDrawIndexedIndirect" => work::cmd_draw_indexed_indirect;
    cmd_draw_indirect_count: vk::PFN_vkCmdDrawIndirectCount = c"vkCmdDrawIndirectCount" => work::cmd_draw_indirect_count;
    cmd_draw_indirect_count_khr: vk::PFN_vkCmdDrawIndirectCount = c"vkCmdDrawIndirectCountKHR" => work::cmd_draw_indirect_count_khr;
    cmd_draw_indirect_count_amd: vk::PFN_vkCmdDrawIndirectCount = c"vkCmdDrawIndirectCountAMD" => work::cmd_draw_indirect_count_amd;
    cmd_draw_indexed_indirect_count: vk::PFN_vkCmdDrawIndexedIndirectCount = c"vkCmdDrawIndexedIndirectCount" => work::cmd_draw_indexed_indirect_count;
    cmd_draw_indexed_indirect_count_khr: vk::PFN_vkCmdDrawIndexedIndirectCount = c"vkCmdDrawIndexedIndirectCountKHR" => work::cmd_draw_indexed_indirect_count_khr;
    cmd_draw_indexed_indirect_count_amd: vk::PFN_vkCmdDrawIndexedIndirectCount = c"vkCmdDrawIndexedIndirectCountAMD" => work::cmd_draw_indexed_indirect_count_amd;
    cmd_draw_mesh_tasks: vk::PFN_vkCmdDrawMeshTasksEXT = c"vkCmdDrawMeshTasksEXT" => work::cmd_draw_mesh_tasks;
    cmd_draw_mesh_tasks_indirect: vk::PFN_vkCmdDrawMeshTasksIndirectEXT = c"vkCmdDrawMeshTasksIndirectEXT" => work::cmd_draw_mesh_tasks_indirect;
    cmd_draw_mesh_tasks_indirect_count: vk::PFN_vkCmdDrawMeshTasksIndirectCountEXT = c"vkCmdDrawMeshTasksIndirectCountEXT" => work::cmd_draw_mesh_tasks_indirect_count;
    cmd_dispatch: vk::PFN_vkCmdDispatch = c"vkCmdDispatch" => work::cmd_dispatch;
    cmd_dispatch_base: vk::PFN_vkCmdDispatchBase = c"vkCmdDispatchBase" => work::cmd_dispatch_base;
    cmd_dispatch_base_khr: vk::PFN_vkCmdDispatchBase = c"vkCmdDispatchBaseKHR" => work::cmd_dispatch_base_khr;
    cmd_dispatch_indirect: vk::PFN_vkCmdDispatchIndirect = c"vkCmdDispatchIndirect" => work::cmd_dispatch_indirect;
    cmd_trace_rays: vk::PFN_vkCmdTraceRaysKHR = c"vkCmdTraceRaysKHR" => work::cmd_trace_rays;
    cmd_trace_rays_indirect: vk::PFN_vkCmdTraceRaysIndirectKHR = c"vkCmdTraceRaysIndirectKHR" => work::cmd_trace_rays_indirect;
    cmd_trace_rays_indirect2: vk::PFN_vkCmdTraceRaysIndirect2KHR = c"vkCmdTraceRaysIndirect2KHR" => work::cmd_trace_rays_indirect2;
    cmd_draw_multi: vk::PFN_vkCmdDrawMultiEXT = c"vkCmdDrawMultiEXT" => work::cmd_draw_multi;
    cmd_draw_multi_indexed: vk::PFN_vkCmdDrawMultiIndexedEXT = c"vkCmdDrawMultiIndexedEXT" => work::cmd_draw_multi_indexed;
    cmd_draw_mesh_tasks_nv: vk::PFN_vkCmdDrawMeshTasksNV = c"vkCmdDrawMeshTasksNV" => work::cmd_draw_mesh_tasks_nv;
    cmd_draw_mesh_tasks_indirect_nv: vk::PFN_vkCmdDrawMeshTasksIndirectNV = c"vkCmdDrawMeshTasksIndirectNV" => work::cmd_draw_mesh_tasks_indirect_nv;
    cmd_draw_mesh_tasks_indirect_count_nv: vk::PFN_vkCmdDrawMeshTasksIndirectCountNV = c"vkCmdDrawMeshTasksIndirectCountNV" => work::cmd_draw_mesh_tasks_indirect_count_nv;
    cmd_draw_indirect_byte_count: vk::PFN_vkCmdDrawIndirectByteCountEXT = c"vkCmdDrawIndirectByteCountEXT" => work::cmd_draw_indirect_byte_count;
    cmd_trace_rays_nv: vk::PFN_vkCmdTraceRaysNV = c"vkCmdTraceRaysNV" => work::cmd_trace_rays_nv;
    cmd_draw_cluster_huawei: vk::PFN_vkCmdDrawClusterHUAWEI = c"vkCmdDrawClusterHUAWEI" => work::cmd_draw_cluster_huawei;
    cmd_draw_cluster_indirect_huawei: vk::PFN_vkCmdDrawClusterIndirectHUAWEI = c"vkCmdDrawClusterIndirectHUAWEI" => work::cmd_draw_cluster_indirect_huawei;
    cmd_subpass_shading_huawei: vk::PFN_vkCmdSubpassShadingHUAWEI = c"vkCmdSubpassShadingHUAWEI" => work::cmd_subpass_shading_huawei;
    cmd_execute_generated_commands_nv: vk::PFN_vkCmdExecuteGeneratedCommandsNV = c"vkCmdExecuteGeneratedCommandsNV" => work::cmd_execute_generated_commands_nv;
}
