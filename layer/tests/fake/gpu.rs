//! The fake driver's GPU: memory with real bytes, buffers bound into it,
//! the transfer commands (and a stand-in for a shader's writes) recorded per
//! command buffer and executed in order at submission, and the
//! synchronization objects that say a submission is complete (fences,
//! timeline semaphores, idle waits).
//!
//! Execution happens inside vkQueueSubmit(2): by the time it returns, every
//! submitted command has run, its fence is signaled and its timeline
//! semaphores hold their signal values. A wait therefore never blocks: it
//! reports what is already true.
//!
//! The state is process-wide, not per thread like the call log: the layer
//! and the tests may touch one object from several threads, and handles
//! are unique across threads already.

use std::collections::HashMap;
use std::sync::{LazyLock, Mutex, MutexGuard, PoisonError};

use ash::vk;
use ash::vk::Handle as _;

use super::{dispatchable, injected_failure, key_of, record};

/// The largest allocation the fake backs with bytes; larger ones fail with
/// VK_ERROR_OUT_OF_DEVICE_MEMORY, so a runaway size cannot eat the host.
pub const MAX_ALLOCATION: u64 = 64 << 20;

/// How deep vkCmdExecuteCommands may nest before the fake stops: a
/// secondary cannot execute secondaries, so 1 is all that is valid; a
/// little more keeps a mistaken test from recursing forever.
const MAX_NESTING: u32 = 4;

/// Zeroed bytes owned by one allocation, freed with it. Held as an address
/// so the state can live in a static; mappings hand out pointers into it.
struct Backing {
    address: usize,
    size: usize,
    memory_type: u32,
}

impl Backing {
    fn zeroed(size: usize, memory_type: u32) -> Self {
        let bytes: Box<[u8]> = vec![0u8; size].into_boxed_slice();
        let address = Box::into_raw(bytes).cast::<u8>().expose_provenance();
        Self {
            address,
            size,
            memory_type,
        }
    }

    fn pointer(&self, offset: usize) -> *mut u8 {
        std::ptr::with_exposed_provenance_mut::<u8>(self.address).wrapping_add(offset)
    }
}

impl Drop for Backing {
    fn drop(&mut self) {
        let bytes = std::ptr::slice_from_raw_parts_mut(self.pointer(0), self.size);
        // SAFETY: made by `Box::into_raw` in `zeroed` with this length.
        drop(unsafe { Box::from_raw(bytes) });
    }
}

#[derive(Clone, Copy)]
struct Buffer {
    size: u64,
    usage: vk::BufferUsageFlags,
    /// The memory and the offset in it, once bound.
    binding: Option<(u64, u64)>,
}

/// A byte write the test makes a command buffer's next vkCmdDispatch
/// perform, as a compute shader writing a storage buffer would.
#[derive(Clone, Debug)]
pub struct Write {
    pub buffer: u64,
    pub offset: u64,
    pub bytes: Vec<u8>,
}

/// A recorded command that changes memory.
#[derive(Clone, Debug)]
enum Command {
    Copy {
        src: u64,
        dst: u64,
        regions: Vec<vk::BufferCopy>,
    },
    Update {
        dst: u64,
        offset: u64,
        bytes: Vec<u8>,
    },
    Fill {
        dst: u64,
        offset: u64,
        size: u64,
        word: u32,
    },
    Execute(Vec<u64>),
    Writes(Vec<Write>),
}

#[derive(Default)]
struct Gpu {
    memory: HashMap<u64, Backing>,
    buffers: HashMap<u64, Buffer>,
    /// Commands by command buffer, in recording order.
    recorded: HashMap<u64, Vec<Command>>,
    /// The pool each command buffer came from.
    pools: HashMap<u64, u64>,
    /// Writes registered for each command buffer's next vkCmdDispatch.
    pending_writes: HashMap<u64, Vec<Write>>,
    /// Fences and whether each is signaled.
    fences: HashMap<u64, bool>,
    /// Timeline semaphores' counter values (binary semaphores are absent).
    timelines: HashMap<u64, u64>,
    /// Queues by (device key, family, index), so each is one handle.
    queues: HashMap<(usize, u32, u32), u64>,
}

static GPU: LazyLock<Mutex<Gpu>> = LazyLock::new(Mutex::default);

