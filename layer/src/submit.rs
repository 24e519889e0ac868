//! Queue submission: the contents of the device builds a submitted command
//! buffer runs are read here, in submission order, before the GPU can
//! change them: from buffers bound to host-visible memory the application
//! has mapped, and from what the transfers recorded before them wrote
//! ([`crate::shadow`], route 1), and handed to the core as buffer contents
//! ([`ommcheck::Validator::check_device_build_contents`]). Builds whose
//! inputs the layer copies on the GPU ([`crate::readback`], route 2) wait
//! for completion instead ([`crate::completion`]). Contents neither route
//! can read are reported once per device and reason
//! ([`crate::report::CONTENTS_NOT_CHECKED`]).

#![allow(unsafe_code)]

use std::ffi::CStr;

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::build_inputs::KnownBytes;
use ommcheck::model::Handle;
use ommcheck::model::SubmitBatch;

use crate::commands::{self, Recorded};
use crate::dispatch::memory_layout::{mapped_window, unreadable_reason};
use crate::dispatch::next_fns::DeviceFns;
use crate::dispatch::submissions::KeptBuild;
use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::{as_void, check, device_and, guarded, panic_message};
use crate::read;
use crate::report::Message;

/// The next layer's submission function for one of the submit commands.
pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkQueueSubmit" => as_void(queue_submit as vk::PFN_vkQueueSubmit),
        b"vkQueueSubmit2" => as_void(queue_submit2 as vk::PFN_vkQueueSubmit2),
        b"vkQueueSubmit2KHR" => as_void(queue_submit2_khr as vk::PFN_vkQueueSubmit2),
        _ => None,
    }
}

/// The bytes of `[offset, offset + len)` of `buffer` as a build submitted
/// now reads them: mapped memory with what transfers of this submission
/// wrote over it, or what transfers wrote alone.
fn window_bytes(state: &DeviceState, buffer: Handle, offset: u64, len: u64) -> Option<Vec<u8>> {
    match mapped_window(state, buffer, offset, len) {
        Some(mut bytes) => {
            state.shadows.overlay(buffer, offset, &mut bytes);
            Some(bytes)
        }
        None => state.shadows.read(buffer, offset, len),
    }
}

