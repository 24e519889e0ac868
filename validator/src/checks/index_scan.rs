//! One pass over an opacity attachment's index buffer: the indices are
//! decoded a chunk at a time, and each chunk is classified without
//! branches (special index, -5 cluster index, or a micromap triangle in
//! range after `baseTriangle`), which compiles to vector operations over
//! packed 16- and 32-bit indices. Only a chunk holding an index that draws
//! a finding goes through the per-index rules, so the findings, their text
//! and their order are what the per-index rules give. The same pass tallies
//! the micromap triangles the indices select per (format, level), for the
//! EXT usage counts, so the time follows the referenced count, not the
//! micromap's size.

use crate::checks::common::TriangleHistogram;
use crate::sim::decode::{MicromapContent, TriangleEntries};
use crate::sim::keys::TriangleKeys;

/// Indices decoded and classified at once.
pub(crate) const CHUNK: usize = 64;

/// The largest value an index of `size` bytes holds (-1 cast to its width).
pub(crate) fn index_max(size: u64) -> u64 {
    match size {
        1 => u64::from(u8::MAX),
        2 => u64::from(u16::MAX),
        _ => u64::from(u32::MAX),
    }
}

/// Whether the `size`-byte index `value` is the unsigned cast of one of the
/// four `VkOpacityMicromapSpecialIndexKHR` values -1..-4 (0xFFFF..0xFFFC for
/// 16-bit indices). The cluster-only -5 is no special index in the
/// geometries checked here: it reads as an ordinary (huge) index.
pub(crate) fn is_special_index(value: u32, size: u64) -> bool {
    u64::from(value) + 3 >= index_max(size)
}

/// Whether `value` is -5 cast to the index width (0xFFFB for 16-bit).
pub(crate) fn is_cluster_skip_index(value: u32, size: u64) -> bool {
    u64::from(value) + 4 == index_max(size)
}

/// The indices of `count` triangles in `bytes` (an index buffer read from
/// its start), as `(triangle, index)`, as far as `bytes` reaches. A stride of
/// 0 reads one index for every triangle, so it is yielded once.
pub(crate) fn read_indices(
    bytes: &[u8],
    size: u64,
    stride: u64,
    count: u64,
) -> impl Iterator<Item = (u64, u32)> + '_ {
    let distinct = if stride == 0 { count.min(1) } else { count };
    (0..distinct).map_while(move |j| {
        let start = usize::try_from(j.checked_mul(stride)?).ok()?;
        let end = start.checked_add(usize::try_from(size).ok()?)?;
        let index = match *bytes.get(start..end)? {
            [a] => u32::from(a),
            [a, b] => u32::from(u16::from_le_bytes([a, b])),
            [a, b, c, d] => u32::from_le_bytes([a, b, c, d]),
            ref other => other
                .iter()
                .rev()
                .fold(0u32, |v, b| (v << 8) | u32::from(*b)),
        };
        Some((j, index))
    })
}

