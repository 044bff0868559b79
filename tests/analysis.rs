//! The analysis verbs end to end: `mbmf pareto`, `mbmf stats` and `mbmf min-budget` on small
//! synthetic datasets with known answers (written with the crate's own Parquet columns) and on
//! datasets made by the real binary, in both layouts (`mbmf run` and `mbmf sweep`).
//!
//! Reference p-values come from scipy 1.17 (`scipy.stats.mannwhitneyu`, method 'auto') and
//! statsmodels (`multipletests(..., method='holm')`); the script is quoted beside each value.

mod common;

use std::path::Path;
use std::process::Output;

use assert_cmd::Command;
use mbmf::analysis::compare;
use mbmf::analysis::dataset::{self, Table, Value};
use mbmf::analysis::min_budget;
use mbmf::analysis::pareto::{Direction, dominates};
use mbmf::batch::RunConfig;
use mbmf::output::{Columns, param_columns, write_parquet};
use mbmf::params::{Controller, Interaction, Params, Profile};

fn mbmf() -> Command {
    Command::new(env!("CARGO_BIN_EXE_mbmf"))
}

fn run_ok(args: &[&str]) -> String {
    let out: Output = mbmf().args(args).output().expect("the binary runs");
    assert!(
        out.status.success(),
        "mbmf {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8 output")
}

/// Runs mbmf expecting a usage error (exit 2); returns stderr.
fn run_usage_error(args: &[&str]) -> String {
    let out = mbmf().args(args).output().expect("the binary runs");
    assert_eq!(
        out.status.code(),
        Some(2),
        "mbmf {} should fail with a usage error; stdout: {}",
        args.join(" "),
        String::from_utf8_lossy(&out.stdout)
    );
    String::from_utf8(out.stderr).expect("utf-8 output")
}

/// One synthetic run: its parameters and the results the analyses read.
struct Run {
    params: Params,
    reward: f64,
    cost: f64,
    entropy: Option<f64>,
}

fn params(controller: Controller, kappa: f64) -> Params {
    Params {
        controller,
        kappa_coeff: kappa,
        ..Params::default()
    }
}

fn human(controller: Controller, interaction: Interaction, budget: u32) -> Params {
    let mut p = params(controller, 9.0);
    p.human.interaction = interaction;
    p.human.budget = budget;
    p.profile = if interaction == Interaction::None {
        Profile::None
    } else {
        Profile::Custom
    };
    p
}

/// Writes `runs` as `path` with exactly the parameter columns `mbmf run` writes.
fn write_runs(path: &Path, runs: &[Run]) {
    let configs: Vec<RunConfig> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| RunConfig {
            params: r.params,
            seed: 1,
            run_index: i as u64,
        })
        .collect();
    let mut cols = Columns::default();
    param_columns(&mut cols, "tidy1", configs.iter());
    cols.f64("total_reward", runs.iter().map(|r| r.reward));
    cols.f64("reward_last10", runs.iter().map(|r| r.reward / 10.0));
    cols.f64("cost_total", runs.iter().map(|r| r.cost));
    cols.opt_f64("mean_entropy_chosen", runs.iter().map(|r| r.entropy));
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    write_parquet(path, &cols.finish().unwrap(), vec![]).unwrap();
}

fn floats(table: &Table, name: &str) -> Vec<Option<f64>> {
    table.numeric(name, "the test").unwrap()
}

fn bools(table: &Table, name: &str) -> Vec<bool> {
    let column = table.column(name).unwrap();
    (0..column.len())
        .map(|i| match column.value(i) {
            Value::Bool(b) => b,
            other => panic!("{name} holds {other}, not a boolean"),
        })
        .collect()
}

/// Whether some line of `text` has exactly the whitespace-separated cells of `row`.
fn has_row(text: &str, row: &str) -> bool {
    let want: Vec<&str> = row.split_whitespace().collect();
    text.lines()
        .any(|l| l.split_whitespace().collect::<Vec<_>>() == want)
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1e-12)
}

// ---------------------------------------------------------------------------------------------
// pareto

/// Six kappas of EC with two seeds each (reward r - 1 and r + 1, so the mean is r), plus kappa
/// 7 whose runs made no decision (entropy missing) but would dominate everything.
///
/// Front by construction: kappas 1, 2, 4, 6; kappa 3 is dominated by 2 and kappa 5 by 4.
fn front_runs() -> Vec<Run> {
    let configs = [
        (1.0, 10.0, 100.0, Some(0.5)),
        (2.0, 20.0, 200.0, Some(0.5)),
        (3.0, 15.0, 250.0, Some(0.6)),
        (4.0, 30.0, 400.0, Some(0.4)),
        (5.0, 25.0, 500.0, Some(0.45)),
        (6.0, 5.0, 90.0, Some(0.9)),
        (7.0, 100.0, 10.0, None),
    ];
    let mut runs = Vec::new();
    for (kappa, reward, cost, entropy) in configs {
        for delta in [-1.0, 1.0] {
            runs.push(Run {
                params: params(Controller::Ec, kappa),
                reward: reward + delta,
                cost,
                entropy,
            });
        }
    }
    runs
}

