//! Findings and reports, and their text in the Khronos validation layer's style.

use std::fmt;

use ommcheck_vuids::Vuid;
use serde::Serialize;

pub mod location;
pub mod names;
pub mod not_checked;
pub(crate) mod objects;
pub mod quote;

use crate::rules::OwnRule;
use not_checked::{Cause, NotChecked, RuleSet};

/// How bad a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Hygiene or portability information.
    Info,
    /// Legal per the specification but known to misbehave (for example on drivers).
    Warning,
    /// A Valid Usage violation.
    Error,
}

impl Severity {
    /// The prefix the Khronos layer prints.
    pub fn label(self) -> &'static str {
        match self {
            Severity::Error => "Validation Error",
            Severity::Warning => "Validation Warning",
            Severity::Info => "Validation Information",
        }
    }
}

/// What a finding enforces: a catalog VUID, or a rule of ours for spec prose
/// that has no VUID.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RuleId {
    Vuid(Vuid),
    Own(&'static OwnRule),
}

impl RuleId {
    /// The id string users filter on.
    pub fn as_str(self) -> &'static str {
        match self {
            RuleId::Vuid(v) => v.id(),
            RuleId::Own(rule) => rule.id,
        }
    }

    /// The specification statement the rule enforces.
    pub fn statement(self) -> &'static str {
        match self {
            RuleId::Vuid(v) => v.info().text,
            RuleId::Own(rule) => rule.statement,
        }
    }

    /// Where that statement is published.
    pub fn link(self) -> String {
        match self {
            RuleId::Vuid(v) => v.link(),
            RuleId::Own(rule) => rule.link.to_string(),
        }
    }

    /// The Khronos layer's MessageID: XXH32 of the id string with seed 8.
    pub fn message_id(self) -> u32 {
        message_id(self.as_str())
    }
}

impl From<Vuid> for RuleId {
    fn from(v: Vuid) -> Self {
        RuleId::Vuid(v)
    }
}

impl From<&'static OwnRule> for RuleId {
    fn from(rule: &'static OwnRule) -> Self {
        RuleId::Own(rule)
    }
}

impl Serialize for RuleId {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.as_str())
    }
}

impl fmt::Display for RuleId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// `messageIdNumber` as the Khronos validation layer computes it (XXH32 of
/// the VUID string, seed 8), so filters written for that layer match ours.
pub fn message_id(id: &str) -> u32 {
    xxhash_rust::xxh32::xxh32(id.as_bytes(), 8)
}

/// `n` and the noun in the number that agrees with it: `1 call`, `2 calls`,
/// for messages and summaries that print a count next to a noun.
pub fn count<N>(n: N, one: &str, many: &str) -> String
where
    N: Copy + fmt::Display + PartialEq + From<u8>,
{
    format!("{n} {}", if n == N::from(1) { one } else { many })
}

/// A Vulkan object a finding involves.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct ObjectRef {
    /// `VkMicromapEXT`, `VkBuffer`, ...
    #[serde(rename = "type")]
    pub ty: &'static str,
    pub handle: u64,
}

/// Where a finding comes from, beyond its parameter path: the call of a
/// scene, the scene file and the line that call starts on, and the names
/// of the objects the finding involves.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct At {
    /// The index of the call in the scene's `calls`.
    pub call: Option<usize>,
    /// The scene file, as the report names it.
    pub scene: Option<String>,
    /// The 1-based line of the scene file on which the call starts.
    pub line: Option<usize>,
    /// Names of objects of [`Finding::objects`], by handle: a scene's
    /// names, or those a program gave with
    /// [`Validator::name_object`](crate::Validator::name_object).
    pub names: Vec<(u64, String)>,
}

impl At {
    /// The name given to `handle`, if any.
    pub fn name_of(&self, handle: u64) -> Option<&str> {
        self.names
            .iter()
            .find(|(h, _)| *h == handle)
            .map(|(_, name)| name.as_str())
    }
}

