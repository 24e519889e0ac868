//! "Did you mean" suggestions for names a user mistyped: a call, an enum
//! value, a scene object, a VUID.

/// How alike two names must be for one to be suggested for the other: the
/// normalized Damerau-Levenshtein similarity of their lower-case forms (1
/// minus the edits, a transposition counting one, over the longer length).
/// Below this, suggestions are noise: `vkCmdDraw` for `omm-input`.
const MIN_SIMILARITY: f64 = 0.5;

/// At most `limit` of `candidates` that are close to `wanted`, closest first
/// (ties keep the candidates' order). Case is ignored.
pub fn closest<'a>(
    wanted: &str,
    candidates: impl IntoIterator<Item = &'a str>,
    limit: usize,
) -> Vec<&'a str> {
    let wanted = Profiled::new(wanted);
    // The exact similarity costs time in the product of the two lengths,
    // and thousands of candidates (every `VkStructureType`) share long
    // prefixes. A bound that costs a candidate's length alone orders them;
    // the exact similarity is computed, best bound first, only until no
    // candidate left can beat (or tie with) the `limit` best found.
    let mut bounded: Vec<(f64, usize, &str, Profiled)> = candidates
        .into_iter()
        .enumerate()
        .filter_map(|(order, c)| {
            let candidate = Profiled::new(c);
            let bound = wanted.similarity_at_most(&candidate);
            (bound >= MIN_SIMILARITY).then_some((bound, order, c, candidate))
        })
        .collect();
    bounded.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    // (similarity, order, name), closest first, ties in the candidates' order.
    let mut scored: Vec<(f64, usize, &str)> = Vec::new();
    for (bound, order, name, candidate) in bounded {
        if limit == 0 || (scored.len() >= limit && bound < scored[limit - 1].0) {
            break;
        }
        let score = strsim::normalized_damerau_levenshtein(&wanted.lower, &candidate.lower);
        if score >= MIN_SIMILARITY && !scored.iter().any(|(_, _, n)| *n == name) {
            scored.push((score, order, name));
            scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            scored.truncate(limit);
        }
    }
    scored
        .into_iter()
        .take(limit)
        .map(|(_, _, name)| name)
        .collect()
}

/// A name's lower-case form with what bounds its edit distance to another
/// cheaply: its length in characters and how many of its characters fall
/// in each of 64 buckets.
struct Profiled {
    lower: String,
    chars: usize,
    buckets: [u32; 64],
}

impl Profiled {
    fn new(name: &str) -> Self {
        let lower = name.to_lowercase();
        let mut buckets = [0u32; 64];
        let mut chars = 0usize;
        for c in lower.chars() {
            chars += 1;
            let bucket = &mut buckets[(c as u32 % 64) as usize];
            *bucket = bucket.saturating_add(1);
        }
        Self {
            lower,
            chars,
            buckets,
        }
    }

    /// An upper bound of the normalized Damerau-Levenshtein similarity of
    /// the two names. The distance is at least the difference of their
    /// lengths, and at least half the characters the two do not share by
    /// bucket: an insertion or deletion changes one bucket's count by one,
    /// a substitution two counts, a transposition none.
    fn similarity_at_most(&self, other: &Profiled) -> f64 {
        let longer = self.chars.max(other.chars);
        if longer == 0 {
            return 1.0;
        }
        let unshared: u64 = self
            .buckets
            .iter()
            .zip(&other.buckets)
            .map(|(a, b)| u64::from(a.abs_diff(*b)))
            .sum();
        let by_length = self.chars.abs_diff(other.chars) as u64;
        let distance_at_least = by_length.max(unshared.div_ceil(2));
        1.0 - distance_at_least as f64 / longer as f64
    }
}

/// `did you mean `a`?` or `did you mean `a`, `b` or `c`?` for the closest
/// candidates, or None when none is close.
pub fn did_you_mean<'a>(
    wanted: &str,
    candidates: impl IntoIterator<Item = &'a str>,
    limit: usize,
) -> Option<String> {
    sentence(&closest(wanted, candidates, limit))
}

