//! The calls the layer makes to the next layer on its own behalf, which
//! the application did not make: [`OwnCall`] names each, with the command
//! it calls, why, and the errors `vk.xml` says that command may return.
//!
//! Every such call runs inside [`call`] or [`checked`], which note on this
//! thread which own call is under way. The layer's tests read that note
//! (`testing::own_call_in_progress`), so their fake driver can fail the
//! layer's own calls, and only those, and can tell every call the layer
//! adds from the application's: one the layer made outside this module's
//! wrappers fails them (tests/own_calls.rs). The note costs a
//! thread-local write per own call; own calls are few (a readback block
//! allocated, a fence or semaphore asked about at a wait).

use std::cell::Cell;
use std::fmt;

use ash::vk;

/// Declares [`OwnCall`] and its tables from one list, so a call site
/// cannot be added without its command, purpose and errors, and
/// [`OwnCall::ALL`] holds every variant.
macro_rules! own_calls {
    ($(
        $(#[doc = $doc:literal])*
        $variant:ident = $command:literal, $purpose:literal, [$($error:ident),*];
    )*) => {
        /// One of the layer's own calls to the next layer (see the module).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum OwnCall {
            $($(#[doc = $doc])* $variant,)*
        }

        impl OwnCall {
            /// Every own call, in declaration order.
            pub const ALL: &'static [OwnCall] = &[$(OwnCall::$variant),*];

            /// The Vulkan command the call makes.
            pub const fn command(self) -> &'static str {
                match self {
                    $(OwnCall::$variant => $command,)*
                }
            }

            /// Why the layer makes it, as a message says it.
            pub const fn purpose(self) -> &'static str {
                match self {
                    $(OwnCall::$variant => $purpose,)*
                }
            }

            /// The error codes `vk.xml` lists for the command (its
            /// `errorcodes`); empty for a command that returns no `VkResult`.
            pub const fn errors(self) -> &'static [vk::Result] {
                match self {
                    $(OwnCall::$variant => &[$(vk::Result::$error),*],)*
                }
            }

            /// The cause a failure of this call is reported under, once
            /// per device (`OMMCHECK-layer-contents-not-checked`).
            pub const fn cause(self) -> &'static str {
                match self {
                    $(OwnCall::$variant => concat!("failed-", $command),)*
                }
            }
        }
    };
}

