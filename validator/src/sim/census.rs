//! Counting the states of one micromap triangle's packed data without
//! decoding them one by one: 2-state data is counted by the ones it holds,
//! 4-state data by popcounts over its low bits, its high bits and the
//! fields with both set, 64 bits at a time.

use serde::Serialize;

use crate::sim::opacity::{bits_per_state, OpacityState};

/// How many micro-triangles hold each state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "camelCase")]
pub struct StateCounts {
    pub transparent: u64,
    pub opaque: u64,
    pub unknown_transparent: u64,
    pub unknown_opaque: u64,
}

impl StateCounts {
    /// `count` micro-triangles, all in `state`.
    pub fn all(state: OpacityState, count: u64) -> Self {
        let mut counts = Self::default();
        *counts.get_mut(state) = count;
        counts
    }

    pub fn get(&self, state: OpacityState) -> u64 {
        match state {
            OpacityState::Transparent => self.transparent,
            OpacityState::Opaque => self.opaque,
            OpacityState::UnknownTransparent => self.unknown_transparent,
            OpacityState::UnknownOpaque => self.unknown_opaque,
        }
    }

    pub fn get_mut(&mut self, state: OpacityState) -> &mut u64 {
        match state {
            OpacityState::Transparent => &mut self.transparent,
            OpacityState::Opaque => &mut self.opaque,
            OpacityState::UnknownTransparent => &mut self.unknown_transparent,
            OpacityState::UnknownOpaque => &mut self.unknown_opaque,
        }
    }

    /// The four counts in state order (transparent, opaque,
    /// unknown-transparent, unknown-opaque).
    pub fn to_array(self) -> [u64; 4] {
        [
            self.transparent,
            self.opaque,
            self.unknown_transparent,
            self.unknown_opaque,
        ]
    }

    pub fn total(&self) -> u64 {
        self.to_array()
            .iter()
            .fold(0u64, |sum, n| sum.saturating_add(*n))
    }

    /// The one state every counted micro-triangle holds, if they all hold
    /// the same one (None when none was counted).
    pub fn uniform(&self) -> Option<OpacityState> {
        let counts = self.to_array();
        let held = counts.iter().filter(|n| **n != 0).count();
        let first = counts.iter().position(|n| *n != 0)?;
        (held == 1).then_some(STATES[first])
    }

    /// Each count times `weight` (saturating: counts of references can
    /// exceed 64 bits only for inputs far beyond any real scene).
    #[inline]
    pub fn times(self, weight: u64) -> Self {
        if weight == 1 {
            return self;
        }
        self.map(|n| n.saturating_mul(weight))
    }

    fn map(self, f: impl Fn(u64) -> u64) -> Self {
        Self {
            transparent: f(self.transparent),
            opaque: f(self.opaque),
            unknown_transparent: f(self.unknown_transparent),
            unknown_opaque: f(self.unknown_opaque),
        }
    }
}

impl std::ops::AddAssign for StateCounts {
    fn add_assign(&mut self, other: Self) {
        self.transparent = self.transparent.saturating_add(other.transparent);
        self.opaque = self.opaque.saturating_add(other.opaque);
        self.unknown_transparent = self
            .unknown_transparent
            .saturating_add(other.unknown_transparent);
        self.unknown_opaque = self.unknown_opaque.saturating_add(other.unknown_opaque);
    }
}

/// The four states, in value order.
pub const STATES: [OpacityState; 4] = [
    OpacityState::Transparent,
    OpacityState::Opaque,
    OpacityState::UnknownTransparent,
    OpacityState::UnknownOpaque,
];

/// The low bit of every 2-bit field of a word.
const LOW_BITS: u64 = 0x5555_5555_5555_5555;