/// Calls `visit(first, indices)` for the indices [`read_indices`] yields,
/// in order, at most [`CHUNK`] at a time (`first` is the triangle of the
/// chunk's first index); returns how many were read. Packed 16- and 32-bit
/// indices are decoded straight from the bytes.
pub(crate) fn for_each_chunk(
    bytes: &[u8],
    size: u64,
    stride: u64,
    count: u64,
    mut visit: impl FnMut(u64, &[u32]),
) -> u64 {
    let mut values = [0u32; CHUNK];
    if stride == size && (size == 2 || size == 4) {
        let width = size as usize;
        // Whole indices inside `bytes`, never more than the triangles.
        let readable = ((bytes.len() / width) as u64).min(count) as usize;
        let mut first = 0u64;
        for chunk in bytes[..readable * width].chunks(CHUNK * width) {
            let n = chunk.len() / width;
            if width == 2 {
                for (value, b) in values.iter_mut().zip(chunk.chunks_exact(2)) {
                    *value = u32::from(u16::from_le_bytes([b[0], b[1]]));
                }
            } else {
                for (value, b) in values.iter_mut().zip(chunk.chunks_exact(4)) {
                    *value = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
            visit(first, &values[..n]);
            first += n as u64;
        }
        return readable as u64;
    }
    // Any other stride or size: one index at a time into the chunk.
    let (mut n, mut first, mut read) = (0usize, 0u64, 0u64);
    for (_, index) in read_indices(bytes, size, stride, count) {
        values[n] = index;
        n += 1;
        read += 1;
        if n == CHUNK {
            visit(first, &values);
            first += CHUNK as u64;
            n = 0;
        }
    }
    if n > 0 {
        visit(first, &values[..n]);
    }
    read
}

/// Whether `values`, `size`-byte indices, hold (a special index, an index
/// that selects a micromap triangle): -5 is neither. Accumulated in locals
/// over the whole chunk without branches, so that it compiles to a few
/// vector operations.
pub(crate) fn special_and_micromap_indices(values: &[u32], size: u64) -> (bool, bool) {
    let max = index_max(size) as u32;
    let (special_from, cluster) = (max - 3, max - 4);
    let (mut special, mut micromap) = (false, false);
    for &value in values {
        let is_special = value >= special_from;
        special |= is_special;
        micromap |= !is_special & (value != cluster);
    }
    (special, micromap)
}

/// What an opacity index buffer holds, as a check read it in full: its
/// index type, address, stride and triangle count, and whether it holds
/// (special indices, micromap indices), as
/// [`special_and_micromap_indices`] says.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct IndexMix {
    pub index_type: i32,
    pub address: u64,
    pub stride: u64,
    pub count: u64,
    pub held: (bool, bool),
}

/// Which indices draw no finding from the index rules: a special index
/// (-1..-4), or any other but -5 whose micromap triangle, index +
/// `baseTriangle`, lies below the micromap's triangle count (none with a
/// NULL micromap).
///
/// Held in 32 bits, so that a vector register holds four indices: an index
/// is in range when it is below `triangles - base`, saturated to
/// `in_range_below` (the one 32-bit value it leaves out, `u32::MAX`, is a
/// special index).
#[derive(Clone, Copy, Debug)]
pub(crate) struct CleanIndices {
    special_from: u32,
    cluster: u32,
    in_range_below: u32,
}

impl CleanIndices {
    /// For `size`-byte indices, `base` = `baseTriangle`, and the micromap's
    /// triangle count (None: a NULL micromap).
    pub fn new(size: u64, base: u64, triangles: Option<u64>) -> Self {
        let max = index_max(size) as u32;
        let below = triangles.unwrap_or(0).saturating_sub(base);
        Self {
            special_from: max - 3,
            cluster: max - 4,
            in_range_below: u32::try_from(below).unwrap_or(u32::MAX),
        }
    }

    /// Whether every index of `values` is clean; written without branches
    /// so that it compiles to a few vector operations per chunk.
    pub fn all(&self, values: &[u32]) -> bool {
        let mut dirty = 0u32;
        for &value in values {
            let special = u32::from(value >= self.special_from);
            let in_range =
                u32::from(value != self.cluster) & u32::from(value < self.in_range_below);
            dirty |= 1 ^ (special | in_range);
        }
        dirty == 0
    }
}

/// The micromap triangles the indices select, per (format, level), each
/// counted `weight` times (a stride of 0 reads one index for every
/// triangle); special indices select none. Undecided once an index selects
/// a triangle the checker did not read (past the entries read, or any with
/// a NULL micromap).
///
/// Tallied over the micromap's [`TriangleKeys`] (kept with its content), so
/// that the time follows the references: no triangle array entry is read
/// per reference. A micromap with more distinct keys than they name (only
/// possible with invalid formats or levels) is tallied entry by entry.
pub(crate) struct ReferenceTally<'e> {
    by: Tallying<'e>,
    weight: u64,
    undecided: bool,
}

/// A NULL micromap's keys: none.
static NO_KEYS: TriangleKeys = TriangleKeys::NONE;

