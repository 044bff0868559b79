//! The batch engine (SPEC 3.4 and 7): R independent runs of one environment, stored as flat
//! arrays with the run axis first, stepped in parallel by rayon, one run per task.
//!
//! Runs never share mutable data and each owns its random stream, seeded from (master seed, run
//! index) only, so results do not depend on batch size, thread count or scheduling order.

mod person;
mod settled;
mod step;
mod storage;
pub mod trace;

pub use person::Refusal;
pub use settled::Settled;
use storage::{Rest, Tables};
pub use storage::{RunView, Sizes};

use std::sync::Arc;
use std::time::Instant;

use ndarray::{Array2, Array3, ArrayView2, CowArray, Ix2};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

use crate::env::{Spec, StateId};
use crate::expert::mb::Observable;
use crate::params::ConfigError;
use crate::params::{HumanParams, Interaction, Params, RewardSource};
pub use crate::rng::{run_rng, uniform};
pub use crate::run_stats::RunStats;
use crate::schedule::{self, Plan, Schedule};

/// Marker in the batch's per-run plan index for a run without a plan.
const NO_PLAN: u16 = u16::MAX;

/// The outcomes any run of the batch can observe: the union over the worlds of every plan, and
/// the outcomes a nuisance produces where one can act (SPEC 10, 11.2). Exactly the environment's
/// own table when no run changes anything.
fn observable(spec: &Spec, plans: &[Plan]) -> Observable {
    let mut worlds: Vec<&Spec> = vec![spec];
    let mut extra = Vec::new();
    for plan in plans {
        for world in &plan.worlds {
            worlds.push(world);
            if let (true, Some(tables)) = (plan.nuisance, world.human.as_ref()) {
                for (sa, &next) in tables.nuisance.iter().enumerate() {
                    if next != crate::env::NO_NUISANCE {
                        extra.push((sa, next));
                    }
                }
            }
        }
    }
    Observable::union(worlds, extra)
}

pub use step::step;

/// One run to simulate: its parameters and where its random stream comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunConfig {
    /// Every sweepable scalar of the run.
    pub params: Params,
    /// The master seed of the experiment or sweep.
    pub seed: u64,
    /// Index of the run within the experiment or sweep; with `seed`, it fixes the random stream.
    pub run_index: u64,
}

/// One row of the time series, written every `checkpoint` experiment steps and at the last.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Checkpoint {
    /// Experiment step (1-based) at which the row was taken.
    pub step: u32,
    /// Reward so far.
    pub cum_reward: f64,
    /// MF inference cost so far.
    pub cum_cost_mf: f64,
    /// MB inference cost so far.
    pub cum_cost_mb: f64,
    /// Mean MC probability of MB over the decisions since the previous row (NaN if none).
    pub p_mb_mean: f64,
    /// Decisions since the previous row.
    pub decisions: u32,
    /// Interactions given so far.
    pub interactions: u32,
}

/// Where a run is: its environment state, the regime it is in (world, human: what a
/// schedule may change, SPEC 10) and counters that are not results.
#[derive(Debug, Clone, Copy, Default)]
pub struct Cursor {
    /// Current environment state.
    pub state: StateId,
    /// The last arrival was terminal: this step is the reset step (SPEC 2.1, 10).
    pub pending_reset: bool,
    /// Steps taken, babbling included.
    pub t: u64,
    /// Interactions the human may still give.
    pub budget_left: u32,
    /// The run's world: an index into its plan's worlds (0 without a plan).
    pub world: u16,
    /// The next action of the run's plan to apply.
    pub next_action: u16,
    /// The human now (from the parameters, then as events change it).
    pub human: HumanParams,
    /// Who brings the goal's reward now (SPEC 11.1).
    pub reward_source: RewardSource,
    /// Sum of P(MB) over decisions since the last checkpoint.
    pub window_p_mb: f64,
    /// Decisions since the last checkpoint.
    pub window_decisions: u32,
    /// Checkpoint rows written.
    pub checkpoints_written: u32,
    /// Pairs in the MF eligibility trace (`lambda_mf` > 0 only).
    pub eligible: u32,
    /// The action a real person chose to take over with at the next step
    /// ([`crate::human::NO_PUT`]: none; SPEC 15).
    pub person_put: u16,
}

