//! A `vk_layer_settings.txt` as vkconfig writes it, found through
//! `VK_LAYER_SETTINGS_PATH` or where vkconfig keeps it, takes effect at
//! `vkCreateInstance`. Its own
//! test binary: it sets process-wide environment variables.

mod fake;

use fake::{Chain, DeviceBuild};
use ommcheck::report::message_id;

const BOTH_USAGE_POINTERS: &str = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";

fn faulty_build_ids(chain: &Chain) -> Vec<String> {
    DeviceBuild::new(chain).record_with_both_usage_pointers(chain);
    chain.collector.take().into_iter().map(|r| r.id).collect()
}

#[test]
fn a_settings_file_vkconfig_writes_takes_effect_below_the_environment() {
    for (var, _) in std::env::vars() {
        if var.starts_with("OMMCHECK_") {
            std::env::remove_var(var);
        }
    }
    let before = faulty_build_ids(&Chain::new());
    assert!(
        before.iter().any(|id| id == BOTH_USAGE_POINTERS),
        "{before:?}"
    );

    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("settings-file");
    std::fs::create_dir_all(&dir).unwrap();
    // The layout vkconfig writes: a comment block, then one line per
    // setting, with the layer's identifier as the prefix; the MessageID in
    // hexadecimal as a user copies it from a message.
    std::fs::write(
        dir.join("vk_layer_settings.txt"),
        format!(
            "# ommcheck\n# ========\n# <LayerIdentifier>.message_id_filter\n\
             ommcheck_validation.message_id_filter = {:#010x}\n\
             khronos_validation.message_id_filter = nothing\n",
            message_id(BOTH_USAGE_POINTERS)
        ),
    )
    .unwrap();
    std::env::set_var("VK_LAYER_SETTINGS_PATH", &dir);
    let muted = faulty_build_ids(&Chain::new());
    assert!(
        !muted.iter().any(|id| id == BOTH_USAGE_POINTERS),
        "{muted:?}"
    );

    // The environment takes precedence over the file.
    std::env::set_var("OMMCHECK_MESSAGE_ID_FILTER", "OMMCHECK-none");
    let unmuted = faulty_build_ids(&Chain::new());
    assert!(
        unmuted.iter().any(|id| id == BOTH_USAGE_POINTERS),
        "{unmuted:?}"
    );
    std::env::remove_var("OMMCHECK_MESSAGE_ID_FILTER");
    std::env::remove_var("VK_LAYER_SETTINGS_PATH");

    // Where vkconfig writes it on Linux: $XDG_DATA_HOME/vulkan/settings.d.
    let data_home = dir.join("data");
    let settings_d = data_home.join("vulkan").join("settings.d");
    std::fs::create_dir_all(&settings_d).unwrap();
    std::fs::rename(
        dir.join("vk_layer_settings.txt"),
        settings_d.join("vk_layer_settings.txt"),
    )
    .unwrap();
    std::env::set_var("XDG_DATA_HOME", &data_home);
    let muted = faulty_build_ids(&Chain::new());
    assert!(
        !muted.iter().any(|id| id == BOTH_USAGE_POINTERS),
        "{muted:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
