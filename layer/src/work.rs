//! The commands that run shaders (draw, dispatch, trace rays) and what they
//! need to know: the pipeline or shader objects bound per command buffer,
//! and which acceleration structures the bound shaders reach, from the
//! descriptor sets bound beside them.
//!
//! What "reach" means here is an over-approximation of the specification's
//! "statically used": every acceleration structure written to a descriptor
//! set that is bound at the command's bind point counts as reached by every
//! stage of the bound pipeline (or every bound shader object) whose stage
//! the set layout binding's `stageFlags` include. Whether a stage reaches
//! it through a ray query or by tracing rays comes from its SPIR-V: a module
//! declaring `RayQueryKHR` uses ray queries, one declaring a ray-tracing
//! capability (or none of these, or whose code is unknown) traces rays.
//!
//! Not tracked (yet): `vkCmdBindDescriptorSets2KHR`, push descriptors,
//! descriptor update templates and buffers, a write that overflows into the
//! next binding, pool resets (a reused set handle starts empty when it is
//! allocated again), and command buffer begin/reset (bindings stay until
//! something else is bound at that point).

#![allow(unsafe_code)]

use std::collections::BTreeMap;

use ash::vk;
use ash::vk::Handle as _;
use foldhash::HashMap;
use ommcheck::checks::pipeline_sync::spirv::SpirvModule;
use ommcheck::checks::pipeline_sync::WorkCommand;
use ommcheck::model::pipeline::{
    AccelerationStructureAccess, AccessingShader, BoundWork, PipelineCreateInfo, ShaderCreateInfo,
};
use ommcheck::model::CommandBuffer;
use ommcheck::raw::pipeline as raw;
use ommcheck::state::Handle;
use ommcheck::Validator;

use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::{check, device_and, guarded, track};

/// SPIR-V `RayQueryKHR`.
const CAPABILITY_RAY_QUERY: u32 = 4472;
/// SPIR-V `RayTracingKHR` and `RayTracingNV`.
const CAPABILITIES_RAY_TRACING: [u32; 2] = [4479, 5340];

const BIND_POINT_GRAPHICS: i32 = vk::PipelineBindPoint::GRAPHICS.as_raw();
const BIND_POINT_COMPUTE: i32 = vk::PipelineBindPoint::COMPUTE.as_raw();
const BIND_POINT_RAY_TRACING: i32 = vk::PipelineBindPoint::RAY_TRACING_KHR.as_raw();

/// The shader stages shader objects may be bound to, per bind point.
fn shader_object_stages(bind_point: i32) -> u32 {
    match bind_point {
        BIND_POINT_GRAPHICS => (vk::ShaderStageFlags::ALL_GRAPHICS
            | vk::ShaderStageFlags::TASK_EXT
            | vk::ShaderStageFlags::MESH_EXT)
            .as_raw(),
        BIND_POINT_COMPUTE => vk::ShaderStageFlags::COMPUTE.as_raw(),
        _ => 0,
    }
}

/// The bind point whose pipeline a command runs. vkCmdExecuteGeneratedCommandsNV
/// runs the one its `VkGeneratedCommandsInfoNV` names; the layer does not
/// read that structure and takes graphics, the common case.
fn bind_point(command: WorkCommand) -> i32 {
    let name = command.function();
    if name.starts_with("vkCmdTraceRays") {
        BIND_POINT_RAY_TRACING
    } else if name.starts_with("vkCmdDispatch") {
        BIND_POINT_COMPUTE
    } else if name == "vkCmdSubpassShadingHUAWEI" {
        vk::PipelineBindPoint::SUBPASS_SHADING_HUAWEI.as_raw()
    } else {
        BIND_POINT_GRAPHICS
    }
}

/// How one shader stage may reach an acceleration structure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StageUse {
    /// `VkShaderStageFlagBits`.
    pub stage: u32,
    pub ray_query: bool,
    pub trace: bool,
}

impl StageUse {
    /// What the stage's code says; unknown code is taken to trace rays.
    fn of(stage: u32, code: Option<&[u32]>) -> Self {
        let Some(module) = code.and_then(SpirvModule::parse) else {
            return Self {
                stage,
                ray_query: false,
                trace: true,
            };
        };
        let ray_query = module.declares_capability(CAPABILITY_RAY_QUERY);
        let traces = CAPABILITIES_RAY_TRACING
            .iter()
            .any(|c| module.declares_capability(*c));
        Self {
            stage,
            ray_query,
            trace: traces || !ray_query,
        }
    }
}

