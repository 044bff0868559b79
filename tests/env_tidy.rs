//! The environments of SPEC 2: the tidy tasks' sizes, ids, dynamics and human tables checked
//! against an independent statement of the rules, the tidy1 fixture in the authors' format, the
//! JSON export round trip through the binary, the authors' navigation world as loaded, and table
//! invariants of every world.

mod common;

use std::collections::{HashMap, VecDeque};

use assert_cmd::Command;
use mbmf::env::{self, NO_TAKEOVER, Spec};

const FIXTURE_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tidy1");

fn load(task: &str) -> Spec {
    env::load(task).unwrap_or_else(|e| panic!("cannot load {task}: {e}"))
}

// ---------------------------------------------------------------------------------------------
// The tidy rules of SPEC 2.1, 2.2 and 5, restated on readable states.

/// Places as the state names spell them.
const TABLE: &str = "table";
const HAND: &str = "hand";
const BOXES: [&str; 3] = ["redbox", "greenbox", "bluebox"];
const CUBES: [&str; 3] = ["R", "G", "B"];

/// A tidy state: the place of each cube and, in task 2, the lit LEDs.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct Tidy {
    places: [&'static str; 3],
    leds: Option<u8>,
}

impl Tidy {
    fn start(task2: bool) -> Tidy {
        Tidy {
            places: [TABLE; 3],
            leds: task2.then_some(0),
        }
    }

    /// Parses `R:redbox G:hand B:table` (task 1) or `... LED:k` (task 2).
    fn parse(name: &str) -> Tidy {
        let mut places = [TABLE; 3];
        let mut leds = None;
        for part in name.split(' ') {
            let (key, value) = part.split_once(':').expect("key:value");
            if key == "LED" {
                leds = Some(value.parse().expect("LED count"));
                continue;
            }
            let cube = CUBES.iter().position(|&c| c == key).expect("cube letter");
            places[cube] = [TABLE, HAND, BOXES[0], BOXES[1], BOXES[2]]
                .into_iter()
                .find(|&p| p == value)
                .unwrap_or_else(|| panic!("unknown place {value}"));
        }
        Tidy { places, leds }
    }

    fn name(&self) -> String {
        let mut parts: Vec<String> = (0..3)
            .map(|c| format!("{}:{}", CUBES[c], self.places[c]))
            .collect();
        if let Some(k) = self.leds {
            parts.push(format!("LED:{k}"));
        }
        parts.join(" ")
    }

    fn held(&self) -> Option<usize> {
        self.places.iter().position(|&p| p == HAND)
    }

    fn is_goal(&self) -> bool {
        match self.leds {
            None => (0..3).all(|c| self.places[c] == BOXES[c]),
            Some(k) => k == 3,
        }
    }

    /// (next state, relevant, error) of an action: 0-2 take R/G/B, 3-5 put in the R/G/B box,
    /// 6 put on the table.
    fn apply(&self, action: usize) -> (Tidy, bool, bool) {
        let mut next = self.clone();
        let (mut relevant, mut error) = (false, false);
        match (action, self.held()) {
            (0..=2, None) => {
                let cube = action;
                let lit = self.leds.is_some_and(|k| usize::from(k) > cube);
                if lit && BOXES.contains(&self.places[cube]) {
                    error = true;
                    next.leds = Some(0);
                }
                next.places[cube] = HAND;
            }
            (3..=5, Some(cube)) => {
                let target = action - 3;
                next.places[cube] = BOXES[target];
                match self.leds {
                    None => {
                        relevant = cube == target;
                        error = cube != target;
                    }
                    Some(k) if cube == target && usize::from(k) == cube => {
                        relevant = true;
                        next.leds = Some(k + 1);
                    }
                    Some(_) => {
                        error = true;
                        next.leds = Some(0);
                    }
                }
            }
            (6, Some(cube)) => next.places[cube] = TABLE,
            // A take with a full hand, a put with an empty hand: nothing changes.
            _ => {}
        }
        (next, relevant, error)
    }

    /// The human's put at a takeover (SPEC 5).
    fn takeover(&self) -> Option<usize> {
        let cube = self.held()?;
        Some(match self.leds {
            Some(k) if usize::from(k) != cube => 6,
            _ => 3 + cube,
        })
    }
}

