//! Questions asked of what a [`Validator`](crate::Validator) tracked,
//! answered by the simulator: where a ray hits an acceleration structure's
//! micromaps (`ommcheck trace`, [`simulate`]) and what the built micromaps
//! hold (`ommcheck stats`, [`stats`]). The simulator itself ([`crate::sim`])
//! knows bytes and numbers only; this module finds them in the tracked
//! state.

pub mod simulate;
pub mod stats;
