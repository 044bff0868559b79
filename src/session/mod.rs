//! A person teaching a live run (SPEC 15), for any front end (`mbmf teach`'s web server): one
//! run of the engine stepped when the front end asks, the person's takeovers and feedback
//! applied as they come, and the run committed after every step and every interaction, so a
//! closed tab or a killed server loses at most the step in progress.
//!
//! The sessions of a folder form one dataset that every analysis verb reads:
//! `DIR/runs/part-NNNNNN.parquet`, `DIR/series/part-NNNNNN.parquet` and
//! `DIR/trace/part-NNNNNN.parquet`, `NNNNNN` the session's run index, which is taken by
//! creating `DIR/sessions/NNNNNN.json` (never reused, even across servers on the same folder).
//! The runs table adds `participant`, `session` and `finished` (false until the session ends:
//! an interrupted session is kept and marked), the trace `shown_at` and `clicked_at` (seconds
//! since the session started).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use arrow::array::{ArrayRef, BooleanArray, Float64Array, RecordBatch, StringArray};
use arrow::datatypes::{Field, Schema};

use crate::batch::trace::{Actor, HumanEvent, NO_ACTION};
use crate::batch::{Batch, Refusal, RunConfig};
use crate::env::Spec;
use crate::output::{self, OutputError, provenance};
use crate::params::{ConfigError, Interaction, Params};

/// The folder of a sessions dataset that holds each session's claim on its run index.
pub const CLAIMS_DIR: &str = "sessions";

/// What goes wrong starting, stepping or committing a session.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The robot's parameters do not fit a person's session.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The sessions folder cannot be used.
    #[error("cannot use the sessions folder {path}: {source}")]
    Folder {
        /// The folder or file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A table could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The folder holds another kind of dataset, which sessions would corrupt.
    #[error(
        "{path} holds {what}, not sessions: give --sessions a folder of its own (sessions add \
         part files to runs/, series/ and trace/)"
    )]
    NotSessions {
        /// The folder.
        path: PathBuf,
        /// What it holds.
        what: &'static str,
    },
}

impl SessionError {
    /// Whether the request was wrong (exit code 2), rather than the machine (1).
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            SessionError::Config(_) | SessionError::NotSessions { .. }
        )
    }
}

/// Checks that `dir` is a sessions folder, or can become one: not the output of `mbmf run` or
/// `mbmf sweep`, whose datasets part files of sessions would corrupt.
pub fn check_folder(dir: &Path) -> Result<(), SessionError> {
    for (file, what) in [
        ("sweep.toml", "a sweep's dataset"),
        ("runs.parquet", "the output of mbmf run"),
    ] {
        if dir.join(file).exists() {
            return Err(SessionError::NotSessions {
                path: dir.to_path_buf(),
                what,
            });
        }
    }
    Ok(())
}

/// What a session is: the robot, its task, who teaches it.
#[derive(Debug, Clone)]
pub struct Teaching {
    /// The task's world (a tidy task).
    pub spec: Arc<Spec>,
    /// The robot's parameters; the human part is the person's (interaction `person`, the
    /// budget, zeta).
    pub params: Params,
    /// The master seed of the run's stream (with the run index).
    pub master_seed: u64,
    /// The person's pseudonym (never a name: the front end says so).
    pub participant: String,
    /// The command that serves the session, for the files' provenance.
    pub command: String,
}

/// One executed step, as a front end shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Shown {
    /// The experiment step (1-based).
    pub step: u32,
    /// The state before the step.
    pub state: usize,
    /// The action executed (`None`: a reset step).
    pub action: Option<usize>,
    /// Who chose it.
    pub actor: Actor,
    /// The state after the step.
    pub next_state: usize,
    /// The step's reward.
    pub reward: f64,
    /// Reward so far.
    pub total_reward: f64,
    /// The arrival was terminal.
    pub terminal: bool,
    /// The person's event at the step (a takeover; feedback comes after).
    pub event: HumanEvent,
    /// Interactions left (`None`: no limit).
    pub budget_left: Option<u32>,
    /// The robot holds a cube now: the person may take over at the next step.
    pub holding: bool,
}

/// A person's session: one traced run and its files.
pub struct Session {
    batch: Batch,
    dir: PathBuf,
    run_index: u64,
    id: String,
    participant: String,
    started: Instant,
    metadata: Vec<(String, String)>,
    /// Per step: seconds from the start to when the step was shown, and to the click that
    /// acted on it (NaN: none).
    shown_at: Vec<f64>,
    clicked_at: Vec<f64>,
    /// The time of the click that chose the takeover waiting for the next step.
    put_clicked: f64,
    finished: bool,
}

/// The budget a person without a limit has.
pub const NO_LIMIT: u32 = u32::MAX;

