//! Changes during a run (SPEC 10) end to end: `mbmf run --change ...` on tidy1 and on the
//! authors' navigation world, the columns it reports, and the refusal of bad schedules.

mod common;

use std::path::Path;

use arrow::array::{Array, Float64Array, StringArray};
use arrow::datatypes::DataType;
use arrow::record_batch::RecordBatch;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use common::{run as mbmf, run_quiet};

/// The navigation world's folder, or `None` as [`common::navworld_task`] says.
fn nav_dir() -> Option<String> {
    common::navworld_task()?;
    let model = Path::new(common::NAVWORLD);
    Some(model.parent()?.to_str()?.to_owned())
}

fn read_runs(dir: &Path) -> RecordBatch {
    let file = std::fs::File::open(dir.join("runs.parquet")).unwrap();
    let batches: Vec<RecordBatch> = ParquetRecordBatchReaderBuilder::try_new(file)
        .unwrap()
        .build()
        .unwrap()
        .map(Result::unwrap)
        .collect();
    arrow::compute::concat_batches(&batches[0].schema(), &batches).unwrap()
}

/// A column as floats (whatever its integer or float type), nulls as `None`.
fn numbers(batch: &RecordBatch, name: &str) -> Vec<Option<f64>> {
    let col = batch.column(batch.schema().index_of(name).unwrap());
    let col = arrow::compute::cast(col, &DataType::Float64).unwrap();
    let col = col.as_any().downcast_ref::<Float64Array>().unwrap();
    (0..col.len())
        .map(|i| (!col.is_null(i)).then(|| col.value(i)))
        .collect()
}

fn strings(batch: &RecordBatch, name: &str) -> Vec<String> {
    let col = batch.column(batch.schema().index_of(name).unwrap());
    let col = col.as_any().downcast_ref::<StringArray>().unwrap();
    (0..col.len()).map(|i| col.value(i).to_string()).collect()
}

#[test]
fn a_box_assignment_change_on_tidy1_is_reported_with_reward_before_after_and_recovery() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("boxes");
    run_quiet(
        &out,
        &[
            "--controller",
            "mf,mb",
            "--runs",
            "2",
            "--steps",
            "3000",
            "--change",
            "1500:boxes=brg",
        ],
    );
    let runs = read_runs(&out);
    assert_eq!(runs.num_rows(), 4);
    for text in strings(&runs, "schedule") {
        assert_eq!(text, "1500:boxes=brg");
    }
    let total = numbers(&runs, "total_reward");
    let before = numbers(&runs, "reward_before_change");
    let after = numbers(&runs, "reward_after_change");
    for i in 0..4 {
        assert_eq!(numbers(&runs, "first_change_step")[i], Some(1500.0));
        let (b, a) = (before[i].unwrap(), after[i].unwrap());
        assert_eq!(b + a, total[i].unwrap());
        // A recovery, when there is one, is at least 1 step and within the run.
        if let Some(r) = numbers(&runs, "recovery_steps")[i] {
            assert!((1.0..=1501.0).contains(&r), "{r}");
        }
    }
    // Without changes the columns are empty.
    let plain = dir.path().join("plain");
    run_quiet(
        &plain,
        &["--controller", "mf", "--runs", "1", "--steps", "200"],
    );
    let runs = read_runs(&plain);
    assert_eq!(strings(&runs, "schedule"), [""]);
    assert_eq!(numbers(&runs, "first_change_step"), [None]);
    assert_eq!(numbers(&runs, "recovery_steps"), [None]);
    assert_eq!(numbers(&runs, "reward_after_change"), [None]);
}

#[test]
fn bad_schedules_exit_2_with_a_message_naming_the_event() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    let out = out.to_str().unwrap();
    for (args, needle) in [
        (vec!["--change", "20000:boxes=brg"], "20000:boxes=brg"),
        (vec!["--change", "5:goal=3"], "use boxes"),
        (vec!["--change", "5:boxes=rrb"], "permutation"),
        (vec!["--change", "5:gaol=3"], "did you mean 'goal'"),
        (
            vec!["--task", "tidy2", "--change", "5:boxes=brg"],
            "tidy2 keeps",
        ),
        (
            vec!["--change", "5:world=json:nowhere.json"],
            "5:world=json:nowhere.json",
        ),
    ] {
        let mut all = vec!["run", "--runs", "1", "--steps", "100", "--quiet"];
        all.extend(args.iter().copied());
        all.extend(["--out", out]);
        let output = mbmf(&all);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{all:?}: {stderr}");
        assert!(stderr.contains(needle), "{all:?}: {stderr}");
    }
}