fn gpu() -> MutexGuard<'static, Gpu> {
    GPU.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Gpu {
    /// The host address of `size` bytes at `offset` in `buffer`.
    fn range(&self, buffer: u64, offset: u64, size: u64) -> Result<*mut u8, String> {
        let b = self
            .buffers
            .get(&buffer)
            .ok_or_else(|| format!("buffer {buffer:#x} is unknown"))?;
        let (memory, base) = b
            .binding
            .ok_or_else(|| format!("buffer {buffer:#x} is not bound"))?;
        let backing = self
            .memory
            .get(&memory)
            .ok_or_else(|| format!("buffer {buffer:#x}'s memory {memory:#x} is freed"))?;
        let end = offset.checked_add(size).filter(|&end| end <= b.size);
        let in_memory = base
            .checked_add(offset)
            .and_then(|start| start.checked_add(size))
            .is_some_and(|end| end <= backing.size as u64);
        if end.is_none() || !in_memory {
            return Err(format!(
                "{size} bytes at {offset} are outside buffer {buffer:#x} ({} bytes)",
                b.size
            ));
        }
        Ok(backing.pointer((base + offset) as usize))
    }

    fn read(&self, buffer: u64, offset: u64, size: u64) -> Result<Vec<u8>, String> {
        let from = self.range(buffer, offset, size)?;
        // SAFETY: `range` checked the bytes lie inside a live backing.
        Ok(unsafe { std::slice::from_raw_parts(from, size as usize) }.to_vec())
    }

    fn write(&self, buffer: u64, offset: u64, bytes: &[u8]) -> Result<(), String> {
        let to = self.range(buffer, offset, bytes.len() as u64)?;
        // SAFETY: as in `read`; `bytes` is a separate vector.
        unsafe { to.copy_from_nonoverlapping(bytes.as_ptr(), bytes.len()) };
        Ok(())
    }

    /// Err unless `buffer` was created with `usage`, as a transfer needs.
    fn needs(&self, buffer: u64, usage: vk::BufferUsageFlags) -> Result<(), String> {
        match self.buffers.get(&buffer) {
            Some(b) if b.usage.contains(usage) => Ok(()),
            Some(b) => Err(format!(
                "buffer {buffer:#x} lacks {usage:?} (it has {:?})",
                b.usage
            )),
            None => Err(format!("buffer {buffer:#x} is unknown")),
        }
    }

    fn apply(&self, command: &Command, depth: u32) -> Result<(), String> {
        let source = vk::BufferUsageFlags::TRANSFER_SRC;
        let destination = vk::BufferUsageFlags::TRANSFER_DST;
        match command {
            Command::Copy { src, dst, regions } => {
                self.needs(*src, source)?;
                self.needs(*dst, destination)?;
                regions.iter().try_for_each(|r| {
                    let bytes = self.read(*src, r.src_offset, r.size)?;
                    self.write(*dst, r.dst_offset, &bytes)
                })
            }
            Command::Update { dst, offset, bytes } => {
                self.needs(*dst, destination)?;
                self.write(*dst, *offset, bytes)
            }
            Command::Fill {
                dst,
                offset,
                size,
                word,
            } => {
                self.needs(*dst, destination)?;
                let size = if *size == vk::WHOLE_SIZE {
                    let buffer_size = self.buffers.get(dst).map_or(0, |b| b.size);
                    buffer_size.saturating_sub(*offset) & !3
                } else {
                    *size
                };
                let bytes: Vec<u8> = word
                    .to_le_bytes()
                    .into_iter()
                    .cycle()
                    .take(size as usize)
                    .collect();
                self.write(*dst, *offset, &bytes)
            }
            Command::Execute(secondaries) => {
                if depth >= MAX_NESTING {
                    return Err("vkCmdExecuteCommands nested too deep".into());
                }
                for &secondary in secondaries {
                    self.execute(secondary, depth + 1);
                }
                Ok(())
            }
            Command::Writes(writes) => writes
                .iter()
                .try_for_each(|w| self.write(w.buffer, w.offset, &w.bytes)),
        }
    }

    /// Runs `command_buffer`'s commands in order; what fails is a fault.
    fn execute(&self, command_buffer: u64, depth: u32) {
        let Some(commands) = self.recorded.get(&command_buffer) else {
            return;
        };
        for command in commands {
            if let Err(why) = self.apply(command, depth) {
                fault(why);
            }
        }
    }

    fn push(&mut self, command_buffer: vk::CommandBuffer, command: Command) {
        self.recorded
            .entry(command_buffer.as_raw())
            .or_default()
            .push(command);
    }
}

