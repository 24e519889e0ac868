//! The layer's settings: environment variables first, then the
//! application's `VkLayerSettingsCreateInfoEXT` (VK_EXT_layer_settings)
//! chained in `VkInstanceCreateInfo`, then the defaults; the same order of
//! precedence as the Khronos layers. Settings are per instance.
//!
//! | variable | setting (VK_EXT_layer_settings) | meaning | default |
//! | --- | --- | --- | --- |
//! | `OMMCHECK_DUPLICATE_LIMIT` | `duplicate_message_limit` (integer) | reports of one rule per instance; 0: unlimited | 10 |
//! | `OMMCHECK_LOG_FILE` | `log_filename` (string) | a file every reported message is appended to | none |
//! | `OMMCHECK_REPORT` | `report_flags` (strings, or one comma-separated string) | severities reported: `error`, `warning`, `info` | `error,warning` |
//! | `OMMCHECK_PROFILE` | `profile` (string) | device limits: `spec-minimum`, `permissive` or a JSON limits file | `spec-minimum` |
//! | `OMMCHECK_BREAK_ON_ERROR` | `break_on_error` (boolean) | raise SIGTRAP after reporting an error, to stop in a debugger | false |
//! | `OMMCHECK_TIER` | `tier` (string) | how far checks look: `params`, `state`, `content`, `simulate` | `content` |
//! | `OMMCHECK_GPU_READBACK` | `gpu_readback` (boolean) | copy device build inputs the host cannot read into layer memory before the build, and check them once the submission completes | true (from the `content` tier) |
//! | `OMMCHECK_GPU_READBACK_MAX_BYTES` | `gpu_readback_max_bytes` (integer) | the most bytes of layer memory readback copies hold at once per device | 268435456 (256 MiB) |

use std::path::{Path, PathBuf};

use ommcheck::{Device, Limits, Profile, Severity, Tier};

pub const DUPLICATE_LIMIT: &str = "OMMCHECK_DUPLICATE_LIMIT";
pub const LOG_FILE: &str = "OMMCHECK_LOG_FILE";
pub const REPORT: &str = "OMMCHECK_REPORT";
pub const PROFILE: &str = "OMMCHECK_PROFILE";
pub const BREAK_ON_ERROR: &str = "OMMCHECK_BREAK_ON_ERROR";
pub const TIER: &str = "OMMCHECK_TIER";
pub const GPU_READBACK: &str = "OMMCHECK_GPU_READBACK";
pub const GPU_READBACK_MAX_BYTES: &str = "OMMCHECK_GPU_READBACK_MAX_BYTES";

/// A setting as the layer manifest's `features.settings` describes it
/// (the format the Khronos layers use and vkconfig reads).
pub struct SettingDoc {
    /// The setting's key in the manifest.
    pub key: &'static str,
    /// The environment variable that sets it.
    pub env: &'static str,
    pub label: &'static str,
    pub description: &'static str,
    /// `INT`, `SAVE_FILE`, `FLAGS` or `STRING`.
    pub kind: &'static str,
    /// The default, as the JSON text of the manifest's `default`.
    pub default_json: &'static str,
    /// For `FLAGS`: the flags' keys.
    pub flags: &'static [&'static str],
}

/// Every setting, for the manifest.
pub const DOCUMENTED: [SettingDoc; 8] = [
    SettingDoc {
        key: "duplicate_message_limit",
        env: DUPLICATE_LIMIT,
        label: "Duplicate message limit",
        description: "How many times one rule is reported per instance; 0 reports every time.",
        kind: "INT",
        default_json: "10",
        flags: &[],
    },
    SettingDoc {
        key: "log_filename",
        env: LOG_FILE,
        label: "Log file",
        description: "A file every reported message is appended to.",
        kind: "SAVE_FILE",
        default_json: "\"\"",
        flags: &[],
    },
    SettingDoc {
        key: "report_flags",
        env: REPORT,
        label: "Message severities",
        description: "The severities reported, comma-separated: error, warning, info.",
        kind: "FLAGS",
        default_json: "[\"error\", \"warning\"]",
        flags: &["error", "warning", "info"],
    },
    SettingDoc {
        key: "profile",
        env: PROFILE,
        label: "Device limits",
        description: "The limits checks use: spec-minimum (what every device with the extension meets), permissive, or the path of a JSON object of limits overriding spec-minimum.",
        kind: "STRING",
        default_json: "\"spec-minimum\"",
        flags: &[],
    },
    SettingDoc {
        key: "break_on_error",
        env: BREAK_ON_ERROR,
        label: "Break on error",
        description: "Raise SIGTRAP after reporting an error, so a debugger stops at the call.",
        kind: "BOOL",
        default_json: "false",
        flags: &[],
    },
    SettingDoc {
        key: "tier",
        env: TIER,
        label: "Validation tier",
        description: "How far the checks look: params (the call's parameters and the device), state (+ tracked objects, buffers and memory), content (+ the bytes builds read: triangle arrays, data, index buffers), simulate (as content in the layer).",
        kind: "ENUM",
        default_json: "\"content\"",
        flags: &["params", "state", "content", "simulate"],
    },
    SettingDoc {
        key: "gpu_readback",
        env: GPU_READBACK,
        label: "GPU readback of build inputs",
        description: "From the content tier: before a device build whose inputs the host cannot read (device-local memory, or memory the GPU writes), copy the ranges it reads into layer-owned host-visible memory and check them once the submission is known to be complete. The application's memory is never written.",
        kind: "BOOL",
        default_json: "true",
        flags: &[],
    },
    SettingDoc {
        key: "gpu_readback_max_bytes",
        env: GPU_READBACK_MAX_BYTES,
        label: "GPU readback memory",
        description: "The most bytes of layer-owned memory the readback copies of one device hold at once; a build past it is reported as not checked.",
        kind: "INT",
        default_json: "268435456",
        flags: &[],
    },
];

