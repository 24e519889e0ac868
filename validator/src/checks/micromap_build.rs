//! `VkMicromapBuildInfoEXT`, `vkCmdBuildMicromapsEXT` and `vkBuildMicromapsEXT`.

use std::collections::hash_map::{Entry, HashMap};
use std::fmt::Display;
use std::sync::Arc;

use ommcheck_vuids::vuid::{
    vkBuildMicromapsEXT as host, vkCmdBuildMicromapsEXT as cmd, VkMicromapBuildInfoEXT as info_vuid,
};

use crate::checks::common::{
    self, readable_entries, usage_counts_match_triangles, CleanRun, CommandBufferVuids, Tally,
    TriangleHistogram,
};
use crate::checks::usage_counts::{self, EntryVuids, PointerVuids};
use crate::checks::usage_keys::{self, UsageKeys};
use crate::checks::Coverage;
use crate::checks::{driver_sizes, hygiene};
use crate::checks::{Ctx, Validator};
use crate::driver::BuildType;
use crate::model::micromap::opacity_triangle_bytes;
use crate::model::values::FormatKind;
use crate::model::values::*;
use crate::model::Handle;
use crate::model::{CommandBuffer, MicromapBuildInfo, MicromapTriangle};
use crate::report::location::Locate;
use crate::report::{Report, RuleId};
use crate::rules;
use crate::sim::decode::{MicromapContent, TriangleEntries};
use crate::state::{BuildRecord, HostMemory, HostRange, State};
use crate::tier::Tier;

pub const COVERAGE: Coverage = Coverage {
    module: "micromap_build",
    enforced: &[
        info_vuid::sType_sType,
        info_vuid::pNext_pNext,
        info_vuid::type_parameter,
        info_vuid::flags_parameter,
        info_vuid::pUsageCounts_07516,
        info_vuid::pUsageCounts_parameter,
        info_vuid::ppUsageCounts_parameter,
        info_vuid::format_11652,
        info_vuid::format_11653,
        info_vuid::subdivisionLevel_11654,
        info_vuid::subdivisionLevel_11655,
        info_vuid::subdivisionLevel_11656,
        info_vuid::format_11657,
        info_vuid::format_11658,
        info_vuid::subdivisionLevel_11659,
        info_vuid::subdivisionLevel_11660,
        info_vuid::subdivisionLevel_11661,
        cmd::commandBuffer_parameter,
        cmd::commandBuffer_recording,
        cmd::commandBuffer_cmdpool,
        cmd::renderpass,
        cmd::videocoding,
        cmd::suspended,
        cmd::infoCount_arraylength,
        cmd::pInfos_parameter,
        cmd::micromap_11648,
        cmd::mode_07462,
        cmd::dstMicromap_07463,
        cmd::pInfos_07464,
        cmd::pInfos_07508,
        cmd::data_07510,
        cmd::pInfos_07511,
        cmd::pInfos_07512,
        cmd::pInfos_07514,
        cmd::pInfos_07515,
        cmd::pInfos_10896,
        cmd::pInfos_10897,
        cmd::dstMicromap_11649,
        cmd::dstMicromap_11650,
        cmd::scratchData_11651,
        host::infoCount_arraylength,
        host::pInfos_parameter,
        host::device_parameter,
        host::deferredOperation_parameter,
        host::deferredOperation_parent,
        host::micromapHostCommands_07555,
        host::mode_07462,
        host::dstMicromap_07463,
        host::pInfos_07464,
        host::pInfos_07552,
        host::pInfos_07553,
        host::pInfos_07554,
        host::pInfos_07556,
        host::pInfos_07557,
        host::dstMicromap_11667,
        host::scratchData_11669,
    ],
    not_decidable: &[],
};

/// Whether the command reads device or host memory, or (a size query) none.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Side {
    Device,
    Host,
    /// `vkGetMicromapBuildSizesEXT`: addresses are ignored, contents never read.
    SizeQuery,
}

impl Validator {
    /// `vkCmdBuildMicromapsEXT(commandBuffer, infoCount, pInfos)`: its rules
    /// ([`Self::cmd_build_micromaps_rules`]), then its record
    /// ([`Self::record_cmd_build_micromaps`]).
    pub fn cmd_build_micromaps(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[MicromapBuildInfo],
    ) -> Report {
        let report = self.cmd_build_micromaps_rules(command_buffer, infos);
        self.record_cmd_build_micromaps(command_buffer, infos);
        report
    }

    /// The rules of `vkCmdBuildMicromapsEXT`; records nothing.
    pub fn cmd_build_micromaps_rules(
        &self,
        command_buffer: &CommandBuffer,
        infos: &[MicromapBuildInfo],
    ) -> Report {
        let mut ctx = self.ctx("vkCmdBuildMicromapsEXT");
        cmd_build_micromaps_rules(&mut ctx, command_buffer, infos);
        crate::report::objects::micromap_builds(&mut ctx.report, infos);
        ctx.finish()
    }

    /// Records the builds `vkCmdBuildMicromapsEXT` put in `command_buffer`:
    /// what each makes of its destination, as far as the tracked buffers'
    /// contents tell now.
    pub fn record_cmd_build_micromaps(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[MicromapBuildInfo],
    ) {
        self.record_builds(infos, None);
        let constructs = infos
            .iter()
            .map(|info| crate::state::execution::ExecEvent::Construct {
                object: info.dst_micromap,
            });
        self.record_execution(command_buffer, "vkCmdBuildMicromapsEXT", constructs);
    }

