//! `omm-stress`: long and concurrent workloads through the system's Vulkan
//! loader and the layer, over the project's fake driver (`layer/fake-icd`,
//! found by its device name) and lavapipe where the loader offers it. The
//! caller sets the loader's variables (`VK_DRIVER_FILES`,
//! `VK_ADD_LAYER_PATH`) and the layer's settings (`OMMCHECK_*`); the layers
//! are enabled in `ppEnabledLayerNames` as `--layer` names them.
//!
//! ```text
//! omm-stress soak [--submissions N] [--lavapipe] [--layer NAME]...
//! omm-stress threads --threads T [--rounds R] [--reenter] [--layer NAME]...
//! omm-stress overhead --threads T [--iterations N] [--layer NAME]...
//! ```
//!
//! - `soak` (`cargo xtask soak`): N submissions (default 10^5) of micromap
//!   and bottom-level builds whose inputs lie in device-local memory the
//!   application never maps (the layer reads them back), recorded anew,
//!   resubmitted as recorded, and their micromaps and structures destroyed
//!   and made again; with `--lavapipe`, every tenth submission is a
//!   top-level build over lavapipe whose one instance a vkCmdUpdateBuffer
//!   writes into device-local memory. Some builds carry known faults. It
//!   prints one line, `soak: ...`: the submissions, the findings against
//!   those expected, and the resident memory (VmRSS) at 10% of the run and
//!   at its end; it fails (exit status 1) when the findings differ or the
//!   end exceeds 1.1 times the 10% mark.
//! - `threads` (`tests/threads.rs`): T threads at once, each with its own
//!   command pool, command buffer, fence and micromap, record R rounds of
//!   three micromap builds (valid; both usage-count pointers set; data past
//!   its buffer), submit them (taking turns at the one queue) and wait.
//!   With `--reenter` the messenger's callback calls back into Vulkan:
//!   `vkGetBufferDeviceAddress`, `vkGetFenceStatus` and, on a worker
//!   thread, `vkCmdFillBuffer` into a command buffer of that thread's.
//!   Prints one JSON line: the findings by id and by the command buffer
//!   they name, mapped to the thread that recorded it. A watchdog aborts
//!   the process (a deadlock) if the threads have not finished in
//!   [`DEADLOCK_BOUND`].
//! - `overhead` (`cargo xtask threads`): T threads at once each time N
//!   valid calls of `vkCmdBuildMicromapsEXT`, `vkBuildMicromapsEXT` and
//!   `vkCmdBuildAccelerationStructuresKHR` (a bottom-level build attaching
//!   a micromap), inputs in mapped memory, into command buffers of their
//!   own; prints one JSON line with each call's mean time per call over
//!   the threads.
//!
//! Errors go to stderr with exit status 1.

use std::cell::Cell;
use std::collections::BTreeMap;
use std::ffi::{c_void, CStr, CString};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};
use std::time::{Duration, Instant};

use ash::vk;
use ash::vk::Handle as _;
use ommcheck_tests::vulkan::{self, instance_words, word_bytes, Instance, USAGE};
use serde_json::json;

/// The fake driver's physical device (`layer/fake-icd`'s DEVICE_NAME).
const FAKE_DEVICE: &CStr = c"ommcheck fake driver";

/// How long `threads` waits for its threads before it calls it a deadlock:
/// far beyond what the work takes (well under a second per round).
const DEADLOCK_BOUND: Duration = Duration::from_secs(300);

/// The bound on the resident memory at the end of a soak, against 10%.
const MEMORY_BOUND: f64 = 1.1;

/// The micromap data buffer's size: a triangle whose data starts here runs
/// past its end.
const DATA_SIZE: u32 = 16;

/// What every message ends up as: how often each id arrived naming each
/// command buffer (0: none, or not told apart), and, with `--reenter`, what
/// the callback calls.
#[derive(Default)]
struct Findings {
    counts: Mutex<BTreeMap<(String, u64), u64>>,
    /// Whether counts tell command buffers apart (`threads`); a soak's
    /// would grow with every command buffer it makes.
    by_command_buffer: AtomicBool,
    reentry: OnceLock<Reentry>,
    /// How often the callback called back into Vulkan.
    reentered: AtomicU64,
}

impl Findings {
    fn total(&self) -> u64 {
        lock(&self.counts).values().sum()
    }
}

fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The calls the callback makes back into Vulkan (`threads --reenter`).
struct Reentry {
    device: vk::Device,
    get_address: vk::PFN_vkGetBufferDeviceAddress,
    fence_status: vk::PFN_vkGetFenceStatus,
    fill: vk::PFN_vkCmdFillBuffer,
    /// A buffer the callback asks the address of and fills.
    buffer: vk::Buffer,
}

thread_local! {
    /// A worker thread's command buffer in the recording state, which the
    /// callback records into, and its fence, whose status it asks.
    static SPARE: Cell<Option<(vk::CommandBuffer, vk::Fence)>> = const { Cell::new(None) };
}

unsafe extern "system" fn count(
    _: vk::DebugUtilsMessageSeverityFlagsEXT,
    types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    // The loader's own messages (general) are no layer's findings.
    if !types.contains(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION) {
        return vk::FALSE;
    }
    // SAFETY: the user data is the leaked Findings the messenger was made
    // with; the callback data is valid for the call.
    let (findings, data) = unsafe { (&*user_data.cast::<Findings>(), &*data) };
    let id = if data.p_message_id_name.is_null() {
        String::new()
    } else {
        // SAFETY: a non-NULL id name is NUL-terminated.
        unsafe { CStr::from_ptr(data.p_message_id_name) }
            .to_string_lossy()
            .into_owned()
    };
    let objects: &[vk::DebugUtilsObjectNameInfoEXT<'_>] = if data.p_objects.is_null() {
        &[]
    } else {
        // SAFETY: the layer passes objectCount objects.
        unsafe { std::slice::from_raw_parts(data.p_objects, data.object_count as usize) }
    };
    let command_buffer = objects
        .iter()
        .find(|o| o.object_type == vk::ObjectType::COMMAND_BUFFER)
        .filter(|_| findings.by_command_buffer.load(Ordering::Relaxed))
        .map_or(0, |o| o.object_handle);
    *lock(&findings.counts)
        .entry((id, command_buffer))
        .or_insert(0) += 1;
    if let Some(reentry) = findings.reentry.get() {
        let info = vk::BufferDeviceAddressInfo::default().buffer(reentry.buffer);
        // SAFETY: a live device and buffer; what the worker thread's spare
        // command buffer and fence are is set by that thread alone.
        unsafe {
            (reentry.get_address)(reentry.device, &info);
            if let Some((command_buffer, fence)) = SPARE.get() {
                (reentry.fill)(command_buffer, reentry.buffer, 0, 4, 0);
                let _ = (reentry.fence_status)(reentry.device, fence);
            }
        }
        findings.reentered.fetch_add(1, Ordering::Relaxed);
    }
    vk::FALSE
}

