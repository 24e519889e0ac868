//! The layer's own memory that GPU readback copies build inputs into
//! (route 2, [`crate::readback`]): each device's [`Arena`] of host-visible
//! blocks, and the [`Readback`] range one recorded build's copies take of
//! it, whose bytes the checks read once the submission is complete.

#![allow(unsafe_code)]

use std::sync::{Arc, Mutex, MutexGuard, PoisonError, Weak};

use ash::vk;
use ommcheck::build_inputs::KnownBytes;
use ommcheck::Bytes;

use super::DeviceData;
use crate::own_calls::{self, OwnCall};
use crate::read;

/// One window of an application buffer a build reads, and where its copy
/// lies in the layer's readback buffer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Window {
    /// The parameter that names the first read in the window.
    pub location: String,
    /// The application's `VkBuffer`.
    pub buffer: u64,
    /// The window's start in that buffer.
    pub offset: u64,
    pub len: u64,
    /// The window's start in its readback's range.
    pub at: u64,
}

/// The layer's host-visible copy of the windows one recorded build reads:
/// a range of a block of the device's [`Arena`]. Dropping it returns the
/// range, which the command buffer's reset, free or pool destruction
/// allows (the command buffer is then not pending).
#[derive(Debug)]
pub struct Readback {
    arena: Arc<Mutex<Arena>>,
    block: u64,
    /// The range's start in its block's buffer, and its length.
    offset: u64,
    size: u64,
    /// The block's buffer, which the copies write.
    buffer: vk::Buffer,
    /// Where the range starts in host memory (the block is mapped whole).
    mapped: usize,
    pub windows: Vec<Window>,
    /// Alive while a view of the range ([`Readback::contents`]) is.
    views: Mutex<Weak<()>>,
    /// Memory of earlier copies of the views, for reuse.
    spares: Mutex<Vec<Bytes>>,
}

impl Drop for Readback {
    fn drop(&mut self) {
        lock(&self.arena).release(self.block, self.offset, self.size);
    }
}

impl Readback {
    /// The bytes the copies wrote, one window each, for the content checks:
    /// views of the range, not copies. Each view keeps the range taken
    /// (this readback alive), so what the checks keep (a built micromap's
    /// triangles and data) stays readable; before the range is written
    /// again, [`Readback::own_views`] makes those copies. Call only once
    /// the submission that ran the copies is complete.
    pub fn contents(self: &Arc<Self>) -> Vec<KnownBytes> {
        let Ok(size) = usize::try_from(self.size) else {
            return Vec::new();
        };
        let token = {
            let mut views = lock(&self.views);
            views.upgrade().unwrap_or_else(|| {
                let token = Arc::new(());
                *views = Arc::downgrade(&token);
                token
            })
        };
        // SAFETY: the range `[mapped, mapped + size)` is this readback's, in
        // a block mapped whole, host-coherent; the view keeps the readback,
        // so the range is neither returned nor the block unmapped while it
        // lives. The copies that write it have completed, and the range is
        // written again only by a later submission of the same recording,
        // before which `own_views` replaces the views the checker keeps.
        let whole = unsafe { read::mapped_view((Arc::clone(self), token), self.mapped, size) };
        self.windows
            .iter()
            .filter_map(|window| {
                let at = usize::try_from(window.at).ok()?;
                let end = at.checked_add(usize::try_from(window.len).ok()?)?;
                (end <= size).then(|| KnownBytes {
                    buffer: window.buffer,
                    offset: window.offset,
                    bytes: whole.slice(at..end),
                })
            })
            .collect()
    }

