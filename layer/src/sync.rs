//! Synchronization commands: barriers, events, timestamps, markers and
//! `vkQueueSubmit2`, each checked for the micromap stage and access rules,
//! then passed on unless a messenger asks to skip it. The KHR aliases have
//! their own next-layer functions and share the core check.

#![allow(unsafe_code)]

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::model::CommandBuffer;
use ommcheck::raw::pipeline::{self as raw, MemoryMarkerInfoAMD};
use ommcheck::{Report, Validator};

use crate::commands;
use crate::dispatch::next_fns::DeviceFns;
use crate::intercept::{aliased_intercepts, check, device_and, guarded};

/// Runs `body` as the check of a command recorded in `command_buffer`,
/// then calls the next layer's function that `pick` selects with `call`
/// unless a messenger asks to skip it.
fn checked_command<F: Copy>(
    function: &'static str,
    command_buffer: vk::CommandBuffer,
    pick: impl FnOnce(&DeviceFns) -> Option<F>,
    body: impl FnOnce(&mut Validator, &CommandBuffer) -> Report,
    call: impl FnOnce(F),
) {
    guarded(function, (), || {
        let Some((data, next)) = device_and(command_buffer, pick) else {
            return;
        };
        let object = (vk::ObjectType::COMMAND_BUFFER, command_buffer.as_raw());
        let skip = check(&data, function, object, |state| {
            body(&mut state.validator, &commands::model(command_buffer))
        });
        if !skip {
            call(next);
        }
    })
}

/// A dependency info read at `pDependencyInfo`, with the reader's findings.
///
/// # Safety
/// A non-NULL `info` must be valid as the API requires.
unsafe fn read_dependency(
    info: *const vk::DependencyInfo<'_>,
    function: &'static str,
    findings: &mut Vec<ommcheck::Finding>,
) -> ommcheck::model::pipeline::DependencyInfo {
    // SAFETY: forwarded from the caller.
    unsafe { info.as_ref() }
        // SAFETY: forwarded from the caller.
        .map(|info| unsafe { raw::dependency_info(info, function, "pDependencyInfo", findings) })
        .unwrap_or_default()
}

/// Prepends what a reader found to a check's report.
fn with_findings(mut report: Report, findings: Vec<ommcheck::Finding>) -> Report {
    report.findings.splice(0..0, findings);
    report
}

macro_rules! barrier_commands {
    ($($ours:ident, $field:ident, $name:literal;)*) => {$(
        /// `vkCmdPipelineBarrier2` or its KHR alias.
        pub unsafe extern "system" fn $ours(
            command_buffer: vk::CommandBuffer,
            info: *const vk::DependencyInfo<'_>,
        ) {
            checked_command($name, command_buffer, |f| f.pipe.$field, |v, cb| {
                let mut findings = Vec::new();
                // SAFETY: the application's dependency info, valid as the API requires.
                let model = unsafe { read_dependency(info, $name, &mut findings) };
                with_findings(v.cmd_pipeline_barrier2(cb, &model), findings)
            }, |next| {
                // SAFETY: the next layer's function, with the application's arguments.
                unsafe { next(command_buffer, info) }
            })
        }
    )*};
}

barrier_commands! {
    cmd_pipeline_barrier2, cmd_pipeline_barrier2, "vkCmdPipelineBarrier2";
    cmd_pipeline_barrier2_khr, cmd_pipeline_barrier2_khr, "vkCmdPipelineBarrier2KHR";
}

macro_rules! set_event_commands {
    ($($ours:ident, $field:ident, $name:literal;)*) => {$(
        /// `vkCmdSetEvent2` or its KHR alias.
        pub unsafe extern "system" fn $ours(
            command_buffer: vk::CommandBuffer,
            event: vk::Event,
            info: *const vk::DependencyInfo<'_>,
        ) {
            checked_command($name, command_buffer, |f| f.pipe.$field, |v, cb| {
                let mut findings = Vec::new();
                // SAFETY: the application's dependency info, valid as the API requires.
                let model = unsafe { read_dependency(info, $name, &mut findings) };
                with_findings(v.cmd_set_event2(cb, event.as_raw(), &model), findings)
            }, |next| {
                // SAFETY: the next layer's function, with the application's arguments.
                unsafe { next(command_buffer, event, info) }
            })
        }
    )*};
}