/// The instance with the named layers and a messenger for errors and
/// warnings that counts into a leaked [`Findings`] (it lives as long as the
/// process; one per process).
struct Vulkan {
    base: Instance,
    findings: &'static Findings,
}

impl Vulkan {
    fn new(layers: &[CString]) -> Result<Self, String> {
        let findings: &'static Findings = Box::leak(Box::default());
        let base = Instance::new(
            c"omm-stress",
            layers,
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
                | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
            Some(count),
            (findings as *const Findings).cast_mut().cast(),
        )?;
        Ok(Self { base, findings })
    }

    /// The physical devices and their names.
    fn physical_devices(&self) -> Result<Vec<(vk::PhysicalDevice, String)>, String> {
        // SAFETY: a live instance.
        let devices = unsafe { self.base.instance.enumerate_physical_devices() }
            .map_err(|e| format!("vkEnumeratePhysicalDevices: {e}"))?;
        Ok(devices
            .into_iter()
            .map(|device| {
                // SAFETY: a physical device of this instance.
                let properties =
                    unsafe { self.base.instance.get_physical_device_properties(device) };
                let name = properties
                    .device_name_as_c_str()
                    .map_or_else(|_| "?".into(), |n| n.to_string_lossy().into_owned());
                (device, name)
            })
            .collect())
    }

    /// The fake driver's physical device.
    fn fake_device(&self) -> Result<vk::PhysicalDevice, String> {
        let name = FAKE_DEVICE.to_string_lossy();
        self.physical_devices()?
            .into_iter()
            .find(|(_, n)| *n == name)
            .map(|(device, _)| device)
            .ok_or_else(|| {
                format!(
                    "no physical device {name:?}: is VK_DRIVER_FILES the fake driver's manifest?"
                )
            })
    }

    /// lavapipe's physical device (named llvmpipe).
    fn lavapipe(&self) -> Result<vk::PhysicalDevice, String> {
        self.physical_devices()?
            .into_iter()
            .find(|(_, n)| n.starts_with("llvmpipe"))
            .map(|(device, _)| device)
            .ok_or_else(|| "no lavapipe (llvmpipe) physical device".into())
    }

    fn destroy(self) {
        self.base.destroy();
    }
}

/// A buffer bound to memory of its own, and its device address (0 without
/// SHADER_DEVICE_ADDRESS usage).
#[derive(Clone, Copy)]
struct Block {
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    address: u64,
}

/// A device with one queue of family 0 and the commands used here.
struct Device {
    core: vulkan::Device,
    /// The queue is externally synchronized: threads take turns.
    queue_turn: Mutex<()>,
    accel: ash::khr::acceleration_structure::Device,
    /// None on a device without VK_EXT_opacity_micromap.
    omm: Option<ash::ext::opacity_micromap::Device>,
    scratch_alignment: u64,
}

impl std::ops::Deref for Device {
    type Target = vulkan::Device;

    fn deref(&self) -> &vulkan::Device {
        &self.core
    }
}

