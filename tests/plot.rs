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
        stdout.contains("controller=mb: 2 runs, 4 checkpoints (steps 100 to 400)"),
        "{stdout}"
    );
    assert!(
        stdout.contains("controller=mf: 2 runs, 4 checkpoints (steps 100 to 400)"),
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

#[test]
fn plot_x_draws_response_curves_and_a_numeric_by_gets_a_colour_bar() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = common::write_sweep(
        dir.path(),
        "kappa.toml",
        "seeds = 3\n[fixed]\nsteps = 200\n[grid]\ncontroller = [\"mf\", \"ec\"]\n\
         kappa_coeff = [1, 5, 9]\n",
    );
    let out = dir.path().join("kappa");
    let d = out.to_str().unwrap();
    let made = mbmf(&["sweep", &sweep, "--out", d, "--quiet"]);
    assert!(made.status.success(), "{made:?}");

    let output = mbmf(&[
        "plot",
        d,
        "--x",
        "kappa_coeff",
        "--metric",
        "total_reward",
        "--by",
        "controller",
    ]);
    assert!(output.status.success(), "{output:?}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    for group in ["ec", "mf"] {
        assert!(
            stdout.contains(&format!(
                "controller={group}: 9 runs at 3 values of kappa_coeff"
            )),
            "{stdout}"
        );
    }
    let svg =
        std::fs::read_to_string(out.join("analysis/total_reward-vs-kappa_coeff-by-controller.svg"))
            .unwrap();
    for text in ["kappa_coeff", "total_reward (mean, 95% CI)", "ec", "mf"] {
        assert!(
            svg.contains(&format!("\n{text}\n")),
            "the SVG lacks '{text}'"
        );
    }
    // Without --by: one curve of every run; the metric defaults to total_reward.
    let output = mbmf(&["plot", d, "--x", "kappa_coeff"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("all runs: 18 runs at 3 values of kappa_coeff"),
        "{stdout}"
    );
    assert!(
        out.join("analysis/total_reward-vs-kappa_coeff.png")
            .is_file()
    );

    // Curves over time grouped by a number: a colour bar, not a legend entry per value.
    let output = mbmf(&["plot", d, "--by", "kappa_coeff"]);
    assert!(output.status.success(), "{output:?}");
    let svg = std::fs::read_to_string(out.join("analysis/cum_reward-by-kappa_coeff.svg")).unwrap();
    assert!(svg.contains("\nkappa_coeff\n"), "no colour bar title");
    assert!(!svg.contains("kappa_coeff=1"), "a legend entry per value");
}

#[test]
fn plot_x_refuses_columns_that_are_not_numbers_naming_the_numeric_ones() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let d = out.to_str().unwrap();
    run_quiet(
        &out,
        &["--controller", "mf", "--runs", "2", "--steps", "100"],
    );
    for (args, needles) in [
        (
            vec!["--x", "controller"],
            vec![
                "column 'controller' holds text, but --x needs a numeric column",
                "numeric columns: ",
            ],
        ),
        (
            vec!["--x", "kappa_coeff", "--metric", "interaction"],
            vec![
                "--metric needs a numeric column",
                "did you mean 'interactions'?",
            ],
        ),
        (
            vec!["--x", "kapa"],
            vec!["no column 'kapa' (did you mean 'kappa_coeff'?)"],
        ),
        (vec![], vec!["--by"]),
    ] {
        let mut all = vec!["plot", d];
        all.extend(args);
        let output = mbmf(&all);
        assert_eq!(output.status.code(), Some(2), "{all:?}: {output:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        for needle in needles {
            assert!(stderr.contains(needle), "{all:?}: {stderr}");
        }
    }
    assert!(
        !out.join("analysis").exists(),
        "no figure for a refused plot"
    );
}

/// A curve that averages several conditions says which parameters vary within it, over time
/// and in a response curve; curves of single conditions say nothing.
#[test]
fn plot_names_the_parameters_that_vary_within_a_curve() {
    let dir = tempfile::tempdir().unwrap();
    let file = common::write_sweep(
        dir.path(),
        "k.toml",
        "seeds = 2\n[fixed]\nsteps = 200\nbabbling = 20\ncheckpoint = 100\n\
         [grid]\ncontroller = [\"mf\", \"ec\"]\nkappa_coeff = [1, 9]\n",
    );
    let out = dir.path().join("k");
    let out_s = out.to_str().unwrap();
    common::run_ok(&["sweep", &file, "--out", out_s, "--quiet"]);
    let stdout = |args: &[&str]| {
        let o = common::run_ok(&[&["plot", out_s][..], args].concat());
        String::from_utf8(o.stdout).unwrap()
    };
    let mixed = "within groups these parameters also vary: kappa_coeff;";
    assert!(stdout(&["--by", "controller"]).contains(mixed));
    let held = stdout(&["--by", "controller", "--where", "kappa_coeff=9"]);
    assert!(!held.contains("also vary"), "{held}");
    assert!(stdout(&["--x", "kappa_coeff"]).contains("also vary: controller;"));
    let response = stdout(&["--x", "kappa_coeff", "--by", "controller"]);
    assert!(!response.contains("also vary"), "{response}");
}
