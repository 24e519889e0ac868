//! `cargo xtask fuzz`: the cargo-fuzz (libFuzzer) targets in
//! `fuzz/libfuzzer/`, whose bodies and oracles are in `fuzz/harness/`; and
//! the nightly tools the undefined-behaviour checks of `cargo xtask test`
//! need (Miri, AddressSanitizer). Installs what is missing: the nightly
//! toolchain (with rustup), its `miri` and `rust-src` components, and
//! cargo-fuzz (`cargo install --locked`).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::host::run_step;
use crate::Error;

/// The fuzz targets (`fuzz/libfuzzer/fuzz_targets/<name>.rs`).
pub const TARGETS: [&str; 5] = ["raw_reader", "decode", "simulate", "scene", "host_build"];

/// Seconds per target of `--smoke` (CI) and `--long`.
pub const SMOKE_SECONDS: u64 = 25;
pub const LONG_SECONDS: u64 = 600;

/// The cargo-fuzz project, relative to the workspace root.
const FUZZ_DIR: &str = "fuzz/libfuzzer";

fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

/// `cargo +nightly fuzz` for the project in [`FUZZ_DIR`], building into
/// `fuzz/` under the workspace's target directory: a directory of its own,
/// as the instrumented artefacts are of no use to the other builds and
/// would evict theirs, but kept (and cached) with them.
fn cargo_fuzz(root: &Path, subcommand: &str) -> Command {
    let mut command = nightly_cargo();
    command
        .current_dir(root)
        .env("CARGO_TARGET_DIR", crate::target_dir(root).join("fuzz"))
        .args(["fuzz", subcommand, "--fuzz-dir", FUZZ_DIR]);
    command
}

/// A `cargo` command for the nightly toolchain. Through rustup's proxy the
/// `+nightly` argument selects it; `CARGO` (set by `cargo xtask`) points at
/// the stable toolchain's cargo, which does not understand `+nightly`.
pub fn nightly_cargo() -> Command {
    let mut command = Command::new("cargo");
    command
        .arg("+nightly")
        .env_remove("CARGO")
        .env_remove("RUSTC");
    command
}

fn nightly_has(component: &str) -> bool {
    Command::new("rustup")
        .args(["component", "list", "--installed", "--toolchain", "nightly"])
        .output()
        .is_ok_and(|out| {
            out.status.success()
                && String::from_utf8_lossy(&out.stdout)
                    .lines()
                    .any(|line| line.starts_with(component))
        })
}

