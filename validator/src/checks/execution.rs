//! Execution order: the rules that depend on what runs before what on the
//! device and on what the host has seen complete. Recorded commands note
//! what their execution does (`state::execution`); the rules are decided
//! when a submission runs them, in submission order, and at the host
//! commands and `vkDestroyMicromapEXT` that depend on submitted work. A
//! batch that waits for a signal not submitted yet runs, and is decided,
//! at the later submission or `vkSignalSemaphore` that provides it.
//!
//! Command buffers that are never submitted are never decided, so a caller
//! that does not submit sees no finding of these rules (`docs/choices.md`).

use std::collections::{BTreeMap, BTreeSet};

use ommcheck_vuids::vuid::{
    vkCmdBuildAccelerationStructuresIndirectKHR as build_indirect,
    vkCmdBuildAccelerationStructuresKHR as build_cmd, vkCmdCopyMicromapEXT as cmd_copy,
    vkCmdWriteMicromapsPropertiesEXT as cmd_write, vkCopyMicromapEXT as host_copy,
    vkDestroyMicromapEXT as destroy, vkWriteMicromapsPropertiesEXT as host_write,
    VkCopyMicromapToMemoryInfoEXT as to_memory_info,
};
use ommcheck_vuids::Vuid;

use crate::checks::Coverage;
use crate::checks::Validator;
use crate::model::accel::{BuildGeometryInfo, GeometryData};
use crate::model::Handle;
use crate::model::{CommandBuffer, SemaphoreOp, SubmitBatch};
use crate::report::{ObjectRef, Report};
use crate::state::execution::{
    first_available, first_outside, join, set_queries, Clock, ExecEvent, Execution, HeldBatch,
    ReadRule, Recording,
};
use crate::state::QueryPool;
use crate::tier::Tier;

pub const COVERAGE: Coverage = Coverage {
    module: "execution",
    enforced: &[
        cmd_copy::src_07532,
        to_memory_info::src_07540,
        cmd_write::pMicromaps_11662,
        cmd_write::None_12417,
        build_cmd::micromap_11632,
        build_indirect::micromap_11632,
        build_cmd::micromap_11701,
        build_indirect::micromap_11701,
        destroy::micromap_07441,
        host_copy::src_11670,
        host_write::pMicromaps_11671,
    ],
    not_decidable: &[],
};

impl ReadRule {
    /// The VUID a read of an unconstructed object breaks.
    fn vuid(self) -> Vuid {
        match self {
            ReadRule::CopySource => cmd_copy::src_07532,
            ReadRule::SerializeSource => to_memory_info::src_07540,
            ReadRule::PropertiesMicromap => cmd_write::pMicromaps_11662,
            ReadRule::AttachedExt { indirect: false } => build_cmd::micromap_11632,
            ReadRule::AttachedExt { indirect: true } => build_indirect::micromap_11632,
            ReadRule::AttachedKhr { indirect: false } => build_cmd::micromap_11701,
            ReadRule::AttachedKhr { indirect: true } => build_indirect::micromap_11701,
        }
    }

    /// The object type the read names.
    fn object_type(self) -> &'static str {
        match self {
            ReadRule::AttachedKhr { .. } => "VkAccelerationStructureKHR",
            _ => "VkMicromapEXT",
        }
    }
}

/// A finding decided while execution state was being updated, reported
/// once the update is done.
struct Decided {
    vuid: Vuid,
    location: String,
    message: String,
    object: Option<ObjectRef>,
}

/// What running batches decided: the rules checked, with or without a
/// finding, and the findings.
#[derive(Default)]
struct Outcome {
    checked: BTreeSet<Vuid>,
    decided: Vec<Decided>,
}

/// The query pools the checker saw created (their queries start uninitialized).
type Pools = BTreeMap<Handle, QueryPool>;

/// What a submitted command buffer is called in the submit command's parameters.
fn command_buffer_member(function: &str, batch: usize, index: usize) -> String {
    if function == "vkQueueSubmit" {
        format!("pSubmits[{batch}].pCommandBuffers[{index}]")
    } else {
        format!("pSubmits[{batch}].pCommandBufferInfos[{index}].commandBuffer")
    }
}

/// Why a batch runs when it does.
enum Mode<'a> {
    /// It runs as it is submitted: decided, and reported at its command buffer.
    Submitted,
    /// It was held for a signal the call at hand provides (`by`, the
    /// member that signals): decided, and reported at that member.
    Released { by: &'a str },
    /// The host saw it complete though the signal it waited for was never
    /// seen, or too many batches were held: its effects apply, and nothing
    /// is decided (it is ordered after work the checker has not seen).
    Undecided,
}

/// One batch as it runs: its command buffers with what they recorded (None:
/// what the command buffer holds now, for a batch run as it is submitted)
/// and the member naming each.
struct BatchRun<'a> {
    queue: Handle,
    seq: u64,
    waits: &'a [SemaphoreOp],
    signals: &'a [SemaphoreOp],
    command_buffers: Vec<(Handle, Option<&'a Recording>, &'a str)>,
    /// The submission's fence, on its last batch (0: none).
    fence: Handle,
    /// The submit command.
    function: &'static str,
    /// Submitted just now (a held batch was remembered in flight when held).
    fresh: bool,
}

