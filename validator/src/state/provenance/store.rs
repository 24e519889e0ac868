//! The persistent provenance store: the fingerprints of serialized bytes and
//! what they hold (a micromap or an acceleration structure, the size used,
//! and opaque keys for the contents of the micromaps involved), kept in a
//! file so that a deserialization in a later run, or in another process,
//! finds what an earlier one serialized.
//!
//! The file (`provenance-v1.log` in the store's directory) is a 16-byte
//! header ([`FILE_MAGIC`]) and then records, appended one `write` each
//! through `O_APPEND`:
//!
//! | bytes | what |
//! | --- | --- |
//! | 4 | [`RECORD_MAGIC`] |
//! | 4 | payload length, little-endian, at most [`MAX_PAYLOAD`] |
//! | 8 | xxh3-64 of the payload |
//! | n | the payload ([`Entry::encode`]) |
//!
//! A record whose length runs past the end of the file, whose checksum
//! does not match or whose payload does not decode is skipped, and reading
//! goes on at the next [`RECORD_MAGIC`]: a process killed in the middle of
//! a write leaves a torn record that the others step over. Appends and
//! compaction hold an exclusive `flock`-style lock of `provenance-v1.lock`
//! (`std::fs::File::try_lock`), readers a shared one, so a reader never
//! sees a record being written; a lock that is not free within
//! [`LOCK_WAIT`] makes the store give up for that call (never blocking the
//! application longer). Compaction, when the file passes its bound, writes
//! the newest entries (up to half the bound) to a temporary file and
//! renames it over the store; appenders that held the old file open find
//! the new one by its inode before they write.
//!
//! Whatever goes wrong (a directory that cannot be created or written, a
//! file that is not a store, a lock that is never free, a failed write) is
//! said once as a warning ([`Store::take_warnings`]) and the store goes on
//! in memory: what it already holds and what is remembered from then on
//! still serve this process. Nothing here panics on what the file holds,
//! and nothing is allocated from a length in it before that length is
//! bounded.

use std::collections::{HashMap, VecDeque};
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

/// The store file's first bytes.
pub const FILE_MAGIC: &[u8; 16] = b"OMMCHECK-PROV-01";
/// Each record's first bytes: where reading resumes after a torn record.
pub const RECORD_MAGIC: &[u8; 4] = b"OMPR";
/// The record header: magic, length, checksum.
const RECORD_HEADER: usize = 4 + 4 + 8;
/// The largest payload a record may have (a structure of 16,384 geometries
/// with both lists fits; larger ones are stored without their micromaps).
pub const MAX_PAYLOAD: usize = 1 << 20;
/// The most geometries a structure's entry lists.
pub const MAX_GEOMETRIES: usize = 16_384;
/// The file's name in the store's directory.
pub const FILE_NAME: &str = "provenance-v1.log";
/// The lock file's name in the store's directory.
pub const LOCK_NAME: &str = "provenance-v1.lock";
/// The default bound on the file's size: 16 MiB, some 200,000 micromap
/// entries.
pub const DEFAULT_MAX_BYTES: u64 = 16 << 20;
/// The smallest bound accepted (smaller ones are raised to it): room for
/// a few hundred entries.
pub const MIN_MAX_BYTES: u64 = 64 << 10;
/// How long a call waits for the lock before the store gives up for it.
pub const LOCK_WAIT: Duration = Duration::from_millis(200);

/// An opaque name for what one construction put in an object: the run
/// (a random number per process and validator) and the construction's
/// number in it. `run == 0`: not known (the object was built before the
/// checker saw it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ContentKey {
    pub run: u64,
    pub content: u64,
}

impl ContentKey {
    pub const UNKNOWN: ContentKey = ContentKey { run: 0, content: 0 };

    pub fn is_known(self) -> bool {
        self.run != 0
    }
}

/// What the micromap of one geometry of a serialized structure held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoredExpected {
    None,
    Content(ContentKey),
    Unknown,
    Replaced,
}

/// A geometry's KHR opacity attachment in a structure's original build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoredAttachment {
    Absent,
    NullMicromap,
    Micromap,
}

/// What a serialized acceleration structure held, besides its contents.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StoredStructure {
    /// `VkAccelerationStructureTypeKHR`.
    pub ty: i32,
    /// The original build's flags and attachments, where known.
    pub original: Option<(u32, Vec<StoredAttachment>)>,
    /// What each geometry's micromap held, where known.
    pub micromaps: Option<Vec<StoredExpected>>,
}

