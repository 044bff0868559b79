//! Runs stepped together in lane groups (four runs whose decision arithmetic shares vector
//! instructions) give exactly what they give stepped one at a time: whatever the batch size
//! (a multiple of the group size or not, so some runs of a batch take the one-run step), the
//! thread count, and the other runs of the batch (other controllers, humans, other step counts).

mod common;

use std::sync::Arc;

use mbmf::batch::{Checkpoint, RunConfig, RunStats};
use mbmf::env;
use mbmf::params::{Controller, HumanParams, Interaction, Params};

/// Everything a run produces (compared as Debug strings, which compare NaN with NaN; tables as
/// bits).
struct Outcome {
    stats: RunStats,
    series: Vec<Checkpoint>,
    q_mf: Vec<u64>,
    pavg_mf: Vec<u64>,
}

/// MF runs with their own learning rate, temperature and filter (a lane reads its own run's
/// parameters), mixed with runs that never join a group and with MF runs of another length.
fn configs() -> Vec<RunConfig> {
    let base = Params {
        controller: Controller::Mf,
        babbling: 150,
        steps: 1200,
        checkpoint: 100,
        ..Params::default()
    };
    let mut params = Vec::new();
    for k in 0..13 {
        let k = f64::from(k);
        params.push(Params {
            alpha_mf: 0.5 + 0.03 * k,
            tau: 0.02 + 0.01 * k,
            filter_alpha: 0.4 + 0.02 * k,
            ..base
        });
    }
    params.insert(
        3,
        Params {
            controller: Controller::Ec,
            ..base
        },
    );
    params.insert(
        7,
        Params {
            human: HumanParams {
                interaction: Interaction::Congratulation,
                budget: 40,
                ..HumanParams::default()
            },
            ..base
        },
    );
    for _ in 0..5 {
        params.push(Params {
            babbling: 90,
            steps: 700,
            checkpoint: 0,
            ..base
        });
    }
    params
        .into_iter()
        .enumerate()
        .map(|(i, params)| RunConfig {
            params,
            seed: 11 + i as u64 % 2,
            run_index: i as u64,
        })
        .collect()
}

fn simulate(configs: &[RunConfig], threads: usize, batch_size: usize) -> Vec<Outcome> {
    let spec = Arc::new(env::load("tidy1").unwrap());
    common::simulate(&spec, configs, threads, batch_size, |batch, r| {
        let bits = |v: ndarray::ArrayView2<'_, f64>| v.iter().map(|x| x.to_bits()).collect();
        Outcome {
            stats: RunStats {
                wall_time_s: 0.0,
                ..batch.stats()[r]
            },
            series: batch.series(r).to_vec(),
            q_mf: bits(batch.q_mf(r)),
            pavg_mf: bits(batch.averaged_probabilities(r).0),
        }
    })
}

#[test]
fn lane_groups_equal_one_run_at_a_time_bit_for_bit() {
    let configs = configs();
    // Batches of one run never form a group: the one-run step throughout.
    let reference = simulate(&configs, 1, 1);
    assert!(
        reference.iter().all(|o| o.stats.decisions > 0),
        "every run should decide"
    );
    assert!(
        reference
            .iter()
            .filter(|o| o.stats.total_reward > 0.0)
            .count()
            > configs.len() / 2,
        "most runs should earn reward, or the comparison proves little"
    );
    let all = configs.len();
    for threads in [1, 2] {
        for batch_size in [4, 5, 8, 9, all] {
            let got = simulate(&configs, threads, batch_size);
            for (r, (want, got)) in reference.iter().zip(&got).enumerate() {
                let setting = format!("run {r} in batches of {batch_size} on {threads} threads");
                let debug = |o: &Outcome| format!("{:?} {:?}", o.stats, o.series);
                assert_eq!(debug(want), debug(got), "{setting}: stats or series differ");
                assert!(want.q_mf == got.q_mf, "{setting}: Q_MF differs");
                assert!(
                    want.pavg_mf == got.pavg_mf,
                    "{setting}: averaged MF distribution differs"
                );
            }
        }
    }
}
