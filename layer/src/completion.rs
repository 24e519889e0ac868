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

#![allow(unsafe_code)]

use std::sync::Arc;

use ash::vk;
use ash::vk::Handle as _;
use foldhash::HashMap;

use crate::commands::KeptBuild;
use crate::dispatch::next_fns::DeviceFns;
use crate::dispatch::DeviceData;
use crate::intercept::{aliased_intercepts, device_and, guarded, panic_message};
use crate::read;
use crate::report::Message;

/// A submitted build whose read-back inputs are checked at completion.
#[derive(Debug)]
pub struct Pending {
    queue: u64,
    /// The submission's place on its device, in submission order.
    sequence: u64,
    command_buffer: u64,
    kept: KeptBuild,
    submit_function: &'static str,
}

/// A device's submissions still to be seen complete.
#[derive(Debug, Default)]
pub struct Submissions {
    next_sequence: u64,
    /// Fence → (queue, sequence) of the submission that signals it.
    fences: HashMap<u64, (u64, u64)>,
    /// (semaphore, value, queue, sequence) a submission signals.
    signals: Vec<(u64, u64, u64, u64)>,
    pending: Vec<Pending>,
}

impl Submissions {
    /// A new submission to `queue`, signalling `fence` (or none) and
    /// `signals`; returns its sequence number.
    pub fn submit(&mut self, queue: u64, fence: u64, signals: &[(u64, u64)]) -> u64 {
        self.next_sequence += 1;
        let sequence = self.next_sequence;
        if fence != 0 {
            self.fences.insert(fence, (queue, sequence));
        }
        self.signals.extend(
            signals
                .iter()
                .map(|&(semaphore, value)| (semaphore, value, queue, sequence)),
        );
        sequence
    }

