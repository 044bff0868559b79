//! `mbmf sweep`: expansion of sweep files, validation messages, dry run, the Parquet dataset
//! (equal to `mbmf run` for the same runs, to a resumed run, and to the union of shards), the
//! lock, and failures of the output folder (unwritable, full disk).

mod common;

use std::path::Path;

use common::*;
use mbmf::params::{Controller, Interaction, Profile};
use mbmf::sweep::keys::Value;
use mbmf::sweep::{Shard, Sweep};

fn parse(text: &str) -> Sweep {
    Sweep::parse("test.toml", Path::new("."), text).unwrap_or_else(|e| panic!("{e}"))
}

fn parse_err(text: &str) -> String {
    match Sweep::parse("bad.toml", Path::new("."), text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn reals(sweep: &Sweep, axis: usize) -> Vec<f64> {
    sweep.axes[axis]
        .values
        .iter()
        .map(|row| row[0].as_f64().unwrap())
        .collect()
}

#[test]
fn a_linear_range_gives_steps_values_with_exact_ends() {
    let s = parse("[grid]\nkappa_coeff = { from = 0, to = 20, steps = 41 }\n");
    let v = reals(&s, 0);
    assert_eq!(v.len(), 41);
    assert_eq!((v[0], v[1], v[40]), (0.0, 0.5, 20.0));
    assert_eq!(s.configurations(), 41);
    assert_eq!(s.runs(), 41);
    let tenths = parse("[grid]\nzeta = { from = 0, to = 1, steps = 11 }\n");
    assert_eq!(
        reals(&tenths, 0)[3],
        0.3,
        "i / (n - 1) scaling, not repeated addition"
    );
}

#[test]
fn a_log_range_is_geometric_and_rounds_for_whole_number_keys() {
    let s = parse("[grid]\nzeta = { from = 0.01, to = 100, steps = 5, log = true }\n");
    let v = reals(&s, 0);
    let expected = [0.01, 0.1, 1.0, 10.0, 100.0];
    for (a, b) in v.iter().zip(expected) {
        assert!((a - b).abs() < 1e-12 * b, "{v:?}");
    }
    let budgets = parse("[grid]\nbudget = { from = 10, to = 1000, steps = 5, log = true }\n");
    let b: Vec<Value> = budgets.axes[0]
        .values
        .iter()
        .map(|r| r[0].clone())
        .collect();
    assert_eq!(
        b,
        [10, 32, 100, 316, 1000].map(Value::Count).to_vec(),
        "10^(1 + k/2) rounded"
    );
}

#[test]
fn a_range_by_increment_includes_its_end() {
    let s = parse("[grid]\nbudget = { from = 0, to = 500, by = 50 }\n");
    assert_eq!(s.configurations(), 11);
    assert_eq!(s.axes[0].values[10][0], Value::Count(500));
}

#[test]
fn grid_axes_multiply_zip_groups_vary_together_and_seeds_multiply_runs() {
    let s = parse(
        r#"
seeds = 4
[grid]
controller = ["mf", "mb", "ec"]
kappa_coeff = [1, 9]
[[zip]]
interaction = ["none", "congratulation", "takeover"]
budget = [0, 30, 50]
"#,
    );
    assert_eq!(s.configurations(), 3 * 2 * 3);
    assert_eq!(s.runs(), 3 * 2 * 3 * 4);
    // The first axis in the file varies slowest, the last fastest.
    let r = s.resolve(0);
    assert_eq!(r.params.controller, Controller::Mf);
    assert_eq!(r.params.human.interaction, Interaction::None);
    let r = s.resolve(5);
    assert_eq!(r.params.controller, Controller::Mf);
    assert_eq!(r.params.kappa_coeff, 9.0);
    assert_eq!(
        (r.params.human.interaction, r.params.human.budget),
        (Interaction::Takeover, 50)
    );
    let r = s.resolve(6);
    assert_eq!(r.params.controller, Controller::Mb);
    assert_eq!(s.split_run(6 * 4 + 3), (6, 3));
}

#[test]
fn profiles_resolve_per_controller_and_explicit_keys_override_them() {
    let s = parse(
        r#"
[grid]
controller = ["mf", "ec"]
profile = ["paper-takeover", "teacher"]
[fixed]
zeta = 0.5
[profiles.teacher]
interaction = "congratulation"
budget = 100
zeta = 0.3
forget = 0
"#,
    );
    let names = |c: u64| s.profile_names[s.resolve(c).profile].clone();
    let mf_paper = s.resolve(0).params;
    assert_eq!(mf_paper.profile, Profile::PaperTakeover);
    assert_eq!(
        (mf_paper.human.interaction, mf_paper.human.budget),
        (Interaction::Takeover, 200),
        "paper-takeover gives MF 200 interactions"
    );
    assert_eq!(s.resolve(2).params.human.budget, 50, "and EC 50");
    let teacher = s.resolve(1).params;
    assert_eq!(teacher.human.budget, 100);
    assert_eq!(teacher.human.forget_prob, 0.0);
    assert_eq!(
        teacher.human.zeta, 0.5,
        "[fixed] zeta overrides the profile's"
    );
    assert_eq!(names(0), "paper-takeover");
    assert_eq!(names(1), "teacher");
}

#[test]
fn steps_default_to_the_task_length_and_kebab_case_keys_are_accepted() {
    let s = parse("[grid]\ntask = [\"tidy1\", \"tidy2\"]\n[fixed]\nkappa-coeff = 3\n");
    assert_eq!(s.resolve(0).params.steps, 10_000);
    assert_eq!(s.resolve(1).params.steps, 20_000);
    assert_eq!(s.resolve(1).params.kappa_coeff, 3.0);
    assert_eq!(s.tasks, vec!["tidy1", "tidy2"]);
}

#[test]
fn a_misspelt_key_names_file_line_and_the_closest_key() {
    let err = parse_err("seeds = 2\n\n[grid]\nkapa_coeff = [1, 2]\n");
    assert!(err.starts_with("bad.toml:4: "), "{err}");
    assert!(err.contains("unknown key 'kapa_coeff' in [grid]"), "{err}");
    assert!(err.contains("did you mean 'kappa_coeff'?"), "{err}");
    assert!(err.contains("known keys: task, controller"), "{err}");
}

/// Settings a configuration's controller ignores are warned about with the file's line when
/// they make configurations repeat one another, or label select runs as mixed; a [[zip]] that
/// gives each rule its own values, and the shipped sweeps, warn of nothing.
#[test]
fn settings_the_controllers_ignore_are_warned_about_with_their_line() {
    let w = |text: &str| parse(text).warnings;
    // w_mb crossed with ec: ec's three configurations are one, run three times.
    let warnings = w("[grid]\ncontroller = [\"ec\", \"fixed\"]\nw_mb = [0.2, 0.4, 0.6]\n");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0]
            .starts_with("test.toml:3: key 'w_mb' in [grid]: 2 configurations of ec repeat others"),
        "{warnings:?}"
    );
    assert!(
        warnings[0].contains("(only fixed reads w_mb)"),
        "{warnings:?}"
    );
    // The same values paired by a zip: no repeat.
    assert!(
        w("[[zip]]\ncontroller = [\"ec\", \"fixed\", \"fixed\"]\nw_mb = [0.5, 0.4, 0.6]\n")
            .is_empty()
    );
    // A mix given to vpi: mislabelled, and a repeat of its select configuration.
    let warnings =
        w("[grid]\ncontroller = [\"vpi\", \"fixed\"]\ncombine = [\"select\", \"mix\"]\n");
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(
        warnings[0].contains("combine = mix does not apply to vpi (1 configuration)"),
        "{warnings:?}"
    );
    assert!(
        warnings[1].contains("1 configuration of vpi repeats others"),
        "{warnings:?}"
    );
    // Budgets without an interaction, and with one.
    let warnings = w("[grid]\nbudget = [0, 10, 20]\n");
    assert!(
        warnings[0].contains("2 configurations of ec repeat"),
        "{warnings:?}"
    );
    assert!(
        warnings[0].contains("no interaction spends a budget"),
        "{warnings:?}"
    );
    assert!(w("[fixed]\ninteraction = \"takeover\"\n[grid]\nbudget = [0, 10, 20]\n").is_empty());
    // Configurations equal in every value are the repeated-value warning's, not this one's.
    let warnings = w("[grid]\nbudget = [5, 5]\n");
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].contains("lists 5 twice"), "{warnings:?}");
    for entry in std::fs::read_dir(common::repo().join("sweeps")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let sweep = Sweep::load(&path).unwrap();
            assert!(
                sweep.warnings.is_empty(),
                "{}: {:?}",
                path.display(),
                sweep.warnings
            );
        }
    }
}

