//! Route 1 of reading device build inputs: what transfer commands wrote.
//!
//! A build's inputs often reach device-local memory through
//! `vkCmdCopyBuffer` from a mapped staging buffer, or through
//! `vkCmdUpdateBuffer` / `vkCmdFillBuffer`. The layer records those
//! commands ([`Transfer`]) and, at submission, applies them in submission
//! order to [`Shadows`]: copies of the bytes of the windows that recorded
//! builds read ([`Shadows::watch`]), nothing else, so the cost follows what
//! builds reference rather than the size of the buffers. A build whose
//! windows are all known is then checked at submission like one reading
//! mapped memory. Anything the layer cannot follow (a command that runs
//! shaders, which may write any buffer through its device address, or a
//! copy from an image or query pool) forgets what was known.
//!
//! Plain data and arithmetic only: the submission code hands in the bytes
//! it reads from mapped memory.

use std::collections::BTreeMap;

use ommcheck::Bytes;

use foldhash::HashMap;

/// A recorded command that writes buffer memory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Transfer {
    /// `vkCmdCopyBuffer(2)`: each region `(src offset, dst offset, size)`.
    Copy {
        src: u64,
        dst: u64,
        regions: Vec<(u64, u64, u64)>,
    },
    /// `vkCmdUpdateBuffer`: `bytes` at `offset`.
    Update { dst: u64, offset: u64, bytes: Bytes },
    /// `vkCmdFillBuffer`: `size` bytes (`VK_WHOLE_SIZE` already resolved)
    /// of the little-endian word `value` repeated, from `offset`.
    Fill {
        dst: u64,
        offset: u64,
        size: u64,
        value: u32,
    },
    /// A command that may write memory the layer does not follow.
    Unknown,
}

/// Known bytes of the windows of buffers that recorded builds read.
#[derive(Debug, Default)]
pub struct Shadows {
    /// Buffer → the window `[start, end)` builds read from it (the hull of
    /// every window recorded builds named).
    watched: HashMap<u64, (u64, u64)>,
    /// Buffer → disjoint known runs inside its window, by start offset.
    known: HashMap<u64, BTreeMap<u64, Vec<u8>>>,
    /// Bytes held in `known`.
    held: u64,
    /// The most bytes `known` may hold; writes past it are forgotten.
    pub max_bytes: u64,
}

impl Shadows {
    pub fn new(max_bytes: u64) -> Self {
        Self {
            max_bytes,
            ..Self::default()
        }
    }

    /// Later transfers into `[start, end)` of `buffer` are followed.
    pub fn watch(&mut self, buffer: u64, start: u64, end: u64) {
        let window = self.watched.entry(buffer).or_insert((start, end));
        *window = (window.0.min(start), window.1.max(end));
    }

