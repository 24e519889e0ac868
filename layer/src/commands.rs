//! Command pools and command buffers: what the checks need to know of a
//! command buffer when a `vkCmd*` command is recorded into it (recording or
//! not, its pool's queue flags, inside a render pass, a video coding scope or
//! between suspended render pass instances), the device builds recorded
//! into it whose contents are checked at submission, and the secondary
//! command buffers it executes.
//!
//! Command buffers are recorded on many threads at once, so their state is
//! kept apart from the device's checked state, in a map split into shards
//! by handle: recording on different command buffers rarely waits on one
//! lock, and no lock here is held while the next layer runs or a check runs.

#![allow(unsafe_code)]

use foldhash::{HashMap, HashSet};
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, PoisonError};

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::build_inputs::DeviceBuild;
use ommcheck::model::CommandBuffer;

use crate::abi::dispatch_key;
use crate::dispatch::next_fns::DeviceFns;
use crate::dispatch::submissions::KeptBuild;
use crate::dispatch::DeviceData;
use crate::intercept::{as_void, device_and, guarded};
use crate::read;
use crate::readback::Plan;
use crate::shadow::Transfer;

/// This layer's function for a command-pool, command-buffer or submission
/// command name.
pub fn intercept(name: &std::ffi::CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkCreateCommandPool" => as_void(create_command_pool as vk::PFN_vkCreateCommandPool),
        b"vkDestroyCommandPool" => as_void(destroy_command_pool as vk::PFN_vkDestroyCommandPool),
        b"vkResetCommandPool" => as_void(reset_command_pool as vk::PFN_vkResetCommandPool),
        b"vkAllocateCommandBuffers" => {
            as_void(allocate_command_buffers as vk::PFN_vkAllocateCommandBuffers)
        }
        b"vkFreeCommandBuffers" => as_void(free_command_buffers as vk::PFN_vkFreeCommandBuffers),
        b"vkBeginCommandBuffer" => as_void(begin_command_buffer as vk::PFN_vkBeginCommandBuffer),
        b"vkEndCommandBuffer" => as_void(end_command_buffer as vk::PFN_vkEndCommandBuffer),
        b"vkResetCommandBuffer" => as_void(reset_command_buffer as vk::PFN_vkResetCommandBuffer),
        b"vkCmdBeginRenderPass" => as_void(cmd_begin_render_pass as vk::PFN_vkCmdBeginRenderPass),
        b"vkCmdBeginRenderPass2" => {
            as_void(cmd_begin_render_pass2 as vk::PFN_vkCmdBeginRenderPass2)
        }
        b"vkCmdBeginRenderPass2KHR" => {
            as_void(cmd_begin_render_pass2_khr as vk::PFN_vkCmdBeginRenderPass2)
        }
        b"vkCmdEndRenderPass" => as_void(cmd_end_render_pass as vk::PFN_vkCmdEndRenderPass),
        b"vkCmdEndRenderPass2" => as_void(cmd_end_render_pass2 as vk::PFN_vkCmdEndRenderPass2),
        b"vkCmdEndRenderPass2KHR" => {
            as_void(cmd_end_render_pass2_khr as vk::PFN_vkCmdEndRenderPass2)
        }
        b"vkCmdBeginRendering" => as_void(cmd_begin_rendering as vk::PFN_vkCmdBeginRendering),
        b"vkCmdBeginRenderingKHR" => {
            as_void(cmd_begin_rendering_khr as vk::PFN_vkCmdBeginRendering)
        }
        b"vkCmdEndRendering" => as_void(cmd_end_rendering as vk::PFN_vkCmdEndRendering),
        b"vkCmdEndRenderingKHR" => as_void(cmd_end_rendering_khr as vk::PFN_vkCmdEndRendering),
        b"vkCmdBeginVideoCodingKHR" => {
            as_void(cmd_begin_video_coding as vk::PFN_vkCmdBeginVideoCodingKHR)
        }
        b"vkCmdEndVideoCodingKHR" => {
            as_void(cmd_end_video_coding as vk::PFN_vkCmdEndVideoCodingKHR)
        }
        b"vkCmdExecuteCommands" => as_void(cmd_execute_commands as vk::PFN_vkCmdExecuteCommands),
        _ => None,
    }
}

