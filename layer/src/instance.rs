//! Instance commands: creation and destruction, the debug-utils messengers
//! and the debug-report callbacks.

#![allow(unsafe_code)]

use std::ffi::CStr;
use std::sync::Arc;

use ash::vk;
use ommcheck::Severity;

use crate::dispatch::next_fns::{next_fn, InstanceFns};
use crate::dispatch::{InstanceData, INSTANCES};
use crate::intercept::{as_void, guarded};
use crate::report::{Message, Reporter, EFFECTIVE_SETTINGS};
use crate::{abi, device, read, settings};

/// This layer's function for an instance-level command name.
pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkCreateInstance" => as_void(create_instance as vk::PFN_vkCreateInstance),
        b"vkDestroyInstance" => as_void(destroy_instance as vk::PFN_vkDestroyInstance),
        b"vkCreateDevice" => as_void(device::create_device as vk::PFN_vkCreateDevice),
        b"vkCreateDebugUtilsMessengerEXT" => {
            as_void(create_debug_utils_messenger as vk::PFN_vkCreateDebugUtilsMessengerEXT)
        }
        b"vkDestroyDebugUtilsMessengerEXT" => {
            as_void(destroy_debug_utils_messenger as vk::PFN_vkDestroyDebugUtilsMessengerEXT)
        }
        b"vkCreateDebugReportCallbackEXT" => {
            as_void(create_debug_report_callback as vk::PFN_vkCreateDebugReportCallbackEXT)
        }
        b"vkDestroyDebugReportCallbackEXT" => {
            as_void(destroy_debug_report_callback as vk::PFN_vkDestroyDebugReportCallbackEXT)
        }
        _ => None,
    }
}

/// `vkCreateInstance`: takes the next layer from the loader's link info,
/// creates the instance below, and resolves the next layer's functions.
unsafe extern "system" fn create_instance(
    create_info: *const vk::InstanceCreateInfo<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    instance_out: *mut vk::Instance,
) -> vk::Result {
    guarded(
        "vkCreateInstance",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            // SAFETY: the loader passes a valid create info.
            let Some(info) = (unsafe { create_info.as_ref() }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the loader's create info, with its writable link info.
            let Some(next_gipa) = (unsafe { abi::take_instance_link(info) }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let Some(create) = next_fn!(
                next_gipa,
                vk::Instance::null(),
                c"vkCreateInstance",
                vk::PFN_vkCreateInstance
            ) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            // SAFETY: the application's chain is well formed, as the API requires.
            let callbacks = unsafe { read::chained_callbacks(info.p_next) };
            // SAFETY: as above.
            let api = unsafe { read::layer_settings(info.p_next, settings::LAYER_NAME_C) };
            let parsed = settings::for_instance(&api);
            let effective = parsed.effective_text();
            let mut problems = parsed.problems;
            let (reporter, log_problem) = Reporter::new(callbacks, parsed.settings);
            problems.extend(log_problem);
            reporter.warn_about_settings(&problems, "vkCreateInstance");
            // Information, so shown where the report level includes info:
            // what a user checks first when the layer does not do what
            // they meant.
            let effective = Message::about_layer(
                EFFECTIVE_SETTINGS,
                Severity::Info,
                "vkCreateInstance",
                &effective,
            );
            reporter.deliver(&[effective], true);
            // SAFETY: the next layer's vkCreateInstance, with the application's arguments.
            let result = unsafe { create(create_info, allocator, instance_out) };
            if result != vk::Result::SUCCESS {
                return result;
            }
            // SAFETY: on success the next layer wrote the instance.
            let Some(handle) = (unsafe { read::value(instance_out) }) else {
                return result;
            };
            let data = InstanceData {
                handle,
                next_gipa,
                fns: InstanceFns::load(next_gipa, handle),
                reporter,
            };
            // SAFETY: the instance the loader's chain just created.
            if let Some(key) = unsafe { abi::dispatch_key(vk::Handle::as_raw(handle)) } {
                INSTANCES.insert(key, Arc::new(data));
            }
            result
        },
    )
}

/// `vkDestroyInstance`.
unsafe extern "system" fn destroy_instance(
    instance: vk::Instance,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyInstance", (), || {
        if instance == vk::Instance::null() {
            return;
        }
        // SAFETY: a non-NULL instance is one the loader created.
        let Some(key) = (unsafe { abi::dispatch_key(vk::Handle::as_raw(instance)) }) else {
            return;
        };
        let Some(data) = INSTANCES.remove(key) else {
            return;
        };
        if let Some(destroy) = data.fns.destroy_instance {
            // SAFETY: the next layer's vkDestroyInstance, with the application's arguments.
            unsafe { destroy(instance, allocator) };
        }
    })
}

