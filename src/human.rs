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
}

impl Encounter<'_> {
    /// An opportunity to interact: one draw; an attentive human is counted by `given` and spends
    /// one unit of budget, recording the step that spends the last (true); an inattentive one
    /// counts a forgotten opportunity (false).
    #[inline(always)]
    fn attend(&mut self, given: impl FnOnce(&mut RunStats)) -> bool {
        if uniform(self.rng) >= self.human.forget_prob {
            given(self.stats);
            *self.budget_left -= 1;
            if *self.budget_left == 0 {
                self.stats.budget_exhausted_step = self.t_exp;
            }
            true
        } else {
            self.stats.forgotten += 1;
            false
        }
    }

    /// Item 2 of SPEC 3.4 in state `s`: the human's put when an attentive takeover human takes
    /// over from the robot, else `None`.
    #[inline]
    pub fn takeover(&mut self, s: usize) -> Option<usize> {
        if self.human.interaction != Interaction::Takeover {
            return None;
        }
        let put = self.tables.map_or(NO_TAKEOVER, |h| h.takeover_action[s]);
        if put == NO_TAKEOVER {
            return None;
        }
        self.attend(|s| s.takeovers += 1).then_some(put as usize)
    }

    /// Item 7 of SPEC 3.4 for the executed pair `sa`: G(s, a) of Eq. 8, 1 when an attentive
    /// human with budget left congratulates a relevant action (or punishes an error), else 0.
    #[inline]
    pub fn feedback(&mut self, sa: usize) -> u8 {
        if *self.budget_left == 0 {
            return 0;
        }
        let congratulation = self.human.interaction == Interaction::Congratulation;
        let opportunity = match self.human.interaction {
            Interaction::Congratulation => self.tables.is_some_and(|h| h.relevant[sa]),
            Interaction::Punishment => self.tables.is_some_and(|h| h.error[sa]),
            _ => false,
        };
        let given = opportunity
            && self.attend(|s| {
                if congratulation {
                    s.congratulations += 1;
                } else {
                    s.punishments += 1;
                }
            });
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

/// The weight of G(s, a) in the experts' softmax (Eq. 8): +zeta for congratulation, -zeta for
/// punishment, 0 otherwise, and 0 for a congratulation that shapes the reward instead (11.3).
#[inline]
pub fn bonus_weight(human: &HumanParams, effect: CongratulationEffect) -> f64 {
    match human.interaction {
        Interaction::Congratulation if effect == CongratulationEffect::Bias => human.zeta,
        Interaction::Punishment => -human.zeta,
        _ => 0.0,
    }
}
