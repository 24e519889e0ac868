//! This layer's intercepts of the pipeline, shader, synchronization and
//! shader-running commands ([`crate::pipelines`], [`crate::sync`],
//! [`crate::work`]), by command name. The table is made from the list
//! that makes the next layer's functions for these commands
//! ([`pipe_commands`]): each command's intercept is the function named
//! like its field in `PipeFns`, so a command listed without one does not
//! compile.

#![allow(unsafe_code)]

use std::ffi::CStr;

use ash::vk;

use crate::dispatch::next_fns::pipe_commands;
use crate::intercept::as_void;
// The intercepts, found by the names of their fields.
use crate::pipelines::*;
use crate::sync::*;
use crate::work::*;

macro_rules! intercept_table {
    ($($field:ident: $pfn:ty = $name:literal;)*) => {
        /// This layer's function for a command of this table.
        pub fn intercept(name: &CStr) -> vk::PFN_vkVoidFunction {
            $(if name == $name {
                return as_void($field as $pfn);
            })*
            None
        }
    };
}
pipe_commands!(intercept_table);
