//! Where serialized bytes came from: what each serialization the checker
//! saw wrote, where it wrote it, and what each deserialization read.
//!
//! A serialization (`vkCmdCopyMicromapToMemoryEXT`, `vkCopyMicromapToMemoryEXT`
//! and the KHR acceleration-structure to-memory commands) is recorded as a
//! [`Serialization`] at the address it writes ([`Provenance::serialized_at`]);
//! the bytes it wrote, once an adaptor has them, are linked to it by their
//! fingerprint ([`Provenance::remember_fingerprint`]). A deserialization finds
//! what its source holds by the fingerprint of the bytes there when they are
//! readable, else by the last write the checker saw at that address.
//!
//! What an object holds is a [`ContentId`]: a build gives its destination a
//! new one, a copy and a deserialization carry the one serialized. The rules
//! on deserialized acceleration structures compare the contents of the
//! micromaps a structure references with those of the micromaps its
//! serialized original was built with.
//!
//! Everything here follows recording order (the record step of each
//! command), not execution order, and is bounded: at most [`WRITES_AT_MOST`]
//! serialization writes and [`FINGERPRINTS_AT_MOST`] fingerprints; past it
//! the oldest are forgotten, which turns a decision into a not-checked
//! information, never into a finding.
//!
//! The fingerprints live in one type, [`Fingerprints`], which can be given
//! a persistent [`store::Store`] shared by runs and processes: what it
//! remembers is appended there (with the content ids turned into keys that
//! name this run, [`store::ContentKey`]), and a fingerprint it does not
//! know is looked up there, the keys of other runs turned into content ids
//! of this one (the same key always into the same id).

pub mod store;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex, PoisonError};

use crate::model::accel::{KhrOpacityAttachment, OriginalAttachments};
use crate::model::Handle;
use store::{ContentKey, Entry, Store, StoredAttachment, StoredExpected, StoredStructure};

/// xxh3-64 of serialized bytes, the addresses an application rewrites
/// before deserializing left out (see `checks::serialized::fingerprint`).
pub type Fingerprint = u64;

/// What one construction (a build) put in an object, carried by copies,
/// serializations and deserializations. Unique within a run.
pub type ContentId = u64;

/// How many serialization writes are remembered by address.
pub const WRITES_AT_MOST: usize = 4096;
/// How many fingerprints of serialized bytes are remembered.
pub const FINGERPRINTS_AT_MOST: usize = 4096;

/// Device addresses or host addresses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Space {
    Device,
    Host,
}

impl Space {
    pub fn of(host: bool) -> Space {
        if host {
            Space::Host
        } else {
            Space::Device
        }
    }
}

/// What a serialization wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Serialized {
    /// A `VkMicromapEXT` (07547, 07550).
    Micromap {
        micromap: Handle,
        /// The size the micromap was created with: the size used to serialize it.
        size: u64,
        content: Option<ContentId>,
    },
    /// A `VkAccelerationStructureKHR`, a KHR opacity micromap among them.
    AccelerationStructure {
        structure: Handle,
        /// The type it was built (or created) with.
        ty: i32,
        content: Option<ContentId>,
        /// The KHR opacity attachments of its original build, where known.
        original: Option<OriginalAttachments>,
        /// For each geometry, what the micromap it references holds; None
        /// when not known (a structure whose build the checker did not see).
        micromaps: Option<Vec<Expected>>,
    },
}

/// One serialization: the command and what it serialized.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Serialization {
    pub function: &'static str,
    pub what: Serialized,
    /// Found in the provenance store: serialized by another run or
    /// process (its handles are then 0: the store keeps none).
    pub stored: bool,
}

/// What the micromap one geometry of a serialized (or deserialized)
/// structure references must hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Expected {
    /// The geometry references no micromap.
    None,
    /// The contents of this construction (serialized: the micromap's
    /// deserialization must carry it).
    Content(ContentId),
    /// A micromap whose contents the checker does not know (built before it
    /// saw anything).
    Unknown,
    /// An update build replaced the micromap after the deserialization:
    /// the rules no longer ask about it.
    Replaced,
}

/// What a deserialized acceleration structure came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Deserialized {
    /// The serialization its bytes came from; None: bytes no serialization
    /// the checker saw wrote (another run, another process, a file).
    pub from: Option<Arc<Serialization>>,
    /// For each geometry, what the micromap it references must hold; None
    /// when not known.
    pub expected: Option<Vec<Expected>>,
    /// The micromap addresses its serialized header held, by geometry; None
    /// when the header was not readable.
    pub addresses: Option<Vec<u64>>,
}