    /// Before the range is written again (a later submission of the
    /// recording that holds it): what `state` keeps of it becomes copies.
    /// The copies' memory is kept here and reused at the next submission
    /// once the checker has let go of it (a completion replaced what it
    /// kept), so a command buffer submitted again and again neither
    /// allocates nor frees its copies each time.
    pub fn own_views(&self, state: &mut ommcheck::state::State) {
        if lock(&self.views).strong_count() == 0 {
            return;
        }
        let Ok(size) = usize::try_from(self.size) else {
            return;
        };
        let mut spares = lock(&self.spares);
        let mut copy = |bytes: &[u8]| {
            let reused = spares
                .iter()
                .position(|spare| spare.len() == bytes.len() && spare.is_unique())
                .and_then(|k| spares.swap_remove(k).try_into_mut().ok());
            let copied = match reused {
                Some(mut memory) => {
                    memory.copy_from_slice(bytes);
                    memory.freeze()
                }
                None => Bytes::copy_from_slice(bytes),
            };
            // One spare per view a build keeps (its triangles and data);
            // more would only be memory held for nothing.
            if spares.len() < MAX_SPARES {
                spares.push(copied.clone());
            }
            copied
        };
        state.own_bytes_within(&(self.mapped..self.mapped.saturating_add(size)), &mut copy);
    }
}

impl Readback {
    /// A range of `size` bytes of the device's readback memory for the
    /// copies of `windows`, within `limit` bytes held in all.
    pub fn take(
        data: &DeviceData,
        size: u64,
        limit: u64,
        windows: Vec<Window>,
    ) -> Result<Self, Refused> {
        let (block, offset, buffer, mapped) = lock(&data.readback_arena).take(data, size, limit)?;
        Ok(Readback {
            arena: Arc::clone(&data.readback_arena),
            block,
            offset,
            size,
            buffer,
            mapped,
            windows,
            views: Mutex::default(),
            spares: Mutex::default(),
        })
    }

    /// The buffer the copies write and the range's start in it.
    pub fn destination(&self) -> (vk::Buffer, u64) {
        (self.buffer, self.offset)
    }
}

/// Copies a readback keeps for reuse (see [`Readback::own_views`]).
const MAX_SPARES: usize = 8;

#[cfg(test)]
impl Readback {
    /// A readback of no memory, for tests of what holds readbacks.
    pub fn empty() -> Self {
        Readback {
            arena: Arc::default(),
            block: 0,
            offset: 0,
            size: 0,
            buffer: vk::Buffer::null(),
            mapped: 0,
            windows: Vec::new(),
            views: Mutex::default(),
            spares: Mutex::default(),
        }
    }
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // The arena is plain bookkeeping updated in single steps.
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Why the arena gave no range.
pub enum Refused {
    OverLimit {
        held: u64,
    },
    /// The next layer lacks a function, or has no memory type to use.
    Setup(String),
    /// One of the layer's own calls to the next layer failed.
    Failed(own_calls::Failed),
}

/// Blocks of a device's readback memory are at least this large, so most
/// recorded builds take a range of an existing block rather than a new
/// allocation from the driver.
const BLOCK_BYTES: u64 = 4 << 20;

/// One host-visible, host-coherent buffer of the layer's, bound to its own
/// memory and mapped whole, with the ranges not taken.
#[derive(Debug)]
struct Block {
    id: u64,
    buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    mapped: usize,
    size: u64,
    /// Free ranges `(offset, len)`, sorted and not touching.
    free: Vec<(u64, u64)>,
}

/// A device's readback memory: blocks sub-allocated first fit. A block
/// left wholly free is given back to the driver unless it is the only one.
#[derive(Debug, Default)]
pub struct Arena {
    blocks: Vec<Block>,
    next_id: u64,
    /// Bytes of the ranges taken (what `gpu_readback_max_bytes` bounds).
    held: u64,
    /// The next layer's functions to give blocks back with, and the device.
    release_with: Option<(vk::Device, vk::PFN_vkDestroyBuffer, vk::PFN_vkFreeMemory)>,
}

impl Arena {
    /// A range of `size` bytes: (block, offset, the block's buffer, the
    /// range's host address).
    fn take(
        &mut self,
        data: &DeviceData,
        size: u64,
        limit: u64,
    ) -> Result<(u64, u64, vk::Buffer, usize), Refused> {
        if self.held.saturating_add(size) > limit {
            return Err(Refused::OverLimit { held: self.held });
        }
        let taken = match self.fit(size) {
            Some(taken) => taken,
            None => {
                let block_size = size.max(BLOCK_BYTES.min(limit));
                let mut block = allocate(data, block_size)?;
                self.next_id += 1;
                block.id = self.next_id;
                if block_size > size {
                    block.free.push((size, block_size - size));
                }
                let taken = (block.id, 0, block.buffer, block.mapped);
                if let (Some(destroy_buffer), Some(free_memory)) =
                    (data.fns.destroy_buffer, data.fns.free_memory)
                {
                    self.release_with = Some((data.handle, destroy_buffer, free_memory));
                }
                self.blocks.push(block);
                taken
            }
        };
        self.held += size;
        Ok(taken)
    }

