//! What `ommcheck vuid` says about a rule: a catalog VUID or a rule of ours,
//! looked up by its id in any case or by its bare number, with whether
//! ommcheck enforces it, the tier that decides it, why it is not decidable
//! where it is not, and whether the Khronos validation layer checks it.
//! Everything comes from the catalog, the check modules' coverage
//! declarations and the tiers measured over the corpus.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use ommcheck_vuids::{Vuid, VuidKind};

use crate::coverage::{self, Status};
use crate::rules::{self, OwnRule};
use crate::suggest;

/// A rule ommcheck knows of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    Vuid(Vuid),
    Own(&'static OwnRule),
}

impl Rule {
    pub fn id(self) -> &'static str {
        match self {
            Rule::Vuid(v) => v.id(),
            Rule::Own(rule) => rule.id,
        }
    }
}

/// Why a query found nothing, with the closest ids.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotFound {
    pub query: String,
    pub suggestions: Vec<&'static str>,
}

/// How many near ids an unknown query suggests.
const SUGGESTIONS: usize = 3;

/// Every id `ommcheck vuid` answers to: the catalog's VUIDs and our rules.
fn all_ids() -> impl Iterator<Item = &'static str> {
    Vuid::all()
        .map(Vuid::id)
        .chain(rules::ALL.iter().map(|r| r.id))
}

/// The rules `query` names: a VUID or `OMMCHECK-` id in any case (the
/// `VUID-` prefix may be left out), or a bare number such as `07516` or
/// `7516`, which names every VUID ending in that number.
pub fn lookup(query: &str) -> Result<Vec<Rule>, NotFound> {
    let query = query.trim();
    let found: Vec<Rule> = if !query.is_empty() && query.bytes().all(|b| b.is_ascii_digit()) {
        let number: Option<u32> = query.parse().ok();
        Vuid::all()
            .filter(|v| v.info().kind == VuidKind::Explicit && v.info().number() == number)
            .map(Rule::Vuid)
            .collect()
    } else {
        let with_prefix = |id: &str| {
            id.eq_ignore_ascii_case(query)
                || id
                    .get(5..)
                    .is_some_and(|rest| rest.eq_ignore_ascii_case(query))
        };
        rules::ALL
            .iter()
            .filter(|r| r.id.eq_ignore_ascii_case(query))
            .map(|r| Rule::Own(r))
            .chain(Vuid::all().filter(|v| with_prefix(v.id())).map(Rule::Vuid))
            .collect()
    };
    if found.is_empty() {
        Err(NotFound {
            query: query.to_string(),
            suggestions: suggest::closest(query, all_ids(), SUGGESTIONS),
        })
    } else {
        Ok(found)
    }
}

/// Whether ommcheck enforces the rule, and that in words.
fn enforcement(rule: Rule) -> (bool, String) {
    static STATUSES: std::sync::OnceLock<BTreeMap<Vuid, Status>> = std::sync::OnceLock::new();
    match rule {
        Rule::Own(_) => (true, "enforced (a rule of ours)".to_string()),
        Rule::Vuid(v) => match STATUSES.get_or_init(coverage::statuses).get(&v) {
            Some(Status::Enforced(module)) => (true, format!("enforced (checks::{module})")),
            Some(Status::LayerOnly(module, needs)) => (
                true,
                format!("enforced in the layer only (checks::{module}): {needs}"),
            ),
            Some(Status::NotDecidable(reason)) => (
                false,
                format!("not enforced: not decidable at the API boundary: {reason}"),
            ),
            Some(Status::NotYet) | None => (false, "not enforced yet".to_string()),
        },
    }
}

/// The tier line: which tier decides the rule, or why none is given.
fn tier_line(rule: Rule, enforced: bool) -> String {
    match coverage::measured_tier(rule.id()) {
        Some(tier) => format!("decided from the {tier} tier up (`--tier {tier}`)"),
        None if enforced => {
            "not measured: the corpus has no failing scene for it (raw-memory rules are checked by the layer and the static checker)".to_string()
        }
        None => "none".to_string(),
    }
}

