//! The state census of the opacity micromaps the checker saw built: for
//! each micromap and in total, the micro-triangles in each state by format
//! and level, counted once per micromap triangle (stored) and once per
//! geometry triangle whose opacity index selects it (referenced, as the
//! Opacity Micromap SDK's stats pass weighs them); the triangles whose
//! states are all alike, which a special index could replace; and the
//! references to special indices. `ommcheck stats` prints it.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::checks::Validator;
use crate::inspect::simulate::{micromap_content, trace_attachment};
use crate::model::accel::INDEX_TYPE_NONE;
use crate::model::values::{
    MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV, OPACITY_MICROMAP_FORMAT_2_STATE,
    OPACITY_MICROMAP_FORMAT_4_STATE,
};
use crate::model::Handle;
use crate::sim::census::{word, Shape, StateCounts};
use crate::sim::decode::{MicromapContent, TriangleEntries};
use crate::sim::index::MAX_LEVEL;
use crate::sim::opacity::{OpacityState, Slot};
use crate::sim::trace::fetch_slot;
use crate::state::{BuildRecord, OpacityAttachmentRecord, State};

/// At most this many uniform triangles, and triangles not counted, are
/// listed per micromap (all are counted): a micromap of millions of
/// uniform triangles keeps the report short.
pub const LISTED: usize = 16;

/// The census of one opacity micromap, or the total over all of them.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Census {
    /// Micromap triangles (of the triangle array as far as the checker read it).
    pub triangles: u64,
    /// Those whose states were counted.
    pub counted: u64,
    /// By format and level, in that order; only those that occur.
    pub levels: Vec<LevelStats>,
    /// Over all levels: each counted triangle's micro-triangles once.
    pub stored: StateCounts,
    /// Over all levels: each counted triangle's micro-triangles once per
    /// geometry triangle that references it.
    pub referenced: StateCounts,
    pub uniform: UniformTriangles,
    pub not_counted: NotCounted,
    pub references: References,
}

/// The triangles of one format and subdivision level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct LevelStats {
    /// `2-state` or `4-state`.
    pub format: &'static str,
    pub level: u32,
    /// Counted triangles.
    pub triangles: u64,
    pub stored: StateCounts,
    /// Geometry triangles referencing these triangles.
    pub references: u64,
    pub referenced: StateCounts,
}

/// Triangles whose micro-triangles all hold one state: a special index
/// (-1 to -4) gives the same result without their data.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct UniformTriangles {
    pub triangles: u64,
    /// How many are uniformly transparent, opaque, and so on.
    pub by_state: StateCounts,
    /// The first [`LISTED`] (per micromap; the total lists none).
    pub listed: Vec<UniformTriangle>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct UniformTriangle {
    /// The micromap triangle (its index in the triangle array).
    pub index: u64,
    pub state: OpacityState,
}

/// Triangles whose states were not counted, by reason.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct NotCounted {
    pub triangles: u64,
    /// The format is not 2-state or 4-state.
    pub format: u64,
    /// The level is above 12.
    pub level: u64,
    /// The data lies past the end of the memory the checker has.
    pub data_past_end: u64,
    /// The first [`LISTED`] (per micromap; the total lists none).
    pub listed: Vec<u64>,
}

/// What the opacity indices of the attachments the checker saw select.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct References {
    /// Geometries attached to the micromap.
    pub attachments: u64,
    /// Their triangles (the build ranges' primitive counts).
    pub geometry_triangles: u64,
    /// Geometry triangles that select a counted micromap triangle.
    pub counted: u64,
    /// Geometry triangles whose index is a special index -1 to -4, by the
    /// state it stands for.
    pub special: StateCounts,
    /// Geometry triangles whose index is -5 (cluster geometry only).
    pub cluster_skip: u64,
    /// Geometry triangles that select a micromap triangle past the
    /// micromap's triangles, or whose states were not counted.
    pub not_counted: u64,
    /// Geometry triangles whose index could not be read (past the index
    /// buffer's known contents, or an unknown index type).
    pub unread: u64,
    /// Attachments of builds without a build range (indirect builds):
    /// their triangle count, and so their references, are unknown.
    pub without_range: u64,
}

