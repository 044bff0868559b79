//! Value iteration alone (`Model::value_iteration_cached`, SPEC 3.2), in (s, a, s') terms per
//! second.
//!
//! The model is the one an MB run has learned by the end of its experiment (stepped by the
//! engine's own per-run kernel), so it holds every transition the run has seen.
//!
//! - `warm`: Q (and the row maxima cached with it) as the run left them, as in the experiment:
//!   typically one sweep that confirms convergence.
//! - `cold`: Q reset to q_init, so the call sweeps until the values converge from scratch.
//!
//! Run: `cargo bench --bench value_iteration`.

#[path = "common/mod.rs"]
mod common;

use criterion::{BatchSize, BenchmarkId, Criterion, Throughput};
use mbmf::batch::{
    Checkpoint, Cursor, RunStats, RunView, Settled, checkpoint_count, run_rng, step,
};
use mbmf::env::Spec;
use mbmf::expert::mb::OwnedModel;
use mbmf::params::{Controller, Params};

/// One MB run with owned arrays, run to its end by the engine's step kernel.
struct Learned {
    params: Params,
    q_mb: Vec<f64>,
    model: OwnedModel,
}

fn learn(spec: &Spec) -> Learned {
    let params = common::params(spec, Controller::Mb);
    let (n_s, n_a) = (spec.n_states, spec.n_actions);
    let sa = n_s * n_a;
    let window_cap = params.window_n as usize;
    let mut q_mf = vec![params.q_init; sa];
    let mut q_mb = vec![params.q_init; sa];
    let mut pavg_mf = vec![1.0 / n_a as f64; sa];
    let mut pavg_mb = vec![1.0 / n_a as f64; sa];
    let mut entropy_mf = vec![f64::NAN; n_s];
    let mut entropy_mb = vec![f64::NAN; n_s];
    // An MB run alone keeps one softmax per state.
    let mut kept_p_mb = vec![0.0; sa];
    let mut kept_owner_mb = vec![u32::MAX; n_s];
    let mut max_mf = vec![params.q_init; n_s];
    let mut settled = vec![Settled::default(); n_s];
    let mut cost_mf = vec![0.0; n_s];
    let mut cost_mb = vec![0.0; n_s];
    let mut visited = vec![false; n_s];
    let mut bonus = vec![0; sa];
    let mut model = OwnedModel::new(spec, window_cap);
    let mut scratch = vec![0.0; 2 * n_a];
    let mut rng = run_rng(common::SEED, 0);
    let state = mbmf::batch::initial_state(spec, &mut rng);
    let mut cursor = Cursor::start(spec, &params, state);
    let mut stats = RunStats::default();
    let mut series = vec![Checkpoint::default(); checkpoint_count(&params)];
    let total = u64::from(params.babbling) + u64::from(params.steps);
    {
        let mut view = RunView {
            q_mf: &mut q_mf,
            q_mb: &mut q_mb,
            pavg_mf: &mut pavg_mf,
            pavg_mb: &mut pavg_mb,
            entropy_mf: &mut entropy_mf,
            entropy_mb: &mut entropy_mb,
            kept_p_mf: &mut [],
            kept_owner_mf: &mut [],
            kept_p_mb: &mut kept_p_mb,
            kept_owner_mb: &mut kept_owner_mb,
            max_mf: &mut max_mf,
            settled: &mut settled,
            cost_mf: &mut cost_mf,
            cost_mb: &mut cost_mb,
            entropy_mix: &mut [],
            weight_mix: &mut [],
            visited: &mut visited,
            bonus: &mut bonus,
            arbiter_run: &mut [],
            arbiter_pairs: &mut [],
            model: model.view(),
            scratch: &mut scratch,
            task_state: &mut [],
            eligibility: &mut [],
            eligible: &mut [],
            tally: &mut [],
            rng: &mut rng,
            cursor: &mut cursor,
            stats: &mut stats,
            series: &mut series,
            trace: Default::default(),
            plan: None,
        };
        while view.cursor.t < total {
            step(spec, &params, &mut view);
        }
    }
    Learned {
        params,
        q_mb,
        model,
    }
}

fn value_iteration(c: &mut Criterion) {
    let mut group = c.benchmark_group("value_iteration");
    for (label, spec) in common::environments() {
        let learned = learn(&spec);
        let p = learned.params;
        let cold_q = vec![p.q_init; learned.q_mb.len()];
        for (start, q) in [("warm", &learned.q_mb), ("cold", &cold_q)] {
            let warm = start == "warm";
            // The engine's call: the row maxima cached by the run's last call are trusted (warm);
            // the cold start resets Q, so it must forget them first.
            let call = |model: &mut OwnedModel, q: &mut Vec<f64>| {
                let mut view = model.view();
                if !warm {
                    view.forget_row_maxima();
                }
                view.value_iteration_cached(q, p.gamma_mb, p.vi_epsilon, p.vi_max_sweeps)
            };
            // One probe call gives the work per call, so rates read as terms per second.
            let report = call(&mut learned.model.clone(), &mut q.clone());
            let terms = report.ops / (1 + spec.n_actions as u64);
            eprintln!(
                "value_iteration/{label}/{start}: {} sweeps, {terms} terms per call",
                report.sweeps
            );
            group.throughput(Throughput::Elements(terms));
            group.bench_function(BenchmarkId::new(label, start), |b| {
                b.iter_batched_ref(
                    || (learned.model.clone(), q.clone()),
                    |(model, q)| call(model, q),
                    BatchSize::SmallInput,
                )
            });
        }
    }
    group.finish();
}

criterion::criterion_group! {
    name = benches;
    config = common::quick();
    targets = value_iteration
}
criterion::criterion_main!(benches);