/// Runs the events of one command buffer in a batch whose clock is `clock`
/// on `(queue, seq)`; nothing is decided unless `decide`.
struct Run<'a> {
    queue: Handle,
    seq: u64,
    clock: &'a Clock,
    decide: bool,
    /// Where a finding is reported.
    at: String,
    /// Appended to each message: why the batch runs at this call.
    note: String,
}

fn run_recording(
    exec: &mut Execution,
    pools: &Pools,
    command_buffer: Handle,
    recording: &Recording,
    run: &Run<'_>,
    uses: &mut BTreeSet<Handle>,
    out: &mut Outcome,
) {
    let decide = run.decide && !recording.overflowed;
    let note = &run.note;
    for (function, event) in &recording.events {
        let function = *function;
        uses.extend(event.object());
        match event {
            ExecEvent::Construct { object } => {
                let c = exec.constructed.entry(*object).or_default();
                c.on_device.entry(run.queue).or_insert(run.seq);
            }
            ExecEvent::Read {
                object,
                rule,
                location,
            } => {
                if decide {
                    out.checked.insert(rule.vuid());
                }
                if decide && !exec.constructed_before(*object, run.clock) {
                    out.decided.push(Decided {
                        vuid: rule.vuid(),
                        location: run.at.clone(),
                        message: format!(
                            "{function} recorded in VkCommandBuffer {command_buffer:#x} reads {location} ({} {object:#x}), which no build, copy or deserialization executed before it has constructed{note}",
                            rule.object_type()
                        ),
                        object: Some(ObjectRef {
                            ty: rule.object_type(),
                            handle: *object,
                        }),
                    });
                }
            }
            ExecEvent::WriteQueries { pool, first, count } => {
                let (start, end) = (u64::from(*first), u64::from(*first) + u64::from(*count));
                if decide {
                    out.checked.insert(cmd_write::None_12417);
                    let problem = uninitialized_query(exec, pools, *pool, start, end)
                        .map(|query| (query, "uninitialized: no vkCmdResetQueryPool executed before it and no vkResetQueryPool has reset it since the pool was created"))
                        .or_else(|| {
                            let available = exec.available_queries.get(pool)?;
                            first_available(available, start, end).map(|query| (query, "available: executed work wrote it, and no vkCmdResetQueryPool or vkResetQueryPool reset it since"))
                        });
                    if let Some((query, state)) = problem {
                        out.decided.push(Decided {
                            vuid: cmd_write::None_12417,
                            location: run.at.clone(),
                            message: format!(
                                "{function} recorded in VkCommandBuffer {command_buffer:#x} writes query {query} of VkQueryPool {pool:#x}, which is {state}{note}"
                            ),
                            object: Some(ObjectRef {
                                ty: "VkQueryPool",
                                handle: *pool,
                            }),
                        });
                    }
                }
                set_queries(
                    exec.available_queries.entry(*pool).or_default(),
                    start,
                    end,
                    true,
                );
            }
            ExecEvent::ResetQueries { pool, first, count } => {
                let start = u64::from(*first);
                exec.reset_queries(*pool, start, start + u64::from(*count));
            }
        }
    }
}

/// The first query of `[start, end)` of `pool` never reset since the pool
/// was created. Only a pool the checker saw created is decided (of another
/// it cannot tell), and only its queries (those past its end are 07528's).
fn uninitialized_query(
    exec: &Execution,
    pools: &Pools,
    pool: Handle,
    start: u64,
    end: u64,
) -> Option<u64> {
    let count = u64::from(pools.get(&pool)?.query_count);
    let reset = exec.reset_queries.get(&pool).map_or(&[][..], Vec::as_slice);
    first_outside(reset, start, end.min(count))
}

