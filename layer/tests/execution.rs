//! Execution order through the in-process chain (see `fake/`): the rules
//! that depend on what runs before what are decided at vkQueueSubmit and
//! at the host commands and destruction that follow it, from what the
//! layer saw of command buffers, submissions, fences and waits.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::sync::Once;

use ash::vk;
use fake::app::{record_micromap_build, AttachmentBuild};
use fake::{device_fn, Chain, DeviceBuild, Received, USAGE};

const ATTACHED_BEFORE_BUILT: &str = "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11632";
const QUERY_NOT_RESET: &str = "VUID-vkCmdWriteMicromapsPropertiesEXT-None-12417";
const DESTROYED_IN_USE: &str = "VUID-vkDestroyMicromapEXT-micromap-07441";
const HOST_COPY_OF_PENDING: &str = "VUID-vkCopyMicromapEXT-src-11670";

fn chain() -> Chain {
    static SETTINGS: Once = Once::new();
    SETTINGS.call_once(|| {
        std::env::set_var("OMMCHECK_REPORT", "error,warning,info");
        std::env::set_var("OMMCHECK_DUPLICATE_LIMIT", "0");
    });
    Chain::new()
}

fn ids(received: &[Received]) -> Vec<&str> {
    received.iter().map(|r| r.id.as_str()).collect()
}

/// Records a device build of `build`'s micromap into a new command buffer.
fn build_command_buffer(chain: &Chain, build: &DeviceBuild) -> vk::CommandBuffer {
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    record_micromap_build(chain, command_buffer, &build.info());
    chain.end(command_buffer);
    command_buffer
}

#[test]
fn an_attachment_built_by_a_later_submission_is_reported_at_submission() {
    let chain = chain();
    let build = DeviceBuild::new(&chain);
    let omm_cb = build_command_buffer(&chain, &build);
    let input_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let blas_cb = chain.allocate_command_buffer();
    chain.begin(blas_cb);
    AttachmentBuild {
        blas: AttachmentBuild::structure(&chain),
        vertices: chain.address(chain.buffer(4096, input_usage, 0)),
        scratch: build.scratch,
        indices: chain.address(chain.buffer(64, input_usage, 0)),
        usage_counts: &USAGE,
        micromap: build.micromap,
    }
    .record(&chain, blas_cb);
    chain.end(blas_cb);
    let recorded = chain.collector.take();
    assert!(
        !ids(&recorded).contains(&ATTACHED_BEFORE_BUILT),
        "decided at recording: {recorded:#?}"
    );

    // The acceleration-structure build runs first: its micromap is not built.
    assert_eq!(chain.submit(blas_cb), vk::Result::SUCCESS);
    let early = chain.collector.take();
    let reported: Vec<_> = early
        .iter()
        .filter(|r| r.id == ATTACHED_BEFORE_BUILT)
        .collect();
    assert_eq!(reported.len(), 1, "{early:#?}");
    assert!(
        reported[0].text.contains("vkQueueSubmit()"),
        "{}",
        reported[0].text
    );

    // Built first, then attached: nothing about the order.
    assert_eq!(chain.submit(omm_cb), vk::Result::SUCCESS);
    assert_eq!(chain.submit(blas_cb), vk::Result::SUCCESS);
    let ordered = chain.collector.take();
    assert!(
        !ids(&ordered).contains(&ATTACHED_BEFORE_BUILT),
        "{ordered:#?}"
    );
}

/// Records, into a new command buffer, a bottom-level build attaching
/// `build`'s micromap.
fn attachment_command_buffer(chain: &Chain, build: &DeviceBuild) -> vk::CommandBuffer {
    let input_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let command_buffer = chain.allocate_command_buffer();
    chain.begin(command_buffer);
    AttachmentBuild {
        blas: AttachmentBuild::structure(chain),
        vertices: chain.address(chain.buffer(4096, input_usage, 0)),
        scratch: build.scratch,
        indices: chain.address(chain.buffer(64, input_usage, 0)),
        usage_counts: &USAGE,
        micromap: build.micromap,
    }
    .record(chain, command_buffer);
    chain.end(command_buffer);
    command_buffer
}

