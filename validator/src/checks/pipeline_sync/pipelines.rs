//! Pipeline and shader creation: the micromap create flags of the four
//! pipeline create-info structures and of `VkShaderCreateInfoEXT`, their
//! pipeline libraries, and the SPIR-V rules (`RuntimeSpirv`) decided from the
//! code and its specialization constants.

use ommcheck_vuids::vuid::{
    RuntimeSpirv as spirv_vuid, VkComputePipelineCreateInfo as compute,
    VkGraphicsPipelineCreateInfo as graphics, VkRayTracingPipelineCreateInfoKHR as rt_khr,
    VkRayTracingPipelineCreateInfoNV as rt_nv, VkShaderCreateInfoEXT as shader_info,
};
use ommcheck_vuids::Vuid;

use super::spirv::{
    Origin, SpirvModule, CAPABILITY_RAY_TRACING_OPACITY_MICROMAP,
    RAY_FLAGS_FORCE_OPACITY_MICROMAP_2_STATE,
};
use crate::checks::{Ctx, Validator};
use crate::model::pipeline::*;
use crate::model::Handle;
use crate::report::Report;

pub(super) const ENFORCED: &[Vuid] = &[
    compute::flags_07367,
    compute::flags_07996,
    compute::flags_11593,
    graphics::flags_07401,
    graphics::flags_07997,
    graphics::flags_11595,
    graphics::pLibraries_11594,
    rt_khr::flags_08701,
    rt_khr::flags_10392,
    rt_khr::flags_11597,
    rt_khr::flags_11599,
    rt_khr::pLibraries_11598,
    rt_nv::flags_07402,
    rt_nv::flags_07998,
    rt_nv::flags_11596,
    shader_info::micromap_11623,
    spirv_vuid::RayTracingOpacityMicromapKHR_11542,
    spirv_vuid::micromap_11630,
];

/// Which constants of a module a check reads: those fixed at module
/// creation, or those a pipeline specializes (the others were checked with
/// the module), or all of them (code given with the pipeline or shader).
#[derive(Clone, Copy, PartialEq, Eq)]
enum ConstantsChecked {
    ModuleOnly,
    SpecializedOnly,
    All,
}

impl ConstantsChecked {
    fn includes(self, origin: Origin) -> bool {
        match self {
            ConstantsChecked::ModuleOnly => origin == Origin::Constant,
            ConstantsChecked::SpecializedOnly => origin == Origin::Specialization,
            ConstantsChecked::All => true,
        }
    }
}

impl Validator {
    /// `vkCreateShaderModule(device, pCreateInfo, pAllocator, pShaderModule)`:
    /// checks the constants fixed at creation and remembers the code.
    pub fn create_shader_module(&mut self, module: Handle, code: &[u32]) -> Report {
        let mut ctx = self.ctx("vkCreateShaderModule");
        if let Some(spirv) = SpirvModule::parse(code) {
            forced_2_state(
                &mut ctx,
                &spirv,
                &[],
                ConstantsChecked::ModuleOnly,
                "pCreateInfo->pCode",
            );
        }
        let report = ctx.finish();
        self.state.shader_modules.insert(module, code.into());
        report
    }

    /// `vkCreateComputePipelines`; `pipelines[i]` is the handle created from `infos[i]`.
    pub fn create_compute_pipelines(
        &mut self,
        infos: &[PipelineCreateInfo],
        pipelines: &[Handle],
    ) -> Report {
        self.create_pipelines(PipelineKind::Compute, infos, pipelines)
    }

    /// `vkCreateGraphicsPipelines`.
    pub fn create_graphics_pipelines(
        &mut self,
        infos: &[PipelineCreateInfo],
        pipelines: &[Handle],
    ) -> Report {
        self.create_pipelines(PipelineKind::Graphics, infos, pipelines)
    }

    /// `vkCreateRayTracingPipelinesKHR`.
    pub fn create_ray_tracing_pipelines_khr(
        &mut self,
        infos: &[PipelineCreateInfo],
        pipelines: &[Handle],
    ) -> Report {
        self.create_pipelines(PipelineKind::RayTracingKhr, infos, pipelines)
    }

    /// `vkCreateRayTracingPipelinesNV`.
    pub fn create_ray_tracing_pipelines_nv(
        &mut self,
        infos: &[PipelineCreateInfo],
        pipelines: &[Handle],
    ) -> Report {
        self.create_pipelines(PipelineKind::RayTracingNv, infos, pipelines)
    }

