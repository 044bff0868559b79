//! Results depend only on (parameters, master seed, run index): not on the number of rayon
//! threads, nor on how runs are grouped into batches (SPEC 7), in the library and end to end
//! through the `mbmf run` binary and its Parquet files.

mod common;

use std::fs::File;
use std::path::Path;
use std::sync::Arc;

use arrow::array::RecordBatch;
use assert_cmd::Command;
use mbmf::batch::{Checkpoint, RunConfig, RunStats};
use mbmf::env::{self, Spec};
use mbmf::params::{Controller, HumanParams, Interaction, Params, Selection};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// Everything a run produces that must be reproducible.
#[derive(Debug, Clone, PartialEq)]
struct Outcome {
    stats: RunStats,
    series: Vec<Checkpoint>,
    q_mf: Vec<f64>,
    q_mb: Vec<f64>,
}

/// Every controller, both selections and every human, short runs.
fn configs() -> Vec<RunConfig> {
    let base = Params {
        babbling: 200,
        steps: 1500,
        checkpoint: 100,
        ..Params::default()
    };
    let human = |interaction, budget| HumanParams {
        interaction,
        budget,
        ..HumanParams::default()
    };
    let mut params: Vec<Params> = Controller::ALL
        .iter()
        .map(|&controller| Params { controller, ..base })
        .collect();
    params.push(Params {
        selection: Selection::Argmax,
        ..base
    });
    params.push(Params {
        human: human(Interaction::Congratulation, 40),
        ..base
    });
    params.push(Params {
        controller: Controller::Rnd,
        human: human(Interaction::Takeover, 40),
        ..base
    });
    params.push(Params {
        controller: Controller::Entropy,
        human: human(Interaction::Punishment, 40),
        window_n: 3,
        ..base
    });
    // SPEC 3.1's eligibility trace, beside runs without: batches mixing both cut anywhere.
    for controller in [Controller::Mf, Controller::Ec] {
        params.push(Params {
            controller,
            lambda_mf: 0.8,
            ..base
        });
    }
    params.push(Params {
        controller: Controller::Fixed,
        combine: mbmf::params::Combine::Mix,
        lambda_mf: 1.0,
        human: human(Interaction::Congratulation, 40),
        ..base
    });
    let mut configs = Vec::new();
    for seed in [1, 2] {
        for &p in &params {
            configs.push(RunConfig {
                params: p,
                seed,
                run_index: configs.len() as u64,
            });
        }
    }
    configs
}

/// Simulates `configs` in batches of `batch_size` on a pool of `threads` threads.
fn simulate(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    threads: usize,
    batch_size: usize,
) -> Vec<Outcome> {
    common::simulate(spec, configs, threads, batch_size, |batch, r| Outcome {
        stats: RunStats {
            wall_time_s: 0.0,
            ..batch.stats()[r]
        },
        series: batch.series(r).to_vec(),
        q_mf: batch.q_mf(r).iter().copied().collect(),
        q_mb: batch.q_mb(r).iter().copied().collect(),
    })
}

/// Panics naming the run, the field and the setting when `got` differs from `want`.
fn assert_same(want: &[Outcome], got: &[Outcome], configs: &[RunConfig], setting: &str) {
    assert_eq!(want.len(), got.len(), "{setting}: number of runs");
    for ((w, g), config) in want.iter().zip(got).zip(configs) {
        let run = format!(
            "run {} ({}, seed {})",
            config.run_index,
            config.params.controller.name(),
            config.seed
        );
        // Debug strings compare NaN with NaN (p_mb_mean of a window without decisions).
        let (ws, gs) = (format!("{:?}", w.stats), format!("{:?}", g.stats));
        assert_eq!(ws, gs, "{run}: stats differ with {setting}");
        assert_eq!(
            w.series.len(),
            g.series.len(),
            "{run}: series length differs with {setting}"
        );
        for (i, (a, b)) in w.series.iter().zip(&g.series).enumerate() {
            assert_eq!(
                format!("{a:?}"),
                format!("{b:?}"),
                "{run}: series row {i} differs with {setting}"
            );
        }
        for (s, (a, b)) in w.q_mf.iter().zip(&g.q_mf).enumerate() {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "{run}: q_mf[{s}] differs with {setting}"
            );
        }
        for (s, (a, b)) in w.q_mb.iter().zip(&g.q_mb).enumerate() {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "{run}: q_mb[{s}] differs with {setting}"
            );
        }
    }
}

