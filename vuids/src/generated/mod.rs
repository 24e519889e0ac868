//! Files written by `cargo xtask generate`; do not edit them by hand.

pub mod aliases;
pub mod catalog;
pub mod khr;