/// The state counts of one micromap triangle of `format` (raw value) at
/// subdivision `level`, from `block`, the bytes from its `dataOffset` on.
/// None when the format is not an opacity format, `4^level` does not fit 64
/// bits, or `block` is shorter than the triangle's data. Bytes past the
/// triangle's data are not read, nor the unused high bits of a triangle
/// smaller than a byte (2-state levels 0 and 1, 4-state level 0).
pub fn block_counts(block: &[u8], format: u32, level: u32) -> Option<StateCounts> {
    Shape::new(format, level)?.counts(block)
}

/// What counting a triangle of one format and level needs to know, worked
/// out once for all the triangles that share them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Bits per state: 1 or 2.
    bits: u32,
    /// Micro-triangles: `4^level`.
    states: u64,
    /// Bits of data used: `states · bits`.
    used_bits: u64,
    /// Bytes of data: `ceil(used_bits / 8)`.
    bytes: usize,
}

impl Shape {
    /// The shape of an opacity `format` (raw value) at `level`; None for
    /// another format or a level whose `4^level` does not fit 64 bits.
    pub fn new(format: u32, level: u32) -> Option<Self> {
        let bits = bits_per_state(format)?;
        let states = 1u64.checked_shl(level.checked_mul(2)?)?;
        let used_bits = states.checked_mul(u64::from(bits))?;
        let bytes = usize::try_from(used_bits.div_ceil(8)).ok()?;
        Some(Self {
            bits,
            states,
            used_bits,
            bytes,
        })
    }

    /// The state counts of the triangle whose data starts `block`; None
    /// when `block` is shorter than its data.
    // Inlined into the census loop: most triangles of a large micromap are
    // a few words, where a call costs as much as the counting.
    #[inline(always)]
    pub fn counts(self, block: &[u8]) -> Option<StateCounts> {
        let block = block.get(..self.bytes)?;
        let sums = match (block, self.bits) {
            // One byte, of which only the low `used_bits` hold states.
            ([byte], _) if self.used_bits < 8 => {
                BitSums::of_word(u64::from(*byte) & ((1u64 << self.used_bits) - 1))
            }
            (_, 1) => BitSums {
                ones: ones(block),
                ..BitSums::default()
            },
            // Too few words for the carry-save counter to pay (up to level 3).
            _ if block.len() < 8 * VECTOR_BYTES => words(block)
                .map(BitSums::of_word)
                .fold(BitSums::default(), |sums, word| sums + word),
            _ => BitSums::of_four_state(block),
        };
        Some(if self.bits == 1 {
            StateCounts {
                transparent: self.states - sums.ones,
                opaque: sums.ones,
                ..StateCounts::default()
            }
        } else {
            sums.four_state(self.states)
        })
    }
}

impl Shape {
    /// Bytes of one triangle's data.
    pub fn bytes(self) -> usize {
        self.bytes
    }

    /// Whether a triangle's states fill its bytes (every level but 2-state
    /// 0 and 1 and 4-state 0), so that the data of triangles laid one after
    /// the other reads as one stream of states.
    pub fn fills_bytes(self) -> bool {
        self.used_bits.is_multiple_of(8)
    }

    /// The state counts of `triangles` triangles of this shape whose data
    /// lies one after the other in `run` (`triangles · bytes` long): one
    /// stream of states, counted at once. Only for shapes that
    /// [fill their bytes](Self::fills_bytes).
    pub fn run_counts(self, run: &[u8], triangles: u64) -> StateCounts {
        let states = self.states.saturating_mul(triangles);
        if self.bits == 1 {
            let opaque = ones(run);
            return StateCounts {
                transparent: states - opaque,
                opaque,
                ..StateCounts::default()
            };
        }
        let sums = if run.len() < 8 * VECTOR_BYTES {
            words(run)
                .map(BitSums::of_word)
                .fold(BitSums::default(), |sums, word| sums + word)
        } else {
            BitSums::of_four_state(run)
        };
        sums.four_state(states)
    }

