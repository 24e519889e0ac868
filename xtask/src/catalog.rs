//! Selects the micromap VUIDs from `validusage.json` and writes the catalog.
//!
//! Selection (a VUID is kept when any rule matches; the rules are the ones
//! `micromap_vuids.json` documents in `selection_rules`, less the two that
//! need the specification's AsciiDoc sources, which select nothing on their
//! own in 1.4.360):
//! - `micromap-api`: the VUID's parent is a type or command one of the four
//!   micromap extensions requires in `vk.xml`;
//! - `text`: the statement matches `micromap|subdivision ?level|\bOMM\b`
//!   (case-insensitive) or names a symbol one of the extensions introduces;
//! - `vuid-name`: the VUID string contains "micromap".

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::Path;

use regex::Regex;
use serde::Deserialize;

use crate::registry::{short_name, VkXml};
use crate::Error;

#[derive(Deserialize)]
struct ValidUsage {
    #[serde(rename = "version info")]
    version_info: VersionInfo,
    validation: BTreeMap<String, BTreeMap<String, Vec<ValidUsageEntry>>>,
}

#[derive(Deserialize)]
struct VersionInfo {
    #[serde(rename = "api version")]
    api_version: String,
}

#[derive(Deserialize)]
struct ValidUsageEntry {
    vuid: String,
    text: String,
    page: String,
}

/// Per-VUID facts that live only in the specification's AsciiDoc sources or
/// in the Khronos layer's sources, neither of which the registry carries.
#[derive(Deserialize)]
struct Annotations {
    vuids: Vec<Annotation>,
}

#[derive(Deserialize)]
struct Annotation {
    vuid: String,
    extensions_short: Vec<String>,
    string_in_vvl_layers: bool,
}

/// One selected VUID.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    pub id: String,
    pub parent: String,
    pub parent_kind: &'static str,
    pub implicit: bool,
    /// Short names of the enabling micromap extensions, in EXT, KHR, NV, ARM order.
    pub extensions: Vec<&'static str>,
    /// The same, derived from `vk.xml` alone (parent requirement and named symbols).
    pub derived_extensions: Vec<&'static str>,
    pub text: String,
    pub page: String,
    pub khronos_layer_checks: Option<bool>,
    pub matched: Vec<&'static str>,
}

/// The selected catalog and where its gating came from.
pub struct Catalog {
    pub api_version: String,
    pub header_version: String,
    pub gating_source: String,
    pub entries: Vec<Entry>,
}

/// Turns a statement's HTML into the plain text the catalog stores.
pub struct PlainText {
    sup: Regex,
    list_item: Regex,
    tag: Regex,
    math: Regex,
    mathtt: Regex,
    entity: Regex,
    space: Regex,
}

impl PlainText {
    pub fn new() -> Self {
        let re = |pattern: &str| Regex::new(pattern).expect("static regex");
        Self {
            sup: re(r"<sup>(.*?)</sup>"),
            list_item: re(r"<li[^>]*>"),
            tag: re(r"<[^>]+>"),
            math: re(r"\\\((.*?)\\\)"),
            mathtt: re(r"\\mathtt\{([^}]*)\}"),
            entity: re(r"&(#x[0-9a-fA-F]+|#[0-9]+|[a-zA-Z]+);"),
            space: re(r"\s+"),
        }
    }

