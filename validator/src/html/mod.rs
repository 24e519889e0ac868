//! The HTML report (`ommcheck check --format html`, or `--html FILE`
//! beside another format): one self-contained page with the summary, each
//! scene's findings grouped by rule with the rule's statement and link,
//! pictures of what the findings point at, and what was not checked and
//! why.
//!
//! The page loads nothing: the style is inline, pictures are `data:` URIs
//! (the drawing module's SVG, or its PNG where that is smaller than a large
//! SVG), there is no script, and a Content-Security-Policy tells the
//! browser to load nothing else. Everything that comes from a scene (paths,
//! names in messages and locations) is escaped. The page's size is bounded
//! apart from the scenes' count: at most [`Limits::pictures`] pictures of
//! bounded size, and at most so many findings listed per rule and in all;
//! the page says what it left out.
//!
//! It sits above `scene` and `draw` and below the CLI; nothing in the core
//! imports it. docs/cli.md describes the page.

pub mod pictures;

use std::borrow::Cow;
use std::collections::HashMap;
use std::fmt::Write as _;

use crate::report::{count, Finding, ObjectRef, RuleId, Severity};
use crate::scene::{CheckOptions, SceneReport, Summary};
use crate::Tier;
use pictures::{Figure, Gallery, Outcome, PictureLimits};

pub use pictures::Source;

/// The bounds of one page.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    pub pictures: PictureLimits,
    /// The most findings one rule's group of one scene lists.
    pub findings_per_rule: usize,
    /// The most findings the page lists in all.
    pub findings: usize,
    /// The most not-checked informations the page lists.
    pub not_checked: usize,
}

/// The bounds `ommcheck check` writes pages under: with 16 pictures of at
/// most 384 KiB and 2,000 findings of a few KiB each, a page stays within
/// about 16 MiB however many findings the scenes have (the example's
/// pictures are 90 to 150 KiB each).
pub const LIMITS: Limits = Limits {
    pictures: PictureLimits {
        pictures: 16,
        bytes: 384 << 10,
    },
    findings_per_rule: 100,
    findings: 2000,
    not_checked: 200,
};

/// `text` with the characters HTML gives a meaning (`& < > " '`) written
/// as references, for text and for attribute values alike.
pub fn escape(text: &str) -> Cow<'_, str> {
    if !text.contains(['&', '<', '>', '"', '\'']) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    Cow::Owned(out)
}

/// The findings of one scene under one rule, in the order they were found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Group<'a> {
    pub rule: RuleId,
    /// The most severe of its findings.
    pub severity: Severity,
    pub findings: Vec<&'a Finding>,
}

/// `findings` grouped by rule, errors first, then warnings, then
/// information, and in the order of each rule's first finding within a
/// severity; the not-checked informations apart (the page lists them
/// under what was not checked), in their order.
pub fn groups(findings: &[Finding]) -> (Vec<Group<'_>>, Vec<&Finding>) {
    let mut groups: Vec<Group<'_>> = Vec::new();
    let mut not_checked = Vec::new();
    let mut index: HashMap<RuleId, usize> = HashMap::new();
    for finding in findings {
        if finding.not_checked_cause().is_some() {
            not_checked.push(finding);
            continue;
        }
        let i = *index.entry(finding.rule).or_insert_with(|| {
            groups.push(Group {
                rule: finding.rule,
                severity: finding.severity,
                findings: Vec::new(),
            });
            groups.len() - 1
        });
        let group = &mut groups[i];
        group.severity = group.severity.max(finding.severity);
        group.findings.push(finding);
    }
    // Stable: rules of one severity keep the order of their first finding.
    groups.sort_by_key(|group| std::cmp::Reverse(group.severity));
    (groups, not_checked)
}

