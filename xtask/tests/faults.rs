//! Accuracy over the seeded fault corpus: every class of fault is caught
//! at the content tier, the lower tiers catch exactly the classes whose
//! rule they decide, and the valid twins draw no finding at any tier.

use std::collections::BTreeMap;
use std::path::Path;

use ommcheck::Tier;
use xtask::faults;

#[test]
fn the_fault_corpus_is_caught_as_each_tier_promises() {
    let classes = faults::classes();
    assert!(classes.len() >= 30, "{} classes", classes.len());
    let cases = faults::corpus(faults::SEED);
    assert_eq!(cases.len(), classes.len() * faults::SIZES.len());
    let table = faults::accuracy(&cases).unwrap_or_else(|e| panic!("{e}"));
    println!("{}", faults::render(&table, classes.len()));

    // The tier each rule needs, measured over the scene corpus.
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(ommcheck::coverage::CORPUS);
    let rule_tiers: BTreeMap<String, Tier> =
        ommcheck::coverage::corpus_tiers(&corpus).unwrap_or_else(|e| panic!("{e}"));

    for (tier, row) in &table {
        assert_eq!(
            row.false_findings, 0,
            "the {tier} tier reports findings on valid twins"
        );
        let expected: Vec<&str> = classes
            .iter()
            .filter(|c| rule_tiers.get(c.rule).is_some_and(|needed| needed <= tier))
            .map(|c| c.name)
            .collect();
        let mut caught = row.classes_caught.clone();
        caught.sort_unstable();
        let mut expected_sorted = expected.clone();
        expected_sorted.sort_unstable();
        assert_eq!(
            caught, expected_sorted,
            "the {tier} tier catches other classes than the rules it decides"
        );
    }
    let content = &table[&Tier::Content];
    assert_eq!(
        content.caught, content.faults,
        "the content tier misses faults"
    );

    // docs/accuracy-costs.md quotes the table `cargo xtask accuracy` prints.
    let page = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/accuracy-costs.md"),
    )
    .expect("docs/accuracy-costs.md");
    assert!(
        page.contains(&faults::render(&table, classes.len())),
        "docs/accuracy-costs.md's accuracy table is stale: paste what `cargo xtask accuracy` prints"
    );
}

#[test]
fn the_corpus_is_the_same_for_the_same_seed() {
    let a = faults::corpus(7);
    let b = faults::corpus(7);
    assert!(a
        .iter()
        .zip(&b)
        .all(|(x, y)| x.faulty == y.faulty && x.twin == y.twin));
    let c = faults::corpus(8);
    assert!(a.iter().zip(&c).any(|(x, y)| x.faulty != y.faulty));
}