thread_local! {
    /// What the fake could not execute (out of range, unbound, a missing
    /// transfer usage), per thread: submissions run on the caller's
    /// thread, so tests running side by side see only their own.
    static FAULTS: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
}

fn fault(why: String) {
    if !super::logged() {
        eprintln!("ommcheck fake driver: GPU fault: {why}");
        return;
    }
    FAULTS.with_borrow_mut(|f| f.push(why));
}

/// What the fake could not execute on this thread since the last call (a
/// copy outside a buffer, an unbound buffer, a buffer without the
/// transfer usage the command needs, ...), emptied.
pub fn faults() -> Vec<String> {
    FAULTS.with_borrow_mut(std::mem::take)
}

/// The most elements of one array the fake reads; more is a fault.
const MAX_ITEMS: u32 = 4096;

/// The first `count` elements at `pointer` (none for NULL), at most
/// [`MAX_ITEMS`].
unsafe fn items<T: Copy>(pointer: *const T, count: u32) -> Vec<T> {
    if count > MAX_ITEMS {
        fault(format!(
            "an array of {count} elements; the fake reads {MAX_ITEMS}"
        ));
    }
    if pointer.is_null() {
        return Vec::new();
    }
    // SAFETY: the caller passes the application's array and its count.
    unsafe { std::slice::from_raw_parts(pointer, count.min(MAX_ITEMS) as usize) }.to_vec()
}

/// Makes `command_buffer`'s next recorded vkCmdDispatch write `bytes` at
/// `offset` in `buffer` when it executes: the stand-in for a compute shader
/// that writes a storage buffer (a GPU baker).
pub fn fake_gpu_write(
    command_buffer: vk::CommandBuffer,
    buffer: vk::Buffer,
    offset: u64,
    bytes: &[u8],
) {
    gpu()
        .pending_writes
        .entry(command_buffer.as_raw())
        .or_default()
        .push(Write {
            buffer: buffer.as_raw(),
            offset,
            bytes: bytes.to_vec(),
        });
}

/// `size` bytes at `offset` in `buffer` as the GPU holds them now, read
/// without mapping (the application never maps device-local memory).
pub fn device_bytes(buffer: vk::Buffer, offset: u64, size: u64) -> Vec<u8> {
    gpu()
        .read(buffer.as_raw(), offset, size)
        .unwrap_or_else(|why| panic!("{why}"))
}

/// Every byte of `memory` as the GPU holds it now, for comparing before
/// and after.
pub fn memory_bytes(memory: vk::DeviceMemory) -> Vec<u8> {
    let gpu = gpu();
    let backing = gpu
        .memory
        .get(&memory.as_raw())
        .unwrap_or_else(|| panic!("memory {:#x} is unknown", memory.as_raw()));
    // SAFETY: the whole live backing.
    unsafe { std::slice::from_raw_parts(backing.pointer(0), backing.size) }.to_vec()
}

/// The memory type of the memory `buffer` is bound to.
pub fn memory_type_of(buffer: vk::Buffer) -> Option<u32> {
    let gpu = gpu();
    let (memory, _) = gpu.buffers.get(&buffer.as_raw())?.binding?;
    Some(gpu.memory.get(&memory)?.memory_type)
}

// Memory and buffers.

pub fn allocate(memory: u64, size: u64, memory_type: u32) -> vk::Result {
    if size > MAX_ALLOCATION {
        return vk::Result::ERROR_OUT_OF_DEVICE_MEMORY;
    }
    gpu()
        .memory
        .insert(memory, Backing::zeroed(size as usize, memory_type));
    vk::Result::SUCCESS
}

pub fn free(memory: u64) {
    gpu().memory.remove(&memory);
}

/// Where `memory` at `offset` lies on the host, if the fake backs it.
pub fn mapping(memory: u64, offset: u64) -> Option<usize> {
    let gpu = gpu();
    let backing = gpu.memory.get(&memory)?;
    (offset <= backing.size as u64).then(|| backing.pointer(offset as usize).expose_provenance())
}

pub fn create_buffer(buffer: u64, size: u64, usage: vk::BufferUsageFlags) {
    gpu().buffers.insert(
        buffer,
        Buffer {
            size,
            usage,
            binding: None,
        },
    );
}

/// The usage `buffer` was created with, as the driver saw it.
pub fn usage_of(buffer: vk::Buffer) -> Option<vk::BufferUsageFlags> {
    gpu().buffers.get(&buffer.as_raw()).map(|b| b.usage)
}

