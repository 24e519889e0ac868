//! Hostile use through the in-process chain (see `fake/`): eight threads
//! creating, building with and destroying objects at once, with valid calls
//! and calls with known faults mixed; and valid calls, which must reach the
//! driver and come back to the application exactly as without the layer.
//!
//! This binary reports every severity with no duplicate limit: its tests
//! count messages exactly, and valid calls must draw not even information.

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::ffi::CStr;
use std::sync::{mpsc, Arc, Once};
use std::time::Duration;

use ash::vk;
use ash::vk::Handle as _;
use fake::app::{Calls, Through};
use fake::{
    device_fn, device_micromap_build, dispatchable, key_of, Chain, Received, TRIANGLES, USAGE,
};

const BOTH_USAGE_POINTERS: &str = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";
const MICROMAP_STRUCTURE_TYPE: &str = "VUID-VkAccelerationStructureCreateInfoKHR-type-11600";
const INDEX_IN_RANGE: &str = "OMMCHECK-attach-index-in-range";
const DESTROYED_IN_USE: &str = "VUID-vkDestroyMicromapEXT-micromap-07441";

/// How long the threads may take before the test calls it a deadlock: far
/// beyond what the work takes (well under a second), so only a hang trips it.
const DEADLOCK_BOUND: Duration = Duration::from_secs(60);

/// The chain over a device with the micromap and acceleration-structure
/// features and their host commands, with this binary's settings in place
/// before the first instance.
fn chain() -> Chain {
    static SETTINGS: Once = Once::new();
    SETTINGS.call_once(|| {
        std::env::set_var("OMMCHECK_REPORT", "error,warning,info");
        std::env::set_var("OMMCHECK_DUPLICATE_LIMIT", "0");
    });
    let mut structures = vk::PhysicalDeviceAccelerationStructureFeaturesKHR {
        acceleration_structure: vk::TRUE,
        acceleration_structure_host_commands: vk::TRUE,
        ..Default::default()
    };
    let (chain, result) = Chain::with_device_chain(
        (&mut structures as *mut vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'_>).cast(),
    );
    assert_eq!(result, vk::Result::SUCCESS);
    chain
}

/// Runs `work` on `threads` threads and waits for them, failing the test if
/// they have not all finished within [`DEADLOCK_BOUND`]; a thread's panic
/// is the test's.
fn on_threads(threads: usize, work: impl Fn(usize) + Send + Sync + 'static) {
    let work = Arc::new(work);
    let (done, finished) = mpsc::channel();
    let handles: Vec<_> = (0..threads)
        .map(|t| {
            let (work, done) = (Arc::clone(&work), done.clone());
            std::thread::spawn(move || {
                // Sent when the thread ends, by return or by panic.
                struct Done(mpsc::Sender<()>);
                impl Drop for Done {
                    fn drop(&mut self) {
                        let _ = self.0.send(());
                    }
                }
                let _done = Done(done);
                work(t);
            })
        })
        .collect();
    let deadline = std::time::Instant::now() + DEADLOCK_BOUND;
    for _ in 0..threads {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        finished.recv_timeout(left).unwrap_or_else(|_| {
            panic!("the threads did not finish within {DEADLOCK_BOUND:?}: a deadlock")
        });
    }
    for handle in handles {
        if let Err(panic) = handle.join() {
            std::panic::resume_unwind(panic);
        }
    }
}

/// The ids received, each with how often.
fn counts(received: &[Received]) -> std::collections::BTreeMap<String, usize> {
    let mut counts = std::collections::BTreeMap::new();
    for r in received {
        *counts.entry(r.id.clone()).or_default() += 1;
    }
    counts
}

/// What the threads need of the chain: its functions, through the layer.
struct Device<'a> {
    chain: &'a Chain,
}

