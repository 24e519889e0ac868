//! The layer's settings, from four sources in this order of precedence
//! (the Khronos layers' order): the environment (`OMMCHECK_*`, then the
//! Khronos settings library's `VK_OMMCHECK_VALIDATION_<KEY>`), the
//! application's `VkLayerSettingsCreateInfoEXT` (VK_EXT_layer_settings)
//! chained in `VkInstanceCreateInfo`, the `vk_layer_settings.txt` file
//! vkconfig writes (lines `ommcheck_validation.<key> = <value>`), then the
//! default. A value that cannot be used is reported as a warning and the
//! next source's value applies, so a bad value never silences the layer.
//! Settings are per instance; their names, types and defaults are in
//! [`DOCUMENTED`], and docs/layer.md describes them.

use std::path::{Path, PathBuf};

use ommcheck::report::message_id;
use ommcheck::{Device, Limits, Profile, Severity, Tier};

pub use crate::setting_docs::*;

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

/// This layer's lines of a `vk_layer_settings.txt`: the file's path (for
/// messages) and each `(key, value)` in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FileSettings {
    pub path: PathBuf,
    pub values: Vec<(String, String)>,
}

/// [`LAYER_NAME`] as the C string VK_EXT_layer_settings names layers by.
pub const LAYER_NAME_C: &std::ffi::CStr = c"VK_LAYER_OMMCHECK_validation";

/// The settings file's name.
pub const SETTINGS_FILE: &str = "vk_layer_settings.txt";
/// The variable naming the settings file or the directory holding it.
pub const SETTINGS_PATH_VAR: &str = "VK_LAYER_SETTINGS_PATH";

/// The Khronos layer's default duplicate-message limit.
pub const DEFAULT_DUPLICATE_LIMIT: u32 = 10;

/// Messages `message_id_filter` mutes: by id (case-insensitive) or by
/// MessageID number.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MessageFilter {
    /// Lower-case VUIDs and rule ids.
    names: Vec<String>,
    numbers: Vec<u32>,
}

impl MessageFilter {
    /// Whether the message with this VUID or rule id is muted.
    pub fn mutes(&self, id: &str) -> bool {
        self.numbers.contains(&message_id(id))
            || self.names.iter().any(|name| name.eq_ignore_ascii_case(id))
    }

    /// The filter of a comma-separated list: `0x`-prefixed hexadecimal and
    /// (signed, as `messageIdNumber` is) decimal numbers, and names.
    fn parse(value: &str) -> Result<Self, String> {
        let mut filter = Self::default();
        for word in value.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            let lower = word.to_ascii_lowercase();
            if let Some(hex) = lower.strip_prefix("0x") {
                let number = u32::from_str_radix(hex, 16)
                    .map_err(|_| format!("`{word}` is not a 32-bit hexadecimal MessageID"))?;
                filter.numbers.push(number);
            } else if lower
                .trim_start_matches('-')
                .bytes()
                .all(|b| b.is_ascii_digit())
            {
                let number = lower
                    .parse::<u32>()
                    .or_else(|_| lower.parse::<i32>().map(|n| n as u32))
                    .map_err(|_| format!("`{word}` is not a 32-bit MessageID"))?;
                filter.numbers.push(number);
            } else {
                filter.names.push(lower);
            }
        }
        Ok(filter)
    }
}

/// What the layer does with a reported message itself (`debug_action`);
/// the application's callbacks receive every reported message regardless.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actions {
    /// Write it to the log file, or to stderr when no callback exists.
    pub log: bool,
    /// Raise SIGTRAP after reporting it.
    pub break_into_debugger: bool,
}

impl Default for Actions {
    fn default() -> Self {
        Self {
            log: true,
            break_into_debugger: false,
        }
    }
}

impl Actions {
    /// The actions of a comma-separated list of `debug_action` flags, by
    /// our names or the Khronos layer's.
    fn parse(value: &str) -> Result<Self, String> {
        let mut actions = Self {
            log: false,
            break_into_debugger: false,
        };
        let mut any = false;
        for word in value.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            any = true;
            let lower = word.to_ascii_lowercase();
            match lower.strip_prefix("vk_dbg_layer_action_").unwrap_or(&lower) {
                "log" | "log_msg" => actions.log = true,
                "break" => actions.break_into_debugger = true,
                // The application's callbacks are always called; Windows's
                // debugger output does not exist here.
                "callback" | "ignore" | "debug_output" => {}
                _ => return Err(format!("`{word}` is not log, callback, break or ignore")),
            }
        }
        if any {
            Ok(actions)
        } else {
            Err("names no action (use ignore for none)".into())
        }
    }
}