#[test]
fn the_authors_goal_change_on_the_navigation_world_runs_and_reports_recovery() {
    let Some(nav) = nav_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nav");
    let world = format!("json:{nav}/realisticNavWorld.json");
    let new_goal = format!("1601:world=json:{nav}/realisticNavWorld_newGoal.json");
    run_quiet(
        &out,
        &[
            "--task",
            &world,
            "--controller",
            "mf,mb,ec",
            "--runs",
            "3",
            "--change",
            "1601:goal=34",
            "--change",
            &new_goal,
            "--steps",
            "3200",
        ],
    );
    let runs = read_runs(&out);
    assert_eq!(runs.num_rows(), 9);
    let recovery = numbers(&runs, "recovery_steps");
    for (i, text) in strings(&runs, "schedule").iter().enumerate() {
        assert_eq!(text, &format!("1601:goal=34;{new_goal}"));
        assert_eq!(numbers(&runs, "first_change_step")[i], Some(1601.0));
    }
    let before: f64 = numbers(&runs, "reward_before_change")
        .iter()
        .flatten()
        .sum();
    assert!(before > 0.0, "the old goal was found before the change");
    // The new goal is found: most runs recover within the 1,600 steps left.
    let recovered = recovery.iter().filter(|r| r.is_some()).count();
    assert!(recovered >= 6, "recovery_steps {recovery:?}");
    // Events the world cannot take are refused (exit 2), naming the event.
    let refusal = |change: &str| {
        let output = mbmf(&[
            "run",
            "--task",
            &world,
            "--change",
            change,
            "--steps",
            "3200",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        stderr
    };
    let stderr = refusal("1601:goal=99");
    assert!(
        stderr.contains("1601:goal=99") && stderr.contains("does not exist"),
        "{stderr}"
    );
    let stderr = refusal("1601:delete=20-22");
    assert!(stderr.contains("no transition 20 -> 22"), "{stderr}");
}

#[test]
fn a_tidy1_run_with_a_box_change_and_a_nuisance_still_holds_under_64_kib_of_state() {
    use mbmf::batch::{Batch, RunConfig};
    use mbmf::params::{HumanParams, Interaction, Params};
    use mbmf::schedule::Schedule;
    use std::sync::Arc;
    let spec = Arc::new(mbmf::env::load("tidy1").unwrap());
    let per_run = |params: Params, schedule: &str| {
        let configs: Vec<RunConfig> = (0..16)
            .map(|i| RunConfig {
                params,
                seed: 1,
                run_index: i,
            })
            .collect();
        let schedules = [Schedule::parse(schedule).unwrap()];
        let batch =
            Batch::with_schedules(Arc::clone(&spec), configs, &schedules, &[0; 16]).unwrap();
        batch.state_bytes() / 16
    };
    let plain = per_run(Params::default(), "");
    let nuisance = Params {
        human: HumanParams {
            interaction: Interaction::Nuisance,
            budget: 300,
            ..HumanParams::default()
        },
        ..Params::default()
    };
    let changing = per_run(nuisance, "5000:boxes=brg;7000:boxes=gbr");
    eprintln!(
        "state per tidy1 run: {plain} B without changes, {changing} B with two box changes and a nuisance"
    );
    assert!(plain < 64 * 1024 && changing < 64 * 1024);
    // The extra outcomes of a nuisance cost 11 bytes each per run (count, reward, terminal):
    // 48 relevant puts per box assignment, three assignments.
    assert!(
        changing > plain && changing - plain <= 3 * 48 * 11 + 16,
        "{plain} {changing}"
    );
}

#[test]
fn a_sweep_grid_over_schedules_runs_each_with_its_changes() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("changes.toml");
    std::fs::write(
        &file,
        "# A grid over the step of a box change, and a nuisance arriving mid-run.\n\
         seeds = 2\n\
         [fixed]\n\
         task = \"tidy1\"\n\
         steps = 600\n\
         babbling = 100\n\
         [grid]\n\
         change = [\"\", \"300:boxes=brg\", \"400:boxes=brg\", \"200:interaction=nuisance;200:budget=20\"]\n\
         controller = [\"mf\", \"ec\"]\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = mbmf(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(output.status.success(), "{output:?}");
    let mut runs = Vec::new();
    for entry in std::fs::read_dir(out.join("runs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "parquet") {
            let file = std::fs::File::open(&path).unwrap();
            for batch in ParquetRecordBatchReaderBuilder::try_new(file)
                .unwrap()
                .build()
                .unwrap()
            {
                runs.push(batch.unwrap());
            }
        }
    }
    let runs = arrow::compute::concat_batches(&runs[0].schema(), &runs).unwrap();
    assert_eq!(runs.num_rows(), 16);
    let schedules = strings(&runs, "schedule");
    let first = numbers(&runs, "first_change_step");
    let nuisances = numbers(&runs, "nuisances");
    for i in 0..16 {
        let expected = match schedules[i].as_str() {
            "" => None,
            "300:boxes=brg" => Some(300.0),
            "400:boxes=brg" => Some(400.0),
            "200:interaction=nuisance;200:budget=20" => Some(200.0),
            other => panic!("unexpected schedule {other}"),
        };
        assert_eq!(first[i], expected, "{}", schedules[i]);
        let nuisance = schedules[i].contains("nuisance");
        assert_eq!(nuisances[i].unwrap() > 0.0, nuisance, "{}", schedules[i]);
    }
    // A bad schedule is refused when the file is read, naming the key and the event.
    std::fs::write(
        &file,
        "# bad\n[grid]\nchange = [\"300:boxes=brg\", \"300:goal=3\"]\n",
    )
    .unwrap();
    let output = mbmf(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("300:goal=3") && stderr.contains("change"),
        "{stderr}"
    );
}
