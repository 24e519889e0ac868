//! The `ommcheck` command line.

use std::io::Write as _;
use std::process::ExitCode;

mod progress;

use clap::{Parser, Subcommand};
use ommcheck::scene::{
    CheckOptions, LimitsOverride, Output, Scene, SceneReport, StatsReport, StatsSummary, Summary,
    TraceReport, TraceSummary,
};
use rayon::prelude::*;

/// A checker for Vulkan opacity-micromap API usage.
#[derive(Parser)]
#[command(name = "ommcheck", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    Text,
    Json,
}

/// `check`'s formats: `--format`'s of the other commands, and the HTML page.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum CheckFormat {
    Text,
    Json,
    /// One self-contained HTML page (docs/cli.md, "The HTML report").
    Html,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Deny {
    Warnings,
}

#[derive(Subcommand)]
enum Command {
    /// Check scene files and print a VUID report.
    ///
    /// Exit status: 0 when no errors were found, 1 when some were (or warnings, with --deny
    /// warnings), 2 when a scene could not be read.
    Check {
        /// Check the built-in example scene (embedded in the binary;
        /// `ommcheck example` prints it).
        #[arg(long)]
        example: bool,
        /// Scene files to check (JSON; see docs/scene-format.md), or
        /// directories: every `.json` file under one is a scene, checked in
        /// path order.
        scenes: Vec<std::path::PathBuf>,
        #[arg(long, value_enum, default_value_t = CheckFormat::Text)]
        format: CheckFormat,
        /// Also write the report as one self-contained HTML page to FILE
        /// (findings by rule, pictures of what they point at, what was not
        /// checked), whatever --format prints.
        #[arg(long, value_name = "FILE")]
        html: Option<std::path::PathBuf>,
        /// Check under these limits instead of each scene's: spec-minimum,
        /// permissive, or a JSON file of limits by spec member name.
        #[arg(long, value_name = "NAME|FILE")]
        profile: Option<String>,
        /// Treat findings of this severity as errors for the exit status.
        #[arg(long, value_enum)]
        deny: Option<Deny>,
        /// How far the checks look: params (the calls' parameters and the
        /// device), state (+ the objects earlier calls created), content
        /// (+ the bytes builds read, no micromap data block), simulate
        /// (+ the hygiene information on the data blocks; `ommcheck trace`
        /// simulates the rays).
        #[arg(long, default_value_t = ommcheck::Tier::Content)]
        tier: ommcheck::Tier,
    },
    /// Check each scene's calls, then simulate each of its `rays`.
    ///
    /// For each ray: the outcome set, the micromap slot, the micro-triangles and their states,
    /// and the rule that decided it. The JSON form is `check`'s (scenes,
    /// findings, summary) with the rays added. Exit status: 0 when every ray
    /// was simulated and the calls had no errors, 1 when they had errors or
    /// a ray could not be simulated, 2 when a scene could not be read.
    Trace {
        /// Scene files (JSON; see docs/scene-format.md).
        #[arg(required = true)]
        scenes: Vec<std::path::PathBuf>,
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// Also draw each ray that read a micromap triangle into DIR
        /// (`SCENE-rayN.svg`, or `.png` with --draw-png): the triangle, the
        /// hit as a dot, and the micro-triangles within its error bound
        /// outlined (docs/pictures.md).
        #[arg(long, value_name = "DIR")]
        draw: Option<std::path::PathBuf>,
        /// With --draw: write PNG instead of SVG.
        #[arg(long, requires = "draw")]
        draw_png: bool,
    },
    /// Count the micro-triangles of each micromap the scene builds, by state.
    ///
    /// Runs each scene's calls, then for each opacity micromap built and in
    /// total: by format and level, the micro-triangles in each state, stored
    /// (each micromap triangle once) and referenced (once per geometry
    /// triangle whose opacity index selects it); the triangles whose states
    /// are all alike, which a special index could replace; and the special
    /// indices used. Exit status: 0, or 2 when a scene could not be read.
    Stats {
        /// Scene files (JSON; see docs/scene-format.md).
        #[arg(required = true)]
        scenes: Vec<std::path::PathBuf>,
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
        /// Instead of the census, print every micro-triangle's state of
        /// every opacity micromap built, in JSON (whatever --format says):
        /// per triangle a string of digits in the specification's order,
        /// 0 transparent, 1 opaque, 2 unknown-transparent, 3 unknown-opaque.
        #[arg(long)]
        states: bool,
    },
    /// Draw a micromap or a BLAS geometry as SVG or PNG.
    ///
    /// --micromap NAME draws the micromap's triangles as a grid, one of
    /// them with --triangle, or its build's usage counts against its
    /// triangle array with --usage-counts; --acceleration-structure NAME
    /// draws one of its geometries with the micromap triangle each geometry
    /// triangle selects, over its alpha texture where the scene names one.
    /// The findings of the scene's calls are marked where they point
    /// (--no-findings leaves them out). Colours, the downsampling rule of
    /// deep levels and the marks: docs/pictures.md. Exit status: 0, or 2
    /// when the scene could not be read, nothing matches the names, or the
    /// file could not be written.
    Draw {
        /// A scene file (JSON; see docs/scene-format.md).
        scene: std::path::PathBuf,
        /// The picture: SVG or PNG, by the file's extension.
        #[arg(long, value_name = "FILE.svg|FILE.png")]
        out: std::path::PathBuf,
        /// The micromap to draw, by its scene name.
        #[arg(
            long,
            required_unless_present = "acceleration_structure",
            conflicts_with = "acceleration_structure"
        )]
        micromap: Option<String>,
        /// Only this triangle of the micromap (its index in the triangle array).
        #[arg(long, requires = "micromap")]
        triangle: Option<u64>,
        /// The micromap build's usage counts against its triangle array, a
        /// histogram per (format, subdivision level).
        #[arg(long, requires = "micromap", conflicts_with = "triangle")]
        usage_counts: bool,
        /// Draw the data alone, without marking the scene's findings.
        #[arg(long)]
        no_findings: bool,
        /// The bottom-level acceleration structure to draw, by its scene name.
        #[arg(long, value_name = "NAME")]
        acceleration_structure: Option<String>,
        /// Its geometry (default 0).
        #[arg(long, requires = "acceleration_structure", default_value_t = 0)]
        geometry: u32,
    },
    /// Map barycentrics to a micro-triangle index, or an index to its micro-triangle.
    Index {
        /// Subdivision level, 0 to 12.
        #[arg(long)]
        level: u32,
        /// Hit barycentrics: u weighs vertex 1, v vertex 2.
        #[arg(long, num_args = 2, value_names = ["U", "V"], allow_negative_numbers = true, conflicts_with = "index")]
        uv: Option<Vec<f32>>,
        /// A micro-triangle index.
        #[arg(long, required_unless_present = "uv")]
        index: Option<u32>,
        /// The error the barycentrics may carry (default: 4 f32 ulps of 1).
        #[arg(long, default_value_t = ommcheck::sim::index::DEFAULT_DELTA)]
        delta: f64,
        #[arg(long, value_enum, default_value_t = Format::Text)]
        format: Format,
    },
    /// Print the JSON Schema of scene files (docs/scene.schema.json).
    Schema,
    /// Print the built-in example scene: `ommcheck example > scene.json`.
    ///
    /// The scene `check --example` checks, a micromap build and a BLAS build
    /// with realistic mistakes, as a starting point for a scene of your own.
    Example,
    /// Explain a rule: enforced or not, at which tier, and by the Khronos layer.
    ///
    /// Prints whether ommcheck enforces the rule, the tier that decides it
    /// (or why it cannot be decided), whether the Khronos validation layer
    /// checks it, its statement and link. Exit status 1 when nothing matches
    /// (with the closest ids).
    Vuid {
        /// A VUID (VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516, in any
        /// case, `VUID-` optional), a bare number (07516: every VUID with
        /// it), or a rule of ours (OMMCHECK-attach-index-in-range).
        id: String,
    },
}

