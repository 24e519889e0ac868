//! The helpers every intercept module uses: guarding a call against
//! panics, finding a device's data and the next layer's function, running
//! a check and delivering its findings, recording what a call did, and
//! handing a command to the loader. They sit above [`crate::dispatch`]
//! and below the intercept modules and the router ([`crate::router`]) that
//! dispatches to them, so no module imports its own caller.

#![allow(unsafe_code)]

use std::any::Any;
use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::report::not_checked::Cause;
use ommcheck::{Report, Severity};

use crate::dispatch::next_fns::DeviceFns;
use crate::dispatch::{DeviceData, DeviceState, DEVICES, INSTANCES};
use crate::report::{CauseCounts, Message, Reporter, INTERNAL_ERROR};

/// Runs an exported function's `body`; a panic becomes one error message to
/// every messenger and `on_panic` is returned.
pub(crate) fn guarded<R>(function: &'static str, on_panic: R, body: impl FnOnce() -> R) -> R {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(result) => result,
        Err(payload) => {
            let message = panic_message(function, payload.as_ref(), "the call failed");
            // Which instance the call belonged to is lost with the panic.
            let instances = INSTANCES.all();
            if instances.is_empty() {
                eprintln!("{}", message.text);
            }
            for instance in instances {
                instance
                    .reporter
                    .deliver(std::slice::from_ref(&message), false);
            }
            on_panic
        }
    }
}

/// The message for a caught panic.
pub(crate) fn panic_message(function: &str, payload: &(dyn Any + Send), outcome: &str) -> Message {
    let reason = payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("no reason given");
    Message::about_layer(
        INTERNAL_ERROR,
        Severity::Error,
        function,
        &format!(
            "ommcheck panicked ({reason}); {outcome}. Please report this as a bug in ommcheck."
        ),
    )
}

thread_local! {
    static PANIC_IN_NEXT_CHECK: Cell<bool> = const { Cell::new(false) };
}

/// Makes the next check this thread runs panic, so tests can see that the
/// panic becomes one error message and never crosses the FFI boundary
/// (the layer's tests reach it as `testing::panic_in_next_check`).
#[doc(hidden)]
pub fn panic_in_next_check() {
    PANIC_IN_NEXT_CHECK.set(true);
}

/// Panics if a test asked for it (see [`panic_in_next_check`]).
pub(crate) fn panic_if_asked() {
    if PANIC_IN_NEXT_CHECK.replace(false) {
        panic!("a panic injected by ommcheck's test hook");
    }
}

/// A command and its aliases (its KHR or EXT spellings): intercepts
/// that share one body, `$with(name, pick, args)`, each with its own name
/// and the next layer's function at its path in [`DeviceFns`].
macro_rules! aliased_intercepts {
    (@alias $with:ident $params:tt $ret:ty;) => {};
    (@alias $with:ident ($($arg:ident: $ty:ty),*) $ret:ty;
        $ours:ident = $name:literal, $($field:ident).+; $($rest:tt)*
    ) => {
        pub unsafe extern "system" fn $ours($($arg: $ty),*) -> $ret {
            // SAFETY: forwarded from the application.
            unsafe { $with($name, |f| f.$($field).+, $($arg),*) }
        }
        $crate::intercept::aliased_intercepts!(@alias $with ($($arg: $ty),*) $ret; $($rest)*);
    };
    ($($with:ident $params:tt -> $ret:ty { $($aliases:tt)* })*) => {$(
        $crate::intercept::aliased_intercepts!(@alias $with $params $ret; $($aliases)*);
    )*};
}
pub(crate) use aliased_intercepts;

/// A command as the loader's `PFN_vkVoidFunction`.
pub fn as_void<F: Copy>(function: F) -> vk::PFN_vkVoidFunction {
    assert_eq!(size_of::<F>(), size_of::<unsafe extern "system" fn()>());
    // SAFETY: `F` is a function pointer type (same size, checked above);
    // the loader casts it back to the command's real type before calling.
    Some(unsafe { std::mem::transmute_copy::<F, unsafe extern "system" fn()>(&function) })
}

