//! Results as Parquet: one row per run (`runs`) and one row per run per checkpoint (`series`),
//! with every parameter and the seed as columns so polars can `group_by` directly (SPEC 8).
//!
//! Files are written to a temporary name beside the target and renamed when complete, so a
//! killed job never leaves a truncated file under the final name. Every file carries its
//! [`provenance`](mod@provenance) as key-value metadata and each column's description and unit as field
//! metadata ([`columns`]); pages are zstd-compressed.

pub mod atomic;
pub mod columns;
pub mod provenance;
mod sink;

pub use provenance::{Context, provenance};
pub use sink::{ParquetSink, write_parquet};

use std::path::PathBuf;
use std::sync::Arc;

use arrow::array::{
    ArrayRef, BooleanArray, Float64Array, Int64Array, RecordBatch, StringArray, UInt64Array,
};
use arrow::datatypes::{DataType, Field, Schema};

use rayon::prelude::*;

use crate::batch::{Batch, RunConfig};
use crate::params::{Kind, PARAMS, Value};

/// Failure to write results.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The file system refused.
    #[error("cannot write {path}")]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The Parquet encoder failed.
    #[error("cannot encode {path} as Parquet")]
    Parquet {
        /// The file concerned.
        path: PathBuf,
        /// The cause.
        source: parquet::errors::ParquetError,
    },
    /// Arrow rejected a batch (a bug: columns of unequal length).
    #[error("internal error building a record batch: {0}")]
    Arrow(#[from] arrow::error::ArrowError),
}

/// Column-by-column builder of one record batch.
#[derive(Default)]
pub struct Columns {
    fields: Vec<Field>,
    arrays: Vec<ArrayRef>,
}

impl Columns {
    /// A non-null float column.
    pub fn f64(&mut self, name: &str, values: impl Iterator<Item = f64>) {
        self.push(
            name,
            false,
            Arc::new(Float64Array::from_iter_values(values)),
        );
    }
    /// A float column where `None` is null.
    pub fn opt_f64(&mut self, name: &str, values: impl Iterator<Item = Option<f64>>) {
        self.push(name, true, Arc::new(values.collect::<Float64Array>()));
    }
    /// A non-null i64 column of unsigned values: every count, step and index is signed, so a
    /// difference of two (`mb_decisions - decisions`) is negative instead of wrapping in pandas,
    /// polars or DuckDB, and 64 bits hold every u32 and every run index unchanged.
    pub fn int<T: Into<u64>>(&mut self, name: &str, values: impl Iterator<Item = T>) {
        self.push(
            name,
            false,
            Arc::new(Int64Array::from_iter_values(values.map(signed))),
        );
    }
    /// An i64 column of unsigned values where `None` is null.
    pub fn opt_int<T: Into<u64>>(&mut self, name: &str, values: impl Iterator<Item = Option<T>>) {
        self.push(
            name,
            true,
            Arc::new(values.map(|v| v.map(signed)).collect::<Int64Array>()),
        );
    }
    /// A non-null u64 column.
    pub fn u64(&mut self, name: &str, values: impl Iterator<Item = u64>) {
        self.push(name, false, Arc::new(UInt64Array::from_iter_values(values)));
    }
    /// A non-null string column.
    pub fn str<'a>(&mut self, name: &str, values: impl Iterator<Item = &'a str>) {
        self.push(
            name,
            false,
            Arc::new(values.map(Some).collect::<StringArray>()),
        );
    }
    /// A non-null boolean column.
    pub fn bool(&mut self, name: &str, values: impl Iterator<Item = bool>) {
        self.push(
            name,
            false,
            Arc::new(values.map(Some).collect::<BooleanArray>()),
        );
    }
    /// A non-null i64 column of values already signed.
    fn push_int(&mut self, name: &str, values: Vec<i64>) {
        self.push(name, false, Arc::new(Int64Array::from(values)));
    }
    fn push(&mut self, name: &str, nullable: bool, array: ArrayRef) {
        let field = columns::field(name, array.data_type().clone(), nullable);
        self.fields.push(field);
        self.arrays.push(array);
    }
    /// The record batch of all columns added.
    pub fn finish(self) -> Result<RecordBatch, OutputError> {
        Ok(RecordBatch::try_new(
            Arc::new(Schema::new(self.fields)),
            self.arrays,
        )?)
    }
}

/// A count or index as i64. Counts are bounded by steps x runs, far below 2^63; saturating
/// keeps a bug from wrapping to a negative count.
fn signed<T: Into<u64>>(v: T) -> i64 {
    i64::try_from(v.into()).unwrap_or(i64::MAX)
}