pub fn destroy_buffer(buffer: u64) {
    gpu().buffers.remove(&buffer);
}

pub fn bind(buffer: u64, memory: u64, offset: u64) {
    let mut gpu = gpu();
    match gpu.buffers.get_mut(&buffer) {
        Some(b) => b.binding = Some((memory, offset)),
        None => fault(format!("bound unknown buffer {buffer:#x}")),
    }
}

pub unsafe extern "system" fn bind_buffer_memory2(
    _: vk::Device,
    count: u32,
    infos: *const vk::BindBufferMemoryInfo<'_>,
) -> vk::Result {
    record("vkBindBufferMemory2", vec![u64::from(count)]);
    let infos = unsafe { items(infos, count) };
    for i in infos {
        bind(i.buffer.as_raw(), i.memory.as_raw(), i.memory_offset);
    }
    vk::Result::SUCCESS
}

/// Memory an allocation for a buffer needs: its size rounded up to 256
/// bytes, 256-byte aligned, of either memory type.
fn requirements(buffer: u64) -> vk::MemoryRequirements {
    let size = gpu().buffers.get(&buffer).map_or(0, |b| b.size);
    vk::MemoryRequirements {
        size: size.div_ceil(256) * 256,
        alignment: 256,
        memory_type_bits: 0b11,
    }
}

pub unsafe extern "system" fn get_buffer_memory_requirements(
    _: vk::Device,
    buffer: vk::Buffer,
    out: *mut vk::MemoryRequirements,
) {
    record("vkGetBufferMemoryRequirements", vec![buffer.as_raw()]);
    unsafe { *out = requirements(buffer.as_raw()) };
}

pub unsafe extern "system" fn get_buffer_memory_requirements2(
    _: vk::Device,
    info: *const vk::BufferMemoryRequirementsInfo2<'_>,
    out: *mut vk::MemoryRequirements2<'_>,
) {
    let buffer = unsafe { (*info).buffer.as_raw() };
    record("vkGetBufferMemoryRequirements2", vec![buffer]);
    unsafe { (*out).memory_requirements = requirements(buffer) };
}

/// The memory is coherent: flushes and invalidations have nothing to do.
pub unsafe extern "system" fn flush_or_invalidate(
    _: vk::Device,
    count: u32,
    _: *const vk::MappedMemoryRange<'_>,
) -> vk::Result {
    record("vkFlushMappedMemoryRanges", vec![u64::from(count)]);
    vk::Result::SUCCESS
}

// Command buffers.

/// Forgets what `command_buffer` recorded (begin, reset, allocation).
pub fn forget(command_buffer: u64) {
    let mut gpu = gpu();
    gpu.recorded.remove(&command_buffer);
    gpu.pending_writes.remove(&command_buffer);
}

pub fn allocated(command_buffer: u64, pool: u64) {
    forget(command_buffer);
    gpu().pools.insert(command_buffer, pool);
}

pub fn freed(command_buffer: u64) {
    forget(command_buffer);
    gpu().pools.remove(&command_buffer);
}

/// The command buffers allocated from `pool`.
fn of_pool(pool: u64) -> Vec<u64> {
    let gpu = gpu();
    gpu.pools
        .iter()
        .filter(|&(_, &p)| p == pool)
        .map(|(&c, _)| c)
        .collect()
}

pub fn pool_destroyed(pool: u64) {
    of_pool(pool).into_iter().for_each(freed);
}

pub unsafe extern "system" fn reset_command_buffer(
    cb: vk::CommandBuffer,
    _: vk::CommandBufferResetFlags,
) -> vk::Result {
    record("vkResetCommandBuffer", vec![cb.as_raw()]);
    forget(cb.as_raw());
    vk::Result::SUCCESS
}

pub unsafe extern "system" fn reset_command_pool(
    _: vk::Device,
    pool: vk::CommandPool,
    _: vk::CommandPoolResetFlags,
) -> vk::Result {
    record("vkResetCommandPool", vec![pool.as_raw()]);
    of_pool(pool.as_raw()).into_iter().for_each(forget);
    vk::Result::SUCCESS
}