own_calls! {
    /// At `vkCreateDevice`: the memory types, to tell device-local memory
    /// from host-visible memory.
    DeviceMemoryProperties = "vkGetPhysicalDeviceMemoryProperties",
        "to learn the device's memory types", [];
    /// At `vkCreateDevice`: the queue families' flags (both calls, count
    /// and fill).
    QueueFamilyProperties = "vkGetPhysicalDeviceQueueFamilyProperties",
        "to learn the device's queue families", [];
    /// At `vkCreateDevice`: the micromap limits the physical device
    /// reports (the KHR alias where only it exists).
    DeviceLimits = "vkGetPhysicalDeviceProperties2",
        "to learn the device's micromap limits", [];
    /// A block of readback memory: its buffer.
    ReadbackCreateBuffer = "vkCreateBuffer",
        "to create the buffer GPU readback copies build inputs into",
        [ERROR_OUT_OF_HOST_MEMORY, ERROR_OUT_OF_DEVICE_MEMORY,
         ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS, ERROR_UNKNOWN, ERROR_VALIDATION_FAILED_EXT];
    ReadbackMemoryRequirements = "vkGetBufferMemoryRequirements",
        "to size the memory of its readback buffer", [];
    ReadbackAllocateMemory = "vkAllocateMemory",
        "to allocate the host-visible memory GPU readback copies build inputs into",
        [ERROR_OUT_OF_HOST_MEMORY, ERROR_OUT_OF_DEVICE_MEMORY, ERROR_INVALID_EXTERNAL_HANDLE,
         ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS, ERROR_UNKNOWN, ERROR_VALIDATION_FAILED_EXT];
    ReadbackBindMemory = "vkBindBufferMemory",
        "to bind its readback buffer to its memory",
        [ERROR_OUT_OF_HOST_MEMORY, ERROR_OUT_OF_DEVICE_MEMORY,
         ERROR_INVALID_OPAQUE_CAPTURE_ADDRESS, ERROR_UNKNOWN, ERROR_VALIDATION_FAILED_EXT];
    ReadbackMapMemory = "vkMapMemory",
        "to map its readback memory for the host to read",
        [ERROR_OUT_OF_HOST_MEMORY, ERROR_OUT_OF_DEVICE_MEMORY, ERROR_MEMORY_MAP_FAILED,
         ERROR_UNKNOWN, ERROR_VALIDATION_FAILED_EXT];
    /// A readback buffer given back: one whose setup failed, a block left
    /// wholly free, or every block before `vkDestroyDevice`.
    ReadbackDestroyBuffer = "vkDestroyBuffer",
        "to give back a readback buffer", [];
    ReadbackFreeMemory = "vkFreeMemory",
        "to give back readback memory", [];
    /// Recorded into the application's command buffer before a build
    /// whose inputs are read back: the barriers around the copies.
    ReadbackBarrier = "vkCmdPipelineBarrier",
        "to order GPU readback's copies after earlier writes and before host reads", [];
    ReadbackCopy = "vkCmdCopyBuffer",
        "to copy a build's inputs into readback memory", [];
    /// At `vkWaitForFences` with `waitAll` VK_FALSE: which fences are
    /// signalled, so the read-back builds their submissions ran are checked.
    FenceStatus = "vkGetFenceStatus",
        "to learn which fence a vkWaitForFences without waitAll saw signalled",
        [ERROR_OUT_OF_HOST_MEMORY, ERROR_OUT_OF_DEVICE_MEMORY, ERROR_DEVICE_LOST,
         ERROR_UNKNOWN, ERROR_VALIDATION_FAILED_EXT];
    /// At `vkWaitSemaphores` with `VK_SEMAPHORE_WAIT_ANY_BIT`: the value
    /// each timeline semaphore reached (the KHR alias where only it exists).
    SemaphoreCounterValue = "vkGetSemaphoreCounterValue",
        "to learn which timeline value a vkWaitSemaphores with VK_SEMAPHORE_WAIT_ANY_BIT saw reached",
        [ERROR_OUT_OF_HOST_MEMORY, ERROR_OUT_OF_DEVICE_MEMORY, ERROR_DEVICE_LOST,
         ERROR_UNKNOWN, ERROR_VALIDATION_FAILED_EXT];
    /// The driver's sizes for a micromap build's shape the application
    /// did not ask about itself (07461, 07509).
    MicromapBuildSizes = "vkGetMicromapBuildSizesEXT",
        "to learn the driver's sizes for a micromap build", [];
    /// Whether the driver accepts serialized micromap data of a version
    /// the application did not ask about itself (07549).
    MicromapCompatibility = "vkGetDeviceMicromapCompatibilityEXT",
        "to learn whether the driver accepts serialized micromap data", [];
}

thread_local! {
    /// The own call this thread is making, if any.
    static IN_PROGRESS: Cell<Option<OwnCall>> = const { Cell::new(None) };
}

/// Puts back the note of the call under way before it, also if the call
/// unwinds.
struct Note(Option<OwnCall>);

impl Drop for Note {
    fn drop(&mut self) {
        IN_PROGRESS.set(self.0);
    }
}

/// Makes the own call `site` (`make` calls the next layer), noting it as
/// under way on this thread meanwhile.
pub(crate) fn call<R>(site: OwnCall, make: impl FnOnce() -> R) -> R {
    let _outer = Note(IN_PROGRESS.replace(Some(site)));
    make()
}

