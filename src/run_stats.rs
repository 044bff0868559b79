//! What one run adds up while it is stepped (SPEC 8): written by the engine and the human
//! kernels, read by the output tables. A leaf module, so that neither of its writers depends on
//! the other.

/// Per-run accumulators, added to in the step and read at the end (SPEC 8).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunStats {
    /// Reward over the experiment.
    pub total_reward: f64,
    /// Reward over the last 10% of experiment steps (steps t > steps - steps / 10).
    pub reward_last10: f64,
    /// 1-based experiment step whose transition first reached the goal; 0 if none.
    pub first_reward_step: u32,
    /// Inference cost of the MF expert over the experiment.
    pub cost_mf: f64,
    /// Inference cost of the MB expert over the experiment.
    pub cost_mb: f64,
    /// Robot decisions (steps that were neither reset steps nor takeovers).
    pub decisions: u64,
    /// Decisions where the MC chose MB.
    pub mb_decisions: u64,
    /// Sum over decisions of the MC's softmax probability of MB.
    pub p_mb_sum: f64,
    /// Sum over decisions of the chosen expert's normalised entropy, as the MC read it.
    pub entropy_sum: f64,
    /// Congratulations given.
    pub congratulations: u32,
    /// Rewards given by the human (reward source `human`, SPEC 11.1).
    pub rewards_given: u32,
    /// Nuisances given (SPEC 11.2).
    pub nuisances: u32,
    /// Takeovers given.
    pub takeovers: u32,
    /// Punishments given.
    pub punishments: u32,
    /// Opportunities the human missed by forgetting.
    pub forgotten: u32,
    /// Experiment step at which the last unit of budget was spent; 0 if never.
    pub budget_exhausted_step: u32,
    /// Value-iteration calls (babbling included).
    pub vi_calls: u64,
    /// Value-iteration sweeps (babbling included).
    pub vi_sweeps: u64,
    /// Value-iteration calls stopped by `vi_max_sweeps` before converging (babbling included).
    pub vi_capped: u64,
    /// Experiment step of the first change of the run's schedule; 0 without changes.
    pub first_change_step: u32,
    /// Reward over the steps before the first change (steps < T).
    pub reward_before_change: f64,
    /// First rewarded experiment step at or after the first change; 0 if none.
    pub first_reward_after_change: u32,
    /// Seconds spent simulating this run.
    pub wall_time_s: f64,
}

impl RunStats {
    /// Interactions of any type given.
    pub fn interactions(&self) -> u32 {
        self.congratulations
            + self.takeovers
            + self.punishments
            + self.rewards_given
            + self.nuisances
    }

    /// Reward from the first change on (steps >= T); `None` without changes (SPEC 10).
    pub fn reward_after_change(&self) -> Option<f64> {
        (self.first_change_step > 0).then_some(self.total_reward - self.reward_before_change)
    }

    /// The first rewarded step at or after the first change T, minus T, plus 1; `None` without
    /// changes or without such a reward (SPEC 10).
    pub fn recovery_steps(&self) -> Option<u32> {
        (self.first_change_step > 0 && self.first_reward_after_change > 0)
            .then(|| self.first_reward_after_change - self.first_change_step + 1)
    }

    /// Total inference cost.
    pub fn cost_total(&self) -> f64 {
        self.cost_mf + self.cost_mb
    }
}
