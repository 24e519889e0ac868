//! `cargo xtask bench`: runs the criterion benchmarks of `ommcheck`
//! (validator/benches), reads criterion's estimates, and writes what each
//! validation tier costs as a markdown table (`target/bench/README-table.md`)
//! and a log-log plot of time per build against N (`target/bench/tiers.svg`).
//!
//! The benchmark names this reads are the ones validator/benches gives:
//! - `build-time/{api}-{format}-{tier}/{N}`: one micromap build of N triangles;
//! - `content-throughput/{content|memcpy}-{format}/L{level}-N{N}`, with
//!   criterion's byte throughput: the content tier next to a memcpy of as
//!   many bytes;
//! - `referenced-fraction/{api}/{K}-of-{M}`: a bottom-level build referencing
//!   K of a micromap's M triangles, at the content tier;
//! - `params-per-call/{call}`: one small build at the params tier;
//! - `state-per-call/{api}-micromap/{B}`: one small build at the state tier
//!   while B other buffers are tracked.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

use crate::Error;

/// criterion's options for `--quick`: a short warm-up and measurement.
pub const QUICK_ARGS: [&str; 4] = ["--warm-up-time", "1", "--measurement-time", "2"];

/// Tiers in the order they look further; rows follow it.
const TIER_ORDER: [&str; 4] = ["params", "state", "content", "simulate"];

/// The per-call time the params tier aims at, in nanoseconds.
const PARAMS_TARGET_NS: f64 = 1_000.0;

/// What criterion measured for one benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    pub group: String,
    pub function: String,
    /// The benchmark's parameter (`BenchmarkId`'s value), if any.
    pub value: Option<String>,
    /// Point estimates of the time per iteration, in nanoseconds.
    pub mean_ns: f64,
    pub median_ns: f64,
    /// Bytes one iteration processes, when the benchmark declared them.
    pub bytes: Option<u64>,
    /// Elements one iteration processes, when the benchmark declared them.
    pub elements: Option<u64>,
}

fn json(text: &str, what: &Path) -> Result<Value, Error> {
    serde_json::from_str(text).map_err(|e| Error::Tool(format!("{}: {e}", what.display())))
}

/// One benchmark from criterion's `new/benchmark.json` and
/// `new/estimates.json`; `source` names them in errors.
pub fn parse_estimate(
    benchmark_json: &str,
    estimates_json: &str,
    source: &Path,
) -> Result<Estimate, Error> {
    let benchmark = json(benchmark_json, source)?;
    let estimates = json(estimates_json, source)?;
    let text = |v: &Value, key: &str| v.get(key).and_then(Value::as_str).map(str::to_string);
    let point = |key: &str| {
        estimates
            .get(key)
            .and_then(|e| e.get("point_estimate"))
            .and_then(Value::as_f64)
            .ok_or_else(|| {
                Error::Tool(format!(
                    "{}: no {key}.point_estimate in estimates.json",
                    source.display()
                ))
            })
    };
    let throughput = benchmark.get("throughput");
    let count = |kinds: &[&str]| {
        kinds
            .iter()
            .find_map(|kind| throughput.and_then(|t| t.get(kind)).and_then(Value::as_u64))
    };
    Ok(Estimate {
        group: text(&benchmark, "group_id").ok_or_else(|| {
            Error::Tool(format!(
                "{}: no group_id in benchmark.json",
                source.display()
            ))
        })?,
        function: text(&benchmark, "function_id").unwrap_or_default(),
        value: text(&benchmark, "value_str"),
        mean_ns: point("mean")?,
        median_ns: point("median")?,
        bytes: count(&["Bytes", "BytesDecimal"]),
        elements: count(&["Elements"]),
    })
}

/// Every benchmark's latest estimates under criterion's output directory
/// (`**/new/benchmark.json` with its `estimates.json`), sorted by id; with
/// `since`, only those written since then (criterion keeps the results of
/// benchmarks that no longer exist, which must not reach a table).
pub fn read_estimates(
    criterion_dir: &Path,
    since: Option<std::time::SystemTime>,
) -> Result<Vec<Estimate>, Error> {
    let mut found = Vec::new();
    let mut pending = vec![criterion_dir.to_path_buf()];
    while let Some(dir) = pending.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|source| Error::Io {
            path: dir.clone(),
            source,
        })?;
        for entry in entries.flatten() {
            let path = entry.path();
            if !path.is_dir() {
                continue;
            }
            let benchmark = path.join("benchmark.json");
            if path.file_name().is_some_and(|n| n == "new") && benchmark.is_file() {
                let estimates = path.join("estimates.json");
                let written = std::fs::metadata(&estimates).and_then(|m| m.modified());
                if since.is_some_and(|since| written.is_ok_and(|at| at < since)) {
                    continue;
                }
                found.push(parse_estimate(
                    &crate::read(&benchmark)?,
                    &crate::read(&estimates)?,
                    &path,
                )?);
            } else {
                pending.push(path);
            }
        }
    }
    found.sort_by(|a, b| (&a.group, &a.function, &a.value).cmp(&(&b.group, &b.function, &b.value)));
    Ok(found)
}

/// The machine the numbers come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Machine {
    /// `/proc/cpuinfo`'s model name.
    pub model: String,
    /// Logical processors in `/proc/cpuinfo`.
    pub cores: usize,
}

/// The machine described by the text of `/proc/cpuinfo`.
pub fn parse_cpuinfo(cpuinfo: &str) -> Machine {
    let field = |line: &str, name: &str| {
        let (key, value) = line.split_once(':')?;
        (key.trim() == name).then(|| value.trim().to_string())
    };
    Machine {
        model: cpuinfo
            .lines()
            .find_map(|l| field(l, "model name"))
            .unwrap_or_else(|| "unknown CPU".into()),
        cores: cpuinfo
            .lines()
            .filter(|l| field(l, "processor").is_some())
            .count(),
    }
}

/// This machine, from `/proc/cpuinfo` (an unknown CPU where it is missing).
pub fn this_machine() -> Machine {
    parse_cpuinfo(&std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default())
}

/// A time in nanoseconds with a unit and three significant digits.
pub fn format_time(ns: f64) -> String {
    let (value, unit) = if ns < 1e3 {
        (ns, "ns")
    } else if ns < 1e6 {
        (ns / 1e3, "µs")
    } else if ns < 1e9 {
        (ns / 1e6, "ms")
    } else {
        (ns / 1e9, "s")
    };
    let decimals = if value >= 100.0 {
        0
    } else if value >= 10.0 {
        1
    } else {
        2
    };
    format!("{value:.decimals$} {unit}")
}

/// Bytes per second as GB/s (10^9 bytes).
fn gigabytes_per_second(bytes: u64, ns: f64) -> f64 {
    bytes as f64 / ns
}

/// A count as 1, 10, 1k, 100k, 1M.
fn short_count(n: u64) -> String {
    match n {
        n if n >= 1_000_000 && n % 1_000_000 == 0 => format!("{}M", n / 1_000_000),
        n if n >= 1_000 && n % 1_000 == 0 => format!("{}k", n / 1_000),
        n => n.to_string(),
    }
}

