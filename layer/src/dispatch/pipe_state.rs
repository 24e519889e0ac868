//! What the bound shaders of a command that runs them may reach: the
//! pipeline or shader objects bound per command buffer, the stages of
//! each pipeline and shader object, and the acceleration structures
//! written to the descriptor sets bound beside them ([`PipeState`], kept
//! in the device state; `crate::work` feeds it).
//!
//! What "reach" means here is an over-approximation of the specification's
//! "statically used": every acceleration structure written to a descriptor
//! set that is bound at the command's bind point counts as reached by every
//! stage of the bound pipeline (or every bound shader object) whose stage
//! the set layout binding's `stageFlags` include. Whether a stage reaches
//! it through a ray query or by tracing rays comes from its SPIR-V: a module
//! declaring `RayQueryKHR` uses ray queries, one declaring a ray-tracing
//! capability (or none of these, or whose code is unknown) traces rays.

use std::collections::BTreeMap;

use ash::vk;
use foldhash::HashMap;
use ommcheck::checks::pipeline_sync::spirv::SpirvModule;
use ommcheck::checks::pipeline_sync::WorkCommand;
use ommcheck::model::pipeline::{
    AccelerationStructureAccess, AccessingShader, BoundWork, PipelineCreateInfo, ShaderCreateInfo,
};
use ommcheck::model::Handle;
use ommcheck::raw::pipeline::{AccelerationStructureWrite, DescriptorCopy};
use ommcheck::Validator;

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

/// The layer's own tracking for these commands, kept in [`DeviceState`](super::DeviceState).
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

    /// A descriptor set layout was created with these acceleration-structure
    /// bindings: (binding, stageFlags).
    pub fn create_set_layout(&mut self, layout: Handle, bindings: Vec<(u32, u32)>) {
        self.set_layouts.insert(layout, bindings);
    }

    pub fn destroy_set_layout(&mut self, layout: Handle) {
        self.set_layouts.remove(&layout);
    }

    /// Sets were allocated with these layouts: each starts with its
    /// layout's acceleration-structure bindings, empty.
    pub fn allocate_sets(&mut self, layouts: &[Handle], sets: Vec<Handle>) {
        for (layout, set) in layouts.iter().zip(sets) {
            let bindings = self
                .set_layouts
                .get(layout)
                .into_iter()
                .flatten()
                .map(|(binding, stages)| (*binding, (*stages, BTreeMap::new())))
                .collect();
            self.sets.insert(set, bindings);
        }
    }

    pub fn free_sets(&mut self, sets: Vec<Handle>) {
        for set in sets {
            self.sets.remove(&set);
        }
    }

    /// Records acceleration-structure writes, and copies between tracked sets.
    pub fn update_sets(
        &mut self,
        writes: Vec<AccelerationStructureWrite>,
        copies: Vec<DescriptorCopy>,
    ) {
        let sets = &mut self.sets;
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
        for ((src_set, src_binding, src_first), (dst_set, dst_binding, dst_first), count) in copies
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
    }

    /// The tracking of `command_buffer`'s bindings.
    fn bound_in(&mut self, command_buffer: Handle) -> &mut Bound {
        self.command_buffers.entry(command_buffer).or_default()
    }

    /// `vkCmdBindDescriptorSets` bound `sets` from `first_set` on.
    pub fn bind_sets(
        &mut self,
        command_buffer: Handle,
        bind_point: i32,
        first_set: u32,
        sets: Vec<Handle>,
    ) {
        let bound = self.bound_in(command_buffer);
        for (set_number, set) in (first_set..).zip(sets) {
            bound.sets.insert((bind_point, set_number), set);
        }
    }

    /// The pipeline replaces shader objects of its bind point.
    pub fn bind_pipeline(&mut self, command_buffer: Handle, bind_point: i32, pipeline: Handle) {
        let bound = self.bound_in(command_buffer);
        let stages = shader_object_stages(bind_point);
        bound.shaders.retain(|stage, _| stage & stages == 0);
        bound.pipelines.insert(bind_point, pipeline);
    }

    /// Shader objects (0: none) replace the pipeline of the bind point
    /// their stages belong to.
    pub fn bind_shaders(
        &mut self,
        command_buffer: Handle,
        stage_list: Vec<u32>,
        shader_list: Vec<Handle>,
    ) {
        let bound = self.bound_in(command_buffer);
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
    }

    /// What is bound for `command` in `command_buffer`, with every
    /// acceleration structure its shaders may reach (see the module's
    /// documentation for what "reach" means here).
    pub fn bound_work(&self, command: WorkCommand, command_buffer: Handle) -> BoundWork {
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
