//! The tidy tasks of the paper (SPEC 2.1 and 2.2): three cubes, three boxes, a hand and, in task
//! 2, a lamp of three LEDs that must be lit in order.
//!
//! States are enumerated breadth-first from the start state, trying actions in index order, so
//! ids match the authors' format export (`../shared/data/tidy1/`).

use std::collections::{HashMap, VecDeque};

use super::registry::{DEFAULTS, Task};
use super::{Goal, HumanTables, NO_NUISANCE, NO_TAKEOVER, Spec, StateId};
use crate::params::Interaction;

/// Number of cubes (red, green, blue).
pub const N_CUBES: usize = 3;
/// Actions: take red/green/blue, put in red/green/blue box, put on the table.
pub const N_ACTIONS: usize = 7;
/// Action that puts the held cube on the table.
pub const PUT_ON_TABLE: usize = 6;

const COLOURS: [&str; N_CUBES] = ["R", "G", "B"];

/// Where each cube belongs in task 1 (SPEC 10): position i is the box of cube i, written as a
/// permutation of `rgb` (`brg` puts the red cube in the blue box, the green cube in the red box,
/// the blue cube in the green box). State ids do not depend on it; the goal, the human's relevant
/// actions, errors and takeover puts do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Boxes(pub [u8; N_CUBES]);

impl Boxes {
    /// Each cube in its own colour's box (the paper's task).
    pub const RGB: Boxes = Boxes([0, 1, 2]);

    /// Parses a permutation of `rgb` (case-insensitive).
    pub fn parse(text: &str) -> Result<Boxes, String> {
        let letters: Vec<char> = text.trim().to_lowercase().chars().collect();
        let mut boxes = [0u8; N_CUBES];
        let mut seen = [false; N_CUBES];
        let bad = || {
            format!(
                "box assignment '{text}' is not a permutation of 'rgb' (position i is the box of \
                 cube i, red, green, blue: e.g. rgb, brg, gbr)"
            )
        };
        if letters.len() != N_CUBES {
            return Err(bad());
        }
        for (cube, letter) in letters.iter().enumerate() {
            let b = match letter {
                'r' => 0,
                'g' => 1,
                'b' => 2,
                _ => return Err(bad()),
            };
            if seen[b] {
                return Err(bad());
            }
            seen[b] = true;
            boxes[cube] = b as u8;
        }
        Ok(Boxes(boxes))
    }

    /// The box of cube `cube`.
    #[inline]
    pub fn of(self, cube: usize) -> u8 {
        self.0[cube]
    }
}

impl Default for Boxes {
    fn default() -> Self {
        Boxes::RGB
    }
}

impl std::fmt::Display for Boxes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for &b in &self.0 {
            f.write_str(["r", "g", "b"][b as usize])?;
        }
        Ok(())
    }
}

/// tidy1's box assignments as sweep files and flags name them: permutations of `rgb`, position
/// i the box of cube i.
pub const BOX_NAMES: &[&str] = &["rgb", "rbg", "grb", "gbr", "brg", "bgr"];

impl crate::params::ParamValue for Boxes {
    const KIND: crate::params::Kind = crate::params::Kind::Choice(BOX_NAMES);
    fn to_value(self) -> crate::params::Value {
        let name = self.to_string();
        crate::params::Value::Choice(BOX_NAMES.iter().find(|n| **n == name).unwrap_or(&"rgb"))
    }
    fn from_value(value: &crate::params::Value) -> Option<Self> {
        match value {
            crate::params::Value::Choice(name) => Boxes::parse(name).ok(),
            _ => None,
        }
    }
}

/// Every interaction type: the tidy tasks define what each needs (SPEC 5, 11.2).
const INTERACTIONS: &[Interaction] = &[
    Interaction::Congratulation,
    Interaction::Takeover,
    Interaction::Punishment,
    Interaction::Nuisance,
];

/// Task 1 in the task registry.
pub const TIDY1: Task = Task {
    name: "tidy1",
    help: "the paper's task 1: put each of three cubes in its box (112 states, 7 actions)",
    build: |_| Ok(build(Variant::Task1)),
    interactions: INTERACTIONS,
    events: &["boxes"],
    refusals: &[(
        "goal",
        "tidy1's objective is its box assignment: use boxes=PERM (e.g. 5000:boxes=brg)",
    )],
    params: &["boxes"],
    configure: |p| Ok((p.boxes != Boxes::RGB).then(|| build_with(Variant::Task1, p.boxes))),
    ..DEFAULTS
};

/// Task 2 in the task registry.
pub const TIDY2: Task = Task {
    name: "tidy2",
    help: "the paper's task 2: light three LEDs in order (142 states, 7 actions)",
    build: |_| Ok(build(Variant::Task2)),
    default_steps: 20_000,
    interactions: INTERACTIONS,
    refusals: &[
        (
            "goal",
            "tidy2 keeps its fixed objective (its reachable states would change)",
        ),
        (
            "boxes",
            "tidy2 keeps its fixed box assignment and LED order (its reachable states would \
             change)",
        ),
    ],
    ..DEFAULTS
};