impl References {
    fn add(&mut self, other: &References) {
        for (sum, n) in [
            (&mut self.attachments, other.attachments),
            (&mut self.geometry_triangles, other.geometry_triangles),
            (&mut self.counted, other.counted),
            (&mut self.cluster_skip, other.cluster_skip),
            (&mut self.not_counted, other.not_counted),
            (&mut self.unread, other.unread),
            (&mut self.without_range, other.without_range),
        ] {
            *sum = sum.saturating_add(n);
        }
        self.special += other.special;
    }
}

/// The census of one micromap the checker saw built.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct MicromapStats {
    pub handle: Handle,
    /// `VkMicromapEXT`, or `VkAccelerationStructureKHR` for a KHR micromap.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// Whether the checker read the build's triangle array and data; when
    /// not, only `references` is known.
    pub content_known: bool,
    #[serde(flatten)]
    pub census: Census,
}

/// [`Validator::micromap_stats`]: each micromap, and the total.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct MicromapStatsReport {
    pub micromaps: Vec<MicromapStats>,
    /// Over all micromaps, with the references of attachments that name
    /// no micromap (VK_NULL_HANDLE, special indices only).
    pub total: Census,
}

/// The triangle array entries of `content`: the one place the census
/// reads them (with a stride of 0, the one entry every triangle reads).
fn entries(content: &MicromapContent) -> &TriangleEntries {
    &content.triangles
}

/// How many micromap triangles `content` has, and how many each entry
/// stands for (1, or all of them with a stride of 0).
fn triangle_count(content: &MicromapContent) -> (u64, u64) {
    match content.repeated {
        Some(count) => (count, count),
        None => (entries(content).len() as u64, 1),
    }
}

/// The entry micromap triangle `m` reads, if `content` has triangle `m`.
fn entry_of(content: &MicromapContent, m: u64) -> Option<usize> {
    let (count, _) = triangle_count(content);
    if m >= count || entries(content).is_empty() {
        return None;
    }
    match content.repeated {
        Some(_) => Some(0),
        None => usize::try_from(m).ok(),
    }
}

/// Adds `n` to a count, saturating: weights multiply counts, and a
/// census must not fail on a scene however large its numbers.
fn bump(sum: &mut u64, n: u64) {
    *sum = sum.saturating_add(n);
}

/// The opacity formats in [`LevelStats::format`] order, with their names.
const FORMATS: [(u32, &str); 2] = [
    (OPACITY_MICROMAP_FORMAT_2_STATE, "2-state"),
    (OPACITY_MICROMAP_FORMAT_4_STATE, "4-state"),
];
const LEVELS: usize = MAX_LEVEL as usize + 1;