#[test]
fn pareto_front_holds_exactly_the_non_dominated_configurations_and_the_knee() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &front_runs());
    let stdout = run_ok(&["pareto", dir.path().to_str().unwrap()]);

    let table = dataset::read_parquet_file(&dir.path().join("analysis/pareto.parquet")).unwrap();
    assert_eq!(table.len(), 7, "one row per configuration");
    let kappa = floats(&table, "kappa_coeff");
    let reward = floats(&table, "total_reward_mean");
    let cost = floats(&table, "cost_total_mean");
    let entropy = floats(&table, "mean_entropy_chosen_mean");
    let front = bools(&table, "front");
    let knee = bools(&table, "knee");
    let rank = floats(&table, "rank");

    let dirs = [
        Direction::Maximize,
        Direction::Minimize,
        Direction::Minimize,
    ];
    let ranked: Vec<usize> = (0..7).filter(|&i| entropy[i].is_some()).collect();
    let point = |i: usize| [reward[i].unwrap(), cost[i].unwrap(), entropy[i].unwrap()];
    for &i in &ranked {
        let dominated = ranked
            .iter()
            .any(|&j| dominates(&point(j), &point(i), &dirs));
        assert_eq!(
            front[i], !dominated,
            "kappa {:?}: front flag disagrees with an independent dominance check",
            kappa[i]
        );
    }
    let on_front: Vec<f64> = (0..7)
        .filter(|&i| front[i])
        .map(|i| kappa[i].unwrap())
        .collect();
    assert_eq!(on_front, [1.0, 2.0, 4.0, 6.0]);
    assert_eq!(rank[2], Some(1.0), "kappa 3 is dominated by a front point");
    assert_eq!(rank[4], Some(1.0), "kappa 5 is dominated by a front point");
    assert_eq!(
        (rank[6], front[6]),
        (None, false),
        "a configuration without entropy is left out, not put on the front"
    );
    // Hand computation of the knee (normalised over the front: reward 5..30, cost 90..400,
    // entropy 0.4..0.9): squared distances to the ideal are 0.681 (kappa 1), 0.326 (kappa 2),
    // 1 (kappa 4) and 2 (kappa 6).
    let knees: Vec<usize> = (0..7).filter(|&i| knee[i]).collect();
    assert_eq!(knees.len(), 1);
    assert!(front[knees[0]], "the knee is on the front");
    assert_eq!(kappa[knees[0]], Some(2.0));
    assert_eq!(reward[1], Some(20.0), "the mean over seeds");
    assert_eq!(floats(&table, "n")[1], Some(2.0));

    assert!(
        stdout.contains("7 configurations; 4 on the Pareto front"),
        "{stdout}"
    );
    assert!(
        stdout.contains("knee (suggested): kappa_coeff=2"),
        "{stdout}"
    );
    assert!(stdout.contains("1 configurations lack a mean"), "{stdout}");
    for ext in ["svg", "png"] {
        let figure = dir.path().join(format!("analysis/pareto.{ext}"));
        assert!(std::fs::metadata(&figure).unwrap().len() > 1000, "{ext}");
    }
    let svg = std::fs::read_to_string(dir.path().join("analysis/pareto.svg")).unwrap();
    // Points are coloured by the swept kappa (named over the colour bar), so a label is the
    // bare value.
    assert!(
        svg.contains("\nknee (2)\n") && svg.contains("\nkappa_coeff\n"),
        "knee, labels and colour bar drawn"
    );
}

#[test]
fn pareto_objectives_can_be_any_numeric_columns() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &front_runs());
    let out = dir.path().join("analysis");
    run_ok(&[
        "pareto",
        dir.path().to_str().unwrap(),
        "--objectives",
        "total_reward:max,cost_total:min",
        "--out",
        out.to_str().unwrap(),
        "--no-plot",
    ]);
    // Named by its objectives: another choice of them writes another file.
    let table =
        dataset::read_parquet_file(&out.join("pareto-total_reward.max-cost_total.min.parquet"))
            .unwrap();
    let kappa = floats(&table, "kappa_coeff");
    let front = bools(&table, "front");
    // On reward and cost alone, kappa 7 (reward 100, cost 10) dominates every other point.
    let on_front: Vec<f64> = (0..7)
        .filter(|&i| front[i])
        .map(|i| kappa[i].unwrap())
        .collect();
    assert_eq!(on_front, [7.0]);
    assert!(
        !out.join("pareto.svg").exists(),
        "--no-plot writes no figure"
    );
}

#[test]
fn pareto_confidence_intervals_match_a_hand_computation() {
    // Five rewards of one configuration: mean 102.12; sd = 5.7363..., t_{0.975,4} = 2.776445,
    // half-width = t * sd / sqrt(5) = 7.122217596850863 (scipy.stats.t.ppf).
    let rewards = [101.5, 98.2, 110.3, 95.7, 104.9];
    let mut runs: Vec<Run> = rewards
        .iter()
        .map(|&r| Run {
            params: params(Controller::Mf, 9.0),
            reward: r,
            cost: 7.0,
            entropy: Some(0.5),
        })
        .collect();
    runs.push(Run {
        params: params(Controller::Mb, 9.0),
        reward: 1.0,
        cost: 1.0,
        entropy: Some(0.5),
    });
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &runs);
    run_ok(&["pareto", dir.path().to_str().unwrap(), "--no-plot"]);
    let table = dataset::read_parquet_file(&dir.path().join("analysis/pareto.parquet")).unwrap();
    let controller = table.column("controller").unwrap();
    let mf = (0..table.len())
        .find(|&i| controller.value(i) == Value::Str("mf".into()))
        .unwrap();
    let mean = floats(&table, "total_reward_mean")[mf].unwrap();
    let ci = floats(&table, "total_reward_ci95")[mf].unwrap();
    assert!(close(mean, 102.12), "{mean}");
    assert!(close(ci, 7.122217596850863), "{ci}");
    assert_eq!(
        floats(&table, "cost_total_ci95")[mf],
        Some(0.0),
        "constant values"
    );
    let mb = 1 - mf;
    assert_eq!(
        floats(&table, "total_reward_ci95")[mb],
        None,
        "one run has no interval"
    );
}