/// Content ids of this run that stand for contents of other runs (from
/// store entries), and the keys they stand for; at most this many.
const FOREIGN_AT_MOST: usize = 1 << 16;
/// The bit that sets the content ids standing for other runs' contents
/// apart from this run's (sequence numbers, far below it).
const FOREIGN_BIT: u64 = 1 << 63;

/// The fingerprints of serialized bytes the checker saw written; the part of
/// the provenance a store shared between processes keeps.
#[derive(Clone, Debug, Default)]
pub struct Fingerprints {
    by_fingerprint: BTreeMap<Fingerprint, (u64, Arc<Serialization>)>,
    next: u64,
    /// The persistent store, where one is used.
    store: Option<Arc<Store>>,
    /// This run's name in store keys (nonzero once a store is used).
    run: u64,
    /// The keys of other runs' contents met in the store, by the content
    /// id that stands for each in this run.
    foreign: Arc<Mutex<BTreeMap<ContentId, ContentKey>>>,
}

impl Fingerprints {
    /// Remembers that bytes with `fingerprint` hold `serialization`.
    pub fn remember(&mut self, fingerprint: Fingerprint, serialization: Arc<Serialization>) {
        self.next += 1;
        self.by_fingerprint
            .insert(fingerprint, (self.next, serialization));
        if self.by_fingerprint.len() > FINGERPRINTS_AT_MOST {
            forget_oldest(&mut self.by_fingerprint, |(seq, _)| *seq);
        }
    }

    /// What bytes with `fingerprint` hold, if a serialization wrote them:
    /// one this run saw, else one the store holds.
    pub fn find(&self, fingerprint: Fingerprint) -> Option<Arc<Serialization>> {
        if let Some((_, s)) = self.by_fingerprint.get(&fingerprint) {
            return Some(s.clone());
        }
        let entry = self.store.as_ref()?.find(fingerprint)?;
        Some(Arc::new(self.serialization_of(&entry)))
    }

    /// Uses `store` from now on; this run gets a name of its own in it.
    pub fn use_store(&mut self, store: Arc<Store>) {
        self.store = Some(store);
        if self.run == 0 {
            self.run = run_name();
        }
    }

    /// The store in use, if any.
    pub fn store(&self) -> Option<&Arc<Store>> {
        self.store.as_ref()
    }

    /// The store key of `content` (unknown: contents from before the
    /// checker saw anything, in `before_run`).
    fn key(&self, content: Option<ContentId>, before_run: &BTreeSet<ContentId>) -> ContentKey {
        let Some(c) = content.filter(|c| !before_run.contains(c)) else {
            return ContentKey::UNKNOWN;
        };
        if c & FOREIGN_BIT != 0 {
            return self
                .foreign
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .get(&c)
                .copied()
                .unwrap_or(ContentKey::UNKNOWN);
        }
        ContentKey {
            run: self.run,
            content: c,
        }
    }

    /// The content id of `key` in this run: this run's own, or one that
    /// stands for another run's (always the same for the same key).
    fn local(&self, key: ContentKey) -> Option<ContentId> {
        if !key.is_known() {
            return None;
        }
        if key.run == self.run {
            return Some(key.content);
        }
        let mut bytes = [0u8; 16];
        bytes[..8].copy_from_slice(&key.run.to_le_bytes());
        bytes[8..].copy_from_slice(&key.content.to_le_bytes());
        let id = FOREIGN_BIT | xxhash_rust::xxh3::xxh3_64(&bytes);
        let mut foreign = self.foreign.lock().unwrap_or_else(PoisonError::into_inner);
        if foreign.len() >= FOREIGN_AT_MOST {
            // Forgetting makes a later serialization of such contents
            // store them as unknown: a not-checked, never a finding.
            foreign.clear();
        }
        foreign.insert(id, key);
        Some(id)
    }

