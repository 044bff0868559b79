//! `mbmf plot` end to end: curves of a real run with a change, the files it writes and where,
//! and the refusal of a bad metric or filter.

mod common;

use common::{run as mbmf, run_quiet};

#[test]
fn plot_draws_one_curve_per_group_with_the_change_marked_beside_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    run_quiet(
        &out,
        &[
            "--controller",
            "mf,mb",
            "--runs",
            "2",
            "--steps",
            "400",
            "--checkpoint",
            "100",
            "--change",
            "200:boxes=brg",
        ],
    );

    let output = mbmf(&["plot", out_s, "--by", "controller", "--metric", "cum_cost"]);
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("controller=mb: 2 runs, 4 steps"),
        "{stdout}"
    );
    assert!(
        stdout.contains("controller=mf: 2 runs, 4 steps"),
        "{stdout}"
    );
    assert!(stdout.contains("changes marked at step 200"), "{stdout}");
    let figures = out.join("analysis");
    let svg = std::fs::read_to_string(figures.join("cum_cost-by-controller.svg")).unwrap();
    for text in ["mb", "mf", "cumulative inference cost", "experiment step"] {
        assert!(svg.contains(text), "the SVG lacks '{text}'");
    }
    assert!(figures.join("cum_cost-by-controller.png").is_file());
    // Figures never land among the Parquet files.
    for entry in std::fs::read_dir(&out).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            !name.ends_with(".svg") && !name.ends_with(".png"),
            "{name} beside the data"
        );
    }

    // A filter keeps its runs only, and names the file.
    let elsewhere = dir.path().join("figs");
    let output = mbmf(&[
        "plot",
        out_s,
        "--by",
        "controller",
        "--where",
        "controller=mb",
        "--out",
        elsewhere.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(!stdout.contains("controller=mf"), "{stdout}");
    assert!(
        elsewhere
            .join("cum_reward-by-controller-controller-mb.svg")
            .is_file()
    );
}

#[test]
fn a_bad_metric_column_or_filter_exits_2_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    run_quiet(
        &out,
        &["--controller", "mf", "--runs", "1", "--steps", "100"],
    );
    for (args, needle) in [
        (vec!["--by", "controller", "--metric", "reward"], "'reward'"),
        (vec!["--by", "controler"], "controller"),
        (vec!["--by", "controller", "--where", "controller=ec"], "mf"),
    ] {
        let mut all = vec!["plot", out_s];
        all.extend(args);
        let output = mbmf(&all);
        assert_eq!(output.status.code(), Some(2), "{all:?}: {output:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(needle), "{all:?}: {stderr}");
    }
    assert!(
        !out.join("analysis").exists(),
        "no figure for a refused plot"
    );
}