/// The text `ommcheck vuid` prints for one rule.
pub fn render(rule: Rule) -> String {
    let mut out = String::new();
    let w = &mut out;
    let (enforced, enforcement) = enforcement(rule);
    let _ = writeln!(w, "{}", rule.id());
    match rule {
        Rule::Vuid(v) => {
            let info = v.info();
            let kind = match info.kind {
                VuidKind::Explicit => "explicit",
                VuidKind::Implicit => "implicit",
            };
            let _ = writeln!(w, "  parent:     {} ({kind} VUID)", info.parent);
            let _ = writeln!(
                w,
                "  extensions: {}",
                info.extensions
                    .extension_names()
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            let _ = writeln!(w, "  ommcheck:   {enforcement}");
            let _ = writeln!(w, "  tier:       {}", tier_line(rule, enforced));
            let khronos = match info.khronos_layer_checks {
                Some(true) => "checks it",
                Some(false) => "does not check it",
                None => "not known",
            };
            let _ = writeln!(w, "  Khronos validation layer: {khronos}");
            let _ = writeln!(w, "  statement:  {}", info.text);
            let _ = writeln!(w, "  link:       {}", info.link());
        }
        Rule::Own(own) => {
            let _ = writeln!(w, "  ommcheck:   {enforcement}");
            let _ = writeln!(w, "  tier:       {}", tier_line(rule, enforced));
            let _ = writeln!(
                w,
                "  Khronos validation layer: does not check it (the specification states it without a VUID)"
            );
            let _ = writeln!(w, "  statement:  {}", own.statement);
            let _ = writeln!(w, "  link:       {}", own.link);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use ommcheck_vuids::vuid;

    #[test]
    fn ids_are_found_in_any_case_and_without_the_prefix() {
        let v = Rule::Vuid(vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516);
        for query in [
            "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516",
            "vuid-vkmicromapbuildinfoext-pusagecounts-07516",
            "VkMicromapBuildInfoEXT-pUsageCounts-07516",
        ] {
            assert_eq!(lookup(query), Ok(vec![v]), "{query}");
        }
        assert_eq!(
            lookup("ommcheck-attach-index-in-range"),
            Ok(vec![Rule::Own(&rules::INDEX_IN_RANGE)])
        );
    }

    #[test]
    fn a_bare_number_lists_every_vuid_with_it() {
        let found = lookup("07516").unwrap();
        let expected: Vec<Rule> = Vuid::all()
            .filter(|v| v.id().ends_with("-07516"))
            .map(Rule::Vuid)
            .collect();
        assert!(!expected.is_empty());
        assert_eq!(found, expected);
        assert_eq!(lookup("7516"), Ok(expected));
        // 11636 is stated once per shader-running command.
        assert!(lookup("11636").unwrap().len() > 10);
    }

    #[test]
    fn unknown_ids_suggest_the_closest() {
        let error = lookup("VUID-VkMicromapBuildInfoEXT-pUsageCount-07516").unwrap_err();
        assert_eq!(
            error.suggestions[0],
            "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516"
        );
        assert!(error.suggestions.len() <= SUGGESTIONS);
        let own = lookup("OMMCHECK-attach-index-in-rnage").unwrap_err();
        assert_eq!(own.suggestions[0], "OMMCHECK-attach-index-in-range");
        assert!(lookup("99999").is_err());
        assert!(lookup("").is_err());
    }

    #[test]
    fn the_text_says_enforcement_tier_and_khronos() {
        let text = render(Rule::Vuid(vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516));
        assert!(text.contains("ommcheck:   enforced (checks::"), "{text}");
        let tier = coverage::measured_tier("VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516")
            .expect("the corpus has a failing scene for 07516");
        assert!(
            text.contains(&format!("tier:       decided from the {tier} tier up")),
            "{text}"
        );
        assert!(
            text.contains("Khronos validation layer: checks it"),
            "{text}"
        );

        let own = render(Rule::Own(&rules::HISTOGRAM_MISMATCH));
        assert!(own.contains("decided from the content tier up"), "{own}");
        assert!(own.contains("Khronos validation layer: does not check it"));
    }

    #[test]
    fn undecidable_vuids_say_why() {
        // None is left since the serialization provenance rules were
        // decided; any that comes back must say why.
        for (v, reason) in crate::checks::coverage()
            .iter()
            .flat_map(|c| c.not_decidable.iter())
            .copied()
        {
            let text = render(Rule::Vuid(v));
            assert!(
                text.contains(&format!("not decidable at the API boundary: {reason}")),
                "{text}"
            );
            assert!(text.contains("tier:       none"), "{text}");
        }
        let decided = render(Rule::Vuid(
            ommcheck_vuids::vuid::VkCopyMemoryToMicromapInfoEXT::src_07547,
        ));
        assert!(!decided.contains("not decidable"), "{decided}");
        assert!(!decided.contains("tier:       none"), "{decided}");
    }
}
