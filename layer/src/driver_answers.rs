//! The driver's answers the checks compare against (`ommcheck::driver`):
//! installing the device's [`NextLayerAnswers`] where the next layer can
//! answer, and keeping what it answered the application's own size and
//! compatibility queries, so what the application asked about costs the
//! layer no call at all.

#![allow(unsafe_code)]

use std::sync::Arc;

use ash::vk;
use ommcheck::driver::{BuildType, MicromapBuildShape, MicromapBuildSizes};

use crate::dispatch::memory_layout;
use crate::dispatch::next_layer_answers::NextLayerAnswers;
use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::device_and;
use crate::read;

/// Lets the checks ask the next layer, where the device enabled the
/// micromap feature and the next layer has `vkGetMicromapBuildSizesEXT` or
/// `vkGetDeviceMicromapCompatibilityEXT`.
pub fn install(data: &DeviceData) {
    let get_sizes = data.fns.accel.get_micromap_build_sizes;
    let get_compatibility = data.fns.accel.get_device_micromap_compatibility;
    if get_sizes.is_none() && get_compatibility.is_none() {
        return;
    }
    let mut state = data.state();
    if !state.validator.device().features.micromap_ext {
        return;
    }
    let answers = Arc::new(NextLayerAnswers::new(
        data.handle,
        get_sizes,
        get_compatibility,
    ));
    state.validator.set_driver_queries(answers.clone());
    state.driver_answers = Some(answers);
}

/// Keeps what the next layer answered the application's own
/// `vkGetMicromapBuildSizesEXT(device, build_type, build_info, size_info)`.
///
/// # Safety
/// The arguments of a call the next layer just returned from: `build_info`
/// valid as the API requires, `size_info` written.
pub unsafe fn remember(
    device: vk::Device,
    build_type: vk::AccelerationStructureBuildTypeKHR,
    build_info: *const vk::MicromapBuildInfoEXT<'_>,
    size_info: *const vk::MicromapBuildSizesInfoEXT<'_>,
) {
    let build_type = match build_type {
        vk::AccelerationStructureBuildTypeKHR::HOST => BuildType::Host,
        vk::AccelerationStructureBuildTypeKHR::DEVICE => BuildType::Device,
        // HOST_OR_DEVICE answers may differ from either; not kept.
        _ => return,
    };
    let Some((data, _)) = device_and(device, |f| f.accel.get_micromap_build_sizes) else {
        return;
    };
    // SAFETY: forwarded from the caller.
    let (Some(info), Some(sizes)) = (unsafe { read::value(build_info) }, unsafe {
        read::value(size_info)
    }) else {
        return;
    };
    let mut findings = Vec::new();
    // SAFETY: forwarded from the caller: the structure was valid for the
    // query, so its usage-count pointers are valid for their count.
    let model = unsafe {
        ommcheck::raw::micromap_build_info(
            &info,
            "vkGetMicromapBuildSizesEXT",
            "pBuildInfo",
            &mut findings,
        )
    };
    let state = data.state();
    let Some(kept) = state.driver_answers.as_ref() else {
        return;
    };
    if let Some(shape) = MicromapBuildShape::queryable(&model, state.validator.device()) {
        kept.keep_sizes(build_type, shape, MicromapBuildSizes::from(sizes));
    }
}

/// Keeps what the next layer answered the application's own
/// `vkGetDeviceMicromapCompatibilityEXT(device, version_info, compatibility)`.
///
/// # Safety
/// The arguments of a call the next layer just returned from: a non-NULL
/// `version_info` valid as the API requires (its `pVersionData` readable
/// for 2 × `VK_UUID_SIZE` bytes), `compatibility` written.
pub unsafe fn remember_compatibility(
    device: vk::Device,
    version_info: *const vk::MicromapVersionInfoEXT<'_>,
    compatibility: *const vk::AccelerationStructureCompatibilityKHR,
) {
    let Some((data, _)) = device_and(device, |f| f.accel.get_device_micromap_compatibility) else {
        return;
    };
    // SAFETY: forwarded from the caller.
    let (Some(info), Some(answer)) = (unsafe { read::value(version_info) }, unsafe {
        read::value(compatibility)
    }) else {
        return;
    };
    // SAFETY: forwarded from the caller: pVersionData holds the version.
    let Some(version) = (unsafe { read::value(info.p_version_data) }) else {
        return;
    };
    let state = data.state();
    if let Some(kept) = state.driver_answers.as_ref() {
        let compatible = answer == vk::AccelerationStructureCompatibilityKHR::COMPATIBLE;
        kept.keep_compatibility(version, compatible);
    }
}

/// Tells the checks where the application has mapped each destination of
/// a host build (`vkBuildMicromapsEXT`'s `pInfos`), so its scratch can be
/// checked against them (`VUID-vkBuildMicromapsEXT-dstMicromap-11668`);
/// what an earlier build was told is forgotten first.
///
/// # Safety
/// A non-NULL `infos` must point to `count` structures, as the API requires.
pub unsafe fn map_destinations(
    state: &mut DeviceState,
    count: u32,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
) {
    let mut mapped = std::mem::take(&mut state.validator.state_mut().mapped_micromaps);
    mapped.clear();
    // SAFETY: forwarded from the caller; at most `read::MAX_ELEMENTS` read.
    for info in unsafe { read::array(infos, count) } {
        let handle = vk::Handle::as_raw(info.dst_micromap);
        let Some(micromap) = state.validator.state().micromaps.get(&handle) else {
            continue;
        };
        let (buffer, offset, size) = (micromap.buffer, micromap.offset, micromap.size);
        if let Some(address) = memory_layout::mapped_address(state, buffer, offset, size) {
            mapped.insert(handle, address as u64);
        }
    }
    state.validator.state_mut().mapped_micromaps = mapped;
}

/// Keeps the serialization sizes the next layer just wrote for the
/// application's `vkWriteMicromapsPropertiesEXT` (`VUID-VkCopyMicromapToMemoryInfoEXT-dst-07541`
/// compares serializations with them); other query types are left alone.
///
/// `written` is `(pData, dataSize, stride)`.
///
/// # Safety
/// The arguments of a call the next layer just returned `VK_SUCCESS` from.
pub unsafe fn remember_serialization_sizes(
    device: vk::Device,
    micromaps: &[vk::MicromapEXT],
    query_type: vk::QueryType,
    (data, data_size, stride): (*const std::ffi::c_void, usize, usize),
) {
    if query_type != vk::QueryType::MICROMAP_SERIALIZATION_SIZE_EXT {
        return;
    }
    let Some((data_of, _)) = device_and(device, |f| f.accel.write_micromaps_properties) else {
        return;
    };
    let count = u32::try_from(micromaps.len()).unwrap_or(u32::MAX);
    // SAFETY: forwarded from the caller.
    let sizes = unsafe { read::device_sizes(data, data_size, stride, count) };
    let mut state = data_of.state();
    let driver = &mut state.validator.state_mut().driver;
    for (micromap, size) in micromaps.iter().zip(sizes) {
        driver.report_serialization_size(vk::Handle::as_raw(*micromap), size);
    }
}
