//! The batch engine (SPEC 3.4 and 7): R independent runs of one environment, stored as flat
//! arrays with the run axis first, stepped in parallel by rayon, one run per task.
//!
//! Runs never share mutable data and each owns its random stream, seeded from (master seed, run
//! index) only, so results do not depend on batch size, thread count or scheduling order.

mod step;

use std::sync::Arc;
use std::time::Instant;

use ndarray::{Array2, Array3, CowArray, Ix2};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

use crate::env::tidy::Boxes;
use crate::env::{Spec, StateId};
use crate::expert::mb::{Model, Observable};
use crate::params::ConfigError;
use crate::params::{Controller, HumanParams, Interaction, Params, RewardSource};
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
}

impl Cursor {
    /// A run at its start in world `spec` with `params`, in state `state`.
    pub fn start(_spec: &Spec, params: &Params, state: StateId) -> Cursor {
        Cursor {
            state,
            budget_left: params.human.budget,
            human: params.human,
            reward_source: params.reward_source,
            ..Cursor::default()
        }
    }
}

/// Flags, per state of a run without a human, of what a decision there may take from the
/// previous one instead of computing it again (bit for bit the same). Without a human the
/// softmax of an expert depends only on its Q row (the bonus term is 0, the temperature fixed).
pub struct Settled;

impl Settled {
    /// The MF Q row has not changed since its softmax was last folded into the averaged
    /// distribution (for an `mf` run, which keeps it, that softmax is in `p_mf`).
    pub const SOFTMAX: u8 = 1;
    /// That fold left the MF averaged distribution as it was, so folding again would too.
    pub const AVERAGE: u8 = 2;
    /// [`SOFTMAX`](Settled::SOFTMAX) for the MB expert (value iteration changed no value).
    pub const MB_SOFTMAX: u8 = 4;
    /// [`AVERAGE`](Settled::AVERAGE) for the MB expert.
    pub const MB_AVERAGE: u8 = 8;
}

/// Number of checkpoint rows of a run.
pub fn checkpoint_count(params: &Params) -> usize {
    if params.steps == 0 || params.checkpoint == 0 {
        return 0;
    }
    (params.steps as usize).div_ceil(params.checkpoint as usize)
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
    window_cap: usize,
    q_mf: Array3<f64>,
    q_mb: Array3<f64>,
    pavg_mf: Array3<f64>,
    pavg_mb: Array3<f64>,
    entropy_mf: Array2<f64>,
    entropy_mb: Array2<f64>,
    p_mf: Array3<f64>,
    max_mf: Array2<f64>,
    settled: Array2<u8>,
    cost_mf: Array2<f64>,
    cost_mb: Array2<f64>,
    visited: Array2<bool>,
    bonus: Array3<u8>,
    ring: Array2<u16>,
    ring_len: Array2<u16>,
    ring_pos: Array2<u16>,
    outcome_count: Array2<u16>,
    outcome_reward: Array2<f64>,
    outcome_terminal: Array2<bool>,
    known: Array2<bool>,
    vi_best: Array2<f64>,
    vi_dirty: Array2<u64>,
    vi_terms: Vec<u64>,
    obs: Arc<Observable>,
    scratch: Array2<f64>,
    rngs: Vec<Xoshiro256PlusPlus>,
    cursors: Vec<Cursor>,
    stats: Vec<RunStats>,
    series: Vec<Checkpoint>,
    series_start: Vec<usize>,
}

