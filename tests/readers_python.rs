//! The files every common reader opens: a `mbmf run` folder and a `mbmf sweep` dataset are read
//! with an old polars (1.20) and pyarrow 14 (`.venv-old`), and with current polars, pandas,
//! pyarrow and DuckDB (`.venv`), both made by `scripts/python-env.sh`. pyarrow must report
//! min/max statistics for the float sweep axes, or a filter on them reads every row group. A
//! dependency bump that brings back a footer old readers refuse fails here. Skipped with a message
//! when a venv is missing, except under CI=true.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::*;

/// Runs `script` with `args` and parses the JSON it prints.
fn run_script(py: &Path, script: &str, args: &[&Path]) -> serde_json::Value {
    let out = Command::new(py)
        .args(["-c", script])
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{} failed:\n{}",
        py.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{} printed no JSON ({e}):\n{}",
            py.display(),
            String::from_utf8_lossy(&out.stdout)
        )
    })
}

/// A `mbmf run` folder and a sweep dataset (several parts, one resumed), written once.
struct Written {
    _dir: tempfile::TempDir,
    run: PathBuf,
    sweep: PathBuf,
}

fn write_both() -> Written {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    run_ok(&[
        "run",
        "--task",
        "tidy1",
        "--controller",
        "mf,ec",
        "--runs",
        "3",
        "--steps",
        "300",
        "--babbling",
        "50",
        "--checkpoint",
        "100",
        "--kappa-coeff",
        "1.5",
        "--out",
        run.to_str().unwrap(),
        "--quiet",
    ]);
    let file = write_sweep(dir.path(), "small.toml", SMALL);
    let sweep = dir.path().join("sweep");
    sweep_in_two_parts(&file, &sweep);
    Written {
        _dir: dir,
        run,
        sweep,
    }
}

/// Shared by both venvs: row counts with polars and pyarrow, and pyarrow's statistics of the
/// float columns in every row group.
const COMMON: &str = r#"
import glob, json, sys
import polars as pl
import pyarrow.parquet as pq

run, sweep = sys.argv[1], sys.argv[2]
files = {
    "run_runs": [f"{run}/runs.parquet"],
    "run_series": [f"{run}/series.parquet"],
    "sweep_runs": sorted(glob.glob(f"{sweep}/runs/*.parquet")),
    "sweep_series": sorted(glob.glob(f"{sweep}/series/*.parquet")),
}
out = {"polars": pl.__version__, "pyarrow": __import__("pyarrow").__version__}
for name, paths in files.items():
    out[f"polars_{name}"] = pl.scan_parquet(paths).select(pl.len()).collect().item()
    out[f"polars_{name}_reward"] = float(
        pl.read_parquet(paths).select(
            pl.col("total_reward" if name.endswith("runs") else "cum_reward").sum()
        ).item()
    )
    out[f"pyarrow_{name}"] = sum(pq.read_table(p).num_rows for p in paths)
    stats = {}
    for p in paths:
        md = pq.ParquetFile(p).metadata
        for g in range(md.num_row_groups):
            rg = md.row_group(g)
            for c in range(rg.num_columns):
                col = rg.column(c)
                if col.path_in_schema in ("kappa_coeff", "zeta", "forget_prob"):
                    s = col.statistics
                    ok = s is not None and s.has_min_max
                    stats.setdefault(col.path_in_schema, []).append(
                        [s.min, s.max] if ok else None
                    )
    out[f"stats_{name}"] = stats
"#;

const CURRENT: &str = r#"
import duckdb
import pandas as pd
out["pandas"] = pd.__version__
out["duckdb"] = duckdb.__version__
out["pandas_run_runs"] = len(pd.read_parquet(f"{run}/runs.parquet"))
out["pandas_sweep_runs"] = len(pd.read_parquet(f"{sweep}/runs"))
out["pandas_sweep_series"] = len(pd.read_parquet(f"{sweep}/series", dtype_backend="pyarrow"))
con = duckdb.connect()
for name, glob_ in [("run", f"{run}/runs.parquet"), ("sweep", f"{sweep}/runs/*.parquet")]:
    n, reward = con.sql(
        f"SELECT count(*), sum(total_reward) FROM read_parquet('{glob_}')"
    ).fetchone()
    out[f"duckdb_{name}_runs"] = n
    out[f"duckdb_{name}_reward"] = reward
    out[f"duckdb_{name}_series"] = con.sql(
        f"SELECT count(*) FROM read_parquet('{glob_.replace('runs', 'series')}')"
    ).fetchone()[0]
