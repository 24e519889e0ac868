//! Memory for a scene's buffer contents that is not allocated up front: a
//! binary file mapped where it is (a multi-GiB bake is checked without
//! being read into memory first), and lazily zeroed pages for the bytes a
//! scene does not give (a buffer declared far larger than its files costs
//! nothing until written), into which files can be mapped too.
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

/// Bytes that read as zero and cost no memory until written: the kernel's
/// anonymous pages, reserved but not committed (`MAP_NORESERVE` on Linux),
/// so a buffer declared 2^40 bytes long with a few bytes given holds only
/// the pages those bytes are written to. Reading an unwritten page maps the
/// shared zero page. Files can be mapped into it ([`Self::map_file_at`]).
pub(super) struct Zeroed(MmapMut);

impl Zeroed {
    /// `len` bytes of zeros. Fails, rather than aborting the process, when
    /// the address space cannot hold them.
    pub fn new(len: usize) -> io::Result<Zeroed> {
        MmapOptions::new()
            .len(len)
            .no_reserve_swap()
            .map_anon()
            .map(Zeroed)
    }

    pub fn bytes_mut(&mut self) -> &mut [u8] {
        &mut self.0
    }

    /// Whether [`Self::map_file_at`] can place a file at `at`: a page
    /// boundary, on a system where it is implemented.
    pub fn can_map_at(at: u64) -> bool {
        page_size().is_some_and(|page| at.is_multiple_of(page as u64))
    }

    /// Maps `file`'s first `len` bytes over `[at, at + len)`, copy-on-write:
    /// its pages are the page cache's until written, and what was there is
    /// replaced, as writing the file's bytes there would. The caller
    /// measured `file` through this same handle, so `len` is at most its
    /// length. On an error `self` is dropped: part of it may have been
    /// unmapped already (a failed `MAP_FIXED` may do that), so it must not
    /// be read again.
    #[cfg(target_os = "linux")]
    pub fn map_file_at(mut self, at: usize, file: &File, len: usize) -> io::Result<Zeroed> {
        use std::os::fd::AsRawFd;

        let invalid = || io::Error::from(io::ErrorKind::InvalidInput);
        let page = page_size().ok_or_else(invalid)?;
        let end = at
            .checked_add(len)
            .filter(|end| *end <= self.0.len() && at.is_multiple_of(page))
            .ok_or_else(invalid)?;
        if len == 0 {
            return Ok(self);
        }
        // The kernel maps whole pages: past the file's end, the last one
        // reads as zero. What earlier pieces wrote there (at most a page
        // less one byte) is put back after.
        let tail_end = end.next_multiple_of(page).min(self.0.len());
        let tail = self.0[end..tail_end].to_vec();
        // SAFETY: `[at, at + len)` lies inside the anonymous mapping `self`
        // owns, `at` on a page boundary, and the pages the kernel rounds
        // `len` up to end at or before the mapping's own page-rounded end,
        // so MAP_FIXED replaces only memory of `self`, and nothing borrows
        // it (`self` is held by value). The file's side is `map_file`'s
        // assumption: no one changes the file while the scene is checked
        // (otherwise changed bytes, or SIGBUS past a new end; never an
        // access outside the mapping). MAP_NORESERVE: only pages written
        // later need memory of their own.
        let placed = unsafe {
            libc::mmap(
                self.0.as_mut_ptr().add(at).cast(),
                len,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_PRIVATE | libc::MAP_FIXED | libc::MAP_NORESERVE,
                file.as_raw_fd(),
                0,
            )
        };
        if placed == libc::MAP_FAILED {
            return Err(io::Error::last_os_error());
        }
        if tail.iter().any(|b| *b != 0) {
            self.0[end..tail_end].copy_from_slice(&tail);
        }
        Ok(self)
    }

    /// Elsewhere files are copied: [`Self::can_map_at`] is false.
    #[cfg(not(target_os = "linux"))]
    pub fn map_file_at(self, _at: usize, _file: &File, _len: usize) -> io::Result<Zeroed> {
        Err(io::Error::from(io::ErrorKind::Unsupported))
    }

    /// The filled memory, read-only from now on, as shared contents.
    pub fn freeze(self) -> io::Result<Bytes> {
        Ok(Bytes::from_owner(self.0.make_read_only()?))
    }
}

/// The system's page size, where files can be mapped into [`Zeroed`].
#[cfg(target_os = "linux")]
fn page_size() -> Option<usize> {
    // SAFETY: sysconf reads a system constant; it has no preconditions.
    let size = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    usize::try_from(size).ok().filter(|s| s.is_power_of_two())
}

#[cfg(not(target_os = "linux"))]
fn page_size() -> Option<usize> {
    None
}
