//! Files written by `cargo xtask vuids`; do not edit them by hand.

pub mod catalog;
pub mod khr;