impl Device {
    /// The device of `physical` with VK_KHR_acceleration_structure and
    /// `bufferDeviceAddress`, and with `micromaps` VK_EXT_opacity_micromap
    /// and the host-command features of both.
    fn new(vulkan: &Vulkan, physical: vk::PhysicalDevice, micromaps: bool) -> Result<Self, String> {
        let mut structures = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
            .acceleration_structure(true)
            .acceleration_structure_host_commands(micromaps);
        let mut micromap = vk::PhysicalDeviceOpacityMicromapFeaturesEXT::default()
            .micromap(true)
            .micromap_host_commands(true);
        let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut structures);
        let mut extensions = vec![
            ash::khr::acceleration_structure::NAME,
            ash::khr::deferred_host_operations::NAME,
        ];
        if micromaps {
            extensions.push(ash::ext::opacity_micromap::NAME);
            features = features.push_next(&mut micromap);
        }
        let instance = &vulkan.base.instance;
        let core = vulkan::Device::new(instance, physical, &extensions, &mut features)?;
        Ok(Self {
            accel: ash::khr::acceleration_structure::Device::new(instance, &core.device),
            omm: micromaps.then(|| ash::ext::opacity_micromap::Device::new(instance, &core.device)),
            core,
            queue_turn: Mutex::new(()),
            scratch_alignment: vulkan.base.scratch_alignment(physical),
        })
    }

    fn omm(&self) -> &ash::ext::opacity_micromap::Device {
        self.omm
            .as_ref()
            .expect("a device with VK_EXT_opacity_micromap")
    }

    /// A buffer of `size` bytes bound to memory of its own, of the first
    /// type with `flags`.
    fn block(
        &self,
        size: u64,
        usage: vk::BufferUsageFlags,
        flags: vk::MemoryPropertyFlags,
    ) -> Result<Block, String> {
        let (buffer, memory) = self.bound_buffer(size, usage, flags)?;
        let address = if usage.contains(vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS) {
            self.address(buffer)
        } else {
            0
        };
        Ok(Block {
            buffer,
            memory,
            address,
        })
    }

    /// A build input in device-local memory the application never maps:
    /// written by vkCmdUpdateBuffer, so it needs TRANSFER_DST.
    fn input(&self, size: u64) -> Result<Block, String> {
        self.block(
            size,
            vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
                | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                | vk::BufferUsageFlags::TRANSFER_DST,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )
    }

    /// Scratch memory of `size` bytes, device-local; its address aligned.
    fn scratch(&self, size: u64) -> Result<(Block, u64), String> {
        let block = self.block(
            size + self.scratch_alignment,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        let aligned = block.address.next_multiple_of(self.scratch_alignment);
        Ok((block, aligned))
    }

    /// A host-visible, coherent buffer, mapped for good.
    fn mapped_block(
        &self,
        size: u64,
        usage: vk::BufferUsageFlags,
    ) -> Result<(Block, *mut u8), String> {
        let (buffer, memory, map) = self.mapped(size, usage)?;
        let address = self.address(buffer);
        Ok((
            Block {
                buffer,
                memory,
                address,
            },
            map,
        ))
    }

    fn free(&self, block: Block) {
        // SAFETY: the queue is idle; nothing alive uses the buffer.
        unsafe {
            self.device.destroy_buffer(block.buffer, None);
            self.device.free_memory(block.memory, None);
        }
    }

    /// A command pool whose buffers are reset by beginning them again.
    fn pool(&self) -> Result<vk::CommandPool, String> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(0)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid arguments.
        unsafe { self.device.create_command_pool(&info, None) }
            .map_err(|e| format!("vkCreateCommandPool: {e}"))
    }

    fn command_buffers(
        &self,
        pool: vk::CommandPool,
        count: u32,
    ) -> Result<Vec<vk::CommandBuffer>, String> {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(count);
        // SAFETY: valid arguments.
        unsafe { self.device.allocate_command_buffers(&info) }
            .map_err(|e| format!("vkAllocateCommandBuffers: {e}"))
    }

    fn fence(&self) -> Result<vk::Fence, String> {
        // SAFETY: valid arguments.
        unsafe {
            self.device
                .create_fence(&vk::FenceCreateInfo::default(), None)
        }
        .map_err(|e| format!("vkCreateFence: {e}"))
    }

    /// Begins `command_buffer` (resetting what it recorded).
    fn begin(&self, command_buffer: vk::CommandBuffer) -> Result<(), String> {
        // SAFETY: a command buffer of a pool with RESET_COMMAND_BUFFER,
        // not pending.
        unsafe {
            self.device
                .begin_command_buffer(command_buffer, &vk::CommandBufferBeginInfo::default())
        }
        .map_err(|e| format!("vkBeginCommandBuffer: {e}"))
    }

    fn end(&self, command_buffer: vk::CommandBuffer) -> Result<(), String> {
        // SAFETY: a recording command buffer.
        unsafe { self.device.end_command_buffer(command_buffer) }
            .map_err(|e| format!("vkEndCommandBuffer: {e}"))
    }

    /// Submits `command_buffer` with `fence` (taking its turn at the
    /// queue), waits for the fence and resets it.
    fn submit_and_wait(
        &self,
        command_buffer: vk::CommandBuffer,
        fence: vk::Fence,
    ) -> Result<(), String> {
        self.submit_and_wait_for(command_buffer, fence)?;
        // SAFETY: a fence of this device, signaled, so not in use.
        unsafe { self.device.reset_fences(&[fence]) }.map_err(|e| format!("vkResetFences: {e}"))
    }

    /// As [`Device::submit_and_wait`], leaving the fence signaled.
    fn submit_and_wait_for(
        &self,
        command_buffer: vk::CommandBuffer,
        fence: vk::Fence,
    ) -> Result<(), String> {
        let command_buffers = [command_buffer];
        let submit = [vk::SubmitInfo::default().command_buffers(&command_buffers)];
        {
            let _turn = lock(&self.queue_turn);
            // SAFETY: an executable command buffer of family 0; an
            // unsignaled fence; the queue is ours while the turn is held.
            unsafe { self.device.queue_submit(self.queue, &submit, fence) }
                .map_err(|e| format!("vkQueueSubmit: {e}"))?;
        }
        // SAFETY: a fence of this device.
        unsafe { self.device.wait_for_fences(&[fence], true, u64::MAX) }
            .map_err(|e| format!("vkWaitForFences: {e}"))
    }

    /// Writes `bytes` into each buffer with vkCmdUpdateBuffer in one
    /// submission, and waits for it.
    fn upload(&self, writes: &[(vk::Buffer, Vec<u8>)]) -> Result<(), String> {
        let pool = self.pool()?;
        let command_buffer = self.command_buffers(pool, 1)?[0];
        let fence = self.fence()?;
        self.begin(command_buffer)?;
        for (buffer, bytes) in writes {
            // SAFETY: a recording command buffer; each buffer has
            // TRANSFER_DST and holds the bytes (a multiple of 4, < 64 KiB).
            unsafe {
                self.device
                    .cmd_update_buffer(command_buffer, *buffer, 0, bytes)
            };
        }
        barrier(self, command_buffer);
        self.end(command_buffer)?;
        self.submit_and_wait(command_buffer, fence)?;
        // SAFETY: the submission is complete.
        unsafe {
            self.device.destroy_fence(fence, None);
            self.device.destroy_command_pool(pool, None);
        }
        Ok(())
    }

    /// A micromap on a storage buffer of its own in memory with `flags`
    /// (host builds need host-visible memory).
    fn new_micromap(
        &self,
        flags: vk::MemoryPropertyFlags,
    ) -> Result<(vk::MicromapEXT, Block), String> {
        let storage = self.block(4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, flags)?;
        Ok((self.micromap(self.omm(), storage.buffer, 4096)?, storage))
    }

    fn destroy_micromap(&self, micromap: vk::MicromapEXT) {
        // SAFETY: no pending work uses the micromap.
        unsafe {
            (self.omm().fp().destroy_micromap_ext)(self.device.handle(), micromap, std::ptr::null())
        };
    }

    /// A structure of `ty` and `size` bytes on a storage buffer of its own.
    fn structure(
        &self,
        ty: vk::AccelerationStructureTypeKHR,
        size: u64,
    ) -> Result<(vk::AccelerationStructureKHR, Block), String> {
        let storage = self.block(
            size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage.buffer)
            .size(size)
            .ty(ty);
        // SAFETY: a storage buffer as large as the structure.
        let structure = unsafe { self.accel.create_acceleration_structure(&info, None) }
            .map_err(|e| format!("vkCreateAccelerationStructureKHR: {e}"))?;
        Ok((structure, storage))
    }

    fn build_sizes(
        &self,
        info: &vk::AccelerationStructureBuildGeometryInfoKHR<'_>,
        primitives: u32,
    ) -> [u64; 2] {
        vulkan::build_sizes(&self.accel, info, primitives)
    }

    fn destroy(self) {
        // SAFETY: the queue is idle; every child was destroyed.
        unsafe { self.device.destroy_device(None) };
    }
}