/// A descriptor set's acceleration-structure bindings: binding number to
/// (the layout binding's `stageFlags`, the structures by array element).
type AccelerationStructureBindings = BTreeMap<u32, (u32, BTreeMap<u32, Handle>)>;

/// What a command buffer has bound.
#[derive(Clone, Debug, Default)]
struct Bound {
    pipelines: HashMap<i32, Handle>,
    /// Shader objects by stage (`VkShaderStageFlagBits`).
    shaders: BTreeMap<u32, Handle>,
    /// Descriptor sets by (bind point, set number).
    sets: BTreeMap<(i32, u32), Handle>,
}

/// Ray-tracing pipelines a deferred operation is creating: recorded once
/// the operation completes, when `pPipelines` holds their handles.
#[derive(Clone, Debug)]
pub struct DeferredPipelines {
    pub infos: Vec<PipelineCreateInfo>,
    /// `pPipelines`, its provenance exposed: the application keeps it valid
    /// until the operation completes, as deferred commands require.
    pub pipelines_out: usize,
    pub count: u32,
}

/// The layer's own tracking for these commands, kept in [`DeviceState`].
#[derive(Debug, Default)]
pub struct PipeState {
    /// Each pipeline's stages, with those of the libraries it links.
    pipelines: HashMap<Handle, Vec<StageUse>>,
    shader_objects: HashMap<Handle, StageUse>,
    /// Descriptor set layouts' acceleration-structure bindings: (binding, stageFlags).
    set_layouts: HashMap<Handle, Vec<(u32, u32)>>,
    sets: HashMap<Handle, AccelerationStructureBindings>,
    command_buffers: HashMap<Handle, Bound>,
    pub deferred_pipelines: HashMap<Handle, DeferredPipelines>,
}

impl PipeState {
    /// Records how the stages of pipelines created from `infos` (handles
    /// `pipelines[i]`; NULL ones were not created) reach acceleration
    /// structures; module code comes from the validator's tracked modules.
    pub fn record_pipelines(
        &mut self,
        validator: &Validator,
        infos: &[PipelineCreateInfo],
        pipelines: &[Handle],
    ) {
        for (info, handle) in infos.iter().zip(pipelines) {
            if *handle == 0 {
                continue;
            }
            let mut uses: Vec<StageUse> = info
                .stages
                .iter()
                .map(|stage| {
                    let module = validator.state().shader_modules.get(&stage.module);
                    let code = stage.code.as_deref().or(module.map(|code| &code[..]));
                    StageUse::of(stage.stage, code)
                })
                .collect();
            for library in info.libraries.iter().flatten() {
                uses.extend(self.pipelines.get(library).into_iter().flatten());
            }
            uses.dedup();
            self.pipelines.insert(*handle, uses);
        }
    }

    pub fn destroy_pipeline(&mut self, pipeline: Handle) {
        self.pipelines.remove(&pipeline);
    }

    pub fn record_shaders(&mut self, infos: &[ShaderCreateInfo], shaders: &[Handle]) {
        for (info, handle) in infos.iter().zip(shaders) {
            if *handle != 0 {
                let code = (!info.code.is_empty()).then_some(&info.code[..]);
                self.shader_objects
                    .insert(*handle, StageUse::of(info.stage, code));
            }
        }
    }

    pub fn destroy_shader(&mut self, shader: Handle) {
        self.shader_objects.remove(&shader);
    }

