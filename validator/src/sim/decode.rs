//! A built opacity micromap's content, decoded on demand: only the
//! micro-triangles a lookup touches are read, so the cost of a simulation
//! follows the hits asked about, not the size of the micromap.

use std::collections::BTreeSet;

use crate::Bytes;

use crate::model::micromap::opacity_triangle_bytes;
use crate::model::MicromapTriangle;
use crate::sim::index::{self, BaryError};
use crate::sim::keys::{KeysCache, TriangleKeys};
use crate::sim::opacity::{bits_per_state, state_at, OpacityState, Slot};

/// The triangle array and data of one micromap build.
///
/// The data is shared, not copied: `data` is the whole memory the build's
/// `data` address lies in (a buffer's contents or a host range) and
/// `data_start` is where `data` begins in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MicromapContent {
    /// `triangleArray`, one entry per micromap triangle (as far as the
    /// checker could read it): a view of the bytes, not a copy.
    pub triangles: TriangleEntries,
    /// The memory holding the bytes `data` points to.
    pub data: Bytes,
    /// The offset of the build's `data` address in [`Self::data`].
    pub data_start: usize,
    /// A build with `triangleArrayStride` 0: all this many triangles read
    /// the one entry in [`Self::triangles`].
    pub repeated: Option<u64>,
    /// Each entry's (format, level) key, worked out on first use; derived
    /// from `triangles`, so whatever changes them starts a new cache (as
    /// [`Self::repeating`] does).
    pub keys: KeysCache,
}

/// A build's triangle array as the checker read it: a shared view of the
/// memory holding it (a buffer's contents or a host range) with the
/// array's start and stride, its entries decoded when asked for. Recording
/// a build shares the bytes rather than copying every entry, so the content
/// tier reads the array once.
#[derive(Clone)]
pub struct TriangleEntries {
    bytes: Bytes,
    start: usize,
    stride: usize,
    len: usize,
}

impl TriangleEntries {
    /// The `len` entries at `stride` from `start` in `bytes`; None unless
    /// every one of them lies inside `bytes`.
    pub fn shared(bytes: Bytes, start: usize, stride: u64, len: u64) -> Option<Self> {
        let stride = usize::try_from(stride).ok()?;
        let len = usize::try_from(len).ok()?;
        if let Some(last) = len.checked_sub(1) {
            let end = last
                .checked_mul(stride)?
                .checked_add(start)?
                .checked_add(MicromapTriangle::SIZE as usize)?;
            if end > bytes.len() {
                return None;
            }
        }
        Some(Self {
            bytes,
            start,
            stride,
            len,
        })
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The 8 bytes of entry `m`.
    fn entry_bytes(&self, m: usize) -> Option<[u8; 8]> {
        if m >= self.len {
            return None;
        }
        // Inside `bytes`: `shared` checked the last entry's end.
        let offset = self.start + m * self.stride;
        self.bytes.get(offset..offset + 8)?.try_into().ok()
    }

    /// Entry `m`.
    pub fn get(&self, m: usize) -> Option<MicromapTriangle> {
        self.entry_bytes(m).map(MicromapTriangle::from_bytes)
    }

    /// Entry `m`'s upper 32 bits, `subdivisionLevel | format << 16`: its
    /// (format, level) key in one load.
    #[inline]
    pub fn format_level(&self, m: usize) -> Option<u32> {
        let bytes = self.entry_bytes(m)?;
        Some(u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]))
    }

    /// The array's bytes from its first entry, its stride and its entries:
    /// for loops that read one member of many entries.
    pub fn raw(&self) -> (&[u8], usize, usize) {
        (
            self.bytes.get(self.start..).unwrap_or(&[]),
            self.stride,
            self.len,
        )
    }

    /// The entries in order.
    pub fn iter(&self) -> impl Iterator<Item = MicromapTriangle> + '_ {
        (0..self.len).filter_map(|m| self.get(m))
    }

    /// Keeps the first `len` entries.
    pub fn truncate(&mut self, len: usize) {
        self.len = self.len.min(len);
    }
}

