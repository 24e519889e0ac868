//! Cases for the `pipeline_sync` checks.

use crate::Case;

pub fn cases() -> Vec<Case> {
    vec![]
}