impl Device<'_> {
    fn f<F: Copy>(&self, name: &CStr) -> F {
        device_fn(self.chain.device, name)
    }

    fn command_pool(&self) -> vk::CommandPool {
        let create: vk::PFN_vkCreateCommandPool = self.f(c"vkCreateCommandPool");
        let info = vk::CommandPoolCreateInfo::default().queue_family_index(0);
        let mut pool = vk::CommandPool::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.chain.device, &info, std::ptr::null(), &mut pool) };
        assert_eq!(result, vk::Result::SUCCESS);
        pool
    }

    fn command_buffer(&self, pool: vk::CommandPool) -> vk::CommandBuffer {
        let allocate: vk::PFN_vkAllocateCommandBuffers = self.f(c"vkAllocateCommandBuffers");
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        let mut command_buffer = vk::CommandBuffer::null();
        // SAFETY: valid arguments, room for one handle.
        let result = unsafe { allocate(self.chain.device, &info, &mut command_buffer) };
        assert_eq!(result, vk::Result::SUCCESS);
        command_buffer
    }

    fn structure(
        &self,
        buffer: vk::Buffer,
        ty: vk::AccelerationStructureTypeKHR,
    ) -> vk::AccelerationStructureKHR {
        let create: vk::PFN_vkCreateAccelerationStructureKHR =
            self.f(c"vkCreateAccelerationStructureKHR");
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer)
            .size(1 << 16)
            .ty(ty);
        let mut structure = vk::AccelerationStructureKHR::null();
        // SAFETY: valid arguments.
        let result = unsafe { create(self.chain.device, &info, std::ptr::null(), &mut structure) };
        assert_eq!(result, vk::Result::SUCCESS);
        structure
    }
}

/// Two triangles' geometry (six vertices, not indexed) whose opacity
/// micromap attachment names `micromap`'s two triangles through 32-bit
/// indices at `indices`; device or host addresses alike.
fn attached_triangles(
    vertices: u64,
    indices: u64,
    micromap: vk::MicromapEXT,
    attachment: &mut vk::AccelerationStructureTrianglesOpacityMicromapEXT<'static>,
) -> vk::AccelerationStructureGeometryKHR<'static> {
    *attachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT {
        index_type: vk::IndexType::UINT32,
        index_buffer: vk::DeviceOrHostAddressConstKHR {
            device_address: indices,
        },
        index_stride: 4,
        usage_counts_count: 1,
        p_usage_counts: USAGE.as_ptr(),
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
        index_type: vk::IndexType::NONE_KHR,
        ..Default::default()
    };
    vk::AccelerationStructureGeometryKHR {
        geometry_type: vk::GeometryTypeKHR::TRIANGLES,
        geometry: vk::AccelerationStructureGeometryDataKHR { triangles },
        ..Default::default()
    }
}

/// A bottom-level build of one geometry into `dst`.
fn blas_build<'a>(
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

/// A micromap build of [`USAGE`]'s two triangles into `dst`: the triangle
/// array (stride 8) at `triangles`, the data at `data`.
fn micromap_build(
    dst: vk::MicromapEXT,
    triangles: u64,
    data: u64,
    scratch: u64,
) -> vk::MicromapBuildInfoEXT<'static> {
    device_micromap_build(dst, &USAGE, triangles, data, scratch)
}

const ITERATIONS: usize = 24;
const THREADS: usize = 8;