#[test]
fn pareto_reads_real_runs_in_the_run_and_the_sweep_layouts_alike() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    for kappa in ["3", "9"] {
        let out = root.join(format!("k{kappa}"));
        run_ok(&[
            "run",
            "--controller",
            "mf,ec",
            "--runs",
            "3",
            "--steps",
            "200",
            "--babbling",
            "50",
            "--kappa-coeff",
            kappa,
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
    }
    // The sweep layout: DIR/runs/part-*.parquet.
    let sweep = root.join("sweep");
    std::fs::create_dir_all(sweep.join("runs")).unwrap();
    for (i, kappa) in ["3", "9"].iter().enumerate() {
        std::fs::copy(
            root.join(format!("k{kappa}/runs.parquet")),
            sweep.join(format!("runs/part-{i:05}.parquet")),
        )
        .unwrap();
    }
    let stdout = run_ok(&["pareto", sweep.to_str().unwrap()]);
    assert!(stdout.contains("12 runs in 4 configurations"), "{stdout}");
    assert!(
        stdout.contains("controller") && stdout.contains("kappa_coeff"),
        "the varying parameters lead the table: {stdout}"
    );
    let table = dataset::read_parquet_file(&sweep.join("analysis/pareto.parquet")).unwrap();
    assert_eq!(table.len(), 4);
    assert!(floats(&table, "n").iter().all(|n| *n == Some(3.0)));
    assert!(bools(&table, "knee").iter().filter(|k| **k).count() == 1);

    // The run layout reads the same runs: one folder of two kappas equals half the sweep.
    let single = run_ok(&["pareto", root.join("k3").to_str().unwrap(), "--no-plot"]);
    assert!(single.contains("6 runs in 2 configurations"), "{single}");
    // Rerunning on the sweep reads the runs only: the outputs are in their own folder.
    let again = run_ok(&["pareto", sweep.join("runs").to_str().unwrap(), "--no-plot"]);
    let again2 = run_ok(&["pareto", sweep.to_str().unwrap(), "--no-plot"]);
    assert!(again.contains("12 runs in 4 configurations"), "{again}");
    assert!(again2.contains("12 runs in 4 configurations"), "{again2}");
}

// ---------------------------------------------------------------------------------------------
// stats

/// Rewards by kappa without ties (exact test) and by controller with ties (normal test).
fn stats_runs() -> Vec<Run> {
    let mut runs = Vec::new();
    let by_kappa: [(f64, &[f64]); 3] = [
        (3.0, &[101.5, 98.2, 110.3, 95.7, 104.9]),
        (9.0, &[112.4, 108.8, 120.1, 99.3, 115.6, 118.0]),
        (15.0, &[97.1, 93.4, 105.2, 90.8, 100.6]),
    ];
    for (kappa, rewards) in by_kappa {
        for &reward in rewards {
            runs.push(Run {
                params: params(Controller::Ec, kappa),
                reward,
                cost: 1.0,
                entropy: Some(0.5),
            });
        }
    }
    let by_controller: [(Controller, &[f64]); 3] = [
        (Controller::Ec, &[13., 14., 12., 15., 16., 13., 11., 14.]),
        (
            Controller::Mb,
            &[18., 20., 17., 15., 19., 21., 16., 18., 22., 17.],
        ),
        (
            Controller::Mf,
            &[12., 15., 9., 14., 11., 13., 10., 16., 12., 14.],
        ),
    ];
    for (controller, rewards) in by_controller {
        for &reward in rewards {
            runs.push(Run {
                params: params(controller, 1.0),
                reward,
                cost: 1.0,
                entropy: Some(0.5),
            });
        }
    }
    runs
}

#[test]
fn stats_exact_p_values_and_holm_match_scipy() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("runs.parquet");
    write_runs(&path, &stats_runs());
    let table = dataset::read_runs(dir.path()).unwrap();
    let table =
        dataset::Filter::apply_all(&table, &[dataset::Filter::parse("controller=ec").unwrap()])
            .unwrap();
    let table = table.take(
        &(0..table.len())
            .filter(|&i| table.column("kappa_coeff").unwrap().f64_at(i) != Some(1.0))
            .collect::<Vec<_>>(),
    );
    let c = compare::compare(&table, "kappa_coeff", "total_reward").unwrap();
    // scipy: mannwhitneyu(a, b, alternative='two-sided') for (3, 9), (3, 15), (9, 15);
    // statsmodels multipletests(p, method='holm').
    let expected = [
        (4.0, 0.05194805194805195, 0.1038961038961039),
        (18.0, 0.30952380952380953, 0.30952380952380953),
        (28.0, 0.017316017316017316, 0.05194805194805195),
    ];
    assert_eq!(c.pairs.len(), 3);
    for (pair, (u, p, holm)) in c.pairs.iter().zip(expected) {
        assert_eq!(pair.test.method, mbmf::analysis::stats::Method::Exact);
        assert_eq!(pair.test.u, u);
        assert!(close(pair.test.p_value, p), "{} vs {p}", pair.test.p_value);
        assert!(close(pair.p_holm, holm), "{} vs {holm}", pair.p_holm);
    }
    let groups: Vec<String> = c.groups.iter().map(|g| g.value.to_string()).collect();
    assert_eq!(groups, ["3", "9", "15"], "groups in numeric order");
    assert!(close(c.pairs[0].test.effect_size, 2.0 * 4.0 / 30.0 - 1.0));
}

#[test]
fn stats_normal_approximation_with_ties_matches_scipy_through_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &stats_runs());
    let d = dir.path().to_str().unwrap();
    let stdout = run_ok(&[
        "stats",
        d,
        "--by",
        "controller",
        "--metric",
        "total_reward",
        "--where",
        "kappa_coeff=1",
    ]);
    // scipy (ties, so the tie-corrected normal approximation):
    // ec vs mb: U=2.0 p=0.0008307934516774577 holm=0.0016615869033549154
    // ec vs mf: U=49.5 p=0.4188145532656513 holm=0.4188145532656513
    // mb vs mf: U=98.0 p=0.00031970214768035134 holm=0.0009591064430410541
    for row in [
        "ec mb 2.000 0.0008 0.0017 ** -0.950 normal",
        "ec mf 49.50 0.4188 0.4188 +0.238 normal",
        "mb mf 98.00 0.0003 0.0010 *** +0.960 normal",
    ] {
        assert!(has_row(&stdout, row), "missing `{row}` in:\n{stdout}");
    }
    assert!(stdout.contains("Holm-corrected over 3 pairs"), "{stdout}");
    assert!(
        !stdout.contains("also vary"),
        "the filter removes the mix: {stdout}"
    );

    let table = dataset::read_runs(dir.path()).unwrap();
    let table =
        dataset::Filter::apply_all(&table, &[dataset::Filter::parse("kappa_coeff=1").unwrap()])
            .unwrap();
    let c = compare::compare(&table, "controller", "total_reward").unwrap();
    let expected = [
        (0.0008307934516774577, 0.0016615869033549154),
        (0.4188145532656513, 0.4188145532656513),
        (0.00031970214768035134, 0.0009591064430410541),
    ];
    for (pair, (p, holm)) in c.pairs.iter().zip(expected) {
        assert!(close(pair.test.p_value, p), "{} vs {p}", pair.test.p_value);
        assert!(close(pair.p_holm, holm), "{} vs {holm}", pair.p_holm);
    }
    assert_eq!((c.groups[0].n, c.groups[1].n, c.groups[2].n), (8, 10, 10));
}

#[test]
fn stats_says_when_other_parameters_vary_within_groups() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &stats_runs());
    let stdout = run_ok(&["stats", dir.path().to_str().unwrap(), "--by", "controller"]);
    assert!(
        stdout.contains("within groups these parameters also vary: kappa_coeff"),
        "{stdout}"
    );
}

// ---------------------------------------------------------------------------------------------
// min-budget

/// EC with takeover: budget 0 stored as interaction none, then 10, 50, 100; the answer is 50
/// (100 is not significantly above it). MF with congratulation: 0 (none), 100, 300, 500; the
/// answer is 100, and the rule is not monotone there (300 is beaten by 500).
fn budget_runs() -> Vec<Run> {
    let ec: [(Interaction, u32, &[f64]); 4] = [
        (
            Interaction::None,
            0,
            &[10., 12., 11., 9., 13., 10., 12., 11.],
        ),
        (
            Interaction::Takeover,
            10,
            &[14., 15., 13., 16., 12., 15., 14., 13.],
        ),
        (
            Interaction::Takeover,
            50,
            &[20., 22., 19., 21., 23., 20., 18., 22.],
        ),
        (
            Interaction::Takeover,
            100,
            &[21., 20., 22., 19., 23., 21., 20., 22.],
        ),
    ];
    let mf: [(Interaction, u32, &[f64]); 4] = [
        (
            Interaction::None,
            0,
            &[30., 31., 29., 32., 30., 28., 31., 30.],
        ),
        (
            Interaction::Congratulation,
            100,
            &[35., 50., 38., 48., 36., 47., 40., 45.],
        ),
        (
            Interaction::Congratulation,
            300,
            &[33., 34., 32., 35., 31., 33., 34., 32.],
        ),
        (
            Interaction::Congratulation,
            500,
            &[44., 45., 43., 46., 42., 44., 45., 47.],
        ),
    ];
    let mut runs = Vec::new();
    for (controller, levels) in [(Controller::Ec, ec), (Controller::Mf, mf)] {
        for (interaction, budget, rewards) in levels {
            for &reward in rewards {
                runs.push(Run {
                    params: human(controller, interaction, budget),
                    reward,
                    cost: 1.0,
                    entropy: Some(0.5),
                });
            }
        }
    }
    runs
}

