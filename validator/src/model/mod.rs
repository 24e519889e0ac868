//! Owned types mirroring the Vulkan API. Enum and flag members keep their raw
//! values, pointer members say whether they were NULL, and counts are kept
//! beside the arrays they describe, so that every invalid input the API can
//! express can be expressed here and checked.

pub mod accel;
pub mod array_or_pointers;
pub mod calls;
pub mod command;
pub mod generated;
pub mod micromap;
pub mod micromap_objects;
pub mod names;
pub mod pipeline;
pub mod values;

/// A Vulkan handle's value; 0 is VK_NULL_HANDLE.
pub type Handle = u64;

pub use command::{CommandBuffer, SemaphoreOp, SubmitBatch};
pub use micromap::{MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts};
