//! The per-step trace (SPEC 14): one row per experiment step of every run of a batch, stored as
//! struct-of-arrays columns preallocated when the batch is built, each run writing its own
//! slice. The step kernel records into it only when compiled for tracing (a const generic), so
//! an untraced batch holds no row and pays nothing per step.

use crate::run_stats::RunStats;

/// Who chose a step's action (the `actor` column).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum Actor {
    /// Drawn from the MF expert's softmax.
    #[default]
    Mf = 0,
    /// Drawn from the MB expert's softmax.
    Mb = 1,
    /// Drawn from a mixture of both experts' values (`combine = mix`, or a `vpi` decision with
    /// an action valued by MB).
    Mix = 2,
    /// Put by the human (a takeover).
    Human = 3,
    /// A reset step: no action.
    Reset = 4,
}

impl Actor {
    /// Every actor, in code order: the `actor` column's dictionary.
    pub const ALL: [Actor; 5] = [Actor::Mf, Actor::Mb, Actor::Mix, Actor::Human, Actor::Reset];

    /// The name written in the `actor` column.
    pub fn name(self) -> &'static str {
        match self {
            Actor::Mf => "mf",
            Actor::Mb => "mb",
            Actor::Mix => "mix",
            Actor::Human => "human",
            Actor::Reset => "reset",
        }
    }
}

/// What the human did at a step (the `human_event` column).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum HumanEvent {
    /// No interaction.
    #[default]
    None = 0,
    /// A congratulation (SPEC 5).
    Congratulation = 1,
    /// A punishment (SPEC 5).
    Punishment = 2,
    /// A takeover (SPEC 5): the actor is `human` too.
    Takeover = 3,
    /// A nuisance (SPEC 11.2).
    Nuisance = 4,
    /// The goal's reward given by the human (SPEC 11.1).
    Reward = 5,
}

impl HumanEvent {
    /// Every event, in code order: the `human_event` column's dictionary.
    pub const ALL: [HumanEvent; 6] = [
        HumanEvent::None,
        HumanEvent::Congratulation,
        HumanEvent::Punishment,
        HumanEvent::Takeover,
        HumanEvent::Nuisance,
        HumanEvent::Reward,
    ];

    /// The name written in the `human_event` column.
    pub fn name(self) -> &'static str {
        match self {
            HumanEvent::None => "none",
            HumanEvent::Congratulation => "congratulation",
            HumanEvent::Punishment => "punishment",
            HumanEvent::Takeover => "takeover",
            HumanEvent::Nuisance => "nuisance",
            HumanEvent::Reward => "reward",
        }
    }

    /// The event of a step from the run's counters before and after it. A human acts with one
    /// interaction type, but a reward given by the human (SPEC 11.1) can come in the same step
    /// as a takeover or a congratulation; the step then names the interaction of the human's
    /// type, and the reward shows in the `reward` column (reward source `human`: a terminal
    /// arrival's reward is non-zero exactly when the human gave it).
    pub fn between(before: &RunStats, after: &RunStats) -> HumanEvent {
        if after.takeovers != before.takeovers {
            HumanEvent::Takeover
        } else if after.congratulations != before.congratulations {
            HumanEvent::Congratulation
        } else if after.punishments != before.punishments {
            HumanEvent::Punishment
        } else if after.nuisances != before.nuisances {
            HumanEvent::Nuisance
        } else if after.rewards_given != before.rewards_given {
            HumanEvent::Reward
        } else {
            HumanEvent::None
        }
    }
}

/// The `action` of a reset step (written as null).
pub const NO_ACTION: u16 = u16::MAX;

/// The trace rows of a batch, run after run; run `r`'s rows are `start[r]..start[r + 1]`, one
/// per experiment step (row `k` is step `k + 1`).
#[derive(Debug, Clone, Default)]
pub struct TraceColumns {
    /// State at the start of the step.
    pub state: Vec<u32>,
    /// Action executed ([`NO_ACTION`] on a reset step).
    pub action: Vec<u16>,
    /// State after the step.
    pub next_state: Vec<u32>,
    /// Reward of the step (the task's; what `total_reward` adds up).
    pub reward: Vec<f64>,
    /// The arrival was terminal.
    pub terminal: Vec<bool>,
    /// Who chose the action.
    pub actor: Vec<Actor>,
    /// P(MB) of the step's decision (NaN without a decision: takeover, reset).
    pub p_mb: Vec<f64>,
    /// What the human did.
    pub event: Vec<HumanEvent>,
}

/// Bytes one trace row takes in [`TraceColumns`].
pub const ROW_BYTES: usize = std::mem::size_of::<u32>() * 2
    + std::mem::size_of::<u16>()
    + std::mem::size_of::<f64>() * 2
    + std::mem::size_of::<bool>()
    + std::mem::size_of::<Actor>()
    + std::mem::size_of::<HumanEvent>();

impl TraceColumns {
    /// Columns of `rows` rows, zeroed (each run overwrites all of its rows).
    pub fn new(rows: usize) -> TraceColumns {
        TraceColumns {
            state: vec![0; rows],
            action: vec![0; rows],
            next_state: vec![0; rows],
            reward: vec![0.0; rows],
            terminal: vec![false; rows],
            actor: vec![Actor::default(); rows],
            p_mb: vec![0.0; rows],
            event: vec![HumanEvent::default(); rows],
        }
    }

