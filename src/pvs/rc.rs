//! The binary range coder of version 3 files (docs/FORMAT.md, "Range
//! coder"): an LZMA-style coder with 16-bit adaptive probabilities, plain
//! (equiprobable) bits, bit trees and a number coding (bit length, then the
//! bits below the leading one). Exact integer arithmetic only, so a reader in
//! any language decodes the same bits. The decoder refuses to read past the
//! end of its bytes (a stream the encoder wrote never does).

/// Probabilities are of a 0 bit, in units of 1/65536.
pub const PROB_BITS: u32 = 16;
/// The two estimates move 1/32 and 1/128 of the way to each bit seen, and
/// faster while the probability is young (see [`Prob`]).
const FAST_BITS: u32 = 5;
const SLOW_BITS: u32 = 7;
/// Every estimate stays in `PROB_MIN ..= PROB_MAX`.
const PROB_MIN: u16 = 31;
const PROB_MAX: u16 = 65505;
const TOP: u32 = 1 << 24;

/// An adaptive probability of a 0 bit: the mean of a fast and a slow
/// estimate, each moved by 1/2^s of its distance to the bit seen, where s
/// is the smaller of its rate (5 or 7) and the bit length of (bits seen so
/// far + 1), so a young probability learns quickly (docs/FORMAT.md, "Range
/// coder").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Prob {
    fast: u16,
    slow: u16,
    seen: u8,
}

/// A probability that has seen nothing: one half.
pub const PROB_INIT: Prob = Prob {
    fast: 1 << (PROB_BITS - 1),
    slow: 1 << (PROB_BITS - 1),
    seen: 0,
};

impl Prob {
    /// The chance of a 0 bit, in 1/65536 (31 to 65505).
    #[inline]
    pub fn value(self) -> u32 {
        (u32::from(self.fast) + u32::from(self.slow)) >> 1
    }
}

#[inline]
fn moved(p: u16, bit: u32, shift: u32) -> u16 {
    let p = u32::from(p);
    let q = if bit == 0 {
        p + (((1u32 << PROB_BITS) - p) >> shift)
    } else {
        p - (p >> shift)
    };
    (q as u16).clamp(PROB_MIN, PROB_MAX)
}

#[inline]
fn update(p: &mut Prob, bit: u32) {
    p.seen = p.seen.saturating_add(1);
    let young = 32 - (u32::from(p.seen) + 1).leading_zeros();
    p.fast = moved(p.fast, bit, young.min(FAST_BITS));
    p.slow = moved(p.slow, bit, young.min(SLOW_BITS));
}

/// Range encoder writing into a byte vector.
pub struct Encoder {
    low: u64,
    range: u32,
    cache: u8,
    cache_size: u64,
    out: Vec<u8>,
}

impl Default for Encoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Encoder {
    pub fn new() -> Self {
        Encoder {
            low: 0,
            range: u32::MAX,
            cache: 0,
            cache_size: 1,
            out: Vec::new(),
        }
    }

    fn shift_low(&mut self) {
        if self.low < 0xff00_0000 || self.low > 0xffff_ffff {
            let carry = (self.low >> 32) as u8;
            let mut temp = self.cache;
            loop {
                self.out.push(temp.wrapping_add(carry));
                temp = 0xff;
                self.cache_size -= 1;
                if self.cache_size == 0 {
                    break;
                }
            }
            self.cache = ((self.low >> 24) & 0xff) as u8;
        }
        self.cache_size += 1;
        self.low = (self.low & 0x00ff_ffff) << 8;
    }

