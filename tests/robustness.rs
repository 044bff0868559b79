//! Numerical robustness: extreme but accepted inputs give finite outputs, and
//! inputs that would overflow are refused with a reason.
//!
//! Every test runs the built binary (`mbmf run`) and reads both Parquet files back: every float
//! column must hold finite values or nulls, never NaN or an infinity.

use std::fs::File;
use std::path::{Path, PathBuf};

use arrow::array::{Array, Float64Array, Int64Array, RecordBatch, StringArray};
use arrow::datatypes::DataType;
use assert_cmd::Command;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use tempfile::TempDir;

/// A json: world written to a temporary folder.
struct World {
    dir: TempDir,
}

impl World {
    /// `n` states, `a` actions; each pair has `outcomes` distinct next states with counts 1 to 9
    /// drawn from a fixed-seed generator. Start in state 0; the last state is the goal.
    fn random(n: usize, a: usize, outcomes: usize, goal_reward: &str) -> World {
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = |bound: usize| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % bound as u64) as usize
        };
        let mut entries = Vec::new();
        for s in 0..n {
            let mut transitions = Vec::new();
            for action in 0..a {
                // A random window of `outcomes` consecutive states (mod n): distinct by design.
                let first = next(n);
                for k in 0..outcomes {
                    let state = (first + k) % n;
                    let prob = 1 + next(9);
                    transitions.push(format!(
                        r#"{{"action": {action}, "state": {state}, "prob": {prob}}}"#
                    ));
                }
            }
            entries.push(format!(
                r#"{{"state": {s}, "transitions": [{}]}}"#,
                transitions.join(", ")
            ));
        }
        let model = format!(r#"{{"transitionActions": [{}]}}"#, entries.join(",\n"));
        let key_states = format!("init 0\ngoal {} {goal_reward}\n", n - 1);
        World::write(&model, &key_states, &format!("state {n}\naction {a}\n"))
    }

    /// A corridor 0 -> 1 -> ... -> n-1 (goal): action 0 moves right, action 1 stays.
    fn corridor(n: usize, goal_reward: &str) -> World {
        let entries: Vec<String> = (0..n - 1)
            .map(|s| {
                format!(
                    r#"{{"state": {s}, "transitions": [{{"action": 0, "state": {}, "prob": 1}}, {{"action": 1, "state": {s}, "prob": 1}}]}}"#,
                    s + 1
                )
            })
            .collect();
        let model = format!(r#"{{"transitionActions": [{}]}}"#, entries.join(",\n"));
        let key_states = format!("init 0\ngoal {} {goal_reward}\n", n - 1);
        World::write(&model, &key_states, &format!("state {n}\naction 2\n"))
    }

    fn write(model: &str, key_states: &str, spaces: &str) -> World {
        let dir = TempDir::new().expect("a temporary folder");
        std::fs::write(dir.path().join("world.json"), model).expect("write the model");
        std::fs::write(dir.path().join("keyStates.txt"), key_states).expect("write keyStates");
        std::fs::write(dir.path().join("spaces.txt"), spaces).expect("write spaces");
        World { dir }
    }

    fn task(&self) -> String {
        format!("json:{}", self.dir.path().join("world.json").display())
    }
}

/// The output of one successful `mbmf run`.
struct Output {
    _dir: TempDir,
    runs: Vec<RecordBatch>,
    series: Vec<RecordBatch>,
}

impl Output {
    /// The float column `name` of runs.parquet (nulls as `None`).
    fn runs_f64(&self, name: &str) -> Vec<Option<f64>> {
        values(&self.runs, name, |a: &Float64Array, i| {
            a.is_valid(i).then(|| a.value(i))
        })
    }

    /// The count column `name` of runs.parquet (Int64, never negative).
    fn runs_u64(&self, name: &str) -> Vec<u64> {
        values(&self.runs, name, |a: &Int64Array, i| {
            u64::try_from(a.value(i)).unwrap()
        })
    }

    /// The string column `name` of runs.parquet (nulls as "").
    fn runs_str(&self, name: &str) -> Vec<String> {
        values(&self.runs, name, |a: &StringArray, i| {
            let text = if a.is_valid(i) { a.value(i) } else { "" };
            text.to_string()
        })
    }
}