    /// The store's entry for a serialization this run saw.
    fn entry_of(
        &self,
        fingerprint: Fingerprint,
        s: &Serialization,
        before_run: &BTreeSet<ContentId>,
    ) -> Entry {
        let function = store::function_index(s.function);
        match &s.what {
            Serialized::Micromap { size, content, .. } => Entry {
                fingerprint,
                function,
                size: *size,
                content: self.key(*content, before_run),
                structure: None,
            },
            Serialized::AccelerationStructure {
                ty,
                content,
                original,
                micromaps,
                ..
            } => Entry {
                fingerprint,
                function,
                size: 0,
                content: self.key(*content, before_run),
                structure: Some(StoredStructure {
                    ty: *ty,
                    original: original.as_ref().map(|o| {
                        let list = o.geometries.iter().map(|a| match a {
                            KhrOpacityAttachment::Absent => StoredAttachment::Absent,
                            KhrOpacityAttachment::NullMicromap => StoredAttachment::NullMicromap,
                            KhrOpacityAttachment::Micromap(_) => StoredAttachment::Micromap,
                        });
                        (o.flags, list.collect())
                    }),
                    micromaps: micromaps.as_ref().map(|list| {
                        list.iter()
                            .map(|e| match e {
                                Expected::None => StoredExpected::None,
                                Expected::Content(c) => {
                                    let key = self.key(Some(*c), before_run);
                                    if key.is_known() {
                                        StoredExpected::Content(key)
                                    } else {
                                        StoredExpected::Unknown
                                    }
                                }
                                Expected::Unknown => StoredExpected::Unknown,
                                Expected::Replaced => StoredExpected::Replaced,
                            })
                            .collect()
                    }),
                }),
            },
        }
    }

    /// The serialization a store entry describes, in this run's terms.
    fn serialization_of(&self, entry: &Entry) -> Serialization {
        let function = store::FUNCTIONS
            .get(usize::from(entry.function))
            .copied()
            .unwrap_or(store::FUNCTIONS[0]);
        let content = self.local(entry.content);
        let what = match &entry.structure {
            None => Serialized::Micromap {
                micromap: 0,
                size: entry.size,
                content,
            },
            Some(s) => Serialized::AccelerationStructure {
                structure: 0,
                ty: s.ty,
                content,
                original: s
                    .original
                    .as_ref()
                    .map(|(flags, list)| OriginalAttachments {
                        flags: *flags,
                        deserialized: false,
                        geometries: list
                            .iter()
                            .map(|a| match a {
                                StoredAttachment::Absent => KhrOpacityAttachment::Absent,
                                StoredAttachment::NullMicromap => {
                                    KhrOpacityAttachment::NullMicromap
                                }
                                // The handle is not kept; a deserialized
                                // structure's rules never compare it.
                                StoredAttachment::Micromap => KhrOpacityAttachment::Micromap(0),
                            })
                            .collect(),
                    }),
                micromaps: s.micromaps.as_ref().map(|list| {
                    list.iter()
                        .map(|e| match e {
                            StoredExpected::None => Expected::None,
                            StoredExpected::Content(k) => {
                                self.local(*k).map_or(Expected::Unknown, Expected::Content)
                            }
                            StoredExpected::Unknown => Expected::Unknown,
                            StoredExpected::Replaced => Expected::Replaced,
                        })
                        .collect()
                }),
            },
        };
        Serialization {
            function,
            what,
            stored: true,
        }
    }
}

/// A name for this run in the store: random per call (std's hasher keys are
/// random per process and per `RandomState`), never 0.
fn run_name() -> u64 {
    use std::hash::BuildHasher;
    let state = std::collections::hash_map::RandomState::new();
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    state.hash_one((std::process::id(), now)) | 1
}

/// Removes the entry of `map` with the smallest sequence number.
fn forget_oldest<K: Ord + Clone, V>(map: &mut BTreeMap<K, V>, seq: impl Fn(&V) -> u64) {
    let oldest = map
        .iter()
        .min_by_key(|(_, v)| seq(v))
        .map(|(k, _)| k.clone());
    if let Some(key) = oldest {
        map.remove(&key);
    }
}

/// A serialization write the checker saw, at its order.
#[derive(Clone, Debug)]
pub struct Write {
    pub seq: u64,
    pub serialization: Arc<Serialization>,
}

/// The provenance the checker keeps (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct Provenance {
    /// Recording order of writes and constructions.
    seq: u64,
    /// Serialization writes by where they start.
    writes: BTreeMap<(Space, u64), Write>,
    pub fingerprints: Fingerprints,
    /// When each object was last constructed in this run and what that put
    /// in it (None: a construction whose contents are not known).
    constructed: BTreeMap<Handle, (u64, Option<ContentId>)>,
    /// Acceleration structures constructed by deserialization, until built
    /// or copied into again.
    pub deserialized: BTreeMap<Handle, Deserialized>,
    /// The structures the instances of each top-level build the checker saw
    /// reference (by handle, resolved from the instances it read): what a
    /// command that reaches the top-level structure also accesses.
    pub instances: BTreeMap<Handle, BTreeSet<Handle>>,
    /// Contents given to objects whose construction the checker did not see
    /// (built before it saw anything): they stand for whatever the object
    /// held, which may itself have been deserialized from anything.
    before_run: BTreeSet<ContentId>,
    /// The fingerprint of a deserialization's source an adaptor read, and
    /// where (see [`Self::source_fingerprint`]).
    source: Option<(Space, u64, Fingerprint)>,
}

