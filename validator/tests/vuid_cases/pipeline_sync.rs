//! Cases for the `pipeline_sync` checks: barriers and stage masks, pipeline
//! and shader creation flags, the SPIR-V rules, the micromap feature and
//! property structures, and the draw/dispatch/trace-rays rules.

use ommcheck::checks::pipeline_sync::spirv::build::TestModule;
use ommcheck::checks::pipeline_sync::WorkCommand;
use ommcheck::device::ext;
use ommcheck::model::accel::*;
use ommcheck::model::pipeline::*;
use ommcheck::model::Handle;
use ommcheck::state::Buffer;
use ommcheck::vuids::vuid;
use ommcheck::vuids::vuid::{
    vkCmdResetEvent2 as reset_event, vkCmdWriteBufferMarker2AMD as buffer_marker,
    vkCmdWriteTimestamp2 as timestamp, RuntimeSpirv as spirv,
    VkBufferMemoryBarrier2 as buffer_barrier, VkComputePipelineCreateInfo as compute,
    VkDeviceCreateInfo as device_info, VkGraphicsPipelineCreateInfo as graphics,
    VkImageMemoryBarrier2 as image_barrier, VkMemoryBarrier2 as memory_barrier,
    VkMemoryMarkerInfoAMD as marker_info, VkMemoryRangeBarrierKHR as range_barrier,
    VkPhysicalDeviceDisplacementMicromapFeaturesNV as nv_features,
    VkPhysicalDeviceDisplacementMicromapPropertiesNV as nv_properties,
    VkPhysicalDeviceOpacityMicromapFeaturesEXT as ext_features,
    VkPhysicalDeviceOpacityMicromapFeaturesKHR as khr_features,
    VkPhysicalDeviceOpacityMicromapPropertiesEXT as ext_properties,
    VkPhysicalDeviceOpacityMicromapPropertiesKHR as khr_properties,
    VkPhysicalDevicePipelineOpacityMicromapFeaturesARM as arm_features,
    VkPhysicalDeviceProperties2 as properties2, VkRayTracingPipelineCreateInfoKHR as rt_khr,
    VkRayTracingPipelineCreateInfoNV as rt_nv, VkSemaphoreSubmitInfo as semaphore_info,
    VkShaderCreateInfoEXT as shader_info,
};
use ommcheck::{Device, Report, Validator};

use crate::accel_attach::{DESERIALIZED_BLAS, DESERIALIZED_MICROMAP, OTHER_MICROMAP};
use crate::fixtures::{command_buffer, device};
use crate::{case, Case};

const COMPUTE_SHADER: u64 = 0x800;
const TRANSFER: u64 = 0x1000;

fn without_micromap_ext() -> Device {
    let mut d = device();
    d.features.micromap_ext = false;
    d
}

fn without_micromap_khr() -> Device {
    let mut d = device();
    d.features.micromap_khr = false;
    d
}

// ---------------------------------------------------------------- barriers

/// Which array of `VkDependencyInfo` a barrier goes into.
#[derive(Clone, Copy)]
enum List {
    Memory,
    Buffer,
    Image,
    Range,
}

/// One barrier with `stage`/`access` on the source or destination side (the
/// other side harmless), recorded with `vkCmdPipelineBarrier2`.
fn barrier(list: List, src: bool, stage: u64, access: u64, device: Device) -> Report {
    let harmless = (COMPUTE_SHADER, ACCESS_SHADER_READ);
    let (src_side, dst_side) = if src {
        ((stage, access), harmless)
    } else {
        (harmless, (stage, access))
    };
    let one = vec![Barrier {
        src_stage_mask: src_side.0,
        src_access_mask: src_side.1,
        dst_stage_mask: dst_side.0,
        dst_access_mask: dst_side.1,
    }];
    let mut info = DependencyInfo::default();
    match list {
        List::Memory => info.memory_barriers = one,
        List::Buffer => info.buffer_memory_barriers = one,
        List::Image => info.image_memory_barriers = one,
        List::Range => info.memory_range_barriers = one,
    }
    Validator::new(device).cmd_pipeline_barrier2(&command_buffer(), &info)
}

