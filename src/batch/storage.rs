//! The batch's per-run arrays, declared once: the `tables!` list below generates their owned
//! storage ([`Tables`]: allocation and `state_layout` rows), one run's views into them
//! ([`RunView`]), each run's initial values, and the bytes one run needs ([`Sizes::bytes`],
//! which the memory estimate of `pipeline` reads). Adding an array is adding a row.
//!
//! Each array holds one row per run, all of one length, run after run; an array no run of the
//! batch needs (the tables of an expert no run runs) has rows of length 0.

use rand_xoshiro::Xoshiro256PlusPlus;

use super::trace::TraceRows;
use super::{Checkpoint, Cursor, RunStats, Settled};
use crate::env::Spec;
use crate::expert::mb::Model;
use crate::params::{Combine, Controller, Params};
use crate::schedule::Plan;

/// The lengths the rows of the per-run arrays are made of.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sizes {
    /// States of the task.
    pub states: usize,
    /// Actions of the task.
    pub actions: usize,
    /// States of the MF expert's tables: the task's, or 0 when no run runs MF.
    pub mf_states: usize,
    /// States of the MB expert's tables: the task's, or 0 when no run runs MB.
    pub mb_states: usize,
    /// States of the MF expert's averaged distribution and its entropy: the task's when a run
    /// runs MF with a rule that keeps them ([`crate::arbiter::Arbiter::AVERAGES`]), else 0.
    pub avg_mf_states: usize,
    /// The same for the MB expert.
    pub avg_mb_states: usize,
    /// States of the table only runs of the MF expert alone keep (its row maxima between
    /// decisions).
    pub kept_states: usize,
    /// Slots of the MF softmaxes kept between decisions (`kept_slots`).
    pub kept_mf_slots: usize,
    /// The same for the MB expert.
    pub kept_mb_slots: usize,
    /// States of the per-state cost averages: the task's when a run's rule weighs costs
    /// ([`crate::arbiter::Arbiter::WEIGHS_COST`]), else 0.
    pub cost_states: usize,
    /// States of the kept entropies of mixed distributions: the task's when a run without a
    /// human mixes the experts (`mixes_keeping_entropies`), else 0.
    pub mix_states: usize,
    /// States of the weights those entropies were computed with: the task's when such a run's
    /// weight may change from one decision to the next
    /// ([`crate::arbiter::Arbiter::STEADY_WEIGHT`]), else 0.
    pub mix_weight_states: usize,
    /// Observable outcomes of the MB model (0 when no run runs MB).
    pub outcomes: usize,
    /// Ring slots per pair of the MB model: the largest window N of the runs.
    pub window_cap: usize,
    /// Words of the MB model's dirty-pair bit set.
    pub dirty_words: usize,
    /// Scalars per run of the most demanding arbitration rule.
    pub arbiter_scalars: usize,
    /// `[state, action]` tables per run of the most demanding arbitration rule.
    pub arbiter_tables: usize,
    /// Values of per-run task state ([`crate::env::Dynamics::len`]; 0 for a task without).
    pub task_state: usize,
    /// Pairs of the MF eligibility trace: the task's when a run has `lambda_mf` > 0, else 0.
    pub eligibility_pairs: usize,
    /// Values of the task's per-run tally ([`crate::env::Tally::len`]; 0 for a task without).
    pub tally: usize,
}

