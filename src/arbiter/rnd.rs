//! `rnd` (SPEC 4): MF or MB with probability 1/2 at every decision.

use super::{Arbiter, Choice, Inputs};

/// A fair draw between the experts.
pub struct Rnd;

impl Arbiter for Rnd {
    const COMBINES: bool = true;
    const STEADY_WEIGHT: bool = true;

    #[inline(always)]
    fn weight(_inputs: &mut Inputs<'_>) -> f64 {
        0.5
    }

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        let use_mb = inputs.uniform() < 0.5;
        inputs.choice(use_mb, 0.5, None)
    }
}