/// The census of `content` whose entry `i` is referenced `weights[i]` times
/// (missing weights are 0). Consecutive triangles of one format and level
/// and one weight whose data lies one after the other are counted as one
/// stream of states ([`Shape::run_counts`]), each checked on its own only
/// for being uniform; others by [`Shape::counts`]. A stride-0 build's one
/// entry is counted once and multiplied by the triangles that read it.
pub fn census(content: &MicromapContent, weights: &[u64]) -> Census {
    let mut levels = [[LevelStats::default(); LEVELS]; 2];
    let shapes: [[Option<Shape>; LEVELS]; 2] = std::array::from_fn(|f| {
        std::array::from_fn(|level| Shape::new(FORMATS[f].0, level as u32))
    });
    let mut out = Census::default();
    let (count, per_entry) = triangle_count(content);
    out.triangles = count;
    let data = content.data_bytes();
    let entries = entries(content);
    let mut run: Option<Run> = None;
    let mut next = 0;
    while let Some(entry) = entries.get(next) {
        let i = next;
        next += 1;
        let weight = weights.get(i).copied().unwrap_or(0);
        let offset = usize::try_from(entry.data_offset).ok();
        if let Some(run) = run.take() {
            run.count_into(&mut levels, data, per_entry);
        }
        let (format, level) = (u32::from(entry.format), u32::from(entry.subdivision_level));
        // Entry `i` not counted, for the reason whose count `reason` picks.
        let skip = |out: &mut Census, reason: fn(&mut NotCounted) -> &mut u64| {
            bump(reason(&mut out.not_counted), per_entry);
            out.not_counted.note(i, per_entry);
            bump(&mut out.references.not_counted, weight);
        };
        let Some(f) = FORMATS.iter().position(|(value, _)| *value == format) else {
            skip(&mut out, |n| &mut n.format);
            continue;
        };
        let (Some(at_level), Some(Some(shape))) = (
            levels[f].get_mut(level as usize),
            shapes[f].get(level as usize),
        ) else {
            skip(&mut out, |n| &mut n.level);
            continue;
        };
        let block = offset.and_then(|offset| data.get(offset..));
        if shape.fills_bytes() {
            let (Some(start), Some(block)) = (offset, block.and_then(|b| b.get(..shape.bytes())))
            else {
                skip(&mut out, |n| &mut n.data_past_end);
                continue;
            };
            if let Some(state) = shape.uniform(block) {
                out.uniform.note(i, per_entry, state);
            }
            let mut started = Run {
                format: entry.format,
                level: entry.subdivision_level,
                shape: *shape,
                weight,
                start,
                end: start + block.len(),
                triangles: 1,
            };
            next = started.extend(entries, next, weights, data, |k, state| {
                out.uniform.note(k, per_entry, state)
            });
            run = Some(started);
            continue;
        }
        let Some(counts) = block.and_then(|block| shape.counts(block)) else {
            skip(&mut out, |n| &mut n.data_past_end);
            continue;
        };
        at_level.add(1, per_entry, weight, counts);
        if let Some(state) = counts.uniform() {
            out.uniform.note(i, per_entry, state);
        }
    }
    if let Some(run) = run {
        run.count_into(&mut levels, data, per_entry);
    }
    for (f, by_level) in levels.iter_mut().enumerate() {
        for (level, stats) in (0u32..).zip(by_level.iter_mut()) {
            if stats.triangles == 0 {
                continue;
            }
            stats.format = FORMATS[f].1;
            stats.level = level;
            out.add_level(stats);
        }
    }
    out
}

/// Consecutive triangles of one format and level, referenced alike, whose
/// data lies one after the other (`data[start..end]`): their states are
/// counted as one stream.
struct Run {
    format: u16,
    level: u16,
    shape: Shape,
    weight: u64,
    start: usize,
    end: usize,
    triangles: u64,
}

impl Run {
    /// Takes the entries from `from` on into the run while each is its
    /// next triangle (the same format and level, referenced as often, its
    /// data right after the run's and inside `data`), then checks each
    /// taken only for being uniform (`uniform` hears of those); returns the
    /// first entry not taken. Most of a large micromap's triangles are read
    /// here, so both passes are a few instructions a triangle: eight
    /// entries' bytes and weights compared at once, then sixteen triangles'
    /// first and last words tested at once for a possibly uniform one
    /// ([`Shape::maybe_uniform_groups`]).
    fn extend(
        &mut self,
        entries: &TriangleEntries,
        from: usize,
        weights: &[u64],
        data: &[u8],
        uniform: impl FnMut(usize, OpacityState),
    ) -> usize {
        // Compiled for AVX2 where the CPU has it, both passes compare four
        // 64-bit words at once (baseline x86-64 has no 64-bit compare):
        // a quarter less time a level-3 triangle (2-state, this machine).
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = pulp::x86::V3::try_new() {
            return avx2.vectorize(|| self.extend_portable(entries, from, weights, data, uniform));
        }
        self.extend_portable(entries, from, weights, data, uniform)
    }