    pub fn convert(&self, html: &str) -> Result<String, Error> {
        let text = self.sup.replace_all(html, "^$1");
        let text = self.list_item.replace_all(&text, " - ");
        let text = self.tag.replace_all(&text, "");
        let text = self.math.replace_all(&text, |caps: &regex::Captures<'_>| {
            let inner = self.mathtt.replace_all(&caps[1], "$1");
            inner.replace("\\times", "×").replace("\\_", "_")
        });
        let mut unknown = None;
        let text = self
            .entity
            .replace_all(&text, |caps: &regex::Captures<'_>| {
                let name = &caps[1];
                let decoded = if let Some(hex) = name.strip_prefix("#x") {
                    u32::from_str_radix(hex, 16).ok().and_then(char::from_u32)
                } else if let Some(dec) = name.strip_prefix('#') {
                    dec.parse().ok().and_then(char::from_u32)
                } else {
                    match name {
                        "lt" => Some('<'),
                        "gt" => Some('>'),
                        "amp" => Some('&'),
                        "quot" => Some('"'),
                        "apos" => Some('\''),
                        "nbsp" => Some(' '),
                        _ => None,
                    }
                };
                decoded.map(String::from).unwrap_or_else(|| {
                    unknown = Some(caps[0].to_string());
                    caps[0].to_string()
                })
            });
        if let Some(entity) = unknown {
            return Err(Error::Registry(format!(
                "unknown HTML entity {entity} in: {html}"
            )));
        }
        Ok(self.space.replace_all(&text, " ").trim().to_string())
    }
}

impl Default for PlainText {
    fn default() -> Self {
        Self::new()
    }
}

fn order_shorts(set: &BTreeSet<&'static str>) -> Vec<&'static str> {
    ["EXT", "KHR", "NV", "ARM"]
        .into_iter()
        .filter(|s| set.contains(s))
        .collect()
}

/// Reads the registry directory and selects the catalog.
pub fn select(registry: &Path) -> Result<Catalog, Error> {
    let vk = VkXml::load(&registry.join("vk.xml"))?;
    let validusage_path = registry.join("validusage.json");
    let validusage: ValidUsage = serde_json::from_str(&crate::read(&validusage_path)?)
        .map_err(|e| Error::Registry(format!("{}: {e}", validusage_path.display())))?;

    let annotations_path = registry.join("micromap_vuids.json");
    let annotations: Option<HashMap<String, Annotation>> = if annotations_path.exists() {
        let parsed: Annotations = serde_json::from_str(&crate::read(&annotations_path)?)
            .map_err(|e| Error::Registry(format!("{}: {e}", annotations_path.display())))?;
        Some(
            parsed
                .vuids
                .into_iter()
                .map(|a| (a.vuid.clone(), a))
                .collect(),
        )
    } else {
        None
    };

    let plain = PlainText::new();
    let topic = Regex::new(r"(?i)micromap|subdivision ?level|\bOMM\b").expect("static regex");
    let symbol = Regex::new(r"[A-Za-z_][A-Za-z0-9_]*").expect("static regex");
    let explicit_number = Regex::new(r"-[0-9]+$").expect("static regex");

    let mut entries = Vec::new();
    let mut seen = BTreeSet::new();
    for (parent, sections) in &validusage.validation {
        let parent_required = vk.micromap_requirements.get(parent);
        for entry in sections.values().flatten() {
            let text = plain.convert(&entry.text)?;
            let mut mentioned = BTreeSet::new();
            for name in symbol.find_iter(&text) {
                for alias in vk.alias_closure(name.as_str()) {
                    if let Some(exts) = vk.micromap_definitions.get(&alias) {
                        mentioned.extend(exts.iter().filter_map(|e| short_name(e)));
                    }
                }
            }
            let names_symbol = symbol
                .find_iter(&text)
                .any(|name| vk.micromap_definitions.contains_key(name.as_str()));

            let mut matched = Vec::new();
            if parent_required.is_some() {
                matched.push("micromap-api");
            }
            if topic.is_match(&text) || names_symbol {
                matched.push("text");
            }
            if entry.vuid.to_ascii_lowercase().contains("micromap") {
                matched.push("vuid-name");
            }
            if matched.is_empty() {
                continue;
            }
            if !seen.insert(entry.vuid.clone()) {
                return Err(Error::Registry(format!("{} appears twice", entry.vuid)));
            }

            let mut derived: BTreeSet<&'static str> = parent_required
                .into_iter()
                .flatten()
                .filter_map(|e| short_name(e))
                .collect();
            derived.extend(mentioned);
            let derived_extensions = order_shorts(&derived);

            let annotation = annotations.as_ref().and_then(|a| a.get(&entry.vuid));
            let extensions = match annotation {
                Some(a) => {
                    let set: BTreeSet<&'static str> = a
                        .extensions_short
                        .iter()
                        .filter_map(|s| ["EXT", "KHR", "NV", "ARM"].into_iter().find(|k| k == s))
                        .collect();
                    order_shorts(&set)
                }
                None => derived_extensions.clone(),
            };
            let parent_kind = if parent == "RuntimeSpirv" {
                "Spirv"
            } else if parent.starts_with("vk") {
                "Command"
            } else {
                "Struct"
            };
            entries.push(Entry {
                id: entry.vuid.clone(),
                parent: parent.clone(),
                parent_kind,
                implicit: !explicit_number.is_match(&entry.vuid),
                extensions,
                derived_extensions,
                text,
                page: entry.page.clone(),
                khronos_layer_checks: annotation.map(|a| a.string_in_vvl_layers),
                matched,
            });
        }
    }
    entries.sort_by(|a, b| a.id.cmp(&b.id));
    if entries.len() > usize::from(u16::MAX) {
        return Err(Error::Registry("catalog too large for a u16 index".into()));
    }
    let gating_source = if annotations.is_some() {
        "ifdef gating of the specification sources, as recorded per VUID in micromap_vuids.json beside vk.xml"
    } else {
        "derived from vk.xml: the micromap extensions that require the VUID's parent or introduce a symbol its statement names"
    };
    Ok(Catalog {
        api_version: validusage.version_info.api_version,
        header_version: vk.header_version,
        gating_source: gating_source.to_string(),
        entries,
    })
}

const RUST_KEYWORDS: &[&str] = &[
    "as", "break", "const", "continue", "crate", "else", "enum", "extern", "false", "fn", "for",
    "if", "impl", "in", "let", "loop", "match", "mod", "move", "mut", "pub", "ref", "return",
    "self", "Self", "static", "struct", "super", "trait", "true", "type", "unsafe", "use", "where",
    "while", "async", "await", "dyn", "abstract", "become", "box", "do", "final", "macro",
    "override", "priv", "typeof", "unsized", "virtual", "yield", "try", "gen",
];

/// The constant name of a VUID inside its parent's module: the part after
/// `VUID-<parent>-`, with `-` turned into `_`.
pub fn const_name(entry: &Entry) -> String {
    let prefix = format!("VUID-{}-", entry.parent);
    let rest = entry.id.strip_prefix(&prefix).unwrap_or(&entry.id);
    let mut name: String = rest
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        name.insert(0, '_');
    }
    if RUST_KEYWORDS.contains(&name.as_str()) {
        name.push('_');
    }
    name
}

