//! The rules that ask which micromaps serialized bytes came from (07547,
//! 07550, 11582, 11587, 11628, 11634, 11637), decided from the provenance
//! the state keeps (`state::provenance`): each serialization is recorded
//! where it writes, each deserialization is linked to what its source
//! holds (by the fingerprint of the bytes when they are readable, else by
//! the last serialization seen writing at that address), and a deserialized
//! acceleration structure remembers what the micromaps of its original
//! build held, for the commands that use it later.
//!
//! An error is reported only where it is certain within what the checker
//! saw: bytes a serialization of something else wrote, or that a build or
//! copy overwrote after; a micromap whose contents come from a build or
//! deserialization other than the one asked for. Bytes no serialization the
//! checker saw wrote (another run, another process, a file) get an
//! `OMMCHECK-not-checked-serialization-not-seen` information instead.

use std::collections::BTreeSet;
use std::sync::Arc;

use ommcheck_vuids::vuid::VkCopyAccelerationStructureToMemoryInfoKHR as to_memory_info;
use ommcheck_vuids::vuid::VkCopyMemoryToMicromapInfoEXT as from_memory_info;
use ommcheck_vuids::vuid::{
    vkCmdBuildAccelerationStructuresIndirectKHR as indirect,
    vkCmdBuildAccelerationStructuresKHR as cmd_build,
};
use ommcheck_vuids::{khr as khr_values, Vuid};

use crate::checks::accel_attach::memory_range;
use crate::checks::serialized;
use crate::checks::Ctx;
use crate::model::accel::{
    BuildGeometryInfo, GeometryData, KhrOpacityAttachment,
    ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP, BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE,
    GEOMETRY_TYPE_TRIANGLES,
};
use crate::model::Handle;
use crate::report::not_checked::Cause;
use crate::report::{ObjectRef, RuleId};
use crate::state::provenance::store::Store;
use crate::state::provenance::{Deserialized, Expected, Serialization, Serialized, Space, Write};
use crate::state::State;