    /// A range of `size` bytes from a block that has room, first fit.
    fn fit(&mut self, size: u64) -> Option<(u64, u64, vk::Buffer, usize)> {
        self.blocks.iter_mut().find_map(|block| {
            let k = block.free.iter().position(|&(_, len)| len >= size)?;
            let (offset, len) = block.free[k];
            if len == size {
                block.free.remove(k);
            } else {
                block.free[k] = (offset + size, len - size);
            }
            Some((
                block.id,
                offset,
                block.buffer,
                block.mapped + offset as usize,
            ))
        })
    }

    /// Returns a range taken from `block`.
    fn release(&mut self, block: u64, offset: u64, size: u64) {
        let Some(k) = self.blocks.iter().position(|b| b.id == block) else {
            return; // The device's blocks were given back already.
        };
        self.held = self.held.saturating_sub(size);
        let b = &mut self.blocks[k];
        let at = b.free.partition_point(|&(o, _)| o < offset);
        b.free.insert(at, (offset, size));
        // Merge with the neighbours it touches.
        if at + 1 < b.free.len() && b.free[at].0 + b.free[at].1 == b.free[at + 1].0 {
            b.free[at].1 += b.free[at + 1].1;
            b.free.remove(at + 1);
        }
        if at > 0 && b.free[at - 1].0 + b.free[at - 1].1 == b.free[at].0 {
            b.free[at - 1].1 += b.free[at].1;
            b.free.remove(at);
        }
        let wholly_free = b.free == [(0, b.size)];
        if wholly_free && self.blocks.len() > 1 {
            let block = self.blocks.remove(k);
            self.give_back(block);
        }
    }

    /// Gives every block back to the driver (before the device is destroyed).
    pub fn give_back_all(&mut self) {
        for block in std::mem::take(&mut self.blocks) {
            self.give_back(block);
        }
        self.held = 0;
    }