    /// Code `bit` (0 or 1) with the adaptive probability `p`.
    #[inline]
    pub fn bit(&mut self, p: &mut Prob, bit: u32) {
        let bound = (self.range >> PROB_BITS) * p.value();
        if bit == 0 {
            self.range = bound;
        } else {
            self.low += u64::from(bound);
            self.range -= bound;
        }
        update(p, bit);
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    /// Code the low `count` bits of `value`, highest first, each with
    /// probability one half.
    pub fn plain(&mut self, value: u64, count: u32) {
        for k in (0..count).rev() {
            self.range >>= 1;
            if (value >> k) & 1 == 1 {
                self.low += u64::from(self.range);
            }
            while self.range < TOP {
                self.range <<= 8;
                self.shift_low();
            }
        }
    }

    /// Code the low `bits` bits of `value`, highest first, through the bit
    /// tree `probs` (`1 << bits` entries; entry 0 unused).
    pub fn tree(&mut self, probs: &mut [Prob], bits: u32, value: u32) {
        let mut m = 1usize;
        for k in (0..bits).rev() {
            let b = (value >> k) & 1;
            self.bit(&mut probs[m], b);
            m = 2 * m + b as usize;
        }
    }

    /// Code a number: its bit length (0 to 64) through the tree of `model`,
    /// then the bits below the leading one as plain bits.
    pub fn number(&mut self, model: &mut NumberModel, value: u64) {
        let len = 64 - value.leading_zeros();
        self.tree(&mut model.0, 7, len);
        if len > 1 {
            self.plain(value, len - 1);
        }
    }

    /// Flush: the stream is complete.
    pub fn finish(mut self) -> Vec<u8> {
        for _ in 0..5 {
            self.shift_low();
        }
        self.out
    }

    /// Bytes written so far (the stream will be up to 5 bytes longer).
    pub fn len(&self) -> usize {
        self.out.len()
    }
    pub fn is_empty(&self) -> bool {
        self.out.is_empty()
    }
}

/// The adaptive model of one kind of number: a bit tree over its bit length.
#[derive(Clone)]
pub struct NumberModel(pub [Prob; 128]);

impl Default for NumberModel {
    fn default() -> Self {
        NumberModel([PROB_INIT; 128])
    }
}

/// Range decoder over one stream's bytes.
pub struct Decoder<'a> {
    bytes: &'a [u8],
    pos: usize,
    range: u32,
    code: u32,
}

/// Reading past the end of the stream's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PastEnd;

impl<'a> Decoder<'a> {
    /// Start decoding `bytes`: the first byte must be 0, the next four are
    /// the initial code.
    pub fn new(bytes: &'a [u8]) -> Result<Self, String> {
        if bytes.len() < 5 {
            return Err(format!(
                "a range-coded stream takes at least 5 bytes, this one {}",
                bytes.len()
            ));
        }
        if bytes[0] != 0 {
            return Err("a range-coded stream must start with a zero byte".into());
        }
        let code = u32::from_be_bytes(bytes[1..5].try_into().unwrap());
        Ok(Decoder {
            bytes,
            pos: 5,
            range: u32::MAX,
            code,
        })
    }

    /// Bytes read so far.
    pub fn pos(&self) -> usize {
        self.pos
    }

    #[inline]
    fn normalize(&mut self) -> Result<(), PastEnd> {
        while self.range < TOP {
            let Some(&b) = self.bytes.get(self.pos) else {
                return Err(PastEnd);
            };
            self.pos += 1;
            self.range <<= 8;
            self.code = (self.code << 8) | u32::from(b);
        }
        Ok(())
    }

    /// Decode a bit with the adaptive probability `p`.
    #[inline]
    pub fn bit(&mut self, p: &mut Prob) -> Result<u32, PastEnd> {
        let bound = (self.range >> PROB_BITS) * p.value();
        let bit = if self.code < bound {
            self.range = bound;
            0
        } else {
            self.code -= bound;
            self.range -= bound;
            1
        };
        update(p, bit);
        self.normalize()?;
        Ok(bit)
    }

    /// Decode `count` plain bits, highest first.
    pub fn plain(&mut self, count: u32) -> Result<u64, PastEnd> {
        let mut v = 0u64;
        for _ in 0..count {
            self.range >>= 1;
            let b = if self.code >= self.range {
                self.code -= self.range;
                1
            } else {
                0
            };
            v = (v << 1) | b;
            self.normalize()?;
        }
        Ok(v)
    }

    /// Decode a `bits`-bit value through the bit tree `probs`.
    pub fn tree(&mut self, probs: &mut [Prob], bits: u32) -> Result<u32, PastEnd> {
        let mut m = 1usize;
        for _ in 0..bits {
            m = 2 * m + self.bit(&mut probs[m])? as usize;
        }
        Ok((m - (1 << bits)) as u32)
    }

    /// Decode a number coded by [`Encoder::number`]; `None` when its bit
    /// length is over 64.
    pub fn number(&mut self, model: &mut NumberModel) -> Result<Option<u64>, PastEnd> {
        let len = self.tree(&mut model.0, 7)?;
        Ok(match len {
            0 => Some(0),
            1..=64 => Some((1u64 << (len - 1)) | self.plain(len - 1)?),
            _ => None,
        })
    }
}

