//! `cargo xtask fuzz`: the cargo-fuzz (libFuzzer) targets in
//! `fuzz/libfuzzer/`, whose bodies and oracles are in `fuzz/harness/`, run
//! by one or more libFuzzer processes each, from binaries built here or
//! carried from another machine; what a run finds is added to the kept
//! corpus and its executions to the record ([`crate::fuzz_record`]); and
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
    /// libFuzzer processes per target, side by side, sharing the working
    /// corpus (each reloads what the others add).
    pub jobs: usize,
    /// Merge what the run found into the committed corpus (`fuzz/corpus/`),
    /// keeping only inputs that add coverage, and record the run's
    /// executions ([`crate::fuzz_record`]).
    pub minimize: bool,
    /// The fuzz binaries, as `cargo fuzz build` leaves them in
    /// `target/fuzz/<host>/release/`, instead of building them here.
    pub prebuilt: Option<PathBuf>,
}

/// What one target's run did.
pub struct Outcome {
    pub target: String,
    /// Inputs executed, over all workers: libFuzzer's
    /// `stat::number_of_executed_units`.
    pub executions: u64,
    pub wall_seconds: u64,
    /// The committed corpus after the merge (inputs, bytes).
    pub corpus: Option<(u64, u64)>,
}

/// Builds the targets (or takes them from `options.prebuilt`) and runs
/// each for `options.seconds`; fails on the first finding, naming the input
/// libFuzzer saved.
pub fn run(root: &Path, options: &Options) -> Result<Vec<Outcome>, Error> {
    for target in &options.targets {
        if !TARGETS.contains(&target.as_str()) {
            return Err(Error::Tool(format!(
                "no fuzz target {target}; the targets are {}",
                TARGETS.join(", ")
            )));
        }
    }
    // With --prebuilt the root is the current directory: check that it is
    // the repository's, instead of starting a corpus elsewhere.
    if !root.join("fuzz/corpus").is_dir() {
        return Err(Error::Tool(format!(
            "{}: no fuzz/corpus here; run from the repository's root",
            root.display()
        )));
    }
    let binaries = match &options.prebuilt {
        Some(dir) => prebuilt(dir, &options.targets)?,
        None => build(root)?,
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get() as u64);
    let mut outcomes = Vec::new();
    for target in &options.targets {
        let binary = binaries.join(target);
        let mut outcome = run_target(root, &binary, target, options.seconds, options.jobs)?;
        if options.minimize {
            let corpus = minimize(root, &binary, target)?;
            outcome.corpus = Some(corpus);
            // A row per target as each finishes: a finding in a later target
            // keeps the executions of the earlier ones.
            crate::fuzz_record::append(
                root,
                &crate::fuzz_record::Row {
                    date: crate::fuzz_record::today(),
                    target: target.clone(),
                    executions: outcome.executions,
                    seconds: options.seconds,
                    jobs: options.jobs as u64,
                    cores,
                    corpus: Some(corpus),
                },
            )?;
            update_record_table(root)?;
        }
        outcomes.push(outcome);
    }
    eprintln!("xtask: fuzzing without a finding:");
    for o in &outcomes {
        let corpus = o.corpus.map_or(String::new(), |(inputs, bytes)| {
            format!("; kept corpus {inputs} inputs, {} KB", bytes.div_ceil(1000))
        });
        eprintln!(
            "xtask:   {:<10} {} executions in {} s with {} worker(s){corpus}",
            o.target, o.executions, o.wall_seconds, options.jobs
        );
    }
    if options.minimize {
        println!(
            "cumulative executions ({}, table in {}):\n{}",
            crate::fuzz_record::RECORD,
            crate::fuzz_record::DOC,
            update_record_table(root)?
        );
    }
    Ok(outcomes)
}

/// Renders the record's totals into its document; returns the table.
fn update_record_table(root: &Path) -> Result<String, Error> {
    let totals = crate::fuzz_record::totals(&crate::fuzz_record::read(root)?, &TARGETS);
    crate::fuzz_record::update_doc(root, &totals)?;
    Ok(crate::fuzz_record::render(&totals))
}

/// Builds every target with cargo-fuzz (release, AddressSanitizer) and
/// returns the directory of the binaries (what `--prebuilt` takes).
pub fn build(root: &Path) -> Result<PathBuf, Error> {
    ensure_nightly(&[])?;
    ensure_cargo_fuzz()?;
    check_lockfile(root)?;
    run_step("build the fuzz targets", &mut cargo_fuzz(root, "build"))?;
    Ok(crate::target_dir(root)
        .join("fuzz")
        .join(host_triple()?)
        .join("release"))
}

