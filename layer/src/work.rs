//! The commands that run shaders (draw, dispatch, trace rays), each
//! checked against what its shaders may reach, and the commands that
//! create descriptor set layouts, allocate, update and bind descriptor
//! sets and bind pipelines and shader objects, which the device's
//! [`PipeState`](crate::dispatch::pipe_state::PipeState) follows (see its module for what "reach" means).
//!
//! Not tracked (yet): `vkCmdBindDescriptorSets2KHR`, push descriptors,
//! descriptor update templates and buffers, a write that overflows into the
//! next binding, pool resets (a reused set handle starts empty when it is
//! allocated again), and command buffer begin/reset (bindings stay until
//! something else is bound at that point).

#![allow(unsafe_code)]

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::checks::pipeline_sync::WorkCommand;
use ommcheck::model::CommandBuffer;
use ommcheck::raw::pipeline as raw;

use crate::dispatch::DeviceData;
use crate::intercept::{check, device_and, guarded, track};

/// `vkCreateDescriptorSetLayout`: its acceleration-structure bindings are tracked.
pub unsafe extern "system" fn create_descriptor_set_layout(
    device: vk::Device,
    create_info: *const vk::DescriptorSetLayoutCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    layout_out: *mut vk::DescriptorSetLayout,
) -> vk::Result {
    let function = "vkCreateDescriptorSetLayout";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.pipe.create_descriptor_set_layout) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, create_info, allocator, layout_out) };
        if result == vk::Result::SUCCESS {
            track(&data, function, |state| {
                // SAFETY: the create info is valid (the API's requirement); on
                // success the next layer wrote the handle.
                let (info, layout) =
                    unsafe { (create_info.as_ref(), crate::read::value(layout_out)) };
                if let (Some(info), Some(layout)) = (info, layout) {
                    // SAFETY: as above.
                    let bindings =
                        unsafe { raw::acceleration_structure_bindings(info, &mut Vec::new()) };
                    state.pipe.create_set_layout(layout.as_raw(), bindings);
                }
            });
        }
        result
    })
}

/// `vkDestroyDescriptorSetLayout`.
pub unsafe extern "system" fn destroy_descriptor_set_layout(
    device: vk::Device,
    layout: vk::DescriptorSetLayout,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let function = "vkDestroyDescriptorSetLayout";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.pipe.destroy_descriptor_set_layout)
        else {
            return;
        };
        track(&data, function, |state| {
            state.pipe.destroy_set_layout(layout.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, layout, allocator) };
    })
}

/// `vkAllocateDescriptorSets`: each set starts with its layout's
/// acceleration-structure bindings, empty.
pub unsafe extern "system" fn allocate_descriptor_sets(
    device: vk::Device,
    allocate_info: *const vk::DescriptorSetAllocateInfo<'_>,
    sets_out: *mut vk::DescriptorSet,
) -> vk::Result {
    let function = "vkAllocateDescriptorSets";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.pipe.allocate_descriptor_sets) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, allocate_info, sets_out) };
        if result == vk::Result::SUCCESS {
            track(&data, function, |state| {
                // SAFETY: the allocate info is valid (the API's requirement).
                let Some(info) = (unsafe { allocate_info.as_ref() }) else {
                    return;
                };
                let count = info.descriptor_set_count;
                let findings = &mut Vec::new();
                // SAFETY: pSetLayouts holds descriptorSetCount layouts, and on
                // success the next layer wrote as many sets.
                let (layouts, sets) = unsafe {
                    (
                        raw::handles(info.p_set_layouts, count, function, "pSetLayouts", findings),
                        raw::handles(
                            sets_out.cast_const(),
                            count,
                            function,
                            "pDescriptorSets",
                            findings,
                        ),
                    )
                };
                state.pipe.allocate_sets(&layouts, sets);
            });
        }
        result
    })
}

