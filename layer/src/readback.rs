//! Route 2 of reading device build inputs: GPU readback.
//!
//! When a device build is recorded whose inputs the host cannot read
//! (device-local memory, or memory the application does not keep mapped),
//! the layer records into the same command buffer, before the build,
//! copies of exactly the windows the build reads into memory of its own:
//! a barrier from every earlier write to transfer reads, one
//! `vkCmdCopyBuffer` per buffer read, and a barrier from those copies to
//! host reads. The copies only read the application's memory; the layer
//! writes nothing but its own. Once the submission is known to be
//! complete (a fence, an idle queue or device, a timeline semaphore value:
//! see [`crate::completion`]) the bytes are what the build read when it
//! ran, and the build is checked with them.
//!
//! The copies need `VK_BUFFER_USAGE_TRANSFER_SRC_BIT` on the application's
//! buffers, which the layer adds when a buffer is created with a build-input
//! usage ([`with_transfer_source`]). Layer memory is bounded per device by
//! the `gpu_readback_max_bytes` setting; a build past it is not checked,
//! and says so.

#![allow(unsafe_code)]

use std::sync::{Arc, Mutex, MutexGuard, PoisonError, Weak};

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::checks::device_contents::{
    ContentRead, DeviceBuild, Extent, KnownBytes, ReadKind, INSTANCE_SIZE,
};
use ommcheck::model::accel::GeometryData;
use ommcheck::{Bytes, Severity};

use crate::dispatch::memory_layout;
use crate::dispatch::{DeviceData, DeviceState};
use crate::read;
use crate::report::{Message, CONTENTS_NOT_CHECKED};
use crate::settings::{GPU_READBACK, GPU_READBACK_INDIRECT_MAX_BYTES, GPU_READBACK_MAX_BYTES};

/// One window of an application buffer a build reads, and where its copy
/// lies in the layer's readback buffer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Window {
    /// The parameter that names the first read in the window.
    pub location: String,
    /// The application's `VkBuffer`.
    pub buffer: u64,
    /// The window's start in that buffer.
    pub offset: u64,
    pub len: u64,
    /// The window's start in its readback's range.
    pub at: u64,
}

/// The layer's host-visible copy of the windows one recorded build reads:
/// a range of a block of the device's [`Arena`]. Dropping it returns the
/// range, which the command buffer's reset, free or pool destruction
/// allows (the command buffer is then not pending).
#[derive(Debug)]
pub struct Readback {
    arena: Arc<Mutex<Arena>>,
    block: u64,
    /// The range's start in its block's buffer, and its length.
    offset: u64,
    size: u64,
    /// The block's buffer, which the copies write.
    buffer: vk::Buffer,
    /// Where the range starts in host memory (the block is mapped whole).
    mapped: usize,
    pub windows: Vec<Window>,
    /// Alive while a view of the range ([`Readback::contents`]) is.
    views: Mutex<Weak<()>>,
    /// Memory of earlier copies of the views, for reuse.
    spares: Mutex<Vec<Bytes>>,
}

impl Drop for Readback {
    fn drop(&mut self) {
        lock(&self.arena).release(self.block, self.offset, self.size);
    }
}

impl Readback {
    /// The bytes the copies wrote, one window each, for the content checks:
    /// views of the range, not copies. Each view keeps the range taken
    /// (this readback alive), so what the checks keep (a built micromap's
    /// triangles and data) stays readable; before the range is written
    /// again, [`Readback::own_views`] makes those copies. Call only once
    /// the submission that ran the copies is complete.
    pub fn contents(self: &Arc<Self>) -> Vec<KnownBytes> {
        let Ok(size) = usize::try_from(self.size) else {
            return Vec::new();
        };
        let token = {
            let mut views = lock(&self.views);
            views.upgrade().unwrap_or_else(|| {
                let token = Arc::new(());
                *views = Arc::downgrade(&token);
                token
            })
        };
        // SAFETY: the range `[mapped, mapped + size)` is this readback's, in
        // a block mapped whole, host-coherent; the view keeps the readback,
        // so the range is neither returned nor the block unmapped while it
        // lives. The copies that write it have completed, and the range is
        // written again only by a later submission of the same recording,
        // before which `own_views` replaces the views the checker keeps.
        let whole = unsafe { read::mapped_view((Arc::clone(self), token), self.mapped, size) };
        self.windows
            .iter()
            .filter_map(|window| {
                let at = usize::try_from(window.at).ok()?;
                let end = at.checked_add(usize::try_from(window.len).ok()?)?;
                (end <= size).then(|| KnownBytes {
                    buffer: window.buffer,
                    offset: window.offset,
                    bytes: whole.slice(at..end),
                })
            })
            .collect()
    }