#[test]
fn min_budget_finds_the_known_answer_with_scipy_p_values() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &budget_runs());
    let table = dataset::read_runs(dir.path()).unwrap();
    let r = min_budget::min_budget(&table, "total_reward", 0.05).unwrap();
    assert_eq!(r.groups.len(), 2);
    let ec = &r.groups[0];
    assert_eq!(r.key_value(0, "controller"), Some(&Value::Str("ec".into())));
    assert_eq!(
        r.key_value(0, "interaction"),
        Some(&Value::Str("takeover".into()))
    );
    let budgets: Vec<u64> = ec.levels.iter().map(|l| l.budget).collect();
    assert_eq!(
        budgets,
        [0, 10, 50, 100],
        "budget 0 comes from the interaction none runs"
    );
    assert_eq!(ec.chosen_budget(), 50);
    assert!(ec.not_monotone.is_empty());
    // scipy: mannwhitneyu(larger, smaller, alternative='greater').
    let expected_ec = [
        (0, 10, 0.0012644446734033474),
        (0, 50, 0.00044945639405704485),
        (0, 100, 0.0004455079537932495),
        (10, 50, 0.00044945639405704485),
        (10, 100, 0.0004455079537932495),
        (50, 100, 0.35390132721824974),
    ];
    check_p_values(ec, &expected_ec);

    let mf = &r.groups[1];
    assert_eq!(
        r.key_value(1, "interaction"),
        Some(&Value::Str("congratulation".into()))
    );
    assert_eq!(mf.chosen_budget(), 100);
    assert_eq!(
        mf.not_monotone,
        [300],
        "300 is beaten by 500 although 100 is not"
    );
    assert_eq!(mf.levels[mf.best].budget, 500);
    let expected_mf = [
        (0, 100, 0.00044945639405704485),
        (0, 300, 0.0012456585162246333),
        (0, 500, 0.00044158299742634485),
        (100, 300, 0.9996249770915807),
        (100, 500, 0.3758258296585855),
        (300, 500, 0.00044945639405704485),
    ];
    check_p_values(mf, &expected_mf);
    let hundred = &mf.levels[1];
    assert!(!hundred.vs_larger[0].higher_mean && !hundred.vs_larger[0].beats);
}

fn check_p_values(group: &min_budget::BudgetGroup, expected: &[(u64, u64, f64)]) {
    for &(small, large, p) in expected {
        let level = group.levels.iter().find(|l| l.budget == small).unwrap();
        let v = level.vs_larger.iter().find(|v| v.budget == large).unwrap();
        assert!(
            close(v.p_value, p),
            "{large} > {small}: {} vs {p}",
            v.p_value
        );
    }
}

#[test]
fn min_budget_prints_the_table_and_writes_parquet() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &budget_runs());
    let stdout = run_ok(&["min-budget", dir.path().to_str().unwrap()]);
    for row in [
        "tidy1 ec takeover 0,10,50,100 50 20.62 100 21.00 100: 0.3539",
        "tidy1 mf congratulation 0,100,300,500 100 42.38 500 44.50 300: 0.9996, 500: 0.3758",
    ] {
        assert!(has_row(&stdout, row), "missing `{row}` in:\n{stdout}");
    }
    assert!(
        stdout.contains("not monotone for tidy1 mf congratulation: above the minimal budget 100, 300 is beaten by 500 (p = 0.0004)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("no multiple-comparison correction"),
        "{stdout}"
    );

    let table =
        dataset::read_parquet_file(&dir.path().join("analysis/min_budget.parquet")).unwrap();
    assert_eq!(table.len(), 8, "one row per group and budget");
    let chosen = bools(&table, "chosen");
    let budget = floats(&table, "budget");
    let picked: Vec<f64> = (0..8)
        .filter(|&i| chosen[i])
        .map(|i| budget[i].unwrap())
        .collect();
    assert_eq!(picked, [50.0, 100.0]);
    let monotone = bools(&table, "monotone");
    assert_eq!(
        monotone,
        [true, true, true, true, false, false, false, false]
    );
    assert_eq!(
        table.column("beaten_by").unwrap().value(4),
        Value::Str("100,300,500".into()),
        "budget 0 of mf is beaten by every larger budget"
    );
}

#[test]
fn min_budget_uses_reward_last10_when_asked() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &budget_runs());
    let stdout = run_ok(&[
        "min-budget",
        dir.path().to_str().unwrap(),
        "--metric",
        "reward_last10",
    ]);
    assert!(
        stdout.contains("minimal budget of reward_last10"),
        "{stdout}"
    );
}

#[test]
fn min_budget_shares_the_none_runs_among_every_interaction_type() {
    let mut runs = Vec::new();
    for (interaction, budget, base) in [
        (Interaction::None, 0, 10.0),
        (Interaction::Takeover, 10, 20.0),
        (Interaction::Congratulation, 10, 30.0),
        (Interaction::Takeover, 0, 12.0),
    ] {
        for k in 0..4 {
            runs.push(Run {
                params: human(Controller::Ec, interaction, budget),
                reward: base + k as f64,
                cost: 1.0,
                entropy: Some(0.5),
            });
        }
    }
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &runs);
    let table = dataset::read_runs(dir.path()).unwrap();
    let r = min_budget::min_budget(&table, "total_reward", 0.05).unwrap();
    assert_eq!(r.groups.len(), 2, "congratulation and takeover");
    for g in &r.groups {
        assert_eq!(g.levels[0].budget, 0);
        assert_eq!(
            g.levels[0].n, 8,
            "the 4 none runs and the 4 takeover runs with budget 0 form budget 0"
        );
    }
}