/// A barrier from every write to every read, so each build sees what the
/// commands before it wrote.
fn barrier(device: &Device, command_buffer: vk::CommandBuffer) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
        .dst_access_mask(vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE)];
    // SAFETY: a recording command buffer.
    unsafe {
        device.device.cmd_pipeline_barrier(
            command_buffer,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

/// The bytes of a triangle array: `(data offset, level, format)` each.
fn triangle_bytes(triangles: &[(u32, u16, u16)]) -> Vec<u8> {
    triangles
        .iter()
        .flat_map(|&(offset, level, format)| {
            let mut entry = offset.to_le_bytes().to_vec();
            entry.extend(level.to_le_bytes());
            entry.extend(format.to_le_bytes());
            entry
        })
        .collect()
}

/// The micromap build inputs on the fake driver, in device-local memory
/// written once by vkCmdUpdateBuffer: a valid triangle array, one whose
/// second triangle's data lies past the data buffer
/// (OMMCHECK-build-triangle-data-in-range), the data, the opacity indices
/// and vertices of a bottom-level build of two triangles.
struct Inputs {
    triangles: Block,
    triangles_past_data: Block,
    data: Block,
    indices: Block,
    vertices: Block,
}

impl Inputs {
    fn new(device: &Device) -> Result<Self, String> {
        let inputs = Self {
            triangles: device.input(16)?,
            triangles_past_data: device.input(16)?,
            data: device.input(u64::from(DATA_SIZE))?,
            indices: device.input(8)?,
            vertices: device.input(72)?,
        };
        let vertices: Vec<u8> = [
            0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, //
            2.0, 0.0, 0.0, 3.0, 0.0, 0.0, 2.0, 1.0, 0.0,
        ]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
        device.upload(&[
            (
                inputs.triangles.buffer,
                triangle_bytes(&[(0, 1, 1), (1, 1, 1)]),
            ),
            (
                inputs.triangles_past_data.buffer,
                triangle_bytes(&[(0, 1, 1), (DATA_SIZE, 1, 1)]),
            ),
            (inputs.data.buffer, vec![0xA5; DATA_SIZE as usize]),
            (
                inputs.indices.buffer,
                [0u32, 1].iter().flat_map(|i| i.to_le_bytes()).collect(),
            ),
            (inputs.vertices.buffer, vertices),
        ])?;
        Ok(inputs)
    }

    fn free(self, device: &Device) {
        for block in [
            self.triangles,
            self.triangles_past_data,
            self.data,
            self.indices,
            self.vertices,
        ] {
            device.free(block);
        }
    }
}

/// A device micromap build of [`USAGE`] into `micromap`.
fn micromap_build(
    micromap: vk::MicromapEXT,
    triangles: u64,
    data: u64,
    scratch: u64,
) -> vk::MicromapBuildInfoEXT<'static> {
    let at = |device_address| vk::DeviceOrHostAddressConstKHR { device_address };
    vulkan::build_info(
        micromap,
        at(triangles),
        at(data),
        vk::DeviceOrHostAddressKHR {
            device_address: scratch,
        },
    )
}

/// Records one device micromap build.
fn record_micromap_build(
    device: &Device,
    command_buffer: vk::CommandBuffer,
    info: &vk::MicromapBuildInfoEXT<'_>,
) {
    // SAFETY: a recording command buffer, one info whose pointers are live.
    unsafe { (device.omm().fp().cmd_build_micromaps_ext)(command_buffer, 1, info) };
}

/// Records the micromap builds of one faulty or valid round: a valid build,
/// and when `faulty` one with both usage-count pointers set
/// (VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516, said at recording) and
/// one whose data lies past its buffer
/// (OMMCHECK-build-triangle-data-in-range, said once the layer has read the
/// inputs back after the submission completes).
fn record_micromap_builds(
    device: &Device,
    command_buffer: vk::CommandBuffer,
    inputs: &Inputs,
    micromap: vk::MicromapEXT,
    scratch: u64,
    faulty: bool,
) {
    let valid = micromap_build(
        micromap,
        inputs.triangles.address,
        inputs.data.address,
        scratch,
    );
    record_micromap_build(device, command_buffer, &valid);
    if faulty {
        let usage_pointers = [USAGE.as_ptr()];
        barrier(device, command_buffer);
        record_micromap_build(
            device,
            command_buffer,
            &vk::MicromapBuildInfoEXT {
                pp_usage_counts: usage_pointers.as_ptr(),
                ..valid
            },
        );
        barrier(device, command_buffer);
        record_micromap_build(
            device,
            command_buffer,
            &micromap_build(
                micromap,
                inputs.triangles_past_data.address,
                inputs.data.address,
                scratch,
            ),
        );
    }
}

/// Records a bottom-level build of two triangles attaching `micromap`
/// through `VkAccelerationStructureTrianglesOpacityMicromapEXT`, its
/// opacity indices (0 and 1) and vertices where `inputs` has them.
fn record_attaching_build(
    device: &Device,
    command_buffer: vk::CommandBuffer,
    inputs: &Inputs,
    micromap: vk::MicromapEXT,
    blas: vk::AccelerationStructureKHR,
    scratch: u64,
) {
    let at = |device_address| vk::DeviceOrHostAddressConstKHR { device_address };
    let attaching = vulkan::Attaching {
        vertices: at(inputs.vertices.address),
        indices: at(inputs.indices.address),
        usage_counts: &USAGE,
        micromap,
        blas,
        scratch: vk::DeviceOrHostAddressKHR {
            device_address: scratch,
        },
    };
    let build = device.accel.fp().cmd_build_acceleration_structures_khr;
    // SAFETY: a recording command buffer; one info and its range.
    attaching.with_info(|info, ranges| unsafe { build(command_buffer, 1, info, ranges) });
}

/// The resident set size of this process in MiB (`VmRSS` in
/// /proc/self/status).
fn resident_mib() -> Result<f64, String> {
    let status = std::fs::read_to_string("/proc/self/status")
        .map_err(|e| format!("/proc/self/status: {e}"))?;
    let kib: f64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .and_then(|v| v.trim().parse().ok())
        .ok_or("/proc/self/status has no VmRSS")?;
    Ok(kib / 1024.0)
}

/// The micromap and the bottom-level structure a soak builds, destroyed
/// and made again every [`Soak::REMAKE_EVERY`] rounds, with their storage.
struct Scene {
    micromap: vk::MicromapEXT,
    blas: vk::AccelerationStructureKHR,
    storage: [Block; 2],
}

impl Scene {
    fn new(device: &Device) -> Result<Self, String> {
        let (micromap, micromap_storage) =
            device.new_micromap(vk::MemoryPropertyFlags::DEVICE_LOCAL)?;
        let (blas, blas_storage) =
            device.structure(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, 1 << 16)?;
        Ok(Self {
            micromap,
            blas,
            storage: [micromap_storage, blas_storage],
        })
    }

    fn destroy(self, device: &Device) {
        device.destroy_micromap(self.micromap);
        // SAFETY: no pending work uses the structure.
        unsafe { device.accel.destroy_acceleration_structure(self.blas, None) };
        for block in self.storage {
            device.free(block);
        }
    }
}

/// A command buffer recorded once and submitted until what it names is
/// destroyed, or [`Soak::RERECORD_EVERY`] rounds have passed.
struct Recorded {
    command_buffer: vk::CommandBuffer,
    stale: bool,
}

/// One soak work's command pool, its valid and its faulty command buffer,
/// and its fence; all of them given back and made again with each remake,
/// so the layer sees command buffers freed and pools destroyed.
struct Rounds {
    pool: vk::CommandPool,
    /// The valid and the faulty command buffer.
    recorded: [Recorded; 2],
    fence: vk::Fence,
}

impl Rounds {
    fn new(device: &Device) -> Result<Self, String> {
        let pool = device.pool()?;
        Ok(Self {
            recorded: Self::allocate(device, pool)?,
            pool,
            fence: device.fence()?,
        })
    }

    fn allocate(device: &Device, pool: vk::CommandPool) -> Result<[Recorded; 2], String> {
        let command_buffers = device.command_buffers(pool, 2)?;
        Ok([0, 1].map(|k| Recorded {
            command_buffer: command_buffers[k],
            stale: true,
        }))
    }

    /// One submission, `round` counting this work's: the faulty command
    /// buffer every [`Soak::FAULTY_EVERY`] rounds, else the valid one,
    /// recorded anew by `record(command_buffer, faulty)` when stale or every
    /// [`Soak::RERECORD_EVERY`] rounds, else resubmitted as it is. Counts
    /// into `recordings` and `submissions` by [valid, faulty]; returns
    /// whether this round ends with a remake.
    fn round(
        &mut self,
        device: &Device,
        round: u64,
        record: impl FnOnce(vk::CommandBuffer, bool) -> Result<(), String>,
        recordings: &mut [u64; 2],
        submissions: &mut [u64; 2],
    ) -> Result<bool, String> {
        let faulty = round % Soak::FAULTY_EVERY == Soak::FAULTY_EVERY - 1;
        let recorded = &mut self.recorded[usize::from(faulty)];
        if recorded.stale || round % Soak::RERECORD_EVERY == Soak::RERECORD_EVERY - 1 {
            device.begin(recorded.command_buffer)?;
            record(recorded.command_buffer, faulty)?;
            device.end(recorded.command_buffer)?;
            recorded.stale = false;
            recordings[usize::from(faulty)] += 1;
        }
        // Before a remake the fence is destroyed signaled, not reset.
        let remake = round % Soak::REMAKE_EVERY == Soak::REMAKE_EVERY - 1;
        if remake {
            device.submit_and_wait_for(recorded.command_buffer, self.fence)?;
        } else {
            device.submit_and_wait(recorded.command_buffer, self.fence)?;
        }
        submissions[usize::from(faulty)] += 1;
        Ok(remake)
    }

    /// Gives the command buffers back, by vkFreeCommandBuffers after an
    /// even remake and by destroying their pool after an odd one, and the
    /// fence (signaled), and makes them again.
    fn remake(&mut self, device: &Device, remake: u64) -> Result<(), String> {
        // SAFETY: the queue is idle: nothing is pending.
        unsafe {
            if remake % 2 == 1 {
                device.device.destroy_command_pool(self.pool, None);
                self.pool = device.pool()?;
            } else {
                let command_buffers = self.recorded.each_ref().map(|r| r.command_buffer);
                device
                    .device
                    .free_command_buffers(self.pool, &command_buffers);
            }
            device.device.destroy_fence(self.fence, None);
        }
        self.recorded = Self::allocate(device, self.pool)?;
        self.fence = device.fence()?;
        Ok(())
    }

    fn destroy(self, device: &Device) {
        // SAFETY: the queue is idle; the command buffers go with the pool.
        unsafe {
            device.device.destroy_fence(self.fence, None);
            device.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// The soak's work on the fake driver: micromap and bottom-level builds.
struct MicromapWork<'a> {
    device: &'a Device,
    inputs: Inputs,
    scene: Option<Scene>,
    scratch: (Block, u64),
    rounds: Rounds,
}

impl<'a> MicromapWork<'a> {
    fn new(device: &'a Device) -> Result<Self, String> {
        Ok(Self {
            inputs: Inputs::new(device)?,
            scene: Some(Scene::new(device)?),
            scratch: device.scratch(1 << 16)?,
            rounds: Rounds::new(device)?,
            device,
        })
    }

    /// One submission; `round` counts this work's submissions.
    fn round(&mut self, round: u64, tally: &mut Tally) -> Result<(), String> {
        let (device, inputs, scratch) = (self.device, &self.inputs, self.scratch.1);
        let scene = self.scene.as_ref().expect("a scene between rounds");
        let record = |command_buffer, faulty| {
            record_micromap_builds(
                device,
                command_buffer,
                inputs,
                scene.micromap,
                scratch,
                faulty,
            );
            barrier(device, command_buffer);
            record_attaching_build(
                device,
                command_buffer,
                inputs,
                scene.micromap,
                scene.blas,
                scratch,
            );
            Ok(())
        };
        let remake = self.rounds.round(
            device,
            round,
            record,
            &mut tally.micromap_recordings,
            &mut tally.micromap_submissions,
        )?;
        if remake {
            self.scene.take().expect("a scene").destroy(device);
            self.scene = Some(Scene::new(device)?);
            self.rounds.remake(device, round / Soak::REMAKE_EVERY)?;
        }
        Ok(())
    }

    fn destroy(mut self) {
        let device = self.device;
        if let Some(scene) = self.scene.take() {
            scene.destroy(device);
        }
        self.rounds.destroy(device);
        device.free(self.scratch.0);
        self.inputs.free(device);
    }
}

/// The soak's work over lavapipe: top-level builds of one instance of a
/// bottom-level structure built once, the instance written by
/// vkCmdUpdateBuffer into device-local memory the application never maps.
/// The faulty instance's flags hold FORCE_OPACITY_MICROMAP_2_STATE on a
/// device without micromaps
/// (VUID-VkAccelerationStructureInstanceKHR-micromap-11580).
struct InstanceWork<'a> {
    device: &'a Device,
    blas: (vk::AccelerationStructureKHR, Block),
    /// The bottom-level build's vertices, mapped.
    vertices: Block,
    instances: Block,
    /// The top-level structure, made again every [`Soak::REMAKE_EVERY`]
    /// rounds, and the size it is made with.
    tlas: Option<(vk::AccelerationStructureKHR, Block)>,
    tlas_size: u64,
    scratch: (Block, u64),
    rounds: Rounds,
}

impl<'a> InstanceWork<'a> {
    fn new(device: &'a Device) -> Result<Self, String> {
        let rounds = Rounds::new(device)?;
        // A bottom-level structure of one triangle, its vertices mapped.
        let (vertices, map) = device.mapped_block(
            36,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        )?;
        let triangle: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        // SAFETY: the mapping holds the buffer's 36 bytes.
        unsafe { map.copy_from_nonoverlapping(triangle.as_ptr(), triangle.len()) };
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR {
                device_address: vertices.address,
            })
            .vertex_stride(12)
            .max_vertex(2)
            .index_type(vk::IndexType::NONE_KHR);
        let blas_geometry = [vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
            .flags(vk::GeometryFlagsKHR::OPAQUE)];
        let mut blas_info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&blas_geometry);
        let [blas_size, blas_scratch_size] = device.build_sizes(&blas_info, 1);
        let blas = device.structure(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, blas_size)?;
        let blas_scratch = device.scratch(blas_scratch_size)?;
        blas_info =
            blas_info
                .dst_acceleration_structure(blas.0)
                .scratch_data(vk::DeviceOrHostAddressKHR {
                    device_address: blas_scratch.1,
                });
        let setup = rounds.recorded[0].command_buffer;
        let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(1)];
        device.begin(setup)?;
        // SAFETY: a recording command buffer; one info and its range.
        unsafe {
            device
                .accel
                .cmd_build_acceleration_structures(setup, &[blas_info], &[&ranges])
        };
        device.end(setup)?;
        device.submit_and_wait(setup, rounds.fence)?;
        device.free(blas_scratch.0);

        let instances = device.block(
            size_of::<vk::AccelerationStructureInstanceKHR>() as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS
                | vk::BufferUsageFlags::TRANSFER_DST,
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        )?;
        let geometry = Self::geometry(instances.address);
        let [tlas_size, scratch_size] = device.build_sizes(
            &vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
                .geometries(std::slice::from_ref(&geometry)),
            1,
        );
        Ok(Self {
            device,
            blas,
            vertices,
            instances,
            tlas: Some(device.structure(vk::AccelerationStructureTypeKHR::TOP_LEVEL, tlas_size)?),
            tlas_size,
            scratch: device.scratch(scratch_size)?,
            rounds,
        })
    }

    /// The one geometry of a top-level build: instances at `address`.
    fn geometry(address: u64) -> vk::AccelerationStructureGeometryKHR<'static> {
        vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::INSTANCES)
            .geometry(vk::AccelerationStructureGeometryDataKHR {
                instances: vk::AccelerationStructureGeometryInstancesDataKHR::default().data(
                    vk::DeviceOrHostAddressConstKHR {
                        device_address: address,
                    },
                ),
            })
    }

    /// One submission; `round` counts this work's submissions.
    fn round(&mut self, round: u64, tally: &mut Tally) -> Result<(), String> {
        let device = self.device;
        let address_info = vk::AccelerationStructureDeviceAddressInfoKHR::default()
            .acceleration_structure(self.blas.0);
        let tlas = self.tlas.as_ref().expect("a top-level structure").0;
        let (instances, scratch) = (self.instances, self.scratch.1);
        let record = |command_buffer, faulty| {
            // SAFETY: a structure of this device.
            let reference = unsafe {
                device
                    .accel
                    .get_acceleration_structure_device_address(&address_info)
            };
            let flags = if faulty {
                vk::GeometryInstanceFlagsKHR::FORCE_OPACITY_MICROMAP_2_STATE_EXT
            } else {
                vk::GeometryInstanceFlagsKHR::empty()
            };
            let geometry = Self::geometry(instances.address);
            let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
                .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                .geometries(std::slice::from_ref(&geometry))
                .dst_acceleration_structure(tlas)
                .scratch_data(vk::DeviceOrHostAddressKHR {
                    device_address: scratch,
                });
            let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(1)];
            // SAFETY (each command): a recording command buffer; the
            // instance buffer has TRANSFER_DST and holds one instance.
            unsafe {
                device.device.cmd_update_buffer(
                    command_buffer,
                    instances.buffer,
                    0,
                    &word_bytes(&instance_words(reference, flags)),
                )
            };
            barrier(device, command_buffer);
            // SAFETY: as above; one info and its range.
            unsafe {
                device
                    .accel
                    .cmd_build_acceleration_structures(command_buffer, &[info], &[&ranges])
            };
            Ok(())
        };
        let remake = self.rounds.round(
            device,
            round,
            record,
            &mut tally.instance_recordings,
            &mut tally.instance_submissions,
        )?;
        if remake {
            let (tlas, storage) = self.tlas.take().expect("a top-level structure");
            // SAFETY: the queue is idle; nothing pending uses it.
            unsafe { device.accel.destroy_acceleration_structure(tlas, None) };
            device.free(storage);
            self.tlas = Some(
                device.structure(vk::AccelerationStructureTypeKHR::TOP_LEVEL, self.tlas_size)?,
            );
            self.rounds.remake(device, round / Soak::REMAKE_EVERY)?;
        }
        Ok(())
    }

    fn destroy(mut self) {
        let device = self.device;
        // SAFETY: the queue is idle; nothing pending uses these.
        unsafe {
            if let Some((tlas, storage)) = self.tlas.take() {
                device.accel.destroy_acceleration_structure(tlas, None);
                device.free(storage);
            }
            device
                .accel
                .destroy_acceleration_structure(self.blas.0, None);
        }
        self.rounds.destroy(device);
        for block in [self.blas.1, self.vertices, self.instances, self.scratch.0] {
            device.free(block);
        }
    }
}

