//! The driver's answers the checks compare against: the sizes
//! `vkGetMicromapBuildSizesEXT` returns for a micromap build's shape, and
//! the compatibility `vkGetDeviceMicromapCompatibilityEXT` answers for a
//! version of serialized micromap data (`ommcheck::driver`). The layer asks
//! the next layer once per distinct shape and build type, and once per
//! distinct version, and keeps the answer; an answer the application's own
//! query got is kept too, so what it asked about costs the layer no call
//! at all.

#![allow(unsafe_code)]

use std::sync::{Arc, Mutex, PoisonError};

use ash::vk;
use foldhash::HashMap;
use ommcheck::driver::{
    BuildType, DriverQueries, MicromapBuildShape, MicromapBuildSizes, MicromapVersion,
};

use crate::dispatch::memory_layout;
use crate::dispatch::{DeviceData, DeviceState};
use crate::intercept::device_and;
use crate::read;

/// At most this many answers of each kind are kept per device; past it the
/// driver is asked each time for a new shape or version (an application
/// builds few shapes and deserializes data of few versions; shape keys are
/// small, [`ommcheck::driver::MAX_SHAPE_USAGES`] usage counts at most).
pub const MAX_KEPT_ANSWERS: usize = 4096;

type Key = (BuildType, MicromapBuildShape);

/// Answers kept by what they answer, at most [`MAX_KEPT_ANSWERS`].
#[derive(Debug)]
struct Kept<K, V>(Mutex<HashMap<K, V>>);

impl<K: std::hash::Hash + Eq, V: Copy> Kept<K, V> {
    fn new() -> Self {
        Self(Mutex::default())
    }

    fn get(&self, key: &K) -> Option<V> {
        let kept = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        kept.get(key).copied()
    }

    /// Keeps `value` as the answer for `key`, within [`MAX_KEPT_ANSWERS`].
    fn keep(&self, key: K, value: V) {
        let mut kept = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        if kept.len() < MAX_KEPT_ANSWERS || kept.contains_key(&key) {
            kept.insert(key, value);
        }
    }
}

/// Asks the next layer's `vkGetMicromapBuildSizesEXT` and
/// `vkGetDeviceMicromapCompatibilityEXT` (those it has), keeping their
/// answers.
#[derive(Debug)]
pub struct NextLayerAnswers {
    device: vk::Device,
    get_sizes: Option<vk::PFN_vkGetMicromapBuildSizesEXT>,
    get_compatibility: Option<vk::PFN_vkGetDeviceMicromapCompatibilityEXT>,
    sizes: Kept<Key, MicromapBuildSizes>,
    compatibility: Kept<MicromapVersion, bool>,
}

impl NextLayerAnswers {
    /// Calls the next layer with a structure made from `shape` alone (no
    /// addresses, no destination: the query reads neither).
    fn ask_sizes(
        &self,
        get: vk::PFN_vkGetMicromapBuildSizesEXT,
        build_type: BuildType,
        shape: &MicromapBuildShape,
    ) -> MicromapBuildSizes {
        let usages: Vec<vk::MicromapUsageEXT> = shape
            .usages
            .iter()
            .map(|u| vk::MicromapUsageEXT {
                count: u.count,
                subdivision_level: u.subdivision_level,
                format: u.format,
            })
            .collect();
        let info = vk::MicromapBuildInfoEXT {
            ty: vk::MicromapTypeEXT::from_raw(shape.ty),
            flags: vk::BuildMicromapFlagsEXT::from_raw(shape.flags),
            mode: vk::BuildMicromapModeEXT::BUILD,
            usage_counts_count: u32::try_from(usages.len()).unwrap_or(0),
            p_usage_counts: usages.as_ptr(),
            ..Default::default()
        };
        let mut sizes = vk::MicromapBuildSizesInfoEXT::default();
        // SAFETY: the next layer's function with its own device, a build
        // info valid in every member the query reads (`queryable` shapes
        // only; `usages` lives across the call) and a structure to fill.
        unsafe {
            get(
                self.device,
                vk::AccelerationStructureBuildTypeKHR::from_raw(build_type.as_raw()),
                &info,
                &mut sizes,
            )
        };
        MicromapBuildSizes::from(sizes)
    }

    /// Calls the next layer with `version` as the version data.
    fn ask_compatibility(
        &self,
        get: vk::PFN_vkGetDeviceMicromapCompatibilityEXT,
        version: &MicromapVersion,
    ) -> bool {
        let info = vk::MicromapVersionInfoEXT {
            p_version_data: version,
            ..Default::default()
        };
        let mut compatibility = vk::AccelerationStructureCompatibilityKHR::INCOMPATIBLE;
        // SAFETY: the next layer's function with its own device, a version
        // info whose data (2 × VK_UUID_SIZE bytes) lives across the call,
        // and a value to fill.
        unsafe { get(self.device, &info, &mut compatibility) };
        compatibility == vk::AccelerationStructureCompatibilityKHR::COMPATIBLE
    }
}

impl DriverQueries for NextLayerAnswers {
    fn micromap_build_sizes(
        &self,
        build_type: BuildType,
        shape: &MicromapBuildShape,
    ) -> Option<MicromapBuildSizes> {
        let key = (build_type, shape.clone());
        if let Some(sizes) = self.sizes.get(&key) {
            return Some(sizes);
        }
        // Asked without the lock held: the next layer may take its time.
        let sizes = self.ask_sizes(self.get_sizes?, build_type, shape);
        self.sizes.keep(key, sizes);
        Some(sizes)
    }

    fn micromap_compatibility(&self, version: &MicromapVersion) -> Option<bool> {
        if let Some(compatible) = self.compatibility.get(version) {
            return Some(compatible);
        }
        let compatible = self.ask_compatibility(self.get_compatibility?, version);
        self.compatibility.keep(*version, compatible);
        Some(compatible)
    }
}

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
    let answers = Arc::new(NextLayerAnswers {
        device: data.handle,
        get_sizes,
        get_compatibility,
        sizes: Kept::new(),
        compatibility: Kept::new(),
    });
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
        kept.sizes
            .keep((build_type, shape), MicromapBuildSizes::from(sizes));
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
        kept.compatibility.keep(version, compatible);
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
