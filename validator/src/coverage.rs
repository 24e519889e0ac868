//! Which catalog VUIDs the checks enforce, which cannot be decided at the API
//! boundary (and why), and which are not done yet: `VUID-COVERAGE.md`.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;

use ommcheck_vuids::{Extensions, Vuid, VuidKind, REGISTRY_VERSION};

use crate::checks;
use crate::rules;
use crate::scene::{CheckOptions, Scene};
use crate::tier::Tier;

/// The corpus of failing and valid scenes, relative to the workspace root.
pub const CORPUS: &str = "tests/scenes/corpus";

/// The lowest tier at which each rule's failing scene in the corpus
/// (`<family>/<rule>.fail.json`) reports it: which tier decides the rule,
/// measured, not declared.
pub fn corpus_tiers(corpus: &std::path::Path) -> Result<BTreeMap<String, Tier>, String> {
    let entries = |dir: &std::path::Path| -> Result<Vec<std::path::PathBuf>, String> {
        let mut paths: Vec<_> = std::fs::read_dir(dir)
            .map_err(|e| format!("{}: {e}", dir.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .collect();
        paths.sort();
        Ok(paths)
    };
    let mut tiers = BTreeMap::new();
    for family in entries(corpus)?.into_iter().filter(|p| p.is_dir()) {
        for path in entries(&family)? {
            let Some(rule) = path
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_suffix(".fail.json"))
            else {
                continue;
            };
            let scene = Scene::load(&path).map_err(|e| e.to_string())?;
            let mut decided = None;
            for tier in Tier::ALL {
                let options = CheckOptions {
                    tier,
                    ..CheckOptions::default()
                };
                let report = scene.check(&options).map_err(|e| e.to_string())?;
                if report.report.ids().contains(&rule) {
                    decided = Some(tier);
                    break;
                }
            }
            let tier =
                decided.ok_or_else(|| format!("{}: reports {rule} at no tier", path.display()))?;
            // A rule with scenes in several families takes the lowest tier.
            let entry = tiers.entry(rule.to_string()).or_insert(tier);
            *entry = (*entry).min(tier);
        }
    }
    Ok(tiers)
}

/// The rules whose inputs include bytes a call reads (the content tier),
/// with what they read: a rule id, or for the per-command work rules the
/// end of their VUIDs. Every other rule is decided by the parameters and
/// the tracked objects alone, so measuring it at the content tier means a
/// check waits for bytes it does not need. The simulate tier's rules are
/// [`rules::SIMULATE_TIER`].
pub static READS_CONTENTS: &[(&str, &str)] = &[
    (
        "VUID-VkCopyMemoryToAccelerationStructureInfoKHR-src-11583",
        "the serialized header's blocks",
    ),
    (
        "VUID-VkCopyMemoryToAccelerationStructureInfoKHR-dst-11584",
        "the serialized header's blocks",
    ),
    (
        "VUID-VkCopyMemoryToAccelerationStructureInfoKHR-dst-11585",
        "the serialized header's blocks",
    ),
    (
        "VUID-VkCopyMemoryToMicromapInfoEXT-src-07549",
        "the serialized data's version (its first 32 bytes)",
    ),
    (
        "VUID-VkCopyAccelerationStructureToMemoryInfoKHR-src-11582",
        "the micromap addresses of the serialized header the structure was deserialized from",
    ),
    (
        "VUID-vkCopyAccelerationStructureKHR-src-11587",
        "the micromap addresses of the serialized header the structure was deserialized from",
    ),
    (
        "VUID-vkCmdCopyAccelerationStructureKHR-src-11634",
        "the micromap addresses of the serialized header the structure was deserialized from",
    ),
    (
        "-micromap-11637",
        "the micromap addresses of the serialized header the structure was deserialized from",
    ),
    (
        "OMMCHECK-build-usage-counts-match-triangles",
        "the triangle array's entries",
    ),
    (
        "OMMCHECK-build-triangle-data-in-range",
        "each entry's dataOffset, format and level",
    ),
    (
        "OMMCHECK-attach-null-micromap-special-only",
        "the index buffer",
    ),
    ("OMMCHECK-attach-index-in-range", "the index buffer"),
    (
        "OMMCHECK-attach-usage-counts-match-indices",
        "the index buffer and the micromap's entries",
    ),
    (
        "OMMCHECK-attach-cluster-index-outside-cluster",
        "the index buffer",
    ),
    (
        "VUID-VkAccelerationStructureBuildGeometryInfoKHR-format-11713",
        "the triangle array's entries",
    ),
    (
        "VUID-VkAccelerationStructureBuildGeometryInfoKHR-subdivisionLevel-11566",
        "the triangle array's entries",
    ),
    (
        "VUID-VkAccelerationStructureBuildGeometryInfoKHR-subdivisionLevel-11567",
        "the triangle array's entries",
    ),
    (
        "VUID-VkAccelerationStructureInstanceKHR-flags-11581",
        "the instances",
    ),
    (
        "VUID-VkAccelerationStructureInstanceKHR-micromap-11580",
        "the instances",
    ),
    (
        "VUID-VkMicromapBuildInfoEXT-format-11657",
        "the triangle array's entries",
    ),
    (
        "VUID-VkMicromapBuildInfoEXT-format-11658",
        "the triangle array's entries",
    ),
    (
        "VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11659",
        "the triangle array's entries",
    ),
    (
        "VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11660",
        "the triangle array's entries",
    ),
    (
        "VUID-VkMicromapBuildInfoEXT-subdivisionLevel-11661",
        "the triangle array's entries",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresIndirectKHR-pInfos-10607",
        "the instances",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresKHR-pInfos-10607",
        "the instances",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresKHR-indexBuffer-11575",
        "the index buffer",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresKHR-indexBuffer-11578",
        "the index buffer",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11553",
        "the triangle array's entries",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11555",
        "the triangle array's entries",
    ),
    (
        "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11556",
        "the triangle array's entries",
    ),
    (
        "-micromap-11638",
        "the index buffers the bound structures were built from (mixed special indices)",
    ),
    (
        "-micromap-11639",
        "the index buffers the bound structures were built from (mixed special indices)",
    ),
];

/// The lowest tier whose information can decide `rule`, as declared:
/// [`rules::SIMULATE_TIER`], then [`READS_CONTENTS`], else the state tier
/// (params and state are not told apart here).
pub fn needed_tier(rule: &str) -> Tier {
    if rules::SIMULATE_TIER.iter().any(|r| r.id == rule) {
        return Tier::Simulate;
    }
    let reads_contents = READS_CONTENTS.iter().any(|(id, _)| {
        if id.starts_with('-') {
            rule.starts_with("VUID-") && rule.ends_with(id)
        } else {
            rule == *id
        }
    });
    if reads_contents {
        Tier::Content
    } else {
        Tier::State
    }
}

/// The rules whose measured tier is above the one their inputs need, with
/// both tiers: a check that waits for information it does not use.
pub fn measured_above_needed(tiers: &BTreeMap<String, Tier>) -> Vec<(&str, Tier, Tier)> {
    tiers
        .iter()
        .filter_map(|(rule, &measured)| {
            let needed = needed_tier(rule);
            (measured > needed).then_some((rule.as_str(), measured, needed))
        })
        .collect()
}

/// Where `cargo xtask coverage` writes the tiers [`corpus_tiers`] measured,
/// relative to the workspace root; the crate embeds the file, so the CLI
/// (`ommcheck vuid`) can say which tier decides a rule without the corpus.
pub const TIERS_FILE: &str = "validator/src/coverage_tiers.json";

/// The measured tiers as written to [`TIERS_FILE`]: a JSON object of rule
/// id to tier name, sorted by id.
pub fn render_tiers(tiers: &BTreeMap<String, Tier>) -> String {
    let mut text = serde_json::to_string_pretty(tiers).unwrap_or_default();
    text.push('\n');
    text
}

/// The tier that decides `id` (a VUID or a rule of ours), as measured over
/// the corpus when [`TIERS_FILE`] was last generated; None for a rule
/// without a failing corpus scene.
pub fn measured_tier(id: &str) -> Option<Tier> {
    static TIERS: std::sync::OnceLock<BTreeMap<String, Tier>> = std::sync::OnceLock::new();
    TIERS
        .get_or_init(|| {
            // A test holds the file to the corpus; an unreadable one would be
            // a build defect, shown as "not measured" rather than a panic.
            serde_json::from_str(include_str!("coverage_tiers.json")).unwrap_or_default()
        })
        .get(id)
        .copied()
}

/// A VUID's status.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Status {
    /// Enforced by the named check module.
    Enforced(&'static str),
    /// Enforced by the named check module in the layer only: it needs what
    /// only the layer has (the second member says what), which scenes and
    /// the static API do not state.
    LayerOnly(&'static str, &'static str),
    /// Cannot be decided at the API boundary, for the reason given.
    NotDecidable(&'static str),
    /// Not checked yet.
    NotYet,
}

/// The status of every catalog VUID.
pub fn statuses() -> BTreeMap<Vuid, Status> {
    let mut out: BTreeMap<Vuid, Status> = Vuid::all().map(|v| (v, Status::NotYet)).collect();
    for module in checks::coverage() {
        for (v, reason) in module.not_decidable {
            out.insert(*v, Status::NotDecidable(reason));
        }
        for v in module.enforced {
            out.insert(*v, Status::Enforced(module.module));
        }
    }
    for (v, module, needs) in checks::layer_only() {
        out.insert(v, Status::LayerOnly(module, needs));
    }
    out
}

/// Counts for one group of VUIDs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    pub total: usize,
    /// Enforced anywhere, the layer-only ones included.
    pub enforced: usize,
    /// Of `enforced`, those only the layer decides.
    pub layer_only: usize,
    pub not_decidable: usize,
    pub khronos: usize,
}

impl Tally {
    fn add(&mut self, v: Vuid, status: &Status) {
        self.total += 1;
        match status {
            Status::Enforced(_) => self.enforced += 1,
            Status::LayerOnly(..) => {
                self.enforced += 1;
                self.layer_only += 1;
            }
            Status::NotDecidable(_) => self.not_decidable += 1,
            Status::NotYet => {}
        }
        self.khronos += usize::from(v.info().khronos_layer_checks == Some(true));
    }
}

/// Distinct explicit rules, counted by VUID number: (total, enforced on every
/// command they apply to, enforced on some, not decidable anywhere).
pub fn distinct_rules(statuses: &BTreeMap<Vuid, Status>) -> (usize, usize, usize, usize) {
    let mut by_number: BTreeMap<u32, Vec<&Status>> = BTreeMap::new();
    for (v, status) in statuses {
        if v.info().kind == VuidKind::Explicit {
            if let Some(n) = v.info().number() {
                by_number.entry(n).or_default().push(status);
            }
        }
    }
    let enforced = |s: &&Status| matches!(s, Status::Enforced(_) | Status::LayerOnly(..));
    let all = by_number
        .values()
        .filter(|s| s.iter().all(enforced))
        .count();
    let some = by_number
        .values()
        .filter(|s| s.iter().any(enforced))
        .count();
    let undecidable = by_number
        .values()
        .filter(|s| s.iter().all(|s| matches!(s, Status::NotDecidable(_))))
        .count();
    (by_number.len(), all, some, undecidable)
}

/// The markdown report; `tiers` is what [`corpus_tiers`] measured.
pub fn render(tiers: &BTreeMap<String, Tier>) -> String {
    let statuses = statuses();
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "# VUID coverage\n");
    let _ = writeln!(
        w,
        "Generated by `cargo xtask coverage` from the check modules' declarations and the catalog of Vulkan {REGISTRY_VERSION}; do not edit. \"Khronos\" counts the VUIDs the Khronos validation layer checks.\n"
    );
    let (mut explicit, mut implicit) = (Tally::default(), Tally::default());
    for (v, status) in &statuses {
        match v.info().kind {
            VuidKind::Explicit => explicit.add(*v, status),
            VuidKind::Implicit => implicit.add(*v, status),
        }
    }
    let (rules_total, rules_all, rules_some, rules_undecidable) = distinct_rules(&statuses);
    let _ = writeln!(
        w,
        "| | total | enforced | of which in the layer only | not decidable | not yet | Khronos |"
    );
    let _ = writeln!(w, "| --- | ---: | ---: | ---: | ---: | ---: | ---: |");
    for (name, t) in [("explicit VUIDs", explicit), ("implicit VUIDs", implicit)] {
        let _ = writeln!(
            w,
            "| {name} | {} | {} | {} | {} | {} | {} |",
            t.total,
            t.enforced,
            t.layer_only,
            t.not_decidable,
            t.total - t.enforced - t.not_decidable,
            t.khronos
        );
    }
    let _ = writeln!(
        w,
        "\nDistinct explicit rules (by VUID number): {rules_total}; enforced on every command they apply to: {rules_all}; on some: {rules_some}; not decidable: {rules_undecidable}.\n"
    );
    let _ = writeln!(
        w,
        "\"In the layer only\": enforced by the layer, which asks the driver or follows what the application maps, but not by scenes or the static API, which cannot state what the rule needs (the status of each says what); layer tests hold them, not corpus scenes.\n"
    );

    let _ = writeln!(w, "## Tiers\n");
    let _ = writeln!(
        w,
        "The tier a rule needs is measured: its failing scene in the corpus (`{CORPUS}`) is checked at each tier, and the lowest tier that reports the rule decides it. Each tier decides the rules of the tiers below it too. Rules without a corpus scene (the raw-memory rules) have no measured tier.\n"
    );
    let _ = writeln!(w, "| tier | sees | rules first decided | decided in all |");
    let _ = writeln!(w, "| --- | --- | ---: | ---: |");
    let mut all = 0;
    for tier in Tier::ALL {
        let first = tiers.values().filter(|t| **t == tier).count();
        all += first;
        let sees = match tier {
            Tier::Params => "the call's parameters and the device (extensions, features, limits)",
            Tier::State => "+ the objects earlier calls created (buffers, memory, addresses, micromaps, acceleration structures, pipelines, queries)",
            Tier::Content => "+ the bytes builds read (triangle arrays, usage counts against them, data offsets, index buffers, instances)",
            Tier::Simulate => "+ the micromap data blocks themselves (hygiene information) and traversal of the rays a user asks about",
        };
        let _ = writeln!(w, "| `{tier}` | {sees} | {first} | {all} |");
    }
    let _ = writeln!(w);
    let above = measured_above_needed(tiers);
    let _ = writeln!(
        w,
        "Rules measured above the tier their inputs need (declared in `validator/src/coverage.rs`, `READS_CONTENTS`): {}.\n",
        if above.is_empty() {
            "none".to_string()
        } else {
            above
                .iter()
                .map(|(rule, measured, needed)| format!("`{rule}` ({measured}, needs {needed})"))
                .collect::<Vec<_>>()
                .join(", ")
        }
    );

    let _ = writeln!(w, "## By extension\n");
    let _ = writeln!(
        w,
        "| stated under | total | enforced | not decidable | Khronos |"
    );
    let _ = writeln!(w, "| --- | ---: | ---: | ---: | ---: |");
    for (name, bit) in [
        ("VK_EXT_opacity_micromap", Extensions::EXT),
        ("VK_KHR_opacity_micromap", Extensions::KHR),
        ("VK_NV_displacement_micromap", Extensions::NV),
        ("VK_ARM_pipeline_opacity_micromap", Extensions::ARM),
    ] {
        let mut t = Tally::default();
        for (v, status) in statuses
            .iter()
            .filter(|(v, _)| v.info().extensions.contains(bit))
        {
            t.add(*v, status);
        }
        let _ = writeln!(
            w,
            "| {name} | {} | {} | {} | {} |",
            t.total, t.enforced, t.not_decidable, t.khronos
        );
    }

    let _ = writeln!(w, "\n## By parent\n");
    let _ = writeln!(w, "| parent | total | enforced | not decidable | Khronos |");
    let _ = writeln!(w, "| --- | ---: | ---: | ---: | ---: |");
    let mut by_parent: BTreeMap<&str, Tally> = BTreeMap::new();
    for (v, status) in &statuses {
        by_parent
            .entry(v.info().parent)
            .or_default()
            .add(*v, status);
    }
    for (parent, t) in &by_parent {
        let _ = writeln!(
            w,
            "| `{parent}` | {} | {} | {} | {} |",
            t.total, t.enforced, t.not_decidable, t.khronos
        );
    }

    let _ = writeln!(w, "\n## Rules of ours\n");
    let _ = writeln!(w, "| id | tier | enforces |");
    let _ = writeln!(w, "| --- | --- | --- |");
    for rule in rules::ALL {
        let _ = writeln!(
            w,
            "| `{}` | {} | {} |",
            rule.id,
            tiers.get(rule.id).map_or(String::new(), |t| t.to_string()),
            rule.statement.replace('|', "\\|")
        );
    }

    let _ = writeln!(w, "\n## Every VUID\n");
    let _ = writeln!(w, "| VUID | kind | status | tier | Khronos |");
    let _ = writeln!(w, "| --- | --- | --- | --- | --- |");
    let modules: BTreeSet<&str> = checks::coverage().iter().map(|c| c.module).collect();
    debug_assert!(!modules.is_empty());
    for (v, status) in &statuses {
        let status = match status {
            Status::Enforced(module) => format!("enforced (`{module}`)"),
            Status::LayerOnly(module, needs) => {
                format!("enforced in the layer only (`{module}`): {needs}")
            }
            Status::NotDecidable(reason) => format!("not decidable: {reason}"),
            Status::NotYet => "not yet".to_string(),
        };
        let kind = match v.info().kind {
            VuidKind::Explicit => "explicit",
            VuidKind::Implicit => "implicit",
        };
        let khronos = if v.info().khronos_layer_checks == Some(true) {
            "yes"
        } else {
            ""
        };
        let tier = tiers.get(v.id()).map_or(String::new(), |t| t.to_string());
        let _ = writeln!(
            w,
            "| `{}` | {kind} | {status} | {tier} | {khronos} |",
            v.id()
        );
    }
    out
}

