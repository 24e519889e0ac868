//! Command-buffer state and device builds' contents at submission, through
//! the in-process chain (see `fake/`).
//!
//! This binary reports every severity with no duplicate limit: its tests
//! count messages exactly, including the once-per-device information.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::ffi::CStr;
use std::sync::Once;

use ash::vk;
use ash::vk::Handle as _;
use fake::app::{record_micromap_build, AttachmentBuild};
use fake::{add_messenger, calls, device_fn, Chain, Collector, DeviceBuild, Received, USAGE};

const INDEX_IN_RANGE: &str = "OMMCHECK-attach-index-in-range";
const NOT_RECORDING: &str = "VUID-vkCmdBuildMicromapsEXT-commandBuffer-recording";
const IN_RENDER_PASS: &str = "VUID-vkCmdBuildMicromapsEXT-renderpass";
const SUSPENDED: &str = "VUID-vkCmdBuildMicromapsEXT-suspended";
const BOTH_USAGE_POINTERS: &str = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";
const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";
const ATTACHED_BEFORE_BUILT: &str = "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11632";

/// The chain, with this binary's settings in place before the first instance.
fn chain() -> Chain {
    chain_at_tier(None)
}

/// As [`chain`], at `tier` (through VK_EXT_layer_settings) where given.
fn chain_at_tier(tier: Option<&CStr>) -> Chain {
    static SETTINGS: Once = Once::new();
    SETTINGS.call_once(|| {
        std::env::set_var("OMMCHECK_REPORT", "error,warning,info");
        std::env::set_var("OMMCHECK_DUPLICATE_LIMIT", "0");
    });
    let Some(tier) = tier else {
        return Chain::new();
    };
    Chain::with_settings(&[(c"tier", tier)])
}

fn ids(received: &[Received]) -> Vec<&str> {
    received.iter().map(|r| r.id.as_str()).collect()
}

/// A micromap of two triangles, built on the device from inputs in
/// device-local memory, and a bottom-level build of two triangles that
/// attaches it with 32-bit indices read from a mapped host-visible buffer.
struct Scene {
    micromap: DeviceBuild,
    blas: vk::AccelerationStructureKHR,
    vertices: u64,
    /// The index buffer's memory as the application sees it through its mapping.
    indices: Box<[u32; 16]>,
    index_buffer: u64,
}

impl Scene {
    /// The scene with its index buffer in memory of `index_memory_type`
    /// (1: host-visible and mapped; 0: device-local).
    fn new(chain: &Chain, index_memory_type: u32) -> Self {
        let micromap = DeviceBuild::new(chain);
        let blas = AttachmentBuild::structure(chain);
        let input_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let vertices = chain.buffer(4096, input_usage, 0);
        let (index_buffer, memory) = chain.buffer_and_memory(64, input_usage, index_memory_type);
        let mut indices = Box::new([0u32; 16]);
        indices[1] = 1;
        if index_memory_type == 1 {
            chain.map(memory, indices.as_mut_ptr().cast());
        }
        Self {
            micromap,
            blas,
            vertices: chain.address(vertices),
            indices,
            index_buffer: chain.address(index_buffer),
        }
    }

    fn micromap_build(&self) -> vk::MicromapBuildInfoEXT<'static> {
        self.micromap.info()
    }

    fn record_micromap_build(
        &self,
        chain: &Chain,
        command_buffer: vk::CommandBuffer,
        info: &vk::MicromapBuildInfoEXT<'_>,
    ) {
        record_micromap_build(chain, command_buffer, info);
    }

    /// Records the bottom-level build that attaches the micromap.
    fn record_blas_build(&self, chain: &Chain, command_buffer: vk::CommandBuffer) {
        AttachmentBuild {
            blas: self.blas,
            vertices: self.vertices,
            scratch: self.micromap.scratch,
            indices: self.index_buffer,
            usage_counts: &USAGE,
            micromap: self.micromap.micromap,
        }
        .record(chain, command_buffer);
    }
}

