//! Reading the small structures the layer's own intercepts look at (the
//! core's `ommcheck::raw` reads everything the checks need). Each function
//! states what the Vulkan API guarantees about its pointer.

#![allow(unsafe_code)]

use std::collections::HashSet;
use std::ffi::{c_char, c_void, CStr};

use ash::vk;

use crate::report::Messenger;

/// The most structures walked in a pNext chain.
const MAX_CHAIN: usize = 64;

/// A copy of the `T` at `pointer`; None for NULL.
///
/// # Safety
/// A non-NULL `pointer` must point to a readable, initialised `T`, as the
/// API requires of the parameter it came from.
pub unsafe fn value<T: Copy>(pointer: *const T) -> Option<T> {
    // SAFETY: forwarded from the caller.
    unsafe { pointer.as_ref() }.copied()
}

/// A command name passed to `vkGet*ProcAddr`.
///
/// # Safety
/// A non-NULL `name` must be NUL-terminated, as the API requires.
pub unsafe fn name<'a>(name: *const c_char) -> Option<&'a CStr> {
    // SAFETY: forwarded from the caller.
    (!name.is_null()).then(|| unsafe { CStr::from_ptr(name) })
}

/// The messenger a `VkDebugUtilsMessengerCreateInfoEXT` describes; None
/// without a callback.
pub fn messenger(
    info: &vk::DebugUtilsMessengerCreateInfoEXT<'_>,
    handle: u64,
) -> Option<Messenger> {
    Some(Messenger {
        handle,
        severities: info.message_severity,
        types: info.message_type,
        callback: info.pfn_user_callback?,
        user_data: info.p_user_data.expose_provenance(),
    })
}

/// The messengers chained in a `VkInstanceCreateInfo`, walking at most
/// [`MAX_CHAIN`] structures and never one address twice.
///
/// # Safety
/// The chain at `next` must be well formed: each structure starts with
/// sType and pNext.
pub unsafe fn chained_messengers(mut next: *const c_void) -> Vec<Messenger> {
    let mut messengers = Vec::new();
    let mut visited = HashSet::new();
    while !next.is_null() && visited.len() < MAX_CHAIN && visited.insert(next as usize) {
        // SAFETY: the caller guarantees a structure starting with sType and pNext.
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT {
            // SAFETY: the sType says what the structure is.
            let info = unsafe { &*next.cast::<vk::DebugUtilsMessengerCreateInfoEXT<'_>>() };
            messengers.extend(messenger(info, 0));
        }
        next = base.p_next.cast();
    }
    messengers
}
