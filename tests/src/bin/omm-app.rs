//! `omm-app`: an application that runs one named scenario through the
//! system's Vulkan loader and prints one JSON line: every message its
//! `VK_EXT_debug_utils` messenger received and what it measured.
//! `tests/layer_e2e.rs` runs it as a child process per scenario, with the
//! loader's variables (`VK_DRIVER_FILES`, `VK_ADD_LAYER_PATH`) and the
//! layer's settings (`OMMCHECK_*`) set for that scenario alone.
//!
//! ```text
//! omm-app SCENARIO [--layer NAME]... [--core-fault] [--iterations N]
//!         [--way copy|update|fill|compute|mapped] [--valid] [--sync-fault]
//! {"scenario": ..., "messages": [{"id", "severity", "phase", "text"}],
//!  "device_layers": [...], "results": {...}}
//! ```
//!
//! The layers are enabled in `ppEnabledLayerNames` in the order given. Each
//! message carries the phase it arrived in (`setup`, `build`, `record`,
//! `submit`, `wait` (vkWaitForFences), `teardown`); `device_layers` are the
//! layers the loader reports (as information) inserting into the device
//! call chain, in its order: from the driver up. `--core-fault` creates a buffer of size 0 at the
//! end (VUID-VkBufferCreateInfo-size-00912, which the Khronos validation
//! layer checks and ommcheck does not), to show a stacked layer is active.
//!
//! Scenarios over the Khronos Mock ICD (VK_EXT_opacity_micromap; every
//! command a stub): `host-build-valid`, `host-build-usage-pointers`,
//! `host-build-data-past-end`, `device-build-valid`,
//! `device-build-usage-pointers`, `device-build-histogram-mismatch`.
//! `threads` (Mock ICD): eight threads creating, building and destroying
//! at once, with known faults.
//! Over lavapipe (acceleration structures that really build): `blas`.
//! `tlas --way W [--valid] [--sync-fault]` (on the first physical device
//! with VK_KHR_acceleration_structure, lavapipe or a GPU): a top-level build
//! of one instance whose flags break
//! VUID-VkAccelerationStructureInstanceKHR-micromap-11580 (or are 0 with
//! `--valid`), the instance written into memory the app never maps by
//! vkCmdCopyBuffer, vkCmdUpdateBuffer, vkCmdFillBuffer or a compute shader,
//! or into memory it keeps mapped; `--sync-fault` plants a hazard for the
//! Khronos layer's synchronization validation. On a machine with a GPU,
//! after `cargo xtask layer` (which writes target/layer/VkLayer_ommcheck.json)
//! and `cargo build -p ommcheck-tests --bin omm-app`:
//! `VK_ADD_LAYER_PATH=target/layer target/debug/omm-app tlas --way compute
//! --layer VK_LAYER_OMMCHECK_validation`.
//! `overhead` (Mock ICD) times `--iterations` valid calls (default 10000) of
//! three build commands and reports nanoseconds per call; `cargo xtask
//! bench` runs it with and without layers. `--usage-entries K` (default 1)
//! gives each build K usage entries and `--triangles N` (default 2) N
//! micromap triangles.
//! Errors go to stderr with exit status 1.

use std::ffi::{c_void, CStr, CString};
use std::process::ExitCode;
use std::sync::Mutex;

use ash::vk;
use ommcheck_tests::vulkan::{
    build_info, build_sizes, instance_words, word_bytes, Attaching, Device, Instance,
    HOST_MAPPABLE, USAGE,
};
use serde_json::{json, Map, Value};

type Results = Map<String, Value>;

/// The messages a messenger received, each tagged with the app's phase,
/// and the layers the loader says it inserted in the device call chain.
#[derive(Default)]
struct Collector {
    phase: Mutex<&'static str>,
    messages: Mutex<Vec<Value>>,
    device_layers: Mutex<Vec<String>>,
}

/// The loader's information `Inserted device layer "NAME" (path)`.
const INSERTED_DEVICE_LAYER: &str = "Inserted device layer \"";

unsafe extern "system" fn collect(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the user data is the Collector registered with the messenger,
    // which outlives it (see `Vulkan::drop`).
    let collector = unsafe { &*user_data.cast::<Collector>() };
    // SAFETY: the loader passes callback data valid for the call.
    let data = unsafe { &*data };
    let text = |p: *const std::ffi::c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: non-NULL strings in the callback data are NUL-terminated.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    use vk::DebugUtilsMessageSeverityFlagsEXT as S;
    let severity = match severity {
        S::ERROR => "error",
        S::WARNING => "warning",
        S::INFO => "info",
        _ => "verbose",
    };
    if !types.contains(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION) {
        // The loader's own (general) messages are no layer's findings; only
        // which layers it inserted is kept, in the order it says so.
        let text = text(data.p_message);
        if let Some(name) = text
            .trim()
            .strip_prefix(INSERTED_DEVICE_LAYER)
            .and_then(|rest| rest.split('"').next())
        {
            collector.device_layers.lock().unwrap().push(name.into());
        }
        return vk::FALSE;
    }
    let phase = *collector.phase.lock().unwrap();
    collector.messages.lock().unwrap().push(json!({
        "id": text(data.p_message_id_name),
        "severity": severity,
        "phase": phase,
        "text": text(data.p_message),
    }));
    // Never ask a layer to skip the call: the app goes on as it would
    // without validation.
    vk::FALSE
}

/// An instance with the named layers and a messenger for every severity.
struct Vulkan {
    base: Instance,
    collector: Box<Collector>,
}

impl std::ops::Deref for Vulkan {
    type Target = Instance;

    fn deref(&self) -> &Instance {
        &self.base
    }
}

impl Vulkan {
    fn new(layers: &[CString]) -> Result<Self, String> {
        let collector = Box::<Collector>::default();
        *collector.phase.lock().unwrap() = "setup";
        // The boxed collector outlives the messenger (destroyed first in
        // `drop`).
        let base = Instance::new(
            c"omm-app",
            layers,
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
            Some(collect),
            (&*collector as *const Collector).cast_mut().cast(),
        )?;
        Ok(Self { base, collector })
    }

    fn phase(&self, phase: &'static str) {
        *self.collector.phase.lock().unwrap() = phase;
    }

    fn messages(&self) -> Vec<Value> {
        self.collector.messages.lock().unwrap().clone()
    }

    /// The first physical device with the device extension `extension`.
    fn physical_device_with(&self, extension: &CStr) -> Result<vk::PhysicalDevice, String> {
        // SAFETY: a live instance.
        let devices = unsafe { self.instance.enumerate_physical_devices() }
            .map_err(|e| format!("vkEnumeratePhysicalDevices: {e}"))?;
        devices
            .into_iter()
            .find(|&device| self.has_device_extension(device, extension))
            .ok_or_else(|| format!("no physical device with {extension:?}"))
    }

    /// Whether `physical` offers the device extension `extension`.
    fn has_device_extension(&self, physical: vk::PhysicalDevice, extension: &CStr) -> bool {
        // SAFETY: a physical device of this instance.
        unsafe {
            self.instance
                .enumerate_device_extension_properties(physical)
        }
        .is_ok_and(|all| {
            all.iter()
                .any(|e| e.extension_name_as_c_str() == Ok(extension))
        })
    }

    /// The first physical device.
    fn physical_device(&self) -> Result<vk::PhysicalDevice, String> {
        // SAFETY: a live instance.
        let devices = unsafe { self.instance.enumerate_physical_devices() }
            .map_err(|e| format!("vkEnumeratePhysicalDevices: {e}"))?;
        devices
            .first()
            .copied()
            .ok_or_else(|| "no physical device".into())
    }
}

impl Drop for Vulkan {
    fn drop(&mut self) {
        // Each scenario destroys its device.
        self.base.destroy();
    }
}

/// A device with one queue of family 0 and a command pool.
struct Gpu<'a> {
    vulkan: &'a Vulkan,
    core: Device,
    pool: vk::CommandPool,
}

impl std::ops::Deref for Gpu<'_> {
    type Target = Device;

    fn deref(&self) -> &Device {
        &self.core
    }
}

impl<'a> Gpu<'a> {
    /// The device of `physical` with `extensions`, the feature
    /// `bufferDeviceAddress` and the features in `features`.
    fn new<F: vk::ExtendsDeviceCreateInfo + ?Sized>(
        vulkan: &'a Vulkan,
        physical: vk::PhysicalDevice,
        extensions: &[&CStr],
        features: &mut F,
    ) -> Result<Self, String> {
        let core = Device::new(&vulkan.instance, physical, extensions, features)?;
        let pool_info = vk::CommandPoolCreateInfo::default().queue_family_index(0);
        // SAFETY: valid arguments.
        let pool = unsafe { core.device.create_command_pool(&pool_info, None) }
            .map_err(|e| format!("vkCreateCommandPool: {e}"))?;
        Ok(Self { vulkan, core, pool })
    }

