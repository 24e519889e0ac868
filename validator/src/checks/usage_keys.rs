//! Usage-count entries (`VkMicromapUsageEXT` and the KHR structure that
//! shares its layout) against the (format, subdivision level) keys a rule
//! allows: one pass over a call's entries decides whether the per-entry
//! rules, with their locations and messages, need to run on every entry or
//! on one entry of each format, and sums the counts on the way.

use crate::device::Limits;
use crate::model::micromap::{MicromapUsage, UsageCounts, UsagesRead};
use crate::model::values::{
    DISPLACEMENT_MICROMAP_FORMATS_NV, OPACITY_MICROMAP_FORMAT_2_STATE,
    OPACITY_MICROMAP_FORMAT_4_STATE,
};

/// The level limits of `VkMicromapUsageEXT` entries: 2-state, 4-state and
/// displacement, as [`UsageKeys::ext`] and the per-entry rules take them.
pub(crate) fn ext_usage_maxima(limits: &Limits) -> (u32, u32, u32) {
    (
        limits.max_opacity2_state_subdivision_level,
        limits.max_opacity4_state_subdivision_level,
        limits.max_displacement_micromap_subdivision_level,
    )
}

/// The (format, subdivision level) keys a usage-count rule allows, as a
/// table of the level bound per format, so that a call's usage entries are
/// checked in one pass of a lookup and a compare each, with nothing
/// formatted, hashed or allocated: a usage entry per (format, level) in use is what real builds
/// give, and the per-entry rules (with their locations and messages) run
/// only where an entry is outside the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct UsageKeys {
    /// Per format 0 to 3, one more than the highest level allowed (0: the
    /// format is not allowed); the last slot stands for every format from
    /// 4 on, which are rejected everywhere. As u64 so that a limit of
    /// `u32::MAX` allows every level.
    level_bound: [u64; Self::FORMATS + 1],
}

impl UsageKeys {
    const FORMATS: usize = 4;

    /// No key allowed; add formats with [`Self::allow`].
    pub fn none() -> Self {
        Self {
            level_bound: [0; Self::FORMATS + 1],
        }
    }

    /// The keys of `VkMicromapUsageEXT` in an opacity micromap (else a
    /// displacement micromap): `maxima` are the 2-state, 4-state and
    /// displacement level limits.
    pub fn ext(opacity: bool, (max2, max4, max_nv): (u32, u32, u32)) -> Self {
        if opacity {
            Self::none()
                .allow(OPACITY_MICROMAP_FORMAT_2_STATE, max2)
                .allow(OPACITY_MICROMAP_FORMAT_4_STATE, max4)
        } else {
            DISPLACEMENT_MICROMAP_FORMATS_NV
                .iter()
                .fold(Self::none(), |keys, &format| keys.allow(format, max_nv))
        }
    }

    /// Also allows `format` (below 4) at levels 0 to `max`.
    pub fn allow(mut self, format: u32, max: u32) -> Self {
        if (format as usize) < Self::FORMATS {
            self.level_bound[format as usize] = u64::from(max) + 1;
        }
        self
    }

    /// The table slot of `format`: itself below 4, else the slot no level
    /// passes.
    #[inline]
    fn slot(format: u32) -> usize {
        format.min(Self::FORMATS as u32) as usize
    }

    /// One table lookup and a compare, without branches, so that a pass
    /// over many entries costs a few instructions each.
    #[inline]
    pub(crate) fn allows(&self, format: u32, level: u32) -> bool {
        u64::from(level) < self.level_bound[Self::slot(format)]
    }

