//! `ec` (SPEC 4, Eqs. 6-7): the paper's entropy-and-cost meta-controller.

use super::{Arbiter, Choice, Inputs};

/// Entropy and cost.
pub struct Ec;

impl Arbiter for Ec {
    const COMBINES: bool = true;
    const WEIGHS_COST: bool = true;

    #[inline(always)]
    fn weight(inputs: &mut Inputs<'_>) -> f64 {
        crate::meta::values(inputs, true).0
    }

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        crate::meta::by_values(inputs, true)
    }
}
