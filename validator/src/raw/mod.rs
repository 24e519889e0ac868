//! Reading the structures an application hands the driver (ash structs with
//! raw pointers) into the owned model. This is the one module that reads
//! raw pointers; every read is bounded and explained by a SAFETY comment.
//!
//! What it tolerates without crashing or allocating without bound: NULL
//! pointers with non-zero counts (kept as NULL: the checks report them),
//! absurd counts (at most [`MAX_ELEMENTS`] elements are read; a warning says
//! so), and unknown, long or cyclic pNext chains (at most [`MAX_CHAIN`]
//! structures are walked, each address once).

#![allow(unsafe_code)]

pub mod accel;
mod calls;
pub mod commands;
mod generated;
pub mod objects;
pub mod pipeline;

use std::ffi::c_void;
use std::fmt::Display;

use ash::vk;

use crate::build_inputs::DeviceBuild;
use crate::model::array_or_pointers::CountedElements;
use crate::model::micromap::SpareInfos;
use crate::model::{CommandBuffer, MicromapBuildInfo, MicromapUsage, UsageCounts};
use crate::report::location::Locate;
use crate::report::{Finding, Report, Severity};
use crate::rules;
use crate::state::HostRange;
use crate::tier::Tier;
use crate::Validator;
use ommcheck_vuids::vuid;

/// The most elements read from one application array.
///
/// Under cargo-fuzz (which builds with `--cfg fuzzing`) the read bounds are
/// small: the code past a bound is the same, but an input reaching it
/// costs a few kilobytes instead of tens of megabytes, which under
/// AddressSanitizer made each such input take a quarter of a second.
pub const MAX_ELEMENTS: usize = if cfg!(fuzzing) { 1 << 10 } else { 1 << 20 };
/// The most structures walked in one pNext chain.
pub const MAX_CHAIN: usize = 64;
/// The most bytes of host memory read for one array of a host command.
/// Small under cargo-fuzz, as [`MAX_ELEMENTS`] is.
pub const MAX_HOST_BYTES: u64 = if cfg!(fuzzing) { 1 << 16 } else { 1 << 28 };

/// One structure of a pNext chain: its sType and where it is.
pub(crate) struct Link {
    pub s_type: i32,
    pub address: *const c_void,
}