/// The eight cases of one barrier structure.
macro_rules! barrier_cases {
    ($($list:ident => $m:ident),* $(,)?) => {
        vec![$(
            case($m::srcStageMask_11541,
                || barrier(List::$list, true, STAGE_MICROMAP_BUILD, 0, without_micromap_ext()),
                || barrier(List::$list, true, COMPUTE_SHADER, 0, without_micromap_ext())),
            case($m::dstStageMask_11541,
                || barrier(List::$list, false, STAGE_MICROMAP_BUILD, 0, without_micromap_ext()),
                || barrier(List::$list, false, COMPUTE_SHADER, 0, without_micromap_ext())),
            case($m::srcAccessMask_07454,
                || barrier(List::$list, true, TRANSFER, ACCESS_SHADER_READ, device()),
                || barrier(List::$list, true, STAGE_MICROMAP_BUILD, ACCESS_SHADER_READ, device())),
            case($m::dstAccessMask_07454,
                || barrier(List::$list, false, TRANSFER, ACCESS_SHADER_READ, device()),
                || barrier(List::$list, false, STAGE_ALL_COMMANDS, ACCESS_SHADER_READ, device())),
            case($m::srcAccessMask_07457,
                || barrier(List::$list, true, STAGE_ACCELERATION_STRUCTURE_BUILD, ACCESS_MICROMAP_WRITE, device()),
                || barrier(List::$list, true, STAGE_MICROMAP_BUILD, ACCESS_MICROMAP_WRITE, device())),
            case($m::dstAccessMask_07457,
                || barrier(List::$list, false, COMPUTE_SHADER, ACCESS_MICROMAP_WRITE, device()),
                || barrier(List::$list, false, STAGE_MICROMAP_BUILD, ACCESS_MICROMAP_WRITE, device())),
            case($m::srcAccessMask_07458,
                || barrier(List::$list, true, COMPUTE_SHADER, ACCESS_MICROMAP_READ, device()),
                || barrier(List::$list, true, STAGE_ACCELERATION_STRUCTURE_BUILD, ACCESS_MICROMAP_READ, device())),
            case($m::dstAccessMask_07458,
                || barrier(List::$list, false, COMPUTE_SHADER, ACCESS_MICROMAP_READ, device()),
                || barrier(List::$list, false, STAGE_MICROMAP_BUILD, ACCESS_MICROMAP_READ, device())),
        )*]
    };
}

/// A barrier whose destination is ALL_COMMANDS with SHADER_READ, recorded
/// in a command buffer of a family with `queue_flags`.
fn all_commands_shader_read(queue_flags: u32) -> Report {
    let info = DependencyInfo {
        memory_barriers: vec![Barrier {
            src_stage_mask: TRANSFER,
            src_access_mask: 0,
            dst_stage_mask: STAGE_ALL_COMMANDS,
            dst_access_mask: ACCESS_SHADER_READ,
        }],
        ..Default::default()
    };
    let cb = ommcheck::model::CommandBuffer {
        queue_flags,
        ..command_buffer()
    };
    Validator::new(device()).cmd_pipeline_barrier2(&cb, &info)
}

fn submit(stage_mask: u64) -> Report {
    let info = SemaphoreSubmitInfo {
        semaphore: 0x5e,
        stage_mask,
        ..Default::default()
    };
    Validator::new(without_micromap_ext()).queue_submit2(&[SubmitInfo2 {
        wait_semaphore_infos: vec![info],
        signal_semaphore_infos: vec![],
    }])
}

fn reset(stage: u64) -> Report {
    Validator::new(without_micromap_ext()).cmd_reset_event2(&command_buffer(), 0xe7, stage)
}

fn stamp(stage: u64) -> Report {
    Validator::new(without_micromap_ext()).cmd_write_timestamp2(&command_buffer(), stage, 0x9f, 0)
}

fn marker2(stage: u64) -> Report {
    Validator::new(without_micromap_ext()).cmd_write_buffer_marker2_amd(
        &command_buffer(),
        stage,
        0xbf,
        0,
        1,
    )
}

