//! Rules the checker could not decide because it was not told something,
//! and the sets of rules a report checked.
//!
//! A check that needs what the checker does not know (bytes of memory it
//! was not given, the extent of host memory, the build of a micromap it did
//! not see, the buffer behind a device address) does not pass in silence:
//! it reports one information finding per cause, with one of the ids of
//! [`Cause`]. The finding lists the rules skipped
//! ([`Finding::not_checked`](crate::Finding::not_checked)), names the object
//! and the parameter, and says what would let the rules run. A report with
//! none of them was checked in full:
//! [`Report::require_fully_checked`](crate::Report::require_fully_checked).
//!
//! Rules a lower [`Tier`](crate::Tier) leaves out are not among them: the
//! tier is the caller's choice, and it is the same for every call.

use std::fmt;

use ommcheck_vuids::Vuid;

use super::{Finding, RuleId};
use crate::rules::{self, OwnRule};

/// Why rules were not checked; each cause has its own information id.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Cause {
    /// Host memory a host command reads was not described, or not where the
    /// command points: its extent is unknown.
    HostMemory,
    /// The bytes of device memory a command reads were not given.
    Contents,
    /// No buffer whose device address the checker knows holds an address a
    /// command reads through (no buffer was given device addresses, or the
    /// buffer holding it was not bound and queried).
    UnknownAddress,
    /// The build of a micromap (or acceleration structure) a command uses
    /// was not seen, so what it holds is unknown.
    BuildNotSeen,
    /// No serialization the checker saw wrote the serialized bytes a command
    /// reads (or the micromaps of the structure serialized are unknown), so
    /// what they were serialized from is unknown.
    SerializationNotSeen,
}

impl Cause {
    pub const ALL: [Cause; 5] = [
        Cause::HostMemory,
        Cause::Contents,
        Cause::UnknownAddress,
        Cause::BuildNotSeen,
        Cause::SerializationNotSeen,
    ];

    /// The rule id of the information finding.
    pub fn rule(self) -> &'static OwnRule {
        match self {
            Cause::HostMemory => &rules::NOT_CHECKED_HOST_MEMORY,
            Cause::Contents => &rules::NOT_CHECKED_CONTENTS,
            Cause::UnknownAddress => &rules::NOT_CHECKED_UNKNOWN_ADDRESS,
            Cause::BuildNotSeen => &rules::NOT_CHECKED_BUILD_NOT_SEEN,
            Cause::SerializationNotSeen => &rules::NOT_CHECKED_SERIALIZATION_NOT_SEEN,
        }
    }

    /// The cause whose information id is `rule`, if it is one.
    pub fn of(rule: RuleId) -> Option<Cause> {
        Cause::ALL
            .into_iter()
            .find(|cause| RuleId::from(cause.rule()) == rule)
    }

    /// What lets the skipped rules run, in the static checker, in a scene
    /// and in the layer.
    pub fn remedy(self) -> &'static str {
        match self {
            Cause::HostMemory => "describe the host memory the call reads (Validator::describe_host_memory with the bytes; in a scene, a hostMemory block with contents); the layer reads host memory only inside mapped host-visible memory",
            Cause::Contents => "give the bytes of the buffer holding it (Validator::set_buffer_contents or Buffer::contents; in a scene, the buffer's contents); the layer reads them at submission from mapped host-visible memory, or copies them back from the GPU (setting gpu_readback)",
            Cause::UnknownAddress => "track the buffer with its device address (Buffer::device_address, or Validator::create_buffer with the address vkGetBufferDeviceAddress returned; a scene assigns one to every buffer); the layer learns it from vkGetBufferDeviceAddress",
            Cause::BuildNotSeen => "check the build of that object before this call (Validator::cmd_build_micromaps, build_micromaps or cmd_build_acceleration_structures; in a scene, a build call earlier in calls); the layer sees the builds recorded while it is active",
            Cause::SerializationNotSeen => "serialize the data through the checker before deserializing it (Validator::cmd_copy_micromap_to_memory, copy_micromap_to_memory or the acceleration-structure to-memory calls, at the address the deserialization reads; Validator::serialized_bytes links bytes an adaptor read back to them; in a scene, the serialization call earlier in calls); data serialized by another run or process is not followed",
        }
    }
}

/// Own rules are indexed after the catalog's VUIDs, in the order of
/// [`rules::ALL`] (the not-checked ids of [`Cause`] are no rules a call is
/// checked against and have no bit); 768 bits hold the 574 VUIDs of the
/// catalog and them (a test holds the catalog to it). No more than that:
/// every checked call returns a [`crate::Report`] holding one set, and at
/// 96 bytes the set keeps the report within the 128 bytes the compiler
/// moves inline rather than through a `memcpy` call (each call moved its
/// report about five times through such calls when the set had 1024 bits).
const WORDS: usize = 12;

/// A set of rules, as a bit per rule: inserting costs a few instructions,
/// so checks can mark every rule they decide, even per element.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct RuleSet {
    bits: [u64; WORDS],
}

impl Default for RuleSet {
    fn default() -> Self {
        Self { bits: [0; WORDS] }
    }
}

impl RuleSet {
    pub fn new() -> Self {
        Self::default()
    }

    fn bit(rule: RuleId) -> Option<usize> {
        let bit = match rule {
            RuleId::Vuid(v) => v.index(),
            RuleId::Own(own) => {
                Vuid::all().len() + rules::ALL.iter().position(|r| std::ptr::eq(*r, own))?
            }
        };
        (bit < WORDS * 64).then_some(bit)
    }