/// What the layer reports and against which limits it checks.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Messages of one rule reported per instance before it goes quiet; 0: no limit.
    pub duplicate_limit: u32,
    /// Where every reported message is also appended.
    pub log_file: Option<PathBuf>,
    /// Severities reported; findings of other severities are dropped.
    pub report: Vec<Severity>,
    /// Messages never reported.
    pub message_filter: MessageFilter,
    /// What the layer does with a reported message itself.
    pub actions: Actions,
    /// The device limits checks use (no create info carries them).
    pub limits: Limits,
    /// Whether the `profile` setting chose `limits`; otherwise the layer
    /// takes the limits the physical device reports over them.
    pub profile_chosen: bool,
    /// How far the checks look.
    pub tier: Tier,
    /// Copy device build inputs the host cannot read into layer memory and
    /// check them at completion (from the content tier on).
    pub gpu_readback: bool,
    /// The most bytes the readback copies of one device hold at once.
    pub gpu_readback_max_bytes: u64,
    /// The most bytes read of each input of an indirect build whose extent
    /// its range infos decide (from its start towards its buffer's end).
    pub gpu_readback_indirect_max_bytes: u64,
}

/// The default of `gpu_readback_max_bytes`: 256 MiB.
pub const DEFAULT_GPU_READBACK_MAX_BYTES: u64 = 256 << 20;

/// The default of `gpu_readback_indirect_max_bytes`: 16 MiB, the 32-bit
/// opacity indices of 4 Mi triangles or 256 Ki instances. A separate bound
/// from `gpu_readback_max_bytes` because an input read to the end of its
/// buffer may lie in a large suballocated buffer: without it one indirect
/// build could take the whole readback memory.
pub const DEFAULT_GPU_READBACK_INDIRECT_MAX_BYTES: u64 = 16 << 20;

impl Default for Settings {
    fn default() -> Self {
        Self {
            duplicate_limit: DEFAULT_DUPLICATE_LIMIT,
            log_file: None,
            report: vec![Severity::Error, Severity::Warning],
            message_filter: MessageFilter::default(),
            actions: Actions::default(),
            limits: Profile::SpecMinimum.limits(),
            profile_chosen: false,
            tier: Tier::default(),
            gpu_readback: true,
            gpu_readback_max_bytes: DEFAULT_GPU_READBACK_MAX_BYTES,
            gpu_readback_indirect_max_bytes: DEFAULT_GPU_READBACK_INDIRECT_MAX_BYTES,
        }
    }
}

impl Settings {
    pub fn reports(&self, severity: Severity) -> bool {
        self.report.contains(&severity)
    }
}

/// Where settings come from, besides the defaults.
pub struct Sources<'a> {
    /// The environment (a lookup, so tests can give their own).
    pub variable: &'a dyn Fn(&str) -> Option<String>,
    pub api: &'a ApiSettings,
    pub file: &'a FileSettings,
}

impl Sources<'_> {
    /// Every value given for `doc`, in order of precedence, each with the
    /// words naming where it came from.
    fn values(&self, doc: &SettingDoc) -> Vec<(String, String)> {
        let mut values = Vec::new();
        for name in [doc.env.to_string(), khronos_style_variable(doc.key)] {
            if let Some(value) = (self.variable)(&name) {
                values.push((name, value));
            }
        }
        if let Some((_, given)) = self.api.iter().rev().find(|(name, _)| name == doc.key) {
            let text: Vec<String> = given
                .iter()
                .map(|v| match v {
                    ApiValue::Bool(b) => b.to_string(),
                    ApiValue::Int(i) => i.to_string(),
                    ApiValue::Float(f) => f.to_string(),
                    ApiValue::Text(t) => t.clone(),
                })
                .collect();
            values.push((format!("VkLayerSettingEXT {}", doc.key), text.join(",")));
        }
        if let Some((_, value)) = self.file.values.iter().rev().find(|(k, _)| k == doc.key) {
            values.push((
                format!("{}: {FILE_PREFIX}.{}", self.file.path.display(), doc.key),
                value.clone(),
            ));
        }
        values
    }

    /// The first of `doc`'s values that `parse` accepts, or None (the
    /// default applies). Each rejected value adds a sentence to `problems`
    /// saying why and what applies instead.
    fn resolve<T>(
        &self,
        doc: &SettingDoc,
        problems: &mut Vec<String>,
        parse: impl Fn(&str) -> Result<T, String>,
    ) -> Option<T> {
        let mut rejected = Vec::new();
        let mut chosen = None;
        for (from, value) in self.values(doc) {
            match parse(&value) {
                Ok(parsed) => {
                    chosen = Some((parsed, from));
                    break;
                }
                Err(why) => rejected.push(format!("{from}={value:?}: {why}")),
            }
        }
        let instead = match &chosen {
            Some((_, from)) => format!("using {from}"),
            None if matches!(doc.default_json, r#""""# | "[]") => "using the default".to_string(),
            None => format!("using the default, {}", doc.default_json),
        };
        problems.extend(rejected.into_iter().map(|r| format!("{r}; {instead}")));
        chosen.map(|(parsed, _)| parsed)
    }
}