    /// What is bound for `command` in `command_buffer`, with every
    /// acceleration structure its shaders may reach (see the module's
    /// documentation for what "reach" means here).
    fn bound_work(&self, command: WorkCommand, command_buffer: Handle) -> BoundWork {
        let point = bind_point(command);
        let Some(bound) = self.command_buffers.get(&command_buffer) else {
            return BoundWork::default();
        };
        let pipeline = bound.pipelines.get(&point).copied().unwrap_or(0);
        let users: Vec<(AccessingShader, StageUse)> = if pipeline != 0 {
            self.pipelines
                .get(&pipeline)
                .into_iter()
                .flatten()
                .map(|u| (AccessingShader::PipelineStage(u.stage), *u))
                .collect()
        } else {
            let stages = shader_object_stages(point);
            bound
                .shaders
                .iter()
                .filter(|(stage, _)| *stage & stages != 0)
                .filter_map(|(_, shader)| {
                    let found = self.shader_objects.get(shader)?;
                    Some((AccessingShader::ShaderObject(*shader), *found))
                })
                .collect()
        };
        let mut accesses = Vec::new();
        let sets = bound
            .sets
            .range((point, 0)..=(point, u32::MAX))
            .filter_map(|(_, set)| self.sets.get(set));
        for bindings in sets {
            for (stage_flags, structures) in bindings.values() {
                for (shader, using) in users.iter().filter(|(_, u)| u.stage & stage_flags != 0) {
                    for structure in structures.values().filter(|s| **s != 0) {
                        let modes = [(true, using.ray_query), (false, using.trace)];
                        for (ray_query, _) in modes.into_iter().filter(|(_, used)| *used) {
                            accesses.push(AccelerationStructureAccess {
                                acceleration_structure: *structure,
                                ray_query,
                                shader: *shader,
                            });
                        }
                    }
                }
            }
        }
        BoundWork { pipeline, accesses }
    }
}

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
                    state.pipe.set_layouts.insert(layout.as_raw(), bindings);
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
            state.pipe.set_layouts.remove(&layout.as_raw());
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
                for (layout, set) in layouts.iter().zip(sets) {
                    let bindings = state
                        .pipe
                        .set_layouts
                        .get(layout)
                        .into_iter()
                        .flatten()
                        .map(|(binding, stages)| (*binding, (*stages, BTreeMap::new())))
                        .collect();
                    state.pipe.sets.insert(set, bindings);
                }
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
            for set in freed {
                state.pipe.sets.remove(&set);
            }
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
            let sets = &mut state.pipe.sets;
            for write in writes {
                let binding = sets
                    .get_mut(&write.dst_set)
                    .and_then(|set| set.get_mut(&write.dst_binding));
                let Some((_, elements)) = binding else {
                    continue;
                };
                for (k, structure) in (0u32..).zip(write.structures) {
                    if let Some(element) = write.dst_array_element.checked_add(k) {
                        elements.insert(element, structure);
                    }
                }
            }
            for ((src_set, src_binding, src_first), (dst_set, dst_binding, dst_first), count) in
                copies
            {
                let end = src_first.saturating_add(count);
                let copied: Vec<(u32, Handle)> = sets
                    .get(&src_set)
                    .and_then(|set| set.get(&src_binding))
                    .map(|(_, elements)| {
                        elements
                            .range(src_first..end)
                            .map(|(element, s)| (element - src_first, *s))
                            .collect()
                    })
                    .unwrap_or_default();
                let target = sets
                    .get_mut(&dst_set)
                    .and_then(|set| set.get_mut(&dst_binding));
                if let Some((_, elements)) = target {
                    for (offset, structure) in copied {
                        if let Some(element) = dst_first.checked_add(offset) {
                            elements.insert(element, structure);
                        }
                    }
                }
            }
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, write_count, writes, copy_count, copies) };
    })
}

/// The tracking of `command_buffer`'s bindings.
fn bound_in(state: &mut DeviceState, command_buffer: vk::CommandBuffer) -> &mut Bound {
    state
        .pipe
        .command_buffers
        .entry(command_buffer.as_raw())
        .or_default()
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
            let bound = bound_in(state, command_buffer);
            for (set_number, set) in (first_set..).zip(bound_sets) {
                bound.sets.insert((bind_point.as_raw(), set_number), set);
            }
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
            let bound = bound_in(state, command_buffer);
            let stages = shader_object_stages(bind_point.as_raw());
            bound.shaders.retain(|stage, _| stage & stages == 0);
            bound
                .pipelines
                .insert(bind_point.as_raw(), pipeline.as_raw());
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
            let bound = bound_in(state, command_buffer);
            for (k, stage) in stage_list.into_iter().enumerate() {
                for point in [BIND_POINT_GRAPHICS, BIND_POINT_COMPUTE] {
                    if shader_object_stages(point) & stage != 0 {
                        bound.pipelines.remove(&point);
                    }
                }
                match shader_list.get(k).copied().filter(|s| *s != 0) {
                    Some(shader) => bound.shaders.insert(stage, shader),
                    None => bound.shaders.remove(&stage),
                };
            }
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