/// The messages of one kept build's content checks at submission.
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
        let mut contents = Vec::new();
        let mut unreadable: Option<String> = None;
        let cap = data
            .instance
            .reporter
            .settings()
            .gpu_readback_indirect_max_bytes;
        match crate::readback::windows(&state, &kept.build, cap, window_bytes) {
            Ok(windows) => {
                for w in &windows {
                    match window_bytes(&state, w.buffer, w.offset, w.len) {
                        Some(bytes) => contents.push(KnownBytes {
                            buffer: w.buffer,
                            offset: w.offset,
                            bytes: bytes.into(),
                        }),
                        None => {
                            unreadable.get_or_insert_with(|| {
                                format!(
                                    "{} in VkBuffer {:#x}, bytes {}..{}: {}",
                                    w.location,
                                    w.buffer,
                                    w.offset,
                                    w.offset.saturating_add(w.len),
                                    unreadable_reason(&state, w.buffer)
                                )
                            });
                        }
                    }
                }
            }
            Err(reason) => unreadable = Some(reason),
        }
        let (report, unread) = state.validator.check_device_build_contents_unread(
            &kept.recorded_in,
            &kept.build,
            contents,
        );
        let mut messages: Vec<Message> = report
            .findings
            .iter()
            .map(|finding| Message::from_finding(finding, object))
            .collect();
        // Where some window could not be read, the message below says so
        // for the whole build.
        if unreadable.is_none() {
            messages.extend(crate::readback::unread_message(
                &mut state,
                command_buffer,
                &kept.build,
                &unread,
                submit_function,
            ));
        }
        if let Some(reason) = unreadable {
            let (key, why_not_read_back) = kept.not_read_back.as_ref().map_or(
                (
                    "not-planned",
                    "GPU readback was not set up when the build was recorded",
                ),
                |(key, why)| (*key, why.as_str()),
            );
            if state.memory_layout.first_report(key) {
                let text = format!(
                    "the inputs of a build recorded in VkCommandBuffer {command_buffer:#x} could not be read at {submit_function} ({reason}), nor read back on the GPU: {why_not_read_back}; the build's content rules are not checked. {}",
                    crate::readback::once_per_cause(key)
                );
                messages.push(crate::readback::not_checked(
                    function,
                    command_buffer,
                    &text,
                ));
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

/// What one submission carries besides its command buffers.
struct Submitted {
    queue: vk::Queue,
    fence: vk::Fence,
    /// Semaphores and the values the submission signals.
    signals: Vec<(u64, u64)>,
    function: &'static str,
}

/// Runs the transfers and checks the builds of the submitted command
/// buffers in order; returns whether a messenger asked for the submission
/// to be skipped.
fn check_submission(
    data: &DeviceData,
    command_buffers: &[vk::CommandBuffer],
    submitted: &Submitted,
) -> bool {
    let run: Vec<(u64, Recorded)> = command_buffers
        .iter()
        .flat_map(|&cb| commands::run_by(cb))
        .collect();
    if run.is_empty() {
        return false;
    }
    let sequence = {
        let mut state = data.state();
        // The host may have written mapped memory since the last submission:
        // what transfers wrote there before is superseded by what it holds.
        let mapped: Vec<u64> = state
            .shadows
            .buffers_known()
            .filter(|&b| state.memory_layout.is_mapped(b))
            .collect();
        for buffer in mapped {
            state.shadows.forget_contents(buffer);
        }
        let transfers = run.iter().rev().filter_map(|(_, r)| match r {
            Recorded::Transfer(transfer) => Some(transfer.as_ref()),
            _ => None,
        });
        state.shadows.watch_copy_sources(transfers);
        let reads_back = run
            .iter()
            .any(|(_, r)| matches!(r, Recorded::Build(k) if k.readback.is_some()));
        reads_back.then(|| {
            state.submissions.submit(
                submitted.queue.as_raw(),
                submitted.fence.as_raw(),
                &submitted.signals,
            )
        })
    };
    let mut skip = false;
    for (recorded_in, recorded) in run {
        match recorded {
            Recorded::Transfer(transfer) => {
                let mut state = data.state();
                let mut shadows = std::mem::take(&mut state.shadows);
                shadows.apply(&transfer, |buffer, offset, len| {
                    mapped_window(&state, buffer, offset, len)
                });
                state.shadows = shadows;
            }
            Recorded::Build(kept) => match (sequence, &kept.readback) {
                (Some(sequence), Some(readback)) => {
                    let mut state = data.state();
                    // The copies write the range again: what the checker
                    // kept of it from an earlier completion becomes copies.
                    readback.own_views(state.validator.state_mut());
                    state.submissions.add(
                        submitted.queue.as_raw(),
                        sequence,
                        recorded_in,
                        kept,
                        submitted.function,
                    );
                }
                _ => {
                    // The device lock is taken per build and released before delivery.
                    let messages = check_kept(data, recorded_in, &kept, submitted.function);
                    if !messages.is_empty() {
                        skip |= data.instance.reporter.deliver(&messages, false);
                    }
                }
            },
            Recorded::Executes(_) => {} // Expanded by `run_by`.
        }
    }
    skip
}

/// One submit command: checks, then passes the submission on unless a
/// messenger asks to skip it.
fn submit_with<F: Copy>(
    function: &'static str,
    queue: vk::Queue,
    fence: vk::Fence,
    pick: fn(&DeviceFns) -> Option<F>,
    read_submission: impl FnOnce() -> (Vec<vk::CommandBuffer>, Vec<(u64, u64)>, Vec<SubmitBatch>),
    call_down: impl FnOnce(F) -> vk::Result,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_DEVICE_LOST, || {
        // A queue shares its device's dispatch key.
        let Some((data, next)) = device_and(queue, pick) else {
            return vk::Result::ERROR_DEVICE_LOST;
        };
        let (command_buffers, signals, batches) = read_submission();
        // Execution order: the recorded work runs now, in submission order.
        let object = (vk::ObjectType::QUEUE, queue.as_raw());
        if check(&data, function, object, |state| {
            state
                .validator
                .queue_submit(function, queue.as_raw(), &batches, fence.as_raw())
        }) {
            return vk::Result::ERROR_VALIDATION_FAILED_EXT;
        }
        let submitted = Submitted {
            queue,
            fence,
            signals,
            function,
        };
        if check_submission(&data, &command_buffers, &submitted) {
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
        fence,
        |f| f.commands.queue_submit,
        // SAFETY: the application's submit infos, valid as the API requires.
        || unsafe {
            (
                read::submitted_command_buffers(count, submits),
                read::submitted_signals(count, submits),
                read::submitted_batches(count, submits),
            )
        },
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
        fence,
        pick,
        // SAFETY: the application's submit infos, valid as the API requires.
        || unsafe {
            (
                read::submitted_command_buffers2(count, submits),
                read::submitted_signals2(count, submits),
                read::submitted_batches2(count, submits),
            )
        },
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