/// One thread's work in [`eight_threads_creating_building_and_destroying_report_exactly_their_faults`]:
/// per iteration it creates every object it uses and destroys it after,
/// records device builds of a micromap and of a bottom-level structure
/// attaching it and submits them, and makes host builds of both. Faults
/// per iteration: one device and one host micromap build with both usage
/// pointers (07516 each), one acceleration structure created with the
/// opacity-micromap type (11600), and in odd iterations the attachment's
/// mapped index 1 is 5, past the micromap's two triangles (reported at
/// submission), and the micromap is destroyed while the submission that
/// builds it has not been waited for (07441).
fn thread_work(chain: &Chain) {
    let device = Device { chain };
    let pool = device.command_pool();
    let address_usage = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let build_input = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
        | address_usage;
    // Host memory this thread's mappings and host builds use.
    let mut indices = Box::new([0u32; 16]);
    let vertices = Box::new([0.5f32; 18]);
    let host_indices = Box::new([0u32, 1]);
    let data = Box::new([0x1u8, 0x2]);
    let mut host_scratch = vec![0u8; 1 << 16];
    for iteration in 0..ITERATIONS {
        // Host-visible storage (type 1): host builds need it.
        let storage = chain.buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
        let micromap = chain.micromap(storage, 4096);
        let structure_usage =
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR | address_usage;
        let structure_storage = chain.buffer(1 << 16, structure_usage, 1);
        let blas = device.structure(
            structure_storage,
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
        );
        let misused = device.structure(
            structure_storage,
            vk::AccelerationStructureTypeKHR::from_raw(
                ommcheck::model::accel::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
            ),
        );
        let input = chain.buffer(4096, build_input, 0);
        let scratch = chain.buffer(
            1 << 16,
            vk::BufferUsageFlags::STORAGE_BUFFER | address_usage,
            0,
        );
        let (index_buffer, index_memory) = chain.buffer_and_memory(64, build_input, 1);
        indices[1] = if iteration % 2 == 1 { 5 } else { 1 };
        chain.map(index_memory, indices.as_mut_ptr().cast());
        let buffers = [storage, structure_storage, input, scratch, index_buffer];
        let (input, scratch, index_buffer) = (
            chain.address(input),
            chain.address(scratch),
            chain.address(index_buffer),
        );

        let command_buffer = device.command_buffer(pool);
        let begin: vk::PFN_vkBeginCommandBuffer = device.f(c"vkBeginCommandBuffer");
        // SAFETY: valid arguments.
        assert_eq!(
            unsafe { begin(command_buffer, &vk::CommandBufferBeginInfo::default()) },
            vk::Result::SUCCESS
        );
        let cmd_build_micromaps: vk::PFN_vkCmdBuildMicromapsEXT =
            device.f(c"vkCmdBuildMicromapsEXT");
        let valid = micromap_build(micromap, input, input + 256, scratch);
        let pointers = [USAGE.as_ptr()];
        let both = vk::MicromapBuildInfoEXT {
            pp_usage_counts: pointers.as_ptr(),
            ..valid
        };
        // SAFETY: a recording command buffer; one info each.
        unsafe {
            cmd_build_micromaps(command_buffer, 1, &valid);
            cmd_build_micromaps(command_buffer, 1, &both);
        }
        let mut attachment = Default::default();
        let geometry = attached_triangles(input + 1024, index_buffer, micromap, &mut attachment);
        let info = blas_build(&geometry, blas, scratch);
        let ranges = [vk::AccelerationStructureBuildRangeInfoKHR {
            primitive_count: 2,
            ..Default::default()
        }];
        let range_pointers = [ranges.as_ptr()];
        let cmd_build_structures: vk::PFN_vkCmdBuildAccelerationStructuresKHR =
            device.f(c"vkCmdBuildAccelerationStructuresKHR");
        // SAFETY: a recording command buffer; one info and its ranges.
        unsafe { cmd_build_structures(command_buffer, 1, &info, range_pointers.as_ptr()) };
        let end: vk::PFN_vkEndCommandBuffer = device.f(c"vkEndCommandBuffer");
        // SAFETY: a recording command buffer.
        assert_eq!(unsafe { end(command_buffer) }, vk::Result::SUCCESS);
        let submit: vk::PFN_vkQueueSubmit = device.f(c"vkQueueSubmit");
        // A queue shares its device's dispatch key.
        let queue = vk::Queue::from_raw(dispatchable(key_of(chain.device.as_raw())));
        let command_buffers = [command_buffer];
        let submit_info = vk::SubmitInfo::default().command_buffers(&command_buffers);
        // SAFETY: valid arguments.
        assert_eq!(
            unsafe { submit(queue, 1, &submit_info, vk::Fence::null()) },
            vk::Result::SUCCESS
        );

        // Host builds: the micromap from this thread's arrays, then a
        // structure attaching it.
        let build_micromaps: vk::PFN_vkBuildMicromapsEXT = device.f(c"vkBuildMicromapsEXT");
        let host = |p: *const u8| p.expose_provenance() as u64;
        let host_valid = micromap_build(
            micromap,
            host(TRIANGLES.as_ptr().cast()),
            host(data.as_ptr()),
            host(host_scratch.as_mut_ptr()),
        );
        let host_both = vk::MicromapBuildInfoEXT {
            pp_usage_counts: pointers.as_ptr(),
            ..host_valid
        };
        for info in [&host_valid, &host_both] {
            // SAFETY: one info whose host addresses are live.
            let result =
                unsafe { build_micromaps(chain.device, vk::DeferredOperationKHR::null(), 1, info) };
            assert_eq!(result, vk::Result::SUCCESS);
        }
        let mut host_attachment = Default::default();
        let host_geometry = attached_triangles(
            host(vertices.as_ptr().cast()),
            host(host_indices.as_ptr().cast()),
            micromap,
            &mut host_attachment,
        );
        let host_info = blas_build(&host_geometry, blas, host(host_scratch.as_mut_ptr()));
        let build_structures: vk::PFN_vkBuildAccelerationStructuresKHR =
            device.f(c"vkBuildAccelerationStructuresKHR");
        // SAFETY: one info with live host addresses, and its ranges.
        let result = unsafe {
            build_structures(
                chain.device,
                vk::DeferredOperationKHR::null(),
                1,
                &host_info,
                range_pointers.as_ptr(),
            )
        };
        assert_eq!(result, vk::Result::SUCCESS);

        // Everything goes again, while other threads create theirs; the
        // micromap without waiting for the submission that uses it (07441).
        let free: vk::PFN_vkFreeCommandBuffers = device.f(c"vkFreeCommandBuffers");
        let destroy_structure: vk::PFN_vkDestroyAccelerationStructureKHR =
            device.f(c"vkDestroyAccelerationStructureKHR");
        let destroy_micromap: vk::PFN_vkDestroyMicromapEXT = device.f(c"vkDestroyMicromapEXT");
        let destroy_buffer: vk::PFN_vkDestroyBuffer = device.f(c"vkDestroyBuffer");
        let free_memory: vk::PFN_vkFreeMemory = device.f(c"vkFreeMemory");
        // SAFETY: objects of this device (the fake driver runs nothing,
        // so the pending submission touches none of them).
        unsafe {
            free(chain.device, pool, 1, &command_buffer);
            destroy_structure(chain.device, blas, std::ptr::null());
            destroy_structure(chain.device, misused, std::ptr::null());
            destroy_micromap(chain.device, micromap, std::ptr::null());
            for buffer in buffers {
                destroy_buffer(chain.device, buffer, std::ptr::null());
            }
            free_memory(chain.device, index_memory, std::ptr::null());
        }
    }
    let destroy_pool: vk::PFN_vkDestroyCommandPool = device.f(c"vkDestroyCommandPool");
    // SAFETY: a pool of this device with no command buffers left.
    unsafe { destroy_pool(chain.device, pool, std::ptr::null()) };
    // Every call reached this thread's driver, whatever was reported.
    assert_eq!(fake::calls("vkCmdBuildMicromapsEXT").len(), 2 * ITERATIONS);
    assert_eq!(fake::calls("vkBuildMicromapsEXT").len(), 2 * ITERATIONS);
    assert_eq!(
        fake::calls("vkCmdBuildAccelerationStructuresKHR").len(),
        ITERATIONS
    );
    assert_eq!(
        fake::calls("vkBuildAccelerationStructuresKHR").len(),
        ITERATIONS
    );
    assert_eq!(fake::calls("vkQueueSubmit").len(), ITERATIONS);
    assert_eq!(
        fake::calls("vkDestroyAccelerationStructureKHR").len(),
        2 * ITERATIONS
    );
}

