//! What the checker cannot decide is said, not skipped: one information
//! finding per cause, naming the rules, the object, the parameter and what
//! would let them run; and a call given everything is checked in full.

use ommcheck::model::values::*;
use ommcheck::rules;
use ommcheck::state::Micromap;
use ommcheck::vuids::vuid::{vkBuildMicromapsEXT as host, VkMicromapBuildInfoEXT as info};
use ommcheck::{Cause, Report, RuleId, Severity, Validator};

use crate::fixtures::*;

fn device_build_in(mut v: Validator) -> Report {
    v.cmd_build_micromaps(&command_buffer(), &[device_build()])
}

fn only_not_checked(report: &Report) -> &ommcheck::Finding {
    let skipped: Vec<_> = report.not_checked().collect();
    assert_eq!(skipped.len(), 1, "{report}");
    assert!(!report.has_errors(), "{report}");
    assert_eq!(skipped[0].severity, Severity::Info);
    skipped[0]
}

#[test]
fn a_build_given_everything_is_checked_in_full() {
    let report = device_build_in(validator());
    report.assert_fully_checked();
    assert!(report.is_empty(), "{report}");
    let summary = report.summary();
    assert_eq!(summary.rules_not_checked, 0);
    for rule in [
        RuleId::from(&rules::TRIANGLE_DATA_RANGE),
        RuleId::from(&rules::HISTOGRAM_MISMATCH),
        info::subdivisionLevel_11660.into(),
    ] {
        assert!(report.checked.contains(rule), "{rule}");
    }
    assert_eq!(summary.rules_checked, report.checked.len());

    let mut v = validator();
    let host_report = v.build_micromaps(DEVICE, 0, &[host_build()]);
    host_report.assert_fully_checked();
    assert!(host_report.checked.contains(host::pInfos_07553));
}

#[test]
fn contents_not_given_name_the_buffer_the_rules_and_the_remedy() {
    let mut v = validator();
    v.state_mut()
        .buffers
        .get_mut(&INPUT)
        .expect("fixture")
        .contents = None;
    let report = device_build_in(v);
    let finding = only_not_checked(&report);
    assert_eq!(finding.not_checked_cause(), Some(Cause::Contents));
    assert_eq!(finding.rule.as_str(), "OMMCHECK-not-checked-contents");
    assert_eq!(finding.location, "pInfos[0].triangleArray");
    assert_eq!(
        (finding.objects[0].ty, finding.objects[0].handle),
        ("VkBuffer", INPUT)
    );
    assert!(finding
        .not_checked
        .contains(&RuleId::from(&rules::TRIANGLE_DATA_RANGE)));
    assert!(finding.not_checked.contains(&info::format_11657.into()));
    assert!(
        finding.message.contains("Buffer::contents"),
        "{}",
        finding.message
    );
    let summary = report.summary();
    assert_eq!(summary.rules_not_checked, finding.not_checked.len());
    assert!(!report.checked.is_empty());
    let error = report.require_fully_checked().unwrap_err().to_string();
    assert!(
        error.contains("OMMCHECK-build-usage-counts-match-triangles"),
        "{error}"
    );
}

#[test]
fn unbound_buffers_say_they_have_no_contents() {
    let mut v = validator();
    let mut input = v.state_mut().buffers.get_mut(&INPUT).expect("fixture");
    input.memory = None;
    input.contents = None;
    drop(input);
    let report = device_build_in(v);
    let finding = report
        .not_checked()
        .next()
        .unwrap_or_else(|| panic!("{report}"));
    assert_eq!(finding.not_checked_cause(), Some(Cause::Contents));
    assert!(
        finding.message.contains("not bound to memory"),
        "{}",
        finding.message
    );
}

#[test]
fn addresses_no_known_buffer_holds_are_reported_not_checked() {
    // Only the destination is tracked: no buffer has a device address.
    let mut v = Validator::new(device());
    v.state_mut().micromaps.insert(
        MICROMAP,
        Micromap {
            ty: MICROMAP_TYPE_OPACITY_MICROMAP_EXT,
            ..Default::default()
        },
    );
    let report = v.cmd_build_micromaps(&command_buffer(), &[device_build()]);
    let skipped: Vec<_> = report.not_checked().collect();
    assert_eq!(skipped.len(), 1, "{report}");
    assert_eq!(skipped[0].not_checked_cause(), Some(Cause::UnknownAddress));
    assert!(skipped[0].message.contains("Buffer::device_address"));
}

#[test]
fn host_memory_of_unknown_extent_is_reported_with_the_address_rules() {
    let mut v = validator();
    v.state_mut().host_memory.clear();
    let report = v.build_micromaps(DEVICE, 0, &[host_build()]);
    let finding = only_not_checked(&report);
    assert_eq!(finding.not_checked_cause(), Some(Cause::HostMemory));
    assert_eq!(finding.location, "pInfos[0].triangleArray");
    for rule in [
        RuleId::from(host::pInfos_07553),
        host::pInfos_07554.into(),
        (&rules::TRIANGLE_DATA_RANGE).into(),
    ] {
        assert!(finding.not_checked.contains(&rule), "{rule}");
    }
    assert!(finding.message.contains("describe_host_memory"));
}

#[test]
fn below_the_content_tier_nothing_is_reported_not_checked() {
    // The tier is the caller's choice, not missing information.
    let mut v = validator();
    v.state_mut().host_memory.clear();
    v.set_tier(ommcheck::Tier::State);
    let report = v.build_micromaps(DEVICE, 0, &[host_build()]);
    assert!(report.is_empty(), "{report}");
}

#[test]
fn the_summary_reads_as_counts() {
    let report = device_build_in(validator());
    let text = report.summary().to_string();
    assert_eq!(
        text,
        format!(
            "0 findings (0 errors, 0 warnings, 0 info); {} rules checked, 0 not checked",
            report.checked.len()
        )
    );
    let json = serde_json::to_value(report.summary()).expect("serializes");
    assert_eq!(json["rulesNotChecked"], 0);
    assert_eq!(json["rulesChecked"], report.checked.len());
}
