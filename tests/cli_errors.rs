//! Bad command lines and bad environment files, through the built binary: each
//! gives its exit code (2 for usage errors, 1 for runtime failures), a message naming the flag,
//! key or file position, the bad value and what is accepted, and never a panic or a backtrace.

use std::path::Path;

use assert_cmd::Command;
use tempfile::TempDir;

/// Files the table refers to, in a temporary folder: `{dir}` is the folder itself.
struct Fixtures {
    dir: TempDir,
}

const GOOD_MODEL: &str = r#"{"transitionActions": [
    {"state": 0, "transitions": [{"action": 0, "state": 1, "prob": 1}]},
    {"state": 1, "transitions": [{"action": 0, "state": 2, "prob": 1}]}]}"#;

impl Fixtures {
    fn new() -> Fixtures {
        let fixtures = Fixtures {
            dir: TempDir::new().expect("a temporary folder"),
        };
        fixtures.world(
            "good",
            GOOD_MODEL,
            "init 0\ngoal 2 1\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "garbled",
            r#"{"transitionActions": [{"state": 0, "transitions": [}]}"#,
            "init 0\ngoal 2 1\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "typo",
            GOOD_MODEL,
            "init 0\ngaol 2 1\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "nostates",
            GOOD_MODEL,
            "init 0\ngoal 2 1\n",
            "state 0\naction 1\n",
        );
        fixtures.world(
            "badprob",
            &GOOD_MODEL.replace("\"prob\": 1}]},\n", "\"prob\": -2}]},\n"),
            "init 0\ngoal 2 1\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "badaction",
            &GOOD_MODEL.replace("\"action\": 0, \"state\": 2", "\"action\": 4, \"state\": 2"),
            "init 0\ngoal 2 1\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "goalinit",
            GOOD_MODEL,
            "init 0 2\ngoal 2 1\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "nanreward",
            GOOD_MODEL,
            "init 0\ngoal 2 nan\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "hugereward",
            GOOD_MODEL,
            "init 0\ngoal 2 1e306\n",
            "state 3\naction 1\n",
        );
        fixtures.world(
            "still",
            r#"{"transitionActions": []}"#,
            "init 0\ngoal 2 1\n",
            "state 3\naction 1\n",
        );
        let sweeps = [
            // A step too small for any value to be counted: refused, not an empty dataset.
            (
                "tiny_by.toml",
                "[grid]\nkappa_coeff = { from = 0, to = 1, by = 1e-320 }\n",
            ),
            (
                "wide_by.toml",
                "[grid]\nkappa_coeff = { from = -1e308, to = 1e308, by = 1 }\n",
            ),
            // 10^12 configurations: sized by arithmetic, refused for the disk.
            (
                "grid_1e12.toml",
                "[grid]\nkappa_coeff = { from = 0, to = 1, steps = 1000000 }\n\
                 tau = { from = 0.01, to = 1, steps = 1000000 }\n",
            ),
            // More runs than an i64 index holds.
            (
                "runs_2e63.toml",
                "seeds = 4294967295\n[grid]\nkappa_coeff = { from = 0, to = 1, steps = 1000000 }\n\
                 tau = { from = 0.01, to = 1, steps = 1000000 }\n\
                 alpha_mf = { from = 0.01, to = 1, steps = 1000000 }\n",
            ),
            // Fits on any disk (no series), but would take centuries: 4.3 * 10^15 agent-steps
            // of `ec` (a few million a second per core; `mf` runs are fast enough now for such a
            // job to come out at about a year).
            (
                "centuries.toml",
                "[grid]\nkappa_coeff = { from = 0, to = 1, steps = 1000000 }\n\
                 [fixed]\nsteps = 4294967295\ncheckpoint = 0\ncontroller = \"ec\"\n",
            ),
        ];
        for (name, text) in sweeps {
            std::fs::write(fixtures.path(name), text).expect("write a sweep file");
        }
        std::fs::write(fixtures.path("a_file"), "not a folder").expect("write a file");
        std::fs::create_dir_all(fixtures.path("taken/runs.parquet")).expect("a folder");
        fixtures
    }

    fn world(&self, name: &str, model: &str, key_states: &str, spaces: &str) {
        let dir = self.path(name);
        std::fs::create_dir_all(&dir).expect("a world folder");
        std::fs::write(dir.join("world.json"), model).expect("write the model");
        std::fs::write(dir.join("keyStates.txt"), key_states).expect("write keyStates.txt");
        std::fs::write(dir.join("spaces.txt"), spaces).expect("write spaces.txt");
    }

    fn path(&self, name: &str) -> std::path::PathBuf {
        self.dir.path().join(name)
    }

    /// `line` with `{dir}` replaced, split on spaces.
    fn args(&self, line: &str) -> Vec<String> {
        let dir = self.dir.path().display().to_string();
        line.split_whitespace()
            .map(|a| a.replace("{dir}", &dir))
            .collect()
    }
}

