//! The simulated human (SPEC 5, 11): takeover, congratulation and punishment, nuisance, reward
//! given by the human only, forgetting and the budget, as pure functions over one run's
//! counters. The step kernel (`batch::step`) calls them
//! at the points of SPEC 3.4; each draws the human's attentiveness from the run's stream only
//! when there is an opportunity, so the draw order is the one documented there.

use rand_xoshiro::Xoshiro256PlusPlus;

use crate::env::{HumanTables, NO_NUISANCE, NO_TAKEOVER};
use crate::params::{CongratulationEffect, HumanParams, Interaction};
use crate::rng::uniform;
use crate::run_stats::RunStats;

/// A run's side of its human's opportunities at experiment step `t_exp` (after babbling, with
/// budget left): who the human is now, the world's tables of opportunities, and what an
/// interaction spends, counts and draws.
pub struct Encounter<'a> {
    /// The human now.
    pub human: &'a HumanParams,
    /// Where the human can act in the run's world now (`None`: nowhere).
    pub tables: Option<&'a HumanTables>,
    /// Interactions the human may still give.
    pub budget_left: &'a mut u32,
    /// The run's accumulators, where interactions and forgotten opportunities are counted.
    pub stats: &'a mut RunStats,
    /// The experiment step (1-based).
    pub t_exp: u32,
    /// The run's random stream.
    pub rng: &'a mut Xoshiro256PlusPlus,
    /// A real person's takeover waiting for the step (the action they chose, SPEC 15), or
    /// [`NO_PUT`]; always [`NO_PUT`] for a simulated human.
    pub put: &'a mut u16,
}

/// No takeover waiting (see [`Encounter::put`]).
pub const NO_PUT: u16 = u16::MAX;

impl Encounter<'_> {
    /// An opportunity to interact: one draw; an attentive human is counted by `given` and spends
    /// one unit of budget, recording the step that spends the last (true); an inattentive one
    /// counts a forgotten opportunity (false).
    #[inline(always)]
    fn attend(&mut self, given: impl FnOnce(&mut RunStats)) -> bool {
        self.attend_then(|_| true, given)
    }

    /// An opportunity with a judgment (SPEC 15): the attention draw; an attentive human then
    /// decides with `decides` (which may draw), and interacts (as in [`Self::attend`]) only
    /// if it says so. An inattentive one counts a forgotten opportunity; an attentive one that
    /// decides against interacting counts nothing and spends nothing.
    #[inline(always)]
    fn attend_then(
        &mut self,
        decides: impl FnOnce(&mut Xoshiro256PlusPlus) -> bool,
        given: impl FnOnce(&mut RunStats),
    ) -> bool {
        if uniform(self.rng) < self.human.forget_prob {
            self.stats.forgotten += 1;
            return false;
        }
        if !decides(self.rng) {
            return false;
        }
        spend(self.budget_left, self.stats, self.t_exp, given);
        true
    }

    /// Item 2 of SPEC 3.4 in state `s`: the human's put when an attentive takeover human takes
    /// over from the robot, else `None`.
    #[inline]
    pub fn takeover(&mut self, s: usize) -> Option<usize> {
        let person = match self.human.interaction {
            Interaction::Takeover => false,
            Interaction::Person => true,
            _ => return None,
        };
        let put = self.tables.map_or(NO_TAKEOVER, |h| h.takeover_action[s]);
        if person {
            // A person's choice, if they made one while the robot holds a cube: no draw.
            let chosen = std::mem::replace(self.put, NO_PUT);
            if put == NO_TAKEOVER || chosen == NO_PUT {
                return None;
            }
            spend(self.budget_left, self.stats, self.t_exp, |s| {
                s.takeovers += 1
            });
            return Some(usize::from(chosen));
        }
        if put == NO_TAKEOVER {
            return None;
        }
        self.attend(|s| s.takeovers += 1).then_some(put as usize)
    }

    /// Item 7 of SPEC 3.4 for the executed pair `sa`: G(s, a) of Eq. 8, 1 when an attentive
    /// human with budget left congratulates (or punishes) it, else 0.
    ///
    /// With `error_prob` 0 only a relevant action (an error, for punishment) is an opportunity
    /// and the human judges it rightly: one draw, SPEC 5 draw for draw. With `error_prob` e > 0
    /// every executed action is one (SPEC 15): the attention draw, then the judgment draw, which
    /// is wrong with probability e; a wrong judgment gives feedback to an action that does not
    /// merit it (and spends budget, as any interaction) or withholds it from one that does.
    #[inline]
    pub fn feedback(&mut self, sa: usize) -> u8 {
        if *self.budget_left == 0 {
            return 0;
        }
        let congratulation = self.human.interaction == Interaction::Congratulation;
        let merits = match self.human.interaction {
            Interaction::Congratulation => self.tables.map(|h| h.relevant[sa]),
            Interaction::Punishment => self.tables.map(|h| h.error[sa]),
            _ => None,
        };
        let Some(merits) = merits else {
            return 0;
        };
        let error_prob = self.human.error_prob;
        if error_prob == 0.0 && !merits {
            return 0;
        }
        let given = self.attend_then(
            |rng| error_prob == 0.0 || judges(merits, error_prob, uniform(rng)),
            |s| {
                if congratulation {
                    s.congratulations += 1;
                } else {
                    s.punishments += 1;
                }
            },
        );
        u8::from(given)
    }

    /// SPEC 11.2 after the robot's relevant action `sa`: the state an attentive nuisance human
    /// with budget left leaves (the cube taken back out onto the table), else `None`.
    #[inline]
    pub fn nuisance(&mut self, sa: usize) -> Option<usize> {
        if *self.budget_left == 0 || self.human.interaction != Interaction::Nuisance {
            return None;
        }
        let tables = self.tables?;
        let undone = tables.nuisance[sa];
        if !tables.relevant[sa] || undone == NO_NUISANCE {
            return None;
        }
        self.attend(|s| s.nuisances += 1).then_some(undone as usize)
    }

    /// SPEC 11.1 at an arrival in the goal after babbling, where only the human brings reward:
    /// the goal's `reward` if an attentive human with budget left gives it, else 0.
    #[inline]
    pub fn reward(&mut self, reward: f64) -> f64 {
        if *self.budget_left > 0 && self.attend(|s| s.rewards_given += 1) {
            reward
        } else {
            0.0
        }
    }
}