/// `build-time` ids: `{api}-{format}-{tier}`.
fn split_build_function(function: &str) -> Option<(&str, &str, &str)> {
    let mut parts = function.splitn(3, '-');
    Some((parts.next()?, parts.next()?, parts.next()?))
}

fn tier_rank(tier: &str) -> usize {
    TIER_ORDER
        .iter()
        .position(|t| *t == tier)
        .unwrap_or(TIER_ORDER.len())
}

/// `2state` as `2-state`.
fn format_label(format: &str) -> String {
    format.replace("state", "-state")
}

/// The measured builds of one (api, format, tier) against N.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildSeries {
    pub api: String,
    pub format: String,
    pub tier: String,
    /// (N, mean ns), by N.
    pub points: Vec<(u64, f64)>,
}

impl BuildSeries {
    fn label(&self) -> String {
        format!("{} {}", self.api.to_uppercase(), format_label(&self.format))
    }
}

/// Time per build against N, one series per (api, format, tier), tiers in
/// the order they look further.
pub fn build_time_series(estimates: &[Estimate]) -> Vec<BuildSeries> {
    let mut series: Vec<BuildSeries> = Vec::new();
    for e in estimates.iter().filter(|e| e.group == "build-time") {
        let (Some((api, format, tier)), Some(n)) = (
            split_build_function(&e.function),
            e.value.as_deref().and_then(|v| v.parse::<u64>().ok()),
        ) else {
            continue;
        };
        let at = series
            .iter()
            .position(|s| {
                (s.api.as_str(), s.format.as_str(), s.tier.as_str()) == (api, format, tier)
            })
            .unwrap_or_else(|| {
                series.push(BuildSeries {
                    api: api.into(),
                    format: format.into(),
                    tier: tier.into(),
                    points: Vec::new(),
                });
                series.len() - 1
            });
        series[at].points.push((n, e.mean_ns));
    }
    for s in &mut series {
        s.points.sort_by_key(|p| p.0);
    }
    series.sort_by(|a, b| {
        (&a.api, &a.format, tier_rank(&a.tier)).cmp(&(&b.api, &b.format, tier_rank(&b.tier)))
    });
    series
}

fn build_time_table(out: &mut String, estimates: &[Estimate]) {
    let series = build_time_series(estimates);
    if series.is_empty() {
        return;
    }
    let sizes: BTreeSet<u64> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .collect();
    out.push_str("### Time per build against N micromap triangles (mean)\n\n");
    out.push_str("One build of N triangles at subdivision level 3, checked at each tier. EXT: `vkCmdBuildMicromapsEXT`; KHR: `vkCmdBuildAccelerationStructuresKHR` of type OPACITY_MICROMAP.\n\n");
    out.push_str("| build | tier |");
    for n in &sizes {
        let _ = write!(out, " N = {} |", short_count(*n));
    }
    out.push_str("\n| --- | --- |");
    out.push_str(&" ---: |".repeat(sizes.len()));
    out.push('\n');
    for s in &series {
        let _ = write!(out, "| {} | {} |", s.label(), s.tier);
        for n in &sizes {
            let cell = s
                .points
                .iter()
                .find(|p| p.0 == *n)
                .map_or_else(|| "–".into(), |p| format_time(p.1));
            let _ = write!(out, " {cell} |");
        }
        out.push('\n');
    }
    // Time per triangle at the largest N, the slope the sweep ends on;
    // series that do not grow with N (under 0.01 ns a triangle) are left out.
    if let Some(largest) = sizes.last() {
        let _ = writeln!(
            out,
            "\nPer triangle at N = {} (series that do not grow with N left out): {}.\n",
            short_count(*largest),
            series
                .iter()
                .filter_map(|s| {
                    let p = s.points.iter().find(|p| p.0 == *largest)?;
                    if p.1 / (*largest as f64) < 0.01 {
                        return None;
                    }
                    Some(format!(
                        "{} {} {}",
                        s.label(),
                        s.tier,
                        format_time(p.1 / *largest as f64)
                    ))
                })
                .collect::<Vec<_>>()
                .join("; ")
        );
    }
}

/// `L{level}-N{n}` as (level, n).
fn split_level_value(value: &str) -> Option<(u32, u64)> {
    let (level, n) = value.strip_prefix('L')?.split_once("-N")?;
    Some((level.parse().ok()?, n.parse().ok()?))
}

/// A time ratio: whole numbers from 10 up, one decimal below (where 0.5×
/// and 2× are the figures that matter).
fn ratio(value: f64) -> String {
    if value >= 10.0 {
        format!("{value:.0}×")
    } else {
        format!("{value:.1}×")
    }
}

/// The content check and the memcpy of one (format, level, N).
type ContentAndMemcpy<'a> = (Option<&'a Estimate>, Option<&'a Estimate>);

fn throughput_table(out: &mut String, estimates: &[Estimate]) {
    let mut rows: BTreeMap<(String, u32, u64), ContentAndMemcpy<'_>> = BTreeMap::new();
    for e in estimates.iter().filter(|e| e.group == "content-throughput") {
        let (Some((kind, format)), Some((level, n))) = (
            e.function.split_once('-'),
            e.value.as_deref().and_then(split_level_value),
        ) else {
            continue;
        };
        let row = rows.entry((format.into(), level, n)).or_default();
        match kind {
            "content" => row.0 = Some(e),
            "memcpy" => row.1 = Some(e),
            _ => {}
        }
    }
    if rows.is_empty() {
        return;
    }
    out.push_str("### Content tier throughput next to memcpy (EXT build, mean)\n\n");
    out.push_str("Bytes read per build: the triangle array, 8 bytes a triangle. The content tier measures each triangle's data block against the memory `data` points into but reads none of it (the hygiene information, which reads every block, runs at the simulate tier), so the level changes only the data offsets checked. N is as many triangles as 16 MiB of array hold, at most 10^6; triangles share data blocks where distinct ones would not fit 16 MiB. The memcpy copies as many bytes in the same run; the ratio is the check's time over the copy's.\n\n");
    out.push_str("| format | level | N | bytes | content | memcpy | content GB/s | memcpy GB/s | content ÷ memcpy |\n");
    out.push_str("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n");
    for ((format, level, n), (content, memcpy)) in &rows {
        let bytes = content.or(*memcpy).and_then(|e| e.bytes).unwrap_or(0);
        let time = |e: &Option<&Estimate>| e.map_or_else(|| "–".into(), |e| format_time(e.mean_ns));
        let rate = |e: &Option<&Estimate>| {
            e.map_or_else(
                || "–".into(),
                |e| format!("{:.2}", gigabytes_per_second(bytes, e.mean_ns)),
            )
        };
        let ratio = match (content, memcpy) {
            (Some(c), Some(m)) => ratio(c.mean_ns / m.mean_ns),
            _ => "–".into(),
        };
        let _ = writeln!(
            out,
            "| {} | {level} | {n} | {bytes} | {} | {} | {} | {} | {ratio} |",
            format_label(format),
            time(content),
            time(memcpy),
            rate(content),
            rate(memcpy),
        );
    }
    out.push('\n');
}

/// `{K}-of-{M}` as (K, M).
fn split_fraction_value(value: &str) -> Option<(u64, u64)> {
    let (k, m) = value.split_once("-of-")?;
    Some((k.parse().ok()?, m.parse().ok()?))
}

