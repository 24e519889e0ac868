//! Feature and property structures: the pNext chains of
//! `vkGetPhysicalDeviceProperties2(KHR)` and `vkCreateDevice` are checked
//! for the micromap structures' places, and a device is checked against the
//! limits its physical device reports, unless `OMMCHECK_PROFILE` chooses
//! limits.
//!
//! A chained structure is known only by its sType, so the `sType-sType`
//! rules of the micromap feature and property structures cannot be decided
//! here: a structure with a wrong sType reads as another structure.

#![allow(unsafe_code)]

use std::ffi::{c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::device::ext;
use ommcheck::model::pipeline::ChainedStruct;
use ommcheck::raw::pipeline as raw;
use ommcheck::vuids::khr;
use ommcheck::{Device, Limits, Report, Validator};

use crate::dispatch::{InstanceData, INSTANCES};
use crate::intercept::{as_void, deliver_checked, guarded, panic_if_asked};
use crate::own_calls::{self, OwnCall};

/// This layer's function for a physical-device command name; like device
/// commands, returned only where the next layer has the command.
pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetPhysicalDeviceProperties2" => {
            as_void(get_physical_device_properties2 as vk::PFN_vkGetPhysicalDeviceProperties2)
        }
        b"vkGetPhysicalDeviceProperties2KHR" => {
            as_void(get_physical_device_properties2_khr as vk::PFN_vkGetPhysicalDeviceProperties2)
        }
        _ => None,
    }
}

/// Runs a chain check (it needs no device) for `instance`'s messengers;
/// returns whether a messenger asked for the call to be skipped. A panic
/// inside becomes one error message and the call goes on.
fn check_chain(
    instance: &InstanceData,
    function: &'static str,
    physical_device: vk::PhysicalDevice,
    body: impl FnOnce(&mut Validator) -> Report,
) -> bool {
    let object = (vk::ObjectType::PHYSICAL_DEVICE, physical_device.as_raw());
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        panic_if_asked();
        body(&mut Validator::new(Device::default()))
    }));
    deliver_checked(&instance.reporter, function, object, outcome)
}

/// `vkGetPhysicalDeviceProperties2` and its KHR alias.
fn get_properties2_with(
    function: &'static str,
    pick: fn(&InstanceData) -> Option<vk::PFN_vkGetPhysicalDeviceProperties2>,
    physical_device: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceProperties2<'_>,
) {
    guarded(function, (), || {
        // A physical device shares its instance's dispatch key.
        let Some(instance) = INSTANCES.get(physical_device) else {
            return;
        };
        let Some(next) = pick(&instance) else {
            return;
        };
        let skip = check_chain(&instance, function, physical_device, |validator| {
            let mut findings = Vec::new();
            // SAFETY: the application's structure and chain, valid as the API requires.
            let chain = unsafe { properties.as_ref() }.map(|p| unsafe {
                raw::feature_chain(p.p_next, function, "pProperties", &mut findings)
            });
            let mut report = validator.get_physical_device_properties2(&chain.unwrap_or_default());
            report.findings.splice(0..0, findings);
            report
        });
        if !skip {
            // SAFETY: the next layer's function, with the application's arguments.
            unsafe { next(physical_device, properties) };
        }
    })
}

unsafe extern "system" fn get_physical_device_properties2(
    physical_device: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceProperties2<'_>,
) {
    get_properties2_with(
        "vkGetPhysicalDeviceProperties2",
        |i| i.fns.get_physical_device_properties2,
        physical_device,
        properties,
    );
}

unsafe extern "system" fn get_physical_device_properties2_khr(
    physical_device: vk::PhysicalDevice,
    properties: *mut vk::PhysicalDeviceProperties2<'_>,
) {
    get_properties2_with(
        "vkGetPhysicalDeviceProperties2KHR",
        |i| i.fns.get_physical_device_properties2_khr,
        physical_device,
        properties,
    );
}

/// Checks the structures chained to a `VkDeviceCreateInfo` before the
/// device is created; returns whether a messenger asked to skip the call.
///
/// # Safety
/// `info`'s pNext chain must be well formed (cycles and length are tolerated).
pub unsafe fn check_device_chain(
    instance: &InstanceData,
    physical_device: vk::PhysicalDevice,
    info: &vk::DeviceCreateInfo<'_>,
) -> bool {
    let function = "vkCreateDevice";
    check_chain(instance, function, physical_device, |validator| {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let chain: Vec<ChainedStruct> =
            unsafe { raw::feature_chain(info.p_next, function, "pCreateInfo", &mut findings) };
        let mut report = validator.create_device(&chain);
        report.findings.splice(0..0, findings);
        report
    })
}

/// The limits a device's checks use: those the `profile` setting chooses, or
/// else what the physical device reports for the extensions `device`
/// enables (queried from the next layer), over the spec-minimum profile for
/// anything it does not report.
pub fn device_limits(
    instance: &InstanceData,
    physical_device: vk::PhysicalDevice,
    device: &Device,
) -> Limits {
    let settings = instance.reporter.settings();
    let chosen = settings.limits.clone();
    if settings.profile_chosen {
        return chosen;
    }
    // Only structures of enabled extensions are chained: the physical
    // device supports those, and each implies Vulkan 1.1 or
    // VK_KHR_get_physical_device_properties2 beneath it.
    let get = instance
        .fns
        .get_physical_device_properties2
        .or(instance.fns.get_physical_device_properties2_khr);
    let has = |name| device.has_extension(name);
    let Some(get) = get.filter(|_| {
        has(ext::EXT_OPACITY_MICROMAP)
            || has(ext::KHR_OPACITY_MICROMAP)
            || has(ext::NV_DISPLACEMENT_MICROMAP)
    }) else {
        return chosen;
    };
    let mut ext_properties = vk::PhysicalDeviceOpacityMicromapPropertiesEXT::default();
    let mut khr_properties = khr::PhysicalDeviceOpacityMicromapPropertiesKHR::default();
    let mut nv_properties = vk::PhysicalDeviceDisplacementMicromapPropertiesNV::default();
    let mut accel_properties = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
    // Each structure of an enabled extension goes to the chain's front.
    let mut next: *mut c_void = std::ptr::null_mut();
    if has(ext::EXT_OPACITY_MICROMAP) {
        ext_properties.p_next = next;
        next = (&raw mut ext_properties).cast();
    }
    if has(ext::KHR_OPACITY_MICROMAP) {
        khr_properties.p_next = next;
        next = (&raw mut khr_properties).cast();
    }
    if has(ext::NV_DISPLACEMENT_MICROMAP) {
        nv_properties.p_next = next;
        next = (&raw mut nv_properties).cast();
    }
    if has(ext::KHR_ACCELERATION_STRUCTURE) {
        accel_properties.p_next = next;
        next = (&raw mut accel_properties).cast();
    }
    let mut properties = vk::PhysicalDeviceProperties2 {
        p_next: next,
        ..Default::default()
    };
    own_calls::call(OwnCall::DeviceLimits, || {
        // SAFETY: the next layer's function, with a physical device of its
        // instance and a chain of live structures of enabled extensions.
        unsafe { get(physical_device, &mut properties) }
    });
    // SAFETY: the chain the next layer just filled.
    unsafe { raw::reported_limits(properties.p_next, &chosen) }
}
