//! The driver's answers: sizes only the implementation computes
//! (`vkGetMicromapBuildSizesEXT`'s `micromapSize` and `buildScratchSize`),
//! and whether it accepts serialized micromap data
//! (`vkGetDeviceMicromapCompatibilityEXT`), which some rules compare the
//! application's objects against.
//!
//! Answers come from two places: stated ones (a scene's `driverAnswers`, or
//! [`crate::Validator::set_micromap_build_sizes`] in a unit test), and a
//! [`DriverQueries`] an adaptor installs that asks the driver itself (the
//! layer asks the next layer and caches the answer per shape). Without
//! either, the rules that need an answer are not decided, as before.

use std::collections::{BTreeMap, HashMap};
use std::fmt::Debug;
use std::sync::Arc;

use crate::device::Device;
use crate::model::micromap::{MicromapBuildInfo, MicromapUsage};
use crate::model::values::*;
use crate::model::Handle;

/// A shape holds at most this many usage counts: a valid opacity build has
/// at most 2 formats x 13 levels of distinct ones, a displacement build
/// 3 x 6, so a longer list repeats entries; no answer is looked up or asked
/// for it, and a cache keyed by shapes holds keys of bounded size.
pub const MAX_SHAPE_USAGES: usize = 64;

/// The version of serialized micromap data: its first 2 × `VK_UUID_SIZE`
/// bytes (the driver UUID, then the compatibility data), what
/// `VkMicromapVersionInfoEXT::pVersionData` points to.
pub type MicromapVersion = [u8; 32];

/// `vkGetMicromapBuildSizesEXT`'s `buildType`: which kind of build the sizes
/// are for (`VkAccelerationStructureBuildTypeKHR`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum BuildType {
    /// `VK_ACCELERATION_STRUCTURE_BUILD_TYPE_HOST_KHR` (`vkBuildMicromapsEXT`).
    Host,
    /// `VK_ACCELERATION_STRUCTURE_BUILD_TYPE_DEVICE_KHR` (`vkCmdBuildMicromapsEXT`).
    Device,
}

impl BuildType {
    /// The `VkAccelerationStructureBuildTypeKHR` value.
    pub fn as_raw(self) -> i32 {
        match self {
            BuildType::Host => 0,
            BuildType::Device => 1,
        }
    }
}

/// What `vkGetMicromapBuildSizesEXT` reads of a `VkMicromapBuildInfoEXT`:
/// the type, the flags and the usage counts (it ignores the addresses and
/// `dstMicromap`). Two builds of one shape get the same answer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct MicromapBuildShape {
    /// `VkMicromapTypeEXT`.
    pub ty: i32,
    /// `VkBuildMicromapFlagsEXT`.
    pub flags: u32,
    /// The usage counts, in the order the structure lists them.
    pub usages: Vec<MicromapUsage>,
}

impl MicromapBuildShape {
    /// The shape of `info` as stated (no validity asked): what a scene's
    /// answer or a test's is matched against.
    pub fn of(info: &MicromapBuildInfo) -> Self {
        Self {
            ty: info.ty,
            flags: info.flags,
            usages: info.usage_counts.usages_read().map(|(_, u)| u).collect(),
        }
    }

    /// The shape of `info` when the driver may be asked about it: a
    /// structure valid in every member `vkGetMicromapBuildSizesEXT` reads
    /// (sType, no pNext, a defined type and flags, one usage-count list of
    /// the stated length without NULL elements, formats and levels the
    /// device supports) and at most [`MAX_SHAPE_USAGES`] usage counts.
    /// Asking with an invalid structure would itself be invalid usage, and
    /// the driver may crash on it; such a build's other rules report it.
    pub fn queryable(info: &MicromapBuildInfo, device: &Device) -> Option<Self> {
        let counts = &info.usage_counts;
        let listed = match (&counts.array, &counts.pointers) {
            (Some(array), None) => array.len(),
            (None, Some(pointers)) if pointers.iter().all(Option::is_some) => pointers.len(),
            (None, None) => 0,
            _ => return None,
        };
        let limits = &device.limits;
        let usage_ok = |u: &MicromapUsage| match info.ty {
            MICROMAP_TYPE_OPACITY_MICROMAP_EXT => match u.format {
                OPACITY_MICROMAP_FORMAT_2_STATE => {
                    u.subdivision_level <= limits.max_opacity2_state_subdivision_level
                }
                OPACITY_MICROMAP_FORMAT_4_STATE => {
                    u.subdivision_level <= limits.max_opacity4_state_subdivision_level
                }
                _ => false,
            },
            MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV => {
                DISPLACEMENT_MICROMAP_FORMATS_NV.contains(&u.format)
                    && u.subdivision_level <= limits.max_displacement_micromap_subdivision_level
            }
            _ => false,
        };
        let ok = info.s_type == STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT
            && info.next.is_empty()
            && info.flags & !BUILD_MICROMAP_FLAGS_ALL == 0
            && listed as u64 == u64::from(counts.count)
            && listed <= MAX_SHAPE_USAGES
            && device.features.micromap_ext
            && (info.ty == MICROMAP_TYPE_OPACITY_MICROMAP_EXT
                || (info.ty == MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV
                    && device.features.displacement_micromap))
            && counts.usages_read().all(|(_, u)| usage_ok(&u));
        ok.then(|| Self::of(info))
    }
}