fn referenced_table(out: &mut String, estimates: &[Estimate]) {
    let mut rows: Vec<(&str, u64, u64, f64)> = estimates
        .iter()
        .filter(|e| e.group == "referenced-fraction")
        .filter_map(|e| {
            let (k, m) = split_fraction_value(e.value.as_deref()?)?;
            Some((e.function.as_str(), k, m, e.mean_ns))
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    rows.sort_by_key(|r| (r.0, r.1));
    out.push_str("### Bottom-level build against the referenced share of a micromap (content tier, mean)\n\n");
    out.push_str("One triangles geometry whose opacity attachment indexes K of the micromap's M triangles (primitiveCount = K); the time should follow K, not M.\n\n");
    out.push_str("| attachment | referenced | of M | share | time | per referenced triangle |\n");
    out.push_str("| --- | ---: | ---: | ---: | ---: | ---: |\n");
    for (api, k, m, ns) in rows {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {}% | {} | {} |",
            api.to_uppercase(),
            short_count(k),
            short_count(m),
            (k as f64 * 100.0 / m as f64).round(),
            format_time(ns),
            format_time(ns / k.max(1) as f64),
        );
    }
    out.push('\n');
}

fn params_table(out: &mut String, estimates: &[Estimate]) {
    let rows: Vec<&Estimate> = estimates
        .iter()
        .filter(|e| e.group == "params-per-call")
        .collect();
    if rows.is_empty() {
        return;
    }
    out.push_str("### Params tier, one small build per call\n\n");
    out.push_str("One build of one level-3 4-state triangle (micromap), or a bottom-level build referencing one (blas). Target: at most 1 µs a call.\n\n");
    out.push_str("| call | mean | median | ≤ 1 µs |\n| --- | ---: | ---: | --- |\n");
    for e in rows {
        let met = if e.mean_ns <= PARAMS_TARGET_NS {
            "met"
        } else {
            "missed"
        };
        let _ = writeln!(
            out,
            "| {} | {} | {} | {met} |",
            e.function,
            format_time(e.mean_ns),
            format_time(e.median_ns)
        );
    }
    out.push('\n');
}

/// The state tier against how many buffers the application has: lookups of
/// device addresses go through an index, so the time should not follow B.
fn state_table(out: &mut String, estimates: &[Estimate]) {
    let rows: BTreeMap<(&str, u64), &Estimate> = estimates
        .iter()
        .filter(|e| e.group == "state-per-call")
        .filter_map(|e| {
            let others = e.value.as_deref()?.parse().ok()?;
            Some(((e.function.as_str(), others), e))
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    out.push_str(
        "### State tier, one small build among B other buffers

",
    );
    out.push_str("One build of one level-3 4-state triangle at the state tier, with B other buffers tracked besides the build's own.

");
    out.push_str("| call | other buffers | mean | median |\n| --- | ---: | ---: | ---: |\n");
    for ((function, others), e) in rows {
        let _ = writeln!(
            out,
            "| {function} | {others} | {} | {} |",
            format_time(e.mean_ns),
            format_time(e.median_ns)
        );
    }
    out.push('\n');
}

/// The markdown table of what each tier costs, with the machine in its header.
pub fn render_table(machine: &Machine, quick: bool, estimates: &[Estimate]) -> String {
    let mut out = String::from("## What accuracy costs: measurements\n\n");
    let _ = writeln!(
        out,
        "Machine: {} ({} logical cores). criterion point estimates of `cargo xtask bench{}`{}.\n",
        machine.model,
        machine.cores,
        if quick { " --quick" } else { "" },
        if quick {
            " (1 s warm-up, 2 s measurement per benchmark)"
        } else {
            ""
        }
    );
    build_time_table(&mut out, estimates);
    throughput_table(&mut out, estimates);
    referenced_table(&mut out, estimates);
    params_table(&mut out, estimates);
    state_table(&mut out, estimates);
    out
}

/// Tier colours of the plot: params, state, content, anything else.
const TIER_COLOURS: [plotters::style::RGBColor; 4] = [
    plotters::style::RGBColor(31, 119, 180),
    plotters::style::RGBColor(255, 127, 14),
    plotters::style::RGBColor(44, 160, 44),
    plotters::style::RGBColor(127, 127, 127),
];

/// An SVG plot of time per build against N, log-log, one panel per (api,
/// format) with one line per tier.
pub fn render_plot(estimates: &[Estimate]) -> Result<String, Error> {
    use plotters::prelude::*;

    // One panel per (api, format), in the order of the series.
    let mut panels: Vec<Vec<BuildSeries>> = Vec::new();
    for series in build_time_series(estimates) {
        match panels.last_mut() {
            Some(panel) if panel[0].label() == series.label() => panel.push(series),
            _ => panels.push(vec![series]),
        }
    }
    let all = || panels.iter().flatten().flat_map(|s| s.points.iter());
    let (n_max, ns_min, ns_max) = all().fold((1u64, f64::MAX, 1.0f64), |(n, lo, hi), p| {
        (n.max(p.0), lo.min(p.1), hi.max(p.1))
    });
    let ns_min = if ns_min == f64::MAX { 1.0 } else { ns_min };
    let rows = panels.len().div_ceil(2).max(1);
    let mut svg = String::new();
    {
        let plot_error = |e: &dyn std::fmt::Display| Error::Tool(format!("plot: {e}"));
        let root = SVGBackend::with_string(&mut svg, (1000, 380 * rows as u32)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(&e))?;
        let areas = root.split_evenly((rows, 2));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            let mut chart = ChartBuilder::on(area)
                .caption(
                    format!("{}: time per build", panel[0].label()),
                    ("sans-serif", 18),
                )
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(
                    (1u64..n_max.max(10)).log_scale(),
                    (ns_min / 2.0..ns_max * 2.0).log_scale(),
                )
                .map_err(|e| plot_error(&e))?;
            chart
                .configure_mesh()
                .x_desc("N micromap triangles")
                .y_desc("time per build")
                .y_label_formatter(&|ns| format_time(*ns))
                .draw()
                .map_err(|e| plot_error(&e))?;
            for BuildSeries { tier, points, .. } in panel {
                let colour = TIER_COLOURS[tier_rank(tier).min(TIER_COLOURS.len() - 1)];
                chart
                    .draw_series(LineSeries::new(
                        points.iter().copied(),
                        colour.stroke_width(2),
                    ))
                    .map_err(|e| plot_error(&e))?
                    .label(tier.as_str())
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                    });
                chart
                    .draw_series(points.iter().map(|p| Circle::new(*p, 3, colour.filled())))
                    .map_err(|e| plot_error(&e))?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperLeft)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(|e| plot_error(&e))?;
        }
        root.present().map_err(|e| plot_error(&e))?;
    }
    Ok(svg)
}

/// The three calls `omm-app overhead` times, as its JSON names them, with
/// the table's column headers.
pub const OVERHEAD_CALLS: [(&str, &str); 3] = [
    ("cmd_build_micromaps", "`vkCmdBuildMicromapsEXT`"),
    ("build_micromaps", "`vkBuildMicromapsEXT` (host)"),
    (
        "cmd_build_acceleration_structures",
        "`vkCmdBuildAccelerationStructuresKHR` (BLAS + micromap)",
    ),
];

/// Calls timed per configuration and process.
pub const OVERHEAD_ITERATIONS: u32 = 10_000;

/// Processes per configuration; the table gives each call's median.
pub const OVERHEAD_RUNS: usize = 3;

/// The heading the overhead section of README-table.md starts with.
const OVERHEAD_HEADING: &str = "#### Layer overhead per call";

const KHRONOS_VALIDATION: &str = "VK_LAYER_KHRONOS_validation";

/// One configuration of the overhead run: the layers enabled, in
/// ppEnabledLayerNames order, ommcheck's tier where it is enabled, and the
/// usage entries of each build (`omm-app overhead --usage-entries`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OverheadConfig {
    pub name: String,
    pub layers: Vec<&'static str>,
    pub tier: Option<&'static str>,
    pub usage_entries: u32,
}