    /// A buffer of `size` bytes bound to host-visible memory of its own,
    /// mapped; returns the buffer and the mapping.
    fn mapped_buffer(
        &self,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<(vk::Buffer, *mut u8), String> {
        let (buffer, _, map) = self.core.mapped(size, usage)?;
        Ok((buffer, map))
    }

    /// A primary command buffer from the pool, begun.
    fn begin(&self) -> Result<vk::CommandBuffer, String> {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid arguments.
        let command_buffer = unsafe { self.device.allocate_command_buffers(&info) }
            .map_err(|e| format!("vkAllocateCommandBuffers: {e}"))?[0];
        // SAFETY: a fresh command buffer.
        unsafe {
            self.device
                .begin_command_buffer(command_buffer, &vk::CommandBufferBeginInfo::default())
        }
        .map_err(|e| format!("vkBeginCommandBuffer: {e}"))?;
        Ok(command_buffer)
    }

    /// Submits `command_buffer` (ended) and waits for the queue; returns
    /// what vkQueueSubmit returned.
    fn submit(&self, command_buffer: vk::CommandBuffer) -> Result<i32, String> {
        let command_buffers = [command_buffer];
        let submit = [vk::SubmitInfo::default().command_buffers(&command_buffers)];
        // SAFETY: an executable command buffer of this device's queue family.
        let result = unsafe {
            self.device
                .queue_submit(self.queue, &submit, vk::Fence::null())
        };
        // SAFETY: the queue is this device's.
        unsafe { self.device.queue_wait_idle(self.queue) }
            .map_err(|e| format!("vkQueueWaitIdle: {e}"))?;
        Ok(result.err().unwrap_or(vk::Result::SUCCESS).as_raw())
    }

    /// A micromap of 4096 bytes, plenty for the two triangles built here
    /// (the Mock ICD's vkGetMicromapBuildSizesEXT writes nothing).
    fn micromap(
        &self,
        omm: &ash::ext::opacity_micromap::Device,
    ) -> Result<vk::MicromapEXT, String> {
        let (storage, _) = self.mapped_buffer(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT)?;
        self.core.micromap(omm, storage, 4096)
    }
}

impl Drop for Gpu<'_> {
    fn drop(&mut self) {
        self.vulkan.phase("teardown");
        // SAFETY: the queue is idle after each submit; the device's other
        // children are released with it (the Khronos layer may say so).
        unsafe {
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
        }
    }
}

/// The Mock ICD's device with VK_EXT_opacity_micromap and the features
/// `micromap`, `micromapHostCommands` and `bufferDeviceAddress`. The Mock
/// ICD reports these features as false and does not check them; the layer
/// checks against what the application enabled.
fn micromap_device(vulkan: &Vulkan) -> Result<Gpu<'_>, String> {
    let physical = vulkan.physical_device()?;
    let mut micromap = vk::PhysicalDeviceOpacityMicromapFeaturesEXT::default()
        .micromap(true)
        .micromap_host_commands(true);
    Gpu::new(
        vulkan,
        physical,
        &[
            ash::ext::opacity_micromap::NAME,
            ash::khr::acceleration_structure::NAME,
            ash::khr::deferred_host_operations::NAME,
        ],
        &mut micromap,
    )
}

/// The triangle array of the two triangles, their data at `offsets`.
fn triangles(offsets: [u32; 2], format: u16) -> [vk::MicromapTriangleEXT; 2] {
    offsets.map(|data_offset| vk::MicromapTriangleEXT {
        data_offset,
        subdivision_level: 1,
        format,
    })
}

/// `vkBuildMicromapsEXT` (host build) of two triangles: the triangle array
/// and scratch in the app's own memory, the data in the last two bytes of
/// a 64-byte mapped host-visible allocation, so the layer knows where the
/// data ends. Faults: `usage-pointers` sets both pUsageCounts and
/// ppUsageCounts; `data-past-end` puts triangle 1's data one byte past the
/// mapping.
fn host_build(vulkan: &Vulkan, fault: &str, results: &mut Results) -> Result<(), String> {
    let gpu = micromap_device(vulkan)?;
    let omm = ash::ext::opacity_micromap::Device::new(&vulkan.instance, &gpu.device);
    let micromap = gpu.micromap(&omm)?;
    let memory = gpu.allocate(64, !0, vk::MemoryPropertyFlags::HOST_VISIBLE, false)?;
    let mapped = gpu.map(memory)?;
    // SAFETY: the mapping is 64 bytes long.
    let data = unsafe { mapped.add(62) };
    // SAFETY: bytes 62 and 63 of the mapping.
    unsafe { data.copy_from_nonoverlapping([0x1u8, 0x2].as_ptr(), 2) };
    let second = if fault == "data-past-end" { 2 } else { 1 };
    let triangles = triangles([0, second], 1);
    let mut scratch = vec![0u8; 4096];
    let usage_pointers = [&USAGE[0] as *const vk::MicromapUsageEXT];
    let mut info = build_info(
        micromap,
        vk::DeviceOrHostAddressConstKHR {
            host_address: triangles.as_ptr().cast(),
        },
        vk::DeviceOrHostAddressConstKHR {
            host_address: data.cast_const().cast(),
        },
        vk::DeviceOrHostAddressKHR {
            host_address: scratch.as_mut_ptr().cast(),
        },
    );
    match fault {
        "valid" | "data-past-end" => {}
        "usage-pointers" => info.pp_usage_counts = usage_pointers.as_ptr(),
        _ => return Err(format!("unknown host-build scenario {fault:?}")),
    }
    vulkan.phase("build");
    // SAFETY: one valid info whose host addresses live across the call (the
    // faults are in values, never in dangling pointers, except data-past-end,
    // whose out-of-range byte the Mock ICD never reads).
    let result = unsafe {
        (omm.fp().build_micromaps_ext)(
            gpu.device.handle(),
            vk::DeferredOperationKHR::null(),
            1,
            &info,
        )
    };
    results.insert("build".into(), json!(result.as_raw()));
    Ok(())
}

/// Stand-in device addresses for the Mock ICD, whose
/// vkGetBufferDeviceAddress returns 0 for every buffer: the mock runs no
/// command, and an address of 0 would be a fault of its own.
const STAND_IN_INPUT: u64 = 0x1_0000_0000;
const STAND_IN_SCRATCH: u64 = 0x2_0000_0000;

/// `vkCmdBuildMicromapsEXT` of two triangles, recorded in a command buffer
/// from a pool, ended and submitted twice. The triangle array lies at the
/// start of a mapped host-visible input buffer, the data 256 bytes in.
/// Faults: `usage-pointers` (a parameter, decided at recording);
/// `histogram-mismatch` (the triangle array says 4-state where the usage
/// counts say 2-state: contents, decided at submission when the layer can
/// read them).
fn device_build(vulkan: &Vulkan, fault: &str, results: &mut Results) -> Result<(), String> {
    let gpu = micromap_device(vulkan)?;
    let omm = ash::ext::opacity_micromap::Device::new(&vulkan.instance, &gpu.device);
    let micromap = gpu.micromap(&omm)?;
    let address_usage = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let (input, mapped) = gpu.mapped_buffer(
        4096,
        vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT | address_usage,
    )?;
    let (scratch, _) =
        gpu.mapped_buffer(4096, vk::BufferUsageFlags::STORAGE_BUFFER | address_usage)?;
    let addresses = [gpu.address(input), gpu.address(scratch)];
    results.insert("buffer_addresses".into(), json!(addresses));
    let (input_address, scratch_address) = match addresses {
        [0, 0] => (STAND_IN_INPUT, STAND_IN_SCRATCH),
        [input, scratch] => (input, scratch),
    };
    let format = if fault == "histogram-mismatch" { 2 } else { 1 };
    let triangles = triangles([0, 1], format);
    // SAFETY: the mapping is 4096 bytes long: 16 bytes of triangles at 0,
    // two bytes of data at 256.
    unsafe {
        mapped.copy_from_nonoverlapping(triangles.as_ptr().cast(), 16);
        mapped
            .add(256)
            .copy_from_nonoverlapping([0x1u8, 0x2].as_ptr(), 2);
    }
    let usage_pointers = [&USAGE[0] as *const vk::MicromapUsageEXT];
    let mut info = build_info(
        micromap,
        vk::DeviceOrHostAddressConstKHR {
            device_address: input_address,
        },
        vk::DeviceOrHostAddressConstKHR {
            device_address: input_address + 256,
        },
        vk::DeviceOrHostAddressKHR {
            device_address: scratch_address,
        },
    );
    match fault {
        "valid" | "histogram-mismatch" => {}
        "usage-pointers" => info.pp_usage_counts = usage_pointers.as_ptr(),
        _ => return Err(format!("unknown device-build scenario {fault:?}")),
    }
    let command_buffer = gpu.begin()?;
    vulkan.phase("record");
    // SAFETY: a recording command buffer; one valid info.
    unsafe { (omm.fp().cmd_build_micromaps_ext)(command_buffer, 1, &info) };
    // SAFETY: the command buffer is recording.
    unsafe { gpu.device.end_command_buffer(command_buffer) }
        .map_err(|e| format!("vkEndCommandBuffer: {e}"))?;
    vulkan.phase("submit");
    let submits = [gpu.submit(command_buffer)?, gpu.submit(command_buffer)?];
    results.insert("submits".into(), json!(submits));
    Ok(())
}

/// Whether `vkGetDeviceProcAddr` returns NULL for `name`.
fn device_command_is_null(gpu: &Gpu<'_>, name: &CStr) -> bool {
    // SAFETY: a live device and a NUL-terminated name.
    unsafe {
        gpu.vulkan
            .instance
            .get_device_proc_addr(gpu.device.handle(), name.as_ptr())
    }
    .is_none()
}

/// Buffers a scenario creates, each bound to memory of its own, and
/// destroys with [`Buffers::destroy`] when its work is done, so that a
/// stacked Khronos layer has no leaked object of the app's to report.
#[derive(Default)]
struct Buffers(Vec<(vk::Buffer, vk::DeviceMemory)>);

impl Buffers {
    /// A buffer in host-visible memory, mapped: the buffer and the mapping.
    fn mapped(
        &mut self,
        gpu: &Gpu<'_>,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<(vk::Buffer, *mut u8), String> {
        let buffer = self.unmapped(gpu, size, usage, HOST_MAPPABLE)?;
        let memory = self.0.last().expect("the buffer just made").1;
        Ok((buffer, gpu.map(memory)?))
    }

