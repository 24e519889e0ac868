//! A plain-text summary of the VUID catalog.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use ommcheck_vuids::{Extensions, Vuid, VuidKind, GATING_SOURCE, REGISTRY_VERSION};

/// Counts of explicit and implicit VUIDs, and how many of each the Khronos
/// validation layer checks.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    pub explicit: usize,
    pub implicit: usize,
    pub explicit_khronos: usize,
    pub implicit_khronos: usize,
}

impl Counts {
    fn add(&mut self, v: Vuid) {
        let info = v.info();
        let khronos = info.khronos_layer_checks == Some(true);
        match info.kind {
            VuidKind::Explicit => {
                self.explicit += 1;
                self.explicit_khronos += usize::from(khronos);
            }
            VuidKind::Implicit => {
                self.implicit += 1;
                self.implicit_khronos += usize::from(khronos);
            }
        }
    }
}

/// Catalog totals, per enabling extension, and per parent.
pub struct CatalogSummary {
    pub total: Counts,
    pub by_extension: Vec<(&'static str, Counts)>,
    pub by_parent: BTreeMap<&'static str, Counts>,
}

impl CatalogSummary {
    pub fn new() -> Self {
        let mut total = Counts::default();
        let mut by_parent: BTreeMap<&'static str, Counts> = BTreeMap::new();
        let extensions = [
            ("VK_EXT_opacity_micromap", Extensions::EXT),
            ("VK_KHR_opacity_micromap", Extensions::KHR),
            ("VK_NV_displacement_micromap", Extensions::NV),
            ("VK_ARM_pipeline_opacity_micromap", Extensions::ARM),
        ];
        let mut by_extension: Vec<(&'static str, Counts)> = extensions
            .iter()
            .map(|(name, _)| (*name, Counts::default()))
            .collect();
        for v in Vuid::all() {
            total.add(v);
            by_parent.entry(v.info().parent).or_default().add(v);
            for ((_, bit), (_, counts)) in extensions.iter().zip(by_extension.iter_mut()) {
                if v.info().extensions.contains(*bit) {
                    counts.add(v);
                }
            }
        }
        Self {
            total,
            by_extension,
            by_parent,
        }
    }

    /// The summary as text.
    pub fn render(&self) -> String {
        let mut out = String::new();
        let t = self.total;
        let _ = writeln!(
            out,
            "Micromap VUID catalog of Vulkan {REGISTRY_VERSION}: {} VUIDs ({} explicit, {} implicit)",
            t.explicit + t.implicit,
            t.explicit,
            t.implicit
        );
        let _ = writeln!(
            out,
            "The Khronos validation layer checks {} explicit and {} implicit of them.",
            t.explicit_khronos, t.implicit_khronos
        );
        let _ = writeln!(out, "Extension gating: {GATING_SOURCE}.\n");
        let _ = writeln!(
            out,
            "{:<36} {:>8} {:>8} {:>8}",
            "stated under", "explicit", "implicit", "Khronos"
        );
        for (name, c) in &self.by_extension {
            let _ = writeln!(
                out,
                "{name:<36} {:>8} {:>8} {:>8}",
                c.explicit,
                c.implicit,
                c.explicit_khronos + c.implicit_khronos
            );
        }
        let _ = writeln!(
            out,
            "\n{:<60} {:>8} {:>8} {:>8}",
            "parent", "explicit", "implicit", "Khronos"
        );
        for (parent, c) in &self.by_parent {
            let _ = writeln!(
                out,
                "{parent:<60} {:>8} {:>8} {:>8}",
                c.explicit,
                c.implicit,
                c.explicit_khronos + c.implicit_khronos
            );
        }
        out
    }
}

impl Default for CatalogSummary {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn totals_add_up() {
        let summary = CatalogSummary::new();
        assert_eq!(
            summary.total.explicit + summary.total.implicit,
            Vuid::all().len()
        );
        let by_parent: usize = summary
            .by_parent
            .values()
            .map(|c| c.explicit + c.implicit)
            .sum();
        assert_eq!(by_parent, Vuid::all().len());
        let text = summary.render();
        assert!(text.contains("vkCmdBuildMicromapsEXT"));
        assert!(text.starts_with(
            "Micromap VUID catalog of Vulkan 1.4.360: 574 VUIDs (431 explicit, 143 implicit)"
        ));
    }
}