enum Tallying<'e> {
    Keyed(KeyedTally<'e>),
    /// Boxed: it carries its histogram, and is rare.
    ByEntry(Box<EntryTally<'e>>),
}

impl<'e> ReferenceTally<'e> {
    /// For `size`-byte indices selecting triangle index + `base` of the
    /// triangle array of `content` (None: a NULL micromap, which has none).
    pub fn new(content: Option<&'e MicromapContent>, size: u64, base: u64, weight: u64) -> Self {
        let keyed = match content {
            None => Some((&NO_KEYS, 0)),
            Some(c) => c.keys().map(|keys| (keys, c.triangles.len() as u64)),
        };
        let by = match keyed {
            Some((keys, entries)) => Tallying::Keyed(KeyedTally::new(keys, entries, size, base)),
            None => Tallying::ByEntry(Box::new(EntryTally::new(
                content.map(|c| &c.triangles),
                size,
                base,
                weight,
            ))),
        };
        Self {
            by,
            weight,
            undecided: false,
        }
    }

    /// Tallies the micromap triangles `values` select.
    pub fn add(&mut self, values: &[u32]) {
        if self.undecided {
            return;
        }
        self.undecided = !match &mut self.by {
            Tallying::Keyed(tally) => tally.add(values),
            Tallying::ByEntry(tally) => tally.add(values),
        };
    }

    /// The tally, or None where it is undecided.
    pub fn finish(self) -> Option<TriangleHistogram> {
        if self.undecided {
            return None;
        }
        Some(match self.by {
            Tallying::Keyed(tally) => tally.finish(self.weight),
            Tallying::ByEntry(tally) => tally.finish(),
        })
    }
}

/// The tally of [`ReferenceTally`] over a micromap's [`TriangleKeys`]: a
/// chunk of indices costs a few vector operations (which are special, and
/// whether any selects a triangle past the entries read), plus, where the
/// micromap has several keys, one byte read per reference.
struct KeyedTally<'e> {
    keys: &'e TriangleKeys,
    base: u64,
    special_from: u32,
    /// An index below `special_from` selects an entry read when it is below
    /// `entries_below` (saturated: every index that selects a triangle is
    /// below `u32::MAX`).
    entries_below: u32,
    /// With one key: the references so far.
    selected: u64,
    /// With several: per key id, four counters, which the references of a
    /// chunk take in turn, so that runs of alike ids add to different
    /// words rather than waiting on one another.
    per_key: Vec<[u64; 4]>,
}

impl<'e> KeyedTally<'e> {
    fn new(keys: &'e TriangleKeys, entries: u64, size: u64, base: u64) -> Self {
        let below = entries.saturating_sub(base);
        Self {
            keys,
            base,
            special_from: index_max(size) as u32 - 3,
            entries_below: u32::try_from(below).unwrap_or(u32::MAX),
            selected: 0,
            per_key: vec![
                [0; 4];
                if keys.ids().is_empty() {
                    0
                } else {
                    keys.distinct().len()
                }
            ],
        }
    }

    /// Tallies `values`; false where one selects a triangle past the
    /// entries read (the tally is then undecided).
    fn add(&mut self, values: &[u32]) -> bool {
        // In 32-bit lanes (a chunk has at most `CHUNK` indices), so that a
        // vector register holds four.
        let (mut selected, mut past) = (0u32, 0u32);
        for &value in values {
            let selects = u32::from(value < self.special_from);
            selected += selects;
            past |= selects & u32::from(value >= self.entries_below);
        }
        if past != 0 {
            return false;
        }
        let selected = u64::from(selected);
        let ids = self.keys.ids();
        if ids.is_empty() {
            self.selected += selected;
            return true;
        }
        for (k, &value) in values.iter().enumerate() {
            if value < self.special_from {
                // Below the entries read (checked above), so inside `ids`.
                if let Some(&id) = ids.get((u64::from(value) + self.base) as usize) {
                    self.per_key[usize::from(id)][k % 4] += 1;
                }
            }
        }
        true
    }

    fn finish(self, weight: u64) -> TriangleHistogram {
        let mut found = TriangleHistogram::new();
        let distinct = self.keys.distinct();
        let totals: Vec<(u32, u64)> = if self.per_key.is_empty() {
            distinct
                .first()
                .map(|&key| (key, self.selected))
                .into_iter()
                .collect()
        } else {
            distinct
                .iter()
                .zip(&self.per_key)
                .map(|(&key, lanes)| (key, lanes.iter().sum()))
                .collect()
        };
        for (key, n) in totals {
            if n > 0 {
                found.add(key >> 16, key & 0xffff, n.saturating_mul(weight));
            }
        }
        found
    }
}

/// The tally of [`ReferenceTally`] entry by entry: each reference reads
/// its triangle's key from the triangle array.
struct EntryTally<'e> {
    /// The triangle array from its first entry, its stride and entries.
    array: &'e [u8],
    stride: usize,
    entries: u64,
    base: u64,
    special_from: u64,
    /// The key (`subdivisionLevel | format << 16`) of the current run of
    /// alike references, and its length: counted when the key changes, so
    /// that alike references cost a compare and an add.
    key: u32,
    run: u64,
    weight: u64,
    found: TriangleHistogram,
}

