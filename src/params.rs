//! Sweepable scalar parameters of one run (SPEC 3–7). Shapes live in [`crate::env::Spec`], mutable
//! state in [`crate::batch::Batch`]; this small `Copy` record is all that may differ between runs
//! of one batch.

pub mod registry;

use thiserror::Error;

pub use crate::arbiter::Controller;
pub use registry::{Kind, Param, ParamValue, Value, param};

/// A parameter value outside what the model accepts.
#[derive(Debug, Error, PartialEq)]
pub enum ConfigError {
    /// A scalar out of range.
    #[error("invalid {name} = {value}: expected {accepted}")]
    InvalidParam {
        /// The parameter's name: the field of [`crate::params::Params`] (or of its `human`),
        /// which is also its output column; [`crate::params::cli_flag`] gives the flag.
        name: &'static str,
        /// The bad value, as [`crate::params::show`] writes it.
        value: String,
        /// What would be accepted, with the default.
        accepted: String,
    },
    /// Values the simulation would compute could exceed the range of a float (SPEC 3.3: no
    /// overflow), so the combination is refused before anything runs.
    #[error(
        "{what} could reach {reached} with {because}, beyond the supported magnitude {limit:e} \
         (sums of such values would overflow to infinity); {fix}",
        limit = crate::params::VALUE_LIMIT
    )]
    ValueOverflow {
        /// The quantity at risk, e.g. "action values".
        what: &'static str,
        /// Its bound, to three significant digits.
        reached: String,
        /// The inputs that make it large, with their values.
        because: String,
        /// How to bring it back in range.
        fix: &'static str,
    },
    /// Human interactions on a task that does not define them (SPEC 5).
    #[error(
        "interaction '{interaction}' is not defined for task '{task}': {accepted}; use \
         --interaction none (or budget 0)"
    )]
    InteractionUnsupported {
        /// The task.
        task: String,
        /// The interaction type asked for.
        interaction: String,
        /// What the task accepts (from the task registry).
        accepted: String,
    },
    /// Two parameters that cannot be used together.
    #[error("{name} = {value} cannot be used with {with} = {with_value}: {why}")]
    Incompatible {
        /// The parameter refused (its output column and sweep key).
        name: &'static str,
        /// Its value.
        value: String,
        /// The parameter it conflicts with.
        with: &'static str,
        /// That one's value.
        with_value: String,
        /// Why, and what to do instead.
        why: &'static str,
    },
    /// A schedule of changes that does not fit the task or the run (SPEC 10): the schedule's
    /// own message, as text, so that parameters do not depend on the schedule that uses them.
    #[error("{0}")]
    Schedule(String),
    /// More distinct schedules in one batch than the engine indexes.
    #[error("too many distinct schedules in one batch (at most 65534): split the runs")]
    TooManySchedules,
}

/// `name()` of each parameter enum, the value's name on the command line, in sweep files and in
/// outputs (what clap's `ValueEnum` derive also accepts), and its [`ParamValue`] impl.
macro_rules! names {
    ($($ty:ident $(($kind:expr))? { $($variant:ident => $name:literal),* $(,)? })*) => { $(
        impl $ty {
            /// Every value, in declaration order.
            pub const VALUES: &[$ty] = &[$($ty::$variant),*];

            /// The name used on the command line and in outputs.
            pub fn name(self) -> &'static str {
                match self { $($ty::$variant => $name),* }
            }
        }

        impl ParamValue for $ty {
            const KIND: Kind = registry::first!($($kind)?, Kind::Choice(&[$($name),*]));
            fn to_value(self) -> Value {
                Value::Choice(self.name())
            }
            fn from_value(value: &Value) -> Option<Self> {
                match value {
                    $(Value::Choice($name) => Some($ty::$variant),)*
                    _ => None,
                }
            }
            #[cfg(feature = "cli")]
            fn possible_values() -> Vec<clap::builder::PossibleValue> {
                use clap::ValueEnum;
                Self::value_variants().iter().filter_map(Self::to_possible_value).collect()
            }
        }
    )* };
}

