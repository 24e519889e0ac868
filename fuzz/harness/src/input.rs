//! Reading typed values off the fuzzer's bytes. Past the end every value
//! reads as zero, so any input is a complete (if short) description.

pub struct Input<'a> {
    data: &'a [u8],
}

impl<'a> Input<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    pub fn bytes(&mut self, n: usize) -> &'a [u8] {
        let n = n.min(self.data.len());
        let (head, tail) = self.data.split_at(n);
        self.data = tail;
        head
    }

    fn array<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        let head = self.bytes(N);
        out[..head.len()].copy_from_slice(head);
        out
    }

    pub fn u8(&mut self) -> u8 {
        self.array::<1>()[0]
    }
    pub fn bool(&mut self) -> bool {
        self.u8() & 1 == 1
    }
    pub fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.array())
    }
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.array())
    }
    pub fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.array())
    }
    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.array())
    }
    /// Any f32 bit pattern: NaNs, infinities and denormals included.
    pub fn f32(&mut self) -> f32 {
        f32::from_bits(self.u32())
    }
    /// Any f64 bit pattern.
    pub fn f64(&mut self) -> f64 {
        f64::from_bits(self.u64())
    }
    /// One time in two any u32, else a byte below `below` (1 to 256):
    /// the shape of the counts, levels and offsets the targets describe,
    /// mostly small and sometimes past every bound.
    pub fn u32_mostly_below(&mut self, below: u32) -> u32 {
        if self.bool() {
            self.u32()
        } else {
            u32::from(self.u8()) % below
        }
    }
    /// [`Self::u32_mostly_below`] for u64 fields (strides).
    pub fn u64_mostly_below(&mut self, below: u64) -> u64 {
        if self.bool() {
            self.u64()
        } else {
            u64::from(self.u8()) % below
        }
    }
    /// A small number below `n` (n > 0).
    pub fn below(&mut self, n: u32) -> u32 {
        u32::from(self.u8()) % n
    }
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    pub fn rest(&mut self) -> &'a [u8] {
        std::mem::take(&mut self.data)
    }
}
