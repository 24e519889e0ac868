//! One misplaced usage count, one finding with a hint: where the usage
//! counts give a (format, subdivision level) key triangles the micromap
//! (or the geometry) lacks, and exactly one neighbouring key holds just as
//! many triangles more than its counts say, the count was most likely
//! written under the wrong key. Both keys' mismatches come from that one
//! mistake: the findings report them as one, with `Did you mean level 3?`.
//! A key no usage count may have (a format the micromap's type does not
//! define, a level above the device's limit) is never suggested: there the
//! triangles are what is wrong, and their own rules say so.

use std::collections::BTreeMap;

use crate::checks::usage_keys::{self, UsageKeys};
use crate::device::Limits;
use crate::model::values::FormatKind;

/// A (format, subdivision level) usage-count key.
pub(crate) type Key = (u32, u32);

/// A count written under `wrong` that belongs under `meant`: `count` of
/// the `said` triangles the usage counts give `wrong` are triangles of
/// `meant`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Misplaced {
    pub wrong: Key,
    pub meant: Key,
    pub count: u64,
    pub said: u64,
}

/// Whether `a` and `b` differ in the level alone or in the format alone.
fn neighbours(a: Key, b: Key) -> bool {
    (a.0 == b.0) != (a.1 == b.1)
}

/// Whether a usage count may have `key`: a format of the micromap's type
/// (`names`) at a level within the device's limit for it.
pub(crate) fn valid_key(key: Key, names: FormatKind, limits: &Limits) -> bool {
    let opacity = names != FormatKind::DisplacementNv;
    UsageKeys::ext(opacity, usage_keys::ext_usage_maxima(limits)).allows(key.0, key.1)
}

/// The misplaced counts of `declared` (per key, the counts' sum) against
/// `found` (per key, the triangles): each key that `declared` gives `d`
/// more triangles than `found` holds, paired with the one neighbouring key
/// `valid` allows of which `found` holds `d` more than `declared` says,
/// where neither key could pair with another. Ambiguous cases give no pair.
pub(crate) fn misplaced(
    declared: &BTreeMap<Key, u64>,
    found: &BTreeMap<Key, u64>,
    valid: impl Fn(Key) -> bool,
) -> Vec<Misplaced> {
    let said = |key: &Key| declared.get(key).copied().unwrap_or(0);
    let has = |key: &Key| found.get(key).copied().unwrap_or(0);
    let short: Vec<(Key, u64)> = declared
        .keys()
        .filter(|k| said(k) > has(k))
        .map(|k| (*k, said(k) - has(k)))
        .collect();
    let over: Vec<(Key, u64)> = found
        .keys()
        .filter(|k| has(k) > said(k) && valid(**k))
        .map(|k| (*k, has(k) - said(k)))
        .collect();
    let matches = |a: &(Key, u64), b: &(Key, u64)| a.1 == b.1 && neighbours(a.0, b.0);
    // `over` holds valid keys only (a few dozen), `short` as many keys as
    // the usage counts give: one pass over `short` counts the shorts
    // matching each over-key, so the work stays linear in the counts.
    let mut matched_by = vec![0usize; over.len()];
    for s in &short {
        for (k, o) in over.iter().enumerate() {
            if matches(s, o) {
                matched_by[k] += 1;
            }
        }
    }
    let mut pairs = Vec::new();
    for s in &short {
        let mut candidates = over.iter().enumerate().filter(|(_, o)| matches(s, o));
        let (Some((k, o)), None) = (candidates.next(), candidates.next()) else {
            continue;
        };
        if matched_by[k] == 1 {
            pairs.push(Misplaced {
                wrong: s.0,
                meant: o.0,
                count: s.1,
                said: said(&s.0),
            });
        }
    }
    pairs
}

