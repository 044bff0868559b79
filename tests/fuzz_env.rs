//! Fuzzing the `json:` environment loader: the JSON model, `keyStates.txt` and
//! `spaces.txt`, from random bytes and from structured mutations of the real fixture
//! `tests/data/tidy1`. Whatever the input, loading returns a well-formed spec or an error with a
//! message; it never panics, and sizes are bounded so it never hangs.
//!
//! The normal test run tries 256 cases per property. A longer session:
//! `PROPTEST_CASES=100000 cargo test --release --test fuzz_env`. Inputs worth keeping go in
//! `tests/fuzz_corpus/env/` (one folder per case, see its README), replayed by the last test.

mod common;

use std::path::{Path, PathBuf};

use mbmf::env::json::load;
use mbmf::env::{JsonPaths, Spec};
use proptest::prelude::*;
use serde_json::{Value, json};
use tempfile::TempDir;

/// The fixture's three files, read once.
struct Fixture {
    model: String,
    key_states: String,
    spaces: String,
}

fn fixture() -> Fixture {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/tidy1");
    let read = |name: &str| std::fs::read_to_string(dir.join(name)).expect("the tidy1 fixture");
    Fixture {
        model: read("tidy1.json"),
        key_states: read("keyStates.txt"),
        spaces: read("spaces.txt"),
    }
}

/// Writes the three files (as bytes) into a fresh folder and loads them.
fn load_bytes(model: &[u8], key_states: &[u8], spaces: &[u8]) -> Result<Spec, String> {
    let dir = TempDir::new().expect("a temporary folder");
    let paths = JsonPaths::beside(dir.path().join("world.json"));
    std::fs::write(&paths.model, model).expect("write");
    std::fs::write(&paths.key_states, key_states).expect("write");
    std::fs::write(&paths.spaces, spaces).expect("write");
    checked(load(&paths, "fuzz"))
}

/// A loaded spec must be well formed; an error must say something.
fn checked(result: Result<Spec, mbmf::env::json::EnvFileError>) -> Result<Spec, String> {
    match result {
        Ok(spec) => {
            assert_well_formed(&spec);
            Ok(spec)
        }
        Err(error) => {
            let message = error.to_string();
            assert!(!message.is_empty());
            Err(message)
        }
    }
}

/// The invariants every consumer of a [`Spec`] relies on (CSR tables, probabilities, ids).
fn assert_well_formed(spec: &Spec) {
    let pairs = spec.n_states * spec.n_actions;
    assert!(spec.n_states > 0 && spec.n_actions > 0);
    assert_eq!(spec.outcome_start.len(), pairs + 1);
    assert_eq!(spec.outcome_start[0], 0);
    assert_eq!(
        *spec.outcome_start.last().unwrap() as usize,
        spec.outcome_state.len()
    );
    assert_eq!(spec.outcome_weight.len(), spec.outcome_state.len());
    assert_eq!(spec.outcome_cum.len(), spec.outcome_state.len());
    for sa in 0..pairs {
        let range = spec.outcomes(sa);
        assert!(!range.is_empty(), "pair {sa} has no outcome");
        let mut previous = 0.0;
        for o in range.clone() {
            assert!((spec.outcome_state[o] as usize) < spec.n_states);
            let w = spec.outcome_weight[o];
            assert!(w > 0.0 && w.is_finite(), "weight {w}");
            let c = spec.outcome_cum[o];
            assert!(
                (previous..=1.0).contains(&c),
                "cumulative {c} after {previous}"
            );
            previous = c;
        }
        assert_eq!(spec.outcome_cum[range.end - 1], 1.0);
    }
    assert!(!spec.initial_states.is_empty());
    assert!(
        spec.initial_states
            .iter()
            .all(|&s| (s as usize) < spec.n_states)
    );
    assert!((spec.goal_state().unwrap() as usize) < spec.n_states);
    assert!(!spec.initial_states.contains(&spec.goal_state().unwrap()));
    assert!(spec.goal.unwrap().reward.is_finite());
    assert_eq!(spec.state_names.len(), spec.n_states);
}