/// Runs the binary with `args` (and a default --out inside the fixtures, so nothing is written
/// elsewhere); returns (exit code, stderr).
fn mbmf(fixtures: &Fixtures, args: &[String]) -> (Option<i32>, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_mbmf"));
    cmd.args(args).env("RUST_BACKTRACE", "1");
    if args.first().map(String::as_str) == Some("run") && !args.iter().any(|a| a == "--out") {
        cmd.arg("--out").arg(fixtures.path("out"));
    }
    let output = cmd.output().expect("the binary runs");
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Asserts one row of a table: exit code, every expected part of the message, no panic.
fn check(fixtures: &Fixtures, line: &str, code: i32, parts: &[&str]) {
    let args = fixtures.args(line);
    let (actual, stderr) = mbmf(fixtures, &args);
    let dir = fixtures.dir.path().display().to_string();
    assert!(
        !stderr.contains("panicked") && !stderr.contains("stack backtrace"),
        "mbmf {line}: panicked:\n{stderr}"
    );
    assert_eq!(
        actual,
        Some(code),
        "mbmf {line}: exit code; stderr:\n{stderr}"
    );
    for part in parts {
        let part = part.replace("{dir}", &dir);
        assert!(
            stderr.contains(&part),
            "mbmf {line}: stderr lacks {part:?}:\n{stderr}"
        );
    }
}

/// Usage errors: (arguments, parts the message must contain). Every row exits with code 2.
const USAGE_ERRORS: &[(&str, &[&str])] = &[
    // Verbs and flags: clap names the word and suggests the closest one.
    ("rn", &["unrecognized subcommand 'rn'"]),
    (
        "rum",
        &[
            "unrecognized subcommand 'rum'",
            "a similar subcommand exists: 'run'",
        ],
    ),
    ("swep x.toml", &["a similar subcommand exists: 'sweep'"]),
    (
        "run --contoller ec",
        &[
            "unexpected argument '--contoller'",
            "a similar argument exists: '--controller'",
        ],
    ),
    (
        "run --kappa-coef 3",
        &["unexpected argument '--kappa-coef'", "'--kappa-coeff'"],
    ),
    (
        "env infos tidy1",
        &["unrecognized subcommand 'infos'", "'info'"],
    ),
    // Names: the accepted values, and the closest one.
    (
        "run --controller ecc",
        &[
            "invalid value 'ecc' for '--controller",
            "[possible values: mf, mb, rnd, ec, entropy, fixed, reliability, vpi]",
            "a similar value exists: 'ec'",
        ],
    ),
    (
        "run --controller mf,mbb",
        &["invalid value 'mbb'", "a similar value exists: 'mb'"],
    ),
    (
        "run --interaction takover",
        &[
            "invalid value 'takover'",
            "a similar value exists: 'takeover'",
        ],
    ),
    (
        "run --profile genrous",
        &[
            "invalid value 'genrous'",
            "a similar value exists: 'generous'",
        ],
    ),
    (
        "run --selection arg-max",
        &[
            "invalid value 'arg-max' for '--selection",
            "possible values: softmax, argmax",
        ],
    ),
    (
        "run --cost-model time",
        &[
            "invalid value 'time' for '--cost-model",
            "possible values: ops, wallclock",
        ],
    ),
    (
        "run --normalise-entropy yes",
        &["invalid value 'yes'", "possible values: on, off"],
    ),
    (
        "run --task tidy3",
        &[
            "unknown task 'tidy3'",
            "did you mean 'tidy1'?",
            "expected tidy1, tidy2, grid:N",
        ],
    ),
    (
        "run --task {dir}/good/world.json",
        &["did you mean 'json:{dir}/good/world.json'?"],
    ),
    (
        "env info tidy0",
        &["unknown task 'tidy0'", "did you mean 'tidy1'?"],
    ),
    // Numbers: the flag, the bad value and the accepted range.
    (
        "run --tau 0",
        &["invalid value '0' for '--tau': expected a temperature > 0"],
    ),
    ("run --tau -0.5", &["invalid value '-0.5' for '--tau'"]),
    ("run --tau nan", &["invalid value 'NaN' for '--tau'"]),
    ("run --tau inf", &["invalid value 'inf' for '--tau'"]),
    (
        "run --tau 1e-320",
        &["invalid value '1e-320' for '--tau'", "at least 1e-300"],
    ),
    (
        "run --tau abc",
        &["invalid value 'abc' for '--tau <TAU>'", "expected a number"],
    ),
    (
        "run --forget 1.5",
        &["invalid value '1.5' for '--forget': expected a probability in [0, 1]"],
    ),
    (
        "run --forget -0.1",
        &["invalid value '-0.1' for '--forget'"],
    ),
    (
        "run --alpha-mf 0",
        &["invalid value '0' for '--alpha-mf': expected a learning rate in (0, 1]"],
    ),
    (
        "run --alpha-mf 1.5",
        &["invalid value '1.5' for '--alpha-mf'"],
    ),
    (
        "run --gamma-mf 1",
        &["invalid value '1' for '--gamma-mf': expected a discount in [0, 1)"],
    ),
    (
        "run --gamma-mb -0.1",
        &["invalid value '-0.1' for '--gamma-mb'"],
    ),
    (
        "run --filter-alpha 0",
        &["invalid value '0' for '--filter-alpha': expected a weight in (0, 1]"],
    ),
    (
        "run --kappa-coeff -1",
        &["invalid value '-1' for '--kappa-coeff': expected a number >= 0"],
    ),
    (
        "run --kappa-coeff inf",
        &["invalid value 'inf' for '--kappa-coeff'"],
    ),
    (
        "run --vi-epsilon 0",
        &["invalid value '0' for '--vi-epsilon': expected a tolerance > 0"],
    ),
    (
        "run --vi-max-sweeps 0",
        &["invalid value '0' for '--vi-max-sweeps': expected at least 1 sweep"],
    ),
    (
        "run --window-n 0",
        &["invalid value '0' for '--window-n': expected a window of 1 to 65535"],
    ),
    (
        "run --window-n 70000",
        &["invalid value '70000' for '--window-n'"],
    ),
    (
        "run --q-init 1e300",
        &["invalid value '1e300' for '--q-init': expected a number from -1e12 to 1e12"],
    ),
    (
        "run --q-init -inf",
        &["invalid value '-inf' for '--q-init'"],
    ),
    (
        "run --zeta -0.1",
        &["invalid value '-0.1' for '--zeta': expected a bonus weight from 0 to 1e12"],
    ),
    ("run --zeta nan", &["invalid value 'NaN' for '--zeta'"]),
    (
        "run --runs 0",
        &[
            "invalid value '0' for '--runs <RUNS>'",
            "expected a whole number from 1 to 1000000",
        ],
    ),
    (
        "run --runs -3",
        &["invalid value '-3' for '--runs <RUNS>'", "too small"],
    ),
    (
        "run --runs 2.5",
        &[
            "invalid value '2.5' for '--runs <RUNS>'",
            "not a whole number",
        ],
    ),
    (
        "run --runs 5000000",
        &["'5000000' for '--runs <RUNS>'", "too large"],
    ),
    (
        "--threads 0 run",
        &[
            "invalid value '0' for '--threads <THREADS>'",
            "from 1 to 4096",
        ],
    ),
    (
        "run --threads 0",
        &["invalid value '0' for '--threads <THREADS>'"],
    ),
    (
        "run --batch-size 0",
        &[
            "invalid value '0' for '--batch-size <BATCH_SIZE>'",
            "a whole number from 1 to 18446744073709551615",
        ],
    ),
    (
        "run --steps -1",
        &[
            "invalid value '-1' for '--steps <STEPS>'",
            "from 0 to 4294967295",
        ],
    ),
    (
        "run --checkpoint 1e3",
        &[
            "invalid value '1e3' for '--checkpoint <CHECKPOINT>'",
            "not a whole number",
        ],
    ),
    (
        "run --budget -5",
        &["invalid value '-5' for '--budget <BUDGET>'"],
    ),
    (
        "run --seed abc",
        &[
            "invalid value 'abc' for '--seed <SEED>'",
            "a whole number from 0 to 18446744073709551615",
        ],
    ),
    // Combinations.
    (
        "run --task json:{dir}/good/world.json --interaction takeover --budget 5",
        &[
            "interaction 'takeover' is not defined for task 'json:{dir}/good/world.json'",
            "use --interaction none",
        ],
    ),
    (
        "run --task json:{dir}/good/world.json --profile generous",
        &["interaction 'congratulation' is not defined"],
    ),
    (
        "run --key-states {dir}/good/keyStates.txt",
        &["--key-states only applies to json:PATH tasks, not 'tidy1'"],
    ),
    (
        "run --task tidy2 --spaces {dir}/good/spaces.txt",
        &["--spaces only applies to json:PATH tasks, not 'tidy2'"],
    ),
    (
        "env info tidy1 --spaces {dir}/good/spaces.txt",
        &["--spaces only applies to json:PATH tasks"],
    ),
    (
        "run --task json:{dir}/hugereward/world.json --controller mb",
        &[
            "action values could reach 2e307",
            "goal reward 1e306",
            "scale the goal reward down",
        ],
    ),
    (
        "run --steps 4000000000 --checkpoint 1 --runs 1",
        &["one run needs about", "raise --checkpoint or lower --steps"],
    ),
    // Environment files: the file, the position, the bad value and what is accepted.
    ("run --task json:", &["task 'json:' names no file"]),
    (
        "run --task json:{dir}/missing.json",
        &["cannot read {dir}/missing.json"],
    ),
    (
        "run --task json:{dir}/good",
        &[
            "{dir}/good is a folder, not a file",
            "json:PATH names the transition-model file itself",
        ],
    ),
    ("env info json:{dir}", &["is a folder, not a file"]),
    (
        "run --task json:/dev/zero",
        &["/dev/zero is a device, pipe or socket, not a file"],
    ),
    (
        "run --task json:{dir}/garbled/world.json",
        &["{dir}/garbled/world.json: invalid JSON", "line 1 column"],
    ),
    (
        "run --task json:{dir}/typo/world.json",
        &["{dir}/typo/keyStates.txt, line 2: unknown keyword 'gaol' (did you mean 'goal'?"],
    ),
    (
        "run --task json:{dir}/nostates/world.json",
        &["{dir}/nostates/spaces.txt, line 1: 'state 0': an environment needs at least one state"],
    ),
    (
        "run --task json:{dir}/badprob/world.json",
        &["state 0, action 0, next state 1: count -2 is not a positive finite number"],
    ),
    (
        "run --task json:{dir}/badaction/world.json",
        &[
            "state 1, transitions[0]: action 4 is outside the action space: spaces.txt declares 1 actions",
        ],
    ),
    (
        "run --task json:{dir}/goalinit/world.json",
        &["goal state 2 is also an initial state"],
    ),
    (
        "run --task json:{dir}/nanreward/world.json",
        &["line 2: goal reward 'nan' is not finite"],
    ),
    (
        "run --task json:{dir}/good/world.json --key-states {dir}/nope.txt",
        &["cannot read {dir}/nope.txt"],
    ),
    // The output folder: a file in the way is a usage error, found before anything runs.
    (
        "run --out {dir}/a_file",
        &["--out {dir}/a_file: {dir}/a_file is a file, not a folder"],
    ),
    (
        "run --out {dir}/a_file/sub",
        &["{dir}/a_file is a file, not a folder"],
    ),
    (
        "run --out {dir}/taken --runs 1 --steps 1",
        &["{dir}/taken/runs.parquet is a folder"],
    ),
    (
        "env export tidy1 --json {dir}/a_file",
        &["--json {dir}/a_file is a file, not a folder"],
    ),
    // Ranges that give no value, and jobs too large to run: refused before any work.
    (
        "sweep {dir}/tiny_by.toml --dry-run",
        &["tiny_by.toml:2: key 'kappa_coeff' in [grid]: from 0 to 1 by 1e-320 gives more values"],
    ),
    (
        "sweep {dir}/wide_by.toml --out {dir}/sweep_out",
        &[
            "wide_by.toml:2: key 'kappa_coeff'",
            "by 1 gives",
            "(at most 1000000)",
        ],
    ),
    (
        "sweep {dir}/grid_1e12.toml --dry-run",
        &[
            "grid_1e12.toml: the results would take about",
            "(1000000000000 runs rows, 100000000000000 series rows)",
            "raise key 'checkpoint'",
            "shrink key 'tau' in [grid] (1000000 values)",
        ],
    ),
    (
        "sweep {dir}/grid_1e12.toml --out {dir}/sweep_out",
        &["grid_1e12.toml: the results would take about", "key 'tau'"],
    ),
    (
        "sweep {dir}/runs_2e63.toml --dry-run",
        &[
            "runs_2e63.toml:5: the axes give 1000000 x 1000000 x 1000000 = 1.000e18 configurations",
            "x 4294967295 seeds",
            "more than run indices hold (2^63 - 1); shrink key 'alpha_mf'",
        ],
    ),
    (
        "sweep {dir}/centuries.toml --out {dir}/sweep_out",
        &[
            "centuries.toml: the job would take about",
            "days",
            "more than the 1-year limit",
            "key 'kappa_coeff' in [grid] (1000000 values)",
            "--shard I/N",
        ],
    ),
    (
        "run --runs 1000000 --steps 1000000 --checkpoint 1",
        &[
            "the results would take about",
            "raise --checkpoint (0 writes no series rows)",
        ],
    ),
    (
        "run --runs 1000000 --steps 4294967295 --checkpoint 0",
        &[
            "the job would take about",
            "more than the 1-year limit: lower --runs or --steps",
        ],
    ),
];

#[test]
fn every_bad_input_exits_with_code_2_and_a_message_naming_it() {
    assert!(USAGE_ERRORS.len() >= 40);
    let fixtures = Fixtures::new();
    for (line, parts) in USAGE_ERRORS {
        check(&fixtures, line, 2, parts);
    }
    assert!(
        !fixtures.path("out").exists(),
        "a refused command wrote its output folder"
    );
}

#[test]
fn an_unwritable_output_folder_is_a_runtime_failure_with_code_1() {
    // /sys refuses new entries even to root; elsewhere there is no portable unwritable folder.
    if !Path::new("/sys/kernel").is_dir() {
        return;
    }
    let fixtures = Fixtures::new();
    check(
        &fixtures,
        "run --out /sys/mbmf-test-out --runs 1 --steps 1",
        1,
        &["cannot create output folder /sys/mbmf-test-out"],
    );
    check(
        &fixtures,
        "env export tidy1 --json /sys/mbmf-test-out",
        1,
        &["cannot write /sys/mbmf-test-out"],
    );
}

#[test]
fn help_and_version_exit_with_code_0() {
    for line in ["--help", "run --help", "env info --help", "--version"] {
        let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
            .args(line.split_whitespace())
            .output()
            .expect("the binary runs");
        assert_eq!(output.status.code(), Some(0), "mbmf {line}");
        assert!(!output.stdout.is_empty());
    }
}

#[test]
fn run_help_documents_what_zero_steps_and_zero_checkpoint_do() {
    let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(["run", "--help"])
        .output()
        .expect("the binary runs");
    let help = String::from_utf8_lossy(&output.stdout);
    assert!(help.contains("0 runs the babbling only"), "{help}");
    assert!(help.contains("0 writes no series rows"), "{help}");
}

#[cfg(unix)]
#[test]
fn an_output_path_that_is_not_utf8_does_not_panic() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join(OsStr::from_bytes(b"out-\xff"));
    let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args([
            "run",
            "--quiet",
            "--runs",
            "1",
            "--steps",
            "10",
            "--babbling",
            "5",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(out.join("runs.parquet").is_file());
}

#[test]
fn a_closed_standard_output_ends_env_info_quietly() {
    // `mbmf env info tidy1 | head -c 1`: the reader leaves early; no panic, no error.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(["env", "info", "tidy1"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the binary runs");
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("it ends");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(output.status.code(), Some(0), "{stderr}");
}

/// A small tmpfs mounted for one test (root only), unmounted on drop.
struct Tmpfs(TempDir);

impl Tmpfs {
    fn mount(size: &str) -> Option<Tmpfs> {
        let dir = TempDir::new().expect("a temporary folder");
        let status = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
            .arg(dir.path())
            .stderr(std::process::Stdio::null())
            .status()
            .ok()?;
        status.success().then_some(Tmpfs(dir))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg(self.0.path())
            .status();
    }
}

#[test]
fn a_full_disk_fails_with_code_1_and_keeps_the_results_it_was_to_replace() {
    let Some(disk) = Tmpfs::mount("160k") else {
        eprintln!("SKIP: mounting a 160 KiB tmpfs needs root (CAP_SYS_ADMIN)");
        return;
    };
    let out = disk.0.path().join("out");
    let job = |seed: &str, force: bool| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_mbmf"));
        command.args(["run", "--quiet", "--runs", "20", "--steps", "2000"]);
        command.args(["--babbling", "10", "--checkpoint", "50", "--seed", seed]);
        if force {
            command.arg("--force");
        }
        command
            .arg("--out")
            .arg(&out)
            .output()
            .expect("the binary runs")
    };
    // A job whose estimate is far beyond the disk is refused before any work (exit 2).
    let refused = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args([
            "run",
            "--runs",
            "200",
            "--steps",
            "2000",
            "--checkpoint",
            "10",
            "--out",
        ])
        .arg(&out)
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("raise --checkpoint"), "{stderr}");
    assert!(!out.exists(), "a refused job created --out");
    // About 85 KiB of results (estimated 83 KiB, the files' footers included) fit.
    let first = job("1", false);
    assert!(
        first.status.success(),
        "{}",
        String::from_utf8_lossy(&first.stderr)
    );
    let files = |dir: &std::path::Path| {
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
            .expect("the output folder")
            .map(|e| {
                let e = e.expect("an entry");
                let bytes = std::fs::read(e.path()).expect("a file");
                (e.file_name().to_string_lossy().into_owned(), bytes)
            })
            .collect();
        files.sort();
        files
    };
    let before = files(&out);
    // Replacing them passes the disk check (their space counts as free) but the new files are
    // written beside the old ones before they replace them: the disk fills.
    let output = job("2", true);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    // The cause once, though Parquet's error quotes the I/O error it also gives as its source.
    assert_eq!(
        stderr.matches("No space left on device").count(),
        1,
        "{stderr}"
    );
    assert!(!stderr.contains("External:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    // The earlier results are untouched and nothing else is left.
    let after = files(&out);
    let names: Vec<&String> = after.iter().map(|(n, _)| n).collect();
    assert_eq!(names, ["runs.parquet", "series.parquet"]);
    assert!(after == before, "the earlier results changed");
}

/// Inputs refused before any work: the output folder of every verb that writes one, the numeric
/// flags of `reproduce`, sweep files that are not regular files, and exports over their source.
/// Each would otherwise compute first (or hang, or overwrite the input) and fail late.
#[test]
fn outputs_and_special_inputs_are_checked_before_any_work() {
    let fixtures = Fixtures::new();
    let dir = fixtures.dir.path();
    let dataset = dir.join("ds");
    tiny_run(dataset.to_str().unwrap(), &[]);
    std::fs::write(
        dir.join("s.toml"),
        "seeds = 1\n[fixed]\nsteps = 20\nbabbling = 5\n[grid]\ncontroller = [\"mf\", \"ec\"]\n",
    )
    .expect("write a sweep file");
    std::fs::write(dir.join("big.toml"), "#".repeat(2 << 20)).expect("write a large file");
    let fifo = std::process::Command::new("mkfifo")
        .arg(dir.join("fifo.toml"))
        .status()
        .is_ok_and(|s| s.success());
    let mut cases: Vec<(&str, Vec<&str>)> = vec![
        (
            "reproduce --runs 0 --out {dir}/r",
            vec![
                "'--runs <RUNS>'",
                "0 is too small: expected a whole number from 1 to 1000000",
            ],
        ),
        (
            "reproduce --runs 2000000 --out {dir}/r",
            vec!["'--runs <RUNS>'", "too large"],
        ),
        (
            "reproduce --seed -1 --out {dir}/r",
            vec!["'--seed <SEED>'", "-1 is too small"],
        ),
        ("min-budget {dir}/ds --alpha -0.1", vec!["--alpha", "-0.1"]),
        (
            "sweep {dir}/big.toml --out {dir}/o",
            vec![
                "sweep file {dir}/big.toml is 2097152 bytes",
                "at most 1048576 bytes",
            ],
        ),
        (
            "sweep /dev/zero --out {dir}/o",
            vec!["sweep file /dev/zero is a device, pipe or socket"],
        ),
        ("sweep {dir} --out {dir}/o", vec!["is a folder"]),
        // A task to time is loaded before anything is measured.
        (
            "bench --task tidy9 --out {dir}/b",
            vec![
                "--task tidy9: unknown task 'tidy9'",
                "expected tidy1, tidy2, grid:N, json:PATH",
            ],
        ),
        (
            "bench --task json:{dir}/none.json --out {dir}/b",
            vec!["--task json:{dir}/none.json: cannot read {dir}/none.json"],
        ),
    ];
    if fifo {
        cases.push((
            "sweep {dir}/fifo.toml --out {dir}/o",
            vec!["sweep file {dir}/fifo.toml is a device, pipe or socket"],
        ));
    }
    for verb in [
        "pareto {dir}/ds",
        "min-budget {dir}/ds",
        "sweep {dir}/s.toml",
        "reproduce --quick",
        "bench",
    ] {
        for (out, message) in [
            (
                "{dir}/a_file",
                "--out {dir}/a_file: it is a file, not a folder",
            ),
            (
                "{dir}/a_file/sub",
                "--out {dir}/a_file/sub: {dir}/a_file is a file",
            ),
            (
                "/dev/null",
                "--out /dev/null: it is a device, pipe or socket, not a folder",
            ),
        ] {
            let line: &'static str = Box::leak(format!("{verb} --out {out}").into_boxed_str());
            cases.push((line, vec![message]));
        }
    }
    for (line, parts) in &cases {
        check(&fixtures, line, 2, parts);
    }
    for left in ["r", "o"] {
        assert!(!dir.join(left).exists(), "a refused command wrote {left}");
    }
    assert!(
        !dataset.join("analysis").exists(),
        "a refused analysis wrote its folder"
    );
}

#[test]
fn env_export_refuses_to_overwrite_the_files_it_was_loaded_from() {
    let fixtures = Fixtures::new();
    let dir = fixtures.dir.path();
    let export = |task: &str, to: &Path| {
        Command::new(env!("CARGO_BIN_EXE_mbmf"))
            .args(["env", "export", task, "--json"])
            .arg(to)
            .output()
            .expect("the binary runs")
    };
    let exp = dir.join("exp");
    assert_eq!(export("tidy1", &exp).status.code(), Some(0));
    let before = std::fs::read(exp.join("tidy1.json")).expect("the export");
    // The same folder, spelt differently: canonical paths are compared.
    let task = format!("json:{}/tidy1.json", exp.display());
    let output = export(&task, &dir.join("exp/../exp"));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("would overwrite") && stderr.contains("which 'json:"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(exp.join("tidy1.json")).expect("still there"),
        before
    );
    // Another folder is fine.
    assert_eq!(export(&task, &dir.join("copy")).status.code(), Some(0));
}

#[test]
fn huge_jobs_are_sized_by_arithmetic_and_print_their_estimate_first() {
    let fixtures = Fixtures::new();
    // A 10^12-configuration grid is refused at once: enumerating it would take days.
    let started = std::time::Instant::now();
    let (code, stderr) = mbmf(
        &fixtures,
        &fixtures.args("sweep {dir}/grid_1e12.toml --dry-run"),
    );
    assert_eq!(code, Some(2), "{stderr}");
    // Generous for a loaded machine; it takes a fraction of a second of CPU.
    assert!(started.elapsed().as_secs() < 30, "{:?}", started.elapsed());
    assert!(!fixtures.path("sweep_out").exists());
    // A huge run prints its size and estimated time before it starts (here it then stops at
    // the earlier results in --out, so nothing runs).
    std::fs::create_dir_all(fixtures.path("earlier")).expect("a folder");
    std::fs::write(fixtures.path("earlier/runs.parquet"), "old").expect("a file");
    let (code, stderr) = mbmf(
        &fixtures,
        &fixtures.args(
            "run --controller mf --runs 1000000 --steps 10000 --checkpoint 0 --out {dir}/earlier",
        ),
    );
    assert_eq!(code, Some(2), "{stderr}");
    let note = stderr
        .lines()
        .find(|l| l.starts_with("note: 1000000 runs, 11000000000 agent-steps"))
        .unwrap_or_else(|| panic!("no size note:\n{stderr}"));
    assert!(
        note.contains("about 122.1 MiB of output (1000000 runs rows, 0 series rows)")
            && note.contains("estimated time: about"),
        "{note}"
    );
    assert!(
        stderr.contains("holds the results of an earlier run"),
        "{stderr}"
    );
}

#[test]
fn likely_mistakes_are_warned_once_naming_the_flag_or_key() {
    let fixtures = Fixtures::new();
    let warned = |line: &str| {
        let (code, stderr) = mbmf(&fixtures, &fixtures.args(line));
        assert_eq!(code, Some(0), "mbmf {line}:\n{stderr}");
        stderr
            .lines()
            .filter(|l| l.starts_with("warning: "))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let quick = "--runs 2 --steps 20 --babbling 5 --force --quiet";
    let w = warned(&format!("run --controller mf,mb,mf {quick}"));
    assert_eq!(
        w,
        [
            "warning: --controller lists mf twice: each listing adds --runs 2 runs (with other run \
          indices), and the summary merges them into one row"
        ],
    );
    let w = warned(&format!("run --controller mf,mf,mf {quick}"));
    assert!(w.len() == 1 && w[0].contains("lists mf 3 times"), "{w:?}");
    let w = warned(&format!("run --budget 30 {quick}"));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("--budget 30 has no effect"), "{w:?}");
    // A budget with an interaction, from the flag or a later change, is used.
    assert!(warned(&format!("run --budget 30 --interaction takeover {quick}")).is_empty());
    assert!(
        warned(&format!(
            "run --budget 30 --change 5:interaction=takeover {quick}"
        ))
        .is_empty()
    );
    let w = warned(&format!("run --task json:{{dir}}/still/world.json {quick}"));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("/still/world.json: the world has no transition at all"),
        "{w:?}"
    );
    assert!(warned(&format!("run --controller mf,mb {quick}")).is_empty());

    let sweep = fixtures.path("twice.toml");
    std::fs::write(
        &sweep,
        "[grid]\nkappa_coeff = [1, 1.0, 2, 1]\ncontroller = [\"mf\", \"mb\", \"mf\"]\n\
         [[zip]]\ninteraction = [\"none\", \"takeover\", \"takeover\"]\nbudget = [0, 30, 30]\n",
    )
    .expect("write");
    let w = warned(&format!("sweep {} --dry-run", sweep.display()));
    let file = sweep.display().to_string();
    assert_eq!(
        w,
        [
            format!(
                "warning: {file}:2: key 'kappa_coeff' in [grid] lists 1 3 times: its \
                 configurations run that many times (use 'seeds' for replicates)"
            ),
            format!(
                "warning: {file}:3: key 'controller' in [grid] lists \"mf\" twice: its \
                 configurations run that many times (use 'seeds' for replicates)"
            ),
            format!(
                "warning: {file}:5: [[zip]] #1 lists the row (interaction = takeover, budget = \
                 30) more than once: its configurations run that many times (use 'seeds' for \
                 replicates)"
            ),
        ]
    );
    let still = fixtures.path("still.toml");
    std::fs::write(
        &still,
        format!(
            "[fixed]\ntask = \"json:{}/still/world.json\"\nsteps = 10\n",
            fixtures.dir.path().display()
        ),
    )
    .expect("write");
    let w = warned(&format!("sweep {} --dry-run", still.display()));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("still.toml:2: key 'task' in [fixed]: task json:")
            && w[0].contains("no transition at all"),
        "{w:?}"
    );
}