/// What a submission of a command buffer runs that the content checks
/// follow, in recording order.
#[derive(Clone, Debug)]
pub enum Recorded {
    Build(KeptBuild),
    Transfer(Arc<Transfer>),
    /// `vkCmdExecuteCommands` ran this secondary command buffer.
    Executes(u64),
}

/// What the layer keeps of one command buffer.
#[derive(Clone, Debug, Default)]
struct Tracked {
    secondary: bool,
    model: CommandBuffer,
    /// The render pass instance begun by vkCmdBeginRendering has
    /// VK_RENDERING_SUSPENDING_BIT: its end suspends it.
    rendering_suspends: bool,
    /// Builds, transfers and executed secondaries, in recording order
    /// (kept from the content tier on).
    recorded: Vec<Recorded>,
}

impl Tracked {
    /// The initial state (after allocation or a reset): nothing recorded.
    fn reset(&mut self) {
        self.model.recording = false;
        self.model.in_render_pass = false;
        self.model.in_video_coding = false;
        self.model.suspended = false;
        self.rendering_suspends = false;
        self.recorded.clear();
    }
}

/// Command buffers by handle, in shards each behind its own lock.
struct CommandBuffers {
    shards: [Mutex<HashMap<u64, Tracked>>; SHARDS],
}

const SHARDS: usize = 16;

static COMMAND_BUFFERS: LazyLock<CommandBuffers> = LazyLock::new(|| CommandBuffers {
    shards: std::array::from_fn(|_| Mutex::new(HashMap::default())),
});

/// Command pools by (device dispatch key, pool handle): the queue flags of
/// the pool's family and the command buffers allocated from it.
#[derive(Default)]
struct Pool {
    queue_flags: u32,
    command_buffers: HashSet<u64>,
}

static POOLS: LazyLock<Mutex<HashMap<(usize, u64), Pool>>> =
    LazyLock::new(|| Mutex::new(HashMap::default()));

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // The data behind these locks is plain maps updated in single steps;
    // nothing that can panic runs while they are held.
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

impl CommandBuffers {
    fn shard(&self, handle: u64) -> MutexGuard<'_, HashMap<u64, Tracked>> {
        // Handles are pointers: the low bits are alignment, the next ones spread.
        lock(&self.shards[(handle >> 4) as usize % SHARDS])
    }

    /// Runs `update` on a tracked command buffer; untracked ones are left alone.
    fn update(&self, handle: u64, update: impl FnOnce(&mut Tracked)) {
        if let Some(tracked) = self.shard(handle).get_mut(&handle) {
            update(tracked);
        }
    }
}

/// The command buffer as the checks see it now. One the layer did not see
/// allocated (created before the layer was loaded, or through another path)
/// is taken to be recording on a compute-capable queue outside any render
/// pass, so no rule fires on a guess.
pub fn model(command_buffer: vk::CommandBuffer) -> CommandBuffer {
    let handle = command_buffer.as_raw();
    COMMAND_BUFFERS.shard(handle).get(&handle).map_or_else(
        || CommandBuffer {
            handle,
            ..CommandBuffer::default()
        },
        |tracked| tracked.model.clone(),
    )
}

/// Keeps what `command_buffer` records for the content checks at submission.
pub fn keep(command_buffer: vk::CommandBuffer, recorded_in: &CommandBuffer, recorded: Recorded) {
    let handle = command_buffer.as_raw();
    COMMAND_BUFFERS
        .shard(handle)
        .entry(handle)
        .or_insert_with(|| Tracked {
            model: recorded_in.clone(),
            ..Tracked::default()
        })
        .recorded
        .push(recorded);
}

/// Keeps a device build recorded into `command_buffer` for the checks of
/// its contents, recording before it the copies of its inputs that GPU
/// readback needs (see [`crate::readback::plan`]); the caller records the
/// build itself next.
pub fn keep_build(
    data: &DeviceData,
    command_buffer: vk::CommandBuffer,
    recorded_in: &CommandBuffer,
    build: DeviceBuild,
) {
    let planned = crate::intercept::track_with(data, build.function(), |state| {
        let unplaced = crate::readback::unplaced_messages(state, command_buffer, &build);
        (
            crate::readback::plan(data, state, command_buffer, &build),
            unplaced,
        )
    });
    let plan = planned.map(|(plan, unplaced)| {
        if !unplaced.is_empty() {
            data.instance.reporter.deliver(&unplaced, false);
        }
        plan
    });
    let (readback, not_read_back) = match plan {
        Some(Plan::ReadBack(readback)) => (Some(readback), None),
        Some(Plan::NotReadBack(key, reason)) => (None, Some((key, reason))),
        Some(Plan::AtSubmission) | None => (None, None),
    };
    let kept = KeptBuild {
        recorded_in: recorded_in.clone(),
        build: Arc::new(build),
        readback,
        not_read_back,
    };
    keep(command_buffer, recorded_in, Recorded::Build(kept));
}