/// Random bytes, at most 2 KiB, biased towards the characters the formats use.
fn bytes() -> impl Strategy<Value = Vec<u8>> {
    let byte = prop_oneof![
        3 => any::<u8>(),
        5 => prop::sample::select(b"{}[]:,\"0123456789.-+eE \n\t#".to_vec()),
    ];
    prop::collection::vec(byte, 0..2048)
}

/// A JSON value of any type, with the numbers that break naive loaders.
fn json_value() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        prop::sample::select(vec![
            json!(0),
            json!(1),
            json!(-1),
            json!(6),
            json!(7),
            json!(90),
            json!(111),
            json!(112),
            json!(4294967295u64),
            json!(4294967296u64),
            json!(u64::MAX),
            json!(i64::MIN),
            json!(0.5),
            json!(1e-320),
            json!(1e308),
            json!(-0.0),
        ]),
        any::<i64>().prop_map(|i| json!(i)),
        any::<f64>()
            .prop_filter("JSON has no NaN or infinity", |f| f.is_finite())
            .prop_map(|f| json!(f)),
        "[a-z0-9 ]{0,8}".prop_map(Value::String),
    ];
    leaf.prop_recursive(3, 16, 4, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..4).prop_map(Value::Array),
            prop::collection::vec(
                (
                    prop::sample::select(vec!["state", "action", "prob", "transitions", "x"]),
                    inner
                ),
                0..4
            )
            .prop_map(|kv| {
                Value::Object(kv.into_iter().map(|(k, v)| (k.to_string(), v)).collect())
            }),
        ]
    })
}