names! {
    Selection { Softmax => "softmax", Argmax => "argmax" }
    CostModel { Ops => "ops", Wallclock => "wallclock" }
    Interaction {
        None => "none",
        Congratulation => "congratulation",
        Takeover => "takeover",
        Punishment => "punishment",
        Nuisance => "nuisance",
        Person => "person",
    }
    RewardSource { Environment => "environment", Human => "human" }
    CongratulationEffect { Bias => "bias", Reward => "reward" }
    Combine { Select => "select", Mix => "mix" }
    Profile (Kind::Profile) {
        None => "none",
        PaperCongratulation => "paper-congratulation",
        PaperTakeover => "paper-takeover",
        Generous => "generous",
        Stingy => "stingy",
        StopsEarly => "stops-early",
        RewardsThenLeaves => "rewards-then-leaves",
        Nuisance => "nuisance",
        Custom => "custom",
    }
}

/// How the meta-controller turns expert values into a choice (SPEC 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Selection {
    /// Softmax over the two values with `tau`, then a draw (the paper).
    Softmax,
    /// The better value, ties broken uniformly (the authors' code).
    Argmax,
}

/// How an arbiter's MB weight combines the experts (SPEC 12.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Combine {
    /// One expert is drawn with P(MB) and acts alone (the paper's cost-saving frame).
    Select,
    /// Both experts infer; the action is drawn from the softmax of P(MB) Q_MB + (1 - P(MB)) Q_MF.
    Mix,
}

/// How inference cost is measured (SPEC 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum CostModel {
    /// Q values read per inference: deterministic.
    Ops,
    /// Measured seconds per inference: not reproducible by nature.
    Wallclock,
}

/// Kind of help the simulated human gives (SPEC 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Interaction {
    /// No human.
    None,
    /// Bonus `zeta` in the softmax of a relevant action just executed (Eq. 8).
    Congratulation,
    /// The human puts the held cube where it belongs instead of the robot.
    Takeover,
    /// Penalty `zeta` in the softmax of an error just executed (the paper's future work).
    Punishment,
    /// The human undoes a relevant action: the cube just put away goes back on the table
    /// (SPEC 11.2, the paper's future work).
    Nuisance,
    /// A real person at `mbmf teach` (SPEC 15): congratulates, punishes or takes over as they
    /// choose. Not a simulated human: `run` and `sweep` refuse it.
    #[cfg_attr(feature = "cli", value(skip))]
    Person,
}

/// Who brings the goal's reward (SPEC 11.1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum RewardSource {
    /// The environment, at every arrival in the goal (SPEC 2).
    #[default]
    Environment,
    /// The human only: an attentive human with budget left gives the goal's reward at an
    /// arrival in the goal, spending one unit of budget; otherwise the arrival gives 0.
    Human,
}

/// How a congratulation acts (SPEC 11.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum CongratulationEffect {
    /// On the choice: zeta * G(s, a) in the softmax (Eq. 8, the paper).
    Bias,
    /// On the learning: the congratulated transition is learned with reward r + zeta by both
    /// experts (reward shaping); no bias in the softmax.
    Reward,
}

/// Named presets of the human's behaviour (SPEC 5), sweepable as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Profile {
    /// No interaction.
    None,
    /// Congratulation with the paper's minimal budget for each controller (SPEC 9 item 6).
    PaperCongratulation,
    /// Takeover with the paper's minimal budget for each controller (SPEC 9 item 6).
    PaperTakeover,
    /// Congratulates every relevant action (never forgets) with a budget of 1,000.
    Generous,
    /// Congratulation, but inattentive 70% of the time (budget 300).
    Stingy,
    /// Congratulation with a budget of 10, then silence.
    StopsEarly,
    /// Only the human brings reward (SPEC 11.1), 300 times (never forgetting), then leaves:
    /// no interaction type, reward source `human`, budget 300, forget 0.
    RewardsThenLeaves,
    /// A nuisance (SPEC 11.2) with a budget of 300.
    Nuisance,
    /// Whatever the individual flags say.
    #[cfg_attr(feature = "cli", value(skip))]
    Custom,
}

