//! `mbmf reproduce --quick` end to end: data, every figure, a report that goes through every
//! claim of SPEC 9 with a verdict, and the sweep file of its conditions.

use std::process::Command;

mod common;

#[test]
fn quick_reproduction_writes_data_figures_and_a_verdict_for_every_claim() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("repro");
    let output = Command::new(env!("CARGO_BIN_EXE_mbmf"))
        .args(["reproduce", "--quick", "--runs", "4", "--quiet", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("| tidy1 | EC (argmax) | none | 0 | 4 |"),
        "{stdout}"
    );

    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    // Quick mode is too small for most claims (claims 1 and 4 flip between seeds 2020, 7 and 99),
    // but with 4 runs these verdicts came out the same for all three seeds: MB's cost far above
    // RND's, RND's above MF's, EC not within 2 x MF (claim 3); takeover helping every controller
    // but congratulation not all (claim 5); some of the paper's minimal budgets confirmed
    // (claim 6). The seed is fixed (2020), so this run is exactly one of those three.
    let expected = [
        ("1", None),
        ("2", None),
        ("3 (softmax MC)", Some("partly holds")),
        ("3 (argmax MC)", Some("partly holds")),
        ("4", None),
        ("5", Some("partly holds")),
        ("6", Some("partly holds")),
        ("T2-a", None),
        ("T2-b", None),
    ];
    for (claim, want) in expected {
        let heading = format!("### Claim {claim}:");
        let at = report
            .find(&heading)
            .unwrap_or_else(|| panic!("no {heading} in the report"));
        let line = report[at..].lines().nth(2).unwrap_or_default();
        let verdict = ["holds", "partly holds", "does not hold"]
            .into_iter()
            .find(|v| line.starts_with(&format!("**{v}.**")))
            .unwrap_or_else(|| panic!("claim {claim} has no verdict: {line}"));
        if let Some(want) = want {
            assert_eq!(verdict, want, "claim {claim}: {line}");
        }
    }
    assert!(report.contains("Quick mode"));

    // Every figure the report embeds exists as a PNG, beside its SVG.
    let mut figures = 0;
    for line in report.lines().filter(|l| l.starts_with("![")) {
        let rel = &line[line.find("](").unwrap() + 2..line.len() - 1];
        let png = std::fs::read(out.join(rel)).unwrap();
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{rel}");
        assert!(
            out.join(rel).with_extension("svg").exists(),
            "{rel} has no SVG"
        );
        figures += 1;
    }
    assert_eq!(
        figures, 15,
        "per task: 2 curves and 4 bar charts; figure 4; two budget scans"
    );

    // The data behind it: 4 runs per condition, numbered as a sweep numbers them.
    let data = out.join("data");
    let mut runs = common::file_rows(&data.join("runs.parquet"), common::NONDETERMINISTIC);
    assert_eq!(runs.len(), 27 * 4, "27 conditions of 4 runs");
    for row in &runs {
        let n = |c: &str| row[c].parse::<u64>().unwrap();
        assert_eq!(
            n("run_index"),
            n("config_index") * 4 + n("seed_index"),
            "{row:?}"
        );
    }
    // The conditions are a sweep, written beside the data: `mbmf sweep` runs the same runs.
    let sweep = out.join("sweep.toml");
    let again = dir.path().join("again");
    let (sweep, again_arg) = (sweep.to_str().unwrap(), again.to_str().unwrap());
    common::run_ok(&["sweep", sweep, "--out", again_arg, "--quiet"]);
    let (swept_runs, swept_series) = common::dataset(&again);
    common::sort_rows(&mut runs);
    common::assert_same_rows("reproduce's runs vs its sweep", &runs, &swept_runs);
    let mut series = common::file_rows(&data.join("series.parquet"), common::NONDETERMINISTIC);
    common::sort_rows(&mut series);
    common::assert_same_rows("reproduce's series vs its sweep", &series, &swept_series);
}
