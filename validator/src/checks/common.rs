//! Checks many commands share: command-buffer state, device addresses,
//! buffer usage, alignment, and a cap on repeated content findings.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Display;

use ommcheck_vuids::Vuid;

use crate::checks::{usage_hints, Ctx};
use crate::model::command::queue;
use crate::model::micromap::UsageCounts;
use crate::model::values::FormatKind;
use crate::model::Handle;
use crate::model::{CommandBuffer, MicromapTriangle};
use crate::report::count as count_of;
use crate::report::not_checked::Cause;
use crate::report::{ObjectRef, RuleId, Severity};
use crate::rules;
use crate::state::{HostMemory, State};

/// The implicit command-buffer VUIDs of one `vkCmd*` command.
pub(crate) struct CommandBufferVuids {
    pub parameter: Vuid,
    pub recording: Vuid,
    pub cmdpool: Vuid,
    /// Present for commands that must be outside a render pass.
    pub renderpass: Option<Vuid>,
    pub videocoding: Option<Vuid>,
    pub suspended: Option<Vuid>,
}

/// Checks the command buffer of a command that needs a compute-capable queue.
pub(crate) fn command_buffer(ctx: &mut Ctx<'_>, cb: &CommandBuffer, vuids: &CommandBufferVuids) {
    let handle = cb.handle;
    ctx.checked(&[vuids.recording.into()]);
    ctx.require(
        handle != 0,
        vuids.parameter,
        || "commandBuffer".into(),
        || "commandBuffer is VK_NULL_HANDLE".into(),
    );
    if !cb.recording {
        ctx.error(
            vuids.recording,
            "commandBuffer",
            "the command buffer is not in the recording state",
        )
        .objects
        .push(crate::report::ObjectRef {
            ty: "VkCommandBuffer",
            handle,
        });
    }
    ctx.require(
        cb.queue_flags & queue::COMPUTE != 0,
        vuids.cmdpool,
        || "commandBuffer".into(),
        || {
            format!(
                "the command pool's queue family supports {:#x}, not VK_QUEUE_COMPUTE_BIT",
                cb.queue_flags
            )
        },
    );
    if let Some(vuid) = vuids.renderpass {
        ctx.require(
            !cb.in_render_pass,
            vuid,
            || "commandBuffer".into(),
            || "called inside a render pass instance".into(),
        );
    }
    if let Some(vuid) = vuids.videocoding {
        ctx.require(
            !cb.in_video_coding,
            vuid,
            || "commandBuffer".into(),
            || "called inside a video coding scope".into(),
        );
    }
    if let Some(vuid) = vuids.suspended {
        ctx.require(
            !cb.suspended,
            vuid,
            || "commandBuffer".into(),
            || "called inside a suspended render pass instance".into(),
        );
    }
}

/// `device` must be the device being checked (0 in `Device::handle` means
/// any non-NULL handle is taken to be it).
pub(crate) fn device_handle(ctx: &mut Ctx<'_>, device: Handle, vuid: Vuid) {
    let known = ctx.device.handle;
    ctx.checked(&[vuid.into()]);
    if device == 0 {
        ctx.error(vuid, "device", "device is VK_NULL_HANDLE");
    } else if known != 0 && device != known {
        ctx.error(
            vuid,
            "device",
            format!("{device:#x} is not the VkDevice {known:#x} being checked"),
        );
    }
}

/// Whether `handle` belongs to another `VkDevice`; reports `vuid` (a
/// `-parent` or `-commonparent` rule) at `location` when it does.
pub(crate) fn other_device(ctx: &mut Ctx<'_>, handle: Handle, vuid: Vuid, location: &str) -> bool {
    let foreign = handle != 0
        && ctx
            .state
            .is_some_and(|state| state.other_device_objects.contains(&handle));
    if foreign {
        ctx.error(
            vuid,
            location,
            format!("{handle:#x} belongs to another VkDevice"),
        );
    }
    foreign
}

/// The VUIDs of a host command's `deferredOperation` parameter.
pub(crate) struct DeferredOperationVuids {
    pub parameter: Vuid,
    pub parent: Vuid,
    /// "Any previous deferred operation ... must be complete", where the command has it.
    pub complete: Option<Vuid>,
}

