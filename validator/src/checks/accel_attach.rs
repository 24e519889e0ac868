//! Triangle geometry that references a micromap: the EXT and KHR opacity
//! attachments and the NV displacement attachment, instance flags, the rules
//! across the infos of one build command, and the opacity-micromap members of
//! NV cluster triangle infos.

use ommcheck_vuids::vuid::{
    vkBuildAccelerationStructuresKHR as host,
    vkCmdBuildAccelerationStructuresIndirectKHR as indirect,
    vkCmdBuildAccelerationStructuresKHR as cmd,
    VkAccelerationStructureGeometryTrianglesDataKHR as triangles_vuid,
    VkAccelerationStructureInstanceKHR as instance_vuid,
    VkAccelerationStructureTrianglesDisplacementMicromapNV as nv,
    VkAccelerationStructureTrianglesOpacityMicromapEXT as ext,
    VkAccelerationStructureTrianglesOpacityMicromapKHR as khr,
    VkClusterAccelerationStructureBuildTriangleClusterInfoNV as cluster,
    VkClusterAccelerationStructureBuildTriangleClusterTemplateInfoNV as cluster_template,
};
use std::collections::BTreeMap;

use ommcheck_vuids::{khr as khr_values, Vuid};

use crate::checks::accel_build::{geometry_at, GeometryAt, InfoAt};

use crate::checks::common::{self, Tally, TriangleHistogram};
use crate::checks::index_scan::{
    for_each_chunk, is_cluster_skip_index, is_special_index, read_indices,
    special_and_micromap_indices, CleanIndices, IndexMix, ReferenceTally,
};
use crate::checks::usage_counts::{self, EntryVuids, PointerVuids};
use crate::checks::usage_hints;
use crate::checks::usage_keys::{self, UsageKeys};
use crate::checks::Coverage;
use crate::checks::{Ctx, Validator};
use crate::model::accel::BuildCommand;
use crate::model::accel::*;
use crate::model::micromap::UsageCounts;
use crate::model::values::FormatKind;
use crate::model::values::*;
use crate::model::Handle;
use crate::report::count as count_of;
use crate::report::location::{Locate, Location, Member, Text};
use crate::report::not_checked::Cause;
use crate::report::{Report, RuleId, Severity};
use crate::rules;
use crate::state::{AccelerationStructure, State};

pub const COVERAGE: Coverage = Coverage {
    module: "accel_attach",
    enforced: &[
        ext::sType_sType,
        ext::indexType_parameter,
        ext::indexType_10719,
        ext::indexType_10722,
        ext::indexType_10723,
        ext::micromap_parameter,
        ext::pUsageCounts_07335,
        ext::pUsageCounts_parameter,
        ext::ppUsageCounts_parameter,
        ext::format_11679,
        ext::subdivisionLevel_11680,
        ext::subdivisionLevel_11681,
        ext::format_11682,
        ext::subdivisionLevel_11683,
        khr::sType_sType,
        khr::indexType_parameter,
        khr::indexType_11570,
        khr::indexBuffer_11571,
        khr::indexBuffer_11572,
        khr::indexStride_11573,
        khr::indexStride_11574,
        khr::micromap_parameter,
        khr::micromap_11579,
        khr::geometry_11576,
        nv::sType_sType,
        nv::indexType_parameter,
        nv::micromap_parameter,
        nv::pUsageCounts_07992,
        nv::pUsageCounts_parameter,
        nv::ppUsageCounts_parameter,
        nv::displacementBiasAndScaleFormat_09501,
        nv::displacementBiasAndScaleFormat_parameter,
        nv::displacementVectorFormat_09502,
        nv::displacementVectorFormat_parameter,
        triangles_vuid::pNext_pNext,
        instance_vuid::micromap_11580,
        instance_vuid::flags_11581,
        cluster::opacityMicromapArray_10881,
        cluster::opacityMicromapArray_parameter,
        cluster::opacityMicromapIndexBuffer_parameter,
        cluster::opacityMicromapIndexType_10492,
        cluster_template::opacityMicromapArray_10882,
        cluster_template::opacityMicromapArray_parameter,
        cluster_template::opacityMicromapIndexBuffer_parameter,
        cluster_template::opacityMicromapIndexType_10501,
        cmd::pInfos_10904,
        cmd::pInfos_10905,
        cmd::pInfos_10607,
        cmd::indexBuffer_11575,
        cmd::indexBuffer_11577,
        cmd::indexBuffer_11578,
        cmd::micromap_11624,
        cmd::dstAccelerationStructure_11548,
        cmd::dstAccelerationStructure_11549,
        cmd::micromap_11625,
        cmd::micromap_11626,
        cmd::micromap_11627,
        cmd::micromap_11629,
        indirect::pInfos_10904,
        indirect::pInfos_10905,
        indirect::pInfos_10607,
        indirect::micromap_11624,
        indirect::micromap_11625,
        indirect::micromap_11626,
        indirect::micromap_11627,
        indirect::micromap_11629,
        cmd::micromap_11628,
        indirect::micromap_11628,
        host::pInfos_10892,
        host::pInfos_11821,
        host::pInfos_11705,
    ],
    not_decidable: &[],
};

/// `VkFormat` values of the 1.4.360 registry (vk.xml, extensions supported
/// for Vulkan), as inclusive ranges.
const VK_FORMAT_RANGES: [(i32, i32); 11] = [
    (0, 184),
    (1_000_054_000, 1_000_054_007),
    (1_000_066_000, 1_000_066_013),
    (1_000_156_000, 1_000_156_033),
    (1_000_288_000, 1_000_288_029),
    (1_000_330_000, 1_000_330_003),
    (1_000_340_000, 1_000_340_001),
    (1_000_460_000, 1_000_460_003),
    (1_000_464_000, 1_000_464_000),
    (1_000_470_000, 1_000_470_001),
    (1_000_609_000, 1_000_609_013),
];

const VK_FORMAT_UNDEFINED: i32 = 0;

fn is_vk_format(value: i32) -> bool {
    VK_FORMAT_RANGES
        .iter()
        .any(|&(first, last)| (first..=last).contains(&value))
}

/// `VkIndexType` values.
const INDEX_TYPES: [i32; 4] = [
    INDEX_TYPE_UINT16,
    INDEX_TYPE_UINT32,
    INDEX_TYPE_NONE,
    INDEX_TYPE_UINT8,
];

/// Which attachment a check looks at.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Ext,
    Khr,
    Nv,
}

impl Kind {
    /// Where the structure is from its triangles geometry.
    fn step(self) -> &'static str {
        match self {
            Kind::Ext => {
                ".geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>"
            }
            Kind::Khr => {
                ".geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapKHR>"
            }
            Kind::Nv => {
                ".geometry.triangles.pNext<VkAccelerationStructureTrianglesDisplacementMicromapNV>"
            }
        }
    }

    fn struct_name(self) -> &'static str {
        match self {
            Kind::Ext => "VkAccelerationStructureTrianglesOpacityMicromapEXT",
            Kind::Khr => "VkAccelerationStructureTrianglesOpacityMicromapKHR",
            Kind::Nv => "VkAccelerationStructureTrianglesDisplacementMicromapNV",
        }
    }

    /// The rules the three structures state alike, with each one's VUID
    /// (None where a structure states no such rule).
    fn vuids(self) -> AttachmentVuids {
        match self {
            Kind::Ext => AttachmentVuids {
                s_type: (
                    ext::sType_sType,
                    STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_EXT,
                ),
                index_type_parameter: ext::indexType_parameter,
                index_type_allowed: Some((
                    ext::indexType_10719,
                    &[INDEX_TYPE_UINT16, INDEX_TYPE_UINT32, INDEX_TYPE_NONE],
                )),
                stride_multiple: Some(ext::indexType_10722),
                stride_max: Some(ext::indexType_10723),
                micromap_parameter: ext::micromap_parameter,
                usage_counts: Some(PointerVuids {
                    one_of: ext::pUsageCounts_07335,
                    array: ext::pUsageCounts_parameter,
                    pointers: ext::ppUsageCounts_parameter,
                }),
            },
            Kind::Khr => AttachmentVuids {
                s_type: (
                    khr::sType_sType,
                    STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR,
                ),
                index_type_parameter: khr::indexType_parameter,
                index_type_allowed: Some((
                    khr::indexType_11570,
                    &[
                        INDEX_TYPE_UINT8,
                        INDEX_TYPE_UINT16,
                        INDEX_TYPE_UINT32,
                        INDEX_TYPE_NONE,
                    ],
                )),
                stride_multiple: Some(khr::indexStride_11573),
                stride_max: Some(khr::indexStride_11574),
                micromap_parameter: khr::micromap_parameter,
                usage_counts: None,
            },
            Kind::Nv => AttachmentVuids {
                s_type: (
                    nv::sType_sType,
                    STRUCTURE_TYPE_TRIANGLES_DISPLACEMENT_MICROMAP_NV,
                ),
                index_type_parameter: nv::indexType_parameter,
                index_type_allowed: None,
                stride_multiple: None,
                stride_max: None,
                micromap_parameter: nv::micromap_parameter,
                usage_counts: Some(PointerVuids {
                    one_of: nv::pUsageCounts_07992,
                    array: nv::pUsageCounts_parameter,
                    pointers: nv::ppUsageCounts_parameter,
                }),
            },
        }
    }
}