    /// The usage entries of `counts` the per-entry rules must run on to
    /// decide what running them on every entry would: the first of each
    /// format where every entry is allowed (see [`Self::representatives`]),
    /// else all of them, in order.
    pub fn entries_to_check<'a>(&self, counts: &'a UsageCounts) -> EntriesToCheck<'a> {
        self.scan(counts).entries
    }

    /// A `pUsageCounts` array from this many entries on is passed over
    /// by [`ByteBounds`]; shorter ones entry by entry, which costs less
    /// than that pass's fixed work.
    const BOUNDS_FROM: usize = 16;

    /// [`Self::entries_to_check`] and the sum of the counts
    /// ([`UsageCounts::total`]), summed in the same pass where the array is
    /// long enough for that to matter.
    pub fn scan<'a>(&self, counts: &'a UsageCounts) -> UsageScan<'a> {
        if let Some(array) = counts
            .array
            .as_deref()
            .filter(|a| a.len() >= Self::BOUNDS_FROM)
        {
            let bounds = ByteBounds::of(array);
            if let Some(first) = self.representatives_within(array, &bounds) {
                return UsageScan {
                    entries: EntriesToCheck::representatives(counts, first),
                    total: bounds.total,
                };
            }
        }
        let entries = match self.representatives(counts) {
            Some(first) => EntriesToCheck::representatives(counts, first),
            None => EntriesToCheck::All(counts.usages_read()),
        };
        UsageScan {
            entries,
            total: counts.total(),
        }
    }

    /// The first entry of each format of `array` (as
    /// [`Self::representatives`] gives them) where `bounds` alone show every
    /// entry allowed: each level below 256, each format below 256, and the
    /// highest level allowed for every format from the lowest to the
    /// highest. None where they do not show it (every entry may still be
    /// allowed: [`Self::representatives`] decides).
    fn representatives_within(
        &self,
        array: &[MicromapUsage],
        bounds: &ByteBounds,
    ) -> Option<FirstOfEachFormat> {
        let (formats, level) = bounds.formats_and_level()?;
        if !formats
            .clone()
            .all(|format| self.allows(u32::from(format), u32::from(level)))
        {
            return None;
        }
        let mut first = FirstOfEachFormat::NONE;
        // Allowed, so every format in the range is below FORMATS.
        if formats.start() == formats.end() {
            first.set(usize::from(*formats.start()), 0);
        } else {
            for format in formats {
                if let Some(k) = array.iter().position(|u| u.format == u32::from(format)) {
                    first.set(usize::from(format), k as u32);
                }
            }
        }
        Some(first)
    }

    /// When every usage entry of `counts` is an allowed key: the index of
    /// the first entry of each format that occurs (as
    /// [`UsageCounts::usages_read`] numbers them). The per-entry rules
    /// decide the same rules for every allowed entry of one format, so
    /// running them on these representatives marks exactly what running
    /// them on every entry would, and reports nothing. None when some entry
    /// is not allowed: then the per-entry rules must run on every entry.
    fn representatives(&self, counts: &UsageCounts) -> Option<FirstOfEachFormat> {
        let mut first = FirstOfEachFormat::NONE;
        let Some(array) = counts.array.as_deref() else {
            // `ppUsageCounts` (NULL elements skipped): one at a time.
            for (k, usage) in counts.usages_read() {
                if !self.allows(usage.format, usage.subdivision_level) {
                    return None;
                }
                // Allowed, so below FORMATS; k below usageCountsCount, a u32.
                if first.get(usage.format as usize).is_none() {
                    first.set(usage.format as usize, k as u32);
                }
            }
            return Some(first);
        };
        // `pUsageCounts`: one branch-free pass, then the first entry of each
        // format seen (most arrays show it within a few entries).
        let mut allowed = true;
        // A bit per table slot seen.
        let mut seen = 0u8;
        for usage in array {
            allowed &= self.allows(usage.format, usage.subdivision_level);
            seen |= 1 << Self::slot(usage.format);
        }
        if !allowed {
            return None;
        }
        for format in 0..Self::FORMATS {
            if seen & (1 << format) != 0 {
                if let Some(k) = array.iter().position(|u| u.format as usize == format) {
                    first.set(format, k as u32);
                }
            }
        }
        Some(first)
    }
}

/// Per format slot of [`UsageKeys`], the index of its first usage entry, if
/// any. Plain words with a sentinel: 16 bytes the compiler moves whole,
/// where an array of `Option<u32>` took 32, which it put together through
/// the stack in pieces and read back whole, a store-forwarding stall of
/// about a tenth of the scan's time (perf, 64 entries).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct FirstOfEachFormat([u32; UsageKeys::FORMATS]);

impl FirstOfEachFormat {
    /// No entry of any format.
    const NONE: Self = Self([Self::ABSENT; UsageKeys::FORMATS]);
    /// An index no entry has: a usage entry's index is below
    /// `usageCountsCount`, a u32.
    const ABSENT: u32 = u32::MAX;

    fn get(&self, slot: usize) -> Option<u32> {
        self.0.get(slot).copied().filter(|&k| k != Self::ABSENT)
    }

    fn set(&mut self, slot: usize, k: u32) {
        if let Some(first) = self.0.get_mut(slot) {
            *first = k;
        }
    }
}

/// What [`UsageKeys::scan`] found: the entries the per-entry rules must run
/// on, and the sum of the counts.
pub(crate) struct UsageScan<'a> {
    pub entries: EntriesToCheck<'a>,
    pub total: u64,
}

