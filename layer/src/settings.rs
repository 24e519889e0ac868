//! The layer's settings, from four sources in this order of precedence
//! (the Khronos layers' order): the environment (`OMMCHECK_*`, then the
//! Khronos settings library's `VK_OMMCHECK_VALIDATION_<KEY>`), the
//! application's `VkLayerSettingsCreateInfoEXT` (VK_EXT_layer_settings)
//! chained in `VkInstanceCreateInfo`, the `vk_layer_settings.txt` file
//! vkconfig writes (lines `ommcheck_validation.<key> = <value>`), then the
//! default. A value that cannot be used is reported as a warning and the
//! next source's value applies, so a bad value never silences the layer.
//! A mistaken name is never silent either: an `OMMCHECK_*` variable, a
//! `VkLayerSettingEXT` or a settings-file key that names no setting, a
//! settings-file line whose prefix looks like a mistyped
//! [`FILE_PREFIX`], a `message_id_filter` entry that names no message the
//! layer reports, and a `VK_LAYER_SETTINGS_PATH` that names nothing are
//! each reported once, with the nearest name where one is close.
//! Settings are per instance; their names, types and defaults are in
//! [`DOCUMENTED`], and docs/layer.md describes them.

use std::fmt;
use std::path::{Path, PathBuf};

use ommcheck::report::message_id;
use ommcheck::vuids::Vuid;
use ommcheck::{not_checked::Cause, rules, suggest};
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
    /// The names (`prefix.key`, or a bare key) of lines meant for this
    /// layer that it does not read: a prefix a few edits from
    /// [`FILE_PREFIX`] or holding `ommcheck`, or one of its keys with no
    /// prefix. Other layers' lines are not among them.
    pub mistyped: Vec<String>,
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
        for word in filter_words(value) {
            match filter_word(word)? {
                FilterWord::Name(name) => filter.names.push(name.to_ascii_lowercase()),
                FilterWord::Number(number) => filter.numbers.push(number),
            }
        }
        Ok(filter)
    }
}

/// The entries of a comma-separated `message_id_filter` value.
fn filter_words(value: &str) -> impl Iterator<Item = &str> {
    value.split(',').map(str::trim).filter(|w| !w.is_empty())
}

/// One entry of `message_id_filter`.
enum FilterWord<'a> {
    /// A VUID or rule id, as written.
    Name(&'a str),
    Number(u32),
}

/// An entry as a MessageID number (`0x`-prefixed hexadecimal, or decimal,
/// signed as `messageIdNumber` is) or else a name.
fn filter_word(word: &str) -> Result<FilterWord<'_>, String> {
    let lower = word.to_ascii_lowercase();
    if let Some(hex) = lower.strip_prefix("0x") {
        let number = u32::from_str_radix(hex, 16)
            .map_err(|_| format!("`{word}` is not a 32-bit hexadecimal MessageID"))?;
        Ok(FilterWord::Number(number))
    } else if lower
        .trim_start_matches('-')
        .bytes()
        .all(|b| b.is_ascii_digit())
    {
        let number = lower
            .parse::<u32>()
            .or_else(|_| lower.parse::<i32>().map(|n| n as u32))
            .map_err(|_| format!("`{word}` is not a 32-bit MessageID"))?;
        Ok(FilterWord::Number(number))
    } else {
        Ok(FilterWord::Name(word))
    }
}

/// Every id the layer can report: the catalog's VUIDs, the rules of ours,
/// the core's not-checked information and the layer's own ids.
fn reportable_ids() -> impl Iterator<Item = &'static str> {
    Vuid::all()
        .map(Vuid::id)
        .chain(rules::ALL.iter().map(|rule| rule.id))
        .chain(Cause::ALL.iter().map(|cause| cause.rule().id))
        .chain(crate::ids::ALL)
}