/// Usage entries of the builds in the rows that show their cost: real
/// builds carry one per (format, level) in use, up to 26 distinct ones
/// (and repeats).
pub const OVERHEAD_MANY_USAGE_ENTRIES: u32 = 64;

/// The configurations, in the table's order: no layer; ommcheck at each
/// tier it has short of `simulate`; the Khronos validation layer alone; both
/// stacked (ommcheck first, at its default tier, content); then no layer,
/// ommcheck at `params` and the Khronos layer with
/// [`OVERHEAD_MANY_USAGE_ENTRIES`] usage entries per build.
pub fn overhead_configs() -> Vec<OverheadConfig> {
    let ommcheck = VkLayer_ommcheck::LAYER_NAME;
    let config = |name: String, layers, tier| OverheadConfig {
        name,
        layers,
        tier,
        usage_entries: 1,
    };
    let mut configs = vec![config("no layer".into(), vec![], None)];
    for tier in ["params", "state", "content"] {
        configs.push(config(
            format!("ommcheck, `{tier}`"),
            vec![ommcheck],
            Some(tier),
        ));
    }
    configs.push(config(
        "Khronos validation".into(),
        vec![KHRONOS_VALIDATION],
        None,
    ));
    configs.push(config(
        "ommcheck `content` + Khronos validation".into(),
        vec![ommcheck, KHRONOS_VALIDATION],
        Some("content"),
    ));
    let many = OVERHEAD_MANY_USAGE_ENTRIES;
    for (name, layers, tier) in [
        ("no layer", vec![], None),
        ("ommcheck, `params`", vec![ommcheck], Some("params")),
        ("Khronos validation", vec![KHRONOS_VALIDATION], None),
    ] {
        configs.push(OverheadConfig {
            usage_entries: many,
            ..config(format!("{name}, {many} usage entries"), layers, tier)
        });
    }
    configs
}

/// What one `omm-app overhead` process measured.
#[derive(Clone, Debug, PartialEq)]
pub struct OverheadRun {
    /// Nanoseconds per call, in [`OVERHEAD_CALLS`] order.
    pub ns: [f64; 3],
    /// The ids of the messages the app's messenger received (none expected).
    pub messages: Vec<String>,
}

/// omm-app's JSON line for the `overhead` scenario.
pub fn parse_overhead(json: &str) -> Result<OverheadRun, Error> {
    let value: Value = serde_json::from_str(json.trim())
        .map_err(|e| Error::Tool(format!("omm-app overhead: {e}: {json}")))?;
    let mut ns = [0.0; 3];
    for (slot, (key, _)) in ns.iter_mut().zip(OVERHEAD_CALLS) {
        *slot = value["results"]["ns_per_call"][key]
            .as_f64()
            .ok_or_else(|| Error::Tool(format!("omm-app overhead: no {key}: {json}")))?;
    }
    // Messages at teardown (the Khronos layer's objects-not-destroyed) come
    // after the timed loops.
    let messages = value["messages"]
        .as_array()
        .map(|ms| {
            ms.iter()
                .filter(|m| m["phase"] != "teardown")
                .map(|m| m["id"].as_str().unwrap_or_default().to_string())
                .collect()
        })
        .unwrap_or_default();
    Ok(OverheadRun { ns, messages })
}

/// The median of `values` (the mean of the middle two for an even count).
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    match sorted.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => sorted[n / 2],
        n => (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0,
    }
}

/// One row of the overhead table: a configuration's runs.
#[derive(Clone, Debug, PartialEq)]
pub struct OverheadRow {
    pub config: String,
    pub runs: Vec<OverheadRun>,
}

impl OverheadRow {
    /// Each call's median over the runs.
    pub fn medians(&self) -> [f64; 3] {
        std::array::from_fn(|i| median(&self.runs.iter().map(|r| r.ns[i]).collect::<Vec<_>>()))
    }
}

/// The markdown section of the overhead table: one row per configuration,
/// one column per call, the median of the runs in nanoseconds per call.
pub fn render_overhead(machine: &Machine, iterations: u32, rows: &[OverheadRow]) -> String {
    let runs = rows.iter().map(|r| r.runs.len()).max().unwrap_or(0);
    let mut out = format!("{OVERHEAD_HEADING} (median of {runs} runs)\n\n");
    let _ = writeln!(
        out,
        "`omm-app overhead --iterations {iterations}` over the Khronos Mock ICD (every command a stub): \
         valid calls timed in a loop after a warm-up, so the time is the loader's and the layers'. \
         Machine: {} ({} logical cores).\n",
        machine.model, machine.cores
    );
    out.push_str("| configuration |");
    for (_, header) in OVERHEAD_CALLS {
        let _ = write!(out, " {header} |");
    }
    out.push_str("\n| --- |");
    for _ in OVERHEAD_CALLS {
        out.push_str(" ---: |");
    }
    out.push('\n');
    for row in rows {
        let _ = write!(out, "| {} |", row.config);
        for ns in row.medians() {
            let _ = write!(out, " {} |", format_time(ns));
        }
        out.push('\n');
    }
    let received: BTreeSet<(&str, &str)> = rows
        .iter()
        .flat_map(|row| {
            row.runs
                .iter()
                .flat_map(|r| r.messages.iter().map(|m| (row.config.as_str(), m.as_str())))
        })
        .collect();
    if received.is_empty() {
        out.push_str("\nThe messenger received no message in any run.\n");
    } else {
        out.push_str("\nMessages received (the inputs are meant to be valid):\n");
        for (config, id) in received {
            let _ = writeln!(out, "- {config}: `{id}`");
        }
    }
    out
}

/// `existing` (README-table.md as a criterion run wrote it, or empty) with
/// its overhead section, if any, replaced by `section`.
pub fn with_overhead_section(existing: &str, machine: &Machine, section: &str) -> String {
    let kept = match existing.find(OVERHEAD_HEADING) {
        Some(at) => &existing[..at],
        None => existing,
    };
    let mut out = if kept.trim().is_empty() {
        format!(
            "## What accuracy costs: measurements\n\nMachine: {} ({} logical cores).\n\n",
            machine.model, machine.cores
        )
    } else {
        format!("{}\n\n", kept.trim_end())
    };
    out.push_str(section);
    out
}

