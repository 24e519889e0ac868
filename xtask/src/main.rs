//! `cargo xtask`. `layer` runs here whatever the features; every other
//! command needs the `driver` feature, and a build without it (the alias's)
//! hands the command to `cargo run -p xtask`, which builds with it.

use std::ffi::OsString;
use std::process::ExitCode;

use xtask::layer;

fn main() -> ExitCode {
    let args: Vec<OsString> = std::env::args_os().skip(1).collect();
    if args.first().is_some_and(|arg| arg == "layer") {
        return layer_command(&args[1..]);
    }
    #[cfg(all(feature = "generate", not(feature = "driver")))]
    if args.first().is_some_and(is_generate) {
        return generate_command(&args[1..]);
    }
    driver::main()
}

/// Whether `arg` names the generator's command (or its alias).
#[cfg_attr(feature = "driver", allow(dead_code))]
fn is_generate(arg: &OsString) -> bool {
    arg == "generate" || arg == "vuids"
}

/// `cargo xtask generate [--registry DIR] [--check]` in a build with only
/// the `generate` feature (the driver build parses the same with clap).
#[cfg(all(feature = "generate", not(feature = "driver")))]
fn generate_command(args: &[OsString]) -> ExitCode {
    let mut registry = xtask::default_registry();
    let mut check = false;
    let mut rest = args.iter();
    while let Some(arg) = rest.next() {
        match arg.to_str() {
            Some("--check") => check = true,
            Some("--registry") => match rest.next() {
                Some(dir) => registry = dir.into(),
                None => {
                    eprintln!("error: --registry needs a directory");
                    return ExitCode::FAILURE;
                }
            },
            _ => {
                eprintln!(
                    "error: unexpected {arg:?}; usage: cargo xtask generate [--registry DIR] [--check]"
                );
                return ExitCode::FAILURE;
            }
        }
    }
    finish(
        xtask::write_generated(&registry, &xtask::workspace_root(), check).map(|lines| {
            for line in lines {
                println!("{line}");
            }
        }),
    )
}

/// `cargo xtask layer ARGS`.
fn layer_command(args: &[OsString]) -> ExitCode {
    let options = match layer::parse_args(args) {
        Ok(options) => options,
        Err(text) => {
            eprintln!("{text}");
            return ExitCode::FAILURE;
        }
    };
    if options.help {
        println!("{}", layer::USAGE);
        return ExitCode::SUCCESS;
    }
    finish(layer::run(&xtask::workspace_root(), &options).map(|lines| {
        for line in lines {
            println!("{line}");
        }
    }))
}

