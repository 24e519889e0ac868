//! Resolving the device, pipeline, shader, binding, shader-running,
//! synchronization, query and cluster calls of a scene to the validator's
//! model and running their checks.

use std::collections::BTreeMap;

use crate::Bytes;

use crate::checks::pipeline_sync::WorkCommand;
use crate::model::accel::{
    ClusterBuildTriangleClusterInfo, ClusterBuildTriangleClusterTemplateInfo,
    ClusterTriangleOpacity,
};
use crate::model::command::CommandBuffer;
use crate::model::pipeline::*;
use crate::model::Handle;
use crate::report::Report;

use super::super::format::*;
use super::{piece_len_hint, problem, ObjectKind, Resolver, Result};
use crate::model::names::{lookup, PipelineBindPoint, StructureType, Value};

/// What a command buffer has bound: a pipeline per bind point and a shader
/// object per stage.
#[derive(Clone, Debug, Default)]
pub(super) struct Bound {
    pipelines: BTreeMap<i32, Handle>,
    shaders: BTreeMap<u32, Handle>,
}

const BIND_POINT_GRAPHICS: i32 = ash::vk::PipelineBindPoint::GRAPHICS.as_raw();
const BIND_POINT_COMPUTE: i32 = ash::vk::PipelineBindPoint::COMPUTE.as_raw();
const BIND_POINT_RAY_TRACING: i32 = ash::vk::PipelineBindPoint::RAY_TRACING_KHR.as_raw();
const BIND_POINT_SUBPASS_SHADING: i32 = ash::vk::PipelineBindPoint::SUBPASS_SHADING_HUAWEI.as_raw();
const BIND_POINT_EXECUTION_GRAPH: i32 = ash::vk::PipelineBindPoint::EXECUTION_GRAPH_AMDX.as_raw();
const STAGE_COMPUTE: u32 = ash::vk::ShaderStageFlags::COMPUTE.as_raw();

/// The bind point whose pipeline a command runs.
fn bind_point(command: WorkCommand, explicit: Option<Value<PipelineBindPoint>>) -> i32 {
    let name = command.function();
    if name.starts_with("vkCmdExecuteGeneratedCommands") {
        explicit.map_or(BIND_POINT_GRAPHICS, Value::as_i32)
    } else if name.starts_with("vkCmdTraceRays") {
        BIND_POINT_RAY_TRACING
    } else if name.starts_with("vkCmdDispatchGraph") {
        BIND_POINT_EXECUTION_GRAPH
    } else if name.starts_with("vkCmdDispatch") {
        BIND_POINT_COMPUTE
    } else if name == "vkCmdSubpassShadingHUAWEI" {
        BIND_POINT_SUBPASS_SHADING
    } else {
        BIND_POINT_GRAPHICS
    }
}

fn structure_type(name: &str) -> i32 {
    lookup::<StructureType>(name).unwrap_or_default() as i32
}

/// The structures of a feature or property chain, as the feature checks
/// take them: micromap structures by their sType, or by `structure` when
/// written with another sType.
fn feature_chain(next: &[ChainStruct]) -> Vec<ChainedStruct> {
    next.iter()
        .map(|entry| {
            let s_type = entry.s_type();
            let named = match entry {
                ChainStruct::Other(OtherStruct {
                    structure: Some(name),
                    ..
                }) => MicromapStruct::ALL.into_iter().find(|s| s.name() == name),
                _ => None,
            };
            match named.or_else(|| MicromapStruct::from_s_type(s_type)) {
                Some(which) => ChainedStruct::Micromap { which, s_type },
                None => ChainedStruct::Other(s_type),
            }
        })
        .collect()
}

fn barrier(d: &BarrierDesc) -> Barrier {
    Barrier {
        src_stage_mask: d.src_stage_mask.as_u64(),
        src_access_mask: d.src_access_mask.as_u64(),
        dst_stage_mask: d.dst_stage_mask.as_u64(),
        dst_access_mask: d.dst_access_mask.as_u64(),
    }
}

