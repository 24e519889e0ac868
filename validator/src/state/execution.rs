//! Execution order: what command buffers recorded that matters once they
//! run, the submissions that ran them, and what the host has seen complete.
//!
//! Recording a `vkCmd*` call checks it at once (`checks/`) and, here, notes
//! what its execution does to micromaps and queries ([`ExecEvent`]). Nothing
//! of that happens until a submission carries the command buffer: the
//! execution-order rules (`checks::execution`) replay the events at
//! `vkQueueSubmit*`, in submission order. Work that is never submitted is
//! never decided, so a caller that never submits sees what it saw before.
//!
//! Ordering between queues is a vector clock per submission: for every
//! queue, the last of its submissions known to execute before this one
//! (earlier on the same queue, or before a semaphore signal it waits on, or
//! seen complete by the host). A batch that waits for a signal not yet
//! submitted (wait-before-signal: a timeline value a later submission or
//! `vkSignalSemaphore` provides) cannot run yet: it is held, with the
//! batches after it on its queue, as a [`HeldBatch`] until the signal
//! arrives, and is decided then. Everything here is bounded: one clock
//! entry per queue, a few signals per semaphore, at most [`HELD_AT_MOST`]
//! held batches, and at most [`IN_FLIGHT_AT_MOST`] submissions remembered
//! while nobody waits for them.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use crate::model::{Handle, SemaphoreOp};

/// How many submissions not yet seen complete are remembered (for the
/// objects they use): past it the oldest are forgotten, which can only hide
/// a use, never invent one.
pub const IN_FLIGHT_AT_MOST: usize = 4096;
/// How many timeline values one semaphore remembers the signals of; a wait
/// on a value whose signal was forgotten takes a later signal's clock,
/// which orders more work before it and so only hides findings.
pub const TIMELINE_SIGNALS_AT_MOST: usize = 64;
/// How many events one command buffer keeps; past it the command buffer's
/// execution order is not decided (see [`Recording::overflowed`]).
pub const EVENTS_AT_MOST: usize = 1 << 16;
/// How many batches are held waiting for a signal; past it the oldest runs
/// undecided (its effects applied, nothing reported for it), which can only
/// hide a finding.
pub const HELD_AT_MOST: usize = 256;

/// The rules a recorded read answers to (which VUID it reports).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadRule {
    /// `vkCmdCopyMicromapEXT` `pInfo->src` (07532).
    CopySource,
    /// `vkCmdCopyMicromapToMemoryEXT` `pInfo->src` (07540).
    SerializeSource,
    /// `vkCmdWriteMicromapsPropertiesEXT` `pMicromaps[k]` (11662).
    PropertiesMicromap,
    /// An acceleration-structure build's EXT attachment (11632).
    AttachedExt { indirect: bool },
    /// An acceleration-structure build's KHR attachment (11701).
    AttachedKhr { indirect: bool },
}

/// What executing one recorded command does that the execution-order rules
/// ask about.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ExecEvent {
    /// A micromap (or acceleration structure) is built, copied or
    /// deserialized into: constructed from here on.
    Construct { object: Handle },
    /// A micromap (or KHR micromap) must have been constructed before this
    /// executes; `location` is the member that names it.
    Read {
        object: Handle,
        rule: ReadRule,
        location: String,
    },
    /// `vkCmdWriteMicromapsPropertiesEXT` writes queries `[first, first + count)`.
    WriteQueries {
        pool: Handle,
        first: u32,
        count: u32,
    },
    /// `vkCmdResetQueryPool` makes queries `[first, first + count)`
    /// unavailable (and, the first time, no longer uninitialized).
    ResetQueries {
        pool: Handle,
        first: u32,
        count: u32,
    },
}

impl ExecEvent {
    /// The micromap or acceleration structure the event refers to.
    pub fn object(&self) -> Option<Handle> {
        match self {
            ExecEvent::Construct { object } | ExecEvent::Read { object, .. } => Some(*object),
            _ => None,
        }
    }
}