/// One attachment's VUIDs for the rules all three state alike.
struct AttachmentVuids {
    s_type: (Vuid, i32),
    index_type_parameter: Vuid,
    index_type_allowed: Option<(Vuid, &'static [i32])>,
    stride_multiple: Option<Vuid>,
    stride_max: Option<Vuid>,
    micromap_parameter: Vuid,
    usage_counts: Option<PointerVuids>,
}

/// Where an attachment is: `pInfos[i].pGeometries[g].geometry.triangles.pNext<Vk...>`.
type AttachmentAt = Location<GeometryAt, Text<'static>>;

fn attachment_at(geometry: GeometryAt, kind: Kind) -> AttachmentAt {
    geometry.text(kind.step())
}

/// The members the three attachments share, and where the structure is.
struct Attachment<'a> {
    kind: Kind,
    at: AttachmentAt,
    s_type: i32,
    index_type: i32,
    index_buffer: u64,
    index_stride: u64,
    base_triangle: u32,
    micromap: Handle,
    usage_counts: Option<&'a UsageCounts>,
}

impl Attachment<'_> {
    /// The location of the member `name`, for a finding.
    fn member(&self, name: &str) -> String {
        self.member_at(name).to_string()
    }

    /// The location of the member `name`, written out only where it is
    /// displayed: for the checks that take a location before they know
    /// whether there is a finding.
    fn member_at<'n>(&self, name: &'n str) -> Location<AttachmentAt, Member<'n>> {
        self.at.member(name)
    }
}

/// The attachments chained to one triangles geometry, at most one of each
/// kind, made one at a time as the caller reaches them (no Vec: a valid call
/// should not allocate).
fn attachments(
    geometry_at: GeometryAt,
    data: &TrianglesData,
) -> impl Iterator<Item = Attachment<'_>> {
    [Kind::Ext, Kind::Khr, Kind::Nv]
        .into_iter()
        .filter_map(move |kind| attachment(geometry_at, data, kind))
}

/// The attachment of `kind` chained to a triangles geometry, if any.
fn attachment(geometry_at: GeometryAt, data: &TrianglesData, kind: Kind) -> Option<Attachment<'_>> {
    let at = attachment_at(geometry_at, kind);
    Some(match kind {
        Kind::Ext => {
            let a = data.opacity_ext.as_ref()?;
            Attachment {
                kind,
                at,
                s_type: a.s_type,
                index_type: a.index_type,
                index_buffer: a.index_buffer,
                index_stride: a.index_stride,
                base_triangle: a.base_triangle,
                micromap: a.micromap,
                usage_counts: Some(&a.usage_counts),
            }
        }
        Kind::Khr => {
            let a = data.opacity_khr.as_ref()?;
            Attachment {
                kind,
                at,
                s_type: a.s_type,
                index_type: a.index_type,
                index_buffer: a.index_buffer,
                index_stride: a.index_stride,
                base_triangle: a.base_triangle,
                micromap: a.micromap,
                usage_counts: None,
            }
        }
        Kind::Nv => {
            let a = data.displacement_nv.as_ref()?;
            Attachment {
                kind,
                at,
                s_type: a.s_type,
                index_type: a.index_type,
                index_buffer: a.index_buffer,
                index_stride: a.index_stride,
                base_triangle: a.base_triangle,
                micromap: a.micromap,
                usage_counts: Some(&a.usage_counts),
            }
        }
    })
}

/// A triangles geometry at `at` (e.g. `pInfos[0].pGeometries[1]`) of `info`,
/// with its build range where the command has one.
pub(crate) fn triangles(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    at: GeometryAt,
    info: &BuildGeometryInfo,
    triangles: &TrianglesData,
    range: Option<&BuildRangeInfo>,
) {
    let _ = info;
    pnext_chain(ctx, at, triangles);
    let primitive_count = range.map(|r| u64::from(r.primitive_count));
    for attachment in attachments(at, triangles) {
        shared_members(ctx, &attachment);
        match attachment.kind {
            Kind::Ext => ext_attachment(ctx, command, &attachment),
            Kind::Khr => khr_attachment(ctx, command, &attachment, primitive_count),
            Kind::Nv => {
                if let Some(data) = &triangles.displacement_nv {
                    nv_formats(ctx, &attachment, data);
                }
            }
        }
        if let Some(count) = primitive_count {
            index_buffer_holds_every_index(ctx, command, &attachment, count);
            let references = index_contents(ctx, command, &attachment, count);
            usage_counts_match_indices(ctx, command, &attachment, count, references);
        }
    }
}

/// The pNext chain of `VkAccelerationStructureGeometryTrianglesDataKHR`: the
/// attachments and motion triangles, nothing else (the model keeps the
/// attachments apart; the sTypes chained after them are in their `next`).
fn pnext_chain(ctx: &mut Ctx<'_>, at: GeometryAt, data: &TrianglesData) {
    const ALLOWED: [i32; 4] = [
        STRUCTURE_TYPE_GEOMETRY_MOTION_TRIANGLES_DATA_NV,
        STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_EXT,
        STRUCTURE_TYPE_TRIANGLES_OPACITY_MICROMAP_KHR,
        STRUCTURE_TYPE_TRIANGLES_DISPLACEMENT_MICROMAP_NV,
    ];
    // The sTypes in chain order; plain slices, which are cheaper to walk
    // than chained iterator adapters.
    let none: &[i32] = &[];
    let chained = [
        &data.next[..],
        data.opacity_ext.as_ref().map_or(none, |a| &a.next),
        data.opacity_khr.as_ref().map_or(none, |a| &a.next),
        data.displacement_nv.as_ref().map_or(none, |a| &a.next),
    ];
    let outsider = chained
        .into_iter()
        .find_map(|list| list.iter().copied().find(|s| !ALLOWED.contains(s)));
    if let Some(s_type) = outsider {
        ctx.error(
            triangles_vuid::pNext_pNext,
            format!("{at}.geometry.triangles.pNext"),
            format!(
                "sType {} does not extend VkAccelerationStructureGeometryTrianglesDataKHR",
                structure_type_name(s_type)
            ),
        );
    }
}

/// sType, index type and stride, the micromap handle and the usage-count
/// pointers: the rules the three attachments state alike.
fn shared_members(ctx: &mut Ctx<'_>, a: &Attachment<'_>) {
    let vuids = a.kind.vuids();
    let (s_type_vuid, s_type) = vuids.s_type;
    ctx.require(
        a.s_type == s_type,
        s_type_vuid,
        || a.member("sType"),
        || {
            format!(
                "{} is not the sType of {}",
                structure_type_name(a.s_type),
                a.kind.struct_name()
            )
        },
    );
    let valid_index_type = INDEX_TYPES.contains(&a.index_type);
    ctx.require(
        valid_index_type,
        vuids.index_type_parameter,
        || a.member("indexType"),
        || format!("{} is not a VkIndexType value", a.index_type),
    );
    if let Some((vuid, allowed)) = vuids.index_type_allowed {
        ctx.require(
            allowed.contains(&a.index_type),
            vuid,
            || a.member("indexType"),
            || {
                format!(
                    "{} is not an index type this structure allows",
                    index_type_name(a.index_type)
                )
            },
        );
    }
    if let Some(size) = index_size(a.index_type) {
        if let Some(vuid) = vuids.stride_multiple {
            common::aligned(ctx, a.index_stride, size, vuid, a.member_at("indexStride"));
        }
        if let Some(vuid) = vuids.stride_max {
            ctx.require(
                a.index_stride <= u64::from(u32::MAX),
                vuid,
                || a.member("indexStride"),
                || format!("{} exceeds 2^32-1", a.index_stride),
            );
        }
        index_alignment(ctx, a, size, vuids.stride_multiple.is_none());
    }
    if let (true, Some(state)) = (a.micromap != 0, ctx.state) {
        let known = match a.kind {
            Kind::Ext | Kind::Nv => state.micromaps.contains_key(&a.micromap),
            Kind::Khr => state.acceleration_structures.contains_key(&a.micromap),
        };
        let handle_type = match a.kind {
            Kind::Ext | Kind::Nv => "VkMicromapEXT",
            Kind::Khr => "VkAccelerationStructureKHR",
        };
        if !known {
            ctx.error(
                vuids.micromap_parameter,
                a.member("micromap"),
                format!(
                    "{:#x} is not a {handle_type} created on this device",
                    a.micromap
                ),
            )
            .objects
            .push(crate::report::ObjectRef {
                ty: handle_type,
                handle: a.micromap,
            });
        }
    }
    if let (Some(vuids), Some(counts)) = (vuids.usage_counts, a.usage_counts) {
        usage_counts::pointer_rules(ctx, a.at, counts, &vuids);
    }
}