impl Profile {
    /// All profiles with a fixed meaning (not `custom`).
    pub const PRESETS: [Profile; 8] = [
        Profile::None,
        Profile::PaperCongratulation,
        Profile::PaperTakeover,
        Profile::Generous,
        Profile::Stingy,
        Profile::StopsEarly,
        Profile::RewardsThenLeaves,
        Profile::Nuisance,
    ];

    /// The human this profile describes for `controller`, or `None` for `custom`.
    pub fn human(self, controller: Controller) -> Option<HumanParams> {
        let base = HumanParams::default();
        let congratulation = Interaction::Congratulation;
        Some(match self {
            Profile::None => base,
            Profile::PaperCongratulation => HumanParams {
                interaction: congratulation,
                budget: paper_budget(controller, congratulation),
                ..base
            },
            Profile::PaperTakeover => HumanParams {
                interaction: Interaction::Takeover,
                budget: paper_budget(controller, Interaction::Takeover),
                ..base
            },
            Profile::Generous => HumanParams {
                interaction: congratulation,
                budget: 1000,
                forget_prob: 0.0,
                ..base
            },
            Profile::Stingy => HumanParams {
                interaction: congratulation,
                budget: 300,
                forget_prob: 0.7,
                ..base
            },
            Profile::StopsEarly => HumanParams {
                interaction: congratulation,
                budget: 10,
                ..base
            },
            Profile::RewardsThenLeaves => HumanParams {
                budget: 300,
                forget_prob: 0.0,
                ..base
            },
            Profile::Nuisance => HumanParams {
                interaction: Interaction::Nuisance,
                budget: 300,
                ..base
            },
            Profile::Custom => return None,
        })
    }

    /// The reward source this profile implies, or `None` for `custom` (SPEC 11.1).
    pub fn reward_source(self) -> Option<RewardSource> {
        match self {
            Profile::Custom => None,
            Profile::RewardsThenLeaves => Some(RewardSource::Human),
            _ => Some(RewardSource::Environment),
        }
    }
}

/// The paper's minimal budgets reaching the maximal rate on task 1 (SPEC 9 item 6). The
/// `entropy` controller, absent from the paper, gets EC's.
pub fn paper_budget(controller: Controller, interaction: Interaction) -> u32 {
    match (interaction, controller) {
        (Interaction::Congratulation | Interaction::Punishment, Controller::Mf) => 300,
        (Interaction::Congratulation | Interaction::Punishment, Controller::Mb) => 50,
        (Interaction::Congratulation | Interaction::Punishment, Controller::Rnd) => 20,
        (Interaction::Congratulation | Interaction::Punishment, _) => 30,
        (Interaction::Takeover, Controller::Mf) => 200,
        (Interaction::Takeover, _) => 50,
        (Interaction::None | Interaction::Nuisance | Interaction::Person, _) => 0,
    }
}