/// One side of the coder, so that a coding is written once for both: the
/// encoder codes `bit` and returns it, the decoder ignores it and returns
/// the bit it decodes.
pub trait BitCoder {
    fn code(&mut self, p: &mut Prob, bit: u32) -> Result<u32, PastEnd>;
    fn code_tree(&mut self, probs: &mut [Prob], bits: u32, value: u32) -> Result<u32, PastEnd> {
        let mut m = 1usize;
        for k in (0..bits).rev() {
            let b = self.code(&mut probs[m], (value >> k) & 1)?;
            m = 2 * m + b as usize;
        }
        Ok((m - (1 << bits)) as u32)
    }
    /// A number with its model (`None` when decoding a bit length over 64).
    fn number_of(&mut self, model: &mut NumberModel, value: u64) -> Result<Option<u64>, PastEnd>;
}

impl BitCoder for Encoder {
    #[inline]
    fn code(&mut self, p: &mut Prob, bit: u32) -> Result<u32, PastEnd> {
        self.bit(p, bit);
        Ok(bit)
    }
    fn number_of(&mut self, model: &mut NumberModel, value: u64) -> Result<Option<u64>, PastEnd> {
        self.number(model, value);
        Ok(Some(value))
    }
}

impl BitCoder for Decoder<'_> {
    #[inline]
    fn code(&mut self, p: &mut Prob, _: u32) -> Result<u32, PastEnd> {
        self.bit(p)
    }
    fn number_of(&mut self, model: &mut NumberModel, _: u64) -> Result<Option<u64>, PastEnd> {
        self.number(model)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_bytes() {
        // Nothing coded: the flush alone.
        assert_eq!(Encoder::new().finish(), [0, 0, 0, 0, 0]);
        // One 1 bit at probability one half: low = 2^31.
        let mut e = Encoder::new();
        let mut p = PROB_INIT;
        e.bit(&mut p, 1);
        // Seen one bit: both estimates move by 1/4 (bit length of 2).
        assert_eq!(p.value(), 24576);
        assert_eq!(e.finish(), [0, 0x7f, 0xff, 0x80, 0x00]);
    }

    #[test]
    fn probabilities_stay_inside() {
        let mut p = PROB_INIT;
        for _ in 0..10_000 {
            update(&mut p, 0);
        }
        // The slow estimate stops moving 127 short of 65536.
        assert!((65450..=65505).contains(&p.value()), "{}", p.value());
        assert_eq!(p.fast, 65505);
        for _ in 0..10_000 {
            update(&mut p, 1);
        }
        assert!((31..=90).contains(&p.value()), "{}", p.value());
        assert_eq!(p.fast, 31);
        // The rates settle at 1/32 and 1/128 once 127 bits were seen.
        let mut q = PROB_INIT;
        for _ in 0..300 {
            update(&mut q, 0);
        }
        let before = q;
        update(&mut q, 1);
        assert_eq!(q.fast, before.fast - (before.fast >> 5));
        assert_eq!(q.slow, before.slow - (before.slow >> 7));
    }

    proptest! {
        #[test]
        fn round_trip_reads_exactly_the_stream(
            items in proptest::collection::vec((0u8..4, any::<u64>(), 0u32..64), 0..300),
        ) {
            let mut e = Encoder::new();
            let mut probs = [PROB_INIT; 4];
            let mut tree = [PROB_INIT; 256];
            let mut num = NumberModel::default();
            for &(kind, v, c) in &items {
                match kind {
                    0 => e.bit(&mut probs[(v % 4) as usize], (v >> 7) as u32 & 1),
                    1 => e.plain(v, c),
                    2 => e.tree(&mut tree, 8, (v & 0xff) as u32),
                    _ => e.number(&mut num, v >> c),
                }
            }
            let bytes = e.finish();
            let mut d = Decoder::new(&bytes).unwrap();
            let mut probs = [PROB_INIT; 4];
            let mut tree = [PROB_INIT; 256];
            let mut num = NumberModel::default();
            for &(kind, v, c) in &items {
                match kind {
                    0 => prop_assert_eq!(d.bit(&mut probs[(v % 4) as usize]).unwrap(), (v >> 7) as u32 & 1),
                    1 => prop_assert_eq!(d.plain(c).unwrap(), v & ((1u64 << c) - 1)),
                    2 => prop_assert_eq!(d.tree(&mut tree, 8).unwrap(), (v & 0xff) as u32),
                    _ => prop_assert_eq!(d.number(&mut num).unwrap(), Some(v >> c)),
                }
            }
            prop_assert_eq!(d.pos(), bytes.len());
        }

        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
            if let Ok(mut d) = Decoder::new(&bytes) {
                let mut num = NumberModel::default();
                let mut p = PROB_INIT;
                for _ in 0..100 {
                    if d.number(&mut num).is_err() || d.bit(&mut p).is_err() {
                        break;
                    }
                    prop_assert!(d.pos() <= bytes.len());
                }
            }
        }
    }
}
