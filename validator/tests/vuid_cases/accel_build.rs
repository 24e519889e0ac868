//! Cases for the `accel_build` checks.

use crate::Case;

pub fn cases() -> Vec<Case> {
    vec![]
}