/// What the bytes a deserialization reads hold, as far as the checker saw.
pub(crate) enum Source {
    /// A serialization the checker saw wrote them (`how`: found by the
    /// fingerprint of the bytes, or by the address).
    Serialized(Arc<Serialization>, &'static str),
    /// A build or copy the checker saw wrote `object`'s memory over them
    /// after the last serialization seen there.
    Overwritten { object: Handle, ty: &'static str },
    /// No serialization the checker saw wrote them.
    Unknown,
}

/// The device memory range of a micromap or acceleration structure.
fn storage(state: &State, buffer: Handle, offset: u64, size: u64) -> Option<(u64, u64)> {
    let start = state.device_address_in(buffer, offset)?;
    Some((start, start.checked_add(size)?))
}

/// The micromap or acceleration structure whose memory holds `address` and
/// that a construction the checker saw wrote after `since`.
fn overwritten_by(state: &State, address: u64, since: u64) -> Option<(Handle, &'static str)> {
    let later = |handle: &Handle| {
        state
            .provenance
            .constructed_seq(*handle)
            .is_some_and(|seq| seq > since)
    };
    let inside =
        |range: Option<(u64, u64)>| range.is_some_and(|(s, e)| s <= address && address < e);
    let micromap = state
        .micromaps
        .iter()
        .find(|(h, m)| later(h) && inside(storage(state, m.buffer, m.offset, m.size)))
        .map(|(h, _)| (*h, "VkMicromapEXT"));
    micromap.or_else(|| {
        state
            .acceleration_structures
            .iter()
            .find(|(h, s)| later(h) && inside(memory_range(state, s)))
            .map(|(h, _)| (*h, "VkAccelerationStructureKHR"))
    })
}

/// What the bytes at `address` (host memory when `host`) hold. The bytes
/// are fingerprinted only from the content tier up (`contents`).
pub(crate) fn source_of(state: &State, host: bool, address: u64, contents: bool) -> Source {
    let bytes = if !contents {
        None
    } else if host {
        state.host_bytes_from(address)
    } else {
        state.device_bytes_from(address)
    };
    // Bytes the state does not hold may have been read by the adaptor.
    let fingerprint = bytes.and_then(serialized::fingerprint).or_else(|| {
        contents
            .then(|| state.provenance.fingerprint_given(Space::of(host), address))
            .flatten()
    });
    if let Some(found) = fingerprint.and_then(|f| state.provenance.fingerprints.find(f)) {
        return Source::Serialized(found, "the fingerprint of the bytes");
    }
    let written = state.provenance.written_at(Space::of(host), address);
    let since = written.map_or(0, |w: &Write| w.seq);
    if !host {
        if let Some((object, ty)) = overwritten_by(state, address, since) {
            return Source::Overwritten { object, ty };
        }
    }
    match written {
        Some(w) => Source::Serialized(w.serialization.clone(), "the address"),
        None => Source::Unknown,
    }
}

fn serialized_what(s: &Serialization) -> String {
    if s.stored {
        let ty = match &s.what {
            Serialized::Micromap { .. } => "VkMicromapEXT",
            Serialized::AccelerationStructure { .. } => "VkAccelerationStructureKHR",
        };
        return format!(
            "{} of a {ty} in another run or process (found in the provenance store)",
            s.function
        );
    }
    match &s.what {
        Serialized::Micromap { micromap, .. } => {
            format!("{} of VkMicromapEXT {micromap:#x}", s.function)
        }
        Serialized::AccelerationStructure { structure, .. } => {
            format!(
                "{} of VkAccelerationStructureKHR {structure:#x}",
                s.function
            )
        }
    }
}

/// `VkCopyMemoryToMicromapInfoEXT::src` must hold a micromap's serialization
/// (07547) and `dst` be at least as large as the micromap serialized (07550).
pub(crate) fn micromap_source(ctx: &mut Ctx<'_>, host: bool, src: u64, dst: Handle) {
    let Some(state) = ctx.state else {
        return;
    };
    if src == 0 {
        return;
    }
    let location = if host {
        "pInfo->src.hostAddress"
    } else {
        "pInfo->src.deviceAddress"
    };
    let rules: [RuleId; 2] = [
        from_memory_info::src_07547.into(),
        from_memory_info::dst_07550.into(),
    ];
    // An address the address rules already report (outside every known
    // buffer or described host range) gets no information as well.
    let outside = if host {
        ctx.host()
            .is_some_and(|memory| memory.describes_all() && memory.bytes_from(src).is_none())
    } else {
        state.knows_addresses() && state.buffers_at(src).next().is_none()
    };
    match source_of(state, host, src, ctx.contents) {
        Source::Unknown if outside => {}
        Source::Unknown => ctx.not_checked(
            Cause::SerializationNotSeen,
            &rules,
            location,
            None,
            format_args!("no serialization the checker saw wrote the bytes at {location}, so which micromap they hold is unknown (bytes serialized by another run or process, or read from a file, are not followed)"),
        ),
        Source::Overwritten { object, ty } => {
            ctx.error(
                from_memory_info::src_07547,
                location,
                format!("the bytes at {location} lie in the memory of {ty} {object:#x}, which a build or copy recorded after the last serialization seen there wrote over: they are not data serialized with vkCmdCopyMicromapToMemoryEXT"),
            );
        }
        Source::Serialized(s, how) => match &s.what {
            Serialized::AccelerationStructure { .. } => {
                ctx.error(
                    from_memory_info::src_07547,
                    location,
                    format!("the bytes at {location} were written by {} (found by {how}), not serialized from a micromap with vkCmdCopyMicromapToMemoryEXT", serialized_what(&s)),
                );
            }
            Serialized::Micromap { size, micromap, .. } => {
                ctx.checked(&[rules[0]]);
                let Some(dst_size) = state.micromaps.get(&dst).map(|m| m.size) else {
                    return;
                };
                ctx.require(
                    dst_size >= *size,
                    from_memory_info::dst_07550,
                    || "pInfo->dst".to_string(),
                    || {
                        let what = if s.stored {
                            serialized_what(&s)
                        } else {
                            format!("VkMicromapEXT {micromap:#x} that {} serialized", s.function)
                        };
                        format!("dst was created with size {dst_size}, smaller than the size {size} of {what} into the bytes at {location} (found by {how})")
                    },
                );
            }
        },
    }
}

/// Records a micromap serialization writing at `dst`.
pub(crate) fn record_micromap_serialization(
    state: &mut State,
    function: &'static str,
    host: bool,
    src: Handle,
    dst: u64,
) {
    let Some(size) = state.micromaps.get(&src).map(|m| m.size) else {
        return;
    };
    let content = Some(state.provenance.content_or_assign(src));
    let serialization = Serialization {
        function,
        what: Serialized::Micromap {
            micromap: src,
            size,
            content,
        },
        stored: false,
    };
    state
        .provenance
        .serialized_at(Space::of(host), dst, serialization);
}

/// A micromap deserialization: `dst` holds what was serialized.
pub(crate) fn record_micromap_deserialization(
    state: &mut State,
    host: bool,
    src: u64,
    dst: Handle,
    contents: bool,
) {
    let content = match source_of(state, host, src, contents) {
        Source::Serialized(s, _) => match s.what {
            Serialized::Micromap { content, .. } => content,
            Serialized::AccelerationStructure { .. } => None,
        },
        _ => None,
    };
    state.provenance.constructed(dst);
    state.provenance.set_content(dst, content);
}

/// A micromap or acceleration-structure copy: `dst` holds what `src` held.
pub(crate) fn record_copy(state: &mut State, src: Handle, dst: Handle) {
    let tracked =
        state.micromaps.contains_key(&src) || state.acceleration_structures.contains_key(&src);
    let content = tracked.then(|| state.provenance.content_or_assign(src));
    let deserialized = state.provenance.deserialized.get(&src).cloned();
    let instances = state.provenance.instances.get(&src).cloned();
    state.provenance.constructed(dst);
    state.provenance.set_content(dst, content);
    if let Some(d) = deserialized {
        state.provenance.deserialized.insert(dst, d);
    }
    match instances {
        Some(referenced) => state.provenance.instances.insert(dst, referenced),
        None => state.provenance.instances.remove(&dst),
    };
}

/// What the micromaps of `structure`'s geometries hold: those a
/// deserialization expects, or those of the original build seen; None when
/// neither is known.
fn expected_micromaps(state: &mut State, structure: Handle) -> Option<Vec<Expected>> {
    if let Some(d) = state.provenance.deserialized.get(&structure) {
        return d.expected.as_ref().map(|list| {
            list.iter()
                .map(|e| match e {
                    Expected::Replaced => Expected::Unknown,
                    other => *other,
                })
                .collect()
        });
    }
    let original = state.original_attachments.get(&structure)?;
    let provenance = &mut state.provenance;
    Some(
        original
            .geometries
            .iter()
            .map(|a| match a {
                KhrOpacityAttachment::Micromap(m) => {
                    Expected::Content(provenance.content_or_assign(*m))
                }
                _ => Expected::None,
            })
            .collect(),
    )
}

/// Records an acceleration-structure serialization writing at `dst`.
pub(crate) fn record_structure_serialization(
    state: &mut State,
    function: &'static str,
    host: bool,
    src: Handle,
    dst: u64,
) {
    let Some(structure) = state.acceleration_structures.get(&src) else {
        return;
    };
    let ty = structure.built.as_ref().map_or(structure.ty, |b| b.ty);
    let micromaps = expected_micromaps(state, src);
    let serialization = Serialization {
        function,
        what: Serialized::AccelerationStructure {
            structure: src,
            ty,
            content: Some(state.provenance.content_or_assign(src)),
            original: state.original_attachments.get(&src).cloned(),
            micromaps,
        },
        stored: false,
    };
    state
        .provenance
        .serialized_at(Space::of(host), dst, serialization);
}

/// The opacity-micromap addresses a serialized bottom-level header holds,
/// in order; None when the bytes are not readable or not block-based.
fn header_addresses(state: &State, host: bool, src: u64) -> Option<Vec<u64>> {
    let bytes = if host {
        state.host_bytes_from(src)
    } else {
        state.device_bytes_from(src)
    }?;
    serialized::micromap_addresses(bytes)
}

/// An acceleration-structure deserialization: `dst` holds what was
/// serialized (a KHR micromap: its contents; another structure: what its
/// micromaps must hold, and its original build's attachments).
pub(crate) fn record_structure_deserialization(
    state: &mut State,
    host: bool,
    src: u64,
    dst: Handle,
    contents: bool,
) {
    let source = source_of(state, host, src, contents);
    let addresses = header_addresses(state, host, src).filter(|_| contents);
    state.provenance.constructed(dst);
    // What a deserialized top-level structure's instances reference is
    // whatever the application rewrote its handles to: not known.
    state.provenance.instances.remove(&dst);
    let from = match source {
        Source::Serialized(s, _) => Some(s),
        _ => None,
    };
    let serialized = from.as_ref().and_then(|s| match &s.what {
        Serialized::AccelerationStructure {
            ty,
            content,
            original,
            micromaps,
            ..
        } => Some((*ty, *content, original.clone(), micromaps.clone())),
        Serialized::Micromap { .. } => None,
    });
    let dst_type = state.acceleration_structures.get(&dst).map(|s| s.ty);
    match serialized {
        Some((ty, content, _, _)) if ty == ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP => {
            state.provenance.set_content(dst, content);
        }
        Some((_, _, original, micromaps)) => {
            if let Some(mut original) = original {
                original.deserialized = true;
                state.original_attachments.insert(dst, original);
            }
            state.provenance.set_content(dst, None);
            state.provenance.deserialized.insert(
                dst,
                Deserialized {
                    from,
                    expected: micromaps,
                    addresses,
                },
            );
        }
        None => {
            state.provenance.set_content(dst, None);
            if dst_type != Some(ACCELERATION_STRUCTURE_TYPE_OPACITY_MICROMAP) {
                state.provenance.deserialized.insert(
                    dst,
                    Deserialized {
                        from: None,
                        expected: None,
                        addresses,
                    },
                );
            }
        }
    }
}

/// A command that uses acceleration structure `structure` (at `location`):
/// if it was constructed through deserialization, each micromap it
/// references that no update replaced must hold what was deserialized from
/// the serialized data of the micromap of its original build (11582, 11587,
/// 11634, 11637).
pub(crate) fn deserialized_micromaps(
    ctx: &mut Ctx<'_>,
    structure: Handle,
    vuid: Vuid,
    location: &str,
) {
    // The header's addresses are read from the content tier up.
    let Some(state) = ctx.contents() else {
        return;
    };
    let Some(d) = state.provenance.deserialized.get(&structure) else {
        return;
    };
    let object = Some(ObjectRef {
        ty: "VkAccelerationStructureKHR",
        handle: structure,
    });
    let rules = [RuleId::from(vuid)];
    let Some(expected) = &d.expected else {
        let why = if d.from.is_some() {
            "the micromaps of the structure that was serialized were not known (its build was not seen)"
        } else {
            "no serialization the checker saw wrote the bytes it was deserialized from (another run or process, or a file)"
        };
        ctx.not_checked(
            Cause::SerializationNotSeen,
            &rules,
            location,
            object,
            format_args!("VkAccelerationStructureKHR {structure:#x} was constructed through deserialization, and {why}, so which micromaps it must reference is unknown"),
        );
        return;
    };
    if expected.contains(&Expected::Unknown) {
        ctx.not_checked(
            Cause::BuildNotSeen,
            &rules,
            location,
            object,
            format_args!("VkAccelerationStructureKHR {structure:#x} was constructed through deserialization, and the builds of the micromaps it was originally built with were not seen"),
        );
        return;
    }
    let needed: Vec<(usize, u64)> = expected
        .iter()
        .enumerate()
        .filter_map(|(g, e)| match e {
            Expected::Content(c) => Some((g, *c)),
            _ => None,
        })
        .collect();
    if needed.is_empty() {
        ctx.checked(&rules);
        return;
    }
    let Some(addresses) = &d.addresses else {
        ctx.not_checked(
            Cause::Contents,
            &rules,
            location,
            object,
            format_args!("the serialized header VkAccelerationStructureKHR {structure:#x} was deserialized from was not readable, so which micromaps it references is unknown"),
        );
        return;
    };
    for (g, content) in needed {
        let address = addresses.get(g).copied().unwrap_or(0);
        let Some(micromap) = serialized::khr_micromap_at(state, address) else {
            // A NULL where the original had a micromap, or an address no
            // micromap has (11585 reports that one).
            ctx.require(
                address != 0,
                vuid,
                || location.to_string(),
                || format!("VkAccelerationStructureKHR {structure:#x} was constructed through deserialization, and its serialized header references no micromap for geometry {g}, where its original build had one"),
            );
            continue;
        };
        match state.provenance.content(micromap) {
            Some(held) if held == content => ctx.checked(&rules),
            Some(held) if state.provenance.seen_constructed(held) => {
                ctx.error(
                    vuid,
                    location,
                    format!("VkAccelerationStructureKHR {structure:#x} was constructed through deserialization; geometry {g} references the KHR micromap VkAccelerationStructureKHR {micromap:#x} (at {address:#x}), which holds what another build or deserialization put there, not data deserialized from the serialization of the micromap its original build used"),
                );
            }
            _ => ctx.not_checked(
                Cause::SerializationNotSeen,
                &rules,
                location,
                object.clone(),
                format_args!("geometry {g} of VkAccelerationStructureKHR {structure:#x} (constructed through deserialization) references the KHR micromap VkAccelerationStructureKHR {micromap:#x}, whose construction the checker did not see, so what it holds is unknown"),
            ),
        }
    }
}

/// `VkCopyAccelerationStructureToMemoryInfoKHR::src` of either serialization
/// command: 11582 where it was constructed through deserialization.
pub(crate) fn serialization_source(ctx: &mut Ctx<'_>, src: Handle) {
    deserialized_micromaps(ctx, src, to_memory_info::src_11582, "pInfo->src");
}

/// An update build whose source was constructed through deserialization and
/// originally built without VK_BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR:
/// each triangles geometry whose original build chained a KHR micromap must
/// chain a micromap deserialized from that micromap's serialized data (11628).
pub(crate) fn update_from_deserialized(
    ctx: &mut Ctx<'_>,
    indirect_build: bool,
    i: usize,
    info: &BuildGeometryInfo,
) {
    let Some(state) = ctx.state else {
        return;
    };
    if info.mode != BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE {
        return;
    }
    let src = info.src_acceleration_structure;
    let Some(d) = state.provenance.deserialized.get(&src) else {
        return;
    };
    let vuid = if indirect_build {
        indirect::micromap_11628
    } else {
        cmd_build::micromap_11628
    };
    let rules = [RuleId::from(vuid)];
    let object = Some(ObjectRef {
        ty: "VkAccelerationStructureKHR",
        handle: src,
    });
    let at = format!("pInfos[{i}].srcAccelerationStructure");
    let (Some(original), Some(expected)) = (state.original_attachments.get(&src), &d.expected)
    else {
        ctx.not_checked(
            Cause::SerializationNotSeen,
            &rules,
            at,
            object,
            format_args!("VkAccelerationStructureKHR {src:#x} was constructed through deserialization from bytes whose original build the checker did not see, so the micromaps it was built with are unknown"),
        );
        return;
    };
    let update_bit =
        khr_values::BUILD_ACCELERATION_STRUCTURE_ALLOW_OPACITY_MICROMAP_UPDATE_BIT_KHR.as_raw();
    if original.flags & update_bit != 0 {
        return;
    }
    let member = info.geometry_member();
    for (g, geometry) in info.geometries_read() {
        if geometry.geometry_type != GEOMETRY_TYPE_TRIANGLES {
            continue;
        }
        let (Some(KhrOpacityAttachment::Micromap(_)), KhrOpacityAttachment::Micromap(new)) = (
            original.geometries.get(g),
            KhrOpacityAttachment::of(geometry),
        ) else {
            continue;
        };
        let location = || {
            format!("pInfos[{i}].{member}[{g}].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapKHR>.micromap")
        };
        match (expected.get(g), state.provenance.content(new)) {
            (Some(Expected::Content(c)), Some(held))
                if held == *c || state.provenance.seen_constructed(held) =>
            {
                ctx.require(
                held == *c,
                vuid,
                location,
                || format!("the KHR micromap VkAccelerationStructureKHR {new:#x} holds what another build or deserialization put there, not data deserialized from the serialization of the micromap geometry {g} of srcAccelerationStructure {src:#x} was originally built with"),
            )
            }
            (Some(Expected::Replaced | Expected::None), _) => {}
            _ => ctx.not_checked(
                Cause::SerializationNotSeen,
                &rules,
                location(),
                object.clone(),
                format_args!("the contents of the KHR micromap VkAccelerationStructureKHR {new:#x}, or of the micromap geometry {g} of VkAccelerationStructureKHR {src:#x} was originally built with, are not known"),
            ),
        }
    }
}

/// The structures the instances of a top-level build reference, as far as
/// the checker read them: by handle (host builds) or by device address.
fn instance_references(state: &State, info: &BuildGeometryInfo) -> BTreeSet<Handle> {
    let mut out = BTreeSet::new();
    for (_, geometry) in info.geometries_read() {
        let GeometryData::Instances(instances) = &geometry.geometry else {
            continue;
        };
        for instance in instances.instances.iter().flatten() {
            let reference = instance.acceleration_structure_reference;
            if reference == 0 {
                continue;
            }
            let handle = if state.acceleration_structures.contains_key(&reference) {
                Some(reference)
            } else {
                state
                    .acceleration_structures
                    .iter()
                    .find(|(_, s)| {
                        memory_range(state, s).is_some_and(|(start, _)| start == reference)
                    })
                    .map(|(h, _)| *h)
            };
            out.extend(handle);
        }
    }
    out
}

/// A draw, dispatch or trace-rays command reaches `structure`: the rule on
/// deserialized structures (11637) for it and for the structures its
/// instances reference, where its build was seen.
pub(crate) fn accessed(ctx: &mut Ctx<'_>, structure: Handle, vuid: Vuid) {
    deserialized_micromaps(ctx, structure, vuid, "");
    let referenced = ctx
        .state
        .and_then(|state| state.provenance.instances.get(&structure));
    for blas in referenced.into_iter().flatten() {
        deserialized_micromaps(ctx, *blas, vuid, "");
    }
}

/// Records what acceleration-structure builds do to provenance: a build
/// gives new contents; an update keeps the source's deserialization, with
/// the micromaps it chains replaced.
pub(crate) fn record_structure_builds(state: &mut State, infos: &[BuildGeometryInfo]) {
    for info in infos {
        let dst = info.dst_acceleration_structure;
        if dst == 0 {
            continue;
        }
        let referenced = instance_references(state, info);
        if referenced.is_empty() {
            state.provenance.instances.remove(&dst);
        } else {
            state.provenance.instances.insert(dst, referenced);
        }
        let carried = (info.mode == BUILD_ACCELERATION_STRUCTURE_MODE_UPDATE)
            .then(|| {
                state
                    .provenance
                    .deserialized
                    .get(&info.src_acceleration_structure)
                    .cloned()
            })
            .flatten();
        state.provenance.constructed(dst);
        let Some(mut d) = carried else {
            continue;
        };
        if let Some(expected) = d.expected.as_mut() {
            for (g, geometry) in info.geometries_read() {
                if let (KhrOpacityAttachment::Micromap(_), Some(e)) =
                    (KhrOpacityAttachment::of(geometry), expected.get_mut(g))
                {
                    *e = Expected::Replaced;
                }
            }
        }
        state.provenance.deserialized.insert(dst, d);
    }
}

impl crate::checks::Validator {
    /// What a deserialization from `src` (`host`: host memory) into `dst`
    /// (a micromap, or with `structure` an acceleration structure) leaves
    /// in `dst`: what was serialized into its source.
    pub(crate) fn record_deserialization(
        &mut self,
        host: bool,
        src: u64,
        dst: Handle,
        structure: bool,
    ) {
        let contents = self.tier >= crate::tier::Tier::Content;
        let state = &mut self.state;
        if structure {
            record_structure_deserialization(state, host, src, dst, contents);
        } else {
            record_micromap_deserialization(state, host, src, dst, contents);
        }
        state.provenance.source_read();
    }

    /// The bytes the next deserialization reads at `address` (host memory
    /// when `host`), as an adaptor read them before the call: bytes the
    /// state does not hold (a host source, or device bytes read back). Their
    /// fingerprint decides what they hold, from this run or the
    /// provenance store. False when they hold no serialized header whose
    /// size they cover.
    pub fn deserialization_source(&mut self, host: bool, address: u64, bytes: &[u8]) -> bool {
        let Some(fingerprint) = serialized::fingerprint(bytes) else {
            self.state.provenance.source_read();
            return false;
        };
        self.state
            .provenance
            .source_fingerprint(Space::of(host), address, fingerprint);
        true
    }

    /// Uses `store` for the fingerprints of serialized bytes from now on:
    /// what this validator links is kept there, and bytes it has not seen
    /// serialized are looked up there. One store may serve several
    /// validators.
    pub fn use_provenance_store(&mut self, store: Arc<Store>) {
        self.state.provenance.fingerprints.use_store(store);
    }

    /// Opens the provenance store in `dir` (bounded to `max_bytes`) and
    /// uses it, as [`Self::use_provenance_store`]; returns the warnings
    /// opening it gave (a store that cannot be used on disk is in memory).
    pub fn open_provenance_store(&mut self, dir: &std::path::Path, max_bytes: u64) -> Vec<String> {
        let store = Arc::new(Store::open(dir, max_bytes));
        let warnings = store.take_warnings();
        self.use_provenance_store(store);
        warnings
    }

    /// The provenance store's warnings not yet handed out (each said once).
    pub fn provenance_store_warnings(&self) -> Vec<String> {
        self.state
            .provenance
            .fingerprints
            .store()
            .map(|s| s.take_warnings())
            .unwrap_or_default()
    }

    /// A serialization of acceleration structure `src` writing at `dst`.
    pub(crate) fn record_structure_serialization(
        &mut self,
        function: &'static str,
        host: bool,
        src: Handle,
        dst: u64,
    ) {
        record_structure_serialization(&mut self.state, function, host, src, dst);
    }

    /// The bytes a serialization the checker saw wrote at `address` (host
    /// memory when `host`), as an adaptor read them once it completed: their
    /// fingerprint is linked to that serialization, so a deserialization of
    /// the same bytes anywhere (copied elsewhere, written back from a file)
    /// is linked to it too. False when no serialization was seen writing at
    /// `address`, or `bytes` hold no serialized header whose size they cover.
    pub fn serialized_bytes(&mut self, host: bool, address: u64, bytes: &[u8]) -> bool {
        let Some(fingerprint) = serialized::fingerprint(bytes) else {
            return false;
        };
        self.state
            .provenance
            .remember_fingerprint(Space::of(host), address, fingerprint)
    }
}
