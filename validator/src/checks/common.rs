//! Checks many commands share: command-buffer state, device addresses,
//! buffer usage, alignment, and a cap on repeated content findings.

use std::collections::BTreeMap;
use std::fmt::Display;

use ommcheck_vuids::Vuid;

use crate::model::command::queue;
use crate::model::CommandBuffer;
use crate::report::{RuleId, Severity};
use crate::state::Handle;
use crate::validator::Ctx;

/// The implicit command-buffer VUIDs of one `vkCmd*` command.
pub(crate) struct CommandBufferVuids {
    pub parameter: Vuid,
    pub recording: Vuid,
    pub cmdpool: Vuid,
    /// Present for commands that must be outside a render pass.
    pub renderpass: Option<Vuid>,
    pub videocoding: Option<Vuid>,
    pub suspended: Option<Vuid>,
}

/// Checks the command buffer of a command that needs a compute-capable queue.
pub(crate) fn command_buffer(ctx: &mut Ctx<'_>, cb: &CommandBuffer, vuids: &CommandBufferVuids) {
    let handle = cb.handle;
    ctx.require(
        handle != 0,
        vuids.parameter,
        || "commandBuffer".into(),
        || "commandBuffer is VK_NULL_HANDLE".into(),
    );
    if !cb.recording {
        ctx.error(
            vuids.recording,
            "commandBuffer",
            "the command buffer is not in the recording state",
        )
        .objects
        .push(crate::report::ObjectRef {
            ty: "VkCommandBuffer",
            handle,
        });
    }
    ctx.require(
        cb.queue_flags & queue::COMPUTE != 0,
        vuids.cmdpool,
        || "commandBuffer".into(),
        || {
            format!(
                "the command pool's queue family supports {:#x}, not VK_QUEUE_COMPUTE_BIT",
                cb.queue_flags
            )
        },
    );
    if let Some(vuid) = vuids.renderpass {
        ctx.require(
            !cb.in_render_pass,
            vuid,
            || "commandBuffer".into(),
            || "called inside a render pass instance".into(),
        );
    }
    if let Some(vuid) = vuids.videocoding {
        ctx.require(
            !cb.in_video_coding,
            vuid,
            || "commandBuffer".into(),
            || "called inside a video coding scope".into(),
        );
    }
    if let Some(vuid) = vuids.suspended {
        ctx.require(
            !cb.suspended,
            vuid,
            || "commandBuffer".into(),
            || "called inside a suspended render pass instance".into(),
        );
    }
}

/// `device` must be the device being checked (0 in `Device::handle` means
/// any non-NULL handle is taken to be it).
pub(crate) fn device_handle(ctx: &mut Ctx<'_>, device: Handle, vuid: Vuid) {
    let known = ctx.device.handle;
    if device == 0 {
        ctx.error(vuid, "device", "device is VK_NULL_HANDLE");
    } else if known != 0 && device != known {
        ctx.error(
            vuid,
            "device",
            format!("{device:#x} is not the VkDevice {known:#x} being checked"),
        );
    }
}

/// Whether `handle` belongs to another `VkDevice`; reports `vuid` (a
/// `-parent` or `-commonparent` rule) at `location` when it does.
pub(crate) fn other_device(ctx: &mut Ctx<'_>, handle: Handle, vuid: Vuid, location: &str) -> bool {
    let foreign = handle != 0
        && ctx
            .state
            .is_some_and(|state| state.other_device_objects.contains(&handle));
    if foreign {
        ctx.error(
            vuid,
            location,
            format!("{handle:#x} belongs to another VkDevice"),
        );
    }
    foreign
}

/// The VUIDs of a host command's `deferredOperation` parameter.
pub(crate) struct DeferredOperationVuids {
    pub parameter: Vuid,
    pub parent: Vuid,
    /// "Any previous deferred operation ... must be complete", where the command has it.
    pub complete: Option<Vuid>,
}

/// Checks `deferredOperation`: NULL or a deferred operation of this device,
/// not one still running a previous command.
pub(crate) fn deferred_operation(
    ctx: &mut Ctx<'_>,
    handle: Handle,
    vuids: &DeferredOperationVuids,
) {
    if handle == 0 || other_device(ctx, handle, vuids.parent, "deferredOperation") {
        return;
    }
    let Some(state) = ctx.state else {
        return;
    };
    if !state.deferred_operations.contains(&handle) {
        ctx.error(
            vuids.parameter,
            "deferredOperation",
            format!("{handle:#x} is not a VkDeferredOperationKHR created on this device"),
        );
    } else if let Some(vuid) = vuids.complete {
        if state.pending_deferred_operations.contains(&handle) {
            ctx.error(vuid, "deferredOperation", format!("{handle:#x} still runs an earlier deferred command (no vkDeferredOperationJoinKHR or vkGetDeferredOperationResultKHR has reported it complete)"));
        }
    }
}