#[test]
fn min_budget_runs_on_datasets_of_the_real_binary() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    let common = [
        "run",
        "--controller",
        "mf",
        "--runs",
        "3",
        "--steps",
        "200",
        "--babbling",
        "50",
        "--quiet",
    ];
    let sweep = root.join("sweep");
    std::fs::create_dir_all(sweep.join("runs")).unwrap();
    for (i, extra) in [&[][..], &["--interaction", "takeover", "--budget", "5"][..]]
        .iter()
        .enumerate()
    {
        let out = root.join(format!("r{i}"));
        let mut args: Vec<&str> = common.to_vec();
        args.extend_from_slice(extra);
        args.extend(["--out", out.to_str().unwrap()]);
        run_ok(&args);
        std::fs::copy(
            out.join("runs.parquet"),
            sweep.join(format!("runs/part-{i:05}.parquet")),
        )
        .unwrap();
    }
    let stdout = run_ok(&["min-budget", sweep.to_str().unwrap()]);
    assert!(stdout.contains("mf          takeover"), "{stdout}");
    let table = dataset::read_parquet_file(&sweep.join("analysis/min_budget.parquet")).unwrap();
    assert_eq!(floats(&table, "budget"), [Some(0.0), Some(5.0)]);
    assert_eq!(floats(&table, "n"), [Some(3.0), Some(3.0)]);
}

// ---------------------------------------------------------------------------------------------
// errors

#[test]
fn errors_name_the_input_and_what_would_be_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_runs(&d.join("data/runs.parquet"), &stats_runs());
    let data = d.join("data");
    let data = data.to_str().unwrap();

    let e = run_usage_error(&["stats", data, "--by", "kapa", "--metric", "total_reward"]);
    assert!(
        e.contains("has no column 'kapa' (did you mean 'kappa_coeff'?)")
            && e.contains("Available columns: run_index, master_seed, task"),
        "{e}"
    );
    let e = run_usage_error(&[
        "pareto",
        data,
        "--objectives",
        "total_reward:max,cost_totl:min",
    ]);
    assert!(
        e.contains("'cost_totl' (did you mean 'cost_total'?)"),
        "{e}"
    );
    let e = run_usage_error(&["pareto", data, "--objectives", "total_reward:best"]);
    assert!(e.contains("max, min, maximize or minimize"), "{e}");
    let e = run_usage_error(&["stats", data, "--by", "controller", "--metric", "task"]);
    assert!(
        e.contains("column 'task' holds text, but --metric needs numbers; numeric columns:"),
        "{e}"
    );
    let e = run_usage_error(&["stats", data, "--by", "task"]);
    assert!(e.contains("--by task gives one group (tidy1)"), "{e}");
    let e = run_usage_error(&[
        "stats",
        data,
        "--by",
        "controller",
        "--where",
        "controller=rnd",
    ]);
    assert!(
        e.contains("no run matches --where 'controller=rnd'; values of 'controller' in the data: ec, mb, mf"),
        "{e}"
    );
    let e = run_usage_error(&["stats", data, "--by", "controller", "--where", "controller"]);
    assert!(e.contains("expected COLUMN=VALUE"), "{e}");
    let e = run_usage_error(&["min-budget", data]);
    assert!(
        e.contains("no run has an interaction type other than none"),
        "{e}"
    );
    let e = run_usage_error(&["min-budget", data, "--alpha", "1.5"]);
    assert!(e.contains("invalid --alpha 1.5"), "{e}");

    let missing = d.join("nowhere");
    let e = run_usage_error(&["pareto", missing.to_str().unwrap()]);
    assert!(
        e.contains("nowhere: no such file or folder")
            && e.contains("DIR/runs.parquet")
            && e.contains("DIR/runs/part-*.parquet"),
        "{e}"
    );
    let other = d.join("other");
    std::fs::create_dir_all(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "x").unwrap();
    let e = run_usage_error(&["pareto", other.to_str().unwrap()]);
    assert!(e.contains("the folder holds notes.txt"), "{e}");
    std::fs::write(other.join("runs.parquet"), "not parquet").unwrap();
    let e = run_usage_error(&["pareto", other.to_str().unwrap()]);
    assert!(
        e.contains("runs.parquet is not a readable Parquet file"),
        "{e}"
    );
}

#[test]
fn the_verbs_read_a_dataset_written_by_mbmf_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("budgets.toml");
    std::fs::write(
        &file,
        "seeds = 3\n[fixed]\ntask = \"tidy1\"\nsteps = 200\nbabbling = 50\n\
         interaction = \"takeover\"\n[grid]\ncontroller = [\"mf\", \"ec\"]\nbudget = [0, 5]\n",
    )
    .unwrap();
    let out = dir.path().join("sweep");
    run_ok(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let d = out.to_str().unwrap();

    let stdout = run_ok(&["pareto", d, "--no-plot"]);
    assert!(stdout.contains("12 runs in 4 configurations"), "{stdout}");
    let table = dataset::read_parquet_file(&out.join("analysis/pareto.parquet")).unwrap();
    assert!(
        !table.has("config_index_mean") && !table.has("seed_index_mean"),
        "the sweep's identity columns are neither keys nor metrics: {:?}",
        table.names()
    );

    let stdout = run_ok(&["min-budget", d]);
    let starts = |l: &str| {
        l.split_whitespace()
            .take(4)
            .eq(["tidy1", "ec", "takeover", "0,5"])
    };
    assert!(stdout.lines().any(starts), "{stdout}");
    let table = dataset::read_parquet_file(&out.join("analysis/min_budget.parquet")).unwrap();
    assert_eq!(floats(&table, "n"), [Some(3.0); 4]);

    let stdout = run_ok(&["stats", d, "--by", "budget", "--where", "controller=mf"]);
    assert!(stdout.contains("Holm-corrected over 1 pair)"), "{stdout}");
}

// ---------------------------------------------------------------------------------------------
// integrity: what a dataset committed, and only that

/// A sweep of 12 runs (two controllers, two budgets, three seeds) into `root/name`, written in
/// parts of `batch` runs; `master_seed` makes a different sweep of the same size.
fn small_sweep(root: &Path, name: &str, batch: &str, master_seed: u32) -> std::path::PathBuf {
    let file = root.join(format!("{name}.toml"));
    std::fs::write(
        &file,
        format!(
            "seeds = 3\nmaster_seed = {master_seed}\n[fixed]\ntask = \"tidy1\"\nsteps = 200\n\
             babbling = 50\ninteraction = \"takeover\"\n[grid]\ncontroller = [\"mf\", \"ec\"]\n\
             budget = [0, 5]\n"
        ),
    )
    .unwrap();
    let out = root.join(name);
    run_ok(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--batch-size",
        batch,
        "--quiet",
    ]);
    out
}