/// A sentence for each entry of a `message_id_filter` value (given as
/// `from`) that names no message the layer can report, so mutes nothing:
/// a misspelled id would otherwise leave its message on without a word.
fn unmatched_filter_entries(value: &str, from: &str) -> Vec<String> {
    let mut problems = Vec::new();
    for word in filter_words(value) {
        match filter_word(word) {
            Ok(FilterWord::Name(name)) => {
                if reportable_ids().any(|id| id.eq_ignore_ascii_case(name)) {
                    continue;
                }
                let hint = suggest::did_you_mean(name, reportable_ids(), 1)
                    .map(|hint| format!("; {hint}"))
                    .unwrap_or_default();
                problems.push(format!(
                    "{from} names `{name}`, which is no message this layer reports, so it mutes nothing{hint}"
                ));
            }
            Ok(FilterWord::Number(number)) => {
                if reportable_ids().any(|id| message_id(id) == number) {
                    continue;
                }
                problems.push(format!(
                    "{from} names MessageID `{word}` ({number:#010x}), which is the number of no message this layer reports, so it mutes nothing"
                ));
            }
            // The whole value was rejected already, with the reason.
            Err(_) => {}
        }
    }
    problems
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
    /// Where the provenance store lives.
    pub provenance_store: ProvenanceStore,
    /// The most bytes the provenance store's file holds.
    pub provenance_store_max_bytes: u64,
}

/// The `provenance_store` setting.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ProvenanceStore {
    /// `$XDG_CACHE_HOME/ommcheck`, else `$HOME/.cache/ommcheck`.
    Default,
    /// A directory the setting named.
    Dir(PathBuf),
    /// `off`: provenance in memory only.
    Off,
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
            provenance_store: ProvenanceStore::Default,
            provenance_store_max_bytes: ommcheck::state::provenance::store::DEFAULT_MAX_BYTES,
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
    /// The names of the environment's variables, so that an `OMMCHECK_*`
    /// one that names no setting is reported.
    pub variable_names: &'a [String],
    pub api: &'a ApiSettings,
    pub file: &'a FileSettings,
}

/// Where the value of a setting in effect came from.
#[derive(Clone, Debug, PartialEq)]
pub enum Origin {
    /// The environment variable of this name.
    Environment(String),
    /// The application's `VkLayerSettingsCreateInfoEXT`.
    Api,
    /// The settings file at this path.
    File(PathBuf),
    Default,
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::Environment(name) => write!(f, "environment {name}"),
            Origin::Api => f.write_str("VK_EXT_layer_settings"),
            Origin::File(path) => write!(f, "file {}", path.display()),
            Origin::Default => f.write_str("default"),
        }
    }
}

/// A setting as it took effect: its value as given (or the default's JSON
/// text) and where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Effective {
    pub key: &'static str,
    pub value: String,
    pub origin: Origin,
    /// The words naming the source in warnings (`OMMCHECK_TIER`,
    /// `VkLayerSettingEXT tier`, `<file>: ommcheck_validation.tier`).
    from: String,
}

/// What the settings sources add up to.
#[derive(Clone, Debug, PartialEq)]
pub struct Parsed {
    pub settings: Settings,
    /// A sentence for each value or name that could not be used.
    pub problems: Vec<String>,
    /// Every setting, in [`DOCUMENTED`] order, as it took effect.
    pub effective: Vec<Effective>,
    /// The settings file read, if any.
    pub file: Option<PathBuf>,
}

impl Parsed {
    /// The text of the information at `vkCreateInstance` that lists the
    /// settings in effect and where each came from, as vkconfig shows them.
    pub fn effective_text(&self) -> String {
        let settings: Vec<String> = self
            .effective
            .iter()
            .map(|e| match e.origin {
                Origin::Default => format!("{} = {} (default)", e.key, e.value),
                _ => format!("{} = {:?} ({})", e.key, e.value, e.origin),
            })
            .collect();
        let file = match &self.file {
            Some(path) => format!("{} read", path.display()),
            None => format!("no {SETTINGS_FILE} found"),
        };
        format!(
            "the settings in effect, each with where its value came from (environment, VK_EXT_layer_settings, file or default; the first of these that gives a usable value wins): {}; {file}",
            settings.join("; ")
        )
    }
}