/// The parameter columns shared by both tables: identity, the task, then every parameter of the
/// registry in its order (SPEC 3–7), one row per config.
pub fn param_columns<'a, I>(cols: &mut Columns, task: &str, configs: I)
where
    I: Iterator<Item = &'a RunConfig> + Clone,
{
    let configs: Vec<&RunConfig> = configs.collect();
    run_param_columns(cols, task, &configs, None);
}

/// [`param_columns`] of rows where the config of run `r` fills `counts[r]` consecutive rows
/// (one row each when `counts` is `None`). Each value is read once per run, not once per row,
/// and a column is written out by filling: a series table repeats its run's parameters on
/// every checkpoint row.
fn run_param_columns(
    cols: &mut Columns,
    task: &str,
    configs: &[&RunConfig],
    counts: Option<&[usize]>,
) {
    let c = configs;
    cols.push_int(
        "run_index",
        repeated(c.iter().map(|r| signed(r.run_index)), counts),
    );
    // The master seed is an identifier, not a quantity: kept unsigned so every accepted
    // --seed (any u64) is written as given.
    let seeds = repeated(c.iter().map(|r| r.seed), counts);
    cols.push("master_seed", false, Arc::new(UInt64Array::from(seeds)));
    let rows = counts.map_or(c.len(), |n| n.iter().sum());
    cols.str("task", std::iter::repeat_n(task, rows));
    // One column per parameter, built side by side: a series table repeats each of them on
    // every checkpoint row, the largest part of building it.
    let params: Vec<Columns> = PARAMS
        .par_iter()
        .map(|p| {
            let mut one = Columns::default();
            let values = c.iter().map(|r| (p.get)(&r.params));
            match p.kind {
                Kind::Real => {
                    let v = repeated(values.map(|v| v.as_f64().unwrap_or(f64::NAN)), counts);
                    one.push(p.name, false, Arc::new(Float64Array::from(v)));
                }
                Kind::Count => {
                    let v = values.map(|v| signed(v.as_count().unwrap_or(0)));
                    one.push_int(p.name, repeated(v, counts));
                }
                Kind::Switch => {
                    let v = repeated(values.map(|v| v == Value::Switch(true)), counts);
                    one.bool(p.name, v.into_iter());
                }
                _ => {
                    let names: Vec<Value> = values.collect();
                    let names = names.iter().map(|v| v.as_str().unwrap_or(""));
                    one.str(p.name, repeated(names, counts).into_iter());
                }
            }
            one
        })
        .collect();
    for one in params {
        cols.fields.extend(one.fields);
        cols.arrays.extend(one.arrays);
    }
}

/// The values of runs, each repeated `counts[r]` times when given.
fn repeated<T: Clone>(values: impl Iterator<Item = T>, counts: Option<&[usize]>) -> Vec<T> {
    let Some(counts) = counts else {
        return values.collect();
    };
    let mut out = Vec::with_capacity(counts.iter().sum());
    for (v, &n) in values.zip(counts) {
        out.resize(out.len() + n, v);
    }
    out
}

/// Whether `name` is a column of [`param_columns`] that repeats a run's configuration (all
/// but the run's index).
fn is_repeated_column(name: &str) -> bool {
    name == "master_seed" || name == "task" || PARAMS.iter().any(|p| p.name == name)
}

fn ratio(num: f64, den: u64) -> Option<f64> {
    (den > 0).then(|| num / den as f64)
}

