//! `mbmf._mbmf`: the native half of the Python package. It turns Python arguments into the
//! library's typed inputs (parameters through the registry, so names, defaults, ranges and
//! messages are the command line's), runs the library entry in a worker thread with the GIL
//! released, and hands tables back as Arrow tables (`pyo3_arrow::PyTable`, readable through the
//! Arrow PyCapsule interface). The Python half (`mbmf/__init__.py`) adds the progress bar, the
//! output type and the docstrings.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::Duration;

use arrow::datatypes::SchemaRef;
use arrow::record_batch::RecordBatch;
use mbmf::analysis::dataset::{self, ReadOptions};
use mbmf::error::Usage;
use mbmf::params::{ConfigError, Controller, Kind, PARAMS, Param, Params, Profile, Value};
use mbmf::run::{Job, RunError};
use mbmf::schedule::Schedule;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use pyo3_arrow::PyTable;

/// The library's batches on huge pages, as in the `mbmf` binary (`mbmf::huge_pages`).
#[global_allocator]
static ALLOCATOR: mbmf::huge_pages::HugePageSystem = mbmf::huge_pages::HugePageSystem;

/// Most runs per configuration, as `mbmf run --runs` accepts.
const MAX_RUNS: u64 = 1_000_000;

/// How often the calling thread looks for Ctrl-C and reports progress while a run is simulated.
const POLL: Duration = Duration::from_millis(50);

/// A usage error (an input that can never work) as `ValueError`, any other as `RuntimeError`.
fn py_error(error: impl std::error::Error + Usage) -> PyErr {
    let text = chain(&error);
    if error.is_usage() {
        PyValueError::new_err(text)
    } else {
        PyRuntimeError::new_err(text)
    }
}

/// An error's message with its causes, as the command line prints them.
fn chain(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        text.push_str(&format!(": {cause}"));
        source = cause.source();
    }
    text
}

/// `ValueError: invalid value 'V' for 'NAME': expected ACCEPTED`: the command line's message,
/// naming the keyword instead of the flag.
fn invalid(name: &str, value: impl std::fmt::Display, accepted: impl std::fmt::Display) -> PyErr {
    refuse(name, value, format!("expected {accepted}"))
}

/// `ValueError: invalid value 'V' for 'NAME': WHY`.
fn refuse(name: &str, value: impl std::fmt::Display, why: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("invalid value '{value}' for '{name}': {why}"))
}

/// The keyword of a registry parameter: its sweep key (the flag without `--`).
fn keyword(param: &Param) -> &'static str {
    param.key
}

/// The parameters `run` takes as keywords: those with a flag of `mbmf run`, and the profile.
fn keyword_params() -> impl Iterator<Item = &'static Param> {
    PARAMS
        .iter()
        .filter(|p| p.flag || matches!(p.kind, Kind::Profile))
}

/// The registry parameter a keyword names: its key, its field (column) name or an alias.
fn find_param(word: &str) -> Option<&'static Param> {
    keyword_params().find(|p| p.key == word || p.name == word || p.aliases.contains(&word))
}

/// A whole number in `min..=max` from a Python object, with `mbmf run`'s messages.
fn whole(name: &str, obj: &Bound<'_, PyAny>, min: u64, max: u64) -> PyResult<u64> {
    let range = if max == u64::MAX {
        format!("a whole number >= {min}")
    } else {
        format!("a whole number from {min} to {max}")
    };
    let shown = obj.str().map(|s| s.to_string()).unwrap_or_default();
    if obj.is_instance_of::<PyBool>() || !obj.is_instance_of::<PyInt>() {
        let why = if obj.is_instance_of::<PyFloat>() {
            format!("not a whole number: expected {range}")
        } else {
            format!("expected {range}")
        };
        return Err(refuse(name, shown, why));
    }
    // Python ints are unbounded: anything outside i128 is too large or too small anyway.
    let n: i128 = match obj.extract::<i128>() {
        Ok(n) => n,
        Err(_) if obj.lt(0)? => i128::MIN,
        Err(_) => i128::MAX,
    };
    if n < i128::from(min) {
        return Err(refuse(
            name,
            &shown,
            format!("{shown} is too small: expected {range}"),
        ));
    }
    if n > i128::from(max) {
        return Err(refuse(
            name,
            &shown,
            format!("{shown} is too large: expected {range}"),
        ));
    }
    Ok(n as u64)
}

/// One of `names` (case ignored), or a `ValueError` listing them.
fn choice<T: Copy>(
    name: &str,
    obj: &Bound<'_, PyAny>,
    values: &[T],
    value_name: impl Fn(T) -> &'static str,
) -> PyResult<T> {
    let names: Vec<&str> = values.iter().map(|&v| value_name(v)).collect();
    let expected = format!("one of {}", names.join(", "));
    let shown = obj.str().map(|s| s.to_string()).unwrap_or_default();
    let Ok(text) = obj.cast::<PyString>() else {
        return Err(invalid(name, shown, expected));
    };
    let text = text.to_str()?;
    values
        .iter()
        .copied()
        .find(|&v| value_name(v).eq_ignore_ascii_case(text))
        .ok_or_else(|| invalid(name, text, expected))
}

