//! Execution order: the rules that depend on what runs before what on the
//! device and on what the host has seen complete. Recorded commands note
//! what their execution does (`state::execution`); the rules are decided
//! when a submission runs them, in submission order, and at the host
//! commands and `vkDestroyMicromapEXT` that depend on submitted work.
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
use crate::model::{CommandBuffer, SubmitBatch};
use crate::report::{ObjectRef, Report};
use crate::state::execution::{
    first_available, first_outside, join, set_queries, Clock, ExecEvent, Execution, ReadRule,
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

/// Runs the events of `command_buffer` in a batch whose clock is `clock`
/// on `(queue, seq)`; `ordered` is false where a wait could not be placed
/// (its signal is not known), and then nothing is decided.
struct Run<'a> {
    queue: Handle,
    seq: u64,
    clock: &'a Clock,
    ordered: bool,
    at: String,
}

fn run_command_buffer(
    exec: &mut Execution,
    pools: &Pools,
    command_buffer: Handle,
    run: &Run<'_>,
    uses: &mut BTreeSet<Handle>,
    checked: &mut BTreeSet<Vuid>,
    decided: &mut Vec<Decided>,
) {
    // Taken out while it runs (the replay updates the rest of `exec`), put back after.
    let Some(recording) = exec.recordings.remove(&command_buffer) else {
        return;
    };
    let decide = run.ordered && !recording.overflowed;
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
                    checked.insert(rule.vuid());
                }
                if decide && !exec.constructed_before(*object, run.clock) {
                    decided.push(Decided {
                        vuid: rule.vuid(),
                        location: run.at.clone(),
                        message: format!(
                            "{function} recorded in VkCommandBuffer {command_buffer:#x} reads {location} ({} {object:#x}), which no build, copy or deserialization executed before it has constructed",
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
                    checked.insert(cmd_write::None_12417);
                    let problem = uninitialized_query(exec, pools, *pool, start, end)
                        .map(|query| (query, "uninitialized: no vkCmdResetQueryPool executed before it and no vkResetQueryPool has reset it since the pool was created"))
                        .or_else(|| {
                            let available = exec.available_queries.get(pool)?;
                            first_available(available, start, end).map(|query| (query, "available: executed work wrote it, and no vkCmdResetQueryPool or vkResetQueryPool reset it since"))
                        });
                    if let Some((query, state)) = problem {
                        decided.push(Decided {
                            vuid: cmd_write::None_12417,
                            location: run.at.clone(),
                            message: format!(
                                "{function} recorded in VkCommandBuffer {command_buffer:#x} writes query {query} of VkQueryPool {pool:#x}, which is {state}"
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
    exec.recordings.insert(command_buffer, recording);
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
    /// signals when they complete.
    pub fn queue_submit(
        &mut self,
        function: &'static str,
        queue: Handle,
        batches: &[SubmitBatch],
        fence: Handle,
    ) -> Report {
        let mut exec = std::mem::take(&mut self.state.execution);
        let mut decided = Vec::new();
        let mut checked = BTreeSet::new();
        let (mut seq, mut clock) = exec.queues.get(&queue).cloned().unwrap_or_default();
        for (b, batch) in batches.iter().enumerate() {
            seq += 1;
            join(&mut clock, &exec.completed);
            clock.insert(queue, seq);
            let mut ordered = true;
            for wait in &batch.waits {
                let signal = if wait.timeline {
                    exec.timeline_reached(wait.semaphore, wait.value).cloned()
                } else {
                    exec.binary_signals.remove(&wait.semaphore)
                };
                match signal {
                    Some(signal) => join(&mut clock, &signal),
                    // A timeline wait whose signal is not submitted yet
                    // orders this batch after work not seen: undecided.
                    None => ordered &= !wait.timeline,
                }
            }
            let mut uses = BTreeSet::new();
            for (k, command_buffer) in batch.command_buffers.iter().enumerate() {
                let run = Run {
                    queue,
                    seq,
                    clock: &clock,
                    ordered,
                    at: command_buffer_member(function, b, k),
                };
                run_command_buffer(
                    &mut exec,
                    &self.state.query_pools,
                    *command_buffer,
                    &run,
                    &mut uses,
                    &mut checked,
                    &mut decided,
                );
            }
            for signal in &batch.signals {
                if signal.timeline {
                    exec.timeline_signal(signal.semaphore, signal.value, clock.clone());
                } else {
                    exec.binary_signals.insert(signal.semaphore, clock.clone());
                }
            }
            exec.submitted(queue, seq, uses);
        }
        if fence != 0 {
            exec.fences.insert(fence, clock.clone());
        }
        if seq > 0 {
            exec.queues.insert(queue, (seq, clock));
        }
        self.state.execution = exec;
        self.report_decided(function, &checked, decided)
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

    /// `vkWaitForFences` or `vkGetFenceStatus` reported these fences
    /// signalled: the submissions that signal them, and everything before
    /// those, are complete.
    pub fn fences_signalled(&mut self, fences: &[Handle]) {
        let exec = &mut self.state.execution;
        for fence in fences {
            if let Some(clock) = exec.fences.get(fence).cloned() {
                exec.complete(&clock);
            }
        }
    }

    /// `vkResetFences`: the fences no longer stand for a submission.
    pub fn reset_fences(&mut self, fences: &[Handle]) {
        for fence in fences {
            self.state.execution.fences.remove(fence);
        }
    }

    /// `vkQueueWaitIdle(queue)` returned `VK_SUCCESS`.
    pub fn queue_wait_idle(&mut self, queue: Handle) {
        let exec = &mut self.state.execution;
        if let Some((_, clock)) = exec.queues.get(&queue).cloned() {
            exec.complete(&clock);
        }
    }

    /// `vkDeviceWaitIdle` returned `VK_SUCCESS`: every submission is complete.
    pub fn device_wait_idle(&mut self) {
        let exec = &mut self.state.execution;
        let clocks: Vec<Clock> = exec.queues.values().map(|(_, c)| c.clone()).collect();
        for clock in clocks {
            exec.complete(&clock);
        }
    }

    /// The host saw timeline `semaphore` reach `value` (`vkWaitSemaphores`
    /// or `vkGetSemaphoreCounterValue`): the submissions signalling up to
    /// it are complete.
    pub fn semaphore_reached(&mut self, semaphore: Handle, value: u64) {
        let exec = &mut self.state.execution;
        if let Some(clock) = exec
            .timeline_signals
            .get(&semaphore)
            .and_then(|signals| signals.range(..=value).next_back())
            .map(|(_, clock)| clock.clone())
        {
            exec.complete(&clock);
        }
    }

    /// `vkSignalSemaphore`: the host signals timeline `semaphore` to
    /// `value`; work waiting on it is ordered after what the host has seen
    /// complete.
    pub fn signal_semaphore(&mut self, semaphore: Handle, value: u64) {
        let exec = &mut self.state.execution;
        let clock = exec.completed.clone();
        exec.timeline_signal(semaphore, value, clock);
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
    use crate::model::SemaphoreOp;
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
        let report = v.queue_submit("vkQueueSubmit", COMPUTE, &[batch(2, waits, vec![])], 0);
        assert!(report.is_empty(), "{report}");
        assert!(!report.checked.contains(cmd_copy::src_07532));
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