/// `dir` when it holds a binary of every target in `targets`.
fn prebuilt(dir: &Path, targets: &[String]) -> Result<PathBuf, Error> {
    let missing: Vec<&str> = targets
        .iter()
        .filter(|t| !dir.join(t).is_file())
        .map(String::as_str)
        .collect();
    if missing.is_empty() {
        Ok(dir.to_path_buf())
    } else {
        Err(Error::Tool(format!(
            "{}: no fuzz binary {} (`cargo xtask fuzz --build-only` builds them and names their directory)",
            dir.display(),
            missing.join(", ")
        )))
    }
}

/// Fails, naming the fix, where `cargo fuzz build` would rewrite the fuzz
/// project's lockfile (a tracked file: a test run must change none), or
/// where the lockfile holds a version of a crate other than the
/// workspace's, so that the fuzzers would test other code than ships.
/// `cargo metadata --locked` resolves (fetching the crates the build would
/// fetch) and fails where the lockfile would change, changing nothing.
pub fn check_lockfile(root: &Path) -> Result<(), Error> {
    let fuzz_lock = Path::new(FUZZ_DIR).join("Cargo.lock");
    let fix = format!(
        "run `cargo update --manifest-path {FUZZ_DIR}/Cargo.toml --workspace` (then `cargo update --manifest-path {FUZZ_DIR}/Cargo.toml -p CRATE --precise VERSION` for each crate named, to the root Cargo.lock's version) and commit {}",
        fuzz_lock.display()
    );
    let out = Command::new(cargo())
        .current_dir(root)
        .args(["metadata", "--format-version", "1", "--locked"])
        .arg("--manifest-path")
        .arg(Path::new(FUZZ_DIR).join("Cargo.toml"))
        .stdout(Stdio::null())
        .output()
        .map_err(|e| Error::Tool(format!("cargo metadata: {e}")))?;
    if !out.status.success() {
        return Err(Error::Tool(format!(
            "{} is not in step with the fuzz project's dependencies (`cargo fuzz build` would rewrite it): {}; {fix}",
            fuzz_lock.display(),
            String::from_utf8_lossy(&out.stderr)
                .lines()
                .next()
                .unwrap_or_default()
        )));
    }
    let workspace = lock_versions(&crate::read(&root.join("Cargo.lock"))?);
    let fuzz = lock_versions(&crate::read(&root.join(&fuzz_lock))?);
    let differing: Vec<String> = fuzz
        .iter()
        .filter(|(name, version)| {
            let theirs: Vec<&(String, String)> =
                workspace.iter().filter(|(n, _)| n == name).collect();
            !theirs.is_empty() && !theirs.iter().any(|(_, v)| v == version)
        })
        .map(|(name, version)| {
            let theirs: Vec<&str> = workspace
                .iter()
                .filter(|(n, _)| n == name)
                .map(|(_, v)| v.as_str())
                .collect();
            format!("{name} {version} (Cargo.lock: {})", theirs.join(", "))
        })
        .collect();
    if differing.is_empty() {
        Ok(())
    } else {
        Err(Error::Tool(format!(
            "{} has other versions than the workspace's Cargo.lock: {}; {fix}",
            fuzz_lock.display(),
            differing.join("; ")
        )))
    }
}

/// The (name, version) of every package of a Cargo.lock.
fn lock_versions(lock: &str) -> Vec<(String, String)> {
    let field = |block: &str, key: &str| {
        block.lines().find_map(|l| {
            l.strip_prefix(key)
                .and_then(|rest| rest.strip_prefix(" = \""))
                .and_then(|rest| rest.strip_suffix('"'))
                .map(str::to_string)
        })
    };
    lock.split("[[package]]")
        .skip(1)
        .filter_map(|block| field(block, "name").zip(field(block, "version")))
        .collect()
}

/// The host's target triple (nightly's, which builds the fuzz targets and
/// the sanitizer runs).
pub fn host_triple() -> Result<String, Error> {
    let out = Command::new("rustup")
        .args(["run", "nightly", "rustc", "-vV"])
        .output()
        .map_err(|e| Error::Tool(format!("rustc -vV: {e}")))?;
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .ok_or_else(|| Error::Tool("rustc -vV names no host".into()))
}

