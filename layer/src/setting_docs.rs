//! The layer's settings as its manifest describes them: key, environment
//! variable, type, default and description. This file has no dependencies
//! so that `cargo xtask layer` can include it (`#[path]`) and write the
//! manifest without compiling the layer's dependencies twice.

/// The layer's name, as in its manifest.
pub const LAYER_NAME: &str = "VK_LAYER_OMMCHECK_validation";

/// The Vulkan version the layer's interception is written against: that
/// of the headers ash 0.38 is generated from, whose commands and
/// structures the layer intercepts and reads (the manifest's `api_version`).
pub const API_VERSION: &str = "1.3.281";

/// The prefix of this layer's lines in `vk_layer_settings.txt`: the layer
/// name without `VK_LAYER_`, in lower case, as vkconfig writes it (the
/// Khronos layer's is `khronos_validation`).
pub const FILE_PREFIX: &str = "ommcheck_validation";

pub const REPORT: &str = "OMMCHECK_REPORT";
pub const DEBUG_ACTION: &str = "OMMCHECK_DEBUG_ACTION";
pub const MESSAGE_ID_FILTER: &str = "OMMCHECK_MESSAGE_ID_FILTER";
pub const DUPLICATE_LIMIT: &str = "OMMCHECK_DUPLICATE_LIMIT";
pub const LOG_FILE: &str = "OMMCHECK_LOG_FILE";
pub const PROFILE: &str = "OMMCHECK_PROFILE";
pub const TIER: &str = "OMMCHECK_TIER";
pub const BREAK_ON_ERROR: &str = "OMMCHECK_BREAK_ON_ERROR";
pub const GPU_READBACK: &str = "OMMCHECK_GPU_READBACK";
pub const GPU_READBACK_MAX_BYTES: &str = "OMMCHECK_GPU_READBACK_MAX_BYTES";
pub const GPU_READBACK_INDIRECT_MAX_BYTES: &str = "OMMCHECK_GPU_READBACK_INDIRECT_MAX_BYTES";
pub const PROVENANCE_STORE: &str = "OMMCHECK_PROVENANCE_STORE";
pub const PROVENANCE_STORE_MAX_BYTES: &str = "OMMCHECK_PROVENANCE_STORE_MAX_BYTES";

/// A setting as the layer manifest's `features.settings` describes it
/// (the format the Khronos layers use and vkconfig reads).
pub struct SettingDoc {
    /// The setting's key: in the manifest, in `VkLayerSettingEXT` and,
    /// after [`FILE_PREFIX`], in `vk_layer_settings.txt`.
    pub key: &'static str,
    /// The environment variable that sets it.
    pub env: &'static str,
    pub label: &'static str,
    pub description: &'static str,
    /// The manifest's type: `BOOL`, `INT`, `SAVE_FILE`, `STRING`, `LIST`,
    /// `FLAGS` or `ENUM`.
    pub kind: &'static str,
    /// The default, as the JSON text of the manifest's `default`.
    pub default_json: &'static str,
    /// For `FLAGS` and `ENUM`: each value's key and description.
    pub flags: &'static [(&'static str, &'static str)],
}