/// Logs a copy as `[command buffer, src, dst, region count, then each
/// region's srcOffset, dstOffset, size]`, so a test sees exactly which
/// ranges were copied.
fn record_copy(
    name: &'static str,
    cb: vk::CommandBuffer,
    src: vk::Buffer,
    dst: vk::Buffer,
    regions: &[vk::BufferCopy],
) {
    let mut args = vec![
        cb.as_raw(),
        src.as_raw(),
        dst.as_raw(),
        regions.len() as u64,
    ];
    for r in regions {
        args.extend([r.src_offset, r.dst_offset, r.size]);
    }
    record(name, args);
    gpu().push(
        cb,
        Command::Copy {
            src: src.as_raw(),
            dst: dst.as_raw(),
            regions: regions.to_vec(),
        },
    );
}

pub unsafe extern "system" fn cmd_copy_buffer(
    cb: vk::CommandBuffer,
    src: vk::Buffer,
    dst: vk::Buffer,
    count: u32,
    regions: *const vk::BufferCopy,
) {
    let regions = unsafe { items(regions, count) };
    record_copy("vkCmdCopyBuffer", cb, src, dst, &regions);
}

pub unsafe extern "system" fn cmd_copy_buffer2(
    cb: vk::CommandBuffer,
    info: *const vk::CopyBufferInfo2<'_>,
) {
    let i = unsafe { &*info };
    let regions: Vec<vk::BufferCopy> = unsafe { items(i.p_regions, i.region_count) }
        .iter()
        .map(|r| vk::BufferCopy {
            src_offset: r.src_offset,
            dst_offset: r.dst_offset,
            size: r.size,
        })
        .collect();
    record_copy("vkCmdCopyBuffer2", cb, i.src_buffer, i.dst_buffer, &regions);
}

pub unsafe extern "system" fn cmd_update_buffer(
    cb: vk::CommandBuffer,
    dst: vk::Buffer,
    offset: vk::DeviceSize,
    size: vk::DeviceSize,
    data: *const std::ffi::c_void,
) {
    record(
        "vkCmdUpdateBuffer",
        vec![cb.as_raw(), dst.as_raw(), offset, size],
    );
    // vkCmdUpdateBuffer takes at most 65536 bytes.
    let size = size.min(65536) as usize;
    // SAFETY: the application's `size` bytes at `data`.
    let bytes = unsafe { std::slice::from_raw_parts(data.cast::<u8>(), size) }.to_vec();
    gpu().push(
        cb,
        Command::Update {
            dst: dst.as_raw(),
            offset,
            bytes,
        },
    );
}

pub unsafe extern "system" fn cmd_fill_buffer(
    cb: vk::CommandBuffer,
    dst: vk::Buffer,
    offset: vk::DeviceSize,
    size: vk::DeviceSize,
    word: u32,
) {
    record(
        "vkCmdFillBuffer",
        vec![cb.as_raw(), dst.as_raw(), offset, size, u64::from(word)],
    );
    gpu().push(
        cb,
        Command::Fill {
            dst: dst.as_raw(),
            offset,
            size,
            word,
        },
    );
}

/// What a barrier orders, as 64-bit (synchronization2) flags: the union of
/// its stage masks and of its memory and buffer barriers' access masks.
#[derive(Default)]
struct Dependency {
    src_stages: u64,
    src_access: u64,
    dst_stages: u64,
    dst_access: u64,
}

impl Dependency {
    /// Logs the barrier as `[command buffer, src stages, src access, dst
    /// stages, dst access]`. The fake executes barriers as no-ops (every
    /// command runs in order at submission); tests read what they order.
    fn record(&self, name: &'static str, cb: vk::CommandBuffer) {
        record(
            name,
            vec![
                cb.as_raw(),
                self.src_stages,
                self.src_access,
                self.dst_stages,
                self.dst_access,
            ],
        );
    }
}

/// The synchronization1 flags are the low bits of synchronization2's.
#[allow(clippy::too_many_arguments)]
pub unsafe extern "system" fn cmd_pipeline_barrier(
    cb: vk::CommandBuffer,
    src: vk::PipelineStageFlags,
    dst: vk::PipelineStageFlags,
    _: vk::DependencyFlags,
    memory_count: u32,
    memory: *const vk::MemoryBarrier<'_>,
    buffer_count: u32,
    buffers: *const vk::BufferMemoryBarrier<'_>,
    _: u32,
    _: *const vk::ImageMemoryBarrier<'_>,
) {
    let mut dependency = Dependency {
        src_stages: u64::from(src.as_raw()),
        dst_stages: u64::from(dst.as_raw()),
        ..Dependency::default()
    };
    let memory = unsafe { items(memory, memory_count) };
    let buffers = unsafe { items(buffers, buffer_count) };
    let access = memory
        .iter()
        .map(|m| (m.src_access_mask, m.dst_access_mask))
        .chain(
            buffers
                .iter()
                .map(|b| (b.src_access_mask, b.dst_access_mask)),
        );
    for (src, dst) in access {
        dependency.src_access |= u64::from(src.as_raw());
        dependency.dst_access |= u64::from(dst.as_raw());
    }
    dependency.record("vkCmdPipelineBarrier", cb);
}

