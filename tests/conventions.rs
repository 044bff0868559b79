//! The command-line conventions scripts rely on, through the built binary: shell completions, the
//! man page, `-q`, and `--json` summaries that parse and agree with the files written.

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

#[test]
fn short_quiet_is_quiet() {
    let dir = TempDir::new().expect("a temporary folder");
    let out = dir.path().join("run");
    let output = mbmf()
        .args(["run", "--runs", "2", "--steps", "200", "-q", "--out"])
        .arg(&out)
        .output()
        .expect("mbmf runs");
    assert!(output.status.success());
    assert!(output.stdout.is_empty(), "-q still printed the table");
    assert!(out.join("runs.parquet").is_file());
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
    std::fs::write(
        &sweep,
        "seeds = 3\nmaster_seed = 5\n[fixed]\ntask = \"tidy1\"\nsteps = 300\nbabbling = 100\n\
         controller = \"ec\"\ninteraction = \"takeover\"\n[grid]\nbudget = [0, 10]\n",
    )
    .expect("write the sweep");
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