/// Checks `deferredOperation`: NULL or a deferred operation of this device,
/// not one still running a previous command.
pub(crate) fn deferred_operation(
    ctx: &mut Ctx<'_>,
    handle: Handle,
    vuids: &DeferredOperationVuids,
) {
    if handle == 0 || other_device(ctx, handle, vuids.parent, "deferredOperation") {
        return;
    }
    let Some(state) = ctx.state else {
        return;
    };
    ctx.checked(&[vuids.parameter.into()]);
    if let Some(complete) = vuids.complete {
        ctx.checked(&[complete.into()]);
    }
    if !state.deferred_operations.contains(&handle) {
        ctx.error(
            vuids.parameter,
            "deferredOperation",
            format!("{handle:#x} is not a VkDeferredOperationKHR created on this device"),
        );
    } else if let Some(vuid) = vuids.complete {
        if state.pending_deferred_operations.contains(&handle) {
            ctx.error(vuid, "deferredOperation", format!("{handle:#x} still runs an earlier deferred command (no vkDeferredOperationJoinKHR or vkGetDeferredOperationResultKHR has reported it complete)"));
        }
    }
}

/// A run of triangle-array entries that draw no finding, checked in bulk.
///
/// Once an entry has gone through the per-entry rules without a finding,
/// every entry with the same format and subdivision level whose data
/// offset keeps its data in range would draw none either. So the entries
/// of a tightly packed array (stride 8) are compared [`Self::ENTRIES`] at a
/// time against that entry, branch-free, and counted; a block of entries
/// that differs in anything goes through the rules entry by entry, so every
/// finding, its text and its order are what the per-entry rules give.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct CleanRun {
    pub format: u32,
    pub level: u32,
    /// The entry's upper 32 bits, `subdivisionLevel | format << 16`, in
    /// place: the smallest entry of the run (dataOffset 0).
    format_level: u64,
    /// The largest dataOffset whose data lies in range (at most 2^32 - 1).
    max_offset: u64,
}

impl CleanRun {
    /// Entries compared at once.
    pub const ENTRIES: usize = 32;

    /// The run of `triangle`, which drew no finding. `range` is the size of
    /// its data and the bytes its data must lie within, where the rules
    /// check the range (None: they do not, and any offset is in range).
    pub fn after(triangle: &MicromapTriangle, range: Option<(u64, u64)>) -> Option<Self> {
        let max_offset = match range {
            Some((size, available)) => available.checked_sub(size)?.min(u64::from(u32::MAX)),
            None => u64::from(u32::MAX),
        };
        Some(Self {
            format: u32::from(triangle.format),
            level: u32::from(triangle.subdivision_level),
            format_level: (u64::from(triangle.subdivision_level)
                | u64::from(triangle.format) << 16)
                << 32,
            max_offset,
        })
    }

    /// How many entries of a tightly packed `array`, from entry `first`
    /// on and before entry `end`, lie in consecutive whole blocks of
    /// [`Self::ENTRIES`] that [hold](Self::holds), and whether the scan
    /// stopped at a block that does not (rather than where no whole block
    /// is left). One tight loop over the blocks: most of a valid array is
    /// counted here without going back to the per-entry loop.
    pub fn span(&self, array: &[u8], first: u64, end: u64) -> (u64, bool) {
        let block_bytes = Self::ENTRIES * MicromapTriangle::SIZE as usize;
        let rest = first
            .checked_mul(MicromapTriangle::SIZE)
            .and_then(|start| usize::try_from(start).ok())
            .and_then(|start| array.get(start..));
        let Some(rest) = rest else {
            return (0, false);
        };
        let blocks_before_end = end.saturating_sub(first) / Self::ENTRIES as u64;
        let blocks_before_end = usize::try_from(blocks_before_end).unwrap_or(usize::MAX);
        let mut held = 0u64;
        for block in rest.chunks_exact(block_bytes).take(blocks_before_end) {
            if !self.holds(block) {
                return (held, true);
            }
            held += Self::ENTRIES as u64;
        }
        (held, false)
    }

