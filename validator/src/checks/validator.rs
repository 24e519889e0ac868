//! The stateful checker: a device, tracked objects, and one method per API
//! call (defined next to their checks in `checks/`).

use super::index_scan::IndexMix;
use crate::device::Device;
use crate::model::Handle;
use crate::report::not_checked::Cause;
use crate::report::{Finding, ObjectRef, Report, RuleId, Severity};
use crate::state::{HostMemory, HostRange, State};
use crate::tier::Tier;

/// Checks calls against a device and the objects earlier calls created.
///
/// Each `vk*` method checks one call, returns its findings, and records what
/// the call did (a created object, a build) so later calls are checked
/// against it.
#[derive(Clone, Debug, Default)]
pub struct Validator {
    pub(crate) device: Device,
    pub(crate) state: State,
    pub(crate) tier: Tier,
    /// Device builds are being recorded by an adaptor that reads their
    /// device memory later, at submission, and reports what it cannot read
    /// itself: contents missing now are not reported as not checked.
    pub(crate) device_contents_later: bool,
    /// The micromap build infos the last build call read and no one kept,
    /// refilled by the next one: a call reads into these vectors instead of
    /// allocating its own (see [`crate::model::micromap::SpareInfos`]).
    pub(crate) spare_micromap_infos: crate::model::micromap::SpareInfos,
    /// Names the program gave objects ([`Validator::name_object`]).
    pub(crate) names: crate::report::names::ObjectNames,
}

impl Validator {
    pub fn new(device: Device) -> Self {
        Self {
            device,
            state: State::default(),
            tier: Tier::default(),
            device_contents_later: false,
            spare_micromap_infos: Default::default(),
            names: Default::default(),
        }
    }

    /// Names the object `handle` `name` in findings from now on, as
    /// `vkSetDebugUtilsObjectNameEXT` names it for the Khronos layer: the
    /// text shows `VkMicromapEXT 'disc' (0x1000)` and the JSON
    /// `"name": "disc"`. An empty name removes the name.
    pub fn name_object(&mut self, handle: impl ash::vk::Handle, name: impl Into<String>) {
        self.names.set(handle.as_raw(), name);
    }

    /// [`Self::name_object`] for a handle as a number.
    pub fn name_raw_object(&mut self, handle: Handle, name: impl Into<String>) {
        self.names.set(handle, name);
    }

    /// Checks from now on look as far as `tier` (default: content).
    /// Objects are tracked whatever the tier, so raising it later checks
    /// later calls in full.
    pub fn set_tier(&mut self, tier: Tier) {
        self.tier = tier;
    }

    pub fn tier(&self) -> Tier {
        self.tier
    }

    pub fn device(&self) -> &Device {
        &self.device
    }

    pub fn state(&self) -> &State {
        &self.state
    }

    /// Direct access to tracked objects, for tests and adaptors that learn of
    /// objects by other means.
    pub fn state_mut(&mut self) -> &mut State {
        &mut self.state
    }

    /// `vkCreateDeferredOperationKHR` returned `operation`.
    pub fn create_deferred_operation(&mut self, operation: Handle) {
        self.state.deferred_operations.insert(operation);
    }

    /// `vkDestroyDeferredOperationKHR(operation)`.
    pub fn destroy_deferred_operation(&mut self, operation: Handle) {
        self.state.deferred_operations.remove(&operation);
        self.state.pending_deferred_operations.remove(&operation);
    }

    /// `vkDeferredOperationJoinKHR` returned `VK_SUCCESS`, or
    /// `vkGetDeferredOperationResultKHR` returned anything but
    /// `VK_NOT_READY`: the operation's command has completed.
    pub fn deferred_operation_completed(&mut self, operation: Handle) {
        self.state.pending_deferred_operations.remove(&operation);
        self.state.execution.operation_completed(operation);
    }

    /// A host command was given `operation`; it runs until reported complete.
    pub(crate) fn defer(&mut self, operation: Handle) {
        if operation != 0 && self.state.deferred_operations.contains(&operation) {
            self.state.pending_deferred_operations.insert(operation);
        }
    }

