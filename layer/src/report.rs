//! Delivering messages to the application's `VK_EXT_debug_utils`
//! messengers the way the Khronos validation layer does: `pMessageIdName`
//! is the VUID, `messageIdNumber` its MessageID, `pMessage` the Khronos-style
//! text, the objects in `pObjects`; a duplicate limit per rule; VK_TRUE from
//! a callback for an error asks for the call to be skipped. Older
//! applications' `VK_EXT_debug_report` callbacks receive the same messages.

#![allow(unsafe_code)]

use std::collections::HashMap;
use std::ffi::{c_char, c_void, CStr, CString};
use std::io::Write;
use std::sync::{Mutex, PoisonError};

use ash::vk;
use ommcheck::report::message_id;
use ommcheck::{Finding, Severity};

use crate::settings::Settings;

pub use crate::ids::{CONTENTS_NOT_CHECKED, EFFECTIVE_SETTINGS, INTERNAL_ERROR, SETTINGS_PROBLEM};

/// How often each cause of a once-per-device warning came up on one
/// device, in the order first reported (few causes: a list).
#[derive(Debug, Default)]
pub struct CauseCounts(Vec<(&'static str, u64)>);

impl CauseCounts {
    /// Counts `count` more of `cause`; true for the first report of
    /// `cause` on the device, which is when its warning is said.
    pub fn first_report_of(&mut self, cause: &'static str, count: u64) -> bool {
        match self.0.iter_mut().find(|(c, _)| *c == cause) {
            Some((_, total)) => {
                *total = total.saturating_add(count);
                false
            }
            None => {
                self.0.push((cause, count));
                true
            }
        }
    }

    /// Each cause with its count, in the order first reported.
    pub fn counts(&self) -> &[(&'static str, u64)] {
        &self.0
    }
}

/// One message to deliver.
#[derive(Clone, Debug, PartialEq)]
pub struct Message {
    /// The VUID or rule id (`pMessageIdName`).
    pub id: &'static str,
    pub severity: Severity,
    /// The Khronos-style text (`pMessage`).
    pub text: String,
    /// `pObjects`: the call's command buffer or device, then the finding's objects.
    pub objects: Vec<(vk::ObjectType, u64)>,
}

impl Message {
    /// The message of a core finding; `call_object` is the dispatchable
    /// object the call was made on.
    pub fn from_finding(finding: &Finding, call_object: (vk::ObjectType, u64)) -> Self {
        let objects = std::iter::once(call_object)
            .chain(
                finding
                    .objects
                    .iter()
                    .map(|object| (object_type(object.ty), object.handle)),
            )
            .collect();
        Self {
            id: finding.rule.as_str(),
            severity: finding.severity,
            text: finding.to_string(),
            objects,
        }
    }

    /// A message about the layer itself, in the same text layout as findings.
    pub fn about_layer(id: &'static str, severity: Severity, function: &str, text: &str) -> Self {
        Self {
            id,
            severity,
            text: format!(
                "{}: [ {id} ] | MessageID = {:#010x} | {function}(): {text}",
                severity.label(),
                message_id(id)
            ),
            objects: Vec::new(),
        }
    }
}

/// The `VkObjectType` of an object type name the core reports.
fn object_type(name: &str) -> vk::ObjectType {
    match name {
        "VkBuffer" => vk::ObjectType::BUFFER,
        "VkMicromapEXT" => vk::ObjectType::MICROMAP_EXT,
        "VkAccelerationStructureKHR" => vk::ObjectType::ACCELERATION_STRUCTURE_KHR,
        "VkCommandBuffer" => vk::ObjectType::COMMAND_BUFFER,
        "VkDevice" => vk::ObjectType::DEVICE,
        "VkDeviceMemory" => vk::ObjectType::DEVICE_MEMORY,
        "VkQueryPool" => vk::ObjectType::QUERY_POOL,
        "VkDeferredOperationKHR" => vk::ObjectType::DEFERRED_OPERATION_KHR,
        "VkPipeline" => vk::ObjectType::PIPELINE,
        "VkShaderEXT" => vk::ObjectType::SHADER_EXT,
        "VkShaderModule" => vk::ObjectType::SHADER_MODULE,
        _ => vk::ObjectType::UNKNOWN,
    }
}

/// A messenger the application created or chained into `VkInstanceCreateInfo`.
#[derive(Clone, Copy, Debug)]
pub struct Messenger {
    /// The `VkDebugUtilsMessengerEXT` (0 for one chained at instance creation).
    pub handle: u64,
    pub severities: vk::DebugUtilsMessageSeverityFlagsEXT,
    pub types: vk::DebugUtilsMessageTypeFlagsEXT,
    pub callback: unsafe extern "system" fn(
        vk::DebugUtilsMessageSeverityFlagsEXT,
        vk::DebugUtilsMessageTypeFlagsEXT,
        *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
        *mut c_void,
    ) -> vk::Bool32,
    /// `pUserData`, its provenance exposed so it can be handed back.
    pub user_data: usize,
}

/// A `VK_EXT_debug_report` callback the application created or chained
/// into `VkInstanceCreateInfo`.
#[derive(Clone, Copy, Debug)]
pub struct ReportCallback {
    /// The `VkDebugReportCallbackEXT` (0 for one chained at instance creation).
    pub handle: u64,
    pub flags: vk::DebugReportFlagsEXT,
    pub callback: unsafe extern "system" fn(
        vk::DebugReportFlagsEXT,
        vk::DebugReportObjectTypeEXT,
        u64,
        usize,
        i32,
        *const c_char,
        *const c_char,
        *mut c_void,
    ) -> vk::Bool32,
    /// `pUserData`, its provenance exposed so it can be handed back.
    pub user_data: usize,
}

/// The application's callbacks of both extensions.
#[derive(Clone, Debug, Default)]
pub struct Callbacks {
    pub messengers: Vec<Messenger>,
    pub report_callbacks: Vec<ReportCallback>,
}

impl Callbacks {
    fn is_empty(&self) -> bool {
        self.messengers.is_empty() && self.report_callbacks.is_empty()
    }

    fn extend(&mut self, other: &Callbacks) {
        self.messengers.extend_from_slice(&other.messengers);
        self.report_callbacks
            .extend_from_slice(&other.report_callbacks);
    }
}

/// An instance's settings, callbacks and duplicate counts.
#[derive(Debug, Default)]
pub struct Reporter {
    settings: Settings,
    /// The log file, opened when the instance is created.
    log_file: Option<Mutex<std::fs::File>>,
    callbacks: Mutex<Callbacks>,
    /// Chained in `VkInstanceCreateInfo`: as the specification says, these
    /// receive messages only during `vkCreateInstance` and `vkDestroyInstance`.
    instance_lifecycle: Callbacks,
    /// Messages reported so far per MessageID.
    counts: Mutex<HashMap<u32, u32>>,
}

impl Reporter {
    /// The reporter of an instance, with the log file opened; the problem
    /// opening it, if any, is returned to be reported with the settings'.
    pub fn new(instance_lifecycle: Callbacks, settings: Settings) -> (Self, Option<String>) {
        let (log_file, problem) = match &settings.log_file {
            Some(path) => match std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
            {
                Ok(file) => (Some(Mutex::new(file)), None),
                Err(e) => (
                    None,
                    Some(format!(
                        "log_filename {} cannot be opened for writing ({e}); messages go to stderr instead",
                        path.display()
                    )),
                ),
            },
            None => (None, None),
        };
        let reporter = Self {
            settings,
            log_file,
            instance_lifecycle,
            ..Self::default()
        };
        (reporter, problem)
    }

    /// The settings of the instance this reporter belongs to.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    pub fn add(&self, messenger: Messenger) {
        lock(&self.callbacks).messengers.push(messenger);
    }

    pub fn remove(&self, handle: u64) {
        lock(&self.callbacks)
            .messengers
            .retain(|m| m.handle != handle);
    }

    pub fn add_report_callback(&self, callback: ReportCallback) {
        lock(&self.callbacks).report_callbacks.push(callback);
    }

    pub fn remove_report_callback(&self, handle: u64) {
        lock(&self.callbacks)
            .report_callbacks
            .retain(|c| c.handle != handle);
    }

    /// Delivers `messages` to every callback whose masks match (with the
    /// ones chained at instance creation when `instance_lifecycle`), and
    /// with the `log` action to the log file, or stderr when no callback
    /// exists. Returns whether a callback returned VK_TRUE for an error:
    /// the call is to be skipped. With the `break` action, raises SIGTRAP
    /// after reporting.
    pub fn deliver(&self, messages: &[Message], instance_lifecycle: bool) -> bool {
        self.deliver_with(messages, instance_lifecycle, false)
    }

    /// Warns of settings the layer could not use. These warnings reach the
    /// user whatever the severity filter says: the callbacks receive them
    /// and stderr always shows them, since a bad value may be what keeps
    /// the callbacks from hearing anything.
    pub fn warn_about_settings(&self, problems: &[String], function: &str) {
        let messages: Vec<Message> = problems
            .iter()
            .map(|problem| {
                Message::about_layer(SETTINGS_PROBLEM, Severity::Warning, function, problem)
            })
            .collect();
        self.deliver_with(&messages, true, true);
    }

    fn deliver_with(&self, messages: &[Message], instance_lifecycle: bool, always: bool) -> bool {
        let settings = &self.settings;
        let mut callbacks = lock(&self.callbacks).clone();
        if instance_lifecycle {
            callbacks.extend(&self.instance_lifecycle);
        }
        let mut skip = false;
        let mut reported = false;
        for message in messages {
            let Some(text) = self.admit(settings, message, always) else {
                continue;
            };
            reported = true;
            if settings.actions.log || always {
                self.log(&text, callbacks.is_empty() || always);
            }
            let severity = severity_flag(message.severity);
            for messenger in &callbacks.messengers {
                if messenger.severities.contains(severity)
                    && messenger
                        .types
                        .contains(vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION)
                {
                    // SAFETY: the callback and its user data are what the
                    // application registered for this messenger.
                    let asked = unsafe { call(messenger, message, &text) };
                    skip |= asked && message.severity == Severity::Error;
                }
            }
            for callback in &callbacks.report_callbacks {
                if callback.flags.contains(report_flag(message.severity)) {
                    // SAFETY: as above, for a debug-report callback.
                    let asked = unsafe { call_report(callback, message, &text) };
                    skip |= asked && message.severity == Severity::Error;
                }
            }
        }
        if reported && settings.actions.break_into_debugger {
            break_into_debugger();
        }
        skip
    }

    /// Appends `text` to the log file and, when `to_stderr` or the log file
    /// could not be opened, writes it to stderr (as the Khronos layer's
    /// default callback does when the application registered none).
    fn log(&self, text: &str, to_stderr: bool) {
        let wanted_file = self.settings.log_file.is_some();
        if let Some(file) = &self.log_file {
            // A failed write cannot be reported anywhere better; drop it.
            drop(writeln!(lock(file), "{text}\n"));
        }
        if to_stderr || (wanted_file && self.log_file.is_none()) {
            eprintln!("{text}\n");
        }
    }

    /// The text to report for `message`, or None when `message_id_filter`
    /// mutes it, or (unless `always`) its severity is not reported or its
    /// rule has reached the duplicate limit.
    fn admit(&self, settings: &Settings, message: &Message, always: bool) -> Option<String> {
        if settings.message_filter.mutes(message.id) {
            return None;
        }
        if always {
            return Some(message.text.clone());
        }
        if !settings.reports(message.severity) {
            return None;
        }
        let limit = settings.duplicate_limit;
        let mut counts = lock(&self.counts);
        let count = counts.entry(message_id(message.id)).or_insert(0);
        *count = count.saturating_add(1);
        if limit == 0 || *count < limit {
            Some(message.text.clone())
        } else if *count == limit {
            Some(format!("(Warning - This VUID has now been reported {limit} times, which is the duplicate_message_limit value, this will be the last time reporting it). {}", message.text))
        } else {
            None
        }
    }
}

fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A panic caught while the lock was held leaves consistent data here
    // (plain lists and counters), so poisoning is ignored.
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

fn severity_flag(severity: Severity) -> vk::DebugUtilsMessageSeverityFlagsEXT {
    match severity {
        Severity::Error => vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        Severity::Warning => vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
        Severity::Info => vk::DebugUtilsMessageSeverityFlagsEXT::INFO,
    }
}

fn report_flag(severity: Severity) -> vk::DebugReportFlagsEXT {
    match severity {
        Severity::Error => vk::DebugReportFlagsEXT::ERROR,
        Severity::Warning => vk::DebugReportFlagsEXT::WARNING,
        Severity::Info => vk::DebugReportFlagsEXT::INFORMATION,
    }
}

/// The `VkDebugReportObjectTypeEXT` of an object: the same number as its
/// `VkObjectType` for the core 1.0 types and acceleration structures;
/// debug report has none for micromaps and later types.
fn report_object_type(object_type: vk::ObjectType) -> vk::DebugReportObjectTypeEXT {
    let raw = object_type.as_raw();
    if (0..=25).contains(&raw) || object_type == vk::ObjectType::ACCELERATION_STRUCTURE_KHR {
        vk::DebugReportObjectTypeEXT::from_raw(raw)
    } else {
        vk::DebugReportObjectTypeEXT::UNKNOWN
    }
}

/// `pLayerPrefix` of debug-report messages.
const REPORT_LAYER_PREFIX: &CStr = c"OMMCHECK";

/// A C string of `text`, with any NUL turned into a space.
fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).unwrap_or_default()
}