// The parameter registry (see `registry`): adding a parameter is adding a row here. The order
// is the order of the output columns, of `mbmf run --help` and of sweep-key listings.
// Task parameters are rows too, declared beside their tasks and appended by `task_params!`.
#[rustfmt::skip]
crate::env::registry::task_params!(registry::registry {
    special controller: Controller = Controller::Ec, "meta-controller, the rule arbitrating between the experts (SPEC 4, 12)";
    flag selection: Selection = Selection::Softmax, "how the MC picks an expert: softmax or argmax";
    flag cost_model: CostModel = CostModel::Ops, "inference cost model: ops or wallclock",
        help ". Wallclock is not reproducible by nature";
    flag interaction in human: Interaction = Interaction::None,
        "human interaction: none, congratulation, takeover, punishment or nuisance";
    special profile: Profile = Profile::None, "human profile name";
    flag budget in human: u32 = 0, "interactions the human may give" ("interactions"),
        help ". A profile sets it for the controller";
    flag forget_prob as forget in human: f64 = 0.1,
        "probability the human misses an opportunity" ("probability"),
        accepts "a probability in [0, 1]" if |x| (0.0..=1.0).contains(&x);
    flag zeta in human: f64 = 0.1, "human's error or reward scale zeta",
        accepts "a bonus weight from 0 to 1e12" if |x| (0.0..=MAGNITUDE_MAX).contains(&x),
        help ". A congratulation adds it to the softmax, a punishment subtracts it";
    flag error_prob in human: f64 = 0.0,
        "probability an attentive human misjudges an action (SPEC 15)" ("probability"),
        accepts "a probability in [0, 1]" if |x| (0.0..=1.0).contains(&x),
        help ". Above 0 every robot action is a congratulation or punishment opportunity";
    flag alpha_mf: f64 = 0.6, "MF learning rate",
        accepts "a learning rate in (0, 1]" if |x| x > 0.0 && x <= 1.0;
    flag gamma_mf: f64 = 0.9, "MF discount factor",
        accepts "a discount in [0, 1)" if |x| (0.0..1.0).contains(&x);
    flag lambda_mf: f64 = 0.0, "MF replacing eligibility trace decay (SPEC 3.1)",
        accepts "a decay in [0, 1]" if |x| (0.0..=1.0).contains(&x),
        help ". 0 is the paper's one-step Q-learning; refused with vpi";
    flag gamma_mb: f64 = 0.95, "MB discount factor",
        accepts "a discount in [0, 1)" if |x| (0.0..1.0).contains(&x);
    flag tau: f64 = 0.02, "MC softmax temperature",
        accepts "a temperature > 0, at least 1e-300" if |x| x >= TAU_MIN,
        help ". MF and MB use it too";
    flag q_init: f64 = 0.0, "initial Q value" ("reward"),
        accepts "a number from -1e12 to 1e12" if |x| x.abs() <= MAGNITUDE_MAX,
        help " (paper; the authors' code uses 1)";
    flag window_n: u32 = 10, "MB model window length" ("transitions"),
        accepts "a window of 1 to 65535 executions" if |n| (1..=u32::from(u16::MAX)).contains(&n);
    flag vi_epsilon: f64 = 0.01, "value-iteration convergence threshold" ("reward"),
        accepts "a tolerance > 0" if |x| x > 0.0,
        help ". Value iteration stops when a sweep's summed |dQ| is below it";
    flag vi_max_sweeps: u32 = 10_000, "value-iteration sweep cap" ("sweeps"),
        accepts "at least 1 sweep per inference" if |n| n >= 1,
        help ". A call that reaches it stops unconverged and is counted in the vi_capped column";
    flag filter_alpha: f64 = 0.6, "averaging filter rate of the expert distributions",
        accepts "a weight in (0, 1]" if |x| x > 0.0 && x <= 1.0,
        help ": the weight of the new value in every moving average";
    flag kappa_coeff ["kappa"]: f64 = 9.0, "kappa = exp(-kappa_coeff * H_MF in bits) (Eq. 7)" ("1/bit"),
        accepts "a number >= 0" if |x| x >= 0.0;
    flag normalise_entropy ["normalize_entropy"]: bool = true,
        "entropies divided by log2(actions) in the MC values", help " (authors' code)";
    flag steps: u32 = 10_000, "experiment steps after babbling" ("steps"),
        help " (the task's default: 20000 for tidy2, 402 for twostep, 1000 for chain). 0 runs the babbling only: one row per run with zero reward \
              and cost, and no series rows";
    flag babbling: u32 = 1_000, "babbling steps before the experiment" ("steps"),
        help " (the task's default: 0 for twostep, 100 for chain). Reward is withheld and the human absent";
    flag checkpoint: u32 = 100, "series row every K experiment steps" ("steps"),
        help ". The last step has a row too; 0 writes no series rows";
    after_profile reward_source: RewardSource = RewardSource::Environment,
        "who brings the goal's reward: environment or human (SPEC 11.1)";
    flag congratulation_effect: CongratulationEffect = CongratulationEffect::Bias,
        "how a congratulation acts: bias (Eq. 8) or reward shaping (SPEC 11.3)";
    flag w_mb: f64 = 0.5, "P(MB) of the fixed controller" ("probability"),
        accepts "a weight in [0, 1]" if |x| (0.0..=1.0).contains(&x);
    flag combine: Combine = Combine::Select,
        "how the MB weight combines the experts: select (one acts) or mix (SPEC 12.1)",
        help ". Ignored by mf, mb and vpi";
    flag spe_threshold: f64 = 0.5, "reliability: |SPE| below it is the zero class" ("probability"),
        accepts "a threshold in (0, 1]" if |x| x > 0.0 && x <= 1.0;
    flag rel_memory: u32 = 10, "reliability: transitions whose SPE class is remembered" ("transitions"),
        accepts "1 to 10000 transitions" if |n| (1..=10_000).contains(&n);
    flag rel_eta: f64 = 0.1, "reliability: rate of the MF's mean |RPE| (Omega)",
        accepts "a rate in (0, 1]" if |x| x > 0.0 && x <= 1.0;
    flag rel_a_mf_mb: f64 = 1.2, "reliability: amplitude of the MF-to-MB rate",
        accepts "a number >= 0, at most 1e12" if |x| (0.0..=MAGNITUDE_MAX).contains(&x);
    flag rel_b_mf_mb: f64 = 10.0, "reliability: steepness of the MF-to-MB rate in chi_MF",
        accepts "a number from -1e12 to 1e12" if |x| x.abs() <= MAGNITUDE_MAX;
    flag rel_a_mb_mf: f64 = 1.0, "reliability: amplitude of the MB-to-MF rate",
        accepts "a number >= 0, at most 1e12" if |x| (0.0..=MAGNITUDE_MAX).contains(&x);
    flag rel_b_mb_mf: f64 = 2.0, "reliability: steepness of the MB-to-MF rate in chi_MB",
        accepts "a number from -1e12 to 1e12" if |x| x.abs() <= MAGNITUDE_MAX;
    flag rel_p0: f64 = 0.7, "reliability: P_MB at the start of a run" ("probability"),
        accepts "a probability in [0, 1]" if |x| (0.0..=1.0).contains(&x);
    flag kalman_v0: f64 = 1.0, "vpi: initial variance of the Kalman MF's values",
        accepts "a variance > 0, at most 1e12" if |x| x > 0.0 && x <= MAGNITUDE_MAX;
    flag kalman_eta: f64 = 1e-4, "vpi: relative variance growth per update (Kalman MF)",
        accepts "a number >= 0, at most 1e12" if |x| (0.0..=MAGNITUDE_MAX).contains(&x);
    flag kalman_noise: f64 = 0.05, "vpi: observation noise of the Kalman MF",
        accepts "a variance > 0, at most 1e12" if |x| x > 0.0 && x <= MAGNITUDE_MAX;
    flag rbar_rate: f64 = 0.02, "vpi: rate of the average reward",
        accepts "a rate in [0, 1]" if |x| (0.0..=1.0).contains(&x);
    flag vpi_tau: f64 = 0.08, "vpi: an action is planned when its VPI >= vpi_tau * average reward",
        accepts "a number from -1e12 to 1e12" if |x| x.abs() <= MAGNITUDE_MAX;
});

