//! `entropy` (SPEC 4): Eq. 6 without the cost term.

use super::{Arbiter, Choice, Inputs};

/// Entropy alone.
pub struct Entropy;

impl Arbiter for Entropy {
    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        crate::meta::by_values(inputs, false)
    }
}