/// A misaligned index buffer, or (where no VUID states it) a misaligned
/// stride: legal for EXT and NV as far as any VUID says, but it crashes drivers.
fn index_alignment(ctx: &mut Ctx<'_>, a: &Attachment<'_>, size: u64, stride_too: bool) {
    if !a.index_buffer.is_multiple_of(size) {
        ctx.report(
            &rules::INDEX_ALIGNMENT,
            Severity::Warning,
            a.member("indexBuffer"),
            format!(
                "{:#x} is not a multiple of the index size {size}",
                a.index_buffer
            ),
        );
    }
    if stride_too && !a.index_stride.is_multiple_of(size) {
        ctx.report(
            &rules::INDEX_ALIGNMENT,
            Severity::Warning,
            a.member("indexStride"),
            format!(
                "{} is not a multiple of the index size {size}",
                a.index_stride
            ),
        );
    }
}

/// `VkAccelerationStructureTrianglesOpacityMicromapEXT`: the index buffer
/// against the index type (10904/10905, 10892/11821), and the usage counts
/// against the type the micromap was created with (11679-11683).
fn ext_attachment(ctx: &mut Ctx<'_>, command: BuildCommand, a: &Attachment<'_>) {
    let location = a.member_at(match command {
        BuildCommand::Host => "indexBuffer.hostAddress",
        _ => "indexBuffer.deviceAddress",
    });
    let (must_be_zero, must_be_valid) = match command {
        BuildCommand::Cmd => (cmd::pInfos_10904, cmd::pInfos_10905),
        BuildCommand::Indirect => (indirect::pInfos_10904, indirect::pInfos_10905),
        BuildCommand::Host => (host::pInfos_10892, host::pInfos_11821),
    };
    if a.index_type == INDEX_TYPE_NONE {
        ctx.require(
            a.index_buffer == 0,
            must_be_zero,
            || location.to_string(),
            || {
                format!(
                    "indexType is VK_INDEX_TYPE_NONE_KHR but the address is {:#x}",
                    a.index_buffer
                )
            },
        );
    } else if command == BuildCommand::Host {
        ctx.require(
            a.index_buffer != 0,
            must_be_valid,
            || location.to_string(),
            || "the address is 0".into(),
        );
    } else {
        common::valid_device_address(ctx, a.index_buffer, must_be_valid, location);
    }
    ext_usage_counts(ctx, a);
}

/// The usage counts of an EXT attachment against the micromap's type.
fn ext_usage_counts(ctx: &mut Ctx<'_>, a: &Attachment<'_>) {
    let micromap = ctx.state.and_then(|state| state.micromaps.get(&a.micromap));
    let (Some(micromap), Some(counts)) = (micromap, a.usage_counts) else {
        return;
    };
    let opacity = micromap.ty == MICROMAP_TYPE_OPACITY_MICROMAP_EXT;
    let displacement = micromap.ty == MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV;
    if !(opacity || displacement) {
        return;
    }
    let maxima = usage_keys::ext_usage_maxima(&ctx.device.limits);
    let keys = UsageKeys::ext(opacity, maxima);
    let member = counts.member();
    // One pass over the entries against the allowed keys; the rules with
    // their locations and messages run per entry only where some entry is
    // outside the table.
    for (k, usage) in keys.entries_to_check(counts) {
        let loc = format_args!("{}.{member}[{k}]", a.at);
        usage_counts::entry_rules(ctx, loc, usage, opacity, maxima, &ATTACHED_USAGE_ENTRIES);
    }
}

/// The usage entries of an EXT attachment against the attached micromap's
/// type (11679-11683).
const ATTACHED_USAGE_ENTRIES: EntryVuids = EntryVuids {
    opacity_format: ext::format_11679,
    opacity_2_state_level: ext::subdivisionLevel_11680,
    opacity_4_state_level: ext::subdivisionLevel_11681,
    displacement_format: ext::format_11682,
    displacement_level: ext::subdivisionLevel_11683,
    name_the_type: true,
};

/// `VkAccelerationStructureTrianglesOpacityMicromapKHR`: the index buffer
/// against the index type (11571/11572/11577), the micromap (11579, 11624,
/// 11705), and with no index buffer the triangle count (11576).
fn khr_attachment(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    a: &Attachment<'_>,
    primitive_count: Option<u64>,
) {
    if a.index_type == INDEX_TYPE_NONE {
        ctx.require(
            a.index_buffer == 0,
            khr::indexBuffer_11571,
            || a.member("indexBuffer"),
            || {
                format!(
                    "indexType is VK_INDEX_TYPE_NONE_KHR but indexBuffer is {:#x}",
                    a.index_buffer
                )
            },
        );
        ctx.require(
            a.micromap != 0,
            khr::micromap_11579,
            || a.member("micromap"),
            || "indexType is VK_INDEX_TYPE_NONE_KHR and micromap is VK_NULL_HANDLE".into(),
        );
    } else if command == BuildCommand::Host {
        ctx.require(
            a.index_buffer != 0,
            khr::indexBuffer_11572,
            || a.member("indexBuffer"),
            || "the address is 0".into(),
        );
    } else {
        common::valid_device_address(
            ctx,
            a.index_buffer,
            khr::indexBuffer_11572,
            a.member_at("indexBuffer"),
        );
    }
    if command == BuildCommand::Host {
        ctx.require(
            a.micromap == 0,
            host::pInfos_11705,
            || a.member("micromap"),
            || {
                format!(
                    "host builds take no KHR micromap, but micromap is {:#x}",
                    a.micromap
                )
            },
        );
        return;
    }
    let built_with = match command {
        BuildCommand::Indirect => indirect::micromap_11624,
        _ => cmd::micromap_11624,
    };
    micromap_is_opacity_micromap(ctx, a, built_with);
    if command == BuildCommand::Cmd {
        if let (Some(count), Some(size)) = (primitive_count, index_size(a.index_type)) {
            index_buffer_in_range(ctx, a, size, count);
        }
    }
}

/// 11624: a KHR attachment's micromap was built (or, unbuilt, can only be
/// built) with type OPACITY_MICROMAP.
fn micromap_is_opacity_micromap(ctx: &mut Ctx<'_>, a: &Attachment<'_>, vuid: Vuid) {
    let Some(structure) = ctx
        .state
        .and_then(|state| state.acceleration_structures.get(&a.micromap))
    else {
        return;
    };
    let built_type = structure.built.as_ref().map(|b| b.ty);
    // 11547 lets only OPACITY_MICROMAP and GENERIC structures be built as micromaps.
    let can_be_micromap = matches!(
        structure.ty,
        ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP | ACCELERATION_STRUCTURE_TYPE_GENERIC
    );
    let wrong = match built_type {
        Some(ty) => ty != ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP,
        None => !can_be_micromap,
    };
    if wrong {
        let found = built_type.map_or_else(
            || {
                format!(
                    "was created with type {}",
                    acceleration_structure_type_name(structure.ty)
                )
            },
            |ty| {
                format!(
                    "was built with type {}",
                    acceleration_structure_type_name(ty)
                )
            },
        );
        ctx.error(
            vuid,
            a.member("micromap"),
            format!(
                "{:#x} {found}, not VK_ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP_KHR",
                a.micromap
            ),
        );
    }
}