/// One row per run of the batch: parameters, then SPEC 8's results, the human's counts included.
pub fn runs_batch(batch: &Batch) -> Result<RecordBatch, OutputError> {
    let mut cols = Columns::default();
    let task = batch.spec().name.clone();
    param_columns(&mut cols, &task, batch.configs().iter());
    let s = batch.stats();
    cols.f64("total_reward", s.iter().map(|r| r.total_reward));
    cols.f64("reward_last10", s.iter().map(|r| r.reward_last10));
    cols.opt_int(
        "first_reward_step",
        s.iter()
            .map(|r| (r.first_reward_step > 0).then_some(r.first_reward_step)),
    );
    cols.int("interactions", s.iter().map(|r| r.interactions()));
    cols.int("congratulations", s.iter().map(|r| r.congratulations));
    cols.int("takeovers", s.iter().map(|r| r.takeovers));
    cols.int("punishments", s.iter().map(|r| r.punishments));
    cols.int("rewards_given", s.iter().map(|r| r.rewards_given));
    cols.int("nuisances", s.iter().map(|r| r.nuisances));
    cols.int("forgotten", s.iter().map(|r| r.forgotten));
    cols.opt_int(
        "budget_exhausted_step",
        s.iter()
            .map(|r| (r.budget_exhausted_step > 0).then_some(r.budget_exhausted_step)),
    );
    cols.f64("cost_total", s.iter().map(|r| r.cost_total()));
    cols.f64("cost_mf", s.iter().map(|r| r.cost_mf));
    cols.f64("cost_mb", s.iter().map(|r| r.cost_mb));
    cols.int("decisions", s.iter().map(|r| r.decisions));
    cols.int("mb_decisions", s.iter().map(|r| r.mb_decisions));
    cols.opt_f64(
        "mb_share",
        s.iter().map(|r| ratio(r.mb_decisions as f64, r.decisions)),
    );
    cols.opt_f64(
        "p_mb_mean",
        s.iter().map(|r| ratio(r.p_mb_sum, r.decisions)),
    );
    cols.opt_f64(
        "mean_entropy_chosen",
        s.iter().map(|r| ratio(r.entropy_sum, r.decisions)),
    );
    cols.str("schedule", (0..batch.len()).map(|r| batch.schedule_text(r)));
    cols.opt_int(
        "first_change_step",
        s.iter()
            .map(|r| (r.first_change_step > 0).then_some(r.first_change_step)),
    );
    cols.opt_f64(
        "reward_before_change",
        s.iter()
            .map(|r| (r.first_change_step > 0).then_some(r.reward_before_change)),
    );
    cols.opt_f64(
        "reward_after_change",
        s.iter().map(|r| r.reward_after_change()),
    );
    cols.opt_int("recovery_steps", s.iter().map(|r| r.recovery_steps()));
    // Every task's metric columns, null for runs of other tasks (SPEC 13).
    let own = crate::env::registry::find(&task).map_or(&[][..], |t| t.metrics);
    for m in crate::env::registry::metrics() {
        let mine = own.iter().any(|o| o.name == m.name);
        let values = (0..batch.len()).map(|r| {
            if mine {
                (m.value)(batch.tally(r))
            } else {
                None
            }
        });
        cols.opt_f64(m.name, values);
    }
    cols.int("vi_calls", s.iter().map(|r| r.vi_calls));
    cols.int("vi_sweeps", s.iter().map(|r| r.vi_sweeps));
    cols.int("vi_capped", s.iter().map(|r| r.vi_capped));
    cols.f64("wall_time_s", s.iter().map(|r| r.wall_time_s));
    cols.finish()
}

/// One row per run per checkpoint: parameters, then the cumulative series of SPEC 8.
pub fn series_batch(batch: &Batch) -> Result<RecordBatch, OutputError> {
    let mut cols = Columns::default();
    let task = batch.spec().name.clone();
    let rows = || (0..batch.len()).flat_map(move |r| batch.series(r).iter().map(move |c| (r, c)));
    let configs: Vec<&RunConfig> = batch.configs().iter().collect();
    let counts: Vec<usize> = (0..batch.len()).map(|r| batch.series(r).len()).collect();
    run_param_columns(&mut cols, &task, &configs, Some(&counts));
    cols.int("step", rows().map(|(_, c)| c.step));
    cols.f64("cum_reward", rows().map(|(_, c)| c.cum_reward));
    cols.f64(
        "cum_cost",
        rows().map(|(_, c)| c.cum_cost_mf + c.cum_cost_mb),
    );
    cols.f64("cum_cost_mf", rows().map(|(_, c)| c.cum_cost_mf));
    cols.f64("cum_cost_mb", rows().map(|(_, c)| c.cum_cost_mb));
    cols.opt_f64(
        "p_mb_mean",
        rows().map(|(_, c)| (c.decisions > 0).then_some(c.p_mb_mean)),
    );
    cols.int("decisions", rows().map(|(_, c)| c.decisions));
    cols.int("interactions", rows().map(|(_, c)| c.interactions));
    cols.finish()
}