/// One problem found.
///
/// In JSON (`ommcheck check --format json`, or serde) a finding is an
/// object with, in this order: `id`, `severity`, `function`, `location`
/// (the call and parameter path as one string, as the text shows it),
/// `at` (the same place in parts: `call`, `parameter`, `scene`, `line`),
/// `objects` (each with `type`, `handle` and, where known, `name`),
/// `message`, `hint` (where a fix is clear), `folded` (how many findings
/// this one stands for besides itself), `messageId`, `specText` (the
/// rule's whole statement), `specQuote` (the one sentence of it the
/// finding breaks, where the statement has more than one), `specUrl` and
/// `notChecked`. Members that would be empty are left out, except
/// `objects`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Finding {
    pub rule: RuleId,
    pub severity: Severity,
    /// The command or entry point checked, e.g. `vkCmdBuildMicromapsEXT`.
    pub function: &'static str,
    /// The place inside its parameters, e.g. `pInfos[1].pUsageCounts[3].subdivisionLevel`
    /// (in a scene's report prefixed with the call: `calls[2]: pInfos[1]...`).
    pub location: String,
    /// The call, scene line and object names (see [`At`]).
    pub at: At,
    pub objects: Vec<ObjectRef>,
    pub message: String,
    /// A likely fix, where one is clear (`Did you mean level 3?`): a
    /// sentence, written after the message.
    pub hint: Option<String>,
    /// How many findings caused by this one (bytes decoded from a range
    /// already in error, the other half of a misplaced usage count) were
    /// folded into it instead of being listed; the message says what they were.
    pub folded: u64,
    pub message_id: u32,
    /// The rule's whole statement.
    pub spec_text: &'static str,
    /// The sentence of `spec_text` this finding breaks (see [`quote`]);
    /// the text form quotes it.
    pub spec_quote: &'static str,
    pub spec_url: String,
    /// For a not-checked information (`OMMCHECK-not-checked-*`): the rules
    /// that could not be decided.
    pub not_checked: Vec<RuleId>,
}

impl Serialize for Finding {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Object<'a> {
            #[serde(rename = "type")]
            ty: &'static str,
            handle: u64,
            #[serde(skip_serializing_if = "Option::is_none")]
            name: Option<&'a str>,
        }
        #[derive(Serialize)]
        struct Place<'a> {
            #[serde(skip_serializing_if = "Option::is_none")]
            call: Option<usize>,
            parameter: &'a str,
            #[serde(skip_serializing_if = "Option::is_none")]
            scene: Option<&'a str>,
            #[serde(skip_serializing_if = "Option::is_none")]
            line: Option<usize>,
        }
        #[derive(Serialize)]
        #[serde(rename_all = "camelCase")]
        struct Out<'a> {
            id: RuleId,
            severity: Severity,
            function: &'static str,
            location: &'a str,
            at: Place<'a>,
            objects: Vec<Object<'a>>,
            message: &'a str,
            #[serde(skip_serializing_if = "Option::is_none")]
            hint: Option<&'a str>,
            #[serde(skip_serializing_if = "is_zero")]
            folded: u64,
            message_id: u32,
            spec_text: &'static str,
            #[serde(skip_serializing_if = "Option::is_none")]
            spec_quote: Option<&'static str>,
            spec_url: &'a str,
            #[serde(skip_serializing_if = "no_rules")]
            not_checked: &'a [RuleId],
        }
        fn is_zero(n: &u64) -> bool {
            *n == 0
        }
        fn no_rules(rules: &&[RuleId]) -> bool {
            rules.is_empty()
        }
        Out {
            id: self.rule,
            severity: self.severity,
            function: self.function,
            location: &self.location,
            at: Place {
                call: self.at.call,
                parameter: self.parameter(),
                scene: self.at.scene.as_deref(),
                line: self.at.line,
            },
            objects: self
                .objects
                .iter()
                .map(|o| Object {
                    ty: o.ty,
                    handle: o.handle,
                    name: self.at.name_of(o.handle),
                })
                .collect(),
            message: &self.message,
            hint: self.hint.as_deref(),
            folded: self.folded,
            message_id: self.message_id,
            spec_text: self.spec_text,
            spec_quote: (self.spec_quote != self.spec_text).then_some(self.spec_quote),
            spec_url: &self.spec_url,
            not_checked: &self.not_checked,
        }
        .serialize(serializer)
    }
}

impl Finding {
    pub fn new(
        rule: impl Into<RuleId>,
        severity: Severity,
        function: &'static str,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        let rule = rule.into();
        let location = location.into();
        Self {
            rule,
            severity,
            function,
            spec_quote: quote::sentence(rule, &location),
            location,
            at: At::default(),
            objects: Vec::new(),
            message: message.into(),
            hint: None,
            folded: 0,
            message_id: rule.message_id(),
            spec_text: rule.statement(),
            spec_url: rule.link(),
            not_checked: Vec::new(),
        }
    }