    /// Calls `check(j, group)` for the groups of triangles of `blocks` (the
    /// data of triangles laid one after the other, from triangle 0; `j` is
    /// the group's first) in which some triangle may be uniform, passing
    /// most of the others by a test without a branch per triangle: a
    /// triangle may be uniform only when its first word (or byte) repeats
    /// one state and its last equals its first, which a random triangle
    /// does once in thousands. Triangles of level 6 and up come one to a
    /// group: their first byte alone rules most out.
    #[inline(always)]
    pub fn maybe_uniform_groups(self, blocks: &[u8], mut check: impl FnMut(usize, &[u8])) {
        match self.bytes {
            1 => self.groups_of::<1>(blocks, check),
            2 => self.groups_of::<2>(blocks, check),
            4 => self.groups_of::<4>(blocks, check),
            8 => self.groups_of::<8>(blocks, check),
            16 => self.groups_of::<16>(blocks, check),
            32 => self.groups_of::<32>(blocks, check),
            64 => self.groups_of::<64>(blocks, check),
            128 => self.groups_of::<128>(blocks, check),
            256 => self.groups_of::<256>(blocks, check),
            _ => blocks
                .chunks_exact(self.bytes)
                .enumerate()
                .for_each(|(j, block)| check(j, block)),
        }
    }

    #[inline(always)]
    fn groups_of<const SIZE: usize>(self, blocks: &[u8], mut check: impl FnMut(usize, &[u8])) {
        const GROUP: usize = 16;
        let groups = blocks.chunks_exact(GROUP * SIZE);
        let rest = groups.remainder();
        let whole = blocks.len() / (GROUP * SIZE);
        for (g, group) in groups.enumerate() {
            let maybe = group.chunks_exact(SIZE).fold(false, |maybe, block| {
                maybe | self.may_be_uniform::<SIZE>(block)
            });
            if maybe {
                check(g * GROUP, group);
            }
        }
        if !rest.is_empty() {
            check(whole * GROUP, rest);
        }
    }

    /// The test of [`Self::maybe_uniform_groups`] for one triangle's
    /// `SIZE` bytes: a word (or byte) that repeats one state is the same
    /// rotated by one state.
    #[inline(always)]
    fn may_be_uniform<const SIZE: usize>(self, block: &[u8]) -> bool {
        if SIZE >= 8 {
            let (first, last) = (word(&block[..8]), word(&block[SIZE - 8..]));
            (first.rotate_left(self.bits) == first) & (last == first)
        } else {
            let (first, last) = (block[0], block[SIZE - 1]);
            (first.rotate_left(self.bits) == first) & (last == first)
        }
    }

    /// The one state all micro-triangles of the triangle whose data starts
    /// `block` hold, if they are alike. For shapes that
    /// [fill their bytes](Self::fills_bytes): every byte repeats the first
    /// state; read a word at a time, stopping at the first that differs.
    #[inline]
    pub fn uniform(self, block: &[u8]) -> Option<OpacityState> {
        let block = block.get(..self.bytes)?;
        let first = *block.first()? & if self.bits == 1 { 1 } else { 3 };
        let (state, byte) = if self.bits == 1 {
            (STATES[usize::from(first)], first * 0xff)
        } else {
            (STATES[usize::from(first)], first * 0x55)
        };
        // Most triangles are not uniform, and most show it in their first
        // byte.
        if block[0] != byte {
            return None;
        }
        let whole = block.chunks_exact(8);
        let alike = whole.remainder().iter().all(|b| *b == byte)
            && whole.map(word).all(|w| w == u64::from_ne_bytes([byte; 8]));
        alike.then_some(state)
    }
}

/// Popcounts over a triangle's data, read as little-endian 64-bit words
/// (a last partial word zero-extended: zero bits are transparent states,
/// which the counts derive from the total, so padding changes nothing).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct BitSums {
    /// Bits set.
    ones: u64,
    /// Bits set among the low bits of the 2-bit fields.
    low: u64,
    /// 2-bit fields with both bits set.
    both: u64,
}