    /// Keeps a build of submission `sequence` for the check at completion.
    /// A build whose readback is already pending from an earlier
    /// submission replaces it: both copy into the same layer memory, so
    /// the bytes seen at completion are the later execution's.
    pub fn add(
        &mut self,
        queue: u64,
        sequence: u64,
        command_buffer: u64,
        kept: KeptBuild,
        submit_function: &'static str,
    ) {
        let same_memory = |p: &Pending| match (&p.kept.readback, &kept.readback) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        };
        self.pending.retain(|p| !same_memory(p));
        self.pending.push(Pending {
            queue,
            sequence,
            command_buffer,
            kept,
            submit_function,
        });
        // Fences and signals matter only while a submission they complete
        // has a build waiting: without this, an application that never
        // waits would grow them by one entry per submission.
        let waiting: Vec<(u64, u64)> = self.pending.iter().map(|p| (p.queue, p.sequence)).collect();
        let completes_one =
            |queue: u64, sequence: u64| waiting.iter().any(|&(q, s)| q == queue && s <= sequence);
        self.fences.retain(|_, &mut (q, s)| completes_one(q, s));
        self.signals.retain(|&(_, _, q, s)| completes_one(q, s));
    }

    /// Takes the pending builds `done` says are complete, in submission
    /// order, and forgets fences and signals of completed submissions.
    fn take(&mut self, done: impl Fn(u64, u64) -> bool) -> Vec<Pending> {
        let (complete, waiting) = std::mem::take(&mut self.pending)
            .into_iter()
            .partition(|p| done(p.queue, p.sequence));
        self.pending = waiting;
        self.fences.retain(|_, &mut (q, s)| !done(q, s));
        self.signals.retain(|&(_, _, q, s)| !done(q, s));
        let mut complete: Vec<Pending> = complete;
        complete.sort_by_key(|p| p.sequence);
        complete
    }

    /// Every submission to `queue` up to `sequence` is complete.
    fn through(&mut self, queue: u64, sequence: u64) -> Vec<Pending> {
        self.take(|q, s| q == queue && s <= sequence)
    }

    fn fence_signalled(&mut self, fence: u64) -> Vec<Pending> {
        match self.fences.get(&fence).copied() {
            Some((queue, sequence)) => self.through(queue, sequence),
            None => Vec::new(),
        }
    }

    fn semaphore_reached(&mut self, semaphore: u64, value: u64) -> Vec<Pending> {
        let reached: Vec<(u64, u64)> = self
            .signals
            .iter()
            .filter(|&&(s, v, _, _)| s == semaphore && v <= value)
            .map(|&(_, _, q, seq)| (q, seq))
            .collect();
        let mut complete = Vec::new();
        for (queue, sequence) in reached {
            complete.extend(self.through(queue, sequence));
        }
        complete.sort_by_key(|p| p.sequence);
        complete
    }

    /// Whether anything waits for completion (so the checks below cost
    /// nothing for applications without readbacks).
    fn waiting(&self) -> bool {
        !self.pending.is_empty()
    }
}

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
            asked.then_some(value)
        } else {
            Some(waited)
        };
        if let Some(value) = reached {
            validator.semaphore_reached(semaphore.as_raw(), value);
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
                    validator.semaphore_reached(semaphore.as_raw(), value);
                    (semaphore.as_raw(), value)
                })
                .into_iter()
                .collect()
        },
        semaphores_reached,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use ommcheck::checks::device_contents::DeviceBuild;
    use ommcheck::model::CommandBuffer;

    fn kept() -> KeptBuild {
        KeptBuild {
            recorded_in: CommandBuffer::default(),
            build: Arc::new(DeviceBuild::Micromaps(Vec::new())),
            readback: None,
            not_read_back: None,
        }
    }

    fn sequences(pending: &[Pending]) -> Vec<u64> {
        pending.iter().map(|p| p.sequence).collect()
    }

    #[test]
    fn a_fence_completes_its_submission_and_earlier_ones_on_its_queue() {
        let mut submissions = Submissions::default();
        let first = submissions.submit(1, 0, &[]);
        submissions.add(1, first, 10, kept(), "vkQueueSubmit");
        let other_queue = submissions.submit(2, 0, &[]);
        submissions.add(2, other_queue, 11, kept(), "vkQueueSubmit");
        let fenced = submissions.submit(1, 77, &[]);
        submissions.add(1, fenced, 12, kept(), "vkQueueSubmit");
        let later = submissions.submit(1, 0, &[]);
        submissions.add(1, later, 13, kept(), "vkQueueSubmit");
        assert_eq!(sequences(&submissions.fence_signalled(77)), [first, fenced]);
        assert!(submissions.fence_signalled(77).is_empty(), "checked once");
        assert_eq!(sequences(&submissions.through(2, u64::MAX)), [other_queue]);
        assert_eq!(sequences(&submissions.take(|_, _| true)), [later]);
    }

    #[test]
    fn resubmitting_without_waiting_keeps_what_is_tracked_bounded() {
        let mut submissions = Submissions::default();
        let build = KeptBuild {
            readback: Some(Arc::new(crate::dispatch::readback_memory::Readback::empty())),
            ..kept()
        };
        let mut last = 0;
        for k in 0..1000u64 {
            // The same recorded build, submitted again with a new fence
            // and timeline value, and never waited for.
            last = submissions.submit(1, 100 + k, &[(5, k)]);
            submissions.add(1, last, 10, build.clone(), "vkQueueSubmit");
        }
        assert_eq!(sequences(&submissions.pending), [last]);
        assert_eq!(submissions.fences.len(), 1);
        assert_eq!(submissions.signals.len(), 1);
        assert_eq!(sequences(&submissions.semaphore_reached(5, 999)), [last]);
    }

    #[test]
    fn a_timeline_value_completes_the_submissions_that_signal_up_to_it() {
        let mut submissions = Submissions::default();
        let one = submissions.submit(1, 0, &[(5, 1)]);
        submissions.add(1, one, 10, kept(), "vkQueueSubmit2");
        let two = submissions.submit(3, 0, &[(5, 2)]);
        submissions.add(3, two, 11, kept(), "vkQueueSubmit2");
        assert_eq!(sequences(&submissions.semaphore_reached(5, 1)), [one]);
        assert!(submissions.semaphore_reached(6, 9).is_empty());
        assert_eq!(sequences(&submissions.semaphore_reached(5, 7)), [two]);
        assert!(!submissions.waiting());
    }
}
