//! `VK_LAYER_OMMCHECK_validation`: the ommcheck checks as a Vulkan layer.
//!
//! The layer feeds an [`ommcheck::Validator`] per device with what the
//! application creates and records, checks each call the micromap rules
//! concern through the core's raw entry points, and reports findings to the
//! application's `VK_EXT_debug_utils` messengers and `VK_EXT_debug_report`
//! callbacks in the Khronos validation layer's format (docs/layer.md). Every other command passes to the next layer untouched.
//! All check logic lives in the core; this crate only adapts the loader
//! interface to it. Its modules, from the bottom up; each imports only
//! modules earlier in this list (and none imports the crate root), so
//! every shared type lies below all its users:
//!
//! - `ids`, `own_calls`, `setting_docs`, `settings`, `report`, `read`,
//!   `abi`, `shadow`: the ids of the layer's messages about itself, the
//!   calls it makes to the next layer on its own behalf, settings (and
//!   their table, which xtask writes the manifest from), message delivery,
//!   the small raw reads of the layer's own, the loader's structures, and
//!   what recorded transfers wrote (route 1);
//! - `dispatch`: per-instance and per-device data by dispatch key, and
//!   every type a device's state holds: the next layer's function tables
//!   (`next_fns`), where buffers lie and memory is mapped
//!   (`memory_layout`), the driver's answers (`next_layer_answers`), what
//!   bound shaders reach (`pipe_state`), the layer's readback memory
//!   (`readback_memory`), and kept builds and pending submissions
//!   (`submissions`);
//! - `provenance`: the persistent provenance store, opened once per
//!   process and directory, and the serialized bytes host copies write and
//!   read;
//! - `intercept`: what every intercept uses: the panic guard, finding a
//!   device and the next layer's function, running a check and delivering
//!   its findings;
//! - the intercepts: `readback` (device builds whose inputs the host
//!   cannot read are copied on the GPU into layer memory), `commands`
//!   (command pools and buffers, and the builds they keep), `completion`
//!   (read-back builds checked once their submission is complete),
//!   `driver_answers`, `sync`, `accel` (acceleration structures, micromap
//!   copies, queries, size queries and compatibility), `transfer`, `work`
//!   (the commands that run shaders, with descriptor tracking),
//!   `pipelines`, `submit` (the contents of device builds read at
//!   submission), `properties` (feature and property chains), `device`
//!   (device creation, buffers, memory, micromap objects and builds);
//! - `pipe`, `router`, `instance`: the tables from a command name to its
//!   intercept, and instance creation with messengers and debug-report
//!   callbacks, which the exported functions here use;
//! - `testing`: hooks for the layer's own tests.
//!
//! Every exported or intercepted function runs its body inside
//! `std::panic::catch_unwind`: a panic becomes one error message and never
//! unwinds into the caller.

// The loader looks the library up as libVkLayer_ommcheck.so.
#![allow(non_snake_case)]

pub mod abi;
mod accel;
mod commands;
mod completion;
mod device;
mod dispatch;
mod driver_answers;
pub mod ids;
mod instance;
mod intercept;
pub mod own_calls;
mod pipe;
mod pipelines;
mod properties;
mod provenance;
mod read;
mod readback;
pub mod report;
mod router;
mod setting_docs;
pub mod settings;
mod shadow;
mod submit;
mod sync;
#[doc(hidden)]
pub mod testing;
mod transfer;
mod work;

use std::ffi::{c_char, CStr};

use ash::vk;

use abi::{NegotiateLayerInterface, LAYER_INTERFACE_VERSION, LAYER_NEGOTIATE_INTERFACE_STRUCT};
use dispatch::{DEVICES, INSTANCES};
use intercept::guarded;

pub use setting_docs::LAYER_NAME;
pub use settings::LAYER_NAME_C;

