//! `cargo xtask layer`: builds the Vulkan layer in release and writes its
//! manifest, `VkLayer_ommcheck.json`, naming the built library by its
//! absolute path.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::{json, Value};
use VkLayer_ommcheck::{settings, LAYER_NAME};

/// The manifest's file name.
pub const MANIFEST: &str = "VkLayer_ommcheck.json";

/// The Vulkan version whose registry the checks follow.
const API_VERSION: &str = "1.4.360";

/// The manifest of a layer library at `library_path`.
pub fn manifest(library_path: &Path) -> Value {
    let settings: Vec<Value> = settings::DOCUMENTED
        .iter()
        .map(|s| {
            let default: Value =
                serde_json::from_str(s.default_json).expect("defaults are JSON literals");
            let mut setting = json!({
                "key": s.key,
                "env": s.env,
                "label": s.label,
                "description": s.description,
                "type": s.kind,
                "default": default,
            });
            if !s.flags.is_empty() {
                setting["flags"] = s
                    .flags
                    .iter()
                    .map(|(key, description)| {
                        json!({ "key": key, "label": key, "description": description })
                    })
                    .collect();
            }
            setting
        })
        .collect();
    json!({
        "file_format_version": "1.2.0",
        "layer": {
            "name": LAYER_NAME,
            "type": "GLOBAL",
            "library_path": library_path.to_string_lossy(),
            "api_version": API_VERSION,
            "implementation_version": "1",
            "description": "ommcheck: checks Vulkan opacity-micromap API usage",
            // Settings also come through VkLayerSettingsCreateInfoEXT; the
            // loader accepts the extension because a layer lists it (and
            // does not pass it down to drivers that lack it).
            "instance_extensions": [{ "name": "VK_EXT_layer_settings", "spec_version": "2" }],
            "features": { "settings": settings },
        }
    })
}

/// Builds the layer in release, writes the manifest into `out_dir`
/// (default `target/layer/`) and returns that directory.
pub fn build(root: &Path, out_dir: Option<PathBuf>) -> Result<PathBuf, crate::Error> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(&cargo)
        .current_dir(root)
        .args(["build", "--release", "-p", "ommcheck-layer"])
        .status()
        .map_err(|e| crate::Error::Tool(format!("cannot run cargo: {e}")))?;
    if !status.success() {
        return Err(crate::Error::Tool(format!("cargo build failed ({status})")));
    }
    let target = crate::target_dir(root);
    let file = format!(
        "{}VkLayer_ommcheck{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    );
    let built = target.join("release").join(&file);
    let library = built.canonicalize().map_err(|source| crate::Error::Io {
        path: built,
        source,
    })?;
    let out_dir = out_dir.unwrap_or_else(|| root.join("target").join("layer"));
    std::fs::create_dir_all(&out_dir).map_err(|source| crate::Error::Io {
        path: out_dir.clone(),
        source,
    })?;
    let path = out_dir.join(MANIFEST);
    let text = serde_json::to_string_pretty(&manifest(&library)).expect("a JSON value") + "\n";
    std::fs::write(&path, text).map_err(|source| crate::Error::Io { path, source })?;
    Ok(out_dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manifest_names_the_layer_and_its_settings() {
        let m = manifest(Path::new("/abs/libVkLayer_ommcheck.so"));
        assert_eq!(m["file_format_version"], "1.2.0");
        let layer = &m["layer"];
        assert_eq!(layer["name"], "VK_LAYER_OMMCHECK_validation");
        assert_eq!(layer["type"], "GLOBAL");
        assert_eq!(layer["api_version"], "1.4.360");
        assert_eq!(layer["library_path"], "/abs/libVkLayer_ommcheck.so");
        let envs: Vec<&str> = layer["features"]["settings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s["env"].as_str().unwrap())
            .collect();
        assert_eq!(
            envs,
            [
                "OMMCHECK_DUPLICATE_LIMIT",
                "OMMCHECK_LOG_FILE",
                "OMMCHECK_REPORT",
                "OMMCHECK_PROFILE",
                "OMMCHECK_BREAK_ON_ERROR",
                "OMMCHECK_TIER",
                "OMMCHECK_GPU_READBACK",
                "OMMCHECK_GPU_READBACK_MAX_BYTES"
            ]
        );
        assert_eq!(layer["features"]["settings"][0]["default"], 10);
        assert_eq!(layer["features"]["settings"][2]["flags"][2]["key"], "info");
        assert_eq!(layer["features"]["settings"][4]["key"], "break_on_error");
        assert_eq!(
            layer["instance_extensions"][0]["name"],
            "VK_EXT_layer_settings"
        );
    }
}