impl std::ops::Add for BitSums {
    type Output = Self;

    fn add(self, other: Self) -> Self {
        Self {
            ones: self.ones + other.ones,
            low: self.low + other.low,
            both: self.both + other.both,
        }
    }
}

impl BitSums {
    #[inline(always)]
    fn of_word(w: u64) -> Self {
        Self {
            ones: u64::from(w.count_ones()),
            low: u64::from((w & LOW_BITS).count_ones()),
            both: u64::from((w & (w >> 1) & LOW_BITS).count_ones()),
        }
    }

    /// The sums over 4-state data in one pass, eight vectors at a time:
    /// the bits set and the low bits (those at even positions) through one
    /// Harley-Seal carry-save counter over the data as it is; the both-set
    /// fields, which use only the even bits of a word, through a second
    /// over the same vectors folded two into one (the second shifted onto
    /// the odd bits), so it adds half as many: eight folded vectors for
    /// every sixteen read.
    fn of_four_state(block: &[u8]) -> Self {
        // The same code, compiled for AVX2 where the CPU has it: twice the
        // lanes a vector, and a popcount of bytes by table lookup
        // (`vpshufb`) where baseline x86-64 has shifts and a multiply.
        #[cfg(target_arch = "x86_64")]
        if let Some(avx2) = pulp::x86::V3::try_new() {
            return avx2.vectorize(|| Self::of_four_state_portable(block));
        }
        Self::of_four_state_portable(block)
    }

    /// [`Self::of_four_state`] for whatever target the crate is built for;
    /// inlined whole into the caller, so that it is compiled with the
    /// caller's target features.
    #[inline(always)]
    fn of_four_state_portable(block: &[u8]) -> Self {
        let mut raw = EightWay::<true>::default();
        let mut both = EightWay::<false>::default();
        let steps = block.chunks_exact(16 * VECTOR_BYTES);
        let rest = steps.remainder();
        for step in steps {
            let mut folded = [[0u64; LANES]; 8];
            for (half, eight) in step.chunks_exact(8 * VECTOR_BYTES).enumerate() {
                let mut v = [[0u64; LANES]; 8];
                for (vector, bytes) in v.iter_mut().zip(eight.chunks_exact(VECTOR_BYTES)) {
                    *vector = lanes(bytes);
                }
                raw.add(&v);
                for k in 0..4 {
                    folded[4 * half + k] = both_set_folded(v[2 * k], v[2 * k + 1]);
                }
            }
            both.add(&folded);
        }
        let (ones, low) = raw.total();
        let tail = words(rest).fold(Self::default(), |sums, w| sums + Self::of_word(w));
        Self {
            ones,
            low,
            both: both.total().0,
        } + tail
    }

    /// A 4-state field's low bit is set for opaque (1) and unknown-opaque
    /// (3), its high bit for the two unknown states (2, 3): with L the
    /// fields with the low bit set, H those with the high bit and B those
    /// with both, opaque = L - B, unknown-transparent = H - B and
    /// unknown-opaque = B, of `states` fields.
    fn four_state(self, states: u64) -> StateCounts {
        let high = self.ones - self.low;
        let (opaque, unknown_transparent) = (self.low - self.both, high - self.both);
        StateCounts {
            transparent: states - opaque - unknown_transparent - self.both,
            opaque,
            unknown_transparent,
            unknown_opaque: self.both,
        }
    }
}

/// Words counted side by side: the carry-save counter works on four
/// independent lanes, which the compiler keeps in vector registers.
const LANES: usize = 4;
type Lanes = [u64; LANES];
const VECTOR_BYTES: usize = 8 * LANES;

