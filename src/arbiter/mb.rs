//! `mb` (SPEC 4): the model-based expert alone; P(MB) reported 1.

use super::{Arbiter, Choice, Inputs};

/// The MB expert alone.
pub struct Mb;

impl Arbiter for Mb {
    const RUNS_MF: bool = false;

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        inputs.choice(true, 1.0, None)
    }
}
