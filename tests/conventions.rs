//! The command-line conventions scripts rely on, through the built binary: shell completions, the
//! man page, `-q`, `--json` summaries that parse and agree with the files written, results on
//! stdout and diagnostics on stderr for every verb, and text tables without trailing spaces.

use assert_cmd::Command;
use tempfile::TempDir;

fn mbmf() -> Command {
    Command::cargo_bin("mbmf").expect("the mbmf binary")
}

fn stdout_of(args: &[&str]) -> String {
    let output = mbmf().args(args).output().expect("mbmf runs");
    assert!(
        output.status.success(),
        "mbmf {args:?} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).expect("UTF-8 output")
}

#[test]
fn completions_for_every_shell_name_the_verbs() {
    for shell in ["bash", "zsh", "fish", "powershell", "elvish"] {
        let script = stdout_of(&["completions", shell]);
        assert!(script.contains("min-budget"), "{shell}: no min-budget verb");
        assert!(script.contains("batch-size"), "{shell}: no run flag");
    }
    mbmf().args(["completions", "tcsh"]).assert().code(2);
}

#[test]
fn man_page_on_stdout_and_one_page_per_verb() {
    let page = stdout_of(&["man"]);
    assert!(page.starts_with(".ie") || page.contains(".TH"), "not roff");
    assert!(page.contains("min\\-budget") || page.contains("min-budget"));
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join("man1");
    let printed = stdout_of(&["man", "--out", out.to_str().expect("UTF-8 path")]);
    assert!(printed.contains("wrote"), "{printed}");
    for page in ["mbmf.1", "mbmf-run.1", "mbmf-sweep.1", "mbmf-min-budget.1"] {
        let text = std::fs::read_to_string(out.join(page)).expect(page);
        assert!(text.contains(".TH"), "{page} is not a man page");
    }
    let run = std::fs::read_to_string(out.join("mbmf-run.1")).expect("run page");
    assert!(run.contains("batch\\-size"), "the run page lacks its flags");
}

/// Runs mbmf, asserts success, and returns its stdout and stderr.
fn split(args: &[&str]) -> (String, String) {
    let output = mbmf().args(args).output().expect("mbmf runs");
    let stderr = String::from_utf8(output.stderr).expect("UTF-8 diagnostics");
    assert!(output.status.success(), "mbmf {args:?} failed: {stderr}");
    (
        String::from_utf8(output.stdout).expect("UTF-8 output"),
        stderr,
    )
}

/// Runs mbmf, asserts success and an empty stderr (no bar off a terminal, no note), checks
/// that no line of stdout ends with white space, and returns stdout.
fn result_only(args: &[&str]) -> String {
    let (stdout, stderr) = split(args);
    assert!(stderr.is_empty(), "mbmf {args:?} wrote to stderr: {stderr}");
    assert!(!stdout.is_empty(), "mbmf {args:?} printed no result");
    assert_no_trailing_spaces(&format!("mbmf {args:?}"), &stdout);
    stdout
}

fn assert_no_trailing_spaces(what: &str, text: &str) {
    for (i, line) in text.lines().enumerate() {
        assert!(
            !line.ends_with([' ', '\t']),
            "{what}: line {} ends with white space: {line:?}",
            i + 1
        );
    }
}

#[test]
fn short_quiet_hides_diagnostics_but_not_the_result() {
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join("run");
    let out = out.to_str().expect("UTF-8 path");
    let quiet = result_only(&["run", "--runs", "2", "--steps", "200", "-q", "--out", out]);
    assert!(quiet.contains("controller"), "-q hid the table: {quiet}");
    assert!(
        quiet.contains(&format!(
            "wrote {out}/runs.parquet and {out}/series.parquet"
        )),
        "{quiet}"
    );
    // The same run without -q prints the same result, apart from the timing.
    let loud = result_only(&[
        "run", "--runs", "2", "--steps", "200", "--force", "--out", out,
    ]);
    let untimed = |s: &str| s.lines().skip(1).map(str::to_owned).collect::<Vec<_>>();
    assert_eq!(untimed(&quiet), untimed(&loud));
}

#[test]
fn run_and_its_analyses_print_results_on_stdout_only() {
    let dir = TempDir::new().expect("a temporary folder");
    let data = dir.path().join("run");
    let data = data.to_str().expect("UTF-8 path");
    let run = result_only(&["run", "--runs", "3", "--steps", "300", "--out", data]);
    let lines: Vec<&str> = run.lines().collect();
    assert!(lines[0].starts_with("tidy1: 12 runs in "), "{run}");
    assert!(lines[1].starts_with("controller"), "{run}");
    assert_eq!(lines.len(), 7, "title, header, 4 controllers, files: {run}");
    assert!(lines[6].starts_with("wrote "), "{run}");

    let stats = result_only(&["stats", data, "--by", "controller"]);
    assert!(stats.contains("p_holm"), "{stats}");
    let pareto = result_only(&["pareto", data]);
    assert!(
        pareto.contains("<- knee") && pareto.contains("wrote "),
        "{pareto}"
    );
    let plot = result_only(&["plot", data, "--by", "controller"]);
    assert!(plot.contains("controller=ec: 3 runs"), "{plot}");

    // A note goes to stderr, in either output mode; stdout keeps the result alone.
    let one = ["pareto", data, "--objectives", "total_reward:max", "--out"];
    let figures = dir.path().join("one");
    let figures = figures.to_str().expect("UTF-8 path");
    let (stdout, stderr) = split(&[&one[..], &[figures]].concat());
    assert!(stderr.starts_with("note: no figure"), "{stderr}");
    assert!(
        !stdout.contains("figure") && stdout.contains("wrote "),
        "{stdout}"
    );
    assert_no_trailing_spaces("pareto, one objective", &stdout);
    let (stdout, stderr) = split(&[&one[..], &[figures, "--json"]].concat());
    assert!(stderr.starts_with("note: no figure"), "{stderr}");
    let report: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_eq!(report["verb"], "pareto");

    // A refusal: nothing on stdout, the error on stderr.
    let output = mbmf()
        .args(["run", "--runs", "1", "--steps", "10", "--out", data])
        .output()
        .expect("mbmf runs");
    assert_eq!(output.status.code(), Some(2));
    assert!(output.stdout.is_empty(), "a refusal printed a result");
    assert!(String::from_utf8_lossy(&output.stderr).contains("--force"));
}

#[test]
fn sweep_compact_and_min_budget_print_results_on_stdout_only() {
    let dir = TempDir::new().expect("a temporary folder");
    let file = dir.path().join("budget.toml");
    std::fs::write(&file, BUDGET_SWEEP).expect("write the sweep");
    let file = file.to_str().expect("UTF-8 path");
    let data = dir.path().join("budget");
    let data = data.to_str().expect("UTF-8 path");

    let plan = result_only(&["sweep", file, "--dry-run"]);
    assert!(
        plan.contains("2 configurations x 3 seeds = 6 runs"),
        "{plan}"
    );
    let line = result_only(&["sweep", file, "--out", data]);
    assert_eq!(line.lines().count(), 1, "{line}");
    // Resuming a finished dataset: the note on stderr (not under -q), the line on stdout.
    let (stdout, stderr) = split(&["sweep", file, "--out", data, "--resume"]);
    assert!(stderr.starts_with("resuming "), "{stderr}");
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    let quiet = result_only(&["sweep", file, "--out", data, "--resume", "-q"]);
    assert_eq!(quiet.lines().count(), 1, "{quiet}");

    let min = result_only(&["min-budget", data, "--levels"]);
    assert!(
        min.contains("min budget") && min.contains("qualifies"),
        "{min}"
    );
    let compact = result_only(&["compact", data]);
    assert!(compact.contains("6 runs"), "{compact}");
    result_only(&["min-budget", data, "--levels"]);
}

#[test]
fn reproduce_and_env_print_results_on_stdout_only() {
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join("repro");
    let out = out.to_str().expect("UTF-8 path");
    let report = result_only(&["reproduce", "--quick", "--runs", "2", "--out", out]);
    assert!(
        report.contains("| task |") && report.contains("report: "),
        "{report}"
    );
    let info = result_only(&["env", "info", "tidy1"]);
    assert!(info.contains("states    112"), "{info}");
    let export = dir.path().join("export");
    let export = result_only(&[
        "env",
        "export",
        "tidy1",
        "--json",
        export.to_str().expect("UTF-8"),
    ]);
    assert!(export.starts_with("wrote "), "{export}");
}

#[test]
fn run_json_is_one_object_matching_the_runs_file() {
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join("run");
    let text = stdout_of(&[
        "run",
        "--runs",
        "3",
        "--steps",
        "300",
        "--json",
        "--out",
        out.to_str().expect("UTF-8 path"),
    ]);
    let report: serde_json::Value = serde_json::from_str(&text).expect("one JSON object");
    assert_eq!(report["verb"], "run");
    assert_eq!(report["runs"], 12, "4 controllers x 3 runs");
    assert!(report["seconds"].as_f64().expect("seconds") >= 0.0);
    let runs_path = report["files"]["runs"].as_str().expect("runs path");
    assert!(std::path::Path::new(runs_path).is_file());
    assert!(report["files"]["series"].as_str().is_some());
    let rows = report["controllers"].as_array().expect("rows");
    let names: Vec<&str> = rows
        .iter()
        .map(|r| r["controller"].as_str().expect("name"))
        .collect();
    assert_eq!(names, ["mf", "mb", "rnd", "ec"]);

    // The means are those of the file written.
    let file = std::fs::File::open(runs_path).expect("runs.parquet");
    let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(file)
        .expect("a Parquet file")
        .build()
        .expect("a reader");
    let mut sums: std::collections::BTreeMap<String, (f64, usize)> = Default::default();
    for batch in reader {
        let batch = batch.expect("a batch");
        let controller = arrow::compute::cast(
            batch.column_by_name("controller").expect("controller"),
            &arrow::datatypes::DataType::Utf8,
        )
        .expect("as strings");
        let controller = controller
            .as_any()
            .downcast_ref::<arrow::array::StringArray>()
            .expect("strings");
        let reward = batch
            .column_by_name("total_reward")
            .expect("total_reward")
            .as_any()
            .downcast_ref::<arrow::array::Float64Array>()
            .expect("f64")
            .clone();
        for i in 0..batch.num_rows() {
            let entry = sums.entry(controller.value(i).to_string()).or_default();
            entry.0 += reward.value(i);
            entry.1 += 1;
        }
    }
    for row in rows {
        let (sum, n) = sums[row["controller"].as_str().expect("name")];
        assert_eq!(row["runs"], n);
        let mean = row["total_reward_mean"].as_f64().expect("mean");
        assert!(
            (mean - sum / n as f64).abs() <= 1e-9 * mean.abs().max(1.0),
            "{mean} vs {}",
            sum / n as f64
        );
    }
}

/// With `combine = mix` no expert is drawn, so the MB share (decisions weighted above 1/2)
/// says little: the table marks the rule `(mix)` and gives its mean P(MB) under it, and the
/// JSON rows carry `combine` and `p_mb_mean`. `mf` ignores `combine`.
#[test]
fn a_mixed_rule_is_marked_and_its_weight_shown() {
    let dir = TempDir::new().expect("a temporary folder");
    let out = |name: &str| {
        dir.path()
            .join(name)
            .to_str()
            .expect("UTF-8 path")
            .to_owned()
    };
    let (table_out, json_out) = (out("table"), out("json"));
    let mixed = [
        "run",
        "--controller",
        "fixed,mf",
        "--combine",
        "mix",
        "--w-mb",
        "0.25",
        "--runs",
        "3",
        "--steps",
        "200",
        "--out",
    ];
    let table = stdout_of(&[&mixed[..], &[table_out.as_str()]].concat());
    let lines: Vec<&str> = table.lines().collect();
    assert!(lines[2].starts_with("fixed (mix) "), "{table}");
    assert!(lines[3].starts_with("mf "), "{table}");
    // Weights of 0.25 are never above 1/2; every decision weighs 0.25 exactly.
    assert!(lines[2].ends_with("0.000 ± 0.000"), "{table}");
    assert!(
        lines[4].ends_with("Mean P(MB): fixed 0.250 ± 0.000"),
        "{table}"
    );

    // Lee 2014's P(MB) on tidy1 falls to about 3e-4 (SPEC 12.3): shown with its digits, not
    // as 0.000, which would read as a weight of 0.
    let small_out = out("small");
    let small = stdout_of(&[
        "run",
        "--controller",
        "reliability",
        "--combine",
        "mix",
        "--runs",
        "2",
        "--steps",
        "300",
        "--out",
        small_out.as_str(),
    ]);
    let weight = small
        .lines()
        .find_map(|line| line.split("Mean P(MB): reliability ").nth(1))
        .unwrap_or_else(|| panic!("{small}"));
    let mean: f64 = weight
        .split(" ± ")
        .next()
        .and_then(|m| m.parse().ok())
        .unwrap_or_else(|| panic!("{small}"));
    assert!(
        weight.contains("e-") && mean > 0.0 && mean < 5e-4,
        "{small}"
    );

    let text = stdout_of(&[&mixed[..], &[json_out.as_str(), "--json"]].concat());
    let report: serde_json::Value = serde_json::from_str(&text).expect("one JSON object");
    let rows = report["controllers"].as_array().expect("rows");
    assert_eq!(rows[0]["controller"], "fixed");
    assert_eq!(rows[0]["combine"], "mix");
    assert_eq!(rows[0]["p_mb_mean"], 0.25);
    assert_eq!(rows[0]["mb_share_mean"], 0.0);
    assert_eq!(rows[1]["controller"], "mf");
    assert_eq!(rows[1]["combine"], "select");
    assert_eq!(rows[1]["p_mb_mean"], 0.0);
}

const SWEEP: &str = r#"
seeds = 2
master_seed = 11

[fixed]
task = "tidy1"
steps = 300
babbling = 100
checkpoint = 100

[grid]
controller = ["mf", "ec"]
"#;

/// Takeover budgets 0 and 10 for EC, 3 seeds: 6 runs, the smallest input of `min-budget`.
const BUDGET_SWEEP: &str = "seeds = 3\nmaster_seed = 5\n[fixed]\ntask = \"tidy1\"\nsteps = 300\n\
                            babbling = 100\ncontroller = \"ec\"\ninteraction = \"takeover\"\n\
                            [grid]\nbudget = [0, 10]\n";

#[test]
fn sweep_json_counts_the_runs() {
    let dir = TempDir::new().expect("a temporary folder");
    let file = dir.path().join("small.toml");
    std::fs::write(&file, SWEEP).expect("write the sweep");
    let out = dir.path().join("data");
    let text = stdout_of(&[
        "sweep",
        file.to_str().expect("UTF-8 path"),
        "--json",
        "--out",
        out.to_str().expect("UTF-8 path"),
    ]);
    let report: serde_json::Value = serde_json::from_str(&text).expect("one JSON object");
    assert_eq!(report["verb"], "sweep");
    assert_eq!(report["runs_total"], 4);
    assert_eq!(report["ran"], 4);
    assert_eq!(report["done_before"], 0);
    assert!(report["parts_written"].as_u64().expect("parts") >= 1);
    assert_eq!(report["out"], out.to_str().expect("UTF-8 path"));

    // A dry run with --json is one object too: the plan and its estimates, nothing run.
    let dry = dir.path().join("dry");
    let text = stdout_of(&[
        "sweep",
        file.to_str().expect("UTF-8 path"),
        "--dry-run",
        "--json",
        "--out",
        dry.to_str().expect("UTF-8 path"),
    ]);
    let plan: serde_json::Value = serde_json::from_str(&text).expect("one JSON object");
    assert_eq!(plan["verb"], "sweep");
    assert_eq!(plan["dry_run"], true);
    assert_eq!(plan["runs"], 4);
    assert_eq!(
        plan["configurations"].as_u64().unwrap() * plan["seeds"].as_u64().unwrap(),
        4
    );
    assert!(plan["agent_steps"].as_u64().expect("agent-steps") > 0);
    assert!(plan["estimated_seconds"].as_f64().expect("seconds") >= 0.0);
    assert!(!dry.exists(), "a dry run writes nothing");
}

#[test]
fn analysis_verbs_print_json() {
    let dir = TempDir::new().expect("a temporary folder");
    let data = dir.path().join("run");
    let data = data.to_str().expect("UTF-8 path");
    stdout_of(&["run", "--runs", "4", "--steps", "300", "-q", "--out", data]);
    let analysis = dir.path().join("analysis");
    let analysis = analysis.to_str().expect("UTF-8 path");

    let stats: serde_json::Value =
        serde_json::from_str(&stdout_of(&["stats", data, "--by", "controller", "--json"]))
            .expect("stats: one JSON object");
    assert_eq!(stats["verb"], "stats");
    assert_eq!(stats["groups"].as_array().expect("groups").len(), 4);
    assert_eq!(
        stats["pairs"].as_array().expect("pairs").len(),
        6,
        "4 choose 2"
    );
    assert!(stats["groups"][0]["n"] == 4);

    let pareto: serde_json::Value = serde_json::from_str(&stdout_of(&[
        "pareto",
        data,
        "--no-plot",
        "--json",
        "--out",
        analysis,
    ]))
    .expect("pareto: one JSON object");
    assert_eq!(pareto["verb"], "pareto");
    assert_eq!(pareto["runs"], 16);
    assert_eq!(pareto["configurations"], 4);
    let front = pareto["front"].as_array().expect("front");
    assert!(!front.is_empty() && front.len() <= 4);
    assert!(front[0]["total_reward_mean"].is_number(), "{}", front[0]);
    let file = pareto["files"][0].as_str().expect("a file");
    assert!(std::path::Path::new(file).is_file());

    let sweep = dir.path().join("budget.toml");
    std::fs::write(&sweep, BUDGET_SWEEP).expect("write the sweep");
    let budget = dir.path().join("budget");
    let budget = budget.to_str().expect("UTF-8 path");
    stdout_of(&[
        "sweep",
        sweep.to_str().expect("UTF-8"),
        "-q",
        "--out",
        budget,
    ]);
    let min: serde_json::Value = serde_json::from_str(&stdout_of(&[
        "min-budget",
        budget,
        "--json",
        "--out",
        analysis,
    ]))
    .expect("min-budget: one JSON object");
    assert_eq!(min["verb"], "min-budget");
    let groups = min["groups"].as_array().expect("groups");
    assert_eq!(groups.len(), 1);
    assert_eq!(groups[0]["budgets"], serde_json::json!([0, 10]));
    assert!(std::path::Path::new(min["files"][0].as_str().expect("file")).is_file());
}

/// The README's first example is the default run on a fresh clone: what it shows must be what
/// the binary prints there, line for line, apart from the wall time in the first line.
#[test]
fn the_readme_shows_what_the_default_run_prints() {
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md"))
        .expect("README.md");
    let prompt = "$ cargo run --release -- run\n";
    let start = readme.find(prompt).expect("the first example") + prompt.len();
    let shown = &readme[start..start + readme[start..].find("```").expect("its end")];
    let dir = TempDir::new().expect("a temporary folder");
    let output = mbmf()
        .arg("run")
        .current_dir(dir.path())
        .output()
        .expect("mbmf runs");
    assert!(output.status.success(), "{output:?}");
    let printed = String::from_utf8(output.stdout).expect("UTF-8 output");
    let untimed = |s: &str| {
        let mut lines: Vec<String> = s.lines().map(str::to_owned).collect();
        let (title, _) = lines[0].split_once(" in ").expect("'N runs in T s'");
        lines[0] = title.to_owned();
        lines
    };
    assert_eq!(
        untimed(shown),
        untimed(&printed),
        "README:\n{shown}\nprinted:\n{printed}"
    );
    // Running it again is refused, as the README says, and --force replaces the results.
    let again = mbmf()
        .arg("run")
        .current_dir(dir.path())
        .output()
        .expect("mbmf runs");
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
}

/// `mbmf bench --json` is one object: a positive rate, and its time per step against EC's, for
/// every rule of SPEC 4 and 12 (and `combine = mix` where it applies) on tidy1, tidy2 and
/// twostep, the thread scaling, the whole commands, and the memory per instance.
#[test]
fn bench_json_is_one_object_with_every_rule_and_the_memory() {
    let output = mbmf()
        .args(["bench", "--json"])
        .output()
        .expect("mbmf runs");
    assert!(output.status.success(), "{output:?}");
    let text = String::from_utf8(output.stdout).unwrap();
    let report: serde_json::Value = serde_json::from_str(&text).expect("one JSON object");
    let rates = report["rates"].as_array().expect("rates");
    let has = |task: &str, controller: &str, combine: &str| {
        rates.iter().any(|r| {
            r["task"] == task
                && r["controller"] == controller
                && r["combine"] == combine
                && r["threads"] == 1
                && r["steps_per_s"].as_f64().is_some_and(|x| x > 0.0)
                // From the rules' table, which times each rule in pairs with EC.
                && r["time_over_ec"].as_f64().is_some_and(|x| x > 0.0)
        })
    };
    let all = [
        "mf",
        "mb",
        "rnd",
        "ec",
        "entropy",
        "fixed",
        "reliability",
        "vpi",
    ];
    for task in ["tidy1", "tidy2", "twostep"] {
        for controller in all {
            assert!(has(task, controller, "select"), "{controller} on {task}");
        }
        for controller in ["rnd", "ec", "entropy", "fixed", "reliability"] {
            assert!(has(task, controller, "mix"), "{controller} mix on {task}");
        }
        // `combine` does not apply to a single expert or to per-action values.
        for controller in ["mf", "mb", "vpi"] {
            assert!(!has(task, controller, "mix"), "{controller} mix on {task}");
        }
    }
    assert!(rates.iter().any(|r| r["threads"] == 2), "the 2-thread rate");
    // The whole commands: MF 4,096 runs x 3,000 steps and EC 1,024 x 1,000, on 1 and 2 threads.
    let wholes = report["whole_commands"].as_array().expect("whole commands");
    for (controller, runs, steps) in [("mf", 4096, 4096 * 3000), ("ec", 1024, 1024 * 1000)] {
        for threads in [1, 2] {
            assert!(
                wholes.iter().any(|w| w["controller"] == controller
                    && w["runs"] == runs
                    && w["agent_steps"] == steps
                    && w["threads"] == threads
                    && w["seconds"].as_f64().is_some_and(|s| s > 0.0)),
                "{controller} whole command on {threads} thread(s): {wholes:?}"
            );
        }
    }
    let state = report["memory"]["state_bytes_per_run"]
        .as_u64()
        .expect("bytes");
    assert!(
        (1024..=64 * 1024).contains(&state),
        "{state} bytes per tidy1 instance"
    );
    // The state of a tidy1 run of every rule, at most 64 KiB: an MF run holds no MB model.
    let by_rule = report["memory"]["state_bytes_per_run_by_rule"]
        .as_array()
        .expect("state by rule");
    let bytes = |controller: &str, combine: &str| {
        by_rule
            .iter()
            .find(|r| r["controller"] == controller && r["combine"] == combine)
            .and_then(|r| r["bytes"].as_u64())
            .unwrap_or_else(|| panic!("{controller} {combine}: {by_rule:?}"))
    };
    for controller in all {
        let held = bytes(controller, "select");
        assert!(
            (1024..=64 * 1024).contains(&held),
            "{controller}: {held} bytes per tidy1 run"
        );
    }
    assert!(bytes("mf", "select") < bytes("ec", "select"));
    // Every rule fits with either combine. Only EC weighs costs, in two f64 per state (tidy1's
    // 112); a mix keeps its distribution's entropy per state, and the weight too where that may
    // change, but not EC's, for want of room.
    for controller in ["rnd", "ec", "entropy", "fixed", "reliability"] {
        let held = bytes(controller, "mix");
        assert!(
            held <= 64 * 1024,
            "{controller} mix: {held} bytes per tidy1 run"
        );
    }
    let f64s = |n: u64| n * 112 * 8;
    // A run holding neither of those tables keeps 24 more softmaxes (16 MF, 8 MB) in their
    // room, each 7 f64 and the u32 of the state it holds.
    let slots = |n: u64| n * (7 * 8 + 4);
    assert_eq!(
        bytes("ec", "select") + slots(24),
        bytes("rnd", "select") + f64s(2)
    );
    assert_eq!(bytes("ec", "mix"), bytes("ec", "select"));
    assert_eq!(
        bytes("fixed", "mix") + slots(24),
        bytes("fixed", "select") + f64s(1)
    );
    assert_eq!(
        bytes("rnd", "mix") + slots(24),
        bytes("rnd", "select") + f64s(1)
    );
    assert_eq!(
        bytes("reliability", "mix") + slots(24),
        bytes("reliability", "select") + f64s(2)
    );
    assert_eq!(
        bytes("entropy", "mix") + slots(24),
        bytes("entropy", "select") + f64s(2)
    );
    let refused = mbmf()
        .args(["bench", "--json", "--growth"])
        .output()
        .expect("mbmf runs");
    assert_eq!(refused.status.code(), Some(2), "{refused:?}");
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--growth"));
}
