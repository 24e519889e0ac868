//! Reading the create infos of the objects an adaptor tracks for the checks
//! (devices, buffers, micromaps) from the ash structures an application
//! hands the driver. Like the rest of [`crate::raw`], every array read is
//! bounded and every pNext chain walked with `chain`.

use std::ffi::c_void;

use ash::vk;

use super::generated::{micromap_create_info, read_features};
use super::{bounded_len, chain, read_array};
use crate::device::{Device, Features, Limits};
use crate::model::micromap_objects::AllocationCallbacks;
use crate::report::{Finding, Report};
use crate::state::Buffer;
use crate::Validator;

/// `VK_MAX_EXTENSION_NAME_SIZE`: the longest extension name, NUL included.
const MAX_EXTENSION_NAME: usize = 256;

/// Reads a NUL-terminated name of at most [`MAX_EXTENSION_NAME`] bytes;
/// None for a NULL pointer, a name without a NUL in that many bytes, or one
/// that is not UTF-8.
///
/// # Safety
/// A non-NULL `name` must point to a NUL-terminated string, as the API
/// requires of extension names.
unsafe fn extension_name(name: *const std::ffi::c_char) -> Option<String> {
    if name.is_null() {
        return None;
    }
    let mut bytes = Vec::new();
    for i in 0..MAX_EXTENSION_NAME {
        // SAFETY: the string is NUL-terminated and the loop stops at the NUL,
        // so every byte read is at or before it.
        let byte = unsafe { *name.add(i) } as u8;
        if byte == 0 {
            return String::from_utf8(bytes).ok();
        }
        bytes.push(byte);
    }
    None
}

/// Reads one feature structure of type `T` at `address`.
///
/// # Safety
/// `address` must point to a readable `T` (the sType said so).
unsafe fn feature<T: Copy>(address: *const c_void) -> T {
    // SAFETY: forwarded from the caller.
    unsafe { *address.cast::<T>() }
}

/// The device a `VkDeviceCreateInfo` creates: its enabled extensions, the
/// features chained in its pNext (`VkPhysicalDevice*Features` structures the
/// checks read, and `VkPhysicalDeviceVulkan12Features`/`13Features`), its
/// queue count and device-group size, with `limits` (which no create info
/// carries) and `handle`, the `VkDevice` the call returned. Findings say
/// where a read was cut short.
///
/// # Safety
/// `info` must be valid as `vkCreateDevice` requires: its arrays valid for
/// their counts, extension names NUL-terminated, its pNext chain well formed
/// (cycles and length are tolerated).
pub unsafe fn device_from_create_info(
    info: &vk::DeviceCreateInfo<'_>,
    limits: Limits,
    handle: vk::Device,
) -> (Device, Vec<Finding>) {
    let function = "vkCreateDevice";
    let mut findings = Vec::new();
    // SAFETY: the caller guarantees the array holds `enabled_extension_count` pointers.
    let names = unsafe {
        read_array(
            info.pp_enabled_extension_names,
            info.enabled_extension_count,
            function,
            "pCreateInfo->ppEnabledExtensionNames",
            &mut findings,
        )
    };
    let extensions = names
        .unwrap_or_default()
        .into_iter()
        // SAFETY: each name is NUL-terminated (the caller's guarantee).
        .filter_map(|name| unsafe { extension_name(name) })
        .collect();
    // SAFETY: the caller guarantees the array holds `queue_create_info_count` elements.
    let queues = unsafe {
        read_array(
            info.p_queue_create_infos,
            info.queue_create_info_count,
            function,
            "pCreateInfo->pQueueCreateInfos",
            &mut findings,
        )
    };
    let queue_count = queues
        .unwrap_or_default()
        .iter()
        .fold(0u32, |sum, q| sum.saturating_add(q.queue_count));
    let mut features = Features::default();
    let mut physical_device_count = 1;
    // SAFETY: the caller guarantees a well-formed chain.
    let links = unsafe { chain(info.p_next, function, "pCreateInfo", &mut findings) };
    for link in links {
        let at = link.address;
        // SAFETY: the structure's sType names its type, so `at` points to a
        // structure of that type (here and below).
        if unsafe { read_features(link.s_type, at, &mut features) } {
            continue;
        }
        if vk::StructureType::from_raw(link.s_type)
            == vk::StructureType::DEVICE_GROUP_DEVICE_CREATE_INFO
        {
            // SAFETY: as above.
            let group: vk::DeviceGroupDeviceCreateInfo<'_> = unsafe { feature(at) };
            physical_device_count = group.physical_device_count.max(1);
        }
    }
    let device = Device {
        extensions,
        features,
        limits,
        physical_device_count,
        handle: vk::Handle::as_raw(handle),
        queue_count,
    };
    (device, findings)
}

