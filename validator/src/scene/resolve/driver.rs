//! States a scene's `driverAnswers` to the checker.

use crate::driver::{MicromapBuildShape, MicromapBuildSizes};
use crate::model::values::MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
use crate::scene::format::DriverAnswersDesc;

use super::{usage, ObjectKind, Resolver, Result};

impl Resolver<'_> {
    /// States `answers`; the micromaps they name must be declared.
    pub(super) fn state_driver_answers(&mut self, answers: &DriverAnswersDesc) -> Result<()> {
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
            self.validator
                .state_mut()
                .driver
                .state_micromap_build_sizes(shape, sizes);
        }
        for (i, desc) in answers.serialization_sizes.iter().enumerate() {
            let at = format!("driverAnswers.serializationSizes[{i}].micromap");
            let micromap = self.handle(&desc.micromap, ObjectKind::Micromap, &at)?;
            self.validator
                .state_mut()
                .driver
                .state_serialization_size(micromap, desc.size);
        }
        Ok(())
    }
}