    /// Counts the entries [`Self::span`] finds into `histogram`; returns
    /// how many, and the entry before which the caller's loop goes one by
    /// one (past the block that left the run; to the end where none did).
    pub fn count(
        &self,
        histogram: &mut TriangleHistogram,
        array: &[u8],
        first: u64,
        end: u64,
    ) -> (u64, u64) {
        let (entries, differs) = self.span(array, first, end);
        histogram.add(self.format, self.level, entries);
        let one_by_one_until = if differs {
            first + entries + Self::ENTRIES as u64
        } else {
            u64::MAX
        };
        (entries, one_by_one_until)
    }

    /// Whether every 8-byte entry of `block` has this run's format and
    /// level and a dataOffset of at most `max_offset`. First a test that
    /// costs one or and one and per entry, which suffices for most blocks:
    /// the upper halves all equal the run's when their union and their
    /// intersection do, and each dataOffset is at most the union of the
    /// dataOffsets (its bits are a subset). Where that test fails, the
    /// exact one decides ([`Self::holds_exactly`]).
    pub fn holds(&self, block: &[u8]) -> bool {
        let (mut union, mut intersection) = (0u64, u64::MAX);
        for entry in block.chunks_exact(8) {
            // Without a panic path in the loop (every chunk has 8 bytes),
            // so that the compiler makes it a vector loop.
            let bits = u64::from_le_bytes(entry.try_into().unwrap_or_default());
            union |= bits;
            intersection &= bits;
        }
        let upper = self.format_level >> 32;
        let quick = union >> 32 == upper
            && intersection >> 32 == upper
            && union & u64::from(u32::MAX) <= self.max_offset;
        quick || self.holds_exactly(block)
    }

    /// [`Self::holds`], deciding each entry: whether the entry, read as a
    /// number, lies in `[format_level, format_level + max_offset]`. Written
    /// without branches so that it compiles to two subtractions and an or
    /// per entry: with `d` the entry less `format_level` (wrapping), `d` is
    /// in range exactly when neither `d` nor `max_offset - d` (which wraps
    /// when `d` is larger, `max_offset` being below 2^32) has bit 63 set.
    /// Out of line, so the quick test's loop stays a tight vector loop
    /// rather than keeping every entry for this one.
    #[cold]
    #[inline(never)]
    fn holds_exactly(&self, block: &[u8]) -> bool {
        let mut differs = 0u64;
        for entry in block.chunks_exact(8) {
            let bits = u64::from_le_bytes(entry.try_into().expect("8 bytes"));
            let d = bits.wrapping_sub(self.format_level);
            differs |= self.max_offset.wrapping_sub(d) | d;
        }
        differs & (1 << 63) == 0
    }
}

/// How many 8-byte entries at `stride` start inside `len` bytes and end
/// inside them too: a bound, from the bytes there are, on what a loop over
/// an untrusted count can read (1 at stride 0).
pub(crate) fn readable_entries(len: u64, stride: u64) -> u64 {
    elements_inside(len, MicromapTriangle::SIZE, stride)
}

/// How many bytes from `address` on lie inside the buffer (or described host
/// memory) holding it, whether or not the checker can read them; known from
/// the state tier up.
/// `host`: the host memory the address points into (None: device memory).
pub(crate) fn bytes_available(
    state: &State,
    host: Option<HostMemory<'_>>,
    address: u64,
) -> Option<u64> {
    if let Some(host) = host {
        return host.bytes_from(address).map(|b| b.len() as u64);
    }
    state
        .buffers_at(address)
        .filter_map(|(_, b)| b.address_range())
        .map(|(_, end)| end - address)
        .max()
}

/// How many elements of `size` bytes at `stride` fit in `len` bytes: the
/// elements an array read at that stride holds (a stride of 0 reads one).
pub(crate) fn elements_inside(len: u64, size: u64, stride: u64) -> u64 {
    match (len.checked_sub(size), stride) {
        (None, _) => 0,
        (Some(_), 0) => 1,
        (Some(last_start), stride) => last_start / stride + 1,
    }
}

/// "the last inside is `<what>` k" or "none lies inside", for a message
/// about an array that runs past the end of its memory.
pub(crate) fn last_inside(what: &str, inside: u64) -> String {
    match inside {
        0 => format!("no {what} lies inside"),
        n => format!("the last inside is {what} {}", n - 1),
    }
}