/// A Python object as a value of `param`, with the command line's messages for a wrong type.
fn to_value(param: &'static Param, name: &str, obj: &Bound<'_, PyAny>) -> PyResult<Value> {
    let shown = || obj.str().map(|s| s.to_string()).unwrap_or_default();
    Ok(match param.kind {
        Kind::Real => {
            if obj.is_instance_of::<PyBool>()
                || !(obj.is_instance_of::<PyFloat>() || obj.is_instance_of::<PyInt>())
            {
                return Err(invalid(name, shown(), "a number, such as 0.5 or 1e-3"));
            }
            Value::Real(obj.extract::<f64>()?)
        }
        Kind::Count => Value::Count(whole(name, obj, 0, u64::from(u32::MAX))? as u32),
        Kind::Switch => match obj.extract::<bool>() {
            Ok(b) if obj.is_instance_of::<PyBool>() => Value::Switch(b),
            _ => return Err(invalid(name, shown(), "True or False")),
        },
        Kind::Choice(names) => Value::Choice(choice(name, obj, names, |n: &'static str| n)?),
        Kind::Profile => Value::Choice(choice(name, obj, Profile::VALUES, Profile::name)?.name()),
        Kind::Task | Kind::Schedule => Value::Text(obj.extract::<String>()?),
    })
}

/// `TypeError: FUNCTION() got an unexpected keyword argument 'WORD'`, with the closest name.
fn unknown_keyword(function: &str, word: &str, known: &[&str]) -> PyErr {
    let hint = mbmf::suggest::closest(word, known.iter().copied())
        .map(|c| format!("; did you mean '{c}'?"))
        .unwrap_or_default();
    PyTypeError::new_err(format!(
        "{function}() got an unexpected keyword argument '{word}'{hint}"
    ))
}

/// The validated parameters of each controller's runs, as `mbmf run` builds them: the
/// profile's human first, the keywords over it, a custom human when human fields are set
/// without a profile. Returns them with the names of the parameters set.
fn controller_params(
    function: &str,
    task: &str,
    controllers: &[Controller],
    params: Option<&Bound<'_, PyDict>>,
    other_keywords: &[&str],
) -> PyResult<(Vec<Params>, Vec<&'static str>)> {
    let mut profile = None;
    let mut given: Vec<(&'static Param, Value)> = Vec::new();
    if let Some(params) = params {
        for (key, obj) in params.iter() {
            let word: String = key.extract()?;
            let Some(param) = find_param(&word) else {
                let mut known: Vec<&str> = keyword_params().map(keyword).collect();
                known.extend_from_slice(other_keywords);
                return Err(unknown_keyword(function, &word, &known));
            };
            let value = to_value(param, &word, &obj)?;
            if matches!(param.kind, Kind::Profile) {
                profile = Profile::VALUES
                    .iter()
                    .copied()
                    .find(|p| Some(p.name()) == value.as_str());
            } else {
                given.push((param, value));
            }
        }
    }
    // The registry's order, as the command line applies its flags.
    given.sort_by_key(|(p, _)| PARAMS.iter().position(|q| std::ptr::eq(q, *p)));
    let mut all = Vec::new();
    for &controller in controllers {
        let chosen = profile.unwrap_or(Profile::None);
        let mut p = Params {
            controller,
            human: chosen.human(controller).unwrap_or_default(),
            profile: chosen,
            reward_source: chosen.reward_source().unwrap_or_default(),
            steps: mbmf::env::registry::default_steps(task),
            babbling: mbmf::env::registry::default_babbling(task),
            ..Params::default()
        };
        for (param, value) in &given {
            (param.set)(&mut p, value);
        }
        if profile.is_none() && given.iter().any(|(p, _)| p.in_human) {
            p.profile = Profile::Custom;
        }
        p.validate().map_err(config_error)?;
        all.push(p);
    }
    Ok((all, given.iter().map(|(p, _)| p.name).collect()))
}

/// A configuration error naming the keyword.
fn config_error(error: ConfigError) -> PyErr {
    match error {
        ConfigError::InvalidParam {
            name,
            value,
            accepted,
        } => {
            let word = mbmf::params::param(name).map_or(name, keyword);
            invalid(word, value, accepted)
        }
        other => py_error(other),
    }
}

/// Loads a task: a registered one, or json:PATH with keyStates.txt and spaces.txt beside it
/// unless `files` (key_states, spaces) name them, as `--key-states` and `--spaces` do.
fn load_task(task: &str, files: (Option<PathBuf>, Option<PathBuf>)) -> PyResult<mbmf::env::Spec> {
    let (key_states, spaces) = files;
    if let Some(path) = task.strip_prefix("json:") {
        if path.is_empty() {
            return Err(PyValueError::new_err(
                "task 'json:' names no file: expected json:PATH, the transition-model file \
                 (e.g. json:data/navworld/realisticNavWorld.json)",
            ));
        }
        let mut paths = mbmf::env::JsonPaths::beside(path);
        if let Some(k) = key_states {
            paths.key_states = k;
        }
        if let Some(s) = spaces {
            paths.spaces = s;
        }
        return mbmf::env::json::load(&paths, task).map_err(|e| PyValueError::new_err(chain(&e)));
    }
    if key_states.is_some() || spaces.is_some() {
        let word = if key_states.is_some() {
            "key_states"
        } else {
            "spaces"
        };
        return Err(PyValueError::new_err(format!(
            "{word} only applies to json:PATH tasks, not '{task}': the built-in tasks have no files"
        )));
    }
    mbmf::env::load(task).map_err(|e| PyValueError::new_err(chain(&e)))
}

/// The record batches and schema of one Parquet file, as written (types and metadata kept).
fn read_parquet(path: &Path) -> PyResult<PyTable> {
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    let fail = |e: &dyn std::fmt::Display| {
        PyRuntimeError::new_err(format!("cannot read back {}: {e}", path.display()))
    };
    let file = std::fs::File::open(path).map_err(|e| fail(&e))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| fail(&e))?;
    let schema: SchemaRef = builder.schema().clone();
    let batches: Vec<RecordBatch> = builder
        .build()
        .map_err(|e| fail(&e))?
        .collect::<Result<_, _>>()
        .map_err(|e| fail(&e))?;
    PyTable::try_new(batches, schema)
}

/// A rayon pool of its own for one call: nothing outlives the call, so a process forked
/// between calls inherits no pool whose threads it lacks.
fn pool(threads: Option<usize>) -> PyResult<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new().thread_name(|i| format!("mbmf-{i}"));
    if let Some(n) = threads {
        builder = builder.num_threads(n);
    }
    builder
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start worker threads: {e}")))
}

/// Runs `work` in a worker thread inside `pool` while the calling thread, with the GIL
/// released between polls, reports progress and watches for Ctrl-C; a signal raises the stop
/// flag, waits for the worker to wind down and returns Python's exception. `progress` is
/// called with (agent-steps since the last call, agent-steps of the whole job, which `work`
/// stores in its third argument).
fn supervised<T: Send>(
    py: Python<'_>,
    pool: &rayon::ThreadPool,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&AtomicBool, &AtomicU64, &AtomicU64) -> T + Send,
) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    let advanced = AtomicU64::new(0);
    let total = AtomicU64::new(0);
    let mut reported = 0u64;
    let mut report = || -> PyResult<()> {
        let now = advanced.load(Ordering::Relaxed);
        if now > reported {
            if let Some(f) = progress {
                f.call1((now - reported, total.load(Ordering::Relaxed)))?;
            }
            reported = now;
        }
        Ok(())
    };
    std::thread::scope(|scope| {
        let worker = scope.spawn(|| pool.install(|| work(&stop, &advanced, &total)));
        let mut pending: Option<PyErr> = None;
        while !worker.is_finished() {
            py.detach(|| std::thread::park_timeout(POLL));
            if pending.is_some() {
                continue;
            }
            if let Err(e) = py.check_signals().and_then(|()| report()) {
                // Ctrl-C (or a failing progress callback): stop and wait, writing nothing.
                stop.store(true, Ordering::Relaxed);
                pending = Some(e);
            }
        }
        let result = py.detach(|| worker.join());
        let result = match result {
            Ok(r) => r,
            Err(panic) => std::panic::resume_unwind(panic),
        };
        match pending {
            Some(e) => Err(e),
            None => {
                report()?;
                Ok(result)
            }
        }
    })
}