/// What a submission of `command_buffer` runs, in order: its own builds
/// and transfers, with those of each secondary command buffer it executes
/// where it executes them. Each entry carries the command buffer that
/// recorded it.
pub fn run_by(command_buffer: vk::CommandBuffer) -> Vec<(u64, Recorded)> {
    let handle = command_buffer.as_raw();
    let own = match COMMAND_BUFFERS.shard(handle).get(&handle) {
        Some(tracked) => tracked.recorded.clone(),
        None => return Vec::new(),
    };
    let mut run = Vec::with_capacity(own.len());
    for recorded in own {
        match recorded {
            Recorded::Executes(secondary) => {
                // A secondary executes no further secondaries (without
                // VK_EXT_nested_command_buffer, which the layer does not follow).
                if let Some(tracked) = COMMAND_BUFFERS.shard(secondary).get(&secondary) {
                    run.extend(
                        tracked
                            .recorded
                            .iter()
                            .filter(|r| !matches!(r, Recorded::Executes(_)))
                            .cloned()
                            .map(|r| (secondary, r)),
                    );
                }
            }
            other => run.push((handle, other)),
        }
    }
    run
}

/// Drops what the command buffers of `device` keep (their readback
/// memory among it), before the device is destroyed below.
pub fn forget_device(device: vk::Device) {
    let key = device_key(device);
    let pools: Vec<(usize, u64)> = lock(&POOLS)
        .keys()
        .filter(|(k, _)| *k == key)
        .copied()
        .collect();
    // The device's checked state goes with it: only the pools' own maps
    // need emptying.
    for (_, pool) in pools {
        forget_pool(device, vk::CommandPool::from_raw(pool));
    }
}

/// The device's dispatch key, for keying its pools.
fn device_key(device: vk::Device) -> usize {
    // SAFETY: a device handle the application passed, which the loader created.
    unsafe { dispatch_key(device.as_raw()) }.unwrap_or(0)
}

/// `vkCreateCommandPool`: the pool's queue family decides its command
/// buffers' queue flags.
unsafe extern "system" fn create_command_pool(
    device: vk::Device,
    create_info: *const vk::CommandPoolCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    pool_out: *mut vk::CommandPool,
) -> vk::Result {
    guarded(
        "vkCreateCommandPool",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) = device_and(device, |f| f.commands.create_command_pool) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, create_info, allocator, pool_out) };
            // SAFETY: the create info is valid (the API's requirement); on
            // success the next layer wrote the handle.
            let (info, pool) = unsafe { (read::value(create_info), read::value(pool_out)) };
            if let (vk::Result::SUCCESS, Some(info), Some(pool)) = (result, info, pool) {
                // An unknown family (the next layer could not say) supports
                // everything, so no rule fires on a guess.
                let queue_flags = data
                    .queue_family_flags
                    .get(info.queue_family_index as usize)
                    .map_or(u32::MAX, |flags| flags.as_raw());
                lock(&POOLS).insert(
                    (device_key(device), pool.as_raw()),
                    Pool {
                        queue_flags,
                        command_buffers: HashSet::default(),
                    },
                );
            }
            result
        },
    )
}

/// Forgets the command buffers of a pool destroyed; returns their handles.
fn forget_pool(device: vk::Device, pool: vk::CommandPool) -> Vec<u64> {
    let removed = lock(&POOLS).remove(&(device_key(device), pool.as_raw()));
    let handles: Vec<u64> = removed
        .into_iter()
        .flat_map(|p| p.command_buffers)
        .collect();
    for &handle in &handles {
        COMMAND_BUFFERS.shard(handle).remove(&handle);
    }
    handles
}