/// Largest magnitude an action value or a run's total reward may reach. Inputs that could push
/// a value beyond it are refused ([`Params::validate_for_reward`]): below it, the differences and
/// sums the experts compute (softmax shifts, Q-learning targets) stay finite.
pub const VALUE_LIMIT: f64 = 1e307;

/// Smallest accepted softmax temperature: below about 5.6e-309, `1 / tau` is infinite and the
/// softmax of the best action would compute `0 * inf`.
pub const TAU_MIN: f64 = 1e-300;

/// Largest accepted |q_init| and zeta: far beyond any meaningful value, and small enough that a
/// Q value plus a bonus never loses its finiteness.
pub const MAGNITUDE_MAX: f64 = 1e12;

/// The command-line flag of a parameter named as in [`ConfigError::InvalidParam`].
pub fn cli_flag(name: &str) -> String {
    param(name).map_or_else(|| format!("--{}", name.replace('_', "-")), Param::flag)
}

/// A number as error messages write it: plain for ordinary magnitudes, with an exponent for
/// very large or very small ones (`1e300`, not three hundred digits).
pub fn show(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-6..1e16).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A bound as error messages write it: three significant digits, or "infinity".
fn approx(x: f64) -> String {
    if !x.is_finite() {
        return "infinity".to_string();
    }
    let text = format!("{x:.2e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) if mantissa.contains('.') => {
            let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{mantissa}e{exponent}")
        }
        _ => text,
    }
}

