//! Users' tools read a sweep dataset: polars `scan_parquet("DIR/runs/*.parquet")`
//! and pandas `read_parquet("DIR/runs")`, with the real packages installed in `.venv` by
//! `scripts/python-env.sh`. Skipped with a message when the venv is missing, except under CI.

mod common;

use std::process::Command;

use common::*;

const SCRIPT: &str = r#"
import json, sys
import pandas as pd
import polars as pl

d = sys.argv[1]
runs = pl.scan_parquet(f"{d}/runs/*.parquet").collect()
series = pl.scan_parquet(f"{d}/series/*.parquet").collect()
by_controller = (
    runs.group_by("controller").agg(pl.col("total_reward").sum()).sort("controller").rows()
)
meta = pl.read_parquet_metadata(sorted(__import__("glob").glob(f"{d}/runs/*.parquet"))[0])
pruns = pd.read_parquet(f"{d}/runs")
pseries = pd.read_parquet(f"{d}/series")
print(json.dumps({
    "polars_runs": runs.height,
    "polars_series": series.height,
    "polars_reward": float(runs["total_reward"].sum()),
    "polars_by_controller": by_controller,
    "polars_columns": runs.columns,
    "polars_run_index_dtype": str(runs["run_index"].dtype),
    "pandas_runs": len(pruns),
    "pandas_series": len(pseries),
    "pandas_reward": float(pruns["total_reward"].sum()),
    "pandas_seeds": sorted(int(s) for s in pruns["seed_index"].unique()),
    "meta_sweep": meta.get("mbmf_sweep"),
    "meta_seed": meta.get("master_seed"),
}))
"#;

#[test]
fn polars_scan_parquet_and_pandas_read_parquet_read_a_sweep_dataset() {
    let Some(py) = venv_python("MBMF_PYTHON", ".venv", "polars, pyarrow, pandas") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let out = dir.path().join("out");
    // Several parts, written by a resumed run, as users will meet them.
    sweep_in_two_parts(&file, &out);
    // Dotfiles and temporaries must not confuse the readers.
    std::fs::write(
        out.join("runs/.part-000099-000099.parquet.tmp-1"),
        "partial",
    )
    .unwrap();
    let result = Command::new(&py)
        .args(["-c", SCRIPT])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        result.status.success(),
        "python failed:\n{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let got: serde_json::Value = serde_json::from_slice(&result.stdout).unwrap();

    let (runs, series) = dataset(&out);
    let reward = |rows: &[Row]| -> f64 {
        rows.iter()
            .map(|r| r["total_reward"].parse::<f64>().unwrap())
            .sum()
    };
    let total = reward(&runs);
    assert_eq!(got["polars_runs"], 12);
    assert_eq!(got["pandas_runs"], 12);
    assert_eq!(got["polars_series"], series.len());
    assert_eq!(got["pandas_series"], series.len());
    assert_eq!(got["polars_reward"].as_f64(), Some(total));
    assert_eq!(got["pandas_reward"].as_f64(), Some(total));
    let ec: Vec<Row> = runs
        .iter()
        .filter(|r| r["controller"] == "ec")
        .cloned()
        .collect();
    assert_eq!(got["polars_by_controller"][0][0], "ec");
    assert_eq!(
        got["polars_by_controller"][0][1].as_f64(),
        Some(reward(&ec))
    );
    assert_eq!(got["pandas_seeds"], serde_json::json!([0, 1, 2]));
    assert_eq!(got["polars_run_index_dtype"], "Int64");
    let columns = got["polars_columns"].as_array().unwrap();
    for c in [
        "master_seed",
        "config_index",
        "seed_index",
        "kappa_coeff",
        "budget",
        "task",
    ] {
        assert!(columns.iter().any(|x| x == c), "no column {c}: {columns:?}");
    }
    assert_eq!(got["meta_sweep"], SMALL);
    assert_eq!(got["meta_seed"], "11");
}
