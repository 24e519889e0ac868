//! Cases for the `accel_attach` checks.

use crate::Case;

pub fn cases() -> Vec<Case> {
    vec![]
}