impl Cursor {
    /// A run at its start in world `spec` with `params`, in state `state`.
    pub fn start(_spec: &Spec, params: &Params, state: StateId) -> Cursor {
        Cursor {
            state,
            budget_left: params.human.budget,
            human: params.human,
            reward_source: params.reward_source,
            person_put: crate::human::NO_PUT,
            ..Cursor::default()
        }
    }
}

/// Bytes a batch holds per run beyond its rows of the per-run arrays and its checkpoint rows:
/// its random stream, cursor, accumulators, configuration, plan index, series offset and MB
/// term count.
pub const RUN_RECORD_BYTES: usize = std::mem::size_of::<Xoshiro256PlusPlus>()
    + std::mem::size_of::<Cursor>()
    + std::mem::size_of::<RunStats>()
    + std::mem::size_of::<RunConfig>()
    + std::mem::size_of::<u16>()
    + std::mem::size_of::<usize>()
    + std::mem::size_of::<u64>();

/// Number of checkpoint rows of a run.
pub fn checkpoint_count(params: &Params) -> usize {
    if params.steps == 0 || params.checkpoint == 0 {
        return 0;
    }
    (params.steps as usize).div_ceil(params.checkpoint as usize)
}

/// Number of trace rows of a run when traced: one per experiment step (SPEC 14).
pub fn trace_rows(params: &Params) -> usize {
    params.steps as usize
}

/// R runs of one environment, with all their state in flat `[run, ...]` arrays.
///
/// `Clone` copies every run's state, so benchmarks can bring a batch to a state once and time
/// further steps on copies of it.
#[derive(Clone)]
pub struct Batch {
    spec: Arc<Spec>,
    configs: Vec<RunConfig>,
    plans: Arc<Vec<Plan>>,
    run_plan: Vec<u16>,
    sizes: Sizes,
    tables: Tables,
    vi_terms: Vec<u64>,
    obs: Arc<Observable>,
    rngs: Vec<Xoshiro256PlusPlus>,
    cursors: Vec<Cursor>,
    stats: Vec<RunStats>,
    series: Vec<Checkpoint>,
    series_start: Vec<usize>,
    trace: trace::TraceColumns,
}

impl Batch {
    /// Allocates and initialises every run (SPEC 3.3: Q = q_init, uniform averaged distributions,
    /// zero costs, empty model) and places each in its initial state. No run changes anything
    /// during the run (but a `tidy1` run may have its own box assignment).
    pub fn new(spec: Arc<Spec>, configs: Vec<RunConfig>) -> Result<Batch, ConfigError> {
        Batch::with_schedules(spec, configs, &[], &[])
    }

    /// [`Batch::new`] where run `r` follows `schedules[run_schedule[r]]` (SPEC 10); an empty
    /// `run_schedule` means no schedule for any run. Every schedule is checked against the task
    /// and each run's parameters, and every world it names is loaded, before anything runs.
    pub fn with_schedules(
        spec: Arc<Spec>,
        configs: Vec<RunConfig>,
        schedules: &[Schedule],
        run_schedule: &[usize],
    ) -> Result<Batch, ConfigError> {
        Batch::reusing(None, spec, configs, schedules, run_schedule)
    }

    /// [`Batch::with_schedules`] in the memory of `spare`, a batch whose results are no longer
    /// needed, where its tables have the sizes this batch needs (else in fresh memory). Results
    /// do not depend on it: every value of every table is written before the runs start.
    pub fn reusing(
        spare: Option<Batch>,
        spec: Arc<Spec>,
        configs: Vec<RunConfig>,
        schedules: &[Schedule],
        run_schedule: &[usize],
    ) -> Result<Batch, ConfigError> {
        for config in &configs {
            crate::env::registry::check_params(&spec, &config.params)?;
        }
        Batch::unchecked(spare, spec, configs, schedules, run_schedule)
    }

