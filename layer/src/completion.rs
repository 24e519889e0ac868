//! When a submission is known to be complete: the builds it ran whose
//! inputs were read back on the GPU ([`crate::readback`]) are checked then,
//! with the bytes the copies wrote, which are what the builds read.
//!
//! A submission is complete once the application learns so: a fence it
//! signals passes `vkWaitForFences` or `vkGetFenceStatus`, its queue or the
//! device passes `vkQueueWaitIdle` / `vkDeviceWaitIdle`, or a timeline
//! semaphore value it signals is reached (`vkWaitSemaphores`,
//! `vkGetSemaphoreCounterValue`). A fence or semaphore signal also
//! completes every earlier submission to the same queue.
//!
//! A wait for any of several fences or timeline values leaves the layer
//! to ask which ones were reached (its own `vkGetFenceStatus` and
//! `vkGetSemaphoreCounterValue`). Where that call fails, the layer does
//! not know: it takes the fence or value as reached for the core's
//! execution order, so no error is reported on a guess (destroying an
//! object the submission used), and does not check the builds read back
//! for that submission, whose copies may not have run; it says so once
//! per device and cause.
//!
//! A host `vkSignalSemaphore` completes nothing, but it can let a
//! submission the core holds (one waiting for the value signalled) run:
//! the core decides its execution-order rules then.

#![allow(unsafe_code)]

use ash::vk;
use ash::vk::Handle as _;

use ommcheck::Severity;

use crate::dispatch::next_fns::DeviceFns;
use crate::dispatch::submissions::{Pending, Submissions};
use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::{aliased_intercepts, check, device_and, guarded, panic_message, track};
use crate::own_calls::{self, OwnCall};
use crate::read;
use crate::report::{Message, CONTENTS_NOT_CHECKED};

/// Checks the completed builds with their read-back bytes and delivers
/// the findings.
fn check_completed(data: &DeviceData, completed: Vec<Pending>, observed_by: &'static str) {
    for pending in completed {
        let Some(readback) = &pending.kept.readback else {
            continue;
        };
        let object = (vk::ObjectType::COMMAND_BUFFER, pending.command_buffer);
        let function = pending.kept.build.function();
        let outcome = {
            let mut state = data.state();
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                let contents = readback.contents();
                let (report, unread) = state.validator.check_device_build_contents_unread(
                    &pending.kept.recorded_in,
                    &pending.kept.build,
                    contents,
                );
                // What an indirect build's ranges place past the bytes read back.
                let unread = crate::readback::unread_message(
                    &mut state,
                    pending.command_buffer,
                    &pending.kept.build,
                    &unread,
                    observed_by,
                );
                (report, unread)
            }))
        };
        let messages: Vec<Message> = match outcome {
            Ok((report, unread)) => report
                .findings
                .iter()
                .map(|finding| {
                    let mut message = Message::from_finding(finding, object);
                    message.text.push_str(&format!(
                        " (Read back from device memory after the build ran: VkCommandBuffer {:#x}, submitted by {}, seen complete at {observed_by}.)",
                        pending.command_buffer, pending.submit_function
                    ));
                    message
                })
                .chain(unread)
                .collect(),
            Err(payload) => vec![panic_message(
                function,
                payload.as_ref(),
                "the build's read-back contents were not checked",
            )],
        };
        if !messages.is_empty() {
            data.instance.reporter.deliver(&messages, false);
        }
    }
}

/// What a successful wait shows complete: fences (`(fence, 0)`) and
/// timeline values (`(semaphore, value)`) reached, and those whose state
/// the layer's own query could not learn.
#[derive(Default)]
struct Observed {
    reached: Vec<(u64, u64)>,
    unknown: Vec<Unknown>,
}

impl From<Vec<(u64, u64)>> for Observed {
    fn from(reached: Vec<(u64, u64)>) -> Self {
        Self {
            reached,
            unknown: Vec::new(),
        }
    }
}