    /// Watches the windows of copy sources that feed watched windows, so a
    /// chain of copies through buffers no build reads (staging to an
    /// intermediate, intermediate to the input) is followed. `transfers`
    /// come last first, as a submission would run them backwards.
    pub fn watch_copy_sources<'a>(&mut self, transfers: impl Iterator<Item = &'a Transfer>) {
        for transfer in transfers {
            let Transfer::Copy { src, dst, regions } = transfer else {
                continue;
            };
            for &(src_offset, dst_offset, size) in regions {
                if let Some((start, end)) = self.clip(*dst, dst_offset, size) {
                    let from = src_offset.saturating_add(start - dst_offset);
                    self.watch(*src, from, from.saturating_add(end - start));
                }
            }
        }
    }

    /// Forgets a destroyed buffer.
    pub fn forget_buffer(&mut self, buffer: u64) {
        self.watched.remove(&buffer);
        self.invalidate(buffer, 0, u64::MAX);
    }

    /// Forgets every known byte of `buffer` (the host may have written it).
    pub fn forget_contents(&mut self, buffer: u64) {
        self.invalidate(buffer, 0, u64::MAX);
    }

    /// Forgets every known byte (something wrote memory the layer cannot follow).
    pub fn forget_all(&mut self) {
        self.known.clear();
        self.held = 0;
    }

    /// Buffers with known bytes.
    pub fn buffers_known(&self) -> impl Iterator<Item = u64> + '_ {
        self.known.keys().copied()
    }

    /// The part of `[start, start + len)` of `buffer` inside its watched
    /// window, or None.
    fn clip(&self, buffer: u64, start: u64, len: u64) -> Option<(u64, u64)> {
        let &(window_start, window_end) = self.watched.get(&buffer)?;
        let end = start.saturating_add(len).min(window_end);
        let start = start.max(window_start);
        (start < end).then_some((start, end))
    }

    /// `[start, end)` of `buffer` is no longer known.
    fn invalidate(&mut self, buffer: u64, start: u64, end: u64) {
        let Some(runs) = self.known.get_mut(&buffer) else {
            return;
        };
        let overlapping: Vec<u64> = runs
            .range(..end)
            .filter(|(&s, bytes)| s.saturating_add(bytes.len() as u64) > start)
            .map(|(&s, _)| s)
            .collect();
        for s in overlapping {
            let Some(bytes) = runs.remove(&s) else {
                continue;
            };
            self.held -= bytes.len() as u64;
            let run_end = s + bytes.len() as u64;
            // Keep what lies before and after the invalidated range.
            if s < start {
                let head = bytes[..(start - s) as usize].to_vec();
                self.held += head.len() as u64;
                runs.insert(s, head);
            }
            if run_end > end {
                let tail = bytes[(end - s) as usize..].to_vec();
                self.held += tail.len() as u64;
                runs.insert(end, tail);
            }
        }
        if runs.is_empty() {
            self.known.remove(&buffer);
        }
    }

    /// Whether `len` more bytes fit under `max_bytes` (checked before bytes
    /// are gathered for a write: a window's length comes from a buffer size
    /// the application chose).
    fn has_room_for(&self, len: u64) -> bool {
        self.held.saturating_add(len) <= self.max_bytes
    }

    /// `bytes` were written at `offset` of `buffer`: the part inside its
    /// watched window becomes known (or unknown, past `max_bytes`).
    pub fn write(&mut self, buffer: u64, offset: u64, bytes: &[u8]) {
        let Some((start, end)) = self.clip(buffer, offset, bytes.len() as u64) else {
            return;
        };
        self.invalidate(buffer, start, end);
        let len = end - start;
        if !self.has_room_for(len) {
            return;
        }
        let from = (start - offset) as usize;
        let run = bytes[from..from + len as usize].to_vec();
        self.held += len;
        self.known.entry(buffer).or_default().insert(start, run);
    }

    /// The bytes `[start, start + len)` of `buffer`, if all are known.
    pub fn read(&self, buffer: u64, start: u64, len: u64) -> Option<Vec<u8>> {
        // Known bytes never exceed what is held: a longer read cannot be
        // covered, and is refused before anything is allocated for it.
        if len > self.held {
            return None;
        }
        let end = start.checked_add(len)?;
        let runs = self.known.get(&buffer)?;
        let mut out = Vec::with_capacity(usize::try_from(len).ok()?);
        let mut at = start;
        // The run holding `start`, then the runs that follow it without a gap.
        let first = runs.range(..=start).next_back().map(|(&s, _)| s)?;
        for (&s, bytes) in runs.range(first..) {
            if at >= end {
                break;
            }
            let run_end = s + bytes.len() as u64;
            if s > at || run_end <= at {
                return None; // A gap.
            }
            let to = run_end.min(end);
            out.extend_from_slice(&bytes[(at - s) as usize..(to - s) as usize]);
            at = to;
        }
        (at >= end).then_some(out)
    }

    /// Copies the known bytes of `buffer` that overlap `[start, start +
    /// out.len())` into `out` (over bytes read from mapped memory).
    pub fn overlay(&self, buffer: u64, start: u64, out: &mut [u8]) {
        let Some(runs) = self.known.get(&buffer) else {
            return;
        };
        let end = start.saturating_add(out.len() as u64);
        for (&s, bytes) in runs.range(..end) {
            let run_end = s + bytes.len() as u64;
            if run_end <= start {
                continue;
            }
            let from = s.max(start);
            let to = run_end.min(end);
            out[(from - start) as usize..(to - start) as usize]
                .copy_from_slice(&bytes[(from - s) as usize..(to - s) as usize]);
        }
    }

    /// Applies one recorded transfer. `read_mapped(buffer, offset, len)`
    /// gives bytes of mapped memory as the host sees them now; a copy's
    /// source is read from the shadow where it is known, else from there.
    pub fn apply(
        &mut self,
        transfer: &Transfer,
        read_mapped: impl Fn(u64, u64, u64) -> Option<Vec<u8>>,
    ) {
        match transfer {
            Transfer::Copy { src, dst, regions } => {
                for &(src_offset, dst_offset, size) in regions {
                    let Some((start, end)) = self.clip(*dst, dst_offset, size) else {
                        continue;
                    };
                    let from = src_offset.saturating_add(start - dst_offset);
                    let len = end - start;
                    if !self.has_room_for(len) {
                        self.invalidate(*dst, start, end);
                        continue;
                    }
                    let bytes = self.read(*src, from, len).or_else(|| {
                        let mut bytes = read_mapped(*src, from, len)?;
                        self.overlay(*src, from, &mut bytes);
                        Some(bytes)
                    });
                    match bytes {
                        Some(bytes) => self.write(*dst, start, &bytes),
                        None => self.invalidate(*dst, start, end),
                    }
                }
            }
            Transfer::Update { dst, offset, bytes } => self.write(*dst, *offset, bytes),
            Transfer::Fill {
                dst,
                offset,
                size,
                value,
            } => {
                let Some((start, end)) = self.clip(*dst, *offset, *size) else {
                    return;
                };
                if !self.has_room_for(end - start) {
                    self.invalidate(*dst, start, end);
                    return;
                }
                // The word's bytes continue from the fill's own start.
                let word = value.to_le_bytes();
                let bytes: Vec<u8> = (start..end)
                    .map(|at| word[((at - offset) % 4) as usize])
                    .collect();
                self.write(*dst, start, &bytes);
            }
            Transfer::Unknown => self.forget_all(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_mapped(_: u64, _: u64, _: u64) -> Option<Vec<u8>> {
        None
    }

    #[test]
    fn only_watched_windows_are_kept() {
        let mut shadows = Shadows::new(1 << 20);
        shadows.watch(1, 8, 16);
        shadows.write(1, 0, &[7u8; 32]);
        assert_eq!(shadows.read(1, 8, 8), Some(vec![7u8; 8]));
        assert_eq!(shadows.read(1, 0, 8), None, "outside the window");
        assert_eq!(shadows.held, 8);
        shadows.write(2, 0, &[1, 2, 3]);
        assert_eq!(shadows.read(2, 0, 3), None, "an unwatched buffer");
    }

    #[test]
    fn copies_take_their_source_from_mapped_memory_or_earlier_shadows() {
        let mut shadows = Shadows::new(1 << 20);
        shadows.watch(10, 0, 8);
        shadows.watch(20, 0, 8);
        let staging = |buffer: u64, offset: u64, len: u64| {
            (buffer == 5).then(|| (offset..offset + len).map(|b| b as u8).collect())
        };
        let copy = |src, dst, regions| Transfer::Copy { src, dst, regions };
        // Staging bytes 4..12 to buffer 10's 0..8, then buffer 10 on to 20.
        shadows.apply(&copy(5, 10, vec![(4, 0, 8)]), staging);
        shadows.apply(&copy(10, 20, vec![(0, 0, 8)]), no_mapped);
        assert_eq!(shadows.read(20, 0, 8), Some((4u8..12).collect()));
        // A copy from memory that is neither mapped nor known forgets the range.
        shadows.apply(&copy(99, 20, vec![(0, 2, 2)]), no_mapped);
        assert_eq!(shadows.read(20, 0, 8), None);
        assert_eq!(shadows.read(20, 0, 2), Some(vec![4, 5]));
        assert_eq!(shadows.read(20, 4, 4), Some(vec![8, 9, 10, 11]));
    }

    #[test]
    fn chains_of_copies_through_unread_buffers_are_followed() {
        let mut shadows = Shadows::new(1 << 20);
        shadows.watch(30, 0, 4);
        let hops = [
            Transfer::Copy {
                src: 5,
                dst: 20,
                regions: vec![(8, 100, 4)],
            },
            Transfer::Copy {
                src: 20,
                dst: 30,
                regions: vec![(100, 0, 4)],
            },
        ];
        shadows.watch_copy_sources(hops.iter().rev());
        let staging = |buffer: u64, offset: u64, len: u64| {
            (buffer == 5).then(|| (offset..offset + len).map(|b| b as u8).collect())
        };
        for hop in &hops {
            shadows.apply(hop, staging);
        }
        assert_eq!(shadows.read(30, 0, 4), Some(vec![8, 9, 10, 11]));
    }

    #[test]
    fn updates_and_fills_write_their_bytes_and_unknown_work_forgets_all() {
        let mut shadows = Shadows::new(1 << 20);
        shadows.watch(1, 0, 16);
        shadows.apply(
            &Transfer::Update {
                dst: 1,
                offset: 0,
                bytes: Bytes::from(vec![1u8; 16]),
            },
            no_mapped,
        );
        shadows.apply(
            &Transfer::Fill {
                dst: 1,
                offset: 4,
                size: 8,
                value: 0x0403_0201,
            },
            no_mapped,
        );
        let expected = [1, 1, 1, 1, 1, 2, 3, 4, 1, 2, 3, 4, 1, 1, 1, 1];
        assert_eq!(shadows.read(1, 0, 16), Some(expected.to_vec()));
        let mut mapped = vec![0u8; 8];
        shadows.overlay(1, 12, &mut mapped);
        assert_eq!(mapped, [1, 1, 1, 1, 0, 0, 0, 0]);
        shadows.apply(&Transfer::Unknown, no_mapped);
        assert_eq!(shadows.read(1, 0, 1), None);
        assert_eq!(shadows.held, 0);
    }

    #[test]
    fn huge_windows_are_refused_before_anything_is_allocated() {
        let mut shadows = Shadows::new(1 << 20);
        // A window as long as a buffer the application says is 2^60 bytes.
        shadows.watch(1, 0, 1 << 60);
        shadows.write(1, 0, &[5u8; 8]);
        let fill = Transfer::Fill {
            dst: 1,
            offset: 0,
            size: 1 << 60,
            value: 7,
        };
        shadows.apply(&fill, no_mapped);
        assert_eq!(
            shadows.read(1, 0, 8),
            None,
            "the fill made the range unknown"
        );
        assert_eq!(shadows.read(1, 0, 1 << 60), None);
        let copy = Transfer::Copy {
            src: 2,
            dst: 1,
            regions: vec![(0, 0, 1 << 60)],
        };
        shadows.apply(&copy, |_, _, len| {
            assert!(len <= 1 << 20, "asked the host for {len} bytes");
            None
        });
        assert_eq!(shadows.held, 0);
    }

    #[test]
    fn writes_past_the_byte_limit_are_forgotten() {
        let mut shadows = Shadows::new(8);
        shadows.watch(1, 0, 64);
        shadows.write(1, 0, &[1u8; 8]);
        shadows.write(1, 8, &[2u8; 8]);
        assert_eq!(shadows.read(1, 0, 8), Some(vec![1u8; 8]));
        assert_eq!(shadows.read(1, 8, 8), None);
        // Rewriting a known run does not count it twice.
        shadows.write(1, 0, &[3u8; 8]);
        assert_eq!(shadows.read(1, 0, 8), Some(vec![3u8; 8]));
    }
}
