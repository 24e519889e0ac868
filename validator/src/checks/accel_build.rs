//! (being written)

use crate::checks::Coverage;

pub const COVERAGE: Coverage = Coverage {
    module: "accel_build",
    enforced: &[],
    not_decidable: &[],
};
