//! Chain tests of the pipeline, shader, synchronization, feature and
//! shader-running intercepts: for each family a failing call and its valid
//! twin, through the layer over the fake driver (`fake/`).
//!
//! These tests assume OMMCHECK_PROFILE is not set, so devices are checked
//! against the limits the (fake) physical device reports.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use ash::vk;
use ash::vk::Handle as _;
use fake::{calls, device_fn, instance_fn, Chain, Received};
use ommcheck::checks::pipeline_sync::spirv::build::TestModule;
use ommcheck::model::pipeline::{
    MicromapGeometry, ACCESS_MICROMAP_WRITE, CREATE_RAY_TRACING_OPACITY_MICROMAP,
    STAGE_MICROMAP_BUILD,
};
use VkLayer_ommcheck as layer;

fn ids(received: &[Received]) -> Vec<&str> {
    received.iter().map(|r| r.id.as_str()).collect()
}

fn shader_module(chain: &Chain, words: &[u32]) -> vk::ShaderModule {
    let create: vk::PFN_vkCreateShaderModule = device_fn(chain.device, c"vkCreateShaderModule");
    let info = vk::ShaderModuleCreateInfo::default().code(words);
    let mut module = vk::ShaderModule::null();
    // SAFETY: valid arguments.
    let result = unsafe { create(chain.device, &info, std::ptr::null(), &mut module) };
    assert_eq!(result, vk::Result::SUCCESS);
    module
}

#[test]
fn a_module_forcing_2_state_without_the_capability_reports_11542() {
    let chain = Chain::new();
    let forcing = TestModule {
        trace_ray_flags: Some(0x400),
        ..Default::default()
    };
    shader_module(&chain, &forcing.words());
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-RuntimeSpirv-RayTracingOpacityMicromapKHR-11542"],
        "{received:#?}"
    );
    assert!(received[0]
        .text
        .contains("vkCreateShaderModule(): pCreateInfo->pCode"));

    let declared = TestModule {
        capability: true,
        ..forcing
    };
    shader_module(&chain, &declared.words());
    assert!(chain.collector.take().is_empty());
    assert_eq!(calls("vkCreateShaderModule").len(), 2);
}

fn compute_pipeline(chain: &Chain, flags: vk::PipelineCreateFlags) -> vk::Result {
    let module = shader_module(chain, &TestModule::default().words());
    let create: vk::PFN_vkCreateComputePipelines =
        device_fn(chain.device, c"vkCreateComputePipelines");
    let info = vk::ComputePipelineCreateInfo::default().flags(flags).stage(
        vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main"),
    );
    let mut pipeline = vk::Pipeline::null();
    // SAFETY: valid arguments for one create info.
    unsafe {
        create(
            chain.device,
            vk::PipelineCache::null(),
            1,
            &info,
            std::ptr::null(),
            &mut pipeline,
        )
    }
}

#[test]
fn a_compute_pipeline_with_the_ray_tracing_micromap_flag_reports_07367() {
    let chain = Chain::new();
    let opacity = vk::PipelineCreateFlags::from_raw(CREATE_RAY_TRACING_OPACITY_MICROMAP as u32);
    assert_eq!(compute_pipeline(&chain, opacity), vk::Result::SUCCESS);
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-VkComputePipelineCreateInfo-flags-07367"],
        "{received:#?}"
    );
    assert!(received[0].text.contains("pCreateInfos[0].flags"));

    assert_eq!(
        compute_pipeline(&chain, vk::PipelineCreateFlags::empty()),
        vk::Result::SUCCESS
    );
    assert!(chain.collector.take().is_empty());
    assert_eq!(calls("vkCreateComputePipelines").len(), 2);

    // A messenger answering VK_TRUE skips the faulty creation.
    chain.collector.answer_with(vk::TRUE);
    assert_eq!(
        compute_pipeline(&chain, opacity),
        vk::Result::ERROR_VALIDATION_FAILED_EXT
    );
    assert_eq!(calls("vkCreateComputePipelines").len(), 2);
}

fn barrier(chain: &Chain, src_stage: u64) {
    let record: vk::PFN_vkCmdPipelineBarrier2 = device_fn(chain.device, c"vkCmdPipelineBarrier2");
    let barriers = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::from_raw(src_stage))
        .src_access_mask(vk::AccessFlags2::from_raw(ACCESS_MICROMAP_WRITE))
        .dst_stage_mask(vk::PipelineStageFlags2::COMPUTE_SHADER)
        .dst_access_mask(vk::AccessFlags2::SHADER_READ)];
    let info = vk::DependencyInfo::default().memory_barriers(&barriers);
    // SAFETY: a valid dependency info.
    unsafe { record(chain.command_buffer, &info) };
}

