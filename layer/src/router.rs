//! The router: which of this layer's functions answers a device-level
//! command name. It sits above every intercept module and asks each for
//! the commands it owns.

use std::ffi::CStr;

use ash::vk;

use crate::{accel, commands, device, pipe, submit, transfer};

/// This layer's function for a device-level command name, or None.
pub fn device_command(name: &CStr) -> vk::PFN_vkVoidFunction {
    device::intercept(name)
        .or_else(|| accel::intercept(name))
        .or_else(|| commands::intercept(name))
        .or_else(|| submit::intercept(name))
        .or_else(|| pipe::intercept(name))
        .or_else(|| transfer::intercept(name))
}
