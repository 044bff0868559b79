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

/// Spends one unit of budget at experiment step `t_exp`, recording the step that spends the last.
#[inline]
pub fn spend_budget(budget_left: &mut u32, stats: &mut RunStats, t_exp: u32) {
    *budget_left -= 1;
    if *budget_left == 0 {
        stats.budget_exhausted_step = t_exp;
    }
}

/// Whether the human, at an opportunity, is attentive (one draw).
#[inline]
pub fn attentive(human: &HumanParams, rng: &mut Xoshiro256PlusPlus) -> bool {
    uniform(rng) >= human.forget_prob
}

/// An opportunity to interact: one draw; an attentive human is counted by `given` and spends one
/// unit of budget (true), an inattentive one counts a forgotten opportunity (false).
#[inline(always)]
fn attend(
    human: &HumanParams,
    budget_left: &mut u32,
    stats: &mut RunStats,
    t_exp: u32,
    rng: &mut Xoshiro256PlusPlus,
    given: impl FnOnce(&mut RunStats),
) -> bool {
    if attentive(human, rng) {
        given(stats);
        spend_budget(budget_left, stats, t_exp);
        true
    } else {
        stats.forgotten += 1;
        false
    }
}

/// Item 2 of SPEC 3.4 in state `s`: the human's put when an attentive takeover human with
/// budget left takes over from the robot, else `None`. `active` says whether the human may act at
/// all this step (after babbling, budget left). Counts takeovers and forgotten opportunities.
#[inline]
pub fn takeover(
    human: &HumanParams,
    tables: Option<&HumanTables>,
    active: bool,
    s: usize,
    budget_left: &mut u32,
    stats: &mut RunStats,
    t_exp: u32,
    rng: &mut Xoshiro256PlusPlus,
) -> Option<usize> {
    if !active || human.interaction != Interaction::Takeover {
        return None;
    }
    let put = tables.map_or(NO_TAKEOVER, |h| h.takeover_action[s]);
    if put == NO_TAKEOVER {
        return None;
    }
    attend(human, budget_left, stats, t_exp, rng, |s| s.takeovers += 1).then_some(put as usize)
}

/// Item 7 of SPEC 3.4 for the executed pair `sa`: G(s, a) of Eq. 8, 1 when an attentive human
/// with budget left congratulates a relevant action (or punishes an error), else 0. Counts what
/// was given and forgotten.
#[inline]
pub fn feedback(
    human: &HumanParams,
    tables: Option<&HumanTables>,
    active: bool,
    sa: usize,
    budget_left: &mut u32,
    stats: &mut RunStats,
    t_exp: u32,
    rng: &mut Xoshiro256PlusPlus,
) -> u8 {
    if !active || *budget_left == 0 {
        return 0;
    }
    let opportunity = match human.interaction {
        Interaction::Congratulation => tables.is_some_and(|h| h.relevant[sa]),
        Interaction::Punishment => tables.is_some_and(|h| h.error[sa]),
        _ => false,
    };
    if !opportunity {
        return 0;
    }
    let congratulation = human.interaction == Interaction::Congratulation;
    let given = attend(human, budget_left, stats, t_exp, rng, |s| {
        if congratulation {
            s.congratulations += 1;
        } else {
            s.punishments += 1;
        }
    });
    if given { 1 } else { 0 }
}

/// SPEC 11.2 after the robot's relevant action `sa`: the state an attentive nuisance human with
/// budget left leaves (the cube taken back out onto the table), else `None`. Counts nuisances
/// and forgotten opportunities.
#[inline]
pub fn nuisance(
    human: &HumanParams,
    tables: Option<&HumanTables>,
    active: bool,
    sa: usize,
    budget_left: &mut u32,
    stats: &mut RunStats,
    t_exp: u32,
    rng: &mut Xoshiro256PlusPlus,
) -> Option<usize> {
    if !active || *budget_left == 0 || human.interaction != Interaction::Nuisance {
        return None;
    }
    let tables = tables?;
    let undone = tables.nuisance[sa];
    if !tables.relevant[sa] || undone == NO_NUISANCE {
        return None;
    }
    attend(human, budget_left, stats, t_exp, rng, |s| s.nuisances += 1).then_some(undone as usize)
}

/// SPEC 11.1 at an arrival in the goal after babbling, where only the human brings reward: the
/// goal's `reward` if an attentive human with budget left gives it (spending one unit), else 0.
/// Counts rewards given and forgotten opportunities.
#[inline]
pub fn reward(
    human: &HumanParams,
    reward: f64,
    budget_left: &mut u32,
    stats: &mut RunStats,
    t_exp: u32,
    rng: &mut Xoshiro256PlusPlus,
) -> f64 {
    if *budget_left == 0 {
        return 0.0;
    }
    if attend(human, budget_left, stats, t_exp, rng, |s| {
        s.rewards_given += 1
    }) {
        reward
    } else {
        0.0
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