    /// [`Batch::with_schedules`] once each run's parameters are known to fit the task.
    fn unchecked(
        spare: Option<Batch>,
        spec: Arc<Spec>,
        configs: Vec<RunConfig>,
        schedules: &[Schedule],
        run_schedule: &[usize],
    ) -> Result<Batch, ConfigError> {
        assert!(run_schedule.is_empty() || run_schedule.len() == configs.len());
        // One plan per distinct (schedule, what compiling depends on in the parameters).
        let none = Schedule::default();
        let mut plans: Vec<Plan> = Vec::new();
        type Key = (
            usize,
            Vec<crate::params::Value>,
            u32,
            crate::params::Controller,
            u64,
            bool,
        );
        let mut keys: Vec<Key> = Vec::new();
        let mut run_plan = Vec::with_capacity(configs.len());
        for (r, config) in configs.iter().enumerate() {
            let p = &config.params;
            let which = run_schedule.get(r).copied();
            let schedule = which.map_or(&none, |i| &schedules[i]);
            let nuisance = p.human.interaction == Interaction::Nuisance;
            if schedule.is_empty() && crate::env::registry::task_params_default(p) && !nuisance {
                run_plan.push(NO_PLAN);
                continue;
            }
            let key = (
                which.unwrap_or(usize::MAX),
                crate::env::registry::task_param_values(p),
                p.steps,
                p.controller,
                p.human.zeta.to_bits(),
                nuisance,
            );
            let index = match keys.iter().position(|k| *k == key) {
                Some(i) => i,
                None => {
                    plans.push(
                        schedule::compile(&spec, schedule, p)
                            .map_err(|e| ConfigError::Schedule(e.to_string()))?,
                    );
                    keys.push(key);
                    plans.len() - 1
                }
            };
            if index >= usize::from(NO_PLAN) {
                return Err(ConfigError::TooManySchedules);
            }
            run_plan.push(index as u16);
        }
        let runs = configs.len();
        // The MB model's index space: every outcome a run of the batch can observe (SPEC 10).
        let obs = Arc::new(observable(&spec, &plans));
        let sizes = Sizes::of(&spec, configs.iter().map(|c| &c.params), obs.len());
        let mut rngs: Vec<Xoshiro256PlusPlus> = configs
            .iter()
            .map(|c| run_rng(c.seed, c.run_index))
            .collect();
        let cursors = configs
            .iter()
            .zip(rngs.iter_mut())
            .zip(&run_plan)
            .map(|((config, rng), &plan)| {
                let world = plans
                    .get(usize::from(plan))
                    .map_or(&*spec, |p| &*p.worlds[0]);
                let state = initial_state(world, rng);
                Cursor::start(world, &config.params, state)
            })
            .collect();
        let mut series_start = Vec::with_capacity(runs + 1);
        series_start.push(0);
        for config in &configs {
            series_start.push(series_start.last().unwrap() + checkpoint_count(&config.params));
        }
        let mut batch = Batch {
            tables: Tables::reuse_or_new(spare.map(|b| b.tables), runs, &sizes),
            sizes,
            vi_terms: vec![0; runs],
            obs,
            rngs,
            cursors,
            stats: vec![RunStats::default(); runs],
            series: vec![Checkpoint::default(); *series_start.last().unwrap()],
            series_start,
            trace: trace::TraceColumns::default(),
            configs,
            plans: Arc::new(plans),
            run_plan,
            spec,
        };
        batch.start_runs();
        Ok(batch)
    }

    /// Writes every run's initial tables (SPEC 3.3: Q = q_init, uniform averaged distributions,
    /// zero costs, empty model), in parallel. The tables are allocated zeroed and untouched, so
    /// these first writes map their pages: spread over the threads, and never first mapped by a
    /// read (the shared zero page), whose copy on the first write costs a TLB shootdown on every
    /// other thread of the process.
    fn start_runs(&mut self) {
        let spec = Arc::clone(&self.spec);
        self.views()
            .into_par_iter()
            .with_max_len(1)
            .for_each(|(params, mut run)| {
                // The world the run starts in: its plan's first, or the batch's.
                let world = run.plan.map_or(&*spec, |p| &*p.worlds[0]);
                run.start(params, world.n_actions, world.dynamics.as_ref());
            });
    }

