//! The catalog of micromap-related Valid Usage IDs of Vulkan 1.4.360, and the
//! `VK_KHR_opacity_micromap` declarations that ash 0.38 predates.
//!
//! Everything under `generated/` is written by `cargo xtask generate` from the
//! Vulkan registry (`vk.xml` and `validusage.json`); nothing in it is typed by
//! hand. A check cites a VUID through the typed constants of [`vuid`], so it
//! cannot cite an id that is not in the catalog:
//!
//! ```
//! use ommcheck_vuids::{vuid, Extensions, VuidKind};
//!
//! let v = vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516;
//! assert_eq!(v.id(), "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516");
//! assert_eq!(v.info().kind, VuidKind::Explicit);
//! assert!(v.info().extensions.contains(Extensions::EXT));
//! assert!(v.link().ends_with("#VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516"));
//! ```

mod generated;

use std::fmt;

pub use generated::catalog::vuid;
pub use generated::catalog::{GATING_SOURCE, REGISTRY_VERSION};
pub use generated::khr;

/// The enum value name `name` stands for, where vk.xml gives `name` as an
/// alias (`VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT_KHR` stands for
/// `VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT`); None for a name that is no
/// alias.
pub fn enum_alias_target(name: &str) -> Option<&'static str> {
    alias_target(generated::aliases::ENUM_ALIASES, name)
}

/// The command `name` stands for, where vk.xml gives `name` as an alias
/// (`vkCmdPipelineBarrier2KHR` stands for `vkCmdPipelineBarrier2`); None
/// for a name that is no alias.
pub fn command_alias_target(name: &str) -> Option<&'static str> {
    alias_target(generated::aliases::COMMAND_ALIASES, name)
}

fn alias_target(table: &'static [(&str, &str)], name: &str) -> Option<&'static str> {
    table
        .binary_search_by(|(alias, _)| (*alias).cmp(name))
        .ok()
        .map(|i| table[i].1)
}

/// A Valid Usage ID that is in the catalog. It can only be obtained from the
/// generated constants in [`vuid`] or by looking a string up with
/// [`Vuid::from_id`], so every `Vuid` names a real catalog entry.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Vuid(u16);

impl Vuid {
    /// The entry at `index` of the sorted catalog; only the generated
    /// constants call this, with indices the generator checked.
    pub(crate) const fn at(index: u16) -> Self {
        Self(index)
    }

    /// Looks up a VUID string such as `"VUID-VkMicromapBuildInfoEXT-type-07517"`.
    pub fn from_id(id: &str) -> Option<Self> {
        generated::catalog::CATALOG
            .binary_search_by(|info| info.id.cmp(id))
            .ok()
            .map(|index| Self(index as u16))
    }

    /// Every VUID of the catalog, in the catalog's (byte-wise id) order.
    pub fn all() -> impl ExactSizeIterator<Item = Self> {
        (0..generated::catalog::CATALOG.len()).map(|index| Self(index as u16))
    }

    /// The catalog entry.
    pub fn info(self) -> &'static VuidInfo {
        &generated::catalog::CATALOG[usize::from(self.0)]
    }

    /// The entry's position in the catalog (`0..Vuid::all().len()`), for
    /// sets and tables indexed by VUID.
    pub fn index(self) -> usize {
        usize::from(self.0)
    }

    /// The VUID string.
    pub fn id(self) -> &'static str {
        self.info().id
    }

    /// The link to the statement in the published specification.
    pub fn link(self) -> String {
        self.info().link()
    }
}

impl fmt::Debug for Vuid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

impl fmt::Display for Vuid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.id())
    }
}

impl serde::Serialize for Vuid {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.id())
    }
}

/// Whether a VUID was written by hand in a "Valid Usage" block or generated
/// into a "Valid Usage (Implicit)" block (sType, pNext, handles, pointers,
/// enum values, flag bits, command-buffer state).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum VuidKind {
    Explicit,
    Implicit,
}

/// What kind of thing a VUID belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ParentKind {
    /// A structure such as `VkMicromapBuildInfoEXT`.
    Struct,
    /// A command such as `vkCmdBuildMicromapsEXT`.
    Command,
    /// The SPIR-V environment appendix (`RuntimeSpirv`).
    Spirv,
}

/// A set of the four micromap extensions.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Extensions(u8);

impl Extensions {
    pub const NONE: Self = Self(0);
    /// `VK_EXT_opacity_micromap`
    pub const EXT: Self = Self(1);
    /// `VK_KHR_opacity_micromap`
    pub const KHR: Self = Self(2);
    /// `VK_NV_displacement_micromap`
    pub const NV: Self = Self(4);
    /// `VK_ARM_pipeline_opacity_micromap`
    pub const ARM: Self = Self(8);

