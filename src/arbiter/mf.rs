//! `mf` (SPEC 4): the model-free expert alone; P(MB) reported 0.

use super::{Arbiter, Choice, Inputs};

/// The MF expert alone.
pub struct Mf;

impl Arbiter for Mf {
    const RUNS_MB: bool = false;

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        inputs.choice(false, 0.0, None)
    }
}