#[test]
fn eight_threads_creating_building_and_destroying_report_exactly_their_faults() {
    let chain = Arc::new(chain());
    let shared = Arc::clone(&chain);
    on_threads(THREADS, move |_| thread_work(&shared));
    let received = chain.collector.take();
    let runs = THREADS * ITERATIONS;
    let expected = std::collections::BTreeMap::from([
        (BOTH_USAGE_POINTERS.to_owned(), 2 * runs),
        (MICROMAP_STRUCTURE_TYPE.to_owned(), runs),
        (INDEX_IN_RANGE.to_owned(), runs / 2),
        (DESTROYED_IN_USE.to_owned(), runs),
        // The host builds' data lies in plain host memory the layer cannot
        // see: said once for the device, whichever thread is first.
        ("OMMCHECK-not-checked-host-memory".to_owned(), 1),
    ]);
    assert_eq!(counts(&received), expected);
    // Each command buffer's submission reported its own index, at most once.
    let mut reported_for: Vec<u64> = received
        .iter()
        .filter(|r| r.id == INDEX_IN_RANGE)
        .map(|r| r.objects[0].1)
        .collect();
    reported_for.sort_unstable();
    reported_for.dedup();
    assert_eq!(reported_for.len(), runs / 2);
}

/// The application's side of [`valid_calls`]: its calls and what they
/// returned, and its host memory, at the same addresses in every run.
struct App {
    calls: Calls,
    /// A host-visible allocation the fake driver maps here: the triangle
    /// array at 0, the data at 256, the attachment's indices at 512, the
    /// vertices at 1024.
    mapped: Box<[u8; 4096]>,
    host_scratch: Box<[u8; 1 << 16]>,
    /// The infos of the calls that pass `pInfos` to the driver as given.
    micromap_info: Box<vk::MicromapBuildInfoEXT<'static>>,
}

