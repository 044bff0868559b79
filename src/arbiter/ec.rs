//! `ec` (SPEC 4, Eqs. 6-7): the paper's entropy-and-cost meta-controller.

use super::{Arbiter, Choice, Inputs};

/// Entropy and cost.
pub struct Ec;

impl Arbiter for Ec {
    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        crate::meta::by_values(inputs, true)
    }
}
