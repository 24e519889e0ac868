//! The next layer's answers the checks compare against
//! (`ommcheck::driver`): the sizes `vkGetMicromapBuildSizesEXT` returns for
//! a micromap build's shape, and the compatibility
//! `vkGetDeviceMicromapCompatibilityEXT` answers for a version of
//! serialized micromap data. The layer asks the next layer once per
//! distinct shape and build type, and once per distinct version, and keeps
//! the answer ([`crate::driver_answers`] keeps the answers to the
//! application's own queries here too).

#![allow(unsafe_code)]

use std::sync::{Mutex, PoisonError};

use ash::vk;
use foldhash::HashMap;
use ommcheck::driver::{
    BuildType, DriverQueries, MicromapBuildShape, MicromapBuildSizes, MicromapVersion,
};

use crate::own_calls::{self, OwnCall};

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
    /// Answers for `device` from the next layer's functions (those it has).
    pub fn new(
        device: vk::Device,
        get_sizes: Option<vk::PFN_vkGetMicromapBuildSizesEXT>,
        get_compatibility: Option<vk::PFN_vkGetDeviceMicromapCompatibilityEXT>,
    ) -> Self {
        Self {
            device,
            get_sizes,
            get_compatibility,
            sizes: Kept::new(),
            compatibility: Kept::new(),
        }
    }

    /// Keeps the sizes the next layer answered for `shape`.
    pub fn keep_sizes(
        &self,
        build_type: BuildType,
        shape: MicromapBuildShape,
        sizes: MicromapBuildSizes,
    ) {
        self.sizes.keep((build_type, shape), sizes);
    }

    /// Keeps whether the next layer answered `version` compatible.
    pub fn keep_compatibility(&self, version: MicromapVersion, compatible: bool) {
        self.compatibility.keep(version, compatible);
    }

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
        own_calls::call(OwnCall::MicromapBuildSizes, || {
            // SAFETY: the next layer's function with its own device, a
            // build info valid in every member the query reads (`queryable`
            // shapes only; `usages` lives across the call) and a structure
            // to fill.
            unsafe {
                get(
                    self.device,
                    vk::AccelerationStructureBuildTypeKHR::from_raw(build_type.as_raw()),
                    &info,
                    &mut sizes,
                )
            }
        });
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
        own_calls::call(OwnCall::MicromapCompatibility, || {
            // SAFETY: the next layer's function with its own device, a
            // version info whose data (2 × VK_UUID_SIZE bytes) lives across
            // the call, and a value to fill.
            unsafe { get(self.device, &info, &mut compatibility) }
        });
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