/// `vkFreeDescriptorSets`.
pub unsafe extern "system" fn free_descriptor_sets(
    device: vk::Device,
    pool: vk::DescriptorPool,
    count: u32,
    sets: *const vk::DescriptorSet,
) -> vk::Result {
    let function = "vkFreeDescriptorSets";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.pipe.free_descriptor_sets) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        track(&data, function, |state| {
            // SAFETY: the array holds `count` sets (the API's requirement).
            let freed =
                unsafe { raw::handles(sets, count, function, "pDescriptorSets", &mut Vec::new()) };
            state.pipe.free_sets(freed);
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, pool, count, sets) }
    })
}

/// `vkUpdateDescriptorSets`: acceleration-structure writes and copies
/// between tracked sets are recorded.
pub unsafe extern "system" fn update_descriptor_sets(
    device: vk::Device,
    write_count: u32,
    writes: *const vk::WriteDescriptorSet<'_>,
    copy_count: u32,
    copies: *const vk::CopyDescriptorSet<'_>,
) {
    let function = "vkUpdateDescriptorSets";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.pipe.update_descriptor_sets) else {
            return;
        };
        track(&data, function, |state| {
            let findings = &mut Vec::new();
            // SAFETY: the arrays hold their counts of valid structures (the API's requirement).
            let (writes, copies) = unsafe {
                (
                    raw::acceleration_structure_writes(writes, write_count, findings),
                    raw::descriptor_copies(copies, copy_count, findings),
                )
            };
            state.pipe.update_sets(writes, copies);
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, write_count, writes, copy_count, copies) };
    })
}

