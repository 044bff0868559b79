//! What each column means and its unit, stored as Arrow field metadata (`description`, `unit`)
//! so a file explains itself without the README. The texts follow the README's schema tables.

use std::collections::HashMap;

use arrow::datatypes::{DataType, Field};

/// (column, description, unit; "" when the value has no unit).
const DOCS: &[(&str, &str, &str)] = &[
    (
        "run_index",
        "index of the run; with master_seed it fixes the run's random stream",
        "",
    ),
    ("master_seed", "master seed of the run or sweep", ""),
    (
        "config_index",
        "configuration of the run: the sweep's configuration index, or for mbmf run the \
         controller's position in --controller",
        "",
    ),
    (
        "seed_index",
        "replicate of the configuration: 0 to seeds-1 in a sweep, 0 to runs-1 in mbmf run",
        "",
    ),
    ("task", "task name (tidy1, tidy2 or the json world)", ""),
    (
        "controller",
        "meta-controller: mf, mb, rnd, ec or entropy",
        "",
    ),
    (
        "selection",
        "how the MC picks an expert: softmax or argmax",
        "",
    ),
    ("cost_model", "inference cost model: ops or wallclock", ""),
    (
        "interaction",
        "human interaction: none, congratulation, takeover, punishment or nuisance",
        "",
    ),
    ("profile", "human profile name", ""),
    ("budget", "interactions the human may give", "interactions"),
    (
        "forget_prob",
        "probability the human misses an opportunity",
        "probability",
    ),
    ("zeta", "human's error or reward scale zeta", ""),
    ("alpha_mf", "MF learning rate", ""),
    ("gamma_mf", "MF discount factor", ""),
    ("gamma_mb", "MB discount factor", ""),
    ("tau", "MC softmax temperature", ""),
    ("q_init", "initial Q value", "reward"),
    ("window_n", "MB model window length", "transitions"),
    (
        "vi_epsilon",
        "value-iteration convergence threshold",
        "reward",
    ),
    ("vi_max_sweeps", "value-iteration sweep cap", "sweeps"),
    (
        "filter_alpha",
        "averaging filter rate of the expert distributions",
        "",
    ),
    (
        "kappa_coeff",
        "kappa = exp(-kappa_coeff * H_MF in bits) (Eq. 7)",
        "1/bit",
    ),
    (
        "normalise_entropy",
        "entropies divided by log2(actions) in the MC values",
        "",
    ),
    ("steps", "experiment steps after babbling", "steps"),
    ("babbling", "babbling steps before the experiment", "steps"),
    ("checkpoint", "series row every K experiment steps", "steps"),
    (
        "total_reward",
        "reward over the experiment (babbling excluded)",
        "reward",
    ),
    (
        "reward_last10",
        "reward over the last 10% of steps",
        "reward",
    ),
    (
        "first_reward_step",
        "1-based experiment step whose transition first reached the goal; null if none",
        "steps",
    ),
    ("interactions", "interactions given", "interactions"),
    ("congratulations", "congratulations given", "interactions"),
    ("takeovers", "takeovers given", "interactions"),
    ("punishments", "punishments given", "interactions"),
    (
        "forgotten",
        "opportunities the human missed by forgetting",
        "interactions",
    ),
    (
        "budget_exhausted_step",
        "experiment step at which the budget ran out; null if it never did",
        "steps",
    ),
    (
        "cost_total",
        "inference cost of both experts",
        "per cost_model: Q values read (ops) or s (wallclock)",
    ),
    (
        "cost_mf",
        "inference cost of MF",
        "per cost_model: Q values read (ops) or s (wallclock)",
    ),
    (
        "cost_mb",
        "inference cost of MB",
        "per cost_model: Q values read (ops) or s (wallclock)",
    ),
    (
        "decisions",
        "robot decisions (not reset steps, not takeovers); in series, since the previous row",
        "decisions",
    ),
    ("mb_decisions", "decisions given to MB", "decisions"),
    ("mb_share", "mb_decisions / decisions", "fraction"),
    (
        "p_mb_mean",
        "MC softmax probability of MB averaged over decisions (in series, since the previous row)",
        "probability",
    ),
    (
        "mean_entropy_chosen",
        "the chosen expert's normalised entropy, averaged over decisions",
        "fraction of log2(actions)",
    ),
    (
        "vi_calls",
        "value-iteration calls (babbling included)",
        "calls",
    ),
    (
        "vi_sweeps",
        "value-iteration sweeps (babbling included)",
        "sweeps",
    ),
    (
        "vi_capped",
        "value-iteration calls stopped by vi_max_sweeps",
        "calls",
    ),
    (
        "reward_source",
        "who brings the goal's reward: environment or human (SPEC 11.1)",
        "",
    ),
    (
        "congratulation_effect",
        "how a congratulation acts: bias (Eq. 8) or reward shaping (SPEC 11.3)",
        "",
    ),
    (
        "boxes",
        "tidy1 box assignment at the start: position i gives cube i's box (rgb by default)",
        "",
    ),
    (
        "rewards_given",
        "goal rewards brought by the human (SPEC 11.1)",
        "interactions",
    ),
    ("nuisances", "nuisances given (SPEC 11.2)", "interactions"),
    (
        "schedule",
        "the run's changes in canonical form (STEP:KEY=VALUE joined by ;), empty without changes",
        "",
    ),
    (
        "first_change_step",
        "step T of the first change; null without changes",
        "steps",
    ),
    (
        "reward_before_change",
        "reward over steps before the first change",
        "reward",
    ),
    (
        "reward_after_change",
        "reward from the first change on",
        "reward",
    ),
    (
        "recovery_steps",
        "first rewarded step at or after the first change, minus its step, plus 1",
        "steps",
    ),
    (
        "wall_time_s",
        "seconds spent simulating the run (not reproducible)",
        "s",
    ),
    ("step", "experiment step of the row", "steps"),
    ("cum_reward", "reward so far", "reward"),
    (
        "cum_cost",
        "inference cost so far, both experts",
        "per cost_model: Q values read (ops) or s (wallclock)",
    ),
    (
        "cum_cost_mf",
        "inference cost so far, MF",
        "per cost_model: Q values read (ops) or s (wallclock)",
    ),
    (
        "cum_cost_mb",
        "inference cost so far, MB",
        "per cost_model: Q values read (ops) or s (wallclock)",
    ),
];

/// The description and unit of a column mbmf writes, if it is one.
pub fn doc(name: &str) -> Option<(&'static str, &'static str)> {
    DOCS.iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, d, u)| (*d, *u))
}

/// A field carrying its column's description and unit (when known) as metadata.
pub fn field(name: &str, data_type: DataType, nullable: bool) -> Field {
    let field = Field::new(name, data_type, nullable);
    match doc(name) {
        Some((description, unit)) => {
            let mut m = HashMap::from([("description".to_string(), description.to_string())]);
            if !unit.is_empty() {
                m.insert("unit".to_string(), unit.to_string());
            }
            field.with_metadata(m)
        }
        None => field,
    }
}