    /// [`Self::extend`] for whatever target the crate is built for; inlined
    /// whole into the caller, so that it is compiled with the caller's
    /// target features.
    #[inline(always)]
    fn extend_portable(
        &mut self,
        entries: &TriangleEntries,
        from: usize,
        weights: &[u64],
        data: &[u8],
        mut uniform: impl FnMut(usize, OpacityState),
    ) -> usize {
        let (array, stride, len) = entries.raw();
        let size = self.shape.bytes();
        // Triangles that still fit after the run's end: inside `data`, and
        // starting at an offset a u32 `dataOffset` can state.
        let in_data = data.len().saturating_sub(self.end) / size;
        let offsets = u64::from(u32::MAX)
            .checked_sub(self.end as u64)
            .map_or(0, |left| left / size as u64 + 1);
        let last =
            len.min(from.saturating_add(in_data.min(offsets.try_into().unwrap_or(usize::MAX))));
        // The entry that continues the run, as its little-endian bytes read:
        // data offset, then level and format; offsets below 2^32 here.
        let key = u64::from(self.level) << 32 | u64::from(self.format) << 48;
        let mut offset = self.end as u64;
        let mut k = from;
        // Packed entries, eight at a time: one test of all eight (their
        // bytes and weights against the expected ones, or-ed together)
        // decides them, without a branch per entry.
        if stride == 8 {
            while k + 8 <= last {
                let (Some(eight), Some(weights)) =
                    (array.get(8 * k..8 * k + 64), weights.get(k..k + 8))
                else {
                    break;
                };
                let mut differ = 0u64;
                let mut expected = key | offset;
                for (entry, weight) in eight.chunks_exact(8).zip(weights) {
                    differ |= (word(entry) ^ expected) | (weight ^ self.weight);
                    expected += size as u64;
                }
                if differ != 0 {
                    break;
                }
                offset += 8 * size as u64;
                k += 8;
            }
        }
        // The rest (and all of a strided array) entry by entry.
        while k < last {
            let at = k * stride;
            // Inside the array: `TriangleEntries` holds every entry whole.
            let Some(entry) = array.get(at..at + 8) else {
                break;
            };
            let weight = weights.get(k).copied().unwrap_or(0);
            if word(entry) != key | offset || weight != self.weight {
                break;
            }
            offset += size as u64;
            k += 1;
        }
        let taken = k - from;
        let blocks = data
            .get(self.end..self.end + taken * size)
            .unwrap_or_default();
        self.shape.maybe_uniform_groups(blocks, |j, group| {
            self.note_uniform(group, from + j, &mut uniform)
        });
        self.end += taken * size;
        self.triangles += taken as u64;
        k
    }

    /// Tells `uniform` of the uniform triangles among `blocks`, the data of
    /// the run's triangles `first` on.
    fn note_uniform(
        &self,
        blocks: &[u8],
        first: usize,
        uniform: &mut impl FnMut(usize, OpacityState),
    ) {
        for (j, block) in blocks.chunks_exact(self.shape.bytes()).enumerate() {
            if let Some(state) = self.shape.uniform(block) {
                uniform(first + j, state);
            }
        }
    }

    /// Adds the run's counts to its level's (each entry standing for
    /// `per_entry` triangles).
    fn count_into(self, levels: &mut [[LevelStats; LEVELS]; 2], data: &[u8], per_entry: u64) {
        let f = usize::from(u32::from(self.format) != FORMATS[0].0);
        // Each triangle's block was found inside `data` as the run grew, and
        // its level has a slot (it has a shape).
        let run = data.get(self.start..self.end).unwrap_or_default();
        let counts = self.shape.run_counts(run, self.triangles);
        if let Some(stats) = levels[f].get_mut(usize::from(self.level)) {
            stats.add(self.triangles, per_entry, self.weight, counts);
        }
    }
}

impl LevelStats {
    /// Adds `triangles` counted triangles, each entry standing for
    /// `per_entry` and referenced `weight` times, holding `counts` in all.
    fn add(&mut self, triangles: u64, per_entry: u64, weight: u64, counts: StateCounts) {
        bump(&mut self.triangles, triangles.saturating_mul(per_entry));
        self.stored += counts.times(per_entry);
        if weight != 0 {
            bump(&mut self.references, triangles.saturating_mul(weight));
            self.referenced += counts.times(weight);
        }
    }
}

impl UniformTriangles {
    /// Entry `i`, standing for `per_entry` triangles, is uniformly `state`.
    fn note(&mut self, i: usize, per_entry: u64, state: OpacityState) {
        bump(&mut self.triangles, per_entry);
        bump(self.by_state.get_mut(state), per_entry);
        let first = if per_entry == 1 { i as u64 } else { 0 };
        let room = LISTED.saturating_sub(self.listed.len()) as u64;
        self.listed.extend(
            (first..first + per_entry.min(room)).map(|index| UniformTriangle { index, state }),
        );
    }
}

