//! The arbitration criteria of SPEC 12 end to end: `mbmf run` with `combine`, `reliability` and
//! `vpi`, read back from the Parquet files it writes.

mod common;

use common::{Row, file_rows, run, run_quiet};

fn runs_rows(dir: &std::path::Path) -> Vec<Row> {
    file_rows(&dir.join("runs.parquet"), &["wall_time_s"])
}

fn num(row: &Row, column: &str) -> f64 {
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column}: {}", row[column]))
}

#[test]
fn combine_is_ignored_by_single_expert_rules_and_vpi_and_recorded_as_given() {
    let tmp = tempfile::tempdir().unwrap();
    let (select, mix) = (tmp.path().join("select"), tmp.path().join("mix"));
    let args = ["--controller", "mf,mb,vpi", "--runs", "2", "--steps", "400"];
    run_quiet(&select, &[&args[..], &["--combine", "select"]].concat());
    run_quiet(&mix, &[&args[..], &["--combine", "mix"]].concat());
    let (a, b) = (runs_rows(&select), runs_rows(&mix));
    assert_eq!(a.len(), 6);
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(
            (x["combine"].as_str(), y["combine"].as_str()),
            ("select", "mix")
        );
        let mut x = x.clone();
        x.insert("combine".into(), "mix".into());
        assert_eq!(&x, y, "the same run whatever combine says");
    }
}

#[test]
fn fixed_with_mix_weighs_without_drawing_and_pays_both_experts() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    run_quiet(
        &out,
        &[
            "--controller",
            "fixed",
            "--combine",
            "mix",
            "--w-mb",
            "0.3",
            "--runs",
            "2",
            "--steps",
            "500",
        ],
    );
    for row in runs_rows(&out) {
        assert_eq!(row["combine"], "mix");
        assert!((num(&row, "p_mb_mean") - 0.3).abs() < 1e-12, "{row:?}");
        // A weight below 1/2 is never counted as an MB decision; both experts infer always.
        assert_eq!(num(&row, "mb_decisions"), 0.0);
        assert!(num(&row, "cost_mf") > 0.0 && num(&row, "cost_mb") > 0.0);
        let h = num(&row, "mean_entropy_chosen");
        assert!((0.0..=1.0).contains(&h), "{h}");
    }
}

#[test]
fn reliability_starts_at_rel_p0_and_moves_and_vpi_reports_a_share_of_actions() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    run_quiet(
        &out,
        &[
            "--controller",
            "reliability,vpi",
            "--runs",
            "2",
            "--steps",
            "1000",
            "--babbling",
            "0",
            "--checkpoint",
            "1",
        ],
    );
    let series = file_rows(&out.join("series.parquet"), &[]);
    for row in &series {
        if row["p_mb_mean"] == "null" {
            continue; // a reset step: no decision in the window
        }
        let p = num(row, "p_mb_mean");
        assert!((0.0..=1.0).contains(&p), "{row:?}");
        if row["controller"] == "reliability" && row["step"] == "1" {
            // The first decision reads P_MB before any transition: rel_p0.
            assert_eq!(p, 0.7);
        }
        if row["controller"] == "vpi" && row["step"] == "1" {
            // No reward yet: Rbar = 0 and every action is worth planning.
            assert_eq!(p, 1.0);
        }
    }
    let last_reliability = series
        .iter()
        .rfind(|r| r["controller"] == "reliability")
        .unwrap();
    assert_ne!(num(last_reliability, "p_mb_mean"), 0.7, "P_MB moves");
}

#[test]
fn out_of_range_arbiter_parameters_are_usage_errors() {
    for args in [
        ["--combine", "blend"],
        ["--rel-memory", "0"],
        ["--kalman-noise", "0"],
        ["--rel-p0", "1.5"],
    ] {
        let out = run(&[&["run", "--controller", "reliability"][..], &args[..]].concat());
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
    // A whole-number parameter names its own range, whichever rule the bad value breaks.
    for bad in ["-1", "1.5", "0", "10001"] {
        let out = run(&["run", "--controller", "reliability", "--rel-memory", bad]);
        assert_eq!(out.status.code(), Some(2), "{bad}");
        let e = String::from_utf8_lossy(&out.stderr);
        assert!(e.contains("--rel-memory"), "{bad}: {e}");
        assert!(e.contains("expected 1 to 10000 transitions"), "{bad}: {e}");
    }
}

/// A rule's own parameter given to rules that do not read it, and a mix given to rules it does
/// not apply to, are legal (sweeps cross them on purpose) but warned about in one run, naming
/// the flag and the rules; given to a rule that reads it, no warning.
#[test]
fn parameters_no_listed_rule_reads_are_warned_about() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let stderr = |args: &[&str]| {
        let base = [
            "run",
            "--runs",
            "1",
            "--steps",
            "20",
            "--quiet",
            "--force",
            "--out",
            out.to_str().unwrap(),
        ];
        let o = run(&[&base[..], args].concat());
        assert_eq!(o.status.code(), Some(0), "{args:?}");
        String::from_utf8(o.stderr).unwrap()
    };
    let e = stderr(&["--controller", "ec,mb", "--w-mb", "0.3", "--rel-p0", "0.2"]);
    assert!(
        e.contains(
            "--w-mb changes nothing here: only fixed reads it, and --controller lists ec, mb"
        ),
        "{e}"
    );
    assert!(
        e.contains("--rel-p0") && e.contains("only reliability"),
        "{e}"
    );
    let e = stderr(&["--controller", "vpi,fixed,mf", "--combine", "mix"]);
    assert!(
        e.contains("--combine mix does not apply to vpi, mf, which run as they would"),
        "{e}"
    );
    let e = stderr(&["--controller", "vpi", "--combine", "mix"]);
    assert!(
        e.contains("to vpi, which runs as it would with select (its rows record"),
        "{e}"
    );
    for quiet in [
        &["--controller", "fixed,ec", "--w-mb", "0.3"][..],
        &[
            "--controller",
            "vpi",
            "--vpi-tau",
            "0.2",
            "--kalman-noise",
            "0.1",
        ],
        &[
            "--controller",
            "reliability",
            "--combine",
            "mix",
            "--rel-memory",
            "5",
        ],
    ] {
        let e = stderr(quiet);
        assert!(!e.contains("warning"), "{quiet:?}: {e}");
    }
}