/// The page's style: plain, readable, printable.
const STYLE: &str = "
:root { color-scheme: light; }
body { font: 15px/1.45 system-ui, -apple-system, 'Segoe UI', sans-serif; color: #202020; background: #fff; margin: 0 auto; max-width: 1100px; padding: 1.5em; }
h1 { font-size: 1.6em; margin: 0 0 .3em; }
h2 { font-size: 1.3em; border-bottom: 1px solid #d0d4d9; padding-bottom: .2em; margin-top: 2em; }
h3 { font-size: 1.05em; margin: 1.4em 0 .3em; }
code { font-family: ui-monospace, 'DejaVu Sans Mono', monospace; font-size: .87em; background: #f2f4f6; padding: 0 .25em; border-radius: 3px; overflow-wrap: anywhere; }
table { border-collapse: collapse; margin: .5em 0; }
th, td { border: 1px solid #d0d4d9; padding: .2em .6em; text-align: left; vertical-align: top; }
td.n { text-align: right; }
.badge { display: inline-block; font-size: .8em; font-weight: 600; padding: 0 .5em; border-radius: 3px; color: #fff; }
.badge.error { background: #b00020; }
.badge.warning { background: #9a5b00; }
.badge.info { background: #1f5f99; }
blockquote.spec { margin: .3em 0; padding: .3em .8em; border-left: 4px solid #d0d4d9; background: #f8f9fa; }
ol.findings > li { margin: .7em 0; }
.message { margin: .15em 0; }
figure { margin: .5em 0; }
figure img { display: block; max-width: min(100%, 540px); height: auto; border: 1px solid #e0e3e6; }
figcaption, .note { font-size: .9em; color: #555; }
footer { margin-top: 3em; font-size: .85em; color: #666; }
";

/// Writes the page of `reports` (checked under `options`, counted in
/// `summary`) within `limits`; `load` reads a report's scene again to draw
/// its pictures ([`Source::reload`] reads it from its path).
pub fn page(
    reports: &[SceneReport],
    summary: &Summary,
    options: &CheckOptions,
    limits: &Limits,
    load: &dyn Fn(&SceneReport) -> Result<Source, String>,
) -> String {
    let mut writer = Writer {
        out: String::new(),
        limits: *limits,
        gallery: Gallery::new(limits.pictures, options, load),
        listed: 0,
        unlisted: 0,
    };
    let grouped: Vec<Grouped<'_>> = reports
        .iter()
        .map(|report| {
            let (groups, not_checked) = groups(&report.findings);
            Grouped {
                report,
                groups,
                not_checked,
            }
        })
        .collect();
    let mut quiet = Vec::new();
    for (i, scene) in grouped.iter().enumerate() {
        if scene.groups.is_empty() {
            quiet.push(scene.report);
        } else {
            writer.scene(i, scene.report, &scene.groups);
        }
    }
    let body = std::mem::take(&mut writer.out);
    let not_checked = writer.not_checked(&grouped, summary, options.tier);

    let mut out = String::with_capacity(body.len() + not_checked.len() + 16_384);
    let title = match reports {
        [one] => format!("ommcheck report: {}", one.path),
        _ => format!(
            "ommcheck report: {}",
            count(reports.len(), "scene", "scenes")
        ),
    };
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; style-src 'unsafe-inline'\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
        escape(&title),
        escape(&title)
    );
    writer.summary(&mut out, &grouped, summary);
    out.push_str(&body);
    if !quiet.is_empty() {
        let _ = write!(
            out,
            "<section id=\"quiet\">\n<h2>Scenes without findings</h2>\n<p>{} with no finding (what was not checked in them is below):</p>\n<ul>\n",
            count(quiet.len(), "scene", "scenes")
        );
        for report in quiet {
            let _ = writeln!(
                out,
                "<li><code>{}</code> ({})</li>",
                escape(&report.path),
                count(report.calls, "call", "calls")
            );
        }
        out.push_str("</ul>\n</section>\n");
    }
    out.push_str(&not_checked);
    let _ = write!(
        out,
        "<footer>Written by ommcheck {}, with the micromap VUIDs of Vulkan {}. The page loads nothing: its pictures are inline.</footer>\n</body>\n</html>\n",
        env!("CARGO_PKG_VERSION"),
        crate::vuids::REGISTRY_VERSION
    );
    out
}

/// One scene's findings as the page shows them.
struct Grouped<'a> {
    report: &'a SceneReport,
    groups: Vec<Group<'a>>,
    not_checked: Vec<&'a Finding>,
}

/// A row of the summary's table of rules with findings.
struct RuleRow {
    rule: RuleId,
    severity: Severity,
    findings: usize,
    scenes: usize,
    /// The id of the rule's first group on the page.
    anchor: String,
}

/// The CSS class of a severity.
fn class(severity: Severity) -> &'static str {
    match severity {
        Severity::Error => "error",
        Severity::Warning => "warning",
        Severity::Info => "info",
    }
}

/// A link to where `rule`'s statement is published, named by the rule.
fn rule_link(rule: RuleId) -> String {
    format!(
        "<a href=\"{}\"><code>{}</code></a>",
        escape(&rule.link()),
        escape(rule.as_str())
    )
}

/// `1 KiB` for byte counts in notes.
fn kib(bytes: usize) -> String {
    format!("{} KiB", bytes.div_ceil(1024))
}

struct Writer<'a> {
    out: String,
    limits: Limits,
    gallery: Gallery<'a>,
    /// Findings listed so far, and left unlisted by the bounds.
    listed: usize,
    unlisted: usize,
}

impl<'a> Writer<'a> {
    /// The counts, the rules with findings over every scene, and what the
    /// page left out.
    fn summary(&self, out: &mut String, grouped: &[Grouped<'_>], summary: &Summary) {
        let _ = write!(
            out,
            "<section id=\"summary\">\n<h2>Summary</h2>\n<p>{}</p>\n<table>\n\
             <tr><th>scenes</th><th>calls</th><th>errors</th><th>warnings</th><th>info</th><th>rules checked</th><th>rules not checked</th></tr>\n\
             <tr><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\"><a href=\"#not-checked\">{}</a></td></tr>\n</table>\n",
            escape(&summary.line()),
            summary.scenes,
            summary.calls,
            summary.errors,
            summary.warnings,
            summary.info,
            summary.rules_checked,
            summary.rules_not_checked
        );
        // Each rule with findings, over every scene, linked to its first group.
        let mut rules: Vec<RuleRow> = Vec::new();
        let mut index: HashMap<RuleId, usize> = HashMap::new();
        for (i, scene) in grouped.iter().enumerate() {
            for (j, group) in scene.groups.iter().enumerate() {
                let k = *index.entry(group.rule).or_insert_with(|| {
                    rules.push(RuleRow {
                        rule: group.rule,
                        severity: group.severity,
                        findings: 0,
                        scenes: 0,
                        anchor: format!("s{i}-r{j}"),
                    });
                    rules.len() - 1
                });
                let row = &mut rules[k];
                row.severity = row.severity.max(group.severity);
                row.findings += group.findings.len();
                row.scenes += 1;
            }
        }
        rules.sort_by_key(|r| (std::cmp::Reverse(r.severity), std::cmp::Reverse(r.findings)));
        if !rules.is_empty() {
            out.push_str("<table>\n<tr><th>rule</th><th>severity</th><th>findings</th><th>scenes</th></tr>\n");
            for row in &rules {
                let _ = writeln!(
                    out,
                    "<tr><td><a href=\"#{}\"><code>{}</code></a></td><td><span class=\"badge {}\">{}</span></td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>",
                    row.anchor,
                    escape(row.rule.as_str()),
                    class(row.severity),
                    class(row.severity),
                    row.findings,
                    row.scenes
                );
            }
            out.push_str("</table>\n");
        }
        let gallery = &self.gallery;
        let bound = self.limits.pictures.describe();
        let _ = write!(
            out,
            "<p>Pictures of what findings point at, each with the legend of its colours (docs/pictures.md describes them): {} shown",
            gallery.shown
        );
        if gallery.left_out > 0 {
            let _ = write!(
                out,
                "; {} not drawn because the page was full",
                count(gallery.left_out, "finding's picture", "findings' pictures")
            );
        }
        if gallery.too_large > 0 {
            let _ = write!(
                out,
                "; {} too large to hold",
                count(gallery.too_large, "picture", "pictures")
            );
        }
        let _ = writeln!(out, " (the page holds {bound}).</p>");
        if self.unlisted > 0 {
            let _ = writeln!(
                out,
                "<p>Findings listed: {} of {} (the page lists at most {} per rule in a scene and {} in all; the text and JSON reports list every one).</p>",
                self.listed,
                self.listed + self.unlisted,
                self.limits.findings_per_rule,
                self.limits.findings
            );
        }
        out.push_str("</section>\n");
    }

    /// One scene's findings, by rule.
    fn scene(&mut self, i: usize, report: &'a SceneReport, groups: &[Group<'_>]) {
        let counts = report.report.summary();
        let _ = write!(
            self.out,
            "<section class=\"scene\" id=\"scene-{i}\">\n<h2><code>{}</code></h2>\n<p>{}: {}, {}, {} info.</p>\n",
            escape(&report.path),
            count(report.calls, "call", "calls"),
            count(counts.errors, "error", "errors"),
            count(counts.warnings, "warning", "warnings"),
            counts.info
        );
        self.gallery.begin(report);
        for (j, group) in groups.iter().enumerate() {
            let rule = group.rule;
            let _ = write!(
                self.out,
                "<section class=\"rule\" id=\"s{i}-r{j}\">\n<h3><span class=\"badge {}\">{}</span> {} <span class=\"note\">({})</span></h3>\n\
                 <blockquote class=\"spec\">{}</blockquote>\n<ol class=\"findings\">\n",
                class(group.severity),
                class(group.severity),
                rule_link(rule),
                count(group.findings.len(), "finding", "findings"),
                escape(rule.statement())
            );
            let room = self
                .limits
                .findings_per_rule
                .min(self.limits.findings.saturating_sub(self.listed));
            for finding in group.findings.iter().take(room) {
                self.finding(report, finding);
            }
            self.out.push_str("</ol>\n");
            let listed = room.min(group.findings.len());
            let unlisted = group.findings.len() - listed;
            if unlisted > 0 {
                let _ = writeln!(
                    self.out,
                    "<p class=\"note\">{} of this rule not listed: the page lists at most {} per rule in a scene and {} in all.</p>",
                    count(unlisted, "more finding", "more findings"),
                    self.limits.findings_per_rule,
                    self.limits.findings
                );
            }
            self.listed += listed;
            self.unlisted += unlisted;
            self.out.push_str("</section>\n");
        }
        if let Some(error) = self.gallery.scene_error() {
            let _ = writeln!(
                self.out,
                "<p class=\"note\">No pictures of this scene: {}</p>",
                escape(error)
            );
        }
        self.out.push_str("</section>\n");
    }

    /// One finding: where, what, the objects, and its picture.
    fn finding(&mut self, report: &SceneReport, finding: &Finding) {
        let out = &mut self.out;
        let _ = write!(out, "<li><code>{}()</code>", escape(finding.function));
        if !finding.location.is_empty() {
            let _ = write!(out, " at <code>{}</code>", escape(&finding.location));
        }
        if let Some(line) = finding.at.line {
            let _ = write!(out, " <span class=\"note\">(line {line})</span>");
        }
        let _ = write!(
            out,
            "\n<div class=\"message\">{}</div>\n",
            escape(&finding.message)
        );
        if let Some(hint) = &finding.hint {
            let _ = writeln!(out, "<div class=\"message\"><b>{}</b></div>", escape(hint));
        }
        if !finding.objects.is_empty() {
            let objects: Vec<String> = finding
                .objects
                .iter()
                .map(|o| format!("<code>{}</code>", escape(&object_text(o, report))))
                .collect();
            let _ = writeln!(
                out,
                "<div class=\"note\">Objects: {}</div>",
                objects.join(", ")
            );
        }
        match self.gallery.picture(finding) {
            None => {}
            Some((Outcome::Shown { .. }, Some(figure))) => figure_html(out, &figure),
            Some((Outcome::Shown { number }, None)) => {
                let _ = writeln!(
                    out,
                    "<p class=\"note\">Shown in <a href=\"#picture-{number}\">picture {number}</a> above.</p>"
                );
            }
            Some((Outcome::NotDrawn(why), _)) => {
                let _ = writeln!(out, "<p class=\"note\">No picture: {}</p>", escape(&why));
            }
            Some((Outcome::TooLarge { bytes }, _)) => {
                let _ = writeln!(
                    out,
                    "<p class=\"note\">No picture: it takes {} even as PNG, more than the {} one picture may take on this page.</p>",
                    kib(bytes),
                    kib(self.limits.pictures.bytes)
                );
            }
            Some((Outcome::LeftOut, _)) => {
                let _ = writeln!(
                    out,
                    "<p class=\"note\">Picture left out: the page holds at most {}.</p>",
                    count(self.limits.pictures.pictures, "picture", "pictures")
                );
            }
        }
        out.push_str("</li>\n");
    }

    /// What was not checked: the tiers not run, and each not-checked
    /// information with the rules it skipped, by scene.
    fn not_checked(&mut self, grouped: &[Grouped<'_>], summary: &Summary, tier: Tier) -> String {
        let mut out =
            String::from("<section id=\"not-checked\">\n<h2>What was not checked, and why</h2>\n");
        let above: Vec<&str> = Tier::ALL
            .into_iter()
            .filter(|t| *t > tier)
            .map(Tier::name)
            .collect();
        let _ = write!(out, "<p>Checked at the <code>{tier}</code> tier");
        if above.is_empty() {
            out.push_str(", the highest.</p>\n");
        } else {
            let _ = writeln!(
                out,
                ": the rules only a higher tier decides ({}) were not looked at (<code>--tier NAME</code> runs one; docs/static-checker.md describes the tiers).</p>",
                above.join(", ")
            );
        }
        if summary.rules_not_checked == 0 {
            out.push_str("<p>Every rule the calls reached was decided: nothing was skipped for want of what a scene did not give.</p>\n");
        } else {
            let _ = writeln!(
                out,
                "<p>{} not checked: the checks that decide them needed something a scene did not give. Each cause below names the rules it skipped and what would let them run.</p>",
                count(summary.rules_not_checked, "rule was", "rules were")
            );
        }
        let mut listed = 0;
        let mut unlisted = 0;
        for Grouped {
            report,
            not_checked,
            ..
        } in grouped
        {
            if not_checked.is_empty() {
                continue;
            }
            let _ = write!(
                out,
                "<h3><code>{}</code></h3>\n<ul>\n",
                escape(&report.path)
            );
            for finding in not_checked {
                if listed == self.limits.not_checked {
                    unlisted += 1;
                    continue;
                }
                listed += 1;
                let _ = write!(
                    out,
                    "<li>{} <code>{}()</code>",
                    rule_link(finding.rule),
                    escape(finding.function)
                );
                if !finding.location.is_empty() {
                    let _ = write!(out, " at <code>{}</code>", escape(&finding.location));
                }
                let rules: Vec<String> =
                    finding.not_checked.iter().map(|r| rule_link(*r)).collect();
                let _ = write!(
                    out,
                    "\n<div class=\"message\">{}</div>\n<div class=\"note\">Not checked: {}</div></li>\n",
                    escape(&finding.message),
                    rules.join(", ")
                );
            }
            out.push_str("</ul>\n");
        }
        if unlisted > 0 {
            let _ = writeln!(
                out,
                "<p class=\"note\">{} not listed: the page lists at most {}.</p>",
                count(unlisted, "more cause", "more causes"),
                self.limits.not_checked
            );
        }
        out.push_str("</section>\n");
        out
    }
}

/// An object as the text report writes it: `VkBuffer 'omm-input' (0xb00001)`
/// where the scene names it.
fn object_text(object: &ObjectRef, report: &SceneReport) -> String {
    match report
        .objects
        .iter()
        .find(|o| o.kind == object.ty && o.handle == object.handle)
    {
        Some(named) => format!("{} '{}' ({:#x})", object.ty, named.name, object.handle),
        None => format!("{} {:#x}", object.ty, object.handle),
    }
}

/// A picture, numbered so later findings can point at it.
fn figure_html(out: &mut String, figure: &Figure) {
    let title = escape(&figure.title);
    let _ = writeln!(
        out,
        "<figure id=\"picture-{}\"><img src=\"{}\" alt=\"{title}\"><figcaption>Picture {}: {title}</figcaption></figure>",
        figure.number,
        figure.uri(),
        figure.number
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rules;
    use crate::scene::{Scene, EXAMPLE, EXAMPLE_PATH};
    use crate::vuids::Vuid;
    use base64::Engine as _;
    use std::path::Path;

    fn example_source(_: &SceneReport) -> Result<Source, String> {
        Source::parse(EXAMPLE, EXAMPLE_PATH, Path::new(".")).map_err(|e| e.to_string())
    }

    fn example_report() -> SceneReport {
        Scene::example().check(&CheckOptions::default()).unwrap()
    }

    fn render(reports: &[SceneReport], limits: &Limits) -> String {
        let summary = Summary::of(reports);
        page(
            reports,
            &summary,
            &CheckOptions::default(),
            limits,
            &example_source,
        )
    }

    /// The `src` of each picture on `page`.
    fn sources(page: &str) -> Vec<&str> {
        page.split("<img src=\"")
            .skip(1)
            .filter_map(|rest| rest.split_once('"').map(|(src, _)| src))
            .collect()
    }

    fn finding(rule: impl Into<RuleId>, severity: Severity, location: &str) -> Finding {
        Finding::new(rule, severity, "vkCmdBuildMicromapsEXT", location, "m")
    }

    #[test]
    fn escaping_covers_markup_and_both_quotes() {
        assert_eq!(
            escape(r#"<a href="x">Tom & 'Jerry'</a>"#),
            "&lt;a href=&quot;x&quot;&gt;Tom &amp; &#39;Jerry&#39;&lt;/a&gt;"
        );
        assert!(matches!(escape("plain text"), Cow::Borrowed("plain text")));
        assert_eq!(escape("&amp;"), "&amp;amp;");
    }

    #[test]
    fn findings_group_by_rule_errors_first_and_not_checked_apart() {
        let not_checked = finding(crate::Cause::Contents.rule(), Severity::Info, "calls[0]");
        let findings = vec![
            finding(&rules::HISTOGRAM_MISMATCH, Severity::Info, "a"),
            finding(&rules::TRIANGLE_DATA_RANGE, Severity::Error, "b"),
            not_checked.clone(),
            finding(&rules::TRIANGLE_DATA_RANGE, Severity::Error, "c"),
            finding(Vuid::all().next().unwrap(), Severity::Warning, "d"),
            finding(&rules::INDEX_IN_RANGE, Severity::Error, "e"),
        ];
        let (groups, apart) = groups(&findings);
        let shape: Vec<(&str, Severity, Vec<&str>)> = groups
            .iter()
            .map(|g| {
                let locations = g.findings.iter().map(|f| f.location.as_str()).collect();
                (g.rule.as_str(), g.severity, locations)
            })
            .collect();
        assert_eq!(
            shape,
            [
                (
                    rules::TRIANGLE_DATA_RANGE.id,
                    Severity::Error,
                    vec!["b", "c"]
                ),
                (rules::INDEX_IN_RANGE.id, Severity::Error, vec!["e"]),
                (
                    Vuid::all().next().unwrap().id(),
                    Severity::Warning,
                    vec!["d"]
                ),
                (rules::HISTOGRAM_MISMATCH.id, Severity::Info, vec!["a"]),
            ]
        );
        assert_eq!(apart, [&not_checked]);
    }

    #[test]
    fn the_examples_page_holds_each_finding_by_rule_with_its_picture() {
        let report = example_report();
        let page = render(std::slice::from_ref(&report), &LIMITS);
        // Self-contained: no script, nothing fetched, a policy saying so.
        assert!(!page.contains("<script"));
        assert!(!page.contains("src=\"http") && !page.contains("<link"));
        assert!(page.contains("content=\"default-src 'none'; img-src data:"));
        for finding in &report.findings {
            assert!(
                page.contains(&*escape(&finding.message)),
                "{}",
                finding.message
            );
            assert!(page.contains(&*escape(finding.rule.statement())));
            assert!(page.contains(&format!("<a href=\"{}\">", escape(&finding.rule.link()))));
        }
        // One section per rule: the two usage-count findings share one.
        let rules: std::collections::BTreeSet<&str> =
            report.findings.iter().map(|f| f.rule.as_str()).collect();
        assert_eq!(page.matches("<section class=\"rule\"").count(), rules.len());
        // Three findings, each pointing at a thing of its own, each drawn
        // once, as SVG (the usage counts' two mismatched keys are one
        // finding, with its hint).
        let pictures = sources(&page);
        assert_eq!(pictures.len(), 3);
        assert!(pictures
            .iter()
            .all(|p| p.starts_with("data:image/svg+xml;base64,")));
        assert!(page.contains("Picture 1: micromap &#39;foliage-omm&#39; triangle 3"));
        assert!(!page.contains("Shown in <a href="));
        assert!(page.contains(
            "<b>Did you mean VK_OPACITY_MICROMAP_FORMAT_4_STATE_EXT for 1 of these 3 triangles?</b>"
        ));
        assert!(page.contains("Picture 2: micromap &#39;foliage-omm&#39; usage counts"));
        assert!(page.contains("Picture 3: &#39;foliage-blas&#39; geometry 0"));
        // Each picture marks the finding it is shown for, as `ommcheck
        // draw` does (one code path: crate::draw::findings).
        let svgs: Vec<String> = pictures
            .iter()
            .map(|p| {
                let data = p.trim_start_matches("data:image/svg+xml;base64,");
                let bytes = base64::engine::general_purpose::STANDARD
                    .decode(data)
                    .unwrap();
                String::from_utf8(bytes).unwrap()
            })
            .collect();
        for (svg, target) in svgs.iter().zip([
            "micromap triangle 3",
            "usage counts VK_OPACITY_MICROMAP_FORMAT_2_STATE_EXT level 3",
            "geometry triangle 4",
        ]) {
            assert!(
                svg.contains(&format!("<g class=\"finding\" data-target=\"{target}\">")),
                "{target}"
            );
        }
        assert!(page.contains(&*escape(&Summary::of(&[report]).line())));
        assert!(page.contains("Every rule the calls reached was decided"));
    }

    #[test]
    fn what_comes_from_the_scene_is_escaped() {
        let hostile = r#"x\"><script>alert('omm')</script>"#;
        let text = EXAMPLE.replace("foliage-omm", hostile);
        let path = "<scene & co>.json";
        let load =
            |_: &SceneReport| Source::parse(&text, path, Path::new(".")).map_err(|e| e.to_string());
        let report = load(&example_report())
            .unwrap()
            .scene
            .check(&CheckOptions::default())
            .unwrap();
        let summary = Summary::of(std::slice::from_ref(&report));
        let page = page(
            std::slice::from_ref(&report),
            &summary,
            &CheckOptions::default(),
            &LIMITS,
            &load,
        );
        assert!(!page.contains("<script"), "a scene's text became markup");
        assert!(page.contains("&lt;script&gt;alert(&#39;omm&#39;)&lt;/script&gt;"));
        assert!(page.contains("<code>&lt;scene &amp; co&gt;.json</code>"));
        // The picture of the renamed micromap is still drawn.
        assert_eq!(sources(&page).len(), 3);
    }

    #[test]
    fn pictures_stop_at_the_pages_bound_and_say_so() {
        let report = example_report();
        // The default bounds with other picture bounds.
        let bounds = |pictures, bytes| Limits {
            pictures: PictureLimits { pictures, bytes },
            ..LIMITS
        };
        let one = bounds(1, LIMITS.pictures.bytes);
        let page = render(std::slice::from_ref(&report), &one);
        assert_eq!(sources(&page).len(), 1);
        // The grid and the geometry left out.
        assert_eq!(
            page.matches("Picture left out: the page holds at most 1 picture.")
                .count(),
            2
        );
        assert!(
            page.contains(": 1 shown; 2 findings' pictures not drawn because the page was full")
        );

        let tiny = bounds(LIMITS.pictures.pictures, 1000);
        let page = render(std::slice::from_ref(&report), &tiny);
        assert!(sources(&page).is_empty());
        assert_eq!(page.matches("No picture: it takes ").count(), 3);
        assert!(page.contains("; 3 pictures too large to hold"));
    }

    #[test]
    fn many_scenes_keep_the_pictures_within_their_bound() {
        let reports = vec![example_report(); 40];
        let page = render(&reports, &LIMITS);
        let pictures = sources(&page);
        assert_eq!(pictures.len(), LIMITS.pictures.pictures);
        let prefix = "data:image/svg+xml;base64,".len();
        assert!(pictures
            .iter()
            .all(|p| p.len() <= prefix + LIMITS.pictures.bytes));
        // 40 scenes of 3 findings, each pointing at something: 16 drawn,
        // and (counted per finding) the rest not.
        let shown_findings = page.matches("<figure").count() + page.matches("Shown in <a").count();
        let left_out = page.matches("Picture left out").count();
        assert_eq!(shown_findings + left_out, 40 * 3);
        assert_eq!(page.matches("<section class=\"scene\"").count(), 40);
    }

    #[test]
    fn thousands_of_findings_make_a_page_of_bounded_size() {
        // 5,000 findings over 50 rules, each at one of the example's
        // micromap triangles.
        let mut report = example_report();
        let vuids: Vec<Vuid> = Vuid::all().take(50).collect();
        let findings: Vec<Finding> = (0..5000)
            .map(|i| {
                let location = format!("calls[1]: pInfos[0].triangleArray[{}].dataOffset", i % 4);
                finding(vuids[i % 50], Severity::Error, &location)
            })
            .collect();
        report.findings = findings.clone();
        report.report = crate::Report::from(findings);
        let page = render(std::slice::from_ref(&report), &LIMITS);
        let listed = page
            .matches("<li><code>vkCmdBuildMicromapsEXT()</code>")
            .count();
        assert_eq!(listed, LIMITS.findings);
        assert!(page.contains(&format!("Findings listed: {} of 5000", LIMITS.findings)));
        // Groups past the bound say how many they leave out.
        assert!(page.contains("100 more findings of this rule not listed"));
        // The four triangles drawn once each.
        assert_eq!(sources(&page).len(), 4);
        let pictures: usize = sources(&page).iter().map(|p| p.len()).sum();
        // Each listed finding is a few hundred bytes; the bound allows a KiB.
        assert!(
            page.len() - pictures < LIMITS.findings * 1024,
            "{} bytes besides the pictures",
            page.len() - pictures
        );
    }
}