/// The inputs `run` and `stream` share, checked: the job (into `out`) and the worker threads.
#[allow(clippy::too_many_arguments)]
fn job_of(
    py: Python<'_>,
    function: &str,
    task: &str,
    files: (Option<PathBuf>, Option<PathBuf>),
    controller: &Bound<'_, PyAny>,
    runs: &Bound<'_, PyAny>,
    seed: &Bound<'_, PyAny>,
    batch_size: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    change: &[String],
    params: Option<&Bound<'_, PyDict>>,
    others: &[&str],
    out: PathBuf,
) -> PyResult<(Job, Option<usize>)> {
    let controllers: Vec<Controller> = match controller.cast::<PyString>() {
        Ok(s) => s
            .to_str()?
            .split(',')
            .map(|c| {
                let c = PyString::new(py, c.trim());
                choice("controller", c.as_any(), &Controller::ALL, Controller::name)
            })
            .collect::<PyResult<_>>()?,
        Err(_) => controller
            .try_iter()
            .map_err(|_| invalid("controller", controller, "a name or a list of names"))?
            .map(|c| choice("controller", &c?, &Controller::ALL, Controller::name))
            .collect::<PyResult<_>>()?,
    };
    if controllers.is_empty() {
        return Err(invalid("controller", "[]", "at least one controller"));
    }
    let runs = whole("runs", runs, 1, MAX_RUNS)? as u32;
    let seed = whole("seed", seed, 0, u64::MAX)?;
    let batch_size = whole("batch_size", batch_size, 1, usize::MAX as u64)? as usize;
    let threads = threads
        .map(|t| whole("threads", t, 1, 4096).map(|n| n as usize))
        .transpose()?;
    let spec = load_task(task, files)?;
    let (configs, set) = controller_params(function, task, &controllers, params, others)?;
    let schedule = Schedule::from_events(change.iter().map(String::as_str))
        .map_err(|e| PyValueError::new_err(format!("change: {}", chain(&e))))?;
    let job = Job {
        runs,
        seed,
        schedule,
        batch_size,
        set,
        command: format!("mbmf.{function} (Python) task={task}"),
        ..Job::new(task, Arc::new(spec), configs, out)
    };
    Ok((job, threads))
}