impl Sources<'_> {
    /// Every value given for `doc`, in order of precedence, each with the
    /// words naming where it came from and its [`Origin`].
    fn values(&self, doc: &SettingDoc) -> Vec<(String, Origin, String)> {
        let mut values = Vec::new();
        for name in [doc.env.to_string(), khronos_style_variable(doc.key)] {
            if let Some(value) = (self.variable)(&name) {
                values.push((name.clone(), Origin::Environment(name), value));
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
            values.push((
                format!("VkLayerSettingEXT {}", doc.key),
                Origin::Api,
                text.join(","),
            ));
        }
        if let Some((_, value)) = self.file.values.iter().rev().find(|(k, _)| k == doc.key) {
            values.push((
                format!("{}: {FILE_PREFIX}.{}", self.file.path.display(), doc.key),
                Origin::File(self.file.path.clone()),
                value.clone(),
            ));
        }
        values
    }

    /// The first of `doc`'s values that `parse` accepts, or None (the
    /// default applies). Each rejected value adds a sentence to `problems`
    /// saying why and what applies instead; the outcome is added to
    /// `effective`.
    fn resolve<T>(
        &self,
        doc: &'static SettingDoc,
        problems: &mut Vec<String>,
        effective: &mut Vec<Effective>,
        parse: impl Fn(&str) -> Result<T, String>,
    ) -> Option<T> {
        let mut rejected = Vec::new();
        let mut chosen = None;
        for (from, origin, value) in self.values(doc) {
            match parse(&value) {
                Ok(parsed) => {
                    chosen = Some((parsed, from, origin, value));
                    break;
                }
                Err(why) => rejected.push(format!("{from}={value:?}: {why}")),
            }
        }
        let instead = match &chosen {
            Some((_, from, _, _)) => format!("using {from}"),
            None if matches!(doc.default_json, r#""""# | "[]") => "using the default".to_string(),
            None => format!("using the default, {}", doc.default_json),
        };
        problems.extend(rejected.into_iter().map(|r| format!("{r}; {instead}")));
        match chosen {
            Some((parsed, from, origin, value)) => {
                effective.push(Effective {
                    key: doc.key,
                    value: value.trim().to_string(),
                    origin,
                    from,
                });
                Some(parsed)
            }
            None => {
                effective.push(Effective {
                    key: doc.key,
                    value: doc.default_json.to_string(),
                    origin: Origin::Default,
                    from: String::new(),
                });
                None
            }
        }
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

/// `; did you mean `X`?` with the setting key closest to `key`, written
/// as `write` writes a key, or nothing when none is close.
fn nearest_key(key: &str, write: impl Fn(&str) -> String) -> String {
    suggest::closest(key, DOCUMENTED.iter().map(|d| d.key), 1)
        .first()
        .map(|near| format!("; did you mean `{}`?", write(near)))
        .unwrap_or_default()
}

/// Prefixes of `OMMCHECK_*` variables that belong to the project's tests
/// and tools (`OMMCHECK_TEST_MOCK_ICD`, `OMMCHECK_UPDATE_SCHEMA`), not to
/// the layer: they are set around applications under test, so warning of
/// them would be noise.
const TOOL_VARIABLE_PREFIXES: [&str; 2] = ["OMMCHECK_TEST_", "OMMCHECK_UPDATE_"];

/// A sentence for each variable in `names` that looks meant for this
/// layer (`OMMCHECK_*`, or the Khronos-style `VK_OMMCHECK_VALIDATION_*`)
/// but names no setting, with the nearest setting's variable.
fn unknown_variables(names: &[String]) -> Vec<String> {
    let khronos_prefix = khronos_style_variable("");
    let mut names: Vec<&String> = names.iter().collect();
    names.sort();
    names.dedup();
    let mut problems = Vec::new();
    for name in names {
        // The Khronos-style prefix starts with VK_, so it is tried first.
        let hint = if let Some(rest) = name.strip_prefix(&khronos_prefix) {
            if DOCUMENTED
                .iter()
                .any(|d| khronos_style_variable(d.key) == *name)
            {
                continue;
            }
            nearest_key(&rest.to_ascii_lowercase(), khronos_style_variable)
        } else if let Some(rest) = name.strip_prefix("OMMCHECK_") {
            if DOCUMENTED.iter().any(|d| d.env == name)
                || TOOL_VARIABLE_PREFIXES.iter().any(|p| name.starts_with(p))
            {
                continue;
            }
            // Compared without the prefix every variable shares, which
            // would make any two names look alike.
            let suffixes = DOCUMENTED.iter().map(|d| &d.env["OMMCHECK_".len()..]);
            suggest::closest(rest, suffixes, 1)
                .first()
                .map(|near| format!("; did you mean `OMMCHECK_{near}`?"))
                .unwrap_or_default()
        } else {
            continue;
        };
        problems.push(format!(
            "the environment variable {name} is not a setting of this layer; ignored{hint}"
        ));
    }
    problems
}

/// A sentence for each name in `sources` (other than variables) that
/// names no setting: application settings, file keys and file lines with
/// a mistyped prefix.
fn unknown_names(sources: &Sources<'_>) -> Vec<String> {
    let mut problems = Vec::new();
    for (name, _) in sources.api {
        if DOCUMENTED.iter().all(|d| d.key != name) {
            let hint = nearest_key(name, str::to_string);
            problems.push(format!(
                "VkLayerSettingEXT `{name}` is not a setting of this layer; ignored{hint}"
            ));
        }
    }
    let file = sources.file.path.display();
    for (key, _) in &sources.file.values {
        if DOCUMENTED.iter().all(|d| d.key != key) {
            let hint = nearest_key(key, |near| format!("{FILE_PREFIX}.{near}"));
            problems.push(format!(
                "{file}: `{FILE_PREFIX}.{key}` is not a setting of this layer; ignored{hint}"
            ));
        }
    }
    for name in &sources.file.mistyped {
        let key = name.rsplit_once('.').map_or(name.as_str(), |(_, key)| key);
        let hint = nearest_key(key.trim(), |near| format!("{FILE_PREFIX}.{near}"));
        problems.push(format!(
            "{file}: `{name}` is not read by this layer, whose lines start with `{FILE_PREFIX}.`; ignored{hint}"
        ));
    }
    problems
}

/// Settings from `sources`, reading a JSON limits file through
/// `read_file`, with a sentence for each value that could not be used
/// and each name that names no setting.
pub fn parse(
    sources: &Sources<'_>,
    read_file: impl Fn(&Path) -> std::io::Result<String>,
) -> (Settings, Vec<String>) {
    let parsed = parse_explained(sources, read_file);
    (parsed.settings, parsed.problems)
}

/// [`parse`], with where each setting in effect came from.
pub fn parse_explained(
    sources: &Sources<'_>,
    read_file: impl Fn(&Path) -> std::io::Result<String>,
) -> Parsed {
    let mut settings = Settings::default();
    let mut problems = unknown_variables(sources.variable_names);
    problems.extend(unknown_names(sources));
    let mut effective = Vec::new();
    let problems_ref = &mut problems;
    let effective_ref = &mut effective;
    let mut get = |env: &str, parse: &dyn Fn(&str) -> Result<Setter, String>| {
        if let Some(set) = sources.resolve(doc(env), problems_ref, effective_ref, parse) {
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
    get(PROVENANCE_STORE, &|v| {
        let store = match v.trim() {
            "" => ProvenanceStore::Default,
            off if off.eq_ignore_ascii_case("off") => ProvenanceStore::Off,
            dir => ProvenanceStore::Dir(PathBuf::from(dir)),
        };
        Ok(Box::new(move |s| s.provenance_store = store))
    });
    get(PROVENANCE_STORE_MAX_BYTES, &|v| {
        let bytes = whole_number::<u64>(v)?;
        let least = ommcheck::state::provenance::store::MIN_MAX_BYTES;
        if bytes < least {
            return Err(format!("less than the least bound, {least}"));
        }
        Ok(Box::new(move |s| s.provenance_store_max_bytes = bytes))
    });
    // In manifest order, as vkconfig lists them.
    effective.sort_by_key(|e| DOCUMENTED.iter().position(|d| d.key == e.key));
    if let Some(filter) = effective
        .iter()
        .find(|e| e.key == doc(MESSAGE_ID_FILTER).key && e.origin != Origin::Default)
    {
        problems.extend(unmatched_filter_entries(&filter.value, &filter.from));
    }
    Parsed {
        settings,
        problems,
        effective,
        file: None,
    }
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
    let mut file = FileSettings {
        path: path.to_path_buf(),
        ..FileSettings::default()
    };
    let lines = text
        .lines()
        .filter_map(|line| line.split('#').next())
        .filter_map(|line| line.split_once('='));
    for (name, value) in lines {
        let name = name.trim();
        match name.split_once('.') {
            Some((prefix, key)) if prefix.eq_ignore_ascii_case(FILE_PREFIX) => {
                file.values
                    .push((key.trim().to_string(), value.trim().to_string()));
            }
            Some((prefix, _)) if looks_like_our_prefix(prefix) => {
                file.mistyped.push(name.to_string());
            }
            None if DOCUMENTED.iter().any(|d| d.key == name) => {
                file.mistyped.push(name.to_string());
            }
            _ => {}
        }
    }
    file
}

/// Whether a settings-file prefix other than [`FILE_PREFIX`] looks meant
/// for this layer: within 3 edits of it (`omcheck_validation`,
/// `ommcheck_validaton`), or naming ommcheck (`ommcheck`,
/// `vk_layer_ommcheck_validation`). Other layers' prefixes
/// (`khronos_validation`, `lunarg_api_dump`) are many edits away.
fn looks_like_our_prefix(prefix: &str) -> bool {
    let prefix = prefix.trim().to_ascii_lowercase();
    strsim::damerau_levenshtein(&prefix, FILE_PREFIX) <= 3 || prefix.contains("ommcheck")
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

/// Why the `VK_LAYER_SETTINGS_PATH` value `named` leads to no settings
/// file, if it does not: it names nothing, or a directory without
/// `vk_layer_settings.txt`. `is_file` and `is_dir` ask the file system
/// (tests give their own). An empty value counts as unset.
pub fn settings_path_problem(
    named: &Path,
    is_file: impl Fn(&Path) -> bool,
    is_dir: impl Fn(&Path) -> bool,
) -> Option<String> {
    if named.as_os_str().is_empty() || is_file(named) {
        None
    } else if is_dir(named) {
        let file = named.join(SETTINGS_FILE);
        (!is_file(&file)).then(|| {
            format!(
                "{SETTINGS_PATH_VAR}={} names a directory without {SETTINGS_FILE}; no settings are read from it",
                named.display()
            )
        })
    } else {
        Some(format!(
            "{SETTINGS_PATH_VAR}={} names no file or directory; no settings are read from it",
            named.display()
        ))
    }
}

/// The settings of an instance: this process's environment, then `api`,
/// then the settings file (read at each `vkCreateInstance`).
pub fn for_instance(api: &ApiSettings) -> Parsed {
    let named = std::env::var_os(SETTINGS_PATH_VAR).map(PathBuf::from);
    let mut problems: Vec<String> = named
        .as_deref()
        .and_then(|named| settings_path_problem(named, Path::is_file, Path::is_dir))
        .into_iter()
        .collect();
    let path = settings_file_path(
        vkconfig_dir(
            std::env::var_os("XDG_DATA_HOME").map(PathBuf::from),
            std::env::var_os("HOME").map(PathBuf::from),
        ),
        named,
        std::env::current_dir().ok(),
    );
    let file = match &path {
        Some(path) => match std::fs::read_to_string(path) {
            Ok(text) => parse_file(path, &text),
            Err(e) => {
                problems.push(format!("{} cannot be read ({e}); ignored", path.display()));
                FileSettings::default()
            }
        },
        None => FileSettings::default(),
    };
    // Names that are not UTF-8 cannot be ours.
    let variable_names: Vec<String> = std::env::vars_os()
        .filter_map(|(name, _)| name.into_string().ok())
        .collect();
    let mut parsed = parse_explained(
        &Sources {
            variable: &|name| std::env::var(name).ok(),
            variable_names: &variable_names,
            api,
            file: &file,
        },
        |path| std::fs::read_to_string(path),
    );
    problems.append(&mut parsed.problems);
    parsed.problems = problems;
    // A file that could not be read was not read: its problem says so.
    parsed.file = path.filter(|_| !file.path.as_os_str().is_empty());
    parsed
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
        let names: Vec<String> = vars.keys().cloned().collect();
        parse(
            &Sources {
                variable: &|name| vars.get(name).cloned(),
                variable_names: &names,
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
                (MESSAGE_ID_FILTER, "OMMCHECK-attach-index-in-range"),
                (DEBUG_ACTION, "break"),
                (TIER, "state"),
                (GPU_READBACK, "false"),
                (GPU_READBACK_MAX_BYTES, "4096"),
                (GPU_READBACK_INDIRECT_MAX_BYTES, "512"),
                (PROVENANCE_STORE, "/tmp/omm-store"),
                (PROVENANCE_STORE_MAX_BYTES, "1048576"),
            ],
            None,
        );
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.duplicate_limit, 0);
        assert_eq!(settings.log_file, Some(PathBuf::from("/tmp/omm.log")));
        assert_eq!(settings.report, [Severity::Error, Severity::Info]);
        assert_eq!(settings.limits, Profile::Permissive.limits());
        assert!(settings
            .message_filter
            .mutes("OMMCHECK-attach-index-in-range"));
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
        assert_eq!(
            settings.provenance_store,
            ProvenanceStore::Dir(PathBuf::from("/tmp/omm-store"))
        );
        assert_eq!(settings.provenance_store_max_bytes, 1 << 20);
    }

    #[test]
    fn the_provenance_store_is_on_by_default_and_off_turns_it_off() {
        let (settings, problems) = parse_with(&[], None);
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(settings.provenance_store, ProvenanceStore::Default);
        let (settings, _) = parse_with(&[(PROVENANCE_STORE, "OFF")], None);
        assert_eq!(settings.provenance_store, ProvenanceStore::Off);
        let (settings, problems) = parse_with(&[(PROVENANCE_STORE_MAX_BYTES, "100")], None);
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert_eq!(
            settings.provenance_store_max_bytes,
            ommcheck::state::provenance::store::DEFAULT_MAX_BYTES
        );
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
                &[(
                    MESSAGE_ID_FILTER,
                    &format!("OMMCHECK-attach-index-in-range, {value}"),
                )],
                None,
            );
            assert!(problems.is_empty(), "{value}: {problems:?}");
            assert!(settings.message_filter.mutes(vuid), "{value}");
            assert!(
                settings
                    .message_filter
                    .mutes("OMMCHECK-attach-index-in-range"),
                "{value}"
            );
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
                    ApiValue::Text("OMMCHECK-attach-index-in-range".into()),
                    ApiValue::Text("OMMCHECK-layer-contents-not-checked".into()),
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
        assert!(settings
            .message_filter
            .mutes("OMMCHECK-layer-contents-not-checked"));
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
ommcheck_validation.provenance_store = off
ommcheck_validation.provenance_store_max_bytes = 131072
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
        assert_eq!(settings.provenance_store, ProvenanceStore::Off);
        assert_eq!(settings.provenance_store_max_bytes, 1 << 17);
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
            ["s.txt: `ommcheck_validation.teir` is not a setting of this layer; ignored; did you mean `ommcheck_validation.tier`?"]
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

    #[test]
    fn an_unknown_ommcheck_variable_warns_with_the_nearest_setting() {
        let (settings, problems) = parse_with(&[("OMMCHECK_REPROT", "info")], None);
        assert_eq!(settings, Settings::default());
        assert_eq!(
            problems,
            ["the environment variable OMMCHECK_REPROT is not a setting of this layer; ignored; did you mean `OMMCHECK_REPORT`?"]
        );
        let (_, problems) = parse_with(&[("VK_OMMCHECK_VALIDATION_REPORT", "info")], None);
        assert_eq!(
            problems,
            ["the environment variable VK_OMMCHECK_VALIDATION_REPORT is not a setting of this layer; ignored; did you mean `VK_OMMCHECK_VALIDATION_REPORT_FLAGS`?"]
        );
        // Nothing close: said without a guess.
        let (_, problems) = parse_with(&[("OMMCHECK_ZZZZZZZZZZZZ", "1")], None);
        assert_eq!(
            problems,
            ["the environment variable OMMCHECK_ZZZZZZZZZZZZ is not a setting of this layer; ignored"]
        );
    }

    #[test]
    fn known_test_tool_and_other_variables_do_not_warn() {
        let mut vars: Vec<(&str, &str)> = DOCUMENTED.iter().map(|d| (d.env, "")).collect();
        let khronos: Vec<String> = DOCUMENTED
            .iter()
            .map(|d| khronos_style_variable(d.key))
            .collect();
        vars.extend(khronos.iter().map(|name| (name.as_str(), "")));
        vars.extend([
            ("OMMCHECK_TEST_MOCK_ICD", "/x.json"),
            ("OMMCHECK_UPDATE_SCHEMA", "1"),
            ("PATH", "/bin"),
            ("VK_LAYER_SETTINGS_PATH", "/x"),
        ]);
        let names: Vec<String> = vars.iter().map(|(name, _)| name.to_string()).collect();
        assert!(unknown_variables(&names).is_empty());
    }

    #[test]
    fn a_mistyped_file_prefix_warns_and_other_layers_lines_do_not() {
        let file = parse_file(
            Path::new("vk_layer_settings.txt"),
            "omcheck_validation.report_flags = error,warning,info\n\
             report_flags = info\n\
             vk_layer_ommcheck_validation.tier = params\n\
             khronos_validation.report_flags = error\n\
             lunarg_api_dump.output_format = text\n",
        );
        assert!(file.values.is_empty(), "{file:?}");
        let (settings, problems) = parse_from(&[], &Vec::new(), &file, None);
        assert_eq!(settings, Settings::default());
        assert_eq!(
            problems,
            [
                "vk_layer_settings.txt: `omcheck_validation.report_flags` is not read by this layer, whose lines start with `ommcheck_validation.`; ignored; did you mean `ommcheck_validation.report_flags`?",
                "vk_layer_settings.txt: `report_flags` is not read by this layer, whose lines start with `ommcheck_validation.`; ignored; did you mean `ommcheck_validation.report_flags`?",
                "vk_layer_settings.txt: `vk_layer_ommcheck_validation.tier` is not read by this layer, whose lines start with `ommcheck_validation.`; ignored; did you mean `ommcheck_validation.tier`?",
            ]
        );
        for prefix in ["khronos_validation", "lunarg_api_dump", "lunarg_monitor"] {
            assert!(!looks_like_our_prefix(prefix), "{prefix}");
        }
    }

    #[test]
    fn an_unknown_application_setting_warns_with_the_nearest_key() {
        let given = api(&[("report_flag", text("info"))]);
        let (_, problems) = parse_from(&[], &given, &FileSettings::default(), None);
        assert_eq!(
            problems,
            ["VkLayerSettingEXT `report_flag` is not a setting of this layer; ignored; did you mean `report_flags`?"]
        );
    }

    #[test]
    fn a_filter_entry_that_names_no_message_warns_and_the_rest_still_mutes() {
        let (settings, problems) = parse_with(
            &[(
                MESSAGE_ID_FILTER,
                "OMMCHECK-build-triangle-data-in-rnage, VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516, 0x12345678",
            )],
            None,
        );
        assert!(settings
            .message_filter
            .mutes("VUID-VkMicromapBuildInfoEXT-pUsageCounts-07516"));
        assert_eq!(
            problems,
            [
                "OMMCHECK_MESSAGE_ID_FILTER names `OMMCHECK-build-triangle-data-in-rnage`, which is no message this layer reports, so it mutes nothing; did you mean `OMMCHECK-build-triangle-data-in-range`?",
                "OMMCHECK_MESSAGE_ID_FILTER names MessageID `0x12345678` (0x12345678), which is the number of no message this layer reports, so it mutes nothing",
            ]
        );
        // The file and the application's setting are checked alike.
        let file = parse_file(
            Path::new("s.txt"),
            "ommcheck_validation.message_id_filter = OMMCHECK-layer-contents-not-chekced\n",
        );
        let (_, problems) = parse_from(&[], &Vec::new(), &file, None);
        assert_eq!(
            problems,
            ["s.txt: ommcheck_validation.message_id_filter names `OMMCHECK-layer-contents-not-chekced`, which is no message this layer reports, so it mutes nothing; did you mean `OMMCHECK-layer-contents-not-checked`?"]
        );
        let given = api(&[("message_id_filter", text("OMMCHECK-nope"))]);
        let (_, problems) = parse_from(&[], &given, &FileSettings::default(), None);
        assert_eq!(
            problems,
            ["VkLayerSettingEXT message_id_filter names `OMMCHECK-nope`, which is no message this layer reports, so it mutes nothing"]
        );
    }

    #[test]
    fn a_filter_of_reportable_ids_and_their_numbers_does_not_warn() {
        let ids = [
            "VUID-vkCmdBuildMicromapsEXT-pInfos-07461",
            "ommcheck-build-triangle-data-in-range",
            "OMMCHECK-not-checked-contents",
            crate::ids::CONTENTS_NOT_CHECKED,
            crate::ids::EFFECTIVE_SETTINGS,
        ];
        let number = message_id(ids[0]);
        let value = format!(
            "{}, {number:#x}, {}",
            ids.join(","),
            message_id(ids[3]) as i32
        );
        let (_, problems) = parse_with(&[(MESSAGE_ID_FILTER, &value)], None);
        assert!(problems.is_empty(), "{problems:?}");
    }

    #[test]
    fn a_settings_path_that_names_nothing_warns() {
        let files = [
            Path::new("/etc/s.txt"),
            Path::new("/etc/d/vk_layer_settings.txt"),
        ];
        let dirs = [Path::new("/etc/d"), Path::new("/etc/empty")];
        let problem = |named: &str| {
            settings_path_problem(
                Path::new(named),
                |p| files.contains(&p),
                |p| dirs.contains(&p),
            )
        };
        assert_eq!(
            problem("/etc/missing"),
            Some("VK_LAYER_SETTINGS_PATH=/etc/missing names no file or directory; no settings are read from it".into())
        );
        assert_eq!(
            problem("/etc/empty"),
            Some("VK_LAYER_SETTINGS_PATH=/etc/empty names a directory without vk_layer_settings.txt; no settings are read from it".into())
        );
        assert_eq!(problem("/etc/s.txt"), None);
        assert_eq!(problem("/etc/d"), None);
        assert_eq!(problem(""), None);
    }

    #[test]
    fn the_effective_settings_say_where_each_came_from() {
        let file = parse_file(
            Path::new("/etc/vk_layer_settings.txt"),
            "ommcheck_validation.tier = state\nommcheck_validation.report_flags = error\n",
        );
        let given = api(&[("duplicate_message_limit", vec![ApiValue::Int(3)])]);
        let (vars, api_given) = (&[(REPORT, "error,warning,info")], &given);
        let names = vec![REPORT.to_string()];
        let parsed = parse_explained(
            &Sources {
                variable: &|name| {
                    vars.iter()
                        .find(|(n, _)| *n == name)
                        .map(|(_, v)| v.to_string())
                },
                variable_names: &names,
                api: api_given,
                file: &file,
            },
            |_| Err(std::io::ErrorKind::NotFound.into()),
        );
        assert!(parsed.problems.is_empty(), "{:?}", parsed.problems);
        let keys: Vec<&str> = parsed.effective.iter().map(|e| e.key).collect();
        let documented: Vec<&str> = DOCUMENTED.iter().map(|d| d.key).collect();
        assert_eq!(keys, documented);
        let origin = |key: &str| {
            parsed
                .effective
                .iter()
                .find(|e| e.key == key)
                .map(|e| e.origin.clone())
        };
        assert_eq!(
            origin("report_flags"),
            Some(Origin::Environment(REPORT.into()))
        );
        assert_eq!(origin("duplicate_message_limit"), Some(Origin::Api));
        assert_eq!(
            origin("tier"),
            Some(Origin::File("/etc/vk_layer_settings.txt".into()))
        );
        assert_eq!(origin("gpu_readback"), Some(Origin::Default));
        let text = Parsed {
            file: Some("/etc/vk_layer_settings.txt".into()),
            ..parsed
        }
        .effective_text();
        for part in [
            r#"report_flags = "error,warning,info" (environment OMMCHECK_REPORT)"#,
            r#"duplicate_message_limit = "3" (VK_EXT_layer_settings)"#,
            r#"tier = "state" (file /etc/vk_layer_settings.txt)"#,
            "gpu_readback = true (default)",
            "/etc/vk_layer_settings.txt read",
        ] {
            assert!(text.contains(part), "{part}: {text}");
        }
    }
}
