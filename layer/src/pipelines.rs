//! Shader modules, pipelines and shader objects: each creation is checked
//! before the driver runs (the core's checks with no handles yet, so nothing
//! is recorded), then what the driver created is recorded with its handles
//! (the core's same call, its report discarded: the call was checked).

#![allow(unsafe_code)]

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::model::pipeline::PipelineCreateInfo;
use ommcheck::model::Handle;
use ommcheck::raw::pipeline::{self as raw, StructReader};
use ommcheck::{Report, Validator};

use crate::dispatch::pipe_state::DeferredPipelines;
use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::{check, device_and, device_object, guarded, track};

/// One of the core's four pipeline-creation checks.
type CreatePipelines = fn(&mut Validator, &[PipelineCreateInfo], &[Handle]) -> Report;

/// `vkCreateShaderModule`: the constants fixed in the code are checked;
/// the code is kept for the pipelines that use the module.
pub unsafe extern "system" fn create_shader_module(
    device: vk::Device,
    create_info: *const vk::ShaderModuleCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    module_out: *mut vk::ShaderModule,
) -> vk::Result {
    let function = "vkCreateShaderModule";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.pipe.create_shader_module) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        let mut code = Vec::new();
        let skip = check(&data, function, device_object(device), |state| {
            let mut findings = Vec::new();
            // SAFETY: the create info is valid (the API's requirement).
            if let Some(info) = unsafe { create_info.as_ref() } {
                // SAFETY: pCode is readable for codeSize bytes (the API's requirement).
                code = unsafe {
                    raw::shader_module_code(info, function, "pCreateInfo", &mut findings)
                };
            }
            // Handle 0 stands for the module the driver has not created yet.
            let mut report = state.validator.create_shader_module(0, &code);
            state.validator.state_mut().shader_modules.remove(&0);
            report.findings.splice(0..0, findings);
            report
        });
        if skip {
            return vk::Result::ERROR_VALIDATION_FAILED_EXT;
        }
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, create_info, allocator, module_out) };
        if result == vk::Result::SUCCESS {
            // SAFETY: on success the next layer wrote the handle.
            if let Some(module) = unsafe { crate::read::value(module_out) } {
                track(&data, function, |state| {
                    let modules = &mut state.validator.state_mut().shader_modules;
                    modules.insert(module.as_raw(), code.into());
                });
            }
        }
        result
    })
}

/// `vkDestroyShaderModule`.
pub unsafe extern "system" fn destroy_shader_module(
    device: vk::Device,
    module: vk::ShaderModule,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let function = "vkDestroyShaderModule";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.pipe.destroy_shader_module) else {
            return;
        };
        track(&data, function, |state| {
            let modules = &mut state.validator.state_mut().shader_modules;
            modules.remove(&module.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, module, allocator) };
    })
}

/// Reads and checks `count` pipeline create infos before the driver runs;
/// returns whether a messenger asked to skip the call, and what was read.
fn check_pipelines<T>(
    data: &DeviceData,
    function: &'static str,
    device: vk::Device,
    (count, infos): (u32, *const T),
    read: StructReader<T, PipelineCreateInfo>,
    run: CreatePipelines,
) -> (bool, Vec<PipelineCreateInfo>) {
    let mut model = Vec::new();
    let skip = check(data, function, device_object(device), |state| {
        let mut findings = Vec::new();
        // SAFETY: the create infos are valid for `count` (the API's requirement).
        model =
            unsafe { raw::structs(infos, count, "pCreateInfos", read, function, &mut findings) };
        let mut report = run(&mut state.validator, &model, &[]);
        report.findings.splice(0..0, findings);
        report
    });
    (skip, model)
}

/// Records the pipelines created from `model`, whose handles are `pipelines`.
fn record_pipelines(
    state: &mut DeviceState,
    run: CreatePipelines,
    model: &[PipelineCreateInfo],
    pipelines: &[Handle],
) {
    // The call was checked before the driver ran; this records it.
    let _ = run(&mut state.validator, model, pipelines);
    // Handles the driver left NULL (VK_PIPELINE_COMPILE_REQUIRED) name nothing.
    state.validator.state_mut().pipelines.remove(&0);
    state
        .pipe
        .record_pipelines(&state.validator, model, pipelines);
}