/// Breadth-first enumeration from the start, actions in index order (SPEC 2.1).
fn enumerate(task2: bool) -> Vec<Tidy> {
    let start = Tidy::start(task2);
    let mut order = vec![start.clone()];
    let mut seen = HashMap::from([(start.clone(), 0)]);
    let mut queue = VecDeque::from([start]);
    while let Some(state) = queue.pop_front() {
        for action in 0..7 {
            let next = state.apply(action).0;
            if !seen.contains_key(&next) {
                seen.insert(next.clone(), order.len());
                order.push(next.clone());
                queue.push_back(next);
            }
        }
    }
    order
}

fn ids(spec: &Spec) -> HashMap<&str, usize> {
    spec.state_names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i))
        .collect()
}

/// The single next state of a deterministic pair.
fn next_of(spec: &Spec, s: usize, a: usize) -> usize {
    let sa = spec.sa(s, a);
    let outcomes = spec.outcomes(sa);
    assert_eq!(outcomes.len(), 1, "tidy transitions are deterministic");
    spec.outcome_state[outcomes.start] as usize
}

/// Checks every state-action pair of a tidy spec against the rules above.
fn check_tidy_against_rules(task: &str, task2: bool) {
    let spec = load(task);
    let expected = enumerate(task2);
    let names: Vec<String> = expected.iter().map(Tidy::name).collect();
    assert_eq!(
        spec.state_names, names,
        "{task}: state ids are not breadth-first"
    );
    let id = ids(&spec);
    let human = spec.human.as_ref().expect("tidy tasks define the human");
    assert_eq!(spec.n_actions, 7);
    assert_eq!(spec.initial_states, vec![0]);
    assert_eq!(spec.goal.unwrap().reward, 1.0);
    assert!(
        expected[spec.goal_state().unwrap() as usize].is_goal(),
        "{task}: goal"
    );
    assert_eq!(expected.iter().filter(|s| s.is_goal()).count(), 1);
    for (s, state) in expected.iter().enumerate() {
        for a in 0..7 {
            let (next, relevant, error) = state.apply(a);
            let sa = spec.sa(s, a);
            let at = format!("{task}: state {s} ({}), action {a}", state.name());
            assert_eq!(
                next_of(&spec, s, a),
                id[next.name().as_str()],
                "{at}: next state"
            );
            assert_eq!(human.relevant[sa], relevant, "{at}: relevant");
            assert_eq!(human.error[sa], error, "{at}: error");
        }
        let takeover = human.takeover_action[s];
        let takeover = (takeover != NO_TAKEOVER).then_some(usize::from(takeover));
        assert_eq!(takeover, state.takeover(), "{task}: state {s}: takeover");
    }
}

#[test]
fn tidy1_has_112_states_64_with_the_hand_empty_and_48_holding_a_cube() {
    let spec = load("tidy1");
    assert_eq!(spec.n_states, 112);
    let holding = spec.state_names.iter().filter(|n| n.contains(HAND)).count();
    assert_eq!(spec.n_states - holding, 64);
    assert_eq!(holding, 48);
    assert_eq!(spec.state_names[0], "R:table G:table B:table");
}

#[test]
fn tidy2_has_142_states() {
    let spec = load("tidy2");
    assert_eq!(spec.n_states, 142);
    assert_eq!(spec.state_names[0], "R:table G:table B:table LED:0");
}

#[test]
fn the_navigation_world_has_38_states_and_8_actions() {
    let Some(task) = common::navworld_task() else {
        return;
    };
    let spec = load(&task);
    assert_eq!((spec.n_states, spec.n_actions), (38, 8));
    assert_eq!(spec.initial_states, vec![0, 32]);
    assert_eq!(
        (spec.goal_state().unwrap(), spec.goal.unwrap().reward),
        (18, 1.0)
    );
    assert!(spec.human.is_none());
}

#[test]
fn every_tidy1_transition_and_human_table_follows_the_rules() {
    check_tidy_against_rules("tidy1", false);
}

#[test]
fn every_tidy2_transition_and_human_table_follows_the_rules() {
    check_tidy_against_rules("tidy2", true);
}

/// The next state's name of (state name, action) in a spec.
fn step_by_name(spec: &Spec, state: &str, action: usize) -> String {
    let id = ids(spec);
    let s = *id
        .get(state)
        .unwrap_or_else(|| panic!("{}: no state {state}", spec.name));
    spec.state_names[next_of(spec, s, action)].clone()
}