/// Runs mbmf; returns (exit code, stdout, stderr).
fn run_any(args: &[&str]) -> (Option<i32>, String, String) {
    let out = mbmf().args(args).output().expect("the binary runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn part_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("part-"))
        .collect();
    names.sort();
    names
}

/// The three verbs' standard output on `d` (without figures), to compare datasets.
fn verb_outputs(d: &str) -> [(String, String); 3] {
    let verbs: [&[&str]; 3] = [
        &["pareto", d, "--no-plot"],
        &["min-budget", d],
        &["stats", d, "--by", "budget", "--where", "controller=mf"],
    ];
    verbs.map(|args| {
        let (code, stdout, stderr) = run_any(args);
        assert_eq!(code, Some(0), "mbmf {}: {stderr}", args.join(" "));
        (stdout, stderr)
    })
}

#[test]
fn stray_copies_in_a_sweep_are_left_out_with_a_warning_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_sweep(dir.path(), "s", "3", 1);
    let d = out.to_str().unwrap();
    let before = verb_outputs(d);
    for (_, stderr) in &before {
        assert!(!stderr.contains("warning"), "a clean sweep warns: {stderr}");
    }
    let runs = out.join("runs");
    let first = &part_names(&runs)[0];
    let copy = runs.join(first.replace(".parquet", " (1).parquet"));
    let other = runs.join("runs copy.parquet");
    std::fs::copy(runs.join(first), &copy).unwrap();
    std::fs::copy(runs.join(first), &other).unwrap();
    std::fs::copy(
        out.join("series").join(first),
        out.join("series/copy.parquet"),
    )
    .unwrap();
    let after = verb_outputs(d);
    for ((stdout_before, _), (stdout_after, stderr)) in before.iter().zip(&after) {
        assert_eq!(stdout_before, stdout_after, "the copies changed a result");
        for f in [&copy, &other] {
            assert!(
                stderr.contains(&format!("warning: ignoring {}: not a part", f.display())),
                "{stderr}"
            );
        }
        assert!(stderr.contains("it is not counted"), "{stderr}");
        assert!(!stderr.contains("series/copy.parquet"), "{stderr}");
    }
    assert!(
        after[0].0.contains("12 runs in 4 configurations"),
        "{}",
        after[0].0
    );
    // mbmf plot reads the series too, and names the series copy once.
    let (code, _, stderr) = run_any(&["plot", d, "--by", "controller"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(stderr.matches("series/copy.parquet").count(), 1, "{stderr}");
}

#[test]
fn parts_of_another_schema_or_sweep_are_refused_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_sweep(dir.path(), "s", "3", 1);
    let d = out.to_str().unwrap();
    let names = part_names(&out.join("runs"));

    // A part of another sweep of the same size, under a part name of this one.
    let other = small_sweep(dir.path(), "other", "12", 2);
    let foreign = out.join("runs/part-000100-000111.parquet");
    for sub in ["runs", "series"] {
        let name = &part_names(&other.join(sub))[0];
        std::fs::copy(
            other.join(sub).join(name),
            out.join(sub).join("part-000100-000111.parquet"),
        )
        .unwrap();
    }
    let e = run_usage_error(&["pareto", d, "--no-plot"]);
    assert!(
        e.contains(&foreign.display().to_string())
            && e.contains("belongs to another sweep")
            && e.contains("sweep.toml"),
        "{e}"
    );
    // A Parquet file of some other tool, named like a part.
    write_runs(&foreign, &stats_runs());
    let e = run_usage_error(&["stats", d, "--by", "controller"]);
    assert!(
        e.contains(&foreign.display().to_string())
            && e.contains("names no sweep size (mbmf_sweep_runs)"),
        "{e}"
    );
    for sub in ["runs", "series"] {
        std::fs::remove_file(out.join(sub).join("part-000100-000111.parquet")).unwrap();
    }
    // Two parts holding the same runs.
    for sub in ["runs", "series"] {
        std::fs::copy(
            out.join(sub).join(&names[0]),
            out.join(sub).join("part-000000-000099.parquet"),
        )
        .unwrap();
    }
    let e = run_usage_error(&["min-budget", d]);
    assert!(
        e.contains("part-000000-000099.parquet") && e.contains(&format!("{} holds too", names[0])),
        "{e}"
    );

    // A folder of parts that no sweep vouches for: every file must be a runs table of mbmf.
    let loose = dir.path().join("loose");
    std::fs::create_dir_all(loose.join("runs")).unwrap();
    std::fs::copy(
        out.join("runs").join(&names[0]),
        loose.join("runs/part-00000.parquet"),
    )
    .unwrap();
    let l = loose.to_str().unwrap();
    let (code, stdout, stderr) = run_any(&["pareto", l, "--no-plot"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("3 runs in 1 configurations"), "{stdout}");
    assert!(
        stderr.contains("is not a sweep dataset (no sweep.toml)")
            && stderr.contains("cannot be checked"),
        "{stderr}"
    );
    let series_part = loose.join("runs/part-00001.parquet");
    std::fs::copy(out.join("series").join(&names[0]), &series_part).unwrap();
    let e = run_usage_error(&["pareto", l]);
    assert!(
        e.contains(&format!(
            "{} is a series table (mbmf_schema series/2), not a runs table",
            series_part.display()
        )),
        "{e}"
    );
    std::fs::remove_file(&series_part).unwrap();
    let pareto_file = loose.join("runs/part-00002.parquet");
    run_ok(&[
        "pareto",
        l,
        "--no-plot",
        "--out",
        dir.path().join("a").to_str().unwrap(),
    ]);
    std::fs::copy(dir.path().join("a/pareto.parquet"), &pareto_file).unwrap();
    let e = run_usage_error(&["stats", l, "--by", "controller"]);
    assert!(
        e.contains(&format!(
            "{}: its mbmf_schema is pareto/1, not a runs table; every file of a dataset folder \
             must carry mbmf_schema runs/1 to runs/2",
            pareto_file.display()
        )),
        "{e}"
    );
    write_runs(&pareto_file, &stats_runs());
    let e = run_usage_error(&["stats", l, "--by", "controller"]);
    assert!(
        e.contains(&format!("{}: it has no mbmf_schema", pareto_file.display()))
            && e.contains("give the file's own path to analyse it alone"),
        "{e}"
    );
    // Alone, the same file is read (a table written by polars or pandas).
    run_ok(&["stats", pareto_file.to_str().unwrap(), "--by", "controller"]);
}

#[test]
fn an_incomplete_or_locked_sweep_is_refused_unless_allowed_saying_how_many_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = small_sweep(dir.path(), "s", "3", 1);
    let d = out.to_str().unwrap();
    let complete = verb_outputs(d);

    // A live writer: hold the lock of shard 1/1 as mbmf sweep does.
    let lock_path = out.join(".lock-0-of-1");
    let lock = std::fs::File::create(&lock_path).unwrap();
    std::fs::write(&lock_path, "pid=4242 host=elsewhere shard=1/1\n").unwrap();
    lock.try_lock().unwrap();
    for args in [
        &["pareto", d, "--no-plot"][..],
        &["stats", d, "--by", "controller"][..],
        &["min-budget", d][..],
        &["plot", d, "--by", "controller"][..],
    ] {
        let e = run_usage_error(args);
        assert!(
            e.contains(&format!(
                "{d} is still being written by pid 4242 on host elsewhere (lock file {})",
                lock_path.display()
            )) && e.contains("12 of 12 runs are committed")
                && e.contains("--allow-incomplete"),
            "{e}"
        );
    }
    common::release_lock(lock, &lock_path);
    // A stale lock (its holder is gone) is no writer.
    assert!(lock_path.exists());
    assert_eq!(verb_outputs(d)[0].0, complete[0].0);

    // Runs missing: one part and its series part deleted, as a killed sweep leaves it.
    let last = part_names(&out.join("runs")).pop().unwrap();
    for sub in ["runs", "series"] {
        std::fs::remove_file(out.join(sub).join(&last)).unwrap();
    }
    let e = run_usage_error(&["pareto", d, "--no-plot"]);
    assert!(
        e.contains(&format!("{d} is incomplete: 9 of 12 runs are committed"))
            && e.contains(&format!("mbmf sweep {d}/sweep.toml --out {d} --resume"))
            && e.contains("pass --allow-incomplete to analyse the runs present"),
        "{e}"
    );
    let (code, stdout, stderr) = run_any(&["pareto", d, "--no-plot", "--allow-incomplete"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert!(stdout.contains("9 runs in"), "{stdout}");
    assert!(
        stderr.contains(&format!(
            "warning: {d} is incomplete: analysing the 9 of 12 runs committed so far"
        )),
        "{stderr}"
    );
    let (code, _, stderr) = run_any(&["plot", d, "--by", "controller", "--allow-incomplete"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(
        stderr.matches("analysing the 9 of 12").count(),
        1,
        "{stderr}"
    );
}

#[test]
fn analyses_of_runs_refuse_a_series_table_and_point_at_the_runs() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    run_ok(&[
        "run",
        "--controller",
        "mf,ec",
        "--runs",
        "2",
        "--steps",
        "200",
        "--babbling",
        "50",
        "--quiet",
        "--out",
        run.to_str().unwrap(),
    ]);
    let series = run.join("series.parquet");
    let s = series.to_str().unwrap();
    for args in [
        &["stats", s, "--by", "controller"][..],
        &["pareto", s][..],
        &["min-budget", s][..],
    ] {
        let e = run_usage_error(args);
        assert!(
            e.contains(&format!(
                "{s} is a series table (mbmf_schema series/2), not a runs table"
            )) && e.contains("one row per checkpoint")
                && e.contains(&format!("give the dataset folder {}", run.display())),
            "{e}"
        );
    }
    let sweep = small_sweep(dir.path(), "s", "12", 1);
    let folder = sweep.join("series");
    let e = run_usage_error(&["stats", folder.to_str().unwrap(), "--by", "controller"]);
    assert!(
        e.contains(&format!(
            "{} is the series folder of the sweep {} (one row per checkpoint), not a runs table",
            folder.display(),
            sweep.display()
        )) && e.contains(&format!(
            "give {} or {}/runs",
            sweep.display(),
            sweep.display()
        )),
        "{e}"
    );
    let part = folder.join(&part_names(&folder)[0]);
    let e = run_usage_error(&["pareto", part.to_str().unwrap()]);
    assert!(
        e.contains("is a series table (mbmf_schema series/2)")
            && e.contains(&format!("give the dataset folder {}", sweep.display())),
        "{e}"
    );
    // The runs table itself reads, in both layouts.
    run_ok(&[
        "stats",
        run.join("runs.parquet").to_str().unwrap(),
        "--by",
        "controller",
    ]);
    run_ok(&[
        "stats",
        sweep.join("runs").to_str().unwrap(),
        "--by",
        "controller",
    ]);
}

#[test]
fn pareto_gives_one_front_per_task_and_step_count() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("tasks.toml");
    std::fs::write(
        &file,
        "seeds = 3\n[fixed]\nsteps = 200\nbabbling = 50\n[grid]\ntask = [\"tidy1\", \"tidy2\"]\n\
         controller = [\"mf\", \"ec\", \"rnd\"]\n",
    )
    .unwrap();
    let out = dir.path().join("tasks");
    let d = out.to_str().unwrap();
    run_ok(&["sweep", file.to_str().unwrap(), "--out", d, "--quiet"]);
    let stdout = run_ok(&["pareto", d]);
    assert!(
        stdout.contains("18 runs in 2 groups of task, whose results cannot be compared")
            && stdout.contains("--where task=VALUE"),
        "{stdout}"
    );
    let table = dataset::read_parquet_file(&out.join("analysis/pareto.parquet")).unwrap();
    assert_eq!(table.len(), 6);
    let task = table.column("task").unwrap();
    let front = bools(&table, "front");
    let knees = bools(&table, "knee");
    for t in ["tidy1", "tidy2"] {
        assert!(
            stdout.contains(&format!(", task={t}: 9 runs in 3 configurations;")),
            "{stdout}"
        );
        assert!(out.join(format!("analysis/pareto-{t}.svg")).is_file());
        // Each group's front is the front of that task alone.
        let alone = dir.path().join(t);
        let where_ = format!("task={t}");
        let single = run_ok(&[
            "pareto",
            d,
            "--where",
            &where_,
            "--no-plot",
            "--out",
            alone.to_str().unwrap(),
        ]);
        assert!(single.contains("9 runs in 3 configurations"), "{single}");
        let reference =
            dataset::read_parquet_file(&alone.join(format!("pareto-task-{t}.parquet"))).unwrap();
        let rows: Vec<usize> = (0..table.len())
            .filter(|&i| task.value(i) == Value::Str(t.to_owned()))
            .collect();
        assert_eq!(rows.len(), 3);
        let picked = |v: &[bool]| rows.iter().map(|&i| v[i]).collect::<Vec<bool>>();
        assert_eq!(picked(&front), bools(&reference, "front"), "{t}");
        assert_eq!(picked(&knees), bools(&reference, "knee"), "{t}");
        let means = floats(&table, "total_reward_mean");
        let picked_means: Vec<Option<f64>> = rows.iter().map(|&i| means[i]).collect();
        assert_eq!(picked_means, floats(&reference, "total_reward_mean"), "{t}");
    }
    assert_eq!(
        knees.iter().filter(|k| **k).count(),
        2,
        "one knee per group"
    );
    let json = run_ok(&["pareto", d, "--no-plot", "--json"]);
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    let groups = report["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 2);
    assert_eq!(groups[0]["group"]["task"], "tidy1");
    assert_eq!(groups[1]["runs"], 9);
    // Opposite objectives on one column would put every configuration on the front.
    let e = run_usage_error(&[
        "pareto",
        d,
        "--objectives",
        "total_reward:max,cost_total:min,total_reward:min",
    ]);
    assert!(
        e.contains("invalid --objectives total_reward:max,total_reward:min: opposite objectives"),
        "{e}"
    );
}

/// EC at four kappas without a human and with takeover, two seeds each (reward r -+ 1).
///
/// Fronts by construction (maximise reward, minimise cost and entropy), per human:
/// - none: kappas 1, 2, 3 (kappa 4 is dominated by all). Knee, normalised over the front
///   (reward 10..30, cost 100..400, entropy 0.4..0.5): squared distances 2 (kappa 1), 1
///   (kappa 2), 0.01 + 0.0278 + 0.25 = 0.288 (kappa 3): kappa 3.
/// - takeover: kappas 1, 2, 4 (kappa 3 is dominated by 1 and 4). Knee (reward 40..50, cost
///   50..100, entropy constant): 1 (kappa 1), 1 (kappa 2), 0.04 + 0.04 (kappa 4): kappa 4.
///
/// Pooled, takeover's front dominates every point without a human.
fn human_runs() -> Vec<Run> {
    let configs = [
        (Interaction::None, 0, 1.0, 10.0, 100.0, 0.5),
        (Interaction::None, 0, 2.0, 30.0, 400.0, 0.4),
        (Interaction::None, 0, 3.0, 28.0, 150.0, 0.45),
        (Interaction::None, 0, 4.0, 9.0, 500.0, 0.9),
        (Interaction::Takeover, 50, 1.0, 50.0, 100.0, 0.2),
        (Interaction::Takeover, 50, 2.0, 40.0, 50.0, 0.2),
        (Interaction::Takeover, 50, 3.0, 45.0, 200.0, 0.3),
        (Interaction::Takeover, 50, 4.0, 48.0, 60.0, 0.2),
    ];
    let mut runs = Vec::new();
    for (interaction, budget, kappa, reward, cost, entropy) in configs {
        let mut p = human(Controller::Ec, interaction, budget);
        p.kappa_coeff = kappa;
        for delta in [-1.0, 1.0] {
            runs.push(Run {
                params: p,
                reward: reward + delta,
                cost,
                entropy: Some(entropy),
            });
        }
    }
    runs
}

#[test]
fn pareto_by_gives_one_front_and_knee_per_group_in_the_table_the_json_and_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    write_runs(&dir.path().join("runs.parquet"), &human_runs());
    let d = dir.path().to_str().unwrap();
    let stdout = run_ok(&["pareto", d, "--by", "interaction"]);
    assert!(
        stdout.contains("16 runs in 2 groups of interaction: one front per group"),
        "{stdout}"
    );
    // The table carries the group column; one knee per group.
    assert!(
        has_row(
            &stdout,
            "none 3 2 28.00 ± 12.71 150.0 ± 0.0 0.4500 ± 0.0000 <- knee"
        ),
        "{stdout}"
    );
    assert!(
        has_row(
            &stdout,
            "takeover 4 2 48.00 ± 12.71 60.00 ± 0.00 0.2000 ± 0.0000 <- knee"
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("knee (suggested): kappa_coeff=3"),
        "{stdout}"
    );
    assert!(
        stdout.contains("knee (suggested): kappa_coeff=4"),
        "{stdout}"
    );

    // Named by its groups: the analysis of the whole dataset, written after, leaves it alone.
    let by_file = dir.path().join("analysis/pareto-by-interaction.parquet");
    let before = std::fs::read(&by_file).unwrap();
    run_ok(&["pareto", d, "--no-plot"]);
    assert!(dir.path().join("analysis/pareto.parquet").is_file());
    assert_eq!(std::fs::read(&by_file).unwrap(), before);
    let table = dataset::read_parquet_file(&by_file).unwrap();
    assert_eq!(table.len(), 8);
    let interaction = table.column("interaction").unwrap();
    let kappa = floats(&table, "kappa_coeff");
    let (front, knee) = (bools(&table, "front"), bools(&table, "knee"));
    let of = |human: &str, flags: &[bool]| -> Vec<f64> {
        (0..8)
            .filter(|&i| interaction.value(i) == Value::Str(human.to_owned()) && flags[i])
            .map(|i| kappa[i].unwrap())
            .collect()
    };
    assert_eq!(of("none", &front), [1.0, 2.0, 3.0]);
    assert_eq!(of("takeover", &front), [1.0, 2.0, 4.0]);
    assert_eq!(of("none", &knee), [3.0]);
    assert_eq!(of("takeover", &knee), [4.0]);

    // One figure, a panel per human, coloured by the swept kappa.
    let svg =
        std::fs::read_to_string(dir.path().join("analysis/pareto-by-interaction.svg")).unwrap();
    for text in ["interaction=none", "interaction=takeover", "kappa_coeff"] {
        assert!(
            svg.contains(&format!("\n{text}\n")),
            "the figure lacks {text}"
        );
    }

    let json = run_ok(&["pareto", d, "--by", "interaction", "--json", "--no-plot"]);
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    let groups = report["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 2);
    for (group, human, knee) in [
        (&groups[0], "none", "kappa_coeff=3"),
        (&groups[1], "takeover", "kappa_coeff=4"),
    ] {
        assert_eq!(group["group"]["interaction"], human);
        assert_eq!(group["knee"], knee);
        let rows = group["front"].as_array().unwrap();
        assert_eq!(rows.len(), 3);
        assert!(rows.iter().all(|r| r["interaction"] == human), "{rows:?}");
    }
    // One group kept with --where still says which group it is.
    let json = run_ok(&[
        "pareto",
        d,
        "--by",
        "interaction",
        "--where",
        "interaction=takeover",
        "--json",
        "--no-plot",
    ]);
    let report: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(report["groups"][0]["group"]["interaction"], "takeover");

    // Pooled, the front is takeover's alone: what --by is for.
    let pooled = run_ok(&["pareto", d, "--json", "--no-plot"]);
    let report: serde_json::Value = serde_json::from_str(&pooled).unwrap();
    let rows = report["front"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert!(
        rows.iter().all(|r| r["interaction"] == "takeover"),
        "{rows:?}"
    );

    // Bad columns are usage errors naming the fix.
    let e = run_usage_error(&["pareto", d, "--by", "interacton"]);
    assert!(
        e.contains("no column 'interacton' (did you mean 'interaction'?)"),
        "{e}"
    );
    let e = run_usage_error(&["pareto", d, "--colour", "controller"]);
    assert!(
        e.contains("column 'controller' holds text") && e.contains("--colour needs numbers"),
        "{e}"
    );
}