/// Submits `command_buffer` to `queue`, waiting for timeline `semaphore`
/// to reach `value`.
fn submit_waiting(
    chain: &Chain,
    queue: vk::Queue,
    command_buffer: vk::CommandBuffer,
    semaphore: vk::Semaphore,
    value: u64,
) -> vk::Result {
    let submit: vk::PFN_vkQueueSubmit = device_fn(chain.device, c"vkQueueSubmit");
    let (semaphores, values) = ([semaphore], [value]);
    let stages = [vk::PipelineStageFlags::ALL_COMMANDS];
    let command_buffers = [command_buffer];
    let mut timeline = vk::TimelineSemaphoreSubmitInfo::default().wait_semaphore_values(&values);
    let info = vk::SubmitInfo::default()
        .wait_semaphores(&semaphores)
        .wait_dst_stage_mask(&stages)
        .command_buffers(&command_buffers)
        .push_next(&mut timeline);
    // SAFETY: valid arguments.
    unsafe { submit(queue, 1, &info, vk::Fence::null()) }
}

/// Signals timeline `semaphore` to `value` from the host.
fn host_signal(chain: &Chain, semaphore: vk::Semaphore, value: u64) -> vk::Result {
    let signal: vk::PFN_vkSignalSemaphore = device_fn(chain.device, c"vkSignalSemaphore");
    let info = vk::SemaphoreSignalInfo::default()
        .semaphore(semaphore)
        .value(value);
    // SAFETY: valid arguments.
    unsafe { signal(chain.device, &info) }
}

#[test]
fn a_submission_held_for_a_host_signal_is_decided_at_the_signal() {
    for wait_first in [false, true] {
        let chain = chain();
        let build = DeviceBuild::new(&chain);
        let omm_cb = build_command_buffer(&chain, &build);
        let blas_cb = attachment_command_buffer(&chain, &build);
        let get_queue: vk::PFN_vkGetDeviceQueue = device_fn(chain.device, c"vkGetDeviceQueue");
        let mut other_queue = vk::Queue::null();
        // SAFETY: valid arguments (the fake driver hands out any queue).
        unsafe { get_queue(chain.device, 0, 1, &mut other_queue) };
        let go = chain.timeline(0);
        chain.collector.take();

        // Nothing submitted signals `go`: the BLAS build is held, not decided.
        assert_eq!(
            submit_waiting(&chain, other_queue, blas_cb, go, 1),
            vk::Result::SUCCESS
        );
        let held = chain.collector.take();
        assert!(!ids(&held).contains(&ATTACHED_BEFORE_BUILT), "{held:#?}");

        let fence = chain.fence();
        assert_eq!(chain.submit_with(omm_cb, fence), vk::Result::SUCCESS);
        if wait_first {
            assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
        }
        chain.collector.take();
        assert_eq!(host_signal(&chain, go, 1), vk::Result::SUCCESS);
        let signalled = chain.collector.take();
        let reported: Vec<_> = signalled
            .iter()
            .filter(|r| r.id == ATTACHED_BEFORE_BUILT)
            .collect();
        if wait_first {
            // The host saw the micromap built before it let the BLAS build run.
            assert!(reported.is_empty(), "{signalled:#?}");
        } else {
            assert_eq!(reported.len(), 1, "{signalled:#?}");
            assert!(
                reported[0].text.contains("vkSignalSemaphore()"),
                "{}",
                reported[0].text
            );
        }
    }
}

/// A pool of `count` serialization-size queries.
fn query_pool(chain: &Chain, count: u32) -> vk::QueryPool {
    let create: vk::PFN_vkCreateQueryPool = device_fn(chain.device, c"vkCreateQueryPool");
    let info = vk::QueryPoolCreateInfo::default()
        .query_type(vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT)
        .query_count(count);
    let mut pool = vk::QueryPool::null();
    // SAFETY: valid arguments.
    let result = unsafe { create(chain.device, &info, std::ptr::null(), &mut pool) };
    assert_eq!(result, vk::Result::SUCCESS);
    pool
}

/// Records a write of `micromap`'s serialization size to query 0 of `pool`.
fn write_size(
    chain: &Chain,
    command_buffer: vk::CommandBuffer,
    micromap: vk::MicromapEXT,
    pool: vk::QueryPool,
) {
    let write: vk::PFN_vkCmdWriteMicromapsPropertiesEXT =
        device_fn(chain.device, c"vkCmdWriteMicromapsPropertiesEXT");
    // SAFETY: one micromap.
    unsafe {
        write(
            command_buffer,
            1,
            &micromap,
            vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT,
            pool,
            0,
        )
    };
}