/// One structured change to the model document.
#[derive(Debug, Clone)]
enum Mutation {
    /// Replace a transition's field (`action`, `state` or `prob`) with a value.
    SetTransitionField(usize, usize, &'static str, Value),
    /// Remove a transition's field.
    RemoveTransitionField(usize, usize, &'static str),
    /// Replace an entry's field (`state` or `transitions`) with a value.
    SetEntryField(usize, &'static str, Value),
    /// Remove an entry's field.
    RemoveEntryField(usize, &'static str),
    /// Copy an entry to the end (a state listed twice).
    DuplicateEntry(usize),
    /// Remove an entry (a state with no listed outcome).
    RemoveEntry(usize),
    /// Copy a transition within its entry (a repeated outcome).
    DuplicateTransition(usize, usize),
    /// Replace the whole document or `transitionActions`.
    ReplaceTop(bool, Value),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let i = 0..120usize;
    let j = 0..8usize;
    let transition_key = prop::sample::select(vec!["action", "state", "prob"]);
    let entry_key = prop::sample::select(vec!["state", "transitions"]);
    prop_oneof![
        4 => (i.clone(), j.clone(), transition_key.clone(), json_value())
            .prop_map(|(i, j, k, v)| Mutation::SetTransitionField(i, j, k, v)),
        1 => (i.clone(), j.clone(), transition_key)
            .prop_map(|(i, j, k)| Mutation::RemoveTransitionField(i, j, k)),
        2 => (i.clone(), entry_key.clone(), json_value())
            .prop_map(|(i, k, v)| Mutation::SetEntryField(i, k, v)),
        1 => (i.clone(), entry_key).prop_map(|(i, k)| Mutation::RemoveEntryField(i, k)),
        1 => i.clone().prop_map(Mutation::DuplicateEntry),
        1 => i.clone().prop_map(Mutation::RemoveEntry),
        1 => (i, j).prop_map(|(i, j)| Mutation::DuplicateTransition(i, j)),
        1 => (any::<bool>(), json_value()).prop_map(|(whole, v)| Mutation::ReplaceTop(whole, v)),
    ]
}

/// Applies `m` to the model document; indices wrap around the lists they point into.
fn apply(doc: &mut Value, m: &Mutation) {
    fn entries(doc: &mut Value) -> Option<&mut Vec<Value>> {
        doc.get_mut("transitionActions")?.as_array_mut()
    }
    fn entry(doc: &mut Value, i: usize) -> Option<&mut serde_json::Map<String, Value>> {
        let list = entries(doc)?;
        let n = list.len();
        (n > 0).then(|| list[i % n].as_object_mut()).flatten()
    }
    fn transitions(doc: &mut Value, i: usize) -> Option<&mut Vec<Value>> {
        entry(doc, i)?.get_mut("transitions")?.as_array_mut()
    }
    fn transition(
        doc: &mut Value,
        i: usize,
        j: usize,
    ) -> Option<&mut serde_json::Map<String, Value>> {
        let list = transitions(doc, i)?;
        let n = list.len();
        (n > 0).then(|| list[j % n].as_object_mut()).flatten()
    }
    match m {
        Mutation::SetTransitionField(i, j, k, v) => {
            if let Some(t) = transition(doc, *i, *j) {
                t.insert(k.to_string(), v.clone());
            }
        }
        Mutation::RemoveTransitionField(i, j, k) => {
            if let Some(t) = transition(doc, *i, *j) {
                t.remove(*k);
            }
        }
        Mutation::SetEntryField(i, k, v) => {
            if let Some(e) = entry(doc, *i) {
                e.insert(k.to_string(), v.clone());
            }
        }
        Mutation::RemoveEntryField(i, k) => {
            if let Some(e) = entry(doc, *i) {
                e.remove(*k);
            }
        }
        Mutation::DuplicateEntry(i) => {
            if let Some(list) = entries(doc).filter(|l| !l.is_empty()) {
                let copy = list[i % list.len()].clone();
                list.push(copy);
            }
        }
        Mutation::RemoveEntry(i) => {
            if let Some(list) = entries(doc).filter(|l| !l.is_empty()) {
                let n = list.len();
                list.remove(i % n);
            }
        }
        Mutation::DuplicateTransition(i, j) => {
            if let Some(list) = transitions(doc, *i).filter(|l| !l.is_empty()) {
                let copy = list[j % list.len()].clone();
                list.push(copy);
            }
        }
        Mutation::ReplaceTop(whole, v) => {
            if *whole {
                *doc = v.clone();
            } else if let Some(top) = doc.as_object_mut() {
                top.insert("transitionActions".into(), v.clone());
            }
        }
    }
}

/// A line of `keyStates.txt` or `spaces.txt` from the formats' own vocabulary.
fn text_line() -> impl Strategy<Value = String> {
    let word = prop::sample::select(vec![
        "init",
        "goal",
        "new_goal",
        "del_trans",
        "state",
        "action",
        "gaol",
        "stat",
        "#",
        "",
    ]);
    let number = prop::sample::select(vec![
        "0",
        "1",
        "6",
        "7",
        "8",
        "89",
        "90",
        "111",
        "112",
        "113",
        "100000",
        "-1",
        "+5",
        "1.5",
        "1e300",
        "-1e300",
        "1e400",
        "nan",
        "inf",
        "-inf",
        "4294967296",
        "18446744073709551616",
        "0x10",
        "abc",
        "\u{feff}",
        "9999999999999999999999",
    ]);
    (word, prop::collection::vec(number, 0..4)).prop_map(|(w, ns)| format!("{w} {}", ns.join(" ")))
}

fn text_file() -> impl Strategy<Value = String> {
    prop::collection::vec(text_line(), 0..6).prop_map(|lines| lines.join("\n"))
}

/// Byte-level edits of a file: replace, delete or duplicate a span.
fn byte_edits() -> impl Strategy<Value = Vec<(u8, usize, usize, Vec<u8>)>> {
    prop::collection::vec(
        (
            0..3u8,
            any::<usize>(),
            0..64usize,
            prop::collection::vec(any::<u8>(), 0..8),
        ),
        1..5,
    )
}

fn edit_bytes(mut bytes: Vec<u8>, edits: &[(u8, usize, usize, Vec<u8>)]) -> Vec<u8> {
    for (kind, at, len, piece) in edits {
        let at = at % (bytes.len() + 1);
        let end = (at + len).min(bytes.len());
        match kind {
            0 => {
                bytes.splice(at..end, piece.iter().copied());
            }
            1 => {
                bytes.drain(at..end);
            }
            _ => {
                let copy = bytes[at..end].to_vec();
                let to = (at * 7 + len) % (bytes.len() + 1);
                bytes.splice(to..to, copy);
            }
        }
    }
    bytes
}

proptest! {
    #![proptest_config(common::proptest_config(256))]

    #[test]
    fn random_bytes_as_any_of_the_three_files_never_panic(which in 0..3usize, junk in bytes()) {
        let f = fixture();
        let mut files = [f.model.into_bytes(), f.key_states.into_bytes(), f.spaces.into_bytes()];
        files[which] = junk;
        let _ = load_bytes(&files[0], &files[1], &files[2]);
    }

    #[test]
    fn structured_mutations_of_the_tidy1_model_never_panic(
        mutations in prop::collection::vec(mutation(), 1..5)
    ) {
        let f = fixture();
        let mut doc: Value = serde_json::from_str(&f.model).expect("the fixture is JSON");
        for m in &mutations {
            apply(&mut doc, m);
        }
        let model = serde_json::to_vec(&doc).expect("serialisable");
        let _ = load_bytes(&model, f.key_states.as_bytes(), f.spaces.as_bytes());
    }

    #[test]
    fn generated_key_states_and_spaces_files_never_panic(
        key_states in text_file(),
        spaces in text_file(),
        keep_spaces in any::<bool>(),
    ) {
        let f = fixture();
        let spaces = if keep_spaces { f.spaces.clone() } else { spaces };
        let _ = load_bytes(f.model.as_bytes(), key_states.as_bytes(), spaces.as_bytes());
    }

    #[test]
    fn byte_edits_of_the_tidy1_files_never_panic(which in 0..3usize, edits in byte_edits()) {
        let f = fixture();
        let mut files = [f.model.into_bytes(), f.key_states.into_bytes(), f.spaces.into_bytes()];
        files[which] = edit_bytes(std::mem::take(&mut files[which]), &edits);
        let _ = load_bytes(&files[0], &files[1], &files[2]);
    }

    #[test]
    fn a_mutation_that_keeps_the_model_valid_loads_the_same_112_states(
        i in 0..112usize,
        j in 0..7usize,
        count in 1u32..1000,
    ) {
        // Changing a count of a deterministic world changes no probability.
        let f = fixture();
        let mut doc: Value = serde_json::from_str(&f.model).expect("the fixture is JSON");
        apply(&mut doc, &Mutation::SetTransitionField(i, j, "prob", json!(count)));
        let model = serde_json::to_vec(&doc).expect("serialisable");
        let spec = load_bytes(&model, f.key_states.as_bytes(), f.spaces.as_bytes())
            .expect("still a valid world");
        prop_assert_eq!(spec.n_states, 112);
        prop_assert_eq!(spec.max_branching(), 1);
    }
}

/// The corpus folder.
fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_corpus/env")
}

#[test]
fn every_corpus_case_loads_or_fails_as_its_expect_file_says() {
    let mut cases: Vec<PathBuf> = std::fs::read_dir(corpus())
        .expect("the corpus folder")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.is_dir())
        .collect();
    cases.sort();
    assert!(cases.len() >= 10, "the corpus has {} cases", cases.len());
    let f = fixture();
    for case in cases {
        let read = |name: &str, default: &str| {
            std::fs::read(case.join(name)).unwrap_or_else(|_| default.as_bytes().to_vec())
        };
        let expect = String::from_utf8(read("expect", "")).expect("a UTF-8 expect file");
        let expect = expect.trim();
        assert!(!expect.is_empty(), "{}: no expect file", case.display());
        let result = load_bytes(
            &read("world.json", &f.model),
            &read("keyStates.txt", &f.key_states),
            &read("spaces.txt", &f.spaces),
        );
        match (expect, result) {
            ("ok", Ok(_)) => {}
            ("ok", Err(message)) => panic!("{}: rejected: {message}", case.display()),
            (part, Err(message)) => assert!(
                message.contains(part),
                "{}: message {message:?} lacks {part:?}",
                case.display()
            ),
            (part, Ok(_)) => panic!(
                "{}: loaded, expected an error with {part:?}",
                case.display()
            ),
        }
    }
}