fn marker_to_memory(stage: u64) -> Report {
    Validator::new(without_micromap_ext()).cmd_write_marker_to_memory_amd(
        &command_buffer(),
        &MemoryMarkerInfo {
            stage,
            dst_address: 0x1000,
            marker: 1,
        },
    )
}

fn sync_cases() -> Vec<Case> {
    let mut cases = barrier_cases!(
        Memory => memory_barrier,
        Buffer => buffer_barrier,
        Image => image_barrier,
        Range => range_barrier,
    );
    cases.extend([
        case(
            semaphore_info::stageMask_11541,
            || submit(STAGE_MICROMAP_BUILD),
            || submit(COMPUTE_SHADER),
        ),
        case(
            reset_event::stageMask_11541,
            || reset(STAGE_MICROMAP_BUILD | COMPUTE_SHADER),
            || reset(COMPUTE_SHADER),
        ),
        case(
            timestamp::stage_11541,
            || stamp(STAGE_MICROMAP_BUILD),
            || stamp(TRANSFER),
        ),
        case(
            buffer_marker::stage_11541,
            || marker2(STAGE_MICROMAP_BUILD),
            || marker2(TRANSFER),
        ),
        case(
            marker_info::stage_11541,
            || marker_to_memory(STAGE_MICROMAP_BUILD),
            || marker_to_memory(TRANSFER),
        ),
    ]);
    cases
}

// --------------------------------------------------------------- pipelines

const LIBRARY: Handle = 0x11b;
const PIPELINE: Handle = 0x9e;
const RAYGEN: u32 = 0x100;

fn flags(flags: u32) -> PipelineCreateFlags {
    PipelineCreateFlags {
        flags,
        flags2: None,
    }
}

fn flags2(flags2: u64) -> PipelineCreateFlags {
    PipelineCreateFlags {
        flags: 0,
        flags2: Some(flags2),
    }
}

fn info(flags: PipelineCreateFlags) -> PipelineCreateInfo {
    PipelineCreateInfo {
        flags,
        ..Default::default()
    }
}

const RT_OPACITY: u32 = CREATE_RAY_TRACING_OPACITY_MICROMAP as u32;
const DISPLACEMENT: u32 = CREATE_RAY_TRACING_DISPLACEMENT_MICROMAP_NV as u32;

fn compute_with(device: Device, flags: PipelineCreateFlags) -> Report {
    Validator::new(device).create_compute_pipelines(&[info(flags)], &[PIPELINE])
}

fn graphics_with(device: Device, flags: PipelineCreateFlags) -> Report {
    Validator::new(device).create_graphics_pipelines(&[info(flags)], &[PIPELINE])
}

fn rt_khr_with(device: Device, flags: PipelineCreateFlags) -> Report {
    Validator::new(device).create_ray_tracing_pipelines_khr(&[info(flags)], &[PIPELINE])
}

fn rt_nv_with(flags: PipelineCreateFlags) -> Report {
    Validator::new(device()).create_ray_tracing_pipelines_nv(&[info(flags)], &[PIPELINE])
}

/// A pipeline linking a library created with `library_flags`.
fn with_library(
    kind_graphics: bool,
    library_flags: PipelineCreateFlags,
    flags: PipelineCreateFlags,
) -> Report {
    let mut v = Validator::new(device());
    let create = |v: &mut Validator, info: PipelineCreateInfo, handle: Handle| {
        if kind_graphics {
            v.create_graphics_pipelines(&[info], &[handle])
        } else {
            v.create_ray_tracing_pipelines_khr(&[info], &[handle])
        }
    };
    let first = create(&mut v, info(library_flags), LIBRARY);
    assert!(!first.has_errors(), "{first}");
    create(
        &mut v,
        PipelineCreateInfo {
            libraries: Some(vec![LIBRARY]),
            ..info(flags)
        },
        PIPELINE,
    )
}

fn shader_flags(device: Device, flags: u32) -> Report {
    Validator::new(device).create_shaders(
        &[ShaderCreateInfo {
            flags,
            ..Default::default()
        }],
        &[0x5a],
    )
}

fn module_with(module: TestModule) -> Report {
    Validator::new(device()).create_shader_module(0x3d, &module.words())
}