/// Peak resident memory (KiB) of `mbmf ARGS`, measured by `wait4` on the child alone.
// The child is reaped by wait4 (which reports its own peak), not by Child::wait.
#[allow(clippy::zombie_processes)]
fn peak_kib(args: &[String]) -> i64 {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("the binary starts");
    let mut status = 0;
    // SAFETY: an all-zero rusage is valid; wait4 fills it for this child only.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: the pid is our child, not yet waited for; both pointers are valid.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32, "wait4");
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "mbmf {args:?}: {status}"
    );
    usage.ru_maxrss
}

#[test]
fn run_memory_does_not_grow_with_the_number_of_runs() {
    let dir = TempDir::new().expect("a folder");
    // 2,000 series rows per run, 64 runs per batch: 0.5 M series rows, then 2 M.
    let peak = |runs: u32| {
        let line = format!(
            "run --controller mf --runs {runs} --steps 2000 --babbling 10 --checkpoint 1 \
             --batch-size 64 --quiet --force --out {}",
            dir.path().join(runs.to_string()).display()
        );
        peak_kib(
            &line
                .split_whitespace()
                .map(String::from)
                .collect::<Vec<_>>(),
        )
    };
    let small = peak(256);
    let large = peak(1024);
    // Kept in memory, 1.5 M more series rows would add hundreds of MiB; streamed, the peak
    // stays that of one batch (plus Parquet's row-group buffer).
    assert!(
        large < small + small / 2,
        "peak {large} KiB for 1024 runs, {small} KiB for 256"
    );
}

