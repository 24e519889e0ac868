//! Memory stays bounded by what the input describes, never by a count the
//! layer has not checked: builds through the in-process chain (see `fake/`)
//! whose counts are 2^32 − 1 (triangles, primitives, indices) over a few
//! bytes of host memory or a 64-byte mapped buffer peak at a few KiB more
//! than before the call, and are reported, at the call or at submission.
//!
//! The peak is measured by a counting global allocator, so this binary's
//! tests take turns ([`measure`] holds a lock). The raw reader's own bounds
//! (array counts) are measured in validator/tests/memory_bound.rs.
//!
//! Objects made and destroyed over and over leave nothing behind in a
//! device's checked state (`cargo xtask soak` found three kinds that did).

#![allow(non_snake_case, unsafe_code)]

mod fake;

use ash::vk;
use ash::vk::Handle as _;
use fake::app::{record_micromap_build, AttachmentBuild};
use fake::{device_fn, device_micromap_build, dispatchable, key_of, Chain, TRIANGLES, USAGE};
use VkLayer_ommcheck as layer;

#[path = "../../validator/tests/support/peak_memory.rs"]
mod peak_memory;
use peak_memory::{measure, BOUND};

const HUGE: u32 = u32::MAX;
const READ_BOUND: &str = "OMMCHECK-reader-bounded";

/// 2^32 − 1 triangles at the highest level, 4-state.
const HUGE_USAGE: [vk::MicromapUsageEXT; 1] = [vk::MicromapUsageEXT {
    count: HUGE,
    subdivision_level: 12,
    format: 2,
}];

fn host(p: *const u8) -> u64 {
    p.expose_provenance() as u64
}

/// The ids `chain` received, sorted and deduplicated, asserting there was
/// at least one (never silence).
fn reported(chain: &Chain, what: &str) -> Vec<String> {
    let received = chain.collector.take();
    let mut ids: Vec<String> = received.into_iter().map(|r| r.id).collect();
    ids.sort_unstable();
    ids.dedup();
    assert!(!ids.is_empty(), "{what}: nothing was reported");
    ids
}

fn assert_small(what: &str, growth: usize) {
    eprintln!("{what}: peak growth {growth} bytes");
    assert!(growth < BOUND, "{what}: the peak grew by {growth} bytes");
}

/// A 64-byte host-visible buffer for build inputs, mapped to `memory`:
/// returns its device address.
fn tiny_mapped_input(chain: &Chain, memory: &mut [u8; 64]) -> u64 {
    let usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let (buffer, bound) = chain.buffer_and_memory(64, usage, 1);
    chain.map(bound, memory.as_mut_ptr());
    chain.address(buffer)
}

fn command_buffer(chain: &Chain) -> vk::CommandBuffer {
    let create: vk::PFN_vkCreateCommandPool = device_fn(chain.device, c"vkCreateCommandPool");
    let info = vk::CommandPoolCreateInfo::default().queue_family_index(0);
    let mut pool = vk::CommandPool::null();
    // SAFETY: valid arguments.
    assert_eq!(
        unsafe { create(chain.device, &info, std::ptr::null(), &mut pool) },
        vk::Result::SUCCESS
    );
    let allocate: vk::PFN_vkAllocateCommandBuffers =
        device_fn(chain.device, c"vkAllocateCommandBuffers");
    let info = vk::CommandBufferAllocateInfo::default()
        .command_pool(pool)
        .level(vk::CommandBufferLevel::PRIMARY)
        .command_buffer_count(1);
    let mut command_buffer = vk::CommandBuffer::null();
    // SAFETY: valid arguments.
    assert_eq!(
        unsafe { allocate(chain.device, &info, &mut command_buffer) },
        vk::Result::SUCCESS
    );
    let begin: vk::PFN_vkBeginCommandBuffer = device_fn(chain.device, c"vkBeginCommandBuffer");
    // SAFETY: valid arguments.
    assert_eq!(
        unsafe { begin(command_buffer, &vk::CommandBufferBeginInfo::default()) },
        vk::Result::SUCCESS
    );
    command_buffer
}