/// The variable the Khronos layers' settings library would read for `key`
/// of this layer: `VK_OMMCHECK_VALIDATION_<KEY>`, after `OMMCHECK_<...>`.
pub fn khronos_style_variable(key: &str) -> String {
    format!("VK_{FILE_PREFIX}_{key}").to_ascii_uppercase()
}

fn doc(env: &str) -> &'static SettingDoc {
    DOCUMENTED
        .iter()
        .find(|d| d.env == env)
        .expect("every variable is documented")
}

/// Settings from `sources`, reading a JSON limits file through
/// `read_file`, with a sentence for each value that could not be used.
pub fn parse(
    sources: &Sources<'_>,
    read_file: impl Fn(&Path) -> std::io::Result<String>,
) -> (Settings, Vec<String>) {
    let mut settings = Settings::default();
    let mut problems = Vec::new();
    for (name, _) in sources.api {
        if DOCUMENTED.iter().all(|d| d.key != name) {
            problems.push(format!(
                "VkLayerSettingEXT `{name}` is not a setting of this layer; ignored"
            ));
        }
    }
    for (key, _) in &sources.file.values {
        if DOCUMENTED.iter().all(|d| d.key != key) {
            problems.push(format!(
                "{}: `{FILE_PREFIX}.{key}` is not a setting of this layer; ignored",
                sources.file.path.display()
            ));
        }
    }
    let problems_ref = &mut problems;
    let mut get = |env: &str, parse: &dyn Fn(&str) -> Result<Setter, String>| {
        if let Some(set) = sources.resolve(doc(env), problems_ref, parse) {
            set(&mut settings);
        }
    };
    get(DUPLICATE_LIMIT, &|v| {
        let limit = whole_number::<u32>(v)?;
        Ok(Box::new(move |s| s.duplicate_limit = limit))
    });
    get(LOG_FILE, &|v| {
        let trimmed = v.trim();
        let file = (!trimmed.is_empty()
            && !["stdout", "stderr"]
                .iter()
                .any(|s| trimmed.eq_ignore_ascii_case(s)))
        .then(|| PathBuf::from(trimmed));
        Ok(Box::new(move |s| s.log_file = file))
    });
    get(REPORT, &|v| {
        let report = severities(v)?;
        Ok(Box::new(move |s| s.report = report))
    });
    get(MESSAGE_ID_FILTER, &|v| {
        let filter = MessageFilter::parse(v)?;
        Ok(Box::new(move |s| s.message_filter = filter))
    });
    get(DEBUG_ACTION, &|v| {
        let actions = Actions::parse(v)?;
        Ok(Box::new(move |s| s.actions = actions))
    });
    get(BREAK_ON_ERROR, &|v| {
        let on = boolean(v)?;
        Ok(Box::new(move |s| s.actions.break_into_debugger |= on))
    });
    get(PROFILE, &|v| {
        // Empty (what vkconfig writes for the default): the device's limits.
        if v.trim().is_empty() {
            return Ok(Box::new(|_| {}));
        }
        let limits = limits(v.trim(), &read_file)?;
        Ok(Box::new(move |s| {
            s.limits = limits;
            s.profile_chosen = true;
        }))
    });
    get(TIER, &|v| {
        let tier = v.parse::<Tier>()?;
        Ok(Box::new(move |s| s.tier = tier))
    });
    get(GPU_READBACK, &|v| {
        let on = boolean(v)?;
        Ok(Box::new(move |s| s.gpu_readback = on))
    });
    get(GPU_READBACK_MAX_BYTES, &|v| {
        let bytes = whole_number::<u64>(v)?;
        Ok(Box::new(move |s| s.gpu_readback_max_bytes = bytes))
    });
    get(GPU_READBACK_INDIRECT_MAX_BYTES, &|v| {
        let bytes = whole_number::<u64>(v)?;
        Ok(Box::new(move |s| s.gpu_readback_indirect_max_bytes = bytes))
    });
    (settings, problems)
}