#[test]
fn an_index_past_the_micromap_in_mapped_memory_is_reported_at_submission_not_recording() {
    let chain = chain();
    let mut scene = Scene::new(&chain, 1);
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    // The application writes its indices after recording: the second
    // triangle's index 5 is past the micromap's two triangles.
    scene.indices[1] = 5;
    scene.record_blas_build(&chain, command_buffer);
    chain.end(command_buffer);
    let recorded = chain.collector.take();
    assert!(recorded.is_empty(), "reported at recording: {recorded:#?}");
    assert_eq!(calls("vkCmdBuildAccelerationStructuresKHR").len(), 1);

    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    let submitted = chain.collector.take();
    assert_eq!(ids(&submitted), [INDEX_IN_RANGE], "{submitted:#?}");
    let message = &submitted[0];
    assert!(message
        .text
        .contains("vkCmdBuildAccelerationStructuresKHR(): pInfos[0].pGeometries[0]"));
    assert!(message.text.contains("indexBuffer[1]"), "{}", message.text);
    assert_eq!(
        message.objects[0],
        (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw())
    );
    assert_eq!(calls("vkQueueSubmit").len(), 1);

    // Fixed in memory, the next submission of the same recording is clean.
    scene.indices[1] = 1;
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    let again = chain.collector.take();
    assert!(again.is_empty(), "{again:#?}");
}

#[test]
fn valid_indices_in_mapped_memory_are_not_reported() {
    let chain = chain();
    let scene = Scene::new(&chain, 1);
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    scene.record_blas_build(&chain, command_buffer);
    chain.end(command_buffer);
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    let received = chain.collector.take();
    assert!(received.is_empty(), "{received:#?}");
    assert_eq!(calls("vkQueueSubmit").len(), 1);
}

#[test]
fn a_build_outside_recording_reports_the_recording_vuid() {
    let chain = chain();
    let scene = Scene::new(&chain, 1);
    let command_buffer = chain.allocate_command_buffer();
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert_eq!(ids(&chain.collector.take()), [NOT_RECORDING]);

    chain.begin(command_buffer);
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert!(chain.collector.take().is_empty());

    chain.end(command_buffer);
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert_eq!(ids(&chain.collector.take()), [NOT_RECORDING]);
    // The calls went on to the driver: the callback did not ask to skip them.
    assert_eq!(calls("vkCmdBuildMicromapsEXT").len(), 3);
}

#[test]
fn a_build_inside_a_render_pass_or_between_suspended_instances_is_reported() {
    let chain = chain();
    let scene = Scene::new(&chain, 1);
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    let begin_render_pass: vk::PFN_vkCmdBeginRenderPass =
        device_fn(chain.device, c"vkCmdBeginRenderPass");
    let end_render_pass: vk::PFN_vkCmdEndRenderPass =
        device_fn(chain.device, c"vkCmdEndRenderPass");
    let pass = vk::RenderPassBeginInfo::default();
    // SAFETY: valid arguments (the fake driver reads nothing).
    unsafe { begin_render_pass(command_buffer, &pass, vk::SubpassContents::INLINE) };
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert_eq!(ids(&chain.collector.take()), [IN_RENDER_PASS]);
    // SAFETY: valid arguments.
    unsafe { end_render_pass(command_buffer) };
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert!(chain.collector.take().is_empty());

    let begin_rendering: vk::PFN_vkCmdBeginRendering =
        device_fn(chain.device, c"vkCmdBeginRendering");
    let end_rendering: vk::PFN_vkCmdEndRendering = device_fn(chain.device, c"vkCmdEndRendering");
    let suspending = vk::RenderingInfo::default().flags(vk::RenderingFlags::SUSPENDING);
    // SAFETY: valid arguments.
    unsafe { begin_rendering(command_buffer, &suspending) };
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert_eq!(ids(&chain.collector.take()), [IN_RENDER_PASS]);
    // SAFETY: valid arguments.
    unsafe { end_rendering(command_buffer) };
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert_eq!(ids(&chain.collector.take()), [SUSPENDED]);

    let resuming = vk::RenderingInfo::default().flags(vk::RenderingFlags::RESUMING);
    // SAFETY: valid arguments.
    unsafe { begin_rendering(command_buffer, &resuming) };
    // SAFETY: valid arguments.
    unsafe { end_rendering(command_buffer) };
    scene.record_micromap_build(&chain, command_buffer, &scene.micromap_build());
    assert!(chain.collector.take().is_empty());
}