/// Calls one messenger's callback; returns what it returned.
///
/// # Safety
/// `messenger` must hold a callback and user data the application registered.
unsafe fn call(messenger: &Messenger, message: &Message, text: &str) -> bool {
    let id = c_string(message.id);
    let text = c_string(text);
    let objects: Vec<vk::DebugUtilsObjectNameInfoEXT<'_>> = message
        .objects
        .iter()
        .map(
            |&(object_type, object_handle)| vk::DebugUtilsObjectNameInfoEXT {
                object_type,
                object_handle,
                ..Default::default()
            },
        )
        .collect();
    let data = vk::DebugUtilsMessengerCallbackDataEXT {
        p_message_id_name: id.as_ptr(),
        // The Khronos layer passes the XXH32 hash's bits as the signed int.
        message_id_number: message_id(message.id) as i32,
        p_message: text.as_ptr(),
        object_count: u32::try_from(objects.len()).unwrap_or(0),
        p_objects: objects.as_ptr(),
        ..Default::default()
    };
    // SAFETY: `data` and what it points to live until the callback returns;
    // the callback and user data are the application's (the caller's guarantee).
    let result = unsafe {
        (messenger.callback)(
            severity_flag(message.severity),
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
            &data,
            std::ptr::with_exposed_provenance_mut(messenger.user_data),
        )
    };
    result == vk::TRUE
}