/// A fence or timeline value the wait may have reached, which the layer
/// could not tell because its own query failed.
struct Unknown {
    /// `(VK_OBJECT_TYPE_FENCE, fence)` or `(VK_OBJECT_TYPE_SEMAPHORE, semaphore)`.
    object: (vk::ObjectType, u64),
    /// As in [`Observed::reached`], were it reached.
    reached: (u64, u64),
    failed: own_calls::Failed,
}

/// Runs a waiting command below, then, where it succeeded, tells the
/// core's execution order what it shows complete (`observe`) and checks
/// the read-back builds it completes (`complete` picks them from the
/// device's submissions; not called when none waits). The builds of what
/// `observe` could not learn are taken out unchecked, and that is said.
fn wait_command<F: Copy>(
    function: &'static str,
    dispatchable: impl vk::Handle,
    pick: fn(&DeviceFns) -> Option<F>,
    call_down: impl FnOnce(F) -> vk::Result,
    observe: impl FnOnce(&DeviceData, &mut ommcheck::Validator) -> Observed,
    complete: impl Fn(&mut Submissions, &[(u64, u64)]) -> Vec<Pending>,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_DEVICE_LOST, || {
        let Some((data, next)) = device_and(dispatchable, pick) else {
            return vk::Result::ERROR_DEVICE_LOST;
        };
        let result = call_down(next);
        if result == vk::Result::SUCCESS {
            let (completed, not_known) = {
                let mut state = data.state();
                let observed = observe(&data, &mut state.validator);
                if !state.submissions.waiting() && observed.unknown.is_empty() {
                    return result;
                }
                // What is known complete first: an unknown fence on the same
                // queue would take its builds too.
                let completed = complete(&mut state.submissions, &observed.reached);
                let not_known: Vec<Message> = observed
                    .unknown
                    .iter()
                    .filter_map(|unknown| {
                        let dropped = complete(&mut state.submissions, &[unknown.reached]);
                        unknown_message(&mut state, function, unknown, &dropped)
                    })
                    .collect();
                (completed, not_known)
            };
            check_completed(&data, completed, function);
            // Delivered with no lock held: a callback may call the layer.
            if !not_known.is_empty() {
                data.instance.reporter.deliver(&not_known, false);
            }
        }
        result
    })
}

/// The [`CONTENTS_NOT_CHECKED`] warning that the layer's own query about
/// `unknown` failed, so the builds read back for its submission
/// (`dropped`) are not checked: once per device and cause, every dropped
/// build counted for `vkDestroyDevice`'s total.
fn unknown_message(
    state: &mut DeviceState,
    function: &'static str,
    unknown: &Unknown,
    dropped: &[Pending],
) -> Option<Message> {
    let cause = unknown.failed.call.cause();
    let builds = u64::try_from(dropped.len()).unwrap_or(u64::MAX);
    if !state.memory_layout.first_report_of(cause, builds) {
        return None;
    }
    let (object_type, handle) = unknown.object;
    let (what, reached) = if object_type == vk::ObjectType::FENCE {
        (format!("VkFence {handle:#x}"), "signalled")
    } else {
        (
            format!("VkSemaphore {handle:#x} (value {})", unknown.reached.1),
            "reached",
        )
    };
    let in_command_buffers: Vec<String> = dropped
        .iter()
        .map(|p| format!("{:#x}", p.command_buffer))
        .collect();
    let recorded_in = in_command_buffers.join(", ");
    let builds = match dropped.len() {
        0 => "no build read back waits for it now".to_owned(),
        1 => format!(
            "the contents of the device build read back for it (recorded in VkCommandBuffer {recorded_in}) are not checked, since its copies may not have run"
        ),
        n => format!(
            "the contents of the {n} device builds read back for it (recorded in VkCommandBuffers {recorded_in}) are not checked, since their copies may not have run"
        ),
    };
    let text = format!(
        "{}, asking about {what}, so the layer cannot tell whether it is {reached}, nor so whether the submission that signals it is complete. It takes it as {reached} for the checks of what pending submissions use (so as not to report an error on a guess), and {builds}. {}",
        unknown.failed,
        crate::readback::once_per_cause(cause)
    );
    let mut message =
        Message::about_layer(CONTENTS_NOT_CHECKED, Severity::Warning, function, &text);
    message.objects.push(unknown.object);
    Some(message)
}