    /// Rows held.
    pub fn len(&self) -> usize {
        self.state.len()
    }

    /// Whether no row is held.
    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.len() * ROW_BYTES
    }

    /// The columns split into consecutive runs of `lens[r]` rows each.
    pub(super) fn split(&mut self, lens: impl Iterator<Item = usize>) -> Vec<TraceRows<'_>> {
        let mut rest = TraceRows {
            state: &mut self.state,
            action: &mut self.action,
            next_state: &mut self.next_state,
            reward: &mut self.reward,
            terminal: &mut self.terminal,
            actor: &mut self.actor,
            p_mb: &mut self.p_mb,
            event: &mut self.event,
        };
        let mut out = Vec::new();
        for len in lens {
            let (head, tail) = rest.split_at(len);
            out.push(head);
            rest = tail;
        }
        out
    }
}

/// One run's rows of [`TraceColumns`] (empty when the batch is not traced).
#[derive(Debug, Default)]
pub struct TraceRows<'a> {
    state: &'a mut [u32],
    action: &'a mut [u16],
    next_state: &'a mut [u32],
    reward: &'a mut [f64],
    terminal: &'a mut [bool],
    actor: &'a mut [Actor],
    p_mb: &'a mut [f64],
    event: &'a mut [HumanEvent],
}

/// One step's row.
#[derive(Debug, Clone, Copy)]
pub struct Row {
    /// State at the start of the step.
    pub state: u32,
    /// Action executed ([`NO_ACTION`] on a reset step).
    pub action: u16,
    /// State after the step.
    pub next_state: u32,
    /// The step's reward.
    pub reward: f64,
    /// The arrival was terminal.
    pub terminal: bool,
    /// Who chose the action.
    pub actor: Actor,
    /// P(MB) of the decision, NaN without one.
    pub p_mb: f64,
    /// What the human did.
    pub event: HumanEvent,
}

impl<'a> TraceRows<'a> {
    /// Whether the run records no row (its batch is not traced).
    pub fn is_empty(&self) -> bool {
        self.state.is_empty()
    }

    fn split_at(self, len: usize) -> (TraceRows<'a>, TraceRows<'a>) {
        let (state, state_rest) = self.state.split_at_mut(len);
        let (action, action_rest) = self.action.split_at_mut(len);
        let (next_state, next_rest) = self.next_state.split_at_mut(len);
        let (reward, reward_rest) = self.reward.split_at_mut(len);
        let (terminal, terminal_rest) = self.terminal.split_at_mut(len);
        let (actor, actor_rest) = self.actor.split_at_mut(len);
        let (p_mb, p_mb_rest) = self.p_mb.split_at_mut(len);
        let (event, event_rest) = self.event.split_at_mut(len);
        (
            TraceRows {
                state,
                action,
                next_state,
                reward,
                terminal,
                actor,
                p_mb,
                event,
            },
            TraceRows {
                state: state_rest,
                action: action_rest,
                next_state: next_rest,
                reward: reward_rest,
                terminal: terminal_rest,
                actor: actor_rest,
                p_mb: p_mb_rest,
                event: event_rest,
            },
        )
    }

    /// Writes the row of experiment step `t_exp` (1-based).
    #[inline(always)]
    pub fn record(&mut self, t_exp: u32, row: Row) {
        let k = t_exp as usize - 1;
        self.state[k] = row.state;
        self.action[k] = row.action;
        self.next_state[k] = row.next_state;
        self.reward[k] = row.reward;
        self.terminal[k] = row.terminal;
        self.actor[k] = row.actor;
        self.p_mb[k] = row.p_mb;
        self.event[k] = row.event;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_row_size_counts_every_column() {
        let mut t = TraceColumns::new(3);
        assert_eq!(t.bytes(), 3 * 29);
        let mut rows = t.split([1, 2].into_iter());
        rows[1].record(
            2,
            Row {
                state: 7,
                action: NO_ACTION,
                next_state: 9,
                reward: 1.5,
                terminal: true,
                actor: Actor::Reset,
                p_mb: f64::NAN,
                event: HumanEvent::Reward,
            },
        );
        drop(rows);
        assert_eq!(t.state, [0, 0, 7]);
        assert_eq!(t.action[2], NO_ACTION);
        assert_eq!(t.actor[2], Actor::Reset);
        assert_eq!(t.event[2], HumanEvent::Reward);
    }

    #[test]
    fn an_event_names_the_interaction_before_a_given_reward() {
        let before = RunStats::default();
        let mut after = before;
        after.rewards_given += 1;
        assert_eq!(HumanEvent::between(&before, &after), HumanEvent::Reward);
        after.takeovers += 1;
        assert_eq!(HumanEvent::between(&before, &after), HumanEvent::Takeover);
        assert_eq!(HumanEvent::between(&before, &before), HumanEvent::None);
        let names: Vec<&str> = HumanEvent::ALL.iter().map(|e| e.name()).collect();
        assert_eq!(
            names,
            [
                "none",
                "congratulation",
                "punishment",
                "takeover",
                "nuisance",
                "reward"
            ]
        );
    }
}
