//! `ommcheck stats`: a scene's calls are run through the checker, then the
//! state census of the micromaps they built ([`Validator::micromap_stats`])
//! is printed per micromap, by its scene name, and in total.

use std::fmt::Write as _;

use serde::Serialize;

use super::resolve::{self, NamedObject};
use super::{count, CheckOptions, Scene, SceneError};
use crate::checks::Validator;
use crate::inspect::stats::{Census, MicromapStats};
use crate::sim::census::{StateCounts, STATES};

/// The census of one scene: an element of the JSON output's `scenes`.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct StatsReport {
    pub path: String,
    /// How many calls were run.
    pub calls: usize,
    pub micromaps: Vec<NamedMicromapStats>,
    pub total: Census,
}

/// One micromap's census with its scene name.
#[derive(Clone, Debug, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct NamedMicromapStats {
    /// The scene's name for the micromap (None for one it did not name).
    pub name: Option<String>,
    #[serde(flatten)]
    pub stats: MicromapStats,
}

/// Counts over the scenes (the JSON output's `summary`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct StatsSummary {
    pub scenes: usize,
    pub micromaps: usize,
    pub triangles: u64,
    pub counted: u64,
    pub uniform: u64,
}

impl StatsSummary {
    pub fn of(reports: &[StatsReport]) -> Self {
        let mut summary = Self {
            scenes: reports.len(),
            ..Self::default()
        };
        for report in reports {
            summary.micromaps += report.micromaps.len();
            summary.triangles += report.total.triangles;
            summary.counted += report.total.counted;
            summary.uniform += report.total.uniform.triangles;
        }
        summary
    }

    /// The text form's last line.
    pub fn line(&self) -> String {
        format!(
            "{}, {}: {} of {} counted, {} uniform",
            count(self.scenes, "scene", "scenes"),
            count(self.micromaps, "micromap", "micromaps"),
            self.counted,
            count64(self.triangles, "triangle", "triangles"),
            self.uniform
        )
    }
}

impl Scene {
    /// Runs the scene's calls (at the content tier, which records what
    /// builds read), then takes the census of the micromaps they built.
    /// A semantic error returns before anything runs.
    pub fn stats(&self) -> Result<StatsReport, SceneError> {
        let run =
            resolve::run(&self.file, &self.base_dir, &CheckOptions::default()).map_err(|p| {
                SceneError::Semantic {
                    path: self.path.clone(),
                    json_path: p.path,
                    message: p.message,
                }
            })?;
        Ok(stats_report(
            &self.path,
            run.checked.calls,
            &run.checked.objects,
            &run.validator,
        ))
    }
}

fn stats_report(
    path: &str,
    calls: usize,
    objects: &[NamedObject],
    validator: &Validator,
) -> StatsReport {
    let stats = validator.micromap_stats();
    let micromaps = stats
        .micromaps
        .into_iter()
        .map(|stats| NamedMicromapStats {
            name: objects
                .iter()
                .find(|o| o.kind == stats.kind && o.handle == stats.handle)
                .map(|o| o.name.clone()),
            stats,
        })
        .collect();
    StatsReport {
        path: path.to_string(),
        calls,
        micromaps,
        total: stats.total,
    }
}