/// Walks a pNext chain, handing `visit` each structure, stopping at NULL,
/// after [`MAX_CHAIN`] structures, or at an address already visited (a
/// cycle), which is reported as [`rules::PNEXT_CHAIN`] at
/// `{location}.pNext`. The addresses visited are kept on the stack: a
/// chain is short, and most calls walk one.
///
/// # Safety
/// Every non-NULL `pNext` in the chain must point to a readable structure
/// that starts with `sType` and `pNext`, as the Vulkan API requires.
unsafe fn walk_chain(
    mut next: *const c_void,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
    mut visit: impl FnMut(Link),
) {
    // Most structures carry no chain: return before clearing the list of
    // visited addresses, which costs more than the rest of the walk.
    if next.is_null() {
        return;
    }
    let mut visited = [std::ptr::null::<c_void>(); MAX_CHAIN];
    let mut walked = 0;
    while !next.is_null() {
        if walked >= MAX_CHAIN || visited[..walked].contains(&next) {
            findings.push(Finding::new(
                &rules::PNEXT_CHAIN,
                Severity::Error,
                function,
                format!("{location}.pNext"),
                format!("the pNext chain loops back or is longer than {MAX_CHAIN} structures; read {walked} of it"),
            ));
            break;
        }
        visited[walked] = next;
        walked += 1;
        // SAFETY: the caller guarantees `next` points to a Vulkan structure,
        // whose first members are sType and pNext (VkBaseInStructure).
        let base = unsafe { &*next.cast::<vk::BaseInStructure<'_>>() };
        visit(Link {
            s_type: base.s_type.as_raw(),
            address: next,
        });
        next = base.p_next.cast();
    }
}

/// The structures of a pNext chain, walked as [`walk_chain`] walks it.
///
/// # Safety
/// As for [`walk_chain`].
pub(crate) unsafe fn chain(
    next: *const c_void,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> Vec<Link> {
    let mut links = Vec::new();
    // SAFETY: forwarded from the caller.
    unsafe { walk_chain(next, function, location, findings, |link| links.push(link)) };
    links
}

/// The sTypes of a pNext chain, walked as [`walk_chain`] walks it.
///
/// # Safety
/// As for [`walk_chain`].
pub(crate) unsafe fn chain_s_types(
    next: *const c_void,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> Vec<i32> {
    let mut s_types = Vec::new();
    // SAFETY: forwarded from the caller.
    unsafe {
        walk_chain(next, function, location, findings, |link| {
            s_types.push(link.s_type)
        })
    };
    s_types
}

/// Copies up to [`MAX_ELEMENTS`] elements of an application array; `None`
/// for a NULL pointer.
///
/// # Safety
/// A non-NULL `pointer` must point to `count` readable, initialised `T`s.
pub(crate) unsafe fn read_array<T: Copy>(
    pointer: *const T,
    count: u32,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> Option<Vec<T>> {
    // SAFETY: forwarded from the caller.
    unsafe { array_slice(pointer, count, function, location, findings) }.map(<[T]>::to_vec)
}

/// Up to [`MAX_ELEMENTS`] elements of an application array in place, for
/// a reader that turns each into the model at once (a copy would be
/// dropped as soon as it is read); `None` for a NULL pointer.
///
/// # Safety
/// A non-NULL `pointer` must point to `count` readable, initialised `T`s
/// that stay so for `'a` (the call being checked).
pub(crate) unsafe fn array_slice<'a, T>(
    pointer: *const T,
    count: u32,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> Option<&'a [T]> {
    if pointer.is_null() {
        return None;
    }
    let len = bounded_len(count, function, location, findings);
    // SAFETY: the caller guarantees `count` elements are readable, and `len`
    // is at most `count`.
    Some(unsafe { std::slice::from_raw_parts(pointer, len) })
}

/// `count` bounded by [`MAX_ELEMENTS`], with a warning when it is cut.
#[inline]
pub(crate) fn bounded_len(
    count: u32,
    function: &'static str,
    location: impl Display,
    findings: &mut Vec<Finding>,
) -> usize {
    let len = usize::try_from(count).unwrap_or(usize::MAX);
    if len > MAX_ELEMENTS {
        count_cut(count, function, &location, findings);
    }
    len.min(MAX_ELEMENTS)
}

/// [`bounded_len`]'s warning, kept out of the line every read takes.
#[cold]
fn count_cut(
    count: u32,
    function: &'static str,
    location: &dyn Display,
    findings: &mut Vec<Finding>,
) {
    findings.push(Finding::new(
        &rules::READ_BOUND,
        Severity::Warning,
        function,
        location.to_string(),
        format!("the count {count} exceeds what ommcheck reads ({MAX_ELEMENTS}); the rest is not checked"),
    ));
}

/// `len` bytes as whole `unit`s (a `u32` word is 4 bytes) bounded by
/// [`MAX_ELEMENTS`], with a warning naming the bytes (`what`, "bytes of
/// code") and the unit (`unit_name`, " words") when they are cut.
pub(crate) fn bounded_units(
    len: usize,
    (unit, unit_name): (usize, &str),
    what: &str,
    function: &'static str,
    location: impl Display,
    findings: &mut Vec<Finding>,
) -> usize {
    let units = len / unit.max(1);
    if units > MAX_ELEMENTS {
        findings.push(Finding::new(
            &rules::READ_BOUND,
            Severity::Warning,
            function,
            location.to_string(),
            format!("{len} {what} exceed what ommcheck reads ({MAX_ELEMENTS}{unit_name}); the rest is not checked"),
        ));
    }
    units.min(MAX_ELEMENTS)
}

/// Up to [`MAX_ELEMENTS`] of the `len` bytes an application hands in
/// (`dataSize` with `pData`), with a warning when they are cut; `None` for
/// a NULL pointer. The bound comes before the allocation.
///
/// # Safety
/// A non-NULL `pointer` must be readable for `len` bytes.
pub(crate) unsafe fn read_bytes(
    pointer: *const u8,
    len: usize,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> Option<Vec<u8>> {
    if pointer.is_null() {
        return None;
    }
    let read = bounded_units(len, (1, ""), "bytes", function, location, findings);
    // SAFETY: the caller guarantees `len` bytes are readable, and `read <= len`.
    Some(unsafe { std::slice::from_raw_parts(pointer, read) }.to_vec())
}

/// `count` bounded by `bound`, with a warning at `location` when it is cut;
/// `names`: the count member and what it counts (`["geometryCount",
/// "geometries"]`).
pub(crate) fn element_bound(
    count: u32,
    bound: u32,
    names: [&str; 2],
    function: &'static str,
    location: impl Display,
    findings: &mut Vec<Finding>,
) -> u32 {
    if count > bound {
        let [member, noun] = names;
        findings.push(Finding::new(
            &rules::READ_BOUND,
            Severity::Warning,
            function,
            location.to_string(),
            format!("{member} {count} exceeds the {noun} ommcheck reads ({bound}); the rest are not checked"),
        ));
    }
    count.min(bound)
}

/// A count member with the array and the array of pointers it counts
/// (`geometryCount`, `pGeometries`, `ppGeometries`), as an application
/// wrote them.
pub(crate) struct ElementArrays<A> {
    pub count: u32,
    pub array: *const A,
    pub pointers: *const *const A,
    /// The most elements read.
    pub bound: u32,
    /// The three members' names.
    pub names: [&'static str; 3],
    /// What the elements are called in a finding.
    pub noun: &'static str,
}

/// Reads the elements of `members` with `read`: the count (as read: cut to
/// the bound where an array was read), the array and the array of pointers
/// (None where NULL; a NULL element of the pointers is None).
///
/// # Safety
/// A non-NULL `array` or `pointers` must be valid for `count` elements, and
/// each element (and each non-NULL pointer's element) valid as `read`
/// requires.
pub(crate) unsafe fn read_elements<A, T>(
    members: ElementArrays<A>,
    function: &'static str,
    at: impl Display + Copy,
    findings: &mut Vec<Finding>,
    mut read: impl FnMut(&A, &dyn Display, &mut Vec<Finding>) -> T,
) -> CountedElements<T> {
    let ElementArrays {
        count,
        array,
        pointers,
        bound,
        names: [count_name, array_name, pointers_name],
        noun,
    } = members;
    let reads = !array.is_null() || !pointers.is_null();
    let bounded = if reads {
        let at = at.member(count_name);
        element_bound(count, bound, [count_name, noun], function, at, findings)
    } else {
        count
    };
    let array_at = at.member(array_name);
    // SAFETY: the caller guarantees `array` is NULL or valid for `count`
    // elements; `bounded` is at most that many.
    let array = unsafe { array_slice(array, bounded, function, array_at, findings) };
    let array = array.map(|list| {
        list.iter()
            .enumerate()
            .map(|(k, element)| read(element, &array_at.index(k), findings))
            .collect::<Vec<_>>()
    });
    let pointers_at = at.member(pointers_name);
    // SAFETY: as for `array`, for pointers.
    let pointers = unsafe { array_slice(pointers, bounded, function, pointers_at, findings) };
    let pointers = pointers.map(|list| {
        list.iter()
            .enumerate()
            .map(|(k, pointer)| {
                // SAFETY: a non-NULL element points to one element the
                // caller guarantees valid; a NULL one is kept as None.
                let element = unsafe { pointer.as_ref() }?;
                Some(read(element, &pointers_at.index(k), findings))
            })
            .collect::<Vec<_>>()
    });
    // A count cut to the bound is reported above; the model holds what was
    // read.
    let read_len = array
        .as_ref()
        .map(Vec::len)
        .or(pointers.as_ref().map(Vec::len));
    let count = read_len.map_or(count, |n| u32::try_from(n).unwrap_or(count));
    (count, array, pointers)
}

// `usage_counts` reads `VkMicromapUsageEXT` arrays as `MicromapUsage`.
const _: () = {
    use std::mem::{align_of, offset_of, size_of};
    assert!(size_of::<vk::MicromapUsageEXT>() == size_of::<MicromapUsage>());
    assert!(align_of::<vk::MicromapUsageEXT>() == align_of::<MicromapUsage>());
    assert!(offset_of!(vk::MicromapUsageEXT, count) == offset_of!(MicromapUsage, count));
    assert!(
        offset_of!(vk::MicromapUsageEXT, subdivision_level)
            == offset_of!(MicromapUsage, subdivision_level)
    );
    assert!(offset_of!(vk::MicromapUsageEXT, format) == offset_of!(MicromapUsage, format));
};

pub(crate) fn usage(u: vk::MicromapUsageEXT) -> MicromapUsage {
    MicromapUsage {
        count: u.count,
        subdivision_level: u.subdivision_level,
        format: u.format,
    }
}

/// Reads a `usageCountsCount` / `pUsageCounts` / `ppUsageCounts` triple,
/// `pUsageCounts` into `spare`'s allocation (a new vector where there is
/// none to reuse).
///
/// # Safety
/// The pointers must be NULL or valid for `count` elements, as the API requires.
pub(crate) unsafe fn usage_counts(
    mut spare: Vec<MicromapUsage>,
    count: u32,
    array: *const vk::MicromapUsageEXT,
    pointers: *const *const vk::MicromapUsageEXT,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> UsageCounts {
    // SAFETY: forwarded from the caller.
    let array = unsafe {
        array_slice(
            array,
            count,
            function,
            location.text(".pUsageCounts"),
            findings,
        )
    };
    // SAFETY: forwarded from the caller.
    let pointers = unsafe {
        array_slice(
            pointers,
            count,
            function,
            location.text(".ppUsageCounts"),
            findings,
        )
    };
    let pointers = pointers.map(|list| {
        list.iter()
            // SAFETY: each non-NULL element points to one VkMicromapUsageEXT.
            .map(|&p| (!p.is_null()).then(|| usage(unsafe { *p })))
            .collect::<Vec<_>>()
    });
    let array = array.map(|list| {
        // SAFETY: `MicromapUsage` is `VkMicromapUsageEXT` laid out alike
        // (repr(C), the same three u32 in the same order; asserted below),
        // so the elements read as they are.
        let list = unsafe {
            std::slice::from_raw_parts(list.as_ptr().cast::<MicromapUsage>(), list.len())
        };
        spare.clear();
        spare.extend_from_slice(list);
        spare
    });
    let read = array
        .as_ref()
        .map(Vec::len)
        .or(pointers.as_ref().map(Vec::len));
    UsageCounts {
        // A count cut to the bound is reported above; the model holds what was read.
        count: read.map_or(count, |n| n as u32),
        array,
        pointers,
    }
}

/// Reads a `VkMicromapBuildInfoEXT`. Addresses become plain numbers: device
/// addresses for device commands, host pointers' values for host commands.
///
/// # Safety
/// `info` must be a structure an application could pass to
/// `vkCmdBuildMicromapsEXT` or `vkBuildMicromapsEXT`: its pointers NULL or
/// valid for the counts beside them, its pNext chain well formed (cycles and
/// length are tolerated).
pub unsafe fn micromap_build_info(
    info: &vk::MicromapBuildInfoEXT<'_>,
    function: &'static str,
    location: impl Display + Copy,
    findings: &mut Vec<Finding>,
) -> MicromapBuildInfo {
    // SAFETY: forwarded from the caller.
    unsafe { generated::micromap_build_info(Vec::new(), info, function, location, findings) }
}

/// Reads `infos` (NULL with a non-zero count reads as empty), into the
/// vectors of `spare`.
///
/// # Safety
/// As [`micromap_build_info`] for each of `count` elements at `infos`.
pub(crate) unsafe fn micromap_build_infos(
    spare: &mut SpareInfos,
    infos: *const vk::MicromapBuildInfoEXT<'_>,
    count: u32,
    function: &'static str,
    findings: &mut Vec<Finding>,
    null_infos: ommcheck_vuids::Vuid,
) -> Vec<MicromapBuildInfo> {
    let mut read = std::mem::take(&mut spare.0);
    if infos.is_null() {
        if count != 0 {
            findings.push(Finding::new(
                null_infos,
                Severity::Error,
                function,
                "pInfos",
                format!("pInfos is NULL with infoCount = {count}"),
            ));
        }
        read.clear();
        return read;
    }
    let len = bounded_len(count, function, "pInfos", findings);
    // SAFETY: the caller guarantees `count` readable elements; `len <= count`.
    let list = unsafe { std::slice::from_raw_parts(infos, len) };
    read.truncate(len);
    read.reserve_exact(len - read.len());
    for (i, info) in list.iter().enumerate() {
        let old = read.get_mut(i);
        let usages = old
            .and_then(|old| old.usage_counts.array.take())
            .unwrap_or_default();
        // SAFETY: forwarded from the caller.
        let info = unsafe {
            generated::micromap_build_info(usages, info, function, "pInfos".index(i), findings)
        };
        match read.get_mut(i) {
            Some(slot) => *slot = info,
            None => read.push(info),
        }
    }
    read
}

impl Validator {
    /// Checks `vkCmdBuildMicromapsEXT` called with the ash structures a
    /// program would hand the driver. Device memory contents are read only
    /// from buffers whose contents the validator was given.
    ///
    /// # Safety
    /// `infos` must be valid as for [`micromap_build_info`].
    pub unsafe fn cmd_build_micromaps_ash(
        &mut self,
        command_buffer: &CommandBuffer,
        infos: &[vk::MicromapBuildInfoEXT<'_>],
    ) -> Report {
        let count = u32::try_from(infos.len()).unwrap_or(u32::MAX);
        // SAFETY: a slice points to `len` valid elements; the rest is the caller's.
        unsafe { self.cmd_build_micromaps_raw(command_buffer, count, infos.as_ptr()) }
    }

    /// Checks `vkCmdBuildMicromapsEXT(commandBuffer, infoCount, pInfos)` as a
    /// layer receives it; a NULL `pInfos` with a count is reported, not read.
    ///
    /// # Safety
    /// A non-NULL `infos` must point to `info_count` structures valid as for
    /// [`micromap_build_info`].
    pub unsafe fn cmd_build_micromaps_raw(
        &mut self,
        command_buffer: &CommandBuffer,
        info_count: u32,
        infos: *const vk::MicromapBuildInfoEXT<'_>,
    ) -> Report {
        // SAFETY: forwarded from the caller.
        unsafe { self.cmd_build_micromaps_raw_kept(command_buffer, info_count, infos) }.0
    }

    /// As [`Self::cmd_build_micromaps_raw`], and returns the build as read,
    /// to check its contents when the command buffer is submitted
    /// ([`Validator::check_device_build_contents`]); None when `pInfos` is
    /// NULL with a count, and below the content tier, where no check reads
    /// contents.
    ///
    /// # Safety
    /// As [`Self::cmd_build_micromaps_raw`].
    pub unsafe fn cmd_build_micromaps_raw_kept(
        &mut self,
        command_buffer: &CommandBuffer,
        info_count: u32,
        infos: *const vk::MicromapBuildInfoEXT<'_>,
    ) -> (Report, Option<DeviceBuild>) {
        let mut findings = Vec::new();
        let function = "vkCmdBuildMicromapsEXT";
        // SAFETY: forwarded from the caller.
        let model = unsafe {
            micromap_build_infos(
                &mut self.spare_micromap_infos,
                infos,
                info_count,
                function,
                &mut findings,
                vuid::vkCmdBuildMicromapsEXT::pInfos_parameter,
            )
        };
        if infos.is_null() && info_count != 0 {
            return (Report::from(findings), None);
        }
        // The caller reads the build's device memory at submission and
        // reports there what it cannot read.
        let later = std::mem::replace(&mut self.device_contents_later, true);
        let mut report = self.cmd_build_micromaps(command_buffer, &model);
        report.prepend(findings);
        self.device_contents_later = later;
        if self.tier < Tier::Content {
            // No check reads the build's contents: its vectors serve the
            // next call.
            self.spare_micromap_infos.keep(model);
            return (report, None);
        }
        (report, Some(DeviceBuild::Micromaps(model)))
    }

    /// Checks `vkBuildMicromapsEXT` called with ash structures whose
    /// addresses are host pointers. The triangle array (whose extent the
    /// usage counts and stride describe) is read so its entries can be
    /// checked; micromap data is read only where the validator was given
    /// host ranges for it, because its extent comes from those entries,
    /// which may be wrong.
    ///
    /// # Safety
    /// `infos` must be valid as for [`micromap_build_info`], and each
    /// triangleArray host address must be readable for
    /// `(Σ usage counts − 1) × triangleArrayStride + 8` bytes, as the API requires.
    pub unsafe fn build_micromaps_ash(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        infos: &[vk::MicromapBuildInfoEXT<'_>],
    ) -> Report {
        let count = u32::try_from(infos.len()).unwrap_or(u32::MAX);
        // SAFETY: a slice points to `len` valid elements; the rest is the caller's.
        unsafe { self.build_micromaps_raw(device, deferred_operation, count, infos.as_ptr()) }
    }

    /// Checks `vkBuildMicromapsEXT(device, deferredOperation, infoCount,
    /// pInfos)` as a layer receives it (see [`Self::build_micromaps_ash`]).
    ///
    /// # Safety
    /// As [`Self::build_micromaps_ash`], for `info_count` structures at a
    /// non-NULL `infos`.
    pub unsafe fn build_micromaps_raw(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        info_count: u32,
        infos: *const vk::MicromapBuildInfoEXT<'_>,
    ) -> Report {
        // SAFETY: forwarded from the caller; no readable ranges are claimed.
        unsafe {
            self.build_micromaps_raw_reading(device, deferred_operation, info_count, infos, &[])
        }
    }

    /// As [`Self::build_micromaps_raw`], and reads each build's micromap
    /// data in full at the call when its host address lies inside one of
    /// `readable` (host memory the caller knows is readable, such as a
    /// mapped range of host-visible memory): the bytes from `data` to the
    /// end of that range, so each triangle's data can be checked to lie
    /// inside it (`OMMCHECK-build-triangle-data-in-range`) and decoded.
    /// A range longer than [`MAX_HOST_BYTES`] from `data` on is reported
    /// and not read. Below [`Tier::Content`] no host memory is read at all
    /// (neither triangle arrays nor data): no check there looks at bytes.
    ///
    /// # Safety
    /// As [`Self::build_micromaps_raw`], and each of `readable` must be
    /// readable host memory for the whole of the call.
    pub unsafe fn build_micromaps_raw_reading(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        info_count: u32,
        infos: *const vk::MicromapBuildInfoEXT<'_>,
        readable: &[ReadableHost],
    ) -> Report {
        // SAFETY: forwarded from the caller.
        let build = unsafe {
            self.read_build_micromaps_raw(device, deferred_operation, info_count, infos, readable)
        };
        let report = self.build_micromaps_read_rules(&build);
        self.record_build_micromaps_read(build);
        report
    }

    /// Reads `vkBuildMicromapsEXT(device, deferredOperation, infoCount,
    /// pInfos)` as [`Self::build_micromaps_raw_reading`] does, for its rules
    /// before the driver runs it ([`Self::build_micromaps_read_rules`]) and
    /// its record after ([`Self::record_build_micromaps_read`]): the host
    /// memory read stays with the call, never in the tracked state.
    ///
    /// # Safety
    /// As [`Self::build_micromaps_raw_reading`].
    pub unsafe fn read_build_micromaps_raw(
        &mut self,
        device: vk::Device,
        deferred_operation: vk::DeferredOperationKHR,
        info_count: u32,
        infos: *const vk::MicromapBuildInfoEXT<'_>,
        readable: &[ReadableHost],
    ) -> HostMicromapBuild {
        let mut findings = Vec::new();
        // SAFETY: forwarded from the caller.
        let model = unsafe {
            micromap_build_infos(
                &mut self.spare_micromap_infos,
                infos,
                info_count,
                "vkBuildMicromapsEXT",
                &mut findings,
                vuid::vkBuildMicromapsEXT::pInfos_parameter,
            )
        };
        let (device, deferred_operation) = (
            vk::Handle::as_raw(device),
            vk::Handle::as_raw(deferred_operation),
        );
        let mut build = HostMicromapBuild {
            device,
            deferred_operation,
            infos: None,
            read_for_call: Vec::new(),
            findings,
        };
        if infos.is_null() && info_count != 0 {
            return build;
        }
        // Host memory read for this call is this call's alone: the
        // application may change or free it once the call returns.
        let (read_for_call, findings) = (&mut build.read_for_call, &mut build.findings);
        // Below the content tier no check reads a byte, so none is copied.
        let read_for = if self.tier >= Tier::Content {
            &model[..]
        } else {
            &[]
        };
        for (i, info) in read_for.iter().enumerate() {
            // SAFETY: forwarded from the caller (`readable` is readable).
            unsafe { self.read_data_in_readable(i, info.data, readable, findings, read_for_call) };
            let triangles = info.usage_counts.total();
            let extent = triangles
                .checked_sub(1)
                .and_then(|n| n.checked_mul(info.triangle_array_stride))
                .and_then(|n| n.checked_add(8));
            let Some(extent) = extent.filter(|_| info.triangle_array != 0) else {
                continue;
            };
            if extent > MAX_HOST_BYTES {
                findings.push(Finding::new(
                    &rules::READ_BOUND,
                    Severity::Warning,
                    "vkBuildMicromapsEXT",
                    format!("pInfos[{i}].triangleArray"),
                    format!("the triangle array spans {extent} bytes, more than ommcheck reads ({MAX_HOST_BYTES}); its entries are not checked"),
                ));
                continue;
            }
            let host = self.state.host_memory(read_for_call);
            if host.read(info.triangle_array, extent).is_none() {
                // SAFETY: the caller guarantees the triangle array is readable
                // for `extent` bytes; `extent` fits in memory (bounded above).
                let bytes = unsafe {
                    std::slice::from_raw_parts(
                        std::ptr::with_exposed_provenance::<u8>(info.triangle_array as usize),
                        extent as usize,
                    )
                };
                read_for_call.push(HostRange {
                    address: info.triangle_array,
                    // A copy: the application may change or free the memory after the call.
                    bytes: crate::Bytes::copy_from_slice(bytes),
                });
            }
        }
        build.infos = Some(model);
        build
    }

    /// The findings of reading `build` and its rules; records nothing.
    pub fn build_micromaps_read_rules(&self, build: &HostMicromapBuild) -> Report {
        let Some(infos) = &build.infos else {
            return Report::from(build.findings.clone());
        };
        let mut report = self.build_micromaps_rules(
            build.device,
            build.deferred_operation,
            infos,
            &build.read_for_call,
        );
        report.prepend(build.findings.clone());
        report
    }

    /// Records what the build `build` describes made, reading the host
    /// memory read for it; then forgets that memory.
    pub fn record_build_micromaps_read(&mut self, build: HostMicromapBuild) {
        let Some(infos) = build.infos else {
            return;
        };
        self.record_micromaps_built(build.deferred_operation, &infos, &build.read_for_call);
        self.spare_micromap_infos.keep(infos);
    }

    /// Copies the host memory from `data` to the end of the readable range
    /// holding it into `read_for_call`, unless it is known already.
    ///
    /// # Safety
    /// Each of `readable` must be readable host memory.
    unsafe fn read_data_in_readable(
        &self,
        info_index: usize,
        data: u64,
        readable: &[ReadableHost],
        findings: &mut Vec<Finding>,
        read_for_call: &mut Vec<HostRange>,
    ) {
        let Some(end) = readable.iter().find_map(|range| {
            let end = range.address.checked_add(range.len)?;
            (range.address <= data && data < end).then_some(end)
        }) else {
            return;
        };
        let extent = end - data;
        if extent > MAX_HOST_BYTES {
            findings.push(Finding::new(
                &rules::READ_BOUND,
                Severity::Warning,
                "vkBuildMicromapsEXT",
                format!("pInfos[{info_index}].data"),
                format!("the mapped memory holding data spans {extent} bytes from it, more than ommcheck reads ({MAX_HOST_BYTES}); the triangles' data is not checked"),
            ));
            return;
        }
        if self
            .state
            .host_memory(read_for_call)
            .read(data, extent)
            .is_some()
        {
            return;
        }
        let (Ok(address), Ok(len)) = (usize::try_from(data), usize::try_from(extent)) else {
            return; // Not a pointer on this target.
        };
        // SAFETY: `[data, end)` lies inside a range the caller guarantees is
        // readable; `len` is at most MAX_HOST_BYTES.
        let bytes = unsafe {
            std::slice::from_raw_parts(std::ptr::with_exposed_provenance::<u8>(address), len)
        };
        read_for_call.push(HostRange {
            address: data,
            // A copy: the application may change or free the memory after the call.
            bytes: crate::Bytes::copy_from_slice(bytes),
        });
    }
}

/// A `vkBuildMicromapsEXT` call as [`Validator::read_build_micromaps_raw`]
/// read it: its infos and the host memory read for it alone, kept between
/// the call's rules and its record.
#[derive(Debug)]
pub struct HostMicromapBuild {
    device: crate::model::Handle,
    deferred_operation: crate::model::Handle,
    /// None where `pInfos` is NULL with a count: then nothing is checked
    /// or recorded but that.
    infos: Option<Vec<MicromapBuildInfo>>,
    read_for_call: Vec<HostRange>,
    /// What reading the call found (a bound reached, a NULL array).
    findings: Vec<Finding>,
}

/// Host memory an adaptor knows the application may read during a call,
/// `[address, address + len)`: a mapped range of host-visible memory (see
/// [`Validator::build_micromaps_raw_reading`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReadableHost {
    /// The host pointer's value (its provenance exposed).
    pub address: u64,
    pub len: u64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Device, Profile};
    use ommcheck_vuids::vuid;

    fn usage_ext(count: u32) -> vk::MicromapUsageEXT {
        vk::MicromapUsageEXT {
            count,
            subdivision_level: 1,
            format: 2,
        }
    }

    #[test]
    fn null_usage_pointer_with_a_count_reads_as_null() {
        let info = vk::MicromapBuildInfoEXT {
            usage_counts_count: 3,
            ..Default::default()
        };
        let mut findings = Vec::new();
        // SAFETY: both usage pointers are NULL.
        let model = unsafe { micromap_build_info(&info, "f", "pInfos[0]", &mut findings) };
        assert_eq!(model.usage_counts.count, 3);
        assert!(model.usage_counts.array.is_none() && model.usage_counts.pointers.is_none());
        assert!(findings.is_empty());
    }

    #[test]
    fn both_usage_pointers_are_reported() {
        let usages = [usage_ext(2)];
        let pointer: *const vk::MicromapUsageEXT = &usages[0];
        let pointers = [pointer];
        let info = vk::MicromapBuildInfoEXT {
            usage_counts_count: 1,
            p_usage_counts: usages.as_ptr(),
            pp_usage_counts: pointers.as_ptr(),
            ..Default::default()
        };
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        // SAFETY: every pointer in `info` points to one live element.
        let report = unsafe { v.cmd_build_micromaps_ash(&CommandBuffer::default(), &[info]) };
        assert!(
            report.contains(vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516),
            "{report}"
        );
    }

    #[test]
    fn cyclic_pnext_chain_is_cut_and_reported() {
        let mut a = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(1),
            ..Default::default()
        };
        let b = vk::BaseInStructure {
            s_type: vk::StructureType::from_raw(2),
            p_next: &a,
            ..Default::default()
        };
        a.p_next = &b;
        let mut findings = Vec::new();
        // SAFETY: `a` and `b` are live structures pointing at each other.
        let s_types = unsafe {
            chain_s_types(
                (&a as *const vk::BaseInStructure<'_>).cast(),
                "f",
                "x",
                &mut findings,
            )
        };
        assert_eq!(s_types, [1, 2]);
        assert_eq!(findings.len(), 1);
        assert_eq!(findings[0].rule.as_str(), rules::PNEXT_CHAIN.id);
    }

    /// `count` build infos, info `i` with `i + 1` usage entries of level
    /// `i` and its own destination, behind `usages`.
    fn infos_with_usages(
        usages: &[[vk::MicromapUsageEXT; 4]; 4],
        count: usize,
    ) -> Vec<vk::MicromapBuildInfoEXT<'_>> {
        (0..count)
            .map(|i| vk::MicromapBuildInfoEXT {
                dst_micromap: vk::Handle::from_raw(0x100 + i as u64),
                usage_counts_count: i as u32 + 1,
                p_usage_counts: usages[i].as_ptr(),
                ..Default::default()
            })
            .collect()
    }

    #[test]
    fn infos_read_into_spare_vectors_equal_a_fresh_read() {
        let usages: [[vk::MicromapUsageEXT; 4]; 4] = std::array::from_fn(|i| {
            std::array::from_fn(|k| vk::MicromapUsageEXT {
                count: k as u32 + 1,
                subdivision_level: i as u32,
                format: 1,
            })
        });
        let mut spare = SpareInfos::default();
        // More infos than the spare holds, then fewer, then more again:
        // every read equals one into fresh vectors.
        for count in [2, 4, 1, 3, 0] {
            let infos = infos_with_usages(&usages, count);
            let mut findings = Vec::new();
            let n = count as u32;
            // SAFETY: each info's usage pointer holds `i + 1` live entries.
            let read = unsafe {
                micromap_build_infos(
                    &mut spare,
                    infos.as_ptr(),
                    n,
                    "f",
                    &mut findings,
                    vuid::vkCmdBuildMicromapsEXT::pInfos_parameter,
                )
            };
            // SAFETY: as above.
            let fresh: Vec<MicromapBuildInfo> = infos
                .iter()
                .enumerate()
                .map(|(i, info)| unsafe {
                    micromap_build_info(info, "f", "pInfos".index(i), &mut findings)
                })
                .collect();
            assert_eq!(read, fresh, "{count} infos");
            assert_eq!(read.len(), count);
            for (i, info) in read.iter().enumerate() {
                let array = info.usage_counts.array.as_deref().unwrap();
                assert_eq!(array.len(), i + 1);
                assert!(array.iter().all(|u| u.subdivision_level == i as u32));
            }
            assert!(findings.is_empty());
            spare.keep(read);
        }
    }

    #[test]
    fn only_small_infos_are_kept_for_reuse() {
        let mut spare = SpareInfos::default();
        let huge = MicromapBuildInfo {
            usage_counts: UsageCounts::array(vec![
                MicromapUsage::default();
                SpareInfos::USAGES + 1
            ]),
            ..Default::default()
        };
        spare.keep(vec![huge]);
        assert!(spare.0.is_empty());
        spare.keep(vec![MicromapBuildInfo::default(); SpareInfos::INFOS + 1]);
        assert!(spare.0.is_empty());
        spare.keep(vec![MicromapBuildInfo::default(); 2]);
        assert_eq!(spare.0.len(), 2);
    }

    #[test]
    fn below_the_content_tier_no_device_build_is_kept() {
        let usages = [usage_ext(2)];
        let info = vk::MicromapBuildInfoEXT {
            usage_counts_count: 1,
            p_usage_counts: usages.as_ptr(),
            ..Default::default()
        };
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        for (tier, kept) in [
            (Tier::Params, false),
            (Tier::State, false),
            (Tier::Content, true),
        ] {
            v.set_tier(tier);
            // SAFETY: the usage pointer holds one live entry.
            let (_, build) =
                unsafe { v.cmd_build_micromaps_raw_kept(&CommandBuffer::default(), 1, &info) };
            assert_eq!(build.is_some(), kept, "{tier}");
        }
    }

    #[test]
    fn absurd_counts_are_bounded() {
        let mut findings = Vec::new();
        assert_eq!(bounded_len(u32::MAX, "f", "x", &mut findings), MAX_ELEMENTS);
        assert_eq!(findings[0].rule.as_str(), rules::READ_BOUND.id);
        assert_eq!(bounded_len(7, "f", "x", &mut findings), 7);
        assert_eq!(findings.len(), 1);
    }

    #[test]
    fn bytes_are_read_up_to_their_bound() {
        let mut findings = Vec::new();
        let bytes = [1u8, 2, 3];
        // SAFETY: `bytes` holds the 3 bytes read; NULL is not read.
        let (read, null) = unsafe {
            (
                read_bytes(bytes.as_ptr(), 3, "f", "x", &mut findings),
                read_bytes(std::ptr::null(), 3, "f", "x", &mut findings),
            )
        };
        assert_eq!((read, null), (Some(vec![1, 2, 3]), None));
        assert!(findings.is_empty());
        let large = vec![7u8; MAX_ELEMENTS];
        // SAFETY: `read_bytes` reads at most MAX_ELEMENTS bytes, which `large` holds.
        let read = unsafe { read_bytes(large.as_ptr(), usize::MAX, "f", "x", &mut findings) };
        assert_eq!(read.map(|r| r.len()), Some(MAX_ELEMENTS));
        assert_eq!(findings[0].rule.as_str(), rules::READ_BOUND.id);
    }

    /// A valid host build: two 2-state level-1 triangles whose data sits in
    /// `data`, away from the triangle array.
    fn host_build_info<'a>(
        triangles: &'a [u8; 16],
        usages: &'a [vk::MicromapUsageEXT; 1],
        data: &'a [u8],
        scratch: &'a mut [u8; 64],
    ) -> vk::MicromapBuildInfoEXT<'a> {
        vk::MicromapBuildInfoEXT {
            usage_counts_count: 1,
            p_usage_counts: usages.as_ptr(),
            triangle_array: vk::DeviceOrHostAddressConstKHR {
                host_address: triangles.as_ptr().cast(),
            },
            data: vk::DeviceOrHostAddressConstKHR {
                host_address: data.as_ptr().cast(),
            },
            scratch_data: vk::DeviceOrHostAddressKHR {
                host_address: scratch.as_mut_ptr().cast(),
            },
            triangle_array_stride: 8,
            ..Default::default()
        }
    }

    /// A validator that knows micromap 9, an opacity micromap of 256
    /// bytes on buffer 5 (host-visible memory), for host builds into it.
    fn with_micromap_9() -> Validator {
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        v.state.buffers.insert(
            5,
            crate::state::Buffer {
                size: 256,
                memory: Some(crate::state::MemoryBinding {
                    host_visible: true,
                    ..Default::default()
                }),
                ..Default::default()
            },
        );
        v.state.micromaps.insert(
            9,
            crate::state::Micromap {
                buffer: 5,
                size: 256,
                ty: vk::MicromapTypeEXT::OPACITY_MICROMAP.as_raw(),
                ..Default::default()
            },
        );
        v
    }

    #[test]
    fn host_data_is_read_in_full_from_a_readable_range() {
        // Entries: dataOffset 0 and 1, level 1, format 1 (2-state, 1 byte each).
        let triangles: [u8; 16] = [0, 0, 0, 0, 1, 0, 1, 0, 1, 0, 0, 0, 1, 0, 1, 0];
        let usages = [vk::MicromapUsageEXT {
            count: 2,
            subdivision_level: 1,
            format: 1,
        }];
        let data = [0x1u8, 0x2];
        let mut scratch = [0u8; 64];
        let info = host_build_info(&triangles, &usages, &data, &mut scratch);
        let device = <vk::Device as vk::Handle>::from_raw(1);
        let mut v = with_micromap_9();
        let info = vk::MicromapBuildInfoEXT {
            dst_micromap: vk::Handle::from_raw(9),
            ..info
        };
        let whole = ReadableHost {
            address: data.as_ptr().expose_provenance() as u64,
            len: 2,
        };
        let build = |v: &mut Validator, readable: &[ReadableHost]| {
            // SAFETY: the triangle array holds the 2 entries the usage counts
            // describe, and `readable` lies inside `data`.
            unsafe {
                v.build_micromaps_raw_reading(
                    device,
                    vk::DeferredOperationKHR::null(),
                    1,
                    &info,
                    readable,
                )
            }
        };
        // Data outside the ranges the call read is not taken to be invalid,
        // and its rules are reported not checked.
        let report = build(&mut v, &[]);
        assert_eq!(
            report.ids(),
            [rules::NOT_CHECKED_HOST_MEMORY.id],
            "{report}"
        );
        assert_eq!(
            report.findings[0].not_checked,
            [
                crate::RuleId::from(&rules::TRIANGLE_DATA_RANGE),
                vuid::vkBuildMicromapsEXT::pInfos_07553.into()
            ]
        );
        assert_eq!(report.findings[0].location, "pInfos[0].data");
        let report = build(&mut v, &[whole]);
        assert!(report.is_empty(), "{report}");
        // With one byte readable, the second triangle's data is past its end.
        let report = build(&mut v, &[ReadableHost { len: 1, ..whole }]);
        assert_eq!(report.ids(), [rules::TRIANGLE_DATA_RANGE.id], "{report}");
        assert!(v.state.host_memory.is_empty());
    }

    /// The bytes a host build's recorded content keeps are the checker's
    /// own: the application may change or free its memory once the call
    /// returns (a view of it would read freed memory; Miri runs this test).
    #[test]
    fn a_host_build_keeps_a_copy_of_what_it_read() {
        let mut triangles: Box<[u8; 16]> =
            Box::new([0, 0, 0, 0, 1, 0, 1, 0, 1, 0, 0, 0, 1, 0, 1, 0]);
        let usages = [vk::MicromapUsageEXT {
            count: 2,
            subdivision_level: 1,
            format: 1,
        }];
        let mut data: Box<[u8]> = Box::new([0x1u8, 0x2]);
        let mut scratch = [0u8; 64];
        let mut v = with_micromap_9();
        let readable = [ReadableHost {
            address: data.as_ptr().expose_provenance() as u64,
            len: 2,
        }];
        let info = vk::MicromapBuildInfoEXT {
            dst_micromap: vk::Handle::from_raw(9),
            ..host_build_info(&triangles, &usages, &data, &mut scratch)
        };
        // SAFETY: the triangle array holds the 2 entries the usage counts
        // describe, and `readable` is `data`.
        unsafe {
            v.build_micromaps_raw_reading(
                <vk::Device as vk::Handle>::from_raw(1),
                vk::DeferredOperationKHR::null(),
                1,
                &info,
                &readable,
            )
        };
        // The application reuses its memory, then frees it.
        triangles.fill(0xAA);
        data.fill(0xBB);
        drop((triangles, data));
        let content = v.state.micromaps[&9]
            .built
            .as_ref()
            .and_then(|b| b.content.clone())
            .expect("the build's content is recorded");
        let offsets: Vec<u32> = content.triangles.iter().map(|t| t.data_offset).collect();
        assert_eq!(offsets, [0, 1]);
        assert_eq!(&content.data[content.data_start..], [0x1, 0x2]);
    }

    #[test]
    fn host_build_reads_host_memory_only_from_the_content_tier_on() {
        let triangles = [0u8; 16];
        let usages = [usage_ext(2)];
        let mut scratch = [0u8; 64];
        let data = [0u8; 8];
        // The stride makes the triangle array longer than ommcheck reads, so
        // reading it is reported (and nothing past the array is touched).
        let info = vk::MicromapBuildInfoEXT {
            triangle_array_stride: MAX_HOST_BYTES,
            ..host_build_info(&triangles, &usages, &data, &mut scratch)
        };
        for tier in Tier::ALL {
            let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
            v.set_tier(tier);
            // SAFETY: the array is never read: its extent is past the bound.
            let report = unsafe {
                v.build_micromaps_ash(
                    <vk::Device as vk::Handle>::from_raw(1),
                    vk::DeferredOperationKHR::null(),
                    &[info],
                )
            };
            assert_eq!(
                report.contains(&rules::READ_BOUND),
                tier >= Tier::Content,
                "{tier}: {report}"
            );
        }
    }

    #[test]
    fn host_build_reads_the_described_triangle_array() {
        let triangles: [u8; 16] = [0, 0, 0, 0, 1, 0, 9, 0, 1, 0, 0, 0, 1, 0, 2, 0];
        let usages = [usage_ext(2)];
        let mut scratch = [0u8; 64];
        let data = [0u8; 8];
        let info = host_build_info(&triangles, &usages, &data, &mut scratch);
        let mut v = Validator::new(Device::with_everything(Profile::SpecMinimum));
        // SAFETY: the triangle array holds the 2 entries the usage counts describe.
        let report = unsafe {
            v.build_micromaps_ash(
                <vk::Device as vk::Handle>::from_raw(1),
                vk::DeferredOperationKHR::null(),
                &[info],
            )
        };
        // Entry 0 has format 9: found by reading the host triangle array.
        assert!(
            report.contains(vuid::VkMicromapBuildInfoEXT::format_11657),
            "{report}"
        );
    }
}