/// Runs one batch: its clock is its queue's, with what the host has seen
/// complete and the signals it waits for; then its command buffers run in
/// order, and its signals and fence stand for its clock.
fn run_batch(
    exec: &mut Execution,
    pools: &Pools,
    batch: &BatchRun<'_>,
    mode: &Mode<'_>,
    out: &mut Outcome,
) {
    let (_, mut clock) = exec.queues.get(&batch.queue).cloned().unwrap_or_default();
    join(&mut clock, &exec.completed);
    clock.insert(batch.queue, batch.seq);
    for wait in batch.waits {
        let signal = if wait.timeline {
            exec.timeline_reached(wait.semaphore, wait.value).cloned()
        } else {
            exec.binary_signals.remove(&wait.semaphore)
        };
        // No signal: a binary one the checker never saw (a swapchain
        // acquire), or a batch run undecided; it orders nothing known.
        if let Some(signal) = signal {
            join(&mut clock, &signal);
        }
    }
    let mut uses = BTreeSet::new();
    for &(command_buffer, snapshot, member) in &batch.command_buffers {
        let (at, note) = match mode {
            Mode::Submitted | Mode::Undecided => (member.to_string(), String::new()),
            Mode::Released { by } => (
                (*by).to_string(),
                format!(
                    " (the batch ran only now: {member} of an earlier {} on VkQueue {:#x} was held until this call signalled what it waits for)",
                    batch.function, batch.queue
                ),
            ),
        };
        let run = Run {
            queue: batch.queue,
            seq: batch.seq,
            clock: &clock,
            decide: !matches!(mode, Mode::Undecided),
            at,
            note,
        };
        match snapshot {
            Some(recording) => {
                run_recording(exec, pools, command_buffer, recording, &run, &mut uses, out)
            }
            // Taken out while it runs (the replay updates the rest of
            // `exec`), put back after.
            None => {
                if let Some(recording) = exec.recordings.remove(&command_buffer) {
                    run_recording(
                        exec,
                        pools,
                        command_buffer,
                        &recording,
                        &run,
                        &mut uses,
                        out,
                    );
                    exec.recordings.insert(command_buffer, recording);
                }
            }
        }
    }
    for signal in batch.signals {
        if signal.timeline {
            exec.timeline_signal(signal.semaphore, signal.value, clock.clone());
        } else {
            exec.binary_signals.insert(signal.semaphore, clock.clone());
        }
    }
    if batch.fence != 0 {
        exec.fences.insert(batch.fence, clock.clone());
    }
    if batch.fresh {
        exec.submitted(batch.queue, batch.seq, uses);
    }
    exec.queues.insert(batch.queue, (batch.seq, clock));
}

/// Runs a held batch with what its command buffers recorded when submitted.
fn run_held(
    exec: &mut Execution,
    pools: &Pools,
    held: &HeldBatch,
    mode: &Mode<'_>,
    out: &mut Outcome,
) {
    let batch = BatchRun {
        queue: held.queue,
        seq: held.seq,
        waits: &held.waits,
        signals: &held.signals,
        command_buffers: held
            .command_buffers
            .iter()
            .map(|(handle, recording, member)| (*handle, Some(recording), member.as_str()))
            .collect(),
        fence: held.fence,
        function: held.function,
        fresh: false,
    };
    run_batch(exec, pools, &batch, mode, out);
}

/// Runs the held batches whose signals have arrived, each as soon as its
/// waits can be placed (a batch's signals may free others), decided and
/// reported at `by`; then, past [`crate::state::execution::HELD_AT_MOST`],
/// the oldest undecided.
fn release(exec: &mut Execution, pools: &Pools, by: &str, out: &mut Outcome) {
    while let Some(held) = exec.take_ready() {
        run_held(exec, pools, &held, &Mode::Released { by }, out);
    }
    while let Some(oldest) = exec.take_overflow() {
        run_held(exec, pools, &oldest, &Mode::Undecided, out);
        while let Some(held) = exec.take_ready() {
            run_held(exec, pools, &held, &Mode::Undecided, out);
        }
    }
}

/// After the host saw work complete: held batches it covers ran on signals
/// the checker did not see, and run now undecided, with the batches their
/// signals free (ordered after unseen work too).
fn release_completed(exec: &mut Execution, pools: &Pools) {
    let mut ignored = Outcome::default();
    while let Some(held) = exec.take_completed().or_else(|| exec.take_ready()) {
        run_held(exec, pools, &held, &Mode::Undecided, &mut ignored);
    }
}

impl Validator {
    /// Notes what executing a command recorded into `command_buffer` does;
    /// a NULL command buffer records nothing.
    pub(crate) fn record_execution(
        &mut self,
        command_buffer: &CommandBuffer,
        function: &'static str,
        events: impl IntoIterator<Item = ExecEvent>,
    ) {
        if command_buffer.handle == 0 {
            return;
        }
        for event in events {
            self.state
                .execution
                .record(command_buffer.handle, function, event);
        }
    }

    /// What executing an acceleration-structure build does: its micromap
    /// attachments are read, its destinations constructed.
    pub(crate) fn record_acceleration_structure_builds(
        &mut self,
        command_buffer: &CommandBuffer,
        function: &'static str,
        infos: &[BuildGeometryInfo],
        indirect: bool,
    ) {
        let mut events = Vec::new();
        for (i, info) in infos.iter().enumerate() {
            let member = info.geometry_member();
            for (g, geometry) in info.geometries_read() {
                let GeometryData::Triangles(triangles) = &geometry.geometry else {
                    continue;
                };
                let at = format!("pInfos[{i}].{member}[{g}].geometry.triangles.pNext");
                if let Some(ext) = triangles.opacity_ext.as_ref().filter(|a| a.micromap != 0) {
                    events.push(ExecEvent::Read {
                        object: ext.micromap,
                        rule: ReadRule::AttachedExt { indirect },
                        location: format!(
                            "{at}<VkAccelerationStructureTrianglesOpacityMicromapEXT>.micromap"
                        ),
                    });
                }
                if let Some(khr) = triangles.opacity_khr.as_ref().filter(|a| a.micromap != 0) {
                    events.push(ExecEvent::Read {
                        object: khr.micromap,
                        rule: ReadRule::AttachedKhr { indirect },
                        location: format!(
                            "{at}<VkAccelerationStructureTrianglesOpacityMicromapKHR>.micromap"
                        ),
                    });
                }
            }
            events.push(ExecEvent::Construct {
                object: info.dst_acceleration_structure,
            });
        }
        self.record_execution(command_buffer, function, events);
    }