/// A ray-tracing pipeline whose raygen code declares `OpacityMicromapIdKHR`
/// with a specialization constant (SpecId 3) specialized to `id_value`.
fn disallowed_with_id_mode(id_value: u64) -> Report {
    let code = TestModule {
        opacity_micromap_id: Some((true, true)),
        ..Default::default()
    }
    .words();
    let stage = ShaderStage {
        stage: RAYGEN,
        name: "main".into(),
        code: Some(code),
        specialization: vec![SpecializationValue {
            constant_id: 3,
            value: id_value,
        }],
        ..Default::default()
    };
    Validator::new(device()).create_ray_tracing_pipelines_khr(
        &[PipelineCreateInfo {
            stages: vec![stage],
            ..info(flags2(CREATE_DISALLOW_OPACITY_MICROMAP_ARM))
        }],
        &[PIPELINE],
    )
}

fn pipeline_cases() -> Vec<Case> {
    vec![
        case(
            compute::flags_07367,
            || compute_with(device(), flags(RT_OPACITY)),
            || compute_with(device(), flags(0)),
        ),
        case(
            compute::flags_07996,
            || compute_with(device(), flags(DISPLACEMENT)),
            || compute_with(device(), flags(0)),
        ),
        case(
            compute::flags_11593,
            || {
                compute_with(
                    without_micromap_khr(),
                    flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                )
            },
            || compute_with(without_micromap_khr(), flags2(0)),
        ),
        case(
            graphics::flags_07401,
            || graphics_with(device(), flags(RT_OPACITY)),
            || graphics_with(device(), flags(0)),
        ),
        case(
            graphics::flags_07997,
            || graphics_with(device(), flags2(u64::from(DISPLACEMENT))),
            || graphics_with(device(), flags2(0)),
        ),
        case(
            graphics::flags_11595,
            || {
                graphics_with(
                    without_micromap_khr(),
                    flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                )
            },
            || graphics_with(device(), flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX)),
        ),
        case(
            graphics::pLibraries_11594,
            || with_library(true, flags2(0), flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX)),
            || {
                with_library(
                    true,
                    flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                    flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                )
            },
        ),
        case(
            rt_khr::flags_08701,
            || with_library(false, flags(0), flags(DISPLACEMENT)),
            || with_library(false, flags(DISPLACEMENT), flags(DISPLACEMENT)),
        ),
        case(
            rt_khr::pLibraries_11598,
            || with_library(false, flags(0), flags(RT_OPACITY)),
            || with_library(false, flags(RT_OPACITY), flags(RT_OPACITY)),
        ),
        case(
            rt_khr::flags_10392,
            || {
                rt_khr_with(
                    device(),
                    flags2(
                        CREATE_RAY_TRACING_OPACITY_MICROMAP | CREATE_DISALLOW_OPACITY_MICROMAP_ARM,
                    ),
                )
            },
            || rt_khr_with(device(), flags2(CREATE_RAY_TRACING_OPACITY_MICROMAP)),
        ),
        case(
            rt_khr::flags_11597,
            || {
                let mut d = without_micromap_khr();
                d.features.micromap_ext = false;
                rt_khr_with(d, flags(RT_OPACITY))
            },
            || rt_khr_with(without_micromap_khr(), flags(RT_OPACITY)),
        ),
        case(
            rt_khr::flags_11599,
            || rt_khr_with(device(), flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX)),
            || {
                rt_khr_with(
                    device(),
                    flags2(
                        CREATE_RAY_TRACING_OPACITY_MICROMAP | CREATE_DISALLOW_MIXED_SPECIAL_INDEX,
                    ),
                )
            },
        ),
        case(
            rt_nv::flags_07402,
            || rt_nv_with(flags(RT_OPACITY)),
            || rt_nv_with(flags(0)),
        ),
        case(
            rt_nv::flags_07998,
            || rt_nv_with(flags(DISPLACEMENT)),
            || rt_nv_with(flags(0)),
        ),
        case(
            rt_nv::flags_11596,
            || rt_nv_with(flags2(CREATE_DISALLOW_MIXED_SPECIAL_INDEX)),
            || rt_nv_with(flags2(0)),
        ),
        case(
            shader_info::micromap_11623,
            || {
                shader_flags(
                    without_micromap_khr(),
                    SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX,
                )
            },
            || shader_flags(device(), SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
        ),
        case(
            spirv::RayTracingOpacityMicromapKHR_11542,
            || {
                module_with(TestModule {
                    trace_ray_flags: Some(0x401),
                    ..Default::default()
                })
            },
            || {
                module_with(TestModule {
                    capability: true,
                    trace_ray_flags: Some(0x401),
                    ..Default::default()
                })
            },
        ),
        case(
            spirv::micromap_11630,
            || disallowed_with_id_mode(1),
            || disallowed_with_id_mode(0),
        ),
    ]
}

