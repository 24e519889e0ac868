//! `cargo xtask test`: install what the tests need, then fmt, clippy, tests.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};

use crate::host::{apt_install, in_ci, run_step};
use crate::Error;

/// The registry directory (`../shared/vulkan-registry`) for the tests that
/// read it; None (the test skips) where it is missing outside CI.
pub fn shared_registry() -> Option<std::path::PathBuf> {
    let dir = crate::default_registry();
    if dir.join("vk.xml").exists() {
        return Some(dir);
    }
    assert!(
        !in_ci(),
        "{}: missing; CI must have ../shared",
        dir.display()
    );
    eprintln!("skipping: {} not present", dir.display());
    None
}

/// A system prerequisite of the test suite.
struct Prerequisite {
    what: &'static str,
    /// Debian packages that provide it.
    debian_packages: &'static [&'static str],
    present: fn() -> bool,
}

fn vulkan_loader_present() -> bool {
    Command::new("ldconfig")
        .arg("-p")
        .output()
        .is_ok_and(|out| String::from_utf8_lossy(&out.stdout).contains("libvulkan.so.1"))
}

/// Whether a Chromium the HTML report's browser test can run is installed
/// (validator/tests/html.rs tries the same names).
fn chromium_present() -> bool {
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .any(|name| {
            Command::new(name)
                .arg("--version")
                .output()
                .is_ok_and(|out| out.status.success())
        })
}

const PREREQUISITES: &[Prerequisite] = &[
    Prerequisite {
        what: "the Vulkan loader (libvulkan.so.1)",
        debian_packages: &["libvulkan1"],
        present: vulkan_loader_present,
    },
    Prerequisite {
        what: "Chromium, which opens the HTML report in the browser test",
        debian_packages: &["chromium"],
        present: chromium_present,
    },
];

/// Makes sure every prerequisite is present, installing with apt where it can.
fn ensure_prerequisites(install: bool) -> Result<(), Error> {
    let missing: Vec<&Prerequisite> = PREREQUISITES.iter().filter(|p| !(p.present)()).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let has_apt = Command::new("apt-get").arg("--version").output().is_ok();
    if install && has_apt {
        let packages: Vec<&str> = missing
            .iter()
            .flat_map(|p| p.debian_packages.iter().copied())
            .collect();
        apt_install(&packages)?;
    }
    let still_missing: Vec<String> = PREREQUISITES
        .iter()
        .filter(|p| !(p.present)())
        .map(|p| format!("{} (Debian: {})", p.what, p.debian_packages.join(" ")))
        .collect();
    if still_missing.is_empty() {
        return Ok(());
    }
    let message = format!(
        "missing test prerequisites: {}{}",
        still_missing.join("; "),
        if has_apt {
            ""
        } else {
            " — this system has no apt-get; install them with its package manager"
        }
    );
    if in_ci() {
        Err(Error::Tool(message))
    } else {
        eprintln!("xtask: warning: {message}; tests that need them will be skipped");
        Ok(())
    }
}

fn ensure_components() -> Result<(), Error> {
    for (component, probe) in [
        ("rustfmt", ["fmt", "--version"]),
        ("clippy", ["clippy", "--version"]),
    ] {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let ok = Command::new(&cargo)
            .args(probe)
            .output()
            .is_ok_and(|o| o.status.success());
        if !ok {
            run_step(
                &format!("install the {component} component"),
                Command::new("rustup").args(["component", "add", component]),
            )?;
        }
    }
    Ok(())
}

/// The whole test run.
pub fn run(root: &Path, install: bool) -> Result<(), Error> {
    ensure_prerequisites(install)?;
    let driver_vars = crate::drivers::prepare(root, install)?;
    ensure_components()?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    run_step(
        "formatting",
        Command::new(&cargo)
            .current_dir(root)
            .args(["fmt", "--all", "--", "--check"]),
    )?;
    run_step(
        "clippy",
        Command::new(&cargo).current_dir(root).args([
            "clippy",
            "--workspace",
            "--all-targets",
            "--",
            "-D",
            "warnings",
        ]),
    )?;
    run_tests(
        Command::new(&cargo)
            .current_dir(root)
            .args(["test", "--workspace"])
            .envs(driver_vars),
    )?;
    // Hostile input: the raw-pointer reader's tests under Miri, then every
    // fuzz target for a short while (each finding fails the run).
    let started = std::time::Instant::now();
    crate::fuzz::miri(root, &crate::target_dir(root))?;
    eprintln!("xtask: Miri took {} s", started.elapsed().as_secs());
    let started = std::time::Instant::now();
    crate::fuzz::run(
        root,
        &crate::fuzz::Options {
            seconds: crate::fuzz::SMOKE_SECONDS,
            targets: crate::fuzz::TARGETS.map(String::from).to_vec(),
            jobs: 1,
            minimize: false,
            prebuilt: None,
        },
    )?;
    eprintln!(
        "xtask: the fuzz smoke run took {} s",
        started.elapsed().as_secs()
    );
    Ok(())
}