/// One run's mutable views into the batch, handed to [`step`].
pub struct RunView<'a> {
    /// MF action values, `[state, action]`.
    pub q_mf: &'a mut [f64],
    /// MB action values, `[state, action]`.
    pub q_mb: &'a mut [f64],
    /// MF averaged action probabilities, `[state, action]`.
    pub pavg_mf: &'a mut [f64],
    /// MB averaged action probabilities, `[state, action]`.
    pub pavg_mb: &'a mut [f64],
    /// Entropy in bits of each state's MF averaged distribution, NaN when not known since the
    /// row last changed.
    pub entropy_mf: &'a mut [f64],
    /// The same for the MB averaged distribution.
    pub entropy_mb: &'a mut [f64],
    /// For an `mf` run without a human: the MF softmax last computed in each state,
    /// `[state, action]` (empty for other runs).
    pub p_mf: &'a mut [f64],
    /// For an `mf` run without a human: the maximum of each state's MF Q row.
    pub max_mf: &'a mut [f64],
    /// For a run without a human: what still holds in each state ([`Settled`] flags).
    pub settled: &'a mut [u8],
    /// MF per-state inference cost average.
    pub cost_mf: &'a mut [f64],
    /// MB per-state inference cost average.
    pub cost_mb: &'a mut [f64],
    /// Per state: the robot has decided there before (first-decision rule, SPEC 4).
    pub visited: &'a mut [bool],
    /// G(s, a) of Eq. 8, `[state, action]`.
    pub bonus: &'a mut [u8],
    /// The MB expert's learned model.
    pub model: Model<'a>,
    /// 2 |A| values of scratch space for the two experts' distributions.
    pub scratch: &'a mut [f64],
    /// The run's random stream.
    pub rng: &'a mut Xoshiro256PlusPlus,
    /// Where the run is.
    pub cursor: &'a mut Cursor,
    /// The run's accumulators.
    pub stats: &'a mut RunStats,
    /// The run's checkpoint rows.
    pub series: &'a mut [Checkpoint],
    /// The run's schedule of changes, compiled; `None` for a run without changes in the
    /// batch's own environment.
    pub plan: Option<&'a Plan>,
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
        for config in &configs {
            crate::env::registry::check_params(&spec, &config.params)?;
        }
        assert!(run_schedule.is_empty() || run_schedule.len() == configs.len());
        // One plan per distinct (schedule, what compiling depends on in the parameters).
        let none = Schedule::default();
        let mut plans: Vec<Plan> = Vec::new();
        let mut keys: Vec<(usize, Boxes, u32, crate::params::Controller, u64, bool)> = Vec::new();
        let mut run_plan = Vec::with_capacity(configs.len());
        for (r, config) in configs.iter().enumerate() {
            let p = &config.params;
            let which = run_schedule.get(r).copied();
            let schedule = which.map_or(&none, |i| &schedules[i]);
            let nuisance = p.human.interaction == Interaction::Nuisance;
            if schedule.is_empty() && p.boxes == Boxes::RGB && !nuisance {
                run_plan.push(NO_PLAN);
                continue;
            }
            let key = (
                which.unwrap_or(usize::MAX),
                p.boxes,
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
        let (n_s, n_a) = (spec.n_states, spec.n_actions);
        let window_cap = configs
            .iter()
            .map(|c| c.params.window_n as usize)
            .max()
            .unwrap_or(1);
        // The MB model's index space: every outcome a run of the batch can observe (SPEC 10).
        let obs = Arc::new(observable(&spec, &plans));
        // An expert no run of the batch runs gets no tables at all: for a batch of `mf` runs
        // that is half of the memory the batch would otherwise fill, and the page faults and
        // stores to fill it, which cost more than a tenth of such a batch's whole time.
        let states_if_any = |runs_it: fn(Controller) -> bool| {
            let any = configs.iter().any(|c| runs_it(c.params.controller));
            if any { n_s } else { 0 }
        };
        let mf_states = states_if_any(Controller::runs_mf);
        let mb_states = states_if_any(Controller::runs_mb);
        // Only `mf` runs keep their softmax between decisions (two-expert runs would outgrow
        // 64 KiB of state per tidy run with it).
        let kept_states = states_if_any(|c| c == Controller::Mf);
        let (mb_pairs, n_outcomes) = if mb_states > 0 {
            (n_s * n_a, obs.len())
        } else {
            (0, 0)
        };
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
            window_cap,
            q_mf: Array3::zeros((runs, mf_states, n_a)),
            q_mb: Array3::zeros((runs, mb_states, n_a)),
            pavg_mf: Array3::zeros((runs, mf_states, n_a)),
            pavg_mb: Array3::zeros((runs, mb_states, n_a)),
            entropy_mf: Array2::zeros((runs, mf_states)),
            entropy_mb: Array2::zeros((runs, mb_states)),
            p_mf: Array3::zeros((runs, kept_states, n_a)),
            max_mf: Array2::zeros((runs, kept_states)),
            settled: Array2::zeros((runs, n_s)),
            cost_mf: Array2::zeros((runs, n_s)),
            cost_mb: Array2::zeros((runs, n_s)),
            visited: Array2::from_elem((runs, n_s), false),
            bonus: Array3::zeros((runs, n_s, n_a)),
            ring: Array2::zeros((runs, mb_pairs * window_cap)),
            ring_len: Array2::zeros((runs, mb_pairs)),
            ring_pos: Array2::zeros((runs, mb_pairs)),
            outcome_count: Array2::zeros((runs, n_outcomes)),
            outcome_reward: Array2::zeros((runs, n_outcomes)),
            outcome_terminal: Array2::from_elem((runs, n_outcomes), false),
            known: Array2::from_elem((runs, mb_states), false),
            vi_best: Array2::zeros((runs, mb_states)),
            vi_dirty: Array2::zeros((runs, if mb_states > 0 { obs.dirty_words() } else { 0 })),
            vi_terms: vec![0; runs],
            obs,
            scratch: Array2::zeros((runs, 2 * n_a)),
            rngs,
            cursors,
            stats: vec![RunStats::default(); runs],
            series: vec![Checkpoint::default(); *series_start.last().unwrap()],
            series_start,
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
        let n_actions = self.spec.n_actions;
        self.views()
            .into_par_iter()
            .for_each(|(params, mut run)| run.start(params, n_actions));
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
        fn bytes<T, D: ndarray::Dimension>(a: &ndarray::Array<T, D>) -> usize {
            a.len() * std::mem::size_of::<T>()
        }
        vec![
            ("q_mf", bytes(&self.q_mf)),
            ("q_mb", bytes(&self.q_mb)),
            ("pavg_mf", bytes(&self.pavg_mf)),
            ("pavg_mb", bytes(&self.pavg_mb)),
            ("entropy_mf", bytes(&self.entropy_mf)),
            ("entropy_mb", bytes(&self.entropy_mb)),
            ("p_mf", bytes(&self.p_mf)),
            ("max_mf", bytes(&self.max_mf)),
            ("settled", bytes(&self.settled)),
            ("cost_mf", bytes(&self.cost_mf)),
            ("cost_mb", bytes(&self.cost_mb)),
            ("visited", bytes(&self.visited)),
            ("bonus", bytes(&self.bonus)),
            ("ring", bytes(&self.ring)),
            ("ring_len", bytes(&self.ring_len)),
            ("ring_pos", bytes(&self.ring_pos)),
            ("outcome_count", bytes(&self.outcome_count)),
            ("outcome_reward", bytes(&self.outcome_reward)),
            ("outcome_terminal", bytes(&self.outcome_terminal)),
            ("known", bytes(&self.known)),
            ("vi_best", bytes(&self.vi_best)),
            ("vi_dirty", bytes(&self.vi_dirty)),
            ("vi_terms", size_of_val(self.vi_terms.as_slice())),
            ("scratch", bytes(&self.scratch)),
            ("rngs", size_of_val(self.rngs.as_slice())),
            ("cursors", size_of_val(self.cursors.as_slice())),
            ("stats", size_of_val(self.stats.as_slice())),
            ("series", size_of_val(self.series.as_slice())),
            ("series_start", size_of_val(self.series_start.as_slice())),
            ("configs", size_of_val(self.configs.as_slice())),
            ("run_plan", size_of_val(self.run_plan.as_slice())),
        ]
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
        self.row_or(&self.q_mf, r, self.configs[r].params.q_init)
    }

    /// MB Q table of run `r`, `[state, action]`, as [`q_mf`](Batch::q_mf) is for MF.
    pub fn q_mb(&self, r: usize) -> CowArray<'_, f64, Ix2> {
        self.row_or(&self.q_mb, r, self.configs[r].params.q_init)
    }

    /// Averaged action probabilities of run `r`: (MF, MB), each `[state, action]`; uniform for
    /// an expert the run's controller does not run.
    pub fn averaged_probabilities(
        &self,
        r: usize,
    ) -> (CowArray<'_, f64, Ix2>, CowArray<'_, f64, Ix2>) {
        let uniform = 1.0 / self.spec.n_actions as f64;
        (
            self.row_or(&self.pavg_mf, r, uniform),
            self.row_or(&self.pavg_mb, r, uniform),
        )
    }

    /// Run `r`'s `[state, action]` table of `tables`, or one of `initial` where the batch holds
    /// none (no run of it runs that expert).
    fn row_or<'b>(
        &'b self,
        tables: &'b Array3<f64>,
        r: usize,
        initial: f64,
    ) -> CowArray<'b, f64, Ix2> {
        if tables.shape()[1] == 0 {
            let shape = (self.spec.n_states, self.spec.n_actions);
            CowArray::from(Array2::from_elem(shape, initial))
        } else {
            CowArray::from(tables.index_axis(ndarray::Axis(0), r))
        }
    }

    /// Number of states the MB expert of run `r` knows: the start of at least one learned
    /// transition, so the states its value iteration sweeps (SPEC 3.2).
    pub fn known_states(&self, r: usize) -> usize {
        self.known.row(r).iter().filter(|&&k| k).count()
    }

    /// T(s,a,s') of run `r` as a dense `[state, action, next]` array (for tests and inspection).
    pub fn transition_model(&self, r: usize) -> Array3<f64> {
        let spec = &self.spec;
        let mut t = Array3::zeros((spec.n_states, spec.n_actions, spec.n_states));
        let counts = self.outcome_count.row(r);
        let lens = self.ring_len.row(r);
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
    /// task per run.
    pub fn advance(&mut self, steps: u64) {
        let spec = Arc::clone(&self.spec);
        let spec: &Spec = &spec;
        let window_cap = self.window_cap;
        let views = self.views();
        views
            .into_par_iter()
            .with_min_len(1)
            .for_each(|(params, mut view)| {
                let started = Instant::now();
                let end = view.cursor.t.saturating_add(steps);
                step::run_until(spec, params, window_cap, &mut view, end);
                view.stats.wall_time_s += started.elapsed().as_secs_f64();
            });
    }

    /// Splits the batch's arrays into one [`RunView`] per run.
    fn views(&mut self) -> Vec<(&Params, RunView<'_>)> {
        let runs = self.configs.len();
        // Each array holds `runs` equal rows; an expert's arrays are empty when no run of the
        // batch runs it, and then every run gets an empty row.
        fn rows<T>(a: &mut [T], runs: usize) -> Rows<'_, T> {
            let len = a.len().checked_div(runs).unwrap_or(0);
            Rows { rest: a, len }
        }
        let mut q_mf = rows(self.q_mf.as_slice_mut().expect("standard layout"), runs);
        let mut q_mb = rows(self.q_mb.as_slice_mut().expect("standard layout"), runs);
        let mut pavg_mf = rows(self.pavg_mf.as_slice_mut().expect("standard layout"), runs);
        let mut pavg_mb = rows(self.pavg_mb.as_slice_mut().expect("standard layout"), runs);
        let mut entropy_mf = rows(
            self.entropy_mf.as_slice_mut().expect("standard layout"),
            runs,
        );
        let mut entropy_mb = rows(
            self.entropy_mb.as_slice_mut().expect("standard layout"),
            runs,
        );
        let mut p_mf = rows(self.p_mf.as_slice_mut().expect("standard layout"), runs);
        let mut max_mf = rows(self.max_mf.as_slice_mut().expect("standard layout"), runs);
        let mut settled = rows(self.settled.as_slice_mut().expect("standard layout"), runs);
        let mut cost_mf = rows(self.cost_mf.as_slice_mut().expect("standard layout"), runs);
        let mut cost_mb = rows(self.cost_mb.as_slice_mut().expect("standard layout"), runs);
        let mut visited = rows(self.visited.as_slice_mut().expect("standard layout"), runs);
        let mut bonus = rows(self.bonus.as_slice_mut().expect("standard layout"), runs);
        let mut ring = rows(self.ring.as_slice_mut().expect("standard layout"), runs);
        let mut ring_len = rows(self.ring_len.as_slice_mut().expect("standard layout"), runs);
        let mut ring_pos = rows(self.ring_pos.as_slice_mut().expect("standard layout"), runs);
        let mut count = rows(
            self.outcome_count.as_slice_mut().expect("standard layout"),
            runs,
        );
        let mut reward = rows(
            self.outcome_reward.as_slice_mut().expect("standard layout"),
            runs,
        );
        let mut terminal = rows(
            self.outcome_terminal
                .as_slice_mut()
                .expect("standard layout"),
            runs,
        );
        let mut known = rows(self.known.as_slice_mut().expect("standard layout"), runs);
        let mut vi_best = rows(self.vi_best.as_slice_mut().expect("standard layout"), runs);
        let mut vi_dirty = rows(self.vi_dirty.as_slice_mut().expect("standard layout"), runs);
        let mut vi_terms = self.vi_terms.iter_mut();
        let obs: &Observable = &self.obs;
        let mut scratch = rows(self.scratch.as_slice_mut().expect("standard layout"), runs);
        let mut series_rest: &mut [Checkpoint] = &mut self.series;
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
            let view = RunView {
                q_mf: q_mf.next().expect("one row per run"),
                q_mb: q_mb.next().expect("one row per run"),
                pavg_mf: pavg_mf.next().expect("one row per run"),
                pavg_mb: pavg_mb.next().expect("one row per run"),
                entropy_mf: entropy_mf.next().expect("one row per run"),
                entropy_mb: entropy_mb.next().expect("one row per run"),
                p_mf: p_mf.next().expect("one row per run"),
                max_mf: max_mf.next().expect("one row per run"),
                settled: settled.next().expect("one row per run"),
                cost_mf: cost_mf.next().expect("one row per run"),
                cost_mb: cost_mb.next().expect("one row per run"),
                visited: visited.next().expect("one row per run"),
                bonus: bonus.next().expect("one row per run"),
                model: Model {
                    ring: ring.next().expect("one row per run"),
                    ring_len: ring_len.next().expect("one row per run"),
                    ring_pos: ring_pos.next().expect("one row per run"),
                    count: count.next().expect("one row per run"),
                    reward: reward.next().expect("one row per run"),
                    terminal: terminal.next().expect("one row per run"),
                    known: known.next().expect("one row per run"),
                    best: vi_best.next().expect("one row per run"),
                    dirty: vi_dirty.next().expect("one row per run"),
                    active_terms: vi_terms.next().expect("one per run"),
                    obs,
                },
                scratch: scratch.next().expect("one row per run"),
                rng,
                cursor,
                stats,
                series,
                plan: plans.get(usize::from(self.run_plan[r])),
            };
            views.push((&config.params, view));
        }
        views
    }
}

