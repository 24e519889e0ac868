//! `vk-probe`: what the system's Vulkan loader shows this process, as lines
//! of tab-separated fields, for `tests/drivers.rs`. The tests run it as a
//! child process with the loader's environment variables set
//! (`VK_DRIVER_FILES`, `VK_ADD_LAYER_PATH`, ...), because the loader reads
//! them once per process and keeps what it found.
//!
//! ```text
//! vk-probe layers                  # layer <name> <spec version>
//! vk-probe devices [--layer NAME]  # device <i> name <name>
//!                                  # device <i> extension <name> <spec version>
//! ```
//!
//! `devices` creates an instance, with the named layers enabled, and lists
//! each physical device's name and extensions. Errors go to stderr with
//! exit status 1.

use std::ffi::{CStr, CString};
use std::process::ExitCode;

use ash::vk;

fn version(v: u32) -> String {
    format!(
        "{}.{}.{}",
        vk::api_version_major(v),
        vk::api_version_minor(v),
        vk::api_version_patch(v)
    )
}

fn text(name: Result<&CStr, std::ffi::FromBytesUntilNulError>) -> String {
    name.map_or_else(|_| "<unterminated>".into(), |s| s.to_string_lossy().into())
}

fn layers(entry: &ash::Entry) -> Result<(), String> {
    // SAFETY: takes no handles; the loader owns the returned data.
    let layers = unsafe { entry.enumerate_instance_layer_properties() }
        .map_err(|e| format!("vkEnumerateInstanceLayerProperties: {e}"))?;
    for layer in &layers {
        println!(
            "layer\t{}\t{}",
            text(layer.layer_name_as_c_str()),
            version(layer.spec_version)
        );
    }
    Ok(())
}

fn devices(entry: &ash::Entry, layers: &[String]) -> Result<(), String> {
    let layers: Vec<CString> = layers
        .iter()
        .map(|l| CString::new(l.as_str()).map_err(|e| format!("layer name {l:?}: {e}")))
        .collect::<Result<_, _>>()?;
    let layer_ptrs: Vec<*const std::ffi::c_char> = layers.iter().map(|l| l.as_ptr()).collect();
    let app = vk::ApplicationInfo::default()
        .application_name(c"vk-probe")
        .api_version(vk::API_VERSION_1_1);
    let info = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layer_ptrs);
    // SAFETY: `info` and everything it points to outlive the call.
    let instance = unsafe { entry.create_instance(&info, None) }
        .map_err(|e| format!("vkCreateInstance: {e}"))?;
    let result = list_devices(&instance);
    // SAFETY: the instance has no child objects left.
    unsafe { instance.destroy_instance(None) };
    result
}

fn list_devices(instance: &ash::Instance) -> Result<(), String> {
    // SAFETY: `instance` is a live instance; the physical devices it returns
    // live as long as it does.
    let physical = unsafe { instance.enumerate_physical_devices() }
        .map_err(|e| format!("vkEnumeratePhysicalDevices: {e}"))?;
    for (i, &device) in physical.iter().enumerate() {
        // SAFETY: `device` came from this instance.
        let properties = unsafe { instance.get_physical_device_properties(device) };
        println!(
            "device\t{i}\tname\t{}",
            text(properties.device_name_as_c_str())
        );
        println!("device\t{i}\tapi\t{}", version(properties.api_version));
        // SAFETY: as above.
        let extensions = unsafe { instance.enumerate_device_extension_properties(device) }
            .map_err(|e| format!("vkEnumerateDeviceExtensionProperties: {e}"))?;
        for extension in &extensions {
            println!(
                "device\t{i}\textension\t{}\t{}",
                text(extension.extension_name_as_c_str()),
                extension.spec_version
            );
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    // SAFETY: loading libvulkan.so.1 runs its initialisers; the loader is the
    // system's, installed from the distribution's packages.
    let entry = match unsafe { ash::Entry::load() } {
        Ok(entry) => entry,
        Err(e) => {
            eprintln!("vk-probe: no Vulkan loader: {e}");
            return ExitCode::FAILURE;
        }
    };
    let result = match args.first().map(String::as_str) {
        Some("layers") if args.len() == 1 => layers(&entry),
        Some("devices") => {
            let mut enabled = Vec::new();
            let mut rest = args[1..].iter();
            let mut bad = None;
            while let Some(arg) = rest.next() {
                match (arg.as_str(), rest.next()) {
                    ("--layer", Some(name)) => enabled.push(name.clone()),
                    _ => bad = Some(arg.clone()),
                }
            }
            match bad {
                Some(arg) => Err(format!("unexpected argument {arg:?}")),
                None => devices(&entry, &enabled),
            }
        }
        _ => Err("usage: vk-probe layers | vk-probe devices [--layer NAME]...".into()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("vk-probe: {e}");
            ExitCode::FAILURE
        }
    }
}