    /// `vkBuildMicromapsEXT(device, deferredOperation, infoCount, pInfos)`: a
    /// build on the host; every address is a host address. A non-NULL
    /// `deferred_operation` is taken to be running the build until
    /// [`Validator::deferred_operation_completed`] says otherwise. Its rules
    /// ([`Self::build_micromaps_rules`]), then its record
    /// ([`Self::record_micromaps_built`]), reading the host memory the
    /// application described.
    pub fn build_micromaps(
        &mut self,
        device: Handle,
        deferred_operation: Handle,
        infos: &[MicromapBuildInfo],
    ) -> Report {
        let report = self.build_micromaps_rules(device, deferred_operation, infos, &[]);
        self.record_micromaps_built(deferred_operation, infos, &[]);
        report
    }

    /// The rules of `vkBuildMicromapsEXT`, before the call, with
    /// `read_for_call`, the host memory an adaptor read for it (see
    /// [`crate::state::HostMemory`]); records nothing.
    pub fn build_micromaps_rules(
        &self,
        device: Handle,
        deferred_operation: Handle,
        infos: &[MicromapBuildInfo],
        read_for_call: &[HostRange],
    ) -> Report {
        let mut ctx = self.ctx_reading("vkBuildMicromapsEXT", read_for_call);
        common::device_handle(&mut ctx, device, host::device_parameter);
        common::deferred_operation(
            &mut ctx,
            deferred_operation,
            &common::DeferredOperationVuids {
                parameter: host::deferredOperation_parameter,
                parent: host::deferredOperation_parent,
                complete: None,
            },
        );
        ctx.require(
            !infos.is_empty(),
            host::infoCount_arraylength,
            || "infoCount".into(),
            || "infoCount is 0".into(),
        );
        ctx.require(
            ctx.device.features.micromap_host_commands,
            host::micromapHostCommands_07555,
            String::new,
            || "the VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromapHostCommands feature is not enabled".into(),
        );
        for (i, info) in infos.iter().enumerate() {
            let at = "pInfos".index(i);
            build_info(&mut ctx, at, info, Side::Host);
            ctx.require(
                info.mode == BUILD_MICROMAP_MODE_BUILD_EXT,
                host::mode_07462,
                || format!("{at}.mode"),
                || format!("{} is not a VkBuildMicromapModeEXT value", info.mode),
            );
            if let Some(buffer) = dst_micromap(
                &mut ctx,
                i,
                info,
                host::dstMicromap_07463,
                host::pInfos_07464,
            ) {
                // dst_micromap found the micromap, so the state is known.
                let memory = ctx
                    .state
                    .and_then(|state| state.buffers.get(&buffer))
                    .and_then(|b| b.memory);
                ctx.require(
                    memory.is_some_and(|m| m.host_visible),
                    host::pInfos_07552,
                    || format!("{at}.dstMicromap"),
                    || format!("the buffer VkBuffer {buffer:#x} of dstMicromap is not bound to host-visible memory"),
                );
                ctx.require(
                    !memory.is_some_and(|m| m.multi_instance),
                    host::pInfos_07557,
                    || format!("{at}.dstMicromap"),
                    || format!("the buffer VkBuffer {buffer:#x} of dstMicromap is bound to memory allocated with multiple instances"),
                );
            }
            let needed = info.usage_counts.has_triangles();
            for (address, member, vuid) in [
                (info.data, "data", host::pInfos_07553),
                (info.triangle_array, "triangleArray", host::pInfos_07554),
            ] {
                // Decided where the address is NULL, inside described host
                // memory, or outside all of it; otherwise the triangle-array
                // check says it was not checked (from the content tier on).
                if needed
                    && ctx.host().is_some_and(|host| {
                        host.describes_all() || host.bytes_from(address).is_some()
                    })
                {
                    ctx.checked(&[vuid.into()]);
                }
                if needed && address == 0 {
                    ctx.error(
                        vuid,
                        format!("{at}.{member}.hostAddress"),
                        "the host address is NULL, but the build has triangles",
                    );
                } else if needed
                    && ctx.host().is_some_and(|host| {
                        host.describes_all() && host.bytes_from(address).is_none()
                    })
                {
                    ctx.error(
                        vuid,
                        format!("{at}.{member}.hostAddress"),
                        format!(
                            "{address:#x} is outside the host memory the application described"
                        ),
                    );
                }
            }
            if needed
                && info.scratch_data == 0
                && driver_sizes::needs_scratch(&ctx, info, BuildType::Host)
            {
                ctx.error(
                    host::pInfos_07556,
                    format!("{at}.scratchData.hostAddress"),
                    "the scratch host address is NULL for a build with triangles",
                );
            }
        }
        overlaps(&mut ctx, infos, Side::Host);
        crate::checks::driver_sizes::build_sizes(&mut ctx, infos, Side::Host);
        crate::checks::driver_sizes::host_scratch_overlaps(&mut ctx, infos);
        crate::report::objects::micromap_builds(&mut ctx.report, infos);
        ctx.finish()
    }

    /// Records what `vkBuildMicromapsEXT` built (or, deferred, is
    /// building), reading its inputs in the host memory the application
    /// described and `read_for_call` (as its rules did).
    pub fn record_micromaps_built(
        &mut self,
        deferred_operation: Handle,
        infos: &[MicromapBuildInfo],
        read_for_call: &[HostRange],
    ) {
        self.record_builds(infos, Some(read_for_call));
        self.defer(deferred_operation);
        for info in infos {
            self.constructed_on_host(info.dst_micromap, deferred_operation);
        }
    }