pub unsafe extern "system" fn cmd_pipeline_barrier2(
    cb: vk::CommandBuffer,
    info: *const vk::DependencyInfo<'_>,
) {
    let i = unsafe { &*info };
    let mut dependency = Dependency::default();
    let memory = unsafe { items(i.p_memory_barriers, i.memory_barrier_count) };
    let buffers = unsafe { items(i.p_buffer_memory_barriers, i.buffer_memory_barrier_count) };
    let masks = memory
        .iter()
        .map(|m| {
            (
                m.src_stage_mask,
                m.src_access_mask,
                m.dst_stage_mask,
                m.dst_access_mask,
            )
        })
        .chain(buffers.iter().map(|b| {
            (
                b.src_stage_mask,
                b.src_access_mask,
                b.dst_stage_mask,
                b.dst_access_mask,
            )
        }));
    for (src_stages, src_access, dst_stages, dst_access) in masks {
        dependency.src_stages |= src_stages.as_raw();
        dependency.src_access |= src_access.as_raw();
        dependency.dst_stages |= dst_stages.as_raw();
        dependency.dst_access |= dst_access.as_raw();
    }
    dependency.record("vkCmdPipelineBarrier2", cb);
}

pub unsafe extern "system" fn cmd_execute_commands(
    cb: vk::CommandBuffer,
    count: u32,
    secondaries: *const vk::CommandBuffer,
) {
    let secondaries: Vec<u64> = unsafe { items(secondaries, count) }
        .iter()
        .map(|s| s.as_raw())
        .collect();
    let mut args = vec![cb.as_raw()];
    args.extend(&secondaries);
    record("vkCmdExecuteCommands", args);
    gpu().push(cb, Command::Execute(secondaries));
}

/// Performs the writes registered with [`fake_gpu_write`] for `cb`.
pub unsafe extern "system" fn cmd_dispatch(cb: vk::CommandBuffer, x: u32, y: u32, z: u32) {
    record(
        "vkCmdDispatch",
        vec![cb.as_raw(), u64::from(x), u64::from(y), u64::from(z)],
    );
    let mut gpu = gpu();
    let writes = gpu.pending_writes.remove(&cb.as_raw()).unwrap_or_default();
    gpu.push(cb, Command::Writes(writes));
}

// Submission.

/// Runs `command_buffers` in order, then sets each timeline semaphore to
/// its signal value and signals `fence`.
fn complete(command_buffers: &[u64], signals: &[(u64, u64)], fence: vk::Fence) {
    let mut gpu = gpu();
    for &command_buffer in command_buffers {
        gpu.execute(command_buffer, 0);
    }
    for &(semaphore, value) in signals {
        if let Some(counter) = gpu.timelines.get_mut(&semaphore) {
            *counter = value;
        }
    }
    if fence != vk::Fence::null() {
        gpu.fences.insert(fence.as_raw(), true);
    }
}

/// The VkTimelineSemaphoreSubmitInfo in a pNext chain (at most 16 deep).
unsafe fn timeline_info<'a>(
    mut next: *const std::ffi::c_void,
) -> Option<&'a vk::TimelineSemaphoreSubmitInfo<'a>> {
    for _ in 0..16 {
        if next.is_null() {
            return None;
        }
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::TIMELINE_SEMAPHORE_SUBMIT_INFO {
            return Some(unsafe { &*next.cast() });
        }
        next = base.p_next.cast();
    }
    None
}

/// Executes `count` VkSubmitInfo in order (called by the fake vkQueueSubmit).
pub unsafe fn execute_submits(count: u32, submits: *const vk::SubmitInfo<'_>, fence: vk::Fence) {
    let submits = unsafe { items(submits, count) };
    let mut command_buffers = Vec::new();
    let mut signals = Vec::new();
    for s in &submits {
        let buffers = unsafe { items(s.p_command_buffers, s.command_buffer_count) };
        command_buffers.extend(buffers.iter().map(|c| c.as_raw()));
        let semaphores = unsafe { items(s.p_signal_semaphores, s.signal_semaphore_count) };
        if let Some(t) = unsafe { timeline_info(s.p_next) } {
            let values =
                unsafe { items(t.p_signal_semaphore_values, t.signal_semaphore_value_count) };
            signals.extend(semaphores.iter().map(|s| s.as_raw()).zip(values));
        }
    }
    complete(&command_buffers, &signals, fence);
}