#[test]
fn a_top_level_key_in_a_section_is_said_to_be_one() {
    for (text, key, section) in [
        ("[fixed]\nsteps = 10\ntrace = true\n", "trace", "[fixed]"),
        ("[grid]\nmaster-seed = [1, 2]\n", "master_seed", "[grid]"),
        ("[[zip]]\nseeds = [1, 2]\n", "seeds", "[[zip]]"),
    ] {
        let err = parse_err(text);
        assert!(
            err.contains(&format!("'{key}' is a top-level key, not a parameter")),
            "{err}"
        );
        assert!(err.contains(&format!("above {section}")), "{err}");
    }
}

#[test]
fn an_unknown_value_lists_the_accepted_values() {
    let err = parse_err("[grid]\ncontroller = [\"mf\",\n  \"eec\"]\n");
    assert!(err.starts_with("bad.toml:3: "), "{err}");
    assert!(err.contains("key 'controller'"), "{err}");
    assert!(err.contains("did you mean 'ec'?"), "{err}");
    assert!(
        err.contains("accepted values: mf, mb, rnd, ec, entropy"),
        "{err}"
    );
}

#[test]
fn an_out_of_range_value_names_its_line_key_and_accepted_range() {
    let err = parse_err("[fixed]\ntask = \"tidy1\"\ntau = -1\n");
    assert!(err.starts_with("bad.toml:3: key 'tau' in [fixed]"), "{err}");
    assert!(err.contains("temperature"), "{err}");
    let err = parse_err("[grid]\nforget = { from = 0, to = 2, steps = 3 }\n");
    assert!(err.contains("the range reaches 2"), "{err}");
    assert!(err.contains("probability in [0, 1]"), "{err}");
}

