//! `fixed` (SPEC 12.2): a constant P(MB) = `w_mb` at every decision (Daw et al. 2011's hybrid
//! weight, here with `select`: one expert acts, drawn with that probability).

use super::{Arbiter, Choice, Inputs};
use crate::meta::pick;

/// A constant MB weight.
pub struct Fixed;

impl Arbiter for Fixed {
    const COMBINES: bool = true;
    const STEADY_WEIGHT: bool = true;
    const PARAMS: &'static [&'static str] = &["w_mb"];

    #[inline(always)]
    fn weight(inputs: &mut Inputs<'_>) -> f64 {
        inputs.params.w_mb
    }

    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        let (p_mb, selection) = (inputs.params.w_mb, inputs.params.selection);
        // Argmax: MB iff w_mb > 1/2, a fair draw at exactly 1/2 (SPEC 12.1).
        let use_mb = pick(selection, p_mb, p_mb.partial_cmp(&0.5), || inputs.uniform());
        inputs.choice(use_mb, p_mb, None)
    }
}