/// Vector `i` of `bytes` (its words `LANES·i` to `LANES·i + LANES - 1`),
/// zeros when it is not whole.
#[inline(always)]
fn vector(bytes: &[u8], i: usize) -> Lanes {
    let at = i * VECTOR_BYTES;
    match bytes.get(at..at + VECTOR_BYTES) {
        Some(whole) => lanes(whole),
        None => [0; LANES],
    }
}

// The helpers below are loops, not `std::array::from_fn` or `map`: those
// are generic functions the compiler may leave out of line, compiled
// without the caller's target features (AVX2 under `of_four_state`).

/// The little-endian words of `VECTOR_BYTES` bytes, side by side.
#[inline(always)]
fn lanes(bytes: &[u8]) -> Lanes {
    let mut lanes = [0u64; LANES];
    for (lane, bytes) in lanes.iter_mut().zip(bytes.chunks_exact(8)) {
        *lane = word(bytes);
    }
    lanes
}

/// The 2-bit fields with both bits set of two vectors, as one: those of
/// `a` on the even bits, those of `b` on the odd bits.
#[inline(always)]
fn both_set_folded(a: Lanes, b: Lanes) -> Lanes {
    let mut folded = [0u64; LANES];
    for l in 0..LANES {
        folded[l] = (a[l] & (a[l] >> 1) & LOW_BITS) | (b[l] & (b[l] << 1) & !LOW_BITS);
    }
    folded
}

/// The bits of `v` at even positions.
#[inline(always)]
fn even_bits(mut v: Lanes) -> Lanes {
    for w in &mut v {
        *w &= LOW_BITS;
    }
    v
}

/// A little-endian word of up to 8 bytes.
#[inline(always)]
pub(crate) fn word(bytes: &[u8]) -> u64 {
    match <[u8; 8]>::try_from(bytes) {
        Ok(whole) => u64::from_le_bytes(whole),
        Err(_) => bytes
            .iter()
            .rev()
            .fold(0u64, |word, byte| (word << 8) | u64::from(*byte)),
    }
}

/// The words of `bytes`, a last partial one zero-extended.
#[inline(always)]
fn words(bytes: &[u8]) -> impl Iterator<Item = u64> + '_ {
    let whole = bytes.chunks_exact(8);
    let last = whole.remainder();
    whole
        .map(word)
        .chain((!last.is_empty()).then(|| word(last)))
}

/// The bits set in `bytes`.
#[inline(always)]
fn ones(bytes: &[u8]) -> u64 {
    let vectors = bytes.len() / VECTOR_BYTES;
    let tail = bytes.get(vectors * VECTOR_BYTES..).unwrap_or_default();
    let tail: u64 = words(tail).map(|w| u64::from(w.count_ones())).sum();
    if vectors == 0 {
        return tail;
    }
    #[cfg(target_arch = "x86_64")]
    if vectors >= 8 {
        if let Some(avx2) = pulp::x86::V3::try_new() {
            return avx2.vectorize(|| count_vectors(bytes, vectors)) + tail;
        }
    }
    count_vectors(bytes, vectors) + tail
}

/// The bits set in the first `n` vectors of `bytes`, eight at a time
/// through an [`EightWay`] counter.
#[inline(always)]
fn count_vectors(bytes: &[u8], n: usize) -> u64 {
    let mut counter = EightWay::<false>::default();
    let mut i = 0;
    while i + 8 <= n {
        let mut v = [[0u64; LANES]; 8];
        for (k, vector_k) in v.iter_mut().enumerate() {
            *vector_k = vector(bytes, i + k);
        }
        counter.add(&v);
        i += 8;
    }
    // Fewer than eight vectors left: counted one by one.
    (i..n).fold(counter.total().0, |all, i| all + popcount(vector(bytes, i)))
}