    const NAMES: [(Self, &'static str, &'static str); 4] = [
        (Self::EXT, "EXT", "VK_EXT_opacity_micromap"),
        (Self::KHR, "KHR", "VK_KHR_opacity_micromap"),
        (Self::NV, "NV", "VK_NV_displacement_micromap"),
        (Self::ARM, "ARM", "VK_ARM_pipeline_opacity_micromap"),
    ];

    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    pub const fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    pub const fn intersects(self, other: Self) -> bool {
        self.0 & other.0 != 0
    }

    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Short names (`EXT`, `KHR`, `NV`, `ARM`) of the members, in that order.
    pub fn short_names(self) -> impl Iterator<Item = &'static str> {
        Self::NAMES
            .into_iter()
            .filter(move |(bit, _, _)| self.contains(*bit))
            .map(|(_, short, _)| short)
    }

    /// Full extension names of the members, in the order of [`Self::short_names`].
    pub fn extension_names(self) -> impl Iterator<Item = &'static str> {
        Self::NAMES
            .into_iter()
            .filter(move |(bit, _, _)| self.contains(*bit))
            .map(|(_, _, name)| name)
    }
}

impl fmt::Debug for Extensions {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set().entries(self.short_names()).finish()
    }
}

impl serde::Serialize for Extensions {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.extension_names())
    }
}

/// One catalog entry.
#[derive(Debug, serde::Serialize)]
pub struct VuidInfo {
    /// The VUID string, e.g. `VUID-VkMicromapBuildInfoEXT-type-07517`.
    pub id: &'static str,
    /// The structure or command the VUID belongs to (`validusage.json`'s key).
    pub parent: &'static str,
    pub parent_kind: ParentKind,
    pub kind: VuidKind,
    /// The micromap extensions under which the specification states this VUID
    /// (see [`GATING_SOURCE`] for where that came from).
    pub extensions: Extensions,
    /// The statement as plain text.
    pub text: &'static str,
    /// The specification page that holds the statement, e.g. `chapters/accelstructures.html`.
    pub page: &'static str,
    /// Whether the Khronos validation layer checks this VUID, where known.
    pub khronos_layer_checks: Option<bool>,
}

impl VuidInfo {
    /// The link to the statement in the published specification.
    pub fn link(&self) -> String {
        format!(
            "https://docs.vulkan.org/spec/latest/{}#{}",
            self.page, self.id
        )
    }

    /// The trailing number of an explicit VUID (`07517`), if it has one.
    pub fn number(&self) -> Option<u32> {
        self.id
            .rsplit('-')
            .next()
            .and_then(|tail| tail.parse().ok())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catalog_is_sorted_and_unique() {
        let ids: Vec<&str> = Vuid::all().map(Vuid::id).collect();
        assert!(ids.windows(2).all(|pair| pair[0] < pair[1]));
    }

    #[test]
    fn every_id_round_trips_through_lookup() {
        for v in Vuid::all() {
            assert_eq!(Vuid::from_id(v.id()), Some(v));
        }
        assert_eq!(
            Vuid::from_id("VUID-VkMicromapBuildInfoEXT-nonexistent-00000"),
            None
        );
    }

    #[test]
    fn catalog_has_the_574_micromap_vuids_of_1_4_360() {
        assert_eq!(REGISTRY_VERSION, "1.4.360");
        let explicit = Vuid::all()
            .filter(|v| v.info().kind == VuidKind::Explicit)
            .count();
        let implicit = Vuid::all()
            .filter(|v| v.info().kind == VuidKind::Implicit)
            .count();
        assert_eq!((explicit, implicit), (431, 143));
    }

    #[test]
    fn constants_name_their_own_entry() {
        let v = vuid::vkCmdBuildMicromapsEXT::pInfos_07461;
        assert_eq!(v.id(), "VUID-vkCmdBuildMicromapsEXT-pInfos-07461");
        assert_eq!(v.info().parent, "vkCmdBuildMicromapsEXT");
        assert_eq!(v.info().parent_kind, ParentKind::Command);
        assert_eq!(v.info().number(), Some(7461));
        assert_eq!(
            vuid::VkMicromapBuildInfoEXT::sType_sType.info().number(),
            None
        );
    }

    #[test]
    fn link_points_at_the_published_spec() {
        let v = vuid::VkMicromapBuildInfoEXT::sType_sType;
        assert_eq!(
            v.link(),
            format!(
                "https://docs.vulkan.org/spec/latest/{}#VUID-VkMicromapBuildInfoEXT-sType-sType",
                v.info().page
            )
        );
    }

    #[test]
    fn extension_sets() {
        let both = Extensions::EXT.union(Extensions::KHR);
        assert!(both.contains(Extensions::KHR));
        assert!(!both.contains(Extensions::NV));
        assert!(both.intersects(Extensions::EXT.union(Extensions::ARM)));
        assert_eq!(both.short_names().collect::<Vec<_>>(), ["EXT", "KHR"]);
        assert!(Extensions::NONE.is_empty());
    }

    #[test]
    fn serializes_as_strings() {
        let v = vuid::VkMicromapBuildInfoEXT::sType_sType;
        assert_eq!(
            serde_json::to_string(&v).unwrap(),
            "\"VUID-VkMicromapBuildInfoEXT-sType-sType\""
        );
        assert_eq!(
            serde_json::to_string(&Extensions::EXT.union(Extensions::NV)).unwrap(),
            r#"["VK_EXT_opacity_micromap","VK_NV_displacement_micromap"]"#
        );
    }
}
