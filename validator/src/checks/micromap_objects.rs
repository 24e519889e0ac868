//! (being written)

use crate::checks::Coverage;

pub const COVERAGE: Coverage = Coverage {
    module: "micromap_objects",
    enforced: &[],
    not_decidable: &[],
};
