//! The snapshot corpus: `tests/scenes/corpus/<family>/`, one failing scene
//! per rule and its valid twin (see the corpus README). Every failing scene
//! must report its rule, every twin must report nothing at all, and every
//! report is kept as an insta snapshot under `tests/snapshots/corpus/`.
//! Scenes are checked at the default tier, except those of the rules only
//! the simulate tier decides ([`ommcheck::rules::SIMULATE_TIER`]), which are
//! checked at that tier.
//!
//! To accept changed reports: `INSTA_UPDATE=always cargo test -p ommcheck
//! --test corpus`, then review the diff of `validator/tests/snapshots/`.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use ommcheck::scene::{CheckOptions, Scene, SceneReport};
use ommcheck::Tier;

/// The corpus, relative to the workspace root (as reports show it).
const CORPUS: &str = "tests/scenes/corpus";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lives in the workspace")
        .to_path_buf()
}

/// What a corpus file is, by its name.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Role {
    /// `pass.json`: the family's valid scene, the twin of every failing
    /// scene without a twin of its own.
    FamilyPass,
    /// `<rule>.fail.json`.
    Fail(String),
    /// `<rule>.pass.json`: the valid twin of `<rule>.fail.json`.
    Twin(String),
}

struct CorpusScene {
    family: String,
    file: String,
    role: Role,
    report: SceneReport,
}

impl CorpusScene {
    /// `family/file`, as messages name it.
    fn name(&self) -> String {
        format!("{}/{}", self.family, self.file)
    }
}

fn role_of(file: &str) -> Option<Role> {
    if file == "pass.json" {
        Some(Role::FamilyPass)
    } else if let Some(rule) = file.strip_suffix(".fail.json") {
        Some(Role::Fail(rule.to_string()))
    } else {
        file.strip_suffix(".pass.json")
            .map(|rule| Role::Twin(rule.to_string()))
    }
}

/// The tier a scene is checked (and its report kept) at: the default, but
/// the simulate tier for the scenes of a rule only that tier decides (the
/// hygiene information), whose failing scenes would report nothing below it.
fn tier_for(role: &Role) -> Tier {
    let rule = match role {
        Role::Fail(rule) | Role::Twin(rule) => rule.as_str(),
        Role::FamilyPass => return Tier::default(),
    };
    if ommcheck::rules::SIMULATE_TIER.iter().any(|r| r.id == rule) {
        Tier::Simulate
    } else {
        Tier::default()
    }
}

fn sorted_entries(dir: &Path) -> Vec<PathBuf> {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    entries
}

/// Every corpus scene, checked, in a stable order (family, then file name).
fn corpus() -> Vec<CorpusScene> {
    let dir = root().join(CORPUS);
    let mut scenes = Vec::new();
    for family_dir in sorted_entries(&dir) {
        if !family_dir.is_dir() {
            continue;
        }
        let family = family_dir
            .file_name()
            .and_then(|n| n.to_str())
            .expect("a UTF-8 family name")
            .to_string();
        for path in sorted_entries(&family_dir) {
            let file = path
                .file_name()
                .and_then(|n| n.to_str())
                .expect("a UTF-8 file name")
                .to_string();
            if !file.ends_with(".json") {
                continue;
            }
            let role = role_of(&file).unwrap_or_else(|| {
                panic!("{family}/{file}: corpus scenes are pass.json, <rule>.fail.json or <rule>.pass.json")
            });
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
            // The path reports show is relative to the workspace root, so
            // snapshots do not depend on where the repository lives.
            let shown = format!("{CORPUS}/{family}/{file}");
            let scene = Scene::parse(&text, &shown, &family_dir).unwrap_or_else(|e| panic!("{e}"));
            let report = scene
                .check(&CheckOptions {
                    tier: tier_for(&role),
                    ..CheckOptions::default()
                })
                .unwrap_or_else(|e| panic!("{e}"));
            scenes.push(CorpusScene {
                family: family.clone(),
                file,
                role,
                report,
            });
        }
    }
    scenes
}

