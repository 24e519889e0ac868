//! Reading the small structures the layer's own intercepts look at (the
//! core's `ommcheck::raw` reads everything the checks need). Each function
//! states what the Vulkan API guarantees about its pointer.

#![allow(unsafe_code)]

use std::collections::HashSet;
use std::ffi::{c_char, c_void, CStr};
use std::sync::Arc;

use ash::vk;
use ommcheck::raw::MAX_ELEMENTS;

use crate::report::Messenger;
use crate::settings::{ApiSettings, ApiValue};

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

/// The most settings and values per setting read from a
/// `VkLayerSettingsCreateInfoEXT`; the rest are ignored.
const MAX_SETTINGS: usize = 256;
const MAX_VALUES: usize = 64;

/// The settings for `layer` in the `VkLayerSettingsCreateInfoEXT`
/// structures chained at `next` (VK_EXT_layer_settings), walking at most
/// [`MAX_CHAIN`] structures and never one address twice. Settings of other
/// layers are skipped; values of a type this layer has no use for are
/// skipped too.
///
/// # Safety
/// The chain at `next` must be well formed, and each
/// `VkLayerSettingsCreateInfoEXT` valid as VK_EXT_layer_settings requires:
/// `pSettings` points to `settingCount` settings, each with NUL-terminated
/// names and `valueCount` values of its type at `pValues`.
pub unsafe fn layer_settings(mut next: *const c_void, layer: &CStr) -> ApiSettings {
    let mut settings = ApiSettings::new();
    let mut visited = HashSet::new();
    while !next.is_null() && visited.len() < MAX_CHAIN && visited.insert(next as usize) {
        // SAFETY: the caller guarantees a structure starting with sType and pNext.
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::LAYER_SETTINGS_CREATE_INFO_EXT {
            // SAFETY: the sType says what the structure is.
            let info = unsafe { &*next.cast::<vk::LayerSettingsCreateInfoEXT<'_>>() };
            let count = (info.setting_count as usize).min(MAX_SETTINGS);
            for k in 0..count {
                if info.p_settings.is_null() {
                    break;
                }
                // SAFETY: `pSettings` holds `settingCount` settings (the
                // caller's guarantee) and k is below that count.
                let setting = unsafe { &*info.p_settings.add(k) };
                // SAFETY: the names are NUL-terminated (the caller's guarantee).
                let (Some(owner), Some(name)) = (unsafe { name(setting.p_layer_name) }, unsafe {
                    name(setting.p_setting_name)
                }) else {
                    continue;
                };
                if owner != layer {
                    continue;
                }
                // SAFETY: `pValues` holds `valueCount` values of the type (the
                // caller's guarantee).
                let values = unsafe { setting_values(setting) };
                settings.push((name.to_string_lossy().into_owned(), values));
            }
        }
        next = base.p_next.cast();
    }
    settings
}

/// The values of one `VkLayerSettingEXT`, at most [`MAX_VALUES`].
///
/// # Safety
/// `pValues` must hold `valueCount` values of `type`.
unsafe fn setting_values(setting: &vk::LayerSettingEXT<'_>) -> Vec<ApiValue> {
    let count = (setting.value_count as usize).min(MAX_VALUES);
    let values = setting.p_values;
    if values.is_null() {
        return Vec::new();
    }
    /// The k-th value of type T.
    ///
    /// # Safety
    /// As for the function: k is below the value count.
    unsafe fn at<T: Copy>(values: *const c_void, k: usize) -> T {
        // SAFETY: forwarded from the caller.
        unsafe { *values.cast::<T>().add(k) }
    }
    use vk::LayerSettingTypeEXT as Type;
    (0..count)
        .filter_map(|k| {
            // SAFETY: k is below valueCount and the type says what is there.
            Some(unsafe {
                match setting.ty {
                    Type::BOOL32 => ApiValue::Bool(at::<vk::Bool32>(values, k) != vk::FALSE),
                    Type::INT32 => ApiValue::Int(i64::from(at::<i32>(values, k))),
                    Type::INT64 => ApiValue::Int(at::<i64>(values, k)),
                    Type::UINT32 => ApiValue::Int(i64::from(at::<u32>(values, k))),
                    Type::UINT64 => {
                        ApiValue::Int(i64::try_from(at::<u64>(values, k)).unwrap_or(i64::MAX))
                    }
                    Type::FLOAT32 => ApiValue::Float(f64::from(at::<f32>(values, k))),
                    Type::FLOAT64 => ApiValue::Float(at::<f64>(values, k)),
                    Type::STRING => ApiValue::Text(
                        name(at::<*const c_char>(values, k))?
                            .to_string_lossy()
                            .into_owned(),
                    ),
                    _ => return None,
                }
            })
        })
        .collect()
}

/// The first `count` elements of an application array, at most
/// [`MAX_ELEMENTS`] of them; empty for NULL.
///
/// # Safety
/// A non-NULL `pointer` must point to `count` readable, initialised `T`s
/// that stay so for `'a`, as the API requires of the parameter.
pub unsafe fn array<'a, T>(pointer: *const T, count: u32) -> &'a [T] {
    if pointer.is_null() {
        return &[];
    }
    let len = usize::try_from(count)
        .unwrap_or(usize::MAX)
        .min(MAX_ELEMENTS);
    // SAFETY: the caller guarantees `count` elements; `len <= count`.
    unsafe { std::slice::from_raw_parts(pointer, len) }
}

/// The command buffers of `vkQueueSubmit`'s `pSubmits`, at most
/// [`MAX_ELEMENTS`] in all.
///
/// # Safety
/// A non-NULL `submits` must point to `count` `VkSubmitInfo`s whose
/// `pCommandBuffers` are valid for their counts.
pub unsafe fn submitted_command_buffers(
    count: u32,
    submits: *const vk::SubmitInfo<'_>,
) -> Vec<vk::CommandBuffer> {
    let mut command_buffers = Vec::new();
    // SAFETY: forwarded from the caller.
    for submit in unsafe { array(submits, count) } {
        // SAFETY: forwarded from the caller.
        let list = unsafe { array(submit.p_command_buffers, submit.command_buffer_count) };
        let room = MAX_ELEMENTS.saturating_sub(command_buffers.len());
        command_buffers.extend(list.iter().take(room).copied());
    }
    command_buffers
}

/// The command buffers of `vkQueueSubmit2`'s `pSubmits`, at most
/// [`MAX_ELEMENTS`] in all.
///
/// # Safety
/// A non-NULL `submits` must point to `count` `VkSubmitInfo2`s whose
/// `pCommandBufferInfos` are valid for their counts.
pub unsafe fn submitted_command_buffers2(
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
) -> Vec<vk::CommandBuffer> {
    let mut command_buffers = Vec::new();
    // SAFETY: forwarded from the caller.
    for submit in unsafe { array(submits, count) } {
        // SAFETY: forwarded from the caller.
        let list = unsafe {
            array(
                submit.p_command_buffer_infos,
                submit.command_buffer_info_count,
            )
        };
        let room = MAX_ELEMENTS.saturating_sub(command_buffers.len());
        command_buffers.extend(list.iter().take(room).map(|info| info.command_buffer));
    }
    command_buffers
}

/// `VkQueueFlags` of each queue family of `physical_device` (at most 64
/// families, more than any device has).
///
/// # Safety
/// `get` must be the next layer's `vkGetPhysicalDeviceQueueFamilyProperties`
/// and `physical_device` one of its instance's.
pub unsafe fn queue_family_flags(
    get: vk::PFN_vkGetPhysicalDeviceQueueFamilyProperties,
    physical_device: vk::PhysicalDevice,
) -> Vec<vk::QueueFlags> {
    const MAX_FAMILIES: u32 = 64;
    let mut count = 0;
    // SAFETY: the count query, as the API defines it.
    unsafe { get(physical_device, &mut count, std::ptr::null_mut()) };
    let mut families = vec![vk::QueueFamilyProperties::default(); count.min(MAX_FAMILIES) as usize];
    let mut written = families.len() as u32;
    // SAFETY: `families` holds `written` elements for the next layer to fill.
    unsafe { get(physical_device, &mut written, families.as_mut_ptr()) };
    families.truncate(written as usize);
    families.iter().map(|family| family.queue_flags).collect()
}

/// A copy of `len` bytes of mapped device memory at host address `address`.
///
/// # Safety
/// `[address, address + len)` must lie inside a range the application
/// mapped with `vkMapMemory` and has not unmapped.
pub unsafe fn mapped_bytes(address: usize, len: usize) -> Arc<[u8]> {
    // SAFETY: forwarded from the caller: mapped memory is readable host memory.
    Arc::from(unsafe {
        std::slice::from_raw_parts(std::ptr::with_exposed_provenance::<u8>(address), len)
    })
}
