//! Queue submission: the contents of the device builds a submitted command
//! buffer runs are read here, before the GPU can change them, from the
//! buffers holding them where those are bound to host-visible memory the
//! application has mapped, and handed to the core as buffer contents
//! ([`ommcheck::Validator::check_device_build_contents`]). Contents in
//! memory the layer cannot read are reported once per device
//! ([`CONTENTS_NOT_CHECKED`]).

#![allow(unsafe_code)]

use std::collections::BTreeMap;
use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;
use foldhash::HashMap;
use ommcheck::raw::MAX_HOST_BYTES;
use ommcheck::state::Handle;
use ommcheck::Severity;

use crate::commands::{self, KeptBuild};
use crate::device::{as_void, device_and};
use crate::dispatch::{DeviceData, DeviceFns, DeviceState};
use crate::report::{Message, CONTENTS_NOT_CHECKED};
use crate::{guarded, panic_message, read};

/// Where buffers lie in device memory and where memory is mapped.
#[derive(Debug, Default)]
pub struct MemoryLayout {
    /// Buffer → (memory, offset in it) from vkBindBufferMemory(2).
    bound: HashMap<u64, (u64, u64)>,
    /// Memory → offset of its mapping (the host range is in `DeviceState::mappings`).
    mapped_at: HashMap<u64, u64>,
    /// [`CONTENTS_NOT_CHECKED`] was reported for this device.
    reported_unreadable: bool,
}

impl MemoryLayout {
    pub fn bind(&mut self, buffer: u64, memory: u64, offset: u64) {
        self.bound.insert(buffer, (memory, offset));
    }

    pub fn forget_buffer(&mut self, buffer: u64) {
        self.bound.remove(&buffer);
    }

    pub fn map(&mut self, memory: u64, offset: u64) {
        self.mapped_at.insert(memory, offset);
    }

    pub fn unmap(&mut self, memory: u64) {
        self.mapped_at.remove(&memory);
    }
}

/// The next layer's submission function for one of the submit commands.
pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkQueueSubmit" => as_void(queue_submit as vk::PFN_vkQueueSubmit),
        b"vkQueueSubmit2" => as_void(queue_submit2 as vk::PFN_vkQueueSubmit2),
        b"vkQueueSubmit2KHR" => as_void(queue_submit2_khr as vk::PFN_vkQueueSubmit2),
        _ => None,
    }
}

/// Why the bytes of one buffer could not be read at submission.
fn unreadable_reason(state: &DeviceState, buffer: Handle) -> Option<&'static str> {
    let tracked = state.validator.state().buffers.get(&buffer)?;
    let Some(binding) = tracked.memory else {
        return Some("the buffer holding them is not bound to memory");
    };
    if !binding.host_visible {
        return Some("the buffer holding them is bound to memory that is not host-visible (device-local), which the host cannot read");
    }
    let mapped = state
        .memory_layout
        .bound
        .get(&buffer)
        .and_then(|(memory, _)| state.memory_layout.mapped_at.get(memory));
    match mapped {
        None => Some("the buffer holding them is bound to host-visible memory that is not mapped at submission"),
        Some(_) => Some("the mapping of the buffer's memory does not cover the buffer's start"),
    }
}

/// The bytes of `buffer` from its start, as far as its memory's mapping,
/// its size and [`MAX_HOST_BYTES`] allow; None when its start is not mapped.
fn mapped_contents(state: &DeviceState, buffer: Handle) -> Option<Arc<[u8]>> {
    let size = state.validator.state().buffers.get(&buffer)?.size;
    let &(memory, offset) = state.memory_layout.bound.get(&buffer)?;
    let &mapped_offset = state.memory_layout.mapped_at.get(&memory)?;
    let mapping = state.mappings.get(&memory)?;
    // The buffer's start inside the mapping.
    let into_mapping = offset.checked_sub(mapped_offset)?;
    let left_in_mapping = mapping.len.checked_sub(into_mapping)?;
    let len = size.min(left_in_mapping).min(MAX_HOST_BYTES);
    if len == 0 {
        return None;
    }
    let address = usize::try_from(mapping.address.checked_add(into_mapping)?).ok()?;
    let len = usize::try_from(len).ok()?;
    address.checked_add(len)?;
    // SAFETY: `[address, address + len)` lies inside the range vkMapMemory
    // returned for this memory, which stays mapped until vkUnmapMemory or
    // vkFreeMemory (both of which forget the mapping here).
    Some(unsafe { read::mapped_bytes(address, len) })
}