/// `did you mean `a`, `b` or `c`?` for names already chosen; None for none.
pub fn sentence(names: &[&str]) -> Option<String> {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    match quoted.as_slice() {
        [] => None,
        [one] => Some(format!("did you mean {one}?")),
        [rest @ .., last] => Some(format!("did you mean {} or {last}?", rest.join(", "))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CALLS: [&str; 4] = [
        "vkCmdBuildMicromapsEXT",
        "vkBuildMicromapsEXT",
        "vkCmdCopyMicromapEXT",
        "vkCmdDraw",
    ];

    #[test]
    fn the_closest_come_first_and_far_names_not_at_all() {
        assert_eq!(
            closest("vkCmdBuildMicromapEXT", CALLS, 2),
            ["vkCmdBuildMicromapsEXT", "vkBuildMicromapsEXT"]
        );
        assert_eq!(closest("omm-input", CALLS, 3), Vec::<&str>::new());
    }

    #[test]
    fn case_is_ignored() {
        assert_eq!(
            closest("VKCMDDRAW", CALLS, 1),
            ["vkCmdDraw"],
            "an exact match in another case is the closest"
        );
    }

    #[test]
    fn sentences_list_one_or_several() {
        assert_eq!(
            did_you_mean("vkCmdDraww", CALLS, 1).as_deref(),
            Some("did you mean `vkCmdDraw`?")
        );
        assert_eq!(
            did_you_mean("vkCmdBuildMicromapEXT", CALLS, 3).as_deref(),
            Some("did you mean `vkCmdBuildMicromapsEXT`, `vkBuildMicromapsEXT` or `vkCmdCopyMicromapEXT`?")
        );
        assert_eq!(did_you_mean("zzz", CALLS, 3), None);
    }

    #[test]
    fn the_bound_never_rules_out_a_name_the_exact_similarity_keeps() {
        let names = [
            "vkCmdBuildMicromapsEXT",
            "VK_STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT",
            "vkCmdDraw",
            "abc",
            "",
            "ÄÖÜ-naïve",
            "ba",
        ];
        let edits = [
            "vkCmdBuildMicromapEXT",
            "VK_STRUCTURE_TYPE_MICROMAP_BIULD_INFO_EXT",
            "vkCmdDrwa",
            "cab",
            "x",
            "äöü-naive",
            "ab",
            "omm-input",
        ];
        for a in names.iter().chain(&edits) {
            for b in names.iter().chain(&edits) {
                let exact =
                    strsim::normalized_damerau_levenshtein(&a.to_lowercase(), &b.to_lowercase());
                let bound = Profiled::new(a).similarity_at_most(&Profiled::new(b));
                assert!(
                    bound + 1e-12 >= exact,
                    "{a:?} vs {b:?}: bound {bound} below the exact {exact}"
                );
            }
        }
    }

    /// Every candidate scored exactly, as `closest` did before it had a
    /// bound: what it must still return.
    fn closest_by_every_score<'a>(
        wanted: &str,
        candidates: &[&'a str],
        limit: usize,
    ) -> Vec<&'a str> {
        let wanted = wanted.to_lowercase();
        let mut scored: Vec<(f64, &str)> = candidates
            .iter()
            .map(|c| {
                (
                    strsim::normalized_damerau_levenshtein(&wanted, &c.to_lowercase()),
                    *c,
                )
            })
            .filter(|(score, _)| *score >= MIN_SIMILARITY)
            .collect();
        scored.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut out: Vec<&str> = Vec::new();
        for (_, name) in scored {
            if out.len() < limit && !out.contains(&name) {
                out.push(name);
            }
        }
        out
    }

    #[test]
    fn the_bound_changes_no_suggestion() {
        let candidates = [
            "VK_STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT",
            "VK_STRUCTURE_TYPE_MICROMAP_CREATE_INFO_EXT",
            "VK_STRUCTURE_TYPE_MICROMAP_VERSION_INFO_EXT",
            "VK_STRUCTURE_TYPE_COPY_MICROMAP_INFO_EXT",
            "VK_STRUCTURE_TYPE_MICROMAP_BUILD_SIZES_INFO_EXT",
            "VK_STRUCTURE_TYPE_MICROMAP_BUILD_INFO_EXT",
            "vkCmdBuildMicromapsEXT",
            "vkBuildMicromapsEXT",
            "ab",
            "ba",
            "abc",
            "cab",
        ];
        let wanted = [
            "VK_STRUCTURE_TYPE_MICROMAP_BUILD_INFO",
            "VK_STRUCTURE_TYPE_MICROMAP_INFO_EXT",
            "VK_STRUCTURE_TYPE_MICROMAP_BIULD_SIZES_INFO_EXT",
            "vk_structure_type_copy_micromap_info",
            "vkCmdBuildMicromapEXT",
            "ab",
            "ac",
            "zzz",
            "",
        ];
        for w in wanted {
            for limit in 0..4 {
                assert_eq!(
                    closest(w, candidates, limit),
                    closest_by_every_score(w, &candidates, limit),
                    "{w:?}, limit {limit}"
                );
            }
        }
    }

    #[test]
    fn a_very_long_name_is_compared_with_no_candidate() {
        // Past twice the longest candidate no candidate can be close, and
        // the bound says so without the product of the lengths.
        let long = "v".repeat(1 << 20);
        assert_eq!(closest(&long, CALLS, 3), Vec::<&str>::new());
    }
}