#[test]
fn structural_mistakes_are_explained() {
    let cases = [
        (
            "[[zip]]\ncontroller = [\"mf\", \"mb\"]\nbudget = [1, 2, 3]\n",
            "must have the same length: controller has 2, budget has 3",
        ),
        ("task = \"tidy1\"\n", "must be inside [fixed]"),
        ("seed = 3\n", "did you mean 'seeds'?"),
        (
            "[grid]\nbudget = []\n",
            "an empty list gives no configuration",
        ),
        (
            "[grid]\nbudget = { from = 0, to = 10, steps = 4 }\n",
            "takes whole numbers",
        ),
        (
            "[grid]\nzeta = { from = 0, to = 1, stepz = 3 }\n",
            "unknown range field 'stepz'; did you mean 'steps'?",
        ),
        (
            "[grid]\ncontroller = { from = 0, to = 1, steps = 2 }\n",
            "ranges are for numeric keys",
        ),
        (
            "[fixed]\nbudget = 5\n[grid]\nbudget = [1, 2]\n",
            "already set in [fixed] (line 2)",
        ),
        (
            "[fixed]\nbudget = [1, 2]\n",
            "put lists and ranges in [grid]",
        ),
        (
            "[grid]\nprofile = [\"generus\"]\n",
            "unknown profile 'generus'; did you mean 'generous'?",
        ),
        ("[grid]\ntask = [\"tidy3\"]\n", "did you mean 'tidy1'?"),
        ("[grid\n", "not valid TOML"),
    ];
    for (text, expected) in cases {
        let err = parse_err(text);
        assert!(err.contains(expected), "for\n{text}\ngot: {err}");
        assert!(err.starts_with("bad.toml:"), "{err}");
    }
}

#[test]
fn interactions_on_a_json_task_are_refused_naming_the_combination() {
    let dir = tempfile::tempdir().unwrap();
    let data = repo().join("tests/data/tidy1/tidy1.json");
    let text = format!(
        "[grid]\ntask = [\"tidy1\", \"json:{}\"]\n\n[[zip]]\ninteraction = [\"none\", \"takeover\"]\nbudget = [0, 10]\n",
        data.display()
    );
    let file = write_sweep(dir.path(), "json.toml", &text);
    let out = run(&["sweep", &file, "--dry-run"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("json.toml:5: key 'interaction'"), "{err}");
    assert!(err.contains("configuration 3 ("), "{err}");
    assert!(err.contains("interaction = takeover"), "{err}");
    assert!(err.contains("is not defined for task"), "{err}");
}

#[test]
fn dry_run_prints_configurations_runs_and_an_estimate_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let out_dir = dir.path().join("out");
    let out = run_ok(&[
        "sweep",
        &file,
        "--dry-run",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("4 configurations x 3 seeds = 12 runs (master seed 11)"),
        "{text}"
    );
    assert!(
        text.contains("[grid] controller: 2 values: mf, ec"),
        "{text}"
    );
    assert!(
        text.contains("[[zip]] #1 interaction, budget: 2 values: (none, 0), (takeover, 15)"),
        "{text}"
    );
    assert!(text.contains("agent-steps: 6000"), "{text}");
    assert!(text.contains("estimated time: "), "{text}");
    assert!(!out_dir.exists());
}

/// The disk check refuses a sweep on its estimate, so the estimate must count what is written:
/// every part file carries a footer of tens of KiB (most of a small sweep's bytes).
#[test]
fn the_dry_run_counts_the_parts_and_estimates_the_bytes_the_sweep_writes() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let out_dir = dir.path().join("out");
    // 4 configurations of 3 runs, batches of 5: a configuration is not split across parts, and
    // each batch holds one controller and interaction, so each configuration is a part.
    let out = run_ok(&["sweep", &file, "--dry-run", "--json", "--batch-size", "5"]);
    let plan: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(plan["parts"], 4, "{plan}");
    let estimate = plan["estimated_output_bytes"].as_f64().unwrap();
    let text = run_ok(&["sweep", &file, "--dry-run", "--batch-size", "5"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains("; 4 part(s) per table of at most 5 runs)"),
        "{text}"
    );
    run_ok(&[
        "sweep",
        &file,
        "--out",
        out_dir.to_str().unwrap(),
        "--quiet",
        "--batch-size",
        "5",
    ]);
    assert_eq!(parts(&out_dir, "runs").len(), 4);
    // A dry run of the resume counts what is there.
    let o = out_dir.to_str().unwrap();
    let again = run_ok(&[
        "sweep",
        &file,
        "--out",
        o,
        "--resume",
        "--dry-run",
        "--json",
    ]);
    let again: serde_json::Value = serde_json::from_slice(&again.stdout).unwrap();
    assert_eq!(
        (&again["already_written"], &again["runs"]),
        (&12.into(), &12.into())
    );
    // Another sweep's folder is refused, as the resume itself refuses it.
    let other = write_sweep(
        dir.path(),
        "other.toml",
        &SMALL.replace("seeds = 3", "seeds = 2"),
    );
    let refused = run(&["sweep", &other, "--out", o, "--resume", "--dry-run"]);
    assert_eq!(refused.status.code(), Some(2));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("holds a different sweep"), "{err}");
    let written: u64 = ["runs", "series"]
        .iter()
        .flat_map(|t| std::fs::read_dir(out_dir.join(t)).unwrap())
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    let ratio = estimate / written as f64;
    assert!(
        (0.8..1.5).contains(&ratio),
        "estimated {estimate} B, wrote {written} B"
    );
}