    /// Makes every run record the per-step trace (SPEC 14): one row per experiment step,
    /// preallocated here. Call before the first step; a batch not traced holds no row.
    pub fn record_trace(&mut self) {
        assert!(
            self.cursors.iter().all(|c| c.t == 0),
            "the trace is asked for before the first step"
        );
        let rows = self.configs.iter().map(|c| trace_rows(&c.params)).sum();
        self.trace = trace::TraceColumns::new(rows);
    }

    /// Whether the runs record the per-step trace.
    pub fn is_traced(&self) -> bool {
        !self.trace.is_empty()
    }

    /// The trace rows of every run, run after run ([`trace_rows`] each; empty when the batch
    /// is not traced).
    pub fn trace(&self) -> &trace::TraceColumns {
        &self.trace
    }

    /// The canonical text of run `r`'s schedule ("" without changes, SPEC 10).
    pub fn schedule_text(&self, r: usize) -> &str {
        self.plans
            .get(usize::from(self.run_plan[r]))
            .map_or("", |p| p.text.as_str())
    }

    /// Bytes of state the batch holds, all runs together: every per-run array, RNG, cursor,
    /// accumulator, configuration and checkpoint row (the shared [`Spec`] is not counted).
    pub fn state_bytes(&self) -> usize {
        self.state_layout().iter().map(|&(_, bytes)| bytes).sum()
    }

    /// [`state_bytes`](Batch::state_bytes) array by array: (name, bytes for all runs).
    pub fn state_layout(&self) -> Vec<(&'static str, usize)> {
        use std::mem::size_of_val;
        let mut layout = self.tables.layout();
        layout.extend([
            ("vi_terms", size_of_val(self.vi_terms.as_slice())),
            ("rngs", size_of_val(self.rngs.as_slice())),
            ("cursors", size_of_val(self.cursors.as_slice())),
            ("stats", size_of_val(self.stats.as_slice())),
            ("series", size_of_val(self.series.as_slice())),
            ("series_start", size_of_val(self.series_start.as_slice())),
            ("trace", self.trace.bytes()),
            ("configs", size_of_val(self.configs.as_slice())),
            ("run_plan", size_of_val(self.run_plan.as_slice())),
        ]);
        layout
    }

    /// Number of runs.
    pub fn len(&self) -> usize {
        self.configs.len()
    }

    /// Whether the batch has no run.
    pub fn is_empty(&self) -> bool {
        self.configs.is_empty()
    }

    /// The environment all runs share.
    pub fn spec(&self) -> &Spec {
        &self.spec
    }

    /// The runs' configurations, in run order.
    pub fn configs(&self) -> &[RunConfig] {
        &self.configs
    }

    /// The runs' accumulators, in run order.
    pub fn stats(&self) -> &[RunStats] {
        &self.stats
    }

    /// The runs' cursors, in run order.
    pub fn cursors(&self) -> &[Cursor] {
        &self.cursors
    }

    /// Checkpoint rows of run `r`.
    pub fn series(&self, r: usize) -> &[Checkpoint] {
        &self.series[self.series_start[r]..self.series_start[r + 1]]
    }