    /// A buffer in memory of the first type with `flags`, never mapped.
    fn unmapped(
        &mut self,
        gpu: &Gpu<'_>,
        size: u64,
        usage: vk::BufferUsageFlags,
        flags: vk::MemoryPropertyFlags,
    ) -> Result<vk::Buffer, String> {
        let (buffer, memory) = gpu.bound_buffer(size, usage, flags)?;
        self.0.push((buffer, memory));
        Ok(buffer)
    }

    /// Destroys every buffer and frees its memory.
    fn destroy(self, gpu: &Gpu<'_>) {
        for (buffer, memory) in self.0 {
            // SAFETY: the queue is idle and nothing alive uses the buffer.
            unsafe {
                gpu.device.destroy_buffer(buffer, None);
                gpu.device.free_memory(memory, None);
            }
        }
    }
}

/// A device of `physical` with VK_KHR_acceleration_structure and its
/// feature `accelerationStructure`, and with VK_KHR_ray_query and its
/// feature `rayQuery` where offered (lavapipe), else VK_KHR_ray_tracing_pipeline
/// and `rayTracingPipeline` where offered. Neither is used: the Khronos
/// layer (1.3.239) requires one of them for
/// vkGetAccelerationStructureBuildSizesKHR (its 03617, since dropped from
/// the specification), and stacked under ommcheck it must report nothing
/// of the app's.
fn structure_device(vulkan: &Vulkan, physical: vk::PhysicalDevice) -> Result<Gpu<'_>, String> {
    let mut structure_features =
        vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
    let mut ray_query = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
    let mut pipeline =
        vk::PhysicalDeviceRayTracingPipelineFeaturesKHR::default().ray_tracing_pipeline(true);
    let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut structure_features);
    let mut extensions = vec![
        ash::khr::acceleration_structure::NAME,
        ash::khr::deferred_host_operations::NAME,
    ];
    if vulkan.has_device_extension(physical, ash::khr::ray_query::NAME) {
        extensions.push(ash::khr::ray_query::NAME);
        features = features.push_next(&mut ray_query);
    } else if vulkan.has_device_extension(physical, ash::khr::ray_tracing_pipeline::NAME) {
        extensions.push(ash::khr::ray_tracing_pipeline::NAME);
        features = features.push_next(&mut pipeline);
    }
    Gpu::new(vulkan, physical, &extensions, &mut features)
}

/// A scratch buffer of `size` bytes and its device address aligned to
/// `alignment`.
fn scratch(gpu: &Gpu<'_>, buffers: &mut Buffers, size: u64, alignment: u64) -> Result<u64, String> {
    let (scratch, _) = buffers.mapped(
        gpu,
        size + alignment,
        vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
    )?;
    Ok(gpu.address(scratch).next_multiple_of(alignment))
}

/// A structure of `ty` and `size` bytes on a storage buffer of its own.
fn create_structure(
    gpu: &Gpu<'_>,
    accel: &ash::khr::acceleration_structure::Device,
    buffers: &mut Buffers,
    ty: vk::AccelerationStructureTypeKHR,
    size: u64,
) -> Result<vk::AccelerationStructureKHR, String> {
    let (storage, _) = buffers.mapped(
        gpu,
        size,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
    )?;
    let create = vk::AccelerationStructureCreateInfoKHR::default()
        .buffer(storage)
        .size(size)
        .ty(ty);
    // SAFETY: a storage buffer of the size the driver asked for.
    unsafe { accel.create_acceleration_structure(&create, None) }
        .map_err(|e| format!("vkCreateAccelerationStructureKHR: {e}"))
}

/// A bottom-level structure of three separate triangles in the z = 0
/// plane, indexed 0..9, whose vertices, indices, storage and scratch lie
/// in mapped memory; created with the size the driver asks for, built
/// with ALLOW_COMPACTION by [`TriangleBlas::record_build`].
struct TriangleBlas {
    structure: vk::AccelerationStructureKHR,
    geometries: [vk::AccelerationStructureGeometryKHR<'static>; 1],
    /// The structure's size and its build scratch size.
    sizes: [u64; 2],
    scratch_address: u64,
}

impl TriangleBlas {
    const TRIANGLES: u32 = 3;

    fn new(
        gpu: &Gpu<'_>,
        accel: &ash::khr::acceleration_structure::Device,
        buffers: &mut Buffers,
        scratch_alignment: u64,
    ) -> Result<Self, String> {
        let input_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
        let vertices: Vec<f32> = (0..Self::TRIANGLES)
            .flat_map(|t| {
                let x = t as f32 * 2.0;
                [x, 0.0, 0.0, x + 1.0, 0.0, 0.0, x, 1.0, 0.0]
            })
            .collect();
        let indices: Vec<u32> = (0..3 * Self::TRIANGLES).collect();
        let (vertex_buffer, vertex_map) =
            buffers.mapped(gpu, 4 * vertices.len() as u64, input_usage)?;
        let (index_buffer, index_map) =
            buffers.mapped(gpu, 4 * indices.len() as u64, input_usage)?;
        // SAFETY: each mapping holds its buffer's size: exactly these bytes.
        unsafe {
            vertex_map.copy_from_nonoverlapping(vertices.as_ptr().cast(), 4 * vertices.len());
            index_map.copy_from_nonoverlapping(indices.as_ptr().cast(), 4 * indices.len());
        }
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR {
                device_address: gpu.address(vertex_buffer),
            })
            .vertex_stride(12)
            .max_vertex(3 * Self::TRIANGLES - 1)
            .index_type(vk::IndexType::UINT32)
            .index_data(vk::DeviceOrHostAddressConstKHR {
                device_address: gpu.address(index_buffer),
            });
        let geometries = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
            .flags(vk::GeometryFlagsKHR::OPAQUE)];
        let mut blas = Self {
            structure: vk::AccelerationStructureKHR::null(),
            geometries,
            sizes: [0; 2],
            scratch_address: 0,
        };
        blas.sizes = build_sizes(accel, &blas.build_info(), Self::TRIANGLES);
        blas.structure = create_structure(
            gpu,
            accel,
            buffers,
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            blas.sizes[0],
        )?;
        blas.scratch_address = scratch(gpu, buffers, blas.sizes[1], scratch_alignment)?;
        Ok(blas)
    }

    fn build_info(&self) -> vk::AccelerationStructureBuildGeometryInfoKHR<'_> {
        vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
            .flags(vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&self.geometries)
            .dst_acceleration_structure(self.structure)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: self.scratch_address,
            })
    }

    /// Records the build into `command_buffer`.
    fn record_build(
        &self,
        accel: &ash::khr::acceleration_structure::Device,
        command_buffer: vk::CommandBuffer,
    ) {
        let ranges =
            [vk::AccelerationStructureBuildRangeInfoKHR::default()
                .primitive_count(Self::TRIANGLES)];
        // SAFETY: a recording command buffer; the build's buffers and
        // structure are alive and sized as the driver asked.
        unsafe {
            accel.cmd_build_acceleration_structures(
                command_buffer,
                &[self.build_info()],
                &[&ranges],
            )
        };
    }
}

/// A query pool of one query of `ty`.
fn query_pool(gpu: &Gpu<'_>, ty: vk::QueryType) -> Result<vk::QueryPool, String> {
    let info = vk::QueryPoolCreateInfo::default()
        .query_type(ty)
        .query_count(1);
    // SAFETY: valid arguments.
    unsafe { gpu.device.create_query_pool(&info, None) }
        .map_err(|e| format!("vkCreateQueryPool: {e}"))
}

/// The one 64-bit result of `pool`, waiting for it.
fn query_result(gpu: &Gpu<'_>, pool: vk::QueryPool) -> Result<u64, String> {
    let mut value = [0u64];
    // SAFETY: one 64-bit result of a query a submission writes.
    unsafe {
        gpu.device.get_query_pool_results(
            pool,
            0,
            &mut value,
            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
        )
    }
    .map_err(|e| format!("vkGetQueryPoolResults: {e}"))?;
    Ok(value[0])
}