/// Every setting, in the order the manifest lists them.
pub const DOCUMENTED: [SettingDoc; 13] = [
    SettingDoc {
        key: "report_flags",
        env: REPORT,
        label: "Message Severity",
        description: "The severities reported, comma-separated. A value naming anything else is ignored with a warning, and the next source's value or the default applies.",
        kind: "FLAGS",
        default_json: r#"["error", "warning"]"#,
        flags: &[
            ("error", "Report violations of valid usage."),
            ("warning", "Report what is valid but likely wrong, device builds whose contents the layer could not read (once per device and cause, with a count at vkDestroyDevice), and problems with the layer's settings. `warn` is accepted too."),
            ("info", "Report which rules could not be checked for each call and why, and, at vkCreateInstance, the settings in effect and where each came from."),
        ],
    },
    SettingDoc {
        key: "debug_action",
        env: DEBUG_ACTION,
        label: "Debug Action",
        description: "What the layer does with a reported message besides calling the application's callbacks, which always receive it. The Khronos names (VK_DBG_LAYER_ACTION_LOG_MSG, ..._CALLBACK, ..._BREAK, ..._IGNORE, ..._DEBUG_OUTPUT) are accepted too.",
        kind: "FLAGS",
        default_json: r#"["log"]"#,
        flags: &[
            ("log", "Write the message to log_filename, or to stderr when the application registered no callback."),
            ("callback", "Call the application's VK_EXT_debug_utils messengers and VK_EXT_debug_report callbacks; they are called whatever this setting says, so alone it means no log."),
            ("break", "Raise SIGTRAP after reporting a message, so a debugger stops at the call."),
            ("ignore", "Take no action of the layer's own."),
        ],
    },
    SettingDoc {
        key: "message_id_filter",
        env: MESSAGE_ID_FILTER,
        label: "Mute Message VUIDs",
        description: "Messages not to report, comma-separated: VUIDs, OMMCHECK rule ids, or MessageID numbers in hexadecimal (0x...) or decimal.",
        kind: "LIST",
        default_json: "[]",
        flags: &[],
    },
    SettingDoc {
        key: "duplicate_message_limit",
        env: DUPLICATE_LIMIT,
        label: "Max Duplicated Messages",
        description: "How many times one rule is reported per instance; 0 reports every time.",
        kind: "INT",
        default_json: "10",
        flags: &[],
    },
    SettingDoc {
        key: "log_filename",
        env: LOG_FILE,
        label: "Log Filename",
        description: "A file every reported message is appended to; empty, stdout or stderr for none. A file that cannot be opened is reported, and messages go to stderr instead.",
        kind: "SAVE_FILE",
        default_json: r#""""#,
        flags: &[],
    },
    SettingDoc {
        key: "profile",
        env: PROFILE,
        label: "Device Limits",
        description: "The limits checks use: spec-minimum (what every device with the extension meets), permissive, or the path of a JSON object of limits overriding spec-minimum. Empty: the limits the device reports, where they meet spec-minimum.",
        kind: "STRING",
        default_json: r#""""#,
        flags: &[],
    },
    SettingDoc {
        key: "tier",
        env: TIER,
        label: "Validation Tier",
        description: "How far the checks look; each tier adds to the one before.",
        kind: "ENUM",
        default_json: r#""content""#,
        flags: &[
            ("params", "The call's parameters and the device's features and limits."),
            ("state", "Also the objects the layer tracks: micromaps, buffers, memory, command buffers."),
            ("content", "Also the bytes builds read: triangle arrays, micromap data, index buffers."),
            ("simulate", "As content, in the layer."),
        ],
    },
    SettingDoc {
        key: "break_on_error",
        env: BREAK_ON_ERROR,
        label: "Break On Error",
        description: "An older spelling of debug_action's break: true adds break to the debug action.",
        kind: "BOOL",
        default_json: "false",
        flags: &[],
    },
    SettingDoc {
        key: "gpu_readback",
        env: GPU_READBACK,
        label: "GPU Readback Of Build Inputs",
        description: "From the content tier: before a device build whose inputs the host cannot read (device-local memory, or memory the GPU writes), copy the ranges it reads into layer-owned host-visible memory and check them once the submission is known to be complete. The application's memory is never written.",
        kind: "BOOL",
        default_json: "true",
        flags: &[],
    },
    SettingDoc {
        key: "gpu_readback_max_bytes",
        env: GPU_READBACK_MAX_BYTES,
        label: "GPU Readback Memory",
        description: "The most bytes of layer-owned memory the readback copies of one device hold at once; a build past it is reported as not checked.",
        kind: "INT",
        default_json: "268435456",
        flags: &[],
    },
    SettingDoc {
        key: "gpu_readback_indirect_max_bytes",
        env: GPU_READBACK_INDIRECT_MAX_BYTES,
        label: "Indirect Build Input Window",
        description: "The most bytes read of each input whose extent an indirect build's range infos decide (opacity index buffers, instances), from its start towards the end of its buffer; what the ranges place past it is reported as not checked.",
        kind: "INT",
        default_json: "16777216",
        flags: &[],
    },
    SettingDoc {
        key: "provenance_store",
        env: PROVENANCE_STORE,
        label: "Provenance Store",
        description: "The directory of the store that links serialized micromaps and acceleration structures to what they were serialized from, across runs and processes: empty for $XDG_CACHE_HOME/ommcheck (or $HOME/.cache/ommcheck), a path, or off to keep provenance in memory only. It holds fingerprints, sizes and object kinds, never application data.",
        kind: "STRING",
        default_json: r#""""#,
        flags: &[],
    },
    SettingDoc {
        key: "provenance_store_max_bytes",
        env: PROVENANCE_STORE_MAX_BYTES,
        label: "Provenance Store Size",
        description: "The most bytes the provenance store's file holds; past it the oldest entries are dropped (said once). At least 65536.",
        kind: "INT",
        default_json: "16777216",
        flags: &[],
    },
];

/// A named set of settings vkconfig offers in one click.
pub struct PresetDoc {
    pub label: &'static str,
    pub description: &'static str,
    /// Setting keys and their values, as JSON text.
    pub settings: &'static [(&'static str, &'static str)],
}

/// The manifest's presets.
pub const PRESETS: [PresetDoc; 2] = [
    PresetDoc {
        label: "Fast",
        description: "Only the call's parameters and the device's limits: the least overhead per call.",
        settings: &[("tier", r#""params""#)],
    },
    PresetDoc {
        label: "Thorough",
        description: "Every check, the contents of builds included, reading device memory back where the host cannot see it.",
        settings: &[("tier", r#""simulate""#), ("gpu_readback", "true")],
    },
];
