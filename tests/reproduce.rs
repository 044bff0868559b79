//! `mbmf reproduce --quick` end to end: data, every figure, and a report that goes through every
//! claim of SPEC 9 with a verdict.

use std::process::Command;

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
    for claim in [
        "1",
        "2",
        "3 (softmax MC)",
        "3 (argmax MC)",
        "4",
        "5",
        "6",
        "T2-a",
        "T2-b",
    ] {
        let heading = format!("### Claim {claim}:");
        let at = report
            .find(&heading)
            .unwrap_or_else(|| panic!("no {heading} in the report"));
        let verdict = &report[at..];
        assert!(
            ["**holds.**", "**partly holds.**", "**does not hold.**"]
                .iter()
                .any(|v| verdict.lines().nth(2).is_some_and(|l| l.starts_with(v))),
            "claim {claim} has no verdict"
        );
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

    // The data behind it: 4 runs per condition.
    for table in ["runs.parquet", "series.parquet"] {
        assert!(
            std::fs::metadata(out.join("data").join(table))
                .unwrap()
                .len()
                > 0
        );
    }
}
