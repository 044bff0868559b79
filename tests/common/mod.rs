//! Helpers shared by the integration tests: running the binary, reading a dataset back as
//! sorted rows (so two datasets compare regardless of how runs were split into parts), the
//! authors' data, the Python venvs of `scripts/python-env.sh`, and simulating configurations on a
//! chosen number of threads. Each test file uses some of them.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::fs::File;
use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use arrow::record_batch::RecordBatch;
use arrow::util::display::array_value_to_string;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::sync::Arc;

use mbmf::batch::{Batch, RunConfig};
use mbmf::env::{self, Spec};
use mbmf::pipeline;

/// Columns that legitimately differ between two runs of the same sweep.
pub const NONDETERMINISTIC: &[&str] = &["wall_time_s"];

/// The mbmf binary built for the tests.
pub fn mbmf() -> Command {
    Command::new(env!("CARGO_BIN_EXE_mbmf"))
}

/// Runs mbmf with `args` and returns its output.
pub fn run(args: &[&str]) -> Output {
    mbmf().args(args).output().expect("mbmf starts")
}

/// Runs mbmf and panics with its stderr unless it succeeds.
pub fn run_ok(args: &[&str]) -> Output {
    let out = run(args);
    assert!(
        out.status.success(),
        "mbmf {args:?} failed ({:?}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Drops `lock`, a lock this test holds on the file at `path`, and waits until no process holds
/// it. Another test's child holds a copy of every descriptor from its fork to its exec (close
/// on exec closes them only then), and with it the lock: a moment that a loaded machine can
/// stretch enough for the next command to find the folder still being written.
pub fn release_lock<L>(lock: L, path: &Path) {
    drop(lock);
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let probe = match File::open(path) {
            Ok(file) => file,
            // Its holder removed it: nobody holds it.
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return,
            Err(e) => panic!("{}: {e}", path.display()),
        };
        match probe.try_lock() {
            Ok(()) => return,
            Err(std::fs::TryLockError::WouldBlock) if Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(e) => panic!("{} is still locked after 30 s: {e}", path.display()),
        }
    }
}

/// `mbmf run` of MF and EC, two runs of 300 steps: the small run several tests start from.
pub const SMALL_RUN: [&str; 7] = [
    "run",
    "--controller",
    "mf,ec",
    "--runs",
    "2",
    "--steps",
    "300",
];

/// Runs `mbmf run ARGS --quiet --out OUT` and panics with its stderr unless it succeeds.
pub fn run_quiet(out: &Path, args: &[&str]) -> Output {
    let mut all = vec!["run"];
    all.extend_from_slice(args);
    all.extend(["--quiet", "--out", out.to_str().expect("a UTF-8 path")]);
    run_ok(&all)
}

/// The repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Writes `text` as `name` in `dir` and returns its path as a string.
pub fn write_sweep(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

/// One row: column name to displayed value.
pub type Row = BTreeMap<String, String>;

/// Every row of every `*.parquet` file of `dir` (no hidden files), minus `skip` columns, sorted
/// by run index then step.
pub fn rows(dir: &Path, skip: &[&str]) -> Vec<Row> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "parquet"))
        .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    files.sort();
    let mut out = Vec::new();
    for file in files {
        out.extend(file_rows(&file, skip));
    }
    sort_rows(&mut out);
    out
}

/// The rows of one Parquet file.
pub fn file_rows(file: &Path, skip: &[&str]) -> Vec<Row> {
    let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(file).unwrap())
        .unwrap_or_else(|e| panic!("{} is not a readable Parquet file: {e}", file.display()))
        .build()
        .unwrap();
    let batches: Vec<RecordBatch> = reader.map(|batch| batch.unwrap()).collect();
    batch_rows(&batches, skip)
}

/// The rows of record batches (a file's, or a table handed over in memory), every value as its
/// text, `null` for a null, leaving out the columns in `skip`.
pub fn batch_rows(batches: &[RecordBatch], skip: &[&str]) -> Vec<Row> {
    let mut out = Vec::new();
    for batch in batches {
        let schema = batch.schema();
        for r in 0..batch.num_rows() {
            let mut row = Row::new();
            for (field, col) in schema.fields().iter().zip(batch.columns()) {
                if skip.contains(&field.name().as_str()) {
                    continue;
                }
                let v = if col.is_null(r) {
                    "null".to_string()
                } else {
                    array_value_to_string(col, r).unwrap()
                };
                row.insert(field.name().clone(), v);
            }
            out.push(row);
        }
    }
    out
}

