//! Accuracy over the fault corpus (the `ommcheck-faults` crate): each
//! case checked at every tier measures how many faults each tier catches,
//! and how many findings it makes on the valid twins (which must be none).
//!
//! `cargo xtask accuracy` prints the table; `xtask/tests/faults.rs`
//! asserts it.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use ommcheck::scene::{CheckOptions, Scene};
use ommcheck::{Severity, Tier};
pub use ommcheck_faults::{classes, corpus, FaultCase, FaultClass, SEED, SIZES};
use serde_json::Value;

/// What one tier made of the corpus.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TierAccuracy {
    /// Faulty scenes whose fault the tier reported (its rule).
    pub caught: usize,
    pub faults: usize,
    /// Errors and warnings on the valid twins.
    pub false_findings: usize,
    /// Classes caught at every size.
    pub classes_caught: Vec<&'static str>,
}

fn findings(scene: &Value, tier: Tier) -> Result<Vec<(String, Severity)>, String> {
    let text = scene.to_string();
    let scene = Scene::parse(&text, "fault corpus", std::path::Path::new("."))
        .map_err(|e| e.to_string())?;
    let report = scene
        .check(&CheckOptions {
            tier,
            ..CheckOptions::default()
        })
        .map_err(|e| e.to_string())?;
    Ok(report
        .report
        .findings
        .iter()
        .map(|f| (f.rule.as_str().to_string(), f.severity))
        .collect())
}

/// Checks the corpus at every tier.
pub fn accuracy(cases: &[FaultCase]) -> Result<BTreeMap<Tier, TierAccuracy>, String> {
    let mut table = BTreeMap::new();
    for tier in [Tier::Params, Tier::State, Tier::Content] {
        let mut row = TierAccuracy::default();
        let mut by_class: BTreeMap<&str, bool> = BTreeMap::new();
        for case in cases {
            let caught = findings(&case.faulty, tier)
                .map_err(|e| format!("{} ({}): {e}", case.class, case.size))?
                .iter()
                .any(|(rule, _)| rule == case.rule);
            row.faults += 1;
            row.caught += usize::from(caught);
            *by_class.entry(case.class).or_insert(true) &= caught;
            row.false_findings += findings(&case.twin, tier)?
                .iter()
                .filter(|(_, severity)| *severity != Severity::Info)
                .count();
        }
        row.classes_caught = by_class
            .into_iter()
            .filter(|(_, all)| *all)
            .map(|(class, _)| class)
            .collect();
        table.insert(tier, row);
    }
    Ok(table)
}

/// The accuracy table as markdown.
pub fn render(table: &BTreeMap<Tier, TierAccuracy>, classes: usize) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "| tier | faults caught | classes caught (of {classes}) | false findings on the valid twins |"
    );
    let _ = writeln!(out, "| --- | ---: | ---: | ---: |");
    for (tier, row) in table {
        let _ = writeln!(
            out,
            "| `{tier}` | {} / {} | {} | {} |",
            row.caught,
            row.faults,
            row.classes_caught.len(),
            row.false_findings
        );
    }
    out
}
