//! Telling the checker what the driver answered: the
//! `VkMicromapBuildSizesInfoEXT` `vkGetMicromapBuildSizesEXT` returned for
//! a build's shape, which the build rules 07461 and 07509 compare against,
//! and the compatibility `vkGetDeviceMicromapCompatibilityEXT` answered for
//! serialized data (07549).

use std::sync::Arc;

use ash::vk;

use crate::checks::Validator;
use crate::driver::{DriverQueries, MicromapBuildShape, MicromapBuildSizes, MicromapVersion};
use crate::model::micromap::MicromapUsage;

impl Validator {
    /// `vkGetMicromapBuildSizesEXT` returned `sizes` for builds of type `ty`
    /// with `flags` and the usage counts `usages` (in the order the build
    /// lists them): later builds of that shape, host or device, are checked
    /// against them.
    pub fn set_micromap_build_sizes(
        &mut self,
        ty: vk::MicromapTypeEXT,
        flags: vk::BuildMicromapFlagsEXT,
        usages: &[vk::MicromapUsageEXT],
        sizes: &vk::MicromapBuildSizesInfoEXT<'_>,
    ) {
        let shape = MicromapBuildShape {
            ty: ty.as_raw(),
            flags: flags.as_raw(),
            usages: usages
                .iter()
                .map(|u| MicromapUsage {
                    count: u.count,
                    subdivision_level: u.subdivision_level,
                    format: u.format,
                })
                .collect(),
        };
        self.state
            .driver
            .state_micromap_build_sizes(shape, MicromapBuildSizes::from(*sizes));
    }

    /// `vkGetDeviceMicromapCompatibilityEXT` answered `compatibility` for
    /// serialized micromap data whose first 32 bytes are `version_data`:
    /// later deserializations of such data are checked against it.
    pub fn set_micromap_compatibility(
        &mut self,
        version_data: &MicromapVersion,
        compatibility: vk::AccelerationStructureCompatibilityKHR,
    ) {
        let compatible = compatibility == vk::AccelerationStructureCompatibilityKHR::COMPATIBLE;
        self.state
            .driver
            .state_micromap_compatibility(*version_data, compatible);
    }

    /// Asks `queries` for the sizes of builds no stated answer covers (an
    /// adaptor that can call the driver installs one).
    pub fn set_driver_queries(&mut self, queries: Arc<dyn DriverQueries>) {
        self.state.driver.set_queries(queries);
    }
}

#[cfg(test)]
mod tests {
    use ash::vk::{self, Handle};

    use crate::model::{CommandBuffer, MicromapBuildInfo, MicromapUsage, UsageCounts};
    use crate::state::MemoryBinding;
    use crate::{Device, Profile, Report, Validator};
    use ommcheck_vuids::{vuid, Vuid};

    const USAGE: vk::MicromapUsageEXT = vk::MicromapUsageEXT {
        count: 2,
        subdivision_level: 1,
        format: 2,
    };

    /// A device build of two level-1 4-state triangles into a micromap of
    /// `created` bytes, scratch at the start of a 4096-byte buffer, after
    /// the driver answered `micromap_size` and `scratch_size` (or nothing).
    fn build(created: u64, answer: Option<(u64, u64)>) -> Report {
        let mut v = validator(created, answer);
        v.cmd_build_micromaps(&CommandBuffer::default(), &[info(0x3_0000)])
    }

    /// The build's objects, with the driver's answer if any.
    fn validator(created: u64, answer: Option<(u64, u64)>) -> Validator {
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        for (handle, usage, address) in [
            (1, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0x2_0000),
            (2, vk::BufferUsageFlags::STORAGE_BUFFER, 0x3_0000),
        ] {
            let buffer = vk::Buffer::from_raw(handle);
            let info = vk::BufferCreateInfo::default()
                .size(4096)
                .usage(usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS);
            v.create_buffer(buffer, &info);
            v.bind_buffer_memory(buffer, MemoryBinding::default());
            v.set_buffer_device_address(buffer, address);
        }
        let create = vk::MicromapCreateInfoEXT::default()
            .buffer(vk::Buffer::from_raw(1))
            .size(created)
            .ty(vk::MicromapTypeEXT::OPACITY_MICROMAP);
        let micromap = vk::MicromapEXT::from_raw(9);
        assert!(v
            .create_micromap_from(vk::Device::from_raw(1), &create, micromap)
            .is_empty());
        if let Some((micromap_size, scratch_size)) = answer {
            v.set_micromap_build_sizes(
                vk::MicromapTypeEXT::OPACITY_MICROMAP,
                vk::BuildMicromapFlagsEXT::empty(),
                &[USAGE],
                &vk::MicromapBuildSizesInfoEXT::default()
                    .micromap_size(micromap_size)
                    .build_scratch_size(scratch_size),
            );
        }
        v
    }

    /// The build of [`USAGE`] into the micromap, its scratch at `scratch`.
    fn info(scratch: u64) -> MicromapBuildInfo {
        MicromapBuildInfo {
            dst_micromap: 9,
            usage_counts: UsageCounts::array(vec![MicromapUsage {
                count: USAGE.count,
                subdivision_level: USAGE.subdivision_level,
                format: USAGE.format,
            }]),
            scratch_data: scratch,
            ..Default::default()
        }
    }

    const SIZE: Vuid = vuid::vkCmdBuildMicromapsEXT::pInfos_07461;
    const SCRATCH: Vuid = vuid::vkCmdBuildMicromapsEXT::pInfos_07509;

    fn reports(report: &Report, rule: Vuid) -> bool {
        report.contains(rule)
    }

    fn decided(report: &Report, rule: Vuid) -> bool {
        report.checked.contains(rule)
    }

    #[test]
    fn the_driver_answer_decides_the_micromap_and_scratch_sizes() {
        let small = build(1024, Some((2048, 8192)));
        assert!(reports(&small, SIZE), "{small:?}");
        assert!(reports(&small, SCRATCH), "{small:?}");
        let exact = build(2048, Some((2048, 4096)));
        assert!(
            !reports(&exact, SIZE) && !reports(&exact, SCRATCH),
            "{exact:?}"
        );
        assert!(decided(&exact, SIZE) && decided(&exact, SCRATCH));
        // Without an answer neither rule is decided.
        let unknown = build(1, None);
        assert!(!decided(&unknown, SIZE) && !decided(&unknown, SCRATCH));
        assert!(!reports(&unknown, SCRATCH));
    }

    #[test]
    fn a_build_the_driver_gives_no_scratch_needs_no_scratch_address() {
        let no_buffer = 0x9000_0000;
        let device_build = |scratch_size| {
            let mut v = validator(4096, Some((2048, scratch_size)));
            v.cmd_build_micromaps(&CommandBuffer::default(), &[info(no_buffer)])
        };
        let invalid = vuid::vkCmdBuildMicromapsEXT::pInfos_07512;
        assert!(reports(&device_build(4096), invalid));
        assert!(!reports(&device_build(0), invalid));
        let host_build = |scratch_size| {
            let mut v = validator(4096, Some((2048, scratch_size)));
            v.build_micromaps(1, 0, &[info(0)])
        };
        let null = vuid::vkBuildMicromapsEXT::pInfos_07556;
        assert!(reports(&host_build(4096), null));
        assert!(!reports(&host_build(0), null));
    }
}