/// Reports `rules` not checked because the memory `location` names, at
/// `address`, could not be read: host memory nobody described, an address
/// no known buffer holds, or a buffer whose contents were not given (or
/// that is not bound). Nothing is reported where an address rule already
/// reports the address (NULL, or outside every buffer or described host
/// range), nor for device memory an adaptor reads later
/// ([`Ctx::device_contents_later`]).
pub(crate) fn unreadable(
    ctx: &mut Ctx<'_>,
    host: bool,
    address: u64,
    rules: &[RuleId],
    location: impl Display,
) {
    let (Some(state), Some(host_memory)) = (ctx.state, ctx.host()) else {
        return;
    };
    if address == 0 {
        return;
    }
    if host {
        if host_memory.describes_all() && host_memory.bytes_from(address).is_none() {
            return;
        }
        ctx.not_checked(
            Cause::HostMemory,
            rules,
            location.to_string(),
            None,
            // No address in the text: host pointers differ from run to run,
            // and the same call must give the same report.
            format_args!("the host memory {location} points to was not described to the checker, so its extent is unknown"),
        );
        return;
    }
    if ctx.device_contents_later {
        return;
    }
    match state.buffers_at(address).next() {
        None if state.knows_addresses() => {}
        None => ctx.not_checked(
            Cause::UnknownAddress,
            rules,
            location.to_string(),
            None,
            format_args!(
                "no buffer whose device address the checker knows holds {location} ({address:#x})"
            ),
        ),
        Some((handle, buffer)) => {
            let object = Some(ObjectRef {
                ty: "VkBuffer",
                handle,
            });
            let why = if buffer.memory.is_none() {
                "is not bound to memory, so it has no contents to read"
            } else if buffer.contents.is_none() {
                "has no contents the checker was given"
            } else {
                "has contents that end before it"
            };
            ctx.not_checked(
                Cause::Contents,
                rules,
                location.to_string(),
                object,
                format_args!("VkBuffer {handle:#x}, which holds {location} ({address:#x}), {why}"),
            );
        }
    }
}

/// A device address must be a valid `VkDeviceAddress`: non-zero, and inside
/// a buffer when the checker knows buffer addresses.
pub(crate) fn valid_device_address(
    ctx: &mut Ctx<'_>,
    address: u64,
    vuid: Vuid,
    location: impl Display,
) {
    // Decided where the address is 0 or buffer addresses are known.
    if address == 0 || ctx.state.is_some_and(|state| state.knows_addresses()) {
        ctx.checked(&[vuid.into()]);
    }
    if address == 0 {
        ctx.error(vuid, location.to_string(), "the address is 0");
    } else if ctx
        .state
        .is_some_and(|state| state.knows_addresses() && state.buffers_at(address).next().is_none())
    {
        ctx.error(
            vuid,
            location.to_string(),
            format!("{address:#x} is inside no buffer's device-address range"),
        );
    }
}

/// The buffer(s) a device address was queried from must have `usage`.
/// Unknown addresses are left to the address checks.
pub(crate) fn device_address_usage(
    ctx: &mut Ctx<'_>,
    address: u64,
    usage: u64,
    usage_name: &str,
    vuid: Vuid,
    location: impl Display,
) {
    let Some(state) = ctx.state else {
        return;
    };
    // Walked, not collected: a valid call should not allocate.
    let mut buffers = state.buffers_at(address);
    let Some((handle, first)) = buffers.next() else {
        return;
    };
    ctx.checked(&[vuid.into()]);
    if first.usage & usage == 0 && !buffers.any(|(_, b)| b.usage & usage != 0) {
        ctx.error(vuid, location.to_string(), format!("{address:#x} lies in VkBuffer {handle:#x}, which was not created with {usage_name}"))
            .objects
            .push(crate::report::ObjectRef { ty: "VkBuffer", handle });
    }
}

/// `value` must be a multiple of `alignment` (a power of two or any non-zero).
pub(crate) fn aligned(
    ctx: &mut Ctx<'_>,
    value: u64,
    alignment: u64,
    vuid: Vuid,
    location: impl Display,
) {
    ctx.checked(&[vuid.into()]);
    if alignment != 0 && !value.is_multiple_of(alignment) {
        ctx.error(
            vuid,
            location.to_string(),
            format!("{value:#x} is not a multiple of {alignment}"),
        );
    }
}

