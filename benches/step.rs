//! The whole step (SPEC 3.4), in agent-steps per second.
//!
//! - `step/<env>/<controller>/<phase>`: 64 runs on one thread, timed over a window of steps
//!   starting at a phase of learning (the first 1,000 steps, right after babbling, or the end of
//!   the experiment). The batch is brought to the phase once, then every iteration steps a clone.
//! - `batch_size/<controller>/<threads>t/<runs>`: tidy1 from a fresh batch, 1 to 16,384 runs on
//!   1 or 2 threads: the engine's overhead per run and its scaling across cores.
//! - `naive/<controller>` against `engine/<controller>`: one whole tidy1 run (11,000 steps) by the
//!   naive reference of `tests/naive` and by the batch engine (one run, one thread).
//! - `rules/<env>/<controller>`: every rule of SPEC 4 and 12, and `combine = mix` wherever it
//!   applies (`<controller>-mix`), on tidy1, tidy2, the navigation world and twostep, 64 runs on
//!   one thread, steady state (twostep's 402-step runs: the whole run).
//!
//! Run: `cargo bench --bench step` (add a filter such as `-- step/tidy1/ec` to select).

#[path = "common/mod.rs"]
mod common;
#[path = "../tests/naive/mod.rs"]
mod naive;

use std::sync::Arc;

use criterion::{BatchSize, BenchmarkId, Criterion, SamplingMode, Throughput};
use mbmf::batch::Batch;
use mbmf::params::{Combine, Controller};

use common::{CONTROLLERS, Phase};

/// Large tables on huge pages, as the `mbmf` binary allocates them (`src/huge_pages.rs`): the
/// steps are timed with the TLB misses of a user's run (and of `mbmf bench`), not those of 4 KiB
/// pages.
#[global_allocator]
static ALLOCATOR: mbmf::huge_pages::HugePageSystem = mbmf::huge_pages::HugePageSystem;

/// Runs per batch in the per-environment matrix.
const RUNS: usize = 64;

/// Steps timed per iteration: 1,000 for the first-1000 phase; fewer for the expensive
/// controllers elsewhere, so each benchmark stays within seconds.
fn window(controller: Controller, phase: Phase) -> u64 {
    match (phase, controller) {
        (Phase::First1000, _) => 1000,
        (_, Controller::Mb | Controller::Rnd) => 250,
        _ => 1000,
    }
}

/// Times `window` steps of clones of `template` on `pool`.
fn time_window(
    b: &mut criterion::Bencher<'_>,
    template: &Batch,
    pool: &rayon::ThreadPool,
    window: u64,
) {
    b.iter_batched(
        || template.clone(),
        |mut batch| {
            pool.install(|| batch.advance(window));
            batch
        },
        BatchSize::PerIteration,
    );
}

fn per_environment(c: &mut Criterion) {
    let one = common::pool(1);
    for (label, spec) in common::environments() {
        let mut group = c.benchmark_group(format!("step/{label}"));
        group.sampling_mode(SamplingMode::Flat);
        for controller in CONTROLLERS {
            let params = common::params(&spec, controller);
            for phase in Phase::ALL {
                let window = window(controller, phase);
                // Bringing a batch to the end of the experiment is the slow part of setup: use
                // both cores for it (results do not depend on the thread count).
                let template =
                    common::prepared(&spec, params, RUNS, phase.start(&params, window), 2);
                group.throughput(Throughput::Elements(RUNS as u64 * window));
                group.bench_with_input(
                    BenchmarkId::new(controller.name(), phase.label()),
                    &template,
                    |b, template| time_window(b, template, &one, window),
                );
            }
        }
        group.finish();
    }
}

fn batch_sizes(c: &mut Criterion) {
    let spec = Arc::new(mbmf::env::load("tidy1").expect("built in"));
    // 1,000-step windows, as `mbmf run` advances runs 2,000 steps at a time: shorter windows
    // would time reloading each run's state more than stepping it. EC's first steps cost ~10x
    // MF's, so it stops at 1,024 runs to keep the bench short.
    for (controller, sizes) in [
        (Controller::Mf, &[1usize, 64, 1024, 16_384][..]),
        (Controller::Ec, &[1, 64, 1024][..]),
    ] {
        let window = 1000;
        let mut group = c.benchmark_group(format!("batch_size/{}", controller.name()));
        group.sampling_mode(SamplingMode::Flat);
        let params = common::params(&spec, controller);
        for &runs in sizes {
            let template = common::prepared(&spec, params, runs, 0, 1);
            group.throughput(Throughput::Elements(runs as u64 * window));
            for threads in [1, 2] {
                let pool = common::pool(threads);
                group.bench_with_input(
                    BenchmarkId::new(format!("{threads}t"), runs),
                    &template,
                    |b, template| time_window(b, template, &pool, window),
                );
            }
        }
        group.finish();
    }
}

fn naive_baseline(c: &mut Criterion) {
    let spec = Arc::new(mbmf::env::load("tidy1").expect("built in"));
    let one = common::pool(1);
    let mut group = c.benchmark_group("naive_vs_engine/tidy1");
    group.sampling_mode(SamplingMode::Flat);
    for controller in CONTROLLERS {
        let params = common::params(&spec, controller);
        let steps = u64::from(params.babbling) + u64::from(params.steps);
        group.throughput(Throughput::Elements(steps));
        group.bench_function(BenchmarkId::new("naive", controller.name()), |b| {
            b.iter_batched(
                || naive::NaiveRun::new(&spec, params, common::SEED, 0),
                |mut run| {
                    run.run_to_end();
                    run
                },
                BatchSize::PerIteration,
            )
        });
        let template = common::prepared(&spec, params, 1, 0, 1);
        group.bench_function(BenchmarkId::new("engine", controller.name()), |b| {
            time_window(b, &template, &one, steps)
        });
    }
    group.finish();
}

fn rules(c: &mut Criterion) {
    let one = common::pool(1);
    let mut envs = common::environments();
    envs.push((
        "twostep",
        Arc::new(mbmf::env::load("twostep").expect("built in")),
    ));
    let rules = mbmf::bench::every_rule();
    for (label, spec) in envs {
        let mut group = c.benchmark_group(format!("rules/{label}"));
        group.sampling_mode(SamplingMode::Flat);
        for &(controller, combine) in &rules {
            let params = mbmf::params::Params {
                combine,
                babbling: mbmf::env::registry::default_babbling(&spec.name),
                ..common::params(&spec, controller)
            };
            let total = u64::from(params.babbling) + u64::from(params.steps);
            // The navigation world's MB plans over stochastic outcomes (about 50 k steps/s):
            // a shorter window keeps each benchmark within seconds.
            let window = if label == "nav" { 250 } else { 1000 }.min(total);
            let template = common::prepared(&spec, params, RUNS, total - window, 2);
            let name = match combine {
                Combine::Select => controller.name().to_string(),
                Combine::Mix => format!("{}-mix", controller.name()),
            };
            group.throughput(Throughput::Elements(RUNS as u64 * window));
            group.bench_with_input(BenchmarkId::new(name, "steady"), &template, |b, t| {
                time_window(b, t, &one, window)
            });
        }
        group.finish();
    }
}

criterion::criterion_group! {
    name = benches;
    config = common::quick();
    targets = per_environment, batch_sizes, naive_baseline, rules
}
criterion::criterion_main!(benches);