/// 11577: `[indexBuffer, indexBuffer + indexStride * primitiveCount)` lies in one buffer.
fn index_buffer_in_range(ctx: &mut Ctx<'_>, a: &Attachment<'_>, size: u64, count: u64) {
    let Some(state) = ctx.state else {
        return;
    };
    if count == 0 {
        return;
    }
    // An address inside no buffer is 11572's finding; with no buffer
    // address known, 11577 is reported not checked.
    if state.buffers_at(a.index_buffer).next().is_none() {
        let rules = [cmd::indexBuffer_11577.into()];
        common::unreadable(ctx, false, a.index_buffer, &rules, a.member("indexBuffer"));
        return;
    }
    ctx.checked(&[cmd::indexBuffer_11577.into()]);
    // A stride below the index size still reads whole indices.
    let len = a.index_stride.checked_mul(count).map(|len| len.max(size));
    let inside = len.is_some_and(|len| state.range_in_one_buffer(a.index_buffer, len));
    if !inside {
        let available = common::bytes_available(state, None, a.index_buffer).unwrap_or(0);
        let held = common::elements_inside(available, size, a.index_stride);
        ctx.error(
            cmd::indexBuffer_11577,
            a.member("indexBuffer"),
            format!(
                "indexStride {} x primitiveCount {count} bytes from {:#x} do not lie inside one buffer, whose {available} bytes from there hold {} ({})",
                a.index_stride,
                a.index_buffer,
                count_of(held, "index", "indices"),
                common::last_inside("index", held)
            ),
        );
    }
}

/// Every one of the `count` indices the build fetches, at `indexStride`
/// intervals, lies inside the memory `indexBuffer` points into: decided
/// from the state tier up, where the buffer's (or described host
/// memory's) size is known. KHR's device command states it as 11577
/// ([`index_buffer_in_range`]); the rest is our rule.
fn index_buffer_holds_every_index(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    a: &Attachment<'_>,
    count: u64,
) {
    if a.kind == Kind::Khr && command == BuildCommand::Cmd {
        return;
    }
    let (Some(state), Some(host), Some(size)) = (ctx.state, ctx.host(), index_size(a.index_type))
    else {
        return;
    };
    if count == 0 || a.index_buffer == 0 {
        return;
    }
    // An address inside no buffer is the address rules' finding.
    let host = (command == BuildCommand::Host).then_some(host);
    let Some(available) = common::bytes_available(state, host, a.index_buffer) else {
        return;
    };
    let inside = common::elements_inside(available, size, a.index_stride);
    let needed = if a.index_stride == 0 { 1 } else { count };
    if inside >= needed {
        return;
    }
    ctx.error(
        &rules::INDEX_BUFFER_RANGE,
        a.member("indexBuffer"),
        format!(
            "the {available} bytes from indexBuffer hold {} at stride {}, but primitiveCount is {count}: index {inside} lies past the end ({})",
            count_of(inside, &format!("{size}-byte index"), &format!("{size}-byte indices")),
            a.index_stride,
            common::last_inside("index", inside)
        ),
    );
}

/// The NV attachment's two displacement formats (09501/09502 and their -parameter rules).
fn nv_formats(ctx: &mut Ctx<'_>, a: &Attachment<'_>, data: &TrianglesDisplacementMicromapNv) {
    let formats = [
        (
            "displacementBiasAndScaleFormat",
            data.displacement_bias_and_scale_format,
            nv::displacementBiasAndScaleFormat_parameter,
            nv::displacementBiasAndScaleFormat_09501,
        ),
        (
            "displacementVectorFormat",
            data.displacement_vector_format,
            nv::displacementVectorFormat_parameter,
            nv::displacementVectorFormat_09502,
        ),
    ];
    for (member, format, parameter, not_undefined) in formats {
        ctx.require(
            is_vk_format(format),
            parameter,
            || a.member(member),
            || format!("{format} is not a VkFormat value"),
        );
        ctx.require(
            format != VK_FORMAT_UNDEFINED,
            not_undefined,
            || a.member(member),
            || "the format is VK_FORMAT_UNDEFINED".into(),
        );
    }
}

/// The number of triangles the attachment's micromap was built with, where
/// the checker saw that build.
fn micromap_triangle_count(state: &State, a: &Attachment<'_>) -> Option<u64> {
    let record = match a.kind {
        Kind::Ext => state.micromaps.get(&a.micromap)?.built.as_ref()?,
        Kind::Khr => {
            let record = state
                .acceleration_structures
                .get(&a.micromap)?
                .built
                .as_ref()?;
            // A structure built as something else has no micromap triangles (11624 says so).
            if record.ty != ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP {
                return None;
            }
            record
        }
        Kind::Nv => return None,
    };
    Some(record.triangle_count)
}

/// The index buffer's contents (where the checker can read them) or, with
/// no index buffer, the triangle indices themselves, against the micromap:
/// without a micromap only special indices (11578 / our rule); with one,
/// `index + baseTriangle` inside its triangles (11575, 11576 / our rule).
///
/// Returns the EXT usage counts' tally of the micromap triangles the
/// indices select, where this pass made it (see [`ReferenceTally`]): None
/// where it did not, Some(None) where it is undecided.
fn index_contents(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    a: &Attachment<'_>,
    count: u64,
) -> Option<Option<TriangleHistogram>> {
    // Host builds take no KHR micromap (11705 says so); nothing to compare with.
    let khr_host_micromap = a.kind == Kind::Khr && command == BuildCommand::Host && a.micromap != 0;
    if a.kind == Kind::Nv || count == 0 || khr_host_micromap {
        return None;
    }
    let Some(state) = ctx.state else {
        return None; // Below the state tier neither the micromap nor the buffer is known.
    };
    // The EXT usage counts are held against the indices too.
    let usage_counts_rule = (a.kind == Kind::Ext && a.usage_counts.is_some())
        .then_some(RuleId::from(&rules::ATTACH_USAGE_COUNTS));
    let triangles = if a.micromap == 0 {
        None
    } else {
        match micromap_triangle_count(state, a) {
            Some(triangles) => Some(triangles),
            None => {
                // Nothing to compare with; where the micromap exists but its
                // build was not seen, say so.
                let mut skipped: Vec<RuleId> = match (a.kind, a.index_type) {
                    (Kind::Khr, INDEX_TYPE_NONE) => vec![khr::geometry_11576.into()],
                    (Kind::Khr, _) => vec![cmd::indexBuffer_11575.into()],
                    _ => vec![(&rules::INDEX_IN_RANGE).into()],
                };
                skipped.extend(usage_counts_rule);
                build_not_seen(ctx, a, &skipped);
                return None;
            }
        }
    };
    let base = u64::from(a.base_triangle);
    let array = a.member("indexBuffer");
    // The rules that decide an index past the micromap's end (see
    // `index_past_end`): KHR's VUID where its words apply, else ours.
    let in_range_rules = |no_index_buffer: bool| -> Vec<RuleId> {
        let ours = RuleId::from(&rules::INDEX_IN_RANGE);
        match a.kind {
            Kind::Khr if no_index_buffer => vec![khr::geometry_11576.into(), ours],
            Kind::Khr => vec![cmd::indexBuffer_11575.into(), ours],
            _ => vec![ours],
        }
    };
    let Some(size) = index_size(a.index_type) else {
        if a.index_type == INDEX_TYPE_NONE {
            if let Some(n) = triangles {
                ctx.checked(&in_range_rules(true));
                // Triangle j uses micromap triangle j + baseTriangle; the last is the largest.
                let last = count - 1;
                if let Some((rule, message)) = index_past_end(a.kind, last, base, n, true) {
                    ctx.error(
                        rule,
                        a.member("baseTriangle"),
                        format!("triangle {message}"),
                    );
                }
            }
        }
        return None;
    };
    let (Some(state), Some(host)) = (ctx.contents(), ctx.host()) else {
        return None; // Below the content tier no index is read.
    };
    let bytes = match command {
        BuildCommand::Host => host.bytes_from(a.index_buffer),
        _ => state.device_bytes_from(a.index_buffer),
    };
    let not_special_rule: RuleId = match (a.kind, command) {
        (Kind::Khr, BuildCommand::Cmd) => cmd::indexBuffer_11578.into(),
        _ => (&rules::NULL_MICROMAP_SPECIAL_ONLY).into(),
    };
    let mut index_rules = if triangles.is_some() {
        in_range_rules(false)
    } else {
        vec![not_special_rule]
    };
    index_rules.push((&rules::CLUSTER_INDEX_OUTSIDE_CLUSTER).into());
    index_rules.extend(usage_counts_rule);
    let host = command == BuildCommand::Host;
    let Some(bytes) = bytes else {
        common::unreadable(
            ctx,
            host,
            a.index_buffer,
            &index_rules,
            a.member("indexBuffer"),
        );
        return None;
    };
    ctx.checked(&index_rules);
    // A stride of 0 reads one index for every triangle.
    let (distinct, weight) = if a.index_stride == 0 {
        (1, count)
    } else {
        (count, 1)
    };
    // The EXT usage counts' tally rides on this pass where their rule
    // reaches the indices: a NULL micromap, or one whose content was read.
    let referenced = match a.micromap {
        0 => Some(None),
        micromap => state
            .micromaps
            .get(&micromap)
            .and_then(|m| m.built.as_ref()?.content.as_deref())
            .map(Some),
    };
    let mut references = referenced
        .filter(|_| usage_counts_rule.is_some())
        .map(|content| ReferenceTally::new(content, size, base, weight));
    let clean = CleanIndices::new(size, base, triangles);
    let mut tally = Tally::new();
    let mut held = (false, false);
    let read = for_each_chunk(bytes, size, a.index_stride, count, |first, values| {
        if let Some(references) = &mut references {
            references.add(values);
        }
        let (special, micromap) = special_and_micromap_indices(values, size);
        held = (held.0 | special, held.1 | micromap);
        if clean.all(values) {
            return;
        }
        for (j, &index) in (first..).zip(values) {
            index_rules_one_by_one(
                ctx,
                &mut tally,
                (a, &array, not_special_rule),
                (j, index),
                (size, base, triangles),
            );
        }
    });
    tally.finish(ctx);
    // The record of a device build asks the same of the same indices (see
    // `index_mix`); a host build's is left to read them itself.
    if read == distinct && !host {
        ctx.index_mixes.push(IndexMix {
            index_type: a.index_type,
            address: a.index_buffer,
            stride: a.index_stride,
            count,
            held,
        });
    }
    if read < distinct {
        // The indices past the readable bytes are not guessed at.
        let cause = if host {
            Cause::HostMemory
        } else {
            Cause::Contents
        };
        let (unread, verb) = if read + 1 == distinct {
            (format!("index {read}"), "lies")
        } else {
            (format!("indices {read} to {}", distinct - 1), "lie")
        };
        ctx.not_checked(
            cause,
            &index_rules,
            array.clone(),
            None,
            format_args!(
                "{unread} of {count} {verb} past the {} bytes the checker can read from indexBuffer{}",
                bytes.len(),
                // A host pointer differs from run to run: the same call
                // must give the same report.
                if host {
                    String::new()
                } else {
                    format!(" ({:#x}) on", a.index_buffer)
                }
            ),
        );
    }
    // Indices past the readable bytes leave the tally undecided.
    references.map(|references| references.finish().filter(|_| read == distinct))
}