/// The buffer a `VkBufferCreateInfo` creates: size, usage (from a chained
/// `VkBufferUsageFlags2CreateInfoKHR` when there is one, as maintenance5
/// says) and flags; not yet bound, no known address or contents.
///
/// # Safety
/// `info`'s pNext chain must be well formed (cycles and length are tolerated).
pub unsafe fn buffer_from_create_info(info: &vk::BufferCreateInfo<'_>) -> (Buffer, Vec<Finding>) {
    let mut findings = Vec::new();
    let mut usage = u64::from(info.usage.as_raw());
    // SAFETY: the caller guarantees a well-formed chain.
    for link in unsafe { chain(info.p_next, "vkCreateBuffer", "pCreateInfo", &mut findings) } {
        if link.s_type == vk::StructureType::BUFFER_USAGE_FLAGS_2_CREATE_INFO_KHR.as_raw() {
            // SAFETY: the sType says the structure is a VkBufferUsageFlags2CreateInfoKHR.
            let flags2: vk::BufferUsageFlags2CreateInfoKHR<'_> = unsafe { feature(link.address) };
            usage = flags2.usage.as_raw();
        }
    }
    let buffer = Buffer {
        size: info.size,
        usage,
        create_flags: info.flags.as_raw(),
        ..Default::default()
    };
    (buffer, findings)
}

/// `VkAllocationCallbacks` as the model keeps them (function pointers as numbers).
///
/// # Safety
/// A non-NULL `allocator` must point to a readable `VkAllocationCallbacks`.
pub unsafe fn allocation_callbacks(
    allocator: *const vk::AllocationCallbacks<'_>,
) -> Option<AllocationCallbacks> {
    // SAFETY: forwarded from the caller.
    let callbacks = unsafe { allocator.as_ref() }?;
    let address = |f: Option<usize>| f.map_or(0, |f| f as u64);
    Some(AllocationCallbacks {
        pfn_allocation: address(callbacks.pfn_allocation.map(|f| f as usize)),
        pfn_reallocation: address(callbacks.pfn_reallocation.map(|f| f as usize)),
        pfn_free: address(callbacks.pfn_free.map(|f| f as usize)),
        pfn_internal_allocation: address(callbacks.pfn_internal_allocation.map(|f| f as usize)),
        pfn_internal_free: address(callbacks.pfn_internal_free.map(|f| f as usize)),
    })
}

impl Validator {
    /// Checks `vkCreateMicromapEXT(device, pCreateInfo, pAllocator,
    /// pMicromap)` as a layer receives it, before the driver runs:
    /// `micromap_requested` says whether `pMicromap` is non-NULL. Nothing is
    /// recorded; once the driver has created the micromap, call
    /// [`Validator::record_micromap`].
    ///
    /// # Safety
    /// A non-NULL `info` must point to a `VkMicromapCreateInfoEXT` with a
    /// well-formed pNext chain, a non-NULL `allocator` to a readable
    /// `VkAllocationCallbacks`.
    pub unsafe fn create_micromap_raw(
        &mut self,
        device: vk::Device,
        info: *const vk::MicromapCreateInfoEXT<'_>,
        allocator: *const vk::AllocationCallbacks<'_>,
        micromap_requested: bool,
    ) -> Report {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe { info.as_ref() }
            // SAFETY: forwarded from the caller.
            .map(|info| unsafe {
                micromap_create_info(info, "vkCreateMicromapEXT", "pCreateInfo", &mut findings)
            });
        // SAFETY: forwarded from the caller.
        let callbacks = unsafe { allocation_callbacks(allocator) };
        // The rules alone: the layer records the handle the driver returns
        // (`record_micromap_raw`).
        let report = self.create_micromap_rules(
            vk::Handle::as_raw(device),
            model.as_ref(),
            callbacks.as_ref(),
            micromap_requested.then_some(0),
        );
        let mut out = Report::from(findings);
        out.extend(report);
        out
    }