/// Over a `pUsageCounts` array, the highest and the lowest value of each
/// byte of each field, and the sum of the counts, from one pass that the
/// compiler turns into byte-wise vector maxima and minima over four entries
/// (48 bytes, three 16-byte vectors) at a time, two instructions per 16
/// bytes on any x86-64. Comparing each entry's level against its format's
/// limit instead takes a lookup, a compare and a branch-free fold, about 12
/// instructions an entry. Bytes are enough because valid levels and formats
/// are small: where a field's upper bytes are 0 in every entry, its lowest
/// byte's highest (lowest) value is the field's.
struct ByteBounds {
    /// Per field (count, subdivisionLevel, format): the bits set in its
    /// upper three bytes in any entry, and its lowest byte's highest and
    /// lowest value.
    upper: [u32; 3],
    highest: [u8; 3],
    lowest: [u8; 3],
    total: u64,
}

/// The bytes of one `VkMicromapUsageEXT`: count, subdivisionLevel, format.
const ENTRY: usize = std::mem::size_of::<MicromapUsage>();
/// Entries a step of [`ByteBounds::of`].
const STEP: usize = 4;
const BLOCK: usize = ENTRY * STEP;
/// The fields of an entry, as u32 words.
const COUNT: usize = 0;
const LEVEL: usize = 1;
const FORMAT: usize = 2;

impl ByteBounds {
    /// Steps whose counts are summed in 32-bit lanes: with every count
    /// below 2^24, 256 of them cannot carry out of a lane.
    const LANE_STEPS: usize = 256;

    fn of(array: &[MicromapUsage]) -> Self {
        // Per byte of a step, over the steps.
        let mut highest = [0u8; BLOCK];
        let mut lowest = [u8::MAX; BLOCK];
        // Every field of every whole step summed in its lane (wrapping;
        // only the counts' lanes are used, and only where they cannot
        // have wrapped).
        let mut lanes = [0u32; BLOCK / 4];
        let mut steps = array.chunks_exact(STEP);
        for step in &mut steps {
            fold(&mut highest, &mut lowest, step);
            let words: &[u32] = bytemuck::cast_slice(step);
            for (lane, &word) in lanes.iter_mut().zip(words) {
                *lane = lane.wrapping_add(word);
            }
        }
        let rest = steps.remainder();
        if let Some(&first) = rest.first() {
            // The last four entries (or the few there are, repeated): an
            // entry seen twice changes no highest or lowest byte.
            let last: [MicromapUsage; STEP] = match array.len().checked_sub(STEP) {
                Some(start) => std::array::from_fn(|k| array[start + k]),
                None => std::array::from_fn(|k| rest.get(k).copied().unwrap_or(first)),
            };
            fold(&mut highest, &mut lowest, &last);
        }
        // A field's words made of the highest (lowest) bytes, one per
        // entry of a step: their low byte is the field's lowest byte, in
        // either byte order.
        let highest: [u32; BLOCK / 4] = bytemuck::cast(highest);
        let lowest: [u32; BLOCK / 4] = bytemuck::cast(lowest);
        let of_field = |words: [u32; BLOCK / 4], field: usize| {
            (0..STEP).map(move |entry| words[entry * (ENTRY / 4) + field])
        };
        let mut bounds = Self {
            upper: [0; 3],
            highest: [0; 3],
            lowest: [u8::MAX; 3],
            total: 0,
        };
        for field in [COUNT, LEVEL, FORMAT] {
            for (high, low) in of_field(highest, field).zip(of_field(lowest, field)) {
                bounds.upper[field] |= high & !0xFF;
                bounds.highest[field] = bounds.highest[field].max(high as u8);
                bounds.lowest[field] = bounds.lowest[field].min(low as u8);
            }
        }
        let rest_total: u64 = rest.iter().map(|u| u64::from(u.count)).sum();
        bounds.total = if bounds.upper[COUNT] < 1 << 24 && array.len() / STEP <= Self::LANE_STEPS {
            of_field(lanes, COUNT).map(u64::from).sum::<u64>() + rest_total
        } else {
            array.iter().map(|u| u64::from(u.count)).sum()
        };
        bounds
    }

    /// The lowest to the highest format and the highest level of the
    /// entries, where every level and format is below 256 (their upper
    /// three bytes 0 in every entry); an empty range for no entries.
    fn formats_and_level(&self) -> Option<(std::ops::RangeInclusive<u8>, u8)> {
        (self.upper[LEVEL] | self.upper[FORMAT] == 0).then(|| {
            (
                self.lowest[FORMAT]..=self.highest[FORMAT],
                self.highest[LEVEL],
            )
        })
    }
}