/// One serialization, as the store keeps it: no handle, no address, no byte
/// of the application's data.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Entry {
    pub fingerprint: u64,
    /// The serializing command (an index into [`FUNCTIONS`]).
    pub function: u8,
    /// A micromap's size used to serialize it (0 for a structure).
    pub size: u64,
    /// What the serialized object held.
    pub content: ContentKey,
    /// None: a micromap.
    pub structure: Option<StoredStructure>,
}

/// The serializing commands, by the index an [`Entry`] stores.
pub const FUNCTIONS: [&str; 4] = [
    "vkCmdCopyMicromapToMemoryEXT",
    "vkCopyMicromapToMemoryEXT",
    "vkCmdCopyAccelerationStructureToMemoryKHR",
    "vkCopyAccelerationStructureToMemoryKHR",
];

/// The index of `function` in [`FUNCTIONS`] (0 for another name).
pub fn function_index(function: &str) -> u8 {
    FUNCTIONS
        .iter()
        .position(|f| *f == function)
        .and_then(|i| u8::try_from(i).ok())
        .unwrap_or(0)
}

/// The payload's format version.
const PAYLOAD_VERSION: u8 = 1;

/// Little-endian reading of a payload, None past its end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.at.checked_add(n)?;
        let out = self.bytes.get(self.at..end)?;
        self.at = end;
        Some(out)
    }
    fn u8(&mut self) -> Option<u8> {
        self.take(1).map(|b| b[0])
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn key(&mut self) -> Option<ContentKey> {
        Some(ContentKey {
            run: self.u64()?,
            content: self.u64()?,
        })
    }
    /// A count, bounded by [`MAX_GEOMETRIES`] and by the bytes left
    /// (`each` bytes per element) before anything is allocated from it.
    fn count(&mut self, each: usize) -> Option<usize> {
        let n = usize::try_from(self.u32()?).ok()?;
        let left = self.bytes.len().checked_sub(self.at)?;
        (n <= MAX_GEOMETRIES && n.checked_mul(each)? <= left).then_some(n)
    }
}

fn put_key(out: &mut Vec<u8>, key: ContentKey) {
    out.extend_from_slice(&key.run.to_le_bytes());
    out.extend_from_slice(&key.content.to_le_bytes());
}