/// The index rules for one index, `index` of triangle `j`, in the chunks
/// of [`index_contents`] that hold a finding: special indices pass; -5 is
/// for cluster geometry only; any other index selects a micromap triangle
/// below the count (`triangles`, None with a NULL micromap, where only
/// special indices may be used).
fn index_rules_one_by_one(
    ctx: &mut Ctx<'_>,
    tally: &mut Tally,
    (a, array, not_special_rule): (&Attachment<'_>, &str, RuleId),
    (j, index): (u64, u32),
    (size, base, triangles): (u64, u64, Option<u64>),
) {
    if is_special_index(index, size) {
        return;
    }
    // Built only for a finding: most indices have none.
    let location = || format!("{array}[{j}]");
    if is_cluster_skip_index(index, size) {
        tally.error(
            ctx,
            &rules::CLUSTER_INDEX_OUTSIDE_CLUSTER,
            location(),
            || format!("index {index:#x} is -5 (CLUSTER_GEOMETRY_DISABLE_OPACITY_MICROMAP_NV), which only cluster geometry may use"),
            array,
        );
        return;
    }
    match triangles {
        None => tally.error(
            ctx,
            not_special_rule,
            location(),
            || format!("micromap is VK_NULL_HANDLE, but index {index:#x} is no VkOpacityMicromapSpecialIndexKHR value"),
            array,
        ),
        Some(n) => {
            if let Some((rule, message)) =
                index_past_end(a.kind, u64::from(index), base, n, false)
            {
                tally.error(ctx, rule, location(), || format!("index {message}"), array);
            }
        }
    }
}

/// Reports `rules` not checked because the build of the attachment's
/// micromap, which the checker tracks, was not seen.
fn build_not_seen(ctx: &mut Ctx<'_>, a: &Attachment<'_>, rules: &[RuleId]) {
    let Some(state) = ctx.state else {
        return;
    };
    let ty = match a.kind {
        Kind::Ext
            if state
                .micromaps
                .get(&a.micromap)
                .is_some_and(|m| m.built.is_none()) =>
        {
            "VkMicromapEXT"
        }
        Kind::Khr
            if state
                .acceleration_structures
                .get(&a.micromap)
                .is_some_and(|s| s.built.is_none()) =>
        {
            "VkAccelerationStructureKHR"
        }
        _ => return,
    };
    ctx.not_checked(
        Cause::BuildNotSeen,
        rules,
        a.member("micromap"),
        Some(crate::report::ObjectRef {
            ty,
            handle: a.micromap,
        }),
        format_args!(
            "the build of {ty} {:#x} was not seen, so its triangle count is unknown",
            a.micromap
        ),
    );
}

/// Whether micromap triangle `index + base` lies past the end of a micromap
/// of `n` triangles, and if so under which rule, with the message's tail.
/// The micromap holds triangles 0 to n - 1, so `index + base >= n` reads
/// past it. KHR's VUIDs state only "less than or equal to numTriangles"
/// (11575 moreover only for an index greater than zero; 11576, with no
/// index buffer, for every triangle index): they are reported where their
/// words apply, and the rest (one past the last triangle, an index 0 at
/// or past the end) under our rule, as are all EXT indices, which have no
/// VUID. `no_index_buffer` selects 11576 over 11575.
fn index_past_end(
    kind: Kind,
    index: u64,
    base: u64,
    n: u64,
    no_index_buffer: bool,
) -> Option<(RuleId, String)> {
    let target = index.checked_add(base);
    if target.is_some_and(|target| target < n) {
        return None;
    }
    let beyond_le = target.is_none_or(|target| target > n);
    let vuid: Option<RuleId> = match kind {
        Kind::Khr if no_index_buffer && beyond_le => Some(khr::geometry_11576.into()),
        Kind::Khr if !no_index_buffer && beyond_le && index > 0 => {
            Some(cmd::indexBuffer_11575.into())
        }
        _ => None,
    };
    let sum = index.saturating_add(base);
    let message = match (vuid, n) {
        (Some(_), _) => {
            format!("{index} + baseTriangle {base} = {sum} is greater than numTriangles {n}")
        }
        (None, 0) => format!(
            "{index} + baseTriangle {base} = {sum}, but the micromap was built with no triangles"
        ),
        (None, _) => format!(
            "{index} + baseTriangle {base} = {sum} is not below numTriangles {n}: the micromap holds triangles 0 to {}",
            n - 1
        ),
    };
    let rule = vuid.unwrap_or_else(|| (&rules::INDEX_IN_RANGE).into());
    Some((rule, message))
}

/// EXT and NV attachments: per (format, subdivision level), the usage
/// counts equal the number of geometry triangles `t < primitiveCount` whose
/// index plus baseTriangle selects a micromap triangle of that key (each
/// reference counted; special indices, which EXT alone has, not counted).
/// Decided only when the micromap's content and every index are known and
/// every index selects a triangle the checker read (an index past the end
/// is the index rules' finding). A NULL micromap has no triangles: every
/// index must be special (11578 or our rule says so otherwise), so every
/// count must be zero.
///
/// `from_index_pass` is the tally [`index_contents`] made in its pass over
/// the index buffer (Some(None): undecided); where it made none (NV
/// attachments), the indices are read here.
fn usage_counts_match_indices(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    a: &Attachment<'_>,
    count: u64,
    from_index_pass: Option<Option<TriangleHistogram>>,
) {
    let Some(state) = ctx.contents() else {
        return; // Below the content tier neither indices nor micromap data are read.
    };
    if a.kind == Kind::Khr || count == 0 {
        return;
    }
    let Some(counts) = a.usage_counts else {
        return;
    };
    let content = if a.micromap == 0 {
        None
    } else {
        let built = state
            .micromaps
            .get(&a.micromap)
            .and_then(|m| m.built.as_ref());
        match built.and_then(|b| b.content.as_ref()) {
            Some(content) => Some(content),
            None => {
                // A build not seen at all is index_contents' finding; one
                // known only by its triangle count (a scene's `built`, or a
                // build whose triangle array could not be read) leaves the
                // counts undecided.
                if built.is_some() && !ctx.device_contents_later {
                    ctx.not_checked(
                        Cause::BuildNotSeen,
                        &[(&rules::ATTACH_USAGE_COUNTS).into()],
                        a.member("micromap"),
                        Some(crate::report::ObjectRef {
                            ty: "VkMicromapEXT",
                            handle: a.micromap,
                        }),
                        format_args!(
                            "only the triangle count of VkMicromapEXT {:#x} is known, not its triangles (its build was not seen, or its triangle array could not be read then)",
                            a.micromap
                        ),
                    );
                }
                return;
            }
        }
    };
    let triangles_read = content.map_or(0, |c| c.triangles.len() as u64);
    let key = |m: u64| {
        let t = content?.triangles.get(usize::try_from(m).ok()?)?;
        Some((u32::from(t.format), u32::from(t.subdivision_level)))
    };
    let base = u64::from(a.base_triangle);
    let mut found = TriangleHistogram::new();
    match index_size(a.index_type) {
        None if a.index_type == INDEX_TYPE_NONE => {
            // Triangle t uses t + baseTriangle: all of them must have been read,
            // which bounds the loop by the triangle array.
            let Some(last) = (count - 1).checked_add(base) else {
                return;
            };
            if last >= triangles_read {
                return;
            }
            for t in 0..count {
                match key(t + base) {
                    Some((format, level)) => found.add(format, level, 1),
                    None => return,
                }
            }
        }
        None => return,
        Some(_) if from_index_pass.is_some() => match from_index_pass.flatten() {
            Some(tallied) => found = tallied,
            None => return,
        },
        Some(size) => {
            let bytes = match (command, ctx.host()) {
                (BuildCommand::Host, Some(host)) => host.bytes_from(a.index_buffer),
                (BuildCommand::Host, None) => None,
                _ => state.device_bytes_from(a.index_buffer),
            };
            let Some(bytes) = bytes else {
                return; // Contents not available to the checker.
            };
            // A stride of 0 reads one index for every triangle.
            let (expected, weight) = if a.index_stride == 0 {
                (1, count)
            } else {
                (count, 1)
            };
            let mut read = 0u64;
            for (_, index) in read_indices(bytes, size, a.index_stride, count) {
                read += 1;
                if a.kind == Kind::Ext && is_special_index(index, size) {
                    continue;
                }
                match key(u64::from(index) + base) {
                    Some((format, level)) => found.add(format, level, weight),
                    None => return,
                }
            }
            if read < expected {
                return; // Part of the index buffer is not readable.
            }
        }
    }
    let found = found.into_map();
    let (member, entries) = counts.entries();
    let mut declared: BTreeMap<(u32, u32), (u64, Option<usize>)> = BTreeMap::new();
    for (k, usage) in &entries {
        let sum = declared
            .entry((usage.format, usage.subdivision_level))
            .or_insert((0, Some(*k)));
        sum.0 = sum.0.saturating_add(u64::from(usage.count));
    }
    let keys: std::collections::BTreeSet<(u32, u32)> =
        declared.keys().chain(found.keys()).copied().collect();
    let array = a.member(member);
    let names = match a.kind {
        Kind::Nv => FormatKind::DisplacementNv,
        _ => FormatKind::OpacityExt,
    };
    let mut tally = Tally::new();
    let message = |(format, level): (u32, u32)| {
        let said = declared.get(&(format, level)).map_or(0, |d| d.0);
        let has = found.get(&(format, level)).copied().unwrap_or(0);
        format!("{}: the usage counts say {said}, the {} reference micromap triangles of that format and level {}", names.key(format, level), count_of(count, "geometry triangle", "geometry triangles"), count_of(has, "time", "times"))
    };
    // A count under the wrong key: one finding, with a hint.
    let sums: BTreeMap<(u32, u32), u64> = declared.iter().map(|(key, d)| (*key, d.0)).collect();
    let limits = &ctx.device.limits;
    let misplaced =
        usage_hints::misplaced(&sums, &found, |k| usage_hints::valid_key(k, names, limits));
    for (format, level) in keys {
        let (said, first) = declared.get(&(format, level)).copied().unwrap_or((0, None));
        let has = found.get(&(format, level)).copied().unwrap_or(0);
        if said == has || misplaced.iter().any(|m| m.meant == (format, level)) {
            continue;
        }
        let location = first.map_or_else(|| array.clone(), |k| format!("{array}[{k}]"));
        if let Some(m) = misplaced.iter().find(|m| m.wrong == (format, level)) {
            let finding = ctx.error(&rules::ATTACH_USAGE_COUNTS, location, message(m.wrong));
            finding.fold(1, format!("and {}", message(m.meant)));
            finding.hint = Some(usage_hints::hint(m, names));
            continue;
        }
        tally.error(
            ctx,
            &rules::ATTACH_USAGE_COUNTS,
            location,
            || message((format, level)),
            &array,
        );
    }
    tally.finish(ctx);
}

/// An instances geometry of a top-level build: each instance's opacity
/// flags need the micromap feature (11580) and, for DISABLE, a referenced
/// structure built to allow it (10607 / 11581).
pub(crate) fn instances(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    at: GeometryAt,
    info: &BuildGeometryInfo,
    instances: &InstancesData,
    range: Option<&BuildRangeInfo>,
) {
    let _ = info;
    if let Some(range) = range {
        instances_in_range(ctx, command, at, instances, range);
    }
    // Instances are buffer contents: decided from the content tier on.
    let Some(state) = ctx.contents() else {
        return;
    };
    let disable_vuid = match command {
        BuildCommand::Cmd => cmd::pInfos_10607,
        BuildCommand::Indirect => indirect::pInfos_10607,
        BuildCommand::Host => instance_vuid::flags_11581,
    };
    let instance_rules = [instance_vuid::micromap_11580.into(), disable_vuid.into()];
    let Some(list) = &instances.instances else {
        // An indirect build's instance count is in device memory too.
        if command != BuildCommand::Indirect {
            common::unreadable(
                ctx,
                command == BuildCommand::Host,
                instances.data,
                &instance_rules,
                format_args!("{at}.geometry.instances.data"),
            );
        }
        return;
    };
    ctx.checked(&instance_rules);
    let force = khr_values::GEOMETRY_INSTANCE_FORCE_OPACITY_MICROMAP_2_STATE_BIT_KHR.as_raw() as u8;
    let disable = khr_values::GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT_KHR.as_raw() as u8;
    let allow_disable =
        khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_BIT_KHR.as_raw();
    let features = &ctx.device.features;
    let micromap_feature = features.micromap_ext || features.micromap_khr;
    let array = format!("{at}.geometry.instances.data");
    let mut tally = Tally::new();
    for (k, instance) in list.iter().enumerate() {
        // Built only for a finding: most instances have none.
        let location = || format!("{array}[{k}].flags");
        if instance.flags & (force | disable) != 0 && !micromap_feature {
            tally.error(
                ctx,
                instance_vuid::micromap_11580,
                location(),
                || format!("flags {:#x} use opacity micromap bits, but neither micromap feature is enabled", instance.flags),
                &array,
            );
        }
        if instance.flags & disable == 0 {
            continue;
        }
        let referenced =
            referenced_structure(state, command, instance.acceleration_structure_reference);
        let built_flags = referenced.and_then(|s| s.built.as_ref()).map(|b| b.flags);
        if let Some(flags) = built_flags.filter(|flags| flags & allow_disable == 0) {
            tally.error(
                ctx,
                disable_vuid,
                location(),
                || format!("VK_GEOMETRY_INSTANCE_DISABLE_OPACITY_MICROMAPS_BIT_KHR is set, but the referenced acceleration structure {:#x} was built with flags {flags:#x}, without VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_DISABLE_OPACITY_MICROMAPS_BIT_KHR", instance.acceleration_structure_reference),
                &array,
            );
        }
    }
    tally.finish(ctx);
}

/// The `primitiveCount` instances (or pointers to them) from `data +
/// primitiveOffset` lie inside the memory holding that address: decided
/// from the state tier up, where its size is known. An instance is counted
/// as 64 bytes, the size of VkAccelerationStructureInstanceKHR; motion
/// instances are larger, so for them the rule errs towards silence.
fn instances_in_range(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    at: GeometryAt,
    instances: &InstancesData,
    range: &BuildRangeInfo,
) {
    const INSTANCE_SIZE: u64 = 64;
    const POINTER_SIZE: u64 = 8;
    let (Some(state), Some(host)) = (ctx.state, ctx.host()) else {
        return;
    };
    let count = u64::from(range.primitive_count);
    if count == 0 || instances.data == 0 {
        return;
    }
    let offset = u64::from(range.primitive_offset);
    let Some(start) = instances.data.checked_add(offset) else {
        return;
    };
    // An address inside no buffer is the address rules' finding.
    let host = (command == BuildCommand::Host).then_some(host);
    let Some(available) = common::bytes_available(state, host, start) else {
        return;
    };
    let (size, what) = if instances.array_of_pointers {
        (POINTER_SIZE, "pointer")
    } else {
        (INSTANCE_SIZE, "instance")
    };
    let inside = common::elements_inside(available, size, size);
    if inside < count {
        ctx.error(
            &rules::INSTANCES_RANGE,
            format!("{at}.geometry.instances.data"),
            format!(
                "the {available} bytes from data + primitiveOffset {offset} hold {}, but primitiveCount is {count}: {what} {inside} lies past the end ({})",
                count_of(inside, &format!("{size}-byte {what}"), &format!("{size}-byte {what}s")),
                common::last_inside(what, inside)
            ),
        );
    }
}

/// The acceleration structure an instance references: a handle in host
/// builds, a device address (the start of its memory) in device builds.
fn referenced_structure(
    state: &State,
    command: BuildCommand,
    reference: u64,
) -> Option<&AccelerationStructure> {
    if command == BuildCommand::Host {
        return state.acceleration_structures.get(&reference);
    }
    state
        .acceleration_structures
        .values()
        .find(|s| memory_range(state, s).is_some_and(|(start, _)| start == reference))
}

/// The device-address range backing an acceleration structure, when known.
pub(crate) fn memory_range(state: &State, structure: &AccelerationStructure) -> Option<(u64, u64)> {
    structure.address_range.or_else(|| {
        let base = state.buffers.get(&structure.buffer)?.device_address?;
        let start = base.checked_add(structure.offset)?;
        Some((start, start.checked_add(structure.size)?))
    })
}

/// Rules that relate different elements of `pInfos`: a KHR micromap of one
/// info is no other info's destination (11548), nor overlaps its memory
/// (11549); and update builds chain what the original build chained
/// (11625-11627, 11629).
pub(crate) fn across_infos(ctx: &mut Ctx<'_>, command: BuildCommand, infos: &[BuildGeometryInfo]) {
    if command == BuildCommand::Cmd {
        micromaps_against_destinations(ctx, infos);
    }
    if command != BuildCommand::Host {
        for (i, info) in infos.iter().enumerate() {
            if info.mode == BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE {
                update_matches_original(ctx, command, i, info);
                let indirect = command == BuildCommand::Indirect;
                crate::checks::provenance::update_from_deserialized(ctx, indirect, i, info);
            }
        }
    }
}

/// The KHR micromaps an info's geometries reference, with where their
/// attachments are.
fn khr_micromaps(
    i: usize,
    info: &BuildGeometryInfo,
) -> impl Iterator<Item = (AttachmentAt, Handle)> + '_ {
    let member = info.geometry_member();
    info.geometries_read().filter_map(move |(g, geometry)| {
        match KhrOpacityAttachment::of(geometry) {
            KhrOpacityAttachment::Micromap(m) => {
                let at = attachment_at(geometry_at(InfoAt::Element(i), member, g), Kind::Khr);
                Some((at, m))
            }
            _ => None,
        }
    })
}