fn finish(result: Result<(), xtask::Error>) -> ExitCode {
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Without the `driver` feature: the same command through a build with it.
#[cfg(not(feature = "driver"))]
mod driver {
    use std::process::{Command, ExitCode};

    pub fn main() -> ExitCode {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let args: Vec<_> = std::env::args_os().skip(1).collect();
        // The generator builds without the crates it writes into.
        let features: &[&str] = if args.first().is_some_and(super::is_generate) {
            &["--no-default-features", "--features", "generate"]
        } else {
            &[]
        };
        let status = Command::new(cargo)
            .current_dir(xtask::workspace_root())
            .args(["run", "--quiet", "--package", "xtask"])
            .args(features)
            .arg("--")
            .args(args)
            .status();
        match status {
            Ok(status) => status
                .code()
                .and_then(|code| u8::try_from(code).ok())
                .map_or(ExitCode::FAILURE, ExitCode::from),
            Err(e) => {
                eprintln!("error: cannot run cargo: {e}");
                ExitCode::FAILURE
            }
        }
    }
}

/// The commands of the test driver.
#[cfg(feature = "driver")]
mod driver {
    use std::ffi::OsString;
    use std::path::PathBuf;
    use std::process::ExitCode;

    use clap::{Parser, Subcommand};

    /// Project automation for ommcheck.
    #[derive(Parser)]
    #[command(name = "cargo xtask")]
    struct Cli {
        #[command(subcommand)]
        command: Task,
    }

    #[derive(Subcommand)]
    enum Task {
        /// Generate the VUID catalog, the KHR declarations, the alias tables
        /// and the scene's enum and flag names from the Vulkan registry.
        #[command(visible_alias = "vuids")]
        Generate {
            /// Directory with vk.xml and validusage.json (a Vulkan SDK has them in
            /// $VULKAN_SDK/share/vulkan/registry).
            #[arg(long, default_value_os_t = xtask::default_registry())]
            registry: PathBuf,
            /// Fail if the committed files differ from what the registry generates.
            #[arg(long)]
            check: bool,
        },
        /// Print the import graph between the top-level modules of
        /// validator/src, layer/src and xtask/src in layers from the bottom;
        /// fail on an import cycle.
        Modules,
        /// Count the core's hand-written lines (blank, comment, inline-test
        /// and generated lines left out): validator/src/{scene,raw,model}
        /// and all of validator/src.
        Lines {
            /// Also list each hand-written file of scene/, raw/ and model/
            /// with its count, largest first.
            #[arg(long)]
            files: bool,
        },
        /// Write VUID-COVERAGE.md (every catalog VUID's status) and docs/rules.md's table of our rules.
        Coverage,
        /// Build the Vulkan layer in release and write its manifest,
        /// VkLayer_ommcheck.json; --install, --uninstall (`cargo xtask layer --help`).
        Layer {
            #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
            args: Vec<OsString>,
        },
        /// Check the seeded fault corpus at each tier and print the accuracy table.
        Accuracy {
            /// The corpus seed.
            #[arg(long, default_value_t = xtask::faults::SEED)]
            seed: u64,
        },
        /// Run the ommcheck benchmarks; write target/bench/README-table.md and tiers.svg.
        Bench {
            /// criterion's short run: 1 s warm-up, 2 s measurement per benchmark.
            #[arg(long)]
            quick: bool,
            /// Skip criterion; run only the layer overhead per call (omm-app over
            /// the Mock ICD) and replace its section of the table.
            #[arg(long)]
            overhead_only: bool,
        },
        /// The layer overhead per call of issue 18's params floor: omm-app over
        /// the Mock ICD with no layer, ommcheck and the Khronos layer,
        /// interleaved round by round over 1, 10^3 and 10^5 micromap
        /// triangles with 1 and 64 usage entries; prints each call's median.
        Overhead {
            /// Rounds (one process per shape and configuration each).
            rounds: usize,
            /// Calls timed per command and process.
            iterations: u32,
            /// ommcheck's tier.
            #[arg(long, default_value = "params")]
            tier: String,
        },
        /// A long workload through the real Vulkan loader, the layer (release)
        /// and the fake driver (layer/fake-icd): micromap and BLAS builds whose
        /// inputs the layer reads back, resubmissions and destroys, and
        /// top-level builds over lavapipe where it is installed. Prints one
        /// line `soak: ...`; fails on findings other than those planted or
        /// resident memory at the end above 1.1 times its 10% mark.
        Soak {
            /// Submissions in all.
            #[arg(long, default_value_t = 100_000)]
            submissions: u64,
            /// Take omm-stress, libVkLayer_ommcheck.so and
            /// libVkICD_ommcheck_fake.so (release) from DIR instead of building.
            #[arg(long)]
            prebuilt: Option<PathBuf>,
            /// Leave lavapipe out even where installed: its 65 MiB or so in the
            /// process make the memory bound ten times looser.
            #[arg(long)]
            without_lavapipe: bool,
        },
        /// The layer's overhead per call at the params and content tiers against
        /// the thread count (1, 2, 4, 8, 16), over the fake driver through the
        /// real loader; prints a markdown table.
        Threads {
            /// Rounds (one process per thread count and configuration each);
            /// the table gives medians.
            #[arg(long, default_value_t = 5)]
            rounds: usize,
            /// Calls of each command timed per thread and process.
            #[arg(long, default_value_t = 10_000)]
            iterations: u32,
            /// As for `soak`.
            #[arg(long)]
            prebuilt: Option<PathBuf>,
        },
        /// Install what the tests need, then run fmt, clippy and the whole test suite.
        Test {
            /// Do not install missing prerequisites; report them.
            #[arg(long)]
            no_install: bool,
        },
        /// The tests through the real Vulkan loader (tests/loader.rs,
        /// tests/layer_e2e.rs, tests/fake_driver.rs) with the test binaries,
        /// the layer and the fake driver built with AddressSanitizer
        /// (nightly). Not part of `test`: its build alone takes longer than
        /// CI can spare (docs/hostile-input.md).
        Asan {
            /// Do not install missing prerequisites; report them.
            #[arg(long)]
            no_install: bool,
        },
        /// Fuzz the reader (device and host builds), decoder, simulator and
        /// scene parser with cargo-fuzz (installing nightly and cargo-fuzz where
        /// missing).
        Fuzz {
            /// 25 s per target, as `cargo xtask test` runs it.
            #[arg(long, conflicts_with_all = ["long", "seconds", "minutes"])]
            smoke: bool,
            /// 10 minutes per target.
            #[arg(long, conflicts_with_all = ["seconds", "minutes"])]
            long: bool,
            /// Seconds per target (default: the smoke run's).
            #[arg(long, conflicts_with = "minutes")]
            seconds: Option<u64>,
            /// Fuzzing that accumulates: N minutes per target from the kept
            /// corpus, then merge into fuzz/corpus/<target> and record the
            /// executions in fuzz/executions.tsv and docs/hostile-input.md
            /// (`--seconds 60N --minimize`).
            #[arg(long)]
            minutes: Option<u64>,
            /// libFuzzer processes per target, side by side (one per core).
            #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u16).range(1..))]
            jobs: u16,
            /// Afterwards, add to fuzz/corpus/<target> the inputs of the run that
            /// reach new edges (deleting none), and record the run's executions.
            #[arg(long)]
            minimize: bool,
            /// Take the fuzz binaries from DIR (as `--build-only` leaves them)
            /// instead of building: no toolchain needed. The corpus and the
            /// record are those under the current directory, which must be the
            /// repository's root.
            #[arg(long, conflicts_with = "build_only")]
            prebuilt: Option<PathBuf>,
            /// Only build the fuzz binaries, and print their directory.
            #[arg(long)]
            build_only: bool,
            /// Targets to run (default: all).
            targets: Vec<String>,
        },
    }

    pub fn main() -> ExitCode {
        let cli = Cli::parse();
        let root = xtask::workspace_root();
        let result = match cli.command {
            Task::Generate { registry, check } => xtask::write_generated(&registry, &root, check)
                .map(|lines| {
                    for line in lines {
                        println!("{line}");
                    }
                }),
            Task::Coverage => {
                let path = root.join("VUID-COVERAGE.md");
                let readme_path = root.join("docs/rules.md");
                ommcheck::coverage::corpus_tiers(&root.join(ommcheck::coverage::CORPUS))
                    .map_err(xtask::Error::Tool)
                    .and_then(|tiers| {
                        // Flag a rule whose check waits for more than its inputs need.
                        for (rule, measured, needed) in
                            ommcheck::coverage::measured_above_needed(&tiers)
                        {
                            eprintln!("xtask coverage: {rule} is measured at the {measured} tier, but its inputs need only {needed}");
                        }
                        let tiers_path = root.join(ommcheck::coverage::TIERS_FILE);
                        std::fs::write(&tiers_path, ommcheck::coverage::render_tiers(&tiers))
                            .map_err(|source| xtask::Error::Io {
                                path: tiers_path,
                                source,
                            })?;
                        std::fs::write(&path, ommcheck::coverage::render(&tiers))
                            .map_err(|source| xtask::Error::Io { path, source })
                    })
                    .and_then(|()| xtask::read(&readme_path))
                    .and_then(|readme| {
                        let updated =
                            ommcheck::coverage::update_readme(&readme).ok_or_else(|| {
                                xtask::Error::Tool(
                                    "docs/rules.md lacks the ommcheck-rules markers".into(),
                                )
                            })?;
                        std::fs::write(&readme_path, updated).map_err(|source| xtask::Error::Io {
                            path: readme_path,
                            source,
                        })
                    })
                    .map(|()| {
                        println!(
                            "wrote VUID-COVERAGE.md, {} and the rules table of docs/rules.md",
                            ommcheck::coverage::TIERS_FILE
                        )
                    })
            }
            Task::Modules => xtask::modules::run(&root).map(|report| print!("{report}")),
            Task::Lines { files } => {
                xtask::lines::report(&root, files).map(|report| println!("{report}"))
            }
            Task::Layer { args } => return super::layer_command(&args),
            Task::Accuracy { seed } => {
                let classes = xtask::faults::classes().len();
                xtask::faults::accuracy(&xtask::faults::corpus(seed))
                    .map_err(xtask::Error::Tool)
                    .map(|table| print!("{}", xtask::faults::render(&table, classes)))
            }
            Task::Bench {
                quick,
                overhead_only,
            } => xtask::bench::run(&root, quick, overhead_only),
            Task::Overhead {
                rounds,
                iterations,
                tier,
            } => xtask::bench::run_interleaved(&root, rounds, iterations, &tier),
            Task::Soak {
                submissions,
                prebuilt,
                without_lavapipe,
            } => xtask::stress::soak(&root, submissions, prebuilt.as_deref(), !without_lavapipe),
            Task::Threads {
                rounds,
                iterations,
                prebuilt,
            } => xtask::stress::threads(&root, rounds, iterations, prebuilt.as_deref()),
            Task::Test { no_install } => xtask::testing::run(&root, !no_install),
            Task::Asan { no_install } => xtask::testing::sanitize(&root, !no_install),
            Task::Fuzz {
                build_only: true, ..
            } => xtask::fuzz::build(&root).map(|dir| println!("{}", dir.display())),
            Task::Fuzz {
                smoke: _,
                long,
                seconds,
                minutes,
                jobs,
                minimize,
                prebuilt,
                build_only: false,
                targets,
            } => {
                let seconds = match (minutes, seconds, long) {
                    (Some(minutes), _, _) => minutes * 60,
                    (None, Some(seconds), _) => seconds,
                    (None, None, true) => xtask::fuzz::LONG_SECONDS,
                    (None, None, false) => xtask::fuzz::SMOKE_SECONDS,
                };
                let targets = if targets.is_empty() {
                    xtask::fuzz::TARGETS.map(String::from).to_vec()
                } else {
                    targets
                };
                // Prebuilt binaries are carried to another machine with the
                // repository, where this build's path does not exist.
                let root = if prebuilt.is_some() {
                    std::env::current_dir().unwrap_or(root)
                } else {
                    root
                };
                xtask::fuzz::run(
                    &root,
                    &xtask::fuzz::Options {
                        seconds,
                        targets,
                        jobs: usize::from(jobs),
                        minimize: minimize || minutes.is_some(),
                        prebuilt,
                    },
                )
                .map(|_| ())
            }
        };
        super::finish(result)
    }
}
