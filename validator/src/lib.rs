//! ommcheck: a checker for Vulkan opacity-micromap API usage.
//!
//! One core, three faces: a Vulkan layer for debug builds, a static checker
//! for unit tests, and snapshot VUID reports from scene files. Every check
//! names the VUID it enforces through the generated catalog of
//! [`ommcheck_vuids`], re-exported here as [`vuids`], or a rule of ours
//! ([`rules`]) for specification prose without a VUID.
//!
//! The core (model, checks, report) is safe Rust with no FFI.

#![deny(unsafe_code)]

pub use ommcheck_vuids as vuids;

pub mod checks;
pub mod coverage;
pub mod device;
pub mod model;
pub mod raw;
pub mod report;
pub mod rules;
pub mod state;
pub mod summary;
mod validator;

pub use device::{Device, Features, Limits, Profile};
pub use report::{Finding, Report, RuleId, Severity};
pub use validator::Validator;
