//! ommcheck: a checker for Vulkan opacity-micromap API usage.
//!
//! One core, three faces: a Vulkan layer for debug builds, a static checker
//! for unit tests, and snapshot VUID reports from scene files. Every check
//! names the VUID it enforces through the generated catalog of
//! [`ommcheck_vuids`], re-exported here as [`vuids`].

pub use ommcheck_vuids as vuids;

pub mod summary;