fn is_error(spec: &Spec, state: &str, action: usize) -> bool {
    let s = ids(spec)[state];
    spec.human.as_ref().unwrap().error[spec.sa(s, action)]
}

#[test]
fn hand_made_tidy1_transitions() {
    let spec = load("tidy1");
    // Take red from the table.
    assert_eq!(
        step_by_name(&spec, "R:table G:table B:table", 0),
        "R:hand G:table B:table"
    );
    // A take with a full hand changes nothing.
    assert_eq!(
        step_by_name(&spec, "R:hand G:table B:table", 1),
        "R:hand G:table B:table"
    );
    // A put with an empty hand changes nothing.
    for put in 3..=6 {
        assert_eq!(
            step_by_name(&spec, "R:table G:greenbox B:table", put),
            "R:table G:greenbox B:table"
        );
    }
    // Taking from a box works, from its own box or another.
    assert_eq!(
        step_by_name(&spec, "R:redbox G:table B:table", 0),
        "R:hand G:table B:table"
    );
    assert_eq!(
        step_by_name(&spec, "R:table G:table B:redbox", 2),
        "R:table G:table B:hand"
    );
    // Putting into a box and on the table.
    assert_eq!(
        step_by_name(&spec, "R:table G:hand B:table", 5),
        "R:table G:bluebox B:table"
    );
    assert_eq!(
        step_by_name(&spec, "R:table G:hand B:table", 6),
        "R:table G:table B:table"
    );
    assert!(is_error(&spec, "R:table G:hand B:table", 5));
    assert!(!is_error(&spec, "R:table G:hand B:table", 4));
    // The last cube into its box reaches the goal, id 90 as in the authors' export.
    let goal = step_by_name(&spec, "R:redbox G:greenbox B:hand", 5);
    assert_eq!(goal, "R:redbox G:greenbox B:bluebox");
    assert_eq!(spec.state_names[spec.goal_state().unwrap() as usize], goal);
    assert_eq!(spec.goal_state().unwrap(), 90);
}

#[test]
fn hand_made_tidy2_transitions() {
    let spec = load("tidy2");
    // Red into the red box at k = 0 lights LED 1.
    assert_eq!(
        step_by_name(&spec, "R:hand G:table B:table LED:0", 3),
        "R:redbox G:table B:table LED:1"
    );
    // Green into the green box at k = 0 is an error (k stays 0); at k = 1 it lights LED 2.
    assert_eq!(
        step_by_name(&spec, "R:table G:hand B:table LED:0", 4),
        "R:table G:greenbox B:table LED:0"
    );
    assert!(is_error(&spec, "R:table G:hand B:table LED:0", 4));
    assert_eq!(
        step_by_name(&spec, "R:redbox G:hand B:table LED:1", 4),
        "R:redbox G:greenbox B:table LED:2"
    );
    // Blue into its box out of order resets k.
    assert_eq!(
        step_by_name(&spec, "R:redbox G:table B:hand LED:1", 5),
        "R:redbox G:table B:bluebox LED:0"
    );
    // A wrong box resets k.
    assert_eq!(
        step_by_name(&spec, "R:redbox G:hand B:table LED:1", 3),
        "R:redbox G:redbox B:table LED:0"
    );
    // Taking a lit cube out of its box resets k; taking an unlit one does not.
    assert_eq!(
        step_by_name(&spec, "R:redbox G:greenbox B:table LED:2", 1),
        "R:redbox G:hand B:table LED:0"
    );
    assert!(is_error(&spec, "R:redbox G:greenbox B:table LED:2", 1));
    assert_eq!(
        step_by_name(&spec, "R:redbox G:table B:bluebox LED:1", 2),
        "R:redbox G:table B:hand LED:1"
    );
    // Table puts are not errors and keep k.
    assert_eq!(
        step_by_name(&spec, "R:redbox G:hand B:table LED:1", 6),
        "R:redbox G:table B:table LED:1"
    );
    assert!(!is_error(&spec, "R:redbox G:hand B:table LED:1", 6));
    // The third LED is the goal.
    let goal = step_by_name(&spec, "R:redbox G:greenbox B:hand LED:2", 5);
    assert_eq!(goal, "R:redbox G:greenbox B:bluebox LED:3");
    assert_eq!(spec.state_names[spec.goal_state().unwrap() as usize], goal);
}