/// What a value accepted for a setting does to the settings.
type Setter = Box<dyn FnOnce(&mut Settings)>;

fn whole_number<T: std::str::FromStr>(value: &str) -> Result<T, String> {
    value
        .trim()
        .parse()
        .map_err(|_| "not a whole number in range".to_string())
}

/// The severities of a comma-separated `report_flags` value; any word that
/// names none rejects the whole value.
fn severities(value: &str) -> Result<Vec<Severity>, String> {
    let mut report = Vec::new();
    for word in value.split(',').map(str::trim).filter(|w| !w.is_empty()) {
        let severity = match word.to_ascii_lowercase().as_str() {
            "error" => Severity::Error,
            "warning" | "warn" => Severity::Warning,
            "info" => Severity::Info,
            _ => return Err(format!("`{word}` is not error, warning or info")),
        };
        report.push(severity);
    }
    if report.is_empty() {
        return Err("names no severity (use debug_action=ignore to report nothing)".into());
    }
    Ok(report)
}

/// The limits a `profile` value names: a profile, in any case, or a file.
fn limits(
    value: &str,
    read_file: &impl Fn(&Path) -> std::io::Result<String>,
) -> Result<Limits, String> {
    if let Some(profile) = Profile::from_name(&value.to_ascii_lowercase()) {
        return Ok(profile.limits());
    }
    let json = read_file(Path::new(value))
        .map_err(|e| format!("neither spec-minimum, permissive nor a readable file ({e})"))?;
    Device::limits_from_json(Profile::SpecMinimum, &json)
        .map_err(|e| format!("not a JSON object of limits ({e})"))
}

/// A boolean setting's value: true/false, on/off, yes/no, 1/0 in any case
/// (empty is false).
fn boolean(value: &str) -> Result<bool, String> {
    match value.trim().to_ascii_lowercase().as_str() {
        "1" | "true" | "on" | "yes" => Ok(true),
        "0" | "false" | "off" | "no" | "" => Ok(false),
        _ => Err("not a boolean (true or false)".into()),
    }
}

/// This layer's settings in the text of a `vk_layer_settings.txt`: lines
/// `ommcheck_validation.<key> = <value>` (the prefix in any case), where
/// `#` starts a comment, as in the Khronos layers' reader; blank lines and
/// other layers' lines are skipped.
pub fn parse_file(path: &Path, text: &str) -> FileSettings {
    let values = text
        .lines()
        .filter_map(|line| line.split('#').next())
        .filter_map(|line| line.split_once('='))
        .filter_map(|(name, value)| {
            let (prefix, key) = name.trim().split_once('.')?;
            prefix
                .eq_ignore_ascii_case(FILE_PREFIX)
                .then(|| (key.trim().to_string(), value.trim().to_string()))
        })
        .collect();
    FileSettings {
        path: path.to_path_buf(),
        values,
    }
}

/// Where vkconfig keeps the settings file it writes on Linux:
/// `$XDG_DATA_HOME/vulkan/settings.d`, else `~/.local/share/vulkan/settings.d`.
pub fn vkconfig_dir(xdg_data_home: Option<PathBuf>, home: Option<PathBuf>) -> Option<PathBuf> {
    let data = xdg_data_home
        .filter(|dir| !dir.as_os_str().is_empty())
        .or_else(|| home.map(|home| home.join(".local").join("share")))?;
    Some(data.join("vulkan").join("settings.d"))
}

/// The settings file that applies, in the Khronos layers' order: the one
/// vkconfig wrote into `vkconfig_dir`, else the one `VK_LAYER_SETTINGS_PATH`
/// names (a file, or a directory holding `vk_layer_settings.txt`), else the
/// one in the working directory; None when none exists.
pub fn settings_file_path(
    vkconfig_dir: Option<PathBuf>,
    settings_path: Option<PathBuf>,
    working_dir: Option<PathBuf>,
) -> Option<PathBuf> {
    let named = settings_path.map(|path| {
        if path.is_dir() {
            path.join(SETTINGS_FILE)
        } else {
            path
        }
    });
    vkconfig_dir
        .map(|dir| dir.join(SETTINGS_FILE))
        .into_iter()
        .chain(named)
        .chain(working_dir.map(|dir| dir.join(SETTINGS_FILE)))
        .find(|path| path.is_file())
}