/// A Harley-Seal carry-save counter, fed eight vectors at a time: it adds
/// them bitwise (the ones, twos and fours of each bit position kept in
/// three vectors), so only one vector in eight (the eights) is popcounted as
/// it goes. The counter keeps bit positions apart, so masking what is
/// popcounted splits the count by position at no other cost: with `EVEN`,
/// the bits at even positions (4-state low bits) are counted too.
#[derive(Default)]
struct EightWay<const EVEN: bool> {
    ones: Lanes,
    twos: Lanes,
    fours: Lanes,
    /// The eights' popcounts, lane by lane: summed across lanes only at
    /// the end, so the popcount stays in vector registers.
    eights: Lanes,
    eights_even: Lanes,
}

impl<const EVEN: bool> EightWay<EVEN> {
    #[inline(always)]
    fn add(&mut self, v: &[Lanes; 8]) {
        let (twos_a, o) = add(self.ones, v[0], v[1]);
        let (twos_b, o) = add(o, v[2], v[3]);
        let (fours_a, t) = add(self.twos, twos_a, twos_b);
        let (twos_a, o) = add(o, v[4], v[5]);
        let (twos_b, o) = add(o, v[6], v[7]);
        let (fours_b, t) = add(t, twos_a, twos_b);
        let (eights, f) = add(self.fours, fours_a, fours_b);
        (self.ones, self.twos, self.fours) = (o, t, f);
        add_popcounts(&mut self.eights, eights);
        if EVEN {
            add_popcounts(&mut self.eights_even, even_bits(eights));
        }
    }

    /// (bits set, bits set at even positions; 0 without `EVEN`).
    #[inline(always)]
    fn total(&self) -> (u64, u64) {
        let (mut all, mut even) = (8 * sum(self.eights), 8 * sum(self.eights_even));
        for (weight, v) in [(4, self.fours), (2, self.twos), (1, self.ones)] {
            all += weight * popcount(v);
            if EVEN {
                even += weight * popcount(even_bits(v));
            }
        }
        (all, even)
    }
}

/// Adds each lane's popcount of `v` to that lane of `counts`.
#[inline(always)]
fn add_popcounts(counts: &mut Lanes, v: Lanes) {
    for l in 0..LANES {
        counts[l] += u64::from(v[l].count_ones());
    }
}

fn sum(v: Lanes) -> u64 {
    v.iter().sum()
}

/// A carry-save adder on each lane: (carries, sums) of a + b + c.
#[inline(always)]
fn add(a: Lanes, b: Lanes, c: Lanes) -> (Lanes, Lanes) {
    let mut carry = [0u64; LANES];
    let mut sum = [0u64; LANES];
    for k in 0..LANES {
        let partial = a[k] ^ b[k];
        carry[k] = (a[k] & b[k]) | (partial & c[k]);
        sum[k] = partial ^ c[k];
    }
    (carry, sum)
}

