//! A real person's part in a run (SPEC 15): the takeover they choose for the next step and the
//! feedback they give on the step just shown. The step kernel treats a person as a human whose
//! takeover comes from [`Cursor::person_put`](super::Cursor::person_put) instead of a draw and
//! who never judges during the step: the page shows the step once it is done, so a
//! congratulation or punishment is applied here, to the step's (s, a), before the next step.
//! G(s, a) is read only by later decisions, so that is Eq. 8 exactly (the reward-shaping
//! effect, learned within the step, is refused for a person).

use std::sync::Arc;

use super::trace::{Actor, HumanEvent, NO_ACTION};
use super::{Batch, RunConfig, trace_rows};
use crate::env::{NO_TAKEOVER, Spec};
use crate::params::{ConfigError, Interaction};

/// Why a person's input was not applied: the session goes on without it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// The run has a simulated human, or none.
    #[error("this run is not taught by a person")]
    NotPerson,
    /// The budget is spent.
    #[error("no interaction left in the budget")]
    NoBudget,
    /// A takeover while the robot's hand is empty.
    #[error("the robot holds no cube: there is nothing to take over")]
    NothingHeld,
    /// A takeover with an action the task does not have, or one that does not put a cube down.
    #[error("action {action} is not a put (the cube goes into a box or onto the table)")]
    NotAPut {
        /// The action asked for.
        action: usize,
    },
    /// Feedback on a step that is not the last one executed.
    #[error("step {step} is not the last step executed ({last})")]
    NotLast {
        /// The step named.
        step: u32,
        /// The last step executed.
        last: u32,
    },
    /// Feedback on a step without an action of the robot.
    #[error("step {step} has no action of the robot to judge ({what})")]
    NothingToJudge {
        /// The step named.
        step: u32,
        /// What it was: a reset, or the person's own takeover.
        what: &'static str,
    },
    /// A second feedback on the same step.
    #[error("step {step} was already judged")]
    AlreadyJudged {
        /// The step named.
        step: u32,
    },
    /// Every step of the run has been taken.
    #[error("the run is over")]
    Over,
}

impl Batch {
    /// A batch of the one run a person teaches (SPEC 15): interaction `person`, traced, its
    /// babbling done, ready for its first experiment step.
    pub fn for_person(spec: Arc<Spec>, config: RunConfig) -> Result<Batch, ConfigError> {
        crate::env::registry::check_person(&spec, &config.params)?;
        let mut batch = Batch::unchecked(None, spec, vec![config], &[], &[])?;
        batch.record_trace();
        batch.advance(u64::from(config.params.babbling));
        Ok(batch)
    }

    /// The experiment steps run `r` has taken (0 until babbling is over).
    pub fn experiment_step(&self, r: usize) -> u32 {
        let babbling = u64::from(self.configs[r].params.babbling);
        self.cursors[r].t.saturating_sub(babbling) as u32
    }

    /// Whether run `r` has taken every step.
    pub fn is_over(&self, r: usize) -> bool {
        self.experiment_step(r) >= self.configs[r].params.steps
    }

    /// Whether the robot of run `r` holds a cube now: a takeover can happen at its next step.
    pub fn holds(&self, r: usize) -> bool {
        let cursor = &self.cursors[r];
        !cursor.pending_reset
            && self.spec.human.as_ref().is_some_and(|h| {
                h.takeover_action
                    .get(cursor.state as usize)
                    .is_some_and(|&p| p != NO_TAKEOVER)
            })
    }

    /// The person of run `r` takes over at its next step with `action` (a put): the step
    /// executes it instead of the robot's choice, counted and paid as a takeover.
    pub fn choose_takeover(&mut self, r: usize, action: usize) -> Result<(), Refusal> {
        self.person_may_act(r)?;
        if !self.holds(r) {
            return Err(Refusal::NothingHeld);
        }
        let puts = crate::env::tidy::N_CUBES..self.spec.n_actions;
        if !puts.contains(&action) {
            return Err(Refusal::NotAPut { action });
        }
        self.cursors[r].person_put = action as u16;
        Ok(())
    }

    /// The person of run `r` congratulates (`positive`) or punishes the robot's action at
    /// experiment step `step`, the last one executed: G(s, a) = +1 or -1 (Eq. 8), one unit of
    /// budget, the step's trace event. Returns the event recorded.
    pub fn judge(&mut self, r: usize, step: u32, positive: bool) -> Result<HumanEvent, Refusal> {
        self.person_may_act(r)?;
        let last = self.experiment_step(r);
        if step != last || step == 0 {
            return Err(Refusal::NotLast { step, last });
        }
        let row = self.configs[..r]
            .iter()
            .map(|c| trace_rows(&c.params))
            .sum::<usize>()
            + step as usize
            - 1;
        let what = match self.trace.actor[row] {
            Actor::Reset => Some("a reset"),
            Actor::Human => Some("the person's own takeover"),
            _ => None,
        };
        if let Some(what) = what {
            return Err(Refusal::NothingToJudge { step, what });
        }
        if self.trace.event[row] != HumanEvent::None {
            return Err(Refusal::AlreadyJudged { step });
        }
        let (s, a) = (self.trace.state[row], self.trace.action[row]);
        debug_assert_ne!(a, NO_ACTION);
        let sa = self.spec.sa(s as usize, usize::from(a));
        let event = if positive {
            HumanEvent::Congratulation
        } else {
            HumanEvent::Punishment
        };
        let (_, view) = self.views().swap_remove(r);
        view.bonus[sa] = if positive { 1 } else { crate::expert::PUNISHED };
        crate::human::spend(&mut view.cursor.budget_left, view.stats, step, |s| {
            if positive {
                s.congratulations += 1;
            } else {
                s.punishments += 1;
            }
        });
        self.trace.event[row] = event;
        Ok(event)
    }

    /// Whether the person of run `r` may still interact.
    fn person_may_act(&self, r: usize) -> Result<(), Refusal> {
        let cursor = &self.cursors[r];
        if cursor.human.interaction != Interaction::Person {
            return Err(Refusal::NotPerson);
        }
        if self.is_over(r) {
            return Err(Refusal::Over);
        }
        if cursor.budget_left == 0 {
            return Err(Refusal::NoBudget);
        }
        Ok(())
    }
}