/// A barrier on all memory between `src` and `dst` in `command_buffer`.
fn memory_barrier(
    gpu: &Gpu<'_>,
    command_buffer: vk::CommandBuffer,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(src.1)
        .dst_access_mask(dst.1)];
    // SAFETY: a recording command buffer.
    unsafe {
        gpu.device.cmd_pipeline_barrier(
            command_buffer,
            src.0,
            dst.0,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

/// A structure's build writes, as a barrier's source or destination.
const STRUCTURE_WRITE: (vk::PipelineStageFlags, vk::AccessFlags) = (
    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
    vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
);
/// Reads of a built structure by a later build or property query.
const STRUCTURE_READ: (vk::PipelineStageFlags, vk::AccessFlags) = (
    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
    vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR,
);

/// A bottom-level acceleration structure of three triangles built on the
/// device (lavapipe), then its compacted and serialization sizes read
/// through query pools. Results: those sizes, the build sizes, and whether
/// the micromap commands resolve (they must not: lavapipe lacks
/// VK_EXT_opacity_micromap).
fn blas(vulkan: &Vulkan, results: &mut Results) -> Result<(), String> {
    let physical = vulkan.physical_device()?;
    let has_micromaps = vulkan.has_device_extension(physical, ash::ext::opacity_micromap::NAME);
    results.insert("has_opacity_micromap".into(), json!(has_micromaps));
    let scratch_alignment = vulkan.scratch_alignment(physical);
    let gpu = structure_device(vulkan, physical)?;
    results.insert(
        "null_micromap_commands".into(),
        json!([
            device_command_is_null(&gpu, c"vkCmdBuildMicromapsEXT"),
            device_command_is_null(&gpu, c"vkBuildMicromapsEXT"),
            device_command_is_null(&gpu, c"vkCreateMicromapEXT"),
        ]),
    );
    let accel = ash::khr::acceleration_structure::Device::new(&vulkan.instance, &gpu.device);
    let mut buffers = Buffers::default();
    let blas = TriangleBlas::new(&gpu, &accel, &mut buffers, scratch_alignment)?;
    results.insert("build_sizes".into(), json!(blas.sizes));

    let query_types = [
        vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
        vk::QueryType::ACCELERATION_STRUCTURE_SERIALIZATION_SIZE_KHR,
    ];
    let pools = query_types
        .iter()
        .map(|&ty| query_pool(&gpu, ty))
        .collect::<Result<Vec<_>, _>>()?;

    let command_buffer = gpu.begin()?;
    vulkan.phase("record");
    for &pool in &pools {
        // SAFETY: a recording command buffer; a pool of one query.
        unsafe { gpu.device.cmd_reset_query_pool(command_buffer, pool, 0, 1) };
    }
    blas.record_build(&accel, command_buffer);
    memory_barrier(&gpu, command_buffer, STRUCTURE_WRITE, STRUCTURE_READ);
    for (&pool, ty) in pools.iter().zip(query_types) {
        // SAFETY: a recording command buffer; the structure is built above.
        unsafe {
            accel.cmd_write_acceleration_structures_properties(
                command_buffer,
                &[blas.structure],
                ty,
                pool,
                0,
            )
        };
    }
    // SAFETY: the command buffer is recording.
    unsafe { gpu.device.end_command_buffer(command_buffer) }
        .map_err(|e| format!("vkEndCommandBuffer: {e}"))?;
    vulkan.phase("submit");
    results.insert("submit".into(), json!(gpu.submit(command_buffer)?));
    results.insert(
        "compacted_size".into(),
        json!(query_result(&gpu, pools[0])?),
    );
    results.insert(
        "serialization_size".into(),
        json!(query_result(&gpu, pools[1])?),
    );
    // SAFETY: the queue is idle; the structure and pools are unused now.
    unsafe {
        accel.destroy_acceleration_structure(blas.structure, None);
        for pool in pools {
            gpu.device.destroy_query_pool(pool, None);
        }
    }
    buffers.destroy(&gpu);
    Ok(())
}

/// How `tlas` puts the one instance where the top-level build reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum InstanceWay {
    /// vkCmdCopyBuffer from a mapped staging buffer to an unmapped one.
    Copy,
    /// vkCmdUpdateBuffer of the whole instance into an unmapped buffer.
    Update,
    /// vkCmdUpdateBuffer of the instance without its flags, then
    /// vkCmdFillBuffer of the word that holds them.
    Fill,
    /// The `copy_words` compute shader, from a mapped storage buffer to an
    /// unmapped one.
    Compute,
    /// Written by the host into a buffer the app keeps mapped.
    Mapped,
}

impl InstanceWay {
    const NAMES: [(&'static str, Self); 5] = [
        ("copy", Self::Copy),
        ("update", Self::Update),
        ("fill", Self::Fill),
        ("compute", Self::Compute),
        ("mapped", Self::Mapped),
    ];

    fn parse(name: &str) -> Result<Self, String> {
        Self::NAMES
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, way)| way)
            .ok_or_else(|| format!("--way {name:?}: one of copy, update, fill, compute, mapped"))
    }
}

/// The `tlas` scenario's arguments.
struct TlasOptions {
    way: Option<InstanceWay>,
    /// The instance's flags are 0 instead of FORCE_OPACITY_MICROMAP_2_STATE.
    valid: bool,
    /// Two fills of one buffer with no barrier between: a write-after-write
    /// hazard, which the Khronos layer's synchronization validation reports
    /// and ommcheck does not, to show the former is on.
    sync_fault: bool,
}

/// The bytes of a VkAccelerationStructureInstanceKHR.
const INSTANCE_SIZE: u64 = std::mem::size_of::<vk::AccelerationStructureInstanceKHR>() as u64;
/// The offset of the 32-bit word whose high byte holds an instance's flags.
const INSTANCE_FLAGS_OFFSET: u64 = std::mem::offset_of!(
    vk::AccelerationStructureInstanceKHR,
    instance_shader_binding_table_record_offset_and_flags
) as u64;

/// A compute pipeline of `copy_words` (tests/shaders.rs) and one
/// descriptor set per pair of storage buffers it copies between: the
/// source at binding 0, the destination at binding 1.
struct CopyWords {
    module: vk::ShaderModule,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    pool: vk::DescriptorPool,
    sets: Vec<vk::DescriptorSet>,
}

impl CopyWords {
    /// Invocations of one workgroup (the shader's LocalSize).
    const WORDS: u64 = 16;

    fn new(gpu: &Gpu<'_>, pairs: &[(vk::Buffer, vk::Buffer)]) -> Result<Self, String> {
        let device = &gpu.device;
        let code = ommcheck_tests::shaders::COPY_WORDS;
        let module_info = vk::ShaderModuleCreateInfo::default().code(&code);
        // SAFETY: valid SPIR-V (spirv-val) for Vulkan 1.1.
        let module = unsafe { device.create_shader_module(&module_info, None) }
            .map_err(|e| format!("vkCreateShaderModule: {e}"))?;
        let bindings = [0, 1].map(|binding| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(binding)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        });
        let set_layout_info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid arguments.
        let set_layout = unsafe { device.create_descriptor_set_layout(&set_layout_info, None) }
            .map_err(|e| format!("vkCreateDescriptorSetLayout: {e}"))?;
        let set_layouts = [set_layout];
        let layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid arguments.
        let layout = unsafe { device.create_pipeline_layout(&layout_info, None) }
            .map_err(|e| format!("vkCreatePipelineLayout: {e}"))?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let pipeline_info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        // SAFETY: valid arguments; the layout matches the shader's bindings.
        let pipeline = unsafe {
            device.create_compute_pipelines(vk::PipelineCache::null(), &pipeline_info, None)
        }
        .map_err(|(_, e)| format!("vkCreateComputePipelines: {e}"))?[0];
        let count = pairs.len() as u32;
        let sizes = [vk::DescriptorPoolSize::default()
            .ty(vk::DescriptorType::STORAGE_BUFFER)
            .descriptor_count(2 * count)];
        let pool_info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(count)
            .pool_sizes(&sizes);
        // SAFETY: valid arguments.
        let pool = unsafe { device.create_descriptor_pool(&pool_info, None) }
            .map_err(|e| format!("vkCreateDescriptorPool: {e}"))?;
        let layouts = vec![set_layout; pairs.len()];
        let allocate = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: a pool with room for these sets.
        let sets = unsafe { device.allocate_descriptor_sets(&allocate) }
            .map_err(|e| format!("vkAllocateDescriptorSets: {e}"))?;
        for (&set, &(source, destination)) in sets.iter().zip(pairs) {
            let infos = [source, destination].map(|buffer| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(buffer)
                    .range(4 * Self::WORDS)]
            });
            let writes = [0, 1].map(|binding| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(&infos[binding as usize])
            });
            // SAFETY: both buffers have STORAGE_BUFFER usage and 64 bytes.
            unsafe { device.update_descriptor_sets(&writes, &[]) };
        }
        Ok(Self {
            module,
            set_layout,
            layout,
            pipeline,
            pool,
            sets,
        })
    }

    /// Records the dispatch of one workgroup copying between the pair
    /// `pair` of those given to [`CopyWords::new`] into `command_buffer`.
    fn record(&self, gpu: &Gpu<'_>, command_buffer: vk::CommandBuffer, pair: usize) {
        // SAFETY: a recording command buffer; the pipeline and set are live.
        unsafe {
            gpu.device.cmd_bind_pipeline(
                command_buffer,
                vk::PipelineBindPoint::COMPUTE,
                self.pipeline,
            );
            gpu.device.cmd_bind_descriptor_sets(
                command_buffer,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[self.sets[pair]],
                &[],
            );
            gpu.device.cmd_dispatch(command_buffer, 1, 1, 1);
        }
    }

    fn destroy(self, gpu: &Gpu<'_>) {
        // SAFETY: the queue is idle; nothing uses these objects any more.
        unsafe {
            gpu.device.destroy_pipeline(self.pipeline, None);
            gpu.device.destroy_pipeline_layout(self.layout, None);
            gpu.device.destroy_descriptor_pool(self.pool, None);
            gpu.device
                .destroy_descriptor_set_layout(self.set_layout, None);
            gpu.device.destroy_shader_module(self.module, None);
        }
    }
}

/// Writes into the instance buffer by transfers, compute and host, as a
/// barrier's source.
const INSTANCE_WRITES: (vk::PipelineStageFlags, vk::AccessFlags) = (
    vk::PipelineStageFlags::from_raw(
        vk::PipelineStageFlags::TRANSFER.as_raw()
            | vk::PipelineStageFlags::COMPUTE_SHADER.as_raw()
            | vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR.as_raw(),
    ),
    vk::AccessFlags::from_raw(
        vk::AccessFlags::TRANSFER_WRITE.as_raw()
            | vk::AccessFlags::SHADER_WRITE.as_raw()
            | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR.as_raw(),
    ),
);
/// What reads the instances and the bottom-level structure after they are
/// written: the top-level build (its inputs are shader reads, the
/// structure it references a structure read) and the shader copying the
/// instance back.
const INSTANCE_READS: (vk::PipelineStageFlags, vk::AccessFlags) = (
    vk::PipelineStageFlags::from_raw(
        vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR.as_raw()
            | vk::PipelineStageFlags::COMPUTE_SHADER.as_raw(),
    ),
    vk::AccessFlags::from_raw(
        vk::AccessFlags::SHADER_READ.as_raw()
            | vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR.as_raw(),
    ),
);
const TRANSFER_WRITE: (vk::PipelineStageFlags, vk::AccessFlags) = (
    vk::PipelineStageFlags::TRANSFER,
    vk::AccessFlags::TRANSFER_WRITE,
);

