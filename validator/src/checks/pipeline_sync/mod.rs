//! Synchronization, pipelines, shaders, the draw/dispatch/trace-rays
//! commands, and the micromap feature and property structures. One module
//! per area; the coverage declaration joins their lists.

mod features;
mod pipelines;
pub mod spirv;
mod sync;
mod work;

pub use work::WorkCommand;

use crate::checks::Coverage;
use ommcheck_vuids::Vuid;

/// The lists of the submodules, joined at compile time.
const fn join<const N: usize, const L: usize>(lists: [&[Vuid]; L]) -> [Vuid; N] {
    // Any catalog entry will do as the filler every slot overwrites.
    let mut out = [ommcheck_vuids::vuid::RuntimeSpirv::micromap_11630; N];
    let mut at = 0;
    let mut l = 0;
    while l < lists.len() {
        let mut k = 0;
        while k < lists[l].len() {
            out[at] = lists[l][k];
            at += 1;
            k += 1;
        }
        l += 1;
    }
    assert!(at == N, "the joined length is the sum of the lists");
    out
}

const ENFORCED_LISTS: [&[Vuid]; 4] = [
    sync::ENFORCED,
    pipelines::ENFORCED,
    features::ENFORCED,
    work::ENFORCED,
];
const ENFORCED_COUNT: usize = sync::ENFORCED.len()
    + pipelines::ENFORCED.len()
    + features::ENFORCED.len()
    + work::ENFORCED.len();
const ENFORCED: [Vuid; ENFORCED_COUNT] = join(ENFORCED_LISTS);

pub const COVERAGE: Coverage = Coverage {
    module: "pipeline_sync",
    enforced: &ENFORCED,
    not_decidable: work::NOT_DECIDABLE,
};