    /// Records the micromap `vkCreateMicromapEXT` created, without checking
    /// the call again (see [`Self::create_micromap_raw`]).
    ///
    /// # Safety
    /// As for [`Self::create_micromap_raw`].
    pub unsafe fn record_micromap_raw(
        &mut self,
        info: &vk::MicromapCreateInfoEXT<'_>,
        with_allocator: bool,
        micromap: vk::MicromapEXT,
    ) {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe {
            micromap_create_info(info, "vkCreateMicromapEXT", "pCreateInfo", &mut findings)
        };
        self.record_micromap(vk::Handle::as_raw(micromap), &model, with_allocator);
    }

    /// Checks `vkDestroyMicromapEXT(device, micromap, pAllocator)` as a layer
    /// receives it, and stops tracking the micromap.
    ///
    /// # Safety
    /// A non-NULL `allocator` must point to a readable `VkAllocationCallbacks`.
    pub unsafe fn destroy_micromap_raw(
        &mut self,
        device: vk::Device,
        micromap: vk::MicromapEXT,
        allocator: *const vk::AllocationCallbacks<'_>,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        let report = unsafe { self.destroy_micromap_rules_raw(device, micromap, allocator) };
        self.record_micromap_destroyed(vk::Handle::as_raw(micromap));
        report
    }

    /// The rules of `vkDestroyMicromapEXT(device, micromap, pAllocator)`,
    /// before the call; records nothing (a layer records the destruction
    /// after the call with [`Validator::record_micromap_destroyed`]).
    ///
    /// # Safety
    /// As [`Self::destroy_micromap_raw`].
    pub unsafe fn destroy_micromap_rules_raw(
        &self,
        device: vk::Device,
        micromap: vk::MicromapEXT,
        allocator: *const vk::AllocationCallbacks<'_>,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        let callbacks = unsafe { allocation_callbacks(allocator) };
        self.destroy_micromap_rules(
            vk::Handle::as_raw(device),
            vk::Handle::as_raw(micromap),
            callbacks.as_ref(),
        )
    }
}