/// Asserts that two specs have the same dynamics (all but the name and state names).
fn assert_same_tables(a: &Spec, b: &Spec) {
    let what = format!("{} vs {}", a.name, b.name);
    assert_eq!(
        (a.n_states, a.n_actions),
        (b.n_states, b.n_actions),
        "{what}: sizes"
    );
    assert_eq!(a.outcome_start, b.outcome_start, "{what}: outcome_start");
    assert_eq!(a.outcome_state, b.outcome_state, "{what}: outcome_state");
    assert_eq!(a.outcome_cum, b.outcome_cum, "{what}: outcome_cum");
    assert_eq!(a.initial_states, b.initial_states, "{what}: initial states");
    assert_eq!(a.goal, b.goal, "{what}: goal");
    assert_eq!(a.arrival, b.arrival, "{what}: arrivals");
}

#[test]
fn the_tidy1_fixture_in_the_authors_format_has_the_built_in_tables() {
    let fixture = load(&format!("json:{FIXTURE_DIR}/tidy1.json"));
    assert_same_tables(&load("tidy1"), &fixture);
}

#[test]
fn the_fixture_state_ids_match_the_built_in_state_names() {
    let builtin = load("tidy1");
    let csv = std::fs::read_to_string(format!("{FIXTURE_DIR}/tidy1_states.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("id,red,green,blue,held,is_goal,is_init"));
    let mut rows = 0;
    for line in lines {
        let cols: Vec<&str> = line.split(',').collect();
        let id: usize = cols[0].parse().unwrap();
        let place = |p: &str| p.to_lowercase();
        let name = format!(
            "R:{} G:{} B:{}",
            place(cols[1]),
            place(cols[2]),
            place(cols[3])
        );
        assert_eq!(builtin.state_names[id], name, "state {id}");
        let held = match cols[4] {
            "none" => None,
            "red" => Some(0),
            "green" => Some(1),
            "blue" => Some(2),
            other => panic!("state {id}: held {other}"),
        };
        assert_eq!(Tidy::parse(&name).held(), held, "state {id}: held cube");
        assert_eq!(
            cols[5] == "1",
            id == builtin.goal_state().unwrap() as usize,
            "state {id}: is_goal"
        );
        assert_eq!(
            cols[6] == "1",
            builtin.initial_states.contains(&(id as u32)),
            "state {id}: is_init"
        );
        rows += 1;
    }
    assert_eq!(rows, 112);
}

#[test]
fn exporting_a_tidy_task_with_the_binary_and_loading_it_back_gives_the_same_tables() {
    let dir = tempfile::tempdir().unwrap();
    for task in ["tidy1", "tidy2"] {
        let out = dir.path().join(task);
        Command::new(env!("CARGO_BIN_EXE_mbmf"))
            .args(["env", "export", task, "--json"])
            .arg(&out)
            .assert()
            .success();
        let model = out.join(format!("{task}.json"));
        let back = load(&format!("json:{}", model.display()));
        let builtin = load(task);
        assert_same_tables(&builtin, &back);
        assert_eq!(back.outcome_weight, builtin.outcome_weight);
    }
}

/// CSR tables are consistent and every pair's cumulative probabilities rise to exactly 1.
fn check_invariants(spec: &Spec) {
    let pairs = spec.n_states * spec.n_actions;
    assert_eq!(spec.outcome_start.len(), pairs + 1);
    assert_eq!(spec.outcome_start[0], 0);
    assert_eq!(
        *spec.outcome_start.last().unwrap() as usize,
        spec.outcome_state.len()
    );
    assert_eq!(spec.outcome_cum.len(), spec.outcome_state.len());
    for sa in 0..pairs {
        let at = format!(
            "{}: state {}, action {}",
            spec.name,
            sa / spec.n_actions,
            sa % spec.n_actions
        );
        let range = spec.outcomes(sa);
        assert!(!range.is_empty(), "{at}: no outcome");
        let cum = &spec.outcome_cum[range.clone()];
        assert_eq!(
            *cum.last().unwrap(),
            1.0,
            "{at}: cumulative probabilities end at {cum:?}"
        );
        assert!(cum[0] > 0.0, "{at}: first outcome has no probability");
        assert!(
            cum.windows(2).all(|w| w[0] < w[1]),
            "{at}: {cum:?} not increasing"
        );
        let next = &spec.outcome_state[range];
        assert!(
            next.windows(2).all(|w| w[0] < w[1]),
            "{at}: next states not ascending"
        );
        assert!(
            next.iter().all(|&s| (s as usize) < spec.n_states),
            "{at}: next state out of range"
        );
    }
    assert!((spec.goal_state().unwrap() as usize) < spec.n_states);
    assert!(!spec.initial_states.is_empty());
    assert!(!spec.initial_states.contains(&spec.goal_state().unwrap()));
}

#[test]
fn every_state_action_pair_has_cumulative_probabilities_ending_at_1() {
    let mut specs = vec![
        load("tidy1"),
        load("tidy2"),
        load(&format!("json:{FIXTURE_DIR}/tidy1.json")),
    ];
    if let Some(task) = common::navworld_task() {
        specs.push(load(&task));
    }
    for spec in &specs {
        check_invariants(spec);
    }
}

#[test]
fn loads_the_authors_navworld_with_its_repeated_outcome_merged() {
    if common::navworld_task().is_none() {
        return;
    }
    let paths = env::JsonPaths::beside(common::NAVWORLD);
    let spec = env::json::load(&paths, "json:navworld").expect("navworld loads");
    assert_eq!((spec.n_states, spec.n_actions), (38, 8));
    assert_eq!(spec.initial_states, vec![0, 32]);
    assert_eq!(
        (spec.goal_state().unwrap(), spec.goal.unwrap().reward),
        (18, 1.0)
    );
    assert_eq!(spec.state_names[37], "s37");
    assert!(spec.human.is_none());
    check_invariants(&spec);

    // The file lists (32, 4) -> 14 twice; the spec holds one outcome with the summed count.
    let text = std::fs::read_to_string(&paths.model).expect("read navworld");
    let root: serde_json::Value = serde_json::from_str(&text).expect("navworld is JSON");
    let listed: Vec<f64> = root["transitionActions"]
        .as_array()
        .expect("entries")
        .iter()
        .filter(|entry| entry["state"] == 32)
        .flat_map(|entry| entry["transitions"].as_array().expect("transitions").iter())
        .filter(|t| t["action"] == 4 && t["state"] == 14)
        .map(|t| t["prob"].as_f64().expect("count"))
        .collect();
    assert_eq!(listed.len(), 2, "the file should list (32, 4) -> 14 twice");
    let sa = spec.sa(32, 4);
    let merged: Vec<f64> = spec
        .outcomes(sa)
        .filter(|&o| spec.outcome_state[o] == 14)
        .map(|o| spec.outcome_weight[o])
        .collect();
    assert_eq!(merged, vec![listed.iter().sum::<f64>()]);
    assert_eq!(spec.outcomes(sa).len(), 2);

    let out = tempfile::tempdir().unwrap();
    let exported = env::json::export(&spec, out.path()).expect("export navworld");
    let back = env::json::load(&exported, "json:navworld").expect("exported navworld loads");
    // The export is the world; the changes its keyStates.txt schedules (and mbmf does not
    // apply) are not part of it.
    assert!(!spec.unapplied.is_empty());
    assert!(back.unapplied.is_empty());
    let mut world = spec.clone();
    world.unapplied.clear();
    assert_eq!(back, world);
}

#[test]
fn outcomes_are_picked_in_proportion_to_their_counts() {
    // A stochastic pair of the navigation world (if present): the draw u falls into the
    // cumulative intervals.
    let Some(task) = common::navworld_task() else {
        return;
    };
    let spec = load(&task);
    let sa = (0..spec.n_states * spec.n_actions)
        .find(|&sa| spec.outcomes(sa).len() >= 2)
        .expect("a stochastic pair");
    let range = spec.outcomes(sa);
    let total: f64 = spec.outcome_weight[range.clone()].iter().sum();
    let mut lower = 0.0;
    for o in range {
        let share = spec.outcome_weight[o] / total;
        assert_eq!(
            spec.pick_outcome(sa, lower),
            o,
            "u at the start of outcome {o}"
        );
        assert_eq!(spec.pick_outcome(sa, lower + share * 0.5), o);
        assert!(
            (spec.outcome_cum[o] - lower - share).abs() < 1e-12,
            "outcome {o}: share"
        );
        lower = spec.outcome_cum[o];
    }
    assert_eq!(
        spec.pick_outcome(sa, 0.999_999_999),
        spec.outcomes(sa).end - 1
    );
}