pub unsafe extern "system" fn queue_submit2(
    queue: vk::Queue,
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
    fence: vk::Fence,
) -> vk::Result {
    record(
        "vkQueueSubmit2",
        vec![queue.as_raw(), u64::from(count), fence.as_raw()],
    );
    let submits = unsafe { items(submits, count) };
    let mut command_buffers = Vec::new();
    let mut signals = Vec::new();
    for s in &submits {
        let infos = unsafe { items(s.p_command_buffer_infos, s.command_buffer_info_count) };
        command_buffers.extend(infos.iter().map(|i| i.command_buffer.as_raw()));
        let infos = unsafe { items(s.p_signal_semaphore_infos, s.signal_semaphore_info_count) };
        signals.extend(infos.iter().map(|i| (i.semaphore.as_raw(), i.value)));
    }
    complete(&command_buffers, &signals, fence);
    vk::Result::SUCCESS
}

pub unsafe extern "system" fn queue_wait_idle(queue: vk::Queue) -> vk::Result {
    record("vkQueueWaitIdle", vec![queue.as_raw()]);
    vk::Result::SUCCESS
}

pub unsafe extern "system" fn device_wait_idle(device: vk::Device) -> vk::Result {
    record("vkDeviceWaitIdle", vec![device.as_raw()]);
    vk::Result::SUCCESS
}

/// One queue handle per (device, family, index), sharing the device's key.
pub unsafe extern "system" fn get_device_queue(
    device: vk::Device,
    family: u32,
    index: u32,
    out: *mut vk::Queue,
) {
    let key = key_of(device.as_raw());
    let queue = *gpu()
        .queues
        .entry((key, family, index))
        .or_insert_with(|| dispatchable(key));
    record(
        "vkGetDeviceQueue",
        vec![u64::from(family), u64::from(index), queue],
    );
    unsafe { *out = vk::Queue::from_raw(queue) };
}

// Fences.

pub unsafe extern "system" fn create_fence(
    _: vk::Device,
    info: *const vk::FenceCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Fence,
) -> vk::Result {
    let fence = super::next_handle();
    let signaled = unsafe { (*info).flags }.contains(vk::FenceCreateFlags::SIGNALED);
    gpu().fences.insert(fence, signaled);
    record("vkCreateFence", vec![fence, u64::from(signaled)]);
    unsafe { *out = vk::Fence::from_raw(fence) };
    vk::Result::SUCCESS
}

pub unsafe extern "system" fn destroy_fence(
    _: vk::Device,
    fence: vk::Fence,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroyFence", vec![fence.as_raw()]);
    gpu().fences.remove(&fence.as_raw());
}

pub unsafe extern "system" fn reset_fences(
    _: vk::Device,
    count: u32,
    fences: *const vk::Fence,
) -> vk::Result {
    let fences = unsafe { items(fences, count) };
    record("vkResetFences", fences.iter().map(|f| f.as_raw()).collect());
    let mut gpu = gpu();
    for f in fences {
        gpu.fences.insert(f.as_raw(), false);
    }
    vk::Result::SUCCESS
}

/// SUCCESS when the fences are signaled (all, or any with `wait_all`
/// false), else TIMEOUT at once: nothing runs later in the fake, so
/// waiting longer could not change the answer.
pub unsafe extern "system" fn wait_for_fences(
    _: vk::Device,
    count: u32,
    fences: *const vk::Fence,
    wait_all: vk::Bool32,
    timeout: u64,
) -> vk::Result {
    let fences = unsafe { items(fences, count) };
    let mut args: Vec<u64> = fences.iter().map(|f| f.as_raw()).collect();
    args.extend([u64::from(wait_all), timeout]);
    record("vkWaitForFences", args);
    let gpu = gpu();
    let signaled = |f: &vk::Fence| gpu.fences.get(&f.as_raw()).copied().unwrap_or(false);
    let done = if wait_all == vk::FALSE {
        fences.iter().any(signaled)
    } else {
        fences.iter().all(signaled)
    };
    if done {
        vk::Result::SUCCESS
    } else {
        vk::Result::TIMEOUT
    }
}