// -------------------------------------------------- features and properties

fn device_chain(next: &[ChainedStruct]) -> Report {
    Validator::new(device()).create_device(next)
}

fn properties_chain(next: &[ChainedStruct]) -> Report {
    Validator::new(device()).get_physical_device_properties2(next)
}

fn bad_s_type(which: MicromapStruct) -> [ChainedStruct; 1] {
    [ChainedStruct::Micromap { which, s_type: 0 }]
}

macro_rules! s_type_cases {
    ($($which:ident => $m:ident via $check:ident),* $(,)?) => {
        vec![$(
            case(
                $m::sType_sType,
                || $check(&bad_s_type(MicromapStruct::$which)),
                || $check(&[ChainedStruct::micromap(MicromapStruct::$which)]),
            ),
        )*]
    };
}

fn feature_cases() -> Vec<Case> {
    let mut cases = s_type_cases!(
        OpacityMicromapFeaturesExt => ext_features via device_chain,
        OpacityMicromapFeaturesKhr => khr_features via device_chain,
        DisplacementMicromapFeaturesNv => nv_features via device_chain,
        PipelineOpacityMicromapFeaturesArm => arm_features via device_chain,
        OpacityMicromapPropertiesExt => ext_properties via properties_chain,
        OpacityMicromapPropertiesKhr => khr_properties via properties_chain,
        DisplacementMicromapPropertiesNv => nv_properties via properties_chain,
    );
    cases.extend([
        case(
            device_info::pNext_pNext,
            || {
                device_chain(&[ChainedStruct::micromap(
                    MicromapStruct::OpacityMicromapPropertiesKhr,
                )])
            },
            || {
                device_chain(&[ChainedStruct::micromap(
                    MicromapStruct::OpacityMicromapFeaturesKhr,
                )])
            },
        ),
        case(
            properties2::pNext_pNext,
            || {
                properties_chain(&[ChainedStruct::Other(
                    MicromapStruct::OpacityMicromapFeaturesExt.s_type(),
                )])
            },
            || {
                properties_chain(&[ChainedStruct::micromap(
                    MicromapStruct::OpacityMicromapPropertiesExt,
                )])
            },
        ),
    ]);
    cases
}

// ------------------------------------------------ draw, dispatch, trace rays

const TLAS: Handle = 0xa5;
const SHADER: Handle = 0x5d;
const INDEX_BUFFER: Handle = 0x1d;
const INDEX_ADDRESS: u64 = 0x40_0000;

/// A validator where `TLAS` was built with `geometry`, a pipeline with
/// `pipeline_flags` whose raygen stage declares the id mode as `id_mode`,
/// and a shader object with `shader_flags`.
fn work_world(
    device: Device,
    geometry: MicromapGeometry,
    pipeline_flags: u64,
    id_mode: bool,
    shader_flags: u32,
) -> Validator {
    let mut v = Validator::new(device);
    let state = v.state_mut();
    state.micromap_geometry.insert(TLAS, geometry);
    state.pipelines.insert(
        PIPELINE,
        PipelineRecord {
            kind: PipelineKind::RayTracingKhr,
            flags: pipeline_flags,
            stages: vec![(
                RAYGEN,
                ShaderFacts {
                    opacity_micromap_id: Some(id_mode),
                },
            )],
        },
    );
    state.shader_objects.insert(
        SHADER,
        ShaderObjectRecord {
            flags: shader_flags,
            stage: RAYGEN,
            facts: ShaderFacts {
                opacity_micromap_id: Some(id_mode),
            },
        },
    );
    v
}

