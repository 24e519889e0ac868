//! States a scene's `driverAnswers` to the checker.

use crate::driver::{MicromapBuildShape, MicromapBuildSizes};
use crate::model::values::MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
use crate::scene::format::DriverAnswersDesc;
use crate::validator::Validator;

use super::usage;

pub(super) fn state_answers(validator: &mut Validator, answers: &DriverAnswersDesc) {
    for desc in &answers.micromap_build_sizes {
        let shape = MicromapBuildShape {
            ty: desc
                .ty
                .map_or(MICROMAP_TYPE_OPACITY_MICROMAP_EXT, |t| t.as_i32()),
            flags: desc.flags.as_u32(),
            usages: desc.usage_counts.iter().map(usage).collect(),
        };
        let sizes = MicromapBuildSizes {
            micromap_size: desc.micromap_size,
            build_scratch_size: desc.build_scratch_size,
            discardable: desc.discardable,
        };
        validator
            .state_mut()
            .driver
            .state_micromap_build_sizes(shape, sizes);
    }
}