#[inline(always)]
fn popcount(v: Lanes) -> u64 {
    let mut ones = 0;
    for w in v {
        ones += u64::from(w.count_ones());
    }
    ones
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::values::{OPACITY_MICROMAP_FORMAT_2_STATE, OPACITY_MICROMAP_FORMAT_4_STATE};

    const TWO: u32 = OPACITY_MICROMAP_FORMAT_2_STATE;
    const FOUR: u32 = OPACITY_MICROMAP_FORMAT_4_STATE;

    fn counts(t: u64, o: u64, ut: u64, uo: u64) -> StateCounts {
        StateCounts {
            transparent: t,
            opaque: o,
            unknown_transparent: ut,
            unknown_opaque: uo,
        }
    }

    #[test]
    fn the_design_notes_baker_examples_count_as_their_states() {
        // 2-state level 3 from the SDK baker: states 0-31 opaque, 32-47
        // transparent, 48-63 opaque.
        let bytes = [0xff, 0xff, 0xff, 0xff, 0x00, 0x00, 0xff, 0xff];
        assert_eq!(block_counts(&bytes, TWO, 3), Some(counts(16, 48, 0, 0)));
        // 4-state 0x55: four opaque states (level 1).
        assert_eq!(block_counts(&[0x55], FOUR, 1), Some(counts(0, 4, 0, 0)));
        // 0b11_10_01_00: one of each.
        assert_eq!(
            block_counts(&[0b1110_0100], FOUR, 1),
            Some(counts(1, 1, 1, 1))
        );
    }

    #[test]
    fn unused_high_bits_and_bytes_past_the_block_are_not_counted() {
        // 2-state level 0 uses bit 0; level 1 bits 0-3; 4-state level 0 bits 0-1.
        assert_eq!(
            block_counts(&[0xfe, 0xff], TWO, 0),
            Some(counts(1, 0, 0, 0))
        );
        assert_eq!(block_counts(&[0xf3], TWO, 1), Some(counts(2, 2, 0, 0)));
        assert_eq!(block_counts(&[0xfe], FOUR, 0), Some(counts(0, 0, 1, 0)));
        // Level 2 4-state is 4 bytes; the fifth is another triangle's.
        assert_eq!(
            block_counts(&[0xff, 0xff, 0xff, 0xff, 0x55], FOUR, 2),
            Some(counts(0, 0, 0, 16))
        );
    }

    #[test]
    fn short_data_unknown_formats_and_huge_levels_are_none() {
        assert_eq!(block_counts(&[0; 15], FOUR, 3), None);
        assert_eq!(block_counts(&[], TWO, 0), None);
        assert_eq!(block_counts(&[0; 8], 3, 1), None);
        assert_eq!(block_counts(&[0; 8], TWO, 32), None);
        assert_eq!(block_counts(&[0; 8], FOUR, u32::MAX), None);
    }

    #[test]
    fn uniform_counts_name_their_state() {
        assert_eq!(
            counts(0, 0, 7, 0).uniform(),
            Some(OpacityState::UnknownTransparent)
        );
        assert_eq!(counts(1, 0, 7, 0).uniform(), None);
        assert_eq!(StateCounts::default().uniform(), None);
        assert_eq!(
            StateCounts::all(OpacityState::Opaque, 3).times(u64::MAX),
            counts(0, u64::MAX, 0, 0)
        );
        let mut sum = counts(1, 2, 3, 4);
        sum += counts(1, 1, 1, u64::MAX);
        assert_eq!(sum, counts(2, 3, 4, u64::MAX));
        assert_eq!(sum.total(), u64::MAX);
    }

    /// Pseudo-random bytes (a 64-bit LCG).
    fn noise(len: usize, seed: u64) -> Vec<u8> {
        let mut x = seed;
        (0..len)
            .map(|_| {
                x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                (x >> 56) as u8
            })
            .collect()
    }

    #[test]
    fn the_avx2_and_portable_counters_agree_with_a_word_by_word_count() {
        // Lengths around the counters' steps (8 and 16 vectors of 32
        // bytes) and their tails; on a CPU with AVX2 the dispatching
        // functions take the AVX2 path, the portable ones never do.
        for len in [
            0, 7, 8, 255, 256, 257, 511, 512, 513, 1000, 4096, 4099, 20_000,
        ] {
            let bytes = noise(len, len as u64 + 1);
            let by_word =
                words(&bytes).fold(BitSums::default(), |sums, w| sums + BitSums::of_word(w));
            assert_eq!(BitSums::of_four_state(&bytes), by_word, "{len} bytes");
            assert_eq!(
                BitSums::of_four_state_portable(&bytes),
                by_word,
                "{len} bytes"
            );
            assert_eq!(ones(&bytes), by_word.ones, "{len} bytes");
            let vectors = len / VECTOR_BYTES;
            let tail: u64 = bytes[vectors * VECTOR_BYTES..]
                .iter()
                .map(|b| u64::from(b.count_ones()))
                .sum();
            assert_eq!(count_vectors(&bytes, vectors) + tail, by_word.ones);
        }
    }
}