/// Which tidy task.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// Task 1: put every cube in its own box (112 states).
    Task1,
    /// Task 2: light the three LEDs in order (142 states).
    Task2,
}

/// Where a cube is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Place {
    /// On the table.
    Table,
    /// In the box of the given colour (0 red, 1 green, 2 blue).
    Box(u8),
    /// In the robot's hand.
    Hand,
}

impl Place {
    fn label(self) -> &'static str {
        match self {
            Place::Table => "table",
            Place::Box(0) => "redbox",
            Place::Box(1) => "greenbox",
            Place::Box(_) => "bluebox",
            Place::Hand => "hand",
        }
    }
}

/// One tidy state: the place of each cube and the number of lit LEDs (always 0 in task 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TidyState {
    /// Place of the red, green and blue cube.
    pub places: [Place; N_CUBES],
    /// Lit LEDs, 0..=3 (task 2 only).
    pub leds: u8,
}

/// What one action does in one state: the next state, and how the human judges the action.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Effect {
    /// The state after the action.
    pub next: TidyState,
    /// The action is the one the human congratulates (SPEC 5).
    pub relevant: bool,
    /// The action is an error (SPEC 5, target of punishment).
    pub error: bool,
}

impl TidyState {
    /// All cubes on the table, hand empty, lamp off.
    pub const START: TidyState = TidyState {
        places: [Place::Table; N_CUBES],
        leds: 0,
    };

    /// The cube in the hand, if any.
    pub fn held(&self) -> Option<usize> {
        self.places.iter().position(|&p| p == Place::Hand)
    }

    /// Whether this is the rewarded state of the task under the box assignment `boxes` (task 1).
    pub fn is_goal_with(&self, variant: Variant, boxes: Boxes) -> bool {
        match variant {
            Variant::Task1 => (0..N_CUBES).all(|c| self.places[c] == Place::Box(boxes.of(c))),
            Variant::Task2 => self.leds == 3,
        }
    }

    /// Readable name, e.g. `R:redbox G:hand B:table LED:1`.
    pub fn name(&self, variant: Variant) -> String {
        let mut parts: Vec<String> = (0..N_CUBES)
            .map(|c| format!("{}:{}", COLOURS[c], self.places[c].label()))
            .collect();
        if variant == Variant::Task2 {
            parts.push(format!("LED:{}", self.leds));
        }
        parts.join(" ")
    }

    /// The deterministic effect of `action` (SPEC 2.1, 2.2).
    pub fn apply(&self, action: usize, variant: Variant) -> Effect {
        self.apply_with(action, variant, Boxes::RGB)
    }

    /// [`apply`](TidyState::apply) under the box assignment `boxes` (task 1; task 2 keeps its
    /// fixed assignment): the next state does not depend on it, relevance and errors do.
    pub fn apply_with(&self, action: usize, variant: Variant, boxes: Boxes) -> Effect {
        let mut next = *self;
        let mut relevant = false;
        let mut error = false;
        let held = self.held();
        match action {
            0..=2 => {
                let cube = action;
                // A take with a full hand changes nothing (SPEC 2.1 Decision).
                if held.is_none() {
                    if variant == Variant::Task2
                        && self.places[cube] == Place::Box(cube as u8)
                        && (self.leds as usize) > cube
                    {
                        // Taking out a cube whose LED is lit is an error (SPEC 2.2).
                        error = true;
                        next.leds = 0;
                    }
                    next.places[cube] = Place::Hand;
                }
            }
            3..=5 => {
                let target = action - 3;
                if let Some(cube) = held {
                    next.places[cube] = Place::Box(target as u8);
                    match variant {
                        Variant::Task1 => {
                            relevant = usize::from(boxes.of(cube)) == target;
                            error = !relevant;
                        }
                        Variant::Task2 => {
                            if cube == target && self.leds as usize == cube {
                                relevant = true;
                                next.leds += 1;
                            } else {
                                error = true;
                                next.leds = 0;
                            }
                        }
                    }
                }
            }
            PUT_ON_TABLE => {
                if let Some(cube) = held {
                    next.places[cube] = Place::Table;
                }
            }
            _ => panic!("tidy action {action} out of range 0..{N_ACTIONS}"),
        }
        Effect {
            next,
            relevant,
            error,
        }
    }

    /// The human's put when the robot holds a cube (SPEC 5, takeover), under the box
    /// assignment `boxes`.
    pub fn takeover_action_with(&self, variant: Variant, boxes: Boxes) -> Option<usize> {
        let cube = self.held()?;
        Some(match variant {
            Variant::Task1 => 3 + usize::from(boxes.of(cube)),
            Variant::Task2 if self.leds as usize == cube => 3 + cube,
            Variant::Task2 => PUT_ON_TABLE,
        })
    }
}