/// What one command buffer recorded since it began.
#[derive(Clone, Debug, Default)]
pub struct Recording {
    /// The events in recording order, each with the function that recorded it.
    pub events: Vec<(&'static str, ExecEvent)>,
    /// More than [`EVENTS_AT_MOST`] events were recorded: the command
    /// buffer's execution order is not decided (nothing is reported for it,
    /// and what it constructs is taken as constructed).
    pub overflowed: bool,
}

/// For each queue, the sequence number of its last submission known to
/// execute before (or be complete at) some point.
pub type Clock = BTreeMap<Handle, u64>;

/// Joins `other` into `clock`: the later of each queue's entries.
pub fn join(clock: &mut Clock, other: &Clock) {
    for (queue, seq) in other {
        let entry = clock.entry(*queue).or_insert(0);
        *entry = (*entry).max(*seq);
    }
}

/// Whether `point` (queue, sequence) lies inside `clock`.
pub fn covers(clock: &Clock, (queue, seq): (Handle, u64)) -> bool {
    clock.get(&queue).is_some_and(|known| *known >= seq)
}

/// How an object came to be constructed, as far as execution goes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Construction {
    /// Constructed before the checker saw anything (declared built), or by
    /// a host command that has returned.
    pub on_host: bool,
    /// A host command deferred to these operations is constructing it.
    pub pending_operations: BTreeSet<Handle>,
    /// For each queue, the earliest submission that constructs it.
    pub on_device: Clock,
}

/// A submission not yet seen complete, with the objects its work refers to.
#[derive(Clone, Debug)]
pub struct InFlight {
    pub queue: Handle,
    pub seq: u64,
    pub uses: BTreeSet<Handle>,
}

/// A batch that could not run when it was submitted: it waits for a
/// semaphore signal not submitted yet, or comes after such a batch on its
/// queue. It keeps what its command buffers recorded at submission.
#[derive(Clone, Debug)]
pub struct HeldBatch {
    pub queue: Handle,
    pub seq: u64,
    /// Submission order over all queues: the oldest held batch is the
    /// first to run undecided when too many are held.
    pub order: u64,
    pub waits: Vec<SemaphoreOp>,
    /// Each command buffer with what it had recorded when submitted, and
    /// the member that names it in the submit command.
    pub command_buffers: Vec<(Handle, Recording, String)>,
    pub signals: Vec<SemaphoreOp>,
    /// The submission's fence, on its last batch (0: none).
    pub fence: Handle,
    /// The submit command (`vkQueueSubmit`, `vkQueueSubmit2`).
    pub function: &'static str,
}

/// Half-open ranges of queries of one pool, sorted, disjoint.
pub type QueryRanges = Vec<(u64, u64)>;

/// Marks `[start, end)` available (`available`) or unavailable.
pub fn set_queries(ranges: &mut QueryRanges, start: u64, end: u64, available: bool) {
    if start >= end {
        return;
    }
    let mut out: QueryRanges = Vec::with_capacity(ranges.len() + 1);
    for &(s, e) in ranges.iter() {
        // The parts of [s, e) outside [start, end) stay as they are.
        if e <= start || s >= end {
            out.push((s, e));
            continue;
        }
        if s < start {
            out.push((s, start));
        }
        if e > end {
            out.push((end, e));
        }
    }
    if available {
        out.push((start, end));
    }
    out.sort_unstable();
    // Merge touching ranges.
    let mut merged: QueryRanges = Vec::with_capacity(out.len());
    for (s, e) in out {
        match merged.last_mut() {
            Some(last) if last.1 >= s => last.1 = last.1.max(e),
            _ => merged.push((s, e)),
        }
    }
    *ranges = merged;
}

/// The first available query in `[start, end)`, if any.
pub fn first_available(ranges: &QueryRanges, start: u64, end: u64) -> Option<u64> {
    ranges
        .iter()
        .find(|(s, e)| *s < end && *e > start)
        .map(|(s, _)| (*s).max(start))
}

/// The first query in `[start, end)` that `ranges` leaves out, if any.
pub fn first_outside(ranges: &[(u64, u64)], start: u64, end: u64) -> Option<u64> {
    let mut at = start;
    for &(s, e) in ranges {
        if at >= end || s > at {
            break;
        }
        at = at.max(e);
    }
    (at < end).then_some(at)
}