#[test]
fn failing_scenes_report_their_rule_and_twins_report_nothing() {
    let scenes = corpus();
    assert!(scenes.len() > 100, "the corpus has {} scenes", scenes.len());
    let mut problems = Vec::new();
    for scene in &scenes {
        let ids = scene.report.report.ids();
        match &scene.role {
            Role::Fail(rule) => {
                if !ids.contains(&rule.as_str()) {
                    problems.push(format!(
                        "{}: does not report {rule}; it reports {ids:?}",
                        scene.name()
                    ));
                }
                let twin = format!("{rule}.pass.json");
                let has_twin = scenes.iter().any(|s| {
                    s.family == scene.family && (s.file == twin || s.role == Role::FamilyPass)
                });
                if !has_twin {
                    problems.push(format!(
                        "{}: no valid twin ({twin} or pass.json)",
                        scene.name()
                    ));
                }
            }
            Role::FamilyPass | Role::Twin(_) => {
                if !valid_scene_findings_allowed(&scene.report.report) {
                    problems.push(format!("{}: a valid scene reports {ids:?}", scene.name()));
                }
                if let Role::Twin(rule) = &scene.role {
                    let fail = format!("{rule}.fail.json");
                    if !scenes
                        .iter()
                        .any(|s| s.family == scene.family && s.file == fail)
                    {
                        problems.push(format!("{}: twin of no {fail}", scene.name()));
                    }
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn corpus_reports_match_their_snapshots() {
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("snapshots/corpus");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        for scene in corpus() {
            let stem = scene.file.trim_end_matches(".json");
            let name = format!("{}__{stem}", scene.family);
            insta::assert_json_snapshot!(name, scene.report);
        }
    });
}

/// A valid scene reports nothing, except that a micromap it declares
/// `built` (a build the scene does not show, known by its triangle count
/// alone) leaves the rules that read its triangles not checked, and says so.
/// Every other rule of a valid scene is checked: the scenes supply the
/// contents and host memory their calls read.
fn valid_scene_findings_allowed(report: &ommcheck::Report) -> bool {
    report
        .findings
        .iter()
        .all(|f| f.not_checked_cause() == Some(ommcheck::Cause::BuildNotSeen))
}

/// Tiers decide more as they go up and never guess: a valid scene reports
/// nothing at any tier, and a failing scene that reports its rule at one
/// tier reports it at every tier above.
#[test]
fn tiers_only_add_findings_and_valid_scenes_stay_clean() {
    let dir = root().join(CORPUS);
    let mut problems = Vec::new();
    for family_dir in sorted_entries(&dir).into_iter().filter(|p| p.is_dir()) {
        for path in sorted_entries(&family_dir) {
            let file = path
                .file_name()
                .and_then(|n| n.to_str())
                .unwrap_or_default();
            let Some(role) = role_of(file) else {
                continue;
            };
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            let mut reported_below = false;
            for tier in ommcheck::Tier::ALL {
                let options = CheckOptions {
                    tier,
                    ..CheckOptions::default()
                };
                let report = scene.check(&options).unwrap_or_else(|e| panic!("{e}"));
                let ids = report.report.ids();
                match &role {
                    Role::Fail(rule) => {
                        let reported = ids.contains(&rule.as_str());
                        if reported_below && !reported {
                            problems.push(format!(
                                "{}: reports {rule} below the {tier} tier but not at it",
                                path.display()
                            ));
                        }
                        reported_below |= reported;
                    }
                    Role::FamilyPass | Role::Twin(_) => {
                        if !valid_scene_findings_allowed(&report.report) {
                            problems.push(format!(
                                "{}: a valid scene reports {ids:?} at the {tier} tier",
                                path.display()
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// The text form (the Khronos layer's message layout) of a handful of
/// failing scenes, one per kind of rule: parameters, content, an index
/// buffer, SPIR-V, a command that runs shaders, synchronization.
#[test]
fn text_reports_match_their_snapshots() {
    const SCENES: [&str; 6] = [
        "ext-build/VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516.fail.json",
        "ext-build/OMMCHECK-build-triangle-data-in-range.fail.json",
        "blas-khr/VUID-vkCmdBuildAccelerationStructuresKHR-indexBuffer-11575.fail.json",
        "pipelines/VUID-RuntimeSpirv-RayTracingOpacityMicromapKHR-11542.fail.json",
        "work-ray-query/VUID-vkCmdTraceRaysKHR-micromap-11636.fail.json",
        "synchronization/VUID-VkMemoryBarrier2-srcAccessMask-07457.fail.json",
    ];
    let mut settings = insta::Settings::clone_current();
    settings.set_snapshot_path("snapshots/corpus-text");
    settings.set_prepend_module_to_snapshot(false);
    settings.bind(|| {
        for scene in SCENES {
            let path = root().join(CORPUS).join(scene);
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{scene}: {e}"));
            let dir = path.parent().expect("a family directory");
            let report = Scene::parse(&text, scene, dir)
                .and_then(|s| s.check(&CheckOptions::default()))
                .unwrap_or_else(|e| panic!("{e}"));
            assert!(report.report.has_errors(), "{scene} reports no error");
            let name = scene
                .replace('/', "__")
                .trim_end_matches(".json")
                .to_string();
            insta::assert_snapshot!(name, report.named_findings());
        }
    });
}

/// Rules the scene format cannot express, with the reason: they are about
/// raw memory an application hands a layer (pointers, chains that loop,
/// arrays past the reader's bound), which JSON arrays cannot describe. The
/// raw reader's tests (`vuid_cases/raw.rs`) cover them. Listed, not counted
/// as missing.
fn inexpressible(id: &str) -> Option<&'static str> {
    const BY_ID: &[(&str, &str)] = &[
        (
            "VUID-vkCmdBuildMicromapsEXT-pInfos-parameter",
            "pInfos is a JSON array and infoCount its length: a NULL pInfos with a non-zero infoCount cannot be written",
        ),
        (
            "VUID-vkBuildMicromapsEXT-pInfos-parameter",
            "pInfos is a JSON array and infoCount its length: a NULL pInfos with a non-zero infoCount cannot be written",
        ),
        (
            "OMMCHECK-reader-pnext-chain",
            "pNext chains are JSON arrays: they cannot loop",
        ),
        (
            "OMMCHECK-reader-bounded",
            "arrays in scenes are JSON arrays of what they hold; the raw reader's bound does not apply",
        ),
    ];
    BY_ID
        .iter()
        .find(|(rule, _)| *rule == id)
        .map(|(_, why)| *why)
}

#[test]
fn corpus_coverage_of_enforced_rules() {
    let scenes = corpus();
    let in_corpus: BTreeSet<String> = scenes
        .iter()
        .filter_map(|s| match &s.role {
            Role::Fail(rule) => Some(rule.clone()),
            _ => None,
        })
        .collect();
    let mut enforced: Vec<(String, String)> = Vec::new();
    for module in ommcheck::checks::coverage() {
        for vuid in module.enforced {
            enforced.push((module.module.to_string(), vuid.id().to_string()));
        }
    }
    for rule in ommcheck::rules::ALL {
        enforced.push(("ommcheck rules".to_string(), rule.id.to_string()));
    }
    let enforced_ids: BTreeSet<&str> = enforced.iter().map(|(_, id)| id.as_str()).collect();

    // A corpus scene names a rule that is enforced (a typo would never fail).
    let unknown: Vec<&String> = in_corpus
        .iter()
        .filter(|rule| !enforced_ids.contains(rule.as_str()))
        .collect();
    assert!(
        unknown.is_empty(),
        "corpus scenes for rules no check enforces: {unknown:?}"
    );

    let mut covered = 0;
    let mut missing = Vec::new();
    let mut not_expressible = Vec::new();
    for (module, id) in &enforced {
        if in_corpus.contains(id) {
            covered += 1;
        } else if let Some(why) = inexpressible(id) {
            not_expressible.push(format!("{id} ({module}): {why}"));
        } else {
            missing.push(format!("{id} ({module})"));
        }
    }
    println!(
        "corpus: {} scenes; {covered} of {} enforced rules covered, {} missing, {} not expressible in scenes",
        scenes.len(),
        enforced.len(),
        missing.len(),
        not_expressible.len()
    );
    println!("missing:\n  {}", missing.join("\n  "));
    println!("not expressible:\n  {}", not_expressible.join("\n  "));
    assert_eq!(
        covered + missing.len() + not_expressible.len(),
        enforced.len()
    );
    assert!(
        missing.is_empty(),
        "{} enforced rules have no failing scene in the corpus:\n{}",
        missing.len(),
        missing.join("\n")
    );
}

/// The rules declared to need the simulate tier are exactly those the
/// corpus measures there, and every other rule is decided by the default
/// tier (content) or below.
#[test]
fn simulate_tier_rules_are_the_measured_ones() {
    let tiers =
        ommcheck::coverage::corpus_tiers(&root().join(CORPUS)).unwrap_or_else(|e| panic!("{e}"));
    let declared: BTreeSet<&str> = ommcheck::rules::SIMULATE_TIER
        .iter()
        .map(|r| r.id)
        .collect();
    let measured: BTreeSet<&str> = tiers
        .iter()
        .filter(|(_, tier)| **tier > Tier::default())
        .map(|(rule, _)| rule.as_str())
        .collect();
    assert_eq!(declared, measured);
    for rule in declared {
        assert_eq!(tiers.get(rule), Some(&Tier::Simulate), "{rule}");
    }
}