    /// The parameter path alone: [`Self::location`] without the call a
    /// scene puts in front of it (`calls[2]: `).
    pub fn parameter(&self) -> &str {
        match self.at.call {
            Some(_) if self.location.starts_with("calls[") => self
                .location
                .split_once(": ")
                .map_or("", |(_, parameter)| parameter),
            _ => &self.location,
        }
    }

    /// Folds `n` findings this one caused into it: they are not listed,
    /// and the message ends with `; {what}` (`and 30 more triangles past
    /// the triangles written: ...`).
    pub fn fold(&mut self, n: u64, what: impl fmt::Display) {
        if n == 0 {
            return;
        }
        self.folded = self.folded.saturating_add(n);
        let end = self.message.trim_end_matches('.').len();
        self.message.truncate(end);
        self.message.push_str(&format!("; {what}"));
    }

    /// Adds a hint (a sentence) to the finding.
    pub fn with_hint(mut self, hint: impl Into<String>) -> Self {
        self.hint = Some(hint.into());
        self
    }

    /// The cause, if this is a not-checked information.
    pub fn not_checked_cause(&self) -> Option<Cause> {
        Cause::of(self.rule)
    }

    pub fn with_object(mut self, ty: &'static str, handle: u64) -> Self {
        self.objects.push(ObjectRef { ty, handle });
        self
    }
}

impl Finding {
    /// The text form, with each object the finding involves written as
    /// `VkBuffer 'omm-input' (0xb00001)` where `name_of` knows its name.
    fn write_text(
        &self,
        f: &mut impl fmt::Write,
        name_of: &dyn Fn(&ObjectRef) -> Option<String>,
    ) -> fmt::Result {
        write!(
            f,
            "{}: [ {} ] | MessageID = {:#010x} | {}(): ",
            self.severity.label(),
            self.rule,
            self.message_id,
            self.function
        )?;
        if !self.location.is_empty() {
            write!(f, "{}: ", self.location)?;
        }
        let message = self.message.trim_end_matches('.');
        write!(f, "{message}.")?;
        if let Some(hint) = &self.hint {
            write!(f, " {hint}")?;
        }
        write!(
            f,
            " The Vulkan spec states: {} ({})",
            self.spec_quote, self.spec_url
        )?;
        for (i, object) in self.objects.iter().enumerate() {
            let own = || self.at.name_of(object.handle).map(str::to_string);
            match name_of(object).or_else(own) {
                Some(name) => write!(
                    f,
                    "\n    Objects[{i}]: {} '{name}' ({:#x})",
                    object.ty, object.handle
                )?,
                None => write!(f, "\n    Objects[{i}]: {} {:#x}", object.ty, object.handle)?,
            }
        }
        if let (Some(scene), Some(line)) = (&self.at.scene, self.at.line) {
            write!(f, "\n    Scene: {scene}:{line}")?;
        }
        Ok(())
    }
}

impl fmt::Display for Finding {
    /// `Validation Error: [ VUID ] | MessageID = 0x... | vkFn(): location: message. The Vulkan spec states: ... (link)`
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_text(f, &|_| None)
    }
}

/// The findings of one or more checked calls, in the order they were found,
/// and the rules the checks decided.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Report {
    pub findings: Vec<Finding>,
    /// Every rule the checks of these calls decided, passed or failed
    /// (see [`Report::summary`]).
    #[serde(skip)]
    pub checked: RuleSet,
}

impl From<Vec<Finding>> for Report {
    fn from(findings: Vec<Finding>) -> Self {
        Self {
            findings,
            checked: RuleSet::new(),
        }
    }
}

impl Report {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn push(&mut self, finding: Finding) {
        self.findings.push(finding);
    }

    /// Puts `findings` of an earlier step of the same call (reading its
    /// arguments) before this report's own; cheaper than [`Self::extend`]
    /// into a report of them, which moves this one and merges rule sets.
    pub fn prepend(&mut self, findings: Vec<Finding>) {
        if !findings.is_empty() {
            self.findings.splice(0..0, findings);
        }
    }

    pub fn extend(&mut self, other: Report) {
        self.findings.extend(other.findings);
        self.checked.union(&other.checked);
    }

    /// The not-checked information findings: rules skipped because the
    /// checker was not told something (see [`crate::report::not_checked`]).
    pub fn not_checked(&self) -> impl Iterator<Item = &Finding> {
        self.findings
            .iter()
            .filter(|f| f.not_checked_cause().is_some())
    }