/// `vkNegotiateLoaderLayerInterfaceVersion`: offers interface version 2
/// with this layer's `vkGetInstanceProcAddr` and `vkGetDeviceProcAddr`.
///
/// # Safety
/// `negotiate` must be NULL or point to the loader's `VkNegotiateLayerInterface`.
#[no_mangle]
pub unsafe extern "system" fn vkNegotiateLoaderLayerInterfaceVersion(
    negotiate: *mut NegotiateLayerInterface,
) -> vk::Result {
    guarded(
        "vkNegotiateLoaderLayerInterfaceVersion",
        vk::Result::ERROR_INITIALIZATION_FAILED,
        || {
            // SAFETY: the loader passes its negotiation structure (or NULL).
            let Some(negotiate) = (unsafe { negotiate.as_mut() }) else {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            };
            if negotiate.s_type != LAYER_NEGOTIATE_INTERFACE_STRUCT
                || negotiate.loader_layer_interface_version < 2
            {
                return vk::Result::ERROR_INITIALIZATION_FAILED;
            }
            negotiate.loader_layer_interface_version = negotiate
                .loader_layer_interface_version
                .min(LAYER_INTERFACE_VERSION);
            negotiate.pfn_get_instance_proc_addr = Some(vkGetInstanceProcAddr);
            negotiate.pfn_get_device_proc_addr = Some(vkGetDeviceProcAddr);
            negotiate.pfn_get_physical_device_proc_addr = None;
            vk::Result::SUCCESS
        },
    )
}

/// `vkGetInstanceProcAddr`: this layer's instance commands; its device
/// commands where the next layer has them; anything else from the next layer.
///
/// # Safety
/// `name` must be NULL or NUL-terminated; `instance` NULL or an instance.
#[no_mangle]
pub unsafe extern "system" fn vkGetInstanceProcAddr(
    instance: vk::Instance,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    guarded("vkGetInstanceProcAddr", None, || {
        // SAFETY: the name is NUL-terminated (the caller's guarantee).
        let name = unsafe { read::name(name) }?;
        if let Some(function) = proc_addr_function(name).or_else(|| instance::intercept(name)) {
            return Some(function);
        }
        let data = (instance != vk::Instance::null())
            .then(|| INSTANCES.get(instance))
            .flatten()?;
        // SAFETY: the next layer's GIPA, with the instance it created.
        let next = unsafe { (data.next_gipa)(data.handle, name.as_ptr()) };
        match router::device_command(name).or_else(|| properties::intercept(name)) {
            Some(ours) if next.is_some() => Some(ours),
            _ => next,
        }
    })
}

/// `vkGetDeviceProcAddr`: this layer's device commands where the next
/// layer has them; anything else from the next layer.
///
/// # Safety
/// `name` must be NULL or NUL-terminated; `device` NULL or a device.
#[no_mangle]
pub unsafe extern "system" fn vkGetDeviceProcAddr(
    device: vk::Device,
    name: *const c_char,
) -> vk::PFN_vkVoidFunction {
    guarded("vkGetDeviceProcAddr", None, || {
        // SAFETY: the name is NUL-terminated (the caller's guarantee).
        let name = unsafe { read::name(name) }?;
        if name == c"vkGetDeviceProcAddr" {
            return intercept::as_void(vkGetDeviceProcAddr as vk::PFN_vkGetDeviceProcAddr);
        }
        let data = (device != vk::Device::null())
            .then(|| DEVICES.get(device))
            .flatten()?;
        // SAFETY: the next layer's GDPA, with the device it created.
        let next = unsafe { (data.next_gdpa)(data.handle, name.as_ptr()) };
        match router::device_command(name) {
            Some(ours) if next.is_some() => Some(ours),
            _ => next,
        }
    })
}

/// This layer's `vkGetInstanceProcAddr` or `vkGetDeviceProcAddr` by name.
/// They are answered here, beside the functions, so that no module below
/// imports the crate root.
fn proc_addr_function(name: &CStr) -> vk::PFN_vkVoidFunction {
    match name.to_bytes() {
        b"vkGetInstanceProcAddr" => {
            intercept::as_void(vkGetInstanceProcAddr as vk::PFN_vkGetInstanceProcAddr)
        }
        b"vkGetDeviceProcAddr" => {
            intercept::as_void(vkGetDeviceProcAddr as vk::PFN_vkGetDeviceProcAddr)
        }
        _ => None,
    }
}

/// Whether `name` is a command this layer intercepts (for tests and tools).
pub fn intercepts(name: &CStr) -> bool {
    proc_addr_function(name).is_some()
        || instance::intercept(name).is_some()
        || router::device_command(name).is_some()
        || properties::intercept(name).is_some()
}
