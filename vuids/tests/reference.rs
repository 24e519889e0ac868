//! Compares the generated catalog with `micromap_vuids.json`, the reference
//! selection kept beside the registry in `../shared/vulkan-registry`, and
//! names every id and field that differs.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use ommcheck_vuids::{ParentKind, Vuid, VuidKind};
use serde::Deserialize;

#[derive(Deserialize)]
struct Reference {
    counts: Counts,
    vuids: Vec<ReferenceVuid>,
}

#[derive(Deserialize)]
struct Counts {
    total: usize,
    explicit: usize,
    implicit: usize,
}

#[derive(Deserialize)]
struct ReferenceVuid {
    vuid: String,
    parent: String,
    parent_kind: String,
    implicit: bool,
    extensions_short: Vec<String>,
    text: String,
    page: String,
    string_in_vvl_layers: bool,
}

fn reference_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/vulkan-registry/micromap_vuids.json")
}

fn load_reference() -> Option<Reference> {
    let path = reference_path();
    match std::fs::read_to_string(&path) {
        Ok(text) => Some(serde_json::from_str(&text).expect("micromap_vuids.json parses")),
        Err(e) => {
            let ci = std::env::var("CI").is_ok_and(|v| v == "true" || v == "1");
            assert!(!ci, "{}: {e}; CI must have ../shared", path.display());
            eprintln!("skipping: {} not readable ({e})", path.display());
            None
        }
    }
}

#[test]
fn catalog_matches_the_reference_selection() {
    let Some(reference) = load_reference() else {
        return;
    };
    let ours: BTreeMap<&str, Vuid> = Vuid::all().map(|v| (v.id(), v)).collect();
    let theirs: BTreeMap<&str, &ReferenceVuid> = reference
        .vuids
        .iter()
        .map(|r| (r.vuid.as_str(), r))
        .collect();

    let ours_ids: BTreeSet<&str> = ours.keys().copied().collect();
    let theirs_ids: BTreeSet<&str> = theirs.keys().copied().collect();
    let mut differences = Vec::new();
    for id in ours_ids.difference(&theirs_ids) {
        differences.push(format!("{id}: in the catalog, not in the reference"));
    }
    for id in theirs_ids.difference(&ours_ids) {
        differences.push(format!("{id}: in the reference, not in the catalog"));
    }
    for (id, r) in &theirs {
        let Some(v) = ours.get(id) else { continue };
        let info = v.info();
        let mut field = |name: &str, ours: String, theirs: String| {
            if ours != theirs {
                differences.push(format!(
                    "{id}: {name}: catalog {ours:?}, reference {theirs:?}"
                ));
            }
        };
        field("parent", info.parent.into(), r.parent.clone());
        let kind = match info.parent_kind {
            ParentKind::Struct => "struct",
            ParentKind::Command => "command",
            ParentKind::Spirv => "spirv",
        };
        field("parent_kind", kind.into(), r.parent_kind.clone());
        field(
            "implicit",
            (info.kind == VuidKind::Implicit).to_string(),
            r.implicit.to_string(),
        );
        field(
            "extensions",
            info.extensions.short_names().collect::<Vec<_>>().join(","),
            r.extensions_short.join(","),
        );
        field("text", info.text.into(), r.text.clone());
        field("page", info.page.into(), r.page.clone());
        field(
            "khronos_layer_checks",
            format!("{:?}", info.khronos_layer_checks),
            format!("{:?}", Some(r.string_in_vvl_layers)),
        );
    }
    assert!(
        differences.is_empty(),
        "{} differences between the catalog and {}:\n{}",
        differences.len(),
        reference_path().display(),
        differences.join("\n")
    );
    assert_eq!(ours.len(), reference.counts.total);
}

#[test]
fn catalog_counts_match_the_reference_counts() {
    let Some(reference) = load_reference() else {
        return;
    };
    let explicit = Vuid::all()
        .filter(|v| v.info().kind == VuidKind::Explicit)
        .count();
    let implicit = Vuid::all()
        .filter(|v| v.info().kind == VuidKind::Implicit)
        .count();
    assert_eq!(explicit, reference.counts.explicit);
    assert_eq!(implicit, reference.counts.implicit);
}