    /// Before the range is written again (a later submission of the
    /// recording that holds it): what `state` keeps of it becomes copies.
    /// The copies' memory is kept here and reused at the next submission
    /// once the checker has let go of it (a completion replaced what it
    /// kept), so a command buffer submitted again and again neither
    /// allocates nor frees its copies each time.
    pub fn own_views(&self, state: &mut ommcheck::state::State) {
        if lock(&self.views).strong_count() == 0 {
            return;
        }
        let Ok(size) = usize::try_from(self.size) else {
            return;
        };
        let mut spares = lock(&self.spares);
        let mut copy = |bytes: &[u8]| {
            let reused = spares
                .iter()
                .position(|spare| spare.len() == bytes.len() && spare.is_unique())
                .and_then(|k| spares.swap_remove(k).try_into_mut().ok());
            let copied = match reused {
                Some(mut memory) => {
                    memory.copy_from_slice(bytes);
                    memory.freeze()
                }
                None => Bytes::copy_from_slice(bytes),
            };
            // One spare per view a build keeps (its triangles and data);
            // more would only be memory held for nothing.
            if spares.len() < MAX_SPARES {
                spares.push(copied.clone());
            }
            copied
        };
        state.own_bytes_within(&(self.mapped..self.mapped.saturating_add(size)), &mut copy);
    }
}

/// Copies a readback keeps for reuse (see [`Readback::own_views`]).
const MAX_SPARES: usize = 8;

#[cfg(test)]
impl Readback {
    /// A readback of no memory, for tests of what holds readbacks.
    pub fn empty() -> Self {
        Readback {
            arena: Arc::default(),
            block: 0,
            offset: 0,
            size: 0,
            buffer: vk::Buffer::null(),
            mapped: 0,
            windows: Vec::new(),
            views: Mutex::default(),
            spares: Mutex::default(),
        }
    }
}