fn main() -> ExitCode {
    match Cli::parse().command {
        Command::Check {
            example,
            scenes,
            format,
            html,
            profile,
            deny,
            tier,
        } => check_command(
            example,
            &scenes,
            (format, html.as_deref()),
            profile.as_deref(),
            deny,
            tier,
        ),
        Command::Trace {
            scenes,
            format,
            draw,
            draw_png,
        } => {
            let draw = draw.map(|dir| (dir, if draw_png { "png" } else { "svg" }));
            trace_command(&scenes, format, draw.as_ref())
        }
        Command::Stats {
            scenes,
            states: true,
            ..
        } => states_command(&scenes),
        Command::Stats { scenes, format, .. } => stats_command(&scenes, format),
        Command::Draw {
            scene,
            out,
            micromap,
            triangle,
            usage_counts,
            no_findings,
            acceleration_structure,
            geometry,
        } => {
            let pick = match (micromap, acceleration_structure) {
                (Some(name), _) if usage_counts => ommcheck::draw::Pick::UsageCounts { name },
                (Some(name), _) => ommcheck::draw::Pick::Micromap { name, triangle },
                (None, Some(name)) => ommcheck::draw::Pick::Geometry { name, geometry },
                (None, None) => {
                    unreachable!("clap requires --micromap or --acceleration-structure")
                }
            };
            draw_command(&scene, &out, &pick, !no_findings)
        }
        Command::Index {
            level,
            uv,
            index,
            delta,
            format,
        } => index_command(level, uv.as_deref(), index, delta, format),
        Command::Schema => {
            print!("{}", ommcheck::scene::schema());
            ExitCode::SUCCESS
        }
        Command::Example => {
            print!("{}", ommcheck::scene::EXAMPLE);
            ExitCode::SUCCESS
        }
        Command::Vuid { id } => vuid_command(&id),
    }
}