/// `tlas`: a bottom-level structure of three triangles ([`TriangleBlas`]),
/// then a top-level structure of one instance of it, built in the same
/// command buffer on the first physical device with
/// VK_KHR_acceleration_structure. The instance's flags hold
/// FORCE_OPACITY_MICROMAP_2_STATE (VUID-VkAccelerationStructureInstanceKHR-
/// micromap-11580: no micromap feature is enabled, nor could be on a
/// device without VK_EXT_opacity_micromap), or 0 with `--valid`. `--way`
/// chooses how the instance reaches the buffer the build reads
/// ([`InstanceWay`]); except for `mapped`, that buffer's memory is
/// DEVICE_LOCAL and never mapped, and it never has TRANSFER_SRC usage.
/// After the build, in the same command buffer, `copy_words` copies the
/// instance into a mapped buffer. One submission with a fence, then
/// vkWaitForFences (phases `record`, `submit`, `wait`). Results: the
/// device, whether the instance memory is host-visible, the build sizes,
/// the submission's and the wait's results, the instance copied back, and
/// the top-level structure's compacted size.
fn tlas(vulkan: &Vulkan, options: &TlasOptions, results: &mut Results) -> Result<(), String> {
    let way = options
        .way
        .ok_or("tlas needs --way copy|update|fill|compute|mapped")?;
    let physical = vulkan.physical_device_with(ash::khr::acceleration_structure::NAME)?;
    // SAFETY: a physical device of this instance.
    let properties = unsafe { vulkan.instance.get_physical_device_properties(physical) };
    let name = properties
        .device_name_as_c_str()
        .map_or_else(|_| "?".into(), |n| n.to_string_lossy().into_owned());
    results.insert("device".into(), json!(name));
    let scratch_alignment = vulkan.scratch_alignment(physical);
    let gpu = structure_device(vulkan, physical)?;
    let accel = ash::khr::acceleration_structure::Device::new(&vulkan.instance, &gpu.device);
    let mut buffers = Buffers::default();
    let blas = TriangleBlas::new(&gpu, &accel, &mut buffers, scratch_alignment)?;
    let address_info = vk::AccelerationStructureDeviceAddressInfoKHR::default()
        .acceleration_structure(blas.structure);
    // SAFETY: a structure of this device.
    let blas_address = unsafe { accel.get_acceleration_structure_device_address(&address_info) };

    let flags = if options.valid {
        vk::GeometryInstanceFlagsKHR::empty()
    } else {
        vk::GeometryInstanceFlagsKHR::FORCE_OPACITY_MICROMAP_2_STATE_EXT
    };
    let instance = instance_words(blas_address, flags);
    let without_flags = instance_words(blas_address, vk::GeometryInstanceFlagsKHR::empty());
    // No TRANSFER_SRC, as in most applications: a layer that copies the
    // instances must add that usage itself.
    let instance_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
        | vk::BufferUsageFlags::TRANSFER_DST
        | vk::BufferUsageFlags::STORAGE_BUFFER;
    let write = |map: *mut u8, words: &[u32; 16]| {
        // SAFETY: every mapping here is at least INSTANCE_SIZE (64) bytes.
        unsafe { map.copy_from_nonoverlapping(word_bytes(words).as_ptr(), words.len() * 4) }
    };
    // The buffer the build reads.
    let memory_flags = if way == InstanceWay::Mapped {
        HOST_MAPPABLE
    } else {
        vk::MemoryPropertyFlags::DEVICE_LOCAL
    };
    let instances = buffers.unmapped(&gpu, INSTANCE_SIZE, instance_usage, memory_flags)?;
    // SAFETY: a buffer of this device.
    let requirements = unsafe { gpu.device.get_buffer_memory_requirements(instances) };
    let memory_type = gpu.memory_type(requirements.memory_type_bits, memory_flags)?;
    let host_visible = gpu.memory.memory_types[memory_type as usize]
        .property_flags
        .contains(vk::MemoryPropertyFlags::HOST_VISIBLE);
    results.insert("instance_memory_host_visible".into(), json!(host_visible));
    if way == InstanceWay::Mapped {
        let memory = buffers.0.last().expect("the instance buffer").1;
        write(gpu.map(memory)?, &instance);
    }
    // For the copy and the shader, a mapped buffer holding the instance.
    let source = match way {
        InstanceWay::Copy | InstanceWay::Compute => {
            let usage = vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::STORAGE_BUFFER;
            let (source, map) = buffers.mapped(&gpu, INSTANCE_SIZE, usage)?;
            write(map, &instance);
            source
        }
        _ => vk::Buffer::null(),
    };
    let (readback, readback_map) =
        buffers.mapped(&gpu, INSTANCE_SIZE, vk::BufferUsageFlags::STORAGE_BUFFER)?;
    // The shader copies the instance back after the build for every way
    // and, for `compute`, writes it before.
    let mut pairs = vec![(instances, readback)];
    if way == InstanceWay::Compute {
        pairs.push((source, instances));
    }
    let copy_words = CopyWords::new(&gpu, &pairs)?;
    let hazard = buffers.unmapped(
        &gpu,
        256,
        vk::BufferUsageFlags::TRANSFER_DST,
        vk::MemoryPropertyFlags::DEVICE_LOCAL,
    )?;

    let instances_data = vk::AccelerationStructureGeometryInstancesDataKHR::default().data(
        vk::DeviceOrHostAddressConstKHR {
            device_address: gpu.address(instances),
        },
    );
    let geometries = [vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::INSTANCES)
        .geometry(vk::AccelerationStructureGeometryDataKHR {
            instances: instances_data,
        })];
    let mut tlas_info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
        .flags(vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(&geometries);
    let tlas_sizes = build_sizes(&accel, &tlas_info, 1);
    results.insert("build_sizes".into(), json!([blas.sizes, tlas_sizes]));
    let tlas = create_structure(
        &gpu,
        &accel,
        &mut buffers,
        vk::AccelerationStructureTypeKHR::TOP_LEVEL,
        tlas_sizes[0],
    )?;
    let tlas_scratch = scratch(&gpu, &mut buffers, tlas_sizes[1], scratch_alignment)?;
    tlas_info =
        tlas_info
            .dst_acceleration_structure(tlas)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: tlas_scratch,
            });
    let compacted = query_pool(
        &gpu,
        vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
    )?;

    let command_buffer = gpu.begin()?;
    vulkan.phase("record");
    let device = &gpu.device;
    // SAFETY (each command below): a recording command buffer; every
    // buffer, structure and pool is alive and large enough for its range.
    unsafe { device.cmd_reset_query_pool(command_buffer, compacted, 0, 1) };
    if options.sync_fault {
        for value in [0, 1] {
            // SAFETY: as above.
            unsafe { device.cmd_fill_buffer(command_buffer, hazard, 0, vk::WHOLE_SIZE, value) };
        }
    }
    match way {
        InstanceWay::Copy => {
            let region = [vk::BufferCopy::default().size(INSTANCE_SIZE)];
            // SAFETY: as above.
            unsafe { device.cmd_copy_buffer(command_buffer, source, instances, &region) };
        }
        InstanceWay::Update => {
            // SAFETY: as above.
            unsafe {
                device.cmd_update_buffer(command_buffer, instances, 0, &word_bytes(&instance))
            };
        }
        InstanceWay::Fill => {
            let flags_word = instance[INSTANCE_FLAGS_OFFSET as usize / 4];
            // SAFETY: as above.
            unsafe {
                device.cmd_update_buffer(command_buffer, instances, 0, &word_bytes(&without_flags))
            };
            memory_barrier(&gpu, command_buffer, TRANSFER_WRITE, TRANSFER_WRITE);
            // SAFETY: as above.
            unsafe {
                device.cmd_fill_buffer(
                    command_buffer,
                    instances,
                    INSTANCE_FLAGS_OFFSET,
                    4,
                    flags_word,
                )
            };
        }
        InstanceWay::Compute => copy_words.record(&gpu, command_buffer, 1),
        InstanceWay::Mapped => {}
    }
    blas.record_build(&accel, command_buffer);
    memory_barrier(&gpu, command_buffer, INSTANCE_WRITES, INSTANCE_READS);
    let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(1)];
    // SAFETY: as above.
    unsafe { accel.cmd_build_acceleration_structures(command_buffer, &[tlas_info], &[&ranges]) };
    memory_barrier(&gpu, command_buffer, STRUCTURE_WRITE, STRUCTURE_READ);
    // SAFETY: as above.
    unsafe {
        accel.cmd_write_acceleration_structures_properties(
            command_buffer,
            &[tlas],
            vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
            compacted,
            0,
        )
    };
    copy_words.record(&gpu, command_buffer, 0);
    memory_barrier(
        &gpu,
        command_buffer,
        (
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::SHADER_WRITE,
        ),
        (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
    );
    // SAFETY: the command buffer is recording.
    unsafe { device.end_command_buffer(command_buffer) }
        .map_err(|e| format!("vkEndCommandBuffer: {e}"))?;

    vulkan.phase("submit");
    // SAFETY: valid arguments.
    let fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
        .map_err(|e| format!("vkCreateFence: {e}"))?;
    let command_buffers = [command_buffer];
    let submit = [vk::SubmitInfo::default().command_buffers(&command_buffers)];
    // SAFETY: an executable command buffer of this device's queue family;
    // an unsignalled fence.
    let submitted = unsafe { device.queue_submit(gpu.queue, &submit, fence) };
    results.insert("submit".into(), json!(vk_result(submitted)));
    vulkan.phase("wait");
    // SAFETY: the fence is this device's.
    let waited = unsafe { device.wait_for_fences(&[fence], true, u64::MAX) };
    results.insert("wait".into(), json!(vk_result(waited)));
    submitted
        .and(waited)
        .map_err(|e| format!("the submission: {e}"))?;
    let mut read_back = [0u32; 16];
    // SAFETY: the readback mapping is 64 bytes, written by the finished
    // submission and made visible to the host by its last barrier.
    unsafe {
        readback_map.copy_to_nonoverlapping(read_back.as_mut_ptr().cast(), read_back.len() * 4)
    };
    // The words before the structure's device address, which differs from
    // run to run on lavapipe (a host pointer); the whole instance is
    // compared here.
    results.insert("instance_read_back".into(), json!(read_back[..14]));
    results.insert("instance_written".into(), json!(read_back == instance));
    results.insert(
        "compacted_size".into(),
        json!(query_result(&gpu, compacted)?),
    );

    vulkan.phase("teardown");
    // SAFETY: the queue is idle; nothing uses these objects any more.
    unsafe {
        device.destroy_fence(fence, None);
        device.destroy_query_pool(compacted, None);
        accel.destroy_acceleration_structure(tlas, None);
        accel.destroy_acceleration_structure(blas.structure, None);
    }
    copy_words.destroy(&gpu);
    buffers.destroy(&gpu);
    Ok(())
}

