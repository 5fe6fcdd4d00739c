//! Deterministic sample streams.
//!
//! Every sample of every pixel has its own stream, a pure function of
//! `(render seed, pixel, sample index)`, so an image does not depend on tile
//! order, thread count, batching, or how many samples a pixel got before:
//!
//! * dimensions 0–5 (pixel position, first-bounce direction, first light
//!   sample) are three independently Owen-scrambled 2-D Sobol sequences,
//!   indexed by the sample number: every prefix of 2^k samples is stratified
//!   in each 2-D pair (Burley 2020, "Practical Hash-based Owen Scrambling");
//! * the remaining dimensions come from `rand_xorshift`'s `XorShiftRng`
//!   (Marsaglia's xorshift128), whose four state words are two 32-bit hashes
//!   of the same triple and their values after the first multiply.
//!
//! What depends on the pixel only (the scramble seeds of the Sobol pairs and
//! the key of the generators) is computed once per pixel by
//! [`PixelSampler::new`]; a sample's stream ([`PixelSampler::stream`]) then
//! costs two 32-bit hashes. Only 32-bit integer arithmetic runs per sample:
//! on a Cortex-M4 a 64-bit multiply is several instructions.

use crate::math;
use rand_core::{Rng, SeedableRng};
use rand_xorshift::XorShiftRng;

/// splitmix64's finaliser: a bijective 64-bit mixer.
#[inline(always)]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The per-pixel scramble seed of a render seed and pixel coordinates.
#[inline(always)]
pub fn pixel_key(seed: u64, x: u32, y: u32) -> u64 {
    pixel_key_of(seed_key(seed), x, y)
}

/// The render seed as [`pixel_key_of`] takes it: computed once per render.
#[inline]
pub fn seed_key(seed: u64) -> u64 {
    mix64(seed)
}

/// [`pixel_key`] with the seed's [`seed_key`] computed beforehand: one
/// 64-bit mix per pixel. Two render seeds give the same key to two pixels
/// only if their seed keys differ in the coordinates' bits alone (for
/// random keys, a chance of 2^-32 for coordinates below 2^16).
#[inline(always)]
pub fn pixel_key_of(seed_key: u64, x: u32, y: u32) -> u64 {
    mix64(seed_key ^ (((y as u64) << 32) | x as u64))
}

