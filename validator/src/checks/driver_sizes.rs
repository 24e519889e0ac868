//! The micromap build rules that compare against the driver's answer to
//! `vkGetMicromapBuildSizesEXT` for the build (`crate::driver`): the
//! destination's size (07461) and the scratch range (07509). Decided only
//! where an answer is stated or the driver can be asked; otherwise nothing
//! is reported, as no other information decides them.

use ommcheck_vuids::vuid::{vkBuildMicromapsEXT as host, vkCmdBuildMicromapsEXT as cmd};

use crate::checks::micromap_build::Side;
use crate::checks::Coverage;
use crate::driver::{BuildType, MicromapBuildSizes};
use crate::model::values::BUILD_MICROMAP_MODE_BUILD_EXT;
use crate::model::MicromapBuildInfo;
use crate::report::ObjectRef;
use crate::validator::Ctx;

pub const COVERAGE: Coverage = Coverage {
    module: "driver_sizes",
    enforced: &[cmd::pInfos_07461, host::pInfos_07461, cmd::pInfos_07509],
    not_decidable: &[],
};

/// Checks each info of a build against the sizes the driver gives for its
/// shape.
pub(crate) fn build_sizes(ctx: &mut Ctx<'_>, infos: &[MicromapBuildInfo], side: Side) {
    let (build_type, dst_size) = match side {
        Side::Device => (BuildType::Device, cmd::pInfos_07461),
        Side::Host => (BuildType::Host, host::pInfos_07461),
        Side::SizeQuery => return,
    };
    let Some(state) = ctx.state else {
        return;
    };
    if !state.driver.any() {
        return;
    }
    for (i, info) in infos.iter().enumerate() {
        let Some(sizes) = state
            .driver
            .micromap_build_sizes(build_type, info, ctx.device)
        else {
            continue;
        };
        // An unknown dstMicromap is 07463's finding.
        if let Some(micromap) = state.micromaps.get(&info.dst_micromap) {
            let created = micromap.size;
            if created < sizes.micromap_size {
                ctx.error(
                    dst_size,
                    format!("pInfos[{i}].dstMicromap"),
                    format!(
                        "dstMicromap was created with size {created}, less than the micromapSize {} that vkGetMicromapBuildSizesEXT returns for this build",
                        sizes.micromap_size
                    ),
                )
                .objects
                .push(ObjectRef {
                    ty: "VkMicromapEXT",
                    handle: info.dst_micromap,
                });
            } else {
                ctx.checked(&[dst_size.into()]);
            }
        }
        if side == Side::Device && info.mode == BUILD_MICROMAP_MODE_BUILD_EXT {
            scratch_range(ctx, i, info, sizes);
        }
    }
}

/// 07509: `[scratchData, scratchData + buildScratchSize)` inside one
/// buffer's device-address range. A start no buffer holds is 07512's
/// finding; with no buffer address known nothing is decided.
fn scratch_range(ctx: &mut Ctx<'_>, i: usize, info: &MicromapBuildInfo, sizes: MicromapBuildSizes) {
    let Some(state) = ctx.state else {
        return;
    };
    let (start, len) = (info.scratch_data, sizes.build_scratch_size);
    if len == 0 || !state.knows_addresses() {
        return;
    }
    // The furthest end among the buffers holding the start.
    let Some(end) = state
        .buffers_at(start)
        .filter_map(|(_, b)| b.address_range().map(|(_, end)| end))
        .max()
    else {
        return;
    };
    ctx.require(
        state.range_in_one_buffer(start, len),
        cmd::pInfos_07509,
        || format!("pInfos[{i}].scratchData.deviceAddress"),
        || {
            format!(
                "the buildScratchSize {len} bytes vkGetMicromapBuildSizesEXT returns for this build, from {start:#x}, run past {end:#x}, the end of the buffer holding {start:#x}"
            )
        },
    );
}