/// A value the application gave a setting through VK_EXT_layer_settings.
#[derive(Clone, Debug, PartialEq)]
pub enum ApiValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Text(String),
}

/// The settings the application gave this layer through
/// `VkLayerSettingsCreateInfoEXT`, by setting name, in the order given.
pub type ApiSettings = Vec<(String, Vec<ApiValue>)>;

/// The Khronos layer's default duplicate-message limit.
pub const DEFAULT_DUPLICATE_LIMIT: u32 = 10;

/// What the layer reports and against which limits it checks.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Messages of one rule reported per instance before it goes quiet; 0: no limit.
    pub duplicate_limit: u32,
    /// Where every reported message is also appended.
    pub log_file: Option<PathBuf>,
    /// Severities reported; findings of other severities are dropped.
    pub report: Vec<Severity>,
    /// The device limits checks use (no create info carries them).
    pub limits: Limits,
    /// Whether the `profile` setting chose `limits`; otherwise the layer
    /// takes the limits the physical device reports over them.
    pub profile_chosen: bool,
    /// Raise SIGTRAP after reporting an error.
    pub break_on_error: bool,
    /// How far the checks look.
    pub tier: Tier,
    /// Copy device build inputs the host cannot read into layer memory and
    /// check them at completion (from the content tier on).
    pub gpu_readback: bool,
    /// The most bytes the readback copies of one device hold at once.
    pub gpu_readback_max_bytes: u64,
}

/// The default of `gpu_readback_max_bytes`: 256 MiB.
pub const DEFAULT_GPU_READBACK_MAX_BYTES: u64 = 256 << 20;

impl Default for Settings {
    fn default() -> Self {
        Self {
            duplicate_limit: DEFAULT_DUPLICATE_LIMIT,
            log_file: None,
            report: vec![Severity::Error, Severity::Warning],
            limits: Profile::SpecMinimum.limits(),
            profile_chosen: false,
            break_on_error: false,
            tier: Tier::default(),
            gpu_readback: true,
            gpu_readback_max_bytes: DEFAULT_GPU_READBACK_MAX_BYTES,
        }
    }
}

impl Settings {
    pub fn reports(&self, severity: Severity) -> bool {
        self.report.contains(&severity)
    }
}

/// One setting's value as text: the environment variable, else the
/// API's values joined by commas (booleans as true/false), else None.
fn lookup(
    variable: &impl Fn(&str) -> Option<String>,
    api: &ApiSettings,
    doc: &SettingDoc,
) -> Option<(String, String)> {
    if let Some(value) = variable(doc.env) {
        return Some((doc.env.to_string(), value));
    }
    let (_, values) = api.iter().rev().find(|(name, _)| name == doc.key)?;
    let text: Vec<String> = values
        .iter()
        .map(|v| match v {
            ApiValue::Bool(b) => b.to_string(),
            ApiValue::Int(i) => i.to_string(),
            ApiValue::Float(f) => f.to_string(),
            ApiValue::Text(t) => t.clone(),
        })
        .collect();
    Some((format!("VkLayerSettingEXT {}", doc.key), text.join(",")))
}

fn doc(env: &str) -> &'static SettingDoc {
    DOCUMENTED
        .iter()
        .find(|d| d.env == env)
        .expect("every variable is documented")
}

