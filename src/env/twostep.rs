//! `twostep`: the two-step task of Daw et al. 2011 (SPEC 13), the task with per-run state.
//!
//! State 0 is the first stage, 1 and 2 the second; two actions everywhere. From 0, action 0
//! goes to 1 with probability `common_prob` and to 2 otherwise, action 1 the other way round.
//! In 1 or 2, action a brings reward 1 with probability p(s, a) and ends the trial: the arrival
//! is terminal and already state 0, with no reset step (`End::Restart`), so a trial is two
//! steps. The four p are the run's task state ([`Dynamics`], slots in the order (1,0), (1,1),
//! (2,0), (2,1)): drawn uniformly in [0.25, 0.75] when the run starts and again when the
//! experiment starts after babbling, and after every trial each takes a Gaussian step of sd
//! `drift_sd`, reflected into [0.25, 0.75].
//!
//! The task reports the stay probabilities of the literature (its [`Metric`]s, from its
//! [`Tally`] of the experiment's trials): how often the first-stage action repeats the previous
//! trial's, after a rewarded or unrewarded trial whose transition was common or rare.

use rand_xoshiro::Xoshiro256PlusPlus;

use super::registry::{DEFAULTS, Metric, Task};
use super::{Arrival, Chance, Dynamics, End, Goal, Spec, StateId, Tally};
use crate::rng::uniform;

/// The transition probability of the common transitions, by default.
pub const COMMON_PROB: f64 = 0.7;
/// The standard deviation of the reward probabilities' drift per trial, by default.
pub const DRIFT_SD: f64 = 0.025;
/// The bounds the reward probabilities stay within.
pub const P_MIN: f64 = 0.25;
/// See [`P_MIN`].
pub const P_MAX: f64 = 0.75;

/// The two-step task in the task registry.
pub const TWOSTEP: Task = Task {
    name: "twostep",
    help: "Daw et al.'s two-step task: a first-stage choice, common (0.7) or rare transitions, \
           drifting reward probabilities (SPEC 13)",
    build: |_| Ok(build(COMMON_PROB, DRIFT_SD)),
    default_steps: 402,
    default_babbling: 0,
    human_reward: false,
    params: &["common_prob", "drift_sd"],
    configure: |p| Ok(Some(build(p.common_prob, p.drift_sd))),
    metrics: &[
        Metric {
            name: "stay_rc",
            doc: "twostep: share of the experiment's trials following a rewarded trial with a common transition whose first-stage action repeats that trial's; null if there was none",
            unit: "probability",
            value: |t| stay(t, RC),
        },
        Metric {
            name: "stay_rr",
            doc: "twostep: the same after a rewarded trial with a rare transition",
            unit: "probability",
            value: |t| stay(t, RR),
        },
        Metric {
            name: "stay_uc",
            doc: "twostep: the same after an unrewarded trial with a common transition",
            unit: "probability",
            value: |t| stay(t, UC),
        },
        Metric {
            name: "stay_ur",
            doc: "twostep: the same after an unrewarded trial with a rare transition",
            unit: "probability",
            value: |t| stay(t, UR),
        },
        Metric {
            name: "stay_reward_effect",
            doc: "twostep: (stay_rc + stay_rr - stay_uc - stay_ur) / 2, the model-free signature; null if one is null",
            unit: "probability",
            value: |t| effects(t).map(|e| e.0),
        },
        Metric {
            name: "stay_interaction",
            doc: "twostep: (stay_rc - stay_rr - stay_uc + stay_ur) / 2, the model-based signature; null if one is null",
            unit: "probability",
            value: |t| effects(t).map(|e| e.1),
        },
    ],
    headline: &[
        ("reward effect", "stay_reward_effect"),
        ("interaction", "stay_interaction"),
    ],
    headline_note: "two-step signatures, mean ± sd over runs (SPEC 13: MF's is the reward \
                    effect, MB's the interaction); `mbmf stay` on the output folder tests them \
                    and draws the figure",
    ..DEFAULTS
};

/// The kinds of a previous trial, in the order of the columns: rewarded or unrewarded, common
/// or rare transition.
pub const RC: usize = 0;
/// See [`RC`].
pub const RR: usize = 1;
/// See [`RC`].
pub const UC: usize = 2;
/// See [`RC`].
pub const UR: usize = 3;

