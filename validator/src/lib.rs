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
//! # A unit test
//!
//! Describe the device and the objects a call uses with the ash structures
//! and handles the program has, check the call, and require that the
//! report is clean and that every rule was checked. The faulty twin of the
//! valid build plants one mistake, and the snapshot shows what a user sees:
//!
//! ```
//! use ash::vk::{self, Handle};
//! use ommcheck::model::{CommandBuffer, MicromapBuildInfo, MicromapUsage, UsageCounts};
//! use ommcheck::state::MemoryBinding;
//! use ommcheck::{rules, Device, HostBytes, Profile, Report, Validator};
//!
//! /// Builds one level-3 4-state micromap triangle whose 16 bytes of data
//! /// start at `data_offset` in a 512-byte input buffer.
//! fn build_one_triangle(data_offset: u32) -> Report {
//!     let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
//!     let bound = MemoryBinding::default();
//!     let buffers = [
//!         (1, 512, vk::BufferUsageFlags::MICROMAP_BUILD_INPUT_READ_ONLY_EXT, 0x1_0000),
//!         (2, 4096, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 0x2_0000),
//!         (3, 4096, vk::BufferUsageFlags::STORAGE_BUFFER, 0x3_0000),
//!     ];
//!     for (handle, size, usage, address) in buffers {
//!         let buffer = vk::Buffer::from_raw(handle);
//!         let info = vk::BufferCreateInfo::default()
//!             .size(size)
//!             .usage(usage | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS);
//!         v.create_buffer(buffer, &info);
//!         v.bind_buffer_memory(buffer, bound);
//!         v.set_buffer_device_address(buffer, address);
//!     }
//!     // The data is at the buffer's start, the triangle array at 256.
//!     let triangles = [vk::MicromapTriangleEXT {
//!         data_offset,
//!         subdivision_level: 3,
//!         format: vk::OpacityMicromapFormatEXT::TYPE_4_STATE.as_raw() as u16,
//!     }];
//!     let mut input = vec![0u8; 512];
//!     input[256..264].copy_from_slice(&triangles.host_bytes());
//!     v.set_buffer_contents(vk::Buffer::from_raw(1), input.as_slice());
//!     let micromap = vk::MicromapEXT::from_raw(7);
//!     let create = vk::MicromapCreateInfoEXT::default()
//!         .buffer(vk::Buffer::from_raw(2))
//!         .size(4096)
//!         .ty(vk::MicromapTypeEXT::OPACITY_MICROMAP);
//!     let device = vk::Device::from_raw(0xde);
//!     v.create_micromap_from(device, &create, micromap).assert_fully_checked();
//!     // Findings name it, as vkSetDebugUtilsObjectNameEXT names it for the Khronos layer.
//!     v.name_object(micromap, "one-triangle");
//!
//!     let build = MicromapBuildInfo {
//!         dst_micromap: micromap.as_raw(),
//!         usage_counts: UsageCounts::array(vec![MicromapUsage {
//!             count: 1,
//!             subdivision_level: 3,
//!             format: vk::OpacityMicromapFormatEXT::TYPE_4_STATE.as_raw() as u32,
//!         }]),
//!         data: 0x1_0000,
//!         triangle_array: 0x1_0100,
//!         triangle_array_stride: 8,
//!         scratch_data: 0x3_0000,
//!         ..Default::default()
//!     };
//!     v.cmd_build_micromaps(&CommandBuffer::default(), &[build])
//! }
//!
//! // Valid: nothing found, and nothing skipped for want of information.
//! let valid = build_one_triangle(0);
//! assert!(valid.is_empty(), "{valid}");
//! valid.assert_fully_checked();
//!
//! // The faulty twin: the triangle's data runs past the buffer's end.
//! let faulty = build_one_triangle(500);
//! faulty.assert_fully_checked();
//! assert_eq!(faulty.ids(), [rules::TRIANGLE_DATA_RANGE.id]);
//! insta::assert_json_snapshot!(faulty, @r#"
//! {
//!   "findings": [
//!     {
//!       "id": "OMMCHECK-build-triangle-data-in-range",
//!       "severity": "error",
//!       "function": "vkCmdBuildMicromapsEXT",
//!       "location": "pInfos[0].triangleArray[0].dataOffset",
//!       "at": {
//!         "parameter": "pInfos[0].triangleArray[0].dataOffset"
//!       },
//!       "objects": [
//!         {
//!           "type": "VkMicromapEXT",
//!           "handle": 7,
//!           "name": "one-triangle"
//!         }
//!       ],
//!       "message": "[500, 516) is past the end of the memory data points into (512 bytes)",
//!       "messageId": 3114820761,
//!       "specText": "Each micromap triangle refers to one element in triangleArray which contains ... a dataOffset in bytes which is the location relative to data where that triangle's micromap data begins (the triangle's data, ceil(4^subdivisionLevel * bits per state / 8) bytes from dataOffset, must lie inside the memory data points to)",
//!       "specUrl": "https://docs.vulkan.org/spec/latest/chapters/VK_KHR_opacity_micromap/micromaps.html"
//!     }
//!   ]
//! }
//! "#);
//! ```
//!
//! [`Report::require_fully_checked`] is the way to write such tests: a
//! call that was not given what its rules read (buffer contents, host
//! memory, the build of a micromap it uses) reports which rules it could
//! not check ([`not_checked`]), and the test fails instead of passing by
//! skipping them. `docs/static-checker.md` describes the static checker.
//!
//! Tests of ill-formed calls build the owned model of [`model`] directly;
//! [`raw`] takes the ash structures with their pointers, as a layer does.

#![deny(unsafe_code)]

/// Shared, immutable bytes: buffer contents, host ranges and what builds
/// keep of them are views of one memory, never copies.
pub use bytes::Bytes;
pub use ommcheck_vuids as vuids;

pub mod acceleration_builds;
pub mod build_inputs;
pub mod checks;
pub mod coverage;
pub mod device;
pub mod draw;
pub mod driver;
pub mod explain;
pub mod fixture;
pub mod html;
pub mod inspect;
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
pub mod tracked;

pub use device::{Device, Features, Limits, Profile};
pub use report::not_checked::{self, Cause, NotChecked, RuleSet};
pub use report::{Finding, Report, ReportSummary, RuleId, Severity};
pub use tier::Tier;
pub use tracked::{DescribesDevice, HostBytes};

/// The examples of `docs/static-checker.md`, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../docs/static-checker.md")]
pub struct StaticCheckerDocs;
/// The README's example, compiled as a doctest, so it keeps up with the
/// API (its `#[test]` function is compiled, not run; the crate
/// documentation's first example runs the same checks).
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct ReadmeDocs;
/// The catalog example of `docs/catalog.md`, through `ommcheck::vuids`.
#[cfg(doctest)]
#[doc = include_str!("../../docs/catalog.md")]
pub struct CatalogDocs;
pub use checks::{Validator, FINDINGS_PER_RULE_PER_CALL};
