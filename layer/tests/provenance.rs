//! Serialization provenance through the layer over the fake driver (issue
//! 26): host serializations are fingerprinted after the driver wrote them,
//! host deserializations by their source bytes, and the fingerprints are
//! kept in the provenance store the `provenance_store` setting names, so a
//! deserialization in another process (or run) is linked to the
//! serialization that wrote its bytes. A store that cannot be used is said
//! once and the layer goes on in memory.
//!
//! The fake driver writes 64 bytes of serialized data on the host, ending
//! with the serialized object's handle (`fake::write_serialization`).

#![allow(non_snake_case, unsafe_code)]

mod fake;

use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use ash::vk;
use fake::{device_fn, Chain, Serialized, DRIVER_UUID};
use ommcheck::state::provenance::store::{self, ContentKey, Entry, Store};

const SMALLER: &str = "VUID-VkCopyMemoryToMicromapInfoEXT-dst-07550";
const NOT_SERIALIZED: &str = "VUID-VkCopyMemoryToMicromapInfoEXT-src-07547";
const STORE_WARNING: &str = "OMMCHECK-layer-provenance-store";
/// Set in a child process: which part it plays, and the store directory.
const CHILD: &str = "OMMCHECK_PROVENANCE_TEST_CHILD";
const CHILD_DIR: &str = "OMMCHECK_PROVENANCE_TEST_DIR";

/// A fresh directory for one test's store.
fn fresh_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "ommcheck-layer-provenance-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("test directory");
    dir
}

/// The chain with `provenance_store` set to `value` (per instance, so
/// parallel tests do not share it).
fn chain_with_setting(value: &std::ffi::CStr) -> Chain {
    Chain::with_settings(&[(c"provenance_store", value)])
}

/// The chain with its provenance store in `dir`.
fn chain_with_store(dir: &Path) -> Chain {
    let value = CString::new(dir.to_str().expect("utf-8 path")).expect("no NUL");
    chain_with_setting(&value)
}

fn micromap(chain: &Chain, size: u64) -> vk::MicromapEXT {
    let storage = chain.buffer(8192, vk::BufferUsageFlags::MICROMAP_STORAGE_EXT, 1);
    chain.micromap(storage, size)
}

/// A bottom-level acceleration structure created through the layer.
fn structure(chain: &Chain) -> vk::AccelerationStructureKHR {
    let storage = chain.buffer(
        8192,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
        1,
    );
    let create: vk::PFN_vkCreateAccelerationStructureKHR =
        device_fn(chain.device, c"vkCreateAccelerationStructureKHR");
    let info = vk::AccelerationStructureCreateInfoKHR {
        buffer: storage,
        size: 4096,
        ty: vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
        ..Default::default()
    };
    let mut out = vk::AccelerationStructureKHR::null();
    // SAFETY: a valid create info.
    let result = unsafe { create(chain.device, &info, std::ptr::null(), &mut out) };
    assert_eq!(result, vk::Result::SUCCESS);
    out
}

/// Serializes micromap `from` on the host into `data`.
fn serialize(chain: &Chain, from: vk::MicromapEXT, data: &mut Serialized) {
    chain.serialize_micromap_on_host(from, data);
}

fn host(data: &mut Serialized) -> vk::DeviceOrHostAddressKHR {
    vk::DeviceOrHostAddressKHR {
        host_address: data.0.as_mut_ptr().cast(),
    }
}

/// Serializes acceleration structure `from` on the host into `data`.
fn serialize_structure(chain: &Chain, from: vk::AccelerationStructureKHR, data: &mut Serialized) {
    let serialize: vk::PFN_vkCopyAccelerationStructureToMemoryKHR =
        device_fn(chain.device, c"vkCopyAccelerationStructureToMemoryKHR");
    let info = vk::CopyAccelerationStructureToMemoryInfoKHR {
        src: from,
        dst: host(data),
        mode: vk::CopyAccelerationStructureModeKHR::SERIALIZE,
        ..Default::default()
    };
    // SAFETY: as in `serialize`.
    let result = unsafe { serialize(chain.device, vk::DeferredOperationKHR::null(), &info) };
    assert_eq!(result, vk::Result::SUCCESS);
}

/// Deserializes `data` into micromap `into` on the host; the ids drawn.
fn deserialize(chain: &Chain, data: &Serialized, into: vk::MicromapEXT) -> Vec<String> {
    chain.deserialize_micromap_on_host(data, into)
}

/// The bytes copied to another place, as an application caching them would
/// (the address no longer says where they came from; the fingerprint does).
fn moved(data: &Serialized) -> Box<Serialized> {
    Box::new(Serialized(data.0))
}