pub unsafe extern "system" fn wait_for_fences(
    device: vk::Device,
    count: u32,
    fences: *const vk::Fence,
    wait_all: vk::Bool32,
    timeout: u64,
) -> vk::Result {
    wait_command(
        "vkWaitForFences",
        device,
        |f| f.memory.wait_for_fences,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, count, fences, wait_all, timeout) },
        |data, validator| {
            // SAFETY: `pFences` holds `fenceCount` fences (the API's requirement).
            let fences = unsafe { read::array(fences, count) };
            let status = data.fns.memory.get_fence_status;
            let mut observed = Observed::default();
            for &fence in fences {
                // With waitAll every fence is signalled; otherwise ask.
                let signalled = match status {
                    _ if wait_all != vk::FALSE => Ok(true),
                    None => Ok(false),
                    Some(status) => own_calls::checked(OwnCall::FenceStatus, || {
                        // SAFETY: the next layer's function, with a fence of the device.
                        unsafe { status(device, fence) }
                    })
                    .map(|answer| answer == vk::Result::SUCCESS),
                };
                let reached = (fence.as_raw(), 0);
                match signalled {
                    Ok(true) => observed.reached.push(reached),
                    Ok(false) => {}
                    Err(failed) => observed.unknown.push(Unknown {
                        object: (vk::ObjectType::FENCE, fence.as_raw()),
                        reached,
                        failed,
                    }),
                }
            }
            // A fence the layer could not ask about is taken as signalled.
            let handles: Vec<u64> = observed
                .reached
                .iter()
                .chain(observed.unknown.iter().map(|u| &u.reached))
                .map(|(f, _)| *f)
                .collect();
            validator.fences_signalled(&handles);
            observed
        },
        |submissions, signalled| {
            let mut completed = Vec::new();
            for (fence, _) in signalled {
                completed.extend(submissions.fence_signalled(*fence));
            }
            completed.sort_by_key(|p| p.sequence);
            completed
        },
    )
}

pub unsafe extern "system" fn get_fence_status(device: vk::Device, fence: vk::Fence) -> vk::Result {
    wait_command(
        "vkGetFenceStatus",
        device,
        |f| f.memory.get_fence_status,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, fence) },
        |_, validator| {
            validator.fences_signalled(&[fence.as_raw()]);
            Observed::default()
        },
        |submissions, _| submissions.fence_signalled(fence.as_raw()),
    )
}

/// `vkResetFences`: a fence reset stands for no submission any more, and
/// the core forgets the submission it stood for, as for one destroyed
/// ([`destroy_fence`]). Without these, every fence an application made,
/// submitted with and destroyed stayed in the core's execution order for
/// the device's life (found by `cargo xtask soak`).
#[allow(dead_code)]
pub unsafe extern "system" fn reset_fences(
    device: vk::Device,
    count: u32,
    fences: *const vk::Fence,
) -> vk::Result {
    guarded("vkResetFences", vk::Result::ERROR_DEVICE_LOST, || {
        let Some((data, next)) = device_and(device, |f| f.memory.reset_fences) else {
            return vk::Result::ERROR_DEVICE_LOST;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        let result = unsafe { next(device, count, fences) };
        if result == vk::Result::SUCCESS {
            // SAFETY: `pFences` holds `fenceCount` fences (the API's requirement).
            let fences: Vec<u64> = unsafe { read::array(fences, count) }
                .iter()
                .map(|f| f.as_raw())
                .collect();
            track(&data, "vkResetFences", |state| {
                state.validator.reset_fences(&fences)
            });
        }
        result
    })
}

/// `vkDestroyFence`: see [`reset_fences`].
#[allow(dead_code)]
pub unsafe extern "system" fn destroy_fence(
    device: vk::Device,
    fence: vk::Fence,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyFence", (), || {
        let Some((data, next)) = device_and(device, |f| f.memory.destroy_fence) else {
            return;
        };
        track(&data, "vkDestroyFence", |state| {
            state.validator.reset_fences(&[fence.as_raw()])
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, fence, allocator) };
    })
}