#[test]
fn the_dataset_equals_mbmf_run_for_the_same_runs() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = "seeds = 4\nmaster_seed = 5\n[fixed]\nsteps = 600\nbabbling = 200\ncheckpoint = 150\n[grid]\ncontroller = [\"mf\", \"rnd\", \"ec\"]\n";
    let file = write_sweep(dir.path(), "s.toml", sweep);
    let sweep_out = dir.path().join("sweep");
    let run_out = dir.path().join("run");
    run_ok(&[
        "sweep",
        &file,
        "--out",
        sweep_out.to_str().unwrap(),
        "--quiet",
        "--batch-size",
        "5",
    ]);
    run_ok(&[
        "run",
        "--controller",
        "mf,rnd,ec",
        "--runs",
        "4",
        "--seed",
        "5",
        "--steps",
        "600",
        "--babbling",
        "200",
        "--checkpoint",
        "150",
        "--quiet",
        "--out",
        run_out.to_str().unwrap(),
    ]);
    let (sweep_runs, sweep_series) = dataset(&sweep_out);
    let run_runs = file_rows(&run_out.join("runs.parquet"), NONDETERMINISTIC);
    let run_series = file_rows(&run_out.join("series.parquet"), NONDETERMINISTIC);
    assert_eq!(sweep_runs.len(), 12);
    let columns: Vec<String> = run_runs[0].keys().cloned().collect();
    assert!(columns.contains(&"total_reward".to_string()));
    let mut expected = run_runs.clone();
    sort_rows(&mut expected);
    assert_same_rows("runs", &project(&sweep_runs, &columns), &expected);
    let columns: Vec<String> = run_series[0].keys().cloned().collect();
    let mut expected = run_series.clone();
    sort_rows(&mut expected);
    assert_same_rows("series", &project(&sweep_series, &columns), &expected);
    // The sweep adds its own identity columns.
    assert_eq!(sweep_runs[7]["config_index"], "1");
    assert_eq!(sweep_runs[7]["seed_index"], "3");
    assert_eq!(sweep_runs[7]["master_seed"], "5");
}

#[test]
fn parts_carry_the_sweep_text_version_and_master_seed() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    run_ok(&["sweep", &file, "--out", out.to_str().unwrap(), "--quiet"]);
    let part = out.join("runs").join(&parts(&out, "runs")[0]);
    let reader =
        parquet::file::reader::SerializedFileReader::new(std::fs::File::open(&part).unwrap())
            .unwrap();
    use parquet::file::reader::FileReader;
    let kv = reader
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .unwrap()
        .clone();
    let get = |k: &str| {
        kv.iter()
            .find(|e| e.key == k)
            .and_then(|e| e.value.clone())
            .unwrap_or_else(|| panic!("no {k} in metadata"))
    };
    assert_eq!(get("mbmf_sweep"), SMALL);
    assert_eq!(get("master_seed"), "11");
    assert_eq!(get("mbmf_version"), env!("CARGO_PKG_VERSION"));
    assert_eq!(
        std::fs::read_to_string(out.join("sweep.toml")).unwrap(),
        SMALL
    );
}

#[test]
fn resuming_after_deleting_parts_equals_a_full_run_and_batch_size_does_not_matter() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let full = dir.path().join("full");
    let partial = dir.path().join("partial");
    run_ok(&["sweep", &file, "--out", full.to_str().unwrap(), "--quiet"]);
    run_ok(&[
        "sweep",
        &file,
        "--out",
        partial.to_str().unwrap(),
        "--quiet",
        "--batch-size",
        "2",
    ]);
    let names = parts(&partial, "runs");
    // Each configuration's 3 seeds in a part of 2 and a part of 1: parts hold one controller.
    assert_eq!(
        names.len(),
        8,
        "12 runs of 4 configurations in parts of at most 2"
    );
    assert_eq!(names[0], "part-000000-000001.parquet");
    // A part lost entirely, and a part whose runs file was never renamed into place.
    for sub in ["runs", "series"] {
        std::fs::remove_file(partial.join(sub).join(&names[0])).unwrap();
    }
    std::fs::remove_file(partial.join("runs").join(&names[2])).unwrap();
    let out = run_ok(&[
        "sweep",
        &file,
        "--out",
        partial.to_str().unwrap(),
        "--resume",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("8 of 12 runs already done, 4 to run"),
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("4 runs in"), "{stdout}");
    assert!(stdout.contains("dataset complete: 12 runs"), "{stdout}");
    assert_same_dataset("resumed vs full", &partial, &full);
    assert!(temporaries(&partial).is_empty());
    // Nothing left to do: a second resume writes nothing.
    let again = run_ok(&[
        "sweep",
        &file,
        "--out",
        partial.to_str().unwrap(),
        "--resume",
    ]);
    assert!(String::from_utf8_lossy(&again.stdout).contains("0 runs in"));
}

