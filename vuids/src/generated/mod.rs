//! Files written by `cargo xtask vuids`; do not edit them by hand.

pub mod aliases;
pub mod catalog;
pub mod khr;
