//! `entropy` (SPEC 4): Eq. 6 without the cost term.

use super::{Arbiter, Choice, Inputs};

/// Entropy alone.
pub struct Entropy;

impl Arbiter for Entropy {
    const COMBINES: bool = true;

    #[inline(always)]
    fn weight(inputs: &mut Inputs<'_>) -> f64 {
        crate::meta::values(inputs, false).0
    }

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        crate::meta::by_values(inputs, false)
    }
}