impl NotCounted {
    /// Entry `i`, standing for `per_entry` triangles, was not counted.
    fn note(&mut self, i: usize, per_entry: u64) {
        bump(&mut self.triangles, per_entry);
        let first = if per_entry == 1 { i as u64 } else { 0 };
        let room = LISTED.saturating_sub(self.listed.len()) as u64;
        self.listed.extend(first..first + per_entry.min(room));
    }
}

impl Census {
    /// Adds one level's counts to the levels and the totals.
    fn add_level(&mut self, stats: &LevelStats) {
        bump(&mut self.counted, stats.triangles);
        self.stored += stats.stored;
        self.referenced += stats.referenced;
        bump(&mut self.references.counted, stats.references);
        match self
            .levels
            .iter_mut()
            .find(|l| (l.format, l.level) == (stats.format, stats.level))
        {
            Some(level) => {
                bump(&mut level.triangles, stats.triangles);
                level.stored += stats.stored;
                bump(&mut level.references, stats.references);
                level.referenced += stats.referenced;
            }
            None => {
                self.levels.push(*stats);
                self.levels.sort_by_key(|l| (l.format, l.level));
            }
        }
    }

    /// Adds `other` (another micromap) to this total; lists stay per micromap.
    fn add(&mut self, other: &Census) {
        bump(&mut self.triangles, other.triangles);
        bump(&mut self.uniform.triangles, other.uniform.triangles);
        self.uniform.by_state += other.uniform.by_state;
        let not_counted = &mut self.not_counted;
        bump(&mut not_counted.triangles, other.not_counted.triangles);
        bump(&mut not_counted.format, other.not_counted.format);
        bump(&mut not_counted.level, other.not_counted.level);
        bump(
            &mut not_counted.data_past_end,
            other.not_counted.data_past_end,
        );
        // `add_level` adds each level's references to `counted`.
        let counted = self.references.counted;
        self.references.add(&other.references);
        self.references.counted = counted;
        for level in &other.levels {
            self.add_level(level);
        }
    }
}

/// The references to one micromap: the weight of each triangle array
/// entry, and the rest.
#[derive(Default)]
struct Referenced {
    weights: Vec<u64>,
    references: References,
}

impl Referenced {
    /// Adds `weight` references to micromap triangle `m` of `content`.
    fn select(&mut self, content: Option<&MicromapContent>, m: u64, weight: u64) {
        match content.and_then(|c| Some((c, entry_of(c, m)?))) {
            Some((content, i)) => {
                if self.weights.is_empty() {
                    self.weights = vec![0; entries(content).len()];
                }
                if let Some(w) = self.weights.get_mut(i) {
                    *w = w.saturating_add(weight);
                }
            }
            None => bump(&mut self.references.not_counted, weight),
        }
    }

    /// Adds the references of geometry triangles `0..count` of an
    /// attachment with index type NONE: triangle `t` selects micromap
    /// triangle `t + baseTriangle`. Only the selected triangles the
    /// content has are visited (the rest are counted at once), so the work
    /// is bounded by the triangle array the checker holds.
    fn select_range(&mut self, content: Option<&MicromapContent>, base: u64, count: u64) {
        let end = base.saturating_add(count);
        let Some(content) = content else {
            bump(&mut self.references.not_counted, count);
            return;
        };
        let (triangles, _) = triangle_count(content);
        let inside = end.min(triangles).saturating_sub(base);
        bump(&mut self.references.not_counted, count - inside);
        match content.repeated {
            Some(_) => self.select(Some(content), base, inside),
            None => (base..base + inside).for_each(|m| self.select(Some(content), m, 1)),
        }
    }
}

/// Where a micromap's census comes from: whether it is a KHR micromap (an
/// acceleration structure), and its handle.
type MicromapKey = (bool, Handle);