/// The corpus directories of `target`: the working one libFuzzer adds to
/// (ignored by git) first, then the committed minimized one, then seeds.
fn corpus_dirs(root: &Path, target: &str) -> Result<Vec<PathBuf>, Error> {
    let work = root.join(FUZZ_DIR).join("work").join(target);
    let committed = root.join("fuzz/corpus").join(target);
    for dir in [&work, &committed] {
        create_dir(dir)?;
    }
    let mut dirs = vec![work, committed];
    if target == "scene" {
        // Every corpus scene is a seed of the raw-text half as it is.
        dirs.push(root.join("tests/scenes/corpus"));
    }
    Ok(dirs)
}

fn create_dir(dir: &Path) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })
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

/// Options of every libFuzzer process: a single input taking 10 s is a
/// finding (unbounded work), as is one needing more than 4 GiB (unbounded
/// allocation).
const LIMITS: [&str; 2] = ["-timeout=10", "-rss_limit_mb=4096"];

/// What one worker said.
#[derive(Default)]
struct Worker {
    /// `stat::number_of_executed_units`, else `Done N runs`.
    executions: Option<u64>,
    /// The latest status line's `#N`: the count of a worker stopped
    /// before its final statistics.
    last_status: u64,
    artifact: Option<String>,
    tail: Vec<String>,
}

impl Worker {
    fn read(&mut self, line: &str) {
        if let Some(n) = line.strip_prefix('#') {
            let digits: String = n.chars().take_while(char::is_ascii_digit).collect();
            if let Ok(n) = digits.parse() {
                self.last_status = n;
            }
        }
        if let Some(n) = line.strip_prefix("stat::number_of_executed_units:") {
            self.executions = n.trim().parse().ok();
        } else if let Some(done) = line.strip_prefix("Done ") {
            // "Done 123456 runs in 25 second(s)"
            if self.executions.is_none() {
                self.executions = done.split_whitespace().next().and_then(|n| n.parse().ok());
            }
        }
        if let Some(at) = line.split("Test unit written to ").nth(1) {
            self.artifact = Some(at.trim().to_string());
        }
        self.tail.push(line.to_string());
        if self.tail.len() > 40 {
            self.tail.remove(0);
        }
    }

    fn executions(&self) -> u64 {
        self.executions.unwrap_or(self.last_status)
    }
}

/// Whether to echo a line of worker `k`. libFuzzer's status lines are many;
/// of the first worker the rest is shown, of the others only what is not
/// a status or a start-up line (with 16 workers those would be hundreds).
fn shown(k: usize, line: &str) -> bool {
    let status = (line.starts_with('#') || line.starts_with('\t'))
        && !line.contains("DONE")
        && !line.contains("INITED");
    if k == 0 {
        return !status;
    }
    !(status
        || line.starts_with('#')
        || line.starts_with("INFO")
        || line.starts_with("stat::")
        || line.starts_with("Done ")
        || line.starts_with("MERGE")
        // The recommended dictionary at the end of a run.
        || line.starts_with('"')
        || line.is_empty())
}

enum Event {
    Line(usize, String),
    Closed(usize),
}

/// Runs `jobs` libFuzzer processes of `target` for `seconds`, the working
/// corpus first (where each writes what it finds and, libFuzzer's
/// `-reload=1`, reads what the others found), then the committed corpus
/// and the seeds. The first that fails stops the others.
fn run_target(
    root: &Path,
    binary: &Path,
    target: &str,
    seconds: u64,
    jobs: usize,
) -> Result<Outcome, Error> {
    let dirs = corpus_dirs(root, target)?;
    let artifacts = root.join(FUZZ_DIR).join("artifacts").join(target);
    create_dir(&artifacts)?;
    let (sender, events) = std::sync::mpsc::channel();
    let mut children = Vec::new();
    let started = Instant::now();
    for k in 0..jobs.max(1) {
        let mut command = Command::new(binary);
        command
            .arg(format!("-artifact_prefix={}/", artifacts.display()))
            .arg(format!("-max_total_time={seconds}"))
            .args(LIMITS)
            .arg("-print_final_stats=1")
            .args(libfuzzer_options(target))
            .args(&dirs)
            .stderr(Stdio::piped());
        if k == 0 {
            eprintln!("xtask: fuzz {target} for {seconds} s with {jobs} worker(s): {command:?}");
        }
        let mut child = match command.spawn() {
            Ok(child) => child,
            Err(e) => {
                stop(&mut children);
                return Err(Error::Tool(format!(
                    "fuzz {target}: could not start {}: {e}",
                    binary.display()
                )));
            }
        };
        let stderr = child.stderr.take().expect("piped stderr");
        let sender = sender.clone();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                let _ = sender.send(Event::Line(k, line));
            }
            let _ = sender.send(Event::Closed(k));
        });
        children.push(Some(child));
    }
    // The channel ends when every reader has sent its last event.
    drop(sender);
    let mut workers: Vec<Worker> = children.iter().map(|_| Worker::default()).collect();
    let mut failure = None;
    for event in events {
        match event {
            Event::Line(k, line) => {
                if shown(k, &line) {
                    if jobs > 1 {
                        eprintln!("[{target} {k}] {line}");
                    } else {
                        eprintln!("{line}");
                    }
                }
                workers[k].read(&line);
            }
            Event::Closed(k) => {
                let status = children[k].take().map(|mut child| child.wait());
                let status = status
                    .transpose()
                    .map_err(|e| Error::Tool(format!("fuzz {target}: {e}")))?;
                if status.is_some_and(|s| !s.success()) && failure.is_none() {
                    failure = Some((k, status));
                    stop(&mut children);
                }
            }
        }
    }
    if let Some((k, status)) = failure {
        let worker = &workers[k];
        eprintln!("{}", worker.tail.join("\n"));
        return Err(Error::Tool(format!(
            "fuzz {target} found a failing input ({}){}; fix it, then keep the input in fuzz/regressions/{target}/ (replayed by `cargo test -p ommcheck-fuzz-harness`)",
            status.map_or("stopped".into(), |s| s.to_string()),
            worker
                .artifact
                .as_ref()
                .map(|a| format!(" saved at {a}"))
                .unwrap_or_default()
        )));
    }
    Ok(Outcome {
        target: target.to_string(),
        executions: workers.iter().map(Worker::executions).sum(),
        wall_seconds: started.elapsed().as_secs(),
        corpus: None,
    })
}

