//! States a scene's `driverAnswers` to the checker.

use crate::driver::{MicromapBuildShape, MicromapBuildSizes, MicromapVersion};
use crate::model::values::MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
use crate::scene::format::DriverAnswersDesc;

use super::{decode_hex, problem, usage, ObjectKind, Resolver, Result};

impl Resolver<'_> {
    /// States `answers`; the micromaps they name must be declared.
    pub(super) fn state_driver_answers(&mut self, answers: &DriverAnswersDesc) -> Result<()> {
        let serialization_sizes = answers
            .serialization_sizes
            .iter()
            .enumerate()
            .map(|(i, desc)| {
                let at = format!("driverAnswers.serializationSizes[{i}].micromap");
                let micromap = self.handle(&desc.micromap, ObjectKind::Micromap, &at)?;
                Ok((micromap, desc.size))
            })
            .collect::<Result<Vec<_>>>()?;
        let compatibility = answers
            .micromap_compatibility
            .iter()
            .enumerate()
            .map(|(i, desc)| {
                let at = format!("driverAnswers.micromapCompatibility[{i}].versionData");
                let bytes = decode_hex(&desc.version_data, &at)?;
                let version = MicromapVersion::try_from(bytes.as_slice()).or_else(|_| {
                    problem(
                        &at,
                        format!("{} bytes, not 2 × VK_UUID_SIZE (32)", bytes.len()),
                    )
                })?;
                Ok((version, desc.compatible))
            })
            .collect::<Result<Vec<_>>>()?;
        let driver = &mut self.validator.state_mut().driver;
        for (micromap, size) in serialization_sizes {
            driver.state_serialization_size(micromap, size);
        }
        for (version, compatible) in compatibility {
            driver.state_micromap_compatibility(version, compatible);
        }
        for desc in &answers.micromap_build_sizes {
            let ty = desc
                .ty
                .map_or(MICROMAP_TYPE_OPACITY_MICROMAP_EXT, |t| t.as_i32());
            let usages = desc.usage_counts.iter().map(usage).collect();
            let shape = MicromapBuildShape {
                ty,
                flags: desc.flags.as_u32(),
                usages,
            };
            let (micromap_size, build_scratch_size) = (desc.micromap_size, desc.build_scratch_size);
            let discardable = desc.discardable;
            let sizes = MicromapBuildSizes {
                micromap_size,
                build_scratch_size,
                discardable,
            };
            driver.state_micromap_build_sizes(shape, sizes);
        }
        Ok(())
    }
}