/// Everything execution order needs.
#[derive(Clone, Debug, Default)]
pub struct Execution {
    /// Command buffer → what it recorded since it began.
    pub recordings: BTreeMap<Handle, Recording>,
    /// Queue → its last submission's sequence number and clock.
    pub queues: BTreeMap<Handle, (u64, Clock)>,
    /// What the host has seen complete.
    pub completed: Clock,
    /// Fence → the clock of the submission that signals it.
    pub fences: BTreeMap<Handle, Clock>,
    /// Binary semaphore → the clock of its pending signal.
    pub binary_signals: BTreeMap<Handle, Clock>,
    /// Timeline semaphore → value → the clock of the submission that signals it.
    pub timeline_signals: BTreeMap<Handle, BTreeMap<u64, Clock>>,
    /// Object → how it was constructed.
    pub constructed: BTreeMap<Handle, Construction>,
    /// Submissions not yet seen complete, oldest first.
    pub in_flight: VecDeque<InFlight>,
    /// Query pool → its available queries, as executed work left them.
    pub available_queries: BTreeMap<Handle, QueryRanges>,
    /// Query pool → its queries reset at least once (by executed work or
    /// on the host) since the pool was created; the others of a pool the
    /// checker saw created are uninitialized.
    pub reset_queries: BTreeMap<Handle, QueryRanges>,
    /// Queue → its batches held until a signal they wait for arrives, in
    /// submission order.
    pub held: BTreeMap<Handle, VecDeque<HeldBatch>>,
    /// Binary semaphores whose pending signal belongs to a held batch: a
    /// wait on one is held too.
    pub held_binary_signals: BTreeSet<Handle>,
    /// Batches submitted so far, over all queues (the next [`HeldBatch::order`]).
    pub batches_submitted: u64,
}

impl Execution {
    /// Notes `event`, recorded by `function` into `command_buffer`.
    pub fn record(&mut self, command_buffer: Handle, function: &'static str, event: ExecEvent) {
        let recording = self.recordings.entry(command_buffer).or_default();
        if recording.events.len() >= EVENTS_AT_MOST {
            recording.overflowed = true;
            return;
        }
        recording.events.push((function, event));
    }

    /// `vkDestroySemaphore`: its signals stand for nothing any more, and a
    /// semaphore made later with the same handle starts without them.
    /// Batches still held that signal it keep their signals (destroying a
    /// semaphore a pending batch refers to is the application's error).
    pub fn forget_semaphore(&mut self, semaphore: Handle) {
        self.binary_signals.remove(&semaphore);
        self.timeline_signals.remove(&semaphore);
        self.held_binary_signals.remove(&semaphore);
    }

    /// `vkBeginCommandBuffer` or a reset: the command buffer records anew.
    pub fn begin(&mut self, command_buffer: Handle) {
        self.recordings.remove(&command_buffer);
    }

    /// `vkCmdExecuteCommands`: the secondaries' events run inside the primary.
    pub fn execute_commands(&mut self, primary: Handle, secondaries: &[Handle]) {
        for secondary in secondaries {
            let Some(recording) = self.recordings.get(secondary).cloned() else {
                continue;
            };
            let target = self.recordings.entry(primary).or_default();
            target.overflowed |= recording.overflowed;
            for event in recording.events {
                if target.events.len() >= EVENTS_AT_MOST {
                    target.overflowed = true;
                    break;
                }
                target.events.push(event);
            }
        }
    }

    /// The host saw everything inside `clock` complete.
    pub fn complete(&mut self, clock: &Clock) {
        join(&mut self.completed, clock);
        let completed = &self.completed;
        self.in_flight
            .retain(|s| !covers(completed, (s.queue, s.seq)));
    }

    /// Whether the host has seen `object`'s construction complete, or
    /// cannot tell: None when nothing is known of its construction.
    pub fn constructed_for_host(&self, object: Handle) -> Option<bool> {
        let c = self.constructed.get(&object)?;
        if c.on_host {
            return Some(true);
        }
        if !c.pending_operations.is_empty() {
            return Some(false);
        }
        Some(
            c.on_device
                .iter()
                .any(|(q, s)| covers(&self.completed, (*q, *s))),
        )
    }

