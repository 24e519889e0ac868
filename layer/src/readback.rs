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

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::checks::device_contents::{DeviceBuild, Extent, KnownBytes};

use crate::dispatch::{DeviceData, DeviceState};
use crate::read;
use crate::settings::{GPU_READBACK, GPU_READBACK_MAX_BYTES};

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
    /// The window's start in the readback buffer.
    pub at: u64,
}

/// The layer's host-visible copy of the windows one recorded build reads.
/// Dropping it destroys the layer's buffer and frees its memory, which the
/// command buffer's reset, free or pool destruction allows (the command
/// buffer is then not pending).
#[derive(Debug)]
pub struct Readback {
    device: vk::Device,
    destroy_buffer: vk::PFN_vkDestroyBuffer,
    free_memory: vk::PFN_vkFreeMemory,
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    /// Where `vkMapMemory` mapped `memory` (all of it).
    mapped: usize,
    /// Bytes counted against the device's `gpu_readback_max_bytes`.
    size: u64,
    held: Arc<AtomicU64>,
    pub windows: Vec<Window>,
}

impl Drop for Readback {
    fn drop(&mut self) {
        // SAFETY: the layer created both with the next layer's functions of
        // this device, which is alive (its command buffers are dropped
        // before vkDestroyDevice is passed on), and no submission that
        // copies into them is pending (see the type's comment).
        unsafe {
            (self.destroy_buffer)(self.device, self.buffer, std::ptr::null());
            (self.free_memory)(self.device, self.memory, std::ptr::null());
        }
        self.held.fetch_sub(self.size, Ordering::Relaxed);
    }
}

impl Readback {
    /// The bytes the copies wrote, one window each, for the content checks.
    /// Call only once the submission that ran them is complete.
    pub fn contents(&self) -> Vec<KnownBytes> {
        self.windows
            .iter()
            .filter_map(|window| {
                let address = self.mapped.checked_add(usize::try_from(window.at).ok()?)?;
                let len = usize::try_from(window.len).ok()?;
                // SAFETY: `[at, at + len)` lies inside the readback buffer,
                // which lies inside the mapped allocation (it was sized to
                // hold every window), and the memory is host-coherent.
                let bytes = unsafe { read::mapped_bytes(address, len) };
                Some(KnownBytes {
                    buffer: window.buffer,
                    offset: window.offset,
                    bytes,
                })
            })
            .collect()
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

/// The windows `build` reads, by buffer (one hull per buffer), as far as
/// each buffer reaches; Err names an input no tracked buffer holds.
pub fn windows(state: &DeviceState, build: &DeviceBuild) -> Result<Vec<Window>, String> {
    let tracked = state.validator.state();
    let mut windows: Vec<Window> = Vec::new();
    for read in build.content_reads() {
        let found = tracked
            .buffers_at(read.address)
            .find_map(|(handle, b)| Some((handle, b.address_range()?.0, b.size)));
        let Some((buffer, start, size)) = found else {
            return Err(format!(
                "no buffer whose device address the layer knows (from vkGetBufferDeviceAddress) holds {} ({:#x})",
                read.location, read.address
            ));
        };
        let offset = read.address - start;
        let left = size.saturating_sub(offset);
        let len = match read.extent {
            Extent::Bytes(n) => n.min(left),
            Extent::ToBufferEnd | Extent::Overflow => left,
        };
        if len == 0 {
            continue;
        }
        match windows.iter_mut().find(|w| w.buffer == buffer) {
            Some(w) => {
                let end = (w.offset + w.len).max(offset + len);
                w.offset = w.offset.min(offset);
                w.len = end - w.offset;
            }
            None => windows.push(Window {
                location: read.location,
                buffer,
                offset,
                len,
                at: 0,
            }),
        }
    }
    Ok(windows)
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
    let mut windows = match windows(state, build) {
        Ok(windows) => windows,
        Err(reason) => return Plan::NotReadBack("unknown-address", reason),
    };
    for w in &windows {
        state.shadows.watch(w.buffer, w.offset, w.offset + w.len);
    }
    if windows
        .iter()
        .all(|w| crate::submit::host_can_read(state, w.buffer, w.offset, w.len))
    {
        return Plan::AtSubmission;
    }
    let settings = data.instance.reporter.settings();
    if !settings.gpu_readback {
        return Plan::NotReadBack("readback-off", format!(
            "they lie in memory the host cannot read and GPU readback is off (setting gpu_readback, {GPU_READBACK})"
        ));
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
        size = size.saturating_add(w.len.next_multiple_of(WINDOW_ALIGNMENT));
    }
    let held = &state.readback_held;
    let limit = settings.gpu_readback_max_bytes;
    let now = held.load(Ordering::Relaxed);
    if now.saturating_add(size) > limit {
        return Plan::NotReadBack("readback-memory", format!(
            "their GPU readback needs {size} bytes of layer memory and {now} of the {limit} allowed are held (raise gpu_readback_max_bytes, {GPU_READBACK_MAX_BYTES})"
        ));
    }
    match allocate(data, size, Arc::clone(held), windows) {
        Ok(readback) => {
            // SAFETY: the application's command buffer, recording (the
            // build command being recorded requires it).
            unsafe { record_copies(data, command_buffer, &readback) };
            Plan::ReadBack(Arc::new(readback))
        }
        Err(reason) => Plan::NotReadBack(
            "readback-setup",
            format!("the layer could not set up GPU readback: {reason}"),
        ),
    }
}

/// Creates, binds and maps a host-visible, host-coherent buffer of `size`
/// bytes through the next layer.
fn allocate(
    data: &DeviceData,
    size: u64,
    held: Arc<AtomicU64>,
    windows: Vec<Window>,
) -> Result<Readback, String> {
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
        .size(size.max(WINDOW_ALIGNMENT))
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
    held.fetch_add(size, Ordering::Relaxed);
    Ok(Readback {
        device,
        destroy_buffer,
        free_memory,
        buffer,
        memory,
        mapped: mapped as usize,
        size,
        held,
        windows,
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
    let before = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
        .dst_access_mask(vk::AccessFlags::TRANSFER_READ);
    let after = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
        .dst_access_mask(vk::AccessFlags::HOST_READ);
    // SAFETY: the next layer's functions, with the caller's recording
    // command buffer, the application's buffers (created with
    // TRANSFER_SRC: see `plan`) and the layer's own.
    unsafe {
        barrier(
            command_buffer,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::TRANSFER,
            vk::DependencyFlags::empty(),
            1,
            &before,
            0,
            std::ptr::null(),
            0,
            std::ptr::null(),
        );
        for w in &readback.windows {
            let region = vk::BufferCopy {
                src_offset: w.offset,
                dst_offset: w.at,
                size: w.len,
            };
            copy(
                command_buffer,
                vk::Buffer::from_raw(w.buffer),
                readback.buffer,
                1,
                &region,
            );
        }
        barrier(
            command_buffer,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            1,
            &after,
            0,
            std::ptr::null(),
            0,
            std::ptr::null(),
        );
    }
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