/// The raw VkResult of a call that returns nothing else.
fn vk_result(result: Result<(), vk::Result>) -> i32 {
    result.err().unwrap_or(vk::Result::SUCCESS).as_raw()
}

/// Calls timed per command in the `overhead` scenario, after as many as a
/// tenth of them (at least one) untimed to warm up.
fn time_calls(iterations: u32, mut call: impl FnMut()) -> f64 {
    for _ in 0..(iterations / 10).max(1) {
        call();
    }
    let start = std::time::Instant::now();
    for _ in 0..iterations {
        call();
    }
    start.elapsed().as_nanos() as f64 / f64::from(iterations.max(1))
}

/// How large the `overhead` builds are: real builds carry one usage entry
/// per (format, level) in use.
#[derive(Clone, Copy, Debug)]
struct OverheadShape {
    /// Usage entries of each micromap build and of the attachment.
    usage_entries: u32,
    /// Micromap triangles (all 2-state at level 1, as [`USAGE`]'s).
    triangles: u32,
}

impl OverheadShape {
    /// `count` triangles of [`USAGE`]'s format and level over the usage
    /// entries: the same key repeated (the specification allows it), the
    /// count split as evenly as it goes.
    fn usages(&self, count: u32) -> Vec<vk::MicromapUsageEXT> {
        let k = self.usage_entries;
        (0..k)
            .map(|i| vk::MicromapUsageEXT {
                count: count / k + u32::from(i < count % k),
                ..USAGE[0]
            })
            .collect()
    }

    /// The triangle array: [`USAGE`]'s format and level, the data of
    /// triangle m at byte m mod 2 (two data bytes serve them all).
    fn triangle_array(&self) -> Vec<vk::MicromapTriangleEXT> {
        (0..self.triangles)
            .map(|m| vk::MicromapTriangleEXT {
                data_offset: m % 2,
                subdivision_level: 1,
                format: 1,
            })
            .collect()
    }
}

/// Stand-in device addresses of the bottom-level build's inputs over the
/// Mock ICD (see [`STAND_IN_INPUT`]).
const STAND_IN_VERTICES: u64 = 0x3_0000_0000;
const STAND_IN_INDICES: u64 = 0x4_0000_0000;
const STAND_IN_OMM_INDICES: u64 = 0x5_0000_0000;
const STAND_IN_BLAS_SCRATCH: u64 = 0x6_0000_0000;

/// `overhead`: what one call costs the application, with whatever layers
/// are enabled, over the Mock ICD (every command a stub, so the time is the
/// loader's trampoline and the layers'). Set up once: a device with
/// VK_EXT_opacity_micromap and VK_KHR_acceleration_structure and their
/// features, mapped host-visible buffers, a micromap, a bottom-level
/// structure and a command buffer in the recording state. Then `iterations`
/// calls of each, all valid (a messenger receives nothing):
/// - `cmd_build_micromaps`: `vkCmdBuildMicromapsEXT` of the `shape`'s
///   triangles and usage entries (see [`OverheadShape`]), inputs in mapped
///   memory;
/// - `build_micromaps`: `vkBuildMicromapsEXT` (host build) of the same,
///   its data in mapped memory;
/// - `cmd_build_acceleration_structures`: `vkCmdBuildAccelerationStructuresKHR`
///   of a bottom-level structure of two triangles whose
///   `VkAccelerationStructureTrianglesOpacityMicromapEXT` names the micromap
///   with the `shape`'s usage entries.
///
/// Results: `iterations` and `ns_per_call`, one mean per command.
fn overhead(
    vulkan: &Vulkan,
    iterations: u32,
    shape: OverheadShape,
    results: &mut Results,
) -> Result<(), String> {
    let physical = vulkan.physical_device()?;
    let mut structure_features =
        vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default().acceleration_structure(true);
    let mut micromap_features = vk::PhysicalDeviceOpacityMicromapFeaturesEXT::default()
        .micromap(true)
        .micromap_host_commands(true);
    let mut features = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut micromap_features)
        .push_next(&mut structure_features);
    let gpu = Gpu::new(
        vulkan,
        physical,
        &[
            ash::ext::opacity_micromap::NAME,
            ash::khr::acceleration_structure::NAME,
            ash::khr::deferred_host_operations::NAME,
        ],
        &mut features,
    )?;
    let omm = ash::ext::opacity_micromap::Device::new(&vulkan.instance, &gpu.device);
    let accel = ash::khr::acceleration_structure::Device::new(&vulkan.instance, &gpu.device);
    let micromap = gpu.micromap(&omm)?;
    let address_usage = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;

    // (a) The device build: the triangle array at the start of a mapped
    // input buffer, the data 256 bytes in, as in `device_build`.
    let micromap_usages = shape.usages(shape.triangles);
    let array = shape.triangle_array();
    let array_bytes = 8 * array.len();
    // The data after the array, 256-byte aligned.
    let data_offset = array_bytes.div_ceil(256) * 256;
    let (input, input_map) = gpu.mapped_buffer(
        data_offset as u64 + 256,
        vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT | address_usage,
    )?;
    let (scratch, _) =
        gpu.mapped_buffer(4096, vk::BufferUsageFlags::STORAGE_BUFFER | address_usage)?;
    let (input_address, scratch_address) = match [gpu.address(input), gpu.address(scratch)] {
        [0, 0] => (STAND_IN_INPUT, STAND_IN_SCRATCH),
        [input, scratch] => (input, scratch),
    };
    // SAFETY: the mapping is `data_offset + 256` bytes long: the array at
    // 0, two bytes of data at `data_offset`.
    unsafe {
        input_map.copy_from_nonoverlapping(array.as_ptr().cast(), array_bytes);
        input_map
            .add(data_offset)
            .copy_from_nonoverlapping([0x1u8, 0x2].as_ptr(), 2);
    }
    let with_usages = |info: vk::MicromapBuildInfoEXT<'static>| vk::MicromapBuildInfoEXT {
        usage_counts_count: shape.usage_entries,
        p_usage_counts: micromap_usages.as_ptr(),
        ..info
    };
    let device_info = with_usages(build_info(
        micromap,
        vk::DeviceOrHostAddressConstKHR {
            device_address: input_address,
        },
        vk::DeviceOrHostAddressConstKHR {
            device_address: input_address + data_offset as u64,
        },
        vk::DeviceOrHostAddressKHR {
            device_address: scratch_address,
        },
    ));

    // (b) The host build: the data in the last two bytes of a mapped
    // allocation, as in `host_build`.
    let memory = gpu.allocate(64, !0, vk::MemoryPropertyFlags::HOST_VISIBLE, false)?;
    let mapped = gpu.map(memory)?;
    // SAFETY: the mapping is 64 bytes long; bytes 62 and 63.
    let data = unsafe { mapped.add(62) };
    // SAFETY: as above.
    unsafe { data.copy_from_nonoverlapping([0x1u8, 0x2].as_ptr(), 2) };
    let mut host_scratch = vec![0u8; 4096];
    let host_info = with_usages(build_info(
        micromap,
        vk::DeviceOrHostAddressConstKHR {
            host_address: array.as_ptr().cast(),
        },
        vk::DeviceOrHostAddressConstKHR {
            host_address: data.cast_const().cast(),
        },
        vk::DeviceOrHostAddressKHR {
            host_address: host_scratch.as_mut_ptr().cast(),
        },
    ));

    // (c) A bottom-level structure of two triangles, indexed 0..6, whose
    // opacity-micromap indices (0 and 1, 32-bit) name the micromap's two
    // triangles.
    let input_usage =
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR | address_usage;
    let vertices: [f32; 18] = [
        0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, //
        2.0, 0.0, 0.0, 3.0, 0.0, 0.0, 2.0, 1.0, 0.0,
    ];
    let indices: [u32; 6] = [0, 1, 2, 3, 4, 5];
    let omm_indices: [u32; 2] = [0, 1];
    // The two geometry triangles reference micromap triangles 0 and 1.
    let attachment_usages = shape.usages(2);
    let (vertex_buffer, vertex_map) = gpu.mapped_buffer(4 * 18, input_usage)?;
    let (index_buffer, index_map) = gpu.mapped_buffer(4 * 6, input_usage)?;
    let (omm_index_buffer, omm_index_map) = gpu.mapped_buffer(4 * 2, input_usage)?;
    // SAFETY: each mapping holds its buffer's size: exactly these bytes.
    unsafe {
        vertex_map.copy_from_nonoverlapping(vertices.as_ptr().cast(), 4 * 18);
        index_map.copy_from_nonoverlapping(indices.as_ptr().cast(), 4 * 6);
        omm_index_map.copy_from_nonoverlapping(omm_indices.as_ptr().cast(), 4 * 2);
    }
    let stand_in = |buffer, stand_in| match gpu.address(buffer) {
        0 => stand_in,
        address => address,
    };
    let (storage, _) = gpu.mapped_buffer(
        65536,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR | address_usage,
    )?;
    let create = vk::AccelerationStructureCreateInfoKHR::default()
        .buffer(storage)
        .size(65536)
        .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL);
    // SAFETY: a storage buffer as large as the structure.
    let structure = unsafe { accel.create_acceleration_structure(&create, None) }
        .map_err(|e| format!("vkCreateAccelerationStructureKHR: {e}"))?;
    let (blas_scratch, _) =
        gpu.mapped_buffer(65536, vk::BufferUsageFlags::STORAGE_BUFFER | address_usage)?;
    let mut attachment = vk::AccelerationStructureTrianglesOpacityMicromapEXT::default()
        .index_type(vk::IndexType::UINT32)
        .index_buffer(vk::DeviceOrHostAddressConstKHR {
            device_address: stand_in(omm_index_buffer, STAND_IN_OMM_INDICES),
        })
        .index_stride(4)
        .base_triangle(0)
        .usage_counts(&attachment_usages)
        .micromap(micromap);
    let blas_triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
        .vertex_format(vk::Format::R32G32B32_SFLOAT)
        .vertex_data(vk::DeviceOrHostAddressConstKHR {
            device_address: stand_in(vertex_buffer, STAND_IN_VERTICES),
        })
        .vertex_stride(12)
        .max_vertex(5)
        .index_type(vk::IndexType::UINT32)
        .index_data(vk::DeviceOrHostAddressConstKHR {
            device_address: stand_in(index_buffer, STAND_IN_INDICES),
        })
        .push_next(&mut attachment);
    let geometries = [vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
        .geometry(vk::AccelerationStructureGeometryDataKHR {
            triangles: blas_triangles,
        })];
    let blas_info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(&geometries)
        .dst_acceleration_structure(structure)
        .scratch_data(vk::DeviceOrHostAddressKHR {
            device_address: stand_in(blas_scratch, STAND_IN_BLAS_SCRATCH),
        });
    let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(2)];
    let range_pointers = [ranges.as_ptr()];

    let command_buffer = gpu.begin()?;
    vulkan.phase("record");
    let cmd_build_micromaps = omm.fp().cmd_build_micromaps_ext;
    // SAFETY (each call below): a recording command buffer, one valid info
    // whose pointers live across the loop.
    let cmd_micromaps_ns = time_calls(iterations, || unsafe {
        cmd_build_micromaps(command_buffer, 1, &device_info)
    });
    vulkan.phase("build");
    let build_micromaps = omm.fp().build_micromaps_ext;
    let device = gpu.device.handle();
    let mut host_results = 0u64;
    let host_ns = time_calls(iterations, || {
        // SAFETY: as above; the host addresses live across the loop.
        let result =
            unsafe { build_micromaps(device, vk::DeferredOperationKHR::null(), 1, &host_info) };
        host_results += u64::from(result != vk::Result::SUCCESS);
    });
    vulkan.phase("record");
    let cmd_build_structures = accel.fp().cmd_build_acceleration_structures_khr;
    // SAFETY: as above.
    let cmd_structures_ns = time_calls(iterations, || unsafe {
        cmd_build_structures(command_buffer, 1, &blas_info, range_pointers.as_ptr())
    });
    vulkan.phase("teardown");
    // SAFETY: the command buffer is recording; nothing was submitted.
    unsafe { gpu.device.end_command_buffer(command_buffer) }
        .map_err(|e| format!("vkEndCommandBuffer: {e}"))?;
    // SAFETY: the structure is unused (the command buffer never runs).
    unsafe { accel.destroy_acceleration_structure(structure, None) };
    results.insert("iterations".into(), json!(iterations));
    results.insert("host_builds_failed".into(), json!(host_results));
    results.insert(
        "ns_per_call".into(),
        json!({
            "cmd_build_micromaps": cmd_micromaps_ns,
            "build_micromaps": host_ns,
            "cmd_build_acceleration_structures": cmd_structures_ns,
        }),
    );
    Ok(())
}