    /// Remembers what each build made of its destination micromap: its
    /// triangle count and (from the content tier up) its content as far as
    /// the memory it reads is known. `host`: a host build, with the host
    /// memory read for the call.
    fn record_builds(&mut self, infos: &[MicromapBuildInfo], host: Option<&[HostRange]>) {
        for info in infos {
            let content = (self.tier >= Tier::Content)
                .then(|| {
                    let host = host.map(|read_for_call| self.state.host_memory(read_for_call));
                    built_content(&self.state, host, info)
                })
                .flatten();
            // Beside the content, for pictures only: one entry per key,
            // bounded by the usage entries the reader already holds.
            let usage_counts = if content.is_some() {
                common::declared_counts(&info.usage_counts)
                    .into_iter()
                    .collect()
            } else {
                Vec::new()
            };
            self.state.driver.forget_micromap(info.dst_micromap);
            self.state.provenance.constructed(info.dst_micromap);
            if let Some(micromap) = self.state.micromaps.get_mut(&info.dst_micromap) {
                micromap.built = Some(BuildRecord {
                    flags: info.flags,
                    ty: info.ty,
                    triangle_count: info.usage_counts.total(),
                    content: content.map(Arc::new),
                    usage_counts,
                    ..Default::default()
                });
            }
        }
    }
}

/// The rules of `vkCmdBuildMicromapsEXT` (without recording the builds).
pub(crate) fn cmd_build_micromaps_rules(
    ctx: &mut Ctx<'_>,
    command_buffer: &CommandBuffer,
    infos: &[MicromapBuildInfo],
) {
    common::command_buffer(
        ctx,
        command_buffer,
        &CommandBufferVuids {
            parameter: cmd::commandBuffer_parameter,
            recording: cmd::commandBuffer_recording,
            cmdpool: cmd::commandBuffer_cmdpool,
            renderpass: Some(cmd::renderpass),
            videocoding: Some(cmd::videocoding),
            suspended: Some(cmd::suspended),
        },
    );
    ctx.require(
        !infos.is_empty(),
        cmd::infoCount_arraylength,
        || "infoCount".into(),
        || "infoCount is 0".into(),
    );
    ctx.require(
        ctx.device.features.micromap_ext,
        cmd::micromap_11648,
        String::new,
        || "the VkPhysicalDeviceOpacityMicromapFeaturesEXT::micromap feature is not enabled".into(),
    );
    for (i, info) in infos.iter().enumerate() {
        let at = "pInfos".index(i);
        build_info(ctx, at, info, Side::Device);
        ctx.require(
            info.mode == BUILD_MICROMAP_MODE_BUILD_EXT,
            cmd::mode_07462,
            || format!("{at}.mode"),
            || format!("{} is not a VkBuildMicromapModeEXT value", info.mode),
        );
        if let Some(micromap) =
            dst_micromap(ctx, i, info, cmd::dstMicromap_07463, cmd::pInfos_07464)
        {
            // dst_micromap found the micromap, so the state is known.
            let bound = ctx
                .state
                .and_then(|state| state.buffers.get(&micromap))
                .is_some_and(|b| b.memory.is_some());
            ctx.require(bound, cmd::pInfos_07508, || format!("{at}.dstMicromap"), || format!("the buffer VkBuffer {micromap:#x} of dstMicromap is not bound to device memory"));
        }
        common::valid_device_address(
            ctx,
            info.data,
            cmd::pInfos_10896,
            at.text(".data.deviceAddress"),
        );
        common::valid_device_address(
            ctx,
            info.triangle_array,
            cmd::pInfos_10897,
            at.text(".triangleArray.deviceAddress"),
        );
        common::aligned(
            ctx,
            info.data,
            256,
            cmd::pInfos_07515,
            at.text(".data.deviceAddress"),
        );
        common::aligned(
            ctx,
            info.triangle_array,
            256,
            cmd::pInfos_07515,
            at.text(".triangleArray.deviceAddress"),
        );
        for (address, member) in [(info.data, "data"), (info.triangle_array, "triangleArray")] {
            common::device_address_usage(
                ctx,
                address,
                BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT,
                "VK_BUFFER_USAGE_MICROMAP_BUILD_INPUT_READ_ONLY_BIT_EXT",
                cmd::data_07510,
                format_args!("{at}.{member}.deviceAddress"),
            );
        }
        if info.scratch_data != 0 {
            if ctx.state.is_some_and(|state| {
                state.knows_addresses() && state.buffers_at(info.scratch_data).next().is_none()
            }) && driver_sizes::needs_scratch(ctx, info, BuildType::Device)
            {
                ctx.error(
                    cmd::pInfos_07512,
                    format!("{at}.scratchData.deviceAddress"),
                    format!(
                        "{:#x} is inside no buffer's device-address range",
                        info.scratch_data
                    ),
                );
            }
            common::device_address_usage(
                ctx,
                info.scratch_data,
                BUFFER_USAGE_STORAGE_BUFFER_BIT,
                "VK_BUFFER_USAGE_STORAGE_BUFFER_BIT",
                cmd::pInfos_07511,
                at.text(".scratchData.deviceAddress"),
            );
        }
        let alignment = u64::from(
            ctx.device
                .limits
                .min_acceleration_structure_scratch_offset_alignment,
        );
        common::aligned(
            ctx,
            info.scratch_data,
            alignment,
            cmd::pInfos_07514,
            at.text(".scratchData.deviceAddress"),
        );
    }
    overlaps(ctx, infos, Side::Device);
    crate::checks::driver_sizes::build_sizes(ctx, infos, Side::Device);
}