/// Runs mbmf on `args` (no default `--out`), asserting exit code 0; returns stderr.
fn mbmf_ok(args: &[&str]) -> String {
    let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(args)
        .output()
        .expect("the binary runs");
    assert_eq!(output.status.code(), Some(0), "mbmf {args:?}: {output:?}");
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// `mbmf run` of two 50-step runs (5 of babbling) into `out`: a dataset for the verbs to read.
fn tiny_run(out: &str, extra: &[&str]) {
    let args = [
        "run",
        "--quiet",
        "--runs",
        "2",
        "--steps",
        "50",
        "--babbling",
        "5",
    ];
    mbmf_ok(&[&args[..], extra, &["--out", out]].concat());
}

#[test]
fn analyses_refuse_mixed_foreign_and_unfinished_datasets_naming_the_file() {
    let fixtures = Fixtures::new();
    let dir = fixtures.dir.path();
    let d = |name: &str| dir.join(name).display().to_string();
    let run = d("r");
    tiny_run(&run, &["--controller", "mf,ec"]);
    // The series file of another run in an mbmf run folder: the pair would mix two runs.
    let other = d("r2");
    tiny_run(&other, &[]);
    std::fs::create_dir_all(dir.join("mixed")).expect("a folder");
    std::fs::copy(dir.join("r/runs.parquet"), dir.join("mixed/runs.parquet")).expect("copy");
    std::fs::copy(
        dir.join("r2/series.parquet"),
        dir.join("mixed/series.parquet"),
    )
    .expect("copy");
    std::fs::write(
        dir.join("s.toml"),
        "seeds = 2\n[fixed]\nsteps = 20\nbabbling = 5\n[grid]\ncontroller = [\"mf\", \"ec\"]\n",
    )
    .expect("write a sweep file");
    let sweep = d("sw");
    mbmf_ok(&[
        "sweep",
        &d("s.toml"),
        "--out",
        &sweep,
        "--batch-size",
        "1",
        "--quiet",
    ]);
    let mut parts: Vec<_> = std::fs::read_dir(dir.join("sw/runs"))
        .expect("the sweep's runs")
        .map(|e| e.expect("an entry").file_name())
        .collect();
    parts.sort();
    for sub in ["runs", "series"] {
        std::fs::remove_file(dir.join("sw").join(sub).join(&parts[3])).expect("remove a part");
    }
    // A sweep killed before its first part: the sweep text alone.
    std::fs::create_dir_all(dir.join("empty/runs")).expect("a folder");
    std::fs::copy(dir.join("s.toml"), dir.join("empty/sweep.toml")).expect("copy");
    std::fs::create_dir_all(dir.join("loose/runs")).expect("a folder");
    std::fs::copy(
        dir.join("r/runs.parquet"),
        dir.join("loose/runs/part-00000.parquet"),
    )
    .expect("copy");
    std::fs::copy(
        dir.join("r/series.parquet"),
        dir.join("loose/runs/part-00001.parquet"),
    )
    .expect("copy");
    let series_table =
        "{dir}/r/series.parquet is a series table (mbmf_schema series/2), not a runs table";
    let cases: &[(&str, &[&str])] = &[
        (
            "stats {dir}/r/series.parquet --by controller",
            &[
                series_table,
                "one row per checkpoint",
                "give the dataset folder {dir}/r",
            ],
        ),
        ("pareto {dir}/r/series.parquet", &[series_table]),
        ("min-budget {dir}/r/series.parquet", &[series_table]),
        (
            "stats {dir}/sw/series --by controller",
            &[
                "{dir}/sw/series is the series folder of the sweep {dir}/sw",
                "give {dir}/sw or {dir}/sw/runs",
            ],
        ),
        (
            "pareto {dir}/loose",
            &["{dir}/loose/runs/part-00001.parquet is a series table (mbmf_schema series/2)"],
        ),
        (
            "stats {dir}/sw --by controller",
            &[
                "{dir}/sw is incomplete: 3 of 4 runs are committed",
                "--resume",
                "pass --allow-incomplete to analyse the runs present",
            ],
        ),
        ("pareto {dir}/sw", &["{dir}/sw is incomplete: 3 of 4 runs"]),
        (
            "pareto {dir}/empty",
            &["{dir}/empty is incomplete: 0 of an unknown number of runs are committed"],
        ),
        (
            "min-budget {dir}/sw",
            &["{dir}/sw is incomplete: 3 of 4 runs"],
        ),
        (
            "plot {dir}/sw --by controller",
            &["{dir}/sw is incomplete: 3 of 4 runs"],
        ),
        (
            "plot {dir}/mixed --by controller",
            &[
                "{dir}/mixed/series.parquet (mbmf_run_id",
                "does not belong to {dir}/mixed/runs.parquet",
                "come from different runs",
            ],
        ),
        (
            "pareto {dir}/r --objectives total_reward:max,total_reward:min",
            &[
                "invalid --objectives total_reward:max,total_reward:min",
                "opposite objectives on one column put every configuration on the front",
            ],
        ),
        (
            "pareto {dir}/r --objectives cost_total:min,total_reward:max,cost_total:min",
            &["invalid --objectives cost_total:min,cost_total:min: an objective listed twice"],
        ),
    ];
    for (line, parts) in cases {
        check(&fixtures, line, 2, parts);
    }
    let warned = mbmf_ok(&["stats", &sweep, "--by", "controller", "--allow-incomplete"]);
    assert!(
        warned.contains(&format!(
            "warning: {sweep} is incomplete: analysing the 3 of 4 runs committed so far"
        )),
        "{warned}"
    );
    assert!(
        !dir.join("sw/analysis").exists(),
        "a refused analysis wrote files"
    );
}

/// Messages that name the limit and the cause once: seed ranges with their maximum, a typo of a
/// verb, an empty column name, a task's huge reward and a world that cannot move.
#[test]
fn messages_name_the_limit_and_the_cause_once() {
    let fixtures = Fixtures::new();
    let dir = fixtures.dir.path().display().to_string();
    check(
        &fixtures,
        "run --seed 18446744073709551616",
        2,
        &[
            "18446744073709551616 is too large: expected a whole number from 0 to 18446744073709551615",
        ],
    );
    check(
        &fixtures,
        "rnu --runs 2",
        2,
        &[
            "unrecognized subcommand 'rnu'",
            "a similar subcommand exists: 'run'",
        ],
    );
    check(
        &fixtures,
        "stats {dir} --where =3 --by controller",
        2,
        &["--where '=3': the column name before '=' is empty"],
    );
    // An empty name is no typo of any column: refused at the flag, with no suggestion.
    for (flag, other) in [("--by", "--metric"), ("--metric", "--by")] {
        let args: Vec<String> = ["stats", &dir, other, "controller", flag, ""]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let (code, stderr) = mbmf(&fixtures, &args);
        assert_eq!(code, Some(2), "{stderr}");
        assert!(stderr.contains("the column name is empty"), "{stderr}");
        assert!(!stderr.contains("did you mean"), "{stderr}");
    }
    for (text, expected) in [
        (
            "seeds = 5000000000\n",
            "key 'seeds': the number of runs per configuration, a whole number from 1 to 4294967295",
        ),
        (
            "master_seed = -1\n",
            "key 'master_seed': a whole number from 0 to 18446744073709551615 (2^64 - 1)",
        ),
    ] {
        let file = fixtures.path("seeds.toml");
        std::fs::write(&file, format!("{text}[fixed]\ntask = \"tidy1\"\n")).expect("write");
        check(
            &fixtures,
            &format!("sweep {} --dry-run", file.display()),
            2,
            &[expected],
        );
    }
    // The largest master seed the check accepts is written as it is.
    let file = fixtures.path("top.toml");
    std::fs::write(
        &file,
        "seeds = 1\nmaster_seed = 18446744073709551615\n[fixed]\ntask = \"tidy1\"\n",
    )
    .expect("write");
    let (code, stderr) = mbmf(
        &fixtures,
        &fixtures.args(&format!("sweep {} --dry-run", file.display())),
    );
    assert_eq!(code, Some(0), "{stderr}");

    let info = |task: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_mbmf"))
            .args(["env", "info", &format!("json:{dir}/{task}/world.json")])
            .output()
            .expect("the binary runs");
        assert_eq!(out.status.code(), Some(0));
        (
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (stdout, stderr) = info("hugereward");
    assert!(stdout.contains("reward 1e306\n"), "{stdout}");
    assert!(stderr.is_empty(), "{stderr}");
    let (_, stderr) = info("still");
    assert!(
        stderr.starts_with("warning: task json:")
            && stderr.contains("no transition at all (every action leaves every state as it is)"),
        "{stderr}"
    );
    let (code, stderr) = mbmf(
        &fixtures,
        &fixtures.args("run --controller ec,ec --runs 1 --steps 20 --babbling 5 --quiet"),
    );
    assert_eq!(code, Some(0), "{stderr}");
    assert!(
        stderr.contains("warning: --controller lists ec twice"),
        "{stderr}"
    );
}