/// All reachable states in breadth-first order from the start, trying actions in index order.
pub fn enumerate(variant: Variant) -> Vec<TidyState> {
    let mut order = vec![TidyState::START];
    let mut seen: HashMap<TidyState, usize> = HashMap::from([(TidyState::START, 0)]);
    let mut queue = VecDeque::from([TidyState::START]);
    while let Some(state) = queue.pop_front() {
        for action in 0..N_ACTIONS {
            let next = state.apply(action, variant).next;
            if let std::collections::hash_map::Entry::Vacant(slot) = seen.entry(next) {
                slot.insert(order.len());
                order.push(next);
                queue.push_back(next);
            }
        }
    }
    order
}

/// Compiles a tidy task into a [`Spec`].
pub fn build(variant: Variant) -> Spec {
    build_with(variant, Boxes::RGB)
}

/// Compiles a tidy task under the box assignment `boxes` (SPEC 10; task 2 only with `rgb`):
/// the same states and transitions as [`build`], another goal and other human tables.
pub fn build_with(variant: Variant, boxes: Boxes) -> Spec {
    assert!(
        variant == Variant::Task1 || boxes == Boxes::RGB,
        "task 2 keeps its fixed box assignment"
    );
    let states = enumerate(variant);
    let id: HashMap<TidyState, StateId> = states
        .iter()
        .enumerate()
        .map(|(i, &s)| (s, i as StateId))
        .collect();
    let n = states.len();
    let mut outcomes = Vec::with_capacity(n * N_ACTIONS);
    let mut relevant = Vec::with_capacity(n * N_ACTIONS);
    let mut error = Vec::with_capacity(n * N_ACTIONS);
    let mut nuisance = Vec::with_capacity(n * N_ACTIONS);
    for state in &states {
        for action in 0..N_ACTIONS {
            let effect = state.apply_with(action, variant, boxes);
            outcomes.push(vec![(id[&effect.next], 1.0)]);
            relevant.push(effect.relevant);
            error.push(effect.error);
            nuisance.push(if effect.relevant {
                // SPEC 11.2: the human takes the cube just put back out, onto the table; in
                // task 2 its LED goes off with the others, as when a lit cube is taken out.
                let mut undone = effect.next;
                let cube = state.held().expect("a relevant action is a put");
                undone.places[cube] = Place::Table;
                undone.leds = 0;
                id.get(&undone).copied().unwrap_or(NO_NUISANCE)
            } else {
                NO_NUISANCE
            });
        }
    }
    let takeover_action = states
        .iter()
        .map(|s| {
            s.takeover_action_with(variant, boxes)
                .map_or(NO_TAKEOVER, |a| a as u8)
        })
        .collect();
    let goal = states
        .iter()
        .position(|s| s.is_goal_with(variant, boxes))
        .expect("goal is reachable");
    let name = match variant {
        Variant::Task1 => "tidy1",
        Variant::Task2 => "tidy2",
    };
    Spec::from_outcomes(
        name.to_string(),
        n,
        N_ACTIONS,
        outcomes,
        vec![0],
        Goal {
            state: goal as StateId,
            reward: 1.0,
        },
        states.iter().map(|s| s.name(variant)).collect(),
        Some(HumanTables {
            relevant,
            error,
            takeover_action,
            nuisance,
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task1_has_112_states_64_with_empty_hand() {
        let states = enumerate(Variant::Task1);
        assert_eq!(states.len(), 112);
        assert_eq!(states.iter().filter(|s| s.held().is_none()).count(), 64);
    }

    #[test]
    fn a_nuisance_never_leaves_the_robot_in_the_goal() {
        // The step treats an undone arrival as bringing nothing: true only if no nuisance state
        // is a goal, for every box assignment.
        let worlds = BOX_NAMES
            .iter()
            .map(|b| build_with(Variant::Task1, Boxes::parse(b).unwrap()));
        for spec in worlds.chain([build(Variant::Task2)]) {
            let goal = spec.goal_state().unwrap();
            let tables = spec.human.as_ref().unwrap();
            let undone: Vec<StateId> = tables
                .nuisance
                .iter()
                .copied()
                .filter(|&s| s != NO_NUISANCE)
                .collect();
            assert!(!undone.is_empty(), "{}", spec.name);
            assert!(!undone.contains(&goal), "{}", spec.name);
        }
    }

    #[test]
    fn task2_has_142_states() {
        assert_eq!(enumerate(Variant::Task2).len(), 142);
    }

    #[test]
    fn start_state_is_id_0_and_names_read_well() {
        let spec = build(Variant::Task2);
        assert_eq!(spec.state_names[0], "R:table G:table B:table LED:0");
        assert_eq!(spec.initial_states, vec![0]);
    }
}