    /// A host command constructed `object` (a build, copy or
    /// deserialization returned, or runs on `deferred_operation`).
    pub(crate) fn constructed_on_host(&mut self, object: Handle, deferred_operation: Handle) {
        if object == 0 {
            return;
        }
        let deferred = (deferred_operation != 0
            && self
                .state
                .pending_deferred_operations
                .contains(&deferred_operation))
        .then_some(deferred_operation);
        self.state.execution.constructed_on_host(object, deferred);
    }

    /// Declares `object` constructed before the first call (a scene's
    /// `built` micromap or acceleration structure).
    pub fn declare_constructed(&mut self, object: Handle) {
        self.state.execution.constructed_on_host(object, None);
    }

    /// `vkBeginCommandBuffer` (or `vkResetCommandBuffer`): what the command
    /// buffer recorded before is forgotten.
    pub fn begin_command_buffer(&mut self, command_buffer: Handle) {
        self.state.execution.begin(command_buffer);
    }

    /// `vkCmdExecuteCommands(commandBuffer, commandBufferCount, pCommandBuffers)`:
    /// the secondaries' recorded work runs in the primary.
    pub fn cmd_execute_commands(&mut self, primary: Handle, secondaries: &[Handle]) {
        self.state.execution.execute_commands(primary, secondaries);
    }

    /// `vkCmdResetQueryPool(commandBuffer, queryPool, firstQuery, queryCount)`.
    pub fn cmd_reset_query_pool(
        &mut self,
        command_buffer: &CommandBuffer,
        query_pool: Handle,
        first_query: u32,
        query_count: u32,
    ) -> Report {
        self.record_execution(
            command_buffer,
            "vkCmdResetQueryPool",
            [ExecEvent::ResetQueries {
                pool: query_pool,
                first: first_query,
                count: query_count,
            }],
        );
        Report::new()
    }

    /// `vkResetQueryPool(device, queryPool, firstQuery, queryCount)`: the
    /// queries are unavailable now.
    pub fn reset_query_pool(
        &mut self,
        query_pool: Handle,
        first_query: u32,
        query_count: u32,
    ) -> Report {
        let start = u64::from(first_query);
        self.state
            .execution
            .reset_queries(query_pool, start, start + u64::from(query_count));
        Report::new()
    }

    /// `vkQueueSubmit` / `vkQueueSubmit2` (`function`) on `queue`: runs the
    /// batches' command buffers in submission order and decides the
    /// execution-order rules for the work they recorded. `fence` (0: none)
    /// signals when they complete. A batch that waits for a signal not
    /// submitted yet is held, with those after it on `queue`, and decided
    /// when the signal arrives; a batch this submission signals for may
    /// run (and report) here.
    pub fn queue_submit(
        &mut self,
        function: &'static str,
        queue: Handle,
        batches: &[SubmitBatch],
        fence: Handle,
    ) -> Report {
        let mut exec = std::mem::take(&mut self.state.execution);
        let pools = &self.state.query_pools;
        let mut out = Outcome::default();
        for (b, batch) in batches.iter().enumerate() {
            let seq = exec.next_seq(queue);
            exec.batches_submitted += 1;
            let members: Vec<String> = (0..batch.command_buffers.len())
                .map(|k| command_buffer_member(function, b, k))
                .collect();
            let fence = if b + 1 == batches.len() { fence } else { 0 };
            if !exec.holds(queue) && batch.waits.iter().all(|w| exec.wait_ready(w)) {
                let run = BatchRun {
                    queue,
                    seq,
                    waits: &batch.waits,
                    signals: &batch.signals,
                    command_buffers: batch
                        .command_buffers
                        .iter()
                        .zip(&members)
                        .map(|(handle, member)| (*handle, None, member.as_str()))
                        .collect(),
                    fence,
                    function,
                    fresh: true,
                };
                run_batch(&mut exec, pools, &run, &Mode::Submitted, &mut out);
            } else {
                let held = HeldBatch {
                    queue,
                    seq,
                    order: exec.batches_submitted,
                    waits: batch.waits.clone(),
                    command_buffers: batch
                        .command_buffers
                        .iter()
                        .zip(members)
                        .map(|(handle, member)| {
                            let recording = exec.recordings.get(handle).cloned();
                            (*handle, recording.unwrap_or_default(), member)
                        })
                        .collect(),
                    signals: batch.signals.clone(),
                    fence,
                    function,
                };
                // Submitted, so in flight for 07441 from now on.
                let uses = held
                    .command_buffers
                    .iter()
                    .flat_map(|(_, recording, _)| &recording.events)
                    .filter_map(|(_, event)| event.object())
                    .collect();
                exec.submitted(queue, seq, uses);
                if fence != 0 {
                    // Until it runs, the fence stands for the batch alone.
                    exec.fences.insert(fence, Clock::from([(queue, seq)]));
                }
                exec.hold(held);
            }
            // This batch's signals may let held batches run.
            release(&mut exec, pools, &format!("pSubmits[{b}]"), &mut out);
        }
        if batches.is_empty() && fence != 0 {
            // The fence signals once the queue's earlier work completes.
            let clock = exec.queue_clock(queue);
            exec.fences.insert(fence, clock);
        }
        self.state.execution = exec;
        self.report_decided(function, &out.checked, out.decided)
    }

