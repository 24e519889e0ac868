//! The stateful checker: a device, tracked objects, and one method per API
//! call (defined next to their checks in `checks/`).

use crate::device::Device;
use crate::report::{Finding, Report, RuleId, Severity};
use crate::state::{Handle, State};
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
}

impl Validator {
    pub fn new(device: Device) -> Self {
        Self {
            device,
            state: State::default(),
            tier: Tier::default(),
        }
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
    }

    /// A host command was given `operation`; it runs until reported complete.
    pub(crate) fn defer(&mut self, operation: Handle) {
        if operation != 0 && self.state.deferred_operations.contains(&operation) {
            self.state.pending_deferred_operations.insert(operation);
        }
    }

    pub(crate) fn ctx(&self, function: &'static str) -> Ctx<'_> {
        Ctx {
            device: &self.device,
            state: (self.tier >= Tier::State).then_some(&self.state),
            contents: self.tier >= Tier::Content,
            hygiene: self.tier >= Tier::Simulate,
            function,
            report: Report::new(),
        }
    }
}

/// What one check runs with: the device, the tracked state (None below the
/// state tier), whether buffer contents may be read, the function being
/// checked, and the findings so far.
pub(crate) struct Ctx<'a> {
    pub device: &'a Device,
    pub state: Option<&'a State>,
    pub contents: bool,
    /// Whether the hygiene information on micromap data
    /// (`OMMCHECK-hygiene-*`) is wanted: it reads every data block and is no
    /// validity rule, so it runs from the simulate tier up.
    pub hygiene: bool,
    pub function: &'static str,
    pub report: Report,
}

impl<'a> Ctx<'a> {
    /// The tracked state where the tier reads contents too (content reads
    /// go through this, so a lower tier never decodes a byte).
    pub fn contents(&self) -> Option<&'a State> {
        self.state.filter(|_| self.contents)
    }

    /// Reports a finding of `severity`.
    pub fn report(
        &mut self,
        rule: impl Into<RuleId>,
        severity: Severity,
        location: impl Into<String>,
        message: impl Into<String>,
    ) -> &mut Finding {
        self.report.findings.push(Finding::new(
            rule,
            severity,
            self.function,
            location,
            message,
        ));
        self.report.findings.last_mut().expect("just pushed")
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

    /// Reports an error unless `ok`; location and message are built only on failure.
    pub fn require(
        &mut self,
        ok: bool,
        rule: impl Into<RuleId>,
        location: impl FnOnce() -> String,
        message: impl FnOnce() -> String,
    ) {
        if !ok {
            self.error(rule, location(), message());
        }
    }

    pub fn finish(self) -> Report {
        self.report
    }
}