impl Validator {
    /// The state census of every opacity micromap whose build the checker
    /// saw, weighted by the attachments of the bottom-level builds it saw
    /// (see [`Census`]).
    pub fn micromap_stats(&self) -> MicromapStatsReport {
        let state = &self.state;
        let mut referenced: BTreeMap<MicromapKey, Referenced> = BTreeMap::new();
        for structure in state.acceleration_structures.values() {
            let Some(built) = &structure.built else {
                continue;
            };
            for geometry in built.geometries.iter().flatten() {
                let Some(opacity) = geometry.opacity else {
                    continue;
                };
                let entry = referenced
                    .entry((opacity.khr, opacity.micromap))
                    .or_default();
                let count = geometry.range.map(|r| u64::from(r.primitive_count));
                attachment_references(state, built.host, &opacity, count, entry);
            }
        }
        let mut report = MicromapStatsReport::default();
        let built = state
            .micromaps
            .iter()
            .filter(|(_, m)| {
                m.built
                    .as_ref()
                    .is_some_and(|b| b.ty != MICROMAP_TYPE_DISPLACEMENT_MICROMAP_NV)
            })
            .map(|(handle, m)| ((false, *handle), m.built.as_ref()));
        let built_khr = state
            .acceleration_structures
            .iter()
            .filter(|(_, s)| s.built.as_ref().is_some_and(|b| b.content.is_some()))
            .map(|(handle, s)| ((true, *handle), s.built.as_ref()));
        for (key, record) in built.chain(built_khr) {
            let refs = referenced.remove(&key).unwrap_or_default();
            let stats = micromap_census(key, record, refs);
            report.total.add(&stats.census);
            report.micromaps.push(stats);
        }
        // Attachments naming no micromap the checker saw built.
        for refs in referenced.values() {
            report.total.references.add(&refs.references);
        }
        report
    }
}

fn micromap_census(
    (khr, handle): MicromapKey,
    record: Option<&BuildRecord>,
    refs: Referenced,
) -> MicromapStats {
    let content = record.and_then(|r| r.content.as_deref());
    let mut census = match content {
        Some(content) => census(content, &refs.weights),
        None => Census {
            triangles: record.map_or(0, |r| r.triangle_count),
            ..Census::default()
        },
    };
    let counted = census.references.counted;
    let not_counted = census.references.not_counted;
    census.references = refs.references;
    bump(&mut census.references.counted, counted);
    bump(&mut census.references.not_counted, not_counted);
    MicromapStats {
        handle,
        kind: if khr {
            "VkAccelerationStructureKHR"
        } else {
            "VkMicromapEXT"
        },
        content_known: content.is_some(),
        census,
    }
}

/// Adds the references of one attachment whose geometry has `count`
/// triangles (None: no build range) to `refs`.
fn attachment_references(
    state: &State,
    host: bool,
    opacity: &OpacityAttachmentRecord,
    count: Option<u64>,
    refs: &mut Referenced,
) {
    bump(&mut refs.references.attachments, 1);
    let Some(count) = count else {
        bump(&mut refs.references.without_range, 1);
        return;
    };
    bump(&mut refs.references.geometry_triangles, count);
    let (content, lossy) = micromap_content(state, opacity);
    if opacity.index_type == INDEX_TYPE_NONE {
        refs.select_range(content, u64::from(opacity.base_triangle), count);
        return;
    }
    let attachment = trace_attachment(state, host, opacity, content, lossy);
    // A stride of 0 gives every triangle the first one's index.
    let (distinct, weight) = if opacity.index_stride == 0 {
        (count.min(1), count)
    } else {
        (count, 1)
    };
    // Each step reads an index inside the known index buffer, and the loop
    // stops at the first that is not: it is bounded by memory the checker holds.
    for t in 0..distinct {
        match fetch_slot(&attachment, t) {
            Ok(Slot::Micromap(m)) => refs.select(content, m, weight),
            Ok(Slot::Special(special)) => match special.state() {
                Some(state) => bump(refs.references.special.get_mut(state), weight),
                None => bump(&mut refs.references.cluster_skip, weight),
            },
            // Past the known index buffer (and so are the later indices),
            // or an index type no attachment may use.
            Err(_) => {
                bump(
                    &mut refs.references.unread,
                    (distinct - t).saturating_mul(weight),
                );
                return;
            }
        }
    }
}