/// The slots of the tally: whether a trial has ended (1) and its kind, this trial's
/// first-stage action and whether its transition was common, the previous trial's first-stage
/// action, then per kind the trials that followed one of that kind and those that repeated its
/// first-stage action.
const HAS_PREVIOUS: usize = 0;
const PREVIOUS_KIND: usize = 1;
const FIRST_ACTION: usize = 2;
const COMMON: usize = 3;
const PREVIOUS_ACTION: usize = 4;
const TRIALS: usize = 5;
const STAYS: usize = 9;
/// Values of the tally.
pub const TALLY_LEN: usize = 13;

/// Counts a step of the experiment (the tally's `note`): a first-stage step counts a stay or a
/// switch after the previous trial's kind and remembers its action and transition; a
/// second-stage step ends the trial and makes it the previous one. A transition is common when
/// it goes where the action goes with `common_prob` (action 0 to state 1, action 1 to 2).
fn note(t: &mut [f64], s: usize, a: usize, next: usize, reward: f64) {
    if s == 0 {
        if t[HAS_PREVIOUS] == 1.0 {
            let kind = t[PREVIOUS_KIND] as usize;
            t[TRIALS + kind] += 1.0;
            if a as f64 == t[PREVIOUS_ACTION] {
                t[STAYS + kind] += 1.0;
            }
        }
        t[FIRST_ACTION] = a as f64;
        t[COMMON] = if next == a + 1 { 1.0 } else { 0.0 };
    } else {
        let rewarded = reward > 0.0;
        let common = t[COMMON] == 1.0;
        t[HAS_PREVIOUS] = 1.0;
        t[PREVIOUS_ACTION] = t[FIRST_ACTION];
        t[PREVIOUS_KIND] = match (rewarded, common) {
            (true, true) => RC,
            (true, false) => RR,
            (false, true) => UC,
            (false, false) => UR,
        } as f64;
    }
}

/// The stay probability after a trial of `kind`, from a run's tally; `None` when no trial
/// followed one of that kind.
pub fn stay(tally: &[f64], kind: usize) -> Option<f64> {
    let trials = tally[TRIALS + kind];
    (trials > 0.0).then(|| tally[STAYS + kind] / trials)
}

/// (reward effect, interaction) from a run's tally (SPEC 13); `None` unless all four stay
/// probabilities are defined.
pub fn effects(tally: &[f64]) -> Option<(f64, f64)> {
    let (rc, rr, uc, ur) = (
        stay(tally, RC)?,
        stay(tally, RR)?,
        stay(tally, UC)?,
        stay(tally, UR)?,
    );
    Some(((rc + rr - uc - ur) / 2.0, (rc - rr - uc + ur) / 2.0))
}

/// The slot of the task state holding p(s, a) of second-stage state `s` (1 or 2).
pub fn slot(s: usize, a: usize) -> usize {
    (s - 1) * 2 + a
}

/// Compiles the two-step task with its common-transition probability and drift.
pub fn build(common_prob: f64, drift_sd: f64) -> Spec {
    let to = |first: StateId, p: f64| {
        [(first, p), (3 - first, 1.0 - p)]
            .into_iter()
            .filter(|&(_, w)| w > 0.0)
            .collect::<Vec<_>>()
    };
    let outcomes = vec![
        to(1, common_prob),
        to(2, common_prob),
        vec![(0, 1.0)],
        vec![(0, 1.0)],
        vec![(0, 1.0)],
        vec![(0, 1.0)],
    ];
    let names = ["first stage", "second stage 1", "second stage 2"];
    let spec = Spec::from_outcomes(
        "twostep".to_string(),
        3,
        2,
        outcomes,
        vec![0],
        // Replaced by the arrivals below.
        Goal {
            state: 0,
            reward: 1.0,
        },
        names.iter().map(|n| n.to_string()).collect(),
        None,
    );
    let arrivals = (0..spec.outcome_state.len())
        .map(|o| {
            let sa = spec
                .outcome_start
                .partition_point(|&start| start as usize <= o)
                - 1;
            let (s, a) = (sa / 2, sa % 2);
            if s == 0 {
                Arrival::NOTHING
            } else {
                Arrival {
                    reward: 1.0,
                    chance: Chance::DrawnFrom(slot(s, a)),
                    end: End::Restart,
                }
            }
        })
        .collect();
    let mut spec = spec.with_arrivals(arrivals);
    spec.dynamics = Some(Dynamics {
        len: 4,
        constants: vec![drift_sd],
        start: start_probabilities,
        after_episode: drift,
    });
    spec.with_tally(Tally {
        len: TALLY_LEN,
        note,
    })
}