    /// Ok when every rule the calls reached was decided; otherwise the
    /// not-checked findings, each naming the rules it skipped and what
    /// would let them run. The way to write a unit test: a test of a
    /// valid call that passes by skipping fails here instead.
    ///
    /// ```
    /// use ommcheck::{Device, Validator};
    /// use ommcheck::model::{CommandBuffer, MicromapBuildInfo, MicromapUsage, UsageCounts};
    ///
    /// let mut v = Validator::new(Device::default());
    /// let build = MicromapBuildInfo {
    ///     usage_counts: UsageCounts::array(vec![MicromapUsage { count: 1, subdivision_level: 0, format: 2 }]),
    ///     data: 0x1000,
    ///     triangle_array: 0x2000,
    ///     ..Default::default()
    /// };
    /// // No buffers were described: the triangle array cannot be read.
    /// let report = v.cmd_build_micromaps(&CommandBuffer::default(), &[build]);
    /// let not_checked = report.require_fully_checked().unwrap_err();
    /// assert!(not_checked.to_string().contains("OMMCHECK-build-triangle-data-in-range"));
    /// ```
    pub fn require_fully_checked(&self) -> Result<(), NotChecked> {
        let findings: Vec<Finding> = self.not_checked().cloned().collect();
        if findings.is_empty() {
            Ok(())
        } else {
            Err(NotChecked { findings })
        }
    }

    /// Panics, listing what was not checked and why, unless every rule the
    /// calls reached was decided (see [`Report::require_fully_checked`]).
    #[track_caller]
    pub fn assert_fully_checked(&self) {
        if let Err(not_checked) = self.require_fully_checked() {
            panic!("{not_checked}");
        }
    }

    /// Counts of the findings by severity and of the rules checked.
    pub fn summary(&self) -> ReportSummary {
        ReportSummary::of([self])
    }

    pub fn is_empty(&self) -> bool {
        self.findings.is_empty()
    }

    pub fn len(&self) -> usize {
        self.findings.len()
    }

    /// Findings of at least error severity.
    pub fn errors(&self) -> impl Iterator<Item = &Finding> {
        self.findings
            .iter()
            .filter(|f| f.severity == Severity::Error)
    }

    pub fn has_errors(&self) -> bool {
        self.errors().next().is_some()
    }

    /// Whether any finding enforces `rule`.
    pub fn contains(&self, rule: impl Into<RuleId>) -> bool {
        let rule = rule.into();
        self.findings.iter().any(|f| f.rule == rule)
    }

    /// The findings that enforce `rule`.
    pub fn with_rule(&self, rule: impl Into<RuleId>) -> impl Iterator<Item = &Finding> {
        let rule = rule.into();
        self.findings.iter().filter(move |f| f.rule == rule)
    }

    /// The ids of all findings, in order (handy in test assertions).
    pub fn ids(&self) -> Vec<&'static str> {
        self.findings.iter().map(|f| f.rule.as_str()).collect()
    }
}

impl Report {
    /// The text form with the objects findings involve named by `name_of`
    /// (a scene names its objects; a program may name its handles).
    pub fn text_naming(&self, name_of: &dyn Fn(&ObjectRef) -> Option<String>) -> String {
        let mut out = String::new();
        for finding in &self.findings {
            let _ = finding.write_text(&mut out, name_of);
            out.push_str("\n\n");
        }
        out
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text_naming(&|_| None))
    }
}

/// A report's counts: findings by severity, and rules checked and not.
///
/// A rule is checked when the checks decided it for every element they
/// reached, and not checked when a not-checked information names it (it
/// was skipped somewhere for want of something the checker was not told).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct ReportSummary {
    pub findings: usize,
    pub errors: usize,
    pub warnings: usize,
    pub info: usize,
    pub rules_checked: usize,
    pub rules_not_checked: usize,
}

impl ReportSummary {
    /// The counts over `reports` together: each finding counted once, and
    /// each rule once however many reports checked it (a rule one report
    /// could not check is not checked).
    pub fn of<'a>(reports: impl IntoIterator<Item = &'a Report>) -> Self {
        let mut summary = ReportSummary::default();
        let mut checked = RuleSet::new();
        let mut not_checked = RuleSet::new();
        for report in reports {
            checked.union(&report.checked);
            for finding in &report.findings {
                summary.findings += 1;
                match finding.severity {
                    Severity::Error => summary.errors += 1,
                    Severity::Warning => summary.warnings += 1,
                    Severity::Info => summary.info += 1,
                }
                for rule in &finding.not_checked {
                    not_checked.insert(*rule);
                }
            }
        }
        checked.remove_all(&not_checked);
        summary.rules_checked = checked.len();
        summary.rules_not_checked = not_checked.len();
        summary
    }
}