    /// Whether `object` is constructed before work whose clock is `clock`.
    pub fn constructed_before(&self, object: Handle, clock: &Clock) -> bool {
        self.constructed.get(&object).is_some_and(|c| {
            c.on_host
                || c.on_device
                    .iter()
                    .any(|(q, s)| covers(clock, (*q, *s)) || covers(&self.completed, (*q, *s)))
        })
    }

    /// `object` is constructed on the host (declared built, or a host
    /// command returned); `deferred` is the operation still running it.
    pub fn constructed_on_host(&mut self, object: Handle, deferred: Option<Handle>) {
        let c = self.constructed.entry(object).or_default();
        match deferred {
            Some(op) => {
                c.pending_operations.insert(op);
            }
            None => c.on_host = true,
        }
    }

    /// A deferred operation completed: what it constructed is constructed.
    pub fn operation_completed(&mut self, operation: Handle) {
        for c in self.constructed.values_mut() {
            if c.pending_operations.remove(&operation) {
                c.on_host = true;
            }
        }
    }

    /// `object` is destroyed: nothing is known of a later object with its handle.
    pub fn forget(&mut self, object: Handle) {
        self.constructed.remove(&object);
    }

    /// Remembers a submission that uses `uses`, forgetting the oldest past
    /// [`IN_FLIGHT_AT_MOST`].
    pub fn submitted(&mut self, queue: Handle, seq: u64, uses: BTreeSet<Handle>) {
        if uses.is_empty() {
            return;
        }
        if self.in_flight.len() >= IN_FLIGHT_AT_MOST {
            self.in_flight.pop_front();
        }
        self.in_flight.push_back(InFlight { queue, seq, uses });
    }

    /// The oldest submission not seen complete that uses `object`.
    pub fn in_flight_use(&self, object: Handle) -> Option<&InFlight> {
        self.in_flight
            .iter()
            .find(|s| s.uses.contains(&object) && !covers(&self.completed, (s.queue, s.seq)))
    }

    /// The queries `[start, end)` of `pool` are reset (unavailable), by a
    /// reset that executed or by `vkResetQueryPool`.
    pub fn reset_queries(&mut self, pool: Handle, start: u64, end: u64) {
        set_queries(
            self.available_queries.entry(pool).or_default(),
            start,
            end,
            false,
        );
        set_queries(
            self.reset_queries.entry(pool).or_default(),
            start,
            end,
            true,
        );
    }

    /// `pool` is created (or destroyed): nothing is known of its queries,
    /// which are uninitialized, and nothing of an earlier pool with its handle.
    pub fn forget_query_pool(&mut self, pool: Handle) {
        self.available_queries.remove(&pool);
        self.reset_queries.remove(&pool);
    }

    /// The sequence number the next batch submitted to `queue` gets (after
    /// those run and those held).
    pub fn next_seq(&self, queue: Handle) -> u64 {
        let ran = self.queues.get(&queue).map_or(0, |(seq, _)| *seq);
        let held = self
            .held
            .get(&queue)
            .and_then(|h| h.back())
            .map_or(0, |b| b.seq);
        ran.max(held) + 1
    }

    /// Everything submitted to `queue` so far, held batches included, and
    /// what it was ordered after.
    pub fn queue_clock(&self, queue: Handle) -> Clock {
        let mut clock = self
            .queues
            .get(&queue)
            .map(|(_, clock)| clock.clone())
            .unwrap_or_default();
        clock.insert(queue, self.next_seq(queue) - 1);
        clock
    }

    /// Whether `queue` holds batches (a new one waits behind them).
    pub fn holds(&self, queue: Handle) -> bool {
        self.held.get(&queue).is_some_and(|h| !h.is_empty())
    }

    /// Whether a wait can be placed now: a timeline wait once a signal
    /// reaching its value is known; a binary wait unless its signal
    /// belongs to a held batch (a binary signal the checker never saw, such
    /// as a swapchain acquire, orders nothing it knows of).
    pub fn wait_ready(&self, wait: &SemaphoreOp) -> bool {
        if wait.timeline {
            self.timeline_reached(wait.semaphore, wait.value).is_some()
        } else {
            !self.held_binary_signals.contains(&wait.semaphore)
        }
    }