#[test]
fn a_micromap_write_outside_the_build_stage_reports_07457() {
    let chain = Chain::new();
    barrier(&chain, vk::PipelineStageFlags2::COMPUTE_SHADER.as_raw());
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-VkMemoryBarrier2-srcAccessMask-07457"],
        "{received:#?}"
    );
    assert!(received[0]
        .text
        .contains("pDependencyInfo.pMemoryBarriers[0]"));
    barrier(&chain, STAGE_MICROMAP_BUILD);
    assert!(chain.collector.take().is_empty());
    assert_eq!(calls("vkCmdPipelineBarrier2").len(), 2);
}

/// A barrier whose source side is ALL_COMMANDS with `src_access`, recorded
/// into `command_buffer`.
fn all_commands_barrier(chain: &Chain, command_buffer: vk::CommandBuffer, src_access: u64) {
    let record: vk::PFN_vkCmdPipelineBarrier2 = device_fn(chain.device, c"vkCmdPipelineBarrier2");
    let barriers = [vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        .src_access_mask(vk::AccessFlags2::from_raw(src_access))
        .dst_stage_mask(vk::PipelineStageFlags2::ALL_TRANSFER)
        .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)];
    let info = vk::DependencyInfo::default().memory_barriers(&barriers);
    // SAFETY: a valid dependency info.
    unsafe { record(command_buffer, &info) };
}

#[test]
fn all_commands_stands_for_the_stages_of_the_pools_queue_family() {
    let chain = Chain::new();
    // Family 0 has compute: ALL_COMMANDS includes MICROMAP_BUILD and the
    // shader stages.
    let compute = chain.allocate_command_buffer();
    all_commands_barrier(&chain, compute, ACCESS_MICROMAP_WRITE);
    all_commands_barrier(&chain, compute, vk::AccessFlags2::SHADER_READ.as_raw());
    let received = chain.collector.take();
    assert!(received.is_empty(), "{received:#?}");
    // Family 1 is transfer-only: it includes neither.
    let transfer =
        chain.command_buffer_from(chain.command_pool_of(1), vk::CommandBufferLevel::PRIMARY);
    all_commands_barrier(&chain, transfer, ACCESS_MICROMAP_WRITE);
    all_commands_barrier(&chain, transfer, vk::AccessFlags2::SHADER_READ.as_raw());
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        [
            "VUID-VkMemoryBarrier2-srcAccessMask-07457",
            "OMMCHECK-sync-access-stage-on-queue"
        ],
        "{received:#?}"
    );
    assert!(received[0].text.contains("VK_QUEUE_TRANSFER_BIT"));
    assert_eq!(calls("vkCmdPipelineBarrier2").len(), 4);
}

#[test]
fn properties_chained_to_the_device_create_info_report_the_pnext_rule() {
    // A properties structure where features belong.
    let mut properties = vk::PhysicalDeviceOpacityMicromapPropertiesEXT::default();
    let (chain, result) = Chain::with_device_chain((&raw mut properties).cast());
    assert_eq!(result, vk::Result::SUCCESS);
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-VkDeviceCreateInfo-pNext-pNext"],
        "{received:#?}"
    );
    assert_eq!(
        received[0].objects[0],
        (
            vk::ObjectType::PHYSICAL_DEVICE,
            chain.physical_device.as_raw()
        )
    );

    // The valid twin: a features structure, as Chain::new chains two.
    let mut features = vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default();
    let (chain, result) = Chain::with_device_chain((&raw mut features).cast());
    assert_eq!(result, vk::Result::SUCCESS);
    assert!(chain.collector.take().is_empty());
}