/// A float in [0, 1) from the top 24 bits of `v`: exactly representable,
/// never 1.
#[inline(always)]
pub fn to_unit(v: u32) -> f32 {
    if math::SOFT_FLOAT {
        // the same value from the bits: no conversion and product calls
        math::soft::unit_u24(v >> 8)
    } else {
        (v >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Laine–Karras style hash permutation that only lets higher bits depend on
/// lower ones (Burley 2020): applied to bit-reversed values it is an Owen
/// scramble.
#[inline(always)]
fn lk_permute(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// The second Sobol dimension of point `i`, *before* bit reversal: the
/// result `b` gives the 32-bit fixed-point value `b.reverse_bits()`.
///
/// Sobol's second generator matrix is Pascal's triangle mod 2: output bit `p`
/// (counted from the top) is the parity of the index bits `k` with
/// `C(k, p)` odd, i.e. (Lucas) with `p ⊆ k` as bit sets. That is the superset
/// sum ("zeta transform") over GF(2), five shift-and-mask steps instead of a
/// loop over the index's 32 bits; the unit tests check it against the textbook
/// loop `v ^= v >> 1`.
#[inline(always)]
fn sobol2_unreversed(i: u32) -> u32 {
    let mut b = i;
    b ^= (b >> 1) & 0x5555_5555;
    b ^= (b >> 2) & 0x3333_3333;
    b ^= (b >> 4) & 0x0f0f_0f0f;
    b ^= (b >> 8) & 0x00ff_00ff;
    b ^= (b >> 16) & 0x0000_ffff;
    b
}

/// The three Owen-scramble seeds of the 2-D Sobol sequence identified by
/// `key`: the index shuffle's and each dimension's.
#[inline]
pub fn sobol_seeds(key: u64) -> [u32; 3] {
    let k = mix64(key);
    let k2 = mix64(k);
    [k as u32, k2 as u32, (k2 >> 32) as u32]
}

/// Point `index` of an Owen-scrambled 2-D Sobol sequence identified by `key`.
/// The index is shuffled by its own scramble (so that different pairs of
/// dimensions are decorrelated), then both dimensions are scrambled.
///
/// With `rev` = bit reversal and `lk` = `lk_permute`, the definition is
/// `shuffled = rev(lk(rev(index)))`, `x = rev(shuffled)`,
/// `y = rev(sobol2_unreversed(shuffled))`, each output `rev(lk(rev(·)))`.
/// The reversals that cancel are left out: four remain instead of nine, and
/// the bits are the same.
#[inline]
pub fn sobol_2d(index: u32, key: u64) -> [f32; 2] {
    sobol_2d_seeded(index, &sobol_seeds(key))
}

/// [`sobol_2d`] with the seeds of [`sobol_seeds`] computed beforehand.
#[inline(always)]
pub fn sobol_2d_seeded(index: u32, seeds: &[u32; 3]) -> [f32; 2] {
    let [s0, s1, s2] = *seeds;
    // rev(shuffled): the first dimension before its own scramble
    let x = lk_permute(index.reverse_bits(), s0);
    let shuffled = x.reverse_bits();
    [
        to_unit(lk_permute(shuffled, s1).reverse_bits()),
        to_unit(lk_permute(sobol2_unreversed(shuffled), s2).reverse_bits()),
    ]
}

/// [`sobol_2d_seeded`] without the index shuffle: point `index` of the
/// Owen-scrambled sequence in its own order (`seeds[0]` unused). One pair
/// of a pixel's stream may use its points unshuffled: the other pairs'
/// shuffles already decorrelate them from it.
#[inline(always)]
pub fn sobol_2d_unshuffled(index: u32, seeds: &[u32; 3]) -> [f32; 2] {
    let [_, s1, s2] = *seeds;
    [
        to_unit(lk_permute(index, s1).reverse_bits()),
        to_unit(lk_permute(sobol2_unreversed(index), s2).reverse_bits()),
    ]
}

/// [`hash32`] and its value after the first multiply and shift-xor.
#[inline(always)]
fn hash32_halves(mut x: u32) -> (u32, u32) {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    let mid = x;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    (x, mid)
}

/// A 32-bit integer hash with good avalanche (Chris Wellons' `lowbias32`):
/// two multiplies and three shift-xors.
#[inline(always)]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Number of stratified 2-D pairs whose scramble seeds are cached per pixel
/// (pixel position, first-bounce direction, first light sample); other
/// pairs are computed when asked for.
pub const CACHED_PAIRS: usize = 3;

/// Seed `j` of the pixel whose hashes are `h`: `lowbias32` of a Weyl
/// sequence (the 32-bit analogue of splitmix64) on the first, so that seeds
/// are independent-looking for every `j`, xor the second, so that two pixels
/// share their seeds only if their 64-bit keys' hashes collide in both
/// halves.
#[inline(always)]
fn pixel_seed(h: [u32; 2], j: u32) -> u32 {
    hash32(h[0].wrapping_add(j.wrapping_mul(0x9e37_79b9))) ^ h[1]
}

/// The three Owen-scramble seeds of stratified pair `pair` of the pixel
/// whose hashes are `h`.
#[inline(always)]
fn pair_seeds(h: [u32; 2], pair: u32) -> [u32; 3] {
    let j = pair.wrapping_mul(3);
    [
        pixel_seed(h, j),
        pixel_seed(h, j.wrapping_add(1)),
        pixel_seed(h, j.wrapping_add(2)),
    ]
}

/// What the sample streams of one pixel share: computed once per pixel, so
/// that a sample pays only for its own index.
#[derive(Debug, Clone, Copy)]
pub struct PixelSampler {
    hash: [u32; 2],
    pairs: [[u32; 3]; CACHED_PAIRS],
    rng: [u32; 2],
}

impl PixelSampler {
    /// The sampler of the pixel whose key is [`pixel_key`]`(seed, x, y)`.
    ///
    /// The key is splitmix64's output, so its two halves are used as they
    /// are (a key that is not well mixed, e.g. a counter, still gives valid
    /// streams, but pixels whose keys share a half share part of their
    /// generator's seed). Every scramble seed is a 32-bit hash of the halves
    /// (a Weyl sequence on the low half through `lowbias32`, xor the high
    /// half): eight 32-bit hashes, where 64-bit mixing cost a Cortex-M4
    /// several instructions per multiply. Pair 0 is used unshuffled, so its
    /// shuffle seed is not computed, and the generator's two words are the
    /// halves themselves (the second xor the first), which no scramble
    /// seed's hash takes as input. This runs once per pixel and budget
    /// round: in a uniform budget, once per sample.
    #[inline]
    pub fn new(pixel_key: u64) -> Self {
        let hash = [pixel_key as u32, (pixel_key >> 32) as u32];
        // pair 0's shuffle seed (`pair_seeds(hash, 0)[0]`) is not needed
        let pair0 = [0, pixel_seed(hash, 1), pixel_seed(hash, 2)];
        Self {
            hash,
            pairs: [pair0, pair_seeds(hash, 1), pair_seeds(hash, 2)],
            rng: [hash[1], hash[0] ^ hash[1]],
        }
    }

    /// The stream of sample `index` of this pixel.
    #[inline(always)]
    pub fn stream(&self, index: u32) -> SampleStream<'_> {
        let [a, b] = self.rng;
        // two different hashes of the index; each gives two of the
        // generator's four words (its result and its value after the first
        // multiply). xorshift128 is linear: output k is output k - 1
        // xor-shifted, xor word k - 1 xor-shifted, so all four words must
        // vary from sample to sample, and not linearly in each other, or
        // consecutive draws would be tied. One word is made odd: the state
        // is never zero (which xorshift cannot leave, and which `from_seed`
        // would replace by a fixed seed).
        let (x, z) = hash32_halves(a ^ index);
        let (y, w) = hash32_halves(b.wrapping_add(index.wrapping_mul(0x9e37_79b9)));
        let mut seed = [0u8; 16];
        for (dst, word) in seed.chunks_exact_mut(4).zip([x, y | 1, z, w]) {
            dst.copy_from_slice(&word.to_le_bytes());
        }
        SampleStream {
            pixel: self,
            index,
            rng: XorShiftRng::from_seed(seed),
        }
    }
}

/// All random numbers of one path sample: sample `index` of a pixel's
/// [`PixelSampler`] (which it borrows).
///
/// ```
/// use micropt::sampler::{PixelSampler, pixel_key};
/// let pixel = PixelSampler::new(pixel_key(7, 3, 4));
/// let mut s = pixel.stream(5);
/// let [u, v] = s.stratified_2d(0);
/// let w = s.next_f32();
/// assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v) && (0.0..1.0).contains(&w));
/// ```
#[derive(Debug, Clone)]
pub struct SampleStream<'p> {
    pixel: &'p PixelSampler,
    index: u32,
    rng: XorShiftRng,
}

impl SampleStream<'_> {
    /// Stratified 2-D point for dimension pair `pair` (0: pixel position,
    /// 1: first-bounce direction, 2: first light sample, 3: lens, 4: first
    /// light choice; higher pairs are further independent Owen-scrambled
    /// Sobol sequences). Pair 0 takes the
    /// points in sequence order ([`sobol_2d_unshuffled`]); every other pair
    /// shuffles them.
    #[inline(always)]
    pub fn stratified_2d(&self, pair: u32) -> [f32; 2] {
        match self.pixel.pairs.get(pair as usize) {
            Some(seeds) if pair == 0 => sobol_2d_unshuffled(self.index, seeds),
            Some(seeds) => sobol_2d_seeded(self.index, seeds),
            None => sobol_2d_seeded(self.index, &pair_seeds(self.pixel.hash, pair)),
        }
    }

    /// An independent uniformly distributed `u32` (xorshift128).
    #[inline(always)]
    pub fn next_u32(&mut self) -> u32 {
        self.rng.next_u32()
    }

    /// An independent uniform float in [0, 1).
    #[inline(always)]
    pub fn next_f32(&mut self) -> f32 {
        to_unit(self.next_u32())
    }

    /// Two independent uniform floats in [0, 1).
    #[inline(always)]
    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }
}