/// Sorts rows by run index, then step (series).
pub fn sort_rows(rows: &mut [Row]) {
    let key = |r: &Row| {
        let n = |c: &str| r.get(c).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
        (n("run_index"), n("step"))
    };
    rows.sort_by_key(key);
}

/// Keeps only the given columns of each row.
pub fn project(rows: &[Row], columns: &[String]) -> Vec<Row> {
    rows.iter()
        .map(|r| {
            r.iter()
                .filter(|(k, _)| columns.contains(k))
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect()
        })
        .collect()
}

/// Asserts that two tables are equal, naming the first differing row and column.
pub fn assert_same_rows(what: &str, left: &[Row], right: &[Row]) {
    assert_eq!(
        left.len(),
        right.len(),
        "{what}: {} rows vs {} rows",
        left.len(),
        right.len()
    );
    for (i, (a, b)) in left.iter().zip(right).enumerate() {
        if a != b {
            let col = a
                .keys()
                .chain(b.keys())
                .find(|k| a.get(*k) != b.get(*k))
                .cloned()
                .unwrap_or_default();
            panic!(
                "{what}: row {i} (run_index {:?}) differs in column '{col}': {:?} vs {:?}",
                a.get("run_index"),
                a.get(&col),
                b.get(&col)
            );
        }
    }
}

/// Runs and series rows of a dataset folder.
pub fn dataset(dir: &Path) -> (Vec<Row>, Vec<Row>) {
    (
        rows(&dir.join("runs"), NONDETERMINISTIC),
        rows(&dir.join("series"), NONDETERMINISTIC),
    )
}

/// Asserts that two dataset folders hold the same runs and series.
pub fn assert_same_dataset(what: &str, a: &Path, b: &Path) {
    let (ra, sa) = dataset(a);
    let (rb, sb) = dataset(b);
    assert!(!ra.is_empty(), "{what}: no runs in {}", a.display());
    assert_same_rows(&format!("{what} (runs)"), &ra, &rb);
    assert_same_rows(&format!("{what} (series)"), &sa, &sb);
}

/// Hidden temporary files (`.part-*.tmp-*`) left in the dataset's part folders.
pub fn temporaries(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for sub in ["runs", "series"] {
        if let Ok(entries) = std::fs::read_dir(dir.join(sub)) {
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().contains(".tmp-") {
                    out.push(e.path());
                }
            }
        }
    }
    out
}

/// Part file names of `dir/sub`.
pub fn parts(dir: &Path, sub: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join(sub))
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("part-") && n.ends_with(".parquet"))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

/// A tidy1 sweep of 6 configurations (controllers mf, rnd and ec x interaction none with budget
/// 0 and takeover with budget 20), `seeds` seeds each, master seed 3, 200 babbling steps.
pub fn six_configurations(seeds: u32, steps: u32, checkpoint: u32) -> String {
    format!(
        r#"
seeds = {seeds}
master_seed = 3

[fixed]
task = "tidy1"
steps = {steps}
babbling = 200
checkpoint = {checkpoint}

[grid]
controller = ["mf", "rnd", "ec"]

[[zip]]
interaction = ["none", "takeover"]
budget = [0, 20]
"#
    )
}

/// A small sweep used by several tests: 2 controllers x 2 profiles (zip) x 3 seeds = 12 runs.
pub const SMALL: &str = r#"
seeds = 3
master_seed = 11

[fixed]
task = "tidy1"
steps = 400
babbling = 100
checkpoint = 100

[grid]
controller = ["mf", "ec"]

[[zip]]
interaction = ["none", "takeover"]
budget = [0, 15]
"#;

/// The authors' navigation world, outside the repository (`../shared/data`).
pub const NAVWORLD: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/data/navworld/realisticNavWorld.json"
);

