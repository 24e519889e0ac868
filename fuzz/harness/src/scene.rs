//! Target (d), the scene parser and everything a scene drives (name
//! resolution, the checks, the simulator through `rays`). Two halves,
//! chosen by the first byte: arbitrary bytes as scene text (any input not
//! starting with a 0 byte, so a scene file is a seed as it is), and after a
//! 0 byte a structure-aware mutation that takes one of the corpus scenes
//! (`tests/scenes/corpus/`, chosen by the input) and replaces numbers in it
//! with values from the input, boundary values among them (0, 2^32 − 1,
//! 2^32, 2^53, −1, 1e308), so the mutated scene still gets past the parser
//! and exercises the resolver and checks. Oracle: the same findings, trace
//! and errors for the same scene (each is checked twice).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ommcheck::scene::{CheckOptions, Scene};
use serde_json::{Number, Value};

use crate::input::Input;

/// The corpus scenes: (directory, text), sorted by path so an input means
/// the same scene on every machine.
fn corpus() -> &'static [(PathBuf, String)] {
    static CORPUS: OnceLock<Vec<(PathBuf, String)>> = OnceLock::new();
    CORPUS.get_or_init(|| {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/corpus");
        let mut files = Vec::new();
        let mut dirs = vec![root];
        while let Some(dir) = dirs.pop() {
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for entry in entries.flatten() {
                let path = entry.path();
                if path.is_dir() {
                    dirs.push(path);
                } else if path.extension().is_some_and(|e| e == "json") {
                    files.push(path);
                }
            }
        }
        files.sort();
        files
            .into_iter()
            .filter_map(|path| {
                let text = std::fs::read_to_string(&path).ok()?;
                Some((path.parent()?.to_path_buf(), text))
            })
            .collect()
    })
}

pub fn run(data: &[u8]) {
    let Some(rest) = data.strip_prefix(&[0]) else {
        // Raw text; relative paths resolve in a directory that does not exist.
        let text = String::from_utf8_lossy(data).into_owned();
        check_twice(&text, Path::new("/nonexistent/ommcheck-fuzz"));
        return;
    };
    let mut input = Input::new(rest);
    let scenes = corpus();
    assert!(!scenes.is_empty(), "the scene corpus is missing");
    let (dir, text) = &scenes[usize::from(input.u16()) % scenes.len()];
    let Ok(mut value) = serde_json::from_str::<Value>(text) else {
        panic!("a corpus scene is not JSON");
    };
    let mut numbers = 0usize;
    count_numbers(&value, &mut numbers);
    if numbers > 0 {
        for _ in 0..1 + input.below(4) {
            let target = input.u32() as usize % numbers;
            let replacement = number(&mut input);
            let mut k = 0;
            replace_number(&mut value, target, &mut k, &replacement);
        }
    }
    check_twice(&value.to_string(), dir);
}

fn number(input: &mut Input<'_>) -> Value {
    let n = match input.below(10) {
        0 => Number::from(0u64),
        1 => Number::from(u64::from(u32::MAX)),
        2 => Number::from(1u64 << 32),
        3 => Number::from(1u64 << 53),
        4 => Number::from(-1i64),
        5 => Number::from_f64(1e308).unwrap_or(Number::from(0u64)),
        6 => Number::from(input.u64()),
        7 => Number::from(i64::from(input.i32())),
        8 => Number::from(u64::from(input.u8())),
        // JSON has no NaN or infinity; anything else an f32 holds.
        _ => Number::from_f64(f64::from(input.f32())).unwrap_or(Number::from(0u64)),
    };
    Value::Number(n)
}

fn count_numbers(value: &Value, n: &mut usize) {
    match value {
        Value::Number(_) => *n += 1,
        Value::Array(list) => list.iter().for_each(|v| count_numbers(v, n)),
        Value::Object(map) => map.values().for_each(|v| count_numbers(v, n)),
        _ => {}
    }
}

fn replace_number(value: &mut Value, target: usize, k: &mut usize, new: &Value) {
    match value {
        Value::Number(_) => {
            if *k == target {
                *value = new.clone();
            }
            *k += 1;
        }
        Value::Array(list) => list
            .iter_mut()
            .for_each(|v| replace_number(v, target, k, new)),
        Value::Object(map) => map
            .values_mut()
            .for_each(|v| replace_number(v, target, k, new)),
        _ => {}
    }
}

fn check_twice(text: &str, base_dir: &Path) {
    let first = check(text, base_dir);
    let second = check(text, base_dir);
    assert_eq!(first, second, "the same scene checked differently");
}

/// Parses, checks and traces the scene; what came out, as text.
fn check(text: &str, base_dir: &Path) -> String {
    let scene = match Scene::parse(text, "fuzz.json", base_dir) {
        Ok(scene) => scene,
        Err(e) => return format!("{e}"),
    };
    let options = CheckOptions::default();
    let checked = match scene.check(&options) {
        Ok(report) => format!("{:?}", report.findings),
        Err(e) => format!("{e}"),
    };
    let traced = match scene.trace(&options) {
        Ok(report) => format!("{}{}", report.text(), report.summary().line()),
        Err(e) => format!("{e}"),
    };
    format!("{checked}\n{traced}")
}
