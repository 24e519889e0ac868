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
//! A host `vkSignalSemaphore` completes nothing, but it can let a
//! submission the core holds (one waiting for the value signalled) run:
//! the core decides its execution-order rules then.

#![allow(unsafe_code)]

use ash::vk;
use ash::vk::Handle as _;

use crate::dispatch::next_fns::DeviceFns;
use crate::dispatch::submissions::{Pending, Submissions};
use crate::dispatch::DeviceData;
use crate::intercept::{aliased_intercepts, check, device_and, guarded, panic_message};
use crate::read;
use crate::report::Message;

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

/// Runs a waiting command below, then, where it succeeded, tells the
/// core's execution order what it shows complete (`observe`) and checks
/// the read-back builds it completes (`complete` picks them from the
/// device's submissions; not called when none waits).
fn wait_command<F: Copy>(
    function: &'static str,
    dispatchable: impl vk::Handle,
    pick: fn(&DeviceFns) -> Option<F>,
    call_down: impl FnOnce(F) -> vk::Result,
    observe: impl FnOnce(&DeviceData, &mut ommcheck::Validator) -> Vec<(u64, u64)>,
    complete: impl FnOnce(&mut Submissions, &[(u64, u64)]) -> Vec<Pending>,
) -> vk::Result {
    guarded(function, vk::Result::ERROR_DEVICE_LOST, || {
        let Some((data, next)) = device_and(dispatchable, pick) else {
            return vk::Result::ERROR_DEVICE_LOST;
        };
        let result = call_down(next);
        if result == vk::Result::SUCCESS {
            let completed = {
                let mut state = data.state();
                let reached = observe(&data, &mut state.validator);
                if !state.submissions.waiting() {
                    return result;
                }
                complete(&mut state.submissions, &reached)
            };
            check_completed(&data, completed, function);
        }
        result
    })
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
            // With waitAll every fence is signalled; otherwise ask.
            let signalled: Vec<(u64, u64)> = fences
                .iter()
                .filter(|&&fence| {
                    wait_all != vk::FALSE
                        || status.is_some_and(|status| {
                            // SAFETY: the next layer's function, with a fence of the device.
                            (unsafe { status(device, fence) }) == vk::Result::SUCCESS
                        })
                })
                .map(|fence| (fence.as_raw(), 0))
                .collect();
            let handles: Vec<u64> = signalled.iter().map(|(f, _)| *f).collect();
            validator.fences_signalled(&handles);
            signalled
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
            Vec::new()
        },
        |submissions, _| submissions.fence_signalled(fence.as_raw()),
    )
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
            Vec::new()
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
            Vec::new()
        },
        |submissions, _| submissions.take(|_, _| true),
    )
}

/// Timeline values reached: after a successful wait for all of them, each
/// waited value; otherwise (waiting for any) each semaphore's counter.
/// The core's execution order learns each.
unsafe fn waited_semaphores(
    data: &DeviceData,
    device: vk::Device,
    info: *const vk::SemaphoreWaitInfo<'_>,
    validator: &mut ommcheck::Validator,
) -> Vec<(u64, u64)> {
    // SAFETY: the application's wait info (the API's requirement).
    let Some(info) = (unsafe { info.as_ref() }) else {
        return Vec::new();
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
    let mut reached_values = Vec::new();
    for (&semaphore, &waited) in semaphores.iter().zip(values) {
        let reached = if any {
            let mut value = 0;
            let asked = counter.is_some_and(|get| {
                // SAFETY: the next layer's function, with a semaphore of the device.
                (unsafe { get(device, semaphore, &mut value) }) == vk::Result::SUCCESS
            });
            // The counter as read: signals above it have not executed.
            if asked {
                validator.semaphore_counter_value(semaphore.as_raw(), value);
            }
            asked.then_some(value)
        } else {
            // Waited for: the first signal reaching the value has executed.
            validator.semaphore_reached(semaphore.as_raw(), waited);
            Some(waited)
        };
        if let Some(value) = reached {
            reached_values.push((semaphore.as_raw(), value));
        }
    }
    reached_values
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
                .collect()
        },
        semaphores_reached,
    )
}
