//! Cases for the `micromap_objects` checks.

use crate::Case;

pub fn cases() -> Vec<Case> {
    vec![]
}
