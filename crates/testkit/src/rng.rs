//! Marsaglia's xorshift generators ("Xorshift RNGs", 2003): a few shifts
//! and xors per number, no dependencies, the same sequence on every
//! machine. Tests and benches use them where a figure (a count of caught
//! corruptions, a timed image) must come out the same on every run; the
//! sequences are fixed, so changing a step here changes those figures.
//!
//! Two widths, because the sites they replaced used both: [`XorShift`]
//! (64-bit state, shifts 13, 7, 17) and [`XorShift32`] (32-bit state,
//! shifts 13, 17, 5). Neither is for anything but tests: the low bits are
//! weak and `% n` is biased.

/// Marsaglia's xorshift64 with shifts (13, 7, 17): each call does
///
/// ```text
/// x ^= x << 13;
/// x ^= x >> 7;
/// x ^= x << 17;
/// ```
///
/// on the 64-bit state and returns the new state, so the first number is
/// the seed after one step, never the seed itself. The period is
/// 2^64 - 1 over the non-zero states; zero maps to zero forever, so a
/// zero seed is refused.
#[derive(Clone, Debug)]
pub struct XorShift(u64);

impl XorShift {
    /// A generator starting from `seed`, which must not be zero.
    pub const fn new(seed: u64) -> Self {
        assert!(seed != 0, "a zero xorshift seed gives only zeros");
        Self(seed)
    }

    /// The next number of the sequence (see [`XorShift`]).
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        self.0 = x;
        x
    }
}

/// Marsaglia's xorshift32 with shifts (13, 17, 5): each call does
///
/// ```text
/// x ^= x << 13;
/// x ^= x >> 17;
/// x ^= x << 5;
/// ```
///
/// on the 32-bit state and returns the new state, so the first number is
/// the seed after one step. The period is 2^32 - 1 over the non-zero
/// states; a zero seed is refused.
#[derive(Clone, Debug)]
pub struct XorShift32(u32);

impl XorShift32 {
    /// A generator starting from `seed`, which must not be zero.
    pub const fn new(seed: u32) -> Self {
        assert!(seed != 0, "a zero xorshift seed gives only zeros");
        Self(seed)
    }

    /// The next number of the sequence (see [`XorShift32`]).
    pub fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// The next number reduced to `0..n` by `% n` (slightly biased toward
    /// small values; fine for test data). `n` must not be zero.
    pub fn below(&mut self, n: u32) -> u32 {
        self.next_u32() % n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first numbers, worked out apart from this code (Python, the
    /// steps above), so a change to a shift, and with it every figure a
    /// test pinned, fails here first.
    #[test]
    fn sequences_are_the_documented_steps() {
        let mut r = XorShift::new(0x9E37_79B9_7F4A_7C15);
        let first: Vec<u64> = (0..3).map(|_| r.next_u64()).collect();
        assert_eq!(
            first,
            [
                0xdc1b_77ae_0bf3_4dad,
                0x64f0_eeb9_026e_6076,
                0x7b07_ce91_e590_6136
            ]
        );
        // Marsaglia's xorshift32 from 1 starts 270369, 67634689.
        let mut r = XorShift32::new(1);
        assert_eq!((r.next_u32(), r.next_u32()), (270369, 67634689));
        let mut r = XorShift32::new(1);
        assert_eq!(r.below(1000), 369);
    }

    #[test]
    #[should_panic(expected = "zero xorshift seed")]
    fn a_zero_seed_is_refused() {
        XorShift::new(0);
    }
}