/// With GPU readback off, inputs in device-local memory that no followed
/// transfer wrote are what the layer cannot read (with it on they are
/// read back: see device_memory.rs).
#[test]
fn contents_in_device_local_memory_are_reported_not_checked_once_per_device() {
    chain();
    let chain = Chain::with_settings(&[(c"gpu_readback", c"false")]);
    let scene = Scene::new(&chain, 0);
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    scene.record_blas_build(&chain, command_buffer);
    scene.record_blas_build(&chain, command_buffer);
    chain.end(command_buffer);
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
    assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);

    // A warning, so the chain's messenger for errors and warnings (the
    // default report level) receives it.
    let (received, errors): (Vec<Received>, Vec<Received>) = chain
        .collector
        .take()
        .into_iter()
        .partition(|r| r.id == CONTENTS_NOT_CHECKED);
    assert_eq!(received.len(), 1, "{received:#?}");
    let text = &received[0].text;
    assert!(
        text.contains("vkCmdBuildAccelerationStructuresKHR(): "),
        "{text}"
    );
    assert!(text.contains("indexBuffer"), "{text}");
    assert!(text.contains("not host-visible"), "{text}");
    assert!(text.contains("gpu_readback"), "{text}");
    assert_eq!(
        received[0].severity,
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
    );
    // The only errors: the micromap the structures attach is never built
    // (this test records no micromap build), once per build per submission.
    assert_eq!(
        ids(&errors),
        [ATTACHED_BEFORE_BUILT; 4],
        "only the attachment's construction is reported"
    );
}

/// Below the content tier no check reads a build's contents, so the layer
/// keeps no device build for submission: neither the index past the
/// micromap in mapped memory nor the contents in device-local memory are
/// looked at, and nothing is reported at submission.
#[test]
fn below_the_content_tier_submission_looks_at_no_build() {
    for tier in [c"params", c"state"] {
        let chain = chain_at_tier(Some(tier));
        let info = Box::<Collector>::default();
        let _messenger = add_messenger(
            chain.instance,
            vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
            &info,
        );
        let mut mapped = Scene::new(&chain, 1);
        mapped.indices[1] = 5;
        let device_local = Scene::new(&chain, 0);
        let command_buffer = chain.allocate_command_buffer();
        chain.begin(command_buffer);
        mapped.record_micromap_build(&chain, command_buffer, &mapped.micromap_build());
        mapped.record_blas_build(&chain, command_buffer);
        // Built first, so that the attachment's micromap build is one the
        // layer saw (else the recording says its indices are not checked).
        device_local.record_micromap_build(&chain, command_buffer, &device_local.micromap_build());
        device_local.record_blas_build(&chain, command_buffer);
        chain.end(command_buffer);
        assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);

        let received = chain.collector.take();
        assert!(received.is_empty(), "{tier:?}: {received:#?}");
        let info = info.take();
        assert!(info.is_empty(), "{tier:?}: {info:#?}");
    }
}

#[test]
fn builds_recorded_on_eight_threads_are_each_reported_as_often_as_made() {
    const THREADS: usize = 8;
    const FAULTY_MICROMAP_BUILDS: usize = 2;
    let chain = chain();
    let mut scene = Scene::new(&chain, 1);
    scene.indices[1] = 7;
    let command_buffers: Vec<vk::CommandBuffer> = (0..THREADS)
        .map(|_| chain.allocate_command_buffer())
        .collect();
    std::thread::scope(|threads| {
        for &command_buffer in &command_buffers {
            let (chain, scene) = (&chain, &scene);
            threads.spawn(move || {
                chain.begin(command_buffer);
                let pointers = [USAGE.as_ptr()];
                let faulty = vk::MicromapBuildInfoEXT {
                    pp_usage_counts: pointers.as_ptr(),
                    ..scene.micromap_build()
                };
                for _ in 0..FAULTY_MICROMAP_BUILDS {
                    scene.record_micromap_build(chain, command_buffer, &faulty);
                }
                scene.record_blas_build(chain, command_buffer);
                chain.end(command_buffer);
                assert_eq!(chain.submit(command_buffer), vk::Result::SUCCESS);
            });
        }
    });
    let received = chain.collector.take();
    let count = |id: &str| received.iter().filter(|r| r.id == id).count();
    assert_eq!(count(BOTH_USAGE_POINTERS), THREADS * FAULTY_MICROMAP_BUILDS);
    assert_eq!(count(INDEX_IN_RANGE), THREADS, "{received:#?}");
    assert_eq!(received.len(), THREADS * (FAULTY_MICROMAP_BUILDS + 1));
    // Each command buffer's submission reported its own build once.
    for command_buffer in &command_buffers {
        let own = received
            .iter()
            .filter(|r| r.id == INDEX_IN_RANGE)
            .filter(|r| r.objects[0] == (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw()))
            .count();
        assert_eq!(own, 1);
    }
}

