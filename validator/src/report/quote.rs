//! The one sentence of a rule's statement a finding quotes.
//!
//! A finding's text ends with `The Vulkan spec states: <sentence> (<link>)`,
//! as the Khronos layer's do. Every VUID text of the catalog is one
//! sentence (a test below holds the catalog to it), so a VUID's finding
//! quotes its whole text. A few rules of ours quote several sentences of
//! the specification, for the EXT and KHR forms of a rule or for a
//! definition next to the requirement: a finding of one of those quotes the
//! sentence it breaks, chosen by [`SENTENCES`]. The whole statement stays
//! in [`Finding::spec_text`](crate::Finding::spec_text), in
//! `ommcheck vuid` and in the HTML report.

use super::RuleId;
use crate::rules::{self, OwnRule};

/// Which findings of a rule quote a sentence: by the attachment their
/// location names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// Every finding of the rule.
    Any,
    /// Findings at a `VkAccelerationStructureTrianglesOpacityMicromapKHR`
    /// (their location names it).
    Khr,
    /// The other findings: EXT attachments (and NV, which follow EXT).
    Ext,
}

impl Scope {
    fn holds_for(self, location: &str) -> bool {
        let khr = location.contains("OpacityMicromapKHR");
        match self {
            Scope::Any => true,
            Scope::Khr => khr,
            Scope::Ext => !khr,
        }
    }
}

/// The rules of ours whose statement quotes more than one sentence, and
/// the sentence each kind of finding breaks. Each sentence is a piece of
/// the rule's statement, word for word (a test checks it).
pub const SENTENCES: &[(&OwnRule, &[(Scope, &str)])] = &[
    (
        &rules::INDEX_IN_RANGE,
        &[
            (
                Scope::Khr,
                "For each triangle in the geometry, a triangle in the micromap is fetched at index reinterpret_cast<indexType>(indexBuffer + indexStride * geomTriangleIndex) + baseTriangle.",
            ),
            (
                Scope::Ext,
                "Otherwise that triangle uses the opacity micromap information from micromap at that index plus baseTriangle.",
            ),
        ],
    ),
    (
        &rules::INDEX_BUFFER_RANGE,
        &[(
            Scope::Any,
            "For each triangle in the geometry, the acceleration structure build fetches an index from indexBuffer using indexType and indexStride.",
        )],
    ),
    (
        &rules::INSTANCES_RANGE,
        &[(
            Scope::Any,
            "primitiveCount VkAccelerationStructureInstanceKHR or VkAccelerationStructureMotionInstanceNV structures are consumed from VkAccelerationStructureGeometryInstancesDataKHR::data, starting at an offset of primitiveOffset.",
        )],
    ),
    (
        &rules::ACCESS_STAGE_ON_QUEUE,
        &[(
            Scope::Any,
            "An application must not specify an access flag in a synchronization command if it does not include a pipeline stage in the corresponding stage mask that is able to perform accesses of that type.",
        )],
    ),
];

/// The sentence a finding of `rule` at `location` quotes: the rule's
/// statement, or for a rule of [`SENTENCES`] the sentence whose scope
/// holds for the location.
pub fn sentence(rule: RuleId, location: &str) -> &'static str {
    let RuleId::Own(own) = rule else {
        return rule.statement();
    };
    SENTENCES
        .iter()
        .find(|(r, _)| r.id == own.id)
        .and_then(|(_, sentences)| {
            sentences
                .iter()
                .find(|(scope, _)| scope.holds_for(location))
        })
        .map_or(own.statement, |(_, sentence)| *sentence)
}

/// How many sentences `text` holds: a sentence ends at `.`, `?` or `!`
/// (and a closing quotation mark, if one follows) followed by a space and
/// a capital letter or an opening quotation mark, outside parentheses (so
/// `e.g.` and `1.4` end none).
pub fn sentence_count(text: &str) -> usize {
    let bytes = text.as_bytes();
    let mut depth = 0usize;
    let mut count = 1;
    for (i, &b) in bytes.iter().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' => depth = depth.saturating_sub(1),
            b'.' | b'?' | b'!' if depth == 0 => {
                let after = if bytes.get(i + 1) == Some(&b'"') {
                    i + 2
                } else {
                    i + 1
                };
                if let Some([b' ', c]) = bytes.get(after..after + 2) {
                    if c.is_ascii_uppercase() || *c == b'"' {
                        count += 1;
                    }
                }
            }
            _ => {}
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use ommcheck_vuids::Vuid;

    /// The design rests on it: a VUID's finding quotes its whole text
    /// because every catalog text is one sentence.
    #[test]
    fn every_vuid_text_is_one_sentence() {
        let longer: Vec<&str> = Vuid::all()
            .filter(|v| sentence_count(v.info().text) != 1)
            .map(|v| v.id())
            .collect();
        assert!(longer.is_empty(), "{longer:?}");
    }

    #[test]
    fn sentences_are_counted_outside_parentheses() {
        assert_eq!(sentence_count("One sentence (e.g. this. And this)."), 1);
        assert_eq!(sentence_count("\"One.\" \"Two.\" (Three. Four.)"), 2);
        assert_eq!(sentence_count("EXT: \"One.\" KHR: \"Two.\""), 2);
        assert_eq!(sentence_count("A. B? C"), 3);
    }

    #[test]
    fn each_quoted_sentence_is_the_rules_own_words_and_one_sentence() {
        for (rule, sentences) in SENTENCES {
            for (_, sentence) in *sentences {
                // A proper part of the statement, word for word.
                assert!(rule.statement.contains(sentence), "{}: {sentence}", rule.id);
                assert!(rule.statement.len() > sentence.len(), "{}", rule.id);
                assert_eq!(sentence_count(sentence), 1, "{sentence}");
            }
        }
    }

    #[test]
    fn the_attachment_in_the_location_picks_the_sentence() {
        let rule = RuleId::from(&rules::INDEX_IN_RANGE);
        let ext = sentence(
            rule,
            "pInfos[0].pGeometries[0].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapEXT>.indexBuffer[1]",
        );
        assert!(ext.starts_with("Otherwise that triangle"), "{ext}");
        let khr = sentence(
            rule,
            "calls[1]: pInfos[0].pGeometries[0].geometry.triangles.pNext<VkAccelerationStructureTrianglesOpacityMicromapKHR>.indexBuffer[1]",
        );
        assert!(
            khr.starts_with("For each triangle in the geometry, a triangle in the micromap"),
            "{khr}"
        );
        // A rule of one sentence, and a VUID, quote their whole statement.
        let whole = RuleId::from(&rules::HISTOGRAM_MISMATCH);
        assert_eq!(sentence(whole, "x"), whole.statement());
        let vuid = RuleId::from(ommcheck_vuids::vuid::VkMicromapBuildInfoEXT::pUsageCounts_07516);
        assert_eq!(sentence(vuid, "pInfos[0]"), vuid.statement());
    }
}