impl From<Vec<MicromapTriangle>> for TriangleEntries {
    /// The entries of a tightly packed array holding `triangles`.
    fn from(triangles: Vec<MicromapTriangle>) -> Self {
        let bytes: Vec<u8> = triangles.iter().flat_map(|t| t.to_bytes()).collect();
        Self {
            bytes: Bytes::from(bytes),
            start: 0,
            stride: MicromapTriangle::SIZE as usize,
            len: triangles.len(),
        }
    }
}

impl PartialEq for TriangleEntries {
    /// Alike when the entries are, wherever their bytes lie.
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len && self.iter().eq(other.iter())
    }
}

impl Eq for TriangleEntries {}

impl PartialEq<Vec<MicromapTriangle>> for TriangleEntries {
    fn eq(&self, other: &Vec<MicromapTriangle>) -> bool {
        self.len == other.len() && self.iter().eq(other.iter().copied())
    }
}

impl std::fmt::Debug for TriangleEntries {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// The work a simulation did: micromap triangles whose states were read
/// (blocks decoded), bytes read from application memory, and indices read
/// from index buffers. Returned with each answer, so the cost of a query can
/// be checked against what it references.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct WorkCounters {
    pub blocks_decoded: u64,
    pub bytes_read: u64,
    pub indices_read: u64,
}

impl std::ops::AddAssign for WorkCounters {
    fn add_assign(&mut self, other: Self) {
        self.blocks_decoded = self.blocks_decoded.saturating_add(other.blocks_decoded);
        self.bytes_read = self.bytes_read.saturating_add(other.bytes_read);
        self.indices_read = self.indices_read.saturating_add(other.indices_read);
    }
}

/// Why a lookup has no answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LookupError {
    /// The slot names micromap triangle `m`, but the micromap has `count`.
    TriangleOutOfRange { m: u64, count: u64 },
    /// Triangle `m` has a format that is not an opacity format.
    Format { m: u64, format: u16 },
    /// Triangle `m`'s data lies outside the data the checker has.
    DataOutOfRange { m: u64 },
    /// The barycentrics cannot be mapped (NaN, or a level above 12).
    Barycentrics(BaryError),
}

/// Replaces `bytes` with `copy(bytes)` where it is a view of host memory
/// in `within` (addresses).
pub fn owned_if_within(
    bytes: &mut Bytes,
    within: &std::ops::Range<usize>,
    copy: &mut dyn FnMut(&[u8]) -> Bytes,
) {
    if within.contains(&bytes.as_ptr().addr()) {
        *bytes = copy(bytes);
    }
}

impl MicromapContent {
    /// Whether the triangles or the data are a view of host memory in
    /// `within` (addresses).
    pub fn views_within(&self, within: &std::ops::Range<usize>) -> bool {
        within.contains(&self.triangles.bytes.as_ptr().addr())
            || within.contains(&self.data.as_ptr().addr())
    }

    /// Makes the triangles and the data that are views of host memory in
    /// `within` copies (`copy` makes them), so that memory may change.
    pub fn own_bytes_within(
        &mut self,
        within: &std::ops::Range<usize>,
        copy: &mut dyn FnMut(&[u8]) -> Bytes,
    ) {
        owned_if_within(&mut self.triangles.bytes, within, copy);
        owned_if_within(&mut self.data, within, copy);
    }

    /// Content whose data starts at the beginning of `data`.
    pub fn new(triangles: impl Into<TriangleEntries>, data: Bytes) -> Self {
        Self::at(triangles, data, 0)
    }

    /// Content whose data starts `data_start` bytes into `data` (clamped to
    /// its length: past the end there is no data).
    pub fn at(triangles: impl Into<TriangleEntries>, data: Bytes, data_start: usize) -> Self {
        let data_start = data_start.min(data.len());
        Self {
            triangles: triangles.into(),
            data,
            data_start,
            repeated: None,
            keys: KeysCache::default(),
        }
    }