    fn create_pipelines(
        &mut self,
        kind: PipelineKind,
        infos: &[PipelineCreateInfo],
        pipelines: &[Handle],
    ) -> Report {
        let function = match kind {
            PipelineKind::Compute => "vkCreateComputePipelines",
            PipelineKind::Graphics => "vkCreateGraphicsPipelines",
            PipelineKind::RayTracingKhr => "vkCreateRayTracingPipelinesKHR",
            PipelineKind::RayTracingNv => "vkCreateRayTracingPipelinesNV",
        };
        let mut ctx = self.ctx(function);
        let mut records = Vec::new();
        for (i, info) in infos.iter().enumerate() {
            let at = format!("pCreateInfos[{i}]");
            create_flags(&mut ctx, kind, info, &at);
            let stages = stages(&mut ctx, kind, info, &at);
            records.push(pipeline_record(&ctx, kind, info, stages));
        }
        let report = ctx.finish();
        for (handle, record) in pipelines.iter().zip(records) {
            self.state.pipelines.insert(*handle, record);
        }
        report
    }

    /// `vkCreateShadersEXT`; `shaders[i]` is the handle created from `infos[i]`.
    pub fn create_shaders(&mut self, infos: &[ShaderCreateInfo], shaders: &[Handle]) -> Report {
        let mut ctx = self.ctx("vkCreateShadersEXT");
        let mut records = Vec::new();
        for (i, info) in infos.iter().enumerate() {
            let at = format!("pCreateInfos[{i}]");
            ctx.require(
                info.flags & SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX == 0
                    || ctx.device.features.micromap_khr,
                shader_info::micromap_11623,
                || format!("{at}.flags"),
                || format!("{:#x} includes VK_SHADER_CREATE_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_EXT, but the VkPhysicalDeviceOpacityMicromapFeaturesKHR::micromap feature is not enabled", info.flags),
            );
            let spirv = (info.code_type == SHADER_CODE_TYPE_SPIRV)
                .then(|| SpirvModule::parse(&info.code))
                .flatten();
            if let Some(spirv) = &spirv {
                forced_2_state(
                    &mut ctx,
                    spirv,
                    &info.specialization,
                    ConstantsChecked::All,
                    &format!("{at}.pCode"),
                );
            }
            records.push(ShaderObjectRecord {
                flags: info.flags,
                stage: info.stage,
                facts: ShaderFacts {
                    opacity_micromap_id: spirv
                        .map(|s| s.opacity_micromap_id(&info.name, &info.specialization)),
                },
            });
        }
        let report = ctx.finish();
        for (handle, record) in shaders.iter().zip(records) {
            self.state.shader_objects.insert(*handle, record);
        }
        report
    }
}

/// A flag bit that must be clear, with its name.
struct Forbidden {
    bit: u64,
    name: &'static str,
    vuid: Vuid,
}