impl Params {
    /// Whether the run's MF learns with an eligibility trace (SPEC 3.1: `lambda_mf` > 0 and an
    /// MF expert learning by Q-learning; `vpi`, whose MF is a Kalman filter, is refused).
    pub fn uses_eligibility(&self) -> bool {
        self.lambda_mf > 0.0 && self.controller.runs_mf() && self.controller != Controller::Vpi
    }

    /// Whether a human (simulated or a person) or a reward of theirs can act on the run: else,
    /// with no schedule either, the run's steps are compiled without any human function.
    pub fn human_may_act(&self) -> bool {
        self.human.interaction != Interaction::None
            || self.reward_source != RewardSource::Environment
    }

    /// Checks that, with an environment whose goal gives `goal_reward`, no value the run computes
    /// can exceed [`VALUE_LIMIT`]: action values stay within max(|q_init|, |r| / (1 - gamma)) for
    /// each discount in use, and the total reward within |r| x steps. Call after [`validate`].
    ///
    /// [`validate`]: Params::validate
    pub fn validate_for_reward(&self, goal_reward: f64) -> Result<(), ConfigError> {
        let mut reward = goal_reward.abs();
        if self.congratulation_effect == CongratulationEffect::Reward {
            // A congratulated transition is learned with r + zeta (SPEC 11.3).
            reward += self.human.zeta;
        }
        let discounts = [
            ("gamma_mf", self.gamma_mf, self.controller.runs_mf()),
            ("gamma_mb", self.gamma_mb, self.controller.runs_mb()),
        ];
        for (name, gamma, used) in discounts {
            let bound = reward / (1.0 - gamma);
            if used && (bound.is_nan() || bound > VALUE_LIMIT) {
                return Err(ConfigError::ValueOverflow {
                    what: "action values",
                    reached: approx(bound),
                    because: format!(
                        "goal reward {} and {name} = {} (|reward| / (1 - {name}))",
                        show(goal_reward),
                        show(gamma)
                    ),
                    fix: "scale the goal reward down (only its ratio to q_init and zeta \
                          matters) or lower the discount",
                });
            }
        }
        let total = reward * f64::from(self.steps);
        if total.is_nan() || total > VALUE_LIMIT {
            return Err(ConfigError::ValueOverflow {
                what: "the total reward of a run",
                reached: approx(total),
                because: format!(
                    "goal reward {} over {} steps",
                    show(goal_reward),
                    self.steps
                ),
                fix: "scale the goal reward down or run fewer steps",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn invalid(p: Params) -> (&'static str, String) {
        match p.validate() {
            Err(ConfigError::InvalidParam { name, value, .. }) => (name, value),
            other => panic!("expected an invalid parameter, got {other:?}"),
        }
    }

    #[test]
    fn the_paper_defaults_are_valid_with_the_tidy_reward() {
        let p = Params::default();
        assert_eq!(p.validate(), Ok(()));
        assert_eq!(p.validate_for_reward(1.0), Ok(()));
    }

    #[test]
    fn each_out_of_range_value_is_named_with_its_value() {
        let d = Params::default();
        let cases = [
            (Params { tau: 0.0, ..d }, "tau", "0"),
            (Params { tau: 1e-310, ..d }, "tau", "1e-310"),
            (
                Params {
                    alpha_mf: f64::NAN,
                    ..d
                },
                "alpha_mf",
                "NaN",
            ),
            (Params { gamma_mb: 1.0, ..d }, "gamma_mb", "1"),
            (Params { q_init: 1e300, ..d }, "q_init", "1e300"),
            (
                Params {
                    filter_alpha: 0.0,
                    ..d
                },
                "filter_alpha",
                "0",
            ),
            (
                Params {
                    kappa_coeff: f64::INFINITY,
                    ..d
                },
                "kappa_coeff",
                "inf",
            ),
            (
                Params {
                    vi_epsilon: -1.0,
                    ..d
                },
                "vi_epsilon",
                "-1",
            ),
            (Params { window_n: 0, ..d }, "window_n", "0"),
            (
                Params {
                    vi_max_sweeps: 0,
                    ..d
                },
                "vi_max_sweeps",
                "0",
            ),
        ];
        for (p, name, value) in cases {
            assert_eq!(invalid(p), (name, value.to_string()));
        }
        let human = HumanParams {
            forget_prob: 1.5,
            ..HumanParams::default()
        };
        assert_eq!(
            invalid(Params { human, ..d }),
            ("forget_prob", "1.5".into())
        );
        let human = HumanParams {
            zeta: -0.1,
            ..HumanParams::default()
        };
        assert_eq!(invalid(Params { human, ..d }), ("zeta", "-0.1".into()));
    }

    #[test]
    fn boundary_values_are_accepted() {
        let d = Params::default();
        for p in [
            Params { tau: TAU_MIN, ..d },
            Params {
                alpha_mf: 1.0,
                gamma_mf: 0.0,
                filter_alpha: 1.0,
                ..d
            },
            Params {
                q_init: -MAGNITUDE_MAX,
                kappa_coeff: 0.0,
                window_n: 65535,
                ..d
            },
        ] {
            assert_eq!(p.validate(), Ok(()), "{p:?}");
        }
    }

    #[test]
    fn flags_are_the_names_with_dashes_except_forget() {
        assert_eq!(cli_flag("alpha_mf"), "--alpha-mf");
        assert_eq!(cli_flag("forget_prob"), "--forget");
        assert_eq!(cli_flag("tau"), "--tau");
    }

    #[test]
    fn numbers_in_messages_are_short() {
        assert_eq!(show(1e300), "1e300");
        assert_eq!(show(0.02), "0.02");
        assert_eq!(show(-3.0), "-3");
        assert_eq!(show(f64::NAN), "NaN");
        assert_eq!(approx(1.9999999999999982e307), "2e307");
        assert_eq!(approx(f64::INFINITY), "infinity");
        assert_eq!(approx(1.25e5), "1.25e5");
    }

    #[test]
    fn a_reward_is_refused_when_values_or_totals_could_pass_the_limit() {
        // |r| / (1 - gamma_mb) = 2e307 with the default 0.95.
        let p = Params {
            controller: Controller::Mb,
            ..Params::default()
        };
        assert!(matches!(
            p.validate_for_reward(1e306),
            Err(ConfigError::ValueOverflow {
                what: "action values",
                ..
            })
        ));
        // MF alone does not use gamma_mb: 1e306 / 0.5 is fine, but not over 10,000 steps.
        let p = Params {
            controller: Controller::Mf,
            gamma_mf: 0.5,
            ..Params::default()
        };
        assert!(matches!(
            p.validate_for_reward(1e306),
            Err(ConfigError::ValueOverflow {
                what: "the total reward of a run",
                ..
            })
        ));
        assert_eq!(Params { steps: 5, ..p }.validate_for_reward(1e306), Ok(()));
        assert_eq!(Params::default().validate_for_reward(-1e300), Ok(()));
    }
}
