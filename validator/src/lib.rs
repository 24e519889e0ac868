//! ommcheck: a checker for Vulkan opacity-micromap API usage.
//!
//! One core, three faces: a Vulkan layer for debug builds, a static checker
//! for unit tests, and snapshot VUID reports from scene files. Every check
//! names the VUID it enforces through the generated catalog of
//! [`ommcheck_vuids`], re-exported here as [`vuids`], or a rule of ours
//! ([`rules`]) for specification prose without a VUID.
//!
//! The core (model, checks, report) is safe Rust with no FFI; [`raw`] is the
//! one module that reads the raw pointers of ash structures.
//!
//! # Checking a build in a unit test
//!
//! Describe the device and the objects a call uses, then check the call.
//! Each method of [`Validator`] checks one API call and returns a [`Report`]:
//!
//! ```
//! use std::sync::Arc;
//! use ommcheck::model::values::*;
//! use ommcheck::model::{CommandBuffer, MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts};
//! use ommcheck::state::{Buffer, MemoryBinding, Micromap};
//! use ommcheck::vuids::vuid;
//! use ommcheck::{rules, Device, Profile, Validator};
//!
//! let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
//! // One input buffer holding the micromap data at 0x10000 and the
//! // triangle array at 0x11000, both read by the checker.
//! let mut bytes = vec![0u8; 0x2000];
//! let triangle = MicromapTriangle { data_offset: 0x1ff8, subdivision_level: 3, format: 2 };
//! bytes[0x1000..0x1008].copy_from_slice(&triangle.to_bytes());
//! let bound = Some(MemoryBinding::default());
//! let state = v.state_mut();
//! state.buffers.insert(1, Buffer {
//!     size: 0x2000,
//!     usage: BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT,
//!     device_address: Some(0x10000),
//!     memory: bound,
//!     contents: Some(Arc::from(bytes)),
//!     ..Default::default()
//! });
//! state.buffers.insert(2, Buffer { size: 0x1000, usage: BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT, memory: bound, ..Default::default() });
//! state.buffers.insert(3, Buffer { size: 0x1000, usage: BUFFER_USAGE_STORAGE_BUFFER_BIT, device_address: Some(0x40000), memory: bound, ..Default::default() });
//! state.micromaps.insert(7, Micromap { buffer: 2, size: 0x1000, ..Default::default() });
//!
//! let build = MicromapBuildInfo {
//!     dst_micromap: 7,
//!     // The counts claim a level-2 triangle; the array holds a level-3 one.
//!     usage_counts: UsageCounts::array(vec![MicromapUsage { count: 1, subdivision_level: 2, format: 2 }]),
//!     data: 0x10000,
//!     triangle_array: 0x11000,
//!     triangle_array_stride: 8,
//!     scratch_data: 0x40000,
//!     ..Default::default()
//! };
//! let report = v.cmd_build_micromaps(&CommandBuffer::default(), &[build]);
//! // The level-3 4-state triangle needs 16 bytes from 0x1ff8: past the buffer.
//! assert!(report.contains(&rules::TRIANGLE_DATA_RANGE));
//! assert!(report.contains(&rules::HISTOGRAM_MISMATCH));
//! assert!(!report.contains(vuid::vkCmdBuildMicromapsEXT::pInfos_07515));
//! println!("{report}");
//! ```
//!
//! Reports serialize with serde, so `insta::assert_json_snapshot!(report)`
//! works in a user's own tests.

#![deny(unsafe_code)]

pub use ommcheck_vuids as vuids;

pub mod checks;
pub mod coverage;
pub mod device;
pub mod explain;
pub mod model;
pub mod raw;
pub mod report;
pub mod rules;
pub mod scene;
pub mod sim;
pub mod state;
pub mod suggest;
pub mod summary;
pub mod tier;
mod validator;

pub use device::{Device, Features, Limits, Profile};
pub use report::{Finding, Report, RuleId, Severity};
pub use tier::Tier;
pub use validator::{Validator, FINDINGS_PER_RULE_PER_CALL};
