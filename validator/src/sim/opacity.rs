//! Opacity states, special indices, and the decision traversal makes for a
//! candidate hit on a triangle with an opacity micromap.

use std::collections::BTreeSet;

use crate::model::values::{OPACITY_MICROMAP_FORMAT_2_STATE, OPACITY_MICROMAP_FORMAT_4_STATE};

/// A micro-triangle's opacity state (4-state values; 2-state data holds 0 or 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum OpacityState {
    Transparent = 0,
    Opaque = 1,
    UnknownTransparent = 2,
    UnknownOpaque = 3,
}

impl OpacityState {
    fn from_bits(bits: u8) -> Self {
        match bits & 3 {
            0 => Self::Transparent,
            1 => Self::Opaque,
            2 => Self::UnknownTransparent,
            _ => Self::UnknownOpaque,
        }
    }
}

/// Bits per state of an opacity format, if it is one.
pub fn bits_per_state(format: u32) -> Option<u32> {
    match format {
        OPACITY_MICROMAP_FORMAT_2_STATE => Some(1),
        OPACITY_MICROMAP_FORMAT_4_STATE => Some(2),
        _ => None,
    }
}

/// The state of micro-triangle `k` in one triangle's data (starting at its
/// `dataOffset`): states are packed from the least significant bit of each
/// byte. `None` when the format is unknown or the data is too short.
pub fn state_at(triangle_data: &[u8], format: u32, k: u32) -> Option<OpacityState> {
    let bits = bits_per_state(format)?;
    let bit = u64::from(k) * u64::from(bits);
    let byte = *triangle_data.get(usize::try_from(bit / 8).ok()?)?;
    let value = (byte >> (bit % 8)) & ((1 << bits) - 1);
    Some(OpacityState::from_bits(value))
}

/// `VkOpacityMicromapSpecialIndexKHR` values -1..-4 and the cluster-only -5.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum SpecialIndex {
    FullyTransparent,
    FullyOpaque,
    FullyUnknownTransparent,
    FullyUnknownOpaque,
    /// -5: no micromap for this triangle; valid only in cluster geometry.
    ClusterGeometryDisableOpacityMicromap,
}

impl SpecialIndex {
    /// The state a special index stands for (-1..-4 are `!index`), or None for -5.
    pub fn state(self) -> Option<OpacityState> {
        match self {
            Self::FullyTransparent => Some(OpacityState::Transparent),
            Self::FullyOpaque => Some(OpacityState::Opaque),
            Self::FullyUnknownTransparent => Some(OpacityState::UnknownTransparent),
            Self::FullyUnknownOpaque => Some(OpacityState::UnknownOpaque),
            Self::ClusterGeometryDisableOpacityMicromap => None,
        }
    }

    pub fn value(self) -> i64 {
        match self {
            Self::FullyTransparent => -1,
            Self::FullyOpaque => -2,
            Self::FullyUnknownTransparent => -3,
            Self::FullyUnknownOpaque => -4,
            Self::ClusterGeometryDisableOpacityMicromap => -5,
        }
    }
}

/// Where a geometry triangle's opacity comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum Slot {
    /// Micromap triangle `m` (the index read plus baseTriangle, in 64 bits).
    Micromap(u64),
    Special(SpecialIndex),
}

/// Interprets an index value read at `width_bits` (8, 16 or 32): it is
/// special when it is the unsigned cast of -1..-5 at that width, else
/// baseTriangle is added (in 64 bits, so it cannot wrap).
pub fn slot(raw: u64, width_bits: u32, base_triangle: u32) -> Slot {
    let width = width_bits.clamp(1, 64);
    let mask = if width == 64 {
        u64::MAX
    } else {
        (1u64 << width) - 1
    };
    let value = raw & mask;
    let distance_below_top = mask - value; // 0 for the cast of -1
    let special = match distance_below_top {
        0 => Some(SpecialIndex::FullyTransparent),
        1 => Some(SpecialIndex::FullyOpaque),
        2 => Some(SpecialIndex::FullyUnknownTransparent),
        3 => Some(SpecialIndex::FullyUnknownOpaque),
        4 => Some(SpecialIndex::ClusterGeometryDisableOpacityMicromap),
        _ => None,
    };
    match special {
        Some(s) => Slot::Special(s),
        None => Slot::Micromap(value + u64::from(base_triangle)),
    }
}

