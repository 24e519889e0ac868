//! Names a program gives its objects, so that findings name them as a
//! scene's do (`VkMicromapEXT 'disc' (0x330001)`, and `"name": "disc"` in
//! JSON): [`Validator::name_object`](crate::Validator::name_object), the
//! counterpart of `vkSetDebugUtilsObjectNameEXT`.

use std::collections::BTreeMap;

use super::{Finding, Report};

/// Object names by handle.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ObjectNames {
    by_handle: BTreeMap<u64, String>,
}

impl ObjectNames {
    /// Names `handle` `name` (an empty name removes the name, as with
    /// `vkSetDebugUtilsObjectNameEXT`).
    pub fn set(&mut self, handle: u64, name: impl Into<String>) {
        let name = name.into();
        if name.is_empty() {
            self.by_handle.remove(&handle);
        } else {
            self.by_handle.insert(handle, name);
        }
    }

    pub fn get(&self, handle: u64) -> Option<&str> {
        self.by_handle.get(&handle).map(String::as_str)
    }

    pub fn is_empty(&self) -> bool {
        self.by_handle.is_empty()
    }

    /// Gives each object of `finding` its name, where it has one and the
    /// finding does not name it already.
    pub fn name(&self, finding: &mut Finding) {
        for object in &finding.objects {
            if finding.at.name_of(object.handle).is_some() {
                continue;
            }
            if let Some(name) = self.get(object.handle) {
                finding.at.names.push((object.handle, name.to_string()));
            }
        }
    }

    /// [`Self::name`] for every finding of `report`.
    pub fn name_all(&self, report: &mut Report) {
        if self.is_empty() {
            return;
        }
        for finding in &mut report.findings {
            self.name(finding);
        }
    }
}
