//! Arbitration rules (SPEC 4 and 12): at each decision, which expert acts and the MB weight
//! reported. Each rule is one type implementing [`Arbiter`], in its own file, registered in one
//! line of the `arbiters!` list below; the list generates the [`Controller`] parameter (its
//! variants, names, and the questions the rest of the program asks of it) and [`dispatch`],
//! which hands a generic step the rule's type, so that every rule gets its own compiled step:
//! no per-step branch on the rule, no dynamic dispatch, no allocation.
//!
//! State a rule keeps beside the experts' (SPEC 12.3's P_MB, 12.4's variances) is declared by
//! the rule ([`Arbiter::run_scalars`], [`Arbiter::pair_tables`]) and held by the batch as two
//! more per-run arrays, sized for the most demanding rule of the batch; a rule that declares
//! nothing costs no memory.

use std::ops::Range;

use rand_xoshiro::Xoshiro256PlusPlus;

use crate::expert::mb::Model;
use crate::expert::{entropy_bits, normalise_bits};
use crate::params::{Kind, ParamValue, Params, Value};
use crate::rng::uniform;

/// What a rule decided at one decision (SPEC 12.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Choice {
    /// The MB expert acts: it infers and the action is drawn from its softmax.
    pub use_mb: bool,
    /// The MB weight reported for this decision (P(MB), SPEC 4: 0.5 for `rnd`, 0 for `mf`, 1
    /// for `mb`).
    pub p_mb: f64,
    /// Normalised entropy of the acting expert's averaged distribution, as read before this
    /// decision.
    pub chosen_entropy: f64,
}

/// The rule's own state in one run: what [`Arbiter::run_scalars`] and [`Arbiter::pair_tables`]
/// declared (each empty when the rule declares none).
pub struct Own<'a> {
    /// The run's scalars.
    pub run: &'a mut [f64],
    /// The run's per-(state, action) tables, one after the other, each `[state, action]`.
    pub pairs: &'a mut [f64],
}

/// What a rule may read at a decision in state `state`: the parameters, what earlier visits of
/// the state stored (the experts' averaged distributions, through their kept entropies, and
/// their cost averages), the run's random stream and the rule's own state.
pub struct Inputs<'a> {
    /// The run's parameters.
    pub params: &'a Params,
    /// Actions of the task.
    pub n_actions: usize,
    /// The state.
    pub state: usize,
    /// The rule's own state.
    pub own: Own<'a>,
    pub(crate) row: Range<usize>,
    pub(crate) costs_mf: &'a [f64],
    pub(crate) costs_mb: &'a [f64],
    pub(crate) q_mf: &'a [f64],
    pub(crate) pavg_mf: &'a [f64],
    pub(crate) pavg_mb: &'a [f64],
    pub(crate) entropy_mf: &'a mut [f64],
    pub(crate) entropy_mb: &'a mut [f64],
    pub(crate) rng: &'a mut Xoshiro256PlusPlus,
}

impl Inputs<'_> {
    /// MF's per-state inference cost average in the state. Kept up to date only for a rule
    /// that says it weighs costs ([`Arbiter::WEIGHS_COST`]).
    #[inline(always)]
    pub fn cost_mf(&self) -> f64 {
        self.costs_mf[self.state]
    }

    /// MB's per-state inference cost average in the state.
    #[inline(always)]
    pub fn cost_mb(&self) -> f64 {
        self.costs_mb[self.state]
    }

    /// The MF expert's Q row in the state. Only for a rule that runs MF.
    #[inline(always)]
    pub fn q_mf(&self) -> &[f64] {
        &self.q_mf[self.row.clone()]
    }

    /// Entropy in bits of the MF averaged distribution in the state (kept between decisions
    /// until the distribution changes). Only for a rule that runs MF: the batch may hold no MF
    /// tables otherwise.
    #[inline(always)]
    pub fn bits_mf(&mut self) -> f64 {
        kept_bits(
            &mut self.entropy_mf[self.state],
            &self.pavg_mf[self.row.clone()],
        )
    }

    /// [`bits_mf`](Inputs::bits_mf) for the MB expert.
    #[inline(always)]
    pub fn bits_mb(&mut self) -> f64 {
        kept_bits(
            &mut self.entropy_mb[self.state],
            &self.pavg_mb[self.row.clone()],
        )
    }

    /// A draw in [0, 1) from the run's stream (SPEC 3.4's draw order: the MC's draw comes
    /// after a takeover's and before the action's).
    #[inline(always)]
    pub fn uniform(&mut self) -> f64 {
        uniform(self.rng)
    }

    /// The [`Choice`] of drawing MB or not: the reported `p_mb` and the acting expert's
    /// normalised entropy, read from `bits` if known, else from the kept one.
    #[inline(always)]
    pub fn choice(&mut self, use_mb: bool, p_mb: f64, bits: Option<f64>) -> Choice {
        let bits = match bits {
            Some(b) => b,
            None if use_mb => self.bits_mb(),
            None => self.bits_mf(),
        };
        Choice {
            use_mb,
            p_mb,
            chosen_entropy: normalise_bits(bits, self.n_actions),
        }
    }
}