/// Settings from `variable` (the environment, in the layer), `api` (the
/// application's VK_EXT_layer_settings values, used where no variable is
/// set) and `read_file` (for a JSON limits file), with a sentence for each
/// value that could not be used; such a setting keeps its default.
pub fn parse(
    variable: impl Fn(&str) -> Option<String>,
    api: &ApiSettings,
    read_file: impl Fn(&Path) -> std::io::Result<String>,
) -> (Settings, Vec<String>) {
    let mut settings = Settings::default();
    let mut problems = Vec::new();
    for (name, _) in api {
        if DOCUMENTED.iter().all(|d| d.key != name) {
            problems.push(format!(
                "VkLayerSettingEXT `{name}` is not a setting of this layer; ignored"
            ));
        }
    }
    let get = |env: &str| lookup(&variable, api, doc(env));
    if let Some((from, value)) = get(DUPLICATE_LIMIT) {
        match value.trim().parse::<u32>() {
            Ok(limit) => settings.duplicate_limit = limit,
            Err(_) => problems.push(format!(
                "{from}={value:?} is not a whole number; using {DEFAULT_DUPLICATE_LIMIT}"
            )),
        }
    }
    if let Some((_, value)) = get(LOG_FILE).filter(|(_, v)| !v.is_empty()) {
        settings.log_file = Some(PathBuf::from(value));
    }
    if let Some((from, value)) = get(REPORT) {
        let mut report = Vec::new();
        for word in value.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            match word.to_ascii_lowercase().as_str() {
                "error" => report.push(Severity::Error),
                "warning" | "warn" => report.push(Severity::Warning),
                "info" => report.push(Severity::Info),
                _ => problems.push(format!(
                    "{from}: `{word}` is not error, warning or info; ignored"
                )),
            }
        }
        settings.report = report;
    }
    if let Some((from, value)) = get(PROFILE).filter(|(_, v)| !v.is_empty()) {
        match Profile::from_name(&value) {
            Some(profile) => {
                settings.limits = profile.limits();
                settings.profile_chosen = true;
            }
            None => match read_file(Path::new(&value)) {
                Ok(json) => match Device::limits_from_json(Profile::SpecMinimum, &json) {
                    Ok(limits) => {
                        settings.limits = limits;
                        settings.profile_chosen = true;
                    }
                    Err(e) => problems.push(format!(
                        "{from}: {value} is not a JSON object of limits ({e}); using spec-minimum"
                    )),
                },
                Err(e) => problems.push(format!(
                    "{from}={value:?} is neither spec-minimum, permissive nor a readable file ({e}); using spec-minimum"
                )),
            },
        }
    }
    if let Some((from, value)) = get(BREAK_ON_ERROR) {
        match boolean(&value) {
            Some(on) => settings.break_on_error = on,
            None => problems.push(format!(
                "{from}={value:?} is not a boolean (true or false); not breaking"
            )),
        }
    }
    if let Some((from, value)) = get(GPU_READBACK) {
        match boolean(&value) {
            Some(on) => settings.gpu_readback = on,
            None => problems.push(format!(
                "{from}={value:?} is not a boolean (true or false); reading back"
            )),
        }
    }
    if let Some((from, value)) = get(GPU_READBACK_MAX_BYTES) {
        match value.trim().parse::<u64>() {
            Ok(bytes) => settings.gpu_readback_max_bytes = bytes,
            Err(_) => problems.push(format!(
                "{from}={value:?} is not a whole number of bytes; using {DEFAULT_GPU_READBACK_MAX_BYTES}"
            )),
        }
    }
    if let Some((from, value)) = get(TIER) {
        match value.parse::<Tier>() {
            Ok(tier) => settings.tier = tier,
            Err(e) => problems.push(format!("{from}: {e}; using content")),
        }
    }
    (settings, problems)
}

/// A boolean setting's value: true/false, on/off, yes/no, 1/0 in any case
/// (empty is false); None for anything else.
fn boolean(value: &str) -> Option<bool> {
    match value.trim().to_ascii_lowercase().as_str() {
        "1" | "true" | "on" | "yes" => Some(true),
        "0" | "false" | "off" | "no" | "" => Some(false),
        _ => None,
    }
}