#[test]
fn properties2_is_checked_and_the_reported_limits_reach_the_device() {
    let chain = Chain::new();
    let get: vk::PFN_vkGetPhysicalDeviceProperties2 =
        instance_fn(chain.instance, c"vkGetPhysicalDeviceProperties2");
    // A features structure in a properties chain.
    let mut features = vk::PhysicalDeviceOpacityMicromapFeaturesEXT::default();
    let mut properties = vk::PhysicalDeviceProperties2 {
        p_next: (&raw mut features).cast(),
        ..Default::default()
    };
    // SAFETY: a valid structure with a live chain.
    unsafe { get(chain.physical_device, &mut properties) };
    assert_eq!(
        ids(&chain.collector.take()),
        ["VUID-VkPhysicalDeviceProperties2-pNext-pNext"]
    );
    let mut reported = vk::PhysicalDeviceOpacityMicromapPropertiesEXT::default();
    let mut properties = vk::PhysicalDeviceProperties2::default().push_next(&mut reported);
    // SAFETY: as above.
    unsafe { get(chain.physical_device, &mut properties) };
    assert!(chain.collector.take().is_empty());
    assert_eq!(reported.max_opacity2_state_subdivision_level, 3);

    // A level-5 2-state build exceeds the spec minimum (3) but not a
    // device reporting 12.
    let build = |chain: &Chain| {
        let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
        let micromap = chain.micromap(storage, 4096);
        let usage = [vk::MicromapUsageEXT {
            count: 1,
            subdivision_level: 5,
            format: 1,
        }];
        let info = vk::MicromapBuildInfoEXT {
            ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
            mode: vk::BuildMicromapModeEXT::BUILD,
            dst_micromap: micromap,
            usage_counts_count: 1,
            p_usage_counts: usage.as_ptr(),
            ..Default::default()
        };
        let record: vk::PFN_vkCmdBuildMicromapsEXT =
            device_fn(chain.device, c"vkCmdBuildMicromapsEXT");
        // SAFETY: one valid info.
        unsafe { record(chain.command_buffer, 1, &info) };
        chain.collector.take()
    };
    let at_minimum = build(&chain);
    assert!(
        ids(&at_minimum).contains(&"VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11654"),
        "{at_minimum:#?}"
    );
    fake::report_2_state_level(12);
    let permissive_device = Chain::new();
    let at_twelve = build(&permissive_device);
    assert!(
        !ids(&at_twelve).contains(&"VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11654"),
        "{at_twelve:#?}"
    );
}

const TLAS: u64 = 0xa5;

/// A ray-tracing pipeline whose raygen shader traces rays, written to
/// `pipeline` (which a deferred creation may write until its operation
/// completes), and a descriptor set with `TLAS` at binding 0 for raygen,
/// bound to the command buffer with the pipeline.
fn ray_tracing_setup(
    chain: &Chain,
    flags: vk::PipelineCreateFlags,
    deferred: vk::DeferredOperationKHR,
    pipeline: &mut vk::Pipeline,
) -> vk::Result {
    let module = shader_module(chain, &TestModule::default().words());
    let stages = [vk::PipelineShaderStageCreateInfo::default()
        .stage(vk::ShaderStageFlags::RAYGEN_KHR)
        .module(module)
        .name(c"main")];
    let info = vk::RayTracingPipelineCreateInfoKHR::default()
        .flags(flags)
        .stages(&stages);
    let create: vk::PFN_vkCreateRayTracingPipelinesKHR =
        device_fn(chain.device, c"vkCreateRayTracingPipelinesKHR");
    // SAFETY: valid arguments for one create info.
    let result = unsafe {
        create(
            chain.device,
            deferred,
            vk::PipelineCache::null(),
            1,
            &info,
            std::ptr::null(),
            pipeline,
        )
    };

    let bindings = [vk::DescriptorSetLayoutBinding::default()
        .binding(0)
        .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
        .descriptor_count(1)
        .stage_flags(vk::ShaderStageFlags::RAYGEN_KHR)];
    let layout_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
    let create_layout: vk::PFN_vkCreateDescriptorSetLayout =
        device_fn(chain.device, c"vkCreateDescriptorSetLayout");
    let mut layout = vk::DescriptorSetLayout::null();
    // SAFETY: valid arguments.
    let created =
        unsafe { create_layout(chain.device, &layout_info, std::ptr::null(), &mut layout) };
    assert_eq!(created, vk::Result::SUCCESS);
    let layouts = [layout];
    let allocate_info = vk::DescriptorSetAllocateInfo::default().set_layouts(&layouts);
    let allocate: vk::PFN_vkAllocateDescriptorSets =
        device_fn(chain.device, c"vkAllocateDescriptorSets");
    let mut set = vk::DescriptorSet::null();
    // SAFETY: valid arguments for one set.
    assert_eq!(
        unsafe { allocate(chain.device, &allocate_info, &mut set) },
        vk::Result::SUCCESS
    );
    let structures = [vk::AccelerationStructureKHR::from_raw(TLAS)];
    let mut written = vk::WriteDescriptorSetAccelerationStructureKHR::default()
        .acceleration_structures(&structures);
    let write = vk::WriteDescriptorSet {
        dst_set: set,
        descriptor_count: 1,
        descriptor_type: vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
        ..Default::default()
    }
    .push_next(&mut written);
    let update: vk::PFN_vkUpdateDescriptorSets = device_fn(chain.device, c"vkUpdateDescriptorSets");
    // SAFETY: one valid write.
    unsafe { update(chain.device, 1, &write, 0, std::ptr::null()) };

    let bind: vk::PFN_vkCmdBindPipeline = device_fn(chain.device, c"vkCmdBindPipeline");
    let bind_sets: vk::PFN_vkCmdBindDescriptorSets =
        device_fn(chain.device, c"vkCmdBindDescriptorSets");
    let point = vk::PipelineBindPoint::RAY_TRACING_KHR;
    // SAFETY: valid arguments.
    unsafe {
        bind(chain.command_buffer, point, *pipeline);
        bind_sets(
            chain.command_buffer,
            point,
            vk::PipelineLayout::null(),
            0,
            1,
            &set,
            0,
            std::ptr::null(),
        );
    }
    assert!(layer::testing::seed_micromap_geometry(
        chain.device,
        TLAS,
        MicromapGeometry {
            opacity_ext: true,
            ..Default::default()
        }
    ));
    result
}

