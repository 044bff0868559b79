//! `chain`: the smallest task, two states and two actions, as a worked example of a task and a
//! fast world for tests. In state 0, action 1 moves to state 1 and action 0 stays; state 1 is
//! the goal (reward 1, then the reset step to state 0, SPEC 2.1). From state 1, which a run
//! only occupies for the reset step, both actions stay.

use super::registry::{Task, unconfigured};
use super::{Goal, Spec};

/// The chain in the task registry.
pub const CHAIN: Task = Task {
    name: "chain",
    help: "two states, two actions: action 1 reaches the rewarded goal (a smallest example task)",
    build: |_| Ok(build()),
    default_steps: 1_000,
    default_babbling: 100,
    interactions: &[],
    human_reward: true,
    events: &["goal"],
    refusals: &[],
    params: &[],
    configure: unconfigured,
    metrics: &[],
    headline: &[],
    headline_note: "",
};

/// Compiles the chain.
pub fn build() -> Spec {
    Spec::from_outcomes(
        "chain".to_string(),
        2,
        2,
        vec![
            vec![(0, 1.0)],
            vec![(1, 1.0)],
            vec![(1, 1.0)],
            vec![(1, 1.0)],
        ],
        vec![0],
        Goal {
            state: 1,
            reward: 1.0,
        },
        vec!["start".to_string(), "goal".to_string()],
        None,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn action_1_reaches_the_goal_and_action_0_stays() {
        let spec = build();
        let next = |s, a| spec.outcome_state[spec.outcomes(spec.sa(s, a)).start];
        assert_eq!((next(0, 0), next(0, 1)), (0, 1));
        let into_goal = spec.outcomes(spec.sa(0, 1)).start;
        assert_eq!(spec.arrival[into_goal].reward, 1.0);
        assert_eq!(spec.arrival[into_goal].end, crate::env::End::Reset);
        assert!(!spec.arrival[spec.outcomes(spec.sa(0, 0)).start].terminal());
    }
}