/// What a soak did, [valid, faulty] each.
#[derive(Default, Debug)]
struct Tally {
    micromap_recordings: [u64; 2],
    micromap_submissions: [u64; 2],
    instance_recordings: [u64; 2],
    instance_submissions: [u64; 2],
}

impl Tally {
    fn submissions(&self) -> u64 {
        self.micromap_submissions.iter().sum::<u64>()
            + self.instance_submissions.iter().sum::<u64>()
    }

    /// The findings the planted faults make: 07516 at each faulty
    /// micromap recording (a recording of the faulty top-level command
    /// buffer plants nothing at recording); the data past its buffer at
    /// each faulty micromap submission, read back each time; the
    /// instance's flags at each faulty top-level submission.
    fn expected(&self) -> u64 {
        self.micromap_recordings[1] + self.micromap_submissions[1] + self.instance_submissions[1]
    }
}

/// The soak's shape.
struct Soak;

impl Soak {
    /// One round in this many is faulty: the fifth and the tenth of each
    /// remake's ten, so the faulty command buffer is recorded fresh once
    /// and, unless [`Soak::RERECORD_EVERY`] says otherwise, resubmitted
    /// once.
    const FAULTY_EVERY: u64 = 5;
    /// A command buffer is recorded anew every this many rounds; in
    /// between it is resubmitted as recorded.
    const RERECORD_EVERY: u64 = 7;
    /// The micromap, the structures, the command buffers (freed, or with
    /// their pool) and the fence are destroyed and made again every this
    /// many rounds: often, so that state kept per object (about 1 KiB each
    /// in the leaks the soak found) adds up past the memory bound even
    /// beside lavapipe's 70 MiB.
    const REMAKE_EVERY: u64 = 10;
    /// With lavapipe, one submission in this many is a top-level build.
    const INSTANCE_EVERY: u64 = 10;
}

