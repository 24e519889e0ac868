//! `cargo xtask lines`: the hand-written lines of code of the core, counted
//! as the design work counts them: blank lines, comment lines and inline
//! test modules (`#[cfg(test)] mod … { … }`) left out, and generated files
//! (under a `generated/` folder, or whose first lines say `@generated` or
//! "do not edit") not counted at all.

use std::path::Path;

use crate::Error;

/// Whether `source` is a generated file, by its first lines.
fn is_generated(source: &str) -> bool {
    let head: String = source.chars().take(300).collect::<String>().to_lowercase();
    head.contains("@generated") || head.contains("do not edit")
}

/// The counted lines of one file's source.
pub fn count_source(source: &str) -> usize {
    let mut count = 0;
    // Brace depth, and the depth at which a skipped test module started.
    let mut depth: i64 = 0;
    let mut skipping_from: Option<i64> = None;
    let mut after_cfg_test = false;
    for line in source.lines() {
        let text = line.trim();
        let opened = line.matches('{').count() as i64 - line.matches('}').count() as i64;
        if let Some(start) = skipping_from {
            depth += opened;
            if depth <= start {
                skipping_from = None;
            }
            continue;
        }
        if text.starts_with("#[cfg(test)]") {
            after_cfg_test = true;
            continue;
        }
        let is_module = text
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub ")
            .starts_with("mod ")
            && text.ends_with('{');
        if after_cfg_test && is_module {
            skipping_from = Some(depth);
            depth += opened;
            if depth <= skipping_from.unwrap_or(depth) {
                skipping_from = None;
            }
            after_cfg_test = false;
            continue;
        }
        if !text.is_empty() && !text.starts_with('#') {
            after_cfg_test = false;
        }
        depth += opened;
        if text.is_empty() || text.starts_with("//") {
            continue;
        }
        count += 1;
    }
    count
}

/// The counted lines of every hand-written `.rs` file under `dir`.
pub fn count_dir(dir: &Path) -> Result<usize, Error> {
    Ok(count_files(dir)?.iter().map(|(_, lines)| lines).sum())
}

/// Every hand-written `.rs` file under `dir` with its counted lines.
pub fn count_files(dir: &Path) -> Result<Vec<(std::path::PathBuf, usize)>, Error> {
    let mut files = Vec::new();
    let entries = std::fs::read_dir(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    for entry in entries {
        let path = entry
            .map_err(|source| Error::Io {
                path: dir.to_path_buf(),
                source,
            })?
            .path();
        if path.is_dir() {
            if path.file_name().is_some_and(|name| name != "generated") {
                files.extend(count_files(&path)?);
            }
        } else if path.extension().is_some_and(|e| e == "rs") {
            let source = crate::read(&path)?;
            if !is_generated(&source) {
                files.push((path, count_source(&source)));
            }
        }
    }
    Ok(files)
}

/// The report `cargo xtask lines` prints.
/// With `files`, each hand-written file of scene/, raw/ and model/ follows,
/// largest first.
pub fn report(root: &Path, files: bool) -> Result<String, Error> {
    let core = root.join("validator/src");
    let mut parts = Vec::new();
    let mut listed = Vec::new();
    let mut sum = 0;
    for part in ["scene", "raw", "model"] {
        let counted = count_files(&core.join(part))?;
        let lines: usize = counted.iter().map(|(_, lines)| lines).sum();
        sum += lines;
        parts.push(format!("{part} {lines}"));
        listed.extend(counted);
    }
    listed.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    let listing: String = if files {
        listed
            .iter()
            .map(|(path, lines)| {
                let shown = path.strip_prefix(root).unwrap_or(path);
                format!("\n{lines:>6} {}", shown.display())
            })
            .collect()
    } else {
        String::new()
    };
    // With the files, each top-level module of validator/src too, so a
    // figure can leave out modules that came as new features.
    let mut modules = String::new();
    if files {
        let mut entries: Vec<_> = std::fs::read_dir(&core)
            .map_err(|source| Error::Io {
                path: core.clone(),
                source,
            })?
            .filter_map(|entry| entry.ok().map(|e| e.path()))
            .collect();
        entries.sort();
        for path in entries {
            let lines = if path.is_dir() {
                count_dir(&path)?
            } else if path.extension().is_some_and(|e| e == "rs") {
                let source = crate::read(&path)?;
                if is_generated(&source) {
                    0
                } else {
                    count_source(&source)
                }
            } else {
                continue;
            };
            let shown = path.strip_prefix(root).unwrap_or(&path);
            modules.push_str(&format!("\n{lines:>6} {}", shown.display()));
        }
        modules.insert_str(0, "\nvalidator/src by top-level module:");
        modules.push_str("\nscene/, raw/ and model/ by file:");
    }
    Ok(format!(
        "hand-written lines (blank, comment, inline-test and generated lines left out):\n\
         validator/src/{{scene,raw,model}}: {sum} ({})\nvalidator/src: {}{modules}{listing}",
        parts.join(", "),
        count_dir(&core)?
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blank_comment_and_test_lines_are_left_out() {
        let source = "//! Docs.\nuse a;\n\n/// Doc.\nfn f() {\n    // why\n    g();\n}\n\n#[cfg(test)]\nmod tests {\n    #[test]\n    fn t() {\n        assert!(true);\n    }\n}\nfn after() {}\n";
        // use a; fn f() {; g(); }; fn after() {}
        assert_eq!(count_source(source), 5);
    }

    #[test]
    fn generated_files_are_recognised_by_their_first_lines() {
        assert!(is_generated(
            "// @generated by `cargo xtask generate`; do not edit.\nfn x() {}\n"
        ));
        assert!(!is_generated("//! Hand-written.\nfn x() {}\n"));
    }
}
