//! The tracked buffers, kept together with an index from device addresses
//! to the buffers that hold them, so that resolving an address does not
//! walk every buffer the application created.
//!
//! The map is private: every change to a buffer's address or size goes
//! through [`Buffers::insert`], [`Buffers::remove`] or the guard
//! [`Buffers::get_mut`] returns, which re-index the buffer, so the index
//! cannot drift from the buffers.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::{Deref, DerefMut, Index};

use super::Buffer;
use crate::model::Handle;

/// Up to this many buffers, a lookup walks them all: cheaper than a look in
/// each size class of the index, and the same answer.
pub const WALK_AT_MOST: usize = 32;

/// One size class for each possible bit length of an address range's
/// length (1 to 2^64 - 1 bytes).
const SIZE_CLASSES: usize = u64::BITS as usize;

/// The `VkBuffer`s tracked, by handle.
#[derive(Clone, Default)]
pub struct Buffers {
    map: BTreeMap<Handle, Buffer>,
    index: AddressIndex,
}

impl fmt::Debug for Buffers {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // The index is derived from the map: showing it adds only noise.
        f.debug_map().entries(self.map.iter()).finish()
    }
}

impl Buffers {
    /// Tracks `buffer` as `handle`, returning the buffer it replaces.
    pub fn insert(&mut self, handle: Handle, buffer: Buffer) -> Option<Buffer> {
        let placement = Placement::of(&buffer);
        let old = self.map.insert(handle, buffer);
        // The old entry goes first: it may have the very key the new one has.
        if let Some(old) = &old {
            self.index.remove(handle, Placement::of(old));
        }
        self.index.add(handle, placement);
        old
    }

    /// Stops tracking `handle` (the buffer was destroyed).
    pub fn remove(&mut self, handle: &Handle) -> Option<Buffer> {
        let old = self.map.remove(handle)?;
        self.index.remove(*handle, Placement::of(&old));
        Some(old)
    }

    pub fn get(&self, handle: &Handle) -> Option<&Buffer> {
        self.map.get(handle)
    }

    /// The buffer `handle`, to change; its address and size are re-indexed
    /// when the returned guard is dropped.
    pub fn get_mut(&mut self, handle: &Handle) -> Option<BufferMut<'_>> {
        let buffer = self.map.get_mut(handle)?;
        Some(BufferMut {
            handle: *handle,
            indexed_as: Placement::of(buffer),
            buffer,
            index: &mut self.index,
        })
    }

    pub fn contains_key(&self, handle: &Handle) -> bool {
        self.map.contains_key(handle)
    }

    pub fn len(&self) -> usize {
        self.map.len()
    }

    pub fn is_empty(&self) -> bool {
        self.map.is_empty()
    }

    /// The buffers, lowest handle first.
    pub fn iter(&self) -> std::collections::btree_map::Iter<'_, Handle, Buffer> {
        self.map.iter()
    }

    /// The buffers' handles, lowest first.
    pub fn keys(&self) -> std::collections::btree_map::Keys<'_, Handle, Buffer> {
        self.map.keys()
    }

    /// The buffers, lowest handle first.
    pub fn values(&self) -> std::collections::btree_map::Values<'_, Handle, Buffer> {
        self.map.values()
    }

    /// Buffers whose device-address range contains `address`, lowest handle
    /// first.
    ///
    /// Cost: with at most [`WALK_AT_MOST`] buffers, a walk over them all.
    /// Beyond, through the index: O(C·log n + s + k·log n) for n buffers, of
    /// which k contain `address`; C ≤ 64 is the number of size classes in use
    /// (buffers whose range lengths have the same bit length), and s counts
    /// the buffers looked at that turn out not to contain `address`. A buffer
    /// of a class is looked at only if it starts less than twice the class's
    /// smallest length below `address`, so s is at most C unless buffers of
    /// one class overlap (aliased memory): then up to all of those
    /// overlapping ones that end below `address` within that window.
    pub fn containing(&self, address: u64) -> impl Iterator<Item = (Handle, &Buffer)> {
        let walk = (self.map.len() <= WALK_AT_MOST).then(|| {
            self.map.iter().filter_map(move |(handle, buffer)| {
                let (start, end) = Placement::of(buffer).range()?;
                (start <= address && address < end).then_some((*handle, buffer))
            })
        });
        let indexed = walk.is_none().then(|| {
            let mut handles = self.index.holding(address);
            // Checks report the first buffer found: the same order as the walk.
            handles.sort_unstable();
            handles
                .into_iter()
                .filter_map(move |handle| Some((handle, self.map.get(&handle)?)))
        });
        walk.into_iter()
            .flatten()
            .chain(indexed.into_iter().flatten())
    }

    /// Whether some buffer has a known device address (of any size).
    pub fn any_with_address(&self) -> bool {
        self.index.with_address > 0
    }
}

