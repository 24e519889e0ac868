//! (being written)

use crate::checks::Coverage;

pub const COVERAGE: Coverage = Coverage {
    module: "pipeline_sync",
    enforced: &[],
    not_decidable: &[],
};