/// Takes a step's bytes into the highest and lowest of each.
#[inline]
fn fold(highest: &mut [u8; BLOCK], lowest: &mut [u8; BLOCK], step: &[MicromapUsage]) {
    let bytes: &[u8] = bytemuck::cast_slice(step);
    for ((high, low), &byte) in highest.iter_mut().zip(lowest.iter_mut()).zip(bytes) {
        *high = (*high).max(byte);
        *low = (*low).min(byte);
    }
}

/// What [`UsageKeys::entries_to_check`] yields: a plain enum rather than a
/// chain of adapters, which cost more per call than the pass itself.
pub(crate) enum EntriesToCheck<'a> {
    /// The first entry of each format (by index into `counts`), where every
    /// entry is allowed; `next` is the format slot to look at next.
    Representatives {
        counts: &'a UsageCounts,
        first: FirstOfEachFormat,
        next: usize,
    },
    /// Every entry, where some entry is not.
    All(UsagesRead<'a>),
}

impl<'a> EntriesToCheck<'a> {
    fn representatives(counts: &'a UsageCounts, first: FirstOfEachFormat) -> Self {
        Self::Representatives {
            counts,
            first,
            next: 0,
        }
    }
}

impl Iterator for EntriesToCheck<'_> {
    type Item = (usize, MicromapUsage);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        match self {
            EntriesToCheck::Representatives {
                counts,
                first,
                next,
            } => {
                while *next < UsageKeys::FORMATS {
                    let slot = first.get(*next);
                    *next += 1;
                    let Some(k) = slot.map(|k| k as usize) else {
                        continue;
                    };
                    // The index came from the list it is looked up in.
                    let usage = match counts.array.as_deref() {
                        Some(array) => array.get(k).copied(),
                        None => counts.pointers.as_deref()?.get(k).copied().flatten(),
                    };
                    return usage.map(|usage| (k, usage));
                }
                None
            }
            EntriesToCheck::All(all) => all.next(),
        }
    }
}

