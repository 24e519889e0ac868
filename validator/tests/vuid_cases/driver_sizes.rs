//! Cases for the rules that compare against the driver's answers
//! (`checks::driver_sizes`): the build sizes `vkGetMicromapBuildSizesEXT`
//! returned for the fixtures' build shape, and a micromap's serialization
//! size. The fixtures' micromap holds 0x1000 bytes and their scratch and
//! input buffers 0x1_0000.

use ommcheck::driver::{MicromapBuildShape, MicromapBuildSizes};
use ommcheck::model::micromap_objects::CopyMicromapToMemoryInfo;
use ommcheck::state::BuildRecord;
use ommcheck::vuids::vuid::{
    vkBuildMicromapsEXT as host, vkCmdBuildMicromapsEXT as cmd,
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
    ]
}