/// Whether a pipeline-creation result left handles in `pPipelines`.
fn created(result: vk::Result) -> bool {
    result == vk::Result::SUCCESS
        || result == vk::Result::PIPELINE_COMPILE_REQUIRED
        || result == vk::Result::OPERATION_NOT_DEFERRED_KHR
}

/// Records the `count` handles at `pipelines_out` after a creation call.
fn track_created(
    data: &DeviceData,
    function: &'static str,
    run: CreatePipelines,
    model: &[PipelineCreateInfo],
    (count, pipelines_out): (u32, *const vk::Pipeline),
) {
    track(data, function, |state| {
        // SAFETY: the next layer wrote `count` handles to pPipelines.
        let handles = unsafe {
            raw::handles(
                pipelines_out,
                count,
                function,
                "pPipelines",
                &mut Vec::new(),
            )
        };
        record_pipelines(state, run, model, &handles);
    });
}

/// The body of `vkCreateComputePipelines`, `vkCreateGraphicsPipelines` and
/// `vkCreateRayTracingPipelinesNV`, which share their parameters but for
/// the create-info type.
macro_rules! create_pipelines {
    ($ours:ident, $field:ident, $name:literal, $info:ty, $read:expr, $run:expr) => {
        pub unsafe extern "system" fn $ours(
            device: vk::Device,
            cache: vk::PipelineCache,
            count: u32,
            infos: *const $info,
            allocator: *const vk::AllocationCallbacks<'_>,
            pipelines_out: *mut vk::Pipeline,
        ) -> vk::Result {
            let function = $name;
            guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
                let Some((data, next)) = device_and(device, |f| f.pipe.$field) else {
                    return vk::Result::ERROR_INITIALIZATION_FAILED;
                };
                let run: CreatePipelines = $run;
                let (skip, model) =
                    check_pipelines(&data, function, device, (count, infos), $read, run);
                if skip {
                    return vk::Result::ERROR_VALIDATION_FAILED_EXT;
                }
                // SAFETY: the next layer's function, with the application's arguments.
                let result = unsafe { next(device, cache, count, infos, allocator, pipelines_out) };
                if created(result) {
                    let out = (count, pipelines_out.cast_const());
                    track_created(&data, function, run, &model, out);
                }
                result
            })
        }
    };
}

create_pipelines!(
    create_compute_pipelines,
    create_compute_pipelines,
    "vkCreateComputePipelines",
    vk::ComputePipelineCreateInfo<'_>,
    raw::compute_pipeline_info,
    Validator::create_compute_pipelines
);
create_pipelines!(
    create_graphics_pipelines,
    create_graphics_pipelines,
    "vkCreateGraphicsPipelines",
    vk::GraphicsPipelineCreateInfo<'_>,
    raw::staged_pipeline_info,
    Validator::create_graphics_pipelines
);
create_pipelines!(
    create_ray_tracing_pipelines_nv,
    create_ray_tracing_pipelines_nv,
    "vkCreateRayTracingPipelinesNV",
    vk::RayTracingPipelineCreateInfoNV<'_>,
    raw::staged_pipeline_info,
    Validator::create_ray_tracing_pipelines_nv
);

/// `vkCreateRayTracingPipelinesKHR`: as the others; when the driver defers
/// the creation to `deferredOperation`, the pipelines are recorded once the
/// operation completes (see [`deferred_operation_completed`]).
#[allow(clippy::too_many_arguments)] // The command's own parameters.
pub unsafe extern "system" fn create_ray_tracing_pipelines_khr(
    device: vk::Device,
    deferred_operation: vk::DeferredOperationKHR,
    cache: vk::PipelineCache,
    count: u32,
    infos: *const vk::RayTracingPipelineCreateInfoKHR<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    pipelines_out: *mut vk::Pipeline,
) -> vk::Result {
    let function = "vkCreateRayTracingPipelinesKHR";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.pipe.create_ray_tracing_pipelines_khr)
        else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        let run: CreatePipelines = Validator::create_ray_tracing_pipelines_khr;
        let read = raw::ray_tracing_pipeline_info_khr;
        let (skip, model) = check_pipelines(&data, function, device, (count, infos), read, run);
        if skip {
            return vk::Result::ERROR_VALIDATION_FAILED_EXT;
        }
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe {
            next(
                device,
                deferred_operation,
                cache,
                count,
                infos,
                allocator,
                pipelines_out,
            )
        };
        if result == vk::Result::OPERATION_DEFERRED_KHR {
            track(&data, function, |state| {
                let pending = DeferredPipelines {
                    infos: model,
                    pipelines_out: pipelines_out.expose_provenance(),
                    count,
                };
                let deferred = &mut state.pipe.deferred_pipelines;
                deferred.insert(deferred_operation.as_raw(), pending);
            });
        } else if created(result) {
            let out = (count, pipelines_out.cast_const());
            track_created(&data, function, run, &model, out);
        }
        result
    })
}