fn micromaps_against_destinations(ctx: &mut Ctx<'_>, infos: &[BuildGeometryInfo]) {
    // Below the state tier only the handles are compared (11548).
    let state = ctx.state;
    let range_of = |handle: Handle| {
        let state = state?;
        state
            .acceleration_structures
            .get(&handle)
            .and_then(|s| memory_range(state, s))
    };
    for (i, info) in infos.iter().enumerate() {
        for (attachment, micromap) in khr_micromaps(i, info) {
            let location = || format!("{attachment}.micromap");
            for (j, other) in infos.iter().enumerate().filter(|(j, _)| *j != i) {
                let dst = other.dst_acceleration_structure;
                if dst == micromap {
                    ctx.error(
                        cmd::dstAccelerationStructure_11548,
                        location(),
                        format!("{micromap:#x} is also pInfos[{j}].dstAccelerationStructure"),
                    );
                    continue;
                }
                if let (Some(a), Some(b)) = (range_of(micromap), range_of(dst)) {
                    if a.0 < b.1 && b.0 < a.1 {
                        ctx.error(
                            cmd::dstAccelerationStructure_11549,
                            location(),
                            format!("the memory of micromap {micromap:#x} [{:#x}, {:#x}) overlaps that of pInfos[{j}].dstAccelerationStructure [{:#x}, {:#x})", a.0, a.1, b.0, b.1),
                        );
                    }
                }
            }
        }
    }
}

