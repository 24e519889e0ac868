//! This machine: whether it runs CI, whether we are root, and how steps and
//! Debian packages are run and installed. Below the test driver and the
//! driver builds, which both use it.

use std::process::Command;

use crate::Error;

/// True when running under CI (`CI=true`), where a missing prerequisite is a
/// failure rather than a skipped test.
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// Runs one step of a command, failing with its description.
pub(crate) fn run_step(description: &str, command: &mut Command) -> Result<(), Error> {
    eprintln!("xtask: {description}: {command:?}");
    let status = command
        .status()
        .map_err(|e| Error::Tool(format!("{description}: could not start: {e}")))?;
    if status.success() {
        Ok(())
    } else {
        Err(Error::Tool(format!("{description} failed ({status})")))
    }
}

/// Whether this process runs as root, so apt-get needs no sudo.
pub(crate) fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|out| String::from_utf8_lossy(&out.stdout).trim() == "0")
}

/// Installs Debian packages with apt-get (through sudo when not root).
pub(crate) fn apt_install(packages: &[&str]) -> Result<(), Error> {
    let sudo: &[&str] = if is_root() { &[] } else { &["sudo"] };
    let mut update = Command::new(sudo.first().copied().unwrap_or("apt-get"));
    if !sudo.is_empty() {
        update.arg("apt-get");
    }
    update.arg("update");
    run_step("apt-get update", &mut update)?;
    let mut install = Command::new(sudo.first().copied().unwrap_or("apt-get"));
    if !sudo.is_empty() {
        install.arg("apt-get");
    }
    install
        .env("DEBIAN_FRONTEND", "noninteractive")
        .args(["install", "-y", "--no-install-recommends"])
        .args(packages);
    run_step("apt-get install", &mut install)
}