/// Writes `vuids/src/generated/catalog.rs`.
pub fn render(catalog: &Catalog) -> Result<String, Error> {
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(
        w,
        "// @generated by `cargo xtask generate` from vk.xml (header {}) and validusage.json ({}).\n// Do not edit: regenerate.\n",
        catalog.header_version, catalog.api_version
    );
    let _ = writeln!(
        w,
        "use crate::{{Extensions, ParentKind, VuidInfo, VuidKind}};\n"
    );
    let _ = writeln!(
        w,
        "/// The Vulkan version of the registry the catalog was generated from."
    );
    let _ = writeln!(
        w,
        "pub const REGISTRY_VERSION: &str = {:?};\n",
        catalog.api_version
    );
    let _ = writeln!(w, "/// Where [`VuidInfo::extensions`] came from.");
    let _ = writeln!(
        w,
        "pub const GATING_SOURCE: &str = {:?};\n",
        catalog.gating_source
    );
    let _ = writeln!(
        w,
        "pub(crate) static CATALOG: [VuidInfo; {}] = [",
        catalog.entries.len()
    );
    for e in &catalog.entries {
        let extensions = if e.extensions.is_empty() {
            "Extensions::NONE".to_string()
        } else {
            let mut parts = e.extensions.iter().map(|s| format!("Extensions::{s}"));
            let first = parts.next().unwrap_or_default();
            parts.fold(first, |acc, p| format!("{acc}.union({p})"))
        };
        let khronos = match e.khronos_layer_checks {
            Some(b) => format!("Some({b})"),
            None => "None".into(),
        };
        let _ = writeln!(
            w,
            "    VuidInfo {{ id: {:?}, parent: {:?}, parent_kind: ParentKind::{}, kind: VuidKind::{}, extensions: {}, text: {:?}, page: {:?}, khronos_layer_checks: {} }},",
            e.id,
            e.parent,
            e.parent_kind,
            if e.implicit { "Implicit" } else { "Explicit" },
            extensions,
            e.text,
            e.page,
            khronos
        );
    }
    let _ = writeln!(w, "];\n");

    let _ = writeln!(
        w,
        "/// One module per parent structure or command; one constant per VUID,\n/// named after the VUID's tail (`VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516` is\n/// `vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516`)."
    );
    let _ = writeln!(w, "#[allow(non_snake_case, non_upper_case_globals)]");
    let _ = writeln!(w, "pub mod vuid {{");
    let mut by_parent: BTreeMap<&str, Vec<(usize, &Entry)>> = BTreeMap::new();
    for (index, e) in catalog.entries.iter().enumerate() {
        by_parent.entry(&e.parent).or_default().push((index, e));
    }
    for (parent, list) in by_parent {
        let _ = writeln!(w, "    #[doc = {:?}]", format!("VUIDs of `{parent}`."));
        let _ = writeln!(w, "    pub mod {parent} {{");
        let _ = writeln!(w, "        use crate::Vuid;");
        let mut names = BTreeSet::new();
        for (index, e) in list {
            let name = const_name(e);
            if !names.insert(name.clone()) {
                return Err(Error::Registry(format!(
                    "two VUIDs of {parent} map to {name}"
                )));
            }
            let _ = writeln!(
                w,
                "        #[doc = {:?}]",
                format!("`{}`: {}", e.id, e.text)
            );
            let _ = writeln!(w, "        pub const {name}: Vuid = Vuid::at({index});");
        }
        let _ = writeln!(w, "    }}");
    }
    let _ = writeln!(w, "}}");
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_text_of_lists_superscripts_math_and_entities() {
        let plain = PlainText::new();
        assert_eq!(
            plain.convert("<code>flags</code> <strong class=\"purple\">must</strong> not include<div class=\"ulist\">\n<ul>\n<li>\n<p>A</p>\n</li>\n<li>\n<p>B</p>\n</li>\n</ul>\n</div>").unwrap(),
            "flags must not include - A - B"
        );
        assert_eq!(
            plain
                .convert("<span class=\"eq\">2<sup>32</sup>-1</span>")
                .unwrap(),
            "2^32-1"
        );
        assert_eq!(
            plain
                .convert(r"array of \(2 \times \mathtt{VK\_UUID\_SIZE}\) values")
                .unwrap(),
            "array of 2 × VK_UUID_SIZE values"
        );
        assert_eq!(
            plain.convert("a-&gt;b &#8594; c&#8217;s").unwrap(),
            "a->b → c’s"
        );
        assert!(plain.convert("&bogus;").is_err());
    }

    #[test]
    fn constant_names() {
        let entry = |id: &str, parent: &str| Entry {
            id: id.into(),
            parent: parent.into(),
            parent_kind: "Struct",
            implicit: false,
            extensions: vec![],
            derived_extensions: vec![],
            text: String::new(),
            page: String::new(),
            khronos_layer_checks: None,
            matched: vec![],
        };
        assert_eq!(
            const_name(&entry("VUID-VkFoo-sType-sType", "VkFoo")),
            "sType_sType"
        );
        assert_eq!(
            const_name(&entry("VUID-vkCmdDraw-None-11636", "vkCmdDraw")),
            "None_11636"
        );
        assert_eq!(const_name(&entry("VUID-VkFoo-type", "VkFoo")), "type_");
        assert_eq!(const_name(&entry("VUID-VkFoo-07000", "VkFoo")), "_07000");
    }
}