/// A location `"{base}{member}"`, written out only when a finding needs it
/// (most calls have none, and building every location string was most of
/// a valid call's cost).
#[derive(Clone, Copy)]
pub(crate) struct At<'a>(pub &'a str, pub &'a str);

impl Display for At<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)?;
        f.write_str(self.1)
    }
}

/// A device address must be a valid `VkDeviceAddress`: non-zero, and inside
/// a buffer when the checker knows buffer addresses.
pub(crate) fn valid_device_address(
    ctx: &mut Ctx<'_>,
    address: u64,
    vuid: Vuid,
    location: impl Display,
) {
    if address == 0 {
        ctx.error(vuid, location.to_string(), "the address is 0");
    } else if ctx
        .state
        .is_some_and(|state| state.knows_addresses() && state.buffers_at(address).next().is_none())
    {
        ctx.error(
            vuid,
            location.to_string(),
            format!("{address:#x} is inside no buffer's device-address range"),
        );
    }
}

/// The buffer(s) a device address was queried from must have `usage`.
/// Unknown addresses are left to the address checks.
pub(crate) fn device_address_usage(
    ctx: &mut Ctx<'_>,
    address: u64,
    usage: u64,
    usage_name: &str,
    vuid: Vuid,
    location: impl Display,
) {
    let Some(state) = ctx.state else {
        return;
    };
    // Walked, not collected: a valid call should not allocate.
    let mut buffers = state.buffers_at(address);
    let Some((handle, first)) = buffers.next() else {
        return;
    };
    if first.usage & usage == 0 && !buffers.any(|(_, b)| b.usage & usage != 0) {
        ctx.error(vuid, location.to_string(), format!("{address:#x} lies in VkBuffer {handle:#x}, which was not created with {usage_name}"))
            .objects
            .push(crate::report::ObjectRef { ty: "VkBuffer", handle });
    }
}

/// `value` must be a multiple of `alignment` (a power of two or any non-zero).
pub(crate) fn aligned(
    ctx: &mut Ctx<'_>,
    value: u64,
    alignment: u64,
    vuid: Vuid,
    location: impl Display,
) {
    if alignment != 0 && value % alignment != 0 {
        ctx.error(
            vuid,
            location.to_string(),
            format!("{value:#x} is not a multiple of {alignment}"),
        );
    }
}

/// Caps how often one rule is reported for the elements of one array, so a
/// million bad triangles give a few findings and a total, not a million.
pub(crate) struct Tally {
    counts: BTreeMap<&'static str, (RuleId, u64, String, Severity)>,
}

impl Tally {
    /// Findings reported in full per rule before the rest are only counted.
    pub const SHOWN: u64 = 8;

    pub fn new() -> Self {
        Self {
            counts: BTreeMap::new(),
        }
    }

    /// Reports the first [`Self::SHOWN`] failures of `rule` in full, as errors.
    pub fn error(
        &mut self,
        ctx: &mut Ctx<'_>,
        rule: impl Into<RuleId>,
        location: String,
        message: impl FnOnce() -> String,
        array: &str,
    ) {
        self.report(ctx, rule, Severity::Error, location, message, array);
    }

    /// Reports the first [`Self::SHOWN`] findings of `rule` in full.
    pub fn report(
        &mut self,
        ctx: &mut Ctx<'_>,
        rule: impl Into<RuleId>,
        severity: Severity,
        location: String,
        message: impl FnOnce() -> String,
        array: &str,
    ) {
        let rule = rule.into();
        let entry =
            self.counts
                .entry(rule.as_str())
                .or_insert((rule, 0, array.to_string(), severity));
        entry.1 += 1;
        if entry.1 <= Self::SHOWN {
            ctx.report(rule, severity, location, message());
        }
    }

    /// Adds one finding per rule that failed more often than it was shown.
    pub fn finish(self, ctx: &mut Ctx<'_>) {
        for (_, (rule, count, array, severity)) in self.counts {
            if count > Self::SHOWN {
                let message = format!(
                    "{} more elements of {array} fail this rule ({count} in all)",
                    count - Self::SHOWN
                );
                ctx.report(rule, severity, array, message);
            }
        }
    }
}
