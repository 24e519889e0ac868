//! A buffer's or host block's contents from its resolved pieces, without
//! copying large files and without allocating the bytes no piece gives:
//!
//! - a binary file that fills the buffer (at 0, as long as the buffer, the
//!   last piece) is mapped read-only as it is: the check reads the page
//!   cache in place, at any size the address space holds;
//! - otherwise a small buffer (under [`MAP_AT_LEAST`]) is one allocation,
//!   filled in place, as before mapping existed;
//! - and a large one is lazily zeroed memory with the pieces placed in it
//!   in order: the bytes no piece gives read as zero but cost nothing, so
//!   memory follows the bytes the scene gives, never its declared sizes. A
//!   file of [`MAP_AT_LEAST`] bytes or more at a page boundary is mapped
//!   there copy-on-write (Linux); any other file is copied in chunks, and a
//!   chunk that already reads as it should (the zeros of a sparse file over
//!   zeros) is not written.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::scene::mapped::{self, Zeroed};
use crate::Bytes;

use super::{problem, PieceBytes, Problem, Result};

/// The size from which contents, and file pieces in them, are mapped
/// rather than allocated and read: below it a mapping's system calls and
/// page-granular memory cost more than the copy they save.
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
pub(super) fn assemble(size: u64, mut pieces: Vec<Placed>, at: &str) -> Result<Bytes> {
    let len = usize::try_from(size).or_else(|_| problem(at, "too large for this machine"))?;
    if len == 0 {
        return Ok(Bytes::new());
    }
    // A last piece that is a file filling the buffer covers every piece
    // before it: the file alone is the contents.
    if size >= MAP_AT_LEAST {
        if let Some(Placed {
            at: 0,
            bytes: PieceBytes::File(path, file_len),
            path: piece_at,
        }) = pieces.last()
        {
            if *file_len == size {
                let file = open_measured(path, size, piece_at)?;
                return mapped::map_file(&file, len).map_err(|e| cannot_map(path, piece_at, e));
            }
        }
    }
    if size < MAP_AT_LEAST {
        // The one allocation the bytes live in: filled in place, then shared
        // as it is, never copied.
        let mut bytes = vec![0u8; len];
        for piece in pieces.drain(..) {
            write_piece(&mut bytes, piece)?;
        }
        return Ok(Bytes::from(bytes));
    }
    let mut memory = Zeroed::new(len).or_else(|e| {
        problem(
            at,
            format!("cannot reserve {size} bytes of address space for the contents: {e}"),
        )
    })?;
    for piece in pieces {
        memory = match piece.bytes {
            PieceBytes::File(ref path, file_len)
                if file_len >= MAP_AT_LEAST && Zeroed::can_map_at(piece.at) =>
            {
                let file = open_measured(path, file_len, &piece.path)?;
                // Both fit usize: the piece lies inside the `len` bytes.
                let (from, n) = (piece.at as usize, file_len as usize);
                memory
                    .map_file_at(from, &file, n)
                    .map_err(|e| cannot_map(path, &piece.path, e))?
            }
            _ => {
                write_piece(memory.bytes_mut(), piece)?;
                memory
            }
        };
    }
    memory
        .freeze()
        .or_else(|e| problem(at, format!("cannot protect the contents: {e}")))
}

fn cannot_map(path: &Path, piece_at: &str, e: std::io::Error) -> Problem {
    Problem {
        path: format!("{piece_at}.file"),
        message: format!("cannot map {}: {e}", path.display()),
    }
}

/// Writes a piece at its place in `target`, which is zero where no piece
/// was written yet.
fn write_piece(target: &mut [u8], piece: Placed) -> Result<()> {
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
            copy_file(file, place).or_else(|e| {
                problem(
                    format!("{}.file", piece.path),
                    format!("cannot read {}: {e}", path.display()),
                )
            })?;
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

/// Reads `file` into `place`, which it fills exactly. A large file goes in
/// chunks, each written only where it differs from what `place` holds: a
/// chunk of zeros over lazily zeroed memory leaves its pages unallocated.
fn copy_file(mut file: File, place: &mut [u8]) -> std::io::Result<()> {
    if place.len() < CHUNK {
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