/// `soak`: see the module documentation.
fn soak(vulkan: &Vulkan, submissions: u64, lavapipe: bool) -> Result<bool, String> {
    let fake = Device::new(vulkan, vulkan.fake_device()?, true)?;
    let lavapipe = if lavapipe {
        Some(Device::new(vulkan, vulkan.lavapipe()?, false)?)
    } else {
        None
    };
    let mut micromaps = MicromapWork::new(&fake)?;
    let mut instances = lavapipe.as_ref().map(InstanceWork::new).transpose()?;
    let mut tally = Tally::default();
    let mut micromap_rounds = 0;
    let mut instance_rounds = 0;
    let mut at_tenth = None;
    let started = Instant::now();
    for n in 0..submissions {
        if n == submissions / 10 {
            at_tenth = Some(resident_mib()?);
        }
        match instances.as_mut() {
            Some(work) if n % Soak::INSTANCE_EVERY == Soak::INSTANCE_EVERY / 2 => {
                work.round(instance_rounds, &mut tally)?;
                instance_rounds += 1;
            }
            _ => {
                micromaps.round(micromap_rounds, &mut tally)?;
                micromap_rounds += 1;
            }
        }
    }
    let at_end = resident_mib()?;
    let at_tenth = at_tenth.unwrap_or(at_end);
    let seconds = started.elapsed().as_secs_f64();
    if let Some(work) = instances {
        work.destroy();
    }
    micromaps.destroy();
    fake.destroy();
    if let Some(device) = lavapipe {
        device.destroy();
    }
    let findings = vulkan.findings.total();
    let expected = tally.expected();
    let ratio = at_end / at_tenth;
    let held = ratio <= MEMORY_BOUND;
    let by_id: BTreeMap<String, u64> =
        lock(&vulkan.findings.counts)
            .iter()
            .fold(BTreeMap::new(), |mut by_id, ((id, _), n)| {
                *by_id.entry(id.clone()).or_insert(0) += n;
                by_id
            });
    eprintln!("omm-stress: soak: {seconds:.1} s; {tally:?}; findings by id {by_id:?}");
    println!(
        "soak: {} submissions ({} micromap and BLAS over the fake driver, {} TLAS over lavapipe), \
         {findings} findings ({expected} expected), resident memory {at_tenth:.1} MiB at 10% and \
         {at_end:.1} MiB at the end ({ratio:.3}x, bound {MEMORY_BOUND}x): {}",
        tally.submissions(),
        tally.micromap_submissions.iter().sum::<u64>(),
        tally.instance_submissions.iter().sum::<u64>(),
        match (held, findings == expected) {
            (true, true) => "passed",
            (false, _) => "FAILED, memory grew",
            (true, false) => "FAILED, findings differ",
        }
    );
    Ok(held && findings == expected)
}