/// Reads `count` elements of an application array of binds (buffer,
/// memory, memoryOffset), at most [`super::MAX_ELEMENTS`]; empty for NULL.
///
/// # Safety
/// A non-NULL `binds` must point to `count` readable elements.
pub unsafe fn bind_buffer_memory_infos(
    count: u32,
    binds: *const vk::BindBufferMemoryInfo<'_>,
) -> Vec<(vk::Buffer, vk::DeviceMemory, vk::DeviceSize)> {
    if binds.is_null() {
        return Vec::new();
    }
    let len = bounded_len(count, "vkBindBufferMemory2", "pBindInfos", &mut Vec::new());
    // SAFETY: the caller guarantees `count` elements; `len <= count`.
    unsafe { std::slice::from_raw_parts(binds, len) }
        .iter()
        .map(|bind| (bind.buffer, bind.memory, bind.memory_offset))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Profile;

    #[test]
    fn device_features_come_from_the_chain() {
        let mut omm = vk::PhysicalDeviceOpacityMicromapFeaturesEXT {
            micromap: vk::TRUE,
            micromap_host_commands: vk::TRUE,
            ..Default::default()
        };
        let mut v12 = vk::PhysicalDeviceVulkan12Features {
            buffer_device_address: vk::TRUE,
            ..Default::default()
        };
        let names = [c"VK_EXT_opacity_micromap".as_ptr()];
        let priorities = [1.0f32];
        let queues = [
            vk::DeviceQueueCreateInfo::default().queue_priorities(&priorities),
            vk::DeviceQueueCreateInfo::default().queue_priorities(&priorities),
        ];
        // Chained by hand: ash 0.38's push_next breaks Stacked Borrows (it
        // keeps a shared pointer across a `&mut` reborrow), which Miri reports.
        v12.p_next = (&raw mut omm).cast();
        let mut info = vk::DeviceCreateInfo::default()
            .enabled_extension_names(&names)
            .queue_create_infos(&queues);
        info.p_next = (&raw mut v12).cast();
        // SAFETY: `info` and everything it points to is alive.
        let (device, findings) = unsafe {
            device_from_create_info(
                &info,
                Profile::SpecMinimum.limits(),
                vk::Handle::from_raw(7),
            )
        };
        assert!(findings.is_empty());
        assert!(device.has_extension("VK_EXT_opacity_micromap"));
        assert_eq!(device.extensions.len(), 1);
        assert!(device.features.micromap_ext && device.features.micromap_host_commands);
        assert!(!device.features.micromap_capture_replay && !device.features.micromap_khr);
        assert!(device.features.buffer_device_address);
        assert_eq!((device.queue_count, device.handle), (2, 7));
    }

    #[test]
    fn buffer_usage2_replaces_the_usage() {
        let mut usage2 = vk::BufferUsageFlags2CreateInfoKHR {
            usage: vk::BufferUsageFlags2KHR::from_raw(1 << 40),
            ..Default::default()
        };
        // Chained by hand: ash 0.38's push_next breaks Stacked Borrows (it
        // keeps a shared pointer across a `&mut` reborrow), which Miri reports.
        let mut info = vk::BufferCreateInfo::default()
            .size(64)
            .usage(vk::BufferUsageFlags::STORAGE_BUFFER);
        info.p_next = (&raw mut usage2).cast();
        // SAFETY: the chain holds one live structure.
        let (buffer, _) = unsafe { buffer_from_create_info(&info) };
        assert_eq!((buffer.size, buffer.usage), (64, 1 << 40));
        let plain = vk::BufferCreateInfo::default().usage(vk::BufferUsageFlags::STORAGE_BUFFER);
        // SAFETY: no chain.
        let (buffer, _) = unsafe { buffer_from_create_info(&plain) };
        assert_eq!(buffer.usage, 0x20);
    }

    #[test]
    fn a_micromap_is_checked_before_and_recorded_after_creation() {
        let mut v = Validator::new(crate::Device::with_everything(Profile::SpecMinimum));
        v.state_mut().buffers.insert(
            5,
            Buffer {
                size: 256,
                usage: vk::BufferUsageFlags::MICROMAP_STORAGE_EXT.as_raw().into(),
                memory: Some(Default::default()),
                ..Default::default()
            },
        );
        let info = vk::MicromapCreateInfoEXT {
            buffer: vk::Handle::from_raw(5),
            size: 256,
            ..Default::default()
        };
        let device = vk::Handle::from_raw(1);
        // SAFETY: `info` is alive and has no chain; no allocator.
        let report = unsafe { v.create_micromap_raw(device, &info, std::ptr::null(), true) };
        assert!(report.is_empty(), "{report}");
        assert!(v.state().micromaps.is_empty());
        // SAFETY: as above.
        unsafe { v.record_micromap_raw(&info, false, vk::Handle::from_raw(9)) };
        assert_eq!(v.state().micromaps[&9].size, 256);
        // SAFETY: no allocator.
        let report =
            unsafe { v.destroy_micromap_raw(device, vk::Handle::from_raw(9), std::ptr::null()) };
        assert!(report.is_empty(), "{report}");
        assert!(v.state().micromaps.is_empty());
    }
}