    fn give_back(&self, block: Block) {
        if let Some((device, destroy_buffer, free_memory)) = self.release_with {
            // SAFETY: the layer created both with the next layer's
            // functions of this device, which is alive (blocks go before
            // vkDestroyDevice is passed on), and no pending submission
            // copies into them (every range was returned).
            own_calls::call(OwnCall::ReadbackDestroyBuffer, || unsafe {
                destroy_buffer(device, block.buffer, std::ptr::null())
            });
            // SAFETY: as above.
            own_calls::call(OwnCall::ReadbackFreeMemory, || unsafe {
                free_memory(device, block.memory, std::ptr::null())
            });
        }
    }
}

/// Creates, binds and maps a host-visible, host-coherent buffer of `size`
/// bytes through the next layer. Whatever a failed step leaves is given
/// back before the error returns, so a failure leaks nothing and the next
/// build that needs readback memory tries again.
fn allocate(data: &DeviceData, size: u64) -> Result<Block, Refused> {
    let f = &data.fns;
    let device = data.handle;
    let (
        Some(create_buffer),
        Some(destroy_buffer),
        Some(requirements),
        Some(allocate_memory),
        Some(free_memory),
        Some(bind),
        Some(map),
    ) = (
        f.create_buffer,
        f.destroy_buffer,
        f.memory.get_buffer_memory_requirements,
        f.allocate_memory,
        f.free_memory,
        f.bind_buffer_memory,
        f.map_memory,
    )
    else {
        return Err(Refused::Setup(
            "the next layer lacks a buffer or memory function".into(),
        ));
    };
    let info = vk::BufferCreateInfo::default()
        .size(size)
        .usage(vk::BufferUsageFlags::TRANSFER_DST)
        .sharing_mode(vk::SharingMode::EXCLUSIVE);
    let mut buffer = vk::Buffer::null();
    let created = own_calls::checked(OwnCall::ReadbackCreateBuffer, || {
        // SAFETY: the next layer's function, with a valid create info.
        unsafe { create_buffer(device, &info, std::ptr::null(), &mut buffer) }
    });
    if let Err(failed) = created {
        return Err(Refused::Failed(failed));
    }
    let mut needs = vk::MemoryRequirements::default();
    own_calls::call(OwnCall::ReadbackMemoryRequirements, || {
        // SAFETY: the buffer just created, and a structure to fill.
        unsafe { requirements(device, buffer, &mut needs) }
    });
    let wanted = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
    let memory_type = data.memory_properties.as_ref().and_then(|p| {
        let types = p.memory_types_as_slice();
        let fits = |i: usize, flags: vk::MemoryPropertyFlags| {
            needs.memory_type_bits & (1 << i) != 0 && types[i].property_flags.contains(flags)
        };
        // Cached memory reads faster on the host; any coherent type will do.
        (0..types.len().min(32))
            .find(|&i| fits(i, wanted | vk::MemoryPropertyFlags::HOST_CACHED))
            .or_else(|| (0..types.len().min(32)).find(|&i| fits(i, wanted)))
    });
    let undo_buffer = || {
        own_calls::call(OwnCall::ReadbackDestroyBuffer, || {
            // SAFETY: the buffer just created, unused.
            unsafe { destroy_buffer(device, buffer, std::ptr::null()) }
        })
    };
    let Some(memory_type) = memory_type else {
        undo_buffer();
        return Err(Refused::Setup(
            "the device reports no host-visible, host-coherent memory type for a transfer buffer"
                .into(),
        ));
    };
    let allocate_info = vk::MemoryAllocateInfo::default()
        .allocation_size(needs.size)
        .memory_type_index(memory_type as u32);
    let mut memory = vk::DeviceMemory::null();
    let allocated = own_calls::checked(OwnCall::ReadbackAllocateMemory, || {
        // SAFETY: the next layer's function, with a valid allocate info.
        unsafe { allocate_memory(device, &allocate_info, std::ptr::null(), &mut memory) }
    });
    if let Err(failed) = allocated {
        undo_buffer();
        return Err(Refused::Failed(failed));
    }
    let mut mapped: *mut std::ffi::c_void = std::ptr::null_mut();
    let bound_and_mapped = own_calls::checked(OwnCall::ReadbackBindMemory, || {
        // SAFETY: the buffer and memory just created.
        unsafe { bind(device, buffer, memory, 0) }
    })
    .and_then(|_| {
        own_calls::checked(OwnCall::ReadbackMapMemory, || {
            // SAFETY: the memory just allocated, mapped whole.
            unsafe {
                map(
                    device,
                    memory,
                    0,
                    vk::WHOLE_SIZE,
                    vk::MemoryMapFlags::empty(),
                    &mut mapped,
                )
            }
        })
    });
    if bound_and_mapped.is_err() || mapped.is_null() {
        undo_buffer();
        own_calls::call(OwnCall::ReadbackFreeMemory, || {
            // SAFETY: the memory just allocated, not in use (freeing it
            // unmaps it, had the mapping succeeded).
            unsafe { free_memory(device, memory, std::ptr::null()) }
        });
        return Err(match bound_and_mapped {
            Err(failed) => Refused::Failed(failed),
            Ok(_) => Refused::Setup("vkMapMemory of the readback memory returned NULL".into()),
        });
    }
    Ok(Block {
        id: 0,
        buffer,
        memory,
        mapped: mapped as usize,
        size,
        free: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(id: u64, size: u64) -> Block {
        Block {
            id,
            buffer: vk::Buffer::null(),
            memory: vk::DeviceMemory::null(),
            mapped: 0x1000,
            size,
            free: vec![(0, size)],
        }
    }

    #[test]
    fn ranges_are_taken_first_fit_and_merged_back_when_returned() {
        let mut arena = Arena {
            blocks: vec![block(1, 64), block(2, 64)],
            ..Arena::default()
        };
        let a = arena.fit(16).expect("room");
        let b = arena.fit(32).expect("room");
        let c = arena.fit(32).expect("room in the second block");
        assert_eq!((a.0, a.1, a.3), (1, 0, 0x1000));
        assert_eq!((b.0, b.1, b.3), (1, 16, 0x1010));
        assert_eq!((c.0, c.1), (2, 0));
        assert!(arena.fit(48).is_none());
        arena.held = 80;
        arena.release(1, 0, 16);
        arena.release(1, 16, 32);
        assert_eq!(arena.blocks.len(), 1, "a wholly free block goes back");
        assert_eq!(arena.blocks[0].id, 2);
        arena.release(2, 0, 32);
        assert_eq!(arena.blocks.len(), 1, "the last block stays");
        assert_eq!(arena.blocks[0].free, [(0, 64)]);
        assert_eq!(arena.held, 0);
    }

    /// A readback whose range is `memory` (standing in for a mapped block),
    /// with one window at `at` of `len` bytes of buffer 9.
    fn readback_over(memory: &[u8], at: u64, len: u64) -> Arc<Readback> {
        Arc::new(Readback {
            size: memory.len() as u64,
            mapped: memory.as_ptr().expose_provenance(),
            windows: vec![Window {
                location: "pInfos[0].triangleArray".into(),
                buffer: 9,
                offset: 0,
                len,
                at,
            }],
            arena: Arc::default(),
            block: 0,
            offset: 0,
            buffer: vk::Buffer::null(),
            views: Mutex::default(),
            spares: Mutex::default(),
        })
    }

    #[test]
    fn contents_are_views_kept_until_the_range_is_written_again() {
        use ommcheck::sim::decode::{MicromapContent, TriangleEntries};
        use ommcheck::state::{BuildRecord, Micromap, State};
        let memory: Vec<u8> = (0..64).collect();
        let readback = readback_over(&memory, 16, 16);
        let contents = readback.contents();
        assert_eq!(contents.len(), 1);
        let bytes = contents[0].bytes.clone();
        assert_eq!(&bytes[..], &memory[16..32]);
        assert_eq!(bytes.as_ptr(), memory[16..].as_ptr(), "a view, not a copy");
        assert_eq!(Arc::strong_count(&readback), 2, "the view keeps the range");
        // What a check keeps: a built micromap's triangles.
        let keep = |state: &mut State, bytes| {
            let triangles = TriangleEntries::shared(bytes, 0, 8, 2).expect("inside");
            let content = MicromapContent::new(triangles, Default::default());
            state.micromaps.insert(
                1,
                Micromap {
                    built: Some(BuildRecord {
                        content: Some(Arc::new(content)),
                        ..BuildRecord::default()
                    }),
                    ..Micromap::default()
                },
            );
        };
        let kept = |state: &State| {
            let content = state.micromaps[&1].built.as_ref().unwrap().content.clone();
            content.expect("kept")
        };
        let mut state = State::default();
        keep(&mut state, bytes);
        drop(contents);
        // Before a later submission copies into the range again.
        readback.own_views(&mut state);
        assert_eq!(Arc::strong_count(&readback), 1, "no view is left");
        let content = kept(&state);
        assert_eq!(content.triangles.iter().count(), 2);
        assert_eq!(
            content.triangles.get(0).map(|t| t.data_offset),
            Some(u32::from_le_bytes([16, 17, 18, 19])),
            "the same bytes, now a copy"
        );
        let spare = |readback: &Readback| {
            let spares = lock(&readback.spares);
            spares.iter().map(|b| b.as_ptr()).collect::<Vec<_>>()
        };
        let first_copy = spare(&readback);
        assert_eq!(first_copy.len(), 1, "the copy's memory is kept");
        // The next completion keeps views again, letting go of the copy,
        // whose memory the next submission's copy reuses.
        drop(content);
        let contents = readback.contents();
        keep(&mut state, contents[0].bytes.clone());
        drop(contents);
        readback.own_views(&mut state);
        assert_eq!(Arc::strong_count(&readback), 1);
        assert_eq!(spare(&readback), first_copy, "reused, not allocated");
        assert_eq!(
            kept(&state).triangles.get(1).map(|t| t.format),
            Some(31 << 8 | 30)
        );
        // A window past the range gives no bytes.
        assert!(readback_over(&memory, 60, 16).contents().is_empty());
    }
}