/// An update build against the KHR attachments of the source's original build.
fn update_matches_original(
    ctx: &mut Ctx<'_>,
    command: BuildCommand,
    i: usize,
    info: &BuildGeometryInfo,
) {
    // The state outlives the context's borrow, so findings can be reported
    // while reading the record.
    let Some(state) = ctx.state else {
        return;
    };
    let (kept_micromap, kept_null, none_added, same_handle) = match command {
        BuildCommand::Indirect => (
            indirect::micromap_11625,
            indirect::micromap_11626,
            indirect::micromap_11627,
            indirect::micromap_11629,
        ),
        _ => (
            cmd::micromap_11625,
            cmd::micromap_11626,
            cmd::micromap_11627,
            cmd::micromap_11629,
        ),
    };
    let update_rules: [RuleId; 4] = [
        kept_micromap.into(),
        kept_null.into(),
        none_added.into(),
        same_handle.into(),
    ];
    let Some(original) = state
        .original_attachments
        .get(&info.src_acceleration_structure)
    else {
        // A source the checker tracks, whose original build it did not see.
        let src = info.src_acceleration_structure;
        if state.acceleration_structures.contains_key(&src) {
            ctx.not_checked(
                Cause::BuildNotSeen,
                &update_rules,
                format!("pInfos[{i}].srcAccelerationStructure"),
                Some(crate::report::ObjectRef {
                    ty: "VkAccelerationStructureKHR",
                    handle: src,
                }),
                format_args!("the original build of VkAccelerationStructureKHR {src:#x} was not seen, so the opacity micromaps it chained are unknown"),
            );
        }
        return;
    };
    ctx.checked(&update_rules);
    let update_bits = khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR
        .as_raw()
        | khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_DATA_UPDATE_BIT_EXT
            .as_raw();
    let handle_must_match = original.flags & update_bits == 0 && !original.deserialized;
    let member = info.geometry_member();
    for (g, geometry) in info.geometries_read() {
        if geometry.geometry_type != GEOMETRY_TYPE_TRIANGLES {
            continue;
        }
        let Some(before) = original.geometries.get(g).copied() else {
            continue;
        };
        // Written out only for a finding.
        let at = format_args!("pInfos[{i}].{member}[{g}].geometry.triangles.pNext");
        use KhrOpacityAttachment::{Absent, Micromap, NullMicromap};
        match (before, KhrOpacityAttachment::of(geometry)) {
            (Micromap(_), Absent | NullMicromap) => {
                ctx.error(kept_micromap, at.to_string(), "the original build chained a VkAccelerationStructureTrianglesOpacityMicromapKHR with a micromap; this update chains none with a micromap");
            }
            (NullMicromap, Absent | Micromap(_)) => {
                ctx.error(kept_null, at.to_string(), "the original build chained a VkAccelerationStructureTrianglesOpacityMicromapKHR with micromap VK_NULL_HANDLE; this update does not");
            }
            (Absent, NullMicromap | Micromap(_)) => {
                ctx.error(none_added, at.to_string(), "the original build chained no VkAccelerationStructureTrianglesOpacityMicromapKHR; this update chains one");
            }
            (Micromap(old), Micromap(new)) if handle_must_match && old != new => {
                ctx.error(same_handle, at.to_string(), format!("micromap {new:#x} differs from {old:#x} of the original build, which allowed no opacity micromap update"));
            }
            _ => {}
        }
    }
}