    /// Content of a build with `triangleArrayStride` 0, whose `count`
    /// triangles all read its first entry.
    pub fn repeating(mut self, count: u64) -> Self {
        self.triangles.truncate(1);
        self.repeated = Some(count);
        self.keys = KeysCache::default();
        self
    }

    /// Each triangle array entry's (format, level) key (see [`TriangleKeys`]):
    /// one pass over the entries on the first call, kept for the next.
    pub fn keys(&self) -> Option<&TriangleKeys> {
        self.keys.get_or_work_out(&self.triangles)
    }

    /// The bytes from the build's `data` address on.
    pub fn data_bytes(&self) -> &[u8] {
        self.data.get(self.data_start..).unwrap_or(&[])
    }

    /// The bytes of triangle `m`'s states.
    pub fn triangle_data(&self, m: u64) -> Result<(MicromapTriangle, &[u8]), LookupError> {
        let count = self.repeated.unwrap_or(self.triangles.len() as u64);
        let entry = if self.repeated.is_some() {
            (m < count).then_some(0)
        } else {
            usize::try_from(m).ok()
        };
        let triangle = entry
            .and_then(|i| self.triangles.get(i))
            .ok_or(LookupError::TriangleOutOfRange { m, count })?;
        let size = opacity_triangle_bytes(
            u32::from(triangle.format),
            u32::from(triangle.subdivision_level),
        )
        .ok_or(LookupError::Format {
            m,
            format: triangle.format,
        })?;
        let start = u64::from(triangle.data_offset);
        let bytes = start
            .checked_add(size)
            .and_then(|end| Some((usize::try_from(start).ok()?, usize::try_from(end).ok()?)))
            .and_then(|(s, e)| self.data_bytes().get(s..e))
            .ok_or(LookupError::DataOutOfRange { m })?;
        Ok((triangle, bytes))
    }

    /// The states a hit at (u, v) with barycentric error up to `delta` may
    /// read from the triangle in `slot`.
    pub fn states(
        &self,
        slot: Slot,
        u: f32,
        v: f32,
        delta: f64,
    ) -> Result<BTreeSet<OpacityState>, LookupError> {
        self.states_counted(slot, u, v, delta, &mut WorkCounters::default())
            .map(|(_, states)| states)
    }

    /// As [`Self::states`], also returning the micro-triangles considered
    /// and adding what was read to `work` (one block, and the bytes holding
    /// the considered states).
    pub fn states_counted(
        &self,
        slot: Slot,
        u: f32,
        v: f32,
        delta: f64,
        work: &mut WorkCounters,
    ) -> Result<(BTreeSet<u32>, BTreeSet<OpacityState>), LookupError> {
        match slot {
            Slot::Special(special) => Ok((BTreeSet::new(), special.state().into_iter().collect())),
            Slot::Micromap(m) => {
                let (triangle, bytes) = self.triangle_data(m)?;
                let level = u32::from(triangle.subdivision_level);
                let format = u32::from(triangle.format);
                let micro = match index::candidates(u, v, level, delta) {
                    Ok(micro) => micro,
                    // The hit could be anywhere on the triangle: all its states.
                    Err(BaryError::TooUncertain) => {
                        return Ok((BTreeSet::new(), self.all_states(m, work)?))
                    }
                    Err(e) => return Err(LookupError::Barycentrics(e)),
                };
                let states = micro
                    .iter()
                    .map(|k| state_at(bytes, format, *k).ok_or(LookupError::DataOutOfRange { m }))
                    .collect::<Result<BTreeSet<_>, _>>()?;
                let bits = u64::from(bits_per_state(format).unwrap_or(2));
                let touched: BTreeSet<u64> =
                    micro.iter().map(|k| u64::from(*k) * bits / 8).collect();
                work.blocks_decoded = work.blocks_decoded.saturating_add(1);
                work.bytes_read = work.bytes_read.saturating_add(touched.len() as u64);
                Ok((micro, states))
            }
        }
    }