/// An interaction given at experiment step `t_exp`: counted by `given`, one unit of budget
/// spent, and the step that spends the last recorded.
#[inline(always)]
pub fn spend(
    budget_left: &mut u32,
    stats: &mut RunStats,
    t_exp: u32,
    given: impl FnOnce(&mut RunStats),
) {
    given(stats);
    *budget_left -= 1;
    if *budget_left == 0 {
        stats.budget_exhausted_step = t_exp;
    }
}

/// The judgment of an attentive human with error probability `error_prob` on an action that
/// `merits` feedback (a relevant action for congratulation, an error for punishment), from the
/// judgment draw `u`: wrong when `u < error_prob`, so feedback comes with probability
/// 1 - error_prob where merited and error_prob elsewhere (SPEC 15, Loftin et al. 2016).
#[inline(always)]
pub fn judges(merits: bool, error_prob: f64, u: f64) -> bool {
    merits != (u < error_prob)
}

/// The weight of G(s, a) in the experts' softmax (Eq. 8): +zeta for congratulation, -zeta for
/// punishment, 0 otherwise, and 0 for a congratulation that shapes the reward instead (11.3).
/// A person's G is +1 (congratulation) or -1 (punishment, stored as
/// [`crate::expert::PUNISHED`]), weighted by +zeta.
#[inline]
pub fn bonus_weight(human: &HumanParams, effect: CongratulationEffect) -> f64 {
    match human.interaction {
        Interaction::Congratulation if effect == CongratulationEffect::Bias => human.zeta,
        Interaction::Punishment => -human.zeta,
        Interaction::Person => human.zeta,
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use rand_core::SeedableRng;

    use super::*;

    /// Two pairs: 0 relevant (and not an error), 1 an error.
    fn tables() -> HumanTables {
        HumanTables {
            relevant: vec![true, false],
            error: vec![false, true],
            takeover_action: vec![NO_TAKEOVER],
            nuisance: vec![NO_NUISANCE; 2],
        }
    }

    /// The outcome of one feedback opportunity on pair `sa`: G, the budget left, the counters
    /// and the draws taken from a stream seeded with `seed`.
    fn feedback(human: HumanParams, sa: usize, seed: u64) -> (u8, u32, RunStats, usize) {
        let tables = tables();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let start = rng.clone();
        let (mut budget_left, mut stats) = (5, RunStats::default());
        let g = Encounter {
            human: &human,
            tables: Some(&tables),
            budget_left: &mut budget_left,
            stats: &mut stats,
            t_exp: 9,
            rng: &mut rng,
            put: &mut { NO_PUT },
        }
        .feedback(sa);
        let draws = (0..4)
            .find(|&k| {
                let mut probe = start.clone();
                (0..k).for_each(|_| _ = uniform(&mut probe));
                probe == rng
            })
            .expect("at most three draws");
        (g, budget_left, stats, draws)
    }

    fn human(interaction: Interaction, forget_prob: f64, error_prob: f64) -> HumanParams {
        HumanParams {
            interaction,
            budget: 5,
            forget_prob,
            error_prob,
            ..HumanParams::default()
        }
    }

    #[test]
    fn a_judgment_is_wrong_exactly_when_its_draw_is_below_error_prob() {
        assert!(judges(true, 0.3, 0.3) && judges(true, 0.3, 0.9));
        assert!(!judges(true, 0.3, 0.29) && !judges(true, 1.0, 0.999));
        assert!(judges(false, 0.3, 0.0) && judges(false, 0.3, 0.299));
        assert!(!judges(false, 0.3, 0.3) && !judges(false, 0.0, 0.0));
    }

    #[test]
    fn without_error_only_a_merited_action_draws_and_it_draws_once() {
        let c = human(Interaction::Congratulation, 0.0, 0.0);
        // The other action: no opportunity, no draw, nothing counted.
        assert_eq!(feedback(c, 1, 3), (0, 5, RunStats::default(), 0));
        let (g, left, stats, draws) = feedback(c, 0, 3);
        assert_eq!((g, left, stats.congratulations, draws), (1, 4, 1, 1));
        let p = human(Interaction::Punishment, 0.0, 0.0);
        assert_eq!(feedback(p, 0, 3).3, 0);
        let (g, left, stats, draws) = feedback(p, 1, 3);
        assert_eq!((g, left, stats.punishments, draws), (1, 4, 1, 1));
    }

    #[test]
    fn an_always_wrong_attentive_human_rewards_the_wrong_action_and_spends_budget() {
        // forget 0, error 1: attention then judgment on every action, always wrong.
        let c = human(Interaction::Congratulation, 0.0, 1.0);
        let (g, left, stats, draws) = feedback(c, 0, 11);
        assert_eq!(
            (g, left, stats.congratulations, stats.forgotten, draws),
            (0, 5, 0, 0, 2)
        );
        let (g, left, stats, draws) = feedback(c, 1, 11);
        assert_eq!((g, left, stats.congratulations, draws), (1, 4, 1, 2));
        let p = human(Interaction::Punishment, 0.0, 1.0);
        let (g, left, stats, _) = feedback(p, 0, 11);
        assert_eq!((g, left, stats.punishments), (1, 4, 1));
        assert_eq!(feedback(p, 1, 11).0, 0);
    }

    #[test]
    fn an_inattentive_human_draws_no_judgment() {
        let c = human(Interaction::Congratulation, 1.0, 0.5);
        for sa in [0, 1] {
            let (g, left, stats, draws) = feedback(c, sa, 5);
            assert_eq!((g, left, stats.forgotten, draws), (0, 5, 1, 1));
        }
    }

    #[test]
    fn each_seeded_opportunity_follows_its_attention_then_judgment_draws() {
        let (f, e) = (0.4, 0.35);
        let mut seen = [[0u32; 2]; 3];
        for seed in 0..200 {
            let mut stream = Xoshiro256PlusPlus::seed_from_u64(seed);
            let (u_attention, u_judgment) = (uniform(&mut stream), uniform(&mut stream));
            for sa in [0, 1] {
                let c = human(Interaction::Congratulation, f, e);
                let (g, left, stats, draws) = feedback(c, sa, seed);
                let merits = sa == 0;
                let case = if u_attention < f {
                    assert_eq!((g, stats.forgotten, draws), (0, 1, 1), "seed {seed}");
                    0
                } else {
                    let wrong = u_judgment < e;
                    assert_eq!(g == 1, merits != wrong, "seed {seed} pair {sa}");
                    assert_eq!((stats.forgotten, draws), (0, 2), "seed {seed}");
                    1 + usize::from(wrong)
                };
                assert_eq!(left, 5 - u32::from(g), "seed {seed}");
                seen[case][sa] += 1;
            }
        }
        // Every branch was taken for both pairs.
        assert!(seen.iter().flatten().all(|&n| n > 0), "{seen:?}");
    }

    #[test]
    fn no_feedback_once_the_budget_is_spent_and_none_for_other_humans() {
        let tables = tables();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
        let (mut budget_left, mut stats) = (0, RunStats::default());
        let c = human(Interaction::Congratulation, 0.0, 0.5);
        let mut meet = Encounter {
            human: &c,
            tables: Some(&tables),
            budget_left: &mut budget_left,
            stats: &mut stats,
            t_exp: 1,
            rng: &mut rng,
            put: &mut { NO_PUT },
        };
        assert_eq!(meet.feedback(0), 0);
        assert_eq!(
            feedback(human(Interaction::Takeover, 0.0, 0.5), 0, 1),
            (0, 5, RunStats::default(), 0)
        );
        assert_eq!(
            feedback(human(Interaction::Nuisance, 0.0, 0.5), 1, 1),
            (0, 5, RunStats::default(), 0)
        );
    }

    #[test]
    fn the_last_unit_of_budget_spent_by_a_wrong_congratulation_is_recorded() {
        let tables = tables();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
        let (mut budget_left, mut stats) = (1, RunStats::default());
        let c = human(Interaction::Congratulation, 0.0, 1.0);
        let g = Encounter {
            human: &c,
            tables: Some(&tables),
            budget_left: &mut budget_left,
            stats: &mut stats,
            t_exp: 42,
            rng: &mut rng,
            put: &mut { NO_PUT },
        }
        .feedback(1);
        assert_eq!((g, budget_left, stats.budget_exhausted_step), (1, 0, 42));
    }
}