/// `vkDestroyCommandPool`: its command buffers are freed with it.
unsafe extern "system" fn destroy_command_pool(
    device: vk::Device,
    pool: vk::CommandPool,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyCommandPool", (), || {
        let Some((data, next)) = device_and(device, |f| f.commands.destroy_command_pool) else {
            return;
        };
        // As vkFreeCommandBuffers does for each: without it, what each
        // command buffer last recorded stayed in the checked state for the
        // device's life (found by `cargo xtask soak`).
        for handle in forget_pool(device, pool) {
            forget_recording(&data, handle);
        }
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, pool, allocator) };
    })
}

/// `vkResetCommandPool`: every command buffer of the pool goes back to the
/// initial state.
unsafe extern "system" fn reset_command_pool(
    device: vk::Device,
    pool: vk::CommandPool,
    flags: vk::CommandPoolResetFlags,
) -> vk::Result {
    guarded("vkResetCommandPool", vk::Result::ERROR_UNKNOWN, || {
        let Some((data, next)) = device_and(device, |f| f.commands.reset_command_pool) else {
            return vk::Result::ERROR_UNKNOWN;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, pool, flags) };
        if result == vk::Result::SUCCESS {
            let members: Vec<u64> = lock(&POOLS)
                .get(&(device_key(device), pool.as_raw()))
                .map(|p| p.command_buffers.iter().copied().collect())
                .unwrap_or_default();
            for handle in members {
                COMMAND_BUFFERS.update(handle, Tracked::reset);
                forget_recording(&data, handle);
            }
        }
        result
    })
}

/// `vkAllocateCommandBuffers`: each new command buffer is tracked in the
/// initial state with its pool's queue flags.
unsafe extern "system" fn allocate_command_buffers(
    device: vk::Device,
    allocate_info: *const vk::CommandBufferAllocateInfo<'_>,
    command_buffers_out: *mut vk::CommandBuffer,
) -> vk::Result {
    guarded(
        "vkAllocateCommandBuffers",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((_, next)) = device_and(device, |f| f.commands.allocate_command_buffers)
            else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(device, allocate_info, command_buffers_out) };
            // SAFETY: the allocate info is valid (the API's requirement).
            let Some(info) = (unsafe { read::value(allocate_info) }) else {
                return result;
            };
            if result != vk::Result::SUCCESS {
                return result;
            }
            // SAFETY: on success the next layer wrote `commandBufferCount` handles.
            let handles =
                unsafe { read::array(command_buffers_out.cast_const(), info.command_buffer_count) };
            let pool_key = (device_key(device), info.command_pool.as_raw());
            let mut pools = lock(&POOLS);
            let pool = pools.entry(pool_key).or_insert_with(|| Pool {
                queue_flags: u32::MAX,
                ..Pool::default()
            });
            for command_buffer in handles {
                let handle = command_buffer.as_raw();
                pool.command_buffers.insert(handle);
                let tracked = Tracked {
                    secondary: info.level == vk::CommandBufferLevel::SECONDARY,
                    model: CommandBuffer {
                        handle,
                        recording: false,
                        queue_flags: pool.queue_flags,
                        ..CommandBuffer::default()
                    },
                    ..Tracked::default()
                };
                COMMAND_BUFFERS.shard(handle).insert(handle, tracked);
            }
            result
        },
    )
}

/// `vkFreeCommandBuffers`.
unsafe extern "system" fn free_command_buffers(
    device: vk::Device,
    pool: vk::CommandPool,
    count: u32,
    command_buffers: *const vk::CommandBuffer,
) {
    guarded("vkFreeCommandBuffers", (), || {
        let Some((data, next)) = device_and(device, |f| f.commands.free_command_buffers) else {
            return;
        };
        // SAFETY: the array holds `count` handles (the API's requirement).
        let handles = unsafe { read::array(command_buffers, count) };
        {
            let mut pools = lock(&POOLS);
            let mut members = pools.get_mut(&(device_key(device), pool.as_raw()));
            for command_buffer in handles {
                let handle = command_buffer.as_raw();
                if let Some(members) = members.as_mut() {
                    members.command_buffers.remove(&handle);
                }
                COMMAND_BUFFERS.shard(handle).remove(&handle);
            }
        }
        // Outside the pools' lock: the device state has its own.
        for command_buffer in handles {
            forget_recording(&data, command_buffer.as_raw());
        }
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, pool, count, command_buffers) };
    })
}

