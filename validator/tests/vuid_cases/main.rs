//! Every enforced rule has a failing case (the rule is reported) and a
//! passing case (a valid twin: the rule is not reported, and nothing else is
//! an error). The coverage test fails when a rule a check module declares
//! enforced has no case here.

mod accel_attach;
mod accel_build;
mod clean_runs;
mod driver_sizes;
mod execution;
mod fixtures;
mod micromap_build;
mod micromap_objects;
mod not_checked;
mod pipeline_sync;
mod raw;

use std::collections::BTreeSet;

use ommcheck::{Report, RuleId};

/// One rule's failing and passing scenario.
pub struct Case {
    pub rule: RuleId,
    pub failing: fn() -> Report,
    pub passing: fn() -> Report,
}

/// Shorthand for building cases.
pub fn case(rule: impl Into<RuleId>, failing: fn() -> Report, passing: fn() -> Report) -> Case {
    Case {
        rule: rule.into(),
        failing,
        passing,
    }
}

fn all_cases() -> Vec<Case> {
    let mut cases = Vec::new();
    cases.extend(micromap_build::cases());
    cases.extend(driver_sizes::cases());
    cases.extend(micromap_objects::cases());
    cases.extend(accel_build::cases());
    cases.extend(accel_attach::cases());
    cases.extend(pipeline_sync::cases());
    cases.extend(raw::cases());
    cases.extend(execution::cases());
    cases
}

#[test]
fn failing_cases_report_their_rule_and_passing_cases_do_not() {
    let mut problems = Vec::new();
    for case in all_cases() {
        let failing = (case.failing)();
        if !failing.contains(case.rule) {
            problems.push(format!(
                "{}: the failing case does not report it; it reports {:?}",
                case.rule,
                failing.ids()
            ));
        }
        let passing = (case.passing)();
        if passing.contains(case.rule) || passing.has_errors() {
            problems.push(format!(
                "{}: the passing case reports errors:\n{passing}",
                case.rule
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn every_enforced_rule_has_a_case() {
    let covered: BTreeSet<&str> = all_cases().iter().map(|c| c.rule.as_str()).collect();
    let mut missing = Vec::new();
    for module in ommcheck::checks::coverage() {
        for vuid in module.enforced {
            if !covered.contains(vuid.id()) {
                missing.push(format!("{} ({})", vuid.id(), module.module));
            }
        }
    }
    for rule in ommcheck::rules::ALL {
        if !covered.contains(rule.id) {
            missing.push(rule.id.to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "enforced rules without a case:\n{}",
        missing.join("\n")
    );
}