impl std::ops::Deref for App {
    type Target = Calls;
    fn deref(&self) -> &Calls {
        &self.calls
    }
}

impl std::ops::DerefMut for App {
    fn deref_mut(&mut self) -> &mut Calls {
        &mut self.calls
    }
}

/// One valid use of everything the layer checks on the way to the driver:
/// buffers, memory and its mapping, size queries, micromap and structure
/// creation, device builds, copies, submission, host builds and copies,
/// destruction. Returns nothing: what came back is in `app.seen`.
fn valid_calls(app: &mut App) {
    let address_usage = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let input_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
        | address_usage;
    let (input, input_memory) = app.buffer(4096, input_usage, 1);
    fake::map_to(app.mapped.as_mut_ptr());
    let map: vk::PFN_vkMapMemory = app.f(c"vkMapMemory");
    let mut mapped = std::ptr::null_mut();
    // SAFETY: valid arguments.
    let result = unsafe {
        map(
            app.device,
            input_memory,
            0,
            vk::WHOLE_SIZE,
            vk::MemoryMapFlags::empty(),
            &mut mapped,
        )
    };
    app.saw((result, mapped));
    let (scratch, _) = app.buffer(
        1 << 16,
        vk::BufferUsageFlags::STORAGE_BUFFER | address_usage,
        1,
    );
    let (input, scratch) = (app.address(input), app.address(scratch));
    let (storage, _) = app.buffer(8192, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    let structure_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR | address_usage;
    let (structure_storage, _) = app.buffer(1 << 17, structure_usage, 1);

    let device = app.device;
    let build = micromap_build(vk::MicromapEXT::null(), input, input + 256, scratch);
    let sizes_of: vk::PFN_vkGetMicromapBuildSizesEXT = app.f(c"vkGetMicromapBuildSizesEXT");
    let mut micromap_sizes = vk::MicromapBuildSizesInfoEXT::default();
    // SAFETY: valid arguments.
    unsafe {
        sizes_of(
            device,
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            &build,
            &mut micromap_sizes,
        )
    };
    app.saw((
        micromap_sizes.micromap_size,
        micromap_sizes.build_scratch_size,
        micromap_sizes.discardable,
    ));
    let create_micromap: vk::PFN_vkCreateMicromapEXT = app.f(c"vkCreateMicromapEXT");
    let mut micromaps = [vk::MicromapEXT::null(); 2];
    for (k, micromap) in micromaps.iter_mut().enumerate() {
        let info = vk::MicromapCreateInfoEXT {
            buffer: storage,
            offset: 4096 * k as u64,
            size: 4096,
            ty: vk::MicromapTypeEXT::OPACITY_MICROMAP,
            ..Default::default()
        };
        // SAFETY: valid arguments.
        let result = unsafe { create_micromap(device, &info, std::ptr::null(), micromap) };
        app.saw((result, *micromap));
    }

    let mut attachment = Default::default();
    let geometry = attached_triangles(input + 1024, input + 512, micromaps[0], &mut attachment);
    let sizes_info = blas_build(&geometry, vk::AccelerationStructureKHR::null(), 0);
    let structure_sizes_of: vk::PFN_vkGetAccelerationStructureBuildSizesKHR =
        app.f(c"vkGetAccelerationStructureBuildSizesKHR");
    let mut structure_sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
    // SAFETY: valid arguments: one geometry, one count.
    unsafe {
        structure_sizes_of(
            device,
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            &sizes_info,
            [2u32].as_ptr(),
            &mut structure_sizes,
        )
    };
    app.saw((
        structure_sizes.acceleration_structure_size,
        structure_sizes.update_scratch_size,
        structure_sizes.build_scratch_size,
    ));
    let create_structure: vk::PFN_vkCreateAccelerationStructureKHR =
        app.f(c"vkCreateAccelerationStructureKHR");
    let mut structures = [vk::AccelerationStructureKHR::null(); 2];
    for (k, structure) in structures.iter_mut().enumerate() {
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(structure_storage)
            .offset((1 << 16) * k as u64)
            .size(1 << 16)
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL);
        // SAFETY: valid arguments.
        let result = unsafe { create_structure(device, &info, std::ptr::null(), structure) };
        app.saw((result, *structure));
    }

    // Device builds and copies, recorded and submitted.
    let create_pool: vk::PFN_vkCreateCommandPool = app.f(c"vkCreateCommandPool");
    let info = vk::CommandPoolCreateInfo::default().queue_family_index(0);
    let mut pool = vk::CommandPool::null();
    // SAFETY: valid arguments.
    let result = unsafe { create_pool(device, &info, std::ptr::null(), &mut pool) };
    app.saw((result, pool));
    let allocate: vk::PFN_vkAllocateCommandBuffers = app.f(c"vkAllocateCommandBuffers");
    let info = vk::CommandBufferAllocateInfo::default()
        .command_pool(pool)
        .level(vk::CommandBufferLevel::PRIMARY)
        .command_buffer_count(1);
    let mut command_buffer = vk::CommandBuffer::null();
    // SAFETY: valid arguments.
    let result = unsafe { allocate(device, &info, &mut command_buffer) };
    app.saw((result, command_buffer));
    let begin: vk::PFN_vkBeginCommandBuffer = app.f(c"vkBeginCommandBuffer");
    let info =
        vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
    // SAFETY: valid arguments.
    app.saw(unsafe { begin(command_buffer, &info) });
    *app.micromap_info = micromap_build(micromaps[0], input, input + 256, scratch);
    let cmd_build_micromaps: vk::PFN_vkCmdBuildMicromapsEXT = app.f(c"vkCmdBuildMicromapsEXT");
    // SAFETY: a recording command buffer, one info.
    unsafe { cmd_build_micromaps(command_buffer, 1, &*app.micromap_info) };
    let info = blas_build(&geometry, structures[0], scratch);
    let ranges = [vk::AccelerationStructureBuildRangeInfoKHR {
        primitive_count: 2,
        ..Default::default()
    }];
    let range_pointers = [ranges.as_ptr()];
    let cmd_build_structures: vk::PFN_vkCmdBuildAccelerationStructuresKHR =
        app.f(c"vkCmdBuildAccelerationStructuresKHR");
    // SAFETY: a recording command buffer, one info and its ranges.
    unsafe { cmd_build_structures(command_buffer, 1, &info, range_pointers.as_ptr()) };
    let cmd_copy_micromap: vk::PFN_vkCmdCopyMicromapEXT = app.f(c"vkCmdCopyMicromapEXT");
    let copy = vk::CopyMicromapInfoEXT {
        src: micromaps[0],
        dst: micromaps[1],
        mode: vk::CopyMicromapModeEXT::CLONE,
        ..Default::default()
    };
    // SAFETY: a recording command buffer; valid pointers.
    unsafe { cmd_copy_micromap(command_buffer, &copy) };
    let cmd_copy_structure: vk::PFN_vkCmdCopyAccelerationStructureKHR =
        app.f(c"vkCmdCopyAccelerationStructureKHR");
    let copy_structure = vk::CopyAccelerationStructureInfoKHR {
        src: structures[0],
        dst: structures[1],
        mode: vk::CopyAccelerationStructureModeKHR::CLONE,
        ..Default::default()
    };
    // SAFETY: as above.
    unsafe { cmd_copy_structure(command_buffer, &copy_structure) };
    let end: vk::PFN_vkEndCommandBuffer = app.f(c"vkEndCommandBuffer");
    // SAFETY: a recording command buffer.
    app.saw(unsafe { end(command_buffer) });
    let submit: vk::PFN_vkQueueSubmit = app.f(c"vkQueueSubmit");
    let queue = app.queue;
    let command_buffers = [command_buffer];
    let submit_info = vk::SubmitInfo::default().command_buffers(&command_buffers);
    // SAFETY: valid arguments.
    app.saw(unsafe { submit(queue, 1, &submit_info, vk::Fence::null()) });

    // Host builds and copies, from the application's own memory.
    let host = |p: *const u8| p.expose_provenance() as u64;
    let triangles = host(app.mapped.as_ptr());
    let host_scratch = host(app.host_scratch.as_mut_ptr());
    *app.micromap_info = micromap_build(micromaps[0], triangles, triangles + 256, host_scratch);
    let build_micromaps: vk::PFN_vkBuildMicromapsEXT = app.f(c"vkBuildMicromapsEXT");
    // SAFETY: one info with live host addresses.
    app.calls.saw(unsafe {
        build_micromaps(
            device,
            vk::DeferredOperationKHR::null(),
            1,
            &*app.micromap_info,
        )
    });
    let mut host_attachment = Default::default();
    let host_geometry = attached_triangles(
        triangles + 1024,
        triangles + 512,
        micromaps[0],
        &mut host_attachment,
    );
    let host_info = blas_build(&host_geometry, structures[0], host_scratch);
    let build_structures: vk::PFN_vkBuildAccelerationStructuresKHR =
        app.f(c"vkBuildAccelerationStructuresKHR");
    // SAFETY: one info with live host addresses, and its ranges.
    app.saw(unsafe {
        build_structures(
            device,
            vk::DeferredOperationKHR::null(),
            1,
            &host_info,
            range_pointers.as_ptr(),
        )
    });
    let copy_micromap: vk::PFN_vkCopyMicromapEXT = app.f(c"vkCopyMicromapEXT");
    // SAFETY: valid arguments.
    app.saw(unsafe { copy_micromap(device, vk::DeferredOperationKHR::null(), &copy) });
    let copy_structure_on_host: vk::PFN_vkCopyAccelerationStructureKHR =
        app.f(c"vkCopyAccelerationStructureKHR");
    // SAFETY: valid arguments.
    app.saw(unsafe {
        copy_structure_on_host(device, vk::DeferredOperationKHR::null(), &copy_structure)
    });

    // Destruction, once the submission is complete (07441).
    let wait_idle: vk::PFN_vkQueueWaitIdle = app.f(c"vkQueueWaitIdle");
    // SAFETY: the application's queue.
    app.saw(unsafe { wait_idle(queue) });
    let free: vk::PFN_vkFreeCommandBuffers = app.f(c"vkFreeCommandBuffers");
    let destroy_pool: vk::PFN_vkDestroyCommandPool = app.f(c"vkDestroyCommandPool");
    let destroy_structure: vk::PFN_vkDestroyAccelerationStructureKHR =
        app.f(c"vkDestroyAccelerationStructureKHR");
    let destroy_micromap: vk::PFN_vkDestroyMicromapEXT = app.f(c"vkDestroyMicromapEXT");
    // SAFETY: objects of this device that nothing pending uses.
    unsafe {
        free(device, pool, 1, &command_buffer);
        destroy_pool(device, pool, std::ptr::null());
        for structure in structures {
            destroy_structure(device, structure, std::ptr::null());
        }
        for micromap in micromaps {
            destroy_micromap(device, micromap, std::ptr::null());
        }
    }
}