/// The device data for a dispatchable `handle` of a device (the device, or
/// a command buffer) and the next layer's function `pick` selects; None
/// when the device is unknown or the next layer lacks the function.
pub(crate) fn device_and<F: Copy>(
    handle: impl vk::Handle,
    pick: impl FnOnce(&DeviceFns) -> Option<F>,
) -> Option<(Arc<DeviceData>, F)> {
    let data = DEVICES.get(handle)?;
    let function = pick(&data.fns)?;
    Some((data, function))
}

/// Runs a check against the device's validator and delivers its findings;
/// a panic inside becomes one error message. Returns whether a messenger
/// asked for the call to be skipped.
pub(crate) fn check(
    data: &DeviceData,
    function: &'static str,
    call_object: (vk::ObjectType, u64),
    body: impl FnOnce(&mut DeviceState) -> Report,
) -> bool {
    let outcome = {
        let mut state = data.state();
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            panic_if_asked();
            body(&mut state)
        }));
        outcome.map(|report| once_per_cause(report, &mut state.core_not_checked))
    };
    deliver_checked(&data.instance.reporter, function, call_object, outcome)
}

/// The core's not-checked information as the layer says it, so that a
/// clean report at the default level means checked: the first finding of
/// each cause on a device is a warning that says it comes once, later ones
/// are counted for [`core_not_checked_totals`]. Two causes stay
/// information: unread device contents (`OMMCHECK-not-checked-contents`),
/// which the layer's own `OMMCHECK-layer-contents-not-checked` warning
/// already says per device with its reason, and a build not seen, which in
/// the layer is a build that never ran while it was loaded, and so comes
/// with the error that the micromap was not built.
const SAID_AS_WARNINGS: [Cause; 2] = [Cause::HostMemory, Cause::UnknownAddress];

pub(crate) fn once_per_cause(mut report: Report, said: &mut CauseCounts) -> Report {
    // Each cause counts once per call; the call that first has it says
    // all of its findings of it (they name different places).
    let mut first = Vec::new();
    for cause in Cause::ALL {
        let in_call = report
            .findings
            .iter()
            .any(|f| Cause::of(f.rule) == Some(cause));
        if cause != Cause::Contents && in_call && said.first_report_of(cause.rule().id, 1) {
            first.push(cause);
        }
    }
    report.findings.retain_mut(|finding| {
        let Some(cause) = Cause::of(finding.rule).filter(|c| SAID_AS_WARNINGS.contains(c)) else {
            return true;
        };
        if !first.contains(&cause) {
            return false;
        }
        finding.severity = Severity::Warning;
        finding.message.push_str(&format!(
            " This is reported once per device and cause (`{}`); vkDestroyDevice says how many calls it affected in all.",
            cause.rule().id
        ));
        true
    });
    report
}

