//! `combine = mix` (SPEC 12.1) for any rule that gives a weight: both experts infer at every
//! decision, and the action is drawn from the softmax of P(MB) Q_MB + (1 - P(MB)) Q_MF.

use std::marker::PhantomData;

use super::{Arbiter, Choice, Draw, Inputs, Model, Own, Transition};
use crate::params::Params;

/// Rule `A` with `combine = mix`: its weight mixes the experts' values instead of drawing one.
pub struct Mixed<A>(PhantomData<A>);

impl<A: Arbiter> Arbiter for Mixed<A> {
    const RUNS_MF: bool = A::RUNS_MF;
    const RUNS_MB: bool = A::RUNS_MB;
    const FIRST_DECISION_BOTH: bool = A::FIRST_DECISION_BOTH;
    const OBSERVES: bool = A::OBSERVES;
    const DRAW: Draw = Draw::Mix;
    const LEARNS_MF: bool = A::LEARNS_MF;
    const WEIGHS_COST: bool = A::WEIGHS_COST;
    const STEADY_WEIGHT: bool = A::STEADY_WEIGHT;

    fn run_scalars(params: &Params) -> usize {
        A::run_scalars(params)
    }

    fn pair_tables(params: &Params) -> usize {
        A::pair_tables(params)
    }

    fn start(params: &Params, own: &mut Own<'_>) {
        A::start(params, own);
    }

    /// No expert is drawn, so no draw is made; `mb_decisions` counts weights above 1/2. The
    /// entropy reported is the mixed distribution's, which the step writes.
    #[inline(always)]
    fn choose(inputs: &mut Inputs<'_>) -> Choice {
        let p_mb = A::weight(inputs);
        Choice {
            use_mb: p_mb > 0.5,
            p_mb,
            chosen_entropy: f64::NAN,
        }
    }

    #[inline(always)]
    fn observe(
        params: &Params,
        own: &mut Own<'_>,
        t: &Transition,
        q_mf: &[f64],
        model: &Model<'_>,
    ) {
        A::observe(params, own, t, q_mf, model);
    }

    #[inline(always)]
    fn learn_mf(params: &Params, own: &mut Own<'_>, t: &Transition, q_mf: &mut [f64]) {
        A::learn_mf(params, own, t, q_mf);
    }
}
