//! Fixtures shared by the benchmarks: environments, fixed-seed run configurations, batches
//! brought to a phase of learning, and rayon pools of a given size.
//!
//! Everything here runs outside the timed loops. Inputs depend on [`SEED`] only, so two machines
//! (or two commits) time the same work.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use criterion::Criterion;
use mbmf::batch::Batch;
use mbmf::env::Spec;
use mbmf::env::registry::default_steps;
use mbmf::params::{Controller, Params};

/// Master seed of every benchmark input, and `runs` runs of some parameters under it: those of
/// `mbmf bench`, so the two time the same work.
// Each benchmark uses a part of this module.
#[allow(unused_imports)]
pub use mbmf::bench::{SEED, configs};

/// Criterion settings that keep `cargo bench` to a few minutes on a 2-core machine: 10 samples,
/// short warm-up and measurement. Command-line flags (`--measurement-time`, ...) still override.
pub fn quick() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2))
        .without_plots()
        .configure_from_args()
}

/// The authors' navigation world, read from `../shared/data/navworld` beside the crate. Not
/// part of the repository: `None` (with a message) when absent.
pub fn navworld() -> Option<Spec> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/navworld/realisticNavWorld.json");
    if !path.exists() {
        eprintln!(
            "skipping the navigation world: {} not found (copy the authors' navworld folder there)",
            path.display()
        );
        return None;
    }
    match mbmf::env::load(&format!("json:{}", path.display())) {
        Ok(spec) => Some(spec),
        Err(e) => {
            eprintln!("skipping the navigation world: {e}");
            None
        }
    }
}

/// The three environments of the paper, by short label: tidy1, tidy2 and (when present) nav.
pub fn environments() -> Vec<(&'static str, Arc<Spec>)> {
    let mut envs = vec![
        (
            "tidy1",
            Arc::new(mbmf::env::load("tidy1").expect("built in")),
        ),
        (
            "tidy2",
            Arc::new(mbmf::env::load("tidy2").expect("built in")),
        ),
    ];
    if let Some(nav) = navworld() {
        envs.push(("nav", Arc::new(nav)));
    }
    envs
}

/// The paper's four controllers (those of `mbmf bench --growth`).
pub const CONTROLLERS: [Controller; 4] = mbmf::bench::GROWTH_CONTROLLERS;

/// Paper defaults for `controller` on `spec` (no human, experiment length of the task).
pub fn params(spec: &Spec, controller: Controller) -> Params {
    Params {
        controller,
        steps: default_steps(&spec.name),
        ..Params::default()
    }
}

/// Where in a run a timed window starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// From a fresh batch: the first 1,000 steps, which are the babbling steps.
    First1000,
    /// Right after the 1,000 babbling steps: the early experiment.
    AfterBabbling,
    /// The last steps of the experiment: learning has settled.
    Steady,
}

impl Phase {
    /// All phases, in run order.
    pub const ALL: [Phase; 3] = [Phase::First1000, Phase::AfterBabbling, Phase::Steady];

    /// Short label for benchmark ids.
    pub fn label(self) -> &'static str {
        match self {
            Phase::First1000 => "first1000",
            Phase::AfterBabbling => "after-babbling",
            Phase::Steady => "steady",
        }
    }

    /// Steps taken before the timed window of `window` steps, for runs of `params`.
    pub fn start(self, params: &Params, window: u64) -> u64 {
        let total = u64::from(params.babbling) + u64::from(params.steps);
        match self {
            Phase::First1000 => 0,
            Phase::AfterBabbling => u64::from(params.babbling),
            Phase::Steady => total.saturating_sub(window),
        }
    }
}

/// A batch of `runs` runs of `params` on `spec`, advanced `start` steps (with `threads` threads).
///
/// The returned batch has touched all its memory (it is a clone), so timing steps on clones of
/// it does not time page faults.
pub fn prepared(
    spec: &Arc<Spec>,
    params: Params,
    runs: usize,
    start: u64,
    threads: usize,
) -> Batch {
    let mut batch = Batch::new(Arc::clone(spec), configs(params, runs)).expect("valid params");
    if start > 0 {
        pool(threads).install(|| batch.advance(start));
    }
    batch.clone()
}

/// A rayon pool of exactly `threads` threads ([`mbmf::bench::pool`]).
pub fn pool(threads: usize) -> rayon::ThreadPool {
    mbmf::bench::pool(threads).expect("a thread pool")
}