/// The warnings of a device's destruction for the core's not-checked
/// causes that came up more than once (`counts`, from
/// [`once_per_cause`]): how many calls each kept from being checked in
/// full.
pub(crate) fn core_not_checked_totals(device: u64, counts: &[(&'static str, u64)]) -> Vec<Message> {
    counts
        .iter()
        .filter(|(_, count)| *count > 1)
        .map(|(id, count)| {
            let text = format!(
                "{count} calls on VkDevice {device:#x} had rules not checked for the cause `{id}`; the first was reported with the rules, the reason and what lets them run."
            );
            let mut message = Message::about_layer(id, Severity::Warning, "vkDestroyDevice", &text);
            message.objects.push((vk::ObjectType::DEVICE, device));
            message
        })
        .collect()
}

/// Delivers what a check (run under `catch_unwind`) found about
/// `call_object`, or one error message for its panic. Returns whether a
/// messenger asked for the call to be skipped.
pub(crate) fn deliver_checked(
    reporter: &Reporter,
    function: &'static str,
    call_object: (vk::ObjectType, u64),
    outcome: std::thread::Result<Report>,
) -> bool {
    let messages: Vec<Message> = match outcome {
        // Most calls are valid: nothing to convert or deliver.
        Ok(report) if report.findings.is_empty() => return false,
        Ok(report) => report
            .findings
            .iter()
            .map(|finding| Message::from_finding(finding, call_object))
            .collect(),
        Err(payload) => vec![panic_message(
            function,
            payload.as_ref(),
            "the call was passed on unchecked",
        )],
    };
    reporter.deliver(&messages, false)
}

/// Calls a host command given `operation` down; where the driver ran it at
/// once (`VK_OPERATION_NOT_DEFERRED_KHR`), the operation is complete, as a
/// join would have reported, so what it constructed is constructed.
pub(crate) fn deferrable(
    device: vk::Device,
    operation: vk::DeferredOperationKHR,
    call_down: impl FnOnce() -> vk::Result,
) -> vk::Result {
    let result = call_down();
    if result == vk::Result::OPERATION_NOT_DEFERRED_KHR
        && operation != vk::DeferredOperationKHR::null()
    {
        if let Some(data) = DEVICES.get(device) {
            track(&data, "vkDeferredOperationJoinKHR", |state| {
                state
                    .validator
                    .deferred_operation_completed(operation.as_raw());
            });
        }
    }
    result
}

/// Records what a call did in the device's state; a panic inside becomes
/// one error message and the call's result stands.
pub(crate) fn track(
    data: &DeviceData,
    function: &'static str,
    body: impl FnOnce(&mut DeviceState),
) {
    track_with(data, function, body);
}

/// [`track`] with the body's result; None when it panicked.
pub(crate) fn track_with<R>(
    data: &DeviceData,
    function: &'static str,
    body: impl FnOnce(&mut DeviceState) -> R,
) -> Option<R> {
    let outcome = {
        let mut state = data.state();
        catch_unwind(AssertUnwindSafe(|| body(&mut state)))
    };
    match outcome {
        Ok(result) => Some(result),
        Err(payload) => {
            let message = panic_message(
                function,
                payload.as_ref(),
                "what the call created is not tracked",
            );
            data.instance.reporter.deliver(&[message], false);
            None
        }
    }
}

pub(crate) fn device_object(device: vk::Device) -> (vk::ObjectType, u64) {
    (vk::ObjectType::DEVICE, device.as_raw())
}

#[cfg(test)]
mod tests {
    use ommcheck::report::not_checked::Cause;
    use ommcheck::{Finding, Report, Severity};

    use super::{core_not_checked_totals, once_per_cause};
    use crate::report::CauseCounts;

    fn not_checked(cause: Cause) -> Finding {
        Finding::new(
            cause.rule(),
            Severity::Info,
            "vkBuildMicromapsEXT",
            "pInfos[0].data",
            "m",
        )
    }

    #[test]
    fn the_cores_not_checked_causes_warn_once_per_device_and_are_counted() {
        let mut said = CauseCounts::default();
        let report = |findings: Vec<Finding>| Report {
            findings,
            ..Report::default()
        };
        let first = once_per_cause(
            report(vec![
                not_checked(Cause::HostMemory),
                not_checked(Cause::HostMemory),
                not_checked(Cause::Contents),
            ]),
            &mut said,
        );
        let kept: Vec<(&str, Severity)> = first
            .findings
            .iter()
            .map(|f| (f.rule.as_str(), f.severity))
            .collect();
        assert_eq!(
            kept,
            [
                // Both places of the first call are said.
                ("OMMCHECK-not-checked-host-memory", Severity::Warning),
                ("OMMCHECK-not-checked-host-memory", Severity::Warning),
                // The layer's own warning covers unread device contents.
                ("OMMCHECK-not-checked-contents", Severity::Info),
            ]
        );
        let again = once_per_cause(report(vec![not_checked(Cause::HostMemory)]), &mut said);
        assert!(again.findings.is_empty());
        let totals = core_not_checked_totals(0xd, said.counts());
        assert_eq!(totals.len(), 1);
        assert_eq!(totals[0].id, "OMMCHECK-not-checked-host-memory");
        assert!(
            totals[0].text.contains("2 calls on VkDevice 0xd"),
            "{}",
            totals[0].text
        );
        // A cause said once needs no total.
        let mut once = CauseCounts::default();
        once_per_cause(report(vec![not_checked(Cause::UnknownAddress)]), &mut once);
        assert!(core_not_checked_totals(0xd, once.counts()).is_empty());
        // A build not seen stays information (it comes with the error
        // that the micromap was not built).
        let unseen = once_per_cause(report(vec![not_checked(Cause::BuildNotSeen)]), &mut once);
        assert_eq!(unseen.findings[0].severity, Severity::Info);
    }
}
