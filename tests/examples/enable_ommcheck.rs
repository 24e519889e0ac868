//! Enabling `VK_LAYER_OMMCHECK_validation` from an application's debug
//! build, with settings through `VkLayerSettingsCreateInfoEXT`
//! (docs/enabling-the-layer.md quotes this program). After `cargo xtask
//! layer --install`: `cargo run -p ommcheck-tests --example enable_ommcheck`.

use std::ffi::{c_char, CStr};

use ash::vk;

const OMMCHECK: &CStr = c"VK_LAYER_OMMCHECK_validation";

/// The layers to enable: ommcheck in debug builds, when it is installed,
/// so that a machine without it still runs the application.
fn debug_layers(entry: &ash::Entry) -> Vec<*const c_char> {
    if !cfg!(debug_assertions) {
        return Vec::new();
    }
    // SAFETY: takes no handles; the loader owns the returned data.
    let available = unsafe { entry.enumerate_instance_layer_properties() }.unwrap_or_default();
    if available
        .iter()
        .any(|layer| layer.layer_name_as_c_str() == Ok(OMMCHECK))
    {
        vec![OMMCHECK.as_ptr()]
    } else {
        eprintln!("{OMMCHECK:?} is not installed; running without it");
        Vec::new()
    }
}

/// One setting of ommcheck's. `value_count` counts values, not bytes, so
/// the fields are set directly: ash's `values()` takes a byte slice.
fn setting<'a, T>(
    name: &'a CStr,
    ty: vk::LayerSettingTypeEXT,
    values: &'a [T],
) -> vk::LayerSettingEXT<'a> {
    vk::LayerSettingEXT {
        p_layer_name: OMMCHECK.as_ptr(),
        p_setting_name: name.as_ptr(),
        ty,
        value_count: values.len() as u32,
        p_values: values.as_ptr().cast(),
        ..Default::default()
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // SAFETY: loads the system's Vulkan loader.
    let entry = unsafe { ash::Entry::load()? };
    let layers = debug_layers(&entry);

    // The environment (OMMCHECK_*) still overrides these.
    let report = [c"error".as_ptr(), c"warning".as_ptr()];
    let tier = [c"content".as_ptr()];
    let limit: [i32; 1] = [20];
    let muted = [c"OMMCHECK-layer-contents-not-checked".as_ptr()];
    let settings = [
        setting(c"report_flags", vk::LayerSettingTypeEXT::STRING, &report),
        setting(c"tier", vk::LayerSettingTypeEXT::STRING, &tier),
        setting(
            c"duplicate_message_limit",
            vk::LayerSettingTypeEXT::INT32,
            &limit,
        ),
        setting(
            c"message_id_filter",
            vk::LayerSettingTypeEXT::STRING,
            &muted,
        ),
    ];
    let mut layer_settings = vk::LayerSettingsCreateInfoEXT::default().settings(&settings);

    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    let info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .push_next(&mut layer_settings);
    // SAFETY: a valid create info; everything it points to outlives the call.
    let instance = unsafe { entry.create_instance(&info, None)? };
    println!("instance created with {} layer(s) enabled", layers.len());
    // SAFETY: nothing else uses the instance.
    unsafe { instance.destroy_instance(None) };
    Ok(())
}