fn run(
    v: &mut Validator,
    command: WorkCommand,
    ray_query: bool,
    shader: AccessingShader,
) -> Report {
    run_on(v, command, TLAS, ray_query, shader)
}

/// `command` with PIPELINE bound, its `shader` reaching `structure`.
fn run_on(
    v: &mut Validator,
    command: WorkCommand,
    structure: Handle,
    ray_query: bool,
    shader: AccessingShader,
) -> Report {
    v.cmd_run_shaders(
        command,
        &command_buffer(),
        &BoundWork {
            pipeline: PIPELINE,
            accesses: vec![AccelerationStructureAccess {
                acceleration_structure: structure,
                ray_query,
                shader,
            }],
        },
    )
}

/// 11637: the shaders access a structure deserialized from a header naming
/// `named` (see [`crate::accel_attach::deserialized_world`]).
fn deserialized_access(command: WorkCommand, named: Handle) -> Report {
    let mut v = crate::accel_attach::deserialized_world(named, 0);
    let raygen = AccessingShader::PipelineStage(RAYGEN);
    run_on(&mut v, command, DESERIALIZED_BLAS, true, raygen)
}

/// 11636: KHR micromap geometry reached by a ray query, without the EXT
/// extension, from a raygen that declares the id mode as `id_mode`.
fn ray_query_mode(command: WorkCommand, id_mode: bool) -> Report {
    let mut d = device();
    d.extensions.remove(ext::EXT_OPACITY_MICROMAP);
    let geometry = MicromapGeometry {
        opacity_khr: true,
        ..Default::default()
    };
    let mut v = work_world(d, geometry, CREATE_RAY_TRACING_OPACITY_MICROMAP, id_mode, 0);
    run(
        &mut v,
        command,
        true,
        AccessingShader::PipelineStage(RAYGEN),
    )
}

/// A validator where `TLAS` is recorded from a build whose KHR opacity index
/// buffer holds `indices` (u16).
fn built_from_indices(v: &mut Validator, indices: &[u16]) {
    let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    v.state_mut().buffers.insert(
        INDEX_BUFFER,
        Buffer {
            size: bytes.len() as u64,
            device_address: Some(INDEX_ADDRESS),
            contents: Some(ommcheck::Bytes::from(bytes)),
            ..Default::default()
        },
    );
    let triangles = TrianglesData {
        opacity_khr: Some(TrianglesOpacityMicromapKhr {
            index_type: INDEX_TYPE_UINT16,
            index_buffer: INDEX_ADDRESS,
            index_stride: 2,
            ..Default::default()
        }),
        ..Default::default()
    };
    let info = BuildGeometryInfo {
        dst_acceleration_structure: TLAS,
        ..BuildGeometryInfo::with_geometries(
            ACCELERATION_STRUCTURE_TYPE_BOTTOM_LEVEL,
            vec![Geometry {
                geometry: GeometryData::Triangles(triangles),
                ..Default::default()
            }],
        )
    };
    let range = BuildRangeInfo {
        primitive_count: indices.len() as u32,
        ..Default::default()
    };
    v.record_micromap_geometry(&[info], &[Some(vec![range])]);
}

/// 11638: a pipeline with `pipeline_flags` reaching geometry whose index
/// buffer mixes a special index (0xffff) with a micromap index (1).
fn mixed_pipeline(command: WorkCommand, pipeline_flags: u64) -> Report {
    let mut v = work_world(
        device(),
        MicromapGeometry::default(),
        pipeline_flags | CREATE_RAY_TRACING_OPACITY_MICROMAP,
        true,
        0,
    );
    built_from_indices(&mut v, &[0xffff, 1]);
    run(
        &mut v,
        command,
        false,
        AccessingShader::PipelineStage(RAYGEN),
    )
}

/// 11639: a shader object with `shader_flags` reaching mixed geometry.
fn mixed_shader(command: WorkCommand, shader_flags: u32) -> Report {
    let geometry = MicromapGeometry {
        mixed_special_indices: true,
        ..Default::default()
    };
    let mut v = work_world(device(), geometry, 0, true, shader_flags);
    v.state_mut().pipelines.clear();
    run(
        &mut v,
        command,
        false,
        AccessingShader::ShaderObject(SHADER),
    )
}