set_event_commands! {
    cmd_set_event2, cmd_set_event2, "vkCmdSetEvent2";
    cmd_set_event2_khr, cmd_set_event2_khr, "vkCmdSetEvent2KHR";
}

macro_rules! wait_events_commands {
    ($($ours:ident, $field:ident, $name:literal;)*) => {$(
        /// `vkCmdWaitEvents2` or its KHR alias.
        pub unsafe extern "system" fn $ours(
            command_buffer: vk::CommandBuffer,
            count: u32,
            events: *const vk::Event,
            infos: *const vk::DependencyInfo<'_>,
        ) {
            checked_command($name, command_buffer, |f| f.pipe.$field, |v, cb| {
                let mut findings = Vec::new();
                // SAFETY: both arrays hold `count` elements, valid as the API requires.
                let (handles, model) = unsafe {
                    (
                        raw::handles(events, count, $name, "pEvents", &mut findings),
                        raw::structs(infos, count, "pDependencyInfos", raw::dependency_info, $name, &mut findings),
                    )
                };
                with_findings(v.cmd_wait_events2(cb, &handles, &model), findings)
            }, |next| {
                // SAFETY: the next layer's function, with the application's arguments.
                unsafe { next(command_buffer, count, events, infos) }
            })
        }
    )*};
}

wait_events_commands! {
    cmd_wait_events2, cmd_wait_events2, "vkCmdWaitEvents2";
    cmd_wait_events2_khr, cmd_wait_events2_khr, "vkCmdWaitEvents2KHR";
}

macro_rules! reset_event_commands {
    ($($ours:ident, $field:ident, $name:literal;)*) => {$(
        /// `vkCmdResetEvent2` or its KHR alias.
        pub unsafe extern "system" fn $ours(
            command_buffer: vk::CommandBuffer,
            event: vk::Event,
            stage_mask: vk::PipelineStageFlags2,
        ) {
            checked_command($name, command_buffer, |f| f.pipe.$field, |v, cb| {
                v.cmd_reset_event2(cb, event.as_raw(), stage_mask.as_raw())
            }, |next| {
                // SAFETY: the next layer's function, with the application's arguments.
                unsafe { next(command_buffer, event, stage_mask) }
            })
        }
    )*};
}

reset_event_commands! {
    cmd_reset_event2, cmd_reset_event2, "vkCmdResetEvent2";
    cmd_reset_event2_khr, cmd_reset_event2_khr, "vkCmdResetEvent2KHR";
}

macro_rules! timestamp_commands {
    ($($ours:ident, $field:ident, $name:literal;)*) => {$(
        /// `vkCmdWriteTimestamp2` or its KHR alias.
        pub unsafe extern "system" fn $ours(
            command_buffer: vk::CommandBuffer,
            stage: vk::PipelineStageFlags2,
            pool: vk::QueryPool,
            query: u32,
        ) {
            checked_command($name, command_buffer, |f| f.pipe.$field, |v, cb| {
                v.cmd_write_timestamp2(cb, stage.as_raw(), pool.as_raw(), query)
            }, |next| {
                // SAFETY: the next layer's function, with the application's arguments.
                unsafe { next(command_buffer, stage, pool, query) }
            })
        }
    )*};
}

timestamp_commands! {
    cmd_write_timestamp2, cmd_write_timestamp2, "vkCmdWriteTimestamp2";
    cmd_write_timestamp2_khr, cmd_write_timestamp2_khr, "vkCmdWriteTimestamp2KHR";
}

