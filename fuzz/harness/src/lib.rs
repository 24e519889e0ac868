//! The bodies of the fuzz targets in `fuzz/fuzz_targets/`, each with an
//! oracle beyond "did not crash": a slow decoder written from the
//! specification's bit layout, the ambiguity set containing every answer
//! the specification allows within the error bound, and the same findings
//! for the same input (each body runs twice and compares). They live in a
//! plain library so the regression tests in `tests/` replay the inputs the
//! fuzzer kept (`fuzz/regressions/`) under `cargo test` on stable.

pub mod decode;
pub mod host_build;
pub mod input;
pub mod raw;
pub mod scene;
pub mod simulate;
mod structs;

/// A target's body: panics on a finding.
pub type Body = fn(&[u8]);

/// The targets, by the names `cargo fuzz` knows them by.
pub const TARGETS: [(&str, Body); 5] = [
    ("raw_reader", raw::run),
    ("decode", decode::run),
    ("simulate", simulate::run),
    ("scene", scene::run),
    ("host_build", host_build::run),
];