/// One row per run per experiment step of a traced batch (SPEC 14), runs in batch order, steps
/// in order. Small integers and dictionary columns keep it compact: 4 bytes for states and
/// steps, 2 for the action, 1-byte codes of a 5- and a 6-word dictionary for `actor` and
/// `human_event`. An untraced batch gives a table of no rows.
pub fn trace_batch(batch: &Batch) -> Result<RecordBatch, OutputError> {
    use crate::batch::trace::{Actor, HumanEvent, NO_ACTION};
    use arrow::array::{BooleanArray, DictionaryArray, Int8Array, Int16Array, Int32Array};
    let t = batch.trace();
    let runs = || {
        batch.configs().iter().flat_map(move |c| {
            let n = if t.is_empty() {
                0
            } else {
                crate::batch::trace_rows(&c.params)
            };
            (1..=n).map(move |k| (c.run_index, k))
        })
    };
    let int32 = |v: &[u32]| -> ArrayRef {
        Arc::new(Int32Array::from_iter_values(
            v.iter().map(|&x| i32::try_from(x).unwrap_or(i32::MAX)),
        ))
    };
    let dictionary = |codes: Vec<i8>, names: Vec<&str>| -> Result<ArrayRef, OutputError> {
        let keys = Int8Array::from(codes);
        let values = Arc::new(StringArray::from(names));
        Ok(Arc::new(DictionaryArray::try_new(keys, values)?))
    };
    let mut cols = Columns::default();
    cols.int("run_index", runs().map(|(r, _)| r));
    cols.push(
        "step",
        false,
        Arc::new(Int32Array::from_iter_values(
            runs().map(|(_, k)| i32::try_from(k).unwrap_or(i32::MAX)),
        )),
    );
    cols.push("state", false, int32(&t.state));
    cols.push(
        "action",
        true,
        Arc::new(
            t.action
                .iter()
                .map(|&a| (a != NO_ACTION).then_some(a as i16))
                .collect::<Int16Array>(),
        ),
    );
    cols.push("next_state", false, int32(&t.next_state));
    cols.f64("reward", t.reward.iter().copied());
    cols.push(
        "terminal",
        false,
        Arc::new(BooleanArray::from(t.terminal.clone())),
    );
    cols.push(
        "actor",
        false,
        dictionary(
            t.actor.iter().map(|&a| a as i8).collect(),
            Actor::ALL.iter().map(|a| a.name()).collect(),
        )?,
    );
    cols.opt_f64("p_mb", t.p_mb.iter().map(|&p| (!p.is_nan()).then_some(p)));
    cols.push(
        "human_event",
        false,
        dictionary(
            t.event.iter().map(|&e| e as i8).collect(),
            HumanEvent::ALL.iter().map(|e| e.name()).collect(),
        )?,
    );
    cols.finish()
}

/// The sweep a results file comes from.
#[derive(Debug, Clone, Copy)]
pub struct SweepOrigin<'a> {
    /// The sweep file's text.
    pub text: &'a str,
    /// The sweep file as named on the command line.
    pub file: &'a str,
    /// Runs of the whole sweep.
    pub runs: u64,
    /// Runs per configuration.
    pub seeds: u32,
    /// Shard `I/N` of the sweep, when not the whole sweep.
    pub shard: Option<(u32, u32)>,
}

/// The key-value metadata of every results file of one command (`run`, `sweep`, `reproduce`):
/// the provenance, the sweep it comes from (if any) and the master seed. Its `mbmf_schema` is
/// the runs table's; [`with_schema`] gives the series table's. `command` is the command that
/// writes them, as the front end states it.
pub fn metadata(
    command: &str,
    master_seed: u64,
    sweep: Option<&SweepOrigin<'_>>,
) -> Vec<(String, String)> {
    let context = Context {
        started: None,
        shard: sweep.and_then(|s| s.shard),
        sweep_text: sweep.map(|s| s.text),
        command,
    };
    let mut kv = provenance(provenance::RUNS_SCHEMA, &context);
    if let Some(s) = sweep {
        kv.push(("mbmf_sweep".to_string(), s.text.to_string()));
        kv.push(("mbmf_sweep_file".to_string(), s.file.to_string()));
    }
    kv.push(("master_seed".to_string(), master_seed.to_string()));
    if let Some(s) = sweep {
        kv.push(("mbmf_sweep_runs".to_string(), s.runs.to_string()));
        kv.push(("mbmf_sweep_seeds".to_string(), s.seeds.to_string()));
    }
    kv
}

/// `metadata` with its `mbmf_schema` entry set to `schema` (added if absent).
pub fn with_schema(metadata: &[(String, String)], schema: &str) -> Vec<(String, String)> {
    let mut kv: Vec<(String, String)> = metadata
        .iter()
        .filter(|(k, _)| k != "mbmf_schema")
        .cloned()
        .collect();
    kv.insert(0, ("mbmf_schema".to_string(), schema.to_string()));
    kv
}

/// Schema of a table, for documentation and checks: (name, type, nullable).
pub fn describe(batch: &RecordBatch) -> Vec<(String, DataType, bool)> {
    batch
        .schema()
        .fields()
        .iter()
        .map(|f| (f.name().clone(), f.data_type().clone(), f.is_nullable()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analyses name the parameter columns from the registry alone; this is the check that
    /// they are the columns a run writes, in its order.
    #[test]
    fn the_analyses_know_the_parameter_columns_a_run_writes() {
        let config = RunConfig {
            params: crate::params::Params::default(),
            seed: 0,
            run_index: 0,
        };
        let mut cols = Columns::default();
        param_columns(&mut cols, "tidy1", std::iter::once(&config));
        let written: Vec<String> = cols
            .finish()
            .expect("columns of one row")
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        assert_eq!(written, crate::analysis::dataset::parameter_columns());
        assert_eq!(written[..3], ["run_index", "master_seed", "task"]);
    }
}