/// The task name of the authors' navigation world, or `None` (saying so) when its files are
/// absent. Under `CI=true` absent data fails the test instead: CI must run every test.
pub fn navworld_task() -> Option<String> {
    if Path::new(NAVWORLD).exists() {
        return Some(format!("json:{NAVWORLD}"));
    }
    assert!(
        !std::env::var("CI").is_ok_and(|v| v == "true"),
        "CI=true but {NAVWORLD} is absent: CI must provide the authors' data"
    );
    println!("skipped: {NAVWORLD} is absent (the authors' data is not in the repository)");
    None
}

/// The authors' navigation world, loaded, or `None` as [`navworld_task`] says.
pub fn navworld() -> Option<Arc<Spec>> {
    navworld_task().map(|task| Arc::new(env::load(&task).expect("navworld loads")))
}

/// Simulates `configs` in batches of `batch_size` on a pool of `threads` threads, turning each
/// run of each finished batch into a `T` with `each`.
pub fn simulate<T>(
    spec: &Arc<Spec>,
    configs: &[RunConfig],
    threads: usize,
    batch_size: usize,
    each: impl Fn(&Batch, usize) -> T + Sync,
) -> Vec<T>
where
    T: Send,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    pool.install(|| {
        let mut out = Vec::new();
        pipeline::simulate(
            spec,
            configs,
            batch_size,
            |_| {},
            |batch: &Batch| {
                out.extend((0..batch.len()).map(|r| each(batch, r)));
                Ok::<(), anyhow::Error>(())
            },
        )
        .expect("valid configurations");
        out
    })
}

/// The python of `venv` (under the repository; `env` overrides it) if `imports` import there.
pub fn venv_python(env: &str, venv: &str, imports: &str) -> Option<PathBuf> {
    let py = std::env::var_os(env)
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join(venv).join("bin/python"));
    let why = match Command::new(&py)
        .args(["-c", &format!("import {imports}")])
        .output()
    {
        Ok(out) if out.status.success() => return Some(py),
        Ok(out) => format!(
            "{} cannot import {imports}: {}",
            py.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ),
        Err(e) => format!("cannot run {}: {e}", py.display()),
    };
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!(
            "CI=true but the Python check cannot run: {why}; .ci/run runs scripts/python-env.sh first"
        );
    }
    eprintln!("SKIP Python check: {why} (run scripts/python-env.sh to create {venv})");
    None
}

/// Runs the sweep `file` into `out` as two commands, the first stopping after shard 0/2 and the
/// second resuming, in parts of 5 runs: a dataset as users meet it.
pub fn sweep_in_two_parts(file: &str, out: &Path) {
    let out = out.to_str().unwrap();
    let args = ["sweep", file, "--out", out, "--quiet", "--batch-size", "5"];
    run_ok(&[&args[..], &["--shard", "0/2"]].concat());
    run_ok(&[&args[..], &["--resume"]].concat());
}

/// Cases per property: `cases` in the normal run, as many as PROPTEST_CASES says if it is set.
pub fn proptest_config(cases: u32) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(cases),
        ..proptest::test_runner::Config::default()
    }
}

/// A running `mbmf` server and the URL it printed.
pub struct Served {
    child: Child,
    /// host:port.
    pub addr: String,
}

impl Served {
    /// Kills the server (SIGKILL) and waits for it.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `mbmf ARGS --port 0` and waits for its URL.
pub fn serve(args: &[&str]) -> Served {
    let mut child = mbmf()
        .args(args)
        .args(["--port", "0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut text = String::new();
    let started = Instant::now();
    let mut buf = [0u8; 256];
    while !text.contains('\n') && started.elapsed() < Duration::from_secs(20) {
        let n = stdout.read(&mut buf).unwrap();
        if n == 0 {
            break;
        }
        text.push_str(&String::from_utf8_lossy(&buf[..n]));
    }
    let addr = text
        .split("http://")
        .nth(1)
        .and_then(|r| r.split('/').next())
        .unwrap_or_else(|| panic!("no URL in {text:?}"))
        .to_owned();
    Served { child, addr }
}

/// The key-value metadata of a Parquet file (its provenance), as (key, value) pairs.
pub fn key_values(path: &Path) -> Vec<(String, String)> {
    use parquet::file::reader::{FileReader, SerializedFileReader};
    let reader = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    reader
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .unwrap()
        .iter()
        .map(|kv| (kv.key.clone(), kv.value.clone().unwrap_or_default()))
        .collect()
}