/// The entropy in bits of `row`, an averaged distribution, from `kept` unless that is NaN (not
/// known since the row last changed), in which case it is computed and kept.
#[inline(always)]
fn kept_bits(kept: &mut f64, row: &[f64]) -> f64 {
    if kept.is_nan() {
        *kept = entropy_bits(row);
    }
    *kept
}

/// An executed transition, as the experts are about to learn it (SPEC 3.4 item 8).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// The state left.
    pub s: usize,
    /// The action.
    pub a: usize,
    /// The reward the experts learn (with a shaping congratulation's zeta, SPEC 11.3).
    pub r: f64,
    /// The state reached.
    pub next: usize,
    /// The arrival ends the episode.
    pub terminal: bool,
    /// Actions of the task (the length of a Q row).
    pub n_actions: usize,
    /// The largest |reward| of the task (SPEC 12.3's R_max).
    pub r_max: f64,
}

/// From which values the action of a decision is drawn (SPEC 12.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Draw {
    /// The acting expert's softmax (`select`): [`Choice::use_mb`] says which.
    Expert,
    /// `combine = mix`: both experts infer; the softmax of P(MB) Q_MB + (1 - P(MB)) Q_MF.
    Mix,
    /// A vector the rule builds per action ([`Arbiter::action_values`]): MF always infers, MB
    /// iff [`Choice::use_mb`] (SPEC 12.4). [`Choice::p_mb`] is the share of actions MB values,
    /// so 1 means every one (the step then draws from MB's softmax as folded, and with no
    /// action by MB from MF's).
    PerAction,
}