#[test]
fn the_union_of_shards_equals_the_single_process_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let single = dir.path().join("single");
    let sharded = dir.path().join("sharded");
    run_ok(&["sweep", &file, "--out", single.to_str().unwrap(), "--quiet"]);
    for i in 0..3 {
        let out = run_ok(&[
            "sweep",
            &file,
            "--out",
            sharded.to_str().unwrap(),
            "--shard",
            &format!("{i}/3"),
            "--batch-size",
            "4",
        ]);
        let line = String::from_utf8_lossy(&out.stdout);
        assert!(line.contains(&format!("(shard {i}/3)")), "{line}");
    }
    assert_same_dataset("3 shards vs 1 process", &sharded, &single);
    // Shard 0 of 3 owns configurations 0 and 3: runs 0-2 and 9-11.
    let shard0 = tempfile::tempdir().unwrap();
    run_ok(&[
        "sweep",
        &file,
        "--out",
        shard0.path().to_str().unwrap(),
        "--shard",
        "0/3",
        "--quiet",
    ]);
    let (runs, _) = dataset(shard0.path());
    let ids: Vec<&str> = runs.iter().map(|r| r["run_index"].as_str()).collect();
    assert_eq!(ids, ["0", "1", "2", "9", "10", "11"]);
}

#[test]
fn shards_from_the_environment_are_checked_against_their_count() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let out_dir = dir.path().join("out");
    let out = mbmf()
        .args(["sweep", &file, "--shard-from-env", "--out"])
        .arg(&out_dir)
        .env("SLURM_ARRAY_TASK_ID", "3")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .env_remove("SLURM_ARRAY_TASK_MIN")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("shard index 3 is not below the shard count 3"),
        "{err}"
    );
    let out = mbmf()
        .args(["sweep", &file, "--shard-from-env", "--quiet", "--out"])
        .arg(&out_dir)
        .env("SLURM_ARRAY_TASK_ID", "3")
        .env("SLURM_ARRAY_TASK_COUNT", "3")
        .env("SLURM_ARRAY_TASK_MIN", "1")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (runs, _) = dataset(&out_dir);
    let ids: Vec<&str> = runs.iter().map(|r| r["run_index"].as_str()).collect();
    assert_eq!(ids, ["6", "7", "8"], "--array=1-3, task 3: shard 2/3");
    assert_eq!(
        "5/4".parse::<Shard>().unwrap_err().to_string(),
        "shard index 5 is not below the shard count 4: shards are numbered from 0, so --shard I/N needs I < N"
    );
}

#[test]
fn a_folder_being_written_is_refused_and_a_stale_lock_is_taken_over() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let lock_path = out.join(".lock-0-of-1");
    // This test process plays the other writer: it holds the lock, as a running sweep does.
    let holder = std::fs::File::create(&lock_path).unwrap();
    holder.try_lock().unwrap();
    std::fs::write(&lock_path, "pid=4242 host=elsewhere shard=0/1\n").unwrap();
    let refused = run(&["sweep", &file, "--out", out.to_str().unwrap()]);
    assert_eq!(refused.status.code(), Some(1));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("is being written by pid 4242 on host elsewhere"),
        "{err}"
    );
    assert!(parts(&out, "runs").is_empty());
    // A sharded process with a different split is refused too.
    let other = run(&[
        "sweep",
        &file,
        "--out",
        out.to_str().unwrap(),
        "--shard",
        "0/2",
    ]);
    assert_eq!(other.status.code(), Some(1));
    let err = String::from_utf8_lossy(&other.stderr);
    assert!(err.contains("different split"), "{err}");
    // The holder dies: its lock file stays, but the kernel released the lock.
    common::release_lock(holder, &lock_path);
    let ok = run_ok(&["sweep", &file, "--out", out.to_str().unwrap(), "--quiet"]);
    let err = String::from_utf8_lossy(&ok.stderr);
    assert!(
        err.contains("warning: taking over the stale lock") && err.contains("pid 4242"),
        "{err}"
    );
    assert!(!lock_path.exists(), "the lock file is removed at the end");
    assert_eq!(dataset(&out).0.len(), 12);
}

#[test]
fn existing_results_need_resume_and_a_different_sweep_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let other = write_sweep(
        dir.path(),
        "other.toml",
        &SMALL.replace("seeds = 3", "seeds = 2"),
    );
    let out = dir.path().join("out");
    let out_s = out.to_str().unwrap();
    run_ok(&["sweep", &file, "--out", out_s, "--quiet"]);
    let again = run(&["sweep", &file, "--out", out_s]);
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("pass --resume"));
    let different = run(&["sweep", &other, "--out", out_s, "--resume"]);
    assert_eq!(different.status.code(), Some(2));
    let err = String::from_utf8_lossy(&different.stderr);
    assert!(err.contains("holds a different sweep"), "{err}");
    assert!(err.contains("first difference at line 2"), "{err}");
    let foreign = dir.path().join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), "mine").unwrap();
    let refused = run(&["sweep", &file, "--out", foreign.to_str().unwrap()]);
    assert_eq!(refused.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&refused.stderr).contains("not a sweep dataset"));
}

