//! The micromap build rules that compare against the driver's answer to
//! `vkGetMicromapBuildSizesEXT` for the build (`crate::driver`): the
//! destination's size (07461) and the scratch range (07509). Decided only
//! where an answer is stated or the driver can be asked; otherwise nothing
//! is reported, as no other information decides them. And a host build's
//! scratch against its destinations' memory as the host sees it (11668),
//! which only an adaptor that follows `vkMapMemory` knows. And whether the
//! driver accepts the serialized data a deserialization reads (07549).

use ommcheck_vuids::vuid::{
    vkBuildMicromapsEXT as host, vkCmdBuildMicromapsEXT as cmd,
    VkCopyMemoryToMicromapInfoEXT as from_memory_info,
    VkCopyMicromapToMemoryInfoEXT as to_memory_info,
};

use crate::checks::common;
use crate::checks::micromap_build::Side;
use crate::checks::Coverage;
use crate::checks::Ctx;
use crate::driver::{BuildType, MicromapBuildSizes, MicromapVersion};
use crate::model::micromap_objects::{CopyMemoryToMicromapInfo, CopyMicromapToMemoryInfo};
use crate::model::values::BUILD_MICROMAP_MODE_BUILD_EXT;
use crate::model::MicromapBuildInfo;
use crate::report::ObjectRef;

pub const COVERAGE: Coverage = Coverage {
    module: "driver_sizes",
    enforced: &[
        cmd::pInfos_07461,
        host::pInfos_07461,
        cmd::pInfos_07509,
        to_memory_info::dst_07541,
        from_memory_info::src_07549,
    ],
    not_decidable: &[],
};

/// Rules only the layer decides, with what it needs that a scene cannot
/// state (see `crate::checks::layer_only`).
pub const LAYER_ONLY: &[(ommcheck_vuids::Vuid, &str)] = &[(
    host::dstMicromap_11668,
    "needs the host address where the application mapped each dstMicromap's memory (vkMapMemory), which the layer follows and scenes do not describe; the scratch range is buildScratchSize bytes where the driver answers, its first byte otherwise",
)];

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
        if info.mode == BUILD_MICROMAP_MODE_BUILD_EXT {
            match side {
                Side::Device => scratch_range(ctx, i, info, sizes),
                _ => host_scratch_range(ctx, i, info, sizes),
            }
        }
    }
}