/// Threads and iterations of `threads`.
const THREADS: usize = 8;
const THREAD_ITERATIONS: usize = 16;
/// How long `threads` waits for its threads before it calls it a deadlock
/// (exit status 2): far beyond what the work takes.
const DEADLOCK_BOUND: std::time::Duration = std::time::Duration::from_secs(60);

/// `threads` (Mock ICD): [`THREADS`] threads at once, each with its own
/// command pool, [`THREAD_ITERATIONS`] times creating a micromap and two
/// acceleration structures on buffers of their own, recording device builds
/// of both into a command buffer of its own and submitting it, making host
/// builds of both, and destroying all of it again. Known faults per
/// iteration: a device and a host micromap build with both usage pointers
/// (VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516, twice) and a structure
/// created with the opacity-micromap type
/// (VUID-VkAccelerationStructureCreateInfoKHR-type-11600). Everything else is
/// valid. Results: `threads`, `iterations` and `failed_calls` (calls that
/// returned an error, 0 expected).
fn threads(vulkan: &Vulkan, results: &mut Results) -> Result<(), String> {
    let physical = vulkan.physical_device()?;
    let mut structure_features = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
        .acceleration_structure(true)
        .acceleration_structure_host_commands(true);
    let mut micromap_features = vk::PhysicalDeviceOpacityMicromapFeaturesEXT::default()
        .micromap(true)
        .micromap_host_commands(true);
    let mut features = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut micromap_features)
        .push_next(&mut structure_features);
    let gpu = Gpu::new(
        vulkan,
        physical,
        &[
            ash::ext::opacity_micromap::NAME,
            ash::khr::acceleration_structure::NAME,
            ash::khr::deferred_host_operations::NAME,
        ],
        &mut features,
    )?;
    let omm = ash::ext::opacity_micromap::Device::new(&vulkan.instance, &gpu.device);
    let accel = ash::khr::acceleration_structure::Device::new(&vulkan.instance, &gpu.device);
    // The queue is externally synchronized: the threads take turns.
    let queue = Mutex::new(());
    let failed = std::sync::atomic::AtomicU64::new(0);
    let (disarm, armed) = std::sync::mpsc::channel::<()>();
    std::thread::spawn(move || {
        if armed.recv_timeout(DEADLOCK_BOUND).is_err() {
            eprintln!("omm-app: threads: not finished within {DEADLOCK_BOUND:?}: a deadlock");
            std::process::exit(2);
        }
    });
    vulkan.phase("threads");
    let outcome: Result<(), String> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..THREADS)
            .map(|_| scope.spawn(|| thread_iterations(&gpu, &omm, &accel, &queue, &failed)))
            .collect();
        workers
            .into_iter()
            .try_for_each(|w| w.join().map_err(|_| "a thread panicked".to_string())?)
    });
    let _ = disarm.send(());
    outcome?;
    results.insert("threads".into(), json!(THREADS));
    results.insert("iterations".into(), json!(THREAD_ITERATIONS));
    results.insert("failed_calls".into(), json!(failed.into_inner()));
    Ok(())
}

