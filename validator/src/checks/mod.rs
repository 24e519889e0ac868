//! The checks, one module per API object or command family, mirroring the
//! specification's structure. Each module lists the VUIDs it enforces and
//! those it cannot decide at the API boundary (with the reason), which the
//! coverage report and its tests read.
//!
//! [`Validator`] is defined here, beside the checks that implement its
//! methods (`impl super::Validator` in each module), as naga keeps its
//! validator inside `valid/`.

use ommcheck_vuids::Vuid;

pub mod accel_attach;
pub mod accel_build;
mod calls;
pub(crate) mod common;
pub mod device_contents;
pub mod driver_sizes;
pub mod execution;
pub(crate) mod hygiene;
pub(crate) mod index_scan;
pub mod micromap_build;
pub mod micromap_objects;
pub mod pipeline_sync;
pub(crate) mod provenance;
mod serialized;
pub(crate) mod usage_counts;
pub(crate) mod usage_hints;
pub(crate) mod usage_keys;
mod validator;

pub(crate) use validator::Ctx;
pub use validator::{Validator, FINDINGS_PER_RULE_PER_CALL};

/// A module's coverage declaration.
pub struct Coverage {
    pub module: &'static str,
    /// VUIDs the module's checks enforce, each with failing and passing tests.
    pub enforced: &'static [Vuid],
    /// VUIDs that cannot be decided at the API boundary, with the reason.
    pub not_decidable: &'static [(Vuid, &'static str)],
}

/// VUIDs decided only in the layer, with what it needs that a scene
/// cannot state: they are enforced there (with layer tests), not in the
/// scene corpus.
pub fn layer_only() -> Vec<(Vuid, &'static str, &'static str)> {
    driver_sizes::LAYER_ONLY
        .iter()
        .map(|&(v, needs)| (v, "driver_sizes", needs))
        .collect()
}

/// Every module's declaration.
pub fn coverage() -> Vec<Coverage> {
    vec![
        micromap_build::COVERAGE,
        driver_sizes::COVERAGE,
        micromap_objects::COVERAGE,
        accel_build::COVERAGE,
        accel_attach::COVERAGE,
        pipeline_sync::COVERAGE,
        execution::COVERAGE,
    ]
}