fn trace_rays(chain: &Chain) -> Vec<Received> {
    let trace: vk::PFN_vkCmdTraceRaysKHR = device_fn(chain.device, c"vkCmdTraceRaysKHR");
    let region = vk::StridedDeviceAddressRegionKHR::default();
    // SAFETY: valid regions.
    unsafe {
        trace(
            chain.command_buffer,
            &region,
            &region,
            &region,
            &region,
            4,
            4,
            1,
        )
    };
    chain.collector.take()
}

const TRACE_WITHOUT_FLAG: &str = "VUID-vkCmdTraceRaysKHR-micromap-11640";

#[test]
fn tracing_into_micromap_geometry_needs_the_pipeline_flag_11640() {
    let chain = Chain::new();
    let mut pipeline = vk::Pipeline::null();
    let result = ray_tracing_setup(
        &chain,
        vk::PipelineCreateFlags::empty(),
        vk::DeferredOperationKHR::null(),
        &mut pipeline,
    );
    assert_eq!(result, vk::Result::SUCCESS);
    assert!(chain.collector.take().is_empty());
    let received = trace_rays(&chain);
    assert_eq!(ids(&received), [TRACE_WITHOUT_FLAG], "{received:#?}");
    assert!(received[0]
        .objects
        .contains(&(vk::ObjectType::ACCELERATION_STRUCTURE_KHR, TLAS)));
    assert!(received[0]
        .text
        .contains(&format!("VkPipeline {:#x}", pipeline.as_raw())));

    let opacity = vk::PipelineCreateFlags::from_raw(CREATE_RAY_TRACING_OPACITY_MICROMAP as u32);
    let result = ray_tracing_setup(
        &chain,
        opacity,
        vk::DeferredOperationKHR::null(),
        &mut pipeline,
    );
    assert_eq!(result, vk::Result::SUCCESS);
    assert!(trace_rays(&chain).is_empty());
    assert_eq!(calls("vkCmdTraceRaysKHR").len(), 2);
}

#[test]
fn a_deferred_pipeline_is_known_once_its_operation_completes() {
    let chain = Chain::new();
    let operation = vk::DeferredOperationKHR::from_raw(0x0d);
    // Kept alive until the operation completes, as deferred commands require.
    let mut pipeline = vk::Pipeline::null();
    let result = ray_tracing_setup(
        &chain,
        vk::PipelineCreateFlags::empty(),
        operation,
        &mut pipeline,
    );
    assert_eq!(result, vk::Result::OPERATION_DEFERRED_KHR);
    // Not created yet as far as the layer knows: nothing to judge.
    assert!(trace_rays(&chain).is_empty());
    let join: vk::PFN_vkDeferredOperationJoinKHR =
        device_fn(chain.device, c"vkDeferredOperationJoinKHR");
    // SAFETY: the operation the creation was deferred to.
    assert_eq!(
        unsafe { join(chain.device, operation) },
        vk::Result::SUCCESS
    );
    assert_eq!(ids(&trace_rays(&chain)), [TRACE_WITHOUT_FLAG]);
}

#[test]
fn commands_the_driver_lacks_stay_missing() {
    let chain = Chain::new();
    for name in [
        c"vkCmdDrawMeshTasksEXT",
        c"vkCmdTraceRaysIndirect2KHR",
        c"vkCmdDrawMultiEXT",
        c"vkCmdWriteMarkerToMemoryAMD",
    ] {
        assert!(layer::intercepts(name), "{name:?}");
        // SAFETY: NUL-terminated names.
        let found = unsafe { layer::vkGetDeviceProcAddr(chain.device, name.as_ptr()) };
        assert!(found.is_none(), "{name:?} was returned");
    }
    let properties = c"vkGetPhysicalDeviceProperties2KHR";
    // SAFETY: a NUL-terminated name.
    let found = unsafe { layer::vkGetInstanceProcAddr(chain.instance, properties.as_ptr()) };
    assert!(found.is_none() && layer::intercepts(properties));
}
