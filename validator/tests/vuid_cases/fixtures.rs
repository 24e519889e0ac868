//! A small world most cases start from: a device with everything enabled at
//! the spec-minimum limits, an input buffer, a scratch buffer, and a micromap.

#![allow(dead_code)]

use ommcheck::Bytes;

use ommcheck::model::values::*;
use ommcheck::model::{
    CommandBuffer, MicromapBuildInfo, MicromapTriangle, MicromapUsage, UsageCounts,
};
use ommcheck::state::{Buffer, HostRange, MemoryBinding, Micromap};
use ommcheck::{Device, Profile, Validator};

/// The `VkDevice` handle host commands name.
pub const DEVICE: u64 = 0xde;
pub const INPUT: u64 = 0x1b;
pub const INPUT_ADDRESS: u64 = 0x10_0000;
pub const INPUT_SIZE: u64 = 0x1_0000;
/// Where the fixtures put the triangle array inside the input buffer.
pub const TRIANGLES_OFFSET: u64 = 0x1000;
pub const SCRATCH: u64 = 0x5b;
pub const SCRATCH_ADDRESS: u64 = 0x20_0000;
pub const STORAGE: u64 = 0x3b;
pub const STORAGE_ADDRESS: u64 = 0x30_0000;
pub const MICROMAP: u64 = 0x3a;
pub const MICROMAP_2: u64 = 0x3c;
/// Host memory for host builds.
pub const HOST_DATA: u64 = 0x7000_0000;
pub const HOST_TRIANGLES: u64 = 0x7000_1000;
pub const HOST_SCRATCH: u64 = 0x7100_0000;

pub fn device() -> Device {
    Device::with_everything(Profile::SpecMinimum)
}

/// Two 4-state level-1 triangles at data offsets 0 and 1, as bytes.
pub fn triangle_bytes(triangles: &[MicromapTriangle]) -> Vec<u8> {
    triangles.iter().flat_map(|t| t.to_bytes()).collect()
}

pub fn two_triangles() -> Vec<MicromapTriangle> {
    vec![
        MicromapTriangle {
            data_offset: 0,
            subdivision_level: 1,
            format: 2,
        },
        MicromapTriangle {
            data_offset: 1,
            subdivision_level: 1,
            format: 2,
        },
    ]
}

/// The input buffer's contents with `triangles` at [`TRIANGLES_OFFSET`].
pub fn input_contents(triangles: &[MicromapTriangle]) -> Bytes {
    let mut bytes = vec![0u8; INPUT_SIZE as usize];
    let array = triangle_bytes(triangles);
    let at = TRIANGLES_OFFSET as usize;
    bytes[at..at + array.len()].copy_from_slice(&array);
    ommcheck::Bytes::from(bytes)
}

/// A validator over [`device`] with the buffers and micromaps above.
pub fn validator_with(device: Device, triangles: &[MicromapTriangle]) -> Validator {
    let mut v = Validator::new(device);
    let state = v.state_mut();
    let bound = Some(MemoryBinding {
        host_visible: true,
        multi_instance: false,
    });
    state.buffers.insert(
        INPUT,
        Buffer {
            size: INPUT_SIZE,
            usage: BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT
                | BUFFER_USAGE_ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_BIT_KHR,
            device_address: Some(INPUT_ADDRESS),
            memory: bound,
            contents: Some(input_contents(triangles)),
            ..Default::default()
        },
    );
    state.buffers.insert(
        SCRATCH,
        Buffer {
            size: 0x1_0000,
            usage: BUFFER_USAGE_STORAGE_BUFFER_BIT,
            device_address: Some(SCRATCH_ADDRESS),
            memory: bound,
            ..Default::default()
        },
    );
    state.buffers.insert(
        STORAGE,
        Buffer {
            size: 0x1_0000,
            usage: BUFFER_USAGE_MICROMAP_STORAGE_BIT_EXT
                | BUFFER_USAGE_ACCELERATION_STRUCTURE_STORAGE_BIT_KHR,
            device_address: Some(STORAGE_ADDRESS),
            memory: bound,
            ..Default::default()
        },
    );
    for (handle, offset) in [(MICROMAP, 0), (MICROMAP_2, 0x8000)] {
        state.micromaps.insert(
            handle,
            Micromap {
                buffer: STORAGE,
                offset,
                size: 0x1000,
                ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                ..Default::default()
            },
        );
    }
    let mut host_data = vec![0u8; 0x1000];
    host_data[..2].copy_from_slice(&[0x55, 0xaa]);
    state.host_memory.push(HostRange {
        address: HOST_DATA,
        bytes: ommcheck::Bytes::from(host_data),
    });
    state.host_memory.push(HostRange {
        address: HOST_TRIANGLES,
        bytes: ommcheck::Bytes::from(triangle_bytes(triangles)),
    });
    state.host_memory.push(HostRange {
        address: HOST_SCRATCH,
        bytes: ommcheck::Bytes::from(vec![0u8; 0x1000]),
    });
    v
}

pub fn validator() -> Validator {
    validator_with(device(), &two_triangles())
}

/// Usage counts matching [`two_triangles`].
pub fn two_triangle_usage() -> UsageCounts {
    UsageCounts::array(vec![MicromapUsage {
        count: 2,
        subdivision_level: 1,
        format: OPACITY_MICROMAP_FORMAT_4_STATE,
    }])
}

/// A valid device build of [`two_triangles`] into [`MICROMAP`].
pub fn device_build() -> MicromapBuildInfo {
    MicromapBuildInfo {
        dst_micromap: MICROMAP,
        usage_counts: two_triangle_usage(),
        data: INPUT_ADDRESS,
        triangle_array: INPUT_ADDRESS + TRIANGLES_OFFSET,
        triangle_array_stride: 8,
        scratch_data: SCRATCH_ADDRESS,
        ..Default::default()
    }
}

/// A valid host build of [`two_triangles`] into [`MICROMAP`].
pub fn host_build() -> MicromapBuildInfo {
    MicromapBuildInfo {
        data: HOST_DATA,
        triangle_array: HOST_TRIANGLES,
        scratch_data: HOST_SCRATCH,
        ..device_build()
    }
}

pub fn command_buffer() -> CommandBuffer {
    CommandBuffer::default()
}

/// `v` with no buffer's device address known, so no address can be placed
/// in a buffer.
pub fn forget_addresses(mut v: Validator) -> Validator {
    let handles: Vec<_> = v.state().buffers.keys().copied().collect();
    for handle in handles {
        if let Some(mut buffer) = v.state_mut().buffers.get_mut(&handle) {
            buffer.device_address = None;
        }
    }
    v
}

/// The information finding that says `rule` was not checked because no
/// buffer address is known, naming the rule in its message.
pub fn unknown_address_skipping(
    report: &ommcheck::Report,
    rule: impl Into<ommcheck::RuleId>,
) -> &ommcheck::Finding {
    let rule = rule.into();
    let finding = report
        .not_checked()
        .find(|f| f.not_checked.contains(&rule))
        .unwrap_or_else(|| panic!("{rule} is not reported not checked: {report}"));
    assert_eq!(
        finding.not_checked_cause(),
        Some(ommcheck::Cause::UnknownAddress)
    );
    assert!(
        finding.message.contains(rule.as_str()),
        "{}",
        finding.message
    );
    assert!(!report.contains(rule), "{report}");
    finding
}
