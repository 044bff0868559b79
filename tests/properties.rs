//! Determinism as a property: for small random configurations (any
//! controller, selection, human and parameters, several runs with different parameters in one
//! batch), the results are the same bit for bit on 1 or 2 threads and in any batch size. A run's
//! result depends only on its parameters, the master seed and its run index (SPEC 7).
//!
//! `tests/determinism.rs` checks fixed configurations on 1, 2 and 8 threads and end to end; this
//! file explores the parameter space. The normal run tries 64 cases; more with PROPTEST_CASES.

mod common;

use std::sync::Arc;

use mbmf::batch::{Batch, RunConfig, RunStats};
use mbmf::env::{self, Spec};
use mbmf::params::{Controller, HumanParams, Interaction, Params, Selection};
use proptest::prelude::*;

/// A run's stats (wall time zeroed), checkpoint rows and final Q tables, as exact text: the
/// Debug form of a float round-trips, and NaN equals NaN there.
fn fingerprint(batch: &Batch, r: usize) -> String {
    let stats = RunStats {
        wall_time_s: 0.0,
        ..batch.stats()[r]
    };
    let q_bits = |q: ndarray::CowArray<'_, f64, ndarray::Ix2>| -> Vec<u64> {
        q.iter().map(|v| v.to_bits()).collect()
    };
    format!(
        "{stats:?}\n{:?}\n{:?}\n{:?}",
        batch.series(r),
        q_bits(batch.q_mf(r)),
        q_bits(batch.q_mb(r))
    )
}

/// Simulates `configs` in batches of `batch_size` on `threads` threads; one fingerprint per run.
fn simulate(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    threads: usize,
    batch_size: usize,
) -> Vec<String> {
    common::simulate(spec, configs, threads, batch_size, fingerprint)
}

/// Random but valid parameters of one run, short enough for many cases.
fn params() -> impl Strategy<Value = Params> {
    let controller = prop::sample::select(Controller::ALL.to_vec());
    let selection = prop::sample::select(vec![Selection::Softmax, Selection::Argmax]);
    let interaction = prop::sample::select(vec![
        Interaction::None,
        Interaction::Congratulation,
        Interaction::Takeover,
        Interaction::Punishment,
    ]);
    // Half the humans judge without error (SPEC 5), half misjudge at some rate (SPEC 15).
    let error_prob = prop_oneof![Just(0.0), 0.0..=1.0f64];
    let human = (interaction, 0u32..60, 0.0..=1.0f64, 0.0..2.0f64, error_prob).prop_map(
        |(interaction, budget, forget_prob, zeta, error_prob)| HumanParams {
            interaction,
            budget,
            forget_prob,
            zeta,
            error_prob,
        },
    );
    let rates = (0.05..=1.0f64, 0.0..0.99f64, 0.0..0.99f64, 0.05..=1.0f64);
    let shape = (
        0.005..1.0f64,
        -1.0..1.0f64,
        1u32..16,
        0.0..20.0f64,
        any::<bool>(),
    );
    let length = (0u32..600, 0u32..300, 0u32..80);
    (controller, selection, human, rates, shape, length).prop_map(
        |(controller, selection, human, rates, shape, length)| {
            let (alpha_mf, gamma_mf, gamma_mb, filter_alpha) = rates;
            let (tau, q_init, window_n, kappa_coeff, normalise_entropy) = shape;
            let (steps, babbling, checkpoint) = length;
            Params {
                controller,
                selection,
                human,
                alpha_mf,
                gamma_mf,
                gamma_mb,
                filter_alpha,
                tau,
                q_init,
                window_n,
                kappa_coeff,
                normalise_entropy,
                steps,
                babbling,
                checkpoint,
                // A loose tolerance and a low cap keep slow-converging cases cheap.
                vi_epsilon: 0.05,
                vi_max_sweeps: 200,
                ..Params::default()
            }
        },
    )
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(64),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn results_do_not_depend_on_threads_or_batch_size(
        task in prop::sample::select(vec!["tidy1", "tidy2"]),
        runs in prop::collection::vec(params(), 1..6),
        seed in any::<u64>(),
        first_index in 0u64..1_000_000,
        small_batch in 1usize..4,
    ) {
        let spec = Arc::new(env::load(task).expect("a built-in task"));
        let configs: Vec<RunConfig> = runs
            .iter()
            .enumerate()
            .map(|(i, &params)| RunConfig { params, seed, run_index: first_index + i as u64 })
            .collect();
        let all = configs.len();
        let reference = simulate(&spec, &configs, 1, all);
        for (threads, batch_size) in [(2, all), (2, small_batch), (1, small_batch)] {
            let got = simulate(&spec, &configs, threads, batch_size);
            for (r, (want, got)) in reference.iter().zip(&got).enumerate() {
                prop_assert_eq!(
                    want, got,
                    "run {} ({:?}) differs on {} threads in batches of {}",
                    configs[r].run_index, configs[r].params, threads, batch_size
                );
            }
        }
    }
}