/// The Python-facing `run`; see `mbmf.run` for the documentation.
#[pyfunction]
#[pyo3(name = "run", signature = (task, controller, runs, seed, out, force, batch_size, threads, change, progress, params, key_states = None, spaces = None))]
#[allow(clippy::too_many_arguments)]
fn run_job(
    py: Python<'_>,
    task: &str,
    controller: &Bound<'_, PyAny>,
    runs: &Bound<'_, PyAny>,
    seed: &Bound<'_, PyAny>,
    out: Option<PathBuf>,
    force: bool,
    batch_size: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    change: Vec<String>,
    progress: Option<&Bound<'_, PyAny>>,
    params: Option<&Bound<'_, PyDict>>,
    key_states: Option<PathBuf>,
    spaces: Option<PathBuf>,
) -> PyResult<(PyTable, PyTable, Vec<String>)> {
    let others = [
        "task",
        "controller",
        "runs",
        "seed",
        "out",
        "force",
        "batch_size",
        "threads",
        "change",
        "progress",
        "output",
        "key_states",
        "spaces",
    ];
    // Without `out`, the files are written to a private folder and read back.
    let scratch = match out {
        Some(_) => None,
        None => Some(tempfile::tempdir().map_err(|e| {
            PyRuntimeError::new_err(format!("cannot create a temporary folder: {e}"))
        })?),
    };
    let out = out.unwrap_or_else(|| scratch.as_ref().expect("made above").path().to_path_buf());
    let (mut job, threads) = job_of(
        py,
        "run",
        task,
        (key_states, spaces),
        controller,
        runs,
        seed,
        batch_size,
        threads,
        &change,
        params,
        &others,
        out,
    )?;
    job.force = force;
    let mut checked = mbmf::run::Run::new(job).map_err(run_error)?;
    let warnings = checked.warnings().to_vec();
    checked.size().map_err(run_error)?;
    let total = checked.job().agent_steps();
    let pool = pool(threads)?;
    let done = supervised(py, &pool, progress, move |stop, advanced, total_steps| {
        total_steps.store(total, Ordering::Relaxed);
        checked.open()?.simulate(stop, |n| {
            advanced.fetch_add(n, Ordering::Relaxed);
        })
    })?;
    let done = match done {
        Ok(done) => done,
        Err(RunError::Interrupted(_)) => {
            return Err(PyKeyboardInterrupt::new_err(
                "interrupted: nothing was written",
            ));
        }
        Err(e) => return Err(run_error(e)),
    };
    let [runs_file, series_file] = &done.files;
    Ok((
        read_parquet(runs_file)?,
        read_parquet(series_file)?,
        warnings,
    ))
}

/// What the simulating thread of a [`Stream`] sends: each finished batch's tables, then an
/// error if the work failed.
type Streamed = Result<[RecordBatch; 2], RunError>;

/// The iterator `mbmf.stream` returns: the runs and series tables of each finished batch of
/// runs, simulated by a thread of its own (without the GIL) at most two batches ahead of the
/// reader. Dropping it, Ctrl-C in `__next__` or `close()` stops the simulation within a stride.
#[pyclass(module = "mbmf._mbmf")]
struct Stream {
    batches: Mutex<Receiver<Streamed>>,
    stop: Arc<AtomicBool>,
    total: u64,
}

#[pymethods]
impl Stream {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__(&self, py: Python<'_>) -> PyResult<Option<(PyTable, PyTable)>> {
        loop {
            let next = py.detach(|| {
                self.batches
                    .lock()
                    .map(|b| b.recv_timeout(POLL))
                    .map_err(|_| ())
            });
            let next = next.map_err(|_| PyRuntimeError::new_err("the stream failed earlier"))?;
            match next {
                Ok(Ok([runs, series])) => {
                    let (rs, ss) = (runs.schema(), series.schema());
                    return Ok(Some((
                        PyTable::try_new(vec![runs], rs)?,
                        PyTable::try_new(vec![series], ss)?,
                    )));
                }
                Ok(Err(RunError::Interrupted(_))) => return Ok(None),
                Ok(Err(e)) => return Err(run_error(e)),
                Err(RecvTimeoutError::Disconnected) => return Ok(None),
                Err(RecvTimeoutError::Timeout) => {
                    if let Err(e) = py.check_signals() {
                        self.stop.store(true, Ordering::Relaxed);
                        return Err(e);
                    }
                }
            }
        }
    }

    /// Stops the simulation; the iterator then ends.
    fn close(&self) {
        self.stop.store(true, Ordering::Relaxed);
    }

    /// Runs of the whole job.
    #[getter]
    fn runs(&self) -> u64 {
        self.total
    }
}