/// `vkDestroySemaphore`: the core forgets the semaphore's signals, so one
/// made later with the same handle is not taken as signalled by them and
/// an application that makes and destroys semaphores does not grow the
/// execution order.
#[allow(dead_code)]
pub unsafe extern "system" fn destroy_semaphore(
    device: vk::Device,
    semaphore: vk::Semaphore,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroySemaphore", (), || {
        let Some((data, next)) = device_and(device, |f| f.memory.destroy_semaphore) else {
            return;
        };
        track(&data, "vkDestroySemaphore", |state| {
            state.validator.destroy_semaphore(semaphore.as_raw())
        });
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, semaphore, allocator) };
    })
}

pub unsafe extern "system" fn queue_wait_idle(queue: vk::Queue) -> vk::Result {
    wait_command(
        "vkQueueWaitIdle",
        queue,
        |f| f.memory.queue_wait_idle,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(queue) },
        |_, validator| {
            validator.queue_wait_idle(queue.as_raw());
            Observed::default()
        },
        |submissions, _| submissions.through(queue.as_raw(), u64::MAX),
    )
}

pub unsafe extern "system" fn device_wait_idle(device: vk::Device) -> vk::Result {
    wait_command(
        "vkDeviceWaitIdle",
        device,
        |f| f.memory.device_wait_idle,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device) },
        |_, validator| {
            validator.device_wait_idle();
            Observed::default()
        },
        |submissions, _| submissions.take(|_, _| true),
    )
}

/// Timeline values reached: after a successful wait for all of them, each
/// waited value; otherwise (waiting for any) each semaphore's counter,
/// or, where asking failed, the waited value as unknown. The core's
/// execution order learns each, unknown ones taken as reached.
unsafe fn waited_semaphores(
    data: &DeviceData,
    device: vk::Device,
    info: *const vk::SemaphoreWaitInfo<'_>,
    validator: &mut ommcheck::Validator,
) -> Observed {
    // SAFETY: the application's wait info (the API's requirement).
    let Some(info) = (unsafe { info.as_ref() }) else {
        return Observed::default();
    };
    // SAFETY: the wait info's arrays hold `semaphoreCount` elements.
    let semaphores = unsafe { read::array(info.p_semaphores, info.semaphore_count) };
    // SAFETY: as above.
    let values = unsafe { read::array(info.p_values, info.semaphore_count) };
    let any = info.flags.contains(vk::SemaphoreWaitFlags::ANY);
    let counter = data
        .fns
        .memory
        .get_semaphore_counter_value
        .or(data.fns.memory.get_semaphore_counter_value_khr);
    let mut observed = Observed::default();
    for (&semaphore, &waited) in semaphores.iter().zip(values) {
        let reached = match counter {
            _ if !any => {
                // Waited for: the first signal reaching the value has executed.
                validator.semaphore_reached(semaphore.as_raw(), waited);
                Ok(Some(waited))
            }
            None => Ok(None),
            Some(get) => {
                let mut value = 0;
                own_calls::checked(OwnCall::SemaphoreCounterValue, || {
                    // SAFETY: the next layer's function, with a semaphore of the device.
                    unsafe { get(device, semaphore, &mut value) }
                })
                .map(|_| {
                    // The counter as read: signals above it have not executed.
                    validator.semaphore_counter_value(semaphore.as_raw(), value);
                    Some(value)
                })
            }
        };
        match reached {
            Ok(Some(value)) => observed.reached.push((semaphore.as_raw(), value)),
            Ok(None) => {}
            Err(failed) => {
                validator.semaphore_reached(semaphore.as_raw(), waited);
                observed.unknown.push(Unknown {
                    object: (vk::ObjectType::SEMAPHORE, semaphore.as_raw()),
                    reached: (semaphore.as_raw(), waited),
                    failed,
                });
            }
        }
    }
    observed
}