    pub(crate) fn ctx(&self, function: &'static str) -> Ctx<'_> {
        self.ctx_reading(function, &[])
    }

    /// The context of a call for which an adaptor read `read_for_call` of
    /// host memory (see [`crate::state::HostMemory`]).
    pub(crate) fn ctx_reading<'a>(
        &'a self,
        function: &'static str,
        read_for_call: &'a [HostRange],
    ) -> Ctx<'a> {
        Ctx {
            device: &self.device,
            state: (self.tier >= Tier::State).then_some(&self.state),
            host_memory: self.state.host_memory(read_for_call),
            contents: self.tier >= Tier::Content,
            hygiene: self.tier >= Tier::Simulate,
            function,
            report: Report::new(),
            per_rule: Vec::new(),
            unlisted: None,
            device_contents_later: self.device_contents_later,
            index_mixes: Vec::new(),
            names: &self.names,
        }
    }
}

/// At most this many findings of one rule are listed for one call; the last
/// one listed says how many more there were. One call can hold up to 2^20
/// infos, and an application that gets all of them wrong the same way would
/// otherwise make us hold millions of findings (hundreds of bytes each)
/// inside its process.
pub const FINDINGS_PER_RULE_PER_CALL: u32 = 256;

/// What one check runs with: the device, the tracked state (None below the
/// state tier), whether buffer contents may be read, the function being
/// checked, and the findings so far.
pub(crate) struct Ctx<'a> {
    pub device: &'a Device,
    pub state: Option<&'a State>,
    /// The host memory the call may read: what the application described
    /// and what an adaptor read for this call (read through [`Self::host`]).
    host_memory: HostMemory<'a>,
    pub contents: bool,
    /// Whether the hygiene information on micromap data
    /// (`OMMCHECK-hygiene-*`) is wanted: it reads every data block and is no
    /// validity rule, so it runs from the simulate tier up.
    pub hygiene: bool,
    pub function: &'static str,
    pub report: Report,
    /// Findings reported so far per rule in this call (few rules a call, so
    /// a list is as fast as a map), to apply [`FINDINGS_PER_RULE_PER_CALL`].
    per_rule: Vec<(RuleId, u32)>,
    /// Where a finding past the limit is built and dropped: `report` hands
    /// out a `&mut Finding` whether or not the finding is listed.
    unlisted: Option<Finding>,
    /// See [`Validator::device_contents_later`].
    pub device_contents_later: bool,
    /// The opacity index buffers this call's checks read in full, for the
    /// record of the build (which then need not read them again).
    pub index_mixes: Vec<IndexMix>,
    /// The names to give the findings' objects (see [`Validator::name_object`]).
    pub names: &'a crate::report::names::ObjectNames,
}