/// Ends and submits `command_buffer`.
fn end_and_submit(chain: &Chain, command_buffer: vk::CommandBuffer) {
    let end: vk::PFN_vkEndCommandBuffer = device_fn(chain.device, c"vkEndCommandBuffer");
    // SAFETY: a recording command buffer.
    assert_eq!(unsafe { end(command_buffer) }, vk::Result::SUCCESS);
    let submit: vk::PFN_vkQueueSubmit = device_fn(chain.device, c"vkQueueSubmit");
    let queue = vk::Queue::from_raw(dispatchable(key_of(chain.device.as_raw())));
    let command_buffers = [command_buffer];
    let info = vk::SubmitInfo::default().command_buffers(&command_buffers);
    // SAFETY: valid arguments.
    assert_eq!(
        unsafe { submit(queue, 1, &info, vk::Fence::null()) },
        vk::Result::SUCCESS
    );
}

fn micromap_build(
    micromap: vk::MicromapEXT,
    triangles: u64,
    data: u64,
    scratch: u64,
) -> vk::MicromapBuildInfoEXT<'static> {
    device_micromap_build(micromap, &HUGE_USAGE, triangles, data, scratch)
}

#[test]
fn micromap_builds_of_huge_triangle_counts_over_tiny_memory_stay_small_and_are_reported() {
    let chain = Chain::new();
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    let micromap = chain.micromap(storage, 4096);
    let mut scratch = vec![0u8; 4096];
    let scratch = host(scratch.as_mut_ptr());

    // On the host: two entries and two bytes of data in the application's
    // memory, the data mapped so the layer knows where it ends.
    let mut mapped = Box::new([0u8; 64]);
    mapped[..2].copy_from_slice(&[0x1, 0x2]);
    let (_, memory) = chain.buffer_and_memory(64, vk::BufferUsageFlags::STORAGE_BUFFER, 1);
    chain.map(memory, mapped.as_mut_ptr());
    let info = micromap_build(
        micromap,
        host(TRIANGLES.as_ptr().cast()),
        host(mapped.as_ptr()),
        scratch,
    );
    let build: vk::PFN_vkBuildMicromapsEXT = device_fn(chain.device, c"vkBuildMicromapsEXT");
    // SAFETY: one info; its arrays are not read past what the layer can
    // bound (what is asserted is that it reports instead).
    let (result, growth) =
        measure(|| unsafe { build(chain.device, vk::DeferredOperationKHR::null(), 1, &info) });
    assert_eq!(result, vk::Result::SUCCESS);
    assert_small("vkBuildMicromapsEXT", growth);
    let ids = reported(&chain, "vkBuildMicromapsEXT");
    assert!(ids.iter().any(|id| id == READ_BOUND), "{ids:?}");

    // On the device: the triangle array and the data in a 64-byte mapped
    // buffer, read at submission.
    let mut input = Box::new([0u8; 64]);
    // SAFETY: 16 bytes of entries at the start of the 64.
    unsafe {
        input
            .as_mut_ptr()
            .copy_from_nonoverlapping(TRIANGLES.as_ptr().cast(), 16)
    };
    let address = tiny_mapped_input(&chain, &mut input);
    let device_scratch = chain.address(chain.buffer(
        4096,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        0,
    ));
    let info = micromap_build(micromap, address, address + 32, device_scratch);
    let command_buffer = command_buffer(&chain);
    let cmd_build: vk::PFN_vkCmdBuildMicromapsEXT =
        device_fn(chain.device, c"vkCmdBuildMicromapsEXT");
    let ((), growth) = measure(|| {
        // SAFETY: a recording command buffer, one info.
        unsafe { cmd_build(command_buffer, 1, &info) };
        end_and_submit(&chain, command_buffer);
    });
    assert_small("vkCmdBuildMicromapsEXT and vkQueueSubmit", growth);
    // The 2^32 − 1 entries do not fit in the 64 bytes: said at submission,
    // having read the 64 bytes, not 2^35.
    let ids = reported(&chain, "vkCmdBuildMicromapsEXT");
    assert!(
        ids.iter()
            .any(|id| id == "OMMCHECK-build-triangle-array-in-range"),
        "{ids:?}"
    );
}

