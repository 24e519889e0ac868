//! What serialization provenance costs per call (issue 26), over the fake
//! driver of the in-process tests (`layer/tests/fake`), which writes 64
//! bytes of serialized data on the host:
//!
//! - `serialize`: `vkCopyMicromapToMemoryEXT` through the layer, with the
//!   provenance store off (the fingerprint is linked in memory) and on (the
//!   entry is also appended to the store file under its lock);
//! - `deserialize`: `vkCopyMemoryToMicromapEXT` of those bytes, copied
//!   elsewhere so that only their fingerprint links them, with the store
//!   off and on (found in memory either way: the store is read only for
//!   fingerprints the process does not know).
//!
//! `cargo bench -p ommcheck-layer --bench provenance`.

#![allow(unsafe_code, dead_code)]

#[path = "../tests/fake/mod.rs"]
mod fake;

use std::ffi::{CStr, CString};
use std::hint::black_box;

use ash::vk;
use criterion::{criterion_group, criterion_main, Criterion};

use fake::{device_fn, Chain, Serialized, DRIVER_UUID};

/// A chain whose `provenance_store` is `value`, with a micromap to
/// serialize and one to deserialize into.
fn setup(value: &CStr) -> (Chain, vk::MicromapEXT, vk::MicromapEXT) {
    let chain = Chain::with_settings(&[(c"provenance_store", value)]);
    let micromap = |size| {
        let storage = chain.buffer(8192, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
        chain.micromap(storage, size)
    };
    let (from, into) = (micromap(4096), micromap(4096));
    (chain, from, into)
}

fn store_dir() -> CString {
    let dir = std::env::temp_dir().join(format!("ommcheck-bench-store-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    CString::new(dir.to_str().expect("utf-8").to_string()).expect("no NUL")
}

fn serialize(c: &mut Criterion) {
    let dir = store_dir();
    let mut group = c.benchmark_group("provenance/serialize");
    for (name, value) in [("store off", c"off"), ("store on", dir.as_c_str())] {
        let (chain, from, _) = setup(value);
        let call: vk::PFN_vkCopyMicromapToMemoryEXT =
            device_fn(chain.device, c"vkCopyMicromapToMemoryEXT");
        let mut data = Box::new(Serialized::new(DRIVER_UUID, 0));
        group.bench_function(name, |b| {
            b.iter(|| {
                let info = vk::CopyMicromapToMemoryInfoEXT {
                    src: from,
                    dst: vk::DeviceOrHostAddressKHR {
                        host_address: data.0.as_mut_ptr().cast(),
                    },
                    mode: vk::CopyMicromapModeEXT::SERIALIZE,
                    ..Default::default()
                };
                // SAFETY: a valid info whose destination is 64 bytes.
                black_box(unsafe { call(chain.device, vk::DeferredOperationKHR::null(), &info) })
            })
        });
        chain.collector.take();
    }
    group.finish();
}

fn deserialize(c: &mut Criterion) {
    let dir = store_dir();
    let mut group = c.benchmark_group("provenance/deserialize");
    for (name, value) in [("store off", c"off"), ("store on", dir.as_c_str())] {
        let (chain, from, into) = setup(value);
        let mut written = Box::new(Serialized::new(DRIVER_UUID, 0));
        chain.serialize_micromap_on_host(from, &mut written);
        chain.collector.take();
        let elsewhere = Box::new(Serialized(written.0));
        let call: vk::PFN_vkCopyMemoryToMicromapEXT =
            device_fn(chain.device, c"vkCopyMemoryToMicromapEXT");
        let info = elsewhere.deserialize_into(into);
        group.bench_function(name, |b| {
            // SAFETY: a valid info whose source holds 64 serialized bytes.
            b.iter(|| {
                black_box(unsafe { call(chain.device, vk::DeferredOperationKHR::null(), &info) })
            })
        });
        // What the calls drew (the first of each rule; duplicates are muted).
        let ids: Vec<String> = chain.collector.take().into_iter().map(|m| m.id).collect();
        eprintln!("deserialize, {name}: {ids:?}");
    }
    group.finish();
}

criterion_group!(benches, serialize, deserialize);
criterion_main!(benches);