/// What the opacity tables make of a state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Opacity {
    /// The candidate is dropped; no later flag revives it.
    Ignored,
    Opaque,
    NonOpaque,
}

/// The specification's tables: normal, and with the 2-state override.
pub fn opacity(state: OpacityState, two_state_override: bool) -> Opacity {
    match (state, two_state_override) {
        (OpacityState::Transparent, _) => Opacity::Ignored,
        (OpacityState::Opaque, _) => Opacity::Opaque,
        (OpacityState::UnknownTransparent, false) | (OpacityState::UnknownOpaque, false) => {
            Opacity::NonOpaque
        }
        (OpacityState::UnknownTransparent, true) => Opacity::Ignored,
        (OpacityState::UnknownOpaque, true) => Opacity::Opaque,
    }
}

/// `VkGeometryInstanceFlagBitsKHR` traversal reads.
pub mod instance_flags {
    pub const FORCE_OPAQUE: u32 = 0x4;
    pub const FORCE_NO_OPAQUE: u32 = 0x8;
    pub const FORCE_OPACITY_MICROMAP_2_STATE: u32 = 0x10;
    pub const DISABLE_OPACITY_MICROMAPS: u32 = 0x20;
}

/// SPIR-V `RayFlags` traversal reads.
pub mod ray_flags {
    pub const OPAQUE: u32 = 0x1;
    pub const NO_OPAQUE: u32 = 0x2;
    pub const CULL_OPAQUE: u32 = 0x40;
    pub const CULL_NO_OPAQUE: u32 = 0x80;
    pub const FORCE_OPACITY_MICROMAP_2_STATE: u32 = 0x400;
}

/// What happens to a candidate hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize)]
pub enum HitOutcome {
    /// Dropped: transparent, or culled by a ray flag.
    Ignored,
    /// Committed as an opaque hit.
    Opaque,
    /// Handed to the any-hit shader (ray query: a non-opaque candidate).
    NonOpaque,
}

/// Everything besides the micromap that decides a candidate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Candidate {
    /// The geometry has an opacity micromap attachment.
    pub has_micromap: bool,
    /// `VK_GEOMETRY_OPAQUE_BIT_KHR` on the geometry.
    pub geometry_opaque: bool,
    pub instance_flags: u32,
    pub ray_flags: u32,
    /// The trace consumes opacity micromaps (pipeline flag, or ray query with
    /// them enabled); when false the micromap is not consulted.
    pub micromaps_enabled: bool,
    /// The micromap was built with `VK_BUILD_ACCELERATION_STRUCTURE_MICROMAP_LOSSY_BIT_KHR`.
    pub lossy: bool,
}

/// The possible outcomes of a candidate hit whose micromap states may be
/// any of `states` (several when the hit is ambiguous), or whose slot is a
/// cluster-skip (`states` empty and `cluster_skip`).
pub fn decide(
    candidate: &Candidate,
    states: &BTreeSet<OpacityState>,
    cluster_skip: bool,
) -> BTreeSet<HitOutcome> {
    let omm_active = candidate.has_micromap
        && candidate.micromaps_enabled
        && candidate.instance_flags & instance_flags::DISABLE_OPACITY_MICROMAPS == 0
        && !cluster_skip
        && !states.is_empty();
    let mut opacities = BTreeSet::new();
    if omm_active {
        let two_state = candidate.instance_flags & instance_flags::FORCE_OPACITY_MICROMAP_2_STATE
            != 0
            || candidate.ray_flags & ray_flags::FORCE_OPACITY_MICROMAP_2_STATE != 0;
        let mut possible = states.clone();
        if candidate.lossy {
            // A lossy build may turn any state into an unknown one.
            possible.insert(OpacityState::UnknownTransparent);
            possible.insert(OpacityState::UnknownOpaque);
        }
        opacities.extend(possible.iter().map(|s| opacity(*s, two_state)));
    } else if candidate.geometry_opaque {
        opacities.insert(Opacity::Opaque);
    } else {
        opacities.insert(Opacity::NonOpaque);
    }
    opacities
        .into_iter()
        .map(|o| match o {
            Opacity::Ignored => HitOutcome::Ignored,
            Opacity::Opaque => apply_flags(candidate, true),
            Opacity::NonOpaque => apply_flags(candidate, false),
        })
        .collect()
}

