//! The micromap feature and property structures: their sTypes, and where
//! they may appear in the pNext chains of `VkDeviceCreateInfo` and
//! `VkPhysicalDeviceProperties2`.

use ommcheck_vuids::vuid::{
    VkDeviceCreateInfo as device_info,
    VkPhysicalDeviceDisplacementMicromapFeaturesNV as nv_features,
    VkPhysicalDeviceDisplacementMicromapPropertiesNV as nv_properties,
    VkPhysicalDeviceOpacityMicromapFeaturesEXT as ext_features,
    VkPhysicalDeviceOpacityMicromapFeaturesKHR as khr_features,
    VkPhysicalDeviceOpacityMicromapPropertiesEXT as ext_properties,
    VkPhysicalDeviceOpacityMicromapPropertiesKHR as khr_properties,
    VkPhysicalDevicePipelineOpacityMicromapFeaturesARM as arm_features,
    VkPhysicalDeviceProperties2 as properties2,
};
use ommcheck_vuids::Vuid;

use crate::checks::{Ctx, Validator};
use crate::model::pipeline::{ChainedStruct, MicromapStruct};
use crate::model::values::structure_type_name;
use crate::report::Report;

pub(super) const ENFORCED: &[Vuid] = &[
    ext_features::sType_sType,
    khr_features::sType_sType,
    nv_features::sType_sType,
    arm_features::sType_sType,
    ext_properties::sType_sType,
    khr_properties::sType_sType,
    nv_properties::sType_sType,
    device_info::pNext_pNext,
    properties2::pNext_pNext,
];

fn s_type_vuid(which: MicromapStruct) -> Vuid {
    match which {
        MicromapStruct::OpacityMicromapFeaturesExt => ext_features::sType_sType,
        MicromapStruct::OpacityMicromapFeaturesKhr => khr_features::sType_sType,
        MicromapStruct::DisplacementMicromapFeaturesNv => nv_features::sType_sType,
        MicromapStruct::PipelineOpacityMicromapFeaturesArm => arm_features::sType_sType,
        MicromapStruct::OpacityMicromapPropertiesExt => ext_properties::sType_sType,
        MicromapStruct::OpacityMicromapPropertiesKhr => khr_properties::sType_sType,
        MicromapStruct::DisplacementMicromapPropertiesNv => nv_properties::sType_sType,
    }
}

impl Validator {
    /// `vkCreateDevice` with the structures of `pCreateInfo->pNext`.
    pub fn create_device(&mut self, next: &[ChainedStruct]) -> Report {
        let mut ctx = self.ctx("vkCreateDevice");
        chain(&mut ctx, "pCreateInfo", next, device_info::pNext_pNext);
        ctx.finish()
    }

    /// `vkGetPhysicalDeviceProperties2` with the structures of `pProperties->pNext`.
    pub fn get_physical_device_properties2(&mut self, next: &[ChainedStruct]) -> Report {
        let mut ctx = self.ctx("vkGetPhysicalDeviceProperties2");
        chain(&mut ctx, "pProperties", next, properties2::pNext_pNext);
        ctx.finish()
    }
}

/// Each micromap structure's sType, and whether the parent's pNext-pNext
/// VUID lists it. Structures ommcheck does not know are not judged.
fn chain(ctx: &mut Ctx<'_>, parent: &str, next: &[ChainedStruct], pnext_vuid: Vuid) {
    for (i, entry) in next.iter().enumerate() {
        let at = format!("{parent}.pNext[{i}]");
        if let ChainedStruct::Micromap { which, s_type } = *entry {
            ctx.require(
                s_type == which.s_type(),
                s_type_vuid(which),
                || format!("{at}<{}>.sType", which.name()),
                || {
                    format!(
                        "{} is not the structure's sType {}",
                        structure_type_name(s_type),
                        structure_type_name(which.s_type())
                    )
                },
            );
        }
        let Some(found) = MicromapStruct::from_s_type(entry.s_type()) else {
            continue;
        };
        ctx.require(
            lists(pnext_vuid, found.name()),
            pnext_vuid,
            || at.clone(),
            || {
                format!(
                    "{} ({}) does not extend this structure",
                    found.name(),
                    structure_type_name(entry.s_type())
                )
            },
        );
    }
}

/// Whether the VUID's statement names `structure` as a whole word.
fn lists(vuid: Vuid, structure: &str) -> bool {
    vuid.info()
        .text
        .split(|c: char| !c.is_ascii_alphanumeric())
        .any(|word| word == structure)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pnext_lists_follow_the_statements() {
        for which in MicromapStruct::ALL {
            let feature = which.name().contains("Features");
            assert_eq!(lists(device_info::pNext_pNext, which.name()), feature);
            assert_eq!(lists(properties2::pNext_pNext, which.name()), !feature);
        }
    }
}
