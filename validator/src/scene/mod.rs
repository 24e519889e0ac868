//! Scene files: a JSON description of a device, its buffers and objects, and
//! an ordered list of API calls, checked call by call without a GPU.
//!
//! ```
//! use ommcheck::scene::{Scene, CheckOptions};
//!
//! let scene = Scene::parse(r#"{
//!     "buffers": [{ "name": "scratch", "size": 65536,
//!                   "usage": "VK_BUFFER_USAGE_STORAGE_BUFFER_BIT" }],
//!     "calls": [{ "call": "vkCmdBuildMicromapsEXT", "pInfos": [] }]
//! }"#, "inline.json", std::path::Path::new(".")).unwrap();
//! let checked = scene.check(&CheckOptions::default()).unwrap();
//! assert!(checked.report.contains(
//!     ommcheck::vuids::vuid::vkCmdBuildMicromapsEXT::infoCount_arraylength));
//! assert!(checked.report.findings[0].location.starts_with("calls[0]"));
//! ```
//!
//! `docs/scene-format.md` describes the format; [`schema`] gives its JSON
//! Schema.

pub mod args;
pub mod format;
mod in_test;
mod lines;
mod mapped;
mod resolve;
pub mod stats;
pub mod trace;
pub mod write;

use std::fmt;
use std::path::{Path, PathBuf};

use serde::Serialize;

pub use resolve::{
    read_profile_file, LimitsOverride, NamedObject, ObjectKind, Problem, ResolvedRay, DEVICE_HANDLE,
};
#[cfg(test)]
use resolve::{resolve_alone, resolve_alone_mut};
pub use stats::{StatsReport, StatsSummary};
pub use trace::{RayReport, TraceReport, TraceSummary};

pub use crate::report::count;
use crate::report::{Finding, Report, ReportSummary};
use format::SceneFile;

/// The built-in example scene (`ommcheck check --example`): a micromap
/// build and a BLAS build with three realistic mistakes.
pub const EXAMPLE: &str = include_str!("../../examples/example-scene.json");
/// The name the example goes by in reports.
pub const EXAMPLE_PATH: &str = "<built-in example>";

/// The largest scene file ommcheck reads (binary data belongs in `file`
/// pieces, which are limited separately).
pub const MAX_SCENE_BYTES: u64 = 64 << 20;

/// Why a scene could not be checked.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneError {
    /// The file could not be read.
    Read { path: String, message: String },
    /// The file is not a scene: malformed JSON or a member of the wrong
    /// shape, at a line and column (1-based).
    Syntax {
        path: String,
        line: usize,
        column: usize,
        message: String,
    },
    /// The scene is well-formed but names something that does not exist or
    /// cannot be; `json_path` says where (`calls[2].pInfos[0].dstMicromap`).
    Semantic {
        path: String,
        json_path: String,
        message: String,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::Read { path, message } => write!(f, "{path}: {message}"),
            SceneError::Syntax {
                path,
                line,
                column,
                message,
            } => write!(f, "{path}:{line}:{column}: {message}"),
            SceneError::Semantic {
                path,
                json_path,
                message,
            } => write!(f, "{path}: {json_path}: {message}"),
        }
    }
}

impl std::error::Error for SceneError {}

/// What the command line may override.
#[derive(Clone, Debug, Default)]
pub struct CheckOptions {
    /// Limits to check under instead of the scene's profile and limits.
    pub limits: Option<LimitsOverride>,
    /// How far the checks look (default: content).
    pub tier: crate::Tier,
}

/// A parsed scene, ready to check.
#[derive(Debug)]
pub struct Scene {
    /// The path as given (or a name for a scene from memory).
    pub path: String,
    /// Where relative paths inside the scene are resolved from.
    pub base_dir: PathBuf,
    pub file: SceneFile,
    /// The line of the scene text each call starts on, for the findings
    /// of that call (empty for a scene not parsed from text).
    pub call_lines: Vec<usize>,
}

/// The result of checking one scene.
#[derive(Clone, Debug, Serialize)]
pub struct SceneReport {
    pub path: String,
    /// How many calls were checked.
    pub calls: usize,
    /// The scene's named objects and the handles findings show for them.
    pub objects: Vec<NamedObject>,
    pub findings: Vec<Finding>,
    #[serde(skip)]
    pub report: Report,
}