/// A deferred operation completed: ray-tracing pipelines it created are recorded.
pub fn deferred_operation_completed(state: &mut DeviceState, operation: Handle) {
    let Some(pending) = state.pipe.deferred_pipelines.remove(&operation) else {
        return;
    };
    let out = std::ptr::with_exposed_provenance::<vk::Pipeline>(pending.pipelines_out);
    let function = "vkCreateRayTracingPipelinesKHR";
    // SAFETY: pPipelines stays valid until the deferred operation completes
    // (a deferred command's parameters must), and the driver has written
    // its `count` handles by then.
    let handles =
        unsafe { raw::handles(out, pending.count, function, "pPipelines", &mut Vec::new()) };
    let run: CreatePipelines = Validator::create_ray_tracing_pipelines_khr;
    record_pipelines(state, run, &pending.infos, &handles);
}

/// `vkDestroyPipeline`.
pub unsafe extern "system" fn destroy_pipeline(
    device: vk::Device,
    pipeline: vk::Pipeline,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let function = "vkDestroyPipeline";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.pipe.destroy_pipeline) else {
            return;
        };
        track(&data, function, |state| {
            let pipelines = &mut state.validator.state_mut().pipelines;
            pipelines.remove(&pipeline.as_raw());
            state.pipe.destroy_pipeline(pipeline.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, pipeline, allocator) };
    })
}

/// `vkCreateShadersEXT`: checked, then the shader objects created are recorded.
pub unsafe extern "system" fn create_shaders(
    device: vk::Device,
    count: u32,
    infos: *const vk::ShaderCreateInfoEXT<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    shaders_out: *mut vk::ShaderEXT,
) -> vk::Result {
    let function = "vkCreateShadersEXT";
    guarded(function, vk::Result::ERROR_INITIALIZATION_FAILED, || {
        let Some((data, next)) = device_and(device, |f| f.pipe.create_shaders) else {
            return vk::Result::ERROR_INITIALIZATION_FAILED;
        };
        let mut model = Vec::new();
        let skip = check(&data, function, device_object(device), |state| {
            let mut findings = Vec::new();
            // SAFETY: the create infos are valid for `count` (the API's requirement).
            model = unsafe { raw::shader_create_infos(infos, count, function, &mut findings) };
            let mut report = state.validator.create_shaders(&model, &[]);
            report.findings.splice(0..0, findings);
            report
        });
        if skip {
            return vk::Result::ERROR_VALIDATION_FAILED_EXT;
        }
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, count, infos, allocator, shaders_out) };
        if result == vk::Result::SUCCESS {
            track(&data, function, |state| {
                // SAFETY: on success the next layer wrote `count` handles.
                let handles = unsafe {
                    raw::handles(
                        shaders_out.cast_const(),
                        count,
                        function,
                        "pShaders",
                        &mut Vec::new(),
                    )
                };
                // Checked before the driver ran; this records the shaders.
                let _ = state.validator.create_shaders(&model, &handles);
                state.pipe.record_shaders(&model, &handles);
            });
        }
        result
    })
}

/// `vkDestroyShaderEXT`.
pub unsafe extern "system" fn destroy_shader(
    device: vk::Device,
    shader: vk::ShaderEXT,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    let function = "vkDestroyShaderEXT";
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, |f| f.pipe.destroy_shader) else {
            return;
        };
        track(&data, function, |state| {
            let shaders = &mut state.validator.state_mut().shader_objects;
            shaders.remove(&shader.as_raw());
            state.pipe.destroy_shader(shader.as_raw());
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, shader, allocator) };
    })
}
