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
    let wanted = wanted.to_lowercase();
    let mut scored: Vec<(f64, &str)> = candidates
        .into_iter()
        .map(|c| {
            (
                strsim::normalized_damerau_levenshtein(&wanted, &c.to_lowercase()),
                c,
            )
        })
        .filter(|(score, _)| *score >= MIN_SIMILARITY)
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut out: Vec<&str> = Vec::with_capacity(limit);
    for (_, name) in scored {
        if out.len() == limit {
            break;
        }
        if !out.contains(&name) {
            out.push(name);
        }
    }
    out
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
}
