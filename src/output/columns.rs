//! What each column means and its unit, stored as Arrow field metadata (`description`, `unit`)
//! so a file explains itself without the docs. The same texts render `docs/schema.md`
//! ([`schema_markdown`]), so the page and the files cannot drift apart.

use std::collections::HashMap;
use std::fmt::Write as _;

use arrow::datatypes::{DataType, Field, Schema};

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
    ("state", "state at the start of the step (the environment's state index)", ""),
    ("action", "action executed (the robot's or the human's); null on a reset step", ""),
    ("next_state", "state after the step (after a nuisance, the state it left)", ""),
    ("reward", "the task's reward of the step (what total_reward adds up; babbling excluded)", "reward"),
    ("terminal", "the arrival ended an episode or trial (no future term for MF)", ""),
    ("actor", "who chose the action: mf or mb (that expert's softmax), mix (a mixture: combine = mix, or a vpi decision with an action valued by MB), human (a takeover), reset (a reset step)", ""),
    ("p_mb", "P(MB) of the step's decision; null without a decision (takeover, reset step)", "probability"),
    ("participant", "mbmf teach: the person's pseudonym (given, or drawn at random)", ""),
    ("session", "mbmf teach: the session's random id", ""),
    ("finished", "mbmf teach: the session ended (the person finished, or every step was taken); false while it runs, or after a closed tab or a killed server", ""),
    ("shown_at", "mbmf teach: when the step was shown to the person, from the session's start", "s"),
    ("clicked_at", "mbmf teach: when the person's click that acted on the step came (its feedback, or the takeover that made it), from the session's start; null without one", "s"),
    ("human_event", "what the human did: none, congratulation, punishment, takeover, nuisance, reward (a reward given with another interaction in one step shows as that interaction)", ""),
];

/// The description and unit of a column mbmf writes, if it is one.
pub fn doc(name: &str) -> Option<(&'static str, &'static str)> {
    if let Some(p) = crate::params::param(name) {
        return Some((p.doc, p.unit));
    }
    if let Some(m) = crate::env::registry::metric(name) {
        return Some((m.doc, m.unit));
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

/// A column's type as the schema page writes it.
fn type_name(data_type: &DataType) -> String {
    match data_type {
        DataType::Int64 => "i64".to_string(),
        DataType::UInt64 => "u64".to_string(),
        DataType::Float64 => "f64".to_string(),
        DataType::Boolean => "bool".to_string(),
        DataType::Utf8 | DataType::LargeUtf8 => "string".to_string(),
        DataType::Int32 => "i32".to_string(),
        DataType::Int16 => "i16".to_string(),
        DataType::Dictionary(key, value) => {
            format!("dictionary<{}, {}>", type_name(key), type_name(value))
        }
        DataType::Int8 => "i8".to_string(),
        other => other.to_string(),
    }
}

/// A table cell: `|` would end the cell early.
fn cell(text: &str) -> String {
    text.replace('|', "\\|")
}

/// The column tables of the schema page, in markdown, from the schemas of a `runs` and a
/// `series` file: first the columns both tables start with (identity and parameters, with the
/// registry's sweep key and default), then each table's own columns, in file order. Each row
/// gives the type (with `null` when the column can be null), the unit and the description the
/// files carry, so `docs/schema.md` is generated rather than kept in step by hand.
pub fn schema_markdown(runs: &Schema, series: &Schema) -> String {
    let shared = runs
        .fields()
        .iter()
        .zip(series.fields().iter())
        .take_while(|(a, b)| a == b)
        .count();
    let kind = |f: &Field| {
        let t = type_name(f.data_type());
        if f.is_nullable() {
            format!("{t}, null")
        } else {
            t
        }
    };
    let meaning = |f: &Field| doc(f.name()).unwrap_or(("", ""));
    let mut s = String::new();
    let _ = writeln!(
        s,
        "**Parameter columns** (both tables, first; `default` and `sweep key` from the parameter registry):\n"
    );
    let _ = writeln!(
        s,
        "| column | type | sweep key | default | unit | meaning |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for f in &runs.fields()[..shared] {
        let (description, unit) = meaning(f);
        let (key, default) = match crate::params::param(f.name()) {
            Some(p) => (
                format!("`{}`", p.key),
                format!("`{}`", p.default_value().shown()),
            ),
            None => ("–".to_string(), "–".to_string()),
        };
        let _ = writeln!(
            s,
            "| `{}` | {} | {key} | {default} | {} | {} |",
            f.name(),
            kind(f),
            cell(unit),
            cell(description)
        );
    }
    for (title, schema) in [
        ("**`runs` results** (one row per run, SPEC 8)", runs),
        (
            "**`series` columns** (one row per run per checkpoint)",
            series,
        ),
    ] {
        let _ = writeln!(s, "\n{title}:\n");
        let _ = writeln!(s, "| column | type | unit | meaning |");
        let _ = writeln!(s, "|---|---|---|---|");
        for f in &schema.fields()[shared..] {
            let (description, unit) = meaning(f);
            let _ = writeln!(
                s,
                "| `{}` | {} | {} | {} |",
                f.name(),
                kind(f),
                cell(unit),
                cell(description)
            );
        }
    }
    s
}

/// The column table of the `trace` table (SPEC 14) for the schema page, in file order.
pub fn trace_markdown(trace: &Schema) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n**`trace` columns** (with `--trace`: one row per run per experiment step, SPEC 14):\n"
    );
    let _ = writeln!(s, "| column | type | unit | meaning |");
    let _ = writeln!(s, "|---|---|---|---|");
    for f in trace.fields() {
        let (description, unit) = doc(f.name()).unwrap_or(("", ""));
        let t = type_name(f.data_type());
        let t = if f.is_nullable() {
            format!("{t}, null")
        } else {
            t
        };
        let _ = writeln!(
            s,
            "| `{}` | {t} | {} | {} |",
            f.name(),
            cell(unit),
            cell(description)
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schema_page_lists_shared_columns_once_then_each_tables_own() {
        let shared = [
            field("run_index", DataType::Int64, false),
            field("kappa_coeff", DataType::Float64, false),
        ];
        let runs = Schema::new(
            shared
                .iter()
                .cloned()
                .chain([field("first_reward_step", DataType::Int64, true)])
                .collect::<Vec<_>>(),
        );
        let series = Schema::new(
            shared
                .iter()
                .cloned()
                .chain([field("step", DataType::Int64, false)])
                .collect::<Vec<_>>(),
        );
        let page = schema_markdown(&runs, &series);
        let rows: Vec<&str> = page.lines().filter(|l| l.starts_with("| `")).collect();
        assert_eq!(
            rows,
            [
                "| `run_index` | i64 | – | – |  | index of the run; with master_seed it fixes the run's random stream |",
                "| `kappa_coeff` | f64 | `kappa_coeff` | `9` | 1/bit | kappa = exp(-kappa_coeff * H_MF in bits) (Eq. 7) |",
                "| `first_reward_step` | i64, null | steps | 1-based experiment step whose transition first reached the goal; null if none |",
                "| `step` | i64 | steps | experiment step of the row |",
            ]
        );
        // A `|` in a text would end its cell early.
        assert_eq!(cell("a | b"), "a \\| b");
    }
}