/// `count` and the noun in its number: `1 rule`, `2 rules`.
pub(crate) fn plural(count: usize, one: &str, many: &str) -> String {
    format!("{count} {}", if count == 1 { one } else { many })
}

impl fmt::Display for ReportSummary {
    /// `2 findings (1 error, 0 warnings, 1 info); 14 rules checked, 3 not checked`
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} ({}, {}, {} info); {} checked, {} not checked",
            plural(self.findings, "finding", "findings"),
            plural(self.errors, "error", "errors"),
            plural(self.warnings, "warning", "warnings"),
            self.info,
            plural(self.rules_checked, "rule", "rules"),
            self.rules_not_checked,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ommcheck_vuids::vuid;

    #[test]
    fn prepended_findings_come_first_and_keep_the_rules_checked() {
        let finding = |location: &str| {
            Finding::new(
                vuid::vkCmdBuildMicromapsEXT::pInfos_parameter,
                Severity::Error,
                "f",
                location,
                "m",
            )
        };
        let mut report = Report::from(vec![finding("check")]);
        report
            .checked
            .insert(vuid::vkCmdBuildMicromapsEXT::pInfos_07508);
        report.prepend(vec![finding("read 1"), finding("read 2")]);
        let order: Vec<&str> = report
            .findings
            .iter()
            .map(|f| f.location.as_str())
            .collect();
        assert_eq!(order, ["read 1", "read 2", "check"]);
        report.prepend(Vec::new());
        assert_eq!(report.findings.len(), 3);
        assert!(report
            .checked
            .contains(vuid::vkCmdBuildMicromapsEXT::pInfos_07508));
    }

    #[test]
    fn counts_agree_with_their_nouns_at_every_width() {
        assert_eq!(count(1u64, "entry", "entries"), "1 entry");
        assert_eq!(count(0u64, "entry", "entries"), "0 entries");
        assert_eq!(count(2u32, "query", "queries"), "2 queries");
        assert_eq!(count(1usize, "element", "elements"), "1 element");
    }

    #[test]
    fn message_id_matches_xxh32_seed_8() {
        // XXH32 reference value of the empty input with seed 8.
        assert_eq!(message_id(""), xxhash_rust::xxh32::xxh32(b"", 8));
        assert_ne!(message_id("VUID-a"), message_id("VUID-b"));
        let f = Finding::new(
            vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516,
            Severity::Error,
            "vkCmdBuildMicromapsEXT",
            "pInfos[0]",
            "both pUsageCounts and ppUsageCounts are set",
        );
        assert_eq!(
            f.message_id,
            message_id("VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516")
        );
    }

    #[test]
    fn text_follows_the_khronos_layout() {
        let f = Finding::new(
            vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516,
            Severity::Error,
            "vkCmdBuildMicromapsEXT",
            "pInfos[0]",
            "both pUsageCounts and ppUsageCounts are set.",
        );
        let text = f.to_string();
        assert!(text.starts_with(
            "Validation Error: [ VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516 ] | MessageID = 0x"
        ));
        assert!(text.contains("| vkCmdBuildMicromapsEXT(): pInfos[0]: both pUsageCounts and ppUsageCounts are set. The Vulkan spec states: Only one of pUsageCounts"));
        assert!(text.ends_with("#VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516)"));
    }

    #[test]
    fn objects_are_named_where_a_name_is_known() {
        let mut report = Report::new();
        report.push(
            Finding::new(
                vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516,
                Severity::Error,
                "vkCmdBuildMicromapsEXT",
                "pInfos[0]",
                "both set",
            )
            .with_object("VkBuffer", 0xb00001)
            .with_object("VkMicromapEXT", 0x330001),
        );
        let named = report.text_naming(&|o| (o.handle == 0xb00001).then(|| "omm-input".into()));
        assert!(
            named.contains("\n    Objects[0]: VkBuffer 'omm-input' (0xb00001)\n"),
            "{named}"
        );
        assert!(
            named.contains("\n    Objects[1]: VkMicromapEXT 0x330001\n"),
            "{named}"
        );
        assert!(report
            .to_string()
            .contains("Objects[0]: VkBuffer 0xb00001\n"));
    }
}