/// Kills the workers still running (each our own child, by its handle);
/// their readers' `Closed` events reap them.
fn stop(children: &mut [Option<std::process::Child>]) {
    for child in children.iter_mut().flatten() {
        let _ = child.kill();
    }
}

/// Adds to `fuzz/corpus/<target>` the inputs of the working corpus that
/// reach an edge neither it nor the target's seeds reach (libFuzzer's
/// `-merge=1` into a copy of it, edges only); returns its inputs and bytes.
/// Only adding, never choosing a new smallest set: each run's commit then
/// adds the inputs that brought coverage and deletes none. A full
/// re-minimization by edges after a minute of fuzzing per target deleted
/// 44 of `raw_reader`'s 180 inputs while adding 58, and 281 of `scene`'s
/// 2,798: churn the repository's history would keep.
fn minimize(root: &Path, binary: &Path, target: &str) -> Result<(u64, u64), Error> {
    let dirs = corpus_dirs(root, target)?;
    let committed = &dirs[1];
    let merged = root
        .join(FUZZ_DIR)
        .join("work")
        .join(format!("{target}.merged"));
    let _ = std::fs::remove_dir_all(&merged);
    create_dir(&merged)?;
    // The kept inputs and the seeds (the corpus scenes, in the repository
    // already) go in the output first, so that libFuzzer adds only inputs
    // reaching edges beyond them; the seeds' copies are taken out after.
    let copy = |from: &Path, to: PathBuf| {
        std::fs::copy(from, &to)
            .map(|_| to)
            .map_err(|source| Error::Io {
                path: from.to_path_buf(),
                source,
            })
    };
    for kept in files_under(committed) {
        let name = kept.file_name().expect("a file has a name");
        copy(&kept, merged.join(name))?;
    }
    let mut seed_copies = Vec::new();
    for (k, seed) in dirs
        .iter()
        .skip(2)
        .flat_map(|dir| files_under(dir))
        .enumerate()
    {
        seed_copies.push(copy(&seed, merged.join(format!("seed-{k}")))?);
    }
    run_step(
        &format!("add to the {target} corpus"),
        Command::new(binary)
            // Edges only (no hit counters): with counters a scene run kept
            // 3,643 inputs (5 MB) beyond the corpus scenes.
            .args(["-merge=1", "-use_counters=0"])
            .args(LIMITS)
            .arg(&merged)
            .arg(&dirs[0]),
    )?;
    for copy in seed_copies {
        std::fs::remove_file(&copy).map_err(|source| Error::Io { path: copy, source })?;
    }
    let _ = std::fs::remove_dir_all(committed);
    std::fs::rename(&merged, committed).map_err(|source| Error::Io {
        path: committed.clone(),
        source,
    })?;
    let inputs = files_under(committed);
    let bytes = inputs
        .iter()
        .filter_map(|f| std::fs::metadata(f).ok())
        .map(|m| m.len())
        .sum();
    Ok((inputs.len() as u64, bytes))
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