/// Every value of column `name` of `batches`, read by `value` from arrays of type `A`.
fn values<A: Array + 'static, T>(
    batches: &[RecordBatch],
    name: &str,
    value: impl Fn(&A, usize) -> T,
) -> Vec<T> {
    let mut out = Vec::new();
    for b in batches {
        let column = b
            .column_by_name(name)
            .unwrap_or_else(|| panic!("no column {name}"));
        let a = column
            .as_any()
            .downcast_ref::<A>()
            .unwrap_or_else(|| panic!("column {name} is not a {}", std::any::type_name::<A>()));
        out.extend((0..a.len()).map(|i| value(a, i)));
    }
    out
}

fn read(path: &Path) -> Vec<RecordBatch> {
    let file = File::open(path).unwrap_or_else(|e| panic!("open {}: {e}", path.display()));
    ParquetRecordBatchReaderBuilder::try_new(file)
        .expect("a Parquet file")
        .build()
        .expect("a reader")
        .collect::<Result<Vec<_>, _>>()
        .expect("readable batches")
}

/// Every float value of every column is finite or null; the message names file, column and row.
fn assert_all_finite(file: &str, batches: &[RecordBatch]) {
    let mut checked = 0;
    for batch in batches {
        for (field, array) in batch.schema().fields().iter().zip(batch.columns()) {
            if field.data_type() != &DataType::Float64 {
                continue;
            }
            let values = array.as_any().downcast_ref::<Float64Array>().unwrap();
            for (row, v) in values.iter().enumerate() {
                if let Some(v) = v {
                    assert!(
                        v.is_finite(),
                        "{file}: column {} row {row} is {v}",
                        field.name()
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 0 || batches.iter().all(|b| b.num_rows() == 0));
}

/// Runs `mbmf run --quiet --out TMP ARGS` and returns its checked output.
fn run(args: &[&str]) -> Output {
    let dir = TempDir::new().expect("a temporary folder");
    let out: PathBuf = dir.path().join("out");
    let assert = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(["run", "--quiet", "--out"])
        .arg(&out)
        .args(args)
        .assert();
    let output = assert.get_output().clone();
    assert!(
        output.status.success(),
        "mbmf run {args:?} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let runs = read(&out.join("runs.parquet"));
    let series = read(&out.join("series.parquet"));
    assert_all_finite("runs.parquet", &runs);
    assert_all_finite("series.parquet", &series);
    Output {
        _dir: dir,
        runs,
        series,
    }
}

/// Runs `mbmf run` expecting a usage error; returns stderr.
fn refused(args: &[&str]) -> String {
    let dir = TempDir::new().expect("a temporary folder");
    let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(["run", "--quiet", "--out"])
        .arg(dir.path().join("out"))
        .args(args)
        .output()
        .expect("mbmf runs");
    assert_eq!(output.status.code(), Some(2), "{args:?} should be refused");
    assert!(
        !dir.path().join("out").exists(),
        "nothing is written before the inputs are checked"
    );
    String::from_utf8_lossy(&output.stderr).into_owned()
}

const ALL: &str = "mf,mb,rnd,ec,entropy";

#[test]
fn a_goal_reward_of_1e300_gives_finite_rewards_values_and_costs() {
    for reward in [1e300, -1e300] {
        let world = World::corridor(6, &format!("{reward:e}"));
        let task = world.task();
        let out = run(&[
            "--task",
            &task,
            "--controller",
            ALL,
            "--runs",
            "2",
            "--steps",
            "600",
            "--babbling",
            "50",
            "--checkpoint",
            "50",
        ]);
        let totals = out.runs_f64("total_reward");
        assert_eq!(totals.len(), 10);
        // The corridor is short: every run reaches the goal (once at least: a negative reward
        // teaches the experts to avoid it).
        for total in totals {
            let total = total.expect("a total reward");
            assert!(total / reward >= 1.0, "total reward {total:e}");
        }
        assert!(out.series.iter().map(|b| b.num_rows()).sum::<usize>() > 0);
    }
}

#[test]
fn a_goal_reward_of_1e300_with_discounts_of_0_999999_stays_finite() {
    // |reward| / (1 - gamma) = 1e306: accepted, just below the 1e307 limit.
    let world = World::corridor(6, "1e300");
    let task = world.task();
    run(&[
        "--task",
        &task,
        "--controller",
        ALL,
        "--runs",
        "2",
        "--steps",
        "400",
        "--babbling",
        "50",
        "--gamma-mf",
        "0.999999",
        "--gamma-mb",
        "0.999999",
        "--vi-max-sweeps",
        "50",
    ]);
}

#[test]
fn a_reward_that_could_overflow_action_values_is_refused_with_the_reason() {
    let world = World::corridor(4, "1e306");
    let message = refused(&["--task", &world.task(), "--controller", "mb"]);
    assert!(
        message.contains("action values could reach 2e307")
            && message.contains("goal reward 1e306 and gamma_mb = 0.95")
            && message.contains("beyond the supported magnitude 1e307")
            && message.contains("scale the goal reward down"),
        "{message}"
    );
    // MF alone with gamma_mf = 0.5 reaches 2e306, and 5 steps 5e306: accepted, and finite.
    run(&[
        "--task",
        &world.task(),
        "--controller",
        "mf",
        "--gamma-mf",
        "0.5",
        "--runs",
        "1",
        "--steps",
        "5",
    ]);
}

#[test]
fn a_reward_whose_total_over_the_steps_could_overflow_is_refused() {
    let world = World::corridor(4, "1e303");
    let message = refused(&[
        "--task",
        &world.task(),
        "--controller",
        "mf",
        "--gamma-mf",
        "0",
        "--steps",
        "100000",
    ]);
    assert!(
        message.contains("the total reward of a run could reach 1e308")
            && message.contains("run fewer steps"),
        "{message}"
    );
}

#[test]
fn a_tiny_temperature_gives_finite_probabilities_and_entropies() {
    let out = run(&[
        "--controller",
        ALL,
        "--runs",
        "2",
        "--steps",
        "1500",
        "--babbling",
        "200",
        "--tau",
        "1e-6",
    ]);
    for p in out.runs_f64("p_mb_mean").into_iter().flatten() {
        assert!((0.0..=1.0).contains(&p), "p_mb_mean {p}");
    }
    for h in out.runs_f64("mean_entropy_chosen").into_iter().flatten() {
        assert!((0.0..=1.0).contains(&h), "entropy {h}");
    }
}

#[test]
fn the_smallest_accepted_temperature_still_gives_finite_outputs() {
    run(&[
        "--controller",
        ALL,
        "--runs",
        "1",
        "--steps",
        "300",
        "--babbling",
        "50",
        "--tau",
        "1e-300",
    ]);
}

#[test]
fn large_positive_or_negative_initial_values_give_finite_outputs() {
    for q_init in ["1e6", "-1e6", "1e12", "-1e12"] {
        run(&[
            "--controller",
            ALL,
            "--runs",
            "1",
            "--steps",
            "600",
            "--babbling",
            "100",
            "--q-init",
            q_init,
            "--vi-max-sweeps",
            "200",
        ]);
    }
}

#[test]
fn value_iteration_that_cannot_converge_stops_at_the_cap_and_is_counted() {
    // Optimistic values (1e6) on tidy1's self-loops (a take with a full hand) decay by a factor
    // gamma = 0.999999 per sweep: about 1e7 sweeps to converge, so every call after babbling
    // has tried a state's actions stops at the cap of 3.
    let out = run(&[
        "--controller",
        "mb",
        "--runs",
        "2",
        "--steps",
        "300",
        "--babbling",
        "1000",
        "--gamma-mb",
        "0.999999",
        "--q-init",
        "1e6",
        "--vi-max-sweeps",
        "3",
    ]);
    let calls = out.runs_u64("vi_calls");
    let sweeps = out.runs_u64("vi_sweeps");
    let capped = out.runs_u64("vi_capped");
    for r in 0..2 {
        assert!(calls[r] > 0);
        assert!(capped[r] > 0, "run {r}: no capped call");
        assert!(sweeps[r] <= 3 * calls[r], "run {r}: {} sweeps", sweeps[r]);
        assert!(capped[r] <= calls[r]);
    }
    // With the default tolerance the same runs converge: nothing is capped.
    let out = run(&[
        "--controller",
        "mb",
        "--runs",
        "2",
        "--steps",
        "300",
        "--babbling",
        "50",
    ]);
    assert_eq!(out.runs_u64("vi_capped"), vec![0, 0]);
}

#[test]
fn a_world_with_200_outcomes_per_pair_gives_finite_outputs() {
    let world = World::random(201, 2, 200, "1");
    let task = world.task();
    let out = run(&[
        "--task",
        &task,
        "--controller",
        "mf,mb,ec",
        "--runs",
        "1",
        "--steps",
        "300",
        "--babbling",
        "30",
        "--window-n",
        "200",
        "--checkpoint",
        "30",
    ]);
    assert_eq!(out.runs_str("controller"), ["mf", "mb", "ec"]);
}

#[test]
fn every_extreme_at_once_still_gives_finite_outputs() {
    let world = World::random(12, 3, 4, "1e300");
    let task = world.task();
    run(&[
        "--task",
        &task,
        "--controller",
        ALL,
        "--runs",
        "1",
        "--steps",
        "400",
        "--babbling",
        "50",
        "--tau",
        "1e-6",
        "--q-init",
        "-1e6",
        "--gamma-mf",
        "0.999999",
        "--gamma-mb",
        "0.999999",
        "--alpha-mf",
        "1",
        "--filter-alpha",
        "1",
        "--kappa-coeff",
        "1e300",
        "--vi-max-sweeps",
        "20",
        "--window-n",
        "1",
    ]);
    run(&[
        "--task",
        &task,
        "--controller",
        ALL,
        "--runs",
        "1",
        "--steps",
        "400",
        "--babbling",
        "0",
        "--tau",
        "1e12",
        "--q-init",
        "1e12",
        "--gamma-mf",
        "0",
        "--gamma-mb",
        "0",
        "--filter-alpha",
        "1e-12",
        "--kappa-coeff",
        "0",
        "--vi-epsilon",
        "1e300",
    ]);
}

#[test]
fn zero_steps_or_zero_checkpoint_write_runs_but_no_series_rows() {
    let out = run(&[
        "--controller",
        "mf,ec",
        "--runs",
        "2",
        "--steps",
        "0",
        "--babbling",
        "100",
    ]);
    assert_eq!(out.runs_f64("total_reward"), vec![Some(0.0); 4]);
    assert_eq!(out.runs_f64("mb_share"), vec![None; 4]);
    assert_eq!(out.series.iter().map(|b| b.num_rows()).sum::<usize>(), 0);
    let out = run(&[
        "--controller",
        "mb",
        "--runs",
        "2",
        "--steps",
        "200",
        "--checkpoint",
        "0",
    ]);
    assert_eq!(out.runs_f64("total_reward").len(), 2);
    assert_eq!(out.series.iter().map(|b| b.num_rows()).sum::<usize>(), 0);
}

/// The authors' `keyStates.txt` may schedule a goal change or deleted transitions; mbmf applies
/// a run's own `--change` events only, so a run without any is warned, with the file and its
/// lines, that its world will not change. With a schedule, no such warning.
#[test]
fn a_world_file_that_schedules_changes_is_named_in_a_warning_when_the_run_has_none() {
    let world = World::corridor(4, "1");
    let key_states = world.dir.path().join("keyStates.txt");
    std::fs::write(&key_states, "init 0\ngoal 3 1\nnew_goal 50 2 1\n").expect("keyStates");
    let stderr = |extra: &[&str]| {
        let dir = TempDir::new().expect("a temporary folder");
        let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
            .args(["run", "--quiet", "--controller", "mf", "--runs", "1"])
            .args(["--steps", "100", "--task", &world.task(), "--out"])
            .arg(dir.path().join("out"))
            .args(extra)
            .output()
            .expect("mbmf runs");
        assert_eq!(output.status.code(), Some(0), "{extra:?}");
        String::from_utf8_lossy(&output.stderr).into_owned()
    };
    let e = stderr(&[]);
    assert!(
        e.contains(&format!(
            "{} (line 3: 'new_goal 50 2 1') schedules changes during the run",
            key_states.display()
        )),
        "{e}"
    );
    assert!(e.contains("this run's world does not change"), "{e}");
    assert!(!stderr(&["--change", "50:goal=2"]).contains("warning"));
}