impl<'a> Ctx<'a> {
    /// The tracked state where the tier reads contents too (content reads
    /// go through this, so a lower tier never decodes a byte).
    pub fn contents(&self) -> Option<&'a State> {
        self.state.filter(|_| self.contents)
    }

    /// The host memory the call may read, from the state tier up (None
    /// below it, like [`Self::state`]).
    pub fn host(&self) -> Option<HostMemory<'a>> {
        self.state.map(|_| self.host_memory)
    }

    /// Reports a finding of `severity`.
    pub fn report(
        &mut self,
        rule: impl Into<RuleId>,
        severity: Severity,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> &mut Finding {
        let finding = Finding::new(rule, severity, self.function, location, message);
        self.report.checked.insert(finding.rule);
        self.push(finding)
    }

    /// Lists `finding` within [`FINDINGS_PER_RULE_PER_CALL`] of its rule.
    fn push(&mut self, finding: Finding) -> &mut Finding {
        if !self.counted(finding.rule) {
            return self.unlisted.insert(finding);
        }
        self.report.findings.push(finding);
        self.report.findings.last_mut().expect("just pushed")
    }

    /// Counts one more finding of `rule` in this call; whether it is listed
    /// (within [`FINDINGS_PER_RULE_PER_CALL`]).
    fn counted(&mut self, rule: RuleId) -> bool {
        let count = match self.per_rule.iter_mut().find(|(r, _)| *r == rule) {
            Some((_, count)) => count,
            None => {
                self.per_rule.push((rule, 0));
                &mut self.per_rule.last_mut().expect("just pushed").1
            }
        };
        *count = count.saturating_add(1);
        *count <= FINDINGS_PER_RULE_PER_CALL
    }

    /// Reports an error.
    pub fn error(
        &mut self,
        rule: impl Into<RuleId>,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> &mut Finding {
        self.report(rule, Severity::Error, location, message)
    }

    /// Reports an error unless `ok`; location and message are built only
    /// for a failure that is listed (past [`FINDINGS_PER_RULE_PER_CALL`] of
    /// its rule it is only counted, which keeps a call with millions of
    /// alike faults from formatting millions of messages).
    pub fn require(
        &mut self,
        ok: bool,
        rule: impl Into<RuleId>,
        location: impl FnOnce() -> String,
        message: impl FnOnce() -> String,
    ) {
        let rule = rule.into();
        self.report.checked.insert(rule);
        if ok {
            return;
        }
        if self.counted(rule) {
            let finding = Finding::new(rule, Severity::Error, self.function, location(), message());
            self.report.findings.push(finding);
        }
    }

    /// Marks `rules` decided (checks that report through [`Self::require`]
    /// or [`Self::report`] are marked by those; this marks rules a check
    /// decided without a finding).
    pub fn checked(&mut self, rules: &[RuleId]) {
        for rule in rules {
            self.report.checked.insert(*rule);
        }
    }

    /// Reports that `rules` were not checked at `location` for `cause`:
    /// `what` says what the checker was not told (the object, the address),
    /// and the finding adds what would let them run. One finding per cause
    /// and place, however many rules it skips.
    pub fn not_checked(
        &mut self,
        cause: Cause,
        rules: &[RuleId],
        location: impl Into<String>,
        object: Option<ObjectRef>,
        what: impl std::fmt::Display,
    ) {
        // Past the per-call limit of the cause's id the finding is only
        // counted: a call with millions of unreadable elements formats no
        // more messages than it lists.
        if rules.is_empty() || !self.counted(cause.rule().into()) {
            return;
        }
        let ids: Vec<&str> = rules.iter().map(|r| r.as_str()).collect();
        let message = format!(
            "{what}; {} not checked: {}. To check {}: {}",
            if rules.len() == 1 {
                "this rule is"
            } else {
                "these rules are"
            },
            ids.join(", "),
            if rules.len() == 1 { "it" } else { "them" },
            cause.remedy()
        );
        // The information is no rule the call was checked against: pushed
        // without marking its id checked.
        let mut finding = Finding::new(
            cause.rule(),
            Severity::Info,
            self.function,
            location,
            message,
        );
        finding.not_checked = rules.to_vec();
        finding.objects.extend(object);
        self.report.findings.push(finding);
    }

    /// The findings, the last listed one of each rule past the limit saying
    /// how many more were found.
    // By reference rather than by value: moving the context (over 200
    // bytes) into the call cost a `memcpy` call per checked call.
    pub fn finish(&mut self) -> Report {
        for (rule, count) in &self.per_rule {
            let unlisted = count.saturating_sub(FINDINGS_PER_RULE_PER_CALL);
            if unlisted == 0 {
                continue;
            }
            if let Some(last) = self
                .report
                .findings
                .iter_mut()
                .rev()
                .find(|f| f.rule == *rule)
            {
                let message = last.message.trim_end_matches('.').len();
                last.message.truncate(message);
                last.message.push_str(&format!(
                    " ({unlisted} more findings of this rule in this call are not listed)."
                ));
            }
        }
        self.names.name_all(&mut self.report);
        std::mem::take(&mut self.report)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ommcheck_vuids::vuid;

    fn ctx_with(validator: &Validator, findings: u32) -> Report {
        let mut ctx = validator.ctx("vkCmdBuildMicromapsEXT");
        for i in 0..findings {
            ctx.error(
                vuid::vkCmdBuildMicromapsEXT::dstMicromap_11649,
                format!("pInfos[{i}]"),
                "collides.",
            )
            .objects
            .push(crate::report::ObjectRef {
                ty: "VkMicromapEXT",
                handle: u64::from(i),
            });
        }
        ctx.error(
            vuid::vkCmdBuildMicromapsEXT::scratchData_11651,
            "pInfos[0]",
            "other rule.",
        );
        ctx.finish()
    }

    #[test]
    fn findings_of_one_rule_are_listed_up_to_the_limit_and_the_rest_counted() {
        let validator = Validator::new(Device::default());
        let over = ctx_with(&validator, FINDINGS_PER_RULE_PER_CALL + 1000);
        let listed: Vec<_> = over
            .with_rule(vuid::vkCmdBuildMicromapsEXT::dstMicromap_11649)
            .collect();
        assert_eq!(listed.len(), FINDINGS_PER_RULE_PER_CALL as usize);
        let last = listed.last().unwrap();
        assert_eq!(
            last.location,
            format!("pInfos[{}]", FINDINGS_PER_RULE_PER_CALL - 1)
        );
        assert_eq!(
            last.message,
            "collides (1000 more findings of this rule in this call are not listed)."
        );
        // Other rules keep their own count.
        assert_eq!(
            over.with_rule(vuid::vkCmdBuildMicromapsEXT::scratchData_11651)
                .count(),
            1
        );

        let at = ctx_with(&validator, FINDINGS_PER_RULE_PER_CALL);
        assert_eq!(at.len(), FINDINGS_PER_RULE_PER_CALL as usize + 1);
        assert!(at
            .findings
            .iter()
            .all(|f| !f.message.contains("not listed")));
    }

    #[test]
    fn not_checked_findings_name_their_rules_and_are_listed_up_to_the_limit() {
        let validator = Validator::new(Device::default());
        let mut ctx = validator.ctx("vkCmdBuildMicromapsEXT");
        let skipped = [RuleId::from(&crate::rules::TRIANGLE_DATA_RANGE)];
        for i in 0..FINDINGS_PER_RULE_PER_CALL + 3 {
            ctx.not_checked(
                Cause::Contents,
                &skipped,
                format!("pInfos[{i}].data"),
                None,
                "the contents were not given",
            );
        }
        // No rules, no finding.
        ctx.not_checked(Cause::HostMemory, &[], "pInfos[0]", None, "unused");
        let report = ctx.finish();
        assert_eq!(report.len(), FINDINGS_PER_RULE_PER_CALL as usize);
        let first = &report.findings[0];
        assert_eq!(first.severity, Severity::Info);
        assert_eq!(first.not_checked, skipped);
        assert!(first.message.starts_with("the contents were not given; this rule is not checked: OMMCHECK-build-triangle-data-in-range. To check it: "));
        assert!(report
            .findings
            .last()
            .unwrap()
            .message
            .contains("(3 more findings"));
        // The information is no rule the call was checked against.
        assert!(report.checked.is_empty());
        assert_eq!(report.summary().rules_not_checked, 1);
    }

    #[test]
    fn require_builds_text_only_for_listed_failures_and_counts_the_rest() {
        let validator = Validator::new(Device::default());
        let mut ctx = validator.ctx("vkCmdBuildMicromapsEXT");
        let mut built = 0u32;
        let failures = FINDINGS_PER_RULE_PER_CALL + 10;
        for i in 0..failures {
            ctx.require(
                false,
                vuid::vkCmdBuildMicromapsEXT::dstMicromap_11649,
                || {
                    built += 1;
                    format!("pInfos[{i}]")
                },
                || "collides.".into(),
            );
            ctx.require(
                true,
                vuid::vkCmdBuildMicromapsEXT::scratchData_11651,
                || unreachable!("a passing check builds no text"),
                || unreachable!("a passing check builds no text"),
            );
        }
        let report = ctx.finish();
        assert_eq!(built, FINDINGS_PER_RULE_PER_CALL);
        assert_eq!(report.len(), FINDINGS_PER_RULE_PER_CALL as usize);
        assert!(report
            .findings
            .last()
            .unwrap()
            .message
            .contains("(10 more findings"));
    }
}