/// The independent part of a sample's stream as a `rand_core` generator,
/// for code that takes any [`rand_core::Rng`] (the same numbers as
/// [`SampleStream::next_u32`], i.e. as the stream's `XorShiftRng`).
///
/// ```
/// use micropt::sampler::{PixelSampler, pixel_key};
/// use rand_core::Rng;
/// let pixel = PixelSampler::new(pixel_key(7, 3, 4));
/// let (mut a, mut b) = (pixel.stream(5), pixel.stream(5));
/// assert_eq!(Rng::next_u32(&mut a), b.next_u32());
/// ```
impl rand_core::TryRng for SampleStream<'_> {
    type Error = rand_core::Infallible;

    #[inline]
    fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
        Ok(SampleStream::next_u32(self))
    }

    #[inline]
    fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
        rand_core::utils::next_u64_via_u32(self)
    }

    #[inline]
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Self::Error> {
        rand_core::utils::fill_bytes_via_next_word(dst, || self.try_next_u32())
    }
}

/// Shirley and Chiu's concentric map of `(u1, u2)` in [0,1)² onto the unit
/// disk: area-preserving (uniform points stay uniform), and low distortion,
/// so that stratified points stay well spread. Square rings map to circles:
/// the radius is the larger of |a|, |b| (the square's coordinates in
/// (−1, 1)), and the angle within each quarter is linear in the other
/// coordinate, so only `sin`/`cos` on [−π/4, π/4] are needed
/// ([`math::sincos_quarter`]; micromath's with `fast` in a build with the
/// `fast-math` feature).
///
/// Returns `(x, y, ρ²)` with `ρ² = x² + y²` (up to rounding).
/// The square is `a = 2u₁ − (1 − 2⁻²⁴)`: for the 24-bit uniforms of
/// this module's samplers (multiples of 2⁻²⁴) that is exact, symmetric, never 0
/// and never ±1, so `ρ ≤ 1 − 2⁻²⁴` and `1 − ρ²` is at least 2⁻²³.
#[inline(always)]
pub fn concentric_disk(u1: f32, u2: f32, fast: bool) -> (f32, f32, f32) {
    // 1 − 2⁻²⁴: with u in [0, 1) on the 2⁻²⁴ grid, a is an odd multiple of
    // 2⁻²⁴ in (−1, 1)
    const ONE_BELOW: f32 = 1.0 - 1.0 / 16_777_216.0;
    let a = math::twice(u1) - ONE_BELOW;
    let b = math::twice(u2) - ONE_BELOW;
    // the larger magnitude is the radius: one quotient of the chosen pair
    // (not both quotients and a choice between them, which is what the
    // compiler makes of two quotients in two branches)
    let swap = !math::gt(math::abs(a), math::abs(b));
    let (r, other) = if swap { (b, a) } else { (a, b) };
    let q = other / r;
    let phi = q * (0.25 * math::PI);
    let (s, c) = if cfg!(feature = "fast-math") && fast {
        math::fast_sincos_quarter(phi)
    } else {
        math::sincos_quarter(phi)
    };
    // angle phi from the x axis in the quarters |a| > |b|, π/2 − phi
    // from it in the others (r's sign turns the opposite quarters)
    if swap {
        (r * s, r * c, r * r)
    } else {
        (r * c, r * s, r * r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_trigonometry_only_with_its_feature() {
        // micromath's sin/cos are ~1e-3 off: a different point with the
        // feature, the exact one without it
        let (fast, exact) = (
            concentric_disk(0.3, 0.7, true),
            concentric_disk(0.3, 0.7, false),
        );
        if cfg!(feature = "fast-math") {
            assert_ne!(fast, exact);
        } else {
            assert_eq!(fast, exact);
        }
    }

    #[test]
    fn sobol_prefixes_are_stratified() {
        // every 2^k prefix puts exactly one point in each cell of every
        // elementary interval of area 1/2^k; check the square grids
        for key in [1u64, 99, 12345] {
            for k in [2u32, 4, 6] {
                let n = 1u32 << k;
                let side = 1u32 << (k / 2);
                let mut cells = [0u8; 64];
                for i in 0..n {
                    let [x, y] = if key == 99 {
                        sobol_2d_unshuffled(i, &sobol_seeds(key))
                    } else {
                        sobol_2d(i, key)
                    };
                    assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                    let c = (y * side as f32) as u32 * side + (x * side as f32) as u32;
                    cells[c as usize] += 1;
                }
                assert!(
                    cells[..n as usize].iter().all(|&c| c == 1),
                    "k = {k}: {cells:?}"
                );
            }
        }
    }

    #[test]
    fn streams_are_pure_functions_of_their_key() {
        let (p, q) = (
            PixelSampler::new(pixel_key(7, 3, 4)),
            PixelSampler::new(pixel_key(7, 3, 4)),
        );
        let mut a = p.stream(5);
        let mut b = q.stream(5);
        let mut c = p.stream(6);
        let (x, y, z) = (a.next_f32(), b.next_f32(), c.next_f32());
        assert_eq!(x, y);
        assert_ne!(x, z);
        assert_eq!(a.stratified_2d(1), b.stratified_2d(1));
        assert_ne!(a.stratified_2d(0), a.stratified_2d(1));
    }

    /// The definitions the fast code rewrites: Owen scramble as
    /// `rev(lk(rev(x)))` and Sobol's second dimension by its direction
    /// numbers `v_{k+1} = v_k ^ (v_k >> 1)`.
    fn owen_scramble(x: u32, seed: u32) -> u32 {
        lk_permute(x.reverse_bits(), seed).reverse_bits()
    }

    fn sobol2_reference(i: u32) -> (u32, u32) {
        let mut y = 0u32;
        let mut v = 1u32 << 31;
        let mut k = i;
        while k != 0 {
            if k & 1 != 0 {
                y ^= v;
            }
            k >>= 1;
            v ^= v >> 1;
        }
        (i.reverse_bits(), y)
    }

    fn sobol_2d_reference(index: u32, key: u64) -> [f32; 2] {
        let k = mix64(key);
        let shuffled = owen_scramble(index, k as u32);
        let (x, y) = sobol2_reference(shuffled);
        let k2 = mix64(k);
        [
            to_unit(owen_scramble(x, k2 as u32)),
            to_unit(owen_scramble(y, (k2 >> 32) as u32)),
        ]
    }

    #[test]
    fn fast_sobol_equals_the_definition_bit_for_bit() {
        // every single-bit index (each direction number) and a spread of others
        for b in 0..32 {
            let i = 1u32 << b;
            assert_eq!(sobol2_unreversed(i).reverse_bits(), sobol2_reference(i).1);
        }
        let mut z = 0x1234_5678_9abc_def0u64;
        for n in 0..20_000u32 {
            z = mix64(z);
            let i = if n < 4096 { n } else { z as u32 };
            assert_eq!(sobol2_unreversed(i).reverse_bits(), sobol2_reference(i).1);
            let [a, b] = sobol_2d(i, z >> 7);
            let [c, d] = sobol_2d_reference(i, z >> 7);
            assert_eq!((a.to_bits(), b.to_bits()), (c.to_bits(), d.to_bits()));
        }
    }

    #[test]
    fn every_pair_of_a_pixel_is_a_scrambled_sobol_sequence() {
        let px = PixelSampler::new(pixel_key(3, 10, 20));
        for i in [0u32, 1, 7, 1000] {
            let a = px.stream(i);
            // cached or not, every pair is the sequence of its seeds (pair 0
            // unshuffled)
            for p in 0..5 {
                let seeds = pair_seeds(px.hash, p);
                let want = if p == 0 {
                    sobol_2d_unshuffled(i, &seeds)
                } else {
                    sobol_2d_seeded(i, &seeds)
                };
                assert_eq!(a.stratified_2d(p), want);
            }
        }
        // and each pair's first 64 points are stratified on an 8x8 grid,
        // while different pairs are different sequences
        for p in 0..5 {
            let mut cells = [0u8; 64];
            for i in 0..64 {
                let [x, y] = px.stream(i).stratified_2d(p);
                cells[(y * 8.0) as usize * 8 + (x * 8.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "pair {p}: {cells:?}");
        }
        assert_ne!(px.stream(5).stratified_2d(1), px.stream(5).stratified_2d(2));
    }

    /// The independent numbers of a pixel's streams: uniform (mean 1/2,
    /// variance 1/12), and uncorrelated between consecutive draws of a
    /// stream and between the same draw of consecutive samples.
    #[test]
    fn independent_numbers_are_uniform_and_uncorrelated() {
        let n = 1 << 16;
        let (mut m, mut m2, mut c_draw, mut c_sample) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let px = PixelSampler::new(pixel_key(0, 5, 6));
        let mut prev_first = 0.5f32;
        for i in 0..n {
            let mut s = px.stream(i);
            let a = s.next_f32();
            let b = s.next_f32();
            m += a;
            m2 += a * a;
            c_draw += (a - 0.5) * (b - 0.5);
            c_sample += (a - 0.5) * (prev_first - 0.5);
            prev_first = a;
        }
        let nf = n as f32;
        let (mean, var) = (m / nf, m2 / nf - (m / nf) * (m / nf));
        // standard errors: 1/sqrt(12 n) = 1.1e-3 for the mean, 1/(12 sqrt(n))
        // = 3.3e-4 for the covariances
        assert!(crate::math::abs(mean - 0.5) < 5e-3, "{mean}");
        assert!(crate::math::abs(var - 1.0 / 12.0) < 2e-3, "{var}");
        assert!(crate::math::abs(c_draw / nf) < 1.5e-3, "{}", c_draw / nf);
        assert!(
            crate::math::abs(c_sample / nf) < 1.5e-3,
            "{}",
            c_sample / nf
        );
    }

    /// xorshift128 is linear over GF(2): output `k` is its predecessor
    /// xor-shifted, xor seed word `k - 1` (then output `k - 4`) xor-shifted.
    /// A seed word that did not vary from sample to sample (or varied
    /// linearly with another) would tie consecutive draws together; over a
    /// pixel's samples, each of the first eight draws must fill an 8x8 grid
    /// with its successor and with the draw four later as independent
    /// uniform pairs do (chi-square, 63 degrees of freedom: mean 63,
    /// standard deviation 11.2).
    #[test]
    fn consecutive_draws_fill_the_square() {
        let n = 1u32 << 16;
        for key in [pixel_key(0, 5, 6), pixel_key(9, 200, 100)] {
            let px = PixelSampler::new(key);
            let mut cells = [[[0u32; 64]; 8]; 2];
            for i in 0..n {
                let mut s = px.stream(i);
                let mut d = [0usize; 12];
                for v in d.iter_mut() {
                    *v = (s.next_f32() * 8.0) as usize;
                }
                for k in 0..8 {
                    cells[0][k][d[k] * 8 + d[k + 1]] += 1;
                    cells[1][k][d[k] * 8 + d[k + 4]] += 1;
                }
            }
            let e = n as f32 / 64.0;
            for (lag, grids) in [(1, &cells[0]), (4, &cells[1])] {
                for (k, g) in grids.iter().enumerate() {
                    let chi2: f32 = g.iter().map(|&c| (c as f32 - e) * (c as f32 - e) / e).sum();
                    assert!(chi2 < 120.0, "draws {k} and {}: chi2 {chi2}", k + lag);
                }
            }
        }
    }

    #[test]
    fn unit_floats_never_reach_one() {
        assert_eq!(to_unit(u32::MAX), 1.0 - 1.0 / 16_777_216.0);
        assert_eq!(to_unit(0), 0.0);
    }
}
