//! Times a target's body (both runs and the oracle) on every input in a
//! directory, without libFuzzer or sanitizers, and lists the slowest: for
//! finding what makes a target run few executions per second.
//!
//! `cargo run --release -p ommcheck-fuzz-harness --example slowest_inputs -- raw_reader fuzz/corpus/raw_reader`

use std::path::PathBuf;
use std::time::{Duration, Instant};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [target, dir] = args.as_slice() else {
        eprintln!("usage: slowest_inputs <target> <directory of inputs>");
        std::process::exit(2);
    };
    let Some((_, body)) = ommcheck_fuzz_harness::TARGETS
        .iter()
        .find(|(name, _)| name == target)
    else {
        eprintln!("no target {target}");
        std::process::exit(2);
    };
    let mut timed: Vec<(Duration, usize, PathBuf)> = Vec::new();
    for entry in std::fs::read_dir(dir).expect("a readable directory") {
        let path = entry.expect("a directory entry").path();
        let Ok(data) = std::fs::read(&path) else {
            continue;
        };
        let started = Instant::now();
        body(&data);
        timed.push((started.elapsed(), data.len(), path));
    }
    timed.sort();
    let total: Duration = timed.iter().map(|(time, ..)| *time).sum();
    for (time, len, path) in timed.iter().rev().take(10) {
        println!("{time:>12.2?}  {len:>6} B  {}", path.display());
    }
    println!("{total:.2?} for {} inputs", timed.len());
}