/// `vkCreateDebugUtilsMessengerEXT`: creates the messenger below, then
/// reports to it too.
unsafe extern "system" fn create_debug_utils_messenger(
    instance: vk::Instance,
    create_info: *const vk::DebugUtilsMessengerCreateInfoEXT<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    messenger_out: *mut vk::DebugUtilsMessengerEXT,
) -> vk::Result {
    guarded(
        "vkCreateDebugUtilsMessengerEXT",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some(data) = INSTANCES.get(instance) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let Some(create) = data.fns.create_debug_utils_messenger else {
                return vk::Result::ERROR_EXTENSION_NOT_PRESENT;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { create(instance, create_info, allocator, messenger_out) };
            if result == vk::Result::SUCCESS {
                // SAFETY: the create info is valid (the API's requirement), and
                // on success the next layer wrote the handle.
                let (info, handle) = unsafe { (create_info.as_ref(), read::value(messenger_out)) };
                if let (Some(info), Some(handle)) = (info, handle) {
                    if let Some(messenger) = read::messenger(info, vk::Handle::as_raw(handle)) {
                        data.reporter.add(messenger);
                    }
                }
            }
            result
        },
    )
}

/// `vkDestroyDebugUtilsMessengerEXT`.
unsafe extern "system" fn destroy_debug_utils_messenger(
    instance: vk::Instance,
    messenger: vk::DebugUtilsMessengerEXT,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyDebugUtilsMessengerEXT", (), || {
        let Some(data) = INSTANCES.get(instance) else {
            return;
        };
        data.reporter.remove(vk::Handle::as_raw(messenger));
        if let Some(destroy) = data.fns.destroy_debug_utils_messenger {
            // SAFETY: the next layer's function, with the application's arguments.
            unsafe { destroy(instance, messenger, allocator) };
        }
    })
}

/// `vkCreateDebugReportCallbackEXT`: creates the callback below, then
/// reports to it too.
unsafe extern "system" fn create_debug_report_callback(
    instance: vk::Instance,
    create_info: *const vk::DebugReportCallbackCreateInfoEXT<'_>,
    allocator: *const vk::AllocationCallbacks<'_>,
    callback_out: *mut vk::DebugReportCallbackEXT,
) -> vk::Result {
    guarded(
        "vkCreateDebugReportCallbackEXT",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            let Some(data) = INSTANCES.get(instance) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            let Some(create) = data.fns.create_debug_report_callback else {
                return vk::Result::ERROR_EXTENSION_NOT_PRESENT;
            };
            // SAFETY: the next layer's function, with the application's arguments.
            let result = unsafe { create(instance, create_info, allocator, callback_out) };
            if result == vk::Result::SUCCESS {
                // SAFETY: the create info is valid (the API's requirement), and
                // on success the next layer wrote the handle.
                let (info, handle) = unsafe { (create_info.as_ref(), read::value(callback_out)) };
                if let (Some(info), Some(handle)) = (info, handle) {
                    if let Some(callback) = read::report_callback(info, vk::Handle::as_raw(handle))
                    {
                        data.reporter.add_report_callback(callback);
                    }
                }
            }
            result
        },
    )
}

/// `vkDestroyDebugReportCallbackEXT`.
unsafe extern "system" fn destroy_debug_report_callback(
    instance: vk::Instance,
    callback: vk::DebugReportCallbackEXT,
    allocator: *const vk::AllocationCallbacks<'_>,
) {
    guarded("vkDestroyDebugReportCallbackEXT", (), || {
        let Some(data) = INSTANCES.get(instance) else {
            return;
        };
        data.reporter
            .remove_report_callback(vk::Handle::as_raw(callback));
        if let Some(destroy) = data.fns.destroy_debug_report_callback {
            // SAFETY: the next layer's function, with the application's arguments.
            unsafe { destroy(instance, callback, allocator) };
        }
    })
}
