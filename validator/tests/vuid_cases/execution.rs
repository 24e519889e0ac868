//! Cases for the `execution` checks: each rule's failing and valid scene of
//! the corpus (the rules need recordings, submissions and waits, which the
//! scenes spell out), checked through the scene reader.

use ommcheck::scene::{CheckOptions, Scene};
use ommcheck::vuids::vuid::{
    vkCmdBuildAccelerationStructuresIndirectKHR as build_indirect,
    vkCmdBuildAccelerationStructuresKHR as build_cmd, vkCmdCopyMicromapEXT as cmd_copy,
    vkCmdWriteMicromapsPropertiesEXT as cmd_write, vkCopyMicromapEXT as host_copy,
    vkDestroyMicromapEXT as destroy, vkWriteMicromapsPropertiesEXT as host_write,
    VkCopyMicromapToMemoryInfoEXT as to_memory_info,
};
use ommcheck::Report;

use crate::{case, Case};

/// The report of corpus scene `family/file`.
fn corpus(family_and_file: &str) -> Report {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/scenes/corpus")
        .join(family_and_file);
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    scene
        .check(&CheckOptions::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .report
}

/// A case from the corpus: `$family/$rule.fail.json` and its twin `$twin`.
macro_rules! corpus_case {
    ($rule:expr, $family:literal, $id:literal, $twin:literal) => {
        case(
            $rule,
            || corpus(concat!($family, "/", $id, ".fail.json")),
            || corpus(concat!($family, "/", $twin)),
        )
    };
}

pub fn cases() -> Vec<Case> {
    vec![
        corpus_case!(
            cmd_copy::src_07532,
            "execution-order",
            "VUID-vkCmdCopyMicromapEXT-src-07532",
            "pass.json"
        ),
        corpus_case!(
            to_memory_info::src_07540,
            "execution-order",
            "VUID-VkCopyMicromapToMemoryInfoEXT-src-07540",
            "pass.json"
        ),
        corpus_case!(
            cmd_write::pMicromaps_11662,
            "execution-order",
            "VUID-vkCmdWriteMicromapsPropertiesEXT-pMicromaps-11662",
            "pass.json"
        ),
        corpus_case!(
            cmd_write::None_12417,
            "execution-order",
            "VUID-vkCmdWriteMicromapsPropertiesEXT-None-12417",
            "pass.json"
        ),
        corpus_case!(
            destroy::micromap_07441,
            "execution-order",
            "VUID-vkDestroyMicromapEXT-micromap-07441",
            "pass.json"
        ),
        corpus_case!(
            host_copy::src_11670,
            "execution-order",
            "VUID-vkCopyMicromapEXT-src-11670",
            "pass.json"
        ),
        corpus_case!(
            host_write::pMicromaps_11671,
            "execution-order",
            "VUID-vkWriteMicromapsPropertiesEXT-pMicromaps-11671",
            "pass.json"
        ),
        corpus_case!(
            build_cmd::micromap_11632,
            "blas-ext",
            "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11632",
            "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11632.pass.json"
        ),
        corpus_case!(
            build_indirect::micromap_11632,
            "ext-indirect",
            "VUID-vkCmdBuildAccelerationStructuresIndirectKHR-micromap-11632",
            "VUID-vkCmdBuildAccelerationStructuresIndirectKHR-micromap-11632.pass.json"
        ),
        corpus_case!(
            build_cmd::micromap_11701,
            "blas-khr",
            "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11701",
            "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11701.pass.json"
        ),
        corpus_case!(
            build_indirect::micromap_11701,
            "khr-indirect",
            "VUID-vkCmdBuildAccelerationStructuresIndirectKHR-micromap-11701",
            "VUID-vkCmdBuildAccelerationStructuresIndirectKHR-micromap-11701.pass.json"
        ),
        // A batch held for a timeline value until the host signals it is
        // decided then, against what the host had seen complete.
        corpus_case!(
            build_cmd::micromap_11632,
            "execution-host-signal",
            "VUID-vkCmdBuildAccelerationStructuresKHR-micromap-11632",
            "pass.json"
        ),
        // A host wait for 3 is met by the signal to 5, not the one to 1.
        corpus_case!(
            host_write::pMicromaps_11671,
            "execution-timeline-values",
            "VUID-vkWriteMicromapsPropertiesEXT-pMicromaps-11671",
            "pass.json"
        ),
        corpus_case!(
            destroy::micromap_07441,
            "execution-timeline-values",
            "VUID-vkDestroyMicromapEXT-micromap-07441",
            "pass.json"
        ),
        // Queries are uninitialized from their pool's creation until reset.
        corpus_case!(
            cmd_write::None_12417,
            "query-initialization",
            "VUID-vkCmdWriteMicromapsPropertiesEXT-None-12417",
            "pass.json"
        ),
        corpus_case!(
            cmd_write::None_12417,
            "query-initialization-host",
            "VUID-vkCmdWriteMicromapsPropertiesEXT-None-12417",
            "pass.json"
        ),
    ]
}
