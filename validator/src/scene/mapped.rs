//! Memory for a scene's buffer contents that is not allocated up front: a
//! binary file mapped where it is (a multi-GiB bake is checked without
//! being read into memory first), and lazily zeroed pages for the bytes a
//! scene does not give (a buffer declared far larger than its files costs
//! nothing until written).
//!
//! This is the scene loader's one module with `unsafe` code: mapping a file
//! is unsafe because another process may change the file while the mapping
//! lives. The assumption it rests on is stated at [`map_file`] and in
//! `docs/scene-format.md`.

#![allow(unsafe_code)]

use std::fs::File;
use std::io;

use memmap2::{MmapMut, MmapOptions};

use crate::Bytes;

/// The first `len` bytes of `file`, mapped read-only and shared: the pages
/// are the page cache's, read from disk when first touched, never copied.
/// The caller measured `file` through this same handle, so `len` is at
/// most its length when mapped.
pub(super) fn map_file(file: &File, len: usize) -> io::Result<Bytes> {
    // SAFETY: memmap2 hands out the mapping as a `&[u8]`, which Rust
    // assumes does not change while borrowed. That holds as long as no one
    // writes or truncates the file while the scene is checked, which
    // `docs/scene-format.md` asks of scene files. Otherwise the bytes the
    // checker reads may change between two reads (findings may then
    // describe neither version of the file, as any read of a file being
    // written would), and a read of a page the file no longer reaches
    // ends the process with SIGBUS. No memory outside the mapping is ever
    // read or written either way: every access is bounds-checked against
    // the mapping's fixed length.
    let map = unsafe { MmapOptions::new().len(len).map(file) }?;
    Ok(Bytes::from_owner(map))
}

/// The first `len` bytes of `file`, mapped copy-on-write: writable, with
/// the pages written becoming the process's own copies and the rest staying
/// the page cache's. For a file that fills its buffer with other pieces
/// placed over it.
pub(super) fn map_file_private(file: &File, len: usize) -> io::Result<MmapMut> {
    // SAFETY: as for `map_file`: the file is not changed while the scene is
    // checked (on Linux, a page not yet written through this mapping may
    // show a later change of the file); otherwise changed bytes or SIGBUS,
    // never an access outside the mapping. `no_reserve_swap`: only the pages
    // the overlaid pieces write need memory, so none is reserved for the rest.
    unsafe { MmapOptions::new().len(len).no_reserve_swap().map_copy(file) }
}

/// `len` bytes of zeros that cost no memory until written: the kernel's
/// anonymous pages, reserved but not committed (`MAP_NORESERVE` on Linux),
/// so a buffer declared 2^40 bytes long with a few bytes given holds only
/// the pages those bytes are written to. Reading an unwritten page maps the
/// shared zero page. Fails, rather than aborting the process, when the
/// address space cannot hold `len` bytes.
pub(super) fn zeroed(len: usize) -> io::Result<MmapMut> {
    MmapOptions::new().len(len).no_reserve_swap().map_anon()
}

/// A filled mapping, read-only from now on, as shared contents.
pub(super) fn freeze(map: MmapMut) -> io::Result<Bytes> {
    Ok(Bytes::from_owner(map.make_read_only()?))
}