/// `vkBeginCommandBuffer`: the command buffer is reset and recording; a
/// secondary one that continues a render pass is inside it.
unsafe extern "system" fn begin_command_buffer(
    command_buffer: vk::CommandBuffer,
    begin_info: *const vk::CommandBufferBeginInfo<'_>,
) -> vk::Result {
    guarded(
        "vkBeginCommandBuffer",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) =
                device_and(command_buffer, |f| f.commands.begin_command_buffer)
            else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(command_buffer, begin_info) };
            if result == vk::Result::SUCCESS {
                forget_recording(&data, command_buffer.as_raw());
                // SAFETY: the begin info is valid (the API's requirement).
                let flags = unsafe { read::value(begin_info) }.map(|info| info.flags);
                let continues = flags
                    .is_some_and(|f| f.contains(vk::CommandBufferUsageFlags::RENDER_PASS_CONTINUE));
                COMMAND_BUFFERS.update(command_buffer.as_raw(), |tracked| {
                    tracked.reset();
                    tracked.model.recording = true;
                    tracked.model.in_render_pass = tracked.secondary && continues;
                });
            }
            result
        },
    )
}

/// The core forgets what `command_buffer` recorded for execution order
/// (it begins anew, is reset or freed).
fn forget_recording(data: &DeviceData, command_buffer: u64) {
    crate::intercept::track(data, "vkBeginCommandBuffer", |state| {
        state.validator.begin_command_buffer(command_buffer);
    });
}

/// `vkEndCommandBuffer`: recording ends (also when it fails: the command
/// buffer is then invalid, not recording).
unsafe extern "system" fn end_command_buffer(command_buffer: vk::CommandBuffer) -> vk::Result {
    guarded(
        "vkEndCommandBuffer",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((_, next)) = device_and(command_buffer, |f| f.commands.end_command_buffer)
            else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(command_buffer) };
            COMMAND_BUFFERS.update(command_buffer.as_raw(), |tracked| {
                tracked.model.recording = false;
            });
            result
        },
    )
}

/// `vkResetCommandBuffer`: back to the initial state.
unsafe extern "system" fn reset_command_buffer(
    command_buffer: vk::CommandBuffer,
    flags: vk::CommandBufferResetFlags,
) -> vk::Result {
    guarded(
        "vkResetCommandBuffer",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some((data, next)) =
                device_and(command_buffer, |f| f.commands.reset_command_buffer)
            else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { next(command_buffer, flags) };
            if result == vk::Result::SUCCESS {
                forget_recording(&data, command_buffer.as_raw());
                COMMAND_BUFFERS.update(command_buffer.as_raw(), Tracked::reset);
            }
            result
        },
    )
}

/// A state command: updates the tracked command buffer, then records the
/// command below (state commands carry no micromap rule).
fn state_command<F: Copy>(
    function: &'static str,
    command_buffer: vk::CommandBuffer,
    pick: fn(&DeviceFns) -> Option<F>,
    update: impl FnOnce(&mut Tracked),
    call_down: impl FnOnce(F),
) {
    guarded(function, (), || {
        let Some((_, next)) = device_and(command_buffer, pick) else {
            return;
        };
        COMMAND_BUFFERS.update(command_buffer.as_raw(), update);
        call_down(next);
    })
}

fn enter_render_pass(tracked: &mut Tracked) {
    tracked.model.in_render_pass = true;
}

fn leave_render_pass(tracked: &mut Tracked) {
    tracked.model.in_render_pass = false;
}

/// vkCmdBeginRendering starts a render pass instance (resuming a suspended
/// one, if it was suspended); whether its end suspends it is in its flags.
fn begin_rendering(tracked: &mut Tracked, flags: vk::RenderingFlags) {
    tracked.model.in_render_pass = true;
    tracked.model.suspended = false;
    tracked.rendering_suspends = flags.contains(vk::RenderingFlags::SUSPENDING);
}

/// vkCmdEndRendering ends the instance; with VK_RENDERING_SUSPENDING_BIT
/// it is suspended until a resuming vkCmdBeginRendering.
fn end_rendering(tracked: &mut Tracked) {
    tracked.model.in_render_pass = false;
    tracked.model.suspended = tracked.rendering_suspends;
    tracked.rendering_suspends = false;
}