impl Sizes {
    /// The sizes for runs of `params` on `spec`, whose MB model observes `outcomes` outcomes.
    /// An expert no run needs gets no tables at all: for a batch of `mf` runs that is half of
    /// the memory the batch would otherwise fill, and the page faults and stores to fill it,
    /// which cost more than a tenth of such a batch's whole time.
    pub fn of<'p>(
        spec: &Spec,
        params: impl Iterator<Item = &'p Params> + Clone,
        outcomes: usize,
    ) -> Sizes {
        let n_s = spec.n_states;
        let any = |needs: fn(Controller) -> bool| params.clone().any(|p| needs(p.controller));
        let states_if = |yes: bool| if yes { n_s } else { 0 };
        let mb = any(Controller::runs_mb);
        let max = |f: &dyn Fn(&Params) -> usize| params.clone().map(f).max().unwrap_or(0);
        let mf_alone = any(|c| c.runs_mf() && !c.runs_mb());
        let mb_alone = any(|c| c.runs_mb() && !c.runs_mf());
        // Only a run without a human keeps a softmax it folds (a human may change its G).
        let folds_unattended = |runs: &dyn Fn(Controller) -> bool| {
            params
                .clone()
                .any(|p| runs(p.controller) && p.controller.averages() && !p.human_may_act())
        };
        let slots = if params
            .clone()
            .any(|p| p.controller.weighs_cost() || mixes_keeping_entropies(p))
        {
            KEPT_SLOTS
        } else {
            ROOMY_KEPT_SLOTS
        };
        Sizes {
            states: n_s,
            actions: spec.n_actions,
            mf_states: states_if(any(Controller::runs_mf)),
            mb_states: states_if(mb),
            avg_mf_states: states_if(any(|c| c.runs_mf() && c.averages())),
            avg_mb_states: states_if(any(|c| c.runs_mb() && c.averages())),
            kept_states: states_if(mf_alone),
            kept_mf_slots: kept_slots(n_s, mf_alone, folds_unattended(&|c| c.runs_mf()), slots.0),
            kept_mb_slots: kept_slots(n_s, mb_alone, folds_unattended(&|c| c.runs_mb()), slots.1),
            cost_states: states_if(any(Controller::weighs_cost)),
            mix_states: states_if(params.clone().any(mixes_keeping_entropies)),
            mix_weight_states: states_if(
                params
                    .clone()
                    .any(|p| mixes_keeping_entropies(p) && !p.controller.steady_weight()),
            ),
            outcomes: if mb { outcomes } else { 0 },
            window_cap: max(&|p| p.window_n as usize).max(1),
            dirty_words: if mb {
                (n_s * spec.n_actions).div_ceil(64)
            } else {
                0
            },
            arbiter_scalars: max(&|p| p.controller.run_scalars(p)),
            arbiter_tables: max(&|p| p.controller.pair_tables(p)),
            task_state: spec.dynamics.as_ref().map_or(0, |d| d.len),
            eligibility_pairs: if params.clone().any(Params::uses_eligibility) {
                n_s * spec.n_actions
            } else {
                0
            },
            tally: spec.tally.as_ref().map_or(0, |t| t.len),
        }
    }

    /// Pairs of the MB model's tables.
    fn mb_pairs(&self) -> usize {
        self.mb_states * self.actions
    }
}

/// Whether a run keeps its mixed distributions' entropies between decisions: it mixes the
/// experts (`combine = mix`) without a human, so that a mixed distribution depends only on the
/// two Q rows and the weight. Not a rule that weighs costs (`ec`): its two per-state cost
/// tables already fill a tidy1 run's 64 KiB, so it computes the entropy at every decision.
fn mixes_keeping_entropies(params: &Params) -> bool {
    let rule = params.controller;
    params.combine == Combine::Mix
        && rule.combines()
        && !rule.weighs_cost()
        && !params.human_may_act()
}

/// Slots of a two-expert run's kept MF softmaxes, and of its MB ones: powers of two, so that a
/// state finds its slot with a mask ([`kept_slot`]). At steady state a run decides in a few
/// states over and over (19 in tidy1), and the slots hold most of their softmaxes; their number
/// is what the 64 KiB of state per tidy run of every rule leaves room for (a slot per state, as
/// a single expert's run has, would exceed it): these where a run holds per-state cost averages
/// or mixed distributions' entropies, [`ROOMY_KEPT_SLOTS`] elsewhere.
pub const KEPT_SLOTS: (usize, usize) = (16, 8);

/// [`KEPT_SLOTS`] for a batch whose runs hold neither per-state cost averages nor mixed
/// entropies: the room of those two tables of a tidy run (1,792 bytes) holds 24 more slots.
/// `fixed` and `rnd` give MB half of their decisions, so states' MB softmaxes would otherwise
/// take one another's slots between visits.
pub const ROOMY_KEPT_SLOTS: (usize, usize) = (32, 16);