/// `vkCmdWriteBufferMarker2AMD`.
pub unsafe extern "system" fn cmd_write_buffer_marker2_amd(
    command_buffer: vk::CommandBuffer,
    stage: vk::PipelineStageFlags2,
    buffer: vk::Buffer,
    offset: vk::DeviceSize,
    marker: u32,
) {
    let name = "vkCmdWriteBufferMarker2AMD";
    checked_command(
        name,
        command_buffer,
        |f| f.pipe.cmd_write_buffer_marker2_amd,
        |v, cb| v.cmd_write_buffer_marker2_amd(cb, stage.as_raw(), buffer.as_raw(), offset, marker),
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, stage, buffer, offset, marker) },
    )
}

/// `vkCmdWriteMarkerToMemoryAMD`.
pub unsafe extern "system" fn cmd_write_marker_to_memory_amd(
    command_buffer: vk::CommandBuffer,
    info: *const MemoryMarkerInfoAMD,
) {
    let name = "vkCmdWriteMarkerToMemoryAMD";
    checked_command(
        name,
        command_buffer,
        |f| f.pipe.cmd_write_marker_to_memory_amd,
        |v, cb| {
            // SAFETY: the application's marker info, valid as the API requires.
            let model = unsafe { info.as_ref() }.map(raw::memory_marker_info);
            v.cmd_write_marker_to_memory_amd(cb, &model.unwrap_or_default())
        },
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, info) },
    )
}

/// The semaphores' stage masks of `vkQueueSubmit2` or its KHR alias
/// (`function`); returns whether a messenger asked for the submission to be
/// skipped. `crate::submit` calls it before checking the builds the
/// submission runs, so one intercept serves both.
///
/// # Safety
/// `submits` must be valid for `count`, as the API requires.
pub unsafe fn check_submit2(
    function: &'static str,
    queue: vk::Queue,
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
) -> bool {
    // A queue shares its device's dispatch key.
    let Some(data) = crate::dispatch::DEVICES.get(queue) else {
        return false;
    };
    let object = (vk::ObjectType::QUEUE, queue.as_raw());
    check(&data, function, object, |state| {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe { raw::submit_infos(submits, count, function, &mut findings) };
        with_findings(state.validator.queue_submit2(&model), findings)
    })
}

/// `vkCmdResetQueryPool`: the reset runs when a submission runs the
/// command buffer (the core's execution order, 12417).
pub unsafe extern "system" fn cmd_reset_query_pool(
    command_buffer: vk::CommandBuffer,
    pool: vk::QueryPool,
    first: u32,
    count: u32,
) {
    checked_command(
        "vkCmdResetQueryPool",
        command_buffer,
        |f| f.pipe.cmd_reset_query_pool,
        |v, cb| v.cmd_reset_query_pool(cb, pool.as_raw(), first, count),
        // SAFETY: the next layer's function, with the application's arguments.
        |next| unsafe { next(command_buffer, pool, first, count) },
    )
}

/// `vkResetQueryPool` (or its EXT alias, `function`): the queries are
/// unavailable once it returns.
///
/// # Safety
/// The arguments are the application's, forwarded as the command received them.
unsafe fn reset_query_pool_with(
    function: &'static str,
    pick: fn(&DeviceFns) -> Option<vk::PFN_vkResetQueryPool>,
    device: vk::Device,
    pool: vk::QueryPool,
    first: u32,
    count: u32,
) {
    guarded(function, (), || {
        let Some((data, next)) = device_and(device, pick) else {
            return;
        };
        // SAFETY: the next layer's function, with the application's arguments.
        unsafe { next(device, pool, first, count) };
        crate::intercept::track(&data, function, |state| {
            state
                .validator
                .reset_query_pool(pool.as_raw(), first, count);
        });
    })
}

aliased_intercepts! {
    reset_query_pool_with(device: vk::Device, pool: vk::QueryPool, first: u32, count: u32) -> () {
        reset_query_pool = "vkResetQueryPool", pipe.reset_query_pool;
        reset_query_pool_ext = "vkResetQueryPoolEXT", pipe.reset_query_pool_ext;
    }
}
