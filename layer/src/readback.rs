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
//! usage ([`with_transfer_source`]). Layer memory
//! ([`crate::dispatch::readback_memory`]) is bounded per device by
//! the `gpu_readback_max_bytes` setting; a build past it is not checked,
//! and says so.

#![allow(unsafe_code)]

use std::sync::Arc;

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::build_inputs::{ContentRead, DeviceBuild, Extent, ReadKind, INSTANCE_SIZE};
use ommcheck::model::accel::GeometryData;
use ommcheck::Severity;

use crate::dispatch::memory_layout;
use crate::dispatch::readback_memory::{Readback, Refused, Window};
use crate::dispatch::{DeviceData, DeviceState};
use crate::own_calls::{self, OwnCall};
use crate::report::{Message, CONTENTS_NOT_CHECKED};
use crate::settings::{GPU_READBACK, GPU_READBACK_INDIRECT_MAX_BYTES, GPU_READBACK_MAX_BYTES};

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
    match Readback::take(data, size, limit, windows) {
        Ok(readback) => {
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
        // Nothing was recorded and nothing is kept: the next build recorded
        // asks the next layer again.
        Err(Refused::Failed(failed)) => Plan::NotReadBack(
            failed.call.cause(),
            format!("the layer could not set up GPU readback: {failed}; it tries again for the next build it records"),
        ),
    }
}

/// The warning that inputs of `build` (recorded in `command_buffer`)
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
            "the inputs at {} of a build recorded in VkCommandBuffer {:#x} are not checked: {why}. {}",
            locations.join(", "),
            command_buffer.as_raw(),
            once_per_cause(cause)
        );
        messages.push(not_checked(function, command_buffer.as_raw(), &text));
    }
    messages
}

/// The warning that inputs an indirect build's range infos place
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
        "the inputs {} of an indirect build recorded in VkCommandBuffer {command_buffer:#x} are not checked at {when}: the build range infos lie, or place them, outside the bytes the layer read. The layer reads each input whose extent the range infos decide from its start towards the end of its buffer, at most gpu_readback_indirect_max_bytes ({GPU_READBACK_INDIRECT_MAX_BYTES}) bytes; raise it if the ranges reach further. {}",
        unread.join("; "),
        once_per_cause("indirect-unread")
    );
    Some(not_checked(build.function(), command_buffer, &text))
}

/// A [`CONTENTS_NOT_CHECKED`] warning about a build of `command_buffer`.
/// A warning, not information, so that it shows at the default report
/// level: a clean default report must mean checked.
pub fn not_checked(function: &'static str, command_buffer: u64, text: &str) -> Message {
    let mut message = Message::about_layer(CONTENTS_NOT_CHECKED, Severity::Warning, function, text);
    message
        .objects
        .push((vk::ObjectType::COMMAND_BUFFER, command_buffer));
    message
}

/// The sentence that ends each [`CONTENTS_NOT_CHECKED`] warning: how
/// often it is said and where the count of the builds it affected is.
pub fn once_per_cause(cause: &str) -> String {
    format!("This is reported once per device and cause (`{cause}`); where more builds follow, vkDestroyDevice reports how many in all.")
}

/// The [`CONTENTS_NOT_CHECKED`] warnings of `device`'s destruction: for
/// each cause that kept more than one build from being checked, how many
/// (`counts`, from `MemoryLayout::not_checked_counts`). A cause that
/// affected one build says nothing more: its first warning said it all.
pub fn not_checked_totals(device: u64, counts: &[(&'static str, u64)]) -> Vec<Message> {
    counts
        .iter()
        .filter(|(_, count)| *count > 1)
        .map(|(cause, count)| {
            let text = format!(
                "the contents of {count} device builds on VkDevice {device:#x} were not checked for the cause `{cause}`, whose first build was reported with the reason. A build counts each time the layer could not read it: at each submission, at each recording for inputs only the GPU places, or at a wait where the layer could not learn whether its submission was complete."
            );
            let mut message = Message::about_layer(
                CONTENTS_NOT_CHECKED,
                Severity::Warning,
                "vkDestroyDevice",
                &text,
            );
            message.objects.push((vk::ObjectType::DEVICE, device));
            message
        })
        .collect()
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
        own_calls::call(OwnCall::ReadbackBarrier, || {
            // SAFETY: the next layer's function, with the caller's
            // recording command buffer and one barrier.
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
            }
        });
    };
    let (buffer, range_offset) = readback.destination();
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
            dst_offset: range_offset + w.at,
            size: w.len,
        };
        own_calls::call(OwnCall::ReadbackCopy, || {
            // SAFETY: the next layer's function, with the caller's
            // recording command buffer, the application's buffer (created
            // with TRANSFER_SRC: see `plan`) and the layer's own.
            unsafe {
                copy(
                    command_buffer,
                    vk::Buffer::from_raw(w.buffer),
                    buffer,
                    1,
                    &region,
                )
            }
        });
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

    #[test]
    fn causes_are_counted_and_totals_said_where_more_than_one_build_was_affected() {
        let mut layout = crate::dispatch::memory_layout::MemoryLayout::default();
        assert!(layout.first_report("not-planned"));
        assert!(!layout.first_report("not-planned"));
        assert!(layout.first_report("indirect-unread"));
        assert!(!layout.first_report("not-planned"));
        let counts = layout.not_checked_counts();
        assert_eq!(counts, [("not-planned", 3), ("indirect-unread", 1)]);
        let totals = not_checked_totals(0xd, counts);
        assert_eq!(totals.len(), 1, "{totals:?}");
        assert_eq!(totals[0].id, CONTENTS_NOT_CHECKED);
        assert_eq!(totals[0].severity, Severity::Warning);
        assert_eq!(totals[0].objects, [(vk::ObjectType::DEVICE, 0xd)]);
        assert!(
            totals[0].text.contains(
                "vkDestroyDevice(): the contents of 3 device builds on VkDevice 0xd were not checked for the cause `not-planned`"
            ),
            "{}",
            totals[0].text
        );
        assert!(not_checked_totals(0xd, &[("not-planned", 1)]).is_empty());
    }

    #[test]
    fn a_build_not_checked_is_a_warning_that_says_where_the_count_is() {
        let message = not_checked(
            "vkCmdBuildMicromapsEXT",
            0xc,
            &once_per_cause("not-planned"),
        );
        assert_eq!(message.severity, Severity::Warning);
        assert_eq!(message.objects, [(vk::ObjectType::COMMAND_BUFFER, 0xc)]);
        assert!(message
            .text
            .starts_with("Validation Warning: [ OMMCHECK-layer-contents-not-checked ]"));
        assert!(message.text.ends_with("This is reported once per device and cause (`not-planned`); where more builds follow, vkDestroyDevice reports how many in all."), "{}", message.text);
    }
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