/// Makes the own call `site` that returns a `VkResult`: its success code,
/// or [`Failed`] for an error code (any negative value, also one `vk.xml`
/// does not list).
pub(crate) fn checked(
    site: OwnCall,
    make: impl FnOnce() -> vk::Result,
) -> Result<vk::Result, Failed> {
    let result = call(site, make);
    if result.as_raw() < 0 {
        Err(Failed { call: site, result })
    } else {
        Ok(result)
    }
}

/// The own call this thread is making now, if any (for the layer's tests,
/// through `testing::own_call_in_progress`).
pub fn in_progress() -> Option<OwnCall> {
    IN_PROGRESS.get()
}

/// An own call the next layer failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Failed {
    pub call: OwnCall,
    pub result: vk::Result,
}

impl fmt::Display for Failed {
    /// "the layer's own vkAllocateMemory (to ...) returned VK_ERROR_..."
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the layer's own {} ({}) returned {}",
            self.call.command(),
            self.call.purpose(),
            result_name(self.result)
        )
    }
}

/// `VK_ERROR_OUT_OF_DEVICE_MEMORY`, or the number of a value ash does not name.
pub fn result_name(result: vk::Result) -> String {
    let name = format!("{result:?}");
    if name.starts_with(|c: char| c.is_ascii_alphabetic()) {
        format!("VK_{name}")
    } else {
        format!("VkResult {}", result.as_raw())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_call_is_listed_once_and_only_result_returning_ones_have_errors() {
        let mut seen = std::collections::HashSet::new();
        for &call in OwnCall::ALL {
            assert!(seen.insert(call), "{call:?} listed twice");
            assert!(call.command().starts_with("vk"), "{call:?}");
            assert!(call.purpose().starts_with("to "), "{call:?}");
            assert!(call.errors().iter().all(|e| e.as_raw() < 0), "{call:?}");
        }
        // The commands that return VkResult, and only they, have errors.
        let with_errors: Vec<&str> = OwnCall::ALL
            .iter()
            .filter(|c| !c.errors().is_empty())
            .map(|c| c.command())
            .collect();
        assert_eq!(
            with_errors,
            [
                "vkCreateBuffer",
                "vkAllocateMemory",
                "vkBindBufferMemory",
                "vkMapMemory",
                "vkGetFenceStatus",
                "vkGetSemaphoreCounterValue"
            ]
        );
    }

    #[test]
    fn the_note_is_set_only_during_the_call_and_nests() {
        assert_eq!(in_progress(), None);
        let inner = call(OwnCall::ReadbackCreateBuffer, || {
            assert_eq!(in_progress(), Some(OwnCall::ReadbackCreateBuffer));
            call(OwnCall::ReadbackDestroyBuffer, in_progress)
        });
        assert_eq!(inner, Some(OwnCall::ReadbackDestroyBuffer));
        assert_eq!(in_progress(), None);
        let unwound = std::panic::catch_unwind(|| {
            call(OwnCall::FenceStatus, || panic!("a driver that unwinds"))
        });
        assert!(unwound.is_err());
        assert_eq!(in_progress(), None, "put back while unwinding");
    }

    #[test]
    fn errors_fail_and_success_codes_do_not() {
        let failed = checked(OwnCall::ReadbackMapMemory, || {
            vk::Result::ERROR_MEMORY_MAP_FAILED
        });
        assert_eq!(
            failed.unwrap_err().to_string(),
            "the layer's own vkMapMemory (to map its readback memory for the host to read) returned VK_ERROR_MEMORY_MAP_FAILED"
        );
        assert_eq!(
            checked(OwnCall::FenceStatus, || vk::Result::NOT_READY),
            Ok(vk::Result::NOT_READY)
        );
        assert_eq!(result_name(vk::Result::from_raw(-77)), "VkResult -77");
        assert_eq!(OwnCall::FenceStatus.cause(), "failed-vkGetFenceStatus");
    }
}