    /// Every state micromap triangle `m` holds (all its micro-triangles),
    /// adding one block and the bytes scanned to `work`. The scan stops once
    /// all four states have been seen.
    pub fn all_states(
        &self,
        m: u64,
        work: &mut WorkCounters,
    ) -> Result<BTreeSet<OpacityState>, LookupError> {
        let (triangle, bytes) = self.triangle_data(m)?;
        let format = u32::from(triangle.format);
        let level = u32::from(triangle.subdivision_level);
        if level > index::MAX_LEVEL {
            return Err(LookupError::Barycentrics(BaryError::Level));
        }
        let bits = u64::from(bits_per_state(format).unwrap_or(2));
        let mut states = BTreeSet::new();
        let mut scanned = 0u64;
        // At most 4^12 micro-triangles.
        for k in 0..(1u32 << (2 * level)) {
            states.insert(state_at(bytes, format, k).ok_or(LookupError::DataOutOfRange { m })?);
            scanned = u64::from(k) * bits / 8 + 1;
            if states.len() == 4 {
                break;
            }
        }
        work.blocks_decoded = work.blocks_decoded.saturating_add(1);
        work.bytes_read = work.bytes_read.saturating_add(scanned);
        Ok(states)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::opacity::SpecialIndex;

    fn content() -> MicromapContent {
        // Triangle 0: 4-state level 1 with states T, O, UT, UO; triangle 1:
        // 2-state level 0, opaque; triangle 2: data past the end.
        MicromapContent::new(
            vec![
                MicromapTriangle {
                    data_offset: 0,
                    subdivision_level: 1,
                    format: 2,
                },
                MicromapTriangle {
                    data_offset: 1,
                    subdivision_level: 0,
                    format: 1,
                },
                MicromapTriangle {
                    data_offset: 2,
                    subdivision_level: 3,
                    format: 2,
                },
            ],
            Bytes::from(vec![0b1110_0100u8, 0x01]),
        )
    }

    #[test]
    fn lookups_read_the_micro_triangle_the_hit_is_in() {
        let c = content();
        assert_eq!(
            c.states(Slot::Micromap(0), 0.1, 0.1, 0.0),
            Ok(BTreeSet::from([OpacityState::Transparent]))
        );
        assert_eq!(
            c.states(Slot::Micromap(0), 0.4, 0.4, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
        assert_eq!(
            c.states(Slot::Micromap(0), 0.1, 0.8, 0.0),
            Ok(BTreeSet::from([OpacityState::UnknownOpaque]))
        );
        // On the diagonal edge between micro-triangles 0 and 1, both are possible.
        assert_eq!(
            c.states(Slot::Micromap(0), 0.25, 0.25, 1e-6),
            Ok(BTreeSet::from([
                OpacityState::Transparent,
                OpacityState::Opaque
            ]))
        );
        assert_eq!(
            c.states(Slot::Micromap(1), 0.3, 0.3, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
        assert_eq!(
            c.states(Slot::Special(SpecialIndex::FullyOpaque), 0.3, 0.3, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
    }

    #[test]
    fn data_is_shared_from_an_offset_and_work_is_counted() {
        // The data starts 2 bytes into the shared memory.
        let memory: Bytes = Bytes::from(vec![0xFFu8, 0xFF, 0b1110_0100]);
        let c = MicromapContent::at(
            vec![MicromapTriangle {
                data_offset: 0,
                subdivision_level: 1,
                format: 2,
            }],
            memory.clone(),
            2,
        );
        assert_eq!(c.data.as_ptr(), memory.as_ptr(), "shared, not copied");
        assert_eq!(c.data_bytes(), &[0b1110_0100]);
        let mut work = WorkCounters::default();
        let (micro, states) = c
            .states_counted(Slot::Micromap(0), 0.4, 0.4, 0.0, &mut work)
            .unwrap();
        assert_eq!(micro, BTreeSet::from([1]));
        assert_eq!(states, BTreeSet::from([OpacityState::Opaque]));
        assert_eq!(
            work,
            WorkCounters {
                blocks_decoded: 1,
                bytes_read: 1,
                indices_read: 0
            }
        );
        assert_eq!(c.all_states(0, &mut work).map(|s| s.len()), Ok(4));
        assert_eq!(work.blocks_decoded, 2);
        // A start past the end is clamped: no data.
        let past = MicromapContent::at(c.triangles.clone(), memory, 99);
        assert_eq!(past.data_bytes(), &[] as &[u8]);
        assert_eq!(
            past.all_states(0, &mut work),
            Err(LookupError::DataOutOfRange { m: 0 })
        );
    }

    #[test]
    fn triangle_entries_view_the_bytes_at_their_stride() {
        let t = |data_offset, subdivision_level, format| MicromapTriangle {
            data_offset,
            subdivision_level,
            format,
        };
        // Two entries at stride 12, four bytes in: 4 + 12 + 8 = 24 bytes.
        let mut bytes = vec![0xEEu8; 24];
        bytes[4..12].copy_from_slice(&t(7, 3, 2).to_bytes());
        bytes[16..24].copy_from_slice(&t(9, 1, 1).to_bytes());
        let memory: Bytes = Bytes::from(bytes);
        let view = TriangleEntries::shared(memory.clone(), 4, 12, 2).expect("inside");
        assert_eq!(view.len(), 2);
        assert_eq!(view.get(0), Some(t(7, 3, 2)));
        assert_eq!(view.get(1), Some(t(9, 1, 1)));
        assert_eq!(view.get(2), None);
        assert_eq!(view.format_level(0), Some(3 | 2 << 16));
        assert_eq!(view, vec![t(7, 3, 2), t(9, 1, 1)]);
        assert_eq!(view, TriangleEntries::from(vec![t(7, 3, 2), t(9, 1, 1)]));
        // A third entry would end at byte 36, past the 24 there are.
        assert!(TriangleEntries::shared(memory.clone(), 4, 12, 3).is_none());
        assert!(TriangleEntries::shared(memory, 0, u64::MAX, 2).is_none());
        let mut first = view.clone();
        first.truncate(1);
        assert_eq!(first, vec![t(7, 3, 2)]);
    }

    #[test]
    fn stride_zero_content_serves_every_triangle_from_one_entry() {
        let c = content().repeating(1 << 40);
        assert_eq!(
            c.states(Slot::Micromap((1 << 40) - 1), 0.4, 0.4, 0.0),
            Ok(BTreeSet::from([OpacityState::Opaque]))
        );
        assert!(matches!(
            c.states(Slot::Micromap(1 << 40), 0.4, 0.4, 0.0),
            Err(LookupError::TriangleOutOfRange { .. })
        ));
    }

    #[test]
    fn bad_slots_and_data_are_errors_not_panics() {
        let c = content();
        assert_eq!(
            c.states(Slot::Micromap(3), 0.1, 0.1, 0.0),
            Err(LookupError::TriangleOutOfRange { m: 3, count: 3 })
        );
        assert_eq!(
            c.states(Slot::Micromap(u64::MAX), 0.1, 0.1, 0.0),
            Err(LookupError::TriangleOutOfRange {
                m: u64::MAX,
                count: 3
            })
        );
        assert_eq!(
            c.states(Slot::Micromap(2), 0.1, 0.1, 0.0),
            Err(LookupError::DataOutOfRange { m: 2 })
        );
        assert_eq!(
            c.states(Slot::Micromap(0), f32::NAN, 0.1, 0.0),
            Err(LookupError::Barycentrics(BaryError::NotANumber))
        );
    }
}