impl RunView<'_> {
    /// Writes the run's initial tables (see [`Batch::start_runs`]).
    fn start(&mut self, params: &Params, n_actions: usize) {
        let uniform_p = 1.0 / n_actions as f64;
        self.q_mf.fill(params.q_init);
        self.q_mb.fill(params.q_init);
        self.pavg_mf.fill(uniform_p);
        self.pavg_mb.fill(uniform_p);
        self.entropy_mf.fill(f64::NAN);
        self.entropy_mb.fill(f64::NAN);
        self.p_mf.fill(0.0);
        // The maximum of a row of q_init, folded as learning folds it (kept by `mf` runs only,
        // whose MF table is there).
        let row = self.q_mf.get(..n_actions).unwrap_or(&[]);
        self.max_mf.fill(crate::expert::max_of(row));
        self.settled.fill(0);
        self.cost_mf.fill(0.0);
        self.cost_mb.fill(0.0);
        self.visited.fill(false);
        self.bonus.fill(0);
        self.model.clear();
        self.scratch.fill(0.0);
    }
}

/// Consecutive rows of `len` elements of a slice, handed out one by one; empty rows forever when
/// `len` is 0.
struct Rows<'a, T> {
    rest: &'a mut [T],
    len: usize,
}

impl<'a, T> Iterator for Rows<'a, T> {
    type Item = &'a mut [T];

    fn next(&mut self) -> Option<&'a mut [T]> {
        if self.rest.len() < self.len {
            return None;
        }
        let (row, rest) = std::mem::take(&mut self.rest).split_at_mut(self.len);
        self.rest = rest;
        Some(row)
    }
}

/// Draws a run's initial state: uniform over the spec's initial states (no draw when only one).
pub fn initial_state(spec: &Spec, rng: &mut Xoshiro256PlusPlus) -> StateId {
    match spec.initial_states.len() {
        1 => spec.initial_states[0],
        n => spec.initial_states[((uniform(rng) * n as f64) as usize).min(n - 1)],
    }
}