/// `cargo xtask asan`: the tests through the real loader (over the Mock
/// ICD and the project's fake driver, `layer/fake-icd`) with
/// AddressSanitizer. `RUSTFLAGS=-Zsanitizer=address` with an explicit
/// `--target` instruments what is built for the target (the test binaries,
/// vk-probe, omm-app and omm-stress, the layer's and the fake driver's
/// cdylibs) but not build scripts and proc-macros. The executables carry
/// the ASan runtime and export it (`--export-dynamic`); the layer and the
/// fake driver, loaded by the (uninstrumented) system loader into them,
/// bind to it there, so no LD_PRELOAD of a shared runtime is needed. Not
/// part of `cargo xtask test`: building it all with nightly from nothing
/// took 8 min 20 s on 2 shared cores (4 min of CPU), where CI has about 3
/// minutes to spare.
pub fn sanitize(root: &Path, install: bool) -> Result<(), Error> {
    ensure_prerequisites(install)?;
    let driver_vars = crate::drivers::prepare(root, install)?;
    crate::fuzz::ensure_nightly(&["rust-src"])?;
    let triple = crate::fuzz::host_triple()?;
    run_step(
        "the tests through the loader under AddressSanitizer",
        crate::fuzz::nightly_cargo()
            .current_dir(root)
            // Rust links the ASan runtime into executables statically and,
            // unlike clang, does not export its symbols; a dlopen'ed
            // instrumented layer then fails with `undefined symbol:
            // __asan_option_detect_stack_use_after_return` (the loader says
            // "Layer specified does not exist"). Exporting the executables'
            // symbols lets the layer bind to the one runtime in the process.
            .env(
                "RUSTFLAGS",
                "-Zsanitizer=address -Clink-arg=-Wl,--export-dynamic",
            )
            // Leaks: the loader and the Mock ICD keep allocations until exit.
            // Quarantine: ASan holds freed blocks back (256 MB by default) to
            // catch uses after free, so the resident memory of
            // fake_driver.rs's soak grew 1.43x after its 10% mark and failed
            // its 1.1x leak bound (133.7 to 190.6 MiB); with 8 MB the
            // quarantine is full by then and the bound holds.
            .env("ASAN_OPTIONS", "detect_leaks=0:quarantine_size_mb=8")
            .env("CARGO_TARGET_DIR", crate::target_dir(root).join("asan"))
            .envs(driver_vars)
            .args(["test", "-p", "ommcheck-tests", "--target", &triple])
            .args([
                "--test",
                "loader",
                "--test",
                "layer_e2e",
                "--test",
                "fake_driver",
            ]),
    )
}

/// Runs `cargo test`, passing its output through, and closes with the
/// totals over every test binary on one line: `xtask: N passed, M failed`.
fn run_tests(command: &mut Command) -> Result<(), Error> {
    eprintln!("xtask: tests: {command:?}");
    let mut child = command
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| Error::Tool(format!("tests: could not start: {e}")))?;
    let stdout = child.stdout.take().expect("piped stdout");
    let (mut passed, mut failed, mut ignored) = (0u64, 0u64, 0u64);
    for line in BufReader::new(stdout).lines() {
        let line = line.map_err(|e| Error::Tool(format!("tests: reading output: {e}")))?;
        println!("{line}");
        if let Some(counts) = line.strip_prefix("test result: ") {
            for part in counts.split([';', '.']) {
                let mut words = part.split_whitespace();
                if let (Some(n), Some(what)) = (words.next(), words.next()) {
                    let n: u64 = n.parse().unwrap_or(0);
                    match what {
                        "passed" => passed += n,
                        "failed" => failed += n,
                        "ignored" => ignored += n,
                        _ => {}
                    }
                }
            }
        }
    }
    let status = child
        .wait()
        .map_err(|e| Error::Tool(format!("tests: {e}")))?;
    println!("xtask: {passed} passed, {failed} failed, {ignored} skipped");
    if status.success() {
        Ok(())
    } else {
        Err(Error::Tool(format!("tests failed ({status})")))
    }
}