    /// Reports what an execution-order check decided, from the state tier
    /// up; `checked`: the rules it decided, with or without a finding.
    fn report_decided(
        &self,
        function: &'static str,
        checked: &BTreeSet<Vuid>,
        decided: Vec<Decided>,
    ) -> Report {
        let mut ctx = self.ctx(function);
        if self.tier < Tier::State {
            return ctx.finish();
        }
        let rules: Vec<_> = checked.iter().map(|v| (*v).into()).collect();
        ctx.checked(&rules);
        for d in decided {
            ctx.error(d.vuid, d.location, d.message)
                .objects
                .extend(d.object);
        }
        ctx.finish()
    }

    /// The host saw everything inside `clock` complete (None: nothing
    /// known): held batches it covers ran on signals the checker did not see.
    fn host_saw_complete(&mut self, clock: Option<Clock>) {
        let Some(clock) = clock else {
            return;
        };
        let exec = &mut self.state.execution;
        exec.complete(&clock);
        release_completed(exec, &self.state.query_pools);
    }

    /// `vkWaitForFences` or `vkGetFenceStatus` reported these fences
    /// signalled: the submissions that signal them, and everything before
    /// those, are complete.
    pub fn fences_signalled(&mut self, fences: &[Handle]) {
        for fence in fences {
            let clock = self.state.execution.fences.get(fence).cloned();
            self.host_saw_complete(clock);
        }
    }

    /// `vkResetFences`: the fences no longer stand for a submission.
    pub fn reset_fences(&mut self, fences: &[Handle]) {
        for fence in fences {
            self.state.execution.fences.remove(fence);
        }
    }

    /// `vkDestroySemaphore`: the semaphore's signals are forgotten, so a
    /// semaphore that reuses the handle is not taken as signalled by them,
    /// and an application that makes and destroys semaphores does not
    /// grow the execution order.
    pub fn destroy_semaphore(&mut self, semaphore: Handle) {
        self.state.execution.forget_semaphore(semaphore);
    }

    /// `vkQueueWaitIdle(queue)` returned `VK_SUCCESS`.
    pub fn queue_wait_idle(&mut self, queue: Handle) {
        let clock = self.state.execution.queue_clock(queue);
        self.host_saw_complete(Some(clock));
    }

    /// `vkDeviceWaitIdle` returned `VK_SUCCESS`: every submission is complete.
    pub fn device_wait_idle(&mut self) {
        let exec = &self.state.execution;
        let queues: BTreeSet<Handle> = exec
            .queues
            .keys()
            .chain(exec.held.keys())
            .copied()
            .collect();
        let mut clock = Clock::new();
        for queue in queues {
            join(&mut clock, &exec.queue_clock(queue));
        }
        self.host_saw_complete(Some(clock));
    }

    /// `vkWaitSemaphores` saw timeline `semaphore` reach `value`: the
    /// first signal that reaches it has executed (signal values only
    /// increase, so nothing else can have set the counter to `value` or
    /// more), with every signal below it, and what each signal follows.
    pub fn semaphore_reached(&mut self, semaphore: Handle, value: u64) {
        let clock = self
            .state
            .execution
            .timeline_wait_completes(semaphore, value);
        self.host_saw_complete(clock);
    }

    /// `vkGetSemaphoreCounterValue` read `value` from timeline `semaphore`:
    /// the signals up to `value` have executed (none above it).
    pub fn semaphore_counter_value(&mut self, semaphore: Handle, value: u64) {
        let clock = self
            .state
            .execution
            .timeline_counter_completes(semaphore, value);
        self.host_saw_complete(clock);
    }

    /// `vkSignalSemaphore`: the host signals timeline `semaphore` to
    /// `value`. Work waiting on it is ordered after what the host has seen
    /// complete, and no later: batches held for this value run now, and
    /// are decided and reported here.
    pub fn signal_semaphore(&mut self, semaphore: Handle, value: u64) -> Report {
        let mut exec = std::mem::take(&mut self.state.execution);
        let clock = exec.completed.clone();
        exec.timeline_signal(semaphore, value, clock);
        let mut out = Outcome::default();
        release(&mut exec, &self.state.query_pools, "pSignalInfo", &mut out);
        self.state.execution = exec;
        self.report_decided("vkSignalSemaphore", &out.checked, out.decided)
    }