/// The messages of one kept build's content checks.
fn check_kept(
    data: &DeviceData,
    command_buffer: u64,
    kept: &KeptBuild,
    submit_function: &'static str,
) -> Vec<Message> {
    let function = kept.build.function();
    let object = (vk::ObjectType::COMMAND_BUFFER, command_buffer);
    let mut state = data.state();
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut contents: BTreeMap<Handle, Arc<[u8]>> = BTreeMap::new();
        let mut unreadable = None;
        for source in kept.build.content_sources() {
            let holder = state
                .validator
                .state()
                .buffers_at(source.address)
                .next()
                .map(|(handle, _)| handle);
            let Some(buffer) = holder else {
                unreadable.get_or_insert((source, "no buffer whose device address the layer knows (from vkGetBufferDeviceAddress) holds them"));
                continue;
            };
            if contents.contains_key(&buffer) {
                continue;
            }
            match mapped_contents(&state, buffer) {
                Some(bytes) => {
                    contents.insert(buffer, bytes);
                }
                None => {
                    let reason = unreadable_reason(&state, buffer).unwrap_or("unknown");
                    unreadable.get_or_insert((source, reason));
                }
            }
        }
        let mut messages: Vec<Message> = state
            .validator
            .check_device_build_contents(
                &kept.recorded_in,
                &kept.build,
                contents.into_iter().collect(),
            )
            .findings
            .iter()
            .map(|finding| Message::from_finding(finding, object))
            .collect();
        if let Some((source, reason)) = unreadable {
            if !state.memory_layout.reported_unreadable {
                state.memory_layout.reported_unreadable = true;
                let text = format!(
                    "the contents of {} (device address {:#x}) of a build recorded in VkCommandBuffer {command_buffer:#x} could not be read at {submit_function}: {reason}; the build's contents are not checked. This is reported once per device.",
                    source.location, source.address
                );
                let mut message =
                    Message::about_layer(CONTENTS_NOT_CHECKED, Severity::Info, function, &text);
                message.objects.push(object);
                messages.push(message);
            }
        }
        messages
    }));
    drop(state);
    outcome.unwrap_or_else(|payload| {
        vec![panic_message(
            function,
            payload.as_ref(),
            "the build's contents were not checked",
        )]
    })
}

/// Checks the contents of every build the submitted command buffers run;
/// returns whether a messenger asked for the submission to be skipped.
fn check_submission(
    data: &DeviceData,
    command_buffers: &[vk::CommandBuffer],
    submit_function: &'static str,
) -> bool {
    let mut skip = false;
    for &command_buffer in command_buffers {
        for (recorded_in, kept) in commands::builds_run_by(command_buffer) {
            // The device lock is taken per build and released before delivery.
            let messages = check_kept(data, recorded_in, &kept, submit_function);
            if !messages.is_empty() {
                skip |= data.instance.reporter.deliver(&messages, false);
            }
        }
    }
    skip
}

/// One submit command: checks, then passes the submission on unless a
/// messenger asks to skip it.
fn submit_with<F: Copy>(
    function: &'static str,
    queue: vk::Queue,
    pick: fn(&DeviceFns) -> Option<F>,
    command_buffers: impl FnOnce() -> Vec<vk::CommandBuffer>,
    call_down: impl FnOnce(F) -> vk::Result,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_DEVICE_LOST, || {
        // A queue shares its device's dispatch key.
        let Some((data, next)) = device_and(queue, pick) else {
            return vk::Result::ERROR_DEVICE_LOST;
        };
        if check_submission(&data, &command_buffers(), function) {
            return vk::Result::ERROR_VALIDATION_FAILED_EXT;
        }
        call_down(next)
    })
}

/// `vkQueueSubmit`.
unsafe extern "system" fn queue_submit(
    queue: vk::Queue,
    count: u32,
    submits: *const vk::SubmitInfo<'_>,
    fence: vk::Fence,
) -> vk::Result {
    submit_with(
        "vkQueueSubmit",
        queue,
        |f| f.commands.queue_submit,
        // SAFETY: the application's submit infos, valid as the API requires.
        || unsafe { read::submitted_command_buffers(count, submits) },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(queue, count, submits, fence) },
    )
}

/// `vkQueueSubmit2` and its KHR alias, each with its own next function.
unsafe fn queue_submit2_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkQueueSubmit2>,
    queue: vk::Queue,
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
    fence: vk::Fence,
) -> vk::Result {
    // The semaphores' stage masks first (guarded like every check).
    let skip = guarded(function, false, || {
        // SAFETY: the application's submit infos, valid as the API requires.
        unsafe { crate::sync::check_submit2(function, queue, count, submits) }
    });
    if skip {
        return vk::Result::ERROR_VALIDATION_FAILED_EXT;
    }
    submit_with(
        function,
        queue,
        pick,
        // SAFETY: the application's submit infos, valid as the API requires.
        || unsafe { read::submitted_command_buffers2(count, submits) },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(queue, count, submits, fence) },
    )
}

unsafe extern "system" fn queue_submit2(
    queue: vk::Queue,
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
    fence: vk::Fence,
) -> vk::Result {
    // SAFETY: forwarded from the application.
    unsafe {
        queue_submit2_with(
            "vkQueueSubmit2",
            |f| f.commands.queue_submit2,
            queue,
            count,
            submits,
            fence,
        )
    }
}

unsafe extern "system" fn queue_submit2_khr(
    queue: vk::Queue,
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
    fence: vk::Fence,
) -> vk::Result {
    // SAFETY: forwarded from the application.
    unsafe {
        queue_submit2_with(
            "vkQueueSubmit2KHR",
            |f| f.commands.queue_submit2_khr,
            queue,
            count,
            submits,
            fence,
        )
    }
}