impl Scene {
    /// Reads and parses a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let shown = path.display().to_string();
        let read_error = |message: String| SceneError::Read {
            path: shown.clone(),
            message,
        };
        let size = std::fs::metadata(path)
            .map_err(|e| read_error(format!("cannot read: {e}")))?
            .len();
        if size > MAX_SCENE_BYTES {
            return Err(read_error(format!(
                "{size} bytes; a scene file may have at most {MAX_SCENE_BYTES} (put large data in binary files the scene names)"
            )));
        }
        let text =
            std::fs::read_to_string(path).map_err(|e| read_error(format!("cannot read: {e}")))?;
        let base_dir = path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        Scene::parse(&text, &shown, &base_dir)
    }

    /// Parses scene text; `path` names it in messages and `base_dir`
    /// anchors the relative paths it contains.
    pub fn parse(text: &str, path: &str, base_dir: &Path) -> Result<Scene, SceneError> {
        let file: SceneFile = serde_json::from_str(text).map_err(|e| syntax(path, &e))?;
        Ok(Scene {
            path: path.to_string(),
            base_dir: base_dir.to_path_buf(),
            file,
            call_lines: lines::call_lines(text),
        })
    }

    /// The built-in example.
    pub fn example() -> Scene {
        match Scene::parse(EXAMPLE, EXAMPLE_PATH, Path::new(".")) {
            Ok(scene) => scene,
            // A test parses the example; an unreadable one is a build defect
            // shown as a scene with no calls rather than a panic.
            Err(_) => Scene {
                path: EXAMPLE_PATH.into(),
                base_dir: PathBuf::from("."),
                file: SceneFile {
                    schema: None,
                    description: None,
                    device: None,
                    buffers: Vec::new(),
                    host_memory: Vec::new(),
                    micromaps: Vec::new(),
                    acceleration_structures: Vec::new(),
                    query_pools: Vec::new(),
                    deferred_operations: Vec::new(),
                    command_buffers: Vec::new(),
                    other_device_objects: Vec::new(),
                    driver_answers: Default::default(),
                    calls: Vec::new(),
                    rays: Vec::new(),
                    alpha_textures: Vec::new(),
                },
                call_lines: Vec::new(),
            },
        }
    }

    /// Resolves every name, address and file of the scene, then checks its
    /// calls in order. A semantic error returns before any finding.
    pub fn check(&self, options: &CheckOptions) -> Result<SceneReport, SceneError> {
        self.check_into_validator(options).map(|(report, _)| report)
    }
}

impl SceneReport {
    /// The findings' text with the scene's objects named.
    pub fn named_findings(&self) -> String {
        self.report
            .text_naming(&|object| resolve::scene_name(&self.objects, object))
    }

    /// The text form `ommcheck check` prints for the scene: a header, then
    /// the findings in the Khronos layer's style or `no findings`.
    pub fn text(&self) -> String {
        let header = format!(
            "== {} ({})\n",
            self.path,
            count(self.calls, "call", "calls")
        );
        if self.findings.is_empty() {
            header + "no findings\n\n"
        } else {
            format!("{header}\n{}", self.named_findings())
        }
    }
}

/// The first line of a scene's text output: `== path (4 calls, 2 rays)`,
/// `what` saying what else the command found in it.
pub(crate) fn header(path: &str, calls: usize, what: String) -> String {
    format!("== {path} ({}, {what})\n", count(calls, "call", "calls"))
}

fn syntax(path: &str, error: &serde_json::Error) -> SceneError {
    let (line, column) = (error.line(), error.column());
    let text = error.to_string();
    // serde_json appends the position; it is shown in front instead.
    let message = text
        .strip_suffix(&format!(" at line {line} column {column}"))
        .unwrap_or(&text)
        .to_string();
    SceneError::Syntax {
        path: path.to_string(),
        line,
        column,
        message,
    }
}

/// Counts over every checked scene (the JSON output's `summary`).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct Summary {
    pub scenes: usize,
    pub calls: usize,
    pub findings: usize,
    pub errors: usize,
    pub warnings: usize,
    pub info: usize,
    /// Rules the checks decided in every scene that reached them.
    pub rules_checked: usize,
    /// Rules a not-checked information names: skipped for want of what a
    /// scene did not give (see [`crate::report::not_checked`]).
    pub rules_not_checked: usize,
}

impl Summary {
    pub fn of(reports: &[SceneReport]) -> Summary {
        Summary::over(reports.iter().map(|r| (r.calls, &r.report)))
    }