/// An arbitration rule (SPEC 12.1). Only [`choose`](Arbiter::choose) is required; every other
/// hook has a default that does nothing and compiles to nothing.
pub trait Arbiter {
    /// Whether the MF expert runs (infers, computes its softmax, learns).
    const RUNS_MF: bool = true;
    /// Whether the MB expert runs.
    const RUNS_MB: bool = true;
    /// Both experts infer at the robot's first decision in a state (SPEC 3.4 item 4): the rule
    /// of every two-expert controller.
    const FIRST_DECISION_BOTH: bool = Self::RUNS_MF && Self::RUNS_MB;
    /// Whether [`observe`](Arbiter::observe) does anything (the step skips it otherwise).
    const OBSERVES: bool = false;
    /// From which values the action is drawn.
    const DRAW: Draw = Draw::Expert;
    /// Whether `combine = mix` applies: the rule gives a weight ([`weight`](Arbiter::weight)).
    const COMBINES: bool = false;
    /// The parameters (registry names) only this rule reads: a run of rules that read none of
    /// those given warns that they change nothing.
    const PARAMS: &'static [&'static str] = &[];
    /// Whether the weight is the same at every decision of a run (a parameter or a constant):
    /// then a mixed distribution's entropy, kept per state (the only `log2`s of a `combine =
    /// mix` step), holds while the experts' rows are unchanged, without keeping the weight too.
    const STEADY_WEIGHT: bool = false;
    /// Whether [`learn_mf`](Arbiter::learn_mf) replaces the MF expert's Q-learning.
    const LEARNS_MF: bool = false;
    /// Whether the rule reads the per-state inference cost averages ([`Inputs::cost_mf`],
    /// [`Inputs::cost_mb`]): only then does the step keep them up to date.
    const WEIGHS_COST: bool = false;
    /// Whether the experts' averaged distributions (SPEC 3.3) are kept: the rule reads their
    /// entropies, or reports the acting expert's ([`Inputs::choice`]). A rule that draws from
    /// values of its own and reports the drawn distribution's entropy (`vpi`) holds no such
    /// tables, and its experts compute a softmax only to draw from it.
    const AVERAGES: bool = !matches!(Self::DRAW, Draw::PerAction);

    /// Scalars the rule keeps per run (SPEC 12.3's P_MB), in [`Own::run`].
    fn run_scalars(_params: &Params) -> usize {
        0
    }

    /// `[state, action]` tables of f64 the rule keeps per run (SPEC 12.4's variances), in
    /// [`Own::pairs`].
    fn pair_tables(_params: &Params) -> usize {
        0
    }

    /// Writes the rule's initial state (all zero before).
    fn start(_params: &Params, _own: &mut Own<'_>) {}

    /// Step 3 of SPEC 3.4: which expert acts, and the MB weight reported.
    fn choose(inputs: &mut Inputs<'_>) -> Choice;

    /// P(MB) at a decision, without drawing an expert (`combine = mix`). Called only when
    /// [`COMBINES`](Arbiter::COMBINES).
    #[inline(always)]
    fn weight(inputs: &mut Inputs<'_>) -> f64 {
        Self::choose(inputs).p_mb
    }

    /// Sees every executed transition, of babbling too, before the experts learn from it
    /// (SPEC 12.3), with the MF table and the MB model as they are before learning.
    #[inline(always)]
    fn observe(
        _params: &Params,
        _own: &mut Own<'_>,
        _t: &Transition,
        _q_mf: &[f64],
        _model: &Model<'_>,
    ) {
    }

    /// The MF expert's learning from `t` in place of Q-learning (SPEC 12.4's Kalman MF), when
    /// [`LEARNS_MF`](Arbiter::LEARNS_MF).
    #[inline(always)]
    fn learn_mf(_params: &Params, _own: &mut Own<'_>, _t: &Transition, _q_mf: &mut [f64]) {}

    /// With [`Draw::PerAction`]: writes into `out` the value of each action in `state`, from
    /// the experts' rows there (`q_mb` is current only when the decision made MB infer).
    #[inline(always)]
    fn action_values(
        _own: &Own<'_>,
        _state: usize,
        _q_mf: &[f64],
        _q_mb: &[f64],
        _out: &mut [f64],
    ) {
    }
}

/// Code generic over the rule, called by [`dispatch`] with the run's.
pub trait Visit {
    /// What the code returns.
    type Output;
    /// Runs the code for rule `A`.
    fn visit<A: Arbiter>(self) -> Self::Output;
}

impl Controller {
    /// The rules that read parameter `name` as their own ([`Arbiter::PARAMS`]), in report order.
    pub fn readers(name: &str) -> Vec<Controller> {
        Controller::ALL
            .into_iter()
            .filter(|c| c.own_params().contains(&name))
            .collect()
    }

    /// The names of `controllers`, joined with commas, for messages.
    pub fn names(controllers: &[Controller]) -> String {
        let names: Vec<&str> = controllers.iter().map(|c| c.name()).collect();
        names.join(", ")
    }
}

/// The registry: one line per rule, `Variant => "name", module::Type, "help";` (the help is
/// the value's description in `--help`). The order is the order results are reported in.
macro_rules! arbiters {
    ($($variant:ident => $name:literal, $module:ident::$ty:ident, $doc:literal;)*) => {
        $(mod $module;)*

        /// Which arbitration rule runs (SPEC 4 and 12): the registered [`Arbiter`]s.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        #[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
        pub enum Controller {
            $(#[doc = $doc] $variant,)*
        }

        impl Controller {
            /// All controllers, in the order results are reported.
            pub const ALL: [Controller; { [$($name),*].len() }] = [$(Controller::$variant),*];

            /// The name used on the command line and in outputs.
            pub fn name(self) -> &'static str {
                match self { $(Controller::$variant => $name),* }
            }

            /// Whether the controller runs both experts (and so both infer at a first decision).
            pub fn is_dual(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::FIRST_DECISION_BOTH),* }
            }

            /// Whether `combine = mix` applies to the controller (it gives a weight).
            pub fn combines(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::COMBINES),* }
            }

            /// The parameters only this rule reads ([`Arbiter::PARAMS`]).
            pub fn own_params(self) -> &'static [&'static str] {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::PARAMS),* }
            }

            /// Whether the rule's weight is the same at every decision ([`Arbiter::STEADY_WEIGHT`]).
            pub fn steady_weight(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::STEADY_WEIGHT),* }
            }

            /// Whether the rule reads the per-state cost averages ([`Arbiter::WEIGHS_COST`]).
            pub fn weighs_cost(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::WEIGHS_COST),* }
            }

            /// Whether the MF expert runs (infers, computes its softmax, learns).
            pub fn runs_mf(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::RUNS_MF),* }
            }

            /// Whether the MB expert runs.
            pub fn runs_mb(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::RUNS_MB),* }
            }

            /// Whether the experts' averaged distributions are kept ([`Arbiter::AVERAGES`]).
            pub fn averages(self) -> bool {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::AVERAGES),* }
            }

            /// Scalars the rule keeps per run with `params`.
            pub fn run_scalars(self, params: &Params) -> usize {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::run_scalars(params)),* }
            }

            /// `[state, action]` tables the rule keeps per run with `params`.
            pub fn pair_tables(self, params: &Params) -> usize {
                match self { $(Controller::$variant => <$module::$ty as Arbiter>::pair_tables(params)),* }
            }
        }

        /// Runs `code` for the rule `controller` stands for.
        #[inline(always)]
        pub fn dispatch<V: Visit>(controller: Controller, code: V) -> V::Output {
            match controller { $(Controller::$variant => code.visit::<$module::$ty>()),* }
        }

        impl ParamValue for Controller {
            const KIND: Kind = Kind::Choice(&[$($name),*]);
            fn to_value(self) -> Value {
                Value::Choice(self.name())
            }
            fn from_value(value: &Value) -> Option<Self> {
                match value {
                    $(Value::Choice($name) => Some(Controller::$variant),)*
                    _ => None,
                }
            }
            #[cfg(feature = "cli")]
            fn possible_values() -> Vec<clap::builder::PossibleValue> {
                use clap::ValueEnum;
                Self::value_variants().iter().filter_map(Self::to_possible_value).collect()
            }
        }
    };
}