/// Calls one debug-report callback with the message's first object (the
/// call's), its MessageID as the message code; returns what it returned.
///
/// # Safety
/// `callback` must hold a callback and user data the application registered.
unsafe fn call_report(callback: &ReportCallback, message: &Message, text: &str) -> bool {
    let text = c_string(text);
    let (object_type, object) = message
        .objects
        .first()
        .copied()
        .unwrap_or((vk::ObjectType::UNKNOWN, 0));
    // SAFETY: the strings live until the callback returns; the callback
    // and user data are the application's (the caller's guarantee).
    let result = unsafe {
        (callback.callback)(
            report_flag(message.severity),
            report_object_type(object_type),
            object,
            0,
            // The same bits as debug utils' messageIdNumber.
            message_id(message.id) as i32,
            REPORT_LAYER_PREFIX.as_ptr(),
            text.as_ptr(),
            std::ptr::with_exposed_provenance_mut(callback.user_data),
        )
    };
    result == vk::TRUE
}

/// Stops the process in a debugger, as the Khronos layer's break action
/// does: SIGTRAP, which a debugger catches and which otherwise ends the
/// process (the user asked for that with the `break` action).
fn break_into_debugger() {
    // SAFETY: raise() has no memory preconditions; SIGTRAP's disposition is
    // the process's (a debugger's trap, or the default action).
    unsafe {
        libc::raise(libc::SIGTRAP);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_messages_follow_the_finding_layout() {
        let message = Message::about_layer(
            INTERNAL_ERROR,
            Severity::Error,
            "vkCmdBuildMicromapsEXT",
            "a check panicked",
        );
        assert!(message
            .text
            .starts_with("Validation Error: [ OMMCHECK-layer-internal-error ] | MessageID = 0x"));
        assert!(message
            .text
            .ends_with("| vkCmdBuildMicromapsEXT(): a check panicked"));
    }

    #[test]
    fn object_types_of_core_findings() {
        assert_eq!(object_type("VkMicromapEXT"), vk::ObjectType::MICROMAP_EXT);
        assert_eq!(object_type("VkBuffer"), vk::ObjectType::BUFFER);
        assert_eq!(object_type("VkSomethingNew"), vk::ObjectType::UNKNOWN);
    }

    #[test]
    fn the_duplicate_limit_marks_the_last_report() {
        let reporter = Reporter::default();
        let settings = Settings {
            duplicate_limit: 2,
            ..Settings::default()
        };
        let message = Message::about_layer(INTERNAL_ERROR, Severity::Error, "f", "x");
        let first = reporter.admit(&settings, &message, false);
        let second = reporter.admit(&settings, &message, false);
        let third = reporter.admit(&settings, &message, false);
        assert_eq!(first.as_deref(), Some(message.text.as_str()));
        assert!(second
            .unwrap()
            .starts_with("(Warning - This VUID has now been reported 2 times"));
        assert_eq!(third, None);
        let info = Message::about_layer(INTERNAL_ERROR, Severity::Info, "f", "x");
        assert_eq!(reporter.admit(&settings, &info, false), None);
    }

    /// What the test callbacks received: (flags or severity bits, object
    /// type, object, message code or id number, id or prefix, text).
    type Received = Vec<(u32, i32, u64, i32, String, String)>;

    unsafe extern "system" fn record_report(
        flags: vk::DebugReportFlagsEXT,
        object_type: vk::DebugReportObjectTypeEXT,
        object: u64,
        _location: usize,
        code: i32,
        prefix: *const c_char,
        text: *const c_char,
        user_data: *mut c_void,
    ) -> vk::Bool32 {
        // SAFETY: the test passes a Mutex<Received> as user data, and the
        // layer NUL-terminated strings.
        let (received, prefix, text) = unsafe {
            (
                &*user_data.cast::<Mutex<Received>>(),
                CStr::from_ptr(prefix),
                CStr::from_ptr(text),
            )
        };
        lock(received).push((
            flags.as_raw(),
            object_type.as_raw(),
            object,
            code,
            prefix.to_string_lossy().into(),
            text.to_string_lossy().into(),
        ));
        vk::TRUE
    }

    fn report_callback(received: &Mutex<Received>, flags: vk::DebugReportFlagsEXT) -> Callbacks {
        Callbacks {
            messengers: Vec::new(),
            report_callbacks: vec![ReportCallback {
                handle: 7,
                flags,
                callback: record_report,
                user_data: (received as *const Mutex<Received>).expose_provenance(),
            }],
        }
    }

    #[test]
    fn debug_report_callbacks_receive_flags_object_and_message_code() {
        let received = Mutex::new(Received::new());
        let reporter = Reporter::default();
        reporter.add_report_callback(
            report_callback(&received, vk::DebugReportFlagsEXT::ERROR).report_callbacks[0],
        );
        let mut error = Message::about_layer(INTERNAL_ERROR, Severity::Error, "f", "x");
        error.objects = vec![(vk::ObjectType::COMMAND_BUFFER, 0xc0ffee)];
        let warning = Message::about_layer(SETTINGS_PROBLEM, Severity::Warning, "f", "y");
        let skip = reporter.deliver(&[error.clone(), warning], false);
        assert!(skip, "VK_TRUE for an error asks for the call to be skipped");
        let received = received.into_inner().unwrap();
        assert_eq!(
            received,
            [(
                vk::DebugReportFlagsEXT::ERROR.as_raw(),
                vk::DebugReportObjectTypeEXT::COMMAND_BUFFER.as_raw(),
                0xc0ffee,
                message_id(INTERNAL_ERROR) as i32,
                "OMMCHECK".to_string(),
                error.text,
            )]
        );
        assert_eq!(
            report_object_type(vk::ObjectType::MICROMAP_EXT),
            vk::DebugReportObjectTypeEXT::UNKNOWN
        );
        assert_eq!(
            report_object_type(vk::ObjectType::ACCELERATION_STRUCTURE_KHR),
            vk::DebugReportObjectTypeEXT::ACCELERATION_STRUCTURE_KHR
        );
        reporter.remove_report_callback(7);
        assert!(lock(&reporter.callbacks).is_empty());
    }

    #[test]
    fn settings_warnings_pass_every_severity_filter_but_message_id_filter_mutes() {
        let received = Mutex::new(Received::new());
        let settings = Settings {
            report: vec![Severity::Error],
            ..Settings::default()
        };
        let (reporter, problem) = Reporter::new(
            report_callback(&received, vk::DebugReportFlagsEXT::WARNING),
            settings.clone(),
        );
        assert_eq!(problem, None);
        reporter.warn_about_settings(&["OMMCHECK_REPORT=\"errors\"".into()], "vkCreateInstance");
        let warning = Message::about_layer(INTERNAL_ERROR, Severity::Warning, "f", "x");
        reporter.deliver(&[warning], true);
        let texts: Vec<String> = lock(&received).iter().map(|r| r.5.clone()).collect();
        assert_eq!(texts.len(), 1, "{texts:?}");
        assert!(texts[0].contains("OMMCHECK-layer-settings"), "{texts:?}");

        let muted = Settings {
            message_filter: crate::settings::parse(
                &crate::settings::Sources {
                    variable: &|name| {
                        (name == crate::settings::MESSAGE_ID_FILTER)
                            .then(|| SETTINGS_PROBLEM.to_uppercase())
                    },
                    variable_names: &[],
                    api: &Vec::new(),
                    file: &Default::default(),
                },
                |_| Err(std::io::ErrorKind::NotFound.into()),
            )
            .0
            .message_filter,
            ..settings
        };
        let received = Mutex::new(Received::new());
        let (reporter, _) = Reporter::new(
            report_callback(&received, vk::DebugReportFlagsEXT::WARNING),
            muted,
        );
        reporter.warn_about_settings(&["x".into()], "vkCreateInstance");
        assert!(lock(&received).is_empty());
    }

    #[test]
    fn an_unwritable_log_file_is_a_problem_and_messages_still_arrive() {
        let received = Mutex::new(Received::new());
        let path = std::env::temp_dir()
            .join("ommcheck-no-such-directory")
            .join("log.txt");
        let (reporter, problem) = Reporter::new(
            report_callback(&received, vk::DebugReportFlagsEXT::ERROR),
            Settings {
                log_file: Some(path.clone()),
                ..Settings::default()
            },
        );
        let problem = problem.expect("the open failure is reported");
        assert!(problem.contains(&path.display().to_string()), "{problem}");
        assert!(problem.contains("messages go to stderr"), "{problem}");
        let error = Message::about_layer(INTERNAL_ERROR, Severity::Error, "f", "x");
        reporter.deliver(&[error], true);
        assert_eq!(lock(&received).len(), 1);
    }
}
