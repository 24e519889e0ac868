//! Delivering messages to the application's `VK_EXT_debug_utils`
//! messengers the way the Khronos validation layer does: `pMessageIdName`
//! is the VUID, `messageIdNumber` its MessageID, `pMessage` the Khronos-style
//! text, the objects in `pObjects`; a duplicate limit per rule; VK_TRUE from
//! a callback for an error asks for the call to be skipped.

#![allow(unsafe_code)]

use std::collections::HashMap;
use std::ffi::{c_void, CString};
use std::io::Write;
use std::sync::{Mutex, OnceLock, PoisonError};

use ash::vk;
use ommcheck::report::message_id;
use ommcheck::{Finding, Severity};

use crate::settings::Settings;

/// The id of a message about the layer itself (a caught panic).
pub const INTERNAL_ERROR: &str = "OMMCHECK-layer-internal-error";
/// The id of a message about a setting the layer could not use.
pub const SETTINGS_PROBLEM: &str = "OMMCHECK-layer-settings";
/// The id of the information that a device build's contents (triangle
/// arrays, micromap data, index buffers) could not be read at submission,
/// so their content rules were not checked: the memory holding them is
/// device-local, not mapped, or not known to the layer. Reported once per
/// device, naming the first such build and why.
pub const CONTENTS_NOT_CHECKED: &str = "OMMCHECK-layer-contents-not-checked";

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

/// An instance's settings, messengers and duplicate counts.
#[derive(Debug, Default)]
pub struct Reporter {
    settings: Settings,
    /// The log file, opened on the first message that needs it.
    log_file: OnceLock<Option<Mutex<std::fs::File>>>,
    messengers: Mutex<Vec<Messenger>>,
    /// Chained in `VkInstanceCreateInfo`: as the specification says, these
    /// receive messages only during `vkCreateInstance` and `vkDestroyInstance`.
    instance_lifecycle: Vec<Messenger>,
    /// Messages reported so far per MessageID.
    counts: Mutex<HashMap<u32, u32>>,
}

impl Reporter {
    pub fn new(instance_lifecycle: Vec<Messenger>, settings: Settings) -> Self {
        Self {
            settings,
            instance_lifecycle,
            ..Self::default()
        }
    }

    /// The settings of the instance this reporter belongs to.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    pub fn add(&self, messenger: Messenger) {
        lock(&self.messengers).push(messenger);
    }

    pub fn remove(&self, handle: u64) {
        lock(&self.messengers).retain(|m| m.handle != handle);
    }

    /// Delivers `messages` to every messenger whose masks match (with the
    /// messengers chained at instance creation when `instance_lifecycle`),
    /// to the log file, and to stderr when no messenger exists. Returns
    /// whether a callback returned VK_TRUE for an error: the call is to be
    /// skipped. With `break_on_error`, raises SIGTRAP after reporting an
    /// error.
    pub fn deliver(&self, messages: &[Message], instance_lifecycle: bool) -> bool {
        let settings = &self.settings;
        let mut messengers = lock(&self.messengers).clone();
        if instance_lifecycle {
            messengers.extend_from_slice(&self.instance_lifecycle);
        }
        let mut skip = false;
        let mut reported_error = false;
        for message in messages {
            let Some(text) = self.admit(settings, message) else {
                continue;
            };
            self.log(&text, messengers.is_empty());
            reported_error |= message.severity == Severity::Error;
            let severity = severity_flag(message.severity);
            for messenger in &messengers {
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
        }
        if reported_error && settings.break_on_error {
            break_into_debugger();
        }
        skip
    }

    /// Appends `text` to the log file; writes it to stderr instead when
    /// there is neither a log file nor a messenger (as the Khronos layer's
    /// default callback does).
    fn log(&self, text: &str, no_messenger: bool) {
        let file = self.log_file.get_or_init(|| {
            let path = self.settings.log_file.as_ref()?;
            std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .ok()
                .map(Mutex::new)
        });
        match file {
            // A failed write cannot be reported anywhere better; drop it.
            Some(file) => drop(writeln!(lock(file), "{text}\n")),
            None if no_messenger => eprintln!("{text}\n"),
            None => {}
        }
    }

    /// The text to report for `message`, or None when its severity is not
    /// reported or its rule has reached the duplicate limit.
    fn admit(&self, settings: &Settings, message: &Message) -> Option<String> {
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

/// Stops the process in a debugger, as the Khronos layer's break action
/// does: SIGTRAP, which a debugger catches and which otherwise ends the
/// process (the user asked for that with `break_on_error`).
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
        let first = reporter.admit(&settings, &message);
        let second = reporter.admit(&settings, &message);
        let third = reporter.admit(&settings, &message);
        assert_eq!(first.as_deref(), Some(message.text.as_str()));
        assert!(second
            .unwrap()
            .starts_with("(Warning - This VUID has now been reported 2 times"));
        assert_eq!(third, None);
        let info = Message::about_layer(INTERNAL_ERROR, Severity::Info, "f", "x");
        assert_eq!(reporter.admit(&settings, &info), None);
    }
}