/// What `vkCmdBeginRendering(info)` does to the tracked command buffer.
///
/// # Safety
/// A non-NULL `info` must point to a `VkRenderingInfo`, as the API requires.
unsafe fn rendering_begun(info: *const vk::RenderingInfo<'_>) -> impl FnOnce(&mut Tracked) {
    // SAFETY: forwarded from the caller.
    let flags = unsafe { info.as_ref() }.map_or(vk::RenderingFlags::empty(), |info| info.flags);
    move |tracked| begin_rendering(tracked, flags)
}

/// State commands: `ours(arguments after the command buffer) = "vkName"
/// => update`, where `update` (an expression over the arguments) changes
/// the tracked command buffer; the next layer's function is the field of
/// the intercept's name.
macro_rules! state_commands {
    ($($ours:ident($($arg:ident: $ty:ty),*) = $name:literal => $update:expr;)*) => {$(
        unsafe extern "system" fn $ours(command_buffer: vk::CommandBuffer, $($arg: $ty),*) {
            state_command(
                $name,
                command_buffer,
                |f| f.commands.$ours,
                $update,
                // SAFETY: the next layer's function, with the application's arguments.
                |next| unsafe { next(command_buffer, $($arg),*) },
            );
        }
    )*};
}

state_commands! {
    cmd_begin_render_pass(
        begin: *const vk::RenderPassBeginInfo<'_>,
        contents: vk::SubpassContents
    ) = "vkCmdBeginRenderPass" => enter_render_pass;
    cmd_begin_render_pass2(
        begin: *const vk::RenderPassBeginInfo<'_>,
        subpass: *const vk::SubpassBeginInfo<'_>
    ) = "vkCmdBeginRenderPass2" => enter_render_pass;
    cmd_begin_render_pass2_khr(
        begin: *const vk::RenderPassBeginInfo<'_>,
        subpass: *const vk::SubpassBeginInfo<'_>
    ) = "vkCmdBeginRenderPass2KHR" => enter_render_pass;
    cmd_end_render_pass() = "vkCmdEndRenderPass" => leave_render_pass;
    cmd_end_render_pass2(end: *const vk::SubpassEndInfo<'_>)
        = "vkCmdEndRenderPass2" => leave_render_pass;
    cmd_end_render_pass2_khr(end: *const vk::SubpassEndInfo<'_>)
        = "vkCmdEndRenderPass2KHR" => leave_render_pass;
    cmd_begin_rendering(info: *const vk::RenderingInfo<'_>)
        // SAFETY: the application's rendering info, valid as the API requires.
        = "vkCmdBeginRendering" => unsafe { rendering_begun(info) };
    cmd_begin_rendering_khr(info: *const vk::RenderingInfo<'_>)
        // SAFETY: the application's rendering info, valid as the API requires.
        = "vkCmdBeginRenderingKHR" => unsafe { rendering_begun(info) };
    cmd_end_rendering() = "vkCmdEndRendering" => end_rendering;
    cmd_end_rendering_khr() = "vkCmdEndRenderingKHR" => end_rendering;
    cmd_begin_video_coding(info: *const vk::VideoBeginCodingInfoKHR<'_>)
        = "vkCmdBeginVideoCodingKHR" => |tracked| tracked.model.in_video_coding = true;
    cmd_end_video_coding(info: *const vk::VideoEndCodingInfoKHR<'_>)
        = "vkCmdEndVideoCodingKHR" => |tracked| tracked.model.in_video_coding = false;
}

/// `vkCmdExecuteCommands`: a submission of the primary runs the builds the
/// secondaries recorded.
unsafe extern "system" fn cmd_execute_commands(
    command_buffer: vk::CommandBuffer,
    count: u32,
    secondaries: *const vk::CommandBuffer,
) {
    // SAFETY: the array holds `count` handles (the API's requirement).
    let handles: Vec<u64> = unsafe { read::array(secondaries, count) }
        .iter()
        .map(|cb| cb.as_raw())
        .collect();
    if let Some(data) = crate::dispatch::DEVICES.get(command_buffer) {
        crate::intercept::track(&data, "vkCmdExecuteCommands", |state| {
            state
                .validator
                .cmd_execute_commands(command_buffer.as_raw(), &handles);
        });
    }
    state_command(
        "vkCmdExecuteCommands",
        command_buffer,
        |f| f.commands.cmd_execute_commands,
        |tracked| {
            tracked
                .recorded
                .extend(handles.into_iter().map(Recorded::Executes))
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, count, secondaries) },
    );
}
