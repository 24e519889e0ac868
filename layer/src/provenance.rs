//! Serialization provenance in the layer: the bytes host serializations
//! write are fingerprinted after the driver wrote them, a host
//! deserialization's source before the driver reads it, and the
//! fingerprints go to the persistent provenance store
//! (`ommcheck::state::provenance::store`) the `provenance_store` setting
//! names, one per process and directory, shared by every device.
//!
//! Device serializations (`vkCmdCopyMicromapToMemoryEXT`,
//! `vkCmdCopyAccelerationStructureToMemoryKHR`) and device
//! deserializations are linked by address within the run by the core; their
//! bytes are not read back yet, so they do not reach the store
//! (docs/device-memory.md).

#![allow(unsafe_code)]

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, LazyLock, Mutex, PoisonError};

use ommcheck::state::provenance::store::Store;
use ommcheck::{Severity, Validator};

use crate::ids::PROVENANCE_STORE;
use crate::report::{Message, Reporter};
use crate::settings::{ProvenanceStore, Settings};

/// The bytes of a serialized header the layer reads before the size it
/// states: driver UUID, compatibility UUID, serialized and deserialized
/// sizes, and the count or packed block count.
const HEADER: usize = 56;
/// The offset of the serialized size in the header.
const SIZE_OFFSET: usize = 32;
/// The most serialized bytes the layer reads to fingerprint one
/// serialization: larger ones are not fingerprinted (said once).
pub const MAX_SERIALIZED_BYTES: u64 = 256 << 20;

/// The stores open in this process, by directory and bound.
type Stores = HashMap<(PathBuf, u64), Arc<Store>>;
static STORES: LazyLock<Mutex<Stores>> = LazyLock::new(Default::default);

/// The store the settings name, opened once per process (None: `off`, or
/// no directory: neither `XDG_CACHE_HOME` nor `HOME` is set, which is
/// said). Warnings from opening it are delivered through `reporter`.
pub fn open(settings: &Settings, reporter: &Reporter, function: &str) -> Option<Arc<Store>> {
    let dir = match &settings.provenance_store {
        ProvenanceStore::Off => return None,
        ProvenanceStore::Dir(dir) => dir.clone(),
        ProvenanceStore::Default => match Store::default_dir(|name| std::env::var(name).ok()) {
            Some(dir) => dir,
            None => {
                let text = "neither XDG_CACHE_HOME nor HOME is set, so the provenance store has no directory; provenance is kept in memory (set provenance_store to a directory to keep it across runs)";
                warn(reporter, function, &[text.to_string()]);
                return None;
            }
        },
    };
    let max_bytes = settings.provenance_store_max_bytes;
    let store = STORES
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .entry((dir.clone(), max_bytes))
        .or_insert_with(|| Arc::new(Store::open(&dir, max_bytes)))
        .clone();
    warn(reporter, function, &store.take_warnings());
    Some(store)
}

/// Delivers the store's warnings (each said once per process).
pub fn warn(reporter: &Reporter, function: &str, warnings: &[String]) {
    if warnings.is_empty() {
        return;
    }
    let messages: Vec<Message> = warnings
        .iter()
        .map(|w| Message::about_layer(PROVENANCE_STORE, Severity::Warning, function, w))
        .collect();
    reporter.deliver(&messages, false);
}

/// The serialized bytes at host address `address`: the header, then as far
/// as the serialized size it states (at most [`MAX_SERIALIZED_BYTES`]).
/// None for a NULL address, a stated size below the header's, or above the
/// bound.
///
/// # Safety
/// `address` must be NULL or point to serialized data as the API requires
/// of a serialization's destination once it completed, or of a
/// deserialization's source: at least [`HEADER`] readable bytes, and
/// readable for the serialized size the header states.
pub unsafe fn host_serialized<'a>(address: u64) -> Option<&'a [u8]> {
    let base = usize::try_from(address).ok().filter(|a| *a != 0)?;
    let pointer = std::ptr::with_exposed_provenance::<u8>(base);
    // SAFETY: the header's bytes are readable (the caller's guarantee).
    let header = unsafe { std::slice::from_raw_parts(pointer, HEADER) };
    let size = u64::from_le_bytes(header[SIZE_OFFSET..SIZE_OFFSET + 8].try_into().ok()?);
    if size < HEADER as u64 || size > MAX_SERIALIZED_BYTES {
        return None;
    }
    let len = usize::try_from(size).ok()?;
    // SAFETY: readable for the size the header states (as above).
    Some(unsafe { std::slice::from_raw_parts(pointer, len) })
}

/// After a host serialization to `address` returned: its bytes'
/// fingerprint is linked to it (and stored).
///
/// # Safety
/// As [`host_serialized`], the serialization complete.
pub unsafe fn host_serialization_done(validator: &mut Validator, address: u64) {
    // Below the content tier no deserialization looks at a fingerprint.
    if validator.tier() < ommcheck::Tier::Content {
        return;
    }
    // SAFETY: forwarded from the caller.
    if let Some(bytes) = unsafe { host_serialized(address) } {
        validator.serialized_bytes(true, address, bytes);
    }
}

/// Before a host deserialization from `address` is checked: its source
/// bytes' fingerprint, which decides what they hold.
///
/// # Safety
/// As [`host_serialized`].
pub unsafe fn host_deserialization_source(validator: &mut Validator, address: u64) {
    if validator.tier() < ommcheck::Tier::Content {
        return;
    }
    // SAFETY: forwarded from the caller.
    if let Some(bytes) = unsafe { host_serialized(address) } {
        validator.deserialization_source(true, address, bytes);
    }
}