/// One thread's work in [`threads`].
fn thread_iterations(
    gpu: &Gpu<'_>,
    omm: &ash::ext::opacity_micromap::Device,
    accel: &ash::khr::acceleration_structure::Device,
    queue: &Mutex<()>,
    failed: &std::sync::atomic::AtomicU64,
) -> Result<(), String> {
    let count = |result: vk::Result| {
        if result != vk::Result::SUCCESS {
            failed.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    };
    let pool_info = vk::CommandPoolCreateInfo::default().queue_family_index(0);
    // SAFETY: valid arguments.
    let pool = unsafe { gpu.device.create_command_pool(&pool_info, None) }
        .map_err(|e| format!("vkCreateCommandPool: {e}"))?;
    let address_usage = vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS;
    let usage_pointers = [&USAGE[0] as *const vk::MicromapUsageEXT];
    let vertices = [0.5f32; 18];
    let omm_indices = [0u32, 1];
    let host_triangles = triangles([0, 1], 1);
    let mut host_scratch = vec![0u8; 1 << 16];
    for _ in 0..THREAD_ITERATIONS {
        let (micromap_storage, micromap_memory, _) =
            gpu.mapped(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT)?;
        let info = vk::MicromapCreateInfoEXT::default()
            .buffer(micromap_storage)
            .size(4096)
            .ty(vk::MicromapTypeEXT::OPACITY_MICROMAP);
        let mut micromap = vk::MicromapEXT::null();
        // SAFETY: valid arguments.
        count(unsafe {
            (omm.fp().create_micromap_ext)(
                gpu.device.handle(),
                &info,
                std::ptr::null(),
                &mut micromap,
            )
        });
        let (structure_storage, structure_memory, _) = gpu.mapped(
            1 << 16,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR | address_usage,
        )?;
        let create = |ty| {
            let info = vk::AccelerationStructureCreateInfoKHR::default()
                .buffer(structure_storage)
                .size(1 << 16)
                .ty(ty);
            // SAFETY: a storage buffer as large as the structure.
            unsafe { accel.create_acceleration_structure(&info, None) }
                .map_err(|e| format!("vkCreateAccelerationStructureKHR: {e}"))
        };
        let blas = create(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)?;
        // The fault: the opacity-micromap type in the KHR create info.
        let misused = create(vk::AccelerationStructureTypeKHR::from_raw(
            ommcheck::model::accel::ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
        ))?;
        // The data in the last two bytes of a mapped allocation, as in
        // `host_build`.
        let data_memory = gpu.allocate(64, !0, vk::MemoryPropertyFlags::HOST_VISIBLE, false)?;
        let mapped = gpu.map(data_memory)?;
        // SAFETY: the mapping is 64 bytes long; bytes 62 and 63.
        let data = unsafe { mapped.add(62) };
        // SAFETY: as above.
        unsafe { data.copy_from_nonoverlapping([0x1u8, 0x2].as_ptr(), 2) };

        // Device builds at stand-in addresses (the Mock ICD returns 0).
        let command_info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: valid arguments; this thread's pool.
        let command_buffer = unsafe { gpu.device.allocate_command_buffers(&command_info) }
            .map_err(|e| format!("vkAllocateCommandBuffers: {e}"))?[0];
        // SAFETY: a fresh command buffer.
        unsafe {
            gpu.device
                .begin_command_buffer(command_buffer, &vk::CommandBufferBeginInfo::default())
        }
        .map_err(|e| format!("vkBeginCommandBuffer: {e}"))?;
        let device_info = build_info(
            micromap,
            vk::DeviceOrHostAddressConstKHR {
                device_address: STAND_IN_INPUT,
            },
            vk::DeviceOrHostAddressConstKHR {
                device_address: STAND_IN_INPUT + 256,
            },
            vk::DeviceOrHostAddressKHR {
                device_address: STAND_IN_SCRATCH,
            },
        );
        let device_both = vk::MicromapBuildInfoEXT {
            pp_usage_counts: usage_pointers.as_ptr(),
            ..device_info
        };
        // SAFETY: a recording command buffer, one info each.
        unsafe {
            (omm.fp().cmd_build_micromaps_ext)(command_buffer, 1, &device_info);
            (omm.fp().cmd_build_micromaps_ext)(command_buffer, 1, &device_both);
        }
        let device_attaching = Attaching {
            vertices: vk::DeviceOrHostAddressConstKHR {
                device_address: STAND_IN_VERTICES,
            },
            indices: vk::DeviceOrHostAddressConstKHR {
                device_address: STAND_IN_OMM_INDICES,
            },
            usage_counts: &USAGE,
            micromap,
            blas,
            scratch: vk::DeviceOrHostAddressKHR {
                device_address: STAND_IN_BLAS_SCRATCH,
            },
        };
        device_attaching.with_info(|info, ranges| {
            // SAFETY: a recording command buffer, one info and its ranges.
            unsafe {
                (accel.fp().cmd_build_acceleration_structures_khr)(command_buffer, 1, info, ranges)
            }
        });
        // SAFETY: the command buffer is recording.
        unsafe { gpu.device.end_command_buffer(command_buffer) }
            .map_err(|e| format!("vkEndCommandBuffer: {e}"))?;
        {
            let _turn = queue.lock().unwrap_or_else(|e| e.into_inner());
            count(vk::Result::from_raw(gpu.submit(command_buffer)?));
        }

        // Host builds from this thread's memory.
        let host = |p: *const u8| vk::DeviceOrHostAddressConstKHR {
            host_address: p.cast(),
        };
        let host_info = build_info(
            micromap,
            host(host_triangles.as_ptr().cast()),
            host(data.cast_const()),
            vk::DeviceOrHostAddressKHR {
                host_address: host_scratch.as_mut_ptr().cast(),
            },
        );
        let host_both = vk::MicromapBuildInfoEXT {
            pp_usage_counts: usage_pointers.as_ptr(),
            ..host_info
        };
        for info in [&host_info, &host_both] {
            // SAFETY: one info whose host addresses are live.
            count(unsafe {
                (omm.fp().build_micromaps_ext)(
                    gpu.device.handle(),
                    vk::DeferredOperationKHR::null(),
                    1,
                    info,
                )
            });
        }
        let host_attaching = Attaching {
            vertices: host(vertices.as_ptr().cast()),
            indices: host(omm_indices.as_ptr().cast()),
            usage_counts: &USAGE,
            micromap,
            blas,
            scratch: vk::DeviceOrHostAddressKHR {
                host_address: host_scratch.as_mut_ptr().cast(),
            },
        };
        count(host_attaching.with_info(|info, ranges| {
            // SAFETY: one info with live host addresses, and its ranges.
            unsafe {
                (accel.fp().build_acceleration_structures_khr)(
                    gpu.device.handle(),
                    vk::DeferredOperationKHR::null(),
                    1,
                    info,
                    ranges,
                )
            }
        }));

        // Everything goes again while the other threads make theirs.
        // SAFETY: the queue was idle after the submission; nothing uses
        // these objects any more.
        unsafe {
            gpu.device.free_command_buffers(pool, &[command_buffer]);
            accel.destroy_acceleration_structure(blas, None);
            accel.destroy_acceleration_structure(misused, None);
            (omm.fp().destroy_micromap_ext)(gpu.device.handle(), micromap, std::ptr::null());
            gpu.device.destroy_buffer(micromap_storage, None);
            gpu.device.destroy_buffer(structure_storage, None);
            for memory in [micromap_memory, structure_memory, data_memory] {
                gpu.device.free_memory(memory, None);
            }
        }
    }
    // SAFETY: this thread's pool, its command buffers freed.
    unsafe { gpu.device.destroy_command_pool(pool, None) };
    Ok(())
}

/// `vkCreateBuffer` with size 0: VUID-VkBufferCreateInfo-size-00912, which
/// the Khronos validation layer checks. The Mock ICD accepts it.
fn core_fault(vulkan: &Vulkan, results: &mut Results) -> Result<(), String> {
    let gpu = micromap_device(vulkan)?;
    vulkan.phase("core-fault");
    let info = vk::BufferCreateInfo::default()
        .size(0)
        .usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: a valid pointer; the size is the deliberate fault.
    let result = unsafe { gpu.device.create_buffer(&info, None) };
    if let Ok(buffer) = result {
        // SAFETY: the buffer was just created and is unused.
        unsafe { gpu.device.destroy_buffer(buffer, None) };
    }
    results.insert(
        "core_fault".into(),
        json!(result.err().unwrap_or(vk::Result::SUCCESS).as_raw()),
    );
    Ok(())
}

fn run(args: &[String]) -> Result<Value, String> {
    let usage =
        "usage: omm-app SCENARIO [--layer NAME]... [--core-fault] [--iterations N (overhead)] \
         [--usage-entries K (overhead)] [--triangles N (overhead)] \
         [--way copy|update|fill|compute|mapped (tlas)] [--valid (tlas)] [--sync-fault (tlas)]";
    let (scenario, rest) = args.split_first().ok_or(usage)?;
    let mut layers = Vec::new();
    let mut with_core_fault = false;
    let mut iterations = 10_000u32;
    let mut shape = OverheadShape {
        usage_entries: 1,
        triangles: 2,
    };
    let mut tlas_options = TlasOptions {
        way: None,
        valid: false,
        sync_fault: false,
    };
    let mut rest = rest.iter();
    while let Some(arg) = rest.next() {
        match arg.as_str() {
            "--layer" => {
                let name = rest.next().ok_or(usage)?;
                layers.push(CString::new(name.as_str()).map_err(|e| format!("{name:?}: {e}"))?)
            }
            "--iterations" => {
                let n = rest.next().ok_or(usage)?;
                iterations = n
                    .parse()
                    .ok()
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("--iterations {n:?}: a positive integer"))?;
            }
            "--usage-entries" | "--triangles" => {
                let n = rest.next().ok_or(usage)?;
                let n = n
                    .parse()
                    .ok()
                    .filter(|&n| (1..=1 << 20).contains(&n))
                    .ok_or_else(|| format!("{arg} {n:?}: an integer from 1 to 2^20"))?;
                match arg.as_str() {
                    "--usage-entries" => shape.usage_entries = n,
                    _ => shape.triangles = n,
                }
            }
            "--core-fault" => with_core_fault = true,
            "--way" => tlas_options.way = Some(InstanceWay::parse(rest.next().ok_or(usage)?)?),
            "--valid" => tlas_options.valid = true,
            "--sync-fault" => tlas_options.sync_fault = true,
            _ => return Err(format!("unexpected argument {arg:?}; {usage}")),
        }
    }
    let vulkan = Vulkan::new(&layers)?;
    let mut results = Results::new();
    match scenario.split_once('-').unwrap_or((scenario, "")) {
        ("host", build) => host_build(&vulkan, build.trim_start_matches("build-"), &mut results)?,
        ("device", build) => {
            device_build(&vulkan, build.trim_start_matches("build-"), &mut results)?
        }
        ("blas", "") => blas(&vulkan, &mut results)?,
        ("tlas", "") => tlas(&vulkan, &tlas_options, &mut results)?,
        ("overhead", "") => overhead(&vulkan, iterations, shape, &mut results)?,
        ("threads", "") => threads(&vulkan, &mut results)?,
        _ => return Err(format!("unknown scenario {scenario:?}")),
    }
    if with_core_fault {
        core_fault(&vulkan, &mut results)?;
    }
    Ok(json!({
        "scenario": scenario,
        "messages": vulkan.messages(),
        "device_layers": *vulkan.collector.device_layers.lock().unwrap(),
        "results": results,
    }))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(line) => {
            println!("{line}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("omm-app: {e}");
            ExitCode::FAILURE
        }
    }
}