/// `VkMicromapBuildSizesInfoEXT`: what the driver answered for a shape.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct MicromapBuildSizes {
    /// The size the micromap needs (`micromapSize`).
    pub micromap_size: u64,
    /// The scratch a build needs (`buildScratchSize`).
    pub build_scratch_size: u64,
    /// `discardable`.
    pub discardable: bool,
}

impl From<ash::vk::MicromapBuildSizesInfoEXT<'_>> for MicromapBuildSizes {
    fn from(sizes: ash::vk::MicromapBuildSizesInfoEXT<'_>) -> Self {
        Self {
            micromap_size: sizes.micromap_size,
            build_scratch_size: sizes.build_scratch_size,
            discardable: sizes.discardable != 0,
        }
    }
}

/// Asks the driver: an adaptor's way to answer what no stated answer does.
/// Called only with a shape [`MicromapBuildShape::queryable`] returned; None
/// when the driver cannot be asked (the function is not there).
pub trait DriverQueries: Send + Sync + Debug {
    /// `vkGetMicromapBuildSizesEXT(device, build_type, shape)`.
    fn micromap_build_sizes(
        &self,
        build_type: BuildType,
        shape: &MicromapBuildShape,
    ) -> Option<MicromapBuildSizes>;

    /// `vkGetDeviceMicromapCompatibilityEXT(device, version)`: whether the
    /// driver answers `VK_ACCELERATION_STRUCTURE_COMPATIBILITY_COMPATIBLE_KHR`.
    /// None where it cannot be asked (the default).
    fn micromap_compatibility(&self, version: &MicromapVersion) -> Option<bool> {
        let _ = version;
        None
    }
}

/// The driver's answers the checks use: those stated, then those the
/// installed [`DriverQueries`] gives.
#[derive(Clone, Debug, Default)]
pub struct DriverAnswers {
    /// Stated answers by shape; they hold for host and device builds alike.
    stated: HashMap<MicromapBuildShape, MicromapBuildSizes>,
    queries: Option<Arc<dyn DriverQueries>>,
    /// Serialization sizes stated for micromaps (a scene's, a test's).
    stated_serialization: BTreeMap<Handle, u64>,
    /// Serialization sizes the driver reported for micromaps as they are
    /// now (`vkWriteMicromapsPropertiesEXT` on the host); a build or the
    /// destruction of the micromap forgets its size.
    reported_serialization: BTreeMap<Handle, u64>,
    /// Stated compatibility answers by version: true for
    /// `VK_ACCELERATION_STRUCTURE_COMPATIBILITY_COMPATIBLE_KHR`.
    stated_compatibility: HashMap<MicromapVersion, bool>,
}

impl DriverAnswers {
    /// States the driver's answer for builds of `shape`.
    pub fn state_micromap_build_sizes(
        &mut self,
        shape: MicromapBuildShape,
        sizes: MicromapBuildSizes,
    ) {
        self.stated.insert(shape, sizes);
    }

    /// Installs the way to ask the driver for what was not stated.
    pub fn set_queries(&mut self, queries: Arc<dyn DriverQueries>) {
        self.queries = Some(queries);
    }

    /// States the serialization size of `micromap`, as
    /// `VK_QUERY_TYPE_MICROMAP_SERIALIZATION_SIZE_EXT` queries report it.
    pub fn state_serialization_size(&mut self, micromap: Handle, size: u64) {
        self.stated_serialization.insert(micromap, size);
    }

    /// Keeps the serialization size the driver just reported for
    /// `micromap`, until the micromap is built again or destroyed.
    pub fn report_serialization_size(&mut self, micromap: Handle, size: u64) {
        self.reported_serialization.insert(micromap, size);
    }

    /// Forgets what the driver reported of `micromap` (a build changes its
    /// serialization size; a destroyed handle may be reused).
    pub fn forget_micromap(&mut self, micromap: Handle) {
        self.reported_serialization.remove(&micromap);
    }

    /// The serialization size of `micromap`, where stated or reported.
    pub fn serialization_size(&self, micromap: Handle) -> Option<u64> {
        self.stated_serialization
            .get(&micromap)
            .or_else(|| self.reported_serialization.get(&micromap))
            .copied()
    }

    /// States the driver's compatibility answer for serialized data of
    /// `version`.
    pub fn state_micromap_compatibility(&mut self, version: MicromapVersion, compatible: bool) {
        self.stated_compatibility.insert(version, compatible);
    }

    /// Whether the driver accepts serialized data of `version`: a stated
    /// answer, else the driver's.
    pub fn micromap_compatibility(&self, version: &MicromapVersion) -> Option<bool> {
        if let Some(compatible) = self.stated_compatibility.get(version) {
            return Some(*compatible);
        }
        self.queries.as_ref()?.micromap_compatibility(version)
    }

