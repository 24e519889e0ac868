//! Cases for the rules that compare against the driver's answers
//! (`checks::driver_sizes`): the build sizes `vkGetMicromapBuildSizesEXT`
//! returned for the fixtures' build shape, and a micromap's serialization
//! size, and the compatibility `vkGetDeviceMicromapCompatibilityEXT`
//! answered for serialized data. The fixtures' micromap holds 0x1000 bytes
//! and their scratch and input buffers 0x1_0000.

use ommcheck::driver::{MicromapBuildShape, MicromapBuildSizes, MicromapVersion};
use ommcheck::model::micromap_objects::{CopyMemoryToMicromapInfo, CopyMicromapToMemoryInfo};
use ommcheck::state::BuildRecord;
use ommcheck::vuids::vuid::{
    vkBuildMicromapsEXT as host, vkCmdBuildMicromapsEXT as cmd,
    VkCopyMemoryToMicromapInfoEXT as from_memory_info,
    VkCopyMicromapToMemoryInfoEXT as to_memory_info,
};
use ommcheck::{Report, Validator};

use crate::fixtures::*;
use crate::{case, Case};

/// [`validator`] after the driver answered `sizes` for the fixtures' build
/// shape.
fn answered(micromap_size: u64, build_scratch_size: u64) -> Validator {
    let mut v = validator();
    let sizes = MicromapBuildSizes {
        micromap_size,
        build_scratch_size,
        discardable: false,
    };
    let shape = MicromapBuildShape::of(&device_build());
    v.state_mut()
        .driver
        .state_micromap_build_sizes(shape, sizes);
    v
}

fn cmd_build(micromap_size: u64, build_scratch_size: u64) -> Report {
    answered(micromap_size, build_scratch_size)
        .cmd_build_micromaps(&command_buffer(), &[device_build()])
}

fn host_build_answered(micromap_size: u64) -> Report {
    answered(micromap_size, 0x100).build_micromaps(DEVICE, 0, &[host_build()])
}

/// Serializes the built [`MICROMAP`] to the start of the input buffer
/// (0x1_0000 bytes) after the driver reported its serialization size.
fn serialize(serialization_size: u64) -> Report {
    let mut v = validator();
    let state = v.state_mut();
    if let Some(micromap) = state.micromaps.get_mut(&MICROMAP) {
        micromap.built = Some(BuildRecord {
            triangle_count: 2,
            ..Default::default()
        });
    }
    state
        .driver
        .state_serialization_size(MICROMAP, serialization_size);
    let info = CopyMicromapToMemoryInfo {
        src: MICROMAP,
        dst: INPUT_ADDRESS,
        ..Default::default()
    };
    v.cmd_copy_micromap_to_memory(&command_buffer(), Some(&info))
}

/// The first 32 bytes at `address` (host memory when `host`) of the
/// fixtures' validator: the version of the serialized data there.
fn version_at(v: &Validator, address: u64, host: bool) -> MicromapVersion {
    let bytes = if host {
        v.state().host_bytes_from(address)
    } else {
        v.state().device_bytes_from(address)
    };
    let header = bytes
        .and_then(|b| b.get(..32))
        .expect("the fixtures' bytes");
    header.try_into().expect("32 bytes")
}

/// Deserializes the data at [`HOST_DATA`] (host) or [`INPUT_ADDRESS`]
/// (device) into [`MICROMAP`], after the driver answered `compatible` for
/// the data's version (or nothing, for None).
fn deserialize(host: bool, compatible: Option<bool>) -> Report {
    deserialize_answered(host, |version| compatible.map(|c| (version, c)))
}

/// As [`deserialize`], the driver's answer (a version and whether it is
/// compatible) made by `answer` from the data's version.
fn deserialize_answered(
    host: bool,
    answer: impl FnOnce(MicromapVersion) -> Option<(MicromapVersion, bool)>,
) -> Report {
    let mut v = validator();
    let src = if host { HOST_DATA } else { INPUT_ADDRESS };
    if let Some((version, compatible)) = answer(version_at(&v, src, host)) {
        v.state_mut()
            .driver
            .state_micromap_compatibility(version, compatible);
    }
    let info = CopyMemoryToMicromapInfo {
        src,
        dst: MICROMAP,
        ..Default::default()
    };
    if host {
        v.copy_memory_to_micromap(DEVICE, 0, Some(&info))
    } else {
        v.cmd_copy_memory_to_micromap(&command_buffer(), Some(&info))
    }
}

#[test]
fn a_device_deserialization_is_checked_against_the_compatibility_answer() {
    let rule = from_memory_info::src_07549;
    let incompatible = deserialize(false, Some(false));
    assert!(incompatible.contains(rule), "{incompatible:?}");
    let compatible = deserialize(false, Some(true));
    assert!(!compatible.contains(rule), "{compatible:?}");
    assert!(compatible.checked.contains(rule));
    // Without an answer for the data's version nothing is decided.
    let unknown = deserialize(false, None);
    assert!(!unknown.contains(rule) && !unknown.checked.contains(rule));
}

#[test]
fn another_version_s_answer_does_not_decide_the_data() {
    let report = deserialize_answered(true, |mut version| {
        version[0] ^= 1;
        Some((version, false))
    });
    let rule = from_memory_info::src_07549;
    assert!(
        !report.contains(rule) && !report.checked.contains(rule),
        "{report:?}"
    );
}

pub fn cases() -> Vec<Case> {
    vec![
        case(
            cmd::pInfos_07461,
            || cmd_build(0x1001, 0x100),
            || cmd_build(0x1000, 0x100),
        ),
        case(
            host::pInfos_07461,
            || host_build_answered(0x1001),
            || host_build_answered(0x1000),
        ),
        case(
            cmd::pInfos_07509,
            || cmd_build(0x100, 0x1_0001),
            || cmd_build(0x100, 0x1_0000),
        ),
        case(
            to_memory_info::dst_07541,
            || serialize(0x1_0001),
            || serialize(0x1_0000),
        ),
        case(
            from_memory_info::src_07549,
            || deserialize(true, Some(false)),
            || deserialize(true, Some(true)),
        ),
    ]
}