impl<'e> EntryTally<'e> {
    fn new(entries: Option<&'e TriangleEntries>, size: u64, base: u64, weight: u64) -> Self {
        let (array, stride, len) = entries.map_or((&[][..], 0, 0), TriangleEntries::raw);
        Self {
            array,
            stride,
            entries: len as u64,
            base,
            special_from: index_max(size) - 3,
            key: 0,
            run: 0,
            weight,
            found: TriangleHistogram::new(),
        }
    }

    /// Tallies `values`; false where one selects a triangle past the
    /// entries read.
    fn add(&mut self, values: &[u32]) -> bool {
        for &value in values {
            let value = u64::from(value);
            if value >= self.special_from {
                continue;
            }
            let m = value + self.base;
            // Below `entries`, whose last ends inside `array`.
            let key = (m < self.entries)
                .then(|| m as usize * self.stride + 4)
                .and_then(|at| self.array.get(at..at + 4));
            let Some(key) = key else {
                return false;
            };
            let key = u32::from_le_bytes([key[0], key[1], key[2], key[3]]);
            if key == self.key {
                self.run += 1;
            } else {
                self.flush();
                self.key = key;
                self.run = 1;
            }
        }
        true
    }

    fn flush(&mut self) {
        if self.run > 0 {
            let (format, level) = (self.key >> 16, self.key & 0xffff);
            self.found
                .add(format, level, self.run.saturating_mul(self.weight));
            self.run = 0;
        }
    }