/// Records, for each info of a build that creates (mode BUILD) an
/// acceleration structure, which KHR opacity attachments its geometries
/// chain, for later update builds to be checked against. The build
/// entry points call it after their checks.
pub fn record_original_attachments(state: &mut State, infos: &[BuildGeometryInfo]) {
    for info in infos {
        if info.mode != BUILD_ACCELERATION_STRUCTURE_MODE_BUILD
            || info.dst_acceleration_structure == 0
        {
            continue;
        }
        // Collected at their exact length: one allocation, no regrowth.
        let geometries = if let Some(list) = &info.geometries {
            list.iter().map(KhrOpacityAttachment::of).collect()
        } else if let Some(list) = &info.geometry_pointers {
            list.iter()
                .map(|g| g.as_ref().map(KhrOpacityAttachment::of).unwrap_or_default())
                .collect()
        } else {
            Vec::new()
        };
        state.original_attachments.insert(
            info.dst_acceleration_structure,
            OriginalAttachments {
                flags: info.flags,
                deserialized: false,
                geometries,
            },
        );
    }
}

/// The cluster info structure whose opacity members are checked.
#[derive(Clone, Copy)]
struct ClusterVuids {
    array_needs_flag: Vuid,
    array_parameter: Vuid,
    index_buffer_parameter: Vuid,
    index_type_single_bit: Vuid,
}

const CLUSTER_VUIDS: ClusterVuids = ClusterVuids {
    array_needs_flag: cluster::opacityMicromapArray_10881,
    array_parameter: cluster::opacityMicromapArray_parameter,
    index_buffer_parameter: cluster::opacityMicromapIndexBuffer_parameter,
    index_type_single_bit: cluster::opacityMicromapIndexType_10492,
};

const CLUSTER_TEMPLATE_VUIDS: ClusterVuids = ClusterVuids {
    array_needs_flag: cluster_template::opacityMicromapArray_10882,
    array_parameter: cluster_template::opacityMicromapArray_parameter,
    index_buffer_parameter: cluster_template::opacityMicromapIndexBuffer_parameter,
    index_type_single_bit: cluster_template::opacityMicromapIndexType_10501,
};

const CLUSTER_FUNCTION: &str = "vkCmdBuildClusterAccelerationStructureIndirectNV";

impl Validator {
    /// The opacity-micromap members of the
    /// `VkClusterAccelerationStructureBuildTriangleClusterInfoNV` elements a
    /// `vkCmdBuildClusterAccelerationStructureIndirectNV` with opType
    /// BUILD_TRIANGLE_CLUSTER reads from `srcInfosArray` (as far as the
    /// caller could read them), against `VkClusterAccelerationStructureInputInfoNV::flags`.
    pub fn cmd_build_cluster_triangle_clusters(
        &mut self,
        input_flags: u32,
        src_infos: &[ClusterBuildTriangleClusterInfo],
    ) -> Report {
        let mut ctx = self.ctx(CLUSTER_FUNCTION);
        for (k, info) in src_infos.iter().enumerate() {
            cluster_opacity(&mut ctx, input_flags, k, &info.opacity, &CLUSTER_VUIDS);
        }
        ctx.finish()
    }

    /// As [`Self::cmd_build_cluster_triangle_clusters`], for opType
    /// BUILD_TRIANGLE_CLUSTER_TEMPLATE and its
    /// `VkClusterAccelerationStructureBuildTriangleClusterTemplateInfoNV` elements.
    pub fn cmd_build_cluster_triangle_cluster_templates(
        &mut self,
        input_flags: u32,
        src_infos: &[ClusterBuildTriangleClusterTemplateInfo],
    ) -> Report {
        let mut ctx = self.ctx(CLUSTER_FUNCTION);
        for (k, info) in src_infos.iter().enumerate() {
            cluster_opacity(
                &mut ctx,
                input_flags,
                k,
                &info.opacity,
                &CLUSTER_TEMPLATE_VUIDS,
            );
        }
        ctx.finish()
    }
}

fn cluster_opacity(
    ctx: &mut Ctx<'_>,
    input_flags: u32,
    k: usize,
    opacity: &ClusterTriangleOpacity,
    vuids: &ClusterVuids,
) {
    let at = format!("pCommandInfos->srcInfosArray[{k}]");
    let allow =
        khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_CLUSTER_OPACITY_MICROMAPS_BIT_NV.as_raw();
    let array = opacity.opacity_micromap_array;
    if array != 0 {
        ctx.require(
            input_flags & allow != 0,
            vuids.array_needs_flag,
            || format!("{at}.opacityMicromapArray"),
            || format!("the input flags {input_flags:#x} lack VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_CLUSTER_OPACITY_MICROMAPS_BIT_NV"),
        );
        cluster_address(
            ctx,
            array,
            vuids.array_parameter,
            &format!("{at}.opacityMicromapArray"),
        );
    }
    let index_buffer = opacity.opacity_micromap_index_buffer;
    if index_buffer != 0 {
        cluster_address(
            ctx,
            index_buffer,
            vuids.index_buffer_parameter,
            &format!("{at}.opacityMicromapIndexBuffer"),
        );
    }
    // A zero index type is left alone where nothing is indexed: structures
    // without micromaps commonly leave the field 0.
    let index_type = opacity.opacity_micromap_index_type;
    let single_bit = index_type.count_ones() == 1 || (index_type == 0 && index_buffer == 0);
    ctx.require(
        single_bit,
        vuids.index_type_single_bit,
        || format!("{at}.opacityMicromapIndexType"),
        || format!("{index_type:#x} does not have exactly one bit set"),
    );
}

/// An optional cluster address that is set must lie in a buffer, where the
/// checker knows buffer addresses.
fn cluster_address(ctx: &mut Ctx<'_>, address: u64, vuid: Vuid, location: &str) {
    if ctx
        .state
        .is_some_and(|state| state.knows_addresses() && state.buffers_at(address).next().is_none())
    {
        ctx.error(
            vuid,
            location,
            format!("{address:#x} is inside no buffer's device-address range"),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_past_end_follows_the_vuid_wording() {
        let rule = |kind, index, base, n, none| {
            index_past_end(kind, index, base, n, none).map(|(rule, _)| rule.as_str())
        };
        let own = rules::INDEX_IN_RANGE.id;
        assert_eq!(rule(Kind::Khr, 1, 0, 2, false), None);
        assert_eq!(rule(Kind::Khr, 2, 0, 2, false), Some(own));
        assert_eq!(
            rule(Kind::Khr, 3, 0, 2, false),
            Some(cmd::indexBuffer_11575.id())
        );
        // Index 0 is outside 11575's "greater than zero", however far past.
        assert_eq!(rule(Kind::Khr, 0, 5, 2, false), Some(own));
        // A micromap with no triangles: index 0 + 0 is "less than or equal to" 0.
        assert_eq!(rule(Kind::Khr, 0, 0, 0, true), Some(own));
        assert_eq!(
            rule(Kind::Khr, 0, 1, 0, true),
            Some(khr::geometry_11576.id())
        );
        assert_eq!(rule(Kind::Ext, 0, 0, 0, false), Some(own));
        assert_eq!(rule(Kind::Ext, 9, 0, 2, false), Some(own));
        let (_, message) = index_past_end(Kind::Khr, 0, 0, 0, false).unwrap();
        assert!(message.contains("no triangles"), "{message}");
    }

    #[test]
    fn special_indices_by_width() {
        assert!(is_special_index(0xFFFF, 2));
        assert!(is_special_index(0xFFFC, 2));
        assert!(!is_special_index(0xFFFB, 2), "-5 is cluster-only");
        assert!(is_special_index(0xFC, 1));
        assert!(!is_special_index(0xFB, 1));
        assert!(is_special_index(u32::MAX - 3, 4));
        assert!(!is_special_index(u32::MAX - 4, 4));
        assert!(!is_special_index(0, 4));
    }

    #[test]
    fn indices_are_read_little_endian_within_the_bytes() {
        let bytes = [1u8, 0, 2, 0, 0xff, 0xff];
        let read: Vec<_> = read_indices(&bytes, 2, 2, 10).collect();
        assert_eq!(read, [(0, 1), (1, 2), (2, 0xffff)]);
        let strided: Vec<_> = read_indices(&bytes, 2, 4, 2).collect();
        assert_eq!(strided, [(0, 1), (1, 0xffff)]);
        // A zero stride reads one index, however many triangles there are.
        assert_eq!(read_indices(&bytes, 4, 0, u64::MAX).count(), 1);
        assert_eq!(read_indices(&bytes, 4, u64::MAX, 3).count(), 1);
    }

    #[test]
    fn vk_format_values() {
        assert!(is_vk_format(0));
        assert!(is_vk_format(vk_format_r16g16_sfloat()));
        assert!(!is_vk_format(185));
        assert!(!is_vk_format(-1));
    }

    fn vk_format_r16g16_sfloat() -> i32 {
        ash::vk::Format::R16G16_SFLOAT.as_raw()
    }
}