#[test]
fn acceleration_structure_and_micromap_copy_commands_are_checked_and_passed_on() {
    let chain = chain();
    let storage = chain.buffer(
        4096,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
        0,
    );
    let create: vk::PFN_vkCreateAccelerationStructureKHR =
        device_fn(chain.device, c"vkCreateAccelerationStructureKHR");
    let create_with = |ty| {
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage)
            .size(4096)
            .ty(ty);
        let mut structure = vk::AccelerationStructureKHR::null();
        // SAFETY: valid arguments.
        unsafe { create(chain.device, &info, std::ptr::null(), &mut structure) }
    };
    assert_eq!(
        create_with(vk::AccelerationStructureTypeKHR::from_raw(
            ommcheck::model::accel::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
        )),
        vk::Result::SUCCESS
    );
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-VkAccelerationStructureCreateInfoKHR-type-11600"],
        "{received:#?}"
    );
    assert_eq!(
        create_with(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL),
        vk::Result::SUCCESS
    );
    assert!(chain.collector.take().is_empty());
    assert_eq!(calls("vkCreateAccelerationStructureKHR").len(), 2);

    let scene = Scene::new(&chain, 1);
    let command_buffer = chain.allocate_command_buffer();
    let copy: vk::PFN_vkCmdCopyMicromapEXT = device_fn(chain.device, c"vkCmdCopyMicromapEXT");
    let info = vk::CopyMicromapInfoEXT {
        src: scene.micromap.micromap,
        dst: scene.micromap.micromap,
        mode: vk::CopyMicromapModeEXT::CLONE,
        ..Default::default()
    };
    // SAFETY: valid pointers.
    unsafe { copy(command_buffer, &info) };
    let outside = chain.collector.take();
    assert!(
        ids(&outside).contains(&"VUID-vkCmdCopyMicromapEXT-commandBuffer-recording"),
        "{outside:#?}"
    );
    chain.begin(command_buffer);
    // SAFETY: valid pointers.
    unsafe { copy(command_buffer, &info) };
    let inside = chain.collector.take();
    assert!(
        !ids(&inside).contains(&"VUID-vkCmdCopyMicromapEXT-commandBuffer-recording"),
        "{inside:#?}"
    );
    assert_eq!(calls("vkCmdCopyMicromapEXT").len(), 2);

    // The fake driver has no vkCreateAccelerationStructure2KHR: neither has the layer.
    // SAFETY: a NUL-terminated name.
    let missing = unsafe {
        VkLayer_ommcheck::vkGetDeviceProcAddr(
            chain.device,
            c"vkCreateAccelerationStructure2KHR".as_ptr(),
        )
    };
    assert!(missing.is_none());
}

/// vkCmdBeginQuery on a micromap size pool breaks 08972; on an occlusion
/// pool it is fine; both reach the driver.
#[test]
fn begin_query_on_a_micromap_size_pool_is_reported() {
    let chain = chain();
    let create: vk::PFN_vkCreateQueryPool = device_fn(chain.device, c"vkCreateQueryPool");
    let pool_of = |query_type| {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(query_type)
            .query_count(1);
        let mut pool = vk::QueryPool::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(chain.device, &info, std::ptr::null(), &mut pool) };
        assert_eq!(result, vk::Result::SUCCESS);
        pool
    };
    let sizes = pool_of(vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT);
    let occlusion = pool_of(vk::QueryType::OCCLUSION);
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    let begin_query: vk::PFN_vkCmdBeginQuery = device_fn(chain.device, c"vkCmdBeginQuery");
    // SAFETY: valid arguments.
    unsafe { begin_query(command_buffer, sizes, 0, vk::QueryControlFlags::empty()) };
    let received = chain.collector.take();
    assert_eq!(
        ids(&received),
        ["VUID-vkCmdBeginQuery-queryType-08972"],
        "{received:#?}"
    );
    // SAFETY: valid arguments.
    unsafe { begin_query(command_buffer, occlusion, 0, vk::QueryControlFlags::empty()) };
    assert!(chain.collector.take().is_empty());
    assert_eq!(calls("vkCmdBeginQuery").len(), 2);
}