/// Caps how often one rule is reported for the elements of one array, so a
/// million bad triangles give a few findings and a total, not a million.
pub(crate) struct Tally {
    counts: BTreeMap<&'static str, (RuleId, u64, String, Severity)>,
    /// Failures of every rule so far, shown or not.
    failures: u64,
}

impl Tally {
    /// Findings reported in full per rule before the rest are only counted.
    pub const SHOWN: u64 = 8;

    pub fn new() -> Self {
        Self {
            counts: BTreeMap::new(),
            failures: 0,
        }
    }

    /// Failures of every rule so far, shown or only counted.
    pub fn failures(&self) -> u64 {
        self.failures
    }

    /// Reports the first [`Self::SHOWN`] failures of `rule` in full, as errors.
    pub fn error(
        &mut self,
        ctx: &mut Ctx<'_>,
        rule: impl Into<RuleId>,
        location: impl Display,
        message: impl FnOnce() -> String,
        array: &str,
    ) {
        self.report(ctx, rule, Severity::Error, location, message, array);
    }

    /// Reports the first [`Self::SHOWN`] findings of `rule` in full; the
    /// location is written out only for those (past them a failure costs a
    /// count, not a string).
    pub fn report(
        &mut self,
        ctx: &mut Ctx<'_>,
        rule: impl Into<RuleId>,
        severity: Severity,
        location: impl Display,
        message: impl FnOnce() -> String,
        array: &str,
    ) {
        let rule = rule.into();
        let entry =
            self.counts
                .entry(rule.as_str())
                .or_insert((rule, 0, array.to_string(), severity));
        entry.1 += 1;
        self.failures += 1;
        if entry.1 <= Self::SHOWN {
            ctx.report(rule, severity, location.to_string(), message());
        }
    }

    /// Adds one finding per rule that failed more often than it was shown.
    pub fn finish(self, ctx: &mut Ctx<'_>) {
        for (_, (rule, count, array, severity)) in self.counts {
            if count > Self::SHOWN {
                let message = format!(
                    "{} more elements of {array} fail this rule ({count} in all)",
                    count - Self::SHOWN
                );
                ctx.report(rule, severity, array, message);
            }
        }
    }
}

/// The usage counts summed per (format, subdivision level); duplicate keys
/// add up (the specification allows them) and zero counts are left out.
pub(crate) fn declared_counts(counts: &UsageCounts) -> BTreeMap<(u32, u32), u64> {
    let mut declared: BTreeMap<(u32, u32), u64> = BTreeMap::new();
    for (_, usage) in counts.usages_read() {
        let sum = declared
            .entry((usage.format, usage.subdivision_level))
            .or_default();
        *sum = sum.saturating_add(u64::from(usage.count));
    }
    declared.retain(|_, count| *count != 0);
    declared
}

/// The usage counts against the triangle array's entries, per (format,
/// subdivision level): one finding for each key whose counts differ,
/// naming the format, the level and both counts.
pub(crate) fn usage_counts_match_triangles(
    ctx: &mut Ctx<'_>,
    location: &str,
    counts: &UsageCounts,
    found: &BTreeMap<(u32, u32), u64>,
    names: FormatKind,
) {
    let declared = declared_counts(counts);
    let keys: BTreeSet<(u32, u32)> = declared.keys().chain(found.keys()).copied().collect();
    let mismatch = |(format, level): (u32, u32)| {
        let said = declared.get(&(format, level)).copied().unwrap_or(0);
        let has = found.get(&(format, level)).copied().unwrap_or(0);
        (said != has).then(|| {
            format!(
                "{}: the usage counts say {said}, the triangle array holds {has}",
                names.key(format, level)
            )
        })
    };
    // A count under the wrong key: one finding, with a hint.
    // No hint where a triangle entry's format or level broke a rule of its
    // own (a format the build's flags forbid): there the triangle is what
    // is wrong.
    let entries = location
        .rsplit_once('.')
        .map(|(at, _)| format!("{at}.triangleArray["));
    let entry_failed = entries.is_some_and(|entries| {
        ctx.report.findings.iter().any(|f| {
            f.severity == Severity::Error
                && f.location.starts_with(&entries)
                && (f.location.ends_with(".format") || f.location.ends_with(".subdivisionLevel"))
        })
    });
    let limits = &ctx.device.limits;
    let misplaced = if entry_failed {
        Vec::new()
    } else {
        usage_hints::misplaced(&declared, found, |k| {
            usage_hints::valid_key(k, names, limits)
        })
    };
    for key in keys {
        if misplaced.iter().any(|m| m.meant == key) {
            continue; // Folded into the finding of the key it was written under.
        }
        let Some(message) = mismatch(key) else {
            continue;
        };
        let finding = ctx.error(&rules::HISTOGRAM_MISMATCH, location.to_owned(), message);
        if let Some(m) = misplaced.iter().find(|m| m.wrong == key) {
            finding.fold(1, format!("and {}", mismatch(m.meant).unwrap_or_default()));
            finding.hint = Some(usage_hints::hint(m, names));
        }
    }
}

