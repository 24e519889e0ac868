//! Each triangle array entry's (format, level) key as a one-byte id into
//! the micromap's few distinct keys. Worked out once per micromap (one pass
//! over its entries) and kept with its content, so that tallying what an
//! index buffer selects per key reads one byte per reference, or, where the
//! micromap has a single key, nothing at all.

use std::sync::OnceLock;

use crate::sim::decode::TriangleEntries;

/// The distinct keys of a triangle array (`subdivisionLevel | format <<
/// 16`, as [`TriangleEntries::format_level`] gives them) and each entry's.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TriangleKeys {
    /// In order of first occurrence; at most [`Self::MAX_KEYS`].
    distinct: Vec<u32>,
    /// Entry `m`'s key is `distinct[ids[m]]`; empty where there is one key
    /// (or none), which every entry then has.
    ids: Vec<u8>,
}

impl TriangleKeys {
    /// Ids are one byte.
    pub const MAX_KEYS: usize = 1 << 8;

    /// The keys of an empty array (a NULL micromap has no triangles).
    pub const NONE: Self = Self {
        distinct: Vec::new(),
        ids: Vec::new(),
    };

    /// The keys of `entries`; None where they hold more than
    /// [`Self::MAX_KEYS`] distinct keys (only possible with formats or
    /// levels no valid build has).
    pub fn of(entries: &TriangleEntries) -> Option<Self> {
        let (array, stride, len) = entries.raw();
        let mut keys = Self {
            distinct: Vec::new(),
            ids: Vec::new(),
        };
        let (mut last_key, mut last_id) = (None, 0u8);
        for m in 0..len {
            // Inside `array`: `TriangleEntries` checked the last entry's end.
            let at = m * stride + 4;
            let key = u32::from_le_bytes(array.get(at..at + 4)?.try_into().ok()?);
            if last_key != Some(key) {
                last_id = match keys.distinct.iter().position(|k| *k == key) {
                    Some(id) => id as u8,
                    None => {
                        if keys.distinct.len() == Self::MAX_KEYS {
                            return None;
                        }
                        keys.distinct.push(key);
                        if keys.distinct.len() == 2 {
                            // A second key: every entry so far had the first.
                            keys.ids = Vec::with_capacity(len);
                            keys.ids.resize(m, 0);
                        }
                        (keys.distinct.len() - 1) as u8
                    }
                };
                last_key = Some(key);
            }
            if keys.distinct.len() > 1 {
                keys.ids.push(last_id);
            }
        }
        Some(keys)
    }

    /// The distinct keys, in order of first occurrence.
    pub fn distinct(&self) -> &[u32] {
        &self.distinct
    }

    /// Each entry's id into [`Self::distinct`]; empty where all entries
    /// share one key.
    pub fn ids(&self) -> &[u8] {
        &self.ids
    }
}

/// [`TriangleKeys`] worked out on first use and kept. Two contents compare
/// alike whatever their caches hold: the cache is derived from the entries.
#[derive(Clone, Debug, Default)]
pub struct KeysCache(OnceLock<Option<TriangleKeys>>);

impl KeysCache {
    /// The keys of `entries`, which must be the entries this cache belongs to.
    pub fn get_or_work_out(&self, entries: &TriangleEntries) -> Option<&TriangleKeys> {
        self.0.get_or_init(|| TriangleKeys::of(entries)).as_ref()
    }
}

impl PartialEq for KeysCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl Eq for KeysCache {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::MicromapTriangle;

    fn entries(keys: &[(u16, u16)]) -> TriangleEntries {
        let triangles: Vec<MicromapTriangle> = keys
            .iter()
            .map(|&(format, subdivision_level)| MicromapTriangle {
                data_offset: 0,
                subdivision_level,
                format,
            })
            .collect();
        TriangleEntries::from(triangles)
    }

    #[test]
    fn one_key_needs_no_ids_and_several_give_each_entry_its_own() {
        let one = TriangleKeys::of(&entries(&[(2, 3), (2, 3), (2, 3)])).expect("few keys");
        assert_eq!(one.distinct(), [3 | 2 << 16]);
        assert!(one.ids().is_empty());
        let none = TriangleKeys::of(&entries(&[])).expect("no keys");
        assert!(none.distinct().is_empty() && none.ids().is_empty());
        let several =
            TriangleKeys::of(&entries(&[(2, 3), (2, 3), (1, 0), (2, 3), (7, 9)])).expect("few");
        assert_eq!(several.distinct(), [3 | 2 << 16, 1 << 16, 9 | 7 << 16]);
        assert_eq!(several.ids(), [0, 0, 1, 0, 2]);
    }

    #[test]
    fn more_keys_than_one_byte_names_have_no_ids() {
        let levels: Vec<(u16, u16)> = (0..=256).map(|l| (1, l)).collect();
        assert!(TriangleKeys::of(&entries(&levels[..256])).is_some());
        assert!(TriangleKeys::of(&entries(&levels)).is_none());
    }
}