/// The create-flag rules of each structure.
fn create_flags(ctx: &mut Ctx<'_>, kind: PipelineKind, info: &PipelineCreateInfo, at: &str) {
    let flags = info.flags.effective();
    let flags_at = || format!("{at}.{}", info.flags.member());
    let opacity = Forbidden {
        bit: CREATE_RAY_TRACING_OPACITY_MICROMAP,
        name: "VK_PIPELINE_CREATE_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR",
        vuid: compute::flags_07367,
    };
    let displacement = Forbidden {
        bit: CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_NV,
        name: "VK_PIPELINE_CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_BIT_NV",
        vuid: compute::flags_07996,
    };
    let mixed = Forbidden {
        bit: CREATE_DISALLOW_MIXED_SPECIAL_INDEX,
        name: "VK_PIPELINE_CREATE_2_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_KHR",
        vuid: compute::flags_11593,
    };
    let micromap_khr = ctx.device.features.micromap_khr;
    let forbidden: Vec<Forbidden> = match kind {
        PipelineKind::Compute | PipelineKind::Graphics => {
            let (opacity_vuid, displacement_vuid, mixed_vuid) = if kind == PipelineKind::Compute {
                (
                    compute::flags_07367,
                    compute::flags_07996,
                    compute::flags_11593,
                )
            } else {
                (
                    graphics::flags_07401,
                    graphics::flags_07997,
                    graphics::flags_11595,
                )
            };
            let mut list = vec![
                Forbidden {
                    vuid: opacity_vuid,
                    ..opacity
                },
                Forbidden {
                    vuid: displacement_vuid,
                    ..displacement
                },
            ];
            if !micromap_khr {
                list.push(Forbidden {
                    vuid: mixed_vuid,
                    ..mixed
                });
            }
            list
        }
        PipelineKind::RayTracingNv => vec![
            Forbidden {
                vuid: rt_nv::flags_07402,
                ..opacity
            },
            Forbidden {
                vuid: rt_nv::flags_07998,
                ..displacement
            },
            Forbidden {
                vuid: rt_nv::flags_11596,
                ..opacity
            },
            Forbidden {
                vuid: rt_nv::flags_11596,
                ..mixed
            },
        ],
        PipelineKind::RayTracingKhr => {
            ray_tracing_khr_flags(ctx, info, at);
            if !micromap_khr || flags & CREATE_RAY_TRACING_OPACITY_MICROMAP == 0 {
                vec![Forbidden {
                    vuid: rt_khr::flags_11599,
                    ..mixed
                }]
            } else {
                Vec::new()
            }
        }
    };
    for rule in forbidden {
        ctx.require(flags & rule.bit == 0, rule.vuid, flags_at, || {
            format!("{flags:#x} includes {}", rule.name)
        });
    }
    let library_rules: &[(u64, &str, Vuid)] = match kind {
        PipelineKind::Graphics => &[(
            CREATE_DISALLOW_MIXED_SPECIAL_INDEX,
            "VK_PIPELINE_CREATE_2_OPACITY_MICROMAP_DISALLOW_MIXED_SPECIAL_INDEX_BIT_KHR",
            graphics::pLibraries_11594,
        )],
        PipelineKind::RayTracingKhr => &[
            (
                CREATE_RAY_TRACING_OPACITY_MICROMAP,
                "VK_PIPELINE_CREATE_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR",
                rt_khr::pLibraries_11598,
            ),
            (
                CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_NV,
                "VK_PIPELINE_CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_BIT_NV",
                rt_khr::flags_08701,
            ),
        ],
        PipelineKind::Compute | PipelineKind::RayTracingNv => &[],
    };
    for (bit, name, vuid) in library_rules {
        if flags & bit != 0 {
            libraries_have(ctx, kind, info, at, *bit, name, *vuid);
        }
    }
}

/// 10392 and 11597, which only `VkRayTracingPipelineCreateInfoKHR` has.
fn ray_tracing_khr_flags(ctx: &mut Ctx<'_>, info: &PipelineCreateInfo, at: &str) {
    let flags = info.flags.effective();
    let opacity = flags & CREATE_RAY_TRACING_OPACITY_MICROMAP != 0;
    if let Some(flags2) = info.flags.flags2 {
        ctx.require(
            !(opacity && flags2 & CREATE_DISALLOW_OPACITY_MICROMAP_ARM != 0),
            rt_khr::flags_10392,
            || format!("{at}.pNext<VkPipelineCreateFlags2CreateInfo>.flags"),
            || format!("{flags2:#x} includes both VK_PIPELINE_CREATE_2_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR and VK_PIPELINE_CREATE_2_DISALLOW_OPACITY_MICROMAP_BIT_ARM"),
        );
    }
    let features = &ctx.device.features;
    ctx.require(
        !opacity || features.micromap_khr || features.micromap_ext,
        rt_khr::flags_11597,
        || format!("{at}.{}", info.flags.member()),
        || format!("{flags:#x} includes VK_PIPELINE_CREATE_RAY_TRACING_OPACITY_MICROMAP_BIT_KHR, but neither the KHR nor the EXT micromap feature is enabled"),
    );
}

/// Each library the checker knows must have been created with `bit`.
fn libraries_have(
    ctx: &mut Ctx<'_>,
    kind: PipelineKind,
    info: &PipelineCreateInfo,
    at: &str,
    bit: u64,
    name: &str,
    vuid: Vuid,
) {
    let member = if kind == PipelineKind::Graphics {
        "pNext<VkPipelineLibraryCreateInfoKHR>.pLibraries"
    } else {
        "pLibraryInfo->pLibraries"
    };
    for (k, library) in info.libraries.iter().flatten().enumerate() {
        if let Some(record) = ctx.state.and_then(|state| state.pipelines.get(library)) {
            if record.flags & bit == 0 {
                ctx.error(
                    vuid,
                    format!("{at}.{member}[{k}]"),
                    format!("VkPipeline {library:#x} was created with flags {:#x}, without {name}, which the pipeline's flags include", record.flags),
                );
            }
        }
    }
}

