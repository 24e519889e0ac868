//! The rules every usage-count member shares, whichever structure holds it
//! (`VkMicromapBuildInfoEXT`, the EXT and NV attachments of a BLAS's
//! triangles, `VkAccelerationStructureGeometryMicromapDataKHR`): the
//! `pUsageCounts`/`ppUsageCounts` pair, and each `VkMicromapUsageEXT`
//! entry's format and level against its micromap's type. Each structure
//! names its own VUIDs for them.

use std::fmt::Display;

use ommcheck_vuids::Vuid;

use crate::checks::Ctx;
use crate::model::micromap::{MicromapUsage, UsageCounts};
use crate::model::values::{
    DISPLACEMENT_MICROMAP_FORMATS_NV, OPACITY_MICROMAP_FORMAT_2_STATE,
    OPACITY_MICROMAP_FORMAT_4_STATE,
};
use crate::report::count as count_of;

/// A structure's VUIDs for its `pUsageCounts` and `ppUsageCounts`.
pub(crate) struct PointerVuids {
    /// Only one of the two is set.
    pub one_of: Vuid,
    /// `pUsageCounts` holds `usageCountsCount` elements.
    pub array: Vuid,
    /// `ppUsageCounts` holds `usageCountsCount` non-NULL pointers.
    pub pointers: Vuid,
}

/// `pUsageCounts` / `ppUsageCounts` of the structure at `at`: at most one
/// set, each as long as `usageCountsCount` says, no NULL element.
pub(crate) fn pointer_rules(
    ctx: &mut Ctx<'_>,
    at: impl Display,
    counts: &UsageCounts,
    vuids: &PointerVuids,
) {
    ctx.require(
        !(counts.array.is_some() && counts.pointers.is_some()),
        vuids.one_of,
        || at.to_string(),
        || "both pUsageCounts and ppUsageCounts are set".into(),
    );
    if counts.count == 0 {
        return;
    }
    let expected = u64::from(counts.count);
    if let Some(array) = &counts.array {
        ctx.require(
            array.len() as u64 == expected,
            vuids.array,
            || format!("{at}.pUsageCounts"),
            || {
                format!(
                    "points to {}, not usageCountsCount = {expected}",
                    count_of(array.len(), "element", "elements")
                )
            },
        );
    }
    if let Some(pointers) = &counts.pointers {
        if pointers.len() as u64 != expected {
            ctx.error(
                vuids.pointers,
                format!("{at}.ppUsageCounts"),
                format!(
                    "points to {} pointers, not usageCountsCount = {expected}",
                    pointers.len()
                ),
            );
        } else if let Some(null) = pointers.iter().position(Option::is_none) {
            ctx.error(
                vuids.pointers,
                format!("{at}.ppUsageCounts[{null}]"),
                "the pointer is NULL",
            );
        }
    }
}

/// A structure's VUIDs for one `VkMicromapUsageEXT` entry against its
/// micromap's type.
pub(crate) struct EntryVuids {
    /// An opacity micromap's entry has a `VkOpacityMicromapFormatEXT`.
    pub opacity_format: Vuid,
    /// ... with a level within maxOpacity2StateSubdivisionLevel (2-state)
    pub opacity_2_state_level: Vuid,
    /// ... or maxOpacity4StateSubdivisionLevel (4-state).
    pub opacity_4_state_level: Vuid,
    /// A displacement micromap's entry has a `VkDisplacementMicromapFormatNV`
    pub displacement_format: Vuid,
    /// ... with a level within maxDisplacementMicromapSubdivisionLevel.
    pub displacement_level: Vuid,
    /// Whether a format message names the micromap's type (where the type
    /// comes from another object, the attached micromap).
    pub name_the_type: bool,
}

/// One usage entry's format and subdivision level, at `loc`, of an opacity
/// (else a displacement) micromap; `maxima` are the 2-state, 4-state and
/// displacement level limits.
pub(crate) fn entry_rules(
    ctx: &mut Ctx<'_>,
    loc: impl Display,
    usage: MicromapUsage,
    opacity: bool,
    (max2, max4, max_nv): (u32, u32, u32),
    vuids: &EntryVuids,
) {
    let level = usage.subdivision_level;
    let exceeds = |max: u32, name: &'static str| move || format!("{level} exceeds {name} = {max}");
    let of_type = |kind: &str| {
        if vuids.name_the_type {
            format!(" (micromap is {kind} micromap)")
        } else {
            String::new()
        }
    };
    if opacity {
        match usage.format {
            OPACITY_MICROMAP_FORMAT_2_STATE => ctx.require(
                level <= max2,
                vuids.opacity_2_state_level,
                || format!("{loc}.subdivisionLevel"),
                exceeds(max2, "maxOpacity2StateSubdivisionLevel"),
            ),
            OPACITY_MICROMAP_FORMAT_4_STATE => ctx.require(
                level <= max4,
                vuids.opacity_4_state_level,
                || format!("{loc}.subdivisionLevel"),
                exceeds(max4, "maxOpacity4StateSubdivisionLevel"),
            ),
            other => {
                ctx.error(
                    vuids.opacity_format,
                    format!("{loc}.format"),
                    format!(
                        "{other} is not a VkOpacityMicromapFormatEXT value{}",
                        of_type("an opacity")
                    ),
                );
            }
        }
    } else {
        ctx.require(
            DISPLACEMENT_MICROMAP_FORMATS_NV.contains(&usage.format),
            vuids.displacement_format,
            || format!("{loc}.format"),
            || {
                format!(
                    "{} is not a VkDisplacementMicromapFormatNV value{}",
                    usage.format,
                    of_type("a displacement")
                )
            },
        );
        ctx.require(
            level <= max_nv,
            vuids.displacement_level,
            || format!("{loc}.subdivisionLevel"),
            exceeds(max_nv, "maxDisplacementMicromapSubdivisionLevel"),
        );
    }
}
