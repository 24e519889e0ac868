//! Reading the small structures the layer's own intercepts look at (the
//! core's `ommcheck::raw` reads everything the checks need). Each function
//! states what the Vulkan API guarantees about its pointer.

#![allow(unsafe_code)]

use std::collections::HashSet;
use std::ffi::{c_char, c_void, CStr};

use ommcheck::Bytes;

use ash::vk;
use ash::vk::Handle as _;
use ommcheck::model::{SemaphoreOp, SubmitBatch};
use ommcheck::raw::MAX_ELEMENTS;

use crate::report::{Callbacks, Messenger, ReportCallback};
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

/// The debug-report callback a `VkDebugReportCallbackCreateInfoEXT`
/// describes; None without a callback.
pub fn report_callback(
    info: &vk::DebugReportCallbackCreateInfoEXT<'_>,
    handle: u64,
) -> Option<ReportCallback> {
    Some(ReportCallback {
        handle,
        flags: info.flags,
        callback: info.pfn_callback?,
        user_data: info.p_user_data.expose_provenance(),
    })
}

/// The messengers and debug-report callbacks chained in a
/// `VkInstanceCreateInfo`, walking at most [`MAX_CHAIN`] structures and
/// never one address twice.
///
/// # Safety
/// The chain at `next` must be well formed: each structure starts with
/// sType and pNext.
pub unsafe fn chained_callbacks(mut next: *const c_void) -> Callbacks {
    let mut callbacks = Callbacks::default();
    let mut visited = HashSet::new();
    while !next.is_null() && visited.len() < MAX_CHAIN && visited.insert(next as usize) {
        // SAFETY: the caller guarantees a structure starting with sType and pNext.
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT {
            // SAFETY: the sType says what the structure is.
            let info = unsafe { &*next.cast::<vk::DebugUtilsMessengerCreateInfoEXT<'_>>() };
            callbacks.messengers.extend(messenger(info, 0));
        } else if base.s_type == vk::StructureType::DEBUG_REPORT_CALLBACK_CREATE_INFO_EXT {
            // SAFETY: the sType says what the structure is.
            let info = unsafe { &*next.cast::<vk::DebugReportCallbackCreateInfoEXT<'_>>() };
            callbacks.report_callbacks.extend(report_callback(info, 0));
        }
        next = base.p_next.cast();
    }
    callbacks
}

/// Whether the chain at `next` holds a structure of `s_type`, walking at
/// most [`MAX_CHAIN`] structures and never one address twice.
///
/// # Safety
/// The chain at `next` must be well formed: each structure starts with
/// sType and pNext.
pub unsafe fn chain_has(mut next: *const c_void, s_type: vk::StructureType) -> bool {
    let mut visited = HashSet::new();
    while !next.is_null() && visited.len() < MAX_CHAIN && visited.insert(next as usize) {
        // SAFETY: the caller guarantees a structure starting with sType and pNext.
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == s_type {
            return true;
        }
        next = base.p_next.cast();
    }
    false
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

/// The semaphores `vkQueueSubmit`'s `pSubmits` signal with the values a
/// chained `VkTimelineSemaphoreSubmitInfo` gives them (binary semaphores
/// get whatever value is there, or 0; only timeline values are looked up).
///
/// # Safety
/// A non-NULL `submits` must point to `count` valid `VkSubmitInfo`s.
pub unsafe fn submitted_signals(count: u32, submits: *const vk::SubmitInfo<'_>) -> Vec<(u64, u64)> {
    let mut signals = Vec::new();
    // SAFETY: forwarded from the caller.
    for submit in unsafe { array(submits, count) } {
        // SAFETY: forwarded from the caller.
        let semaphores =
            unsafe { array(submit.p_signal_semaphores, submit.signal_semaphore_count) };
        // SAFETY: forwarded from the caller.
        let (_, values) = unsafe { timeline_values(submit.p_next) };
        let room = MAX_ELEMENTS.saturating_sub(signals.len());
        signals.extend(
            semaphores
                .iter()
                .enumerate()
                .take(room)
                .map(|(k, s)| (s.as_raw(), values.get(k).copied().unwrap_or(0))),
        );
    }
    signals
}

/// The wait and signal values of a `VkTimelineSemaphoreSubmitInfo` in the
/// chain at `next` (empty without one).
///
/// # Safety
/// The chain must be well formed and a chained
/// `VkTimelineSemaphoreSubmitInfo` valid for its counts.
unsafe fn timeline_values<'a>(next: *const c_void) -> (&'a [u64], &'a [u64]) {
    let mut next = next;
    let mut visited = HashSet::new();
    while !next.is_null() && visited.len() < MAX_CHAIN && visited.insert(next as usize) {
        // SAFETY: a well-formed chain (the caller's guarantee).
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        if base.s_type == vk::StructureType::TIMELINE_SEMAPHORE_SUBMIT_INFO {
            // SAFETY: the sType says what the structure is.
            let timeline = unsafe { &*next.cast::<vk::TimelineSemaphoreSubmitInfo<'_>>() };
            // SAFETY: the value arrays hold their counts of values.
            return unsafe {
                (
                    array(
                        timeline.p_wait_semaphore_values,
                        timeline.wait_semaphore_value_count,
                    ),
                    array(
                        timeline.p_signal_semaphore_values,
                        timeline.signal_semaphore_value_count,
                    ),
                )
            };
        }
        next = base.p_next.cast();
    }
    (&[], &[])
}

/// A semaphore operation for the core: a value other than 0 marks a
/// timeline semaphore (a binary semaphore's value is ignored, and
/// applications leave it 0).
fn semaphore_op(semaphore: u64, value: u64) -> SemaphoreOp {
    SemaphoreOp {
        semaphore,
        value,
        timeline: value != 0,
    }
}

/// Limits the batches' lists to [`MAX_ELEMENTS`] elements in all: each
/// list takes what room is left.
struct Room(usize);

impl Room {
    fn take<T: Copy, U>(&mut self, list: &[T], map: impl Fn(usize, T) -> U) -> Vec<U> {
        let taken: Vec<U> = list
            .iter()
            .take(self.0)
            .enumerate()
            .map(|(k, item)| map(k, *item))
            .collect();
        self.0 -= taken.len();
        taken
    }
}

/// The batches of `vkQueueSubmit`'s `pSubmits` for the core's execution
/// order, with at most [`MAX_ELEMENTS`] semaphores and command buffers in all.
///
/// # Safety
/// A non-NULL `submits` must point to `count` valid `VkSubmitInfo`s.
pub unsafe fn submitted_batches(
    count: u32,
    submits: *const vk::SubmitInfo<'_>,
) -> Vec<SubmitBatch> {
    let mut room = Room(MAX_ELEMENTS);
    // SAFETY: forwarded from the caller.
    let submits = unsafe { array(submits, count) };
    let mut batches = Vec::new();
    for submit in submits.iter().take(MAX_ELEMENTS) {
        // SAFETY: forwarded from the caller (each array holds its count).
        let (wait_values, signal_values, waits, command_buffers, signals) = unsafe {
            let (wait_values, signal_values) = timeline_values(submit.p_next);
            (
                wait_values,
                signal_values,
                array(submit.p_wait_semaphores, submit.wait_semaphore_count),
                array(submit.p_command_buffers, submit.command_buffer_count),
                array(submit.p_signal_semaphores, submit.signal_semaphore_count),
            )
        };
        let value = |values: &[u64], k: usize| values.get(k).copied().unwrap_or(0);
        batches.push(SubmitBatch {
            waits: room.take(waits, |k, s| {
                semaphore_op(s.as_raw(), value(wait_values, k))
            }),
            command_buffers: room.take(command_buffers, |_, cb| cb.as_raw()),
            signals: room.take(signals, |k, s| {
                semaphore_op(s.as_raw(), value(signal_values, k))
            }),
        });
    }
    batches
}

/// The batches of `vkQueueSubmit2`'s `pSubmits` for the core's execution
/// order, with at most [`MAX_ELEMENTS`] semaphores and command buffers in all.
///
/// # Safety
/// A non-NULL `submits` must point to `count` valid `VkSubmitInfo2`s.
pub unsafe fn submitted_batches2(
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
) -> Vec<SubmitBatch> {
    let mut room = Room(MAX_ELEMENTS);
    // SAFETY: forwarded from the caller.
    let submits = unsafe { array(submits, count) };
    let op =
        |_, info: vk::SemaphoreSubmitInfo<'_>| semaphore_op(info.semaphore.as_raw(), info.value);
    let mut batches = Vec::new();
    for submit in submits.iter().take(MAX_ELEMENTS) {
        // SAFETY: forwarded from the caller (each array holds its count).
        let (waits, command_buffers, signals) = unsafe {
            (
                array(
                    submit.p_wait_semaphore_infos,
                    submit.wait_semaphore_info_count,
                ),
                array(
                    submit.p_command_buffer_infos,
                    submit.command_buffer_info_count,
                ),
                array(
                    submit.p_signal_semaphore_infos,
                    submit.signal_semaphore_info_count,
                ),
            )
        };
        batches.push(SubmitBatch {
            waits: room.take(waits, op),
            command_buffers: room.take(command_buffers, |_, info| info.command_buffer.as_raw()),
            signals: room.take(signals, op),
        });
    }
    batches
}

/// The semaphores and values `vkQueueSubmit2`'s `pSubmits` signal.
///
/// # Safety
/// A non-NULL `submits` must point to `count` valid `VkSubmitInfo2`s.
pub unsafe fn submitted_signals2(
    count: u32,
    submits: *const vk::SubmitInfo2<'_>,
) -> Vec<(u64, u64)> {
    let mut signals = Vec::new();
    // SAFETY: forwarded from the caller.
    for submit in unsafe { array(submits, count) } {
        // SAFETY: forwarded from the caller.
        let infos = unsafe {
            array(
                submit.p_signal_semaphore_infos,
                submit.signal_semaphore_info_count,
            )
        };
        let room = MAX_ELEMENTS.saturating_sub(signals.len());
        signals.extend(
            infos
                .iter()
                .take(room)
                .map(|i| (i.semaphore.as_raw(), i.value)),
        );
    }
    signals
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
pub unsafe fn mapped_bytes(address: usize, len: usize) -> Bytes {
    // SAFETY: forwarded from the caller: mapped memory is readable host memory.
    Bytes::copy_from_slice(unsafe {
        std::slice::from_raw_parts(std::ptr::with_exposed_provenance::<u8>(address), len)
    })
}

/// `len` bytes of mapped device memory at host address `address`, shared
/// without a copy: the view keeps `owner`, which keeps the memory mapped.
///
/// # Safety
/// `[address, address + len)` must lie inside memory mapped with
/// `vkMapMemory` that stays mapped, and is not written, while `owner`
/// lives: the bytes are read whenever the view (or a clone of it) is.
pub unsafe fn mapped_view<O: Send + 'static>(owner: O, address: usize, len: usize) -> Bytes {
    Bytes::from_owner(MappedView {
        _owner: owner,
        address,
        len,
    })
}

/// See [`mapped_view`]: constructed only there, under its contract.
struct MappedView<O> {
    _owner: O,
    address: usize,
    len: usize,
}

impl<O> AsRef<[u8]> for MappedView<O> {
    fn as_ref(&self) -> &[u8] {
        // SAFETY: `mapped_view`'s caller promised the range stays mapped and
        // unwritten while the owner, a field of this view, lives.
        unsafe {
            std::slice::from_raw_parts(
                std::ptr::with_exposed_provenance::<u8>(self.address),
                self.len,
            )
        }
    }
}

/// Every reader on the structures an application (or the next layer) could
/// hand it, so that Miri (`cargo xtask test`) checks each read stays inside
/// them. Chains are linked by hand through raw pointers: ash's `push_next`
/// keeps a `&mut` to the chained structure, which Stacked Borrows rejects
/// once the chain is read through the head.
/// The `VkDeviceSize` results a size query wrote to `data`: the `k`-th
/// at `k * stride` bytes in, for `k < count`, as far as `data_size` bytes
/// hold them (at most [`MAX_ELEMENTS`]); empty for NULL.
///
/// # Safety
/// A non-NULL `data` must point to `data_size` readable bytes, as the
/// query's `pData` does once it returned.
pub unsafe fn device_sizes(
    data: *const c_void,
    data_size: usize,
    stride: usize,
    count: u32,
) -> Vec<u64> {
    if data.is_null() {
        return Vec::new();
    }
    let size = std::mem::size_of::<u64>();
    let count = usize::try_from(count)
        .unwrap_or(usize::MAX)
        .min(MAX_ELEMENTS);
    (0..count)
        .map_while(|k| {
            let at = k.checked_mul(stride)?;
            (at.checked_add(size)? <= data_size).then_some(at)
        })
        // SAFETY: `at + 8 <= data_size`, inside what the caller guarantees
        // readable; the results need not be aligned.
        .map(|at| unsafe { data.cast::<u8>().add(at).cast::<u64>().read_unaligned() })
        .collect()
}

#[cfg(test)]
mod tests {
    use std::ffi::{c_void, CStr};
    use std::ptr;
    use std::sync::Arc;

    use ash::vk;

    use super::*;

    unsafe extern "system" fn callback(
        _: vk::DebugUtilsMessageSeverityFlagsEXT,
        _: vk::DebugUtilsMessageTypeFlagsEXT,
        _: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
        _: *mut c_void,
    ) -> vk::Bool32 {
        vk::FALSE
    }

    unsafe extern "system" fn report_callback_fn(
        _: vk::DebugReportFlagsEXT,
        _: vk::DebugReportObjectTypeEXT,
        _: u64,
        _: usize,
        _: i32,
        _: *const c_char,
        _: *const c_char,
        _: *mut c_void,
    ) -> vk::Bool32 {
        vk::FALSE
    }

    fn as_next<T>(structure: &T) -> *const c_void {
        (structure as *const T).cast()
    }

    #[test]
    fn value_copies_what_is_there_and_none_for_null() {
        let x = 7u64;
        // SAFETY: `&x` is a readable u64; NULL is allowed.
        assert_eq!(unsafe { value(&x) }, Some(7));
        assert_eq!(unsafe { value::<u64>(ptr::null()) }, None);
    }

    #[test]
    fn name_reads_to_the_terminator_and_none_for_null() {
        let text = c"vkCmdBuildMicromapsEXT";
        // SAFETY: a NUL-terminated string; NULL is allowed.
        assert_eq!(unsafe { name(text.as_ptr()) }, Some(text));
        assert_eq!(unsafe { name(ptr::null()) }, None);
    }

    #[test]
    fn callbacks_are_found_anywhere_in_the_chain_and_skipped_without_callback() {
        let mut without_callback = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING);
        let mut other = vk::ValidationFeaturesEXT::default();
        let mut report = vk::DebugReportCallbackCreateInfoEXT::default()
            .flags(vk::DebugReportFlagsEXT::ERROR)
            .pfn_callback(Some(report_callback_fn));
        report.p_user_data = ptr::without_provenance_mut(0x5678);
        let report_without_callback = vk::DebugReportCallbackCreateInfoEXT::default();
        report.p_next = as_next(&report_without_callback);
        let mut with_callback = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR)
            .message_type(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION)
            .pfn_user_callback(Some(callback));
        with_callback.p_user_data = ptr::without_provenance_mut(0x1234);
        with_callback.p_next = as_next(&report);
        other.p_next = as_next(&with_callback);
        without_callback.p_next = as_next(&other);
        // SAFETY: a well-formed chain of five structures.
        let callbacks = unsafe { chained_callbacks(as_next(&without_callback)) };
        assert_eq!(callbacks.report_callbacks.len(), 1);
        assert_eq!(
            callbacks.report_callbacks[0].flags,
            vk::DebugReportFlagsEXT::ERROR
        );
        assert_eq!(callbacks.report_callbacks[0].user_data, 0x5678);
        let found = callbacks.messengers;
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].handle, 0);
        assert_eq!(
            found[0].severities,
            vk::DebugUtilsMessageSeverityFlagsEXT::ERROR
        );
        assert_eq!(
            found[0].types,
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
        );
        assert_eq!(found[0].user_data, 0x1234);
        // SAFETY: an empty chain.
        let none = unsafe { chained_callbacks(ptr::null()) };
        assert!(none.messengers.is_empty() && none.report_callbacks.is_empty());
    }

    #[test]
    fn a_cyclic_chain_is_walked_once() {
        let mut first =
            vk::DebugUtilsMessengerCreateInfoEXT::default().pfn_user_callback(Some(callback));
        let mut second = vk::ValidationFeaturesEXT::default();
        let first_at = ptr::addr_of_mut!(first);
        second.p_next = first_at.cast_const().cast();
        // SAFETY: `first_at` points to `first`; written through it so the
        // pointer stays valid for the read below.
        unsafe { (*first_at).p_next = as_next(&second) };
        // SAFETY: every structure is valid; the chain loops back to the head.
        let found = unsafe { chained_callbacks(first_at.cast_const().cast()) }.messengers;
        assert_eq!(
            found.len(),
            1,
            "the messenger is read once, not once per lap"
        );
    }

    #[test]
    fn a_chain_longer_than_the_bound_is_walked_to_the_bound() {
        let mut nodes: Vec<vk::DebugUtilsMessengerCreateInfoEXT<'_>> = (0..MAX_CHAIN + 8)
            .map(|_| {
                vk::DebugUtilsMessengerCreateInfoEXT::default().pfn_user_callback(Some(callback))
            })
            .collect();
        let base = nodes.as_mut_ptr();
        for k in 0..nodes.len() - 1 {
            // SAFETY: k + 1 is inside `nodes`; the pointers come from one
            // raw pointer to the whole vector, so none invalidates another.
            unsafe { (*base.add(k)).p_next = base.add(k + 1).cast_const().cast() };
        }
        // SAFETY: a well-formed chain of `nodes.len()` structures.
        let found = unsafe { chained_callbacks(base.cast_const().cast()) }.messengers;
        assert_eq!(found.len(), MAX_CHAIN);
    }

    fn setting<'a>(
        layer: &'a CStr,
        setting: &'a CStr,
        ty: vk::LayerSettingTypeEXT,
        count: u32,
        values: *const c_void,
    ) -> vk::LayerSettingEXT<'a> {
        vk::LayerSettingEXT {
            p_layer_name: layer.as_ptr(),
            p_setting_name: setting.as_ptr(),
            ty,
            value_count: count,
            p_values: values,
            ..Default::default()
        }
    }

    #[test]
    fn layer_settings_of_every_type_are_read_for_this_layer_only() {
        let layer = c"VK_LAYER_OMMCHECK_validation";
        let other = c"VK_LAYER_KHRONOS_validation";
        let bools = [vk::TRUE, vk::FALSE];
        let i32s = [-3i32];
        let i64s = [i64::MIN];
        let u32s = [u32::MAX];
        let u64s = [u64::MAX, 5];
        let f32s = [0.5f32];
        let f64s = [-2.25f64];
        let texts = [c"params".as_ptr(), ptr::null()];
        let unknown = [1u8; 16];
        use vk::LayerSettingTypeEXT as Type;
        let list = [
            setting(layer, c"a", Type::BOOL32, 2, bools.as_ptr().cast()),
            setting(layer, c"b", Type::INT32, 1, i32s.as_ptr().cast()),
            setting(layer, c"c", Type::INT64, 1, i64s.as_ptr().cast()),
            setting(layer, c"d", Type::UINT32, 1, u32s.as_ptr().cast()),
            setting(layer, c"e", Type::UINT64, 2, u64s.as_ptr().cast()),
            setting(layer, c"f", Type::FLOAT32, 1, f32s.as_ptr().cast()),
            setting(layer, c"g", Type::FLOAT64, 1, f64s.as_ptr().cast()),
            setting(layer, c"h", Type::STRING, 2, texts.as_ptr().cast()),
            setting(layer, c"i", Type::from_raw(99), 16, unknown.as_ptr().cast()),
            setting(layer, c"j", Type::UINT32, 3, ptr::null()),
            setting(other, c"a", Type::BOOL32, 2, bools.as_ptr().cast()),
        ];
        let info = vk::LayerSettingsCreateInfoEXT {
            setting_count: list.len() as u32,
            p_settings: list.as_ptr(),
            ..Default::default()
        };
        // SAFETY: every setting holds `valueCount` values of its type.
        let read = unsafe { layer_settings(as_next(&info), layer) };
        let expected: ApiSettings = vec![
            (
                "a".into(),
                vec![ApiValue::Bool(true), ApiValue::Bool(false)],
            ),
            ("b".into(), vec![ApiValue::Int(-3)]),
            ("c".into(), vec![ApiValue::Int(i64::MIN)]),
            ("d".into(), vec![ApiValue::Int(i64::from(u32::MAX))]),
            ("e".into(), vec![ApiValue::Int(i64::MAX), ApiValue::Int(5)]),
            ("f".into(), vec![ApiValue::Float(0.5)]),
            ("g".into(), vec![ApiValue::Float(-2.25)]),
            // A NULL string is no value.
            ("h".into(), vec![ApiValue::Text("params".into())]),
            ("i".into(), vec![]),
            ("j".into(), vec![]),
        ];
        assert_eq!(read, expected);
    }

    #[test]
    fn layer_settings_stop_at_their_bounds_and_at_null() {
        let layer = c"VK_LAYER_OMMCHECK_validation";
        let values = vec![7u32; MAX_VALUES + 3];
        let many = setting(
            layer,
            c"many",
            vk::LayerSettingTypeEXT::UINT32,
            values.len() as u32,
            values.as_ptr().cast(),
        );
        let settings = vec![many; MAX_SETTINGS + 2];
        let info = vk::LayerSettingsCreateInfoEXT {
            setting_count: settings.len() as u32,
            p_settings: settings.as_ptr(),
            ..Default::default()
        };
        let null_settings = vk::LayerSettingsCreateInfoEXT {
            p_next: as_next(&info),
            setting_count: u32::MAX,
            ..Default::default()
        };
        // SAFETY: `null_settings` has NULL pSettings (nothing to read);
        // `info` holds `settingCount` settings of `valueCount` values.
        let read = unsafe { layer_settings(as_next(&null_settings), layer) };
        assert_eq!(read.len(), MAX_SETTINGS);
        assert!(read.iter().all(|(_, v)| v.len() == MAX_VALUES));
    }

    #[test]
    fn arrays_are_read_for_their_count_and_empty_for_null() {
        let list = [1u32, 2, 3];
        // SAFETY: three elements; NULL is allowed.
        assert_eq!(unsafe { array(list.as_ptr(), 3) }, &list);
        assert_eq!(unsafe { array(list.as_ptr(), 2) }, &list[..2]);
        assert!(unsafe { array::<u32>(ptr::null(), u32::MAX) }.is_empty());
    }

    #[test]
    fn submitted_command_buffers_are_gathered_from_every_submit() {
        let a: [vk::CommandBuffer; 2] = [vk::Handle::from_raw(1), vk::Handle::from_raw(2)];
        let b: [vk::CommandBuffer; 1] = [vk::Handle::from_raw(3)];
        let first = vk::SubmitInfo::default().command_buffers(&a);
        let second = vk::SubmitInfo::default().command_buffers(&b);
        let empty = vk::SubmitInfo {
            command_buffer_count: u32::MAX,
            ..Default::default()
        };
        let submits = [first, empty, second];
        // SAFETY: three submits, each valid for its count (or NULL).
        let got = unsafe { submitted_command_buffers(3, submits.as_ptr()) };
        assert_eq!(got, [a[0], a[1], b[0]]);
        // SAFETY: NULL pSubmits is not read.
        assert!(unsafe { submitted_command_buffers(5, ptr::null()) }.is_empty());

        let infos: Vec<vk::CommandBufferSubmitInfo<'_>> = a
            .iter()
            .chain(&b)
            .map(|&cb| vk::CommandBufferSubmitInfo::default().command_buffer(cb))
            .collect();
        let first2 = vk::SubmitInfo2::default().command_buffer_infos(&infos);
        let empty2 = vk::SubmitInfo2 {
            command_buffer_info_count: 9,
            ..Default::default()
        };
        let submits2 = [empty2, first2];
        // SAFETY: two submits, each valid for its count (or NULL).
        let got = unsafe { submitted_command_buffers2(2, submits2.as_ptr()) };
        assert_eq!(got, [a[0], a[1], b[0]]);
    }

    #[test]
    fn signals_pair_semaphores_with_their_timeline_values() {
        let semaphores: [vk::Semaphore; 2] = [vk::Handle::from_raw(7), vk::Handle::from_raw(8)];
        // One value for two semaphores: the second gets 0.
        let values = [5u64];
        let timeline = vk::TimelineSemaphoreSubmitInfo {
            signal_semaphore_value_count: 1,
            p_signal_semaphore_values: values.as_ptr(),
            ..Default::default()
        };
        let mut with_values = vk::SubmitInfo::default().signal_semaphores(&semaphores);
        with_values.p_next = as_next(&timeline);
        let binary = vk::SubmitInfo::default().signal_semaphores(&semaphores[..1]);
        let submits = [with_values, binary];
        // SAFETY: two submits, each valid for its counts; the chain holds
        // one timeline structure.
        let got = unsafe { submitted_signals(2, submits.as_ptr()) };
        assert_eq!(got, [(7, 5), (8, 0), (7, 0)]);
        // SAFETY: NULL pSubmits is not read.
        assert!(unsafe { submitted_signals(3, ptr::null()) }.is_empty());

        let infos = [
            vk::SemaphoreSubmitInfo::default()
                .semaphore(semaphores[1])
                .value(9),
            vk::SemaphoreSubmitInfo::default()
                .semaphore(semaphores[0])
                .value(3),
        ];
        let submit2 = vk::SubmitInfo2::default().signal_semaphore_infos(&infos);
        // SAFETY: one submit, valid for its count.
        let got = unsafe { submitted_signals2(1, &submit2) };
        assert_eq!(got, [(8, 9), (7, 3)]);
    }

    #[test]
    fn batches_keep_each_submit_s_waits_command_buffers_and_signals() {
        let semaphores: [vk::Semaphore; 2] = [vk::Handle::from_raw(7), vk::Handle::from_raw(8)];
        let command_buffers: [vk::CommandBuffer; 1] = [vk::Handle::from_raw(0xcb)];
        let (wait_values, signal_values) = ([4u64], [0u64, 6]);
        let timeline = vk::TimelineSemaphoreSubmitInfo::default()
            .wait_semaphore_values(&wait_values)
            .signal_semaphore_values(&signal_values);
        let stages = [vk::PipelineStageFlags::ALL_COMMANDS];
        let mut submit = vk::SubmitInfo::default()
            .wait_semaphores(&semaphores[..1])
            .wait_dst_stage_mask(&stages)
            .command_buffers(&command_buffers)
            .signal_semaphores(&semaphores);
        submit.p_next = as_next(&timeline);
        let empty = vk::SubmitInfo {
            command_buffer_count: 3,
            ..Default::default()
        };
        let op = |semaphore, value| SemaphoreOp {
            semaphore,
            value,
            timeline: value != 0,
        };
        // SAFETY: two submits, each valid for its counts (or NULL arrays).
        let got = unsafe { submitted_batches(2, [submit, empty].as_ptr()) };
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].waits, [op(7, 4)]);
        assert_eq!(got[0].command_buffers, [0xcb]);
        assert_eq!(got[0].signals, [op(7, 0), op(8, 6)]);
        assert_eq!(got[1], SubmitBatch::default());
        // SAFETY: NULL pSubmits is not read.
        assert!(unsafe { submitted_batches(4, ptr::null()) }.is_empty());

        let waits = [vk::SemaphoreSubmitInfo::default()
            .semaphore(semaphores[1])
            .value(2)];
        let infos = [vk::CommandBufferSubmitInfo::default().command_buffer(command_buffers[0])];
        let submit2 = vk::SubmitInfo2::default()
            .wait_semaphore_infos(&waits)
            .command_buffer_infos(&infos);
        // SAFETY: one submit, valid for its counts.
        let got = unsafe { submitted_batches2(1, &submit2) };
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].waits, [op(8, 2)]);
        assert_eq!(got[0].command_buffers, [0xcb]);
        assert!(got[0].signals.is_empty());
    }

    #[test]
    fn chain_has_finds_a_structure_and_stops_on_a_cycle() {
        let mut first = vk::ValidationFeaturesEXT::default();
        let usage = vk::BufferUsageFlags2CreateInfoKHR::default();
        let first_at = ptr::addr_of_mut!(first);
        // SAFETY: `first_at` points to `first`.
        unsafe { (*first_at).p_next = as_next(&usage) };
        let head: *const c_void = first_at.cast_const().cast();
        let flags2 = vk::StructureType::BUFFER_USAGE_FLAGS_2_CREATE_INFO_KHR;
        // SAFETY: a well-formed chain of two structures.
        assert!(unsafe { chain_has(head, flags2) });
        // SAFETY: as above.
        assert!(!unsafe { chain_has(head, vk::StructureType::SUBMIT_INFO) });
        // SAFETY: the head points back at itself: walked once.
        unsafe { (*first_at).p_next = head };
        // SAFETY: a chain that loops back to its head.
        assert!(!unsafe { chain_has(head, flags2) });
        // SAFETY: NULL is not read.
        assert!(!unsafe { chain_has(ptr::null(), flags2) });
    }

    /// A next layer's `vkGetPhysicalDeviceQueueFamilyProperties` with 100
    /// families, each flagged by its index's parity: it writes no more than
    /// the count it is given, as the API requires.
    unsafe extern "system" fn hundred_families(
        _: vk::PhysicalDevice,
        count: *mut u32,
        properties: *mut vk::QueueFamilyProperties,
    ) {
        const FAMILIES: u32 = 100;
        // SAFETY: the caller passes a valid count (as the API requires).
        let count = unsafe { &mut *count };
        if properties.is_null() {
            *count = FAMILIES;
            return;
        }
        *count = (*count).min(FAMILIES);
        for k in 0..*count as usize {
            let flags = if k % 2 == 0 {
                vk::QueueFlags::GRAPHICS
            } else {
                vk::QueueFlags::TRANSFER
            };
            // SAFETY: `properties` holds `count` elements (the API's rule).
            unsafe { (*properties.add(k)).queue_flags = flags };
        }
    }

    #[test]
    fn queue_families_are_read_up_to_the_bound() {
        // SAFETY: the function follows the count-then-fill protocol.
        let flags = unsafe { queue_family_flags(hundred_families, vk::PhysicalDevice::null()) };
        assert_eq!(flags.len(), 64);
        assert_eq!(flags[0], vk::QueueFlags::GRAPHICS);
        assert_eq!(flags[63], vk::QueueFlags::TRANSFER);
    }

    #[test]
    fn mapped_bytes_copies_the_range() {
        let memory: Vec<u8> = (0..32).collect();
        let address = memory.as_ptr().expose_provenance();
        // SAFETY: bytes 4..12 of a live allocation whose provenance is exposed.
        let copy = unsafe { mapped_bytes(address + 4, 8) };
        assert_eq!(&copy[..], &memory[4..12]);
    }

    #[test]
    fn mapped_views_share_the_range_and_keep_their_owner() {
        let memory: Arc<Vec<u8>> = Arc::new((0..32).collect());
        let address = memory.as_ptr().expose_provenance();
        // SAFETY: bytes 4..12 of an allocation the view's owner keeps alive
        // and nothing writes; its provenance is exposed.
        let view = unsafe { mapped_view(Arc::clone(&memory), address + 4, 8) };
        assert_eq!(&view[..], &memory[4..12]);
        assert_eq!(view.as_ptr().addr(), address + 4, "not a copy");
        let tail = view.slice(6..);
        drop(view);
        assert_eq!(Arc::strong_count(&memory), 2, "a slice keeps the owner");
        assert_eq!(&tail[..], &[10, 11]);
        drop(tail);
        assert_eq!(Arc::strong_count(&memory), 1);
    }

    #[test]
    fn device_sizes_stop_where_the_data_ends() {
        let data: [u64; 3] = [10, 20, 30];
        let bytes = std::mem::size_of_val(&data);
        // SAFETY: `data` holds `bytes` readable bytes.
        let read = |size, stride, count| unsafe {
            device_sizes(data.as_ptr().cast(), size, stride, count)
        };
        assert_eq!(read(bytes, 8, 3), [10, 20, 30]);
        assert_eq!(read(bytes, 16, 3), [10, 30]);
        assert_eq!(read(bytes - 1, 8, 3), [10, 20]);
        assert_eq!(read(bytes, 8, u32::MAX), [10, 20, 30]);
        assert_eq!(read(bytes, usize::MAX, 2), [10]);
        // SAFETY: NULL is never read.
        assert!(unsafe { device_sizes(std::ptr::null(), 8, 8, 1) }.is_empty());
    }
}