/// `pUsageCounts` holding `(count, subdivisionLevel, format)` entries.
#[cfg(test)]
pub(crate) fn usage_counts(entries: &[(u32, u32, u32)]) -> UsageCounts {
    UsageCounts::array(
        entries
            .iter()
            .map(|&(count, subdivision_level, format)| MicromapUsage {
                count,
                subdivision_level,
                format,
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usage_keys_check_every_entry_or_one_of_each_format() {
        let opacity = UsageKeys::ext(true, (12, 3, 5));
        // Format 1 up to level 12, format 2 up to 3: the first of each format.
        let valid = usage_counts(&[(4, 12, 1), (1, 3, 2), (2, 0, 1), (9, 2, 2)]);
        let checked: Vec<usize> = opacity.entries_to_check(&valid).map(|(k, _)| k).collect();
        assert_eq!(checked, [0, 1]);
        // One entry past its format's limit: every entry, in order.
        let past = usage_counts(&[(4, 12, 1), (1, 4, 2), (2, 0, 1)]);
        let checked: Vec<usize> = opacity.entries_to_check(&past).map(|(k, _)| k).collect();
        assert_eq!(checked, [0, 1, 2]);
        for bad in [
            (1, 0, 0),
            (1, 0, 3),
            (1, 0, 1 << 16),
            (1, 64, 1),
            (1, u32::MAX, 2),
        ] {
            let counts = usage_counts(&[(1, 0, 1), bad]);
            assert_eq!(opacity.entries_to_check(&counts).count(), 2, "{bad:?}");
        }
        // Displacement formats 1 to 3, all up to one limit.
        let displacement = UsageKeys::ext(false, (12, 12, 5));
        let valid = usage_counts(&[(1, 5, 3), (1, 0, 1), (1, 5, 3)]);
        let checked: Vec<usize> = displacement
            .entries_to_check(&valid)
            .map(|(k, _)| k)
            .collect();
        assert_eq!(checked, [1, 0]);
        // A limit of u32::MAX allows every level.
        let every = UsageKeys::none().allow(1, u32::MAX);
        let last = usage_counts(&[(1, u32::MAX, 1), (1, 0, 1)]);
        assert_eq!(every.entries_to_check(&last).count(), 1);
        // A limit of 63 or more allows every level a u64 mask holds.
        let wide = UsageKeys::none().allow(2, 70);
        assert_eq!(
            wide.entries_to_check(&usage_counts(&[(1, 63, 2)])).count(),
            1
        );
        assert_eq!(
            UsageKeys::none()
                .entries_to_check(&UsageCounts::default())
                .count(),
            0
        );
    }

    /// What [`UsageKeys::scan`] must give, worked out entry by entry: the
    /// first entry of each format (in format order) where every entry is
    /// allowed, else every entry; and the sum of the counts.
    fn scan_by_entry(keys: &UsageKeys, counts: &UsageCounts) -> (Vec<usize>, u64) {
        let entries: Vec<(usize, MicromapUsage)> = counts.usages_read().collect();
        let total = entries.iter().map(|(_, u)| u64::from(u.count)).sum();
        if !entries
            .iter()
            .all(|(_, u)| keys.allows(u.format, u.subdivision_level))
        {
            return (entries.iter().map(|&(k, _)| k).collect(), total);
        }
        let first = (0..UsageKeys::FORMATS as u32)
            .filter_map(|format| entries.iter().find(|(_, u)| u.format == format))
            .map(|&(k, _)| k)
            .collect();
        (first, total)
    }

    fn scanned(keys: &UsageKeys, counts: &UsageCounts) -> (Vec<usize>, u64) {
        let scan = keys.scan(counts);
        let total = scan.total;
        (scan.entries.map(|(k, _)| k).collect(), total)
    }

    #[test]
    fn long_usage_arrays_are_scanned_by_their_bytes_alike() {
        let opacity = UsageKeys::ext(true, (12, 12, 5));
        // Long enough for the byte pass, with a remainder of 1 to 3.
        for len in [16, 17, 18, 19, 20, 64, 1031] {
            let valid: Vec<(u32, u32, u32)> = (0..len)
                .map(|i| (i as u32 * 7, i as u32 % 13, 2 - (i as u32 / 3) % 2))
                .collect();
            let counts = usage_counts(&valid);
            assert_eq!(scanned(&opacity, &counts), scan_by_entry(&opacity, &counts));
            assert_eq!(scanned(&opacity, &counts).0, [3, 0], "{len}");
            // One entry wrong in each field, first, in the middle and last.
            for at in [0, len / 2, len - 1] {
                for bad in [
                    (1, 13, 1),
                    (1, 256, 2),
                    (1, 1 << 24, 1),
                    (1, 0, 0),
                    (1, 0, 3),
                    (1, 0, 257),
                    (1, 0, 1 << 31),
                ] {
                    let mut entries = valid.clone();
                    entries[at] = bad;
                    let counts = usage_counts(&entries);
                    let (checked, total) = scanned(&opacity, &counts);
                    assert_eq!(checked.len(), len, "{len} {at} {bad:?}");
                    assert_eq!(total, scan_by_entry(&opacity, &counts).1);
                }
            }
        }
        // Counts from 2^24 up, and sums past u32, are summed exactly.
        let big: Vec<(u32, u32, u32)> = (0..40).map(|i| (u32::MAX - i, 3, 1)).collect();
        let counts = usage_counts(&big);
        assert_eq!(scanned(&opacity, &counts), (vec![0], counts.total()));
        assert_eq!(
            counts.total(),
            (0..40).map(|i| u64::from(u32::MAX - i)).sum::<u64>()
        );
        // One format: its first entry is the representative.
        let four_state = usage_counts(&[(5, 12, 2); 33]);
        assert_eq!(scanned(&opacity, &four_state), (vec![0], 165));
        // Different limits per format: a level the 4-state limit allows
        // but the 2-state one does not is decided entry by entry.
        let uneven = UsageKeys::ext(true, (3, 12, 5));
        let mut entries = vec![(1, 3, 1); 20];
        entries[7] = (1, 12, 2);
        let counts = usage_counts(&entries);
        assert_eq!(scanned(&uneven, &counts), (vec![0, 7], 20));
        entries[9] = (1, 4, 1);
        let counts = usage_counts(&entries);
        assert_eq!(scanned(&uneven, &counts).0.len(), 20);
    }

    proptest::proptest! {
        #[test]
        fn usage_scan_matches_the_entry_by_entry_rules(
            entries in proptest::collection::vec(
                (
                    proptest::prop_oneof![0..4u32, proptest::num::u32::ANY],
                    proptest::prop_oneof![8 => 0..14u32, 1 => proptest::num::u32::ANY],
                    proptest::prop_oneof![8 => 1..3u32, 1 => 0..5u32, 1 => proptest::num::u32::ANY],
                ),
                0..80,
            ),
            limits in (0..14u32, 0..14u32),
        ) {
            let counts = usage_counts(&entries);
            for keys in [
                UsageKeys::ext(true, (limits.0, limits.1, 5)),
                UsageKeys::ext(false, (12, 12, limits.0)),
            ] {
                proptest::prop_assert_eq!(scanned(&keys, &counts), scan_by_entry(&keys, &counts));
            }
        }
    }
}