    /// MF Q table of run `r`, `[state, action]`. A run whose controller does not run the MF
    /// expert has it as it started (`q_init` everywhere), also when the batch holds no MF table.
    pub fn q_mf(&self, r: usize) -> CowArray<'_, f64, Ix2> {
        self.row_or(&self.tables.q_mf, r, self.configs[r].params.q_init)
    }

    /// MB Q table of run `r`, `[state, action]`, as [`q_mf`](Batch::q_mf) is for MF.
    pub fn q_mb(&self, r: usize) -> CowArray<'_, f64, Ix2> {
        self.row_or(&self.tables.q_mb, r, self.configs[r].params.q_init)
    }

    /// Averaged action probabilities of run `r`: (MF, MB), each `[state, action]`; uniform for
    /// an expert the run's controller does not run, and for a rule that keeps none (`vpi`,
    /// [`crate::arbiter::Arbiter::AVERAGES`]).
    pub fn averaged_probabilities(
        &self,
        r: usize,
    ) -> (CowArray<'_, f64, Ix2>, CowArray<'_, f64, Ix2>) {
        let uniform = 1.0 / self.spec.n_actions as f64;
        (
            self.row_or(&self.tables.pavg_mf, r, uniform),
            self.row_or(&self.tables.pavg_mb, r, uniform),
        )
    }

    /// Run `r`'s `[state, action]` table of `tables`, or one of `initial` where the batch holds
    /// none (no run of it runs that expert).
    fn row_or<'b>(&'b self, tables: &'b [f64], r: usize, initial: f64) -> CowArray<'b, f64, Ix2> {
        let shape = (self.spec.n_states, self.spec.n_actions);
        let row = storage::row(tables, self.len(), r);
        if row.is_empty() {
            CowArray::from(Array2::from_elem(shape, initial))
        } else {
            CowArray::from(ArrayView2::from_shape(shape, row).expect("one [state, action] table"))
        }
    }

    /// Run `r`'s task state ([`crate::env::Dynamics`]; empty for a task without).
    pub fn task_state(&self, r: usize) -> &[f64] {
        storage::row(&self.tables.task_state, self.len(), r)
    }

    /// Run `r`'s tally of the experiment ([`crate::env::Tally`]; empty for a task without).
    pub fn tally(&self, r: usize) -> &[f64] {
        storage::row(&self.tables.tally, self.len(), r)
    }

    /// Number of states the MB expert of run `r` knows: the start of at least one learned
    /// transition, so the states its value iteration sweeps (SPEC 3.2).
    pub fn known_states(&self, r: usize) -> usize {
        storage::row(&self.tables.known, self.len(), r)
            .iter()
            .filter(|&&k| k)
            .count()
    }

    /// T(s,a,s') of run `r` as a dense `[state, action, next]` array (for tests and inspection).
    pub fn transition_model(&self, r: usize) -> Array3<f64> {
        let spec = &self.spec;
        let mut t = Array3::zeros((spec.n_states, spec.n_actions, spec.n_states));
        let counts = storage::row(&self.tables.count, self.len(), r);
        let lens = storage::row(&self.tables.ring_len, self.len(), r);
        if lens.is_empty() {
            // No run of the batch runs the MB expert: nothing was learned.
            return t;
        }
        for s in 0..spec.n_states {
            for a in 0..spec.n_actions {
                let sa = spec.sa(s, a);
                if lens[sa] == 0 {
                    continue;
                }
                for o in self.obs.outcomes(sa) {
                    t[[s, a, self.obs.next_state(o)]] = f64::from(counts[o]) / f64::from(lens[sa]);
                }
            }
        }
        t
    }

    /// Runs every run to its end (babbling, then the experiment), in parallel.
    pub fn run_to_end(&mut self) {
        self.advance(u64::MAX);
    }

    /// Advances every run by up to `steps` steps (fewer where a run ends), in parallel; one rayon
    /// task per run, never runs folded into one task: runs differ in cost, and a thread that
    /// finished its share would otherwise wait out another's whole chunk of runs (rayon cuts a
    /// slice into about as many pieces as threads, and a piece once begun is not cut again).
    pub fn advance(&mut self, steps: u64) {
        let spec = Arc::clone(&self.spec);
        let spec: &Spec = &spec;
        let views = self.views();
        views
            .into_par_iter()
            .with_max_len(1)
            .for_each(|(params, mut view)| {
                let started = Instant::now();
                let end = view.cursor.t.saturating_add(steps);
                step::run_until(spec, params, &mut view, end);
                view.stats.wall_time_s += started.elapsed().as_secs_f64();
            });
    }

    /// Splits the batch's arrays into one [`RunView`] per run.
    fn views(&mut self) -> Vec<(&Params, RunView<'_>)> {
        let runs = self.configs.len();
        let mut rows = self.tables.rows(runs);
        let mut vi_terms = self.vi_terms.iter_mut();
        let obs: &Observable = &self.obs;
        let mut series_rest: &mut [Checkpoint] = &mut self.series;
        let traced = !self.trace.is_empty();
        let lens = self
            .configs
            .iter()
            .map(|c| if traced { trace_rows(&c.params) } else { 0 });
        let mut traces = self.trace.split(lens).into_iter();
        let plans: &[Plan] = &self.plans;
        let mut views = Vec::with_capacity(self.configs.len());
        for (((config, rng), cursor), (stats, r)) in self
            .configs
            .iter()
            .zip(self.rngs.iter_mut())
            .zip(self.cursors.iter_mut())
            .zip(self.stats.iter_mut().zip(0..))
        {
            let n_rows = self.series_start[r + 1] - self.series_start[r];
            let (series, rest) = std::mem::take(&mut series_rest).split_at_mut(n_rows);
            series_rest = rest;
            let view = rows.next_run(Rest {
                window_cap: self.sizes.window_cap,
                active_terms: vi_terms.next().expect("one per run"),
                obs,
                rng,
                cursor,
                stats,
                series,
                trace: traces.next().expect("one per run"),
                plan: plans.get(usize::from(self.run_plan[r])),
            });
            views.push((&config.params, view));
        }
        views
    }
}