/// The usage counts in words, at most four keys, for a message about
/// entries the triangle array lacks: "4 (`<key>`: 3, `<key>`: 1)".
pub(crate) fn counts_in_words(counts: &UsageCounts, names: FormatKind) -> String {
    const SHOWN: usize = 4;
    let declared = declared_counts(counts);
    let total: u64 = declared.values().fold(0, |sum, c| sum.saturating_add(*c));
    let mut parts: Vec<String> = declared
        .iter()
        .take(SHOWN)
        .map(|(&(format, level), count)| format!("{}: {count}", names.key(format, level)))
        .collect();
    if declared.len() > SHOWN {
        parts.push(format!("{} more keys", declared.len() - SHOWN));
    }
    format!("{total} ({})", parts.join(", "))
}

/// The message for triangle-array entry `m` lying past the end of the
/// `len` bytes the array's memory holds from its start.
pub(crate) fn entry_past_end(
    m: u64,
    stride: u64,
    len: u64,
    counts: &UsageCounts,
    names: FormatKind,
) -> String {
    let inside = readable_entries(len, stride);
    format!(
        "the {len} bytes from triangleArray hold {} at stride {stride}, but the usage counts say {}: entry {m} lies past the end ({})",
        count_of(inside, "entry", "entries"),
        counts_in_words(counts, names),
        last_inside("entry", inside)
    )
}

/// Every entry of a micromap build's triangle array (the usage counts'
/// sum of them at `stride`, one for a stride of 0) lies inside the memory
/// `address` points into: decided from the state tier up, where the
/// buffer's (or described host memory's) size is known, under
/// `OMMCHECK-build-triangle-array-in-range` (KHR's device command states it
/// as 11554).
pub(crate) fn triangle_array_holds_every_entry(
    ctx: &mut Ctx<'_>,
    location: impl Display,
    (address, host): (u64, bool),
    stride: u64,
    counts: &UsageCounts,
    names: FormatKind,
) {
    let (Some(state), Some(host_memory)) = (ctx.state, ctx.host()) else {
        return;
    };
    let total = counts.total();
    if total == 0 {
        return;
    }
    // An address inside no buffer is the address rules' finding.
    let Some(available) = bytes_available(state, host.then_some(host_memory), address) else {
        return;
    };
    let inside = readable_entries(available, stride);
    let needed = if stride == 0 { 1 } else { total };
    if inside < needed {
        ctx.error(
            &rules::TRIANGLE_ARRAY_RANGE,
            location.to_string(),
            entry_past_end(inside, stride, available, counts, names),
        );
    }
}

/// Triangles counted per (format, subdivision level), to hold against the
/// usage counts. Every valid (format, level) of the opacity and
/// displacement formats has a slot of a flat array, so counting a triangle
/// is an index and an add; only entries with other values (all invalid, and
/// reported as such) go to a map.
pub(crate) struct TriangleHistogram {
    flat: [u64; Self::FORMATS * Self::LEVELS],
    other: BTreeMap<(u32, u32), u64>,
}

impl TriangleHistogram {
    /// Formats 0 to 3 (the opacity formats are 1 and 2, the displacement
    /// formats 1 to 3) and levels 0 to 15 (the limits stop at 12) are flat.
    const FORMATS: usize = 4;
    const LEVELS: usize = 16;

    pub fn new() -> Self {
        Self {
            flat: [0; Self::FORMATS * Self::LEVELS],
            other: BTreeMap::new(),
        }
    }

