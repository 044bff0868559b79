//! What each column means and its unit, stored as Arrow field metadata (`description`, `unit`)
//! so a file explains itself without the README. The texts follow the README's schema tables.

use std::collections::HashMap;

use arrow::datatypes::{DataType, Field};

/// The unit of inference costs, which depends on the cost model.
const COST: &str = "per cost_model: Q values read (ops) or s (wallclock)";

/// (column, description, unit; "" when the value has no unit) of every column but the
/// parameters, whose texts are in the registry ([`crate::params::PARAMS`]).
#[rustfmt::skip]
const DOCS: &[(&str, &str, &str)] = &[
    ("run_index", "index of the run; with master_seed it fixes the run's random stream", ""),
    ("master_seed", "master seed of the run or sweep", ""),
    ("config_index", "configuration of the run: the sweep's configuration index, or for mbmf run the controller's position in --controller", ""),
    ("seed_index", "replicate of the configuration: 0 to seeds-1 in a sweep, 0 to runs-1 in mbmf run", ""),
    ("task", "task name as given (a task of the registry: mbmf run --help lists them)", ""),
    ("total_reward", "reward over the experiment (babbling excluded)", "reward"),
    ("reward_last10", "reward over the last 10% of steps", "reward"),
    ("first_reward_step", "1-based experiment step whose transition first reached the goal; null if none", "steps"),
    ("interactions", "interactions given", "interactions"),
    ("congratulations", "congratulations given", "interactions"),
    ("takeovers", "takeovers given", "interactions"),
    ("punishments", "punishments given", "interactions"),
    ("forgotten", "opportunities the human missed by forgetting", "interactions"),
    ("budget_exhausted_step", "experiment step at which the budget ran out; null if it never did", "steps"),
    ("cost_total", "inference cost of both experts", COST),
    ("cost_mf", "inference cost of MF", COST),
    ("cost_mb", "inference cost of MB", COST),
    ("decisions", "robot decisions (not reset steps, not takeovers); in series, since the previous row", "decisions"),
    ("mb_decisions", "decisions given to MB", "decisions"),
    ("mb_share", "mb_decisions / decisions", "fraction"),
    ("p_mb_mean", "MC softmax probability of MB averaged over decisions (in series, since the previous row)", "probability"),
    ("mean_entropy_chosen", "the chosen expert's normalised entropy, averaged over decisions", "fraction of log2(actions)"),
    ("vi_calls", "value-iteration calls (babbling included)", "calls"),
    ("vi_sweeps", "value-iteration sweeps (babbling included)", "sweeps"),
    ("vi_capped", "value-iteration calls stopped by vi_max_sweeps", "calls"),
    ("rewards_given", "goal rewards brought by the human (SPEC 11.1)", "interactions"),
    ("nuisances", "nuisances given (SPEC 11.2)", "interactions"),
    ("schedule", "the run's changes in canonical form (STEP:KEY=VALUE joined by ;), empty without changes", ""),
    ("first_change_step", "step T of the first change; null without changes", "steps"),
    ("reward_before_change", "reward over steps before the first change", "reward"),
    ("reward_after_change", "reward from the first change on", "reward"),
    ("recovery_steps", "first rewarded step at or after the first change, minus its step, plus 1", "steps"),
    ("wall_time_s", "seconds spent simulating the run (not reproducible)", "s"),
    ("step", "experiment step of the row", "steps"),
    ("cum_reward", "reward so far", "reward"),
    ("cum_cost", "inference cost so far, both experts", COST),
    ("cum_cost_mf", "inference cost so far, MF", COST),
    ("cum_cost_mb", "inference cost so far, MB", COST),
];

/// The description and unit of a column mbmf writes, if it is one.
pub fn doc(name: &str) -> Option<(&'static str, &'static str)> {
    if let Some(p) = crate::params::param(name) {
        return Some((p.doc, p.unit));
    }
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