/// Where the overhead run finds its driver and the Khronos layer: the
/// variables `cargo xtask test` sets (see `drivers`); None, with a note, when
/// one is unset or names nothing.
fn overhead_drivers() -> Option<(PathBuf, PathBuf)> {
    let lookup = |var: &str| {
        let path = PathBuf::from(std::env::var_os(var)?);
        path.exists().then_some(path)
    };
    let icd = lookup(crate::drivers::MOCK_ICD_VAR);
    let khronos = lookup(crate::drivers::KHRONOS_LAYER_VAR);
    if icd.is_none() || khronos.is_none() {
        eprintln!(
            "xtask: bench: skipping the layer overhead run: {} and {} must name the Mock ICD's \
             manifest and the Khronos layer's directory (`cargo xtask test` prepares both)",
            crate::drivers::MOCK_ICD_VAR,
            crate::drivers::KHRONOS_LAYER_VAR
        );
    }
    icd.zip(khronos)
}

/// Builds the layer (into `target/bench/layer`) and omm-app in release;
/// returns omm-app and the layer's manifest directory.
fn build_overhead_app(root: &Path) -> Result<(PathBuf, PathBuf), Error> {
    let target = crate::target_dir(root);
    // The layer: `cargo build -p ommcheck-tests --bin omm-app` does not build
    // the tests crate's dev-dependency on it, so it is built on its own.
    let layer_dir = crate::layer::build(root, Some(target.join("bench").join("layer")))?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(root)
        .args([
            "build",
            "--release",
            "-p",
            "ommcheck-tests",
            "--bin",
            "omm-app",
        ])
        .status()
        .map_err(|e| Error::Tool(format!("cargo build omm-app: could not start: {e}")))?;
    if !status.success() {
        return Err(Error::Tool(format!(
            "cargo build omm-app failed ({status})"
        )));
    }
    Ok((target.join("release").join("omm-app"), layer_dir))
}

/// Where and how one `omm-app overhead` process runs: the app, the Mock
/// ICD, the layer search path, and (for the interleaved run) a directory
/// holding a `vk_layer_settings.txt`.
struct OverheadSetup {
    app: PathBuf,
    icd: PathBuf,
    layer_path: std::ffi::OsString,
    settings: Option<PathBuf>,
}

/// One process's shape: the layers, ommcheck's tier, the usage entries and
/// micromap triangles of each build.
struct OverheadProcess<'a> {
    name: &'a str,
    layers: &'a [&'static str],
    tier: Option<&'a str>,
    iterations: u32,
    usage_entries: u32,
    triangles: Option<u32>,
}

impl OverheadSetup {
    /// Runs `omm-app overhead` once, with no `VK_*` or `OMMCHECK_*`
    /// variable of the caller's.
    fn run(&self, process: &OverheadProcess<'_>) -> Result<OverheadRun, Error> {
        let mut command = Command::new(&self.app);
        command
            .args(["overhead", "--iterations"])
            .arg(process.iterations.to_string())
            .arg("--usage-entries")
            .arg(process.usage_entries.to_string());
        if let Some(triangles) = process.triangles {
            command.arg("--triangles").arg(triangles.to_string());
        }
        for layer in process.layers {
            command.args(["--layer", layer]);
        }
        for (var, _) in std::env::vars_os() {
            let name = var.to_string_lossy();
            if name.starts_with("VK_") || name.starts_with("OMMCHECK_") {
                command.env_remove(&var);
            }
        }
        command
            .env("NODEVICE_SELECT", "1")
            .env("VK_DRIVER_FILES", &self.icd)
            .env("VK_ADD_LAYER_PATH", &self.layer_path);
        if let Some(settings) = &self.settings {
            command.env("VK_LAYER_SETTINGS_PATH", settings);
        }
        if let Some(tier) = process.tier {
            command.env(VkLayer_ommcheck::settings::TIER, tier);
        }
        let output = command
            .output()
            .map_err(|e| Error::Tool(format!("{}: could not start: {e}", self.app.display())))?;
        if !output.status.success() {
            return Err(Error::Tool(format!(
                "omm-app overhead ({}) failed ({}): {}",
                process.name,
                output.status,
                String::from_utf8_lossy(&output.stderr)
            )));
        }
        parse_overhead(&String::from_utf8_lossy(&output.stdout))
    }
}

/// The layer search path: ommcheck's manifest directory, then the Khronos layer's.
fn layer_path(layer_dir: &Path, khronos: &Path) -> Result<std::ffi::OsString, Error> {
    std::env::join_paths([layer_dir, khronos])
        .map_err(|e| Error::Tool(format!("VK_ADD_LAYER_PATH: {e}")))
}

/// Builds omm-app and the layer in release, runs `omm-app overhead` per
/// configuration [`OVERHEAD_RUNS`] times, and returns the rows.
fn run_overhead(root: &Path, icd: &Path, khronos: &Path) -> Result<Vec<OverheadRow>, Error> {
    let (app, layer_dir) = build_overhead_app(root)?;
    let setup = OverheadSetup {
        app,
        icd: icd.to_path_buf(),
        layer_path: layer_path(&layer_dir, khronos)?,
        settings: None,
    };
    let mut rows = Vec::new();
    for config in overhead_configs() {
        let mut runs = Vec::new();
        for _ in 0..OVERHEAD_RUNS {
            let run = setup.run(&OverheadProcess {
                name: &config.name,
                layers: &config.layers,
                tier: config.tier,
                iterations: OVERHEAD_ITERATIONS,
                usage_entries: config.usage_entries,
                triangles: None,
            })?;
            eprintln!("xtask: bench: overhead, {}: {:?} ns", config.name, run.ns);
            runs.push(run);
        }
        rows.push(OverheadRow {
            config: config.name,
            runs,
        });
    }
    Ok(rows)
}

/// The Khronos layer's errors that come from the Mock ICD's zero limits and
/// zero buffer addresses, muted in the interleaved run so that its BLAS
/// figure is the cost of checking.
const MOCK_ICD_ERRORS: [&str; 2] = [
    "VUID-VkAccelerationStructureBuildGeometryInfoKHR-type-03793",
    "VUID-vkCmdBuildAccelerationStructuresKHR-pInfos-03802",
];

/// The builds' shapes of the interleaved run: (micromap triangles, usage
/// entries).
pub const INTERLEAVED_SHAPES: [(u32, u32); 6] = [
    (1, 1),
    (1, OVERHEAD_MANY_USAGE_ENTRIES),
    (1000, 1),
    (1000, OVERHEAD_MANY_USAGE_ENTRIES),
    (100_000, 1),
    (100_000, OVERHEAD_MANY_USAGE_ENTRIES),
];

/// The interleaved run's configurations: no layer, ommcheck, the Khronos layer.
const INTERLEAVED_CONFIGS: [(&str, &[&str]); 3] = [
    ("none", &[]),
    ("ommcheck", &[VkLayer_ommcheck::LAYER_NAME]),
    ("khronos", &[KHRONOS_VALIDATION]),
];

/// One call's medians in the interleaved run: no layer, ommcheck, Khronos.
#[derive(Clone, Debug, PartialEq)]
pub struct InterleavedRow {
    pub triangles: u32,
    pub usage_entries: u32,
    pub call: &'static str,
    pub medians: [f64; 3],
}