/// `Did you mean level 3?` (or the other format's name; `... for 1 of
/// these 3 triangles?` where only some of the key's count is misplaced),
/// for a finding at the key a count was misplaced under.
pub(crate) fn hint(misplaced: &Misplaced, names: FormatKind) -> String {
    let (wrong, meant) = (misplaced.wrong, misplaced.meant);
    let key = if wrong.0 == meant.0 {
        format!("level {}", meant.1)
    } else {
        names.name(meant.0)
    };
    if misplaced.count == misplaced.said {
        format!("Did you mean {key}?")
    } else {
        format!(
            "Did you mean {key} for {} of these {} triangles?",
            misplaced.count, misplaced.said
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(entries: &[(u32, u32, u64)]) -> BTreeMap<Key, u64> {
        entries.iter().map(|&(f, l, c)| ((f, l), c)).collect()
    }

    /// [`misplaced`] with every key valid.
    fn misplaced_any(declared: &BTreeMap<Key, u64>, found: &BTreeMap<Key, u64>) -> Vec<Misplaced> {
        misplaced(declared, found, |_| true)
    }

    #[test]
    fn keys_no_count_may_have_are_never_meant() {
        let limits = crate::Profile::SpecMinimum.limits();
        let opacity = FormatKind::OpacityExt;
        // A triangle of format 5 (none) where the counts say 4-state.
        let (declared, found) = (map(&[(2, 1, 1)]), map(&[(5, 1, 1)]));
        assert_eq!(misplaced_any(&declared, &found).len(), 1);
        assert!(misplaced(&declared, &found, |k| valid_key(k, opacity, &limits)).is_empty());
        // A level above the limit, and the limit itself.
        let max = limits.max_opacity4_state_subdivision_level;
        assert!(!valid_key((2, max + 1), opacity, &limits));
        assert!(valid_key((2, max), opacity, &limits));
        // Format 0 is no format of either kind.
        assert!(!valid_key((0, 0), opacity, &limits));
        assert!(!valid_key((0, 0), FormatKind::DisplacementNv, &limits));
    }

    #[test]
    fn a_count_under_the_wrong_level_pairs_with_the_level_meant() {
        // Counts: 1 at level 1, 1 at level 2; triangles: 2 at level 1.
        let pairs = misplaced_any(&map(&[(2, 1, 1), (2, 2, 1)]), &map(&[(2, 1, 2)]));
        assert_eq!(
            pairs,
            [Misplaced {
                wrong: (2, 2),
                meant: (2, 1),
                count: 1,
                said: 1,
            }]
        );
        assert_eq!(
            hint(&pairs[0], FormatKind::OpacityExt),
            "Did you mean level 1?"
        );
        // Part of a key's count: three 2-state triangles said, two held,
        // one 4-state said, two held.
        let pairs = misplaced_any(&map(&[(1, 3, 3), (2, 3, 1)]), &map(&[(1, 3, 2), (2, 3, 2)]));
        assert_eq!(
            hint(&pairs[0], FormatKind::OpacityExt),
            "Did you mean VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT for 1 of these 3 triangles?"
        );
        // The other format at the same level.
        let pairs = misplaced_any(&map(&[(1, 3, 4)]), &map(&[(2, 3, 4)]));
        assert_eq!(
            hint(&pairs[0], FormatKind::OpacityExt),
            "Did you mean VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT?"
        );
    }

    #[test]
    fn no_hint_where_the_fix_is_not_clear() {
        // Counts that match.
        assert!(misplaced_any(&map(&[(2, 1, 2)]), &map(&[(2, 1, 2)])).is_empty());
        // The surplus is not the shortfall.
        assert!(misplaced_any(&map(&[(2, 2, 2)]), &map(&[(2, 1, 1)])).is_empty());
        // Two keys could be meant.
        assert!(misplaced_any(&map(&[(2, 2, 1)]), &map(&[(2, 1, 1), (2, 3, 1)])).is_empty());
        // Another format at another level is no neighbour.
        assert!(misplaced_any(&map(&[(1, 2, 1)]), &map(&[(2, 3, 1)])).is_empty());
        // Two shortfalls could have gone to one key.
        assert!(misplaced_any(&map(&[(2, 2, 1), (2, 3, 1)]), &map(&[(2, 1, 1)])).is_empty());
        // As many shortfalls as usage counts may hold, all neighbours of the
        // one surplus: none is the one meant (and the pairing stays linear).
        let many: BTreeMap<Key, u64> = (100..100 + (1u32 << 16)).map(|l| ((2, l), 1)).collect();
        assert!(misplaced_any(&many, &map(&[(2, 1, 1)])).is_empty());
    }
}
