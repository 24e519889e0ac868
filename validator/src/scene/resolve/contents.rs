//! A buffer's or host block's contents from its resolved pieces, without
//! copying large files and without allocating the bytes no piece gives:
//!
//! - a binary file that fills the buffer (at 0, as long as the buffer) is
//!   mapped, not read: the check reads the page cache in place, at any size
//!   the address space holds. Pieces placed after it go over it in a
//!   copy-on-write mapping, so only the pages they touch are copied;
//! - otherwise a small buffer (under [`MAP_AT_LEAST`]) is one allocation,
//!   filled in place, as before mapping existed;
//! - and a large one is lazily zeroed memory with every piece written into
//!   it: the bytes no piece gives read as zero but cost nothing, so memory
//!   follows the bytes the scene gives, never its declared sizes. A file is
//!   copied in chunks, and a chunk that already reads as it should (the
//!   zeros of a sparse file over zeros) is not written.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::scene::mapped;
use crate::Bytes;

use super::{problem, PieceBytes, Problem, Result};

/// The size from which contents are mapped rather than allocated: below it
/// a mapping's system calls and page-granular memory cost more than the
/// copy they save.
pub const MAP_AT_LEAST: u64 = 1 << 20;

/// How much of a file is read at once when it is copied into place.
const CHUNK: usize = 1 << 20;

/// One resolved piece: where it goes, its bytes, and its JSON path.
pub(super) struct Placed {
    pub at: u64,
    pub bytes: PieceBytes,
    pub path: String,
}

/// The `size` bytes the pieces describe, in order (a later piece goes over
/// an earlier one), every piece already known to lie inside them.
pub(super) fn assemble(size: u64, pieces: Vec<Placed>, at: &str) -> Result<Bytes> {
    let len = usize::try_from(size).or_else(|_| problem(at, "too large for this machine"))?;
    if len == 0 {
        return Ok(Bytes::new());
    }
    // The last piece that is a file filling the buffer: the pieces before it
    // are wholly covered by it, those after it go over it.
    let filling = pieces.iter().rposition(|p| {
        size >= MAP_AT_LEAST && p.at == 0 && matches!(p.bytes, PieceBytes::File(_, n) if n == size)
    });
    if let Some(base) = filling {
        let mut pieces = pieces;
        let over = pieces.split_off(base + 1);
        let Some(Placed {
            bytes: PieceBytes::File(path, _),
            path: piece_at,
            ..
        }) = pieces.pop()
        else {
            unreachable!("`filling` found a file piece at `base`");
        };
        let file = open_measured(&path, size, &piece_at)?;
        let failed = |e: std::io::Error| Problem {
            path: format!("{piece_at}.file"),
            message: format!("cannot map {}: {e}", path.display()),
        };
        if over.is_empty() {
            return mapped::map_file(&file, len).map_err(failed);
        }
        let mut map = mapped::map_file_private(&file, len).map_err(failed)?;
        write_pieces(&mut map, over)?;
        return mapped::freeze(map).map_err(failed);
    }
    if size < MAP_AT_LEAST {
        // The one allocation the bytes live in: filled in place, then shared
        // as it is, never copied.
        let mut bytes = vec![0u8; len];
        write_pieces(&mut bytes, pieces)?;
        return Ok(Bytes::from(bytes));
    }
    let mut map = mapped::zeroed(len).or_else(|e| {
        problem(
            at,
            format!("cannot reserve {size} bytes of address space for the contents: {e}"),
        )
    })?;
    write_pieces(&mut map, pieces)?;
    mapped::freeze(map).or_else(|e| problem(at, format!("cannot protect the contents: {e}")))
}

/// Writes each piece at its place in `target`, which is zero where no piece
/// was written yet.
fn write_pieces(target: &mut [u8], pieces: Vec<Placed>) -> Result<()> {
    for piece in pieces {
        // Both bounds were checked against the buffer's size, which is
        // `target`'s length.
        let from = usize::try_from(piece.at).unwrap_or(usize::MAX);
        let len = usize::try_from(piece.bytes.len()).unwrap_or(usize::MAX);
        let Some(place) = from
            .checked_add(len)
            .and_then(|to| target.get_mut(from..to))
        else {
            return problem(piece.path, "the piece ends past the buffer");
        };
        match piece.bytes {
            PieceBytes::Decoded(decoded) => place.copy_from_slice(&decoded),
            PieceBytes::File(path, len) => {
                let file = open_measured(&path, len, &piece.path)?;
                copy_file(file, place, place.len() >= CHUNK).or_else(|e| {
                    problem(
                        format!("{}.file", piece.path),
                        format!("cannot read {}: {e}", path.display()),
                    )
                })?;
            }
        }
    }
    Ok(())
}

/// Opens the file a piece names and checks it still has the `len` bytes it
/// had when the piece was resolved: its size decided where it goes, and a
/// mapping longer than the file would fault past its end.
fn open_measured(path: &Path, len: u64, at: &str) -> Result<File> {
    let at = format!("{at}.file");
    let file = File::open(path)
        .or_else(|e| problem(&at, format!("cannot read {}: {e}", path.display())))?;
    let now = file
        .metadata()
        .or_else(|e| problem(&at, format!("cannot read {}: {e}", path.display())))?
        .len();
    if now != len {
        return problem(
            at,
            format!(
                "{} changed while the scene was read: {len} bytes, now {now}",
                path.display()
            ),
        );
    }
    Ok(file)
}

/// Reads `file` into `place`, which it fills exactly. With `skip_same`, in
/// chunks, writing only those that differ from what `place` holds: a chunk
/// of zeros over lazily zeroed memory leaves its pages unallocated.
fn copy_file(mut file: File, place: &mut [u8], skip_same: bool) -> std::io::Result<()> {
    if !skip_same {
        return file.read_exact(place);
    }
    let mut chunk = vec![0u8; CHUNK];
    for target in place.chunks_mut(CHUNK) {
        let read = &mut chunk[..target.len()];
        file.read_exact(read)?;
        if target != read {
            target.copy_from_slice(read);
        }
    }
    Ok(())
}