/// The interleaved run's markdown table: each call's medians and
/// ommcheck's overhead over the Khronos layer's (each less the no-layer
/// time), then the messages received.
pub fn render_interleaved(
    tier: &str,
    rows: &[InterleavedRow],
    messages: &BTreeSet<String>,
) -> String {
    let mut out = format!(
        "| micromap triangles | usage entries | call | no layer | ommcheck `{tier}` | Khronos \
         | ommcheck overhead ÷ Khronos overhead |\n| ---: | ---: | --- | ---: | ---: | ---: | ---: |\n"
    );
    for row in rows {
        let [none, ommcheck, khronos] = row.medians;
        let _ = writeln!(
            out,
            "| {} | {} | {} | {none:.1} ns | {ommcheck:.0} ns | {khronos:.0} ns | {:.2}× |",
            row.triangles,
            row.usage_entries,
            row.call,
            (ommcheck - none) / (khronos - none)
        );
    }
    let received: Vec<&str> = messages.iter().map(String::as_str).collect();
    let _ = write!(
        out,
        "\nMessages received: {}\n",
        if received.is_empty() {
            "none".into()
        } else {
            received.join(", ")
        }
    );
    out
}

/// `cargo xtask overhead ROUNDS ITERATIONS [--tier TIER]`: issue 18's
/// params floor. Runs `omm-app overhead` with no layer, with ommcheck at
/// `tier` and with the Khronos layer, one process each, interleaved round
/// by round over [`INTERLEAVED_SHAPES`], so that load on the machine falls
/// on all three alike; prints each call's median over the rounds and
/// ommcheck's overhead over the Khronos layer's.
pub fn run_interleaved(
    root: &Path,
    rounds: usize,
    iterations: u32,
    tier: &str,
) -> Result<(), Error> {
    let Some((icd, khronos)) = overhead_drivers() else {
        return Err(Error::Tool(
            "the Mock ICD and the Khronos layer are needed".into(),
        ));
    };
    let (app, layer_dir) = build_overhead_app(root)?;
    let settings = crate::target_dir(root)
        .join("bench")
        .join("overhead-settings");
    std::fs::create_dir_all(&settings).map_err(|source| Error::Io {
        path: settings.clone(),
        source,
    })?;
    let settings_file = settings.join("vk_layer_settings.txt");
    let muted = format!(
        "khronos_validation.message_id_filter = {}\n",
        MOCK_ICD_ERRORS.join(",")
    );
    std::fs::write(&settings_file, muted).map_err(|source| Error::Io {
        path: settings_file,
        source,
    })?;
    let setup = OverheadSetup {
        app,
        icd,
        layer_path: layer_path(&layer_dir, &khronos)?,
        settings: Some(settings),
    };
    // Per (shape, configuration): each round's nanoseconds per call.
    let mut runs: BTreeMap<(usize, usize), Vec<[f64; 3]>> = BTreeMap::new();
    let mut messages = BTreeSet::new();
    for round in 1..=rounds {
        for (s, &(triangles, usage_entries)) in INTERLEAVED_SHAPES.iter().enumerate() {
            for (c, (name, layers)) in INTERLEAVED_CONFIGS.iter().enumerate() {
                let run = setup.run(&OverheadProcess {
                    name,
                    layers,
                    tier: (c == 1).then_some(tier),
                    iterations,
                    usage_entries,
                    triangles: Some(triangles),
                })?;
                messages.extend(run.messages.iter().map(|m| format!("{name}: {m}")));
                runs.entry((s, c)).or_default().push(run.ns);
            }
        }
        eprintln!("xtask: overhead: round {round} of {rounds} done");
    }
    let mut rows = Vec::new();
    for (s, &(triangles, usage_entries)) in INTERLEAVED_SHAPES.iter().enumerate() {
        for (i, &(_, header)) in OVERHEAD_CALLS.iter().enumerate() {
            let medians = std::array::from_fn(|c| {
                let ns: Vec<f64> = runs[&(s, c)].iter().map(|ns| ns[i]).collect();
                median(&ns)
            });
            rows.push(InterleavedRow {
                triangles,
                usage_entries,
                call: header,
                medians,
            });
        }
    }
    print!("{}", render_interleaved(tier, &rows, &messages));
    Ok(())
}

/// Runs the benchmarks (`--quick`: criterion's short warm-up and
/// measurement), then writes the table and the plot under `target/bench/`;
/// then, where the Mock ICD and the Khronos layer are prepared, the layer
/// overhead per call, appended to the table. `overhead_only` skips criterion
/// and replaces only the overhead section of an existing table.
pub fn run(root: &Path, quick: bool, overhead_only: bool) -> Result<(), Error> {
    let target = crate::target_dir(root);
    let out_dir = target.join("bench");
    std::fs::create_dir_all(&out_dir).map_err(|source| Error::Io {
        path: out_dir.clone(),
        source,
    })?;
    let table_path = out_dir.join("README-table.md");
    let machine = this_machine();
    let mut table = if overhead_only {
        std::fs::read_to_string(&table_path).unwrap_or_default()
    } else {
        criterion(root, &target, quick, &machine)?
    };
    if let Some((icd, khronos)) = overhead_drivers() {
        let rows = run_overhead(root, &icd, &khronos)?;
        let section = render_overhead(&machine, OVERHEAD_ITERATIONS, &rows);
        table = with_overhead_section(&table, &machine, &section);
    }
    std::fs::write(&table_path, &table).map_err(|source| Error::Io {
        path: table_path.clone(),
        source,
    })?;
    println!("{table}");
    println!("wrote {}", table_path.display());
    Ok(())
}