/// `ommcheck vuid`: every rule the query names, or the closest ids.
fn vuid_command(query: &str) -> ExitCode {
    match ommcheck::explain::lookup(query) {
        Ok(rules) => {
            let texts: Vec<String> = rules.into_iter().map(ommcheck::explain::render).collect();
            print!("{}", texts.join("\n"));
            ExitCode::SUCCESS
        }
        Err(not_found) => {
            let hint = ommcheck::suggest::sentence(&not_found.suggestions)
                .map(|s| format!("; {s}"))
                .unwrap_or_default();
            eprintln!(
                "ommcheck: `{}` is neither a micromap VUID of Vulkan {}, nor the number of one, nor a rule of ours (OMMCHECK-...){hint}",
                not_found.query,
                ommcheck::vuids::REGISTRY_VERSION
            );
            ExitCode::from(1)
        }
    }
}

/// `ommcheck check`: reads every scene first (a scene that cannot be read
/// stops the run with status 2 before anything is checked), then checks
/// each and prints the findings in `format`, and writes the HTML page to
/// the file `html` names, if it names one.
fn check_command(
    example: bool,
    paths: &[std::path::PathBuf],
    (format, html): (CheckFormat, Option<&std::path::Path>),
    profile: Option<&str>,
    deny: Option<Deny>,
    tier: ommcheck::Tier,
) -> ExitCode {
    if !example && paths.is_empty() {
        eprintln!("ommcheck: give scene files or --example");
        return ExitCode::from(2);
    }
    let limits = match profile {
        None => None,
        Some(name) => match ommcheck::Profile::from_name(name) {
            Some(profile) => Some(LimitsOverride::Profile(profile)),
            None => match ommcheck::scene::read_profile_file(std::path::Path::new(name)) {
                Ok(limits) => Some(LimitsOverride::Limits(limits)),
                Err(message) => {
                    eprintln!("ommcheck: --profile {name}: {message}");
                    return ExitCode::from(2);
                }
            },
        },
    };
    let options = CheckOptions { limits, tier };
    let paths = match scene_files(paths) {
        Ok(paths) => paths,
        Err(message) => {
            eprintln!("ommcheck: {message}");
            return ExitCode::from(2);
        }
    };
    let scene_bytes: u64 = paths
        .iter()
        .filter_map(|p| std::fs::metadata(p).ok())
        .map(|m| m.len())
        .sum();
    let progress = progress::for_scenes(paths.len() as u64 + u64::from(example), scene_bytes);
    // Each scene is read and checked on its own, on every core; the
    // reports keep the input order, and the first scene (in that order)
    // that cannot be read or resolved decides the error.
    let check = |scene: Result<Scene, String>| {
        let checked = scene.and_then(|scene| scene.check(&options).map_err(|e| e.to_string()));
        progress.inc(1);
        checked
    };
    let example_report = example.then(|| check(Ok(Scene::example())));
    let file_reports: Vec<Result<SceneReport, String>> = paths
        .par_iter()
        .map(|path| check(Scene::load(path).map_err(|e| e.to_string())))
        .collect();
    progress.finish_and_clear();
    let mut reports: Vec<SceneReport> = Vec::new();
    for checked in example_report.into_iter().chain(file_reports) {
        match checked {
            Ok(report) => reports.push(report),
            Err(error) => {
                eprintln!("ommcheck: {error}");
                return ExitCode::from(2);
            }
        }
    }
    let summary = Summary::of(&reports);
    let page = || {
        ommcheck::html::page(
            &reports,
            &summary,
            &options,
            &ommcheck::html::LIMITS,
            &ommcheck::html::Source::reload,
        )
    };
    let printed = match format {
        CheckFormat::Html => {
            print!("{}", page());
            Ok(())
        }
        CheckFormat::Text | CheckFormat::Json => {
            let format = if format == CheckFormat::Json {
                Format::Json
            } else {
                Format::Text
            };
            print_reports(
                format,
                &reports,
                &summary,
                SceneReport::text,
                summary.line(),
            )
        }
    };
    if let Err(status) = printed {
        return status;
    }
    if let Some(file) = html {
        if let Err(error) = std::fs::write(file, page()) {
            eprintln!(
                "ommcheck: {}: cannot write the HTML report: {error}",
                file.display()
            );
            return ExitCode::from(2);
        }
    }
    let denied_warnings = deny == Some(Deny::Warnings) && summary.warnings > 0;
    if summary.errors > 0 || denied_warnings {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// The scene files `paths` name: a file as given, a directory as every
/// `.json` file under it (at any depth), in path order. Links to
/// directories below a given directory are not followed, so a link back
/// up the tree cannot make the walk endless.
fn scene_files(paths: &[std::path::PathBuf]) -> Result<Vec<std::path::PathBuf>, String> {
    let mut files = Vec::new();
    for path in paths {
        if !path.is_dir() {
            files.push(path.clone());
            continue;
        }
        let mut found = Vec::new();
        let mut pending = vec![path.clone()];
        while let Some(dir) = pending.pop() {
            let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            for entry in entries {
                let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
                let path = entry.path();
                // `file_type` does not follow links, unlike `Path::is_dir`.
                if entry.file_type().is_ok_and(|t| t.is_dir()) {
                    pending.push(path);
                } else if path.extension().is_some_and(|e| e == "json") {
                    found.push(path);
                }
            }
        }
        if found.is_empty() {
            return Err(format!("{}: no scene (.json) files", path.display()));
        }
        found.sort();
        files.extend(found);
    }
    Ok(files)
}

/// `ommcheck trace`: reads every scene first (status 2 before anything runs
/// when one cannot be read or resolved), then for each the calls' findings
/// and each ray's answer.
fn trace_command(
    paths: &[std::path::PathBuf],
    format: Format,
    draw: Option<&(std::path::PathBuf, &str)>,
) -> ExitCode {
    let options = CheckOptions {
        tier: ommcheck::Tier::Simulate,
        ..CheckOptions::default()
    };
    let mut reports = Vec::with_capacity(paths.len());
    for path in paths {
        match Scene::load(path).and_then(|scene| scene.trace(&options)) {
            Ok(report) => reports.push(report),
            Err(error) => {
                eprintln!("ommcheck: {error}");
                return ExitCode::from(2);
            }
        }
    }
    let summary = TraceSummary::of(&reports);
    if let Err(status) = print_reports(
        format,
        &reports,
        &summary,
        TraceReport::text,
        summary.line(),
    ) {
        return status;
    }
    for report in &reports {
        for ray in &report.rays {
            if let Some(error) = &ray.error {
                eprintln!(
                    "ommcheck: {}: rays[{}] not simulated: {error}",
                    report.path, ray.ray
                );
            }
        }
    }
    if let Some((dir, extension)) = draw {
        for (path, report) in paths.iter().zip(&reports) {
            if let Err(error) = draw_rays(path, report, &options, dir, extension) {
                eprintln!("ommcheck: {error}");
                return ExitCode::from(2);
            }
        }
    }
    if summary.success() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// `ommcheck trace --draw`: a picture of each ray of `report` that read a
/// micromap triangle, in `dir` as `STEM-rayN.EXTENSION`; a ray that read
/// none is said on stderr. An error: the scene or a file failed.
fn draw_rays(
    path: &std::path::Path,
    report: &TraceReport,
    options: &CheckOptions,
    dir: &std::path::Path,
    extension: &str,
) -> Result<(), String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let drawable =
        ommcheck::draw::Drawable::run_with(&scene, options).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let stem = path
        .file_stem()
        .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
    for ray in &report.rays {
        match drawable.ray(ray) {
            Ok(picture) => {
                let file = dir.join(format!("{stem}-ray{}.{extension}", ray.ray));
                picture.write(&file).map_err(|e| e.to_string())?;
                eprintln!("ommcheck: wrote {}", file.display());
            }
            Err(why) => eprintln!(
                "ommcheck: {}: rays[{}] not drawn: {why}",
                report.path, ray.ray
            ),
        }
    }
    Ok(())
}

/// `ommcheck stats`: reads and runs every scene first (status 2 before
/// anything is printed when one cannot be read or resolved), then prints
/// each one's census.
fn stats_command(paths: &[std::path::PathBuf], format: Format) -> ExitCode {
    let mut reports = Vec::with_capacity(paths.len());
    for path in paths {
        match Scene::load(path).and_then(|scene| scene.stats()) {
            Ok(report) => reports.push(report),
            Err(error) => {
                eprintln!("ommcheck: {error}");
                return ExitCode::from(2);
            }
        }
    }
    let summary = StatsSummary::of(&reports);
    match print_reports(
        format,
        &reports,
        &summary,
        StatsReport::text,
        summary.line(),
    ) {
        Ok(()) => ExitCode::SUCCESS,
        Err(status) => status,
    }
}

/// `ommcheck stats --states`: every scene's micromaps' states, in JSON.
fn states_command(paths: &[std::path::PathBuf]) -> ExitCode {
    let mut scenes = Vec::with_capacity(paths.len());
    for path in paths {
        match Scene::load(path) {
            Ok(scene) => scenes.push(scene),
            Err(error) => {
                eprintln!("ommcheck: {error}");
                return ExitCode::from(2);
            }
        }
    }
    let output = match ommcheck::draw::states::states_of(&scenes) {
        Ok(output) => output,
        Err(error) => {
            eprintln!("ommcheck: {error}");
            return ExitCode::from(2);
        }
    };
    // Written as it is serialized: the listing can be hundreds of MiB.
    let mut stdout = std::io::BufWriter::new(std::io::stdout().lock());
    let written = serde_json::to_writer_pretty(&mut stdout, &output)
        .map_err(|e| e.to_string())
        .and_then(|()| {
            writeln!(stdout)
                .and_then(|()| stdout.flush())
                .map_err(|e| e.to_string())
        });
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("ommcheck: cannot write the states: {error}");
            ExitCode::from(2)
        }
    }
}