/// A bottom-level build of two primitives' worth of vertices and indices
/// claiming 2^32 − 1 primitives, whose attachment claims 2^32 − 1 triangles.
#[test]
fn structure_builds_of_huge_primitive_counts_over_tiny_memory_stay_small_and_are_reported() {
    let mut structures = vk::PhysicalDeviceAccelerationStructureFeaturesKHR {
        acceleration_structure: vk::TRUE,
        acceleration_structure_host_commands: vk::TRUE,
        ..Default::default()
    };
    let (chain, result) = Chain::with_device_chain(
        (&mut structures as *mut vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'_>).cast(),
    );
    assert_eq!(result, vk::Result::SUCCESS);
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    let micromap = chain.micromap(storage, 4096);
    let structure_storage = chain.buffer(
        1 << 16,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
        1,
    );
    let create: vk::PFN_vkCreateAccelerationStructureKHR =
        device_fn(chain.device, c"vkCreateAccelerationStructureKHR");
    let info = vk::AccelerationStructureCreateInfoKHR::default()
        .buffer(structure_storage)
        .size(1 << 16)
        .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL);
    let mut blas = vk::AccelerationStructureKHR::null();
    // SAFETY: valid arguments.
    assert_eq!(
        unsafe { create(chain.device, &info, std::ptr::null(), &mut blas) },
        vk::Result::SUCCESS
    );
    let vertices = Box::new([0.5f32; 18]);
    let indices = Box::new([0u32, 1, 2, 3, 4, 5]);
    let omm_indices = Box::new([0u32, 1]);
    let mut scratch = vec![0u8; 4096];
    let scratch = host(scratch.as_mut_ptr());
    let ranges = [vk::AccelerationStructureBuildRangeInfoKHR {
        primitive_count: HUGE,
        ..Default::default()
    }];
    let range_pointers = [ranges.as_ptr()];
    let geometry = |vertices: u64, indices: u64, omm_indices: u64, attachment: &mut _| {
        *attachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
            index_type: vk::IndexType::UINT32,
            index_buffer: vk::DeviceOrHostAddressConstKHR {
                device_address: omm_indices,
            },
            index_stride: 4,
            usage_counts_count: 1,
            p_usage_counts: HUGE_USAGE.as_ptr(),
            micromap,
            ..Default::default()
        };
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR {
            p_next: (attachment as *const vk::AccelerationStructureTrianglesOpacityMicromapEXT<'_>)
                .cast(),
            vertex_format: vk::Format::R32G32B32_SFLOAT,
            vertex_data: vk::DeviceOrHostAddressConstKHR {
                device_address: vertices,
            },
            vertex_stride: 12,
            max_vertex: 5,
            index_type: vk::IndexType::UINT32,
            index_data: vk::DeviceOrHostAddressConstKHR {
                device_address: indices,
            },
            ..Default::default()
        };
        vk::AccelerationStructureGeometryKHR {
            geometry_type: vk::GeometryTypeKHR::TRIANGLES,
            geometry: vk::AccelerationStructureGeometryDataKHR { triangles },
            ..Default::default()
        }
    };
    fn build_info<'a>(
        geometry: &'a vk::AccelerationStructureGeometryKHR<'a>,
        dst: vk::AccelerationStructureKHR,
        scratch: u64,
    ) -> vk::AccelerationStructureBuildGeometryInfoKHR<'a> {
        vk::AccelerationStructureBuildGeometryInfoKHR {
            ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            mode: vk::BuildAccelerationStructureModeKHR::BUILD,
            dst_acceleration_structure: dst,
            geometry_count: 1,
            p_geometries: geometry,
            scratch_data: vk::DeviceOrHostAddressKHR {
                device_address: scratch,
            },
            ..Default::default()
        }
    }

    // On the host, from the application's few bytes.
    let mut attachment = Default::default();
    let host_geometry = geometry(
        host(vertices.as_ptr().cast()),
        host(indices.as_ptr().cast()),
        host(omm_indices.as_ptr().cast()),
        &mut attachment,
    );
    let info = build_info(&host_geometry, blas, scratch);
    let build: vk::PFN_vkBuildAccelerationStructuresKHR =
        device_fn(chain.device, c"vkBuildAccelerationStructuresKHR");
    // SAFETY: one info and its range; the host arrays are not read past
    // what the layer can bound (what is asserted is that it reports).
    let (result, growth) = measure(|| unsafe {
        build(
            chain.device,
            vk::DeferredOperationKHR::null(),
            1,
            &info,
            range_pointers.as_ptr(),
        )
    });
    assert_eq!(result, vk::Result::SUCCESS);
    assert_small("vkBuildAccelerationStructuresKHR", growth);
    let ids = reported(&chain, "vkBuildAccelerationStructuresKHR");
    assert!(ids.iter().any(|id| id == READ_BOUND), "{ids:?}");

    // On the device: the indices and the attachment's indices in a 64-byte
    // mapped buffer, read at submission.
    let mut input = Box::new([0u8; 64]);
    let address = tiny_mapped_input(&chain, &mut input);
    let mut attachment = Default::default();
    let device_geometry = geometry(address, address, address + 32, &mut attachment);
    let device_scratch = chain.address(chain.buffer(
        1 << 16,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        0,
    ));
    let info = build_info(&device_geometry, blas, device_scratch);
    let command_buffer = command_buffer(&chain);
    let cmd_build: vk::PFN_vkCmdBuildAccelerationStructuresKHR =
        device_fn(chain.device, c"vkCmdBuildAccelerationStructuresKHR");
    let ((), growth) = measure(|| {
        // SAFETY: a recording command buffer, one info and its range.
        unsafe { cmd_build(command_buffer, 1, &info, range_pointers.as_ptr()) };
        end_and_submit(&chain, command_buffer);
    });
    assert_small(
        "vkCmdBuildAccelerationStructuresKHR and vkQueueSubmit",
        growth,
    );
    // Level 12 is past the device's limit; reported, never a crash.
    let ids = reported(&chain, "vkCmdBuildAccelerationStructuresKHR");
    assert!(
        ids.iter().any(|id| id
            == "VUID-VkAccelerationStructureTrianglesOpacityMicromapEXT-subdivisionLevel-11681"),
        "{ids:?}"
    );
}