impl Provenance {
    fn next(&mut self) -> u64 {
        self.seq += 1;
        self.seq
    }

    /// `object` was built: new contents.
    pub fn constructed(&mut self, object: Handle) {
        let seq = self.next();
        self.constructed.insert(object, (seq, Some(seq)));
        self.deserialized.remove(&object);
    }

    /// `object` now holds `content` (a copy or a deserialization, after
    /// [`Self::constructed`] recorded the construction).
    pub fn set_content(&mut self, object: Handle, content: Option<ContentId>) {
        let seq = self.constructed.get(&object).map_or(0, |(seq, _)| *seq);
        self.constructed.insert(object, (seq, content));
    }

    /// What `object` holds, if a construction the checker saw says.
    pub fn content(&self, object: Handle) -> Option<ContentId> {
        self.constructed.get(&object).and_then(|(_, c)| *c)
    }

    /// What `object` holds: the contents a construction the checker saw
    /// gave it, or else new contents standing for what it held before
    /// (see [`Self::seen_constructed`]).
    pub fn content_or_assign(&mut self, object: Handle) -> ContentId {
        if let Some(content) = self.content(object) {
            return content;
        }
        let content = self.next();
        self.before_run.insert(content);
        let seq = self.constructed_seq(object).unwrap_or(0);
        self.constructed.insert(object, (seq, Some(content)));
        content
    }

    /// Whether `content` is what a construction the checker saw produced,
    /// rather than what an object held before the checker saw it (which
    /// may be anything, so differing from it decides nothing).
    pub fn seen_constructed(&self, content: ContentId) -> bool {
        !self.before_run.contains(&content)
    }

    /// When `object` was last constructed in this run (None: not seen).
    pub fn constructed_seq(&self, object: Handle) -> Option<u64> {
        self.constructed.get(&object).map(|(seq, _)| *seq)
    }

    /// A destroyed object: nothing of it is kept.
    pub fn forget(&mut self, object: Handle) {
        self.constructed.remove(&object);
        self.deserialized.remove(&object);
        self.instances.remove(&object);
    }

    /// A serialization writes at `address`.
    pub fn serialized_at(
        &mut self,
        space: Space,
        address: u64,
        serialization: Serialization,
    ) -> Arc<Serialization> {
        let seq = self.next();
        let serialization = Arc::new(serialization);
        self.writes.insert(
            (space, address),
            Write {
                seq,
                serialization: serialization.clone(),
            },
        );
        if self.writes.len() > WRITES_AT_MOST {
            forget_oldest(&mut self.writes, |w| w.seq);
        }
        serialization
    }

    /// The last serialization the checker saw write at `address`.
    pub fn written_at(&self, space: Space, address: u64) -> Option<&Write> {
        self.writes.get(&(space, address))
    }

    /// Links bytes with `fingerprint` to the serialization last seen writing
    /// at `address`; false when none was.
    pub fn remember_fingerprint(
        &mut self,
        space: Space,
        address: u64,
        fingerprint: Fingerprint,
    ) -> bool {
        let Some(write) = self.writes.get(&(space, address)) else {
            return false;
        };
        let serialization = write.serialization.clone();
        if let Some(store) = self.fingerprints.store.clone() {
            store.remember(self.fingerprints.entry_of(
                fingerprint,
                &serialization,
                &self.before_run,
            ));
        }
        self.fingerprints.remember(fingerprint, serialization);
        true
    }

    /// The fingerprint of the bytes a deserialization is about to read at
    /// `address`, as an adaptor read them (bytes the core's state does not
    /// hold: a host source, or device bytes read back); consulted for
    /// that address until [`Self::source_read`] clears it.
    pub fn source_fingerprint(&mut self, space: Space, address: u64, fingerprint: Fingerprint) {
        self.source = Some((space, address, fingerprint));
    }

    /// The deserialization whose source fingerprint was given is done.
    pub fn source_read(&mut self) {
        self.source = None;
    }

