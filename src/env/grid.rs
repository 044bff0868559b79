//! `grid:N`: a generated family of stochastic grid worlds with N states, for measuring how time
//! and memory grow with the size of the state space (benchmarks, `mbmf bench --growth`).
//!
//! The world is deterministic from N alone:
//! - the N cells fill a near-square grid row by row: `width = ceil(sqrt(N))`, cell `id` at
//!   `x = id % width`, `y = id / width`; when N is not a rectangle the last row is partial;
//! - five actions: 0 north (y - 1), 1 east (x + 1), 2 south (y + 1), 3 west (x - 1), 4 stay;
//! - a move goes in the intended direction with probability 0.8 and in each perpendicular one
//!   with probability 0.1; a move into the edge (or a missing cell of the last row) stays put,
//!   and outcomes that land in the same cell are merged; stay is deterministic;
//! - the run starts in cell 0, the corner (0, 0), and the goal is cell N - 1, the opposite
//!   corner when N is a rectangle; arriving there gives reward 1 (then the reset step, SPEC 2.1);
//! - state names are `"x,y"`; the human does not interact (no relevant actions are defined).

use super::registry::{DEFAULTS, Task};
use super::{EnvError, Goal, Spec, StateId};

/// The grid worlds in the task registry.
pub const GRID: Task = Task {
    name: "grid:N",
    help: "a grid world of N cells (2 to 1000000), slippery moves, goal in the far corner",
    build: |task| {
        let n = task.strip_prefix("grid:").unwrap_or(task);
        parse(n).map_err(|error| EnvError::Grid {
            task: task.to_string(),
            error,
        })
    },
    events: &["world", "goal", "delete"],
    ..DEFAULTS
};

/// Actions of every grid world.
pub const N_ACTIONS: usize = 5;
/// The action that stays in place.
pub const STAY: usize = 4;
/// Smallest grid: a start and a distinct goal.
pub const MIN_STATES: usize = 2;
/// Largest grid accepted: about 5 million state-action pairs, ~0.5 GB per run.
pub const MAX_STATES: usize = 1_000_000;

/// Relative weight of the intended direction (the perpendicular ones weigh 1 each): 0.8 / 0.1.
const INTENDED_WEIGHT: f64 = 8.0;
const SLIP_WEIGHT: f64 = 1.0;

/// (dx, dy) of the four moves, in action order.
const MOVES: [(i64, i64); 4] = [(0, -1), (1, 0), (0, 1), (-1, 0)];

/// A `grid:N` name that does not describe a grid.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GridError {
    /// N is not a whole number.
    #[error("grid:{0}: the number of states must be a whole number, e.g. grid:100")]
    NotANumber(String),
    /// N is out of range.
    #[error("grid:{0}: the number of states must be between {MIN_STATES} and {MAX_STATES}")]
    OutOfRange(usize),
}

/// The shape of a grid of `n_states` cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shape {
    /// Cells per row.
    pub width: usize,
    /// Rows (the last may be partial).
    pub height: usize,
    /// Number of cells.
    pub n_states: usize,
}

impl Shape {
    /// The near-square shape of `n_states` cells.
    pub fn new(n_states: usize) -> Shape {
        let mut width = (n_states as f64).sqrt().ceil() as usize;
        // Guard against rounding in sqrt for large perfect squares.
        while width > 1 && (width - 1) * (width - 1) >= n_states {
            width -= 1;
        }
        while width * width < n_states {
            width += 1;
        }
        Shape {
            width,
            height: n_states.div_ceil(width),
            n_states,
        }
    }

    /// Coordinates of cell `id`.
    pub fn xy(&self, id: usize) -> (usize, usize) {
        (id % self.width, id / self.width)
    }

    /// The cell one move in direction `(dx, dy)` from `id`, or `id` itself at an edge or a
    /// missing cell.
    pub fn neighbour(&self, id: usize, (dx, dy): (i64, i64)) -> usize {
        let (x, y) = self.xy(id);
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        if nx < 0 || ny < 0 || nx >= self.width as i64 || ny >= self.height as i64 {
            return id;
        }
        let next = ny as usize * self.width + nx as usize;
        if next < self.n_states { next } else { id }
    }
}

/// Parses the N of `grid:N` and builds the world.
pub fn parse(n: &str) -> Result<Spec, GridError> {
    let n_states: usize = n
        .trim()
        .parse()
        .map_err(|_| GridError::NotANumber(n.to_string()))?;
    build(n_states)
}