/// Instance then ray flags on a candidate the micromap did not drop.
fn apply_flags(candidate: &Candidate, mut opaque: bool) -> HitOutcome {
    let (instance, ray) = (candidate.instance_flags, candidate.ray_flags);
    if instance & instance_flags::FORCE_OPAQUE != 0 {
        opaque = true;
    }
    if instance & instance_flags::FORCE_NO_OPAQUE != 0 {
        opaque = false;
    }
    if ray & ray_flags::OPAQUE != 0 {
        opaque = true;
    }
    if ray & ray_flags::NO_OPAQUE != 0 {
        opaque = false;
    }
    let culled = (ray & ray_flags::CULL_OPAQUE != 0 && opaque)
        || (ray & ray_flags::CULL_NO_OPAQUE != 0 && !opaque);
    match (culled, opaque) {
        (true, _) => HitOutcome::Ignored,
        (false, true) => HitOutcome::Opaque,
        (false, false) => HitOutcome::NonOpaque,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn states_are_packed_lsb_first() {
        // 2-state L3 bytes from a baker: states 0-31 opaque, 32-47 transparent, 48-63 opaque.
        let data = [0xff, 0xff, 0xff, 0xff, 0x00, 0x00, 0xff, 0xff];
        assert_eq!(state_at(&data, 1, 0), Some(OpacityState::Opaque));
        assert_eq!(state_at(&data, 1, 40), Some(OpacityState::Transparent));
        assert_eq!(state_at(&data, 1, 63), Some(OpacityState::Opaque));
        assert_eq!(state_at(&data, 1, 64), None);
        // 4-state: 0x55 is four opaque states; 0b11_10_01_00 is T, O, UT, UO.
        assert_eq!(state_at(&[0x55], 2, 3), Some(OpacityState::Opaque));
        let mixed = [0b1110_0100];
        let decoded: Vec<_> = (0..4).map(|k| state_at(&mixed, 2, k).unwrap()).collect();
        assert_eq!(
            decoded,
            [
                OpacityState::Transparent,
                OpacityState::Opaque,
                OpacityState::UnknownTransparent,
                OpacityState::UnknownOpaque
            ]
        );
        assert_eq!(state_at(&mixed, 3, 0), None);
        assert_eq!(state_at(&mixed, 2, u32::MAX), None);
    }

    #[test]
    fn special_indices_at_each_width() {
        assert_eq!(
            slot(0xFFFF, 16, 7),
            Slot::Special(SpecialIndex::FullyTransparent)
        );
        assert_eq!(
            slot(0xFFFC, 16, 7),
            Slot::Special(SpecialIndex::FullyUnknownOpaque)
        );
        assert_eq!(
            slot(0xFFFB, 16, 0),
            Slot::Special(SpecialIndex::ClusterGeometryDisableOpacityMicromap)
        );
        assert_eq!(slot(0xFFFA, 16, 1), Slot::Micromap(0xFFFB));
        assert_eq!(slot(0xFE, 8, 0), Slot::Special(SpecialIndex::FullyOpaque));
        assert_eq!(
            slot(0xFFFF_FFFD, 32, 0),
            Slot::Special(SpecialIndex::FullyUnknownTransparent)
        );
        // baseTriangle is added in 64 bits: no wraparound.
        assert_eq!(slot(0xFFFF_FFF0, 32, 0x20), Slot::Micromap(0x1_0000_0010));
        for s in [
            SpecialIndex::FullyTransparent,
            SpecialIndex::FullyOpaque,
            SpecialIndex::FullyUnknownTransparent,
            SpecialIndex::FullyUnknownOpaque,
        ] {
            assert_eq!(s.state().map(|st| st as i64), Some(!s.value()));
        }
    }

    fn states(list: &[OpacityState]) -> BTreeSet<OpacityState> {
        list.iter().copied().collect()
    }

    fn omm() -> Candidate {
        Candidate {
            has_micromap: true,
            micromaps_enabled: true,
            ..Default::default()
        }
    }

    #[test]
    fn tables_and_overrides() {
        use OpacityState::*;
        let one = |c: &Candidate, s| decide(c, &states(&[s]), false);
        assert_eq!(
            one(&omm(), UnknownTransparent),
            BTreeSet::from([HitOutcome::NonOpaque])
        );
        let forced = Candidate {
            instance_flags: instance_flags::FORCE_OPACITY_MICROMAP_2_STATE,
            ..omm()
        };
        assert_eq!(
            one(&forced, UnknownTransparent),
            BTreeSet::from([HitOutcome::Ignored])
        );
        assert_eq!(
            one(&forced, UnknownOpaque),
            BTreeSet::from([HitOutcome::Opaque])
        );
        // Transparent stays ignored whatever the flags say.
        let force_opaque = Candidate {
            instance_flags: instance_flags::FORCE_OPAQUE,
            ray_flags: ray_flags::OPAQUE,
            ..omm()
        };
        assert_eq!(
            one(&force_opaque, Transparent),
            BTreeSet::from([HitOutcome::Ignored])
        );
        // Ray flags win over instance flags.
        let ray_no_opaque = Candidate {
            instance_flags: instance_flags::FORCE_OPAQUE,
            ray_flags: ray_flags::NO_OPAQUE,
            ..omm()
        };
        assert_eq!(
            one(&ray_no_opaque, Opaque),
            BTreeSet::from([HitOutcome::NonOpaque])
        );
        // Disabled micromaps fall back to the geometry's opaque bit.
        let disabled = Candidate {
            instance_flags: instance_flags::DISABLE_OPACITY_MICROMAPS
                | instance_flags::FORCE_OPACITY_MICROMAP_2_STATE,
            geometry_opaque: true,
            ..omm()
        };
        assert_eq!(
            one(&disabled, Transparent),
            BTreeSet::from([HitOutcome::Opaque])
        );
        // Culling.
        let cull = Candidate {
            ray_flags: ray_flags::CULL_OPAQUE,
            ..omm()
        };
        assert_eq!(one(&cull, Opaque), BTreeSet::from([HitOutcome::Ignored]));
        // -5 uses the geometry bit.
        assert_eq!(
            decide(&omm(), &BTreeSet::new(), true),
            BTreeSet::from([HitOutcome::NonOpaque])
        );
    }

    #[test]
    fn lossy_builds_give_sets() {
        let lossy = Candidate {
            lossy: true,
            ..omm()
        };
        assert_eq!(
            decide(&lossy, &states(&[OpacityState::Opaque]), false),
            BTreeSet::from([HitOutcome::Opaque, HitOutcome::NonOpaque])
        );
        let lossy_forced = Candidate {
            ray_flags: ray_flags::FORCE_OPACITY_MICROMAP_2_STATE,
            ..lossy
        };
        let outcomes = decide(&lossy_forced, &states(&[OpacityState::Opaque]), false);
        assert!(!outcomes.contains(&HitOutcome::NonOpaque));
        assert_eq!(
            outcomes,
            BTreeSet::from([HitOutcome::Ignored, HitOutcome::Opaque])
        );
    }

    /// The ray flags the simulator reads have the values it tests for.
    #[test]
    fn ray_flag_names_agree_with_the_simulator() {
        use crate::model::names::{lookup, RayFlags, Value};
        for (name, value) in [
            ("OpaqueKHR", ray_flags::OPAQUE),
            ("NoOpaqueKHR", ray_flags::NO_OPAQUE),
            ("CullOpaqueKHR", ray_flags::CULL_OPAQUE),
            ("CullNoOpaqueKHR", ray_flags::CULL_NO_OPAQUE),
            (
                "ForceOpacityMicromap2StateEXT",
                ray_flags::FORCE_OPACITY_MICROMAP_2_STATE,
            ),
        ] {
            assert_eq!(lookup::<RayFlags>(name), Some(i64::from(value)), "{name}");
        }
        let from_json = |text| serde_json::from_str::<Value<RayFlags>>(text).map(Value::raw);
        assert_eq!(
            from_json("[\"OpaqueKHR\", \"CullNoOpaqueKHR\"]").ok(),
            Some(0x81)
        );
        assert!(from_json("\"gl_RayFlagsOpaqueEXT\"").is_err());
    }
}
