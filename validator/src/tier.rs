//! Validation tiers: how much of what a call touches the checker looks at.
//! Each tier decides every rule the one below it decides, and more; what a
//! tier cannot see is not guessed at (its checks are skipped, never turned
//! into findings).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// How far the checks look.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Tier {
    /// What the call's parameters and the device (its enabled extensions,
    /// features and limits) decide.
    Params,
    /// And the objects earlier calls created: buffers with their usage,
    /// memory and device addresses, micromaps, acceleration structures,
    /// pipelines, query pools, deferred operations.
    State,
    /// And the bytes the call reads: triangle arrays, usage counts against
    /// them, data offsets, index buffers, instances (the default). Data
    /// blocks are measured against the memory holding them, not read.
    #[default]
    Content,
    /// And the micromap data blocks themselves, for the hygiene information
    /// (`OMMCHECK-hygiene-*`: unused bits, identical blocks stored twice,
    /// partial overlaps, which reads every data byte), and traversal of the
    /// rays or hits a user asks about (`ommcheck trace`,
    /// `Validator::simulate_hit`).
    Simulate,
}

impl Tier {
    pub const ALL: [Tier; 4] = [Tier::Params, Tier::State, Tier::Content, Tier::Simulate];

    /// The tier's name: `params`, `state`, `content` or `simulate`.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Params => "params",
            Tier::State => "state",
            Tier::Content => "content",
            Tier::Simulate => "simulate",
        }
    }
}

impl fmt::Display for Tier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Tier {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        Tier::ALL
            .into_iter()
            .find(|t| t.name().eq_ignore_ascii_case(text.trim()))
            .ok_or_else(|| {
                format!("`{text}` is not a tier: expected params, state, content or simulate")
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiers_are_ordered_and_named() {
        assert!(Tier::Params < Tier::State && Tier::State < Tier::Content);
        assert!(Tier::Content < Tier::Simulate);
        assert_eq!(Tier::default(), Tier::Content);
        for tier in Tier::ALL {
            assert_eq!(tier.name().parse::<Tier>(), Ok(tier));
        }
        assert!("everything".parse::<Tier>().is_err());
    }
}