/// 11668: each host build's scratch, `[scratchData, + buildScratchSize)`
/// (its first byte where the driver did not answer), against the host
/// ranges where the destinations' memory is mapped. Sorted by start, with
/// the furthest end reached so far, so `infoCount` infos take n log n.
pub(crate) fn host_scratch_overlaps(ctx: &mut Ctx<'_>, infos: &[MicromapBuildInfo]) {
    let Some(state) = ctx.state else {
        return;
    };
    if state.mapped_micromaps.is_empty() {
        return;
    }
    // (start, end, info index) of each destination mapped whole.
    let mut mapped: Vec<(u64, u64, usize)> = Vec::new();
    let mut all_mapped = true;
    for (i, info) in infos.iter().enumerate() {
        let range = state.micromaps.get(&info.dst_micromap).and_then(|m| {
            let start = *state.mapped_micromaps.get(&info.dst_micromap)?;
            Some((start, start.checked_add(m.size)?, i))
        });
        match range {
            Some(range) => mapped.push(range),
            None => all_mapped = false,
        }
    }
    mapped.sort_unstable();
    let mut furthest: Vec<(u64, usize)> = Vec::with_capacity(mapped.len());
    for &(_, end, i) in &mapped {
        let reach = match furthest.last() {
            Some(&last) if last.0 >= end => last,
            _ => (end, i),
        };
        furthest.push(reach);
    }
    for (j, info) in infos.iter().enumerate() {
        let scratch = info.scratch_data;
        let len = match state
            .driver
            .micromap_build_sizes(BuildType::Host, info, ctx.device)
        {
            Some(sizes) => sizes.build_scratch_size,
            None => u64::from(info.usage_counts.total() > 0),
        };
        if scratch == 0 || len == 0 {
            continue;
        }
        let scratch_end = scratch.saturating_add(len);
        // The destinations starting before the scratch ends; the one of
        // them reaching furthest overlaps it if any does.
        let before = mapped.partition_point(|&(start, _, _)| start < scratch_end);
        match before.checked_sub(1).and_then(|k| furthest.get(k)) {
            Some(&(end, i)) if scratch < end => {
                ctx.error(
                    host::dstMicromap_11668,
                    format!("pInfos[{j}].scratchData.hostAddress"),
                    format!(
                        "the scratch [{scratch:#x}, {scratch_end:#x}) overlaps the memory of pInfos[{i}].dstMicromap, which the application mapped at {:#x}",
                        state.mapped_micromaps.get(&infos[i].dst_micromap).copied().unwrap_or_default()
                    ),
                );
            }
            _ if all_mapped => ctx.checked(&[host::dstMicromap_11668.into()]),
            _ => {}
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

/// 07541: the memory `dst` points to (to the end of the buffer holding it,
/// or of the host memory described) holds at least the serialization size
/// the driver reported for `src`. A `dst` in no known memory is another
/// rule's finding.
pub(crate) fn serialized_size_fits(
    ctx: &mut Ctx<'_>,
    info: &CopyMicromapToMemoryInfo,
    host_address: bool,
) {
    let (Some(state), Some(host)) = (ctx.state, ctx.host()) else {
        return;
    };
    let Some(size) = state.driver.serialization_size(info.src) else {
        return;
    };
    let dst = info.dst;
    let room = if host_address {
        host.bytes_from(dst).map(|bytes| bytes.len() as u64)
    } else {
        state
            .buffers_at(dst)
            .filter_map(|(_, b)| b.address_range().map(|(_, end)| end.saturating_sub(dst)))
            .max()
    };
    let Some(room) = room else {
        return;
    };
    let member = if host_address {
        "pInfo->dst.hostAddress"
    } else {
        "pInfo->dst.deviceAddress"
    };
    ctx.require(
        room >= size,
        to_memory_info::dst_07541,
        || member.to_string(),
        || {
            format!(
                "{room} bytes lie from {dst:#x} to the end of the memory holding it, fewer than the serialization size {size} the driver reports for src"
            )
        },
    );
}

/// 07549: the driver accepts the serialized data at `src` (host memory when
/// `host`): its answer for the data's version, the first 2 × `VK_UUID_SIZE`
/// bytes, is `VK_ACCELERATION_STRUCTURE_COMPATIBILITY_COMPATIBLE_KHR`.
/// Decided where those bytes are known (described host memory, stated
/// buffer contents) and the driver answered for them.
pub(crate) fn compatible_source(ctx: &mut Ctx<'_>, info: &CopyMemoryToMicromapInfo, host: bool) {
    let (Some(state), Some(host_memory)) = (ctx.state, ctx.host()) else {
        return;
    };
    if !ctx.contents || !state.driver.any_compatibility() || info.src == 0 {
        return;
    }
    let bytes = if host {
        host_memory.bytes_from(info.src)
    } else {
        state.device_bytes_from(info.src)
    };
    let version: Option<MicromapVersion> = bytes
        .and_then(|b| b.get(..32))
        .and_then(|b| b.try_into().ok());
    let Some(version) = version else {
        let rule = [from_memory_info::src_07549.into()];
        common::unreadable(ctx, host, info.src, &rule, "pInfo->src");
        return;
    };
    let Some(compatible) = state.driver.micromap_compatibility(&version) else {
        return;
    };
    let hex = |bytes: &[u8]| bytes.iter().map(|b| format!("{b:02x}")).collect::<String>();
    ctx.require(
        compatible,
        from_memory_info::src_07549,
        || "pInfo->src".to_string(),
        || {
            format!(
                "vkGetDeviceMicromapCompatibilityEXT answers VK_ACCELERATION_STRUCTURE_COMPATIBILITY_INCOMPATIBLE_KHR for the serialized data's version (driver UUID {}, compatibility data {})",
                hex(&version[..16]),
                hex(&version[16..])
            )
        },
    );
}

/// Whether a `build_type` build of `info` needs scratch memory: the
/// driver's `buildScratchSize` for it is not 0. Where the driver did not
/// answer, it is taken to (07512 and 07556 then read as they did before
/// there were answers).
pub(crate) fn needs_scratch(
    ctx: &Ctx<'_>,
    info: &MicromapBuildInfo,
    build_type: BuildType,
) -> bool {
    ctx.state
        .and_then(|state| {
            state
                .driver
                .micromap_build_sizes(build_type, info, ctx.device)
        })
        .is_none_or(|sizes| sizes.build_scratch_size != 0)
}

/// 07556 with the driver's answer: `[scratchData, + buildScratchSize)`
/// inside host memory the application described, where it described all
/// of it (a NULL scratch is `micromap_build`'s finding).
fn host_scratch_range(
    ctx: &mut Ctx<'_>,
    i: usize,
    info: &MicromapBuildInfo,
    sizes: MicromapBuildSizes,
) {
    let Some(host) = ctx.host() else {
        return;
    };
    let (start, len) = (info.scratch_data, sizes.build_scratch_size);
    if start == 0 || len == 0 || !host.describes_all() {
        return;
    }
    ctx.require(
        host.read(start, len).is_some(),
        host::pInfos_07556,
        || format!("pInfos[{i}].scratchData.hostAddress"),
        || {
            format!(
                "the buildScratchSize {len} bytes vkGetMicromapBuildSizesEXT returns for this build, from {start:#x}, do not lie in one block of the host memory the application described"
            )
        },
    );
}