/// `ommcheck draw`: runs the scene's calls, draws what the pick names
/// (with the marks of the findings when `marks`) and writes it as the
/// extension of `out` says.
fn draw_command(
    path: &std::path::Path,
    out: &std::path::Path,
    pick: &ommcheck::draw::Pick,
    marks: bool,
) -> ExitCode {
    use ommcheck::draw::{DrawError, Drawable, Source};
    let drawn = Source::load(path)
        .and_then(|source| Drawable::run_source(&source, &Default::default()))
        .map_err(DrawError::Scene)
        .and_then(|mut drawable| {
            drawable.marks = marks;
            drawable.draw(pick)
        })
        .and_then(|picture| picture.write(out));
    match drawn {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("ommcheck: {error}");
            ExitCode::from(2)
        }
    }
}

/// Prints the scenes' reports: in JSON, `scenes` and `summary` (one layout
/// for `check` and `trace`); as text, each scene's `text` and then the
/// summary `line`. Status 2 when the JSON cannot be written.
fn print_reports<R: serde::Serialize, S: serde::Serialize>(
    format: Format,
    reports: &[R],
    summary: &S,
    text: impl Fn(&R) -> String,
    line: String,
) -> Result<(), ExitCode> {
    match format {
        Format::Json => {
            let output = Output {
                scenes: reports,
                summary,
            };
            match serde_json::to_string_pretty(&output) {
                Ok(json) => println!("{json}"),
                Err(error) => {
                    eprintln!("ommcheck: cannot write the report: {error}");
                    return Err(ExitCode::from(2));
                }
            }
        }
        Format::Text => {
            for report in reports {
                print!("{}", text(report));
            }
            println!("{line}");
        }
    }
    Ok(())
}