/// The grid world of `n_states` cells.
pub fn build(n_states: usize) -> Result<Spec, GridError> {
    if !(MIN_STATES..=MAX_STATES).contains(&n_states) {
        return Err(GridError::OutOfRange(n_states));
    }
    let shape = Shape::new(n_states);
    let mut outcomes = Vec::with_capacity(n_states * N_ACTIONS);
    for id in 0..n_states {
        for (a, &intended) in MOVES.iter().enumerate() {
            let left = MOVES[(a + 3) % 4];
            let right = MOVES[(a + 1) % 4];
            // Spec::from_outcomes merges outcomes that land in the same cell.
            outcomes.push(vec![
                (shape.neighbour(id, intended) as StateId, INTENDED_WEIGHT),
                (shape.neighbour(id, left) as StateId, SLIP_WEIGHT),
                (shape.neighbour(id, right) as StateId, SLIP_WEIGHT),
            ]);
        }
        outcomes.push(vec![(id as StateId, 1.0)]);
    }
    let state_names = (0..n_states)
        .map(|id| {
            let (x, y) = shape.xy(id);
            format!("{x},{y}")
        })
        .collect();
    Ok(Spec::from_outcomes(
        format!("grid:{n_states}"),
        n_states,
        N_ACTIONS,
        outcomes,
        vec![0],
        Goal {
            state: (n_states - 1) as StateId,
            reward: 1.0,
        },
        state_names,
        None,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probability(spec: &Spec, s: usize, a: usize, next: usize) -> f64 {
        let sa = spec.sa(s, a);
        let total: f64 = spec.outcomes(sa).map(|o| spec.outcome_weight[o]).sum();
        spec.outcomes(sa)
            .filter(|&o| spec.outcome_state[o] as usize == next)
            .map(|o| spec.outcome_weight[o] / total)
            .sum()
    }

    #[test]
    fn a_grid_has_exactly_the_requested_number_of_states_and_five_actions() {
        for n in [2, 3, 7, 100, 101, 1000, 10_000] {
            let spec = build(n).unwrap();
            assert_eq!(spec.n_states, n);
            assert_eq!(spec.n_actions, N_ACTIONS);
            assert_eq!(spec.state_names.len(), n);
            assert_eq!(spec.outcome_start.len(), n * N_ACTIONS + 1);
            assert_eq!(spec.name, format!("grid:{n}"));
        }
    }

    #[test]
    fn shapes_are_near_square_and_hold_every_cell() {
        assert_eq!(
            Shape::new(100),
            Shape {
                width: 10,
                height: 10,
                n_states: 100
            }
        );
        // 101 cells: an 11-wide grid of 10 rows, the last holding 2 cells.
        assert_eq!(Shape::new(101).width, 11);
        assert_eq!(Shape::new(101).height, 10);
        for n in 2..400 {
            let s = Shape::new(n);
            assert!(
                s.width * s.height >= n && s.width * (s.height - 1) < n,
                "{n}"
            );
            assert!(s.width >= s.height && s.width - s.height <= 2, "{n}: {s:?}");
        }
    }

    #[test]
    fn the_outcome_probabilities_of_every_pair_sum_to_one() {
        for n in [2, 5, 100, 101] {
            let spec = build(n).unwrap();
            for sa in 0..n * N_ACTIONS {
                let total: f64 = spec.outcomes(sa).map(|o| spec.outcome_weight[o]).sum();
                let sum: f64 = spec
                    .outcomes(sa)
                    .map(|o| spec.outcome_weight[o] / total)
                    .sum();
                assert!((sum - 1.0).abs() < 1e-12, "grid:{n} pair {sa}: {sum}");
                assert_eq!(spec.outcome_cum[spec.outcomes(sa).end - 1], 1.0);
            }
        }
    }

    #[test]
    fn moves_slip_sideways_one_time_in_five_and_stay_at_the_edges() {
        // 10 x 10: cell 55 is (5, 5), in the middle.
        let spec = build(100).unwrap();
        let (mid, north, east, west) = (55, 45, 56, 54);
        assert!((probability(&spec, mid, 0, north) - 0.8).abs() < 1e-12);
        assert!((probability(&spec, mid, 0, east) - 0.1).abs() < 1e-12);
        assert!((probability(&spec, mid, 0, west) - 0.1).abs() < 1e-12);
        assert_eq!(probability(&spec, mid, STAY, mid), 1.0);
        // From the start corner (0, 0), north is a wall: 0.8 stay, 0.1 west (a wall: stay too),
        // 0.1 east.
        assert!((probability(&spec, 0, 0, 0) - 0.9).abs() < 1e-12);
        assert!((probability(&spec, 0, 0, 1) - 0.1).abs() < 1e-12);
        assert_eq!(spec.state_names[55], "5,5");
    }

    #[test]
    fn the_goal_is_the_far_corner_and_reachable_from_the_start() {
        for n in [2, 3, 100, 101, 10_000] {
            let spec = build(n).unwrap();
            assert_eq!(spec.initial_states, vec![0]);
            assert_eq!(spec.goal_state(), Some((n - 1) as StateId));
            assert!(spec.human.is_none());
            // Breadth-first search over outcomes with positive probability.
            let mut seen = vec![false; n];
            let mut queue = std::collections::VecDeque::from([0usize]);
            seen[0] = true;
            while let Some(s) = queue.pop_front() {
                for a in 0..N_ACTIONS {
                    for o in spec.outcomes(spec.sa(s, a)) {
                        let next = spec.outcome_state[o] as usize;
                        if !seen[next] {
                            seen[next] = true;
                            queue.push_back(next);
                        }
                    }
                }
            }
            assert!(seen[n - 1], "grid:{n}: goal unreachable");
            assert!(seen.iter().all(|&s| s), "grid:{n}: some cell unreachable");
        }
        assert_eq!(build(100).unwrap().state_names[99], "9,9");
    }

    #[test]
    fn malformed_or_out_of_range_sizes_are_refused_with_the_accepted_range() {
        assert_eq!(parse("x").unwrap_err(), GridError::NotANumber("x".into()));
        assert_eq!(parse("1").unwrap_err(), GridError::OutOfRange(1));
        let message = parse("2000000").unwrap_err().to_string();
        assert!(message.contains("between 2 and 1000000"), "{message}");
        assert_eq!(parse("64").unwrap().n_states, 64);
    }
}