    /// 07441: `micromap` is used by a submission not seen complete.
    pub(crate) fn destroyed_in_flight(&self, micromap: Handle) -> Report {
        let mut decided = Vec::new();
        if let Some(s) = self.state.execution.in_flight_use(micromap) {
            decided.push(Decided {
                vuid: destroy::micromap_07441,
                location: "micromap".into(),
                message: format!(
                    "submission {} on VkQueue {:#x} refers to the micromap and has not been seen complete (no vkWaitForFences, vkGetFenceStatus, vkQueueWaitIdle, vkDeviceWaitIdle or timeline wait covers it)",
                    s.seq, s.queue
                ),
                object: Some(ObjectRef {
                    ty: "VkMicromapEXT",
                    handle: micromap,
                }),
            });
        }
        let checked = BTreeSet::from([destroy::micromap_07441]);
        self.report_decided("vkDestroyMicromapEXT", &checked, decided)
    }

    /// 11670, 11671, 07540 on the host: the micromaps a host command reads
    /// (`(location, handle)`) must be constructed by work the host has seen
    /// complete; a micromap whose construction the checker never saw is
    /// not decided.
    pub(crate) fn host_reads_constructed(
        &self,
        function: &'static str,
        vuid: Vuid,
        reads: &[(String, Handle)],
    ) -> Report {
        let decided = reads
            .iter()
            .filter(|(_, handle)| {
                self.state.execution.constructed_for_host(*handle) == Some(false)
            })
            .map(|(location, handle)| Decided {
                vuid,
                location: location.clone(),
                message: format!(
                    "VkMicromapEXT {handle:#x} is still being constructed: the build, copy or deserialization that constructs it is on the device and not seen complete, or deferred to an operation not yet joined"
                ),
                object: Some(ObjectRef {
                    ty: "VkMicromapEXT",
                    handle: *handle,
                }),
            })
            .collect();
        let checked = reads.iter().take(1).map(|_| vuid).collect();
        self.report_decided(function, &checked, decided)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Device;

    /// The micromap, and the two queues the submissions go to.
    const OMM: Handle = 0x33;
    const GRAPHICS: Handle = 0x9e1;
    const COMPUTE: Handle = 0x9e2;

    /// A validator where command buffer 1 builds OMM and 2 copies from it.
    fn recorded() -> Validator {
        let mut v = Validator::new(Device::default());
        v.record_execution(
            &cb(1),
            "vkCmdBuildMicromapsEXT",
            [ExecEvent::Construct { object: OMM }],
        );
        let read = ExecEvent::Read {
            object: OMM,
            rule: ReadRule::CopySource,
            location: "pInfo->src".into(),
        };
        v.record_execution(&cb(2), "vkCmdCopyMicromapEXT", [read]);
        v
    }

    /// A command buffer recording on every queue kind.
    fn cb(handle: Handle) -> CommandBuffer {
        CommandBuffer {
            handle,
            ..CommandBuffer::default()
        }
    }

    fn batch(
        command_buffer: Handle,
        waits: Vec<SemaphoreOp>,
        signals: Vec<SemaphoreOp>,
    ) -> SubmitBatch {
        SubmitBatch {
            waits,
            command_buffers: vec![command_buffer],
            signals,
        }
    }

    fn timeline(semaphore: Handle, value: u64) -> SemaphoreOp {
        SemaphoreOp {
            semaphore,
            value,
            timeline: true,
        }
    }

    #[test]
    fn recorded_work_never_submitted_decides_nothing() {
        let v = recorded();
        assert!(v.state.execution.in_flight.is_empty());
        assert_eq!(v.state.execution.constructed_for_host(OMM), None);
    }

    #[test]
    fn a_timeline_wait_orders_work_across_queues_and_its_absence_does_not() {
        let mut v = recorded();
        let signal = vec![timeline(0x5e, 1)];
        let report = v.queue_submit("vkQueueSubmit", GRAPHICS, &[batch(1, vec![], signal)], 0);
        assert!(report.is_empty(), "{report}");
        let waited = batch(2, vec![timeline(0x5e, 1)], vec![]);
        let report = v.queue_submit("vkQueueSubmit", COMPUTE, &[waited], 0);
        assert!(report.is_empty(), "{report}");
        assert!(report.checked.contains(cmd_copy::src_07532));

        // Without the wait the compute queue may run the copy first.
        let mut v = recorded();
        v.queue_submit("vkQueueSubmit", GRAPHICS, &[batch(1, vec![], vec![])], 0);
        let report = v.queue_submit("vkQueueSubmit", COMPUTE, &[batch(2, vec![], vec![])], 0);
        assert_eq!(report.ids(), [cmd_copy::src_07532.id()]);

        // After the host saw the graphics queue idle, it is ordered.
        v.queue_wait_idle(GRAPHICS);
        let report = v.queue_submit("vkQueueSubmit", COMPUTE, &[batch(2, vec![], vec![])], 0);
        assert!(report.is_empty(), "{report}");
    }

    #[test]
    fn a_wait_for_a_value_no_one_signals_yet_is_not_decided() {
        let mut v = recorded();
        let waits = vec![timeline(0x5e, 7)];
        undecided(&v.queue_submit("vkQueueSubmit", COMPUTE, &[batch(2, waits, vec![])], 0));
    }

    /// `report` decided the copy's rule (07532) and found nothing.
    fn decided_clean(report: &Report) {
        assert!(report.is_empty(), "{report}");
        assert!(report.checked.contains(cmd_copy::src_07532), "{report}");
    }

    /// `report` left the copy's rule undecided (its batch is held).
    fn undecided(report: &Report) {
        assert!(report.is_empty(), "{report}");
        assert!(!report.checked.contains(cmd_copy::src_07532), "{report}");
    }

    /// The build on GRAPHICS, unwaited; the copy on COMPUTE, held for
    /// timeline value 1 of semaphore 0x5e.
    fn copy_held_for_a_host_signal() -> Validator {
        let mut v = recorded();
        v.queue_submit("vkQueueSubmit", GRAPHICS, &[batch(1, vec![], vec![])], 0);
        let held = batch(2, vec![timeline(0x5e, 1)], vec![]);
        undecided(&v.queue_submit("vkQueueSubmit", COMPUTE, &[held], 0));
        v
    }

    #[test]
    fn a_held_batch_is_decided_when_the_host_signal_arrives() {
        // The host signals without having seen the build complete: the
        // copy may run before it.
        let mut v = copy_held_for_a_host_signal();
        let report = v.signal_semaphore(0x5e, 1);
        assert_eq!(report.ids(), [cmd_copy::src_07532.id()]);
        assert_eq!(report.findings[0].location, "pSignalInfo");
        assert!(
            report.findings[0]
                .message
                .contains("pSubmits[0].pCommandBuffers[0] of an earlier vkQueueSubmit"),
            "{report}"
        );

        // Having waited for the build first, the host signal orders the copy after it.
        let mut v = copy_held_for_a_host_signal();
        v.queue_wait_idle(GRAPHICS);
        decided_clean(&v.signal_semaphore(0x5e, 1));
    }

    #[test]
    fn a_later_submission_that_signals_the_value_decides_the_held_batch() {
        let mut v = recorded();
        let held = batch(2, vec![timeline(0x5e, 3)], vec![]);
        v.queue_submit("vkQueueSubmit", COMPUTE, &[held], 0);
        // Signal 5 reaches the wait for 3, and the build is before it.
        let signal = batch(1, vec![], vec![timeline(0x5e, 5)]);
        decided_clean(&v.queue_submit("vkQueueSubmit", GRAPHICS, &[signal], 0));
    }

    #[test]
    fn a_semaphore_reusing_a_destroyed_ones_handle_starts_unsignalled() {
        let mut v = recorded();
        let signal = batch(1, vec![], vec![timeline(0x5e, 5)]);
        v.queue_submit("vkQueueSubmit", GRAPHICS, &[signal], 0);
        v.destroy_semaphore(0x5e);
        assert!(!v.state.execution.timeline_signals.contains_key(&0x5e));
        // A new semaphore with the same handle: the old signal 5 does not
        // reach its wait for 3, so the copy waits for a signal of its own.
        let waited = batch(2, vec![timeline(0x5e, 3)], vec![]);
        undecided(&v.queue_submit("vkQueueSubmit", COMPUTE, &[waited], 0));
        // The host signals it without having seen the build complete.
        let report = v.signal_semaphore(0x5e, 3);
        assert_eq!(report.ids(), [cmd_copy::src_07532.id()]);

        // Without the destroy, the same wait is reached by signal 5.
        let mut v = recorded();
        let signal = batch(1, vec![], vec![timeline(0x5e, 5)]);
        v.queue_submit("vkQueueSubmit", GRAPHICS, &[signal], 0);
        let waited = batch(2, vec![timeline(0x5e, 3)], vec![]);
        decided_clean(&v.queue_submit("vkQueueSubmit", COMPUTE, &[waited], 0));
    }

    #[test]
    fn batches_behind_a_held_one_on_its_queue_wait_with_it() {
        let mut v = recorded();
        let held = batch(0x77, vec![timeline(0x5e, 1)], vec![]);
        v.queue_submit("vkQueueSubmit", COMPUTE, &[held], 0);
        // Submitted behind it: held too, so not decided yet.
        undecided(&v.queue_submit("vkQueueSubmit", COMPUTE, &[batch(2, vec![], vec![])], 0));
        // Both run at the signal; the copy, never ordered after the build
        // (which is not even submitted), is reported then.
        let report = v.signal_semaphore(0x5e, 1);
        assert_eq!(report.ids(), [cmd_copy::src_07532.id()]);
    }

    #[test]
    fn a_binary_wait_on_a_held_batch_signal_is_held_too() {
        let mut v = recorded();
        let binary = SemaphoreOp {
            semaphore: 0xb1,
            value: 0,
            timeline: false,
        };
        // The build waits for a host signal and then signals the binary semaphore.
        let build = batch(1, vec![timeline(0x5e, 1)], vec![binary]);
        v.queue_submit("vkQueueSubmit", GRAPHICS, &[build], 0);
        let copy = batch(2, vec![binary], vec![]);
        undecided(&v.queue_submit("vkQueueSubmit", COMPUTE, &[copy], 0));
        // The host signal runs the build, whose signal runs the copy after it.
        decided_clean(&v.signal_semaphore(0x5e, 1));
    }

    #[test]
    fn a_host_wait_is_met_by_the_first_signal_that_reaches_its_value() {
        // Signals 1 (an empty batch) and 5 (the build's batch) on one queue.
        let mut v = recorded();
        let empty = SubmitBatch {
            signals: vec![timeline(0x5e, 1)],
            ..SubmitBatch::default()
        };
        let build = batch(1, vec![], vec![timeline(0x5e, 5)]);
        v.queue_submit("vkQueueSubmit", GRAPHICS, &[empty, build], 0);
        assert!(v.state.execution.in_flight_use(OMM).is_some());

        // Reading the counter at 3 shows only signal 1 executed.
        let mut read = v.clone();
        read.semaphore_counter_value(0x5e, 3);
        assert!(read.state.execution.in_flight_use(OMM).is_some());
        assert_eq!(read.state.execution.constructed_for_host(OMM), Some(false));

        // A wait for 3 returned: only signal 5 can have reached it.
        v.semaphore_reached(0x5e, 3);
        assert!(v.state.execution.in_flight_use(OMM).is_none());
        assert_eq!(v.state.execution.constructed_for_host(OMM), Some(true));
    }

    #[test]
    fn a_held_batch_the_host_saw_complete_runs_undecided() {
        let mut v = recorded();
        let held = batch(2, vec![timeline(0x5e, 1)], vec![]);
        v.queue_submit("vkQueueSubmit", COMPUTE, &[held], 0xf0);
        assert!(
            v.state.execution.in_flight_use(OMM).is_some(),
            "submitted, so in flight"
        );
        // Its fence signalled: a signal the checker never saw let it run.
        v.fences_signalled(&[0xf0]);
        assert!(v.state.execution.held.is_empty());
        assert!(v.state.execution.in_flight_use(OMM).is_none());
        let report = v.signal_semaphore(0x5e, 1);
        assert!(report.is_empty() && report.checked.is_empty(), "{report}");
    }

    #[test]
    fn held_batches_stay_bounded() {
        let mut v = recorded();
        for value in 1..=(crate::state::execution::HELD_AT_MOST as u64 + 3) {
            let held = batch(2, vec![timeline(0x5e, value)], vec![]);
            v.queue_submit("vkQueueSubmit", COMPUTE, &[held], 0);
        }
        let held: usize = v.state.execution.held.values().map(|h| h.len()).sum();
        assert_eq!(held, crate::state::execution::HELD_AT_MOST);
    }

    const POOL: Handle = 0x99;

    /// A validator with a query pool of 4 queries created, command buffer
    /// 3 resetting them all and command buffer 4 writing query 0.
    fn with_pool() -> Validator {
        let mut v = Validator::new(Device::default());
        v.state.query_pools.insert(
            POOL,
            QueryPool {
                query_type: 1_000_396_001,
                query_count: 4,
            },
        );
        v.cmd_reset_query_pool(&cb(3), POOL, 0, 4);
        let write = ExecEvent::WriteQueries {
            pool: POOL,
            first: 0,
            count: 1,
        };
        v.record_execution(&cb(4), "vkCmdWriteMicromapsPropertiesEXT", [write]);
        v
    }

    #[test]
    fn a_query_is_uninitialized_from_creation_until_a_reset() {
        let submit = |v: &mut Validator, command_buffer| {
            v.queue_submit(
                "vkQueueSubmit",
                GRAPHICS,
                &[batch(command_buffer, vec![], vec![])],
                0,
            )
        };
        // Never reset: the write is reported.
        let mut v = with_pool();
        let report = submit(&mut v, 4);
        assert_eq!(report.ids(), [cmd_write::None_12417.id()]);
        assert!(
            report.findings[0].message.contains("uninitialized"),
            "{report}"
        );

        // Reset by a command buffer submitted before, or on the host: silent.
        let mut v = with_pool();
        assert!(submit(&mut v, 3).is_empty());
        let report = submit(&mut v, 4);
        assert!(
            report.is_empty() && report.checked.contains(cmd_write::None_12417),
            "{report}"
        );
        let mut v = with_pool();
        v.reset_query_pool(POOL, 0, 1);
        assert!(submit(&mut v, 4).is_empty());

        // A reset of other queries, or one submitted after the write, is too late.
        let mut v = with_pool();
        v.reset_query_pool(POOL, 1, 3);
        assert_eq!(submit(&mut v, 4).ids(), [cmd_write::None_12417.id()]);
        let mut v = with_pool();
        assert_eq!(submit(&mut v, 4).ids(), [cmd_write::None_12417.id()]);
        assert!(submit(&mut v, 3).is_empty());

        // A pool the checker did not see created is not decided for it.
        let mut v = with_pool();
        v.state.query_pools.clear();
        assert!(submit(&mut v, 4).is_empty());
    }
}