fn barriers(list: &[BarrierDesc]) -> Vec<Barrier> {
    list.iter().map(barrier).collect()
}

fn dependency_info(d: &DependencyInfoDesc) -> DependencyInfo {
    DependencyInfo {
        memory_barriers: barriers(&d.p_memory_barriers),
        buffer_memory_barriers: barriers(&d.p_buffer_memory_barriers),
        image_memory_barriers: barriers(&d.p_image_memory_barriers),
        memory_range_barriers: d
            .p_next
            .iter()
            .filter(|n| n.s_type.as_i32() == STRUCTURE_TYPE_MEMORY_RANGE_BARRIERS_INFO_KHR)
            .flat_map(|n| n.p_memory_range_barriers.iter().flatten().map(barrier))
            .collect(),
    }
}

fn semaphore_infos(
    resolver: &mut Resolver<'_>,
    list: &[SemaphoreSubmitInfoDesc],
    at: &str,
) -> Result<Vec<SemaphoreSubmitInfo>> {
    list.iter()
        .enumerate()
        .map(|(k, d)| resolver.semaphore_submit_info(d, &format!("{at}[{k}]")))
        .collect()
}

fn cluster_opacity(
    resolver: &Resolver<'_>,
    d: &ClusterTriangleInfoDesc,
    at: &str,
) -> Result<ClusterTriangleOpacity> {
    Ok(ClusterTriangleOpacity {
        opacity_micromap_index_type: d.opacity_micromap_index_type.as_u32(),
        opacity_micromap_index_buffer_stride: d.opacity_micromap_index_buffer_stride,
        opacity_micromap_array: resolver.address(
            &d.opacity_micromap_array,
            &format!("{at}.opacityMicromapArray"),
        )?,
        opacity_micromap_index_buffer: resolver.address(
            &d.opacity_micromap_index_buffer,
            &format!("{at}.opacityMicromapIndexBuffer"),
        )?,
    })
}