/// Looks up `dstMicromap` (07463) and checks the build type matches its
/// creation type (07464). Returns the buffer backing it; None also below
/// the state tier, where nothing is known of it.
fn dst_micromap(
    ctx: &mut Ctx<'_>,
    i: usize,
    info: &MicromapBuildInfo,
    valid: ommcheck_vuids::Vuid,
    same_type: ommcheck_vuids::Vuid,
) -> Option<Handle> {
    let state = ctx.state?;
    let Some(micromap) = state.micromaps.get(&info.dst_micromap) else {
        ctx.error(
            valid,
            format!("pInfos[{i}].dstMicromap"),
            format!(
                "{:#x} is not a VkMicromapEXT created on this device",
                info.dst_micromap
            ),
        )
        .objects
        .push(crate::report::ObjectRef {
            ty: "VkMicromapEXT",
            handle: info.dst_micromap,
        });
        return None;
    };
    let (ty, buffer) = (micromap.ty, micromap.buffer);
    ctx.require(
        ty == info.ty,
        same_type,
        || format!("pInfos[{i}].type"),
        || {
            format!(
                "the build's type {} differs from the type {} dstMicromap was created with",
                micromap_type_name(info.ty),
                micromap_type_name(ty)
            )
        },
    );
    Some(buffer)
}

/// Memory ranges `[start, end)` the builds write: each dstMicromap's backing
/// memory (when its buffer's address is known) and each scratch start.
///
/// Each info is reported at most once per rule, against one other info it
/// collides with, and the collisions are found by sorting: comparing every
/// pair, as the rules read, would take time and findings quadratic in
/// `infoCount` (the reader takes up to 2^20 infos: 2^39 pairs, and as many
/// findings when all name one micromap).
fn overlaps(ctx: &mut Ctx<'_>, infos: &[MicromapBuildInfo], side: Side) {
    let (dst_dst, dst_scratch, scratch_scratch) = match side {
        Side::Device => (
            cmd::dstMicromap_11649,
            cmd::dstMicromap_11650,
            cmd::scratchData_11651,
        ),
        // Host scratch is host memory; the destination is device memory
        // reached through a mapping: 11668 is decided where the mapping is
        // known (checks::driver_sizes), not here.
        Side::Host | Side::SizeQuery => (
            host::dstMicromap_11667,
            host::dstMicromap_11668,
            host::scratchData_11669,
        ),
    };
    let Some(state) = ctx.state else {
        return;
    };
    let dst_range = |info: &MicromapBuildInfo| -> Option<(u64, u64)> {
        let micromap = state.micromaps.get(&info.dst_micromap)?;
        let (start, _) = state.buffers.get(&micromap.buffer)?.address_range()?;
        let begin = start.checked_add(micromap.offset)?;
        Some((begin, begin.checked_add(micromap.size)?))
    };
    // (start, end, info index), by start (then index).
    let mut sorted: Vec<(u64, u64, usize)> = infos
        .iter()
        .enumerate()
        .filter_map(|(k, info)| dst_range(info).map(|(start, end)| (start, end, k)))
        .collect();
    sorted.sort_unstable();
    // For each position, the range among those up to it that reaches
    // furthest: any range overlapping a later-starting one overlaps it too.
    let mut furthest: Vec<(u64, u64, usize)> = Vec::with_capacity(sorted.len());
    for &range in &sorted {
        let reach = match furthest.last() {
            Some(&last) if last.1 >= range.1 => last,
            _ => range,
        };
        if let Some(&(a_start, a_end, a)) = furthest.last() {
            let (b_start, b_end, b) = range;
            if a_start < b_end && b_start < a_end {
                let ((i, (i_start, i_end)), (j, (j_start, j_end))) = if a < b {
                    ((a, (a_start, a_end)), (b, (b_start, b_end)))
                } else {
                    ((b, (b_start, b_end)), (a, (a_start, a_end)))
                };
                ctx.error(dst_dst, format!("pInfos[{j}].dstMicromap"), format!("its memory [{j_start:#x}, {j_end:#x}) overlaps that of pInfos[{i}].dstMicromap [{i_start:#x}, {i_end:#x})"));
            }
        }
        furthest.push(reach);
    }
    // The scratch size is the implementation's; a scratch start inside a
    // destination is an overlap whatever that size is.
    for (j, info) in infos.iter().enumerate() {
        if info.scratch_data == 0 || side == Side::Host {
            continue;
        }
        // The last range starting at or before the scratch start, and the
        // furthest-reaching range up to it.
        let at = sorted.partition_point(|&(start, _, _)| start <= info.scratch_data);
        let Some(&(_, end, i)) = at.checked_sub(1).and_then(|k| furthest.get(k)) else {
            continue;
        };
        if info.scratch_data < end {
            ctx.error(
                dst_scratch,
                format!("pInfos[{j}].scratchData"),
                format!(
                    "{:#x} lies inside the memory of pInfos[{i}].dstMicromap",
                    info.scratch_data
                ),
            );
        }
    }
    // The first info using each scratch start.
    let mut first_with: HashMap<u64, usize> = HashMap::new();
    for (j, b) in infos.iter().enumerate() {
        if b.scratch_data == 0 || !b.usage_counts.has_triangles() {
            continue;
        }
        match first_with.entry(b.scratch_data) {
            Entry::Vacant(vacant) => {
                vacant.insert(j);
            }
            Entry::Occupied(first) => {
                let i = *first.get();
                ctx.error(
                    scratch_scratch,
                    format!("pInfos[{j}].scratchData"),
                    format!(
                        "pInfos[{i}] and pInfos[{j}] use the same scratch memory {:#x}",
                        b.scratch_data
                    ),
                );
            }
        }
    }
}

