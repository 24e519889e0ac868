//! The helpers every intercept module uses: finding a device's data and
//! the next layer's function, running a check and delivering its findings,
//! recording what a call did, and handing a command to the loader. They
//! sit below the intercept modules and the router ([`crate::router`]) that
//! dispatches to them, so no module imports its own caller.

#![allow(unsafe_code)]

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::Report;

use crate::dispatch::{DeviceData, DeviceFns, DeviceState, DEVICES};
use crate::report::{Message, Reporter};
use crate::{panic_message, testing};

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
        catch_unwind(AssertUnwindSafe(|| {
            testing::panic_if_asked();
            body(&mut state)
        }))
    };
    deliver_checked(&data.instance.reporter, function, call_object, outcome)
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