/// One worker thread's objects in `threads`.
struct Worker {
    pool: vk::CommandPool,
    command_buffer: vk::CommandBuffer,
    spare: vk::CommandBuffer,
    fence: vk::Fence,
    micromap: (vk::MicromapEXT, Block),
    scratch: (Block, u64),
}

impl Worker {
    /// The worker's objects, its micromap's storage in memory with
    /// `micromap_memory`.
    fn new(device: &Device, micromap_memory: vk::MemoryPropertyFlags) -> Result<Self, String> {
        let pool = device.pool()?;
        let command_buffers = device.command_buffers(pool, 2)?;
        Ok(Self {
            pool,
            command_buffer: command_buffers[0],
            spare: command_buffers[1],
            fence: device.fence()?,
            micromap: device.new_micromap(micromap_memory)?,
            scratch: device.scratch(4096)?,
        })
    }

    /// `rounds` times: record the builds of a faulty round, submit, wait.
    fn run(&self, device: &Device, inputs: &Inputs, rounds: u64) -> Result<(), String> {
        // The callback records into the spare command buffer, which stays
        // in the recording state while this thread works.
        device.begin(self.spare)?;
        SPARE.set(Some((self.spare, self.fence)));
        for _ in 0..rounds {
            device.begin(self.command_buffer)?;
            record_micromap_builds(
                device,
                self.command_buffer,
                inputs,
                self.micromap.0,
                self.scratch.1,
                true,
            );
            device.end(self.command_buffer)?;
            device.submit_and_wait(self.command_buffer, self.fence)?;
        }
        SPARE.set(None);
        device.end(self.spare)
    }

    fn destroy(self, device: &Device) {
        device.destroy_micromap(self.micromap.0);
        device.free(self.micromap.1);
        device.free(self.scratch.0);
        // SAFETY: the queue is idle; the command buffers go with the pool.
        unsafe {
            device.device.destroy_fence(self.fence, None);
            device.device.destroy_command_pool(self.pool, None);
        }
    }
}

/// Runs `work` for each of `count` threads at once; aborts the process if
/// they have not all finished within [`DEADLOCK_BOUND`] (a deadlock).
fn on_threads<T: Sync>(
    items: &[T],
    work: impl Fn(&T) -> Result<(), String> + Sync,
) -> Result<(), String> {
    let (disarm, armed) = std::sync::mpsc::channel::<()>();
    let watchdog = std::thread::spawn(move || {
        if let Err(std::sync::mpsc::RecvTimeoutError::Timeout) = armed.recv_timeout(DEADLOCK_BOUND)
        {
            eprintln!(
                "omm-stress: the threads did not finish within {DEADLOCK_BOUND:?}: a deadlock"
            );
            // Not exit: its handlers could wait on a lock a stuck thread holds.
            std::process::abort();
        }
    });
    let outcome = std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .iter()
            .map(|item| scope.spawn(|| work(item)))
            .collect();
        handles
            .into_iter()
            .try_for_each(|handle| handle.join().map_err(|_| "a thread panicked".to_string())?)
    });
    let _ = disarm.send(());
    let _ = watchdog.join();
    outcome
}

/// `threads`: see the module documentation.
fn threads(vulkan: &Vulkan, count: usize, rounds: u64, reenter: bool) -> Result<(), String> {
    vulkan
        .findings
        .by_command_buffer
        .store(true, Ordering::Relaxed);
    let device = Device::new(vulkan, vulkan.fake_device()?, true)?;
    let inputs = Inputs::new(&device)?;
    let workers = (0..count)
        .map(|_| Worker::new(&device, vk::MemoryPropertyFlags::DEVICE_LOCAL))
        .collect::<Result<Vec<_>, _>>()?;
    let target = device.block(
        256,
        vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        vk::MemoryPropertyFlags::DEVICE_LOCAL,
    )?;
    if reenter {
        let f = |name: &CStr| {
            // SAFETY: a live device; a NUL-terminated name.
            unsafe {
                vulkan
                    .base
                    .instance
                    .get_device_proc_addr(device.device.handle(), name.as_ptr())
            }
            .ok_or_else(|| format!("no {name:?}"))
        };
        type Void = unsafe extern "system" fn();
        // SAFETY (each): the command of that name, as its own type.
        let reentry = Reentry {
            device: device.device.handle(),
            get_address: unsafe {
                std::mem::transmute::<Void, vk::PFN_vkGetBufferDeviceAddress>(f(
                    c"vkGetBufferDeviceAddress",
                )?)
            },
            fence_status: unsafe {
                std::mem::transmute::<Void, vk::PFN_vkGetFenceStatus>(f(c"vkGetFenceStatus")?)
            },
            fill: unsafe {
                std::mem::transmute::<Void, vk::PFN_vkCmdFillBuffer>(f(c"vkCmdFillBuffer")?)
            },
            buffer: target.buffer,
        };
        let _ = vulkan.findings.reentry.set(reentry);
    }
    // The threads start their rounds together, so their calls overlap.
    let start = std::sync::Barrier::new(count);
    on_threads(&workers, |worker| {
        start.wait();
        worker.run(&device, &inputs, rounds)
    })?;
    let thread_of: BTreeMap<u64, usize> = workers
        .iter()
        .enumerate()
        .map(|(t, w)| (w.command_buffer.as_raw(), t))
        .collect();
    let mut per_thread = vec![BTreeMap::<String, u64>::new(); count];
    let mut elsewhere = BTreeMap::<String, u64>::new();
    for ((id, command_buffer), n) in lock(&vulkan.findings.counts).iter() {
        let counts = match thread_of.get(command_buffer) {
            Some(&t) => &mut per_thread[t],
            None => &mut elsewhere,
        };
        *counts.entry(id.clone()).or_insert(0) += n;
    }
    for worker in workers {
        worker.destroy(&device);
    }
    device.free(target);
    inputs.free(&device);
    device.destroy();
    println!(
        "{}",
        json!({
            "threads": count,
            "rounds": rounds,
            "per_thread": per_thread,
            "elsewhere": elsewhere,
            "reentered": vulkan.findings.reentered.load(Ordering::Relaxed),
        })
    );
    Ok(())
}

/// Calls recorded between command buffer resets in `overhead`: a build is
/// kept until its command buffer is reset, so the batches bound what the
/// layer holds.
const OVERHEAD_BATCH: u32 = 1000;