    /// The fingerprint an adaptor gave for the bytes at `address`.
    pub fn fingerprint_given(&self, space: Space, address: u64) -> Option<Fingerprint> {
        self.source
            .filter(|(s, a, _)| *s == space && *a == address)
            .map(|(_, _, f)| f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn micromap(handle: Handle) -> Serialization {
        Serialization {
            function: "vkCmdCopyMicromapToMemoryEXT",
            what: Serialized::Micromap {
                micromap: handle,
                size: 64,
                content: None,
            },
            stored: false,
        }
    }

    #[test]
    fn a_later_write_at_the_same_address_replaces_the_earlier() {
        let mut p = Provenance::default();
        p.serialized_at(Space::Device, 0x100, micromap(1));
        p.serialized_at(Space::Device, 0x100, micromap(2));
        let write = p.written_at(Space::Device, 0x100).expect("written");
        assert_eq!(write.serialization.what, micromap(2).what);
        assert!(p.written_at(Space::Host, 0x100).is_none(), "another space");
    }

    #[test]
    fn writes_and_fingerprints_stay_bounded_and_forget_the_oldest() {
        let mut p = Provenance::default();
        for k in 0..(WRITES_AT_MOST as u64 + 10) {
            p.serialized_at(Space::Host, k * 16, micromap(k));
            assert!(p.remember_fingerprint(Space::Host, k * 16, k));
        }
        assert_eq!(p.writes.len(), WRITES_AT_MOST);
        assert!(p.written_at(Space::Host, 0).is_none());
        assert!(p
            .written_at(Space::Host, (WRITES_AT_MOST as u64 + 9) * 16)
            .is_some());
        assert!(p.fingerprints.find(0).is_none());
        assert!(p.fingerprints.find(WRITES_AT_MOST as u64 + 9).is_some());
        assert!(
            !p.remember_fingerprint(Space::Device, 8, 1),
            "never written"
        );
    }

    #[test]
    fn another_run_finds_a_serialization_through_a_shared_store() {
        let dir =
            std::env::temp_dir().join(format!("ommcheck-provenance-shared-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut first = Provenance::default();
        first
            .fingerprints
            .use_store(Arc::new(Store::open(&dir, store::DEFAULT_MAX_BYTES)));
        first.constructed(1);
        let content = first.content(1);
        let mut serialization = micromap(1);
        serialization.what = Serialized::Micromap {
            micromap: 1,
            size: 4096,
            content,
        };
        first.serialized_at(Space::Host, 0x100, serialization);
        assert!(first.remember_fingerprint(Space::Host, 0x100, 0xF1));
        // Another run (a fresh store handle stands for another process).
        let mut second = Provenance::default();
        second
            .fingerprints
            .use_store(Arc::new(Store::open(&dir, store::DEFAULT_MAX_BYTES)));
        let found = second.fingerprints.find(0xF1).expect("in the store");
        assert!(found.stored);
        let Serialized::Micromap { size, content, .. } = found.what else {
            panic!("a micromap");
        };
        assert_eq!(size, 4096);
        let content = content.expect("a construction the first run saw");
        assert!(second.seen_constructed(content));
        let again = second.fingerprints.find(0xF1).expect("in the store");
        assert!(
            matches!(again.what, Serialized::Micromap { content: Some(c), .. } if c == content),
            "the same key is the same content id"
        );
        // Contents from before the first run saw anything are stored as
        // unknown, never as something to compare with.
        let unseen = first.content_or_assign(2);
        first.serialized_at(
            Space::Host,
            0x200,
            Serialization {
                what: Serialized::Micromap {
                    micromap: 2,
                    size: 64,
                    content: Some(unseen),
                },
                ..micromap(2)
            },
        );
        assert!(first.remember_fingerprint(Space::Host, 0x200, 0xF2));
        let found = second.fingerprints.find(0xF2).expect("in the store");
        assert!(matches!(
            found.what,
            Serialized::Micromap { content: None, .. }
        ));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_build_gives_new_contents_and_a_copy_carries_them() {
        let mut p = Provenance::default();
        p.constructed(1);
        p.constructed(2);
        assert_ne!(p.content(1), p.content(2));
        let first = p.content(1);
        p.constructed(3);
        p.set_content(3, first);
        assert_eq!(p.content(3), first);
        assert!(p.constructed_seq(3) > p.constructed_seq(1));
        let unseen = p.content_or_assign(4);
        assert_eq!(p.content_or_assign(4), unseen, "assigned once");
        assert!(!p.seen_constructed(unseen));
        assert!(p.seen_constructed(first.expect("built")));
        p.forget(3);
        assert_eq!(p.content(3), None);
    }
}