impl Drop for Stream {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// The Python-facing `stream`; see `mbmf.stream`. Checks every input before it returns.
#[pyfunction]
#[pyo3(signature = (task, controller, runs, seed, batch_size, threads, change, params, key_states = None, spaces = None))]
#[allow(clippy::too_many_arguments)]
fn stream(
    py: Python<'_>,
    task: &str,
    controller: &Bound<'_, PyAny>,
    runs: &Bound<'_, PyAny>,
    seed: &Bound<'_, PyAny>,
    batch_size: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    change: Vec<String>,
    params: Option<&Bound<'_, PyDict>>,
    key_states: Option<PathBuf>,
    spaces: Option<PathBuf>,
) -> PyResult<(Stream, Vec<String>)> {
    let others = [
        "task",
        "controller",
        "runs",
        "seed",
        "batch_size",
        "threads",
        "change",
        "output",
        "key_states",
        "spaces",
    ];
    let (job, threads) = job_of(
        py,
        "stream",
        task,
        (key_states, spaces),
        controller,
        runs,
        seed,
        batch_size,
        threads,
        &change,
        params,
        &others,
        PathBuf::new(),
    )?;
    let checked = mbmf::run::Run::new(job).map_err(run_error)?;
    let warnings = checked.warnings().to_vec();
    let total = checked.job().total();
    let pool = pool(threads)?;
    let stop = Arc::new(AtomicBool::new(false));
    // Two batches ahead at most: a slow reader holds back the simulation, not memory.
    let (send, batches) = std::sync::mpsc::sync_channel::<Streamed>(2);
    let halt = Arc::clone(&stop);
    std::thread::Builder::new()
        .name("mbmf-stream".into())
        .spawn(move || {
            let result = pool.install(|| {
                checked.stream(
                    &halt,
                    |_| {},
                    |tables| match send.send(Ok(tables)) {
                        Ok(()) => ControlFlow::Continue(()),
                        // The reader is gone: stop.
                        Err(_) => ControlFlow::Break(()),
                    },
                )
            });
            if let Err(e) = result {
                let _ = send.send(Err(e));
            }
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a thread: {e}")))?;
    Ok((
        Stream {
            batches: Mutex::new(batches),
            stop,
            total,
        },
        warnings,
    ))
}

/// A run entry's error: configuration errors name the keyword, schedule errors `change`.
fn run_error(error: RunError) -> PyErr {
    match error {
        RunError::Invalid(e) => config_error(e),
        RunError::Change(e) => PyValueError::new_err(format!("change: {}", chain(&e))),
        e => py_error(e),
    }
}

/// Table `name` of a dataset (a run's folder, a sweep's committed parts, or a file) as the
/// analysis verbs read it, keeping the rows that pass every `--where` filter; with the
/// warnings about files left out.
fn load(
    path: &Path,
    name: &str,
    filters: &[String],
    allow_incomplete: bool,
) -> PyResult<(dataset::Table, Vec<String>)> {
    let options = ReadOptions { allow_incomplete };
    let read =
        dataset::read_table(path, name, &options).map_err(|e| PyValueError::new_err(chain(&e)))?;
    let filters = parse_filters(filters)?;
    let table = dataset::Filter::apply_all(&read.table, &filters)
        .map_err(|e| PyValueError::new_err(chain(&e)))?;
    Ok((table, read.warnings))
}

/// A dataset table as an Arrow table.
fn to_py(table: &dataset::Table) -> PyResult<PyTable> {
    let batch = table
        .to_record_batch()
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let schema = batch.schema();
    PyTable::try_new(vec![batch], schema)
}

/// The runs table `data` names: a dataset's path (read as the analysis verbs read it), or any
/// table with the Arrow PyCapsule interface (polars, pyarrow, DuckDB, `mbmf.run`'s); with the
/// rows that pass every `--where` filter and the reader's warnings.
fn runs_of(
    data: &Bound<'_, PyAny>,
    filters: &[String],
    allow_incomplete: bool,
) -> PyResult<(dataset::Table, Vec<String>)> {
    if let Ok(path) = data.extract::<PathBuf>() {
        return load(&path, "runs", filters, allow_incomplete);
    }
    let Ok(table) = data.extract::<PyTable>() else {
        return Err(PyTypeError::new_err(format!(
            "data: expected a dataset's path or an Arrow table (with __arrow_c_stream__), not {}",
            data.get_type().name()?
        )));
    };
    let (batches, schema) = table.into_inner();
    let table = dataset::Table::from_batches("<table>", &schema, &batches)
        .map_err(|e| PyValueError::new_err(chain(&e)))?;
    let filters = parse_filters(filters)?;
    let table = dataset::Filter::apply_all(&table, &filters)
        .map_err(|e| PyValueError::new_err(chain(&e)))?;
    Ok((table, Vec::new()))
}

/// `--where` filters, with the message of a bad one.
fn parse_filters(filters: &[String]) -> PyResult<Vec<dataset::Filter>> {
    filters
        .iter()
        .map(|f| dataset::Filter::parse(f))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| PyValueError::new_err(format!("where: {}", chain(&e))))
}

/// The Python-facing `pareto`; see `mbmf.pareto`: the table `mbmf pareto` writes as
/// pareto.parquet.
#[pyfunction]
#[pyo3(signature = (data, objectives, by, filters, allow_incomplete))]
fn pareto(
    data: &Bound<'_, PyAny>,
    objectives: Option<Vec<String>>,
    by: Vec<String>,
    filters: Vec<String>,
    allow_incomplete: bool,
) -> PyResult<(PyTable, Vec<String>)> {
    use mbmf::analysis::pareto::Objective;
    let (table, warnings) = runs_of(data, &filters, allow_incomplete)?;
    if table.is_empty() {
        return Err(PyValueError::new_err(format!(
            "{} holds no runs",
            table.source()
        )));
    }
    let objectives = objectives
        .map(|list| {
            list.iter()
                .map(|o| Objective::parse(o))
                .collect::<Result<Vec<_>, _>>()
        })
        .transpose()
        .map_err(|e| PyValueError::new_err(format!("objectives: {}", chain(&e))))?;
    let result = mbmf::analysis::front::pareto(&table, objectives.as_deref(), &by)
        .map_err(|e| PyValueError::new_err(chain(&e)))?;
    let front = result
        .to_table()
        .map_err(|e| PyRuntimeError::new_err(chain(&e)))?;
    Ok((to_py(&front)?, warnings))
}

/// What `stats` returns: the groups, the pairs, the columns that also vary within groups, the
/// `by` values left out (no value of the metric), and the reader's warnings.
type StatsTables = (PyTable, PyTable, Vec<String>, Vec<String>, Vec<String>);

/// The Python-facing `stats`; see `mbmf.stats`: the tables `mbmf stats` prints.
#[pyfunction]
#[pyo3(signature = (data, by, metric, filters, allow_incomplete))]
fn stats(
    data: &Bound<'_, PyAny>,
    by: &str,
    metric: &str,
    filters: Vec<String>,
    allow_incomplete: bool,
) -> PyResult<StatsTables> {
    let (table, warnings) = runs_of(data, &filters, allow_incomplete)?;
    let c = mbmf::analysis::compare::compare(&table, by, metric)
        .map_err(|e| PyValueError::new_err(chain(&e)))?;
    Ok((
        to_py(&c.groups_table())?,
        to_py(&c.pairs_table())?,
        c.mixed.clone(),
        c.empty.iter().map(|v| v.to_string()).collect(),
        warnings,
    ))
}

/// The Python-facing `read`; see `mbmf.read`.
#[pyfunction]
#[pyo3(signature = (path, table, filters, allow_incomplete))]
fn read(
    path: PathBuf,
    table: &str,
    filters: Vec<String>,
    allow_incomplete: bool,
) -> PyResult<(PyTable, Vec<String>)> {
    let (table, warnings) = load(&path, table, &filters, allow_incomplete)?;
    Ok((to_py(&table)?, warnings))
}

/// The Python-facing `min_budget`; see `mbmf.min_budget`: the table `mbmf min-budget` writes
/// as min_budget.parquet.
#[pyfunction]
#[pyo3(signature = (path, metric, alpha, filters, allow_incomplete))]
fn min_budget(
    path: PathBuf,
    metric: &str,
    alpha: Option<f64>,
    filters: Vec<String>,
    allow_incomplete: bool,
) -> PyResult<(PyTable, Vec<String>)> {
    use mbmf::analysis::min_budget::{DEFAULT_ALPHA, min_budget};
    let (table, warnings) = load(&path, "runs", &filters, allow_incomplete)?;
    if table.is_empty() {
        return Err(PyValueError::new_err(format!(
            "{} holds no runs",
            table.source()
        )));
    }
    let result = min_budget(&table, metric, alpha.unwrap_or(DEFAULT_ALPHA))
        .map_err(|e| PyValueError::new_err(chain(&e)))?;
    Ok((to_py(&result.to_table())?, warnings))
}

/// A Python dict as a TOML table (sweep files are TOML): strings, booleans, ints, floats,
/// lists and nested dicts.
fn toml_value(obj: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(obj.extract()?));
    }
    if obj.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(obj.extract()?));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(obj.extract()?));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(toml::Value::String(s.to_str()?.to_string()));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, v) in d.iter() {
            table.insert(k.extract::<String>()?, toml_value(&v)?);
        }
        return Ok(toml::Value::Table(table));
    }
    if let Ok(items) = obj.try_iter() {
        return Ok(toml::Value::Array(
            items.map(|i| toml_value(&i?)).collect::<PyResult<_>>()?,
        ));
    }
    Err(PyTypeError::new_err(format!(
        "a sweep holds strings, numbers, booleans, lists and dicts, not {}",
        obj.get_type().name()?
    )))
}