/// Draws a run's initial state: uniform over the spec's initial states (no draw when only one).
pub fn initial_state(spec: &Spec, rng: &mut Xoshiro256PlusPlus) -> StateId {
    match spec.initial_states.len() {
        1 => spec.initial_states[0],
        n => spec.initial_states[((uniform(rng) * n as f64) as usize).min(n - 1)],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Controller;

    fn configs(controller: Controller, seeds: std::ops::Range<u64>) -> Vec<RunConfig> {
        seeds
            .map(|seed| RunConfig {
                params: Params {
                    controller,
                    babbling: 100,
                    steps: 600,
                    checkpoint: 100,
                    ..Params::default()
                },
                seed,
                run_index: seed,
            })
            .collect()
    }

    /// Every result of every run of a finished batch but its wall time, bit for bit.
    fn results(batch: &Batch) -> Vec<String> {
        (0..batch.len())
            .map(|r| {
                let stats = RunStats {
                    wall_time_s: 0.0,
                    ..batch.stats()[r]
                };
                let bits =
                    |a: CowArray<'_, f64, Ix2>| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                format!(
                    "{stats:?} {:?} {:?} {:?}",
                    batch.series(r),
                    bits(batch.q_mf(r)),
                    bits(batch.q_mb(r))
                )
            })
            .collect()
    }

    #[test]
    fn a_batch_in_a_finished_batchs_memory_gives_the_results_of_a_fresh_one() {
        let spec = Arc::new(crate::env::load("tidy1").unwrap());
        let mut finished = Batch::new(Arc::clone(&spec), configs(Controller::Ec, 0..4)).unwrap();
        finished.run_to_end();
        let memory = finished.tables.q_mb.as_ptr();
        let next = || configs(Controller::Ec, 10..14);
        let mut fresh = Batch::new(Arc::clone(&spec), next()).unwrap();
        let mut reused =
            Batch::reusing(Some(finished), Arc::clone(&spec), next(), &[], &[]).unwrap();
        assert_eq!(
            reused.tables.q_mb.as_ptr(),
            memory,
            "the finished batch's tables are taken"
        );
        fresh.run_to_end();
        reused.run_to_end();
        assert!(fresh.stats().iter().any(|s| s.total_reward > 0.0));
        assert_eq!(results(&fresh), results(&reused));

        // Tables of other sizes (an `mf` batch holds no MB model) are not taken.
        let others = || configs(Controller::Mf, 20..23);
        let mut fresh = Batch::new(Arc::clone(&spec), others()).unwrap();
        let mut reused =
            Batch::reusing(Some(reused), Arc::clone(&spec), others(), &[], &[]).unwrap();
        assert!(reused.tables.q_mb.is_empty());
        fresh.run_to_end();
        reused.run_to_end();
        assert_eq!(results(&fresh), results(&reused));
    }
}