    /// Counts over scenes given as (calls, report): each finding once, each
    /// rule once however many scenes checked it (see [`ReportSummary::of`]).
    pub fn over<'a>(scenes: impl Iterator<Item = (usize, &'a Report)> + Clone) -> Summary {
        let counts = ReportSummary::of(scenes.clone().map(|(_, report)| report));
        Summary {
            scenes: scenes.clone().count(),
            calls: scenes.map(|(calls, _)| calls).sum(),
            findings: counts.findings,
            errors: counts.errors,
            warnings: counts.warnings,
            info: counts.info,
            rules_checked: counts.rules_checked,
            rules_not_checked: counts.rules_not_checked,
        }
    }

    /// The text form's last line: `2 scenes, 5 calls: 1 error, 0 warnings,
    /// 0 info; 14 rules checked, 3 not checked`.
    pub fn line(&self) -> String {
        format!(
            "{}, {}: {}, {}, {} info; {} checked, {} not checked",
            count(self.scenes, "scene", "scenes"),
            count(self.calls, "call", "calls"),
            count(self.errors, "error", "errors"),
            count(self.warnings, "warning", "warnings"),
            self.info,
            count(self.rules_checked, "rule", "rules"),
            self.rules_not_checked
        )
    }
}

impl fmt::Display for Summary {
    /// The last line of `ommcheck check`'s text output.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.line())
    }
}

/// The JSON output of `ommcheck check --format json` (`Output<SceneReport,
/// Summary>`) and `ommcheck trace --format json` (`Output<TraceReport,
/// TraceSummary>`): one layout, the scenes and then the counts over them.
#[derive(Clone, Debug, Serialize)]
pub struct Output<'a, R = SceneReport, S = Summary> {
    pub scenes: &'a [R],
    pub summary: &'a S,
}

/// The JSON Schema of scene files, generated from the serde types
/// (published as `docs/scene.schema.json`).
pub fn schema() -> String {
    let schema = schemars::schema_for!(SceneFile);
    let mut text = serde_json::to_string_pretty(&schema).unwrap_or_default();
    text.push('\n');
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_example_parses_and_checks() {
        let scene = Scene::parse(EXAMPLE, EXAMPLE_PATH, Path::new(".")).unwrap();
        let report = scene.check(&CheckOptions::default()).unwrap();
        assert!(report.report.has_errors());
    }

    /// Calls and enum values may be spelled with any name vk.xml gives
    /// them, aliases included, and check exactly as their core names do.
    #[test]
    fn every_vk_xml_spelling_is_accepted() {
        let barrier = |call: &str, suffix: &str| {
            format!(
                r#"{{"buffers": [], "calls": [{{"call": "{call}", "pDependencyInfo": {{
                    "pMemoryBarriers": [{{
                        "srcStageMask": "VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT{suffix}",
                        "srcAccessMask": "VK_ACCESS_2_SHADER_READ_BIT{suffix}"}}]}}}},
                    {{"call": "vkResetQueryPool{suffix2}", "queryPool": 0, "firstQuery": 0, "queryCount": 0}}]}}"#,
                suffix2 = if suffix.is_empty() { "" } else { "EXT" },
            )
        };
        let check = |text: String| {
            let scene = Scene::parse(&text, "aliases.json", Path::new("."))
                .unwrap_or_else(|e| panic!("{e}"));
            scene.check(&CheckOptions::default()).unwrap().report
        };
        let core = check(barrier("vkCmdPipelineBarrier2", ""));
        assert!(!core.is_empty(), "the barrier's masks disagree: {core}");
        let aliased = check(barrier("vkCmdPipelineBarrier2KHR", "_KHR"));
        assert_eq!(aliased.ids(), core.ids());
        assert_eq!(aliased.to_string(), core.to_string());
        // A name vk.xml does not give is still refused.
        let wrong = barrier("vkCmdPipelineBarrier2NV", "");
        assert!(Scene::parse(&wrong, "aliases.json", Path::new(".")).is_err());
    }

    #[test]
    fn counts_agree_with_their_nouns() {
        assert_eq!(count(1, "call", "calls"), "1 call");
        assert_eq!(count(0, "call", "calls"), "0 calls");
        let summary = Summary {
            scenes: 2,
            calls: 1,
            findings: 1,
            errors: 1,
            warnings: 0,
            info: 0,
            rules_checked: 1,
            rules_not_checked: 2,
        };
        assert_eq!(
            summary.line(),
            "2 scenes, 1 call: 1 error, 0 warnings, 0 info; 1 rule checked, 2 not checked"
        );
    }

    #[test]
    fn syntax_errors_carry_line_and_column() {
        let error = Scene::parse(
            "{\n  \"calls\": [\n    {\"call\": 5}\n  ]\n}",
            "s.json",
            Path::new("."),
        )
        .unwrap_err();
        match error {
            SceneError::Syntax { line, .. } => assert_eq!(line, 3),
            other => panic!("{other}"),
        }
    }
}