impl Index<&Handle> for Buffers {
    type Output = Buffer;

    fn index(&self, handle: &Handle) -> &Buffer {
        &self.map[handle]
    }
}

impl<'a> IntoIterator for &'a Buffers {
    type Item = (&'a Handle, &'a Buffer);
    type IntoIter = std::collections::btree_map::Iter<'a, Handle, Buffer>;

    fn into_iter(self) -> Self::IntoIter {
        self.map.iter()
    }
}

impl FromIterator<(Handle, Buffer)> for Buffers {
    fn from_iter<I: IntoIterator<Item = (Handle, Buffer)>>(iter: I) -> Self {
        let mut buffers = Buffers::default();
        for (handle, buffer) in iter {
            buffers.insert(handle, buffer);
        }
        buffers
    }
}

/// A tracked buffer being changed: derefs to the [`Buffer`] and, when
/// dropped, moves the buffer in the address index if its address or size
/// changed.
pub struct BufferMut<'a> {
    handle: Handle,
    indexed_as: Placement,
    buffer: &'a mut Buffer,
    index: &'a mut AddressIndex,
}

impl Deref for BufferMut<'_> {
    type Target = Buffer;

    fn deref(&self) -> &Buffer {
        self.buffer
    }
}

impl DerefMut for BufferMut<'_> {
    fn deref_mut(&mut self) -> &mut Buffer {
        self.buffer
    }
}

impl Drop for BufferMut<'_> {
    fn drop(&mut self) {
        let now = Placement::of(self.buffer);
        if now != self.indexed_as {
            self.index.remove(self.handle, self.indexed_as);
            self.index.add(self.handle, now);
        }
    }
}

/// What of a buffer the index depends on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Placement {
    device_address: Option<u64>,
    size: u64,
}

impl Placement {
    fn of(buffer: &Buffer) -> Self {
        Placement {
            device_address: buffer.device_address,
            size: buffer.size,
        }
    }

    /// The address range `[start, end)`, as `Buffer::address_range`
    /// computes it, when it holds at least one address.
    fn range(self) -> Option<(u64, u64)> {
        let start = self.device_address?;
        let end = start.saturating_add(self.size);
        (start < end).then_some((start, end))
    }
}

/// Buffers with non-empty address ranges, grouped by the bit length of
/// their range's length: every buffer of class c is at least 2^c and less
/// than 2^(c+1) bytes long, so one containing an address starts less than
/// 2^(c+1) below it, and a query walks only that window of each class.
#[derive(Clone, Debug)]
struct AddressIndex {
    /// Per class: `(start, handle)` to end. Several buffers may share a
    /// start; the handle keeps their keys apart.
    classes: [BTreeMap<(u64, Handle), u64>; SIZE_CLASSES],
    /// Bit c is set while class c holds a buffer, so queries skip empty ones.
    occupied: u64,
    /// Buffers with a known device address, zero-sized ones included.
    with_address: usize,
}

impl Default for AddressIndex {
    fn default() -> Self {
        AddressIndex {
            classes: std::array::from_fn(|_| BTreeMap::new()),
            occupied: 0,
            with_address: 0,
        }
    }
}

impl AddressIndex {
    fn class_of(start: u64, end: u64) -> usize {
        // end > start, so the length is at least 1 and ilog2 is defined.
        (end - start).ilog2() as usize
    }

    fn add(&mut self, handle: Handle, placement: Placement) {
        if placement.device_address.is_some() {
            self.with_address += 1;
        }
        if let Some((start, end)) = placement.range() {
            let class = Self::class_of(start, end);
            self.classes[class].insert((start, handle), end);
            self.occupied |= 1 << class;
        }
    }

    fn remove(&mut self, handle: Handle, placement: Placement) {
        if placement.device_address.is_some() {
            self.with_address -= 1;
        }
        if let Some((start, end)) = placement.range() {
            let class = Self::class_of(start, end);
            self.classes[class].remove(&(start, handle));
            if self.classes[class].is_empty() {
                self.occupied &= !(1 << class);
            }
        }
    }

    /// Handles of the buffers whose range contains `address`, in no
    /// particular order.
    fn holding(&self, address: u64) -> Vec<Handle> {
        let mut found = Vec::new();
        let mut classes = self.occupied;
        while classes != 0 {
            let class = classes.trailing_zeros() as usize;
            classes &= classes - 1;
            // The longest range of the class; one starting further below
            // `address` ends at or before it.
            let longest = u64::MAX >> (SIZE_CLASSES - 1 - class);
            let lowest_start = address.saturating_sub(longest);
            found.extend(
                self.classes[class]
                    .range((lowest_start, Handle::MIN)..=(address, Handle::MAX))
                    .filter(|(_, &end)| address < end)
                    .map(|(&(_, handle), _)| handle),
            );
        }
        found
    }
}