impl Entry {
    /// The payload of this entry's record. A structure with more than
    /// [`MAX_GEOMETRIES`] geometries is stored without its lists.
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(64);
        out.push(PAYLOAD_VERSION);
        out.push(u8::from(self.structure.is_some()));
        out.push(self.function);
        out.extend_from_slice(&self.fingerprint.to_le_bytes());
        out.extend_from_slice(&self.size.to_le_bytes());
        put_key(&mut out, self.content);
        let Some(s) = &self.structure else {
            return out;
        };
        out.extend_from_slice(&s.ty.to_le_bytes());
        match s
            .original
            .as_ref()
            .filter(|(_, g)| g.len() <= MAX_GEOMETRIES)
        {
            Some((flags, geometries)) => {
                out.push(1);
                out.extend_from_slice(&flags.to_le_bytes());
                out.extend_from_slice(&(geometries.len() as u32).to_le_bytes());
                out.extend(geometries.iter().map(|a| match a {
                    StoredAttachment::Absent => 0u8,
                    StoredAttachment::NullMicromap => 1,
                    StoredAttachment::Micromap => 2,
                }));
            }
            None => out.push(0),
        }
        match s.micromaps.as_ref().filter(|m| m.len() <= MAX_GEOMETRIES) {
            Some(list) => {
                out.push(1);
                out.extend_from_slice(&(list.len() as u32).to_le_bytes());
                for e in list {
                    let (tag, key) = match e {
                        StoredExpected::None => (0u8, ContentKey::UNKNOWN),
                        StoredExpected::Content(k) => (1, *k),
                        StoredExpected::Unknown => (2, ContentKey::UNKNOWN),
                        StoredExpected::Replaced => (3, ContentKey::UNKNOWN),
                    };
                    out.push(tag);
                    put_key(&mut out, key);
                }
            }
            None => out.push(0),
        }
        out
    }

    /// The entry a payload holds; None for anything else (another version,
    /// a value out of range, bytes left over).
    pub fn decode(payload: &[u8]) -> Option<Entry> {
        let mut r = Reader {
            bytes: payload,
            at: 0,
        };
        if r.u8()? != PAYLOAD_VERSION {
            return None;
        }
        let is_structure = match r.u8()? {
            0 => false,
            1 => true,
            _ => return None,
        };
        let function = r.u8()?;
        if usize::from(function) >= FUNCTIONS.len() {
            return None;
        }
        let fingerprint = r.u64()?;
        let size = r.u64()?;
        let content = r.key()?;
        let structure = if is_structure {
            let ty = i32::from_le_bytes(r.take(4)?.try_into().ok()?);
            let original = match r.u8()? {
                0 => None,
                1 => {
                    let flags = r.u32()?;
                    let n = r.count(1)?;
                    let mut list = Vec::with_capacity(n);
                    for _ in 0..n {
                        list.push(match r.u8()? {
                            0 => StoredAttachment::Absent,
                            1 => StoredAttachment::NullMicromap,
                            2 => StoredAttachment::Micromap,
                            _ => return None,
                        });
                    }
                    Some((flags, list))
                }
                _ => return None,
            };
            let micromaps = match r.u8()? {
                0 => None,
                1 => {
                    let n = r.count(17)?;
                    let mut list = Vec::with_capacity(n);
                    for _ in 0..n {
                        let tag = r.u8()?;
                        let key = r.key()?;
                        list.push(match tag {
                            0 => StoredExpected::None,
                            1 => StoredExpected::Content(key),
                            2 => StoredExpected::Unknown,
                            3 => StoredExpected::Replaced,
                            _ => return None,
                        });
                    }
                    Some(list)
                }
                _ => return None,
            };
            Some(StoredStructure {
                ty,
                original,
                micromaps,
            })
        } else {
            None
        };
        (r.at == payload.len()).then_some(Entry {
            fingerprint,
            function,
            size,
            content,
            structure,
        })
    }

    /// This entry's whole record: header and payload. None when the
    /// payload is larger than [`MAX_PAYLOAD`].
    pub fn record(&self) -> Option<Vec<u8>> {
        let payload = self.encode();
        let len = u32::try_from(payload.len())
            .ok()
            .filter(|_| payload.len() <= MAX_PAYLOAD)?;
        let mut out = Vec::with_capacity(RECORD_HEADER + payload.len());
        out.extend_from_slice(RECORD_MAGIC);
        out.extend_from_slice(&len.to_le_bytes());
        out.extend_from_slice(&xxhash_rust::xxh3::xxh3_64(&payload).to_le_bytes());
        out.extend_from_slice(&payload);
        Some(out)
    }
}

/// What reading a run of records found.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Parsed {
    /// The entries of the complete, intact records, in file order.
    pub entries: Vec<Entry>,
    /// Records skipped: a bad checksum, a payload that does not decode, or
    /// bytes between records that are not one.
    pub skipped: usize,
    /// How far the records were read: the start of a record that runs past
    /// the end (it may still be being written), else the end.
    pub consumed: usize,
}

/// The position of the next [`RECORD_MAGIC`] in `bytes` from `from`.
fn next_magic(bytes: &[u8], from: usize) -> Option<usize> {
    let tail = bytes.get(from..)?;
    tail.windows(RECORD_MAGIC.len())
        .position(|w| w == RECORD_MAGIC)
        .and_then(|p| p.checked_add(from))
}