# Signed counts: a difference is negative, not 1.8e19.
out["pandas_mb_minus_decisions_min"] = int(
    (lambda t: (t["mb_decisions"] - t["decisions"]).min())(pd.read_parquet(f"{run}/runs.parquet"))
)
out["duckdb_mb_minus_decisions_min"] = con.sql(
    f"SELECT min(mb_decisions - decisions) FROM read_parquet('{run}/runs.parquet')"
).fetchone()[0]
out["polars_dtypes"] = {
    c: str(t) for c, t in pl.read_parquet_schema(f"{run}/runs.parquet").items()
}
# Provenance and column documentation.
pf = pq.ParquetFile(f"{run}/runs.parquet")
kv = {k.decode(): v.decode() for k, v in pf.metadata.metadata.items() if k != b"ARROW:schema"}
out["meta"] = kv
field = pf.schema_arrow.field("kappa_coeff")
out["kappa_doc"] = {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}
out["sweep_meta"] = {
    k.decode(): v.decode()
    for k, v in pq.ParquetFile(files["sweep_runs"][0]).metadata.metadata.items()
    if k != b"ARROW:schema"
}
print(json.dumps(out))
"#;

/// After `mbmf pareto` and `mbmf min-budget` on a dataset (and on a sweep's `runs/` folder), the
/// data folders hold only data: globs and folder reads still see the runs alone.
const AFTER_ANALYSIS: &str = r#"
import glob, json, sys
import pandas as pd
import polars as pl
run, sweep = sys.argv[1], sys.argv[2]
print(json.dumps({
    "pandas_sweep_runs": len(pd.read_parquet(f"{sweep}/runs")),
    "polars_sweep_runs": pl.scan_parquet(f"{sweep}/runs/**/*.parquet").select(pl.len()).collect().item(),
    "polars_run_runs": pl.scan_parquet(f"{run}/runs.parquet").select(pl.len()).collect().item(),
    "analysis": sorted(glob.glob(f"{sweep}/analysis/*") + glob.glob(f"{run}/analysis/*")),
    "pareto_rows": pl.read_parquet(f"{sweep}/analysis/pareto.parquet").height,
}))
"#;

const OLD: &str = r#"
print(json.dumps(out))
"#;

fn sum(rows: &[Row], column: &str) -> f64 {
    rows.iter().map(|r| r[column].parse::<f64>().unwrap()).sum()
}

/// Checks what both venvs report against the files as this crate reads them.
fn check_common(got: &serde_json::Value, w: &Written) {
    let who = format!("polars {} / pyarrow {}", got["polars"], got["pyarrow"]);
    let run_runs = file_rows(&w.run.join("runs.parquet"), &[]);
    let run_series = file_rows(&w.run.join("series.parquet"), &[]);
    let (sweep_runs, sweep_series) = dataset(&w.sweep);
    for (name, rows, reward) in [
        ("run_runs", &run_runs, "total_reward"),
        ("run_series", &run_series, "cum_reward"),
        ("sweep_runs", &sweep_runs, "total_reward"),
        ("sweep_series", &sweep_series, "cum_reward"),
    ] {
        assert!(!rows.is_empty(), "{name}: no rows written");
        assert_eq!(got[format!("polars_{name}")], rows.len(), "{who}: {name}");
        assert_eq!(got[format!("pyarrow_{name}")], rows.len(), "{who}: {name}");
        let want = sum(rows, reward);
        let have = got[format!("polars_{name}_reward")].as_f64().unwrap();
        assert!(
            (have - want).abs() <= 1e-9 * want.abs().max(1.0),
            "{who}: {name} {have} != {want}"
        );
        // Float statistics in every row group of every file, with the values written.
        let stats = &got[format!("stats_{name}")];
        for column in ["kappa_coeff", "zeta", "forget_prob"] {
            let groups = stats[column]
                .as_array()
                .unwrap_or_else(|| panic!("{who}: {name}: no column {column} in {stats}"));
            assert!(!groups.is_empty());
            let values: Vec<f64> = rows.iter().map(|r| r[column].parse().unwrap()).collect();
            let lo = values.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            for g in groups {
                let mm = g.as_array().unwrap_or_else(|| {
                    panic!("{who}: {name}: pyarrow reports no min/max for {column}: {stats}")
                });
                let (min, max) = (mm[0].as_f64().unwrap(), mm[1].as_f64().unwrap());
                assert!(
                    lo <= min && min <= max && max <= hi,
                    "{who}: {name} {column} {mm:?}"
                );
            }
        }
    }
    // The value the run was given arrives as a statistic.
    assert_eq!(
        got["stats_run_runs"]["kappa_coeff"][0],
        serde_json::json!([1.5, 1.5])
    );
}

#[test]
fn old_polars_and_pyarrow_14_read_run_and_sweep_files_with_float_statistics() {
    let Some(py) = venv_python("MBMF_PYTHON_OLD", ".venv-old", "polars, pyarrow") else {
        return;
    };
    let w = write_both();
    let got = run_script(&py, &format!("{COMMON}{OLD}"), &[&w.run, &w.sweep]);
    assert_eq!(got["polars"], "1.20.0", "{got}");
    assert_eq!(got["pyarrow"], "14.0.2", "{got}");
    check_common(&got, &w);
}