    fn rule_at(bit: usize) -> Option<RuleId> {
        let vuids = Vuid::all().len();
        if bit < vuids {
            Vuid::all().nth(bit).map(RuleId::Vuid)
        } else {
            rules::ALL.get(bit - vuids).map(|own| RuleId::Own(own))
        }
    }

    pub fn insert(&mut self, rule: impl Into<RuleId>) {
        if let Some(bit) = Self::bit(rule.into()) {
            self.bits[bit / 64] |= 1 << (bit % 64);
        }
    }

    pub fn contains(&self, rule: impl Into<RuleId>) -> bool {
        Self::bit(rule.into()).is_some_and(|bit| self.bits[bit / 64] & (1 << (bit % 64)) != 0)
    }

    /// Adds every rule of `other`.
    pub fn union(&mut self, other: &RuleSet) {
        for (word, other) in self.bits.iter_mut().zip(other.bits) {
            *word |= other;
        }
    }

    /// Removes every rule of `other`.
    pub fn remove_all(&mut self, other: &RuleSet) {
        for (word, other) in self.bits.iter_mut().zip(other.bits) {
            *word &= !other;
        }
    }

    pub fn len(&self) -> usize {
        self.bits
            .iter()
            .map(|word| word.count_ones() as usize)
            .sum()
    }

    pub fn is_empty(&self) -> bool {
        self.bits.iter().all(|word| *word == 0)
    }

    /// The rules, VUIDs in catalog order, then own rules.
    pub fn iter(&self) -> impl Iterator<Item = RuleId> + '_ {
        (0..WORDS * 64)
            .filter(|bit| self.bits[bit / 64] & (1 << (bit % 64)) != 0)
            .filter_map(Self::rule_at)
    }
}

impl fmt::Debug for RuleSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set().entries(self.iter()).finish()
    }
}

impl<R: Into<RuleId>> FromIterator<R> for RuleSet {
    fn from_iter<I: IntoIterator<Item = R>>(iter: I) -> Self {
        let mut set = RuleSet::new();
        for rule in iter {
            set.insert(rule);
        }
        set
    }
}

/// What a report did not check: its not-checked information findings
/// (the error of [`Report::require_fully_checked`](crate::Report::require_fully_checked)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotChecked {
    pub findings: Vec<Finding>,
}

impl fmt::Display for NotChecked {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let rules: RuleSet = self
            .findings
            .iter()
            .flat_map(|finding| finding.not_checked.iter().copied())
            .collect();
        writeln!(
            f,
            "the report was not checked in full: {} not checked, for {}:",
            super::plural(rules.len(), "rule was", "rules were"),
            super::plural(self.findings.len(), "cause", "causes")
        )?;
        for finding in &self.findings {
            write!(f, "- [ {} ] {}()", finding.rule, finding.function)?;
            if !finding.location.is_empty() {
                write!(f, " {}", finding.location)?;
            }
            writeln!(f, ": {}", finding.message)?;
        }
        Ok(())
    }
}

impl std::error::Error for NotChecked {}

#[cfg(test)]
mod tests {
    use super::*;
    use ommcheck_vuids::vuid;

    #[test]
    fn every_rule_has_a_bit() {
        assert!(Vuid::all().len() + rules::ALL.len() <= WORDS * 64);
        let all: RuleSet = Vuid::all()
            .map(RuleId::from)
            .chain(rules::ALL.iter().map(|own| RuleId::from(*own)))
            .collect();
        assert_eq!(all.len(), Vuid::all().len() + rules::ALL.len());
        let back: Vec<RuleId> = all.iter().collect();
        assert_eq!(back.len(), all.len());
        assert_eq!(back[0], RuleId::from(Vuid::all().next().unwrap()));
    }

    #[test]
    fn sets_insert_union_and_remove() {
        let mut set = RuleSet::new();
        assert!(set.is_empty());
        set.insert(vuid::vkCmdBuildMicromapsEXT::pInfos_07515);
        set.insert(&rules::TRIANGLE_DATA_RANGE);
        set.insert(&rules::TRIANGLE_DATA_RANGE);
        assert_eq!(set.len(), 2);
        assert!(set.contains(&rules::TRIANGLE_DATA_RANGE));
        assert!(!set.contains(&rules::HISTOGRAM_MISMATCH));
        let other: RuleSet = [RuleId::from(&rules::HISTOGRAM_MISMATCH)]
            .into_iter()
            .collect();
        set.union(&other);
        assert_eq!(set.len(), 3);
        set.remove_all(&other);
        assert_eq!(set.len(), 2);
        assert_eq!(
            set.iter().map(RuleId::as_str).collect::<Vec<_>>(),
            [
                "VUID-vkCmdBuildMicromapsEXT-pInfos-07515",
                "OMMCHECK-build-triangle-data-in-range"
            ]
        );
    }

    #[test]
    fn each_cause_has_its_own_id() {
        for cause in Cause::ALL {
            assert_eq!(Cause::of(RuleId::from(cause.rule())), Some(cause));
            assert!(cause.rule().id.starts_with("OMMCHECK-not-checked-"));
        }
        assert_eq!(Cause::of(RuleId::from(&rules::TRIANGLE_DATA_RANGE)), None);
    }
}