impl Resolver<'_> {
    /// A handle of an object that carries no state ommcheck reads (events,
    /// semaphores): a new name denotes a new object.
    pub(super) fn loose_handle(
        &mut self,
        arg: &super::HandleArg,
        kind: ObjectKind,
        at: &str,
    ) -> Result<Handle> {
        if let super::HandleArg::Name(name) = arg {
            if !self.objects.contains_key(name) {
                return self.bind(name, kind, at);
            }
        }
        self.handle(arg, kind, at)
    }

    /// The bytes `contents` describes, as long as its pieces reach.
    pub(super) fn sized_contents(&mut self, contents: &Contents, at: &str) -> Result<Bytes> {
        let mut end = 0u64;
        for (k, piece) in contents.pieces().iter().enumerate() {
            let len = match (piece_len_hint(piece), &piece.file) {
                (Some(len), _) => len,
                (None, Some(file)) => match std::fs::metadata(self.base_dir.join(file)) {
                    Ok(meta) => meta.len(),
                    Err(e) => return problem(format!("{at}[{k}].file"), format!("{file}: {e}")),
                },
                (None, None) => 0,
            };
            let Some(piece_end) = piece.at.checked_add(len) else {
                return problem(format!("{at}[{k}].at"), "the piece ends past 2^64");
            };
            end = end.max(piece_end);
        }
        self.contents(contents, end, at)
    }

    /// SPIR-V words: contents whose length is a multiple of 4.
    fn spirv_words(&mut self, contents: &Contents, at: &str) -> Result<Vec<u32>> {
        let bytes = self.sized_contents(contents, at)?;
        if bytes.len() % 4 != 0 {
            return problem(
                at,
                format!(
                    "{} bytes of SPIR-V: codeSize must be a multiple of 4",
                    bytes.len()
                ),
            );
        }
        Ok(bytes
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
            .collect())
    }

    /// The values of a `VkSpecializationInfo`: every map entry must select
    /// 1 to 8 bytes of pData.
    fn specialization(
        &mut self,
        d: &Option<SpecializationInfoDesc>,
        at: &str,
    ) -> Result<Vec<SpecializationValue>> {
        let Some(d) = d else {
            return Ok(Vec::new());
        };
        let info = self.specialization_info(d, at)?;
        for (k, entry) in info.map_entries.iter().enumerate() {
            if entry.size == 0 || SpecializationValue::of(entry, &info.data).is_none() {
                return problem(
                    format!("{at}.pMapEntries[{k}]"),
                    format!(
                        "offset {} and size {} do not select 1 to 8 bytes of the {} bytes of pData",
                        entry.offset,
                        entry.size,
                        info.data.len()
                    ),
                );
            }
        }
        Ok(SpecializationValue::all(&info))
    }

    fn shader_stage(&mut self, d: &ShaderStageDesc, at: &str) -> Result<ShaderStage> {
        let module_create_info = structure_type("VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO");
        let mut code = None;
        for (k, next) in d.p_next.iter().enumerate() {
            if let (true, Some(words)) = (next.s_type.as_i32() == module_create_info, &next.p_code)
            {
                code = Some(self.spirv_words(words, &format!("{at}.pNext[{k}].pCode"))?);
            }
        }
        Ok(ShaderStage {
            stage: d.stage.as_u32(),
            module: self.handle(&d.module, ObjectKind::ShaderModule, &format!("{at}.module"))?,
            name: d.p_name.clone(),
            code,
            specialization: self.specialization(
                &d.p_specialization_info,
                &format!("{at}.pSpecializationInfo"),
            )?,
        })
    }

    fn pipeline_create_info(
        &mut self,
        d: &PipelineCreateInfoDesc,
        at: &str,
    ) -> Result<PipelineCreateInfo> {
        // The last of each chained structure counts, as in the raw reader.
        let mut flags2 = None;
        let mut libraries = None;
        for (k, next) in d.p_next.iter().enumerate() {
            let next_at = format!("{at}.pNext[{k}]");
            match next {
                ChainStruct::PipelineCreateFlags2CreateInfo(e) => {
                    flags2 = Some(self.pipeline_create_flags2_create_info(e, &next_at)?.flags);
                }
                ChainStruct::PipelineLibraryCreateInfo(e) => {
                    libraries = Some(self.pipeline_library_create_info(e, &next_at)?.libraries);
                }
                _ => {}
            }
        }
        if let Some(info) = &d.p_library_info {
            let info_at = format!("{at}.pLibraryInfo");
            libraries = Some(self.pipeline_library_create_info(info, &info_at)?.libraries);
        }
        let mut stages = Vec::new();
        if let Some(stage) = &d.stage {
            stages.push(self.shader_stage(stage, &format!("{at}.stage"))?);
        }
        for (k, stage) in d.p_stages.iter().enumerate() {
            stages.push(self.shader_stage(stage, &format!("{at}.pStages[{k}]"))?);
        }
        Ok(PipelineCreateInfo {
            flags: PipelineCreateFlags {
                flags: d.flags.as_u32(),
                flags2,
            },
            stages,
            libraries,
        })
    }

    /// The create infos and the names of the new objects, one per info.
    fn new_names(
        &mut self,
        names: &[String],
        infos: usize,
        kind: ObjectKind,
        member: &str,
        at: &str,
    ) -> Result<Vec<Handle>> {
        if names.len() != infos {
            return problem(
                format!("{at}.{member}"),
                format!(
                    "{} names for {infos} create infos: give one name per create info",
                    names.len()
                ),
            );
        }
        names
            .iter()
            .enumerate()
            .map(|(k, name)| self.bind(name, kind, &format!("{at}.{member}[{k}]")))
            .collect()
    }

    fn create_pipelines(
        &mut self,
        kind: PipelineKind,
        infos: &[PipelineCreateInfoDesc],
        names: &[String],
        at: &str,
    ) -> Result<Report> {
        let infos = infos
            .iter()
            .enumerate()
            .map(|(i, d)| self.pipeline_create_info(d, &format!("{at}.pCreateInfos[{i}]")))
            .collect::<Result<Vec<_>>>()?;
        let handles = self.new_names(names, infos.len(), ObjectKind::Pipeline, "pPipelines", at)?;
        Ok(match kind {
            PipelineKind::Compute => self.validator.create_compute_pipelines(&infos, &handles),
            PipelineKind::Graphics => self.validator.create_graphics_pipelines(&infos, &handles),
            PipelineKind::RayTracingKhr => self
                .validator
                .create_ray_tracing_pipelines_khr(&infos, &handles),
            PipelineKind::RayTracingNv => self
                .validator
                .create_ray_tracing_pipelines_nv(&infos, &handles),
        })
    }

    fn create_shaders(&mut self, c: &CreateShaders, at: &str) -> Result<Report> {
        let mut infos = Vec::new();
        for (i, d) in c.p_create_infos.iter().enumerate() {
            let info_at = format!("{at}.pCreateInfos[{i}]");
            let defaults = ShaderCreateInfo::default();
            infos.push(ShaderCreateInfo {
                flags: d.flags.as_u32(),
                stage: d.stage.as_u32(),
                code_type: d.code_type.map_or(defaults.code_type, Value::as_i32),
                code: self.spirv_words(&d.p_code, &format!("{info_at}.pCode"))?,
                name: d.p_name.clone(),
                specialization: self.specialization(
                    &d.p_specialization_info,
                    &format!("{info_at}.pSpecializationInfo"),
                )?,
            });
        }
        let handles = self.new_names(
            &c.p_shaders,
            infos.len(),
            ObjectKind::Shader,
            "pShaders",
            at,
        )?;
        Ok(self.validator.create_shaders(&infos, &handles))
    }

    fn bind_pipeline(&mut self, c: &CmdBindPipeline, at: &str) -> Result<Report> {
        let command_buffer = self.command_buffer(&c.command_buffer, at)?;
        let pipeline = self.handle(&c.pipeline, ObjectKind::Pipeline, &format!("{at}.pipeline"))?;
        self.bound
            .entry(command_buffer.handle)
            .or_default()
            .pipelines
            .insert(c.pipeline_bind_point.as_i32(), pipeline);
        Ok(Report::new())
    }

    /// Binding shader objects replaces the pipeline of the bind point their
    /// stages belong to, as `vkCmdBindShadersEXT` does.
    fn bind_shaders(&mut self, c: &CmdBindShaders, at: &str) -> Result<Report> {
        let command_buffer = self.command_buffer(&c.command_buffer, at)?;
        if c.p_stages.len() != c.p_shaders.len() {
            return problem(
                format!("{at}.pShaders"),
                format!(
                    "{} shaders for {} stages: stageCount is the length of both",
                    c.p_shaders.len(),
                    c.p_stages.len()
                ),
            );
        }
        let mut shaders = Vec::new();
        for (k, (stage, shader)) in c.p_stages.iter().zip(&c.p_shaders).enumerate() {
            let handle = self.handle(shader, ObjectKind::Shader, &format!("{at}.pShaders[{k}]"))?;
            shaders.push((stage.as_u32(), handle));
        }
        let bound = self.bound.entry(command_buffer.handle).or_default();
        for (stage, handle) in shaders {
            let point = if stage == STAGE_COMPUTE {
                BIND_POINT_COMPUTE
            } else {
                BIND_POINT_GRAPHICS
            };
            bound.pipelines.remove(&point);
            if handle == 0 {
                bound.shaders.remove(&stage);
            } else {
                bound.shaders.insert(stage, handle);
            }
        }
        Ok(Report::new())
    }

    /// A command that runs shaders: each acceleration structure its shaders
    /// use is reached by the bound pipeline's stage, or else by the shader
    /// object bound to the stage.
    fn run_shaders(&mut self, call: &RunShadersCall, at: &str) -> Result<Report> {
        let command = call.command.0;
        let c = &call.params;
        let command_buffer = self.command_buffer(&c.command_buffer, at)?;
        let bound = self
            .bound
            .get(&command_buffer.handle)
            .cloned()
            .unwrap_or_default();
        let pipeline = bound
            .pipelines
            .get(&bind_point(command, c.pipeline_bind_point))
            .copied()
            .unwrap_or(0);
        let mut accesses = Vec::new();
        for (k, d) in c.acceleration_structures.iter().enumerate() {
            let stage = d.stage.as_u32();
            let shader = match bound.shaders.get(&stage) {
                Some(shader) if pipeline == 0 => AccessingShader::ShaderObject(*shader),
                _ => AccessingShader::PipelineStage(stage),
            };
            accesses.push(AccelerationStructureAccess {
                acceleration_structure: self.handle(
                    &d.acceleration_structure,
                    ObjectKind::AccelerationStructure,
                    &format!("{at}.accelerationStructures[{k}].accelerationStructure"),
                )?,
                ray_query: d.ray_query,
                shader,
            });
        }
        let work = BoundWork { pipeline, accesses };
        Ok(self
            .validator
            .cmd_run_shaders(command, &command_buffer, &work))
    }

    fn cluster_build(
        &mut self,
        c: &CmdBuildClusterAccelerationStructureIndirect,
        at: &str,
    ) -> Result<Report> {
        self.command_buffer(&c.command_buffer, at)?;
        let info = &c.p_command_infos;
        let flags = info.input.flags.as_u32();
        let op_at = format!("{at}.pCommandInfos.input.opType");
        let array_at = format!("{at}.pCommandInfos.srcInfosArray");
        let opacity = info
            .src_infos_array
            .iter()
            .enumerate()
            .map(|(k, d)| {
                Ok((
                    d.cluster_id,
                    d.triangle_count,
                    cluster_opacity(self, d, &format!("{array_at}[{k}]"))?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(match info.input.op_type.raw() {
            2 => {
                let infos: Vec<_> = opacity
                    .into_iter()
                    .map(|(cluster_id, triangle_count, opacity)| ClusterBuildTriangleClusterInfo {
                        cluster_id,
                        triangle_count,
                        opacity,
                    })
                    .collect();
                self.validator
                    .cmd_build_cluster_triangle_clusters(flags, &infos)
            }
            3 => {
                let infos: Vec<_> = opacity
                    .into_iter()
                    .map(|(cluster_id, triangle_count, opacity)| {
                        ClusterBuildTriangleClusterTemplateInfo {
                            cluster_id,
                            triangle_count,
                            opacity,
                        }
                    })
                    .collect();
                self.validator
                    .cmd_build_cluster_triangle_cluster_templates(flags, &infos)
            }
            other => {
                return problem(
                    op_at,
                    format!("opType {other}: scenes express the triangle-cluster builds (VK_CLUSTER_ACCELERATION_STRUCTURE_OP_TYPE_BUILD_TRIANGLE_CLUSTER_NV or ..._TEMPLATE_NV), whose inputs carry opacity micromaps"),
                )
            }
        })
    }

    /// The command buffer and query pool of a query command.
    fn query_command(
        &self,
        command_buffer: &CommandBufferArg,
        query_pool: &super::HandleArg,
        at: &str,
    ) -> Result<(CommandBuffer, Handle)> {
        Ok((
            self.command_buffer(command_buffer, at)?,
            self.handle(
                query_pool,
                ObjectKind::QueryPool,
                &format!("{at}.queryPool"),
            )?,
        ))
    }

    /// The calls of this module; None for any other call.
    pub(super) fn pipeline_call(&mut self, call: &Call, at: &str) -> Option<Result<Report>> {
        Some(match call {
            Call::CreateDevice(c) => Ok(self
                .validator
                .create_device(&feature_chain(&c.p_create_info.p_next))),
            Call::GetPhysicalDeviceProperties2(c) => Ok(self
                .validator
                .get_physical_device_properties2(&feature_chain(&c.p_properties.p_next))),
            Call::CreateShaderModule(c) => (|| {
                let code =
                    self.spirv_words(&c.p_create_info.p_code, &format!("{at}.pCreateInfo.pCode"))?;
                let module = self.bind(
                    &c.p_shader_module,
                    ObjectKind::ShaderModule,
                    &format!("{at}.pShaderModule"),
                )?;
                Ok(self.validator.create_shader_module(module, &code))
            })(),
            Call::CreateComputePipelines(c) => {
                self.create_pipelines(PipelineKind::Compute, &c.p_create_infos, &c.p_pipelines, at)
            }
            Call::CreateGraphicsPipelines(c) => self.create_pipelines(
                PipelineKind::Graphics,
                &c.p_create_infos,
                &c.p_pipelines,
                at,
            ),
            Call::CreateRayTracingPipelinesKhr(c) => self.create_pipelines(
                PipelineKind::RayTracingKhr,
                &c.p_create_infos,
                &c.p_pipelines,
                at,
            ),
            Call::CreateRayTracingPipelinesNv(c) => self.create_pipelines(
                PipelineKind::RayTracingNv,
                &c.p_create_infos,
                &c.p_pipelines,
                at,
            ),
            Call::CreateShaders(c) => self.create_shaders(c, at),
            Call::CmdBindPipeline(c) => self.bind_pipeline(c, at),
            Call::CmdBindShaders(c) => self.bind_shaders(c, at),
            Call::RunShaders(c) => self.run_shaders(c, at),
            Call::CmdPipelineBarrier2(c) => self.command_buffer(&c.command_buffer, at).map(|cb| {
                self.validator
                    .cmd_pipeline_barrier2(&cb, &dependency_info(&c.p_dependency_info))
            }),
            Call::CmdSetEvent2(c) => (|| {
                let cb = self.command_buffer(&c.command_buffer, at)?;
                let event =
                    self.loose_handle(&c.event, ObjectKind::Event, &format!("{at}.event"))?;
                Ok(self.validator.cmd_set_event2(
                    &cb,
                    event,
                    &dependency_info(&c.p_dependency_info),
                ))
            })(),
            Call::CmdWaitEvents2(c) => (|| {
                let cb = self.command_buffer(&c.command_buffer, at)?;
                let events = c
                    .p_events
                    .iter()
                    .enumerate()
                    .map(|(k, e)| {
                        self.loose_handle(e, ObjectKind::Event, &format!("{at}.pEvents[{k}]"))
                    })
                    .collect::<Result<Vec<_>>>()?;
                let infos: Vec<_> = c.p_dependency_infos.iter().map(dependency_info).collect();
                Ok(self.validator.cmd_wait_events2(&cb, &events, &infos))
            })(),
            Call::CmdResetEvent2(c) => (|| {
                let cb = self.command_buffer(&c.command_buffer, at)?;
                let event =
                    self.loose_handle(&c.event, ObjectKind::Event, &format!("{at}.event"))?;
                Ok(self
                    .validator
                    .cmd_reset_event2(&cb, event, c.stage_mask.as_u64()))
            })(),
            Call::CmdWriteTimestamp2(c) => (|| {
                let cb = self.command_buffer(&c.command_buffer, at)?;
                let pool = self.handle(
                    &c.query_pool,
                    ObjectKind::QueryPool,
                    &format!("{at}.queryPool"),
                )?;
                Ok(self
                    .validator
                    .cmd_write_timestamp2(&cb, c.stage.as_u64(), pool, c.query))
            })(),
            Call::CmdWriteBufferMarker2Amd(c) => (|| {
                let cb = self.command_buffer(&c.command_buffer, at)?;
                let buffer = self.handle(
                    &c.dst_buffer,
                    ObjectKind::Buffer,
                    &format!("{at}.dstBuffer"),
                )?;
                Ok(self.validator.cmd_write_buffer_marker2_amd(
                    &cb,
                    c.stage.as_u64(),
                    buffer,
                    c.dst_offset,
                    c.marker,
                ))
            })(),
            Call::CmdWriteMarkerToMemoryAmd(c) => (|| {
                let cb = self.command_buffer(&c.command_buffer, at)?;
                let info = MemoryMarkerInfo {
                    stage: c.p_info.stage.as_u64(),
                    dst_address: self
                        .address(&c.p_info.dst_address, &format!("{at}.pInfo.dstAddress"))?,
                    marker: c.p_info.marker,
                };
                Ok(self.validator.cmd_write_marker_to_memory_amd(&cb, &info))
            })(),
            Call::QueueSubmit2(c) => (|| {
                let mut submits = Vec::new();
                for (i, d) in c.p_submits.iter().enumerate() {
                    let submit_at = format!("{at}.pSubmits[{i}]");
                    submits.push(SubmitInfo2 {
                        wait_semaphore_infos: semaphore_infos(
                            self,
                            &d.p_wait_semaphore_infos,
                            &format!("{submit_at}.pWaitSemaphoreInfos"),
                        )?,
                        signal_semaphore_infos: semaphore_infos(
                            self,
                            &d.p_signal_semaphore_infos,
                            &format!("{submit_at}.pSignalSemaphoreInfos"),
                        )?,
                    });
                }
                let mut report = self.validator.queue_submit2(&submits);
                report.extend(self.submit2_execution(c, &submits, at)?);
                Ok(report)
            })(),
            Call::CmdBeginQuery(c) => self
                .query_command(&c.command_buffer, &c.query_pool, at)
                .map(|(cb, pool)| self.validator.cmd_begin_query(&cb, pool)),
            Call::CmdBeginQueryIndexed(c) => self
                .query_command(&c.command_buffer, &c.query_pool, at)
                .map(|(cb, pool)| self.validator.cmd_begin_query_indexed(&cb, pool)),
            Call::CmdBuildClusterAccelerationStructureIndirect(c) => self.cluster_build(c, at),
            Call::Execution(c) => self.execution_call(c, at),
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn specialization(json: &str) -> std::result::Result<Vec<SpecializationValue>, String> {
        let desc: SpecializationInfoDesc = serde_json::from_str(json).unwrap();
        crate::scene::resolve_alone(|r| r.specialization(&Some(desc), "x"))
    }

    #[test]
    fn specialization_values_are_read_from_the_data_and_bad_entries_rejected() {
        let data = r#""pData": {"u8": [9, 0, 0, 0, 1, 2, 0, 0]}"#;
        let values = specialization(&format!(
            r#"{{"pMapEntries": [{{"constantID": 3, "offset": 4}}, {{"constantID": 5, "size": 1}}], {data}}}"#
        ));
        let value = |constant_id, value| SpecializationValue { constant_id, value };
        assert_eq!(values, Ok(vec![value(3, 0x0201), value(5, 9)]));
        let past_the_end = specialization(&format!(
            r#"{{"pMapEntries": [{{"constantID": 3, "offset": 6}}], {data}}}"#
        ));
        assert_eq!(
            past_the_end,
            Err("x.pMapEntries[0]: offset 6 and size 4 do not select 1 to 8 bytes of the 8 bytes of pData".to_string())
        );
        let empty = specialization(&format!(
            r#"{{"pMapEntries": [{{"constantID": 3, "size": 0}}], {data}}}"#
        ));
        assert!(empty.is_err(), "{empty:?}");
    }
}