/// Reads the records in `bytes` (the file after its header, or a part of
/// it that starts anywhere: reading starts at the first magic).
pub fn parse(bytes: &[u8]) -> Parsed {
    let mut out = Parsed::default();
    let mut at = 0;
    // After a skipped record, the bytes up to the next magic are its own.
    let mut resyncing = false;
    loop {
        let Some(start) = next_magic(bytes, at) else {
            // No further record. The end of the bytes, where it begins
            // a magic, may be the start of a record being written: it is
            // left for the next read. Anything before it is not a record.
            let rest = bytes.get(at..).unwrap_or_default();
            let partial = (1..RECORD_MAGIC.len())
                .rev()
                .find(|&n| rest.len() >= n && rest[rest.len() - n..] == RECORD_MAGIC[..n])
                .unwrap_or(0);
            out.consumed = bytes.len() - partial;
            out.skipped += usize::from(out.consumed > at && !resyncing);
            return out;
        };
        if start > at && !resyncing {
            out.skipped += 1;
        }
        resyncing = false;
        let header_end = start + RECORD_HEADER;
        let Some(header) = bytes.get(start..header_end) else {
            out.consumed = start;
            return out;
        };
        let len = u32::from_le_bytes(header[4..8].try_into().unwrap_or_default()) as usize;
        let sum = u64::from_le_bytes(header[8..16].try_into().unwrap_or_default());
        if len > MAX_PAYLOAD {
            out.skipped += 1;
            at = start + 1;
            resyncing = true;
            continue;
        }
        let Some(payload) = bytes.get(header_end..header_end + len) else {
            // Runs past the end: torn for good if another magic follows
            // (a later record was appended after it), else perhaps still
            // being written.
            match next_magic(bytes, start + 1) {
                Some(next) => {
                    out.skipped += 1;
                    at = next;
                    continue;
                }
                None => {
                    out.consumed = start;
                    return out;
                }
            }
        };
        match (xxhash_rust::xxh3::xxh3_64(payload) == sum)
            .then(|| Entry::decode(payload))
            .flatten()
        {
            Some(entry) => {
                out.entries.push(entry);
                at = header_end + len;
            }
            None => {
                out.skipped += 1;
                at = start + 1;
                resyncing = true;
            }
        }
    }
}

/// The file's identity, to find out that compaction replaced it.
#[cfg(unix)]
fn identity(meta: &std::fs::Metadata) -> (u64, u64) {
    use std::os::unix::fs::MetadataExt;
    (meta.dev(), meta.ino())
}
#[cfg(not(unix))]
fn identity(_: &std::fs::Metadata) -> (u64, u64) {
    (0, 0)
}

/// The open store file, while the store works on disk.
struct Disk {
    dir: PathBuf,
    file: File,
    lock: File,
    identity: (u64, u64),
    /// How far this process has read the file.
    offset: u64,
}

/// The in-memory index: entries by fingerprint, oldest first.
#[derive(Default)]
struct Index {
    by_fingerprint: HashMap<u64, Entry>,
    order: VecDeque<u64>,
}

impl Index {
    fn insert(&mut self, entry: Entry, at_most: usize) {
        if self
            .by_fingerprint
            .insert(entry.fingerprint, entry.clone())
            .is_some()
        {
            self.order.retain(|f| *f != entry.fingerprint);
        }
        self.order.push_back(entry.fingerprint);
        while self.order.len() > at_most {
            if let Some(old) = self.order.pop_front() {
                self.by_fingerprint.remove(&old);
            }
        }
    }
}

struct Inner {
    disk: Option<Disk>,
    index: Index,
    max_bytes: u64,
    warnings: Vec<String>,
    /// Which warnings were said (each once).
    said: Vec<&'static str>,
    /// Test hook: the next append writes half its record and then waits
    /// forever, as a process killed in the middle of a write would leave it.
    tear_next: bool,
}

impl Inner {
    fn warn(&mut self, kind: &'static str, text: String) {
        if !self.said.contains(&kind) {
            self.said.push(kind);
            self.warnings.push(text);
        }
    }

    /// Stops using the file: from now on the store is in memory only.
    fn fall_back_to_memory(&mut self, kind: &'static str, text: String) {
        self.disk = None;
        self.warn(
            kind,
            format!("{text}; provenance is kept in memory for the rest of this process"),
        );
    }

    /// The most entries the index holds: about what the file's bound holds.
    fn index_bound(&self) -> usize {
        usize::try_from(self.max_bytes / 48).unwrap_or(usize::MAX)
    }
}

/// A persistent provenance store (see the module documentation). Shared by
/// the validators of one process through an `Arc`.
pub struct Store {
    inner: Mutex<Inner>,
    path: Option<PathBuf>,
}

impl std::fmt::Debug for Store {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Store").field("path", &self.path).finish()
    }
}

/// Takes `lock` (exclusive or shared), trying for at most [`LOCK_WAIT`].
fn take_lock(lock: &File, exclusive: bool) -> bool {
    let start = Instant::now();
    loop {
        let got = if exclusive {
            lock.try_lock()
        } else {
            lock.try_lock_shared()
        };
        match got {
            Ok(()) => return true,
            Err(std::fs::TryLockError::WouldBlock) if start.elapsed() < LOCK_WAIT => {
                std::thread::sleep(Duration::from_millis(2));
            }
            Err(_) => return false,
        }
    }
}