/// Slots of an expert's kept softmaxes in a batch of `states` states: one per state when a run
/// runs the expert `alone`, `cap` (or one per state, if fewer) when a run runs it with the other
/// expert and `folds` its softmax without a human (only such a fold keeps one), else none.
fn kept_slots(states: usize, alone: bool, folds: bool, cap: usize) -> usize {
    if alone {
        states
    } else if folds {
        states.min(cap)
    } else {
        0
    }
}

/// The slot of state `s` among `slots` kept softmaxes (more than 0, and a power of two if fewer
/// than the states): `s` itself when there is a slot per state, else `s` masked.
#[inline(always)]
pub(super) fn kept_slot(s: usize, slots: usize) -> usize {
    if s < slots { s } else { s & (slots - 1) }
}

/// Each array's row: `name: element type [per-run length] = initial value` (a view row; the
/// MB model's rows have no initial value, `Model::clear` writes theirs). The first line names
/// what lengths and initial values may read: the batch's [`Sizes`], the run's [`Params`] and
/// the task's action count.
macro_rules! tables {
    (
        |$z:ident, $p:ident, $n:ident|
        view { $( $(#[$doc:meta])* $v:ident: $vt:ty [$vlen:expr] = $init:expr; )* }
        model { $( $m:ident: $mt:ty [$mlen:expr]; )* }
    ) => {
        /// Every per-run array of a batch, each one row per run.
        #[derive(Clone)]
        pub(super) struct Tables {
            $(pub(super) $v: Vec<$vt>,)*
            $(pub(super) $m: Vec<$mt>,)*
        }

        impl Tables {
            /// Zeroed arrays for `runs` runs of sizes `z`: allocated, not yet written (see
            /// `Batch::start_runs`).
            pub(super) fn new(runs: usize, $z: &Sizes) -> Tables {
                Tables {
                    $($v: vec![<$vt>::default(); runs * $vlen],)*
                    $($m: vec![<$mt>::default(); runs * $mlen],)*
                }
            }

            /// `spare`'s arrays where each has the length `runs` runs of sizes `z` need (their
            /// contents are stale: every element is written again before a run starts), else
            /// [`Tables::new`]. A finished batch's arrays serve the next batch without mapping
            /// and zeroing fresh pages, the first touch of which costs a page fault each.
            pub(super) fn reuse_or_new(spare: Option<Tables>, runs: usize, $z: &Sizes) -> Tables {
                match spare {
                    Some(t) if true $(&& t.$v.len() == runs * $vlen)* $(&& t.$m.len() == runs * $mlen)* => t,
                    _ => Tables::new(runs, $z),
                }
            }

            /// (name, bytes for all runs) of each array.
            pub(super) fn layout(&self) -> Vec<(&'static str, usize)> {
                vec![
                    $((stringify!($v), std::mem::size_of_val(self.$v.as_slice())),)*
                    $((stringify!($m), std::mem::size_of_val(self.$m.as_slice())),)*
                ]
            }

            /// The arrays' rows, handed out run by run.
            pub(super) fn rows(&mut self, runs: usize) -> TableRows<'_> {
                TableRows {
                    $($v: Rows::new(&mut self.$v, runs),)*
                    $($m: Rows::new(&mut self.$m, runs),)*
                }
            }
        }

        impl Sizes {
            /// Bytes of one run's rows of every array.
            pub fn bytes(&self) -> usize {
                let $z = self;
                0 $(+ $vlen * std::mem::size_of::<$vt>())* $(+ $mlen * std::mem::size_of::<$mt>())*
            }
        }

        /// The rows of every array not handed out yet.
        pub(super) struct TableRows<'a> {
            $($v: Rows<'a, $vt>,)*
            $($m: Rows<'a, $mt>,)*
        }

        impl<'a> TableRows<'a> {
            /// The next run's view: its rows of every array, and what is not an array.
            pub(super) fn next_run(&mut self, rest: Rest<'a>) -> RunView<'a> {
                RunView {
                    $($v: self.$v.next().expect("one row per run"),)*
                    model: Model {
                        $($m: self.$m.next().expect("one row per run"),)*
                        window_cap: rest.window_cap,
                        active_terms: rest.active_terms,
                        obs: rest.obs,
                    },
                    rng: rest.rng,
                    cursor: rest.cursor,
                    stats: rest.stats,
                    series: rest.series,
                    trace: rest.trace,
                    plan: rest.plan,
                }
            }
        }

        /// One run's mutable views into the batch, handed to the step (`batch/step.rs`).
        pub struct RunView<'a> {
            $($(#[$doc])* pub $v: &'a mut [$vt],)*
            /// The MB expert's learned model.
            pub model: Model<'a>,
            /// The run's random stream.
            pub rng: &'a mut Xoshiro256PlusPlus,
            /// Where the run is.
            pub cursor: &'a mut Cursor,
            /// The run's accumulators.
            pub stats: &'a mut RunStats,
            /// The run's checkpoint rows.
            pub series: &'a mut [Checkpoint],
            /// The run's trace rows, one per experiment step (none when the batch is not
            /// traced).
            pub trace: TraceRows<'a>,
            /// The run's schedule of changes, compiled; `None` for a run without changes in the
            /// batch's own environment.
            pub plan: Option<&'a Plan>,
        }

        impl RunView<'_> {
            /// Writes the run's initial values (see `Batch::start_runs`): every view row's, the
            /// empty model, the arbitration rule's own start and the task state's (the task's
            /// `start` hook, drawing from the run's stream, for a task with dynamics).
            pub(super) fn start(
                &mut self,
                params: &Params,
                n_actions: usize,
                dynamics: Option<&crate::env::Dynamics>,
            ) {
                let ($p, $n) = (params, n_actions);
                $(self.$v.fill($init);)*
                if let Some(d) = dynamics {
                    (d.start)(d, self.task_state, self.rng);
                }
                self.model.clear();
                let mut own = crate::arbiter::Own {
                    run: self.arbiter_run,
                    pairs: self.arbiter_pairs,
                };
                crate::arbiter::start(params.controller, params, &mut own);
            }
        }
    };
}

/// What a run's view holds besides its rows of the arrays.
pub(super) struct Rest<'a> {
    pub window_cap: usize,
    pub active_terms: &'a mut u64,
    pub obs: &'a crate::expert::mb::Observable,
    pub rng: &'a mut Xoshiro256PlusPlus,
    pub cursor: &'a mut Cursor,
    pub stats: &'a mut RunStats,
    pub series: &'a mut [Checkpoint],
    pub trace: TraceRows<'a>,
    pub plan: Option<&'a Plan>,
}

tables! {
    |z, p, n_actions|
    view {
        /// MF action values, `[state, action]`.
        q_mf: f64 [z.mf_states * z.actions] = p.q_init;
        /// MB action values, `[state, action]`.
        q_mb: f64 [z.mb_states * z.actions] = p.q_init;
        /// MF averaged action probabilities, `[state, action]` (SPEC 3.3: uniform at first).
        pavg_mf: f64 [z.avg_mf_states * z.actions] = 1.0 / n_actions as f64;
        /// MB averaged action probabilities, `[state, action]`.
        pavg_mb: f64 [z.avg_mb_states * z.actions] = 1.0 / n_actions as f64;
        /// Entropy in bits of each state's MF averaged distribution, NaN when not known since
        /// the row last changed.
        entropy_mf: f64 [z.avg_mf_states] = f64::NAN;
        /// The same for the MB averaged distribution.
        entropy_mb: f64 [z.avg_mb_states] = f64::NAN;
        /// For a run without a human: MF softmaxes kept between decisions, `[slot, action]`
        /// (`kept_slot`; empty for runs that keep none).
        kept_p_mf: f64 [z.kept_mf_slots * z.actions] = 0.0;
        /// The state whose MF softmax each slot holds (`u32::MAX`: none).
        kept_owner_mf: u32 [z.kept_mf_slots] = u32::MAX;
        /// The same for the MB expert.
        kept_p_mb: f64 [z.kept_mb_slots * z.actions] = 0.0;
        /// The state whose MB softmax each slot holds.
        kept_owner_mb: u32 [z.kept_mb_slots] = u32::MAX;
        /// For an `mf` run without a human: the maximum of each state's MF Q row, folded as
        /// learning folds it.
        max_mf: f64 [z.kept_states] = crate::expert::max_of(&[p.q_init]);
        /// For a run without a human: what still holds in each state ([`Settled`]).
        settled: Settled [z.states] = Settled::default();
        /// MF per-state inference cost average (for a rule that weighs costs).
        cost_mf: f64 [z.cost_states] = 0.0;
        /// MB per-state inference cost average.
        cost_mb: f64 [z.cost_states] = 0.0;
        /// For a run that keeps them (`mixes_keeping_entropies`): the entropy in bits of each
        /// state's mixed distribution, valid while [`Settled::mix_kept`] and the weight is the
        /// one it was computed with.
        entropy_mix: f64 [z.mix_states] = f64::NAN;
        /// The weight each kept entropy was computed with (for a rule whose weight may change).
        weight_mix: f64 [z.mix_weight_states] = f64::NAN;
        /// Per state: the robot has decided there before (first-decision rule, SPEC 4).
        visited: bool [z.states] = false;
        /// G(s, a) of Eq. 8, `[state, action]`.
        bonus: u8 [z.states * z.actions] = 0;
        /// The arbitration rule's per-run scalars ([`crate::arbiter::Own::run`]).
        arbiter_run: f64 [z.arbiter_scalars] = 0.0;
        /// The arbitration rule's per-run `[state, action]` tables ([`crate::arbiter::Own::pairs`]).
        arbiter_pairs: f64 [z.arbiter_tables * z.states * z.actions] = 0.0;
        /// 2 |A| values of scratch space for the two experts' distributions.
        scratch: f64 [2 * z.actions] = 0.0;
        /// The task's per-run state ([`crate::env::Dynamics`]; empty for a task without).
        task_state: f64 [z.task_state] = 0.0;
        /// MF eligibility trace e(s, a), `[state, action]` (SPEC 3.1; empty unless a run of the
        /// batch has `lambda_mf` > 0).
        eligibility: f64 [z.eligibility_pairs] = 0.0;
        /// The pairs with e > 0, the first `Cursor::eligible` of them ([`crate::expert::mf::Eligibility`]).
        eligible: u32 [z.eligibility_pairs] = 0;
        /// The task's tally of the experiment ([`crate::env::Tally`]; empty for a task without).
        tally: f64 [z.tally] = 0.0;
    }
    model {
        ring: u16 [z.mb_pairs() * z.window_cap];
        ring_len: u16 [z.mb_pairs()];
        ring_pos: u16 [z.mb_pairs()];
        count: u16 [z.outcomes];
        reward: f64 [z.outcomes];
        terminal: bool [z.outcomes];
        known: bool [z.mb_states];
        best: f64 [z.mb_states];
        dirty: u64 [z.dirty_words];
    }
}

/// Consecutive rows of `len` elements of a slice, handed out one by one; empty rows forever when
/// `len` is 0.
pub(super) struct Rows<'a, T> {
    rest: &'a mut [T],
    len: usize,
}

impl<'a, T> Rows<'a, T> {
    /// The rows of `a`, which holds `runs` equal rows.
    fn new(a: &'a mut [T], runs: usize) -> Self {
        let len = a.len().checked_div(runs).unwrap_or(0);
        Rows { rest: a, len }
    }
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

/// Run `r`'s row of `a`, an array of `runs` equal rows.
pub(super) fn row<T>(a: &[T], runs: usize, r: usize) -> &[T] {
    let len = a.len().checked_div(runs).unwrap_or(0);
    &a[r * len..(r + 1) * len]
}