#[test]
fn a_query_written_twice_without_a_reset_is_reported_and_a_reset_between_is_silent() {
    let chain = chain();
    let build = DeviceBuild::new(&chain);
    assert_eq!(
        chain.submit(build_command_buffer(&chain, &build)),
        vk::Result::SUCCESS
    );
    let pool = query_pool(&chain, 4);
    let reset: vk::PFN_vkCmdResetQueryPool = device_fn(chain.device, c"vkCmdResetQueryPool");
    chain.collector.take();

    let twice = chain.allocate_command_buffer();
    chain.begin(twice);
    // SAFETY: valid arguments.
    unsafe { reset(twice, pool, 0, 4) };
    write_size(&chain, twice, build.micromap, pool);
    write_size(&chain, twice, build.micromap, pool);
    chain.end(twice);
    assert!(chain.collector.take().is_empty());
    assert_eq!(chain.submit(twice), vk::Result::SUCCESS);
    let submitted = chain.collector.take();
    assert_eq!(ids(&submitted), [QUERY_NOT_RESET], "{submitted:#?}");
    assert!(
        submitted[0].text.contains("query 0"),
        "{}",
        submitted[0].text
    );

    let reset_between = chain.allocate_command_buffer();
    chain.begin(reset_between);
    // SAFETY: valid arguments.
    unsafe { reset(reset_between, pool, 0, 4) };
    write_size(&chain, reset_between, build.micromap, pool);
    // SAFETY: valid arguments.
    unsafe { reset(reset_between, pool, 0, 1) };
    write_size(&chain, reset_between, build.micromap, pool);
    chain.end(reset_between);
    assert_eq!(chain.submit(reset_between), vk::Result::SUCCESS);
    let clean = chain.collector.take();
    assert!(clean.is_empty(), "{clean:#?}");
}

fn destroy(chain: &Chain, micromap: vk::MicromapEXT) {
    let destroy: vk::PFN_vkDestroyMicromapEXT = device_fn(chain.device, c"vkDestroyMicromapEXT");
    // SAFETY: a micromap of the device.
    unsafe { destroy(chain.device, micromap, std::ptr::null()) };
}

#[test]
fn destroying_a_micromap_before_its_fence_is_waited_for_is_reported() {
    let chain = chain();
    let early = DeviceBuild::new(&chain);
    let fence = chain.fence();
    let command_buffer = build_command_buffer(&chain, &early);
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    chain.collector.take();
    destroy(&chain, early.micromap);
    let destroyed = chain.collector.take();
    assert_eq!(ids(&destroyed), [DESTROYED_IN_USE], "{destroyed:#?}");

    let waited = DeviceBuild::new(&chain);
    let fence = chain.fence();
    let command_buffer = build_command_buffer(&chain, &waited);
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    chain.collector.take();
    destroy(&chain, waited.micromap);
    let clean = chain.collector.take();
    assert!(clean.is_empty(), "{clean:#?}");
}

#[test]
fn a_host_copy_of_a_micromap_whose_device_build_is_not_waited_for_is_reported() {
    let chain = chain();
    let mut build = DeviceBuild::new(&chain);
    // Host commands need the micromaps in host-visible memory.
    let host_storage = || chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    build.micromap = chain.micromap(host_storage(), 4096);
    let clone = chain.micromap(host_storage(), 4096);
    let fence = chain.fence();
    let command_buffer = build_command_buffer(&chain, &build);
    assert_eq!(
        chain.submit_with(command_buffer, fence),
        vk::Result::SUCCESS
    );
    chain.collector.take();
    let copy: vk::PFN_vkCopyMicromapEXT = device_fn(chain.device, c"vkCopyMicromapEXT");
    let info = vk::CopyMicromapInfoEXT::default()
        .src(build.micromap)
        .dst(clone)
        .mode(vk::CopyMicromapModeEXT::CLONE);
    // SAFETY: valid arguments.
    let copied = unsafe { copy(chain.device, vk::DeferredOperationKHR::null(), &info) };
    assert_eq!(copied, vk::Result::SUCCESS);
    let early = chain.collector.take();
    assert_eq!(ids(&early), [HOST_COPY_OF_PENDING], "{early:#?}");

    assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
    // What the read-back build reports at the wait is no concern here.
    chain.collector.take();
    // SAFETY: valid arguments.
    let copied = unsafe { copy(chain.device, vk::DeferredOperationKHR::null(), &info) };
    assert_eq!(copied, vk::Result::SUCCESS);
    let waited = chain.collector.take();
    assert!(waited.is_empty(), "{waited:#?}");
}