    /// Whether a compatibility answer can come: one stated or a driver to ask.
    pub fn any_compatibility(&self) -> bool {
        !self.stated_compatibility.is_empty() || self.queries.is_some()
    }

    /// Whether any answer can come: something stated or a driver to ask.
    pub fn any(&self) -> bool {
        !self.stated.is_empty() || self.queries.is_some()
    }

    /// The sizes a `build_type` build of `info` needs, as far as the driver
    /// answered: a stated answer for its shape, else (for a queryable shape)
    /// the driver's.
    pub fn micromap_build_sizes(
        &self,
        build_type: BuildType,
        info: &MicromapBuildInfo,
        device: &Device,
    ) -> Option<MicromapBuildSizes> {
        // A longer list is no shape (see MAX_SHAPE_USAGES): nothing is
        // copied of it.
        let too_long = info
            .usage_counts
            .usages_read()
            .nth(MAX_SHAPE_USAGES)
            .is_some();
        if !self.any() || too_long {
            return None;
        }
        let shape = MicromapBuildShape::of(info);
        if let Some(sizes) = self.stated.get(&shape) {
            return Some(*sizes);
        }
        let queries = self.queries.as_ref()?;
        let shape = MicromapBuildShape::queryable(info, device)?;
        queries.micromap_build_sizes(build_type, &shape)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::micromap::UsageCounts;
    use crate::Profile;
    use std::sync::atomic::{AtomicU32, Ordering};

    #[derive(Debug, Default)]
    struct Counting(AtomicU32);

    impl DriverQueries for Counting {
        fn micromap_build_sizes(
            &self,
            _: BuildType,
            shape: &MicromapBuildShape,
        ) -> Option<MicromapBuildSizes> {
            self.0.fetch_add(1, Ordering::Relaxed);
            Some(MicromapBuildSizes {
                micromap_size: 100 * shape.usages.len() as u64,
                ..Default::default()
            })
        }
    }

    fn info(format: u32, level: u32) -> MicromapBuildInfo {
        MicromapBuildInfo {
            usage_counts: UsageCounts::array(vec![MicromapUsage {
                count: 2,
                subdivision_level: level,
                format,
            }]),
            ..Default::default()
        }
    }

    #[test]
    fn stated_answers_come_first_and_only_valid_shapes_are_asked() {
        let device = Device::with_everything(Profile::SpecMinimum);
        let mut answers = DriverAnswers::default();
        let good = info(OPACITY_MICROMAP_FORMAT_4_STATE, 1);
        assert_eq!(
            answers.micromap_build_sizes(BuildType::Device, &good, &device),
            None
        );
        let queries = Arc::new(Counting::default());
        answers.set_queries(queries.clone());
        assert_eq!(
            answers
                .micromap_build_sizes(BuildType::Device, &good, &device)
                .map(|s| s.micromap_size),
            Some(100)
        );
        // A format the driver does not know is never asked about.
        let bad = info(7, 1);
        assert_eq!(
            answers.micromap_build_sizes(BuildType::Device, &bad, &device),
            None
        );
        assert_eq!(queries.0.load(Ordering::Relaxed), 1);
        // A stated answer holds, for any shape, without asking.
        answers.state_micromap_build_sizes(
            MicromapBuildShape::of(&bad),
            MicromapBuildSizes {
                micromap_size: 7,
                ..Default::default()
            },
        );
        assert_eq!(
            answers
                .micromap_build_sizes(BuildType::Host, &bad, &device)
                .map(|s| s.micromap_size),
            Some(7)
        );
        assert_eq!(queries.0.load(Ordering::Relaxed), 1);
    }

    #[test]
    fn a_shape_is_queryable_only_within_the_bound() {
        let device = Device::with_everything(Profile::SpecMinimum);
        let usage = MicromapUsage {
            count: 1,
            subdivision_level: 0,
            format: OPACITY_MICROMAP_FORMAT_2_STATE,
        };
        let mut many = info(OPACITY_MICROMAP_FORMAT_2_STATE, 0);
        many.usage_counts = UsageCounts::array(vec![usage; MAX_SHAPE_USAGES]);
        assert!(MicromapBuildShape::queryable(&many, &device).is_some());
        many.usage_counts = UsageCounts::array(vec![usage; MAX_SHAPE_USAGES + 1]);
        assert!(MicromapBuildShape::queryable(&many, &device).is_none());
        // Nor is a stated answer looked up for it.
        let mut answers = DriverAnswers::default();
        answers.state_micromap_build_sizes(MicromapBuildShape::of(&many), Default::default());
        assert_eq!(
            answers.micromap_build_sizes(BuildType::Device, &many, &device),
            None
        );
        let mut both = info(OPACITY_MICROMAP_FORMAT_2_STATE, 0);
        both.usage_counts.pointers = Some(vec![Some(usage)]);
        assert!(MicromapBuildShape::queryable(&both, &device).is_none());
        let mut level = info(OPACITY_MICROMAP_FORMAT_2_STATE, 99);
        assert!(MicromapBuildShape::queryable(&level, &device).is_none());
        level.usage_counts = UsageCounts::pointers(vec![usage]);
        assert!(MicromapBuildShape::queryable(&level, &device).is_some());
    }
}