/// `VkMicromapBuildInfoEXT` itself, the usage counts, and (when the checker
/// can read them) the triangle array's entries.
pub(crate) fn build_info(
    ctx: &mut Ctx<'_>,
    at: impl Display + Copy,
    info: &MicromapBuildInfo,
    side: Side,
) {
    ctx.require(
        info.s_type == STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT,
        info_vuid::sType_sType,
        || format!("{at}.sType"),
        || {
            format!(
                "{} is not VK_STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT",
                structure_type_name(info.s_type)
            )
        },
    );
    if let Some(s_type) = info.next.first() {
        ctx.error(
            info_vuid::pNext_pNext,
            format!("{at}.pNext"),
            format!(
                "VkMicromapBuildInfoEXT extends with no structure, but pNext has sType {}",
                structure_type_name(*s_type)
            ),
        );
    }
    let opacity = info.ty == MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
    let displacement = info.ty == MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
    ctx.require(
        opacity || displacement,
        info_vuid::type_parameter,
        || format!("{at}.type"),
        || format!("{} is not a VkMicromapTypeEXT value", info.ty),
    );
    ctx.require(
        info.flags & !BUILD_MICROMAP_FLAGS_ALL == 0,
        info_vuid::flags_parameter,
        || format!("{at}.flags"),
        || {
            format!(
                "{:#x} has bits outside VkBuildMicromapFlagBitsEXT",
                info.flags
            )
        },
    );

    let counts = &info.usage_counts;
    usage_counts::pointer_rules(ctx, at, counts, &USAGE_POINTERS);

    if !(opacity || displacement) {
        return;
    }
    let maxima = usage_keys::ext_usage_maxima(&ctx.device.limits);
    let keys = UsageKeys::ext(opacity, maxima);
    let member = counts.member();
    // One pass over the entries against the allowed keys, which also sums
    // the counts; the rules with their locations and messages run per entry
    // only where some entry is outside the table.
    let scan = keys.scan(counts);
    let total = scan.total;
    for (k, usage) in scan.entries {
        let loc = format_args!("{at}.{member}[{k}]");
        usage_counts::entry_rules(ctx, loc, usage, opacity, maxima, &USAGE_ENTRIES);
    }
    if side != Side::SizeQuery {
        triangle_array_stride(ctx, at, info, total);
        common::triangle_array_holds_every_entry(
            ctx,
            format_args!("{at}.triangleArray"),
            (info.triangle_array, side == Side::Host),
            info.triangle_array_stride,
            &info.usage_counts,
            format_names(opacity),
        );
        triangle_array(ctx, at, info, side, opacity, total);
    }
}

/// What a build of `info` makes of its destination, as far as the memory
/// it reads is known: the triangle array's entries (as many as its bytes
/// hold, at most the usage counts' sum), and the data, both shared with the
/// memory holding them; None where the type is neither opacity nor
/// displacement, there are no triangles or the array is unreadable (as for
/// the rules, which then read no entry). `host`: a host build's memory (None: device
/// memory, in the tracked buffers).
pub(crate) fn built_content(
    state: &State,
    host: Option<HostMemory<'_>>,
    info: &MicromapBuildInfo,
) -> Option<MicromapContent> {
    let opacity = info.ty == MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
    let displacement = info.ty == MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
    let triangles = info.usage_counts.total();
    if !(opacity || displacement) || triangles == 0 {
        return None;
    }
    let shared_from = |address: u64| match host {
        Some(host) => host.contents_from(address),
        None => state.device_contents_from(address),
    };
    let (array_memory, array_start) = shared_from(info.triangle_array)?;
    let array_len = array_memory.get(array_start..)?.len() as u64;
    let stride = info.triangle_array_stride;
    // A stride of 0 makes every triangle read the one entry.
    let entries_to_read = if stride == 0 { 1 } else { triangles };
    let entries_read = readable_entries(array_len, stride).min(entries_to_read);
    // A view of the array's bytes, not a copy of its entries.
    let entries = TriangleEntries::shared(
        array_memory,
        array_start,
        stride.max(MicromapTriangle::SIZE),
        entries_read,
    )
    .unwrap_or_else(|| Vec::new().into());
    let (data, data_start) = shared_from(info.data).unwrap_or_else(|| (crate::Bytes::new(), 0));
    let content = MicromapContent::at(entries, data, data_start);
    Some(if stride == 0 {
        content.repeating(triangles)
    } else {
        content
    })
}

/// `VkMicromapBuildInfoEXT`'s usage-count pointers (07516).
const USAGE_POINTERS: PointerVuids = PointerVuids {
    one_of: info_vuid::pUsageCounts_07516,
    array: info_vuid::pUsageCounts_parameter,
    pointers: info_vuid::ppUsageCounts_parameter,
};

/// `VkMicromapBuildInfoEXT`'s usage entries against the build's type
/// (11652-11656).
const USAGE_ENTRIES: EntryVuids = EntryVuids {
    opacity_format: info_vuid::format_11652,
    opacity_2_state_level: info_vuid::subdivisionLevel_11654,
    opacity_4_state_level: info_vuid::subdivisionLevel_11655,
    displacement_format: info_vuid::format_11653,
    displacement_level: info_vuid::subdivisionLevel_11656,
    name_the_type: false,
};

/// The triangle array's stride against the entries' 8 bytes: decided by the
/// parameters alone (KHR states it as 11646/11647).
/// `triangles` is the sum of the usage counts.
fn triangle_array_stride(
    ctx: &mut Ctx<'_>,
    at: impl Display,
    info: &MicromapBuildInfo,
    triangles: u64,
) {
    let stride = info.triangle_array_stride;
    if stride >= MicromapTriangle::SIZE && stride.is_multiple_of(4) {
        return;
    }
    if triangles > 1 {
        ctx.report(
            &rules::EXT_TRIANGLE_ARRAY_STRIDE,
            crate::report::Severity::Warning,
            format!("{at}.triangleArrayStride"),
            format!("{stride} is below 8 or not a multiple of 4, so the {triangles} entries overlap or are misaligned"),
        );
    }
}