fn count64(n: u64, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// The column heads of the state tables, in state order.
const HEADS: [&str; 4] = [
    "transparent",
    "opaque",
    "unknown-transparent",
    "unknown-opaque",
];

impl StatsReport {
    /// The text form: a header, then one block per micromap and one for
    /// the total (the summary line is the caller's, after the last scene).
    pub fn text(&self) -> String {
        let micromaps = count(self.micromaps.len(), "micromap", "micromaps");
        let mut out = super::header(&self.path, self.calls, micromaps);
        for micromap in &self.micromaps {
            let stats = &micromap.stats;
            let name = micromap
                .name
                .as_ref()
                .map_or_else(String::new, |n| format!("'{n}' "));
            let _ = writeln!(
                out,
                "micromap {name}({} {:#x}){}",
                stats.kind,
                stats.handle,
                if stats.content_known {
                    ""
                } else {
                    ": contents not known to the checker"
                }
            );
            write_census(&mut out, &stats.census, true);
        }
        if self.micromaps.len() > 1 {
            out.push_str("total\n");
            write_census(&mut out, &self.total, false);
        }
        out.push('\n');
        out
    }
}

/// One census as text: the counts, a table of the states by level, the
/// uniform triangles and the references; `listed` when it has lists.
fn write_census(out: &mut String, census: &Census, listed: bool) {
    let _ = writeln!(
        out,
        "  {}, {} counted",
        count64(census.triangles, "triangle", "triangles"),
        census.counted
    );
    let mut rows: Vec<[String; 7]> = vec![[
        "level".into(),
        String::new(),
        "triangles".into(),
        HEADS[0].into(),
        HEADS[1].into(),
        HEADS[2].into(),
        HEADS[3].into(),
    ]];
    let mut row = |label: String, kind: &str, triangles: u64, counts: &StateCounts| {
        let [a, b, c, d] = counts.to_array().map(|n| n.to_string());
        rows.push([label, kind.into(), triangles.to_string(), a, b, c, d]);
    };
    for level in &census.levels {
        let label = format!("{} L{}", level.format, level.level);
        row(label, "stored", level.triangles, &level.stored);
        row(
            String::new(),
            "referenced",
            level.references,
            &level.referenced,
        );
    }
    if census.levels.len() > 1 {
        row("all".into(), "stored", census.counted, &census.stored);
        let references = census.references.counted;
        row(String::new(), "referenced", references, &census.referenced);
    }
    if census.levels.is_empty() {
        rows.clear();
    }
    write_table(out, &rows);
    write_uniform(out, census, listed);
    write_not_counted(out, census, listed);
    write_references(out, census);
}

/// Rows of cells, the first two columns left-aligned, the rest right-aligned.
fn write_table(out: &mut String, rows: &[[String; 7]]) {
    let mut widths = [0usize; 7];
    for row in rows {
        for (width, cell) in widths.iter_mut().zip(row) {
            *width = (*width).max(cell.len());
        }
    }
    for row in rows {
        let mut line = String::from("  ");
        for (i, (cell, width)) in row.iter().zip(widths).enumerate() {
            let _ = match i {
                0 | 1 => write!(line, "{cell:<width$}  "),
                _ => write!(line, "{cell:>width$}  "),
            };
        }
        let _ = writeln!(out, "{}", line.trim_end());
    }
}

/// `3 transparent, 1 opaque` (the states with a count, or `none`).
fn by_state(counts: &StateCounts) -> String {
    let held: Vec<String> = STATES
        .iter()
        .zip(HEADS)
        .filter(|(state, _)| counts.get(**state) != 0)
        .map(|(state, head)| format!("{} {head}", counts.get(*state)))
        .collect();
    if held.is_empty() {
        "none".into()
    } else {
        held.join(", ")
    }
}

fn write_uniform(out: &mut String, census: &Census, listed: bool) {
    let uniform = &census.uniform;
    if uniform.triangles == 0 {
        return;
    }
    let _ = write!(
        out,
        "  uniform (a special index could replace them): {} ({})",
        count64(uniform.triangles, "triangle", "triangles"),
        by_state(&uniform.by_state)
    );
    if listed {
        let shown: Vec<String> = uniform
            .listed
            .iter()
            .map(|t| format!("[{}] {}", t.index, HEADS[t.state as usize]))
            .collect();
        let more = uniform.triangles - uniform.listed.len() as u64;
        let _ = write!(out, ": {}", shown.join(", "));
        if more > 0 {
            let _ = write!(out, " and {more} more");
        }
    }
    out.push('\n');
}

fn write_not_counted(out: &mut String, census: &Census, listed: bool) {
    let not = &census.not_counted;
    if not.triangles == 0 {
        return;
    }
    let reasons: Vec<String> = [
        (not.format, "not an opacity format"),
        (not.level, "level above 12"),
        (not.data_past_end, "data past the end"),
    ]
    .iter()
    .filter(|(n, _)| *n != 0)
    .map(|(n, why)| format!("{n} {why}"))
    .collect();
    let _ = write!(
        out,
        "  not counted: {} ({})",
        count64(not.triangles, "triangle", "triangles"),
        reasons.join(", ")
    );
    if listed {
        let shown: Vec<String> = not.listed.iter().map(|i| format!("[{i}]")).collect();
        let _ = write!(out, ": {}", shown.join(", "));
        let more = not.triangles - not.listed.len() as u64;
        if more > 0 {
            let _ = write!(out, " and {more} more");
        }
    }
    out.push('\n');
}

fn write_references(out: &mut String, census: &Census) {
    let r = &census.references;
    let _ = write!(
        out,
        "  references: {}, {}: {} to counted triangles",
        count64(r.attachments, "attachment", "attachments"),
        count64(
            r.geometry_triangles,
            "geometry triangle",
            "geometry triangles"
        ),
        r.counted
    );
    let special = r.special.total();
    if special > 0 {
        let _ = write!(out, ", {special} special ({})", by_state(&r.special));
    }
    for (n, what) in [
        (r.cluster_skip, "-5 (cluster skip)"),
        (r.not_counted, "to triangles not counted"),
        (r.unread, "not read"),
    ] {
        if n > 0 {
            let _ = write!(out, ", {n} {what}");
        }
    }
    if r.without_range > 0 {
        let _ = write!(
            out,
            "; {} without a build range",
            count64(r.without_range, "attachment", "attachments")
        );
    }
    out.push('\n');
}