impl Session {
    /// Starts a session in the sessions folder `dir`: claims the next run index, builds the
    /// run (babbling done), and commits its empty tables so the session is visible at once.
    pub fn start(dir: &Path, teaching: Teaching) -> Result<Session, SessionError> {
        check_folder(dir)?;
        let mut params = teaching.params;
        params.human.interaction = Interaction::Person;
        let claims = dir.join(CLAIMS_DIR);
        let folder = |path: &Path| {
            let path = path.to_path_buf();
            move |source| SessionError::Folder { path, source }
        };
        for sub in [CLAIMS_DIR, "runs", "series", "trace"] {
            std::fs::create_dir_all(dir.join(sub)).map_err(folder(&dir.join(sub)))?;
        }
        // Validate before claiming an index, so a refused request leaves nothing behind.
        let probe = RunConfig {
            params,
            seed: teaching.master_seed,
            run_index: 0,
        };
        crate::env::registry::check_person(&teaching.spec, &probe.params)?;
        let id = format!("s-{}", &output::atomic::new_run_id()[..12]);
        let run_index = claim(&claims, &id, &teaching.participant)?;
        let config = RunConfig { run_index, ..probe };
        let batch = Batch::for_person(Arc::clone(&teaching.spec), config)?;
        let mut metadata = output::metadata(&teaching.command, teaching.master_seed, None);
        metadata.push((
            output::atomic::RUN_ID_KEY.to_string(),
            format!("{id}-{run_index}"),
        ));
        let steps = params.steps as usize;
        let session = Session {
            batch,
            dir: dir.to_path_buf(),
            run_index,
            id,
            participant: teaching.participant,
            started: Instant::now(),
            metadata,
            shown_at: Vec::with_capacity(steps),
            clicked_at: Vec::with_capacity(steps),
            put_clicked: f64::NAN,
            finished: false,
        };
        session.commit()?;
        Ok(session)
    }

    /// The session's run index (its part files' number).
    pub fn run_index(&self) -> u64 {
        self.run_index
    }

    /// The session's id.
    pub fn id(&self) -> &str {
        &self.id
    }

    /// The person's pseudonym.
    pub fn participant(&self) -> &str {
        &self.participant
    }

    /// The world taught.
    pub fn spec(&self) -> &Spec {
        self.batch.spec()
    }

    /// The run's parameters.
    pub fn params(&self) -> &Params {
        &self.batch.configs()[0].params
    }

    /// Interactions left (`None`: no limit).
    pub fn budget_left(&self) -> Option<u32> {
        let left = self.batch.cursors()[0].budget_left;
        (self.params().human.budget != NO_LIMIT).then_some(left)
    }

    /// The robot holds a cube now.
    pub fn holding(&self) -> bool {
        self.batch.holds(0)
    }

    /// The last step executed (0 before the first).
    pub fn step_count(&self) -> u32 {
        self.batch.experiment_step(0)
    }

    /// Whether every step has been taken or the session was ended.
    pub fn is_over(&self) -> bool {
        self.finished || self.batch.is_over(0)
    }