/// How the inputs of a recorded device build will be read.
#[derive(Debug)]
pub enum Plan {
    /// At submission, from memory the application has mapped or from what
    /// transfers wrote.
    AtSubmission,
    /// At completion, from the copies recorded before the build.
    ReadBack(Arc<Readback>),
    /// At submission if transfers make them known; why no readback was
    /// recorded otherwise: a short key (reported once per device) and the
    /// sentence.
    NotReadBack(&'static str, String),
}

/// Reads `[offset, offset + len)` of a buffer as far as the host knows it
/// now (mapped memory at recording; mapped memory and followed transfers
/// at submission).
pub type HostBytes = fn(&DeviceState, u64, u64, u64) -> Option<Vec<u8>>;

/// At most this many instance pointers are followed per build input
/// (512 KiB of pointers); a longer array's instances are not placed.
pub const MAX_POINTERS_FOLLOWED: u64 = 1 << 16;

/// The windows `build` reads, by buffer (one hull per buffer), as far as
/// each buffer reaches; Err names an input no tracked buffer holds.
/// Inputs whose extent an indirect build's range infos decide are read
/// from their start towards their buffer's end, at most `indirect_cap`
/// bytes. The instances an array of pointers points to are added where
/// `host` can read the pointers (see [`pointed_instances`]).
pub fn windows(
    state: &DeviceState,
    build: &DeviceBuild,
    indirect_cap: u64,
    host: HostBytes,
) -> Result<Vec<Window>, String> {
    let tracked = state.validator.state();
    let mut windows: Vec<Window> = Vec::new();
    let reads = build.content_reads();
    for read in &reads {
        let found = tracked
            .buffers_at(read.address)
            .find_map(|(handle, b)| Some((handle, b.address_range()?.0, b.size)));
        let Some((buffer, start, size)) = found else {
            // A micromap build's triangle array or data inside no buffer
            // whose address is known is an error its recording reported
            // (VUID-vkCmdBuildMicromapsEXT-pInfos-10896, -10897): there
            // are no bytes to check, and nothing more to say.
            if matches!(build, DeviceBuild::Micromaps(_)) && tracked.knows_addresses() {
                continue;
            }
            return Err(format!(
                "no buffer whose device address the layer knows (from vkGetBufferDeviceAddress) holds {} ({:#x})",
                read.location, read.address
            ));
        };
        let offset = read.address - start;
        let left = size.saturating_sub(offset);
        let len = match read.extent {
            Extent::Bytes(n) => n.min(left),
            Extent::RangesDecide => left.min(indirect_cap),
            Extent::ToBufferEnd | Extent::Overflow => left,
        };
        add_window(&mut windows, &read.location, buffer, offset, len);
    }
    for read in reads
        .iter()
        .filter(|r| r.kind == ReadKind::InstancePointers)
    {
        for (buffer, offset, len) in pointed_instances(state, read, host).unwrap_or_default() {
            add_window(&mut windows, &read.location, buffer, offset, len);
        }
    }
    Ok(windows)
}

/// Adds `[offset, offset + len)` of `buffer` to the window of that buffer
/// (their hull), or as a new window.
fn add_window(windows: &mut Vec<Window>, location: &str, buffer: u64, offset: u64, len: u64) {
    if len == 0 {
        return;
    }
    match windows.iter_mut().find(|w| w.buffer == buffer) {
        Some(w) => {
            let end = (w.offset + w.len).max(offset + len);
            w.offset = w.offset.min(offset);
            w.len = end - w.offset;
        }
        None => windows.push(Window {
            location: location.to_owned(),
            buffer,
            offset,
            len,
            at: 0,
        }),
    }
}

/// The instances the array of pointers `read` points to, as
/// `(buffer, offset, len)`, adjacent ones coalesced: None where the
/// pointers cannot be read through `host` now (their count is unknown,
/// as an indirect build's is, or there are more than
/// [`MAX_POINTERS_FOLLOWED`], or the host cannot read them). NULL
/// pointers and pointers into no known buffer point to nothing read.
pub fn pointed_instances(
    state: &DeviceState,
    read: &ContentRead,
    host: HostBytes,
) -> Option<Vec<(u64, u64, u64)>> {
    let Extent::Bytes(len) = read.extent else {
        return None;
    };
    if len / 8 > MAX_POINTERS_FOLLOWED {
        return None;
    }
    let tracked = state.validator.state();
    let (buffer, start) = tracked
        .buffers_at(read.address)
        .find_map(|(handle, b)| Some((handle, b.address_range()?.0)))?;
    let pointers = host(state, buffer, read.address - start, len)?;
    let mut addresses: Vec<u64> = pointers
        .chunks_exact(8)
        .filter_map(|p| Some(u64::from_le_bytes(p.try_into().ok()?)))
        .filter(|&address| address != 0)
        .collect();
    addresses.sort_unstable();
    addresses.dedup();
    let mut found: Vec<(u64, u64, u64)> = Vec::new();
    for address in addresses {
        let Some((buffer, start, size)) = tracked
            .buffers_at(address)
            .find_map(|(handle, b)| Some((handle, b.address_range()?.0, b.size)))
        else {
            continue;
        };
        let offset = address - start;
        let len = INSTANCE_SIZE.min(size.saturating_sub(offset));
        match found.last_mut() {
            Some(last) if last.0 == buffer && last.1 + last.2 >= offset => {
                last.2 = last.2.max(offset + len - last.1);
            }
            _ => found.push((buffer, offset, len)),
        }
    }
    Some(found)
}

/// `VK_BUFFER_USAGE_TRANSFER_SRC_BIT`.
const TRANSFER_SRC: u64 = 0x1;
/// Copies into the readback buffer start at multiples of this.
const WINDOW_ALIGNMENT: u64 = 16;

/// Decides how `build`'s inputs will be read and, for a readback, records
/// the copies into `command_buffer` (before the build, which the caller
/// records next). Every window is watched for transfers (route 1) too.
pub fn plan(
    data: &DeviceData,
    state: &mut DeviceState,
    command_buffer: vk::CommandBuffer,
    build: &DeviceBuild,
) -> Plan {
    let settings = data.instance.reporter.settings();
    let cap = settings.gpu_readback_indirect_max_bytes;
    let mut windows = match windows(state, build, cap, memory_layout::mapped_window) {
        Ok(windows) => windows,
        Err(reason) => return Plan::NotReadBack("unknown-address", reason),
    };
    for w in &windows {
        state.shadows.watch(w.buffer, w.offset, w.offset + w.len);
    }
    if windows
        .iter()
        .all(|w| memory_layout::host_can_read(state, w.buffer, w.offset, w.len))
    {
        return Plan::AtSubmission;
    }
    if !settings.gpu_readback {
        return Plan::NotReadBack("readback-off", format!(
            "they lie in memory the host cannot read and GPU readback is off (setting gpu_readback, {GPU_READBACK})"
        ));
    }
    let memory_fns = &data.fns.memory;
    if memory_fns.cmd_pipeline_barrier.is_none() || memory_fns.cmd_copy_buffer.is_none() {
        return Plan::NotReadBack(
            "readback-setup",
            "the layer could not set up GPU readback: the next layer lacks vkCmdPipelineBarrier or vkCmdCopyBuffer".into(),
        );
    }
    let tracked = state.validator.state();
    if let Some(w) = windows.iter().find(|w| {
        tracked
            .buffers
            .get(&w.buffer)
            .is_some_and(|b| b.usage & TRANSFER_SRC == 0)
    }) {
        return Plan::NotReadBack("no-transfer-source", format!(
            "VkBuffer {:#x} holding them lacks VK_BUFFER_USAGE_TRANSFER_SRC_BIT, which the layer adds only where the usage is given in VkBufferCreateInfo::usage, so it cannot be copied for GPU readback",
            w.buffer
        ));
    }
    let mut size = 0u64;
    for w in &mut windows {
        w.at = size;
        // A window's length comes from a buffer size the application chose.
        let padded = w
            .len
            .checked_next_multiple_of(WINDOW_ALIGNMENT)
            .unwrap_or(u64::MAX);
        size = size.saturating_add(padded);
    }
    let size = size.max(WINDOW_ALIGNMENT);
    let limit = settings.gpu_readback_max_bytes;
    let taken = lock(&data.readback_arena).take(data, size, limit);
    match taken {
        Ok((block, offset, buffer, mapped)) => {
            let readback = Readback {
                arena: Arc::clone(&data.readback_arena),
                block,
                offset,
                size,
                buffer,
                mapped,
                windows,
                views: Mutex::default(),
            spares: Mutex::default(),
            };
            // SAFETY: the application's command buffer, recording (the
            // build command being recorded requires it).
            unsafe { record_copies(data, command_buffer, &readback) };
            Plan::ReadBack(Arc::new(readback))
        }
        Err(Refused::OverLimit { held }) => Plan::NotReadBack(
            "readback-memory",
            format!(
                "their GPU readback needs {size} bytes of layer memory and {held} of the {limit} allowed are held (raise gpu_readback_max_bytes, {GPU_READBACK_MAX_BYTES})"
            ),
        ),
        Err(Refused::Setup(reason)) => Plan::NotReadBack(
            "readback-setup",
            format!("the layer could not set up GPU readback: {reason}"),
        ),
    }
}

/// The information that inputs of `build` (recorded in `command_buffer`)
/// whose place is known only when the GPU runs it are not checked: once
/// per device and cause ([`CONTENTS_NOT_CHECKED`]), said at recording.
/// Neither route reads them: transfers and readback follow the windows
/// known at recording, and these depend on bytes in device memory: the
/// instances behind an array of pointers the host cannot read now (or of
/// an indirect build, whose pointer count the GPU reads), and an indirect
/// build's inputs where it was given no range info addresses.
pub fn unplaced_messages(
    state: &mut DeviceState,
    command_buffer: vk::CommandBuffer,
    build: &DeviceBuild,
) -> Vec<Message> {
    let unplaced = build.unplaced_reads();
    // Most builds have no array of pointers: they skip listing their reads.
    let has_pointers = match build {
        DeviceBuild::AccelerationStructures { infos, .. } => infos.iter().any(|info| {
            info.geometries_read().any(
                |(_, g)| matches!(&g.geometry, GeometryData::Instances(d) if d.array_of_pointers),
            )
        }),
        DeviceBuild::Micromaps(_) => false,
    };
    let reads = if has_pointers {
        build.content_reads()
    } else {
        Vec::new()
    };
    let pointers_unknown: Vec<String> = reads
        .iter()
        .filter(|read| {
            read.kind == ReadKind::InstancePointers
                && pointed_instances(state, read, memory_layout::mapped_window).is_none()
        })
        .map(|read| read.location.clone())
        .collect();
    let causes = [
        (
            "indirect-ranges",
            unplaced.without_ranges,
            "their extent comes from the build range infos (primitiveCount, primitiveOffset) the GPU reads, and pIndirectDeviceAddresses gives none for them, so the rules over them (opacity indices, instances) are not checked".to_owned(),
        ),
        (
            "instance-pointers",
            pointers_unknown,
            format!("with arrayOfPointers the instances are wherever the pointers point, and the layer records the copies that read them back when the build is recorded, when it can read the pointers only from memory the application has mapped (and at most {MAX_POINTERS_FOLLOWED} of them, and not for an indirect build, whose pointer count the GPU reads). These pointers lie elsewhere, so the instances they point to are checked only if at submission the host knows the pointers and the instances (mapped memory, followed transfers); otherwise the rules over those instances are not checked. Keep the array of pointers in mapped memory, or pass the instances themselves (arrayOfPointers VK_FALSE), to have them checked"),
        ),
    ];
    let function = build.function();
    let mut messages = Vec::new();
    for (cause, locations, why) in causes {
        if locations.is_empty() || !state.memory_layout.first_report(cause) {
            continue;
        }
        let text = format!(
            "the inputs at {} of a build recorded in VkCommandBuffer {:#x} are not checked: {why}. This is reported once per device and reason.",
            locations.join(", "),
            command_buffer.as_raw()
        );
        messages.push(not_checked(function, command_buffer.as_raw(), &text));
    }
    messages
}

/// The information that inputs an indirect build's range infos place
/// outside the bytes the layer read (`unread`, from
/// [`ommcheck::Validator::check_device_build_contents_unread`]) are not
/// checked: once per device ([`CONTENTS_NOT_CHECKED`], cause
/// `indirect-unread`), said where the build was checked (`when`).
pub fn unread_message(
    state: &mut DeviceState,
    command_buffer: u64,
    build: &DeviceBuild,
    unread: &[String],
    when: &str,
) -> Option<Message> {
    if unread.is_empty() || !state.memory_layout.first_report("indirect-unread") {
        return None;
    }
    let text = format!(
        "the inputs {} of an indirect build recorded in VkCommandBuffer {command_buffer:#x} are not checked at {when}: the build range infos lie, or place them, outside the bytes the layer read. The layer reads each input whose extent the range infos decide from its start towards the end of its buffer, at most gpu_readback_indirect_max_bytes ({GPU_READBACK_INDIRECT_MAX_BYTES}) bytes; raise it if the ranges reach further. This is reported once per device and reason.",
        unread.join("; ")
    );
    Some(not_checked(build.function(), command_buffer, &text))
}

/// A [`CONTENTS_NOT_CHECKED`] information about a build of `command_buffer`.
fn not_checked(function: &'static str, command_buffer: u64, text: &str) -> Message {
    let mut message = Message::about_layer(CONTENTS_NOT_CHECKED, Severity::Info, function, text);
    message
        .objects
        .push((vk::ObjectType::COMMAND_BUFFER, command_buffer));
    message
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // The arena is plain bookkeeping updated in single steps.
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Why the arena gave no range.
enum Refused {
    OverLimit { held: u64 },
    Setup(String),
}

/// Blocks of a device's readback memory are at least this large, so most
/// recorded builds take a range of an existing block rather than a new
/// allocation from the driver.
const BLOCK_BYTES: u64 = 4 << 20;

/// One host-visible, host-coherent buffer of the layer's, bound to its own
/// memory and mapped whole, with the ranges not taken.
#[derive(Debug)]
struct Block {
    id: u64,
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    mapped: usize,
    size: u64,
    /// Free ranges `(offset, len)`, sorted and not touching.
    free: Vec<(u64, u64)>,
}

/// A device's readback memory: blocks sub-allocated first fit. A block
/// left wholly free is given back to the driver unless it is the only one.
#[derive(Debug, Default)]
pub struct Arena {
    blocks: Vec<Block>,
    next_id: u64,
    /// Bytes of the ranges taken (what `gpu_readback_max_bytes` bounds).
    held: u64,
    /// The next layer's functions to give blocks back with, and the device.
    release_with: Option<(vk::Device, vk::PFN_vkDestroyBuffer, vk::PFN_vkFreeMemory)>,
}

impl Arena {
    /// A range of `size` bytes: (block, offset, the block's buffer, the
    /// range's host address).
    fn take(
        &mut self,
        data: &DeviceData,
        size: u64,
        limit: u64,
    ) -> Result<(u64, u64, vk::Buffer, usize), Refused> {
        if self.held.saturating_add(size) > limit {
            return Err(Refused::OverLimit { held: self.held });
        }
        let taken = match self.fit(size) {
            Some(taken) => taken,
            None => {
                let block_size = size.max(BLOCK_BYTES.min(limit));
                let mut block = allocate(data, block_size).map_err(Refused::Setup)?;
                self.next_id += 1;
                block.id = self.next_id;
                if block_size > size {
                    block.free.push((size, block_size - size));
                }
                let taken = (block.id, 0, block.buffer, block.mapped);
                if let (Some(destroy_buffer), Some(free_memory)) =
                    (data.fns.destroy_buffer, data.fns.free_memory)
                {
                    self.release_with = Some((data.handle, destroy_buffer, free_memory));
                }
                self.blocks.push(block);
                taken
            }
        };
        self.held += size;
        Ok(taken)
    }

    /// A range of `size` bytes from a block that has room, first fit.
    fn fit(&mut self, size: u64) -> Option<(u64, u64, vk::Buffer, usize)> {
        self.blocks.iter_mut().find_map(|block| {
            let k = block.free.iter().position(|&(_, len)| len >= size)?;
            let (offset, len) = block.free[k];
            if len == size {
                block.free.remove(k);
            } else {
                block.free[k] = (offset + size, len - size);
            }
            Some((
                block.id,
                offset,
                block.buffer,
                block.mapped + offset as usize,
            ))
        })
    }

    /// Returns a range taken from `block`.
    fn release(&mut self, block: u64, offset: u64, size: u64) {
        let Some(k) = self.blocks.iter().position(|b| b.id == block) else {
            return; // The device's blocks were given back already.
        };
        self.held = self.held.saturating_sub(size);
        let b = &mut self.blocks[k];
        let at = b.free.partition_point(|&(o, _)| o < offset);
        b.free.insert(at, (offset, size));
        // Merge with the neighbours it touches.
        if at + 1 < b.free.len() && b.free[at].0 + b.free[at].1 == b.free[at + 1].0 {
            b.free[at].1 += b.free[at + 1].1;
            b.free.remove(at + 1);
        }
        if at > 0 && b.free[at - 1].0 + b.free[at - 1].1 == b.free[at].0 {
            b.free[at - 1].1 += b.free[at].1;
            b.free.remove(at);
        }
        let wholly_free = b.free == [(0, b.size)];
        if wholly_free && self.blocks.len() > 1 {
            let block = self.blocks.remove(k);
            self.give_back(block);
        }
    }

    /// Gives every block back to the driver (before the device is destroyed).
    pub fn give_back_all(&mut self) {
        for block in std::mem::take(&mut self.blocks) {
            self.give_back(block);
        }
        self.held = 0;
    }

    fn give_back(&self, block: Block) {
        if let Some((device, destroy_buffer, free_memory)) = self.release_with {
            // SAFETY: the layer created both with the next layer's
            // functions of this device, which is alive (blocks go before
            // vkDestroyDevice is passed on), and no pending submission
            // copies into them (every range was returned).
            unsafe {
                destroy_buffer(device, block.buffer, std::ptr::null());
                free_memory(device, block.memory, std::ptr::null());
            }
        }
    }
}

/// Creates, binds and maps a host-visible, host-coherent buffer of `size`
/// bytes through the next layer.
fn allocate(data: &DeviceData, size: u64) -> Result<Block, String> {
    let f = &data.fns;
    let device = data.handle;
    let (
        Some(create_buffer),
        Some(destroy_buffer),
        Some(requirements),
        Some(allocate_memory),
        Some(free_memory),
        Some(bind),
        Some(map),
    ) = (
        f.create_buffer,
        f.destroy_buffer,
        f.memory.get_buffer_memory_requirements,
        f.allocate_memory,
        f.free_memory,
        f.bind_buffer_memory,
        f.map_memory,
    )
    else {
        return Err("the next layer lacks a buffer or memory function".into());
    };
    let info = vk::BufferCreateInfo::default()
        .size(size)
        .usage(vk::BufferUsageFlags::TRANSFER_DST)
        .sharing_mode(vk::SharingMode::EXCLUSIVE);
    let mut buffer = vk::Buffer::null();
    // SAFETY: the next layer's function, with a valid create info.
    let result = unsafe { create_buffer(device, &info, std::ptr::null(), &mut buffer) };
    if result != vk::Result::SUCCESS {
        return Err(format!("vkCreateBuffer returned {result:?}"));
    }
    let mut needs = vk::MemoryRequirements::default();
    // SAFETY: the buffer just created, and a structure to fill.
    unsafe { requirements(device, buffer, &mut needs) };
    let wanted = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
    let memory_type = data.memory_properties.as_ref().and_then(|p| {
        let types = p.memory_types_as_slice();
        let fits = |i: usize, flags: vk::MemoryPropertyFlags| {
            needs.memory_type_bits & (1 << i) != 0 && types[i].property_flags.contains(flags)
        };
        // Cached memory reads faster on the host; any coherent type will do.
        (0..types.len().min(32))
            .find(|&i| fits(i, wanted | vk::MemoryPropertyFlags::HOST_CACHED))
            .or_else(|| (0..types.len().min(32)).find(|&i| fits(i, wanted)))
    });
    let undo_buffer = || {
        // SAFETY: the buffer just created, unused.
        unsafe { destroy_buffer(device, buffer, std::ptr::null()) }
    };
    let Some(memory_type) = memory_type else {
        undo_buffer();
        return Err(
            "the device reports no host-visible, host-coherent memory type for a transfer buffer"
                .into(),
        );
    };
    let allocate_info = vk::MemoryAllocateInfo::default()
        .allocation_size(needs.size)
        .memory_type_index(memory_type as u32);
    let mut memory = vk::DeviceMemory::null();
    // SAFETY: the next layer's function, with a valid allocate info.
    let result = unsafe { allocate_memory(device, &allocate_info, std::ptr::null(), &mut memory) };
    if result != vk::Result::SUCCESS {
        undo_buffer();
        return Err(format!(
            "vkAllocateMemory of {} bytes returned {result:?}",
            needs.size
        ));
    }
    let mut mapped: *mut std::ffi::c_void = std::ptr::null_mut();
    // SAFETY: the buffer and memory just created; the whole allocation is mapped.
    let bound = unsafe { bind(device, buffer, memory, 0) };
    let result = match bound {
        vk::Result::SUCCESS => unsafe {
            map(
                device,
                memory,
                0,
                vk::WHOLE_SIZE,
                vk::MemoryMapFlags::empty(),
                &mut mapped,
            )
        },
        failed => failed,
    };
    if result != vk::Result::SUCCESS || mapped.is_null() {
        undo_buffer();
        // SAFETY: the memory just allocated, not in use.
        unsafe { free_memory(device, memory, std::ptr::null()) };
        return Err(format!(
            "binding or mapping the readback memory returned {result:?}"
        ));
    }
    Ok(Block {
        id: 0,
        buffer,
        memory,
        mapped: mapped as usize,
        size,
        free: Vec::new(),
    })
}

/// Records the barrier, the copies and the barrier of `readback` into
/// `command_buffer` through the next layer.
///
/// # Safety
/// `command_buffer` must be an application command buffer of the device,
/// in the recording state, outside a render pass.
unsafe fn record_copies(data: &DeviceData, command_buffer: vk::CommandBuffer, readback: &Readback) {
    let (Some(barrier), Some(copy)) = (
        data.fns.memory.cmd_pipeline_barrier,
        data.fns.memory.cmd_copy_buffer,
    ) else {
        return;
    };
    // One global memory barrier from `src` to `dst`.
    let memory_barrier = |src: (vk::PipelineStageFlags, vk::AccessFlags),
                          dst: (vk::PipelineStageFlags, vk::AccessFlags)| {
        let memory = vk::MemoryBarrier::default()
            .src_access_mask(src.1)
            .dst_access_mask(dst.1);
        // SAFETY: the next layer's function, with the caller's recording
        // command buffer and one barrier.
        unsafe {
            barrier(
                command_buffer,
                src.0,
                dst.0,
                vk::DependencyFlags::empty(),
                1,
                &memory,
                0,
                std::ptr::null(),
                0,
                std::ptr::null(),
            )
        };
    };
    let transfer_read = (
        vk::PipelineStageFlags::TRANSFER,
        vk::AccessFlags::TRANSFER_READ,
    );
    // Every earlier write (an upload, a shader) is visible to the copies.
    memory_barrier(
        (
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::AccessFlags::MEMORY_WRITE,
        ),
        transfer_read,
    );
    for w in &readback.windows {
        let region = vk::BufferCopy {
            src_offset: w.offset,
            dst_offset: readback.offset + w.at,
            size: w.len,
        };
        // SAFETY: the next layer's function, with the caller's recording
        // command buffer, the application's buffer (created with
        // TRANSFER_SRC: see `plan`) and the layer's own.
        unsafe {
            copy(
                command_buffer,
                vk::Buffer::from_raw(w.buffer),
                readback.buffer,
                1,
                &region,
            )
        };
    }
    // The copies' writes are visible to the host at completion.
    memory_barrier(
        (
            vk::PipelineStageFlags::TRANSFER,
            vk::AccessFlags::TRANSFER_WRITE,
        ),
        (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
    );
}

/// Usages that make a buffer a build input read by device address.
const BUILD_INPUT_USAGES: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT.as_raw()
        | vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw(),
);

/// The create info to pass down for `info`: with
/// `VK_BUFFER_USAGE_TRANSFER_SRC_BIT` added where the buffer is a build
/// input, so the layer may copy it for GPU readback. A buffer whose usage
/// comes from a chained `VkBufferUsageFlags2CreateInfo` is left as it is
/// (its readback is then reported as not possible).
pub fn with_transfer_source<'a>(
    info: &vk::BufferCreateInfo<'a>,
    usage_chained: bool,
    readback_on: bool,
) -> Option<vk::BufferCreateInfo<'a>> {
    let wants = readback_on
        && !usage_chained
        && info.usage.intersects(BUILD_INPUT_USAGES)
        && !info.usage.contains(vk::BufferUsageFlags::TRANSFER_SRC);
    wants.then(|| {
        let mut copy = *info;
        copy.usage |= vk::BufferUsageFlags::TRANSFER_SRC;
        copy
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(id: u64, size: u64) -> Block {
        Block {
            id,
            buffer: vk::Buffer::null(),
            memory: vk::DeviceMemory::null(),
            mapped: 0x1000,
            size,
            free: vec![(0, size)],
        }
    }

    #[test]
    fn ranges_are_taken_first_fit_and_merged_back_when_returned() {
        let mut arena = Arena {
            blocks: vec![block(1, 64), block(2, 64)],
            ..Arena::default()
        };
        let a = arena.fit(16).expect("room");
        let b = arena.fit(32).expect("room");
        let c = arena.fit(32).expect("room in the second block");
        assert_eq!((a.0, a.1, a.3), (1, 0, 0x1000));
        assert_eq!((b.0, b.1, b.3), (1, 16, 0x1010));
        assert_eq!((c.0, c.1), (2, 0));
        assert!(arena.fit(48).is_none());
        arena.held = 80;
        arena.release(1, 0, 16);
        arena.release(1, 16, 32);
        assert_eq!(arena.blocks.len(), 1, "a wholly free block goes back");
        assert_eq!(arena.blocks[0].id, 2);
        arena.release(2, 0, 32);
        assert_eq!(arena.blocks.len(), 1, "the last block stays");
        assert_eq!(arena.blocks[0].free, [(0, 64)]);
        assert_eq!(arena.held, 0);
    }

    /// A readback whose range is `memory` (standing in for a mapped block),
    /// with one window at `at` of `len` bytes of buffer 9.
    fn readback_over(memory: &[u8], at: u64, len: u64) -> Arc<Readback> {
        Arc::new(Readback {
            size: memory.len() as u64,
            mapped: memory.as_ptr().expose_provenance(),
            windows: vec![Window {
                location: "pInfos[0].triangleArray".into(),
                buffer: 9,
                offset: 0,
                len,
                at,
            }],
            arena: Arc::default(),
            block: 0,
            offset: 0,
            buffer: vk::Buffer::null(),
            views: Mutex::default(),
            spares: Mutex::default(),
        })
    }

    #[test]
    fn contents_are_views_kept_until_the_range_is_written_again() {
        use ommcheck::sim::decode::{MicromapContent, TriangleEntries};
        use ommcheck::state::{BuildRecord, Micromap, State};
        let memory: Vec<u8> = (0..64).collect();
        let readback = readback_over(&memory, 16, 16);
        let contents = readback.contents();
        assert_eq!(contents.len(), 1);
        let bytes = contents[0].bytes.clone();
        assert_eq!(&bytes[..], &memory[16..32]);
        assert_eq!(bytes.as_ptr(), memory[16..].as_ptr(), "a view, not a copy");
        assert_eq!(Arc::strong_count(&readback), 2, "the view keeps the range");
        // What a check keeps: a built micromap's triangles.
        let keep = |state: &mut State, bytes| {
            let triangles = TriangleEntries::shared(bytes, 0, 8, 2).expect("inside");
            let content = MicromapContent::new(triangles, Default::default());
            state.micromaps.insert(
                1,
                Micromap {
                    built: Some(BuildRecord {
                        content: Some(Arc::new(content)),
                        ..BuildRecord::default()
                    }),
                    ..Micromap::default()
                },
            );
        };
        let kept = |state: &State| {
            let content = state.micromaps[&1].built.as_ref().unwrap().content.clone();
            content.expect("kept")
        };
        let mut state = State::default();
        keep(&mut state, bytes);
        drop(contents);
        // Before a later submission copies into the range again.
        readback.own_views(&mut state);
        assert_eq!(Arc::strong_count(&readback), 1, "no view is left");
        let content = kept(&state);
        assert_eq!(content.triangles.iter().count(), 2);
        assert_eq!(
            content.triangles.get(0).map(|t| t.data_offset),
            Some(u32::from_le_bytes([16, 17, 18, 19])),
            "the same bytes, now a copy"
        );
        let spare = |readback: &Readback| {
            let spares = lock(&readback.spares);
            spares.iter().map(|b| b.as_ptr()).collect::<Vec<_>>()
        };
        let first_copy = spare(&readback);
        assert_eq!(first_copy.len(), 1, "the copy's memory is kept");
        // The next completion keeps views again, letting go of the copy,
        // whose memory the next submission's copy reuses.
        drop(content);
        let contents = readback.contents();
        keep(&mut state, contents[0].bytes.clone());
        drop(contents);
        readback.own_views(&mut state);
        assert_eq!(Arc::strong_count(&readback), 1);
        assert_eq!(spare(&readback), first_copy, "reused, not allocated");
        assert_eq!(
            kept(&state).triangles.get(1).map(|t| t.format),
            Some(31 << 8 | 30)
        );
        // A window past the range gives no bytes.
        assert!(readback_over(&memory, 60, 16).contents().is_empty());
    }

    #[test]
    fn build_inputs_gain_the_transfer_source_usage() {
        let input = vk::BufferCreateInfo::default().usage(
            vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        );
        let passed = with_transfer_source(&input, false, true).expect("changed");
        assert!(passed.usage.contains(vk::BufferUsageFlags::TRANSFER_SRC));
        assert!(passed.usage.contains(input.usage));
        // Other buffers, chained usage, or readback off: passed unchanged.
        let other = vk::BufferCreateInfo::default().usage(vk::BufferUsageFlags::STORAGE_BUFFER);
        assert!(with_transfer_source(&other, false, true).is_none());
        assert!(with_transfer_source(&input, true, true).is_none());
        assert!(with_transfer_source(&input, false, false).is_none());
    }
}