    fn finish(mut self) -> TriangleHistogram {
        self.flush();
        self.found
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MicromapTriangle;

    fn packed(values: &[u32], size: u64) -> Vec<u8> {
        values
            .iter()
            .flat_map(|v| v.to_le_bytes()[..size as usize].to_vec())
            .collect()
    }

    /// Every index as `for_each_chunk` hands them over, with their triangles.
    fn chunked(bytes: &[u8], size: u64, stride: u64, count: u64) -> (Vec<(u64, u32)>, u64) {
        let mut seen = Vec::new();
        let read = for_each_chunk(bytes, size, stride, count, |first, values| {
            assert!(values.len() <= CHUNK);
            seen.extend((first..).zip(values.iter().copied()));
        });
        (seen, read)
    }

    #[test]
    fn chunks_hold_what_reading_one_by_one_gives() {
        let values: Vec<u32> = (0..200).map(|i| i * 7 % 0x1_0000).collect();
        for size in [1u64, 2, 4] {
            let mask = index_max(size) as u32;
            let bytes = packed(&values, size);
            // Packed, strided, stride 0, cut short, and more triangles than bytes.
            for (stride, count, len) in [
                (size, 200, bytes.len()),
                (size, 130, bytes.len()),
                (size, 200, bytes.len() - 1),
                (2 * size, 90, bytes.len()),
                (0, 50, bytes.len()),
                (size, 300, bytes.len()),
            ] {
                let bytes = &bytes[..len];
                let one_by_one: Vec<(u64, u32)> =
                    read_indices(bytes, size, stride, count).collect();
                let (seen, read) = chunked(bytes, size, stride, count);
                assert_eq!(
                    seen, one_by_one,
                    "size {size} stride {stride} count {count}"
                );
                assert_eq!(read, one_by_one.len() as u64);
                assert!(seen.iter().all(|&(_, v)| v <= mask));
            }
        }
    }

    #[test]
    fn clean_indices_are_special_or_in_range_but_not_minus_five() {
        let clean = CleanIndices::new(2, 10, Some(20));
        assert!(clean.all(&[0, 9, 0xFFFF, 0xFFFC]));
        for dirty in [10, 0xFFFB, 0xFFFA, 20] {
            assert!(!clean.all(&[0, dirty, 1]), "{dirty:#x}");
        }
        // A NULL micromap: only special indices are clean.
        let null = CleanIndices::new(4, 0, None);
        assert!(null.all(&[u32::MAX, u32::MAX - 3]));
        assert!(!null.all(&[0]));
        assert!(!null.all(&[u32::MAX - 4]));
        // A micromap large enough to hold -5's value: still not clean.
        let huge = CleanIndices::new(2, 0, Some(1 << 20));
        assert!(huge.all(&[0xFFFA]));
        assert!(!huge.all(&[0xFFFB]));
        assert!(CleanIndices::new(1, 0, Some(3)).all(&[2, 0xFF]));
        // Bounds beyond 32 bits: a base past the count, a count past 2^32.
        assert!(!CleanIndices::new(4, 7, Some(5)).all(&[0]));
        let wide = CleanIndices::new(4, 1, Some(1 << 33));
        assert!(wide.all(&[0, u32::MAX - 5]));
        assert!(!wide.all(&[u32::MAX - 4]));
        let edge = CleanIndices::new(4, 0, Some(u64::from(u32::MAX)));
        assert!(edge.all(&[u32::MAX - 5]));
    }

    #[test]
    fn references_tally_per_key_and_stop_past_the_entries_read() {
        let t = |subdivision_level, format| MicromapTriangle {
            data_offset: 0,
            subdivision_level,
            format,
        };
        let content = MicromapContent::new(
            vec![t(3, 2), t(3, 2), t(1, 1), t(3, 2)],
            crate::Bytes::new(),
        );
        let mut tally = ReferenceTally::new(Some(&content), 4, 1, 1);
        // Triangles 1, 2, 3, 1 and a special index.
        tally.add(&[0, 1, 2]);
        tally.add(&[0, u32::MAX]);
        let found = tally.finish().expect("decided").into_map();
        assert_eq!(
            found.into_iter().collect::<Vec<_>>(),
            [((1, 1), 1), ((2, 3), 3)]
        );
        // Weighted (stride 0): one index for 5 triangles.
        let mut tally = ReferenceTally::new(Some(&content), 2, 0, 5);
        tally.add(&[2]);
        let found = tally.finish().expect("decided").into_map();
        assert_eq!(found.into_iter().collect::<Vec<_>>(), [((1, 1), 5)]);
        // Past the entries read, or any index with a NULL micromap: undecided.
        let mut past = ReferenceTally::new(Some(&content), 4, 1, 1);
        past.add(&[0, 3]);
        assert!(past.finish().is_none());
        let mut null = ReferenceTally::new(None, 4, 0, 1);
        null.add(&[u32::MAX]);
        assert!(null.finish().is_some_and(|f| f.into_map().is_empty()));
        let mut null = ReferenceTally::new(None, 4, 0, 1);
        null.add(&[0]);
        assert!(null.finish().is_none());
    }

    /// Triangle array entries whose keys come from `pool` by `picks`.
    fn content_of(pool: &[(u16, u16)], picks: &[usize]) -> MicromapContent {
        let triangles: Vec<MicromapTriangle> = picks
            .iter()
            .map(|&p| MicromapTriangle {
                data_offset: 0,
                subdivision_level: pool[p % pool.len()].1,
                format: pool[p % pool.len()].0,
            })
            .collect();
        MicromapContent::new(triangles, crate::Bytes::new())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2048))]

        /// The tally over the micromap's keys gives what reading each
        /// reference's entry gives: the same counts per key, and undecided
        /// alike, whatever the indices (in range, special, -5, past the
        /// entries), the keys (one, or several), the width, base, weight
        /// and chunking.
        #[test]
        fn the_keyed_tally_is_the_entry_by_entry_tally(
            keys in 1usize..5,
            picks in proptest::collection::vec(0usize..8, 0..300),
            raw in proptest::collection::vec(proptest::prelude::any::<u32>(), 0..400),
            size in proptest::sample::select(vec![1u64, 2, 4]),
            base in 0u64..6,
            weight in 1u64..4,
            chunk in 1usize..=CHUNK,
        ) {
            let pool = [(2, 3), (1, 0), (2, 12), (1, 7)];
            // One key for every entry where `keys` is 1.
            let content = content_of(&pool[..keys.min(pool.len())], &picks);
            let max = index_max(size) as u32;
            // Mostly in range, some special or -5, and now and then one
            // anywhere (most often past the end, which leaves it undecided).
            let in_range = (picks.len() as u32).saturating_sub(base as u32).max(1);
            let values: Vec<u32> = raw
                .iter()
                .map(|r| match r % 128 {
                    0 => (r >> 7) & max,
                    1..=15 => max - (r >> 7) % 5,
                    _ => (r >> 7) % in_range,
                })
                .collect();
            let mut keyed = ReferenceTally::new(Some(&content), size, base, weight);
            let mut by_entry = EntryTally::new(Some(&content.triangles), size, base, weight);
            let mut decided = true;
            for part in values.chunks(chunk) {
                keyed.add(part);
                decided &= by_entry.add(part);
            }
            let expected = decided.then(|| by_entry.finish().into_map());
            proptest::prop_assert_eq!(keyed.finish().map(|f| f.into_map()), expected);
        }
    }
}