#[test]
fn within_one_run_copied_bytes_are_linked_by_their_fingerprint() {
    let dir = fresh_dir("one-run");
    let chain = chain_with_store(&dir);
    assert!(
        chain.collector.take().is_empty(),
        "a usable store is silent"
    );
    let (large, small) = (micromap(&chain, 4096), micromap(&chain, 2048));
    let mut data = Serialized::new(DRIVER_UUID, 0);
    serialize(&chain, large, &mut data);
    let elsewhere = moved(&data);
    // 07550: the destination is smaller than the micromap serialized.
    let ids = deserialize(&chain, &elsewhere, small);
    assert_eq!(ids, [SMALLER]);
    let ids = deserialize(&chain, &elsewhere, micromap(&chain, 4096));
    assert!(ids.is_empty(), "{ids:?}");
    // 07547: bytes an acceleration-structure serialization wrote.
    let mut blas = Serialized::new(DRIVER_UUID, 0);
    serialize_structure(&chain, structure(&chain), &mut blas);
    let ids = deserialize(&chain, &moved(&blas), micromap(&chain, 4096));
    assert_eq!(ids, [NOT_SERIALIZED]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The part a child process plays, when the parent test started it.
#[test]
fn child_process() {
    let (Ok(part), Ok(dir)) = (std::env::var(CHILD), std::env::var(CHILD_DIR)) else {
        // Not a child: nothing to play. The assertion keeps the test honest.
        assert!(std::env::var(CHILD).is_err());
        return;
    };
    let dir = PathBuf::from(dir);
    match part.as_str() {
        // An application that serializes a micromap of 4096 bytes on the
        // host and caches the bytes in a file.
        "serialize" => {
            let chain = chain_with_store(&dir);
            let mut data = Serialized::new(DRIVER_UUID, 0);
            serialize(&chain, micromap(&chain, 4096), &mut data);
            std::fs::write(dir.join("cached.bin"), data.0).expect("cache file");
        }
        // A process that writes one complete entry, then half of another,
        // and stops there until it is killed.
        "tear" => {
            let store = Store::open(&dir, store::DEFAULT_MAX_BYTES);
            store.remember(entry(0xC0FFEE));
            // The file's length before the half record, for the parent.
            let len = std::fs::metadata(dir.join(store::FILE_NAME))
                .expect("store")
                .len();
            // Written whole before the parent sees it (renamed into place).
            std::fs::write(dir.join("torn.tmp"), len.to_string()).expect("marker");
            std::fs::rename(dir.join("torn.tmp"), dir.join("torn.ready")).expect("marker");
            store.tear_next_write();
            store.remember(entry(0xDEAD));
        }
        // Another application that reads bytes cached as `later.bin` (from
        // a micromap of 8192 bytes) and deserializes them into a smaller one.
        "deserialize-later" => {
            let chain = chain_with_store(&dir);
            let cached = std::fs::read(dir.join("later.bin")).expect("cache file");
            let mut data = Box::new(Serialized([0; 64]));
            data.0.copy_from_slice(&cached);
            assert_eq!(
                deserialize(&chain, &data, micromap(&chain, 4096)),
                [SMALLER]
            );
        }
        other => panic!("unknown part {other}"),
    }
}

fn entry(fingerprint: u64) -> Entry {
    Entry {
        fingerprint,
        function: 1,
        size: 99,
        content: ContentKey { run: 5, content: 1 },
        structure: None,
    }
}

/// Starts this test binary as a child playing `part` on the store in `dir`.
fn child(part: &str, dir: &Path) -> std::process::Child {
    Command::new(std::env::current_exe().expect("test binary"))
        .args(["child_process", "--exact", "--test-threads=1"])
        .env(CHILD, part)
        .env(CHILD_DIR, dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("child process")
}

#[test]
fn another_process_finds_the_serialization_and_a_killed_writer_harms_nothing() {
    let dir = fresh_dir("processes");
    let status = child("serialize", &dir).wait().expect("serializer");
    assert!(status.success());
    // A second writer killed in the middle of a record.
    let mut tearing = child("tear", &dir);
    let watchdog = Instant::now();
    while !dir.join("torn.ready").exists() {
        assert!(
            watchdog.elapsed() < Duration::from_secs(60),
            "the tearing child never got ready"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    // Let it write its half record (it flushes, then sleeps forever).
    let file = dir.join(store::FILE_NAME);
    let before: u64 = std::fs::read_to_string(dir.join("torn.ready"))
        .expect("marker")
        .parse()
        .expect("a length");
    while std::fs::metadata(&file).expect("store").len() == before {
        assert!(
            watchdog.elapsed() < Duration::from_secs(60),
            "no half record written"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    tearing.kill().expect("kill");
    tearing.wait().expect("reaped");

    // This process: the cached bytes, read back from the file, are linked
    // to the serialization in the other process.
    let chain = chain_with_store(&dir);
    let warnings = chain.collector.take();
    assert!(
        warnings.iter().all(|m| m.id == STORE_WARNING),
        "{warnings:?}"
    );
    let cached = std::fs::read(dir.join("cached.bin")).expect("cache file");
    let mut data = Box::new(Serialized([0; 64]));
    data.0.copy_from_slice(&cached);
    assert_eq!(
        deserialize(&chain, &data, micromap(&chain, 2048)),
        [SMALLER]
    );
    assert!(deserialize(&chain, &data, micromap(&chain, 4096)).is_empty());
    // What this process serializes after the torn record is kept too.
    let mut later = Serialized::new(DRIVER_UUID, 0);
    serialize(&chain, micromap(&chain, 8192), &mut later);
    std::fs::write(dir.join("later.bin"), later.0).expect("cache file");
    let fresh = Store::open(&dir, store::DEFAULT_MAX_BYTES);
    assert_eq!(
        fresh.find(0xC0FFEE),
        Some(entry(0xC0FFEE)),
        "before the tear"
    );
    assert_eq!(fresh.find(0xDEAD), None, "the torn entry");
    let status = child("deserialize-later", &dir).wait().expect("reader");
    assert!(status.success(), "the entry written after the torn record");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Deserializing bytes serialized in the same run still works when the
/// store is unusable: the layer goes on in memory.
fn still_links_in_memory(chain: &Chain) {
    let (large, small) = (micromap(chain, 4096), micromap(chain, 2048));
    let mut data = Serialized::new(DRIVER_UUID, 0);
    serialize(chain, large, &mut data);
    assert_eq!(deserialize(chain, &moved(&data), small), [SMALLER]);
}

#[test]
fn a_file_that_is_not_a_store_is_said_once_and_left_alone() {
    let dir = fresh_dir("corrupt");
    let file = dir.join(store::FILE_NAME);
    std::fs::write(&file, b"\x00\x01 not a provenance store at all").expect("write");
    let chain = chain_with_store(&dir);
    let said: Vec<_> = chain.collector.take();
    assert_eq!(said.len(), 1, "{said:?}");
    assert_eq!(said[0].id, STORE_WARNING);
    assert!(said[0].text.contains("in memory"), "{}", said[0].text);
    still_links_in_memory(&chain);
    // A second device of the process is not told again.
    let again = chain_with_store(&dir);
    assert!(again.collector.take().is_empty());
    let bytes = std::fs::read(&file).expect("read");
    assert_eq!(bytes, b"\x00\x01 not a provenance store at all");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn damaged_records_are_skipped_with_one_warning_and_the_rest_read() {
    let dir = fresh_dir("damaged");
    {
        let store = Store::open(&dir, store::DEFAULT_MAX_BYTES);
        store.remember(entry(1));
    }
    let file = dir.join(store::FILE_NAME);
    let mut bytes = std::fs::read(&file).expect("read");
    let good = bytes.clone();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x55;
    bytes.extend_from_slice(&good[store::FILE_MAGIC.len()..]);
    std::fs::write(&file, &bytes).expect("write");
    let chain = chain_with_store(&dir);
    let said = chain.collector.take();
    assert_eq!(said.len(), 1, "{said:?}");
    assert!(said[0].text.contains("damaged"), "{}", said[0].text);
    still_links_in_memory(&chain);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_unwritable_store_directory_is_said_once_and_the_layer_goes_on() {
    use std::os::unix::fs::PermissionsExt;
    let base = fresh_dir("read-only");
    let dir = base.join("store");
    std::fs::create_dir_all(&dir).expect("dir");
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).expect("chmod");
    // Root writes through permissions: then a directory that cannot be
    // created at all (beneath a regular file) stands for it.
    let unwritable = if std::fs::write(dir.join("probe"), b"").is_ok() {
        let file = base.join("a-file");
        std::fs::write(&file, b"").expect("file");
        file.join("store")
    } else {
        dir.clone()
    };
    let chain = chain_with_store(&unwritable);
    let said = chain.collector.take();
    assert_eq!(said.len(), 1, "{said:?}");
    assert_eq!(said[0].id, STORE_WARNING);
    still_links_in_memory(&chain);
    assert!(chain.collector.take().is_empty(), "said once");
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn off_keeps_provenance_in_memory_without_a_word() {
    let chain = chain_with_setting(c"off");
    assert!(chain.collector.take().is_empty());
    still_links_in_memory(&chain);
}