/// A dict as the text of a sweep file, its keys in the dict's order (a sweep's grid order is
/// the order its keys are written in): a table's plain values first, then its sub-tables as
/// `[a.b]` sections.
fn toml_text(table: &Bound<'_, PyDict>, path: &str, out: &mut String) -> PyResult<()> {
    let key = |k: &str| {
        let bare = !k.is_empty()
            && k.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
        if bare {
            k.to_string()
        } else {
            toml::Value::String(k.to_string()).to_string()
        }
    };
    let mut tables = Vec::new();
    for (k, v) in table.iter() {
        let k: String = k.extract()?;
        match v.cast::<PyDict>() {
            Ok(d) => tables.push((k, d.clone())),
            Err(_) => out.push_str(&format!("{} = {}\n", key(&k), toml_value(&v)?)),
        }
    }
    for (k, d) in tables {
        let path = if path.is_empty() {
            key(&k)
        } else {
            format!("{path}.{}", key(&k))
        };
        out.push_str(&format!("\n[{path}]\n"));
        toml_text(&d, &path, out)?;
    }
    Ok(())
}

/// The Python-facing `sweep`; see `mbmf.sweep` for the documentation. Returns the report
/// (out, runs of the sweep, runs of the shard, done before, ran, parts, seconds, summary line)
/// and the sweep's warnings.
#[pyfunction]
#[pyo3(signature = (sweep, out, resume, shard, batch_size, threads, progress))]
#[allow(clippy::too_many_arguments)]
fn sweep(
    py: Python<'_>,
    sweep: &Bound<'_, PyAny>,
    out: PathBuf,
    resume: bool,
    shard: (u64, u64),
    batch_size: &Bound<'_, PyAny>,
    threads: Option<&Bound<'_, PyAny>>,
    progress: Option<&Bound<'_, PyAny>>,
) -> PyResult<(SweepReport, Vec<String>)> {
    use mbmf::sweep::{Shard, Sweep, runner};
    let batch_size = whole("batch_size", batch_size, 1, usize::MAX as u64)? as usize;
    let threads = threads
        .map(|t| whole("threads", t, 1, 4096).map(|n| n as usize))
        .transpose()?;
    let (name, loaded) = if let Ok(d) = sweep.cast::<PyDict>() {
        let mut text = String::new();
        toml_text(d, "", &mut text)?;
        let here = std::env::current_dir().unwrap_or_default();
        ("<dict>".to_string(), Sweep::parse("<dict>", &here, &text))
    } else {
        let path: PathBuf = sweep.extract()?;
        (path.display().to_string(), Sweep::load(&path))
    };
    let loaded = loaded.map_err(py_error)?;
    let shard = Shard::new(
        shard.0,
        shard.1,
        "shards are numbered from 0, so shard=(INDEX, COUNT) needs INDEX < COUNT",
    )
    .map_err(|e| refuse("shard", format!("{shard:?}"), e))?;
    loaded
        .check_size(shard, batch_size, &out, resume)
        .map_err(|e| PyValueError::new_err(format!("{name}: {e}")))?;
    let specs = loaded.load_specs().map_err(py_error)?;
    loaded.check(&specs).map_err(py_error)?;
    let options = runner::Options {
        out,
        resume,
        shard,
        batch_size,
        command: format!("mbmf.sweep (Python) {name}"),
    };
    let pool = pool(threads)?;
    let mut warnings = loaded.warnings.clone();
    let (report, event_warnings) = supervised(py, &pool, progress, |stop, advanced, total| {
        let mut seen = Vec::new();
        let report = runner::execute(&loaded, &specs, &options, stop, &mut |event| match event {
            runner::Event::Warning(w) => seen.push(w.to_string()),
            runner::Event::Started { agent_steps } => total.store(agent_steps, Ordering::Relaxed),
            runner::Event::Advanced(n) => {
                advanced.fetch_add(n, Ordering::Relaxed);
            }
            _ => {}
        });
        (report, seen)
    })?;
    warnings.extend(event_warnings);
    let report = match report {
        Ok(r) => r,
        Err(runner::RunError::Interrupted(_)) => {
            return Err(PyKeyboardInterrupt::new_err(
                "interrupted: the parts written so far are kept; resume=True runs the rest",
            ));
        }
        Err(e) => return Err(py_error(e)),
    };
    let line = report.line();
    Ok((
        (
            report.out.display().to_string(),
            report.total,
            report.shard_runs,
            report.done_before,
            report.ran,
            report.parts_written,
            report.seconds,
            line,
        ),
        warnings,
    ))
}