/// Installs the nightly toolchain and `components` where missing.
pub fn ensure_nightly(components: &[&str]) -> Result<(), Error> {
    let present = Command::new("rustup")
        .args(["run", "nightly", "rustc", "--version"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !present {
        run_step(
            "install the nightly toolchain",
            Command::new("rustup").args([
                "toolchain",
                "install",
                "nightly",
                "--profile",
                "minimal",
            ]),
        )?;
    }
    let missing: Vec<&str> = components
        .iter()
        .copied()
        .filter(|c| !nightly_has(c))
        .collect();
    if !missing.is_empty() {
        run_step(
            "add nightly components",
            Command::new("rustup")
                .args(["component", "add", "--toolchain", "nightly"])
                .args(&missing),
        )?;
    }
    Ok(())
}

/// Installs cargo-fuzz where missing.
fn ensure_cargo_fuzz() -> Result<(), Error> {
    let present = Command::new(cargo())
        .args(["fuzz", "--version"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !present {
        run_step(
            "install cargo-fuzz",
            Command::new(cargo()).args(["install", "cargo-fuzz", "--locked"]),
        )?;
    }
    Ok(())
}

/// How long and what to fuzz.
pub struct Options {
    pub seconds: u64,
    pub targets: Vec<String>,
    /// Merge what the run found into the committed corpus (`fuzz/corpus/`),
    /// keeping only inputs that add coverage.
    pub minimize: bool,
}

/// What one target's run did.
pub struct Outcome {
    pub target: String,
    /// libFuzzer's `Done N runs in S second(s)`.
    pub runs: Option<(u64, u64)>,
    pub wall_seconds: u64,
}

/// Builds the targets and runs each for `options.seconds`; fails on the
/// first finding, naming the input libFuzzer saved.
pub fn run(root: &Path, options: &Options) -> Result<Vec<Outcome>, Error> {
    ensure_nightly(&[])?;
    ensure_cargo_fuzz()?;
    for target in &options.targets {
        if !TARGETS.contains(&target.as_str()) {
            return Err(Error::Tool(format!(
                "no fuzz target {target}; the targets are {}",
                TARGETS.join(", ")
            )));
        }
    }
    run_step("build the fuzz targets", &mut cargo_fuzz(root, "build"))?;
    let mut outcomes = Vec::new();
    for target in &options.targets {
        let outcome = run_target(root, target, options.seconds)?;
        if options.minimize {
            minimize(root, target)?;
        }
        outcomes.push(outcome);
    }
    eprintln!("xtask: fuzzing without a finding:");
    for o in &outcomes {
        match o.runs {
            Some((runs, seconds)) => {
                eprintln!("xtask:   {:<10} {runs} runs in {seconds} s", o.target)
            }
            None => eprintln!("xtask:   {:<10} ({} s)", o.target, o.wall_seconds),
        }
    }
    Ok(outcomes)
}

/// The corpus directories of `target`: the working one libFuzzer adds to
/// (ignored by git) first, then the committed minimized one, then seeds.
fn corpus_dirs(root: &Path, target: &str) -> Result<Vec<PathBuf>, Error> {
    let work = root.join(FUZZ_DIR).join("work").join(target);
    let committed = root.join("fuzz/corpus").join(target);
    for dir in [&work, &committed] {
        std::fs::create_dir_all(dir).map_err(|source| Error::Io {
            path: dir.clone(),
            source,
        })?;
    }
    let mut dirs = vec![work, committed];
    if target == "scene" {
        // Every corpus scene is a seed of the raw-text half as it is.
        dirs.push(root.join("tests/scenes/corpus"));
    }
    Ok(dirs)
}

/// libFuzzer options of one target beyond the common ones. The targets
/// that build API structures from their input read it as a stream of
/// numbers (its end reads as zeros), so an input describes more the longer
/// it is: they start at full length (`-len_control=0`) instead of growing
/// from a few bytes. In 60 s from the committed corpus, `raw_reader` ran
/// 31,300 inputs to 2,907 edges (8,141 features) with these options and
/// 65,883 to 2,789 (6,335) without (the inputs stayed under 76 bytes).
fn libfuzzer_options(target: &str) -> &'static [&'static str] {
    match target {
        "raw_reader" | "host_build" => &["-len_control=0", "-max_len=2048"],
        _ => &[],
    }
}

fn run_target(root: &Path, target: &str, seconds: u64) -> Result<Outcome, Error> {
    let dirs = corpus_dirs(root, target)?;
    let mut command = cargo_fuzz(root, "run");
    command
        .arg(target)
        .args(&dirs)
        .arg("--")
        .arg(format!("-max_total_time={seconds}"))
        // A single input taking 10 s is a finding (unbounded work), as is
        // one needing more than 4 GiB (unbounded allocation).
        .args(["-timeout=10", "-rss_limit_mb=4096", "-print_final_stats=1"])
        .args(libfuzzer_options(target))
        .stderr(Stdio::piped());
    eprintln!("xtask: fuzz {target} for {seconds} s: {command:?}");
    let started = Instant::now();
    let mut child = command
        .spawn()
        .map_err(|e| Error::Tool(format!("fuzz {target}: could not start: {e}")))?;
    let stderr = child.stderr.take().expect("piped stderr");
    let mut runs = None;
    let mut artifact = None;
    let mut tail: Vec<String> = Vec::new();
    for line in BufReader::new(stderr).lines() {
        let line = line.map_err(|e| Error::Tool(format!("fuzz {target}: {e}")))?;
        // libFuzzer's status lines are many; keep the interesting ones.
        if !(line.starts_with('#') || line.starts_with('\t'))
            || line.contains("DONE")
            || line.contains("INITED")
        {
            eprintln!("{line}");
        }
        if let Some(done) = line.strip_prefix("Done ") {
            // "Done 123456 runs in 25 second(s)"
            let words: Vec<&str> = done.split_whitespace().collect();
            if let (Some(n), Some(s)) = (words.first(), words.get(3)) {
                runs = n.parse().ok().zip(s.parse().ok());
            }
        }
        if let Some(at) = line.split("Test unit written to ").nth(1) {
            artifact = Some(at.trim().to_string());
        }
        tail.push(line);
        if tail.len() > 40 {
            tail.remove(0);
        }
    }
    let status = child
        .wait()
        .map_err(|e| Error::Tool(format!("fuzz {target}: {e}")))?;
    let wall_seconds = started.elapsed().as_secs();
    if !status.success() {
        return Err(Error::Tool(format!(
            "fuzz {target} found a failing input ({status}){}; fix it, then keep the input in fuzz/regressions/{target}/ (replayed by `cargo test -p ommcheck-fuzz-harness`)",
            artifact
                .map(|a| format!(" saved at {a}"))
                .unwrap_or_default()
        )));
    }
    Ok(Outcome {
        target: target.to_string(),
        runs,
        wall_seconds,
    })
}

/// Replaces `fuzz/corpus/<target>` with the inputs of it and the working
/// corpus that add coverage (libFuzzer's `-merge=1`, edges only), beyond
/// what the target's seeds cover.
fn minimize(root: &Path, target: &str) -> Result<(), Error> {
    let dirs = corpus_dirs(root, target)?;
    let committed = root.join("fuzz/corpus").join(target);
    let merged = root
        .join(FUZZ_DIR)
        .join("work")
        .join(format!("{target}.merged"));
    let _ = std::fs::remove_dir_all(&merged);
    std::fs::create_dir_all(&merged).map_err(|source| Error::Io {
        path: merged.clone(),
        source,
    })?;
    // The seeds (the corpus scenes) are in the repository already: copies
    // of them go in the output first, so that libFuzzer keeps only inputs
    // adding coverage beyond them, and are taken out after the merge.
    let mut seed_copies = Vec::new();
    for (k, seed) in dirs
        .iter()
        .skip(2)
        .flat_map(|dir| files_under(dir))
        .enumerate()
    {
        let copy = merged.join(format!("seed-{k}"));
        std::fs::copy(&seed, &copy).map_err(|source| Error::Io {
            path: seed.clone(),
            source,
        })?;
        seed_copies.push(copy);
    }
    let sources: Vec<&PathBuf> = dirs.iter().take(2).collect();
    run_step(
        &format!("minimize the {target} corpus"),
        cargo_fuzz(root, "run")
            .arg(target)
            .arg(&merged)
            .args(sources)
            // Edges only (no hit counters): the committed corpus covers every
            // edge the run reached with few inputs; with counters a scene
            // run kept 3,643 inputs (5 MB) beyond the corpus scenes.
            .args([
                "--",
                "-merge=1",
                "-use_counters=0",
                "-timeout=10",
                "-rss_limit_mb=4096",
            ]),
    )?;
    for copy in seed_copies {
        std::fs::remove_file(&copy).map_err(|source| Error::Io { path: copy, source })?;
    }
    let _ = std::fs::remove_dir_all(&committed);
    std::fs::rename(&merged, &committed).map_err(|source| Error::Io {
        path: committed,
        source,
    })
}

/// The unit tests run under Miri: those of every module that reads
/// through pointers an application (or the loader) handed over — the
/// core's reader (`ommcheck::raw`) and the layer's own (`read`, and `abi`
/// for the loader's link chain).
/// Test filters are substrings: `raw::` also matches `draw::`, whose
/// pictures hold no pointer and take minutes under Miri, hence the skip.
const MIRI_TESTS: [(&str, &str, &[&str]); 2] = [
    (
        "the core's raw-pointer reader",
        "ommcheck",
        &["raw::", "--skip", "draw::"],
    ),
    (
        "the layer's pointer readers",
        "ommcheck-layer",
        &["read::", "abi::"],
    ),
];

/// Runs the pointer readers' unit tests ([`MIRI_TESTS`]) under Miri.
pub fn miri(root: &Path, target_dir: &Path) -> Result<(), Error> {
    ensure_nightly(&["miri", "rust-src"])?;
    for (what, package, filters) in MIRI_TESTS {
        run_step(
            &format!("the tests of {what} under Miri"),
            nightly_cargo()
                .current_dir(root)
                // Its own target directory: Miri's artefacts are not the
                // stable toolchain's, and would evict them.
                .env("CARGO_TARGET_DIR", target_dir.join("miri"))
                // The readers turn addresses back into pointers
                // (`with_exposed_provenance`), which Miri supports under
                // permissive provenance; say so instead of warning per test.
                .env("MIRIFLAGS", "-Zmiri-permissive-provenance")
                .args(["miri", "test", "-p", package, "--lib", "--"])
                .args(filters),
        )?;
    }
    Ok(())
}

/// Every file under `dir`, at any depth.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(dir) = pending.pop() {
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.is_dir() {
                pending.push(path);
            } else {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}