/// A mounted tmpfs, unmounted on drop.
struct Mount(std::path::PathBuf);

impl Mount {
    /// Mounts a tmpfs with `options` on a new folder, or says why it cannot.
    fn tmpfs(options: &str) -> Result<Mount, String> {
        let dir = tempfile::tempdir().unwrap().keep();
        let out = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(&dir)
            .output()
            .map_err(|e| e.to_string())?;
        if out.status.success() {
            Ok(Mount(dir))
        } else {
            Err(String::from_utf8_lossy(&out.stderr).trim().to_string())
        }
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount").arg(&self.0).status();
        let _ = std::fs::remove_dir(&self.0);
    }
}

fn is_root() -> bool {
    std::process::Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

#[test]
fn an_unwritable_output_folder_fails_before_simulating() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    // Root ignores permission bits, so root gets a read-only file system instead.
    let (_mount, readonly) = if is_root() {
        match Mount::tmpfs("ro,size=64k") {
            Ok(m) => {
                let p = m.0.clone();
                (Some(m), p)
            }
            Err(e) => {
                eprintln!(
                    "SKIP an_unwritable_output_folder_fails_before_simulating: cannot mount a read-only tmpfs as root ({e})"
                );
                return;
            }
        }
    } else {
        use std::os::unix::fs::PermissionsExt;
        let p = dir.path().join("readonly");
        std::fs::create_dir(&p).unwrap();
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o555)).unwrap();
        (None, p)
    };
    let out = readonly.join("dataset");
    let result = run(&["sweep", &file, "--out", out.to_str().unwrap()]);
    // An output folder that cannot be written is a usage error, found before the sweep starts.
    assert_eq!(result.status.code(), Some(2));
    let err = String::from_utf8_lossy(&result.stderr);
    assert!(
        err.contains(&format!("--out {}: cannot write into", out.display())),
        "{err}"
    );
    assert!(
        err.contains("Read-only file system") || err.contains("Permission denied"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_full_disk_fails_with_a_clear_error_and_leaves_no_partial_file() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(
        dir.path(),
        "big.toml",
        &SMALL.replace("seeds = 3", "seeds = 40"),
    );
    let mount = match Mount::tmpfs("size=64k") {
        Ok(m) => m,
        Err(e) => {
            eprintln!(
                "SKIP a_full_disk_fails_with_a_clear_error_and_leaves_no_partial_file: cannot \
                 mount a 64 KiB tmpfs ({e}); this needs root (CAP_SYS_ADMIN)"
            );
            return;
        }
    };
    let out = mount.0.join("dataset");
    // The front ends refuse this sweep before it starts: its 20 parts' footers alone exceed the
    // disk (exit 2, nothing created).
    let refused = run(&[
        "sweep",
        &file,
        "--out",
        out.to_str().unwrap(),
        "--batch-size",
        "8",
    ]);
    assert_eq!(refused.status.code(), Some(2));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("more than the 64.0 KiB free") && err.contains("raise --batch-size"),
        "{err}"
    );
    assert!(!out.exists());
    // A disk that fills while the sweep runs (other jobs write to it too) is the library's to
    // meet: its runner, which the front ends call once the size is checked.
    let sweep = Sweep::load(Path::new(&file)).unwrap();
    let specs = sweep.load_specs().unwrap();
    let options = mbmf::sweep::Options {
        out: out.clone(),
        resume: false,
        shard: Shard::ALL,
        batch_size: 8,
        command: "test".into(),
    };
    let stop = std::sync::atomic::AtomicBool::new(false);
    let error = mbmf::sweep::execute(&sweep, &specs, &options, &stop, &mut |_| {})
        .expect_err("the disk fills");
    // The message and its causes, as the front ends print them.
    let mut err = error.to_string();
    let mut cause = std::error::Error::source(&error);
    while let Some(c) = cause {
        err += &format!(": {c}");
        cause = c.source();
    }
    assert!(err.contains("No space left on device"), "{err}");
    assert!(err.contains("part-"), "the message names the file: {err}");
    assert!(temporaries(&out).is_empty(), "{:?}", temporaries(&out));
    // Whatever was written before the disk filled is complete and committed in pairs.
    let runs = parts(&out, "runs");
    assert_eq!(runs, parts(&out, "series"));
    for name in &runs {
        for sub in ["runs", "series"] {
            file_rows(&out.join(sub).join(name), &[]);
        }
    }
    assert!(runs.len() < 20, "the disk should have filled up");
}

