//! Fuzzing the sweep file parser: random bytes, files generated from the
//! format's own vocabulary, and edits of the repository's `sweeps/*.toml`. Whatever the text,
//! `Sweep::parse` returns a sweep whose every configuration resolves to valid parameters, or an
//! error with a `file:line` message; it never panics, and sizes are bounded so it never hangs.
//!
//! The normal test run tries 256 cases per property. A longer session:
//! `PROPTEST_CASES=100000 cargo test --release --test fuzz_sweep`.

mod common;

use std::path::Path;

use mbmf::sweep::file::{Sweep, SweepError};
use proptest::prelude::*;

/// The repository's sweep files, read once per case (they are small).
fn examples() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .expect("the sweeps folder")
        .map(|e| e.expect("an entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .iter()
        .map(|p| std::fs::read_to_string(p).expect("a sweep file"))
        .collect()
}

/// Parses `text`; a sweep must resolve every configuration it has (the first, the last and a
/// few between) to parameters that pass validation; an error must name the file and line.
fn check(text: &str) {
    let dir = tempfile::TempDir::new().expect("a temporary folder");
    match Sweep::parse("fuzz.toml", dir.path(), text) {
        Ok(sweep) => {
            let n = sweep.configurations();
            assert!(n >= 1, "a sweep with no configuration");
            assert!(sweep.runs() >= n);
            for config in [0, n / 3, n / 2, n - 1] {
                let resolved = sweep.resolve(config);
                if let Err(e) = resolved.params.validate() {
                    panic!(
                        "configuration {config} of\n{text}\nresolves to invalid parameters: {e}"
                    );
                }
                let _ = sweep.describe(config);
            }
            let (config, seed) = sweep.split_run(sweep.runs() - 1);
            assert_eq!(config, n - 1);
            assert!(seed < u32::MAX);
        }
        Err(SweepError::Invalid {
            file,
            line,
            message,
            ..
        }) => {
            assert_eq!(file, "fuzz.toml");
            let lines = text.lines().count().max(1);
            assert!(
                line >= 1 && line <= lines + 1,
                "line {line} of {lines}: {message}"
            );
            assert!(!message.is_empty());
        }
        Err(other) => panic!("parsing text gave a read error: {other}"),
    }
}

/// A value from the format's vocabulary: numbers, names, lists and range tables.
fn value() -> impl Strategy<Value = String> {
    let scalar = prop::sample::select(vec![
        "0",
        "1",
        "-1",
        "2",
        "0.5",
        "1.5",
        "1e300",
        "-1e-320",
        "nan",
        "inf",
        "-inf",
        "1e6",
        "4294967296",
        "18446744073709551616",
        "true",
        "false",
        "\"tidy1\"",
        "\"tidy2\"",
        "\"tidy3\"",
        "\"json:nope.json\"",
        "\"grid:9\"",
        "\"ec\"",
        "\"mf\"",
        "\"rnd\"",
        "\"entropy\"",
        "\"softmax\"",
        "\"argmax\"",
        "\"ops\"",
        "\"congratulation\"",
        "\"takeover\"",
        "\"none\"",
        "\"generous\"",
        "\"patient\"",
        "\"\"",
        "'x'",
        "1979-05-27",
        "{}",
        "[]",
    ])
    .prop_map(str::to_string);
    let range_key = prop::sample::select(vec!["from", "to", "steps", "by", "log", "form"]);
    let range = prop::collection::vec((range_key, scalar.clone()), 0..4).prop_map(|kv| {
        let parts: Vec<String> = kv.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        format!("{{ {} }}", parts.join(", "))
    });
    let list = prop::collection::vec(scalar.clone(), 0..5)
        .prop_map(|items| format!("[{}]", items.join(", ")));
    prop_oneof![4 => scalar, 2 => list, 2 => range]
}

/// A line: a section header, a `key = value`, a comment or junk.
fn line() -> impl Strategy<Value = String> {
    let key = prop::sample::select(vec![
        "task",
        "controller",
        "selection",
        "cost_model",
        "alpha_mf",
        "gamma_mf",
        "gamma_mb",
        "tau",
        "q_init",
        "window_n",
        "vi_epsilon",
        "vi_max_sweeps",
        "filter_alpha",
        "kappa_coeff",
        "normalise_entropy",
        "profile",
        "interaction",
        "budget",
        "zeta",
        "forget",
        "steps",
        "babbling",
        "checkpoint",
        "seeds",
        "master_seed",
        "kappa-coeff",
        "kapa_coeff",
        "Tau",
        "forget_prob",
    ]);
    let section = prop::sample::select(vec![
        "[fixed]",
        "[grid]",
        "[[zip]]",
        "[profiles.patient]",
        "[profiles.none]",
        "[profiles]",
        "[[grid]]",
        "[zip]",
        "[fixd]",
        "[profiles.a.b]",
    ]);
    prop_oneof![
        6 => (key, value()).prop_map(|(k, v)| format!("{k} = {v}")),
        2 => section.prop_map(str::to_string),
        1 => Just("# comment".to_string()),
        1 => "[ -~]{0,12}".prop_map(|s| s),
    ]
}

fn sweep_text() -> impl Strategy<Value = String> {
    prop::collection::vec(line(), 0..14).prop_map(|lines| lines.join("\n"))
}

/// Random bytes, biased towards TOML's punctuation, read as (lossy) UTF-8.
fn junk() -> impl Strategy<Value = String> {
    let byte = prop_oneof![
        2 => any::<u8>(),
        5 => prop::sample::select(b"[]{}=\",.#'\n 0123456789abcdefgkorstz_-".to_vec()),
    ];
    prop::collection::vec(byte, 0..1024).prop_map(|b| String::from_utf8_lossy(&b).into_owned())
}

proptest! {
    #![proptest_config(common::proptest_config(256))]

    #[test]
    fn random_text_never_makes_the_sweep_parser_panic(text in junk()) {
        check(&text);
    }

    #[test]
    fn generated_sweep_files_parse_or_fail_with_a_line(text in sweep_text()) {
        check(&text);
    }

    #[test]
    fn line_edits_of_the_repository_sweeps_never_panic(
        which in any::<prop::sample::Index>(),
        edits in prop::collection::vec(
            (0..4u8, any::<prop::sample::Index>(), line()), 1..4
        ),
    ) {
        let files = examples();
        let text = which.get(&files);
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        for (kind, at, new) in &edits {
            let at = if lines.is_empty() { 0 } else { at.index(lines.len()) };
            match kind {
                0 if !lines.is_empty() => lines[at] = new.clone(),
                1 if !lines.is_empty() => {
                    lines.remove(at);
                }
                2 if !lines.is_empty() => {
                    let copy = lines[at].clone();
                    lines.insert(at, copy);
                }
                _ => lines.insert(at, new.clone()),
            }
        }
        check(&lines.join("\n"));
    }
}

#[test]
fn every_repository_sweep_parses_and_resolves() {
    for text in examples() {
        check(&text);
        let dir = tempfile::TempDir::new().expect("a temporary folder");
        assert!(Sweep::parse("fuzz.toml", dir.path(), &text).is_ok());
    }
}

#[test]
fn axes_whose_product_overflows_are_refused_not_wrapped() {
    let text = "seeds = 4294967295\n[grid]\n\
                kappa_coeff = { from = 0, to = 1, steps = 1000000 }\n\
                tau = { from = 0.01, to = 1, steps = 1000000 }\n\
                zeta = { from = 0, to = 1, steps = 1000000 }\n\
                q_init = { from = 0, to = 1, steps = 1000000 }\n";
    check(text);
    let dir = tempfile::TempDir::new().expect("a temporary folder");
    assert!(Sweep::parse("fuzz.toml", dir.path(), text).is_err());
}
