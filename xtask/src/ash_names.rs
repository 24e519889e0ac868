//! The type and trait names of the ash version this workspace pins, read from
//! its source, so the generator refers to `vk::Name` exactly where ash has it.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

use regex::Regex;

use crate::Error;

pub struct AshNames {
    /// Structures, unions, enums, bitmasks and type aliases: `MicromapTriangleEXT`, ...
    pub types: BTreeSet<String>,
    /// Marker traits such as `ExtendsPhysicalDeviceFeatures2`.
    pub traits: BTreeSet<String>,
    pub version: String,
}

impl AshNames {
    /// Finds ash through `cargo metadata` of the workspace at `root`.
    pub fn load(root: &Path) -> Result<Self, Error> {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let output = Command::new(cargo)
            .args(["metadata", "--format-version", "1", "--manifest-path"])
            .arg(root.join("Cargo.toml"))
            .output()
            .map_err(|e| Error::Tool(format!("cargo metadata: {e}")))?;
        if !output.status.success() {
            return Err(Error::Tool(format!(
                "cargo metadata failed: {}",
                String::from_utf8_lossy(&output.stderr)
            )));
        }
        let metadata: serde_json::Value = serde_json::from_slice(&output.stdout)
            .map_err(|e| Error::Tool(format!("cargo metadata output: {e}")))?;
        let ash = metadata["packages"]
            .as_array()
            .into_iter()
            .flatten()
            .find(|p| p["name"] == "ash")
            .ok_or_else(|| Error::Tool("ash is not in the workspace's dependency graph".into()))?;
        let manifest = PathBuf::from(ash["manifest_path"].as_str().unwrap_or_default());
        let version = ash["version"].as_str().unwrap_or_default().to_string();
        let dir = manifest
            .parent()
            .ok_or_else(|| Error::Tool("ash manifest path has no parent".into()))?
            .join("src")
            .join("vk");
        Self::scan(&dir, version)
    }

    fn scan(dir: &Path, version: String) -> Result<Self, Error> {
        let type_re = Regex::new(r"(?m)^\s*(?:pub (?:struct|union|type) |(?:handle_nondispatchable|define_handle) ?! ?\( ?)(\w+)").expect("static regex");
        let trait_re = Regex::new(r"(?m)^\s*pub unsafe trait (\w+)").expect("static regex");
        let mut types = BTreeSet::new();
        let mut traits = BTreeSet::new();
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .map_err(|e| Error::Tool(format!("{}: {e}", dir.display())))?
            .filter_map(|entry| entry.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "rs"))
            .collect();
        files.sort();
        for file in files {
            let text = crate::read(&file)?;
            types.extend(type_re.captures_iter(&text).map(|c| c[1].to_string()));
            traits.extend(trait_re.captures_iter(&text).map(|c| c[1].to_string()));
        }
        if types.is_empty() {
            return Err(Error::Tool(format!(
                "no ash types found under {}",
                dir.display()
            )));
        }
        Ok(Self {
            types,
            traits,
            version,
        })
    }
}