/// 11640: rays traced into EXT micromap geometry by a pipeline with `pipeline_flags`.
fn traced_opacity(command: WorkCommand, pipeline_flags: u64) -> Report {
    let geometry = MicromapGeometry {
        opacity_ext: true,
        ..Default::default()
    };
    let mut v = work_world(device(), geometry, pipeline_flags, true, 0);
    run(
        &mut v,
        command,
        false,
        AccessingShader::PipelineStage(RAYGEN),
    )
}

macro_rules! work_cases {
    (plain: [$($plain:ident),* $(,)?], trace: [$($trace:ident),* $(,)?] $(,)?) => {{
        let mut cases: Vec<Case> = Vec::new();
        $(cases.extend([
            case(vuid::$plain::micromap_11636,
                || ray_query_mode(WorkCommand::$plain, false),
                || ray_query_mode(WorkCommand::$plain, true)),
            case(vuid::$plain::micromap_11638,
                || mixed_pipeline(WorkCommand::$plain, CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                || mixed_pipeline(WorkCommand::$plain, 0)),
            case(vuid::$plain::micromap_11639,
                || mixed_shader(WorkCommand::$plain, SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                || mixed_shader(WorkCommand::$plain, 0)),
            case(vuid::$plain::micromap_11637,
                || deserialized_access(WorkCommand::$plain, OTHER_MICROMAP),
                || deserialized_access(WorkCommand::$plain, DESERIALIZED_MICROMAP)),
        ]);)*
        $(cases.extend([
            case(vuid::$trace::micromap_11636,
                || ray_query_mode(WorkCommand::$trace, false),
                || ray_query_mode(WorkCommand::$trace, true)),
            case(vuid::$trace::micromap_11638,
                || mixed_pipeline(WorkCommand::$trace, CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                || mixed_pipeline(WorkCommand::$trace, 0)),
            case(vuid::$trace::micromap_11639,
                || mixed_shader(WorkCommand::$trace, SHADER_CREATE_DISALLOW_MIXED_SPECIAL_INDEX),
                || mixed_shader(WorkCommand::$trace, 0)),
            case(vuid::$trace::micromap_11640,
                || traced_opacity(WorkCommand::$trace, 0),
                || traced_opacity(WorkCommand::$trace, CREATE_RAY_TRACING_OPACITY_MICROMAP)),
            case(vuid::$trace::micromap_11637,
                || deserialized_access(WorkCommand::$trace, OTHER_MICROMAP),
                || deserialized_access(WorkCommand::$trace, DESERIALIZED_MICROMAP)),
        ]);)*
        cases
    }};
}

fn work_cases() -> Vec<Case> {
    work_cases! {
        plain: [
            vkCmdDispatch, vkCmdDispatchBase, vkCmdDispatchGraphAMDX, vkCmdDispatchGraphIndirectAMDX,
            vkCmdDispatchGraphIndirectCountAMDX, vkCmdDispatchIndirect, vkCmdDispatchIndirect2KHR,
            vkCmdDispatchTileQCOM, vkCmdDraw, vkCmdDrawClusterHUAWEI, vkCmdDrawClusterIndirectHUAWEI,
            vkCmdDrawIndexed, vkCmdDrawIndexedIndirect, vkCmdDrawIndexedIndirect2KHR,
            vkCmdDrawIndexedIndirectCount, vkCmdDrawIndexedIndirectCount2KHR, vkCmdDrawIndirect,
            vkCmdDrawIndirect2KHR, vkCmdDrawIndirectByteCount2EXT, vkCmdDrawIndirectByteCountEXT,
            vkCmdDrawIndirectCount, vkCmdDrawIndirectCount2KHR, vkCmdDrawMeshTasksEXT,
            vkCmdDrawMeshTasksIndirect2EXT, vkCmdDrawMeshTasksIndirectCount2EXT,
            vkCmdDrawMeshTasksIndirectCountEXT, vkCmdDrawMeshTasksIndirectCountNV,
            vkCmdDrawMeshTasksIndirectEXT, vkCmdDrawMeshTasksIndirectNV, vkCmdDrawMeshTasksNV,
            vkCmdDrawMultiEXT, vkCmdDrawMultiIndexedEXT, vkCmdExecuteGeneratedCommandsEXT,
            vkCmdExecuteGeneratedCommandsNV, vkCmdSubpassShadingHUAWEI, vkCmdTraceRaysNV,
        ],
        trace: [vkCmdTraceRaysIndirect2KHR, vkCmdTraceRaysIndirectKHR, vkCmdTraceRaysKHR],
    }
}

pub fn cases() -> Vec<Case> {
    use ommcheck::model::command::queue;
    let mut cases = sync_cases();
    cases.push(case(
        &ommcheck::rules::ACCESS_STAGE_ON_QUEUE,
        || all_commands_shader_read(queue::TRANSFER),
        || all_commands_shader_read(queue::COMPUTE | queue::TRANSFER),
    ));
    cases.extend(pipeline_cases());
    cases.extend(feature_cases());
    cases.extend(work_cases());
    cases
}

#[test]
fn a_traced_structure_whose_build_was_not_seen_is_reported_not_checked_once() {
    let command = WorkCommand::vkCmdTraceRaysKHR;
    let mut v = work_world(device(), MicromapGeometry::default(), 0, false, 0);
    let state = v.state_mut();
    state.micromap_geometry.remove(&TLAS);
    state
        .acceleration_structures
        .insert(TLAS, ommcheck::state::AccelerationStructure::default());
    let mut bound = BoundWork {
        pipeline: PIPELINE,
        accesses: Vec::new(),
    };
    for ray_query in [false, true] {
        bound.accesses.push(AccelerationStructureAccess {
            acceleration_structure: TLAS,
            ray_query,
            shader: AccessingShader::PipelineStage(RAYGEN),
        });
    }
    let report = v.cmd_run_shaders(command, &command_buffer(), &bound);
    let skipped: Vec<_> = report.not_checked().collect();
    assert_eq!(skipped.len(), 1, "{report}");
    assert_eq!(
        skipped[0].not_checked_cause(),
        Some(ommcheck::Cause::BuildNotSeen)
    );
    assert_eq!(skipped[0].objects[0].handle, TLAS);
    assert_eq!(skipped[0].not_checked.len(), 4);
    // With the build recorded, the rules are decided.
    let mut built = work_world(device(), MicromapGeometry::default(), 0, false, 0);
    let report = built.cmd_run_shaders(command, &command_buffer(), &bound);
    report.assert_fully_checked();
}

/// 11637 through a top-level structure: the shaders reach TLAS, whose one
/// instance references the deserialized structure.
#[test]
fn a_deserialized_structure_reached_through_instances_is_checked() {
    use crate::accel_attach::TLAS;
    for (named, fails) in [(OTHER_MICROMAP, true), (DESERIALIZED_MICROMAP, false)] {
        let mut v = crate::accel_attach::deserialized_world(named, 0);
        let instances = InstancesData {
            instances: Some(vec![Instance {
                acceleration_structure_reference: DESERIALIZED_BLAS,
                ..Default::default()
            }]),
            ..Default::default()
        };
        let geometry = Geometry {
            geometry_type: GEOMETRY_TYPE_INSTANCES,
            geometry: GeometryData::Instances(instances),
            ..Default::default()
        };
        let build = BuildGeometryInfo {
            dst_acceleration_structure: TLAS,
            ..BuildGeometryInfo::with_geometries(
                ACCELERATION_STRUCTURE_TYPE_TOP_LEVEL,
                vec![geometry],
            )
        };
        let range = BuildRangeInfo {
            primitive_count: 1,
            ..Default::default()
        };
        v.build_acceleration_structures(&[build], &[Some(vec![range])]);
        let raygen = AccessingShader::PipelineStage(RAYGEN);
        let report = run_on(&mut v, WorkCommand::vkCmdTraceRaysKHR, TLAS, false, raygen);
        let rule = vuid::vkCmdTraceRaysKHR::micromap_11637;
        assert_eq!(report.contains(rule), fails, "{report}");
        assert!(report.checked.contains(rule), "{report}");
    }
}