/// A resumed shard counts its own parts as free space (its size includes them), never another
/// shard's, which stay: shard 1 beside shard 0 on a small disk is refused before it starts
/// rather than filling the disk.
#[test]
fn a_resumed_shard_counts_only_its_own_parts_as_free_space() {
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let mount = match Mount::tmpfs("size=200k") {
        Ok(m) => m,
        Err(e) => {
            eprintln!(
                "SKIP a_resumed_shard_counts_only_its_own_parts_as_free_space: cannot mount a \
                 tmpfs ({e}); this needs root (CAP_SYS_ADMIN)"
            );
            return;
        }
    };
    let out = mount.0.join("dataset");
    let o = out.to_str().unwrap();
    run_ok(&["sweep", &file, "--out", o, "--quiet", "--shard", "0/2"]);
    let before = parts(&out, "runs");
    let sweep = Sweep::load(Path::new(&file)).unwrap();
    let seeds = u64::from(sweep.seeds);
    let half = |i| Shard { index: i, count: 2 };
    let own = mbmf::sweep::store::shard_bytes(&out, seeds, half(0));
    assert!(own > 100_000, "{own}");
    assert_eq!(mbmf::sweep::store::shard_bytes(&out, seeds, half(1)), 0);
    let refused = run(&["sweep", &file, "--out", o, "--shard", "1/2", "--resume"]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{err}");
    assert!(err.contains("would take about"), "{err}");
    assert_eq!(parts(&out, "runs"), before);
    // Resuming shard 0 itself counts its parts: nothing is left to run, and it is not refused.
    run_ok(&[
        "sweep", &file, "--out", o, "--quiet", "--shard", "0/2", "--resume",
    ]);
}

#[test]
fn shipped_sweeps_are_valid_and_say_what_they_answer() {
    let mut found = 0;
    for entry in std::fs::read_dir(repo().join("sweeps")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        found += 1;
        let text = std::fs::read_to_string(&path).unwrap();
        let nav = repo().join("../shared/data/navworld/realisticNavWorld.json");
        if text.contains("shared/data/") && !nav.exists() {
            // The authors' files are not in the repository.
            assert!(
                std::env::var("CI").as_deref() != Ok("true"),
                "{} needs {}",
                path.display(),
                nav.display()
            );
            eprintln!("skipped {}: {} is absent", path.display(), nav.display());
            continue;
        }
        let sweep = Sweep::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let specs = sweep.load_specs().unwrap_or_else(|e| panic!("{e}"));
        sweep.check(&specs).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            sweep.text.trim_start().starts_with('#'),
            "{} should start with a comment saying what question it answers",
            path.display()
        );
    }
    assert!(found >= 6, "paper, kappa, budget, zeta, profiles, smoke");
    let kappa = Sweep::load(&repo().join("sweeps/kappa.toml")).unwrap();
    assert_eq!(kappa.seeds, 50);
    assert_eq!(kappa.axes[0].values.len(), 41, "kappa_coeff 0..20 by 0.5");
}

/// Rows of every part of `dir` from the files' footers (cheap for large datasets).
fn footer_rows(dir: &Path) -> i64 {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    parts(
        dir.parent().unwrap(),
        dir.file_name().unwrap().to_str().unwrap(),
    )
    .iter()
    .map(|name| {
        let f = std::fs::File::open(dir.join(name)).unwrap();
        SerializedFileReader::new(f)
            .unwrap()
            .metadata()
            .file_metadata()
            .num_rows()
    })
    .sum()
}

#[test]
fn a_100000_run_sweep_holds_one_batch_in_memory_not_all_runs() {
    // 100,000 runs of 50 steps with a checkpoint at every step: 5 million series rows, which
    // held in memory as Arrow columns would take over a gigabyte.
    let sweep = "seeds = 10\n[fixed]\ncontroller = \"mf\"\nsteps = 50\nbabbling = 0\n\
                 checkpoint = 1\n[grid]\nbudget = { from = 0, to = 9999, by = 1 }\n";
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "big.toml", sweep);
    let out = dir.path().join("out");
    let mut child = mbmf()
        .args(["sweep", &file, "--quiet", "--batch-size", "1000", "--out"])
        .arg(&out)
        .spawn()
        .unwrap();
    // VmHWM is the peak resident size so far: the last reading before exit is the peak.
    let status_file = format!("/proc/{}/status", child.id());
    let mut peak_kb = 0u64;
    let status = loop {
        let reading = std::fs::read_to_string(&status_file).ok().and_then(|text| {
            text.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        });
        peak_kb = peak_kb.max(reading.unwrap_or(0));
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    };
    assert!(status.success());
    assert_eq!(footer_rows(&out.join("runs")), 100_000);
    assert_eq!(footer_rows(&out.join("series")), 5_000_000);
    assert_eq!(parts(&out, "runs").len(), 100);
    if peak_kb == 0 {
        eprintln!("SKIP the memory bound: /proc/PID/status is not readable here");
        return;
    }
    assert!(
        peak_kb < 400 * 1024,
        "peak resident memory {} MB for batches of 1,000 runs",
        peak_kb / 1024
    );
}