/// The settings of an instance: this process's environment, then `api`,
/// then the settings file (read at each `vkCreateInstance`).
pub fn for_instance(api: &ApiSettings) -> (Settings, Vec<String>) {
    let path = settings_file_path(
        vkconfig_dir(
            std::env::var_os("XDG_DATA_HOME").map(PathBuf::from),
            std::env::var_os("HOME").map(PathBuf::from),
        ),
        std::env::var_os(SETTINGS_PATH_VAR).map(PathBuf::from),
        std::env::current_dir().ok(),
    );
    let mut problems = Vec::new();
    let file = match path {
        Some(path) => match std::fs::read_to_string(&path) {
            Ok(text) => parse_file(&path, &text),
            Err(e) => {
                problems.push(format!("{} cannot be read ({e}); ignored", path.display()));
                FileSettings::default()
            }
        },
        None => FileSettings::default(),
    };
    let (settings, mut more) = parse(
        &Sources {
            variable: &|name| std::env::var(name).ok(),
            api,
            file: &file,
        },
        |path| std::fs::read_to_string(path),
    );
    problems.append(&mut more);
    (settings, problems)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Settings from `vars`, `api` and `file`, with `limits_file` as the
    /// text of every limits file.
    fn parse_from(
        vars: &[(&str, &str)],
        api: &ApiSettings,
        file: &FileSettings,
        limits_file: Option<&str>,
    ) -> (Settings, Vec<String>) {
        let vars: HashMap<String, String> = vars
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        parse(
            &Sources {
                variable: &|name| vars.get(name).cloned(),
                api,
                file,
            },
            |_| {
                limits_file
                    .map(str::to_string)
                    .ok_or_else(|| std::io::ErrorKind::NotFound.into())
            },
        )
    }

    fn parse_with(vars: &[(&str, &str)], limits_file: Option<&str>) -> (Settings, Vec<String>) {
        parse_from(vars, &Vec::new(), &FileSettings::default(), limits_file)
    }

    fn api(settings: &[(&str, Vec<ApiValue>)]) -> ApiSettings {
        settings
            .iter()
            .map(|(name, values)| (name.to_string(), values.clone()))
            .collect()
    }

    fn text(value: &str) -> Vec<ApiValue> {
        vec![ApiValue::Text(value.into())]
    }

    #[test]
    fn the_manifest_api_version_is_the_headers_the_layer_is_built_with() {
        let v = ash::vk::HEADER_VERSION_COMPLETE;
        let headers = format!(
            "{}.{}.{}",
            ash::vk::api_version_major(v),
            ash::vk::api_version_minor(v),
            ash::vk::HEADER_VERSION
        );
        assert_eq!(API_VERSION, headers);
    }

    #[test]
    fn defaults_without_variables() {
        let (settings, problems) = parse_with(&[], None);
        assert_eq!(settings, Settings::default());
        assert_eq!(settings.duplicate_limit, 10);
        assert!(settings.reports(Severity::Error) && !settings.reports(Severity::Info));
        assert!(settings.actions.log && !settings.actions.break_into_debugger);
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
                (MESSAGE_ID_FILTER, "OMMCHECK-a"),
                (DEBUG_ACTION, "break"),
                (TIER, "state"),
                (GPU_READBACK, "false"),
                (GPU_READBACK_MAX_BYTES, "4096"),
                (GPU_READBACK_INDIRECT_MAX_BYTES, "512"),
            ],
            None,
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 0);
        assert_eq!(settings.log_file, Some(PathBuf::from("/tmp/omm.log")));
        assert_eq!(settings.report, [Severity::Error, Severity::Info]);
        assert_eq!(settings.limits, Profile::Permissive.limits());
        assert!(settings.message_filter.mutes("OMMCHECK-a"));
        assert_eq!(
            settings.actions,
            Actions {
                log: false,
                break_into_debugger: true
            }
        );
        assert_eq!(settings.tier, Tier::State);
        assert!(!settings.gpu_readback);
        assert_eq!(settings.gpu_readback_max_bytes, 4096);
        assert_eq!(settings.gpu_readback_indirect_max_bytes, 512);
    }

    /// No documented setting is left unread: a value for each either
    /// changes the settings or is reported as unusable.
    #[test]
    fn every_documented_setting_is_read() {
        for doc in &DOCUMENTED {
            let (settings, problems) = parse_with(&[(doc.env, "0xZZ-nonsense")], None);
            assert!(
                settings != Settings::default() || problems.iter().any(|p| p.starts_with(doc.env)),
                "{}: {problems:?}",
                doc.key
            );
        }
    }

    #[test]
    fn khronos_style_variables_rank_after_ours() {
        assert_eq!(
            khronos_style_variable("report_flags"),
            "VK_OMMCHECK_VALIDATION_REPORT_FLAGS"
        );
        let (settings, problems) = parse_with(&[("VK_OMMCHECK_VALIDATION_TIER", "params")], None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.tier, Tier::Params);
        let (settings, _) = parse_with(
            &[(TIER, "state"), ("VK_OMMCHECK_VALIDATION_TIER", "params")],
            None,
        );
        assert_eq!(settings.tier, Tier::State);
    }

    #[test]
    fn values_are_case_insensitive() {
        let (settings, problems) = parse_with(
            &[
                (REPORT, "Error,WARN"),
                (PROFILE, "Permissive"),
                (TIER, "PARAMS"),
                (DEBUG_ACTION, "Log,VK_DBG_LAYER_ACTION_BREAK"),
                (GPU_READBACK, "Off"),
                (LOG_FILE, "StdOut"),
            ],
            None,
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.report, [Severity::Error, Severity::Warning]);
        assert_eq!(settings.limits, Profile::Permissive.limits());
        assert_eq!(settings.tier, Tier::Params);
        assert!(settings.actions.log && settings.actions.break_into_debugger);
        assert!(!settings.gpu_readback);
        assert_eq!(settings.log_file, None);
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
        assert!(settings.profile_chosen);
    }

    #[test]
    fn a_plural_typo_in_report_flags_keeps_the_default_and_says_so() {
        let (settings, problems) = parse_with(&[(REPORT, "errors,warnings")], None);
        assert_eq!(settings.report, [Severity::Error, Severity::Warning]);
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(problems[0].contains("`errors` is not error, warning or info"));
        assert!(problems[0].ends_with(r#"using the default, ["error", "warning"]"#));
        let (settings, problems) = parse_with(&[(REPORT, " , ")], None);
        assert_eq!(settings.report, Settings::default().report);
        assert!(problems[0].contains("names no severity"), "{problems:?}");
    }

    #[test]
    fn bad_values_keep_defaults_and_say_why() {
        let (settings, problems) = parse_with(
            &[
                (DUPLICATE_LIMIT, "-3"),
                (PROFILE, "missing.json"),
                (DEBUG_ACTION, "shout"),
                (GPU_READBACK_MAX_BYTES, "lots"),
                (MESSAGE_ID_FILTER, "0xZZ"),
                (TIER, "deep"),
            ],
            None,
        );
        assert_eq!(settings, Settings::default());
        assert_eq!(problems.len(), 6, "{problems:?}");
        for (problem, words) in problems.iter().zip([
            "not a whole number",
            "not a 32-bit hexadecimal MessageID",
            "not log, callback, break or ignore",
            "neither spec-minimum, permissive nor a readable file",
            "is not a tier",
            "not a whole number",
        ]) {
            assert!(problem.contains(words), "{problem}: {words}");
            assert!(problem.contains("using the default"), "{problem}");
        }
        let (_, problems) = parse_with(&[(PROFILE, "bad.json")], Some(r#"{"maxBogus": 1}"#));
        assert!(
            problems[0].contains("not a JSON object of limits"),
            "{problems:?}"
        );
    }

    #[test]
    fn an_invalid_variable_falls_back_to_the_application_then_the_file() {
        let given = api(&[
            ("report_flags", text("error,info")),
            ("tier", text("nonsense")),
        ]);
        let file = parse_file(
            Path::new("vk_layer_settings.txt"),
            "ommcheck_validation.tier = params\n",
        );
        let (settings, problems) =
            parse_from(&[(REPORT, "loud"), (TIER, "deeper")], &given, &file, None);
        assert_eq!(settings.report, [Severity::Error, Severity::Info]);
        assert_eq!(settings.tier, Tier::Params);
        assert_eq!(problems.len(), 3, "{problems:?}");
        assert!(problems[0].starts_with("OMMCHECK_REPORT=\"loud\""));
        assert!(problems[0].ends_with("using VkLayerSettingEXT report_flags"));
        assert!(problems[1].ends_with("using vk_layer_settings.txt: ommcheck_validation.tier"));
        assert!(problems[2].starts_with("VkLayerSettingEXT tier=\"nonsense\""));
    }

    #[test]
    fn message_id_filter_takes_ids_and_numbers() {
        let vuid = "VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516";
        let number = message_id(vuid);
        // docs/layer.md quotes this MessageID and its signed form.
        assert_eq!((number, number as i32), (0xe6f7_0ac5, -420_017_467));
        for value in [
            vuid.to_string(),
            vuid.to_uppercase(),
            format!("{number:#x}"),
            format!("{number:#010X}"),
            number.to_string(),
            (number as i32).to_string(),
        ] {
            let (settings, problems) = parse_with(
                &[(MESSAGE_ID_FILTER, &format!("OMMCHECK-other, {value}"))],
                None,
            );
            assert!(problems.is_empty(), "{value}: {problems:?}");
            assert!(settings.message_filter.mutes(vuid), "{value}");
            assert!(settings.message_filter.mutes("OMMCHECK-other"), "{value}");
            assert!(
                !settings
                    .message_filter
                    .mutes("OMMCHECK-build-triangle-data-in-range"),
                "{value}"
            );
        }
        let (settings, _) = parse_with(&[(MESSAGE_ID_FILTER, "")], None);
        assert_eq!(settings.message_filter, MessageFilter::default());
    }

    #[test]
    fn break_on_error_is_an_alias_of_the_break_action() {
        let (settings, problems) = parse_with(&[(BREAK_ON_ERROR, "TRUE")], None);
        assert!(problems.is_empty(), "{problems:?}");
        assert!(settings.actions.break_into_debugger && settings.actions.log);
        let (settings, _) = parse_with(&[(BREAK_ON_ERROR, "false")], None);
        assert!(!settings.actions.break_into_debugger);
        let (settings, _) = parse_with(&[(DEBUG_ACTION, "ignore")], None);
        assert_eq!(
            settings.actions,
            Actions {
                log: false,
                break_into_debugger: false
            }
        );
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
            ("profile", text("permissive")),
            ("tier", text("state")),
            (
                "message_id_filter",
                vec![
                    ApiValue::Text("OMMCHECK-a".into()),
                    ApiValue::Text("OMMCHECK-b".into()),
                ],
            ),
        ]);
        let (settings, problems) = parse_from(&[], &given, &FileSettings::default(), None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 3);
        assert_eq!(settings.report, [Severity::Error, Severity::Info]);
        assert!(settings.actions.break_into_debugger);
        assert_eq!(settings.limits, Profile::Permissive.limits());
        assert_eq!(settings.tier, Tier::State);
        assert!(settings.message_filter.mutes("OMMCHECK-b"));
    }

    #[test]
    fn variables_then_api_then_file_then_default() {
        let file = parse_file(
            Path::new("/etc/x/vk_layer_settings.txt"),
            "ommcheck_validation.duplicate_message_limit = 5\nommcheck_validation.tier = state\nommcheck_validation.gpu_readback_max_bytes = 77\n",
        );
        let given = api(&[
            ("duplicate_message_limit", vec![ApiValue::Int(3)]),
            ("tier", text("params")),
        ]);
        let (settings, problems) = parse_from(&[(DUPLICATE_LIMIT, "7")], &given, &file, None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 7);
        assert_eq!(settings.tier, Tier::Params);
        assert_eq!(settings.gpu_readback_max_bytes, 77);
        assert_eq!(settings.log_file, None);
    }

    #[test]
    fn unknown_and_malformed_api_settings_are_reported() {
        let given = api(&[
            ("validate_sync", vec![ApiValue::Bool(true)]),
            ("duplicate_message_limit", vec![ApiValue::Float(2.5)]),
            ("break_on_error", text("sometimes")),
        ]);
        let (settings, problems) = parse_from(&[], &given, &FileSettings::default(), None);
        assert_eq!(settings.duplicate_limit, DEFAULT_DUPLICATE_LIMIT);
        assert!(!settings.actions.break_into_debugger);
        assert_eq!(problems.len(), 3, "{problems:?}");
        assert!(problems[0].contains("`validate_sync`"), "{problems:?}");
        assert!(problems[1].contains("VkLayerSettingEXT duplicate_message_limit"));
    }

    /// What vkconfig writes for this layer: a comment block per setting,
    /// every setting's line, other layers' lines beside ours.
    const VKCONFIG_FILE: &str = "\
# The settings in this file can be used to configure the behavior of
# layers in this repository.
#
# Message Severity
# =====================
# <LayerIdentifier>.report_flags
# The severities reported, comma-separated.
ommcheck_validation.report_flags = error,warning,info

# Debug Action
# =====================
ommcheck_validation.debug_action = VK_DBG_LAYER_ACTION_LOG_MSG

ommcheck_validation.message_id_filter = VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516
ommcheck_validation.duplicate_message_limit = 4 # a trailing comment
ommcheck_validation.log_filename = 
ommcheck_validation.profile =
ommcheck_validation.tier = simulate
ommcheck_validation.break_on_error = false
ommcheck_validation.gpu_readback = true
ommcheck_validation.gpu_readback_max_bytes = 1048576
ommcheck_validation.gpu_readback_indirect_max_bytes = 65536
khronos_validation.report_flags = error
khronos_validation.tier = nonsense
";

    #[test]
    fn a_file_vkconfig_writes_takes_effect() {
        let file = parse_file(Path::new("vk_layer_settings.txt"), VKCONFIG_FILE);
        assert_eq!(file.values.len(), DOCUMENTED.len());
        let (settings, problems) = parse_from(&[], &Vec::new(), &file, None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(
            settings.report,
            [Severity::Error, Severity::Warning, Severity::Info]
        );
        assert!(settings
            .message_filter
            .mutes("VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516"));
        assert_eq!(settings.duplicate_limit, 4);
        assert_eq!(settings.tier, Tier::Simulate);
        assert_eq!(settings.gpu_readback_max_bytes, 1 << 20);
        assert_eq!(settings.gpu_readback_indirect_max_bytes, 1 << 16);
        assert_eq!(settings.log_file, None);
        assert!(settings.actions.log);
        assert!(
            !settings.profile_chosen,
            "an empty profile keeps the device's limits"
        );
    }

    /// vkconfig writes every setting, each at its manifest default unless
    /// the user changed it: such a file changes nothing.
    #[test]
    fn a_file_of_the_manifest_defaults_changes_nothing() {
        let text: String = DOCUMENTED
            .iter()
            .map(|doc| {
                let value: String = doc
                    .default_json
                    .chars()
                    .filter(|c| !matches!(c, '[' | ']' | '"' | ' '))
                    .collect();
                format!("{FILE_PREFIX}.{} = {value}\n", doc.key)
            })
            .collect();
        let file = parse_file(Path::new("vk_layer_settings.txt"), &text);
        assert_eq!(file.values.len(), DOCUMENTED.len());
        let (settings, problems) = parse_from(&[], &Vec::new(), &file, None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings, Settings::default());
    }

    #[test]
    fn unknown_file_keys_are_reported() {
        let file = parse_file(
            Path::new("s.txt"),
            "OMMCHECK_VALIDATION.tier = state\nommcheck_validation.teir = state\n",
        );
        let (settings, problems) = parse_from(&[], &Vec::new(), &file, None);
        assert_eq!(settings.tier, Tier::State);
        assert_eq!(
            problems,
            ["s.txt: `ommcheck_validation.teir` is not a setting of this layer; ignored"]
        );
    }

    #[test]
    fn the_settings_file_comes_from_vkconfig_then_the_variable_then_the_working_directory() {
        let dir = std::env::temp_dir().join(format!("ommcheck-settings-{}", std::process::id()));
        let vkconfig = dir.join("vkconfig");
        let named = dir.join("named");
        let working = dir.join("working");
        for d in [&vkconfig, &named, &working] {
            std::fs::create_dir_all(d).unwrap();
        }
        let in_named = named.join(SETTINGS_FILE);
        let in_working = working.join(SETTINGS_FILE);
        std::fs::write(&in_working, "").unwrap();
        let find = |vkconfig: &Path, named: &Path| {
            settings_file_path(
                Some(vkconfig.to_path_buf()),
                Some(named.to_path_buf()),
                Some(working.clone()),
            )
        };
        // Directories without the file: the working directory's applies.
        assert_eq!(find(&vkconfig, &named), Some(in_working.clone()));
        std::fs::write(&in_named, "").unwrap();
        assert_eq!(find(&vkconfig, &named), Some(in_named.clone()));
        assert_eq!(find(&vkconfig, &in_named), Some(in_named.clone()));
        std::fs::write(vkconfig.join(SETTINGS_FILE), "").unwrap();
        assert_eq!(find(&vkconfig, &named), Some(vkconfig.join(SETTINGS_FILE)));
        assert_eq!(settings_file_path(None, None, Some(dir.join("no"))), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn vkconfig_writes_under_the_xdg_data_directory() {
        assert_eq!(
            vkconfig_dir(Some("/x".into()), Some("/home/u".into())),
            Some(PathBuf::from("/x/vulkan/settings.d"))
        );
        assert_eq!(
            vkconfig_dir(None, Some("/home/u".into())),
            Some(PathBuf::from("/home/u/.local/share/vulkan/settings.d"))
        );
        assert_eq!(vkconfig_dir(None, None), None);
    }
}
