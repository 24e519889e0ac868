//! The ids of the messages the layer reports about itself, rather than
//! about a rule a call breaks. They live below both message delivery
//! ([`crate::report`]) and the settings ([`crate::settings`]), which checks
//! that `message_id_filter` names only ids the layer can report.

/// A panic inside the layer, caught before it reached the application.
pub const INTERNAL_ERROR: &str = "OMMCHECK-layer-internal-error";
/// A setting the layer could not use, or a setting's name or value that
/// looks mistyped.
pub const SETTINGS_PROBLEM: &str = "OMMCHECK-layer-settings";
/// The settings in effect and where each came from (information, at
/// `vkCreateInstance`).
pub const EFFECTIVE_SETTINGS: &str = "OMMCHECK-layer-effective-settings";
/// A device build's contents (triangle arrays, micromap data, index
/// buffers) could not be read, so their content rules were not checked:
/// the memory holding them is device-local, not mapped, or not known to
/// the layer. A warning once per device and cause, naming the first such
/// build and why, and a count at `vkDestroyDevice` where more followed.
pub const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";
/// The provenance store cannot serve as it should (cannot be created or
/// written, is not a store, holds damaged records, stays locked, or reached
/// its bound): a warning once per process and kind; the layer goes on with
/// provenance in memory.
pub const PROVENANCE_STORE: &str = "OMMCHECK-layer-provenance-store";

/// Every id above: what `message_id_filter` may name besides the rules.
pub const ALL: [&str; 5] = [
    INTERNAL_ERROR,
    SETTINGS_PROBLEM,
    EFFECTIVE_SETTINGS,
    CONTENTS_NOT_CHECKED,
    PROVENANCE_STORE,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_well_formed_and_outside_the_core_rules() {
        for id in ALL {
            assert!(
                id.starts_with("OMMCHECK-layer-") && id.split('-').count() >= 3,
                "{id}"
            );
            assert!(
                ommcheck::rules::ALL.iter().all(|rule| rule.id != id),
                "{id}"
            );
        }
    }
}