#[test]
fn validation_checks_the_combinations_that_interact_and_finds_the_first_bad_one() {
    // 10^9 configurations, of which only interaction and task are checked together: validated
    // in a moment, and the first bad configuration is the one an enumeration would name.
    let dir = tempfile::tempdir().expect("a folder");
    std::fs::write(
        dir.path().join("w.json"),
        r#"{"transitionActions": [{"state": 0, "transitions": [{"action": 0, "state": 1, "prob": 1}]}]}"#,
    )
    .expect("write");
    std::fs::write(dir.path().join("keyStates.txt"), "init 0\ngoal 1 1\n").expect("write");
    std::fs::write(dir.path().join("spaces.txt"), "state 2\naction 1\n").expect("write");
    let text = "[fixed]\ntask = \"json:w.json\"\nbudget = 10\n[grid]\n\
                kappa_coeff = { from = 0, to = 1, steps = 1000000 }\n\
                tau = { from = 0.01, to = 1, steps = 500 }\n\
                interaction = [\"none\", \"takeover\"]\n";
    let sweep = Sweep::parse("i.toml", dir.path(), text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(sweep.configurations(), 1_000_000_000);
    let specs = sweep.load_specs().unwrap_or_else(|e| panic!("{e}"));
    let started = std::time::Instant::now();
    let e = sweep
        .check(&specs)
        .expect_err("takeover on a json task")
        .to_string();
    assert!(started.elapsed().as_secs() < 10, "{:?}", started.elapsed());
    assert!(
        e.starts_with("i.toml:7: key 'interaction' in [grid]: configuration 1 (kappa_coeff = 0, tau = 0.01, interaction = takeover")
            ,
        "{e}"
    );
    // Without the bad value the same grid passes.
    let ok = text.replace("\"takeover\"", "\"none\"");
    let sweep = Sweep::parse("i.toml", dir.path(), &ok).unwrap_or_else(|e| panic!("{e}"));
    let specs = sweep.load_specs().unwrap_or_else(|e| panic!("{e}"));
    sweep.check(&specs).unwrap_or_else(|e| panic!("{e}"));

    // Steps interact with the steps of a schedule's changes: the first configuration whose
    // change falls outside its run is named (kappa_coeff = 0 with steps = 10).
    let big = "[fixed]\nchange = \"15:interaction=takeover\"\n[grid]\n\
               kappa_coeff = { from = 0, to = 1, steps = 1000000 }\nsteps = [20, 10]\n";
    let sweep = parse(big);
    let specs = sweep.load_specs().unwrap_or_else(|e| panic!("{e}"));
    let e = sweep.check(&specs).expect_err("step 15 of 10").to_string();
    assert!(
        e.starts_with(
            "test.toml:2: key 'change' in [fixed]: configuration 1 (kappa_coeff = 0, steps = 10)"
        ) && e.contains("step 15 is outside the experiment"),
        "{e}"
    );
}

#[test]
fn a_sweep_is_sized_by_arithmetic_exactly_as_by_enumeration() {
    // 400,000 configurations: beyond what is enumerated, so sized through the steps and
    // checkpoint axes.
    let text = "seeds = 3\n[grid]\nkappa_coeff = { from = 0, to = 1, steps = 100000 }\n\
                steps = [10, 25]\ncheckpoint = [0, 10]\n[fixed]\nbabbling = 5\n";
    let sweep = parse(text);
    let size = sweep.size(Shard::ALL, 256);
    assert!(size.exact);
    let n = 100_000u128 * 3;
    assert_eq!(size.runs, 4 * n);
    // Per kappa value and seed: steps 10 and 25, each with checkpoint 0 and 10, 5 babbling.
    assert_eq!(size.agent_steps, n * 2 * (15 + 30));
    // Rows: checkpoint 0 none; checkpoint 10 gives 1 (10 steps) and 3 (25 steps).
    assert_eq!(size.series_rows, n * (1 + 3));
    // One kind of run, so parts of 85 configurations (255 runs: the 86th would not fit): 4,706
    // parts, counted in closed form from the samples (and so not called exact).
    assert_eq!(size.parts, 4706);
    assert!(!size.parts_exact);
    // A shard of it is estimated from the same axes, in proportion.
    let half = sweep.size(Shard { index: 1, count: 2 }, 256);
    assert_eq!(half.runs, 2 * n);
    assert!(!half.exact && half.agent_steps == n * (15 + 30));
    // A small grid is enumerated: the same counts.
    let small = parse("[grid]\nsteps = [10, 25]\ncheckpoint = [0, 10]\n[fixed]\nbabbling = 5\n");
    let size = small.size(Shard::ALL, 256);
    assert_eq!((size.runs, size.agent_steps, size.series_rows), (4, 90, 4));
    assert_eq!(size.parts, 1);
    assert!(size.parts_exact);
    // The parts are those the runner plans, for any batch size: configurations of several
    // seeds sharing a kind of run close a batch before one that would not fit.
    let mixed =
        parse("seeds = 3\n[grid]\nkappa_coeff = [0, 1, 2, 3, 4]\ncontroller = [\"mf\", \"ec\"]\n");
    let none = mbmf::sweep::store::RunSet::new(mixed.runs());
    for batch in [1, 2, 3, 4, 5, 6, 7, 9, 13, 256] {
        let mut planned = 0u128;
        mbmf::sweep::runner::plan(&mixed, Shard::ALL, &none, batch, |_, _| {
            planned += 1;
            Ok::<(), ()>(())
        })
        .unwrap();
        assert_eq!(
            mixed.size(Shard::ALL, batch).parts,
            planned,
            "batch {batch}"
        );
    }
    // Five configurations of 3 runs per controller: one a part at 5, two at 6, all at 15.
    assert_eq!(mixed.size(Shard::ALL, 5).parts, 10);
    assert_eq!(mixed.size(Shard::ALL, 6).parts, 6);
    assert_eq!(mixed.size(Shard::ALL, 15).parts, 2);
}