pub unsafe extern "system" fn get_fence_status(_: vk::Device, fence: vk::Fence) -> vk::Result {
    if let Some(failed) = injected_failure("vkGetFenceStatus") {
        return failed;
    }
    record("vkGetFenceStatus", vec![fence.as_raw()]);
    if gpu().fences.get(&fence.as_raw()).copied().unwrap_or(false) {
        vk::Result::SUCCESS
    } else {
        vk::Result::NOT_READY
    }
}

// Semaphores.

pub unsafe extern "system" fn create_semaphore(
    _: vk::Device,
    info: *const vk::SemaphoreCreateInfo<'_>,
    _: *const vk::AllocationCallbacks<'_>,
    out: *mut vk::Semaphore,
) -> vk::Result {
    let semaphore = super::next_handle();
    let mut next = unsafe { (*info).p_next };
    let mut timeline = None;
    for _ in 0..16 {
        if next.is_null() {
            break;
        }
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::SEMAPHORE_TYPE_CREATE_INFO {
            let t = unsafe { &*next.cast::<vk::SemaphoreTypeCreateInfo<'_>>() };
            if t.semaphore_type == vk::SemaphoreType::TIMELINE {
                timeline = Some(t.initial_value);
            }
        }
        next = base.p_next.cast();
    }
    if let Some(initial) = timeline {
        gpu().timelines.insert(semaphore, initial);
    }
    record(
        "vkCreateSemaphore",
        vec![semaphore, u64::from(timeline.is_some())],
    );
    unsafe { *out = vk::Semaphore::from_raw(semaphore) };
    vk::Result::SUCCESS
}

pub unsafe extern "system" fn destroy_semaphore(
    _: vk::Device,
    semaphore: vk::Semaphore,
    _: *const vk::AllocationCallbacks<'_>,
) {
    record("vkDestroySemaphore", vec![semaphore.as_raw()]);
    gpu().timelines.remove(&semaphore.as_raw());
}

pub unsafe extern "system" fn get_semaphore_counter_value(
    _: vk::Device,
    semaphore: vk::Semaphore,
    out: *mut u64,
) -> vk::Result {
    if let Some(failed) = injected_failure("vkGetSemaphoreCounterValue") {
        return failed;
    }
    let value = gpu().timelines.get(&semaphore.as_raw()).copied();
    record(
        "vkGetSemaphoreCounterValue",
        vec![semaphore.as_raw(), value.unwrap_or(0)],
    );
    match value {
        Some(value) => {
            unsafe { *out = value };
            vk::Result::SUCCESS
        }
        None => vk::Result::ERROR_UNKNOWN,
    }
}

/// As [`wait_for_fences`]: SUCCESS when the counters have reached the
/// values (all, or any with VK_SEMAPHORE_WAIT_ANY_BIT), else TIMEOUT.
pub unsafe extern "system" fn wait_semaphores(
    _: vk::Device,
    info: *const vk::SemaphoreWaitInfo<'_>,
    timeout: u64,
) -> vk::Result {
    let i = unsafe { &*info };
    let semaphores = unsafe { items(i.p_semaphores, i.semaphore_count) };
    let values = unsafe { items(i.p_values, i.semaphore_count) };
    let mut args = vec![u64::from(i.flags.as_raw()), timeout];
    for (s, v) in semaphores.iter().zip(&values) {
        args.extend([s.as_raw(), *v]);
    }
    record("vkWaitSemaphores", args);
    let gpu = gpu();
    let reached =
        |(s, v): (&vk::Semaphore, &u64)| gpu.timelines.get(&s.as_raw()).is_some_and(|c| c >= v);
    let mut pairs = semaphores.iter().zip(&values);
    let done = if i.flags.contains(vk::SemaphoreWaitFlags::ANY) {
        pairs.any(reached)
    } else {
        pairs.all(reached)
    };
    if done {
        vk::Result::SUCCESS
    } else {
        vk::Result::TIMEOUT
    }
}

pub unsafe extern "system" fn signal_semaphore(
    _: vk::Device,
    info: *const vk::SemaphoreSignalInfo<'_>,
) -> vk::Result {
    let i = unsafe { &*info };
    record("vkSignalSemaphore", vec![i.semaphore.as_raw(), i.value]);
    if let Some(counter) = gpu().timelines.get_mut(&i.semaphore.as_raw()) {
        *counter = i.value;
    }
    vk::Result::SUCCESS
}
