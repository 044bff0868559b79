//! One random stream per run, seeded from (master seed, run index) only, and the uniform draw
//! every random choice of a step is made from. A leaf module: the engine and the human kernels
//! draw through it.

use rand_core::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The random stream of run `run_index` under master seed `seed`.
///
/// NOTE: the two numbers are mixed by a SplitMix64 finaliser (so neighbouring runs get unrelated
/// seeds), then expanded by `Xoshiro256PlusPlus::seed_from_u64`. Part of the reproducibility
/// contract: changing it changes every result.
pub fn run_rng(seed: u64, run_index: u64) -> Xoshiro256PlusPlus {
    let mut z = seed
        ^ run_index
            .wrapping_add(1)
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    Xoshiro256PlusPlus::seed_from_u64(z)
}

/// A uniform number in [0, 1) from the top 53 bits of one draw.
#[inline(always)]
pub fn uniform(rng: &mut Xoshiro256PlusPlus) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}
