//! The device builds kept from recording for the checks of their contents
//! ([`KeptBuild`]), and a device's submissions whose builds read back on
//! the GPU wait to be seen complete ([`Submissions`]); `crate::submit`
//! adds to them and `crate::completion` says when a submission is complete.

use std::sync::Arc;

use foldhash::HashMap;
use ommcheck::build_inputs::DeviceBuild;
use ommcheck::model::CommandBuffer;

use super::readback_memory::Readback;

/// A device build recorded into a command buffer, whose contents are
/// checked each time the command buffer is submitted.
#[derive(Clone, Debug)]
pub struct KeptBuild {
    /// The command buffer as the checks saw it when the build was recorded.
    pub recorded_in: CommandBuffer,
    pub build: Arc<DeviceBuild>,
    /// The copies of its inputs the layer recorded before it (route 2):
    /// the build is then checked once its submission completes.
    pub readback: Option<Arc<Readback>>,
    /// Why its inputs, which the host could not read at recording, were
    /// not read back: a key naming the cause, and the sentence.
    pub not_read_back: Option<(&'static str, String)>,
}

/// A submitted build whose read-back inputs are checked at completion.
#[derive(Debug)]
pub struct Pending {
    queue: u64,
    /// The submission's place on its device, in submission order.
    pub sequence: u64,
    pub command_buffer: u64,
    pub kept: KeptBuild,
    pub submit_function: &'static str,
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
    pub fn take(&mut self, done: impl Fn(u64, u64) -> bool) -> Vec<Pending> {
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
    pub fn through(&mut self, queue: u64, sequence: u64) -> Vec<Pending> {
        self.take(|q, s| q == queue && s <= sequence)
    }

    pub fn fence_signalled(&mut self, fence: u64) -> Vec<Pending> {
        match self.fences.get(&fence).copied() {
            Some((queue, sequence)) => self.through(queue, sequence),
            None => Vec::new(),
        }
    }

    pub fn semaphore_reached(&mut self, semaphore: u64, value: u64) -> Vec<Pending> {
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
    pub fn waiting(&self) -> bool {
        !self.pending.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
            readback: Some(Arc::new(Readback::empty())),
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