#[test]
fn valid_calls_reach_the_driver_and_come_back_as_without_the_layer() {
    let chain = chain();
    let info = Box::<fake::Collector>::default();
    let _messenger = fake::add_messenger(
        chain.instance,
        vk::DebugUtilsMessageSeverityFlagsEXT::INFO
            | vk::DebugUtilsMessageSeverityFlagsEXT::VERBOSE,
        &info,
    );
    let mut mapped = Box::new([0u8; 4096]);
    // The triangle array, the data, the attachment's indices, the vertices.
    // SAFETY: 16 bytes of triangles at 0, all inside the 4096.
    unsafe {
        mapped
            .as_mut_ptr()
            .copy_from_nonoverlapping(TRIANGLES.as_ptr().cast(), 16)
    };
    mapped[256..258].copy_from_slice(&[0x1, 0x2]);
    mapped[512..520].copy_from_slice(&[0, 0, 0, 0, 1, 0, 0, 0]);
    let mut app = App {
        calls: Calls {
            through: Through::Driver,
            device: chain.device,
            // A queue shares its device's dispatch key.
            queue: vk::Queue::from_raw(dispatchable(key_of(chain.device.as_raw()))),
            seen: Vec::new(),
        },
        mapped,
        host_scratch: Box::new([0; 1 << 16]),
        micromap_info: Box::default(),
    };
    fake::describe_calls(true);
    let run = |app: &mut App, through| {
        fake::reset();
        app.through = through;
        app.seen.clear();
        valid_calls(app);
        (fake::all_calls(), std::mem::take(&mut app.seen))
    };
    let (driver_alone, seen_alone) = run(&mut app, Through::Driver);
    let (through_layer, seen_through) = run(&mut app, Through::Layer);
    fake::describe_calls(false);

    // The layer asks the driver for the sizes of the micromap builds'
    // shapes (with no addresses: the query reads none), once per shape
    // and build type: the device build's shape the application asked about
    // itself, so only the host build's is asked.
    let (own, through_layer): (Vec<_>, Vec<_>) = through_layer.into_iter().partition(|c| {
        c.name == "vkGetMicromapBuildSizesEXT"
            && c.detail
                .contains("data=0x0 scratch=0x0 triangles=0x0 stride=0")
    });
    assert_eq!(
        own.iter().map(|c| c.args[0]).collect::<Vec<_>>(),
        [vk::AccelerationStructureBuildTypeKHR::HOST.as_raw() as u64],
        "{own:?}"
    );
    // Otherwise the layer added, dropped and changed nothing, but for one
    // usage bit: build inputs gain TRANSFER_SRC, so GPU readback (on by
    // default) may copy them.
    assert_eq!(through_layer.len(), driver_alone.len());
    for (with, without) in through_layer.iter().zip(&driver_alone) {
        let mut with = with.clone();
        if with.name == "vkCreateBuffer"
            && with.detail.contains("BUILD_INPUT_READ_ONLY")
            && !without.detail.contains("TRANSFER_SRC")
        {
            assert!(with.detail.contains(" TRANSFER_SRC |"), "{with:?}");
            with.detail = with.detail.replacen(" TRANSFER_SRC |", "", 1);
        }
        assert_eq!(&with, without);
    }
    assert_eq!(seen_through, seen_alone);
    // The log is the calls made, with the contents that matter.
    let names: Vec<&str> = driver_alone.iter().map(|c| c.name).collect();
    for name in [
        "vkGetMicromapBuildSizesEXT",
        "vkGetAccelerationStructureBuildSizesKHR",
        "vkCmdBuildMicromapsEXT",
        "vkCmdBuildAccelerationStructuresKHR",
        "vkCmdCopyMicromapEXT",
        "vkCmdCopyAccelerationStructureKHR",
        "vkQueueSubmit",
        "vkBuildMicromapsEXT",
        "vkBuildAccelerationStructuresKHR",
        "vkCopyMicromapEXT",
        "vkCopyAccelerationStructureKHR",
    ] {
        assert_eq!(
            names.iter().filter(|&&n| n == name).count(),
            1,
            "{name}: {names:?}"
        );
    }
    let structure_build = &driver_alone[names
        .iter()
        .position(|&n| n == "vkBuildAccelerationStructuresKHR")
        .unwrap()];
    assert!(
        structure_build.detail.contains("omm UINT32"),
        "{}",
        structure_build.detail
    );
    assert!(
        structure_build.detail.contains("primitive_count: 2"),
        "{}",
        structure_build.detail
    );
    // And nothing was reported: the calls were valid.
    let reported = chain.collector.take();
    assert!(reported.is_empty(), "{reported:#?}");
    let informed = info.take();
    assert!(informed.is_empty(), "{informed:#?}");
}