/// The settings of an instance: this process's environment over `api`.
pub fn for_instance(api: &ApiSettings) -> (Settings, Vec<String>) {
    parse(
        |name| std::env::var(name).ok(),
        api,
        |path| std::fs::read_to_string(path),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn parse_with(vars: &[(&str, &str)], file: Option<&str>) -> (Settings, Vec<String>) {
        let vars: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        parse_with_api(vars, &Vec::new(), file)
    }

    fn parse_with_api(
        vars: HashMap<String, String>,
        api: &ApiSettings,
        file: Option<&str>,
    ) -> (Settings, Vec<String>) {
        parse(
            |name| vars.get(name).cloned(),
            api,
            |_| {
                file.map(str::to_string)
                    .ok_or_else(|| std::io::ErrorKind::NotFound.into())
            },
        )
    }

    #[test]
    fn defaults_without_variables() {
        let (settings, problems) = parse_with(&[], None);
        assert_eq!(settings, Settings::default());
        assert_eq!(settings.duplicate_limit, 10);
        assert!(settings.reports(Severity::Error) && !settings.reports(Severity::Info));
        assert!(problems.is_empty());
    }

    #[test]
    fn every_variable_is_read() {
        let (settings, problems) = parse_with(
            &[
                (DUPLICATE_LIMIT, "0"),
                (LOG_FILE, "/tmp/omm.log"),
                (REPORT, "error, INFO"),
                (PROFILE, "permissive"),
            ],
            None,
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 0);
        assert_eq!(settings.log_file, Some(PathBuf::from("/tmp/omm.log")));
        assert_eq!(settings.report, [Severity::Error, Severity::Info]);
        assert_eq!(settings.limits, Profile::Permissive.limits());
    }

    #[test]
    fn a_limits_file_overrides_spec_minimum() {
        let (settings, problems) = parse_with(
            &[(PROFILE, "limits.json")],
            Some(r#"{"maxOpacity2StateSubdivisionLevel": 9}"#),
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.limits.max_opacity2_state_subdivision_level, 9);
        assert_eq!(settings.limits.max_opacity4_state_subdivision_level, 3);
    }

    #[test]
    fn bad_values_keep_defaults_and_say_why() {
        let (settings, problems) = parse_with(
            &[
                (DUPLICATE_LIMIT, "-3"),
                (REPORT, "error,loud"),
                (PROFILE, "missing.json"),
            ],
            None,
        );
        assert_eq!(settings.duplicate_limit, DEFAULT_DUPLICATE_LIMIT);
        assert_eq!(settings.report, [Severity::Error]);
        assert_eq!(settings.limits, Profile::SpecMinimum.limits());
        assert_eq!(problems.len(), 3, "{problems:?}");
        assert!(problems[1].contains("`loud`"));
        let (_, problems) = parse_with(&[(PROFILE, "bad.json")], Some(r#"{"maxBogus": 1}"#));
        assert!(
            problems[0].contains("not a JSON object of limits"),
            "{problems:?}"
        );
    }

    fn api(settings: &[(&str, Vec<ApiValue>)]) -> ApiSettings {
        settings
            .iter()
            .map(|(name, values)| (name.to_string(), values.clone()))
            .collect()
    }

    #[test]
    fn api_settings_apply_where_no_variable_is_set() {
        let given = api(&[
            ("duplicate_message_limit", vec![ApiValue::Int(3)]),
            (
                "report_flags",
                vec![
                    ApiValue::Text("error".into()),
                    ApiValue::Text("info".into()),
                ],
            ),
            ("break_on_error", vec![ApiValue::Bool(true)]),
            ("profile", vec![ApiValue::Text("permissive".into())]),
            ("tier", vec![ApiValue::Text("state".into())]),
        ]);
        let (settings, problems) = parse_with_api(HashMap::new(), &given, None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 3);
        assert_eq!(settings.report, [Severity::Error, Severity::Info]);
        assert!(settings.break_on_error);
        assert_eq!(settings.limits, Profile::Permissive.limits());
        assert_eq!(settings.tier, Tier::State);
    }

    #[test]
    fn variables_take_precedence_over_api_settings() {
        let given = api(&[("duplicate_message_limit", vec![ApiValue::Int(3)])]);
        let vars = HashMap::from([(DUPLICATE_LIMIT.to_string(), "7".to_string())]);
        let (settings, problems) = parse_with_api(vars, &given, None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 7);
    }

    #[test]
    fn unknown_and_malformed_api_settings_are_reported() {
        let given = api(&[
            ("validate_sync", vec![ApiValue::Bool(true)]),
            ("duplicate_message_limit", vec![ApiValue::Float(2.5)]),
            ("break_on_error", vec![ApiValue::Text("sometimes".into())]),
        ]);
        let (settings, problems) = parse_with_api(HashMap::new(), &given, None);
        assert_eq!(settings.duplicate_limit, DEFAULT_DUPLICATE_LIMIT);
        assert!(!settings.break_on_error);
        assert_eq!(problems.len(), 3, "{problems:?}");
        assert!(problems[0].contains("`validate_sync`"), "{problems:?}");
        assert!(problems[1].contains("VkLayerSettingEXT duplicate_message_limit"));
    }
}
