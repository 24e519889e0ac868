//! KHR acceleration-structure builds as far as micromaps are concerned: the
//! entry points of the build commands, `VkAccelerationStructureBuildGeometryInfoKHR`,
//! KHR opacity micromaps (type OPACITY_MICROMAP, `VkAccelerationStructureGeometryMicromapDataKHR`),
//! their creation, size queries and copies. The triangle-geometry
//! attachments are checked in `accel_attach`.

use crate::checks::{accel_attach, Coverage};
use crate::model::accel::{BuildGeometryInfo, BuildRangeInfo, GeometryData};
use crate::model::CommandBuffer;
use crate::report::Report;
use crate::validator::{Ctx, Validator};

pub const COVERAGE: Coverage = Coverage {
    module: "accel_build",
    enforced: &[],
    not_decidable: &[],
};

/// Which build command is checked; many rules differ only in their VUID.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildCommand {
    /// `vkCmdBuildAccelerationStructuresKHR`
    Cmd,
    /// `vkCmdBuildAccelerationStructuresIndirectKHR`
    Indirect,
    /// `vkBuildAccelerationStructuresKHR` (addresses are host addresses)
    Host,
}

impl BuildCommand {
    pub fn function(self) -> &'static str {
        match self {
            BuildCommand::Cmd => "vkCmdBuildAccelerationStructuresKHR",
            BuildCommand::Indirect => "vkCmdBuildAccelerationStructuresIndirectKHR",
            BuildCommand::Host => "vkBuildAccelerationStructuresKHR",
        }
    }
}

impl Validator {
    /// `vkCmdBuildAccelerationStructuresKHR(commandBuffer, infoCount, pInfos, ppBuildRangeInfos)`;
    /// `build_range_infos[i]` is `ppBuildRangeInfos[i]` (None: NULL).
    pub fn cmd_build_acceleration_structures(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) -> Report {
        let mut ctx = self.ctx(BuildCommand::Cmd.function());
        let _ = command_buffer;
        builds(&mut ctx, BuildCommand::Cmd, infos, Some(build_range_infos));
        ctx.finish()
    }

    /// `vkCmdBuildAccelerationStructuresIndirectKHR(commandBuffer, infoCount, pInfos,
    /// pIndirectDeviceAddresses, pIndirectStrides, ppMaxPrimitiveCounts)`.
    pub fn cmd_build_acceleration_structures_indirect(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[BuildGeometryInfo],
        indirect_device_addresses: &[u64],
        indirect_strides: &[u32],
        max_primitive_counts: &[Option<Vec<u32>>],
    ) -> Report {
        let mut ctx = self.ctx(BuildCommand::Indirect.function());
        let _ = (
            command_buffer,
            indirect_device_addresses,
            indirect_strides,
            max_primitive_counts,
        );
        builds(&mut ctx, BuildCommand::Indirect, infos, None);
        ctx.finish()
    }

    /// `vkBuildAccelerationStructuresKHR(device, deferredOperation, infoCount, pInfos, ppBuildRangeInfos)`.
    pub fn build_acceleration_structures(
        &mut self,
        infos: &[BuildGeometryInfo],
        build_range_infos: &[Option<Vec<BuildRangeInfo>>],
    ) -> Report {
        let mut ctx = self.ctx(BuildCommand::Host.function());
        builds(&mut ctx, BuildCommand::Host, infos, Some(build_range_infos));
        ctx.finish()
    }
}

/// The checks every build command shares: each info, each geometry's
/// attachments (in `accel_attach`), and rules across infos.
fn builds(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    infos: &[BuildGeometryInfo],
    ranges: Option<&[Option<Vec<BuildRangeInfo>>]>,
) {
    for (i, info) in infos.iter().enumerate() {
        let info_ranges = ranges.and_then(|r| r.get(i)).and_then(Option::as_ref);
        let (member, geometries) = info.geometry_entries();
        for (g, geometry) in geometries {
            let at = format!("pInfos[{i}].{member}[{g}]");
            let range = info_ranges.and_then(|r| r.get(g));
            match &geometry.geometry {
                GeometryData::Triangles(triangles) => {
                    accel_attach::triangles(ctx, command, &at, info, triangles, range)
                }
                GeometryData::Instances(instances) => {
                    accel_attach::instances(ctx, command, &at, info, instances)
                }
                GeometryData::Aabbs(_) | GeometryData::None => {}
            }
        }
    }
    accel_attach::across_infos(ctx, command, infos);
}