/// `vkCmdBindDescriptorSets`.
#[allow(clippy::too_many_arguments)] // The command's own parameters.
pub unsafe extern "system" fn cmd_bind_descriptor_sets(
    command_buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    layout: vk::PipelineLayout,
    first_set: u32,
    count: u32,
    sets: *const vk::DescriptorSet,
    dynamic_offset_count: u32,
    dynamic_offsets: *const u32,
) {
    let function = "vkCmdBindDescriptorSets";
    guarded(function, (), || {
        let Some((data, next)) = device_and(command_buffer, |f| f.pipe.cmd_bind_descriptor_sets)
        else {
            return;
        };
        track(&data, function, |state| {
            // SAFETY: the array holds `count` sets (the API's requirement).
            let bound_sets =
                unsafe { raw::handles(sets, count, function, "pDescriptorSets", &mut Vec::new()) };
            state.pipe.bind_sets(
                command_buffer.as_raw(),
                bind_point.as_raw(),
                first_set,
                bound_sets,
            );
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe {
            next(
                command_buffer,
                bind_point,
                layout,
                first_set,
                count,
                sets,
                dynamic_offset_count,
                dynamic_offsets,
            )
        };
    })
}

/// `vkCmdBindPipeline`: the pipeline replaces shader objects of its bind point.
pub unsafe extern "system" fn cmd_bind_pipeline(
    command_buffer: vk::CommandBuffer,
    bind_point: vk::PipelineBindPoint,
    pipeline: vk::Pipeline,
) {
    let function = "vkCmdBindPipeline";
    guarded(function, (), || {
        let Some((data, next)) = device_and(command_buffer, |f| f.pipe.cmd_bind_pipeline) else {
            return;
        };
        track(&data, function, |state| {
            state.pipe.bind_pipeline(
                command_buffer.as_raw(),
                bind_point.as_raw(),
                pipeline.as_raw(),
            );
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(command_buffer, bind_point, pipeline) };
    })
}

/// `vkCmdBindShadersEXT`: shader objects (NULL: none) replace the pipeline
/// of the bind point their stages belong to.
pub unsafe extern "system" fn cmd_bind_shaders(
    command_buffer: vk::CommandBuffer,
    stage_count: u32,
    stages: *const vk::ShaderStageFlags,
    shaders: *const vk::ShaderEXT,
) {
    let function = "vkCmdBindShadersEXT";
    guarded(function, (), || {
        let Some((data, next)) = device_and(command_buffer, |f| f.pipe.cmd_bind_shaders) else {
            return;
        };
        track(&data, function, |state| {
            let findings = &mut Vec::new();
            // SAFETY: both arrays hold `stage_count` elements, pShaders may be NULL.
            let (stage_list, shader_list) = unsafe {
                (
                    raw::stage_flags(stages, stage_count, function, "pStages", findings),
                    raw::handles(shaders, stage_count, function, "pShaders", findings),
                )
            };
            state
                .pipe
                .bind_shaders(command_buffer.as_raw(), stage_list, shader_list);
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(command_buffer, stage_count, stages, shaders) };
    })
}

/// Checks a command that runs shaders against what is bound; returns
/// whether a messenger asked for it to be skipped.
fn run_shaders(data: &DeviceData, command: WorkCommand, command_buffer: vk::CommandBuffer) -> bool {
    let handle = command_buffer.as_raw();
    let object = (vk::ObjectType::COMMAND_BUFFER, handle);
    check(data, command.function(), object, |state| {
        let bound = state.pipe.bound_work(command, handle);
        let recording = CommandBuffer {
            handle,
            ..CommandBuffer::default()
        };
        state.validator.cmd_run_shaders(command, &recording, &bound)
    })
}

/// Intercepts of commands that run shaders: each is checked, then recorded
/// below unless a messenger asks to skip it.
macro_rules! work_commands {
    ($($ours:ident, $field:ident, $command:ident, ($($arg:ident: $ty:ty),*);)*) => {$(
        #[allow(clippy::too_many_arguments)] // The command's own parameters.
        pub unsafe extern "system" fn $ours(command_buffer: vk::CommandBuffer, $($arg: $ty),*) {
            let command = WorkCommand::$command;
            guarded(command.function(), (), || {
                let Some((data, next)) = device_and(command_buffer, |f| f.pipe.$field) else {
                    return;
                };
                if !run_shaders(&data, command, command_buffer) {
                    crate::transfer::shaders_run(&data, command_buffer);
                    // SAFETY: the next layer's function, with the application's arguments.
                    unsafe { next(command_buffer, $($arg),*) };
                }
            })
        }
    )*};
}

type Region = *const vk::StridedDeviceAddressRegionKHR;

work_commands! {
    cmd_draw, cmd_draw, vkCmdDraw, (vertices: u32, instances: u32, first_vertex: u32, first_instance: u32);
    cmd_draw_indexed, cmd_draw_indexed, vkCmdDrawIndexed,
        (indices: u32, instances: u32, first_index: u32, vertex_offset: i32, first_instance: u32);
    cmd_draw_indirect, cmd_draw_indirect, vkCmdDrawIndirect,
        (buffer: vk::Buffer, offset: u64, draws: u32, stride: u32);
    cmd_draw_indexed_indirect, cmd_draw_indexed_indirect, vkCmdDrawIndexedIndirect,
        (buffer: vk::Buffer, offset: u64, draws: u32, stride: u32);
    cmd_draw_indirect_count, cmd_draw_indirect_count, vkCmdDrawIndirectCount,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_indirect_count_khr, cmd_draw_indirect_count_khr, vkCmdDrawIndirectCount,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_indirect_count_amd, cmd_draw_indirect_count_amd, vkCmdDrawIndirectCount,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_indexed_indirect_count, cmd_draw_indexed_indirect_count, vkCmdDrawIndexedIndirectCount,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_indexed_indirect_count_khr, cmd_draw_indexed_indirect_count_khr, vkCmdDrawIndexedIndirectCount,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_indexed_indirect_count_amd, cmd_draw_indexed_indirect_count_amd, vkCmdDrawIndexedIndirectCount,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_mesh_tasks, cmd_draw_mesh_tasks, vkCmdDrawMeshTasksEXT, (x: u32, y: u32, z: u32);
    cmd_draw_mesh_tasks_indirect, cmd_draw_mesh_tasks_indirect, vkCmdDrawMeshTasksIndirectEXT,
        (buffer: vk::Buffer, offset: u64, draws: u32, stride: u32);
    cmd_draw_mesh_tasks_indirect_count, cmd_draw_mesh_tasks_indirect_count, vkCmdDrawMeshTasksIndirectCountEXT,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_dispatch, cmd_dispatch, vkCmdDispatch, (x: u32, y: u32, z: u32);
    cmd_dispatch_base, cmd_dispatch_base, vkCmdDispatchBase,
        (base_x: u32, base_y: u32, base_z: u32, x: u32, y: u32, z: u32);
    cmd_dispatch_base_khr, cmd_dispatch_base_khr, vkCmdDispatchBase,
        (base_x: u32, base_y: u32, base_z: u32, x: u32, y: u32, z: u32);
    cmd_dispatch_indirect, cmd_dispatch_indirect, vkCmdDispatchIndirect, (buffer: vk::Buffer, offset: u64);
    cmd_trace_rays, cmd_trace_rays, vkCmdTraceRaysKHR,
        (raygen: Region, miss: Region, hit: Region, callable: Region, width: u32, height: u32, depth: u32);
    cmd_trace_rays_indirect, cmd_trace_rays_indirect, vkCmdTraceRaysIndirectKHR,
        (raygen: Region, miss: Region, hit: Region, callable: Region, indirect: u64);
    cmd_trace_rays_indirect2, cmd_trace_rays_indirect2, vkCmdTraceRaysIndirect2KHR, (indirect: u64);
    cmd_draw_multi, cmd_draw_multi, vkCmdDrawMultiEXT,
        (draws: u32, vertex_info: *const vk::MultiDrawInfoEXT, instances: u32, first_instance: u32, stride: u32);
    cmd_draw_multi_indexed, cmd_draw_multi_indexed, vkCmdDrawMultiIndexedEXT,
        (draws: u32, index_info: *const vk::MultiDrawIndexedInfoEXT, instances: u32, first_instance: u32, stride: u32, vertex_offset: *const i32);
    cmd_draw_mesh_tasks_nv, cmd_draw_mesh_tasks_nv, vkCmdDrawMeshTasksNV, (tasks: u32, first_task: u32);
    cmd_draw_mesh_tasks_indirect_nv, cmd_draw_mesh_tasks_indirect_nv, vkCmdDrawMeshTasksIndirectNV,
        (buffer: vk::Buffer, offset: u64, draws: u32, stride: u32);
    cmd_draw_mesh_tasks_indirect_count_nv, cmd_draw_mesh_tasks_indirect_count_nv, vkCmdDrawMeshTasksIndirectCountNV,
        (buffer: vk::Buffer, offset: u64, count_buffer: vk::Buffer, count_offset: u64, max_draws: u32, stride: u32);
    cmd_draw_indirect_byte_count, cmd_draw_indirect_byte_count, vkCmdDrawIndirectByteCountEXT,
        (instances: u32, first_instance: u32, counter_buffer: vk::Buffer, counter_buffer_offset: u64, counter_offset: u32, vertex_stride: u32);
    cmd_trace_rays_nv, cmd_trace_rays_nv, vkCmdTraceRaysNV,
        (raygen: vk::Buffer, raygen_offset: u64, miss: vk::Buffer, miss_offset: u64, miss_stride: u64,
         hit: vk::Buffer, hit_offset: u64, hit_stride: u64, callable: vk::Buffer, callable_offset: u64,
         callable_stride: u64, width: u32, height: u32, depth: u32);
    cmd_draw_cluster_huawei, cmd_draw_cluster_huawei, vkCmdDrawClusterHUAWEI, (x: u32, y: u32, z: u32);
    cmd_draw_cluster_indirect_huawei, cmd_draw_cluster_indirect_huawei, vkCmdDrawClusterIndirectHUAWEI,
        (buffer: vk::Buffer, offset: u64);
    cmd_subpass_shading_huawei, cmd_subpass_shading_huawei, vkCmdSubpassShadingHUAWEI, ();
    cmd_execute_generated_commands_nv, cmd_execute_generated_commands_nv, vkCmdExecuteGeneratedCommandsNV,
        (preprocessed: vk::Bool32, info: *const vk::GeneratedCommandsInfoNV<'_>);
}