/// Markers around the generated list of our rules in docs/rules.md.
pub const README_RULES_START: &str =
    "<!-- ommcheck-rules:start (generated by cargo xtask coverage) -->";
pub const README_RULES_END: &str = "<!-- ommcheck-rules:end -->";

/// The table of our rules (docs/rules.md): id, what it enforces, and where the
/// specification says so.
pub fn render_readme_rules() -> String {
    let mut out = String::from("| id | enforces | source |\n| --- | --- | --- |\n");
    for rule in rules::ALL {
        let _ = writeln!(
            out,
            "| `{}` | {} | {} |",
            rule.id,
            rule.statement.replace('|', "\\|"),
            rule.link
        );
    }
    out
}

/// `readme` with the text between the rule markers replaced; None when the
/// markers are missing.
pub fn update_readme(readme: &str) -> Option<String> {
    let start = readme.find(README_RULES_START)? + README_RULES_START.len();
    let end = readme[start..].find(README_RULES_END)? + start;
    Some(format!(
        "{}\n{}{}",
        &readme[..start],
        render_readme_rules(),
        &readme[end..]
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_vuid_is_both_enforced_and_undecidable() {
        let mut seen = BTreeMap::new();
        for module in checks::coverage() {
            for v in module.enforced {
                assert!(
                    seen.insert(*v, module.module).is_none(),
                    "{v} declared enforced twice"
                );
            }
        }
        for module in checks::coverage() {
            for (v, _) in module.not_decidable {
                assert!(
                    !seen.contains_key(v),
                    "{v} is both enforced and not decidable"
                );
            }
        }
    }

    #[test]
    fn layer_only_vuids_are_declared_nowhere_else() {
        let layer_only = checks::layer_only();
        assert!(!layer_only.is_empty());
        for (v, module, needs) in layer_only {
            assert!(!needs.is_empty(), "{v}");
            assert_eq!(statuses()[&v], Status::LayerOnly(module, needs));
            for declared in checks::coverage() {
                assert!(!declared.enforced.contains(&v), "{v} is also enforced");
                assert!(
                    !declared.not_decidable.iter().any(|(u, _)| *u == v),
                    "{v} is also not decidable"
                );
            }
        }
    }

    #[test]
    fn needed_tiers_follow_the_declarations() {
        assert_eq!(
            needed_tier("OMMCHECK-build-triangle-array-stride"),
            Tier::State
        );
        assert_eq!(needed_tier("OMMCHECK-attach-index-in-range"), Tier::Content);
        assert_eq!(needed_tier("VUID-vkCmdDraw-micromap-11638"), Tier::Content);
        assert_eq!(needed_tier("OMMCHECK-hygiene-unused-bits"), Tier::Simulate);
        let measured = BTreeMap::from([
            (
                "OMMCHECK-build-triangle-array-stride".to_string(),
                Tier::Content,
            ),
            ("OMMCHECK-attach-index-in-range".to_string(), Tier::Content),
        ]);
        assert_eq!(
            measured_above_needed(&measured),
            [(
                "OMMCHECK-build-triangle-array-stride",
                Tier::Content,
                Tier::State
            )]
        );
    }

    #[test]
    fn no_rule_is_measured_above_the_tier_its_inputs_need() {
        let corpus = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(CORPUS);
        let tiers = corpus_tiers(&corpus).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(measured_above_needed(&tiers), []);
        // Every declaration names a rule the corpus measures.
        for (id, _) in READS_CONTENTS {
            assert!(
                tiers
                    .keys()
                    .any(|rule| needed_tier(rule) == Tier::Content
                        && (rule == id || rule.ends_with(id))),
                "{id} is declared but measured nowhere"
            );
        }
    }

    #[test]
    fn the_rules_page_lists_every_rule_of_ours() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/rules.md");
        let page = std::fs::read_to_string(&path).expect("docs/rules.md");
        assert!(
            update_readme(&page).as_deref() == Some(page.as_str()),
            "the rules table of docs/rules.md is stale: run `cargo xtask coverage`"
        );
    }

    #[test]
    fn committed_report_is_current() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../VUID-COVERAGE.md");
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        let corpus = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(CORPUS);
        let tiers = corpus_tiers(&corpus).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            committed == render(&tiers),
            "{} is stale: run `cargo xtask coverage`",
            path.display()
        );
        let tiers_path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join(TIERS_FILE);
        let committed_tiers = std::fs::read_to_string(&tiers_path).unwrap_or_default();
        assert!(
            committed_tiers == render_tiers(&tiers),
            "{} is stale: run `cargo xtask coverage`",
            tiers_path.display()
        );
        for (id, tier) in &tiers {
            assert_eq!(measured_tier(id), Some(*tier), "{id}");
        }
    }
}