#[test]
fn current_polars_pandas_pyarrow_and_duckdb_read_run_and_sweep_files() {
    let Some(py) = venv_python("MBMF_PYTHON", ".venv", "polars, pyarrow, pandas, duckdb") else {
        return;
    };
    let w = write_both();
    let got = run_script(&py, &format!("{COMMON}{CURRENT}"), &[&w.run, &w.sweep]);
    check_common(&got, &w);
    let (sweep_runs, sweep_series) = dataset(&w.sweep);
    let run_runs = file_rows(&w.run.join("runs.parquet"), &[]);
    assert_eq!(got["pandas_run_runs"], run_runs.len());
    assert_eq!(got["pandas_sweep_runs"], sweep_runs.len());
    assert_eq!(got["pandas_sweep_series"], sweep_series.len());
    assert_eq!(got["duckdb_run_runs"], run_runs.len());
    assert_eq!(got["duckdb_sweep_runs"], sweep_runs.len());
    assert_eq!(got["duckdb_sweep_series"], sweep_series.len());
    let want = sum(&sweep_runs, "total_reward");
    let have = got["duckdb_sweep_reward"].as_f64().unwrap();
    assert!((have - want).abs() <= 1e-9 * want.abs().max(1.0));

    // mf never gives MB a decision: the difference is minus the decisions, in every reader.
    let mf_decisions: i64 = run_runs
        .iter()
        .filter(|r| r["controller"] == "mf")
        .map(|r| r["decisions"].parse::<i64>().unwrap())
        .max()
        .unwrap();
    assert_eq!(got["pandas_mb_minus_decisions_min"], -mf_decisions);
    assert_eq!(got["duckdb_mb_minus_decisions_min"], -mf_decisions);
    let dtypes = &got["polars_dtypes"];
    for c in [
        "run_index",
        "config_index",
        "seed_index",
        "decisions",
        "mb_decisions",
        "budget",
        "steps",
    ] {
        assert_eq!(dtypes[c], "Int64", "{c}: {dtypes}");
    }
    assert_eq!(dtypes["master_seed"], "UInt64");
    assert!(dtypes.get("seed").is_none(), "{dtypes}");

    let meta = &got["meta"];
    assert_eq!(meta["mbmf_schema"], "runs/2");
    let commit = meta["mbmf_git_commit"].as_str().unwrap();
    assert!(commit == "unknown" || commit.len() == 40, "{commit}");
    for key in [
        "mbmf_git_dirty",
        "mbmf_rustc",
        "mbmf_target",
        "mbmf_host",
        "mbmf_started_utc",
        "mbmf_ended_utc",
        "mbmf_threads",
        "mbmf_command",
        "mbmf_run_id",
        "master_seed",
    ] {
        assert!(meta.get(key).is_some_and(|v| v != ""), "no {key} in {meta}");
    }
    assert!(
        meta["mbmf_command"]
            .as_str()
            .unwrap()
            .contains("--kappa-coeff 1.5")
    );
    assert!(meta["mbmf_started_utc"].as_str().unwrap() <= meta["mbmf_ended_utc"].as_str().unwrap());
    assert_eq!(got["kappa_doc"]["unit"], "1/bit");
    let sweep_meta = &got["sweep_meta"];
    assert_eq!(sweep_meta["mbmf_schema"], "runs/2");
    assert!(
        sweep_meta["mbmf_command"]
            .as_str()
            .unwrap()
            .contains("--shard 0/2")
            || sweep_meta["mbmf_command"]
                .as_str()
                .unwrap()
                .contains("--resume")
    );
    assert_eq!(
        sweep_meta["mbmf_sweep_sha256"].as_str().unwrap().len(),
        64,
        "{sweep_meta}"
    );

    // Analysis outputs go to analysis/, never among the data files.
    let s = w.sweep.to_str().unwrap();
    let runs_folder = w.sweep.join("runs");
    run_ok(&["pareto", s, "--no-plot"]);
    run_ok(&["pareto", runs_folder.to_str().unwrap(), "--no-plot"]);
    run_ok(&["min-budget", s]);
    run_ok(&["pareto", w.run.to_str().unwrap()]);
    let after = run_script(&py, AFTER_ANALYSIS, &[&w.run, &w.sweep]);
    assert_eq!(after["pandas_sweep_runs"], sweep_runs.len(), "{after}");
    assert_eq!(after["polars_sweep_runs"], sweep_runs.len(), "{after}");
    assert_eq!(after["polars_run_runs"], run_runs.len(), "{after}");
    assert!(after["pareto_rows"].as_u64().unwrap() > 0);
    let mut written: Vec<String> = after["analysis"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap().rsplit('/').next().unwrap().to_string())
        .collect();
    written.sort();
    assert_eq!(
        written,
        [
            "min_budget.parquet",
            "pareto.parquet",
            "pareto.parquet",
            "pareto.png",
            "pareto.svg"
        ]
    );
}
