//! The two-step task (SPEC 13) on the real step kernel: the drift of its per-run task state,
//! its transition frequencies, the two-step trials, rewards that follow the drifting p, and
//! `mbmf run` end to end.

mod common;

use std::sync::Arc;

use mbmf::batch::{Batch, RunConfig, run_rng, uniform};
use mbmf::env::twostep::{self, P_MAX, P_MIN, slot};
use mbmf::env::{self, Chance, Spec};
use mbmf::params::{Controller, Params};

fn mean_sd(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// 40,000 single drift steps from p = 0.5 (10,000 per slot, never reflected at sd 0.025: a step
/// of 0.25 is 10 sd): mean within 0.001 of 0 (8 standard errors), sd within 3% of 0.025 (the
/// standard error of a sample sd is 0.35% here). Then 100,000 consecutive steps at sd 0.025 and
/// at sd 0.3 never leave [0.25, 0.75].
#[test]
fn the_drift_has_the_declared_sd_and_stays_within_bounds() {
    let spec = twostep::build(0.7, 0.025);
    let d = spec.dynamics.as_ref().expect("twostep declares task state");
    assert_eq!(d.len, 4);
    let mut rng = run_rng(11, 0);
    let mut steps = Vec::new();
    for _ in 0..10_000 {
        let mut p = [0.5; 4];
        (d.after_episode)(d, &mut p, &mut rng);
        steps.extend(p.iter().map(|p| p - 0.5));
    }
    let (mean, sd) = mean_sd(&steps);
    assert!(mean.abs() < 0.001, "mean step {mean}");
    assert!((sd / 0.025 - 1.0).abs() < 0.03, "step sd {sd}");

    for drift_sd in [0.025, 0.3] {
        let spec = twostep::build(0.7, drift_sd);
        let d = spec.dynamics.as_ref().unwrap();
        let mut p = [0.0; 4];
        (d.start)(d, &mut p, &mut rng);
        for _ in 0..100_000 {
            (d.after_episode)(d, &mut p, &mut rng);
            assert!(p.iter().all(|p| (P_MIN..=P_MAX).contains(p)), "{p:?}");
        }
    }
}

/// 100,000 outcome draws per first-stage action: the common transition within 0.01 of 0.7
/// (the standard error is 0.0015).
#[test]
fn first_stage_transitions_are_common_with_probability_0_7() {
    let spec = env::load("twostep").unwrap();
    let mut rng = run_rng(3, 0);
    for (a, common) in [(0, 1), (1, 2)] {
        let sa = spec.sa(0, a);
        let n = 100_000;
        let hits = (0..n)
            .filter(|_| spec.outcome_state[spec.pick_outcome(sa, uniform(&mut rng))] == common)
            .count();
        let f = hits as f64 / n as f64;
        assert!((f - 0.7).abs() < 0.01, "action {a}: {f}");
    }
}

/// The two-step task with both actions of a state made the same (action 1 as action 0), so
/// that what a step brings does not depend on the action drawn: state 0 goes to 1 with 0.7,
/// and a second-stage state s rewards with p(s, 0).
fn equal_actions() -> Spec {
    let mut spec = env::load("twostep").unwrap();
    let (o0, o1) = (spec.outcomes(spec.sa(0, 0)), spec.outcomes(spec.sa(0, 1)));
    for (i, j) in o0.zip(o1) {
        spec.outcome_cum[j] = spec.outcome_cum[i];
        spec.outcome_weight[j] = spec.outcome_weight[i];
    }
    for s in 1..3 {
        let o = spec.outcomes(spec.sa(s, 1)).start;
        spec.arrival[o].chance = Chance::DrawnFrom(slot(s, 0));
    }
    spec
}

/// 10 runs of 20,000 steps stepped one at a time: states alternate first stage, second stage
/// (no reset step, a trial is two steps); the first stage goes to state 1 in 0.7 of trials
/// (100,000 trials, within 0.01); the rewards of second-stage arrivals follow the p each run held
/// before the step: over all arrivals and over those with p below and above 0.5, the reward rate
/// is within 0.015 of the mean p (standard errors below 0.0025); p stays within [0.25, 0.75]
/// and changes only at the end of a trial.
#[test]
fn trials_are_two_steps_and_rewards_follow_the_drifting_p() {
    let runs = 10;
    let steps = 20_000;
    let params = Params {
        controller: Controller::Mf,
        steps,
        babbling: 0,
        ..Params::default()
    };
    let configs = (0..runs)
        .map(|r| RunConfig {
            params,
            seed: 5,
            run_index: r,
        })
        .collect();
    let mut batch = Batch::new(Arc::new(equal_actions()), configs).unwrap();
    let runs = runs as usize;
    let (mut to_one, mut trials) = (0usize, 0usize);
    // (p, reward) of every second-stage arrival.
    let mut arrivals: Vec<(f64, f64)> = Vec::new();
    for t in 0..steps {
        let before: Vec<(u32, f64, Vec<f64>)> = (0..runs)
            .map(|r| {
                (
                    batch.cursors()[r].state,
                    batch.stats()[r].total_reward,
                    batch.task_state(r).to_vec(),
                )
            })
            .collect();
        batch.advance(1);
        for (r, (state, reward, p)) in before.into_iter().enumerate() {
            let cursor = batch.cursors()[r];
            assert!(!cursor.pending_reset);
            let after = batch.task_state(r);
            assert!(after.iter().all(|p| (P_MIN..=P_MAX).contains(p)));
            let expected = if t % 2 == 0 { 0 } else { 1 };
            assert_eq!(state == 0, expected == 0, "run {r} step {t}: state {state}");
            if state == 0 {
                assert!(cursor.state == 1 || cursor.state == 2);
                assert_eq!(after, &p[..], "p changes only after a trial");
                trials += 1;
                to_one += usize::from(cursor.state == 1);
            } else {
                assert_eq!(cursor.state, 0, "the trial ends in the first stage");
                assert_ne!(after, &p[..], "p drifts after every trial");
                let got = batch.stats()[r].total_reward - reward;
                arrivals.push((p[slot(state as usize, 0)], got));
            }
        }
    }
    assert_eq!(trials, runs * steps as usize / 2);
    let f = to_one as f64 / trials as f64;
    assert!((f - 0.7).abs() < 0.01, "common transitions {f}");
    for (what, keep) in [
        ("all", &(|_: f64| true) as &dyn Fn(f64) -> bool),
        ("p < 0.5", &|p| p < 0.5),
        ("p >= 0.5", &|p| p >= 0.5),
    ] {
        let kept: Vec<&(f64, f64)> = arrivals.iter().filter(|(p, _)| keep(*p)).collect();
        assert!(kept.len() > 20_000, "{what}: {}", kept.len());
        let n = kept.len() as f64;
        let p = kept.iter().map(|(p, _)| p).sum::<f64>() / n;
        let rate = kept.iter().map(|(_, r)| r).sum::<f64>() / n;
        assert!(
            (rate - p).abs() < 0.015,
            "{what}: reward rate {rate}, mean p {p}"
        );
    }
}

/// With babbling, the p are drawn afresh when the experiment starts: without drift
/// (`drift_sd` 0, a configured world) they stay as drawn through the 20 babbling steps and
/// change at the 20th, where the experiment starts, and then stay again.
#[test]
fn babbling_draws_the_p_afresh_at_the_experiment_start() {
    let params = Params {
        controller: Controller::Mb,
        steps: 10,
        babbling: 20,
        drift_sd: 0.0,
        ..Params::default()
    };
    let config = RunConfig {
        params,
        seed: 9,
        run_index: 0,
    };
    let spec = Arc::new(env::load("twostep").unwrap());
    let mut batch = Batch::new(spec, vec![config]).unwrap();
    let at_start = batch.task_state(0).to_vec();
    assert!(at_start.iter().all(|p| (P_MIN..=P_MAX).contains(p)));
    batch.advance(19);
    assert_eq!(batch.task_state(0), &at_start[..]);
    batch.advance(1);
    let fresh = batch.task_state(0).to_vec();
    assert!(
        fresh.iter().zip(&at_start).all(|(a, b)| a != b),
        "{fresh:?}"
    );
    assert!(fresh.iter().all(|p| (P_MIN..=P_MAX).contains(p)));
    batch.run_to_end();
    assert_eq!(batch.task_state(0), &fresh[..]);
}

#[test]
fn mbmf_run_twostep_writes_its_runs_with_the_task_parameters() {
    let dir = tempfile::tempdir().unwrap();
    common::run_quiet(
        dir.path(),
        &["--task", "twostep", "--controller", "mf,mb", "--runs", "20"],
    );
    let runs: Vec<common::Row> = common::rows(dir.path(), &[])
        .into_iter()
        .filter(|r| !r.contains_key("step"))
        .collect();
    assert_eq!(runs.len(), 40);
    for row in &runs {
        assert_eq!(row["steps"], "402");
        assert_eq!(row["babbling"], "0");
        assert_eq!(row["common_prob"], "0.7");
        assert_eq!(row["drift_sd"], "0.025");
        let reward: f64 = row["total_reward"].parse().unwrap();
        // 201 trials, each rewarded with a p in [0.25, 0.75].
        assert!((25.0..=176.0).contains(&reward), "{reward}");
    }
    for controller in ["mf", "mb"] {
        let mean = runs
            .iter()
            .filter(|r| r["controller"] == controller)
            .map(|r| r["total_reward"].parse::<f64>().unwrap())
            .sum::<f64>()
            / 20.0;
        assert!((70.0..=135.0).contains(&mean), "{controller}: {mean}");
    }
    // Interactions are refused.
    let out = common::run(&[
        "run",
        "--task",
        "twostep",
        "--interaction",
        "congratulation",
        "--budget",
        "5",
    ]);
    assert!(!out.status.success());
}

/// The stay columns (SPEC 13) end to end: in [0, 1] (the effects in [-1, 1]) and consistent
/// with each other for twostep runs, read back from the Parquet; null for tidy1 runs.
#[test]
fn mbmf_run_writes_stay_columns_for_twostep_and_nulls_for_tidy1() {
    let dir = tempfile::tempdir().unwrap();
    common::run_quiet(
        dir.path(),
        &[
            "--task",
            "twostep",
            "--controller",
            "mf,mb",
            "--runs",
            "5",
            "--lambda-mf",
            "1",
            "--tau",
            "0.2",
        ],
    );
    let runs = common::file_rows(&dir.path().join("runs.parquet"), &[]);
    assert_eq!(runs.len(), 10);
    let stays = ["stay_rc", "stay_rr", "stay_uc", "stay_ur"];
    for row in &runs {
        assert_eq!(row["lambda_mf"], "1.0");
        let v: Vec<f64> = stays.iter().map(|c| row[*c].parse().unwrap()).collect();
        assert!(v.iter().all(|p| (0.0..=1.0).contains(p)), "{row:?}");
        let reward: f64 = row["stay_reward_effect"].parse().unwrap();
        let interaction: f64 = row["stay_interaction"].parse().unwrap();
        assert!((reward - (v[0] + v[1] - v[2] - v[3]) / 2.0).abs() < 1e-12);
        assert!((interaction - (v[0] - v[1] - v[2] + v[3]) / 2.0).abs() < 1e-12);
    }

    let tidy = tempfile::tempdir().unwrap();
    common::run_quiet(
        tidy.path(),
        &["--controller", "mf", "--runs", "2", "--steps", "200"],
    );
    for row in common::file_rows(&tidy.path().join("runs.parquet"), &[]) {
        for c in stays
            .iter()
            .chain(&["stay_reward_effect", "stay_interaction"])
        {
            assert_eq!(row[*c], "null", "{c}");
        }
    }
    // The stay verb says what is wrong with a dataset of another task.
    let out = common::run(&["stay", tidy.path().to_str().unwrap(), "--by", "controller"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("no run has a stay probability"), "{err}");
    assert!(err.contains("mbmf run --task twostep"), "{err}");
}

/// `mbmf run` on the two-step task summarises each controller's reward effect and interaction
/// under its table and in `--json`, as the mean and sd of the runs' columns; other tasks show
/// neither.
#[test]
fn mbmf_run_summarises_the_two_step_signatures_per_controller() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ts");
    let args = |json: bool| {
        let mut a = vec![
            "run",
            "--task",
            "twostep",
            "--controller",
            "mf,mb",
            "--runs",
            "12",
            "--steps",
            "300",
            "--lambda-mf",
            "1",
            "--tau",
            "0.2",
            "--quiet",
            "--force",
            "--out",
            out.to_str().unwrap(),
        ];
        if json {
            a.push("--json");
        }
        a
    };
    let text = String::from_utf8(common::run_ok(&args(false)).stdout).unwrap();
    assert!(text.contains("two-step signatures"), "{text}");
    assert!(
        text.contains("reward effect") && text.contains("interaction"),
        "{text}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&common::run_ok(&args(true)).stdout).unwrap();
    let runs = common::file_rows(&out.join("runs.parquet"), &[]);
    for (k, controller) in ["mf", "mb"].into_iter().enumerate() {
        let entry = &report["controllers"][k];
        assert_eq!(entry["controller"], controller);
        for column in ["stay_reward_effect", "stay_interaction"] {
            let values: Vec<f64> = runs
                .iter()
                .filter(|r| r["controller"] == controller && r[column] != "null")
                .map(|r| r[column].parse().unwrap())
                .collect();
            assert!(values.len() >= 10, "{controller} {column}: {values:?}");
            let (mean, sd) = mean_sd(&values);
            let got = |key: &str| entry[format!("{column}_{key}")].as_f64().unwrap();
            assert!((got("mean") - mean).abs() < 1e-12, "{controller} {column}");
            assert!((got("sd") - sd).abs() < 1e-12, "{controller} {column}");
            // The table prints the same mean to three decimals on the controller's line.
            let line = text
                .lines()
                .rev()
                .find(|l| l.starts_with(&format!("{controller} ")))
                .unwrap();
            assert!(line.contains(&format!("{mean:.3} ± {sd:.3}")), "{line}");
        }
    }

    let tidy = dir.path().join("tidy");
    let o = common::run_ok(&[
        "run",
        "--controller",
        "mf",
        "--runs",
        "2",
        "--steps",
        "100",
        "--json",
        "--quiet",
        "--out",
        tidy.to_str().unwrap(),
    ]);
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        report["controllers"][0]
            .get("stay_reward_effect_mean")
            .is_none()
    );
}

/// `mbmf stay` on a small run: the table, the JSON (the same means as the runs' columns) and
/// the figure.
#[test]
fn mbmf_stay_prints_tests_and_draws_the_stay_figure() {
    let dir = tempfile::tempdir().unwrap();
    common::run_quiet(
        dir.path(),
        &[
            "--task",
            "twostep",
            "--controller",
            "mf,mb",
            "--runs",
            "8",
            "--steps",
            "600",
            "--tau",
            "0.2",
        ],
    );
    let data = dir.path().to_str().unwrap();
    let out = common::run_ok(&["stay", data, "--by", "controller"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("reward effect") && text.contains("interaction"),
        "{text}"
    );
    assert!(
        text.lines()
            .any(|l| l.starts_with("stay_interaction") && l.contains("mb") && l.contains("mf")),
        "{text}"
    );
    let figure = dir.path().join("analysis");
    // Named by the groups (another --by or --where writes another figure).
    for f in ["stay-by-controller.svg", "stay-by-controller.png"] {
        assert!(figure.join(f).metadata().unwrap().len() > 1000, "{f}");
    }
    let svg = std::fs::read_to_string(figure.join("stay-by-controller.svg")).unwrap();
    assert!(svg.contains("controller=mb") && svg.contains("unrewarded"));

    let figures = tempfile::tempdir().unwrap();
    let out = common::run_ok(&[
        "stay",
        data,
        "--by",
        "controller",
        "--json",
        "--out",
        figures.path().to_str().unwrap(),
    ]);
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["verb"], "stay");
    let groups = json["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 2);
    let runs = common::file_rows(&dir.path().join("runs.parquet"), &[]);
    for g in groups {
        let controller = g["value"].as_str().unwrap();
        assert_eq!(g["runs"], 8);
        let values: Vec<f64> = runs
            .iter()
            .filter(|r| r["controller"] == controller)
            .map(|r| r["stay_interaction"].parse().unwrap())
            .collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let reported = g["columns"]["stay_interaction"]["mean"].as_f64().unwrap();
        assert!((reported - mean).abs() < 1e-12, "{controller}");
        assert!(g["columns"]["stay_rc"]["ci95"].as_f64().unwrap() > 0.0);
    }
    // Six columns, one pair of groups each; MB's interaction (about 0.3 here) is far above
    // MF's (about 0), so its test is significant even with 8 runs against 8.
    let pairs = json["pairs"].as_array().unwrap();
    assert_eq!(pairs.len(), 6);
    let interaction = pairs
        .iter()
        .find(|p| p["column"] == "stay_interaction")
        .unwrap();
    assert!(interaction["p"].as_f64().unwrap() < 0.01, "{interaction}");
    assert_eq!(json["files"].as_array().unwrap().len(), 2);
    assert!(figures.path().join("stay-by-controller.png").exists());
}

/// `lambda_mf` > 0 with `vpi` is refused, naming both (SPEC 12.4), on the command line and in a
/// sweep file.
#[test]
fn an_eligibility_trace_with_vpi_is_refused_naming_both() {
    let out = common::run(&["run", "--controller", "vpi", "--lambda-mf", "0.5"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--lambda-mf 0.5 cannot be used with --controller vpi"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let file = common::write_sweep(
        dir.path(),
        "s.toml",
        "seeds = 1\n[fixed]\ntask = \"twostep\"\n[grid]\ncontroller = [\"mf\", \"vpi\"]\nlambda_mf = [0.0, 1.0]\n",
    );
    let out = common::run(&[
        "sweep",
        &file,
        "--out",
        dir.path().join("o").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("lambda_mf = 1 cannot be used with controller = vpi"),
        "{err}"
    );
}