    /// Holds `batch` until its waits can be placed; its binary signals
    /// are then pending on it.
    pub fn hold(&mut self, batch: HeldBatch) {
        self.held_binary_signals.extend(
            batch
                .signals
                .iter()
                .filter(|s| !s.timeline)
                .map(|s| s.semaphore),
        );
        self.held.entry(batch.queue).or_default().push_back(batch);
    }

    /// Takes the first held batch of a queue whose waits can all be placed
    /// now, if any (queues in handle order, so the result is deterministic).
    pub fn take_ready(&mut self) -> Option<HeldBatch> {
        let queue = self.held.iter().find_map(|(queue, batches)| {
            let first = batches.front()?;
            first
                .waits
                .iter()
                .all(|w| self.wait_ready(w))
                .then_some(*queue)
        })?;
        self.take_first_held(queue)
    }

    /// Takes the first held batch of a queue that the host has seen
    /// complete: a signal the checker did not see let it run.
    pub fn take_completed(&mut self) -> Option<HeldBatch> {
        let queue = self.held.iter().find_map(|(queue, batches)| {
            let first = batches.front()?;
            covers(&self.completed, (first.queue, first.seq)).then_some(*queue)
        })?;
        self.take_first_held(queue)
    }

    /// Takes the oldest held batch when more than [`HELD_AT_MOST`] are held.
    pub fn take_overflow(&mut self) -> Option<HeldBatch> {
        if self.held.values().map(VecDeque::len).sum::<usize>() <= HELD_AT_MOST {
            return None;
        }
        let queue = self
            .held
            .iter()
            .filter_map(|(queue, batches)| Some((batches.front()?.order, *queue)))
            .min()?
            .1;
        self.take_first_held(queue)
    }

    fn take_first_held(&mut self, queue: Handle) -> Option<HeldBatch> {
        let batches = self.held.get_mut(&queue)?;
        let batch = batches.pop_front();
        if batches.is_empty() {
            self.held.remove(&queue);
        }
        if let Some(batch) = &batch {
            for signal in batch.signals.iter().filter(|s| !s.timeline) {
                self.held_binary_signals.remove(&signal.semaphore);
            }
        }
        batch
    }

    /// The held batch that first signals timeline `semaphore` to `value`
    /// or more (the lowest such value), as `(queue, seq)`.
    pub fn held_signal_reaching(&self, semaphore: Handle, value: u64) -> Option<(Handle, u64)> {
        self.held
            .values()
            .flatten()
            .flat_map(|b| {
                b.signals
                    .iter()
                    .filter(|s| s.timeline && s.semaphore == semaphore && s.value >= value)
                    .map(|s| (s.value, b.queue, b.seq))
            })
            .min()
            .map(|(_, queue, seq)| (queue, seq))
    }

    /// What the host knows complete once timeline `semaphore` is seen at
    /// `value` or more (`vkWaitSemaphores`): signal values only increase,
    /// so the first signal reaching `value` has executed, and every signal
    /// below it before it. None when no known signal reaches `value`.
    pub fn timeline_wait_completes(&self, semaphore: Handle, value: u64) -> Option<Clock> {
        let signals = self.timeline_signals.get(&semaphore);
        let reaching = signals.and_then(|s| s.range(value..).next().map(|(v, _)| *v));
        let Some(reaching) = reaching else {
            let (queue, seq) = self.held_signal_reaching(semaphore, value)?;
            // A held batch signals it: it ran, on a signal the checker did not see.
            let mut clock = Clock::from([(queue, seq)]);
            if let Some(signals) = signals {
                signals.values().for_each(|c| join(&mut clock, c));
            }
            return Some(clock);
        };
        self.timeline_counter_completes(semaphore, reaching)
    }

