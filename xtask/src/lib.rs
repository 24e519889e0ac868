//! Project automation behind `cargo xtask`: code generation from the Vulkan
//! registry and the test driver. A library so that tests can call the
//! generators directly.
//!
//! Everything but `cargo xtask layer` is behind the `driver` feature (on by
//! default): the `cargo xtask` alias builds without it, so building the
//! layer does not first compile the test driver's dependencies, and the
//! binary hands other commands to a build with it (see main.rs). Code
//! generation needs only the `generate` feature, which `cargo xtask
//! generate` builds with: it does not build the crates it writes into.

#[cfg(feature = "generate")]
pub mod aliases;
#[cfg(feature = "generate")]
pub mod ash_names;
#[cfg(feature = "driver")]
pub mod bench;
#[cfg(feature = "generate")]
pub mod catalog;
#[cfg(feature = "generate")]
pub mod commands;
#[cfg(feature = "driver")]
mod drivers;
#[cfg(feature = "driver")]
pub mod faults;
#[cfg(feature = "generate")]
pub mod features;
#[cfg(feature = "driver")]
pub mod fuzz;
#[cfg(feature = "driver")]
pub mod fuzz_record;
#[cfg(feature = "driver")]
mod host;
#[cfg(feature = "generate")]
pub mod khr;
pub mod layer;
#[cfg(feature = "driver")]
pub mod lines;
#[cfg(feature = "driver")]
pub mod modules;
#[cfg(feature = "generate")]
pub mod names;
#[cfg(feature = "generate")]
pub mod registry;
#[cfg(feature = "driver")]
pub mod stress;
#[cfg(feature = "generate")]
pub mod structs;
#[cfg(feature = "driver")]
pub mod testing;

#[cfg(feature = "generate")]
use std::io::Write as _;
use std::path::{Path, PathBuf};
#[cfg(feature = "generate")]
use std::process::{Command, Stdio};

#[derive(Debug)]
pub enum Error {
    Registry(String),
    Tool(String),
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    Stale(String),
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Error::Registry(text) => write!(f, "registry: {text}"),
            Error::Tool(text) | Error::Stale(text) => f.write_str(text),
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

pub fn read(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The workspace root (the parent of `xtask/`).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask lives inside the workspace")
        .to_path_buf()
}

/// The target directory cargo uses here: `$CARGO_TARGET_DIR` (relative to
/// the workspace root), else `target/`.
pub fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .map(|dir| {
            if dir.is_absolute() {
                dir
            } else {
                root.join(dir)
            }
        })
        .unwrap_or_else(|| root.join("target"))
}

#[cfg(feature = "generate")]
/// `../shared/vulkan-registry` beside the workspace, where the project keeps
/// the registry of Vulkan 1.4.360.
pub fn default_registry() -> PathBuf {
    workspace_root().join("../shared/vulkan-registry")
}

#[cfg(feature = "generate")]
/// Formats generated source with the toolchain's rustfmt, so generated files
/// pass `cargo fmt --check` and regenerate byte for byte.
pub fn rustfmt(source: &str) -> Result<String, Error> {
    let mut child = Command::new("rustfmt")
        .args(["--edition", "2021", "--emit", "stdout", "--quiet"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| {
            Error::Tool(format!(
                "rustfmt: {e} (install it with `rustup component add rustfmt`)"
            ))
        })?;
    child
        .stdin
        .take()
        .expect("piped stdin")
        .write_all(source.as_bytes())
        .map_err(|e| Error::Tool(format!("rustfmt stdin: {e}")))?;
    let output = child
        .wait_with_output()
        .map_err(|e| Error::Tool(format!("rustfmt: {e}")))?;
    if !output.status.success() {
        return Err(Error::Tool(format!(
            "rustfmt rejected generated code: {}",
            String::from_utf8_lossy(&output.stderr)
        )));
    }
    String::from_utf8(output.stdout).map_err(|e| Error::Tool(format!("rustfmt output: {e}")))
}

#[cfg(feature = "generate")]
/// Paths (relative to the workspace root) and contents of every generated file.
pub fn generate(registry: &Path, root: &Path) -> Result<Vec<(PathBuf, String)>, Error> {
    let catalog = catalog::select(registry)?;
    let vk = registry::VkXml::load(&registry.join("vk.xml"))?;
    let ash = ash_names::AshNames::load(root)?;
    Ok(vec![
        (
            PathBuf::from("vuids/src/generated/catalog.rs"),
            rustfmt(&catalog::render(&catalog)?)?,
        ),
        (
            PathBuf::from("vuids/src/generated/khr.rs"),
            rustfmt(&khr::render(&vk, &ash)?)?,
        ),
        (
            PathBuf::from("vuids/src/generated/aliases.rs"),
            rustfmt(&aliases::render(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/model/names/generated.rs"),
            rustfmt(&names::render(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/model/generated.rs"),
            rustfmt(&structs::render_model(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/raw/generated.rs"),
            rustfmt(&(structs::render_reader(&vk)? + &features::render_reader(&vk)?))?,
        ),
        (
            PathBuf::from("validator/src/scene/format/generated.rs"),
            rustfmt(&(structs::render_scene_form(&vk)? + &features::render_scene_form(&vk)?))?,
        ),
        (
            PathBuf::from("validator/src/scene/resolve/generated.rs"),
            rustfmt(&(structs::render_resolver(&vk)? + &features::render_resolver()))?,
        ),
        (
            PathBuf::from("validator/src/scene/write/generated.rs"),
            rustfmt(&structs::render_writer(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/model/calls.rs"),
            rustfmt(&commands::render_model(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/checks/calls.rs"),
            rustfmt(&commands::render_checks(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/scene/format/calls.rs"),
            rustfmt(&commands::render_scene_form(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/scene/resolve/calls.rs"),
            rustfmt(&commands::render_resolver(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/scene/write/calls.rs"),
            rustfmt(&commands::render_writer(&vk)?)?,
        ),
        (
            PathBuf::from("validator/src/raw/calls.rs"),
            rustfmt(&commands::render_raw(&vk)?)?,
        ),
    ])
}

#[cfg(feature = "generate")]
/// `cargo xtask generate`: writes every generated file, or with `check`
/// fails naming the stale ones; returns the lines to print.
pub fn write_generated(registry: &Path, root: &Path, check: bool) -> Result<Vec<String>, Error> {
    if check {
        check_generated(registry, root)?;
        return Ok(vec![format!(
            "generated files are up to date with {}",
            registry.display()
        )]);
    }
    let mut lines = Vec::new();
    for (path, content) in generate(registry, root)? {
        let full = root.join(&path);
        std::fs::write(&full, content).map_err(|source| Error::Io { path: full, source })?;
        lines.push(format!("wrote {}", path.display()));
    }
    Ok(lines)
}

#[cfg(feature = "generate")]
/// Compares generated files with the committed ones; names each stale file.
pub fn check_generated(registry: &Path, root: &Path) -> Result<(), Error> {
    let mut stale = Vec::new();
    for (path, content) in generate(registry, root)? {
        let committed = std::fs::read_to_string(root.join(&path)).unwrap_or_default();
        if committed != content {
            let line = committed
                .lines()
                .zip(content.lines())
                .position(|(a, b)| a != b)
                .unwrap_or_else(|| committed.lines().count().min(content.lines().count()))
                + 1;
            stale.push(format!(
                "{} (first difference at line {line})",
                path.display()
            ));
        }
    }
    if stale.is_empty() {
        Ok(())
    } else {
        Err(Error::Stale(format!(
            "generated files are stale; run `cargo xtask generate`: {}",
            stale.join(", ")
        )))
    }
}