/// Command pools (destroyed whole, their command buffers with them),
/// fences (destroyed signalled) and bottom-level structures, made, used
/// and destroyed 20 times over, leave the device's checked state as one
/// round did. Before `cargo xtask soak` found them, each round left the
/// recording of the destroyed pool's command buffer (about 1 KiB with its
/// builds), the fence's submission (the layer passed vkResetFences and
/// vkDestroyFence on unseen) and the structure's micromap geometry.
#[test]
fn pools_fences_and_structures_destroyed_over_and_over_leave_nothing_behind() {
    let mut structures = vk::PhysicalDeviceAccelerationStructureFeaturesKHR {
        acceleration_structure: vk::TRUE,
        ..Default::default()
    };
    let (chain, result) = Chain::with_device_chain(
        (&mut structures as *mut vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'_>).cast(),
    );
    assert_eq!(result, vk::Result::SUCCESS);
    // Valid inputs in one buffer the application keeps mapped: the
    // triangle array at 0, their data at 256, the opacity indices at 512,
    // the vertices (any) at 768.
    let mut inputs = vec![0u8; 1024];
    for (k, t) in TRIANGLES.iter().enumerate() {
        let entry = &mut inputs[8 * k..8 * k + 8];
        entry[..4].copy_from_slice(&t.data_offset.to_le_bytes());
        entry[4..6].copy_from_slice(&t.subdivision_level.to_le_bytes());
        entry[6..].copy_from_slice(&t.format.to_le_bytes());
    }
    inputs[256..258].fill(0xA5);
    inputs[516..520].copy_from_slice(&1u32.to_le_bytes());
    let input = chain.address(chain.mapped_buffer_holding(
        &inputs,
        vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
            | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
    ));
    let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0);
    let micromap = chain.micromap(storage, 4096);
    let scratch = chain.address(chain.buffer(
        1 << 16,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        0,
    ));
    let round = || {
        let pool = chain.command_pool();
        let command_buffer = chain.command_buffer_from(pool, vk::CommandBufferLevel::PRIMARY);
        let blas = AttachmentBuild::structure(&chain);
        chain.begin(command_buffer);
        let info = device_micromap_build(micromap, &USAGE, input, input + 256, scratch);
        record_micromap_build(&chain, command_buffer, &info);
        AttachmentBuild {
            blas,
            vertices: input + 768,
            scratch,
            indices: input + 512,
            usage_counts: &USAGE,
            micromap,
        }
        .record(&chain, command_buffer);
        chain.end(command_buffer);
        let fence = chain.fence();
        assert_eq!(
            chain.submit_with(command_buffer, fence),
            vk::Result::SUCCESS
        );
        assert_eq!(chain.wait_for_fence(fence), vk::Result::SUCCESS);
        let destroy_fence: vk::PFN_vkDestroyFence = device_fn(chain.device, c"vkDestroyFence");
        let destroy_structure: vk::PFN_vkDestroyAccelerationStructureKHR =
            device_fn(chain.device, c"vkDestroyAccelerationStructureKHR");
        let destroy_pool: vk::PFN_vkDestroyCommandPool =
            device_fn(chain.device, c"vkDestroyCommandPool");
        // SAFETY: the submission is complete; nothing uses these any more.
        unsafe {
            destroy_fence(chain.device, fence, std::ptr::null());
            destroy_structure(chain.device, blas, std::ptr::null());
            destroy_pool(chain.device, pool, std::ptr::null());
        }
        // The fake driver's call log, which would grow too.
        fake::clear_calls();
    };
    round();
    let after_one = layer::testing::kept_per_object(chain.device).expect("a known device");
    for _ in 0..20 {
        round();
    }
    assert_eq!(
        layer::testing::kept_per_object(chain.device),
        Some(after_one)
    );
    // The rounds were valid: nothing was reported.
    let received = chain.collector.take();
    assert!(received.is_empty(), "{received:#?}");
}

