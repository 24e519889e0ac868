//! Replays, on stable and without libFuzzer, every input the fuzzer kept:
//! the crashes it found (`fuzz/regressions/<target>/`, each a bug fixed
//! since) and the minimized corpus (`fuzz/corpus/<target>/`), through the
//! same bodies and oracles the fuzz targets run.

use std::path::{Path, PathBuf};

fn inputs(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.retain(|p| p.is_file());
    files.sort();
    files
}

fn replay(kind: &str) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(kind);
    let mut replayed = 0;
    for (target, body) in ommcheck_fuzz_harness::TARGETS {
        for path in inputs(&root.join(target)) {
            let data = std::fs::read(&path).expect("a kept input is readable");
            let outcome = std::panic::catch_unwind(|| body(&data));
            assert!(outcome.is_ok(), "{target}: {} fails again", path.display());
            replayed += 1;
        }
    }
    replayed
}

#[test]
fn crashes_found_by_fuzzing_stay_fixed() {
    replay("regressions");
}

#[test]
fn the_minimized_corpus_passes_every_oracle() {
    let replayed = replay("corpus");
    assert!(replayed > 0, "fuzz/corpus/ is empty");
}