/// `ommcheck index`: one mapping, as text or JSON.
fn index_command(
    level: u32,
    uv: Option<&[f32]>,
    index: Option<u32>,
    delta: f64,
    format: Format,
) -> ExitCode {
    use ommcheck::sim::index::{candidates, spec_triangle, MicroTriangle, MAX_LEVEL};
    if level > MAX_LEVEL {
        eprintln!("ommcheck: --level {level} is above the highest subdivision level, {MAX_LEVEL}");
        return ExitCode::from(2);
    }
    let (triangle, ambiguous) = match (uv, index) {
        (Some([u, v]), _) => {
            let (triangle, set) = match (
                spec_triangle(*u, *v, level),
                candidates(*u, *v, level, delta),
            ) {
                (Ok(t), Ok(set)) => (t, set),
                (_, Err(ommcheck::sim::index::BaryError::TooUncertain)) => {
                    eprintln!("ommcheck: --delta {delta} spans more than {} micro-triangles: the whole triangle is uncertain", ommcheck::sim::index::MAX_CANDIDATE_SPAN);
                    return ExitCode::from(2);
                }
                _ => {
                    eprintln!("ommcheck: the barycentrics ({u}, {v}) are not numbers");
                    return ExitCode::from(2);
                }
            };
            let ambiguous: Vec<u32> = if set.len() > 1 {
                set.into_iter().collect()
            } else {
                Vec::new()
            };
            (triangle, Some(ambiguous))
        }
        (_, Some(i)) => match MicroTriangle::from_index(i, level) {
            Some(t) => (t, None),
            None => {
                eprintln!("ommcheck: index {i} is not below 4^{level}");
                return ExitCode::from(2);
            }
        },
        _ => unreachable!("clap requires --uv or --index"),
    };
    let index = triangle.index(level);
    let vertices = triangle.vertices(level);
    match format {
        Format::Json => {
            let mut json = serde_json::json!({
                "index": index,
                "upright": triangle.upright,
                "i": triangle.i,
                "j": triangle.j,
                "vertices": vertices.map(|(u, v)| [u, v]),
            });
            if let Some(ambiguous) = ambiguous {
                json["ambiguous"] = serde_json::json!(ambiguous);
            }
            println!("{json}");
        }
        Format::Text => {
            let shape = if triangle.upright {
                "upright"
            } else {
                "inverted"
            };
            println!(
                "index {index} at level {level}: {shape} micro-triangle, cell (i, j) = ({}, {})",
                triangle.i, triangle.j
            );
            let corners: Vec<String> = vertices
                .iter()
                .map(|(u, v)| format!("({u}, {v})"))
                .collect();
            println!("vertices (u, v): {}", corners.join(", "));
            match ambiguous.as_deref() {
                Some([]) => println!("definite within delta {delta}"),
                Some(set) => println!("ambiguous within delta {delta}: any of {set:?}"),
                None => {}
            }
        }
    }
    ExitCode::SUCCESS
}