/// The read-back builds the timeline values `reached` complete, in submission order.
fn semaphores_reached(submissions: &mut Submissions, reached: &[(u64, u64)]) -> Vec<Pending> {
    let mut completed = Vec::new();
    for (semaphore, value) in reached {
        completed.extend(submissions.semaphore_reached(*semaphore, *value));
    }
    completed.sort_by_key(|p| p.sequence);
    completed
}

/// `vkWaitSemaphores(KHR)`: the waited timeline values are reached.
unsafe fn wait_semaphores_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkWaitSemaphores>,
    device: vk::Device,
    info: *const vk::SemaphoreWaitInfo<'_>,
    timeout: u64,
) -> vk::Result {
    wait_command(
        function,
        device,
        pick,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, info, timeout) },
        // SAFETY: the application's wait info.
        |data, validator| unsafe { waited_semaphores(data, device, info, validator) },
        semaphores_reached,
    )
}

aliased_intercepts! {
    wait_semaphores_with(device: vk::Device, info: *const vk::SemaphoreWaitInfo<'_>, timeout: u64) -> vk::Result {
        wait_semaphores = "vkWaitSemaphores", memory.wait_semaphores;
        wait_semaphores_khr = "vkWaitSemaphoresKHR", memory.wait_semaphores_khr;
    }
    counter_value_with(device: vk::Device, semaphore: vk::Semaphore, value: *mut u64) -> vk::Result {
        get_semaphore_counter_value = "vkGetSemaphoreCounterValue", memory.get_semaphore_counter_value;
        get_semaphore_counter_value_khr = "vkGetSemaphoreCounterValueKHR", memory.get_semaphore_counter_value_khr;
    }
    signal_semaphore_with(device: vk::Device, info: *const vk::SemaphoreSignalInfo<'_>) -> vk::Result {
        signal_semaphore = "vkSignalSemaphore", memory.signal_semaphore;
        signal_semaphore_khr = "vkSignalSemaphoreKHR", memory.signal_semaphore_khr;
    }
}

/// `vkSignalSemaphore(KHR)`: the host signals a timeline value. Submissions
/// the core held for it run now, ordered after what the host has seen
/// complete, and their execution-order rules are reported here; as at
/// submission, a messenger may skip the call.
unsafe fn signal_semaphore_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkSignalSemaphore>,
    device: vk::Device,
    info: *const vk::SemaphoreSignalInfo<'_>,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_DEVICE_LOST, || {
        let Some((data, next)) = device_and(device, pick) else {
            return vk::Result::ERROR_DEVICE_LOST;
        };
        // SAFETY: the application's signal info (the API's requirement).
        let signal = unsafe { info.as_ref() }.map(|i| (i.semaphore.as_raw(), i.value));
        if let Some((semaphore, value)) = signal {
            let object = (vk::ObjectType::SEMAPHORE, semaphore);
            if check(&data, function, object, |state| {
                state.validator.signal_semaphore(semaphore, value)
            }) {
                return vk::Result::ERROR_VALIDATION_FAILED_EXT;
            }
        }
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, info) }
    })
}

/// `vkGetSemaphoreCounterValue(KHR)`: the counter reached the value written.
unsafe fn counter_value_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkGetSemaphoreCounterValue>,
    device: vk::Device,
    semaphore: vk::Semaphore,
    value: *mut u64,
) -> vk::Result {
    wait_command(
        function,
        device,
        pick,
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(device, semaphore, value) },
        |_, validator| {
            // SAFETY: on success the next layer wrote the value.
            let reached = unsafe { read::value(value.cast_const()) };
            reached
                .map(|value| {
                    validator.semaphore_counter_value(semaphore.as_raw(), value);
                    (semaphore.as_raw(), value)
                })
                .into_iter()
                .collect::<Vec<_>>()
                .into()
        },
        semaphores_reached,
    )
}