/// What a sweep did: (out, runs of the sweep, runs of the shard, runs in the folder before,
/// runs simulated, parts written, seconds, summary line).
type SweepReport = (String, u64, u64, u64, u64, usize, f64, String);

/// The keywords `run` takes for parameters, with what each accepts: (keyword, kind, choices,
/// default, accepted range, description), in the registry's order.
#[pyfunction]
fn parameters() -> Vec<(String, String, Vec<String>, String, String, String)> {
    keyword_params()
        .map(|p| {
            let (kind, choices): (&str, Vec<String>) = match p.kind {
                Kind::Real => ("float", vec![]),
                Kind::Count => ("int", vec![]),
                Kind::Switch => ("bool", vec![]),
                Kind::Choice(names) => ("str", names.iter().map(|n| n.to_string()).collect()),
                Kind::Profile => (
                    "str",
                    Profile::VALUES
                        .iter()
                        .map(|v| v.name().to_string())
                        .collect(),
                ),
                Kind::Task | Kind::Schedule => ("str", vec![]),
            };
            let default = match p.kind {
                Kind::Profile => "none".to_string(),
                _ => p.default_value().to_string(),
            };
            (
                keyword(p).to_string(),
                kind.to_string(),
                choices,
                default,
                p.accepted.unwrap_or("").to_string(),
                p.doc.to_string(),
            )
        })
        .collect()
}

/// The native half of `mbmf.VecEnv`; see `mbmf.VecEnv` for the documentation.
#[pyclass(module = "mbmf._mbmf", name = "VecEnv")]
struct VecEnv {
    env: mbmf::vec_env::VecEnv,
}