/// Reads at most `limit` bytes of `file` from `from`.
fn read_from(file: &mut File, from: u64, limit: u64) -> std::io::Result<Vec<u8>> {
    file.seek(SeekFrom::Start(from))?;
    let mut out = Vec::new();
    file.take(limit).read_to_end(&mut out)?;
    Ok(out)
}

impl Store {
    /// The default directory: `$XDG_CACHE_HOME/ommcheck`, else
    /// `$HOME/.cache/ommcheck`; None when neither variable is set.
    pub fn default_dir(var: impl Fn(&str) -> Option<String>) -> Option<PathBuf> {
        let nonempty = |name: &str| var(name).filter(|v| !v.is_empty());
        nonempty("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .or_else(|| nonempty("HOME").map(|h| Path::new(&h).join(".cache")))
            .map(|base| base.join("ommcheck"))
    }

    /// A store in memory only (what `off` means, and what a store that
    /// cannot work on disk becomes).
    pub fn in_memory(max_bytes: u64) -> Store {
        Store {
            inner: Mutex::new(Inner {
                disk: None,
                index: Index::default(),
                max_bytes: max_bytes.max(MIN_MAX_BYTES),
                warnings: Vec::new(),
                said: Vec::new(),
                tear_next: false,
            }),
            path: None,
        }
    }

    /// Opens (creating it where needed) the store in directory `dir`,
    /// bounded to `max_bytes` (at least [`MIN_MAX_BYTES`]). Never fails: a
    /// store that cannot be used on disk is in memory, with a warning.
    pub fn open(dir: &Path, max_bytes: u64) -> Store {
        let store = Store {
            path: Some(dir.join(FILE_NAME)),
            ..Store::in_memory(max_bytes)
        };
        {
            let mut inner = store.lock();
            match Self::open_disk(dir) {
                Ok(disk) => {
                    inner.disk = Some(disk);
                    Self::refresh(&mut inner);
                }
                Err(e) => inner.fall_back_to_memory(
                    "open",
                    format!(
                        "the provenance store {} could not be opened ({e})",
                        dir.join(FILE_NAME).display()
                    ),
                ),
            }
        }
        store
    }

    fn open_disk(dir: &Path) -> std::io::Result<Disk> {
        std::fs::create_dir_all(dir)?;
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .read(true)
            .write(true)
            .open(dir.join(LOCK_NAME))?;
        let path = dir.join(FILE_NAME);
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .read(true)
            .open(&path)?;
        if !take_lock(&lock, true) {
            return Err(std::io::Error::other("locked by another process"));
        }
        let checked = Self::check_header(&file);
        let _ = lock.unlock();
        checked?;
        let identity = identity(&file.metadata()?);
        Ok(Disk {
            dir: dir.to_path_buf(),
            file,
            lock,
            identity,
            offset: FILE_MAGIC.len() as u64,
        })
    }

    /// Writes the header of an empty file, or checks that of a store.
    fn check_header(file: &File) -> std::io::Result<()> {
        let mut file = file;
        let len = file.metadata()?.len();
        if len == 0 {
            return file.write_all(FILE_MAGIC);
        }
        let mut magic = [0u8; 16];
        file.seek(SeekFrom::Start(0))?;
        match file.read_exact(&mut magic) {
            Ok(()) if &magic == FILE_MAGIC => Ok(()),
            _ => Err(std::io::Error::other(
                "the file is not an ommcheck provenance store (its first bytes differ); move it away or delete it",
            )),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Reads what other processes appended since the last read (all of
    /// the file when compaction replaced it), under a shared lock.
    fn refresh(inner: &mut Inner) {
        let bound = inner.index_bound();
        let max_bytes = inner.max_bytes;
        let Some(disk) = inner.disk.as_mut() else {
            return;
        };
        if !take_lock(&disk.lock, false) {
            inner.warn(
                "locked",
                "the provenance store is locked by another process for longer than 200 ms; this lookup used what the process already knew".into(),
            );
            return;
        }
        let result = Self::read_new(disk, max_bytes);
        let _ = disk.lock.unlock();
        match result {
            Ok(parsed) => {
                if parsed.skipped > 0 {
                    inner.warn(
                        "damaged",
                        format!("the provenance store holds {} damaged or torn record(s), which were skipped", parsed.skipped),
                    );
                }
                for entry in parsed.entries {
                    inner.index.insert(entry, bound);
                }
            }
            Err(e) => inner.fall_back_to_memory(
                "read",
                format!("the provenance store could not be read ({e})"),
            ),
        }
    }

    /// The records past `disk.offset`, reopening the file when compaction
    /// replaced it. At most twice the bound is read: of a larger file only
    /// its newest part.
    fn read_new(disk: &mut Disk, max_bytes: u64) -> std::io::Result<Parsed> {
        let path = disk.dir.join(FILE_NAME);
        let meta = std::fs::metadata(&path)?;
        if identity(&meta) != disk.identity || meta.len() < disk.offset {
            disk.file = OpenOptions::new().append(true).read(true).open(&path)?;
            Self::check_header(&disk.file)?;
            disk.identity = identity(&disk.file.metadata()?);
            disk.offset = FILE_MAGIC.len() as u64;
        }
        let len = disk.file.metadata()?.len();
        let window = max_bytes.saturating_mul(2);
        let from = disk.offset.max(len.saturating_sub(window));
        let bytes = read_from(&mut disk.file, from, window)?;
        // Read from the middle of a large file: up to the first record is
        // the tail of an older one, not damage.
        let skip = if from > disk.offset {
            next_magic(&bytes, 0).unwrap_or(bytes.len())
        } else {
            0
        };
        let parsed = parse(bytes.get(skip..).unwrap_or_default());
        disk.offset = from.saturating_add((skip + parsed.consumed) as u64);
        Ok(parsed)
    }

    /// What the store holds for `fingerprint`, reading what other
    /// processes appended first when this process does not know it.
    pub fn find(&self, fingerprint: u64) -> Option<Entry> {
        let mut inner = self.lock();
        if let Some(e) = inner.index.by_fingerprint.get(&fingerprint) {
            return Some(e.clone());
        }
        Self::refresh(&mut inner);
        inner.index.by_fingerprint.get(&fingerprint).cloned()
    }

    /// Remembers `entry`: in memory, and appended to the file.
    pub fn remember(&self, entry: Entry) {
        let mut inner = self.lock();
        let bound = inner.index_bound();
        inner.index.insert(entry.clone(), bound);
        if inner.disk.is_none() {
            return;
        }
        let Some(record) = entry.record() else {
            return;
        };
        let tear = std::mem::take(&mut inner.tear_next);
        if let Err(e) = Self::append(&mut inner, &record, tear) {
            inner.fall_back_to_memory(
                "write",
                format!("the provenance store could not be written ({e})"),
            );
        }
    }

    fn append(inner: &mut Inner, record: &[u8], tear: bool) -> std::io::Result<()> {
        let max_bytes = inner.max_bytes;
        let Some(disk) = inner.disk.as_mut() else {
            return Ok(());
        };
        if !take_lock(&disk.lock, true) {
            inner.warn(
                "locked",
                "the provenance store was locked by another process for longer than 200 ms; an entry was kept in memory only".into(),
            );
            return Ok(());
        }
        let result = Self::append_locked(disk, record, tear, max_bytes);
        let _ = disk.lock.unlock();
        match result? {
            Some(dropped) if dropped > 0 => inner.warn(
                "bound",
                format!("the provenance store reached its bound of {max_bytes} bytes (provenance_store_max_bytes); its oldest entries are dropped to make room"),
            ),
            _ => {}
        }
        Ok(())
    }

    /// Appends `record` while holding the exclusive lock, then compacts the
    /// file when it is past `max_bytes`; returns how many entries
    /// compaction dropped.
    fn append_locked(
        disk: &mut Disk,
        record: &[u8],
        tear: bool,
        max_bytes: u64,
    ) -> std::io::Result<Option<usize>> {
        let path = disk.dir.join(FILE_NAME);
        if identity(&std::fs::metadata(&path)?) != disk.identity {
            // Compaction replaced the file: what this process has not
            // read yet is read from the new one at the next lookup.
            disk.file = OpenOptions::new().append(true).read(true).open(&path)?;
            Self::check_header(&disk.file)?;
            disk.identity = identity(&disk.file.metadata()?);
            disk.offset = FILE_MAGIC.len() as u64;
        }
        if tear {
            disk.file.write_all(&record[..record.len() / 2])?;
            disk.file.flush()?;
            // The test stands for a process killed here; it is killed.
            loop {
                std::thread::sleep(Duration::from_secs(3600));
            }
        }
        // One write: O_APPEND places it at the end as a whole.
        disk.file.write_all(record)?;
        if disk.file.metadata()?.len() <= max_bytes {
            return Ok(None);
        }
        Self::compact(disk, max_bytes).map(Some)
    }

    /// Rewrites the file with its newest entries (one per fingerprint, up
    /// to half of `max_bytes`) through a temporary file and a rename.
    fn compact(disk: &mut Disk, max_bytes: u64) -> std::io::Result<usize> {
        let len = disk.file.metadata()?.len();
        let window = max_bytes.saturating_mul(2);
        let from = (FILE_MAGIC.len() as u64).max(len.saturating_sub(window));
        let parsed = parse(&read_from(&mut disk.file, from, window)?);
        let mut newest: HashMap<u64, usize> = HashMap::new();
        for (i, e) in parsed.entries.iter().enumerate() {
            newest.insert(e.fingerprint, i);
        }
        let keep = max_bytes / 2;
        let mut kept: Vec<Vec<u8>> = Vec::new();
        let mut total = FILE_MAGIC.len() as u64;
        for (i, e) in parsed.entries.iter().enumerate().rev() {
            if newest.get(&e.fingerprint) != Some(&i) {
                continue;
            }
            let Some(record) = e.record() else { continue };
            let next = total.saturating_add(record.len() as u64);
            if next > keep {
                break;
            }
            total = next;
            kept.push(record);
        }
        let dropped = parsed.entries.len().saturating_sub(kept.len());
        let temp = disk
            .dir
            .join(format!("{FILE_NAME}.{}.tmp", std::process::id()));
        {
            let mut out = File::create(&temp)?;
            let mut bytes = Vec::with_capacity(usize::try_from(total).unwrap_or(0));
            bytes.extend_from_slice(FILE_MAGIC);
            for record in kept.iter().rev() {
                bytes.extend_from_slice(record);
            }
            out.write_all(&bytes)?;
            out.sync_all()?;
        }
        let path = disk.dir.join(FILE_NAME);
        if let Err(e) = std::fs::rename(&temp, &path) {
            let _ = std::fs::remove_file(&temp);
            return Err(e);
        }
        disk.file = OpenOptions::new().append(true).read(true).open(&path)?;
        disk.identity = identity(&disk.file.metadata()?);
        disk.offset = FILE_MAGIC.len() as u64;
        Ok(dropped)
    }

    /// The warnings not yet handed out (each kind is said once).
    pub fn take_warnings(&self) -> Vec<String> {
        std::mem::take(&mut self.lock().warnings)
    }

    /// Whether the store still works on disk.
    pub fn on_disk(&self) -> bool {
        self.lock().disk.is_some()
    }

    /// The store file's path (None: a store in memory from the start).
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Test hook: the next [`Self::remember`] writes half its record and
    /// never returns, standing for a process killed in the middle of a
    /// write. Only the store's own tests and the layer's cross-process
    /// test call it.
    #[doc(hidden)]
    pub fn tear_next_write(&self) {
        self.lock().tear_next = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn micromap(fingerprint: u64) -> Entry {
        Entry {
            fingerprint,
            function: 1,
            size: 64 + fingerprint,
            content: ContentKey {
                run: 7,
                content: fingerprint,
            },
            structure: None,
        }
    }

    fn structure(fingerprint: u64) -> Entry {
        Entry {
            fingerprint,
            function: 3,
            size: 0,
            content: ContentKey { run: 7, content: 1 },
            structure: Some(StoredStructure {
                ty: 0,
                original: Some((
                    4,
                    vec![StoredAttachment::Micromap, StoredAttachment::Absent],
                )),
                micromaps: Some(vec![
                    StoredExpected::Content(ContentKey { run: 7, content: 2 }),
                    StoredExpected::None,
                ]),
            }),
        }
    }

    /// A fresh directory under the target's temporary directory.
    fn dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "ommcheck-store-{name}-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn entries_round_trip_through_their_records() {
        for e in [micromap(3), structure(4)] {
            let record = e.record().expect("small");
            let parsed = parse(&record);
            assert_eq!(parsed.entries, vec![e.clone()]);
            assert_eq!((parsed.skipped, parsed.consumed), (0, record.len()));
        }
    }

    #[test]
    fn a_torn_record_is_skipped_and_the_next_one_read() {
        let a = micromap(1).record().expect("small");
        let b = micromap(2).record().expect("small");
        let mut bytes = a[..a.len() / 2].to_vec();
        bytes.extend_from_slice(&b);
        let parsed = parse(&bytes);
        assert_eq!(parsed.entries, vec![micromap(2)]);
        assert_eq!(parsed.skipped, 1);
        // Alone at the end, a partial record may still be being written:
        // not consumed, so a later read sees it whole.
        let parsed = parse(&a[..a.len() - 3]);
        assert!(parsed.entries.is_empty());
        assert_eq!(parsed.consumed, 0);
    }

    #[test]
    fn a_bad_checksum_skips_only_that_record() {
        let mut bytes = micromap(1).record().expect("small");
        let last = bytes.len() - 1;
        bytes[last] ^= 0xFF;
        bytes.extend(micromap(2).record().expect("small"));
        let parsed = parse(&bytes);
        assert_eq!(parsed.entries, vec![micromap(2)]);
        assert_eq!(parsed.skipped, 1);
    }

    #[test]
    fn lengths_and_counts_in_the_file_are_bounded_before_use() {
        let mut record = micromap(1).record().expect("small");
        record[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(parse(&record).entries.is_empty());
        // A structure whose geometry count says 2^32 - 1, with a matching
        // checksum: refused by the count's bound, nothing allocated.
        let mut payload = structure(1).encode();
        let count_at = 1 + 1 + 1 + 8 + 8 + 16 + 4 + 1 + 4;
        payload[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(Entry::decode(&payload), None);
        assert_eq!(parse(b"garbage without a record").skipped, 1);
    }

    #[test]
    fn entries_survive_reopening_and_reach_another_handle() {
        let dir = dir("reopen");
        let a = Store::open(&dir, DEFAULT_MAX_BYTES);
        let b = Store::open(&dir, DEFAULT_MAX_BYTES);
        assert!(a.on_disk() && b.on_disk());
        a.remember(micromap(1));
        a.remember(structure(2));
        assert_eq!(b.find(1), Some(micromap(1)), "appended by another handle");
        drop((a, b));
        let c = Store::open(&dir, DEFAULT_MAX_BYTES);
        assert_eq!(c.find(2), Some(structure(2)));
        assert_eq!(c.find(3), None);
        assert!(c.take_warnings().is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn compaction_keeps_the_newest_entries_within_the_bound_and_says_so_once() {
        let dir = dir("bound");
        let store = Store::open(&dir, MIN_MAX_BYTES);
        let record_len = micromap(0).record().expect("small").len() as u64;
        let n = 3 * MIN_MAX_BYTES / record_len;
        for f in 0..n {
            store.remember(micromap(f));
        }
        let len = std::fs::metadata(dir.join(FILE_NAME)).expect("file").len();
        assert!(len <= MIN_MAX_BYTES, "{len}");
        let warnings = store.take_warnings();
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].contains("bound"), "{warnings:?}");
        let fresh = Store::open(&dir, MIN_MAX_BYTES);
        assert_eq!(fresh.find(n - 1), Some(micromap(n - 1)), "the newest stays");
        assert_eq!(fresh.find(0), None, "the oldest went first");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_file_that_is_not_a_store_leaves_it_alone_and_works_in_memory() {
        let dir = dir("foreign");
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(dir.join(FILE_NAME), b"something else entirely").expect("write");
        let store = Store::open(&dir, DEFAULT_MAX_BYTES);
        assert!(!store.on_disk());
        store.remember(micromap(5));
        assert_eq!(store.find(5), Some(micromap(5)), "in memory");
        let warnings = store.take_warnings();
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(store.take_warnings().is_empty(), "said once");
        let bytes = std::fs::read(dir.join(FILE_NAME)).expect("read");
        assert_eq!(bytes, b"something else entirely");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_default_directory_follows_xdg_then_home() {
        let both = |n: &str| match n {
            "XDG_CACHE_HOME" => Some("/x".to_string()),
            "HOME" => Some("/h".to_string()),
            _ => None,
        };
        assert_eq!(Store::default_dir(both), Some(PathBuf::from("/x/ommcheck")));
        let home = |n: &str| (n == "HOME").then(|| "/h".to_string());
        assert_eq!(
            Store::default_dir(home),
            Some(PathBuf::from("/h/.cache/ommcheck"))
        );
        assert_eq!(Store::default_dir(|_| None), None);
    }
}