    fn now(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Executes the next step and commits it; `None` once the run is over.
    pub fn step(&mut self) -> Result<Option<Shown>, SessionError> {
        if self.is_over() {
            return Ok(None);
        }
        self.batch.advance(1);
        let k = self.step_count() as usize - 1;
        let t = self.batch.trace();
        let actor = t.actor[k];
        self.shown_at.push(self.now());
        let clicked = if actor == Actor::Human {
            self.put_clicked
        } else {
            f64::NAN
        };
        self.clicked_at.push(clicked);
        self.put_clicked = f64::NAN;
        let shown = Shown {
            step: k as u32 + 1,
            state: t.state[k] as usize,
            action: (t.action[k] != NO_ACTION).then_some(usize::from(t.action[k])),
            actor,
            next_state: t.next_state[k] as usize,
            reward: t.reward[k],
            terminal: t.terminal[k],
            event: t.event[k],
            total_reward: self.batch.stats()[0].total_reward,
            budget_left: self.budget_left(),
            holding: self.holding(),
        };
        self.commit()?;
        Ok(Some(shown))
    }

    /// The person takes over at the next step with `action` (a put).
    pub fn take_over(&mut self, action: usize) -> Result<(), Refusal> {
        if self.finished {
            return Err(Refusal::Over);
        }
        self.batch.choose_takeover(0, action)?;
        self.put_clicked = self.now();
        Ok(())
    }

    /// The person congratulates (`positive`) or punishes the robot's action at `step`, the
    /// last executed; committed at once. A refusal changes nothing.
    pub fn judge(&mut self, step: u32, positive: bool) -> Result<HumanEvent, SessionJudgeError> {
        if self.finished {
            return Err(Refusal::Over.into());
        }
        let event = self.batch.judge(0, step, positive)?;
        self.clicked_at[step as usize - 1] = self.now();
        self.commit()?;
        Ok(event)
    }

    /// Ends the session (the person finished, or every step is taken): committed as finished.
    pub fn finish(&mut self) -> Result<(), SessionError> {
        self.finished = true;
        self.commit()
    }

    /// Writes the session's three part files, each atomically, the trace first and the runs
    /// row last (a reader that sees the runs row sees at least its steps).
    fn commit(&self) -> Result<(), SessionError> {
        let name = format!("part-{:06}.parquet", self.run_index);
        let steps = self.step_count() as usize;
        let trace = self.trace_table(steps)?;
        let [runs, series] = crate::pipeline::tables(&self.batch, 1, &[], &[])?;
        let written = self.batch.cursors()[0].checkpoints_written as usize;
        let series = series.slice(0, written.min(series.num_rows()));
        let runs = self.runs_table(runs)?;
        let md = &self.metadata;
        let write = |table: &str, batch: &RecordBatch, schema: &str| {
            let path = self.dir.join(table).join(&name);
            output::write_parquet(&path, batch, output::with_schema(md, schema)).map(|_| ())
        };
        write("trace", &trace, provenance::TRACE_SCHEMA)?;
        write("series", &series, provenance::SERIES_SCHEMA)?;
        write("runs", &runs, provenance::RUNS_SCHEMA)?;
        Ok(())
    }

    /// The trace of the steps taken, with the times each was shown and clicked.
    fn trace_table(&self, steps: usize) -> Result<RecordBatch, OutputError> {
        let full = output::trace_batch(&self.batch)?.slice(0, steps);
        let times = |v: &[f64]| -> ArrayRef {
            Arc::new(Float64Array::from_iter(
                v.iter().take(steps).map(|&x| (!x.is_nan()).then_some(x)),
            ))
        };
        append(
            full,
            vec![
                ("shown_at", times(&self.shown_at)),
                ("clicked_at", times(&self.clicked_at)),
            ],
        )
    }

    /// The runs row with who taught it and whether the session ended.
    fn runs_table(&self, runs: RecordBatch) -> Result<RecordBatch, OutputError> {
        let text = |s: &str| -> ArrayRef { Arc::new(StringArray::from(vec![s.to_owned()])) };
        append(
            runs,
            vec![
                ("participant", text(&self.participant)),
                ("session", text(&self.id)),
                (
                    "finished",
                    Arc::new(BooleanArray::from(vec![self.is_over()])),
                ),
            ],
        )
    }
}

/// A feedback that was refused, or whose commit failed.
#[derive(Debug, thiserror::Error)]
pub enum SessionJudgeError {
    /// Refused: the session goes on.
    #[error(transparent)]
    Refused(#[from] Refusal),
    /// Applied, but not written.
    #[error(transparent)]
    Session(#[from] SessionError),
}

/// `table` with `columns` added at its end (nullable, so every part of a folder concatenates).
fn append(table: RecordBatch, columns: Vec<(&str, ArrayRef)>) -> Result<RecordBatch, OutputError> {
    let schema = table.schema();
    let mut fields: Vec<Field> = schema.fields().iter().map(|f| f.as_ref().clone()).collect();
    let mut arrays: Vec<ArrayRef> = table.columns().to_vec();
    for (name, array) in columns {
        fields.push(output::columns::field(
            name,
            array.data_type().clone(),
            true,
        ));
        arrays.push(array);
    }
    let schema = Schema::new_with_metadata(fields, schema.metadata().clone());
    Ok(RecordBatch::try_new(Arc::new(schema), arrays)?)
}

/// Claims the first free run index in `claims` by creating its file (exclusively, so two
/// servers on one folder never share one), recording the session and its participant.
fn claim(claims: &Path, id: &str, participant: &str) -> Result<u64, SessionError> {
    let err = |source| SessionError::Folder {
        path: claims.to_path_buf(),
        source,
    };
    let mut next = std::fs::read_dir(claims)
        .map_err(err)?
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_suffix(".json")?.parse::<u64>().ok()
        })
        .max()
        .map_or(0, |m| m + 1);
    loop {
        let path = claims.join(format!("{next:06}.json"));
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
        {
            Ok(mut f) => {
                use std::io::Write;
                let record = serde_json::json!({
                    "session": id,
                    "participant": participant,
                    "started_utc": provenance::utc(std::time::SystemTime::now()),
                });
                writeln!(f, "{record}").map_err(err)?;
                return Ok(next);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => next += 1,
            Err(e) => return Err(err(e)),
        }
    }
}

/// A random pseudonym for a person who gave none: `p-` and six hex digits.
pub fn pseudonym() -> String {
    format!("p-{}", &output::atomic::new_run_id()[..6])
}

/// Whether `name` may be a participant's pseudonym: 1 to 40 letters, digits, `-` or `_` (no
/// spaces, no paths, nothing that looks like a person's full name).
pub fn valid_pseudonym(name: &str) -> bool {
    (1..=40).contains(&name.len())
        && name
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
}