/// A vector environment's error: parameters name the keyword.
fn vec_env_error(error: mbmf::vec_env::VecEnvError) -> PyErr {
    use mbmf::vec_env::VecEnvError;
    match error {
        VecEnvError::Config(e) => config_error(e),
        e => py_error(e),
    }
}

/// States as numpy's default integers.
fn states<'py>(py: Python<'py>, states: &[u32]) -> Bound<'py, PyArray1<i64>> {
    PyArray1::from_iter(py, states.iter().map(|&s| i64::from(s)))
}

#[pymethods]
impl VecEnv {
    #[new]
    #[pyo3(signature = (task, num_envs, seed, max_episode_steps, params, key_states = None, spaces = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        task: &str,
        num_envs: &Bound<'_, PyAny>,
        seed: &Bound<'_, PyAny>,
        max_episode_steps: Option<&Bound<'_, PyAny>>,
        params: Option<&Bound<'_, PyDict>>,
        key_states: Option<PathBuf>,
        spaces: Option<PathBuf>,
    ) -> PyResult<VecEnv> {
        let num_envs = whole("num_envs", num_envs, 1, 1 << 24)? as usize;
        let seed = whole("seed", seed, 0, u64::MAX)?;
        let max_episode_steps = max_episode_steps
            .map(|m| whole("max_episode_steps", m, 1, u64::from(u32::MAX)))
            .transpose()?
            .unwrap_or(0) as u32;
        let spec = load_task(task, (key_states, spaces))?;
        let others = [
            "task",
            "num_envs",
            "seed",
            "max_episode_steps",
            "key_states",
            "spaces",
        ];
        let (configs, _) = controller_params("VecEnv", task, &[Controller::Mf], params, &others)?;
        let env = mbmf::vec_env::VecEnv::new(
            Arc::new(spec),
            &configs[0],
            num_envs,
            seed,
            max_episode_steps,
        )
        .map_err(vec_env_error)?;
        Ok(VecEnv { env })
    }

    /// Starts every copy afresh; returns the states.
    #[pyo3(signature = (seed = None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let seed = seed.map(|s| whole("seed", s, 0, u64::MAX)).transpose()?;
        Ok(states(py, self.env.reset(seed)))
    }

    /// One step of every copy: (obs, reward, terminated, truncated, info).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyDict>,
    )> {
        let actions = actions
            .as_slice()
            .map_err(|e| PyValueError::new_err(format!("actions: {e}")))?;
        let len = self.env.task_state_len();
        let n = self.env.len();
        let out = self
            .env
            .step(actions)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let info = PyDict::new(py);
        info.set_item("action", states(py, &out.action))?;
        info.set_item("final_obs", states(py, &out.final_obs))?;
        for (key, values) in [
            ("takeover", &out.takeover),
            ("congratulation", &out.congratulation),
            ("punishment", &out.punishment),
            ("nuisance", &out.nuisance),
            ("human_reward", &out.human_reward),
            ("forgotten", &out.forgotten),
        ] {
            info.set_item(key, PyArray1::from_slice(py, values))?;
        }
        info.set_item(
            "budget_left",
            PyArray1::from_iter(py, out.budget_left.iter().map(|&b| i64::from(b))),
        )?;
        let result = (
            states(py, &out.obs),
            PyArray1::from_slice(py, &out.reward),
            PyArray1::from_slice(py, &out.terminated),
            PyArray1::from_slice(py, &out.truncated),
            info,
        );
        if len > 0 {
            let task_state = PyArray1::from_slice(py, self.env.task_state()).reshape([n, len])?;
            result.4.set_item("task_state", task_state)?;
        }
        Ok(result)
    }

    /// Copies stepped together.
    #[getter]
    fn num_envs(&self) -> usize {
        self.env.len()
    }

    /// States of the task (observations are 0 to n_states - 1).
    #[getter]
    fn n_states(&self) -> usize {
        self.env.world().n_states
    }

    /// Actions of the task (actions are 0 to n_actions - 1).
    #[getter]
    fn n_actions(&self) -> usize {
        self.env.world().n_actions
    }

    /// The name of each state.
    #[getter]
    fn state_names(&self) -> Vec<String> {
        self.env.world().state_names.clone()
    }

    /// The copies' task state (twostep: the four reward probabilities), one row per copy.
    #[getter]
    fn task_state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let len = self.env.task_state_len();
        PyArray1::from_slice(py, self.env.task_state()).reshape([self.env.len(), len])
    }
}

/// The native module.
#[pymodule]
fn _mbmf(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run_job, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(sweep, m)?)?;
    m.add_function(wrap_pyfunction!(min_budget, m)?)?;
    m.add_function(wrap_pyfunction!(parameters, m)?)?;
    m.add_function(wrap_pyfunction!(pareto, m)?)?;
    m.add_function(wrap_pyfunction!(stats, m)?)?;
    m.add_function(wrap_pyfunction!(stream, m)?)?;
    m.add_class::<Stream>()?;
    m.add_class::<VecEnv>()?;
    m.add(
        "CONTROLLERS",
        Controller::ALL.iter().map(|c| c.name()).collect::<Vec<_>>(),
    )?;
    Ok(())
}