arbiters! {
    Mf => "mf", mf::Mf, "Model-free expert alone.";
    Mb => "mb", mb::Mb, "Model-based expert alone.";
    Rnd => "rnd", rnd::Rnd, "MF or MB with probability 1/2 each.";
    Ec => "ec", ec::Ec, "Entropy and cost (Eqs. 6–7): the paper's coordination.";
    Entropy => "entropy", entropy::Entropy, "Eq. 6 without the cost term.";
    Fixed => "fixed", fixed::Fixed, "MB with the constant probability w_mb (SPEC 12.2).";
    Reliability => "reliability", reliability::Reliability, "Lee et al. 2014's reliability arbitration (SPEC 12.3).";
    Vpi => "vpi", vpi::Vpi, "Keramati et al. 2011's value of information, per action (SPEC 12.4).";
}

mod mix;
pub use mix::Mixed;

/// Start of every rule's state in one run: declared sizes zeroed, then the rule's own start.
pub fn start(controller: Controller, params: &Params, own: &mut Own<'_>) {
    struct Start<'p, 'o, 'a>(&'p Params, &'o mut Own<'a>);
    impl Visit for Start<'_, '_, '_> {
        type Output = ();
        fn visit<A: Arbiter>(self) {
            self.1.run.fill(0.0);
            self.1.pairs.fill(0.0);
            A::start(self.0, self.1);
        }
    }
    dispatch(controller, Start(params, own));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rule's own parameters are parameters of the registry (a misspelt name would never
    /// warn), and none is claimed by two rules.
    #[test]
    fn own_parameters_are_registry_parameters_of_one_rule_each() {
        let mut seen = Vec::new();
        for c in Controller::ALL {
            for &name in c.own_params() {
                assert!(crate::params::param(name).is_some(), "{}: {name}", c.name());
                assert!(!seen.contains(&name), "{name} claimed twice");
                seen.push(name);
            }
        }
        assert_eq!(Controller::Fixed.own_params(), ["w_mb"]);
        assert_eq!(seen.len(), 14);
    }
}
