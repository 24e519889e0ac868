//! Triangle geometry that references a micromap: the EXT and KHR opacity
//! attachments and the NV displacement attachment, instance flags, and the
//! rules across the infos of one build command.

use crate::checks::accel_build::BuildCommand;
use crate::checks::Coverage;
use crate::model::accel::{BuildGeometryInfo, BuildRangeInfo, InstancesData, TrianglesData};
use crate::validator::Ctx;

pub const COVERAGE: Coverage = Coverage {
    module: "accel_attach",
    enforced: &[],
    not_decidable: &[],
};

/// A triangles geometry at `at` (e.g. `pInfos[0].pGeometries[1]`) of `info`,
/// with its build range where the command has one.
pub(crate) fn triangles(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    at: &str,
    info: &BuildGeometryInfo,
    triangles: &TrianglesData,
    range: Option<&BuildRangeInfo>,
) {
    let _ = (ctx, command, at, info, triangles, range);
}

/// An instances geometry of a top-level build.
pub(crate) fn instances(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    at: &str,
    info: &BuildGeometryInfo,
    instances: &InstancesData,
) {
    let _ = (ctx, command, at, info, instances);
}

/// Rules that relate different elements of `pInfos`.
pub(crate) fn across_infos(ctx: &mut Ctx<'_>, command: BuildCommand, infos: &[BuildGeometryInfo]) {
    let _ = (ctx, command, infos);
}