    /// What the host knows complete once timeline `semaphore`'s counter
    /// reads `value` (`vkGetSemaphoreCounterValue`): every signal up to
    /// `value` has executed, none above it.
    pub fn timeline_counter_completes(&self, semaphore: Handle, value: u64) -> Option<Clock> {
        let mut clock: Option<Clock> = None;
        if let Some(signals) = self.timeline_signals.get(&semaphore) {
            for signal in signals.range(..=value).map(|(_, c)| c) {
                join(clock.get_or_insert_with(Clock::new), signal);
            }
        }
        for batch in self.held.values().flatten() {
            let signals_below = batch
                .signals
                .iter()
                .any(|s| s.timeline && s.semaphore == semaphore && s.value <= value);
            if signals_below {
                join(
                    clock.get_or_insert_with(Clock::new),
                    &Clock::from([(batch.queue, batch.seq)]),
                );
            }
        }
        clock
    }

    /// Records a timeline signal, keeping at most [`TIMELINE_SIGNALS_AT_MOST`].
    pub fn timeline_signal(&mut self, semaphore: Handle, value: u64, clock: Clock) {
        let signals = self.timeline_signals.entry(semaphore).or_default();
        signals.insert(value, clock);
        while signals.len() > TIMELINE_SIGNALS_AT_MOST {
            signals.pop_first();
        }
    }

    /// The clock a wait for `value` of a timeline semaphore joins: that of
    /// the first signal reaching it; None when no known signal does.
    pub fn timeline_reached(&self, semaphore: Handle, value: u64) -> Option<&Clock> {
        self.timeline_signals
            .get(&semaphore)?
            .range(value..)
            .next()
            .map(|(_, clock)| clock)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn query_ranges_split_and_merge() {
        let mut r = QueryRanges::new();
        set_queries(&mut r, 0, 8, true);
        set_queries(&mut r, 2, 4, false);
        assert_eq!(r, vec![(0, 2), (4, 8)]);
        assert_eq!(first_available(&r, 2, 4), None);
        assert_eq!(first_available(&r, 3, 6), Some(4));
        set_queries(&mut r, 2, 4, true);
        assert_eq!(r, vec![(0, 8)]);
        set_queries(&mut r, 0, 100, false);
        assert!(r.is_empty());
        set_queries(&mut r, 5, 5, true);
        assert!(r.is_empty(), "an empty range changes nothing");
    }

    #[test]
    fn the_first_query_outside_the_ranges() {
        let r = vec![(0, 2), (4, 8)];
        assert_eq!(first_outside(&r, 0, 2), None);
        assert_eq!(first_outside(&r, 0, 3), Some(2));
        assert_eq!(first_outside(&r, 3, 6), Some(3));
        assert_eq!(first_outside(&r, 5, 8), None);
        assert_eq!(first_outside(&r, 5, 9), Some(8));
        assert_eq!(first_outside(&[], 1, 2), Some(1));
        assert_eq!(
            first_outside(&[], 2, 2),
            None,
            "an empty range has no query"
        );
    }

    #[test]
    fn clocks_join_and_cover() {
        let mut a = Clock::from([(1, 3)]);
        join(&mut a, &Clock::from([(1, 2), (2, 7)]));
        assert_eq!(a, Clock::from([(1, 3), (2, 7)]));
        assert!(covers(&a, (2, 7)));
        assert!(!covers(&a, (2, 8)));
        assert!(!covers(&a, (3, 1)));
    }

    #[test]
    fn in_flight_submissions_stay_bounded_and_leave_when_complete() {
        let mut e = Execution::default();
        for seq in 1..=(IN_FLIGHT_AT_MOST as u64 + 10) {
            e.submitted(1, seq, BTreeSet::from([42]));
        }
        assert_eq!(e.in_flight.len(), IN_FLIGHT_AT_MOST);
        assert_eq!(e.in_flight_use(42).map(|s| s.seq), Some(11));
        e.complete(&Clock::from([(1, IN_FLIGHT_AT_MOST as u64 + 10)]));
        assert!(e.in_flight.is_empty());
        assert!(e.in_flight_use(42).is_none());
    }

    #[test]
    fn a_deferred_construction_completes_with_its_operation() {
        let mut e = Execution::default();
        assert_eq!(e.constructed_for_host(7), None);
        e.constructed_on_host(7, Some(99));
        assert_eq!(e.constructed_for_host(7), Some(false));
        e.operation_completed(99);
        assert_eq!(e.constructed_for_host(7), Some(true));
    }
}