/// The criterion run: writes tiers.svg and returns the table.
fn criterion(root: &Path, target: &Path, quick: bool, machine: &Machine) -> Result<String, Error> {
    let criterion_dir = target.join("criterion");
    let started = std::time::SystemTime::now();
    let mut command = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    // Only the bench targets (`--benches` would add the library, whose libtest
    // harness rejects criterion's options).
    command
        .current_dir(root)
        .args(["bench", "-p", "ommcheck", "--bench", "*", "--"])
        .env("CRITERION_HOME", &criterion_dir);
    if quick {
        command.args(QUICK_ARGS);
    }
    eprintln!("xtask: {command:?}");
    let status = command
        .status()
        .map_err(|e| Error::Tool(format!("cargo bench: could not start: {e}")))?;
    if !status.success() {
        return Err(Error::Tool(format!("cargo bench failed ({status})")));
    }
    let estimates = read_estimates(&criterion_dir, Some(started))?;
    let path = target.join("bench").join("tiers.svg");
    std::fs::write(&path, render_plot(&estimates)?).map_err(|source| Error::Io {
        path: path.clone(),
        source,
    })?;
    println!("wrote {}", path.display());
    Ok(render_table(machine, quick, &estimates))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_keep_a_decimal_below_ten() {
        assert_eq!(ratio(40.2), "40×");
        assert_eq!(ratio(10.0), "10×");
        assert_eq!(ratio(2.04), "2.0×");
        assert_eq!(ratio(0.46), "0.5×");
    }

    fn estimates_json(mean: f64, median: f64) -> String {
        let estimate = |point: f64| {
            format!(
                r#"{{"confidence_interval":{{"confidence_level":0.95,"lower_bound":{lo},"upper_bound":{hi}}},"point_estimate":{point},"standard_error":1.0}}"#,
                lo = point * 0.9,
                hi = point * 1.1
            )
        };
        format!(
            r#"{{"mean":{},"median":{},"median_abs_dev":{},"slope":null,"std_dev":{}}}"#,
            estimate(mean),
            estimate(median),
            estimate(1.0),
            estimate(2.0)
        )
    }

    fn benchmark_json(group: &str, function: &str, value: &str, throughput: &str) -> String {
        format!(
            r#"{{"group_id":"{group}","function_id":"{function}","value_str":"{value}","throughput":{throughput},"full_id":"{group}/{function}/{value}","directory_name":"{group}/{function}/{value}","title":"{group}/{function}/{value}"}}"#
        )
    }

    fn estimate(group: &str, function: &str, value: &str, throughput: &str, mean: f64) -> Estimate {
        parse_estimate(
            &benchmark_json(group, function, value, throughput),
            &estimates_json(mean, mean * 0.9),
            Path::new("fixture"),
        )
        .expect("fixture parses")
    }

    /// A small run: two tiers at two sizes, one throughput pair, two
    /// referenced shares and one params call.
    fn fixture() -> Vec<Estimate> {
        vec![
            estimate(
                "build-time",
                "ext-2state-params",
                "1",
                r#"{"Elements":1}"#,
                800.0,
            ),
            estimate(
                "build-time",
                "ext-2state-params",
                "1000",
                r#"{"Elements":1000}"#,
                900.0,
            ),
            estimate(
                "build-time",
                "ext-2state-content",
                "1",
                r#"{"Elements":1}"#,
                2_000.0,
            ),
            estimate(
                "build-time",
                "ext-2state-content",
                "1000",
                r#"{"Elements":1000}"#,
                150_000.0,
            ),
            estimate(
                "content-throughput",
                "content-4state",
                "L2-N1000",
                r#"{"Bytes":12000}"#,
                24_000.0,
            ),
            estimate(
                "content-throughput",
                "memcpy-4state",
                "L2-N1000",
                r#"{"Bytes":12000}"#,
                600.0,
            ),
            estimate(
                "referenced-fraction",
                "ext",
                "10-of-1000",
                r#"{"Elements":10}"#,
                1_000.0,
            ),
            estimate(
                "referenced-fraction",
                "ext",
                "1000-of-1000",
                r#"{"Elements":1000}"#,
                100_000.0,
            ),
            estimate("params-per-call", "ext-micromap", "", "null", 750.0),
            estimate("params-per-call", "khr-micromap", "", "null", 1_300.0),
            estimate("state-per-call", "ext-micromap", "10000", "null", 900.0),
            estimate("state-per-call", "ext-micromap", "100", "null", 800.0),
        ]
    }

    #[test]
    fn criterion_files_parse_into_estimates() {
        let e = estimate(
            "content-throughput",
            "memcpy-2state",
            "L0-N5",
            r#"{"Bytes":45}"#,
            12.5,
        );
        assert_eq!(e.group, "content-throughput");
        assert_eq!(e.function, "memcpy-2state");
        assert_eq!(e.value.as_deref(), Some("L0-N5"));
        assert_eq!(e.mean_ns, 12.5);
        assert_eq!(e.median_ns, 12.5 * 0.9);
        assert_eq!((e.bytes, e.elements), (Some(45), None));
        let bad = parse_estimate("{}", &estimates_json(1.0, 1.0), Path::new("x/new"));
        assert!(matches!(bad, Err(Error::Tool(m)) if m.contains("group_id")));
        let bad = parse_estimate(&benchmark_json("g", "f", "v", "null"), "{}", Path::new("x"));
        assert!(matches!(bad, Err(Error::Tool(m)) if m.contains("mean.point_estimate")));
    }

    #[test]
    fn estimates_are_found_under_new_directories_only() {
        let dir = std::env::temp_dir().join(format!("xtask-bench-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for (sub, mean) in [("g_f/1/new", 10.0), ("g_f/1/base", 99.0)] {
            let at = dir.join(sub);
            std::fs::create_dir_all(&at).unwrap();
            std::fs::write(
                at.join("benchmark.json"),
                benchmark_json("g", "f", "1", "null"),
            )
            .unwrap();
            std::fs::write(at.join("estimates.json"), estimates_json(mean, mean)).unwrap();
        }
        let found = read_estimates(&dir, None);
        let later = std::time::SystemTime::now() + std::time::Duration::from_secs(3600);
        let only_later = read_estimates(&dir, Some(later));
        std::fs::remove_dir_all(&dir).unwrap();
        let found = found.unwrap();
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].mean_ns, 10.0);
        // Results written before the run are left out.
        assert!(only_later.unwrap().is_empty());
    }

    #[test]
    fn cpuinfo_gives_model_and_logical_cores() {
        let text = "processor\t: 0\nmodel name\t: Example CPU @ 2.0GHz\n\nprocessor\t: 1\nmodel name\t: Example CPU @ 2.0GHz\n";
        assert_eq!(
            parse_cpuinfo(text),
            Machine {
                model: "Example CPU @ 2.0GHz".into(),
                cores: 2
            }
        );
        assert_eq!(parse_cpuinfo("").model, "unknown CPU");
    }

    #[test]
    fn times_have_units_and_three_digits() {
        assert_eq!(format_time(12.345), "12.3 ns");
        assert_eq!(format_time(999.0), "999 ns");
        assert_eq!(format_time(1_234.0), "1.23 µs");
        assert_eq!(format_time(45_600_000.0), "45.6 ms");
        assert_eq!(format_time(2.5e9), "2.50 s");
    }

    #[test]
    fn table_has_every_section_from_the_fixture() {
        let machine = Machine {
            model: "Example CPU".into(),
            cores: 2,
        };
        let table = render_table(&machine, true, &fixture());
        assert!(
            table.contains("Machine: Example CPU (2 logical cores)"),
            "{table}"
        );
        assert!(table.contains("--quick"), "{table}");
        // Tiers in order params before content, sizes as columns.
        assert!(
            table.contains("| build | tier | N = 1 | N = 1k |"),
            "{table}"
        );
        let params = table
            .find("| EXT 2-state | params | 800 ns | 900 ns |")
            .expect(&table);
        let content = table
            .find("| EXT 2-state | content | 2.00 µs | 150 µs |")
            .expect(&table);
        assert!(params < content);
        assert!(
            table.contains("EXT 2-state content 150 ns"),
            "per triangle: {table}"
        );
        // 12000 bytes in 24 µs is 0.50 GB/s; in 600 ns 20 GB/s; 40 times slower.
        assert!(
            table
                .contains("| 4-state | 2 | 1000 | 12000 | 24.0 µs | 600 ns | 0.50 | 20.00 | 40× |"),
            "{table}"
        );
        assert!(
            table.contains("| EXT | 10 | 1k | 1% | 1.00 µs | 100 ns |"),
            "{table}"
        );
        assert!(
            table.contains("| EXT | 1k | 1k | 100% | 100 µs | 100 ns |"),
            "{table}"
        );
        assert!(
            table.contains("| ext-micromap | 750 ns | 675 ns | met |"),
            "{table}"
        );
        assert!(
            table.contains("| khr-micromap | 1.30 µs | 1.17 µs | missed |"),
            "{table}"
        );
        // Buffer counts in numeric order, not string order.
        let hundred = table
            .find("| ext-micromap | 100 | 800 ns | 720 ns |")
            .expect(&table);
        let ten_thousand = table
            .find("| ext-micromap | 10000 | 900 ns | 810 ns |")
            .expect(&table);
        assert!(hundred < ten_thousand);
    }

    #[test]
    fn sections_without_benchmarks_are_left_out() {
        let machine = Machine {
            model: "m".into(),
            cores: 1,
        };
        let only_params: Vec<Estimate> = fixture()
            .into_iter()
            .filter(|e| e.group == "params-per-call")
            .collect();
        let table = render_table(&machine, false, &only_params);
        assert!(table.contains("Params tier"));
        assert!(!table.contains("Time per build"));
        assert!(!table.contains("--quick"));
    }

    #[test]
    fn plot_has_a_panel_per_build_and_a_line_per_tier() {
        let svg = render_plot(&fixture()).expect("plot renders");
        assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(200)]);
        assert!(svg.contains("EXT 2-state: time per build"));
        // Two tiers, each drawn as its line and its legend entry in its colour.
        for colour in ["#1F77B4", "#2CA02C"] {
            let lines =
                format!(r#"<polyline fill="none" opacity="1" stroke="{colour}" stroke-width="2""#);
            assert_eq!(svg.matches(&lines).count(), 2, "{colour}: {svg}");
        }
        for tier in ["params", "content"] {
            assert!(
                svg.contains(&format!("\n{tier}\n</text>")),
                "legend {tier}: {svg}"
            );
        }
    }

    fn overhead_run(ns: [f64; 3], messages: &[&str]) -> OverheadRun {
        OverheadRun {
            ns,
            messages: messages.iter().map(|m| m.to_string()).collect(),
        }
    }

    #[test]
    fn omm_app_overhead_output_parses() {
        let line = r#"{"scenario":"overhead","messages":[{"id":"VUID-x","severity":"error","phase":"record","text":""},{"id":"VUID-y","severity":"error","phase":"teardown","text":""}],"device_layers":[],"results":{"iterations":10,"ns_per_call":{"cmd_build_micromaps":12.5,"build_micromaps":30.0,"cmd_build_acceleration_structures":1500.0}}}"#;
        assert_eq!(
            parse_overhead(line).expect("parses"),
            overhead_run([12.5, 30.0, 1500.0], &["VUID-x"])
        );
        assert!(parse_overhead(r#"{"results":{}}"#).is_err());
    }

    #[test]
    fn interleaved_table_gives_overhead_over_khronos_less_no_layer() {
        let rows = [InterleavedRow {
            triangles: 1000,
            usage_entries: 64,
            call: OVERHEAD_CALLS[0].1,
            medians: [2.0, 202.0, 402.0],
        }];
        let table = render_interleaved("params", &rows, &BTreeSet::new());
        assert!(table.starts_with("| micromap triangles |"), "{table}");
        assert!(table.contains("ommcheck `params`"), "{table}");
        assert!(
            table.contains(
                "| 1000 | 64 | `vkCmdBuildMicromapsEXT` | 2.0 ns | 202 ns | 402 ns | 0.50× |"
            ),
            "{table}"
        );
        assert!(table.ends_with("Messages received: none\n"), "{table}");
        let messages = BTreeSet::from(["khronos: VUID-x".to_string()]);
        assert!(
            render_interleaved("params", &rows, &messages).contains("received: khronos: VUID-x")
        );
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn overhead_table_has_a_row_per_configuration_and_the_medians() {
        let machine = Machine {
            model: "Test CPU".into(),
            cores: 4,
        };
        let rows = vec![
            OverheadRow {
                config: "no layer".into(),
                runs: vec![
                    overhead_run([10.0, 20.0, 30.0], &[]),
                    overhead_run([12.0, 2000.0, 31.0], &[]),
                    overhead_run([11.0, 22.0, 5000.0], &[]),
                ],
            },
            OverheadRow {
                config: "ommcheck, `content`".into(),
                runs: vec![
                    overhead_run([1500.0, 2500.0, 3.5e6], &[]),
                    overhead_run([1600.0, 2600.0, 3.6e6], &["VUID-a"]),
                    overhead_run([1400.0, 2400.0, 3.4e6], &[]),
                ],
            },
        ];
        let table = render_overhead(&machine, 1000, &rows);
        let expected = "\
#### Layer overhead per call (median of 3 runs)

`omm-app overhead --iterations 1000` over the Khronos Mock ICD (every command a stub): valid calls timed in a loop after a warm-up, so the time is the loader's and the layers'. Machine: Test CPU (4 logical cores).

| configuration | `vkCmdBuildMicromapsEXT` | `vkBuildMicromapsEXT` (host) | `vkCmdBuildAccelerationStructuresKHR` (BLAS + micromap) |
| --- | ---: | ---: | ---: |
| no layer | 11.0 ns | 22.0 ns | 31.0 ns |
| ommcheck, `content` | 1.50 µs | 2.50 µs | 3.50 ms |

Messages received (the inputs are meant to be valid):
- ommcheck, `content`: `VUID-a`
";
        assert_eq!(table, expected);
        let quiet = render_overhead(&machine, 1000, &rows[..1]);
        assert!(quiet.ends_with("\nThe messenger received no message in any run.\n"));
    }

    #[test]
    fn the_overhead_section_replaces_its_predecessor_and_keeps_the_rest() {
        let machine = Machine {
            model: "Test CPU".into(),
            cores: 4,
        };
        let criterion = "## What accuracy costs: measurements\n\nMachine: X.\n\n| a |\n";
        let first =
            with_overhead_section(criterion, &machine, "#### Layer overhead per call\n\nold\n");
        assert_eq!(
            first,
            "## What accuracy costs: measurements\n\nMachine: X.\n\n| a |\n\n#### Layer overhead per call\n\nold\n"
        );
        let second =
            with_overhead_section(&first, &machine, "#### Layer overhead per call\n\nnew\n");
        assert_eq!(second, first.replace("old", "new"));
        let alone = with_overhead_section("", &machine, "#### Layer overhead per call\n");
        assert!(alone.starts_with(
            "## What accuracy costs: measurements\n\nMachine: Test CPU (4 logical cores).\n\n####"
        ));
    }

    #[test]
    fn overhead_configurations_in_table_order() {
        let configs = overhead_configs();
        let names: Vec<&str> = configs.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "no layer",
                "ommcheck, `params`",
                "ommcheck, `state`",
                "ommcheck, `content`",
                "Khronos validation",
                "ommcheck `content` + Khronos validation",
                "no layer, 64 usage entries",
                "ommcheck, `params`, 64 usage entries",
                "Khronos validation, 64 usage entries"
            ]
        );
        assert!(configs[..6].iter().all(|c| c.usage_entries == 1));
        assert!(configs[6..].iter().all(|c| c.usage_entries == 64));
        assert_eq!(configs[7].tier, Some("params"));
        assert_eq!(
            configs[5].layers,
            [
                "VK_LAYER_OMMCHECK_validation",
                "VK_LAYER_KHRONOS_validation"
            ]
        );
        assert_eq!(configs[0].tier, None);
        assert_eq!(configs[2].tier, Some("state"));
    }
}