    /// Counts `weight` more triangles of `format` at `level` (saturating:
    /// a stride of 0 counts one entry for every triangle at once).
    #[inline]
    pub fn add(&mut self, format: u32, level: u32, weight: u64) {
        let (f, l) = (format as usize, level as usize);
        let count = if f < Self::FORMATS && l < Self::LEVELS {
            &mut self.flat[f * Self::LEVELS + l]
        } else {
            self.other.entry((format, level)).or_default()
        };
        *count = count.saturating_add(weight);
    }

    /// The (format, level) pairs counted at least once, with their counts.
    pub fn into_map(self) -> BTreeMap<(u32, u32), u64> {
        let mut map = self.other;
        for (slot, &count) in self.flat.iter().enumerate() {
            if count != 0 {
                let key = ((slot / Self::LEVELS) as u32, (slot % Self::LEVELS) as u32);
                map.insert(key, count);
            }
        }
        map
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_counts_flat_and_other_pairs_alike() {
        let mut histogram = TriangleHistogram::new();
        let pairs = [
            (1, 0),
            (2, 12),
            (3, 15),
            (0, 0),
            (4, 0),
            (1, 16),
            (65535, 65535),
        ];
        for (i, (format, level)) in pairs.into_iter().enumerate() {
            histogram.add(format, level, i as u64 + 1);
            histogram.add(format, level, 10);
        }
        let expected: BTreeMap<(u32, u32), u64> = pairs
            .into_iter()
            .enumerate()
            .map(|(i, pair)| (pair, i as u64 + 11))
            .collect();
        assert_eq!(histogram.into_map(), expected);
        assert!(TriangleHistogram::new().into_map().is_empty());
    }

    use crate::checks::usage_keys::usage_counts;

    #[test]
    fn formats_are_named_by_their_enum() {
        assert_eq!(
            FormatKind::OpacityExt.key(2, 3),
            "VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 3"
        );
        assert_eq!(
            FormatKind::OpacityKhr.name(1),
            "VK_OPACITY_MICROMAP_FORMAT_2_STATE_KHR"
        );
        assert_eq!(
            FormatKind::DisplacementNv.name(3),
            "VK_DISPLACEMENT_MICROMAP_FORMAT_1024_TRIANGLES_128_BYTES_NV"
        );
        assert_eq!(FormatKind::OpacityExt.name(3), "format 3");
    }

    #[test]
    fn counts_in_words_sum_duplicate_keys_and_stop_at_four() {
        let counts = usage_counts(&[(3, 3, 2), (2, 3, 2), (0, 1, 1), (1, 1, 1)]);
        assert_eq!(
            counts_in_words(&counts, FormatKind::OpacityExt),
            "6 (VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT level 1: 1, VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 3: 5)"
        );
        let many: Vec<_> = (0..6).map(|level| (1, level, 2)).collect();
        let words = counts_in_words(&usage_counts(&many), FormatKind::OpacityKhr);
        assert!(words.starts_with("6 ("), "{words}");
        assert!(words.ends_with(", 2 more keys)"), "{words}");
    }

    #[test]
    fn an_entry_past_the_end_names_the_last_inside() {
        let counts = usage_counts(&[(5, 3, 2)]);
        let message = entry_past_end(4, 8, 36, &counts, FormatKind::OpacityExt);
        assert_eq!(
            message,
            "the 36 bytes from triangleArray hold 4 entries at stride 8, but the usage counts say 5 (VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT level 3: 5): entry 4 lies past the end (the last inside is entry 3)"
        );
        let none = entry_past_end(0, 8, 4, &counts, FormatKind::OpacityExt);
        assert!(none.ends_with("(no entry lies inside)"), "{none}");
    }

    #[test]
    fn readable_entries_counts_whole_entries() {
        assert_eq!(readable_entries(0, 8), 0);
        assert_eq!(readable_entries(7, 8), 0);
        assert_eq!(readable_entries(8, 8), 1);
        assert_eq!(readable_entries(15, 8), 1);
        assert_eq!(readable_entries(16, 8), 2);
        assert_eq!(readable_entries(24, 12), 2);
        assert_eq!(readable_entries(100, 0), 1);
        assert_eq!(readable_entries(10, 1), 3);
        assert_eq!(readable_entries(u64::MAX, 1), u64::MAX - 7);
    }

    fn entry(data_offset: u32, subdivision_level: u16, format: u16) -> MicromapTriangle {
        MicromapTriangle {
            data_offset,
            subdivision_level,
            format,
        }
    }

    #[test]
    fn a_clean_run_holds_for_same_format_and_level_with_data_in_range() {
        // Level-2 4-state blocks of 4 bytes in 100 bytes: offsets 0 to 96.
        let run = CleanRun::after(&entry(0, 2, 2), Some((4, 100))).expect("in range");
        let block = |f: &dyn Fn(u32) -> MicromapTriangle| -> Vec<u8> {
            (0..CleanRun::ENTRIES as u32)
                .flat_map(|i| f(i).to_bytes())
                .collect()
        };
        assert!(run.holds(&block(&|i| entry(i * 3, 2, 2))));
        assert!(run.holds(&block(&|_| entry(96, 2, 2))));
        assert!(!run.holds(&block(&|i| entry(if i == 31 { 97 } else { 0 }, 2, 2))));
        assert!(!run.holds(&block(&|i| entry(u32::MAX * (i == 5) as u32, 2, 2))));
        assert!(!run.holds(&block(&|i| entry(0, 2 + (i == 7) as u16, 2))));
        assert!(!run.holds(&block(&|i| entry(0, 2, 2 - (i == 0) as u16))));
        // Upper halves far above or below the run's, whatever the offset.
        assert!(!run.holds(&block(&|i| entry(0, 2, 2 | (0x8000 * (i == 3) as u16)))));
        assert!(!run.holds(&block(&|i| entry(
            u32::MAX * (i == 9) as u32,
            2 - (i == 9) as u16,
            2
        ))));
        assert!(!run.holds(&block(&|i| entry(0, 0xFFFF * (i == 30) as u16, 0xFFFF))));
        // Offsets whose union passes the range (64 | 37 = 101) but each
        // inside it: the exact test decides.
        let tight = CleanRun::after(&entry(0, 2, 2), Some((4, 104))).expect("in range");
        assert!(tight.holds(&block(&|i| entry(if i % 2 == 0 { 64 } else { 37 }, 2, 2))));
        assert!(!tight.holds(&block(&|i| entry(if i == 4 { 101 } else { 37 }, 2, 2))));
        // Data shorter than a block: no entry is in range.
        assert_eq!(CleanRun::after(&entry(0, 2, 2), Some((4, 3))), None);
        // No range to check: every offset is in range.
        let unchecked = CleanRun::after(&entry(0, 2, 2), None).expect("a run");
        assert!(unchecked.holds(&block(&|_| entry(u32::MAX, 2, 2))));
    }

    #[test]
    fn a_span_counts_whole_blocks_that_hold_before_the_end_and_inside_the_array() {
        let run = CleanRun::after(&entry(0, 2, 2), Some((4, 100))).expect("in range");
        let clean: Vec<u8> = (0..100).flat_map(|_| entry(0, 2, 2).to_bytes()).collect();
        assert_eq!(run.span(&clean, 0, 100), (96, false));
        assert_eq!(run.span(&clean, 8, 100), (64, false));
        assert_eq!(run.span(&clean, 8, 72), (64, false));
        assert_eq!(run.span(&clean, 9, 40), (0, false));
        assert_eq!(run.span(&clean, 0, 31), (0, false));
        assert_eq!(
            run.span(&clean, 0, u64::MAX),
            (96, false),
            "to the array's end"
        );
        assert_eq!(run.span(&clean, u64::MAX, u64::MAX), (0, false));
        assert_eq!(run.span(&clean, u64::MAX / 8, u64::MAX), (0, false));
        // Entry 40 leaves the run: the second block does not hold.
        let mut dirty = clean.clone();
        dirty[40 * 8..41 * 8].copy_from_slice(&entry(0, 3, 2).to_bytes());
        assert_eq!(run.span(&dirty, 0, 100), (32, true));
        assert_eq!(run.span(&dirty, 41, 100), (32, false));
        // Counted into the histogram; one by one past the block that left.
        let mut histogram = TriangleHistogram::new();
        assert_eq!(run.count(&mut histogram, &dirty, 0, 100), (32, 64));
        assert_eq!(run.count(&mut histogram, &clean, 0, 100), (96, u64::MAX));
        assert_eq!(
            histogram.into_map().into_iter().collect::<Vec<_>>(),
            [((2, 2), 128)]
        );
    }
}