/// The enum that names the formats of an opacity or displacement micromap.
fn format_names(opacity: bool) -> FormatKind {
    if opacity {
        FormatKind::OpacityExt
    } else {
        FormatKind::DisplacementNv
    }
}

/// The rules that read a triangle array's entries: formats and levels,
/// the array's and each triangle's data extent, and the usage counts
/// against the entries.
fn entry_rules(opacity: bool) -> Vec<RuleId> {
    let formats_and_levels = if opacity {
        [
            info_vuid::format_11657,
            info_vuid::subdivisionLevel_11659,
            info_vuid::subdivisionLevel_11660,
        ]
    } else {
        [
            info_vuid::format_11658,
            info_vuid::subdivisionLevel_11661,
            info_vuid::subdivisionLevel_11661,
        ]
    };
    let mut read: Vec<RuleId> = formats_and_levels.into_iter().map(RuleId::from).collect();
    read.dedup();
    read.extend([
        RuleId::from(&rules::TRIANGLE_ARRAY_RANGE),
        RuleId::from(&rules::HISTOGRAM_MISMATCH),
    ]);
    if opacity {
        read.push(RuleId::from(&rules::TRIANGLE_DATA_RANGE));
    }
    read
}

/// The triangle array's entries, when the checker can read them: each entry's
/// format and level (11657-11661), its data inside `data`, and the usage
/// counts against the entries.
fn triangle_array(
    ctx: &mut Ctx<'_>,
    at: impl Display,
    info: &MicromapBuildInfo,
    side: Side,
    opacity: bool,
    triangles: u64,
) {
    // The bytes borrow the tracked state, not the context, so findings can
    // be reported while reading. Below the content tier nothing is read.
    let (Some(state), Some(host_memory)) = (ctx.contents(), ctx.host()) else {
        return;
    };
    if triangles == 0 {
        return;
    }
    // Past this point the array is read, which costs far more than
    // writing out the location once.
    let at = at.to_string();
    let at = at.as_str();
    // The memory holding an address, shared, and the address's offset in it.
    let shared_from = |address: u64| match side {
        Side::Device => state.device_contents_from(address),
        Side::Host => host_memory.contents_from(address),
        Side::SizeQuery => None,
    };
    let host = side == Side::Host;
    let shared_data = shared_from(info.data);
    let data = shared_data
        .as_ref()
        .and_then(|(memory, start)| memory.get(*start..));
    // Where a host build's address rules are not decided (the memory was
    // not described), this finding names them with the content rules.
    let host_address = |vuid: ommcheck_vuids::Vuid, readable: bool| {
        (host && !readable && !host_memory.describes_all()).then_some(RuleId::from(vuid))
    };
    let shared_array = shared_from(info.triangle_array);
    let Some(array) = shared_array
        .as_ref()
        .and_then(|(memory, start)| memory.get(*start..))
    else {
        let mut skipped = entry_rules(opacity);
        skipped.extend(host_address(host::pInfos_07554, false));
        skipped.extend(host_address(host::pInfos_07553, data.is_some()));
        common::unreadable(
            ctx,
            host,
            info.triangle_array,
            &skipped,
            at.text(".triangleArray"),
        );
        return;
    };
    ctx.checked(&entry_rules(opacity));
    let data_rules: Vec<RuleId> = opacity
        .then(|| RuleId::from(&rules::TRIANGLE_DATA_RANGE))
        .into_iter()
        .chain(host_address(host::pInfos_07553, data.is_some()))
        .collect();
    if data.is_none() {
        common::unreadable(ctx, host, info.data, &data_rules, at.text(".data"));
    } else {
        ctx.checked(&data_rules);
    }
    let stride = info.triangle_array_stride;
    let names = format_names(opacity);
    // The device outlives the context's borrow, so the limits are read in
    // place while findings are reported.
    let device = ctx.device;
    let limits = &device.limits;
    let mut tally = Tally::new();
    let mut histogram = TriangleHistogram::new();
    // A stride of 0 makes every triangle read the one entry: check it once
    // and count it for all, rather than looping over up to 2^64 triangles.
    let (entries_to_read, weight) = if stride == 0 {
        (1, triangles)
    } else {
        (triangles, 1)
    };
    // The entries the record keeps: those read, up to the first past the
    // array's bytes (where the loop below stops).
    let entries_read = readable_entries(array.len() as u64, stride).min(entries_to_read);
    let data_len = data.map(|data| data.len() as u64);
    // The run of the last entry without a finding, in a tightly packed
    // opacity array; blocks that leave it go one by one to their end.
    let mut run: Option<CleanRun> = None;
    let mut one_by_one_until = 0u64;
    // Where the usage counts ask for more entries than the array's memory
    // holds (the range finding, reported before), entries of zero bytes
    // are memory the counts overrun, not triangles written: they fold into
    // that finding instead of each failing the format rule.
    let range_finding = {
        let array_at = format!("{at}.triangleArray");
        let range = RuleId::from(&rules::TRIANGLE_ARRAY_RANGE);
        ctx.report
            .findings
            .iter()
            .rposition(|f| f.rule == range && f.location == array_at)
    };
    let mut zero_entries = 0u64;
    let mut next = 0u64;
    while next < entries_to_read {
        if let Some(clean) = run.filter(|_| next >= one_by_one_until) {
            let clean_entries;
            (clean_entries, one_by_one_until) =
                clean.count(&mut histogram, array, next, entries_to_read);
            next += clean_entries;
            if next >= entries_to_read {
                break;
            }
        }
        let m = next;
        next += 1;
        let findings_before = (ctx.report.findings.len(), tally.failures());
        // Written out only for a finding: most entries have none.
        let loc = at.member("triangleArray").index(m);
        let entry = m
            .checked_mul(stride)
            .and_then(|offset| usize::try_from(offset).ok())
            .and_then(|offset| array.get(offset..offset.checked_add(8)?));
        let Some(bytes) = entry else {
            // The rest is past the end of the memory (our rule says so from
            // its size) or was not given to the checker.
            break;
        };
        if range_finding.is_some() && bytes.iter().all(|&b| b == 0) {
            zero_entries += 1;
            histogram.add(0, 0, weight);
            continue;
        }
        let triangle = MicromapTriangle::from_bytes(bytes.try_into().expect("8 bytes"));
        let (format, level) = (
            u32::from(triangle.format),
            u32::from(triangle.subdivision_level),
        );
        histogram.add(format, level, weight);
        if opacity {
            match format {
                OPACITY_MICROMAP_FORMAT_2_STATE => {
                    if level > limits.max_opacity2_state_subdivision_level {
                        tally.error(
                            ctx,
                            info_vuid::subdivisionLevel_11659,
                            loc.member("subdivisionLevel"),
                            || {
                                format!(
                                    "{level} exceeds maxOpacity2StateSubdivisionLevel = {}",
                                    limits.max_opacity2_state_subdivision_level
                                )
                            },
                            "triangleArray",
                        );
                    }
                }
                OPACITY_MICROMAP_FORMAT_4_STATE => {
                    if level > limits.max_opacity4_state_subdivision_level {
                        tally.error(
                            ctx,
                            info_vuid::subdivisionLevel_11660,
                            loc.member("subdivisionLevel"),
                            || {
                                format!(
                                    "{level} exceeds maxOpacity4StateSubdivisionLevel = {}",
                                    limits.max_opacity4_state_subdivision_level
                                )
                            },
                            "triangleArray",
                        );
                    }
                }
                _ => {
                    tally.error(
                        ctx,
                        info_vuid::format_11657,
                        loc.member("format"),
                        || format!("{format} is not a VkOpacityMicromapFormatEXT value"),
                        "triangleArray",
                    );
                    continue;
                }
            }
            let range = data_len.zip(opacity_triangle_bytes(format, level));
            if let Some((data_len, size)) = range {
                let end = u64::from(triangle.data_offset).checked_add(size);
                if end.is_none_or(|end| end > data_len) {
                    tally.error(
                        ctx,
                        &rules::TRIANGLE_DATA_RANGE,
                        loc.member("dataOffset"),
                        || format!("[{}, {}) is past the end of the memory data points into ({data_len} bytes)", triangle.data_offset, u64::from(triangle.data_offset) + size),
                        "triangleArray",
                    );
                }
            }
            if stride == MicromapTriangle::SIZE
                && findings_before == (ctx.report.findings.len(), tally.failures())
            {
                run = CleanRun::after(&triangle, range.map(|(len, size)| (size, len)));
            }
        } else {
            if !DISPLACEMENT_MICROMAP_FORMATS_NV.contains(&format) {
                tally.error(
                    ctx,
                    info_vuid::format_11658,
                    loc.member("format"),
                    || format!("{format} is not a VkDisplacementMicromapFormatNV value"),
                    "triangleArray",
                );
            }
            if level > limits.max_displacement_micromap_subdivision_level {
                tally.error(
                    ctx,
                    info_vuid::subdivisionLevel_11661,
                    loc.member("subdivisionLevel"),
                    || {
                        format!(
                            "{level} exceeds maxDisplacementMicromapSubdivisionLevel = {}",
                            limits.max_displacement_micromap_subdivision_level
                        )
                    },
                    "triangleArray",
                );
            }
        }
    }
    tally.finish(ctx);
    if let Some(finding) = range_finding.and_then(|r| ctx.report.findings.get_mut(r)) {
        finding.fold(
            zero_entries,
            format_args!(
                "and {} past the triangles written: zero bytes inside the array's memory (format 0), not reported one by one",
                crate::report::count(zero_entries, "more triangle", "more triangles")
            ),
        );
    }
    // Information about the data blocks themselves reads every byte of
    // them; it is no validity rule, so it runs from the simulate tier up.
    if let (true, true, Some(data)) = (opacity, ctx.hygiene, data) {
        // A view of the array's bytes, not a copy of its entries.
        let entries = shared_array
            .and_then(|(memory, start)| {
                let stride = stride.max(MicromapTriangle::SIZE);
                TriangleEntries::shared(memory, start, stride, entries_read)
            })
            .unwrap_or_else(|| Vec::new().into());
        hygiene::opacity_blocks(ctx, at, data, &entries);
    }
    let histogram = histogram.into_map();

    // The usage counts must describe the array: per (format, level), the sum
    // of the counts equals the number of entries.
    if histogram.values().sum::<u64>() == triangles {
        let location = format!("{at}.{}", info.usage_counts.member());
        usage_counts_match_triangles(ctx, &location, &info.usage_counts, &histogram, names);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Device;
    use crate::model::micromap::{MicromapUsage, UsageCounts};
    use crate::state::Micromap;
    use crate::tier::Tier;

    /// The usage entries of one build: `n` entries of `count` triangles,
    /// 2-state and 4-state in turn.
    fn usages(n: u32, count: u32) -> UsageCounts {
        UsageCounts::array(
            (0..n)
                .map(|i| MicromapUsage {
                    count,
                    subdivision_level: i % 13,
                    format: 1 + i % 2,
                })
                .collect(),
        )
    }

    /// Each build's record holds the sum of its usage counts, whichever
    /// way the pass over them summed them: entry by entry (under 16
    /// entries), in 32-bit lanes, or one by one again (counts from 2^24,
    /// or over 1,024 entries); on the host and the device command, for
    /// every info of one call, at every tier.
    #[test]
    fn a_build_records_the_sum_of_its_usage_counts() {
        let cases = [
            usages(1, 5),
            usages(15, 7),
            usages(64, 3),
            usages(67, 1 << 24),
            usages(40, u32::MAX),
            usages(2000, 9),
            UsageCounts::pointers(vec![MicromapUsage {
                count: 11,
                subdivision_level: 2,
                format: 2,
            }]),
        ];
        let infos: Vec<MicromapBuildInfo> = cases
            .iter()
            .enumerate()
            .map(|(i, usage_counts)| MicromapBuildInfo {
                dst_micromap: 100 + i as Handle,
                usage_counts: usage_counts.clone(),
                ..Default::default()
            })
            .collect();
        for tier in [Tier::Params, Tier::State, Tier::Content] {
            for host in [true, false] {
                let mut v = Validator::new(Device::default());
                v.set_tier(tier);
                for info in &infos {
                    v.state_mut().micromaps.insert(
                        info.dst_micromap,
                        Micromap {
                            ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                            ..Default::default()
                        },
                    );
                }
                if host {
                    v.build_micromaps(1, 0, &infos);
                } else {
                    let command_buffer = CommandBuffer {
                        handle: 2,
                        recording: true,
                        ..Default::default()
                    };
                    v.cmd_build_micromaps(&command_buffer, &infos);
                }
                for info in &infos {
                    let recorded = v.state().micromaps[&info.dst_micromap]
                        .built
                        .as_ref()
                        .map(|b| b.triangle_count);
                    assert_eq!(
                        recorded,
                        Some(info.usage_counts.total()),
                        "{tier:?} host {host}: {} entries",
                        info.usage_counts.count
                    );
                }
            }
        }
    }

    /// A host build of one 2-state triangle whose triangle array (at
    /// 0x1000) and data (at 0x2000) are `memory`, and a validator at the
    /// content tier that tracks its destination micromap 7.
    fn host_build(memory: &[HostRange]) -> (Validator, MicromapBuildInfo) {
        let mut v = Validator::new(Device::with_everything(crate::Profile::SpecMinimum));
        v.set_tier(Tier::Content);
        v.state_mut().micromaps.insert(
            7,
            Micromap {
                ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
                ..Default::default()
            },
        );
        v.state_mut().host_memory.extend(memory.iter().cloned());
        let info = MicromapBuildInfo {
            dst_micromap: 7,
            usage_counts: UsageCounts::array(vec![MicromapUsage {
                count: 1,
                subdivision_level: 0,
                format: OPACITY_MICROMAP_FORMAT_2_STATE,
            }]),
            triangle_array: 0x1000,
            triangle_array_stride: 8,
            data: 0x2000,
            scratch_data: 0x3000,
            ..Default::default()
        };
        (v, info)
    }

    /// One triangle at data offset 0, 2-state, level 0; and its data byte.
    fn triangle_memory() -> Vec<HostRange> {
        vec![
            HostRange {
                address: 0x1000,
                bytes: crate::Bytes::from(vec![0u8, 0, 0, 0, 0, 0, 1, 0]),
            },
            HostRange {
                address: 0x2000,
                bytes: crate::Bytes::from(vec![0xffu8]),
            },
        ]
    }

    /// The rules of a build leave the state as it was (run twice, they
    /// report the same); its record alone makes of the state what the
    /// whole call does; the two in turn are the whole call. With the host
    /// memory described and with it read for the call alone, which the
    /// state never keeps.
    #[test]
    fn building_is_rules_then_record() {
        for described in [true, false] {
            let memory = triangle_memory();
            let (kept, read_for_call) = if described {
                (&memory[..], &[][..])
            } else {
                (&[][..], &memory[..])
            };
            let (mut v, info) = host_build(kept);
            let infos = [info];
            let before = format!("{:?}", v.state());
            let report = v.build_micromaps_rules(1, 0, &infos, read_for_call);
            assert_eq!(
                format!("{:?}", v.state()),
                before,
                "the rules changed the state"
            );
            assert_eq!(v.build_micromaps_rules(1, 0, &infos, read_for_call), report);
            assert!(
                report.checked.contains(&rules::TRIANGLE_DATA_RANGE),
                "the data was read: {report:?}"
            );

            let (mut recorded, _) = host_build(kept);
            recorded.record_micromaps_built(0, &infos, read_for_call);
            let built = recorded.state().micromaps[&7].built.clone().expect("built");
            assert_eq!(built.triangle_count, 1);
            let content = built.content.expect("the content was read");
            assert_eq!(&content.data[..], &[0xffu8][..]);
            assert_eq!(recorded.state().host_memory.len(), kept.len());

            v.record_micromaps_built(0, &infos, read_for_call);
            assert_eq!(
                format!("{:?}", v.state()),
                format!("{:?}", recorded.state())
            );
            if described {
                let (mut whole, _) = host_build(kept);
                assert_eq!(whole.build_micromaps(1, 0, &infos), report);
                assert_eq!(format!("{:?}", whole.state()), format!("{:?}", v.state()));
            }
        }
    }
}