/// `overhead`: see the module documentation.
fn overhead(vulkan: &Vulkan, count: usize, iterations: u32) -> Result<(), String> {
    let device = Device::new(vulkan, vulkan.fake_device()?, true)?;
    // The inputs in mapped memory: the triangle array at 0, the data at
    // 256, the opacity indices at 512, the vertices at 768.
    let (input, map) = device.mapped_block(
        1024,
        vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
            | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
    )?;
    let triangles = triangle_bytes(&[(0, 1, 1), (1, 1, 1)]);
    let indices: Vec<u8> = [0u32, 1].iter().flat_map(|i| i.to_le_bytes()).collect();
    // SAFETY: the mapping holds 1024 bytes; each write stays below.
    unsafe {
        map.copy_from_nonoverlapping(triangles.as_ptr(), triangles.len());
        map.add(256).write_bytes(0xA5, 2);
        map.add(512)
            .copy_from_nonoverlapping(indices.as_ptr(), indices.len());
    }
    let inputs = Inputs {
        triangles: input,
        triangles_past_data: input,
        data: Block {
            address: input.address + 256,
            ..input
        },
        indices: Block {
            address: input.address + 512,
            ..input
        },
        vertices: Block {
            address: input.address + 768,
            ..input
        },
    };
    let host_triangles = triangle_bytes(&[(0, 1, 1), (1, 1, 1)]);
    let host_data = [0xA5u8; 2];
    let workers = (0..count)
        .map(|_| {
            // Host builds write the micromap from the host.
            let worker = Worker::new(&device, vulkan::HOST_MAPPABLE)?;
            let blas = device.structure(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, 1 << 16)?;
            Ok((worker, blas))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let start = std::sync::Barrier::new(count);
    let totals = Mutex::new([0f64; 3]);
    on_threads(&workers, |(worker, blas)| {
        let command_buffer = worker.command_buffer;
        let micromap = worker.micromap.0;
        let scratch = worker.scratch.1;
        let mut host_scratch = vec![0u8; 4096];
        let host_info = vk::MicromapBuildInfoEXT {
            triangle_array: vk::DeviceOrHostAddressConstKHR {
                host_address: host_triangles.as_ptr().cast(),
            },
            data: vk::DeviceOrHostAddressConstKHR {
                host_address: host_data.as_ptr().cast(),
            },
            scratch_data: vk::DeviceOrHostAddressKHR {
                host_address: host_scratch.as_mut_ptr().cast(),
            },
            ..micromap_build(micromap, 0, 0, 0)
        };
        let device_info = micromap_build(
            micromap,
            inputs.triangles.address,
            inputs.data.address,
            scratch,
        );
        let build_micromaps = device.omm().fp().build_micromaps_ext;
        let handle = device.device.handle();
        // Each call's total time over the batches; recording restarts
        // between batches, untimed.
        let mut ns = [0f64; 3];
        start.wait();
        for (k, total) in ns.iter_mut().enumerate() {
            let mut left = iterations;
            while left > 0 {
                let batch = left.min(OVERHEAD_BATCH);
                device.begin(command_buffer)?;
                let timer = Instant::now();
                for _ in 0..batch {
                    match k {
                        0 => record_micromap_build(&device, command_buffer, &device_info),
                        // SAFETY: one info whose host addresses are live.
                        1 => unsafe {
                            let _ = build_micromaps(
                                handle,
                                vk::DeferredOperationKHR::null(),
                                1,
                                &host_info,
                            );
                        },
                        _ => record_attaching_build(
                            &device,
                            command_buffer,
                            &inputs,
                            micromap,
                            blas.0,
                            scratch,
                        ),
                    }
                }
                *total += timer.elapsed().as_nanos() as f64;
                device.end(command_buffer)?;
                left -= batch;
            }
        }
        let mut totals = lock(&totals);
        for (sum, own) in totals.iter_mut().zip(ns) {
            *sum += own;
        }
        Ok(())
    })?;
    let calls = f64::from(iterations) * count as f64;
    let totals = *lock(&totals);
    for (worker, (blas, storage)) in workers {
        // SAFETY: nothing was submitted.
        unsafe { device.accel.destroy_acceleration_structure(blas, None) };
        device.free(storage);
        worker.destroy(&device);
    }
    device.free(input);
    device.destroy();
    println!(
        "{}",
        json!({
            "threads": count,
            "iterations": iterations,
            "ns_per_call": {
                "cmd_build_micromaps": totals[0] / calls,
                "build_micromaps": totals[1] / calls,
                "cmd_build_acceleration_structures": totals[2] / calls,
            },
            "findings": vulkan.findings.total(),
        })
    );
    Ok(())
}

/// The command line's options.
struct Options {
    layers: Vec<CString>,
    submissions: u64,
    lavapipe: bool,
    threads: usize,
    rounds: u64,
    reenter: bool,
    iterations: u32,
}

const USAGE_TEXT: &str = "usage: omm-stress soak [--submissions N] [--lavapipe] | \
    threads --threads T [--rounds R] [--reenter] | overhead --threads T [--iterations N]; \
    each with [--layer NAME]...";

fn number<T: std::str::FromStr>(arg: &str, value: Option<&String>) -> Result<T, String> {
    value
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| format!("{arg} takes a number; {USAGE_TEXT}"))
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        layers: Vec::new(),
        submissions: 100_000,
        lavapipe: false,
        threads: 1,
        rounds: 4,
        reenter: false,
        iterations: 10_000,
    };
    let mut rest = args.iter();
    while let Some(arg) = rest.next() {
        match arg.as_str() {
            "--layer" => {
                let name = rest.next().ok_or(USAGE_TEXT)?;
                options
                    .layers
                    .push(CString::new(name.as_str()).map_err(|e| format!("{name:?}: {e}"))?);
            }
            "--submissions" => options.submissions = number(arg, rest.next())?,
            "--lavapipe" => options.lavapipe = true,
            "--threads" => options.threads = number(arg, rest.next())?,
            "--rounds" => options.rounds = number(arg, rest.next())?,
            "--reenter" => options.reenter = true,
            "--iterations" => options.iterations = number(arg, rest.next())?,
            _ => return Err(format!("unexpected argument {arg:?}; {USAGE_TEXT}")),
        }
    }
    if options.threads == 0 || options.iterations == 0 {
        return Err(format!(
            "--threads and --iterations must be positive; {USAGE_TEXT}"
        ));
    }
    Ok(options)
}

fn run(args: &[String]) -> Result<bool, String> {
    let (mode, rest) = args.split_first().ok_or(USAGE_TEXT)?;
    let options = parse(rest)?;
    let vulkan = Vulkan::new(&options.layers)?;
    let passed = match mode.as_str() {
        "soak" => soak(&vulkan, options.submissions, options.lavapipe)?,
        "threads" => {
            threads(&vulkan, options.threads, options.rounds, options.reenter)?;
            true
        }
        "overhead" => {
            overhead(&vulkan, options.threads, options.iterations)?;
            true
        }
        _ => return Err(format!("unknown mode {mode:?}; {USAGE_TEXT}")),
    };
    vulkan.destroy();
    Ok(passed)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("omm-stress: {e}");
            ExitCode::FAILURE
        }
    }
}