/// The four p, uniform in [0.25, 0.75], in slot order: four uniform draws.
fn start_probabilities(_: &Dynamics, p: &mut [f64], rng: &mut Xoshiro256PlusPlus) {
    for p in p.iter_mut() {
        *p = P_MIN + (P_MAX - P_MIN) * uniform(rng);
    }
}

/// One Gaussian step of sd `constants[0]` for each p, in slot order, reflected into
/// [0.25, 0.75].
fn drift(d: &Dynamics, p: &mut [f64], rng: &mut Xoshiro256PlusPlus) {
    let sd = d.constants[0];
    for p in p.iter_mut() {
        *p = reflect(*p + sd * standard_normal(rng));
    }
}

/// `p` reflected at the bounds until within them (once for any step shorter than 0.5).
pub fn reflect(mut p: f64) -> f64 {
    loop {
        if p > P_MAX {
            p = 2.0 * P_MAX - p;
        } else if p < P_MIN {
            p = 2.0 * P_MIN - p;
        } else {
            return p;
        }
    }
}

/// A standard normal by the Box–Muller transform: two uniform draws of the run's stream per
/// normal (the cosine branch; the sine one is not kept, so no state is carried between draws).
pub fn standard_normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    let u1 = 1.0 - uniform(rng); // in (0, 1]: the logarithm is finite
    let u2 = uniform(rng);
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_stage_transitions_and_terminal_second_stage() {
        let spec = build(COMMON_PROB, DRIFT_SD);
        let o = spec.outcomes(spec.sa(0, 0));
        assert_eq!(&spec.outcome_state[o.clone()], &[1, 2]);
        assert!((spec.outcome_cum[o.start] - 0.7).abs() < 1e-12);
        for s in 1..3 {
            for a in 0..2 {
                let o = spec.outcomes(spec.sa(s, a)).start;
                assert_eq!(spec.outcome_state[o], 0);
                let arrival = spec.arrival[o];
                assert_eq!(arrival.end, End::Restart);
                assert_eq!(arrival.chance, Chance::DrawnFrom(slot(s, a)));
            }
        }
        assert!(!spec.arrival[spec.outcomes(spec.sa(0, 1)).start].terminal());
    }

    #[test]
    fn stays_are_counted_by_the_previous_trials_reward_and_transition_by_hand() {
        // Trials as (first action, second-stage state, reward):
        // 1. (0, 1, 1): rewarded common.
        // 2. (0, 2, 0): stays after rc; unrewarded rare.
        // 3. (1, 2, 1): switches after ur; rewarded common.
        // 4. (1, 1, 0): stays after rc; unrewarded rare.
        // 5. (1, 2, 0): stays after ur; unrewarded common.
        // 6. (0, 1, 0): switches after uc.
        // So rc: 2 of 2 stay; rr: none; uc: 0 of 1; ur: 1 of 2.
        let mut t = [0.0; TALLY_LEN];
        for (a, s2, r) in [
            (0, 1, 1.0),
            (0, 2, 0.0),
            (1, 2, 1.0),
            (1, 1, 0.0),
            (1, 2, 0.0),
            (0, 1, 0.0),
        ] {
            note(&mut t, 0, a, s2, 0.0);
            note(&mut t, s2, 0, 0, r);
        }
        assert_eq!(stay(&t, RC), Some(1.0));
        assert_eq!(stay(&t, RR), None);
        assert_eq!(stay(&t, UC), Some(0.0));
        assert_eq!(stay(&t, UR), Some(0.5));
        assert_eq!(effects(&t), None);
        // 7. (0, 2, 1): stays after uc; rewarded rare. 8. (1, ...): switches after rr. Now all
        // four are defined: rc 1, rr 0 of 1, uc 1 of 2, ur 0.5.
        note(&mut t, 0, 0, 2, 0.0);
        note(&mut t, 2, 1, 0, 1.0);
        note(&mut t, 0, 1, 2, 0.0);
        assert_eq!(stay(&t, UC), Some(0.5));
        assert_eq!(stay(&t, RR), Some(0.0));
        let (reward, interaction) = effects(&t).unwrap();
        // (1 + 0 - 0.5 - 0.5) / 2 = 0; (1 - 0 - 0.5 + 0.5) / 2 = 0.5.
        assert_eq!((reward, interaction), (0.0, 0.5));
    }

    #[test]
    fn reflection_keeps_p_in_bounds() {
        assert!((reflect(0.76) - 0.74).abs() < 1e-12);
        assert!((reflect(0.24) - 0.26).abs() < 1e-12);
        assert_eq!(reflect(0.5), 0.5);
        assert!((P_MIN..=P_MAX).contains(&reflect(2.3)));
    }
}