/// The SPIR-V rules of each stage; returns what each stage's code says.
fn stages(
    ctx: &mut Ctx<'_>,
    kind: PipelineKind,
    info: &PipelineCreateInfo,
    at: &str,
) -> Vec<(u32, ShaderFacts)> {
    let disallowed = info.flags.effective() & CREATE_DISALLOW_OPACITY_MICROMAP_ARM != 0;
    let mut facts = Vec::new();
    for (k, stage) in info.stages.iter().enumerate() {
        let stage_at = if kind == PipelineKind::Compute {
            format!("{at}.stage")
        } else {
            format!("{at}.pStages[{k}]")
        };
        let (spirv, checked, code_at) = match &stage.code {
            Some(code) => (
                SpirvModule::parse(code),
                ConstantsChecked::All,
                format!("{stage_at}.pNext<VkShaderModuleCreateInfo>.pCode"),
            ),
            None => (
                ctx.state
                    .and_then(|state| state.shader_modules.get(&stage.module))
                    .and_then(|code| SpirvModule::parse(code)),
                ConstantsChecked::SpecializedOnly,
                format!("{stage_at}.module"),
            ),
        };
        let Some(spirv) = spirv else {
            facts.push((stage.stage, ShaderFacts::default()));
            continue;
        };
        forced_2_state(ctx, &spirv, &stage.specialization, checked, &code_at);
        let id_mode = spirv.opacity_micromap_id(&stage.name, &stage.specialization);
        ctx.require(
            !(id_mode && disallowed),
            spirv_vuid::micromap_11630,
            || stage_at.clone(),
            || format!("entry point \"{}\" declares OpacityMicromapIdKHR with a true operand, but the pipeline is created with VK_PIPELINE_CREATE_2_DISALLOW_OPACITY_MICROMAP_BIT_ARM", stage.name),
        );
        facts.push((
            stage.stage,
            ShaderFacts {
                opacity_micromap_id: Some(id_mode),
            },
        ));
    }
    facts
}

/// 11542: without the RayTracingOpacityMicromapKHR capability, no constant
/// Rayflags operand may include ForceOpacityMicromap2StateKHR.
fn forced_2_state(
    ctx: &mut Ctx<'_>,
    spirv: &SpirvModule,
    specialization: &[SpecializationValue],
    checked: ConstantsChecked,
    at: &str,
) {
    if spirv.declares_capability(CAPABILITY_RAY_TRACING_OPACITY_MICROMAP) {
        return;
    }
    for use_ in spirv.constant_ray_flags(specialization) {
        if checked.includes(use_.origin)
            && use_.flags & RAY_FLAGS_FORCE_OPACITY_MICROMAP_2_STATE != 0
        {
            ctx.error(
                spirv_vuid::RayTracingOpacityMicromapKHR_11542,
                at,
                format!("{} (instruction {}) has Rayflags {:#x}, which include ForceOpacityMicromap2StateKHR, but the module does not declare the RayTracingOpacityMicromapKHR capability", use_.instruction, use_.index, use_.flags),
            );
        }
    }
}

/// What the tracked state keeps of a created pipeline: its flags, and its
/// stages with those of the libraries it links.
fn pipeline_record(
    ctx: &Ctx<'_>,
    kind: PipelineKind,
    info: &PipelineCreateInfo,
    mut stages: Vec<(u32, ShaderFacts)>,
) -> PipelineRecord {
    for library in info.libraries.iter().flatten() {
        if let Some(record) = ctx.state.and_then(|state| state.pipelines.get(library)) {
            stages.extend(record.stages.iter().copied());
        }
    }
    // Libraries of libraries repeat stages; keep each (stage, facts) once so
    // records stay small however deep the linking goes.
    stages.sort_unstable();
    stages.dedup();
    PipelineRecord {
        kind,
        flags: info.flags.effective(),
        stages,
    }
}