fn check_thread_and_batch_independence(spec: Arc<Spec>, configs: Vec<RunConfig>) {
    let all = configs.len();
    let reference = simulate(&spec, &configs, 1, all);
    assert!(
        reference.iter().any(|o| o.stats.total_reward > 0.0),
        "the runs should earn some reward, or the comparison proves little"
    );
    for threads in [1, 2, 8] {
        for batch_size in [1, 7, all] {
            let got = simulate(&spec, &configs, threads, batch_size);
            let setting = format!("{threads} threads and batches of {batch_size}");
            assert_same(&reference, &got, &configs, &setting);
        }
    }
}

#[test]
fn tidy1_results_do_not_depend_on_thread_count_or_batch_size() {
    let spec = Arc::new(env::load("tidy1").unwrap());
    check_thread_and_batch_independence(spec, configs());
}

#[test]
fn twostep_results_do_not_depend_on_thread_count_or_batch_size() {
    let spec = Arc::new(env::load("twostep").unwrap());
    let configs: Vec<RunConfig> = configs()
        .into_iter()
        .filter(|c| c.params.human.interaction == Interaction::None)
        .map(|c| RunConfig {
            params: Params {
                tau: 0.2,
                ..c.params
            },
            ..c
        })
        .collect();
    check_thread_and_batch_independence(spec, configs);
}

#[test]
fn stochastic_world_results_do_not_depend_on_thread_count_or_batch_size() {
    let Some(spec) = common::navworld() else {
        return;
    };
    // No human: json worlds define no interactions.
    let configs: Vec<RunConfig> = configs()
        .into_iter()
        .filter(|c| c.params.human.interaction == Interaction::None)
        .collect();
    check_thread_and_batch_independence(spec, configs);
}

/// The record batches of a Parquet file, with the `wall_time_s` column removed.
fn read_parquet(path: &Path) -> Vec<RecordBatch> {
    let file = File::open(path).unwrap_or_else(|e| panic!("cannot open {}: {e}", path.display()));
    let reader = ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap();
    reader
        .map(|batch| {
            let mut batch = batch.unwrap();
            if let Ok(i) = batch.schema().index_of("wall_time_s") {
                batch.remove_column(i);
            }
            batch
        })
        .collect()
}

fn mbmf_run(out: &Path, threads: &str) {
    Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .env("RAYON_NUM_THREADS", threads)
        .args([
            "run",
            "--runs",
            "3",
            "--steps",
            "1500",
            "--babbling",
            "200",
            "--quiet",
            "--out",
        ])
        .arg(out)
        .assert()
        .success();
}

#[test]
fn mbmf_run_writes_the_same_parquet_rows_with_one_or_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    let (one, two) = (dir.path().join("one"), dir.path().join("two"));
    mbmf_run(&one, "1");
    mbmf_run(&two, "2");
    for file in ["runs.parquet", "series.parquet"] {
        let a = read_parquet(&one.join(file));
        let b = read_parquet(&two.join(file));
        let rows: usize = a.iter().map(RecordBatch::num_rows).sum();
        assert!(rows > 0, "{file} has no rows");
        assert_eq!(a.len(), b.len(), "{file}: number of record batches");
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert_eq!(x.schema(), y.schema(), "{file}: schema of batch {i}");
            for (field, (cx, cy)) in x
                .schema()
                .fields()
                .iter()
                .zip(x.columns().iter().zip(y.columns()))
            {
                assert_eq!(
                    cx,
                    cy,
                    "{file}: record batch {i}, column {} differs between 1 and 2 threads",
                    field.name()
                );
            }
        }
    }
    // 4 default controllers x 3 runs.
    let runs: usize = read_parquet(&one.join("runs.parquet"))
        .iter()
        .map(RecordBatch::num_rows)
        .sum();
    assert_eq!(runs, 12);
}