#[test]
fn semaphores_signalled_and_destroyed_over_and_over_leave_nothing_behind() {
    let chain = Chain::new();
    let signal: vk::PFN_vkSignalSemaphore = device_fn(chain.device, c"vkSignalSemaphore");
    let destroy: vk::PFN_vkDestroySemaphore = device_fn(chain.device, c"vkDestroySemaphore");
    let round = || {
        let semaphore = chain.timeline(0);
        let info = vk::SemaphoreSignalInfo::default()
            .semaphore(semaphore)
            .value(1);
        // SAFETY: a timeline semaphore of this device, signalled once.
        assert_eq!(unsafe { signal(chain.device, &info) }, vk::Result::SUCCESS);
        // SAFETY: no submission refers to it.
        unsafe { destroy(chain.device, semaphore, std::ptr::null()) };
        fake::clear_calls();
    };
    round();
    let after_one = layer::testing::kept_per_object(chain.device).expect("a known device");
    for _ in 0..20 {
        round();
    }
    let kept = layer::testing::kept_per_object(chain.device).expect("a known device");
    assert_eq!(kept, after_one);
    assert!(
        kept.contains(&("semaphore_signals", 0)),
        "a destroyed semaphore's signal is forgotten: {kept:?}"
    );
    let received = chain.collector.take();
    assert!(received.is_empty(), "{received:#?}");
}
