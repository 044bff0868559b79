//! Reading result datasets into a small [`Table`] of Arrow columns, filtering rows and grouping
//! runs by configuration with Arrow's compute kernels.
//!
//! A dataset is what `mbmf run --out DIR` writes (`DIR/runs.parquet`, `DIR/series.parquet`,
//! with `--trace` `DIR/trace.parquet`) or what `mbmf sweep --out DIR` writes
//! (`DIR/runs/part-*.parquet`, `DIR/series/part-*.parquet`, traced: `DIR/trace/part-*.parquet`).
//! [`read_dataset`] accepts either folder, the `runs/` folder itself, or one `.parquet` file.
//! Columns are cast on reading to one of five Arrow types (Float64, Int64, UInt64, Utf8,
//! Boolean; all nullable): whatever the Parquet writer chose (i32 or u64, Utf8 or LargeUtf8,
//! dictionary or not) is widened to one of these, so files written by polars or pandas read the
//! same way, and a dataset whose files disagree on an integer's signedness reads as Int64.

use crate::suggest::closest;
use crate::sweep::store::{self, RUNS_DIR, SERIES_DIR, SWEEP_FILE, TRACE_DIR};
use std::cmp::Ordering;
use std::collections::BTreeSet;
use std::fmt;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};

use arrow::array::{
    Array, ArrayRef, AsArray, BooleanArray, Float64Array, Int64Array, RecordBatch,
    RecordBatchReader, StringArray, UInt32Array, UInt64Array, new_null_array,
};
use arrow::compute::kernels::cmp::eq;
use arrow::compute::{
    CastOptions, SortColumn, and, cast, cast_with_options, concat, concat_batches, filter, is_null,
    lexsort_to_indices, partition, take,
};
use arrow::datatypes::{DataType, Field, Float64Type, Int64Type, Schema, SchemaRef, UInt64Type};
use arrow::error::ArrowError;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// Failure to read a dataset or to find what an analysis asks for in it. Every message names
/// the dataset and says what would be accepted.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// No result files at the given path.
    #[error(
        "no {table} table found at {path}: {detail}; expected a folder written by \
         `mbmf run --out DIR` (DIR/{table}.parquet) or `mbmf sweep --out DIR` \
         (DIR/{table}/part-*.parquet), or a .parquet file"
    )]
    NotFound {
        /// The path given.
        path: PathBuf,
        /// Which table was looked for (`runs` or `series`).
        table: String,
        /// What was found instead.
        detail: String,
    },
    /// The file system refused.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file or folder concerned.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file is not valid Parquet.
    #[error("{path} is not a readable Parquet file: {source}")]
    Parquet {
        /// The file concerned.
        path: PathBuf,
        /// The cause.
        source: parquet::errors::ParquetError,
    },
    /// Arrow failed to decode or convert a column.
    #[error("{path}: cannot decode the data: {source}")]
    Arrow {
        /// The file concerned.
        path: PathBuf,
        /// The cause.
        source: arrow::error::ArrowError,
    },
    /// Two files of one dataset disagree on a column's type.
    #[error(
        "{path}: column '{column}' holds {found} but the earlier files hold {expected}; the \
         files of one dataset must share a schema"
    )]
    SchemaMismatch {
        /// The file where the mismatch was seen.
        path: PathBuf,
        /// The column.
        column: String,
        /// The type in earlier files.
        expected: &'static str,
        /// The type in this file.
        found: &'static str,
    },
    /// An analysis asked for a column the dataset does not have.
    #[error("{dataset} has no column '{column}'{hint}. Available columns: {available}")]
    MissingColumn {
        /// The dataset (its file or folder).
        dataset: String,
        /// The column asked for.
        column: String,
        /// ` (did you mean 'x'?)` or empty.
        hint: String,
        /// The columns it has, comma-separated.
        available: String,
    },
    /// A column holds no numbers where numbers are needed.
    #[error(
        "{dataset}: column '{column}' holds {found}, but {purpose} needs numbers; numeric columns: {numeric}"
    )]
    NotNumeric {
        /// The dataset (its file or folder).
        dataset: String,
        /// The column.
        column: String,
        /// Its type.
        found: &'static str,
        /// What needed numbers (e.g. `--metric`).
        purpose: String,
        /// The numeric columns, comma-separated.
        numeric: String,
    },
    /// A `--where` filter is malformed or does not fit its column.
    #[error("--where '{text}': {reason}")]
    BadFilter {
        /// The filter as given.
        text: String,
        /// What is wrong and what would be accepted.
        reason: String,
    },
    /// A file or folder holds another table than the one asked for (a series table given to
    /// an analysis of runs).
    #[error("{path} is {found}, not a {expected} table; {hint}")]
    WrongTable {
        /// The file or folder.
        path: PathBuf,
        /// What it holds.
        found: String,
        /// The table asked for (`runs` or `series`).
        expected: String,
        /// What to give instead.
        hint: String,
    },
    /// A file among a dataset's files that mbmf did not write as that table.
    #[error(
        "{path}: {found}; every file of a dataset folder must carry mbmf_schema {expected}{hint}"
    )]
    ForeignFile {
        /// The file.
        path: PathBuf,
        /// What its metadata says.
        found: String,
        /// The schema versions accepted.
        expected: String,
        /// What to do.
        hint: String,
    },
    /// A sweep that misses runs or is still being written.
    #[error("{dir} is {state}: {done} of {total} runs are committed; {advice}")]
    Incomplete {
        /// The sweep's folder.
        dir: PathBuf,
        /// `incomplete`, or who is still writing it.
        state: String,
        /// Runs committed.
        done: u64,
        /// Runs of the whole sweep (`an unknown number of` when no part records it yet).
        total: String,
        /// How to finish it, or to analyse it anyway.
        advice: String,
    },
    /// The parts of a sweep folder do not form one dataset (a run twice, a part of another
    /// sweep, a runs part without its series part).
    #[error(transparent)]
    Store(#[from] crate::sweep::store::StoreError),
    /// The runs and series files of an `mbmf run` folder come from different runs.
    #[error(
        "{series} (mbmf_run_id {series_id}) does not belong to {runs} (mbmf_run_id {runs_id}): \
         the two files come from different runs; rerun mbmf run into this folder with --force"
    )]
    PairMismatch {
        /// The runs file.
        runs: PathBuf,
        /// Its run id.
        runs_id: String,
        /// The series file.
        series: PathBuf,
        /// Its run id.
        series_id: String,
    },
    /// Filtering left no rows.
    #[error(
        "{dataset}: no run matches --where '{text}'; values of '{column}' in the data: {values}"
    )]
    NoMatch {
        /// The dataset (its file or folder).
        dataset: String,
        /// The filter that removed the last rows.
        text: String,
        /// Its column.
        column: String,
        /// The distinct values present (at most 20 shown).
        values: String,
    },
}

/// One column of a [`Table`]: an Arrow array of Float64, Int64, UInt64, Utf8 or Boolean, every
/// value nullable.
#[derive(Debug, Clone)]
pub struct Column(ArrayRef);

impl PartialEq for Column {
    fn eq(&self, other: &Column) -> bool {
        self.0.as_ref() == other.0.as_ref()
    }
}

impl Column {
    /// Floats, `None` for null.
    pub fn floats(values: impl IntoIterator<Item = Option<f64>>) -> Column {
        Column(Arc::new(Float64Array::from_iter(values)))
    }

    /// Unsigned integers, `None` for null.
    pub fn uints(values: impl IntoIterator<Item = Option<u64>>) -> Column {
        Column(Arc::new(UInt64Array::from_iter(values)))
    }

    /// Signed integers, `None` for null.
    pub fn ints(values: impl IntoIterator<Item = Option<i64>>) -> Column {
        Column(Arc::new(Int64Array::from_iter(values)))
    }

    /// Text, `None` for null.
    pub fn texts<S: AsRef<str>>(values: impl IntoIterator<Item = Option<S>>) -> Column {
        Column(Arc::new(StringArray::from_iter(values)))
    }

    /// Booleans, `None` for null.
    pub fn bools(values: impl IntoIterator<Item = Option<bool>>) -> Column {
        Column(Arc::new(BooleanArray::from_iter(values)))
    }

    /// The Arrow array.
    pub fn array(&self) -> &ArrayRef {
        &self.0
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// `true` when the column has no values.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The type's name, for messages (signed and unsigned integers alike: which one a file
    /// holds is the writer's choice, not something a reader should have to care about).
    pub fn type_name(&self) -> &'static str {
        type_name(self.0.data_type())
    }

    /// `true` for floats and integers.
    pub fn is_numeric(&self) -> bool {
        self.0.data_type().is_numeric()
    }

    /// Value `i` as a float, `None` when null or not numeric.
    pub fn f64_at(&self, i: usize) -> Option<f64> {
        self.value(i).as_f64()
    }

    /// Value `i`.
    pub fn value(&self, i: usize) -> Value {
        let a = &self.0;
        if a.is_null(i) {
            return Value::Null;
        }
        match a.data_type() {
            DataType::Float64 => Value::Float(a.as_primitive::<Float64Type>().value(i)),
            DataType::Int64 => Value::Int(a.as_primitive::<Int64Type>().value(i)),
            DataType::UInt64 => Value::UInt(a.as_primitive::<UInt64Type>().value(i)),
            DataType::Boolean => Value::Bool(a.as_boolean().value(i)),
            _ => Value::Str(a.as_string::<i32>().value(i).to_owned()),
        }
    }

    /// The values at `rows`, in that order.
    ///
    /// # Panics
    /// If a row is out of range (a bug in the caller).
    pub fn take(&self, rows: &[usize]) -> Column {
        let indices = UInt64Array::from_iter_values(rows.iter().map(|&r| r as u64));
        Column(take(&self.0, &indices, None).expect("row indices within the column"))
    }

    /// The values where `mask` is true.
    fn filter(&self, mask: &BooleanArray) -> Column {
        Column(filter(&self.0, mask).expect("a mask as long as the column"))
    }

    /// A column of the same type holding `values` (which must match that type or be null).
    pub fn from_values(like: &Column, values: &[Value]) -> Column {
        match like.0.data_type() {
            DataType::Float64 => Column::floats(values.iter().map(Value::as_f64)),
            DataType::Int64 => Column(Arc::new(Int64Array::from_iter(values.iter().map(
                |v| match v {
                    Value::Int(x) => Some(*x),
                    _ => None,
                },
            )))),
            DataType::UInt64 => Column::uints(values.iter().map(|v| match v {
                Value::UInt(x) => Some(*x),
                _ => None,
            })),
            DataType::Boolean => Column::bools(values.iter().map(|v| match v {
                Value::Bool(b) => Some(*b),
                _ => None,
            })),
            _ => Column::texts(values.iter().map(|v| match v {
                Value::Str(s) => Some(s.as_str()),
                _ => None,
            })),
        }
    }

    /// Casts an Arrow array to the column type it reads as, or `None` for types the analyses
    /// do not use (lists, dates...).
    fn from_arrow(array: &ArrayRef) -> Result<Option<Column>, ArrowError> {
        let dt = array.data_type();
        let to = if dt.is_floating() {
            DataType::Float64
        } else if dt.is_signed_integer() {
            DataType::Int64
        } else if dt.is_unsigned_integer() {
            DataType::UInt64
        } else if *dt == DataType::Boolean {
            DataType::Boolean
        } else if is_text(dt) {
            DataType::Utf8
        } else {
            return Ok(None);
        };
        Ok(Some(Column(cast(array, &to)?)))
    }
}

fn type_name(dt: &DataType) -> &'static str {
    match dt {
        DataType::Float64 => "floats",
        DataType::Int64 | DataType::UInt64 => "integers",
        DataType::Boolean => "booleans",
        _ => "text",
    }
}

fn is_text(dt: &DataType) -> bool {
    match dt {
        DataType::Utf8 | DataType::LargeUtf8 | DataType::Utf8View => true,
        DataType::Dictionary(_, value) => is_text(value),
        _ => false,
    }
}

/// One cell of a [`Table`], used as a grouping key and for display.
///
/// Values order as: null, booleans, numbers (by numeric value across the three number types),
/// text. Floats order by `f64::total_cmp`, so the order is total and NaN is a value like any
/// other.
#[derive(Debug, Clone)]
pub enum Value {
    /// A missing value.
    Null,
    /// A boolean.
    Bool(bool),
    /// A signed integer.
    Int(i64),
    /// An unsigned integer.
    UInt(u64),
    /// A float.
    Float(f64),
    /// Text.
    Str(String),
}

impl Value {
    /// The value as a float (numbers only).
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Int(x) => Some(*x as f64),
            Value::UInt(x) => Some(*x as f64),
            Value::Float(x) => Some(*x),
            _ => None,
        }
    }

    fn class(&self) -> u8 {
        match self {
            Value::Null => 0,
            Value::Bool(_) => 1,
            Value::Int(_) | Value::UInt(_) | Value::Float(_) => 2,
            Value::Str(_) => 3,
        }
    }

    fn variant(&self) -> u8 {
        match self {
            Value::Null => 0,
            Value::Bool(_) => 1,
            Value::Int(_) => 2,
            Value::UInt(_) => 3,
            Value::Float(_) => 4,
            Value::Str(_) => 5,
        }
    }
}

impl Ord for Value {
    fn cmp(&self, other: &Self) -> Ordering {
        match (self, other) {
            (Value::Bool(a), Value::Bool(b)) => a.cmp(b),
            (Value::Int(a), Value::Int(b)) => a.cmp(b),
            (Value::UInt(a), Value::UInt(b)) => a.cmp(b),
            (Value::Float(a), Value::Float(b)) => a.total_cmp(b),
            (Value::Str(a), Value::Str(b)) => a.cmp(b),
            _ if self.class() == 2 && other.class() == 2 => {
                let (a, b) = (self.as_f64().unwrap_or(0.0), other.as_f64().unwrap_or(0.0));
                a.total_cmp(&b)
                    .then_with(|| self.variant().cmp(&other.variant()))
            }
            _ => self
                .class()
                .cmp(&other.class())
                .then_with(|| self.variant().cmp(&other.variant())),
        }
    }
}

impl PartialOrd for Value {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl PartialEq for Value {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Value {}

impl fmt::Display for Value {
    /// Floats in their shortest round-trip form (`0.1`, `9`), null as `null`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Value::Null => f.pad("null"),
            Value::Bool(b) => f.pad(if *b { "true" } else { "false" }),
            Value::Int(x) => f.pad(&x.to_string()),
            Value::UInt(x) => f.pad(&x.to_string()),
            Value::Float(x) => f.pad(&x.to_string()),
            Value::Str(s) => f.pad(s),
        }
    }
}

/// Named columns of equal length, read from a dataset or built by an analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    source: String,
    names: Vec<String>,
    columns: Vec<Column>,
    rows: usize,
    skipped: Vec<(String, String)>,
}

impl Table {
    /// An empty table; `source` names it in error messages (a path, or what computed it).
    pub fn new(source: impl Into<String>) -> Table {
        Table {
            source: source.into(),
            names: Vec::new(),
            columns: Vec::new(),
            rows: 0,
            skipped: Vec::new(),
        }
    }

    /// Adds a column; replaces one of the same name.
    ///
    /// # Panics
    /// If the table already has columns of another length (a bug in the caller).
    pub fn push(&mut self, name: impl Into<String>, column: Column) {
        let name = name.into();
        if self.columns.is_empty() {
            self.rows = column.len();
        }
        assert_eq!(
            column.len(),
            self.rows,
            "column '{name}' has {} values but the table has {} rows",
            column.len(),
            self.rows
        );
        match self.names.iter().position(|n| *n == name) {
            Some(i) => self.columns[i] = column,
            None => {
                self.names.push(name);
                self.columns.push(column);
            }
        }
    }

    /// The same table under another name (its source in messages).
    pub fn renamed(mut self, source: impl Into<String>) -> Table {
        self.source = source.into();
        self
    }

    /// `tables` one after the other, as one table named `source`: every column of any table,
    /// null in those that lack it.
    pub fn stack(source: impl Into<String>, tables: &[Table]) -> Result<Table, DatasetError> {
        let parts: Vec<(Table, PathBuf)> = tables
            .iter()
            .map(|t| (t.clone(), PathBuf::from(&t.source)))
            .collect();
        Table::concat(source.into(), &parts)
    }

    /// What the table was read from (or computed by), for messages.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.rows
    }

    /// `true` when the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.rows == 0
    }

    /// Column names, in file order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Columns the reader left out because of their type, with the type: `(name, type)`.
    pub fn skipped(&self) -> &[(String, String)] {
        &self.skipped
    }

    /// `true` when the table has a column `name`.
    pub fn has(&self, name: &str) -> bool {
        self.names.iter().any(|n| n == name)
    }

    /// The column `name`, or an error listing the columns and the closest name.
    pub fn column(&self, name: &str) -> Result<&Column, DatasetError> {
        match self.names.iter().position(|n| n == name) {
            Some(i) => Ok(&self.columns[i]),
            None => Err(self.missing(name)),
        }
    }

    /// The error for a column that is not there.
    pub fn missing(&self, name: &str) -> DatasetError {
        let hint = closest(name, self.names.iter().map(String::as_str))
            .map(|c| format!(" (did you mean '{c}'?)"))
            .unwrap_or_default();
        let mut available = self.names.join(", ");
        for (n, t) in &self.skipped {
            available.push_str(&format!(", {n} (type {t}, not readable here)"));
        }
        DatasetError::MissingColumn {
            dataset: self.source.clone(),
            column: name.to_owned(),
            hint,
            available,
        }
    }

    /// The numeric column `name` as floats (null stays `None`); `purpose` says who needs it
    /// (e.g. `--metric`), for the error when the column is not numeric.
    pub fn numeric(&self, name: &str, purpose: &str) -> Result<Vec<Option<f64>>, DatasetError> {
        let column = self.column(name)?;
        if !column.is_numeric() {
            return Err(DatasetError::NotNumeric {
                dataset: self.source.clone(),
                column: name.to_owned(),
                found: column.type_name(),
                purpose: purpose.to_owned(),
                numeric: self.numeric_names().join(", "),
            });
        }
        let floats = cast(column.array(), &DataType::Float64).map_err(|e| self.arrow_error(e))?;
        Ok(floats.as_primitive::<Float64Type>().iter().collect())
    }

    /// Names of the numeric columns.
    pub fn numeric_names(&self) -> Vec<String> {
        self.names
            .iter()
            .zip(&self.columns)
            .filter(|(_, c)| c.is_numeric())
            .map(|(n, _)| n.clone())
            .collect()
    }

    /// The rows at `rows`, in that order, as a new table with the same source.
    pub fn take(&self, rows: &[usize]) -> Table {
        self.with_columns(
            self.columns.iter().map(|c| c.take(rows)).collect(),
            rows.len(),
        )
    }

    /// The rows where `mask` is true, as a new table with the same source.
    fn filter(&self, mask: &BooleanArray) -> Table {
        let rows = mask.true_count();
        self.with_columns(self.columns.iter().map(|c| c.filter(mask)).collect(), rows)
    }

    fn with_columns(&self, columns: Vec<Column>, rows: usize) -> Table {
        Table {
            source: self.source.clone(),
            names: self.names.clone(),
            columns,
            rows,
            skipped: self.skipped.clone(),
        }
    }

    fn arrow_error(&self, source: ArrowError) -> DatasetError {
        DatasetError::Arrow {
            path: PathBuf::from(&self.source),
            source,
        }
    }

    /// A table of Arrow record batches of `schema` (a file's, or another program's table),
    /// read as a Parquet file is: columns of types the analyses do not use are skipped.
    pub fn from_batches(
        source: impl Into<String>,
        schema: &SchemaRef,
        batches: &[RecordBatch],
    ) -> Result<Table, DatasetError> {
        let mut table = Table::new(source);
        let batch = concat_batches(schema, batches).map_err(|e| table.arrow_error(e))?;
        for (field, array) in schema.fields().iter().zip(batch.columns()) {
            match Column::from_arrow(array).map_err(|e| table.arrow_error(e))? {
                Some(column) => table.push(field.name().clone(), column),
                None => table
                    .skipped
                    .push((field.name().clone(), field.data_type().to_string())),
            }
        }
        Ok(table)
    }

    /// The table as one Arrow record batch (every field nullable), e.g. for `write_parquet`.
    pub fn to_record_batch(&self) -> Result<RecordBatch, ArrowError> {
        let arrays: Vec<ArrayRef> = self.columns.iter().map(|c| c.0.clone()).collect();
        let fields: Vec<Field> = self
            .names
            .iter()
            .zip(&arrays)
            .map(|(n, a)| Field::new(n, a.data_type().clone(), true))
            .collect();
        RecordBatch::try_new(Arc::new(Schema::new(fields)), arrays)
    }

    /// The files' tables one after the other: every column of any file, null in the files
    /// that lack it; integers of both signs in one column become Int64.
    fn concat(source: String, parts: &[(Table, PathBuf)]) -> Result<Table, DatasetError> {
        let mut table = Table::new(source);
        for (part, _) in parts {
            for name in &part.names {
                if !table.has(name) {
                    table.names.push(name.clone());
                }
            }
            for s in &part.skipped {
                if !table.skipped.contains(s) {
                    table.skipped.push(s.clone());
                }
            }
        }
        for name in &table.names {
            let mut dt = parts
                .iter()
                .find_map(|(p, _)| p.column(name).ok())
                .map(|c| c.0.data_type().clone())
                .expect("a column of some part");
            let integer = |d: &DataType| d.is_integer();
            let of = |p: &Table| p.column(name).ok().map(|c| c.0.data_type().clone());
            if integer(&dt) && parts.iter().filter_map(|(p, _)| of(p)).any(|d| d != dt) {
                dt = DataType::Int64;
            }
            let mut arrays = Vec::with_capacity(parts.len());
            for (part, path) in parts {
                let array = match part.column(name) {
                    Ok(c) if *c.0.data_type() == dt => c.0.clone(),
                    Ok(c) if integer(&dt) && c.0.data_type().is_integer() => {
                        let strict = CastOptions {
                            safe: false,
                            ..CastOptions::default()
                        };
                        cast_with_options(&c.0, &dt, &strict).map_err(|source| {
                            DatasetError::Arrow {
                                path: path.clone(),
                                source,
                            }
                        })?
                    }
                    Ok(c) => {
                        return Err(DatasetError::SchemaMismatch {
                            path: path.clone(),
                            column: name.clone(),
                            expected: type_name(&dt),
                            found: c.type_name(),
                        });
                    }
                    Err(_) => new_null_array(&dt, part.rows),
                };
                arrays.push(array);
            }
            let refs: Vec<&dyn Array> = arrays.iter().map(|a| a.as_ref()).collect();
            let joined = concat(&refs).map_err(|e| table.arrow_error(e))?;
            table.columns.push(Column(joined));
        }
        table.rows = parts.iter().map(|(p, _)| p.rows).sum();
        Ok(table)
    }
}

/// Reads one Parquet file into a table.
pub fn read_parquet_file(path: &Path) -> Result<Table, DatasetError> {
    read_file(path).map(|(table, _)| table)
}

/// Reads one Parquet file into a table, with its `mbmf_schema` (e.g. `runs/2`) if it has one.
fn read_file(path: &Path) -> Result<(Table, Option<String>), DatasetError> {
    let file = File::open(path).map_err(|source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let parquet_err = |source| DatasetError::Parquet {
        path: path.to_path_buf(),
        source,
    };
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(parquet_err)?;
    let schema_version = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .and_then(|kv| kv.iter().find(|k| k.key == "mbmf_schema"))
        .and_then(|k| k.value.clone());
    let reader = builder.build().map_err(parquet_err)?;
    let arrow_err = |source| DatasetError::Arrow {
        path: path.to_path_buf(),
        source,
    };
    let schema = reader.schema();
    let batches = reader.collect::<Result<Vec<_>, _>>().map_err(arrow_err)?;
    let table = Table::from_batches(path.display().to_string(), &schema, &batches)?;
    Ok((table, schema_version))
}

/// The newest version of table `name` this build writes (the `N` of `runs/N`).
fn current_version(name: &str) -> u32 {
    let schema = match name {
        "series" => crate::output::provenance::SERIES_SCHEMA,
        "trace" => crate::output::provenance::TRACE_SCHEMA,
        _ => crate::output::provenance::RUNS_SCHEMA,
    };
    schema
        .rsplit_once('/')
        .and_then(|(_, n)| n.parse().ok())
        .unwrap_or(1)
}

/// Where the runs table of the dataset holding the series file or folder `path` is.
fn runs_instead(path: &Path) -> String {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    let dataset = match parent {
        Some(p) if p.file_name().is_some_and(|n| n == SERIES_DIR) => p.parent(),
        Some(p) if path.is_dir() && p.join(SWEEP_FILE).is_file() => Some(p),
        other => other,
    };
    match dataset {
        Some(d) => format!(
            "give the dataset folder {} (or its runs table)",
            d.display()
        ),
        None => "give the runs table (runs.parquet, or the dataset folder)".to_owned(),
    }
}

/// Checks that `table`, read from `path` with metadata `schema`, is a version of table `name`
/// that this build reads. A file without `mbmf_schema` (written by polars, pandas or an old
/// mbmf) is accepted when `trusted` (given alone, or a part its sweep vouches for), and refused
/// among the files of a folder; either way a series table is never read as runs.
fn check_schema(
    path: &Path,
    schema: Option<&str>,
    name: &str,
    trusted: bool,
    table: &Table,
) -> Result<(), DatasetError> {
    let current = current_version(name);
    let expected = if current > 1 {
        format!("{name}/1 to {name}/{current}")
    } else {
        format!("{name}/1")
    };
    let series_as_runs = |found: String| DatasetError::WrongTable {
        path: path.to_path_buf(),
        found,
        expected: name.to_owned(),
        hint: format!(
            "the analysis reads the runs table (one row per run; a series table has one row per \
             checkpoint, so each run would count many times): {}",
            runs_instead(path)
        ),
    };
    let Some(schema) = schema else {
        if name == "runs" && table.has("step") && !table.has("total_reward") {
            return Err(series_as_runs(
                "a series table (it has a step column and no total_reward)".to_owned(),
            ));
        }
        if trusted {
            return Ok(());
        }
        return Err(DatasetError::ForeignFile {
            path: path.to_path_buf(),
            found: "it has no mbmf_schema, so mbmf did not write it as a table of this dataset"
                .to_owned(),
            expected,
            hint: "; move it out of the folder, or give the file's own path to analyse it alone"
                .to_owned(),
        });
    };
    let (table_name, version) = schema.split_once('/').unwrap_or((schema, ""));
    match version.parse::<u32>() {
        Ok(v) if table_name == name && (1..=current).contains(&v) => Ok(()),
        _ if name == "runs" && table_name == "series" => Err(series_as_runs(format!(
            "a series table (mbmf_schema {schema})"
        ))),
        Ok(v) if table_name == name && v > current => Err(DatasetError::ForeignFile {
            path: path.to_path_buf(),
            found: format!("its mbmf_schema {schema} is newer than this mbmf reads"),
            expected,
            hint: ": read it with the mbmf that wrote it".to_owned(),
        }),
        _ => Err(DatasetError::ForeignFile {
            path: path.to_path_buf(),
            found: format!("its mbmf_schema is {schema}, not a {name} table"),
            expected,
            hint: String::new(),
        }),
    }
}

/// How [`read_table`] treats a sweep that is not finished.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ReadOptions {
    /// Read the runs a sweep has committed even when it misses some or is still being written
    /// (with a warning); by default such a sweep is refused, so that a partial result is never
    /// taken for the whole.
    pub allow_incomplete: bool,
}

/// A table read by [`read_table`], and what the caller should tell the user about it.
#[derive(Debug, Clone)]
pub struct Read {
    /// The table.
    pub table: Table,
    /// Files left out, an unfinished sweep read anyway: one sentence each.
    pub warnings: Vec<String>,
}

/// The files of one table of a dataset, as [`locate`] finds them.
struct Located {
    files: Vec<PathBuf>,
    /// Whether a file without `mbmf_schema` may be read (see [`check_schema`]).
    trusted: bool,
    source: String,
    warnings: Vec<String>,
}

/// Whether `name` is a part name: `part-` and dash-separated digits (`part-000000-000255`,
/// `part-00001`), then `.parquet`; a copy (`part-000000-000255 (1).parquet`) is not.
fn is_part_name(name: &str) -> bool {
    name.strip_prefix("part-")
        .and_then(|n| n.strip_suffix(".parquet"))
        .is_some_and(|n| {
            n.split('-')
                .all(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
        })
}

fn ignored(file: &Path, why: &str) -> String {
    format!("ignoring {}: {why}; it is not counted", file.display())
}

/// The sweep folder that `path` is, or whose `runs/` or `series/` folder it is.
fn sweep_root(path: &Path) -> Option<PathBuf> {
    if path.join(SWEEP_FILE).is_file() {
        return Some(path.to_path_buf());
    }
    let parent = path.parent()?;
    let sub = path.file_name()?;
    ((sub == RUNS_DIR || sub == SERIES_DIR || sub == TRACE_DIR)
        && parent.join(SWEEP_FILE).is_file())
    .then(|| parent.to_path_buf())
}

/// The committed parts of table `name` of the sweep folder `root` (given as `path`).
fn locate_sweep(
    path: &Path,
    root: &Path,
    name: &str,
    options: &ReadOptions,
) -> Result<Located, DatasetError> {
    let committed = store::committed(root)?;
    let table_dir = root.join(name);
    if name == TRACE_DIR && !committed.traced {
        return Err(DatasetError::NotFound {
            path: path.to_path_buf(),
            table: name.to_owned(),
            detail: "the sweep was run without the trace (add trace = true to a new sweep, or \
                     pass --trace)"
                .to_owned(),
        });
    }
    let mut warnings: Vec<String> = committed
        .strays
        .iter()
        .filter(|f| f.parent() == Some(table_dir.as_path()))
        .map(|f| store::stray_warning(f))
        .collect();
    if !committed.is_complete() {
        let total = committed
            .total
            .map_or_else(|| "an unknown number of".to_owned(), |t| t.to_string());
        let state = if committed.writers.is_empty() {
            "incomplete".to_owned()
        } else {
            format!("still being written by {}", committed.writers.join(", "))
        };
        if !options.allow_incomplete {
            return Err(DatasetError::Incomplete {
                dir: root.to_path_buf(),
                state,
                done: committed.done,
                total,
                advice: format!(
                    "finish it (mbmf sweep {} --out {} --resume, or wait for the writer), or pass \
                     --allow-incomplete to analyse the runs present",
                    root.join(SWEEP_FILE).display(),
                    root.display()
                ),
            });
        }
        warnings.push(format!(
            "{} is {state}: analysing the {} of {total} runs committed so far (--allow-incomplete)",
            root.display(),
            committed.done
        ));
    }
    let files: Vec<PathBuf> = committed.parts.iter().map(|p| table_dir.join(p)).collect();
    let source = match files.len() {
        1 => format!("{} (1 {name} file)", path.display()),
        n => format!("{} ({n} {name} files)", path.display()),
    };
    Ok(Located {
        files,
        trusted: true,
        source,
        warnings,
    })
}

/// The part files of `dir`, a folder that no sweep vouches for: those named `part-…` if any
/// (copies warned about and left out), else every `.parquet` file (`any` only).
fn loose_parts(
    dir: &Path,
    any: bool,
    warnings: &mut Vec<String>,
) -> Result<Vec<PathBuf>, DatasetError> {
    let named = parquet_files(dir, |n| n.starts_with("part-"))?;
    if named.is_empty() {
        return if any {
            parquet_files(dir, |_| true)
        } else {
            Ok(named)
        };
    }
    let (parts, copies): (Vec<PathBuf>, Vec<PathBuf>) = named.into_iter().partition(|p| {
        p.file_name()
            .is_some_and(|n| is_part_name(&n.to_string_lossy()))
    });
    for copy in &copies {
        warnings.push(ignored(
            copy,
            "its name is not a part name (part-NUMBERS.parquet), as a copy's would be",
        ));
    }
    Ok(parts)
}

/// The files of table `name` at `path` (see [`read_table`]).
fn locate(path: &Path, name: &str, options: &ReadOptions) -> Result<Located, DatasetError> {
    let not_found = |detail: String| DatasetError::NotFound {
        path: path.to_path_buf(),
        table: name.to_owned(),
        detail,
    };
    if path.is_file() {
        return Ok(Located {
            files: vec![path.to_path_buf()],
            trusted: true,
            source: path.display().to_string(),
            warnings: Vec::new(),
        });
    }
    if !path.is_dir() {
        return Err(not_found("no such file or folder".to_owned()));
    }
    if let Some(root) = sweep_root(path) {
        if name == RUNS_DIR && path.file_name().is_some_and(|n| n == SERIES_DIR) && root != path {
            return Err(DatasetError::WrongTable {
                path: path.to_path_buf(),
                found: format!(
                    "the series folder of the sweep {} (one row per checkpoint)",
                    root.display()
                ),
                expected: name.to_owned(),
                hint: format!(
                    "the analysis reads the runs table (one row per run): give {} or {}",
                    root.display(),
                    root.join(RUNS_DIR).display()
                ),
            });
        }
        return locate_sweep(path, &root, name, options);
    }
    let mut warnings = Vec::new();
    let single = path.join(format!("{name}.parquet"));
    let folder = path.join(name);
    // Only `part-*` files when there are any: an analysis run on the `NAME/` folder itself
    // wrote its own results (pareto.parquet, ...) there in earlier versions, which are not runs.
    let parts = if folder.is_dir() {
        loose_parts(&folder, true, &mut warnings)?
    } else {
        Vec::new()
    };
    let runs_file = path.join("runs.parquet");
    if name == TRACE_DIR && single.is_file() && runs_file.is_file() && parts.is_empty() {
        // The trace of the last committed `mbmf run`, never one an earlier run left.
        return match crate::output::atomic::committed_trace(path) {
            Some(file) => Ok(Located {
                source: file.display().to_string(),
                files: vec![file],
                trusted: true,
                warnings,
            }),
            None => Err(not_found(format!(
                "{} is not the trace of the run in {} (an earlier run's, or an unfinished \
                 commit's); run again with --trace",
                single.display(),
                runs_file.display()
            ))),
        };
    }
    if single.is_file() || (name == "series" && runs_file.is_file()) {
        if !parts.is_empty() {
            return Err(not_found(format!(
                "it holds both {} and {} part files in {}; pass the one you mean",
                single.display(),
                parts.len(),
                folder.display()
            )));
        }
        // The series file of the last committed `mbmf run` (an interrupted commit keeps the
        // previous one under a hidden name), and never one of another run.
        let file = crate::output::atomic::committed_file(path, name);
        if name == "series" {
            let ids = (
                crate::output::atomic::run_id(&runs_file),
                crate::output::atomic::run_id(&file),
            );
            if let (Some(runs_id), Some(series_id)) = ids
                && runs_id != series_id
            {
                return Err(DatasetError::PairMismatch {
                    runs: runs_file,
                    runs_id,
                    series: file,
                    series_id,
                });
            }
        }
        if file.is_file() {
            return Ok(Located {
                source: file.display().to_string(),
                files: vec![file],
                trusted: true,
                warnings,
            });
        }
    }
    let parts = if parts.is_empty() {
        loose_parts(path, false, &mut warnings)?
    } else {
        parts
    };
    if !parts.is_empty() {
        warnings.push(format!(
            "{} is not a sweep dataset (no {SWEEP_FILE}): reading its {} {name} part file(s) \
             as given; whether runs are missing or repeated cannot be checked",
            path.display(),
            parts.len()
        ));
        let source = match parts.len() {
            1 => format!("{} (1 {name} file)", path.display()),
            n => format!("{} ({n} {name} files)", path.display()),
        };
        return Ok(Located {
            files: parts,
            trusted: false,
            source,
            warnings,
        });
    }
    let mut entries: Vec<String> = std::fs::read_dir(path)
        .map_err(|source| DatasetError::Io {
            path: path.to_path_buf(),
            source,
        })?
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    entries.sort();
    let shown = if entries.is_empty() {
        "the folder is empty".to_owned()
    } else {
        let more = entries.len().saturating_sub(10);
        let mut s = format!(
            "the folder holds {}",
            entries[..entries.len().min(10)].join(", ")
        );
        if more > 0 {
            s.push_str(&format!(" and {more} more"));
        }
        s
    };
    Err(not_found(shown))
}

fn parquet_files(dir: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>, DatasetError> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| DatasetError::Io {
            path: dir.to_path_buf(),
            source,
        })?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            let n = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            !n.starts_with('.') && n.ends_with(".parquet") && keep(&n) && p.is_file()
        })
        .collect();
    files.sort();
    Ok(files)
}

/// Reads table `name` (`runs` or `series`) of the dataset at `path`: `path` itself if it is a
/// file; a sweep folder (`DIR/sweep.toml`; or its `runs/` or `series/` folder): the parts its
/// store committed, refusing parts that do not form one dataset and, unless
/// [`ReadOptions::allow_incomplete`], a sweep missing runs or still being written; an `mbmf
/// run` folder: `DIR/NAME.parquet` (the series file of the same run); else the `part-*.parquet`
/// files of `DIR/NAME/` (any `*.parquet` there if none is named `part-*`) or of `DIR`. Hidden
/// files (a writer's temporary files) are never read; files that only look like parts (copies)
/// are left out with a warning. Every file must be a version of table `name`; a file without
/// `mbmf_schema` is read only alone or as a part of its sweep. Files are concatenated in name
/// order; a column missing from some files is null there.
pub fn read_table(path: &Path, name: &str, options: &ReadOptions) -> Result<Read, DatasetError> {
    let located = locate(path, name, options)?;
    let mut parts = Vec::with_capacity(located.files.len());
    for file in located.files {
        let (table, schema) = read_file(&file)?;
        check_schema(&file, schema.as_deref(), name, located.trusted, &table)?;
        parts.push((table, file));
    }
    Ok(Read {
        table: Table::concat(located.source, &parts)?,
        warnings: located.warnings,
    })
}

/// [`read_table`] with the default options (an unfinished sweep is refused); its warnings are
/// dropped, for callers that read a dataset they have just written.
pub fn read_dataset(path: &Path, name: &str) -> Result<Table, DatasetError> {
    read_table(path, name, &ReadOptions::default()).map(|r| r.table)
}

/// Reads the `runs` table of a dataset (see [`read_dataset`]).
pub fn read_runs(path: &Path) -> Result<Table, DatasetError> {
    read_dataset(path, "runs")
}

/// Reads the `trace` table of a traced dataset (SPEC 14; see [`read_dataset`]): one row per run
/// per experiment step, only what was committed with the runs. Integer columns read as Int64
/// and the dictionary columns (`actor`, `human_event`) as text, as every column of a table.
pub fn read_trace(path: &Path) -> Result<Table, DatasetError> {
    read_dataset(path, "trace")
}

/// The folder analyses write into by default: `analysis/` in the dataset's folder, never among
/// the data files, so `pd.read_parquet(DIR/runs)` and globs over the data keep reading runs
/// only. The dataset's folder is `path` if it is a folder, else the folder holding the file; a
/// sweep's `runs/` or `series/` folder stands for the sweep's folder.
pub fn output_folder(path: &Path) -> PathBuf {
    let folder = if path.is_dir() {
        path.to_path_buf()
    } else {
        match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    };
    let in_sweep = folder
        .file_name()
        .is_some_and(|n| n == "runs" || n == "series")
        && folder
            .parent()
            .is_some_and(|p| p.join(SWEEP_FILE).is_file());
    let root = match folder.parent() {
        Some(p) if in_sweep => p.to_path_buf(),
        _ => folder,
    };
    root.join("analysis")
}

/// The parameter columns `mbmf run` and `mbmf sweep` write, in their order: the run's identity
/// (`run_index`, `master_seed`), the task, then every parameter of the registry
/// ([`crate::params::PARAMS`]), as [`crate::output::param_columns`] writes them.
pub fn parameter_columns() -> &'static [String] {
    static NAMES: OnceLock<Vec<String>> = OnceLock::new();
    NAMES.get_or_init(|| {
        ["run_index", "master_seed", "task"]
            .into_iter()
            .chain(crate::params::PARAMS.iter().map(|p| p.name))
            .map(String::from)
            .collect()
    })
}

/// Columns that identify a run rather than configure it or report on it: never grouped by,
/// never averaged (`config_index` and `seed_index` are added by `mbmf sweep`).
pub const RUN_IDENTITY: [&str; 4] = ["run_index", "master_seed", "config_index", "seed_index"];

/// The configuration columns of `table`: its parameter columns except those of
/// [`RUN_IDENTITY`], in the order `mbmf` writes them.
pub fn configuration_columns(table: &Table) -> Vec<String> {
    parameter_columns()
        .iter()
        .filter(|n| !RUN_IDENTITY.contains(&n.as_str()) && table.has(n))
        .cloned()
        .collect()
}

/// Rows grouped by key: `(key values, row indices)` per distinct key.
pub type Groups = Vec<(Vec<Value>, Vec<usize>)>;

/// Groups the rows of `table` by their values in `keys`: one `(key values, row indices)` per
/// distinct combination, in ascending key order (numbers numerically, nulls first), rows in
/// table order.
pub fn group_rows(table: &Table, keys: &[String]) -> Result<Groups, DatasetError> {
    let columns: Vec<&Column> = keys
        .iter()
        .map(|k| table.column(k))
        .collect::<Result<_, _>>()?;
    if columns.is_empty() {
        let all: Vec<usize> = (0..table.len()).collect();
        return Ok(if all.is_empty() {
            vec![]
        } else {
            vec![(vec![], all)]
        });
    }
    let sort_by: Vec<SortColumn> = columns
        .iter()
        .map(|c| SortColumn {
            values: c.0.clone(),
            options: None,
        })
        .collect();
    let arrow_err = |e| table.arrow_error(e);
    let order: UInt32Array = lexsort_to_indices(&sort_by, None).map_err(arrow_err)?;
    let sorted = columns
        .iter()
        .map(|c| take(&c.0, &order, None))
        .collect::<Result<Vec<_>, _>>()
        .map_err(arrow_err)?;
    let ranges = partition(&sorted).map_err(arrow_err)?.ranges();
    Ok(ranges
        .into_iter()
        .map(|range| {
            // The sort is not stable: put each group's rows back in table order.
            let mut rows: Vec<usize> = order.values()[range].iter().map(|&i| i as usize).collect();
            rows.sort_unstable();
            (columns.iter().map(|c| c.value(rows[0])).collect(), rows)
        })
        .collect())
}

/// The configuration columns other than `by` that vary within a group of `grouped`: groups that
/// mix configurations, which the verbs comparing groups name in a note.
pub fn mixed_columns(table: &Table, by: &str, grouped: &Groups) -> Vec<String> {
    let others: Vec<String> = configuration_columns(table)
        .into_iter()
        .filter(|c| c != by)
        .collect();
    let mut mixed: Vec<String> = Vec::new();
    for (_, rows) in grouped {
        for c in varying_columns(table, &others, rows) {
            if !mixed.contains(&c) {
                mixed.push(c);
            }
        }
    }
    mixed
}

/// The columns among `keys` that take more than one value over `rows` of `table`.
pub fn varying_columns(table: &Table, keys: &[String], rows: &[usize]) -> Vec<String> {
    keys.iter()
        .filter(|k| {
            // Unsorted values split into more than one run of equal values iff they differ.
            table
                .column(k)
                .is_ok_and(|c| partition(&[c.take(rows).0]).is_ok_and(|p| p.len() > 1))
        })
        .cloned()
        .collect()
}

/// The distinct values of a column, sorted, joined by ", " (at most `limit`, then "...").
pub fn distinct_values(column: &Column, limit: usize) -> String {
    let values: BTreeSet<Value> = (0..column.len()).map(|i| column.value(i)).collect();
    let mut shown: Vec<String> = values.iter().take(limit).map(|v| v.to_string()).collect();
    if values.len() > limit {
        shown.push(format!("... ({} values)", values.len()));
    }
    shown.join(", ")
}

/// A row filter `COLUMN=VALUE` (`--where`): keeps the rows whose value equals `VALUE`, compared
/// as a number for numeric columns (`kappa_coeff=9` matches 9.0), as text otherwise; booleans
/// accept true/false/on/off/1/0; `null` matches missing values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Filter {
    /// The column.
    pub column: String,
    /// The value as written.
    pub value: String,
}

impl Filter {
    /// Parses `COLUMN=VALUE`.
    pub fn parse(text: &str) -> Result<Filter, DatasetError> {
        match text.split_once('=') {
            Some((c, v)) if !c.trim().is_empty() => Ok(Filter {
                column: c.trim().to_owned(),
                value: v.trim().to_owned(),
            }),
            Some(_) => Err(DatasetError::BadFilter {
                text: text.to_owned(),
                reason: "the column name before '=' is empty: expected COLUMN=VALUE, e.g. \
                         --where controller=ec or --where budget=50"
                    .to_owned(),
            }),
            _ => Err(DatasetError::BadFilter {
                text: text.to_owned(),
                reason: "expected COLUMN=VALUE, e.g. --where controller=ec or --where budget=50"
                    .to_owned(),
            }),
        }
    }

    fn text(&self) -> String {
        format!("{}={}", self.column, self.value)
    }

    /// The rows of `column` that match (true), errors when the value cannot be of that type.
    fn mask(&self, column: &Column) -> Result<BooleanArray, DatasetError> {
        let bad = |reason: String| DatasetError::BadFilter {
            text: self.text(),
            reason,
        };
        let array = column.array();
        let matched = if self.value == "null" {
            is_null(array)
        } else if column.is_numeric() {
            let x = self.value.parse::<f64>().map_err(|_| {
                bad(format!(
                    "column '{}' holds numbers; '{}' is not a number",
                    self.column, self.value
                ))
            })?;
            cast(array, &DataType::Float64).and_then(|a| eq(&a, &Float64Array::new_scalar(x)))
        } else if *array.data_type() == DataType::Boolean {
            let b = match self.value.to_lowercase().as_str() {
                "true" | "on" | "1" => true,
                "false" | "off" | "0" => false,
                _ => {
                    return Err(bad(format!(
                        "column '{}' holds booleans; use true or false",
                        self.column
                    )));
                }
            };
            eq(array, &BooleanArray::new_scalar(b))
        } else {
            eq(array, &StringArray::new_scalar(&self.value))
        };
        matched.map_err(|e| bad(format!("cannot compare column '{}': {e}", self.column)))
    }

    /// The rows of `table` that match every filter (all of them when `filters` is empty).
    /// Errors name the filter and, when nothing matches, the values present.
    pub fn apply_all(table: &Table, filters: &[Filter]) -> Result<Table, DatasetError> {
        let mut keep = BooleanArray::from(vec![true; table.len()]);
        for f in filters {
            let column = table.column(&f.column)?;
            let kept = and(&keep, &f.mask(column)?).map_err(|e| table.arrow_error(e))?;
            if kept.true_count() == 0 {
                return Err(DatasetError::NoMatch {
                    dataset: table.source().to_owned(),
                    text: f.text(),
                    column: f.column.clone(),
                    values: distinct_values(&column.filter(&keep), 20),
                });
            }
            keep = kept;
        }
        Ok(table.filter(&keep))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Column names go through the one "did you mean" rule of [`crate::suggest`].
    #[test]
    fn closest_names_catch_typos_but_not_unrelated_words() {
        let names = ["total_reward", "cost_total", "mean_entropy_chosen"];
        assert_eq!(
            closest("total_rewrd", names.into_iter()),
            Some("total_reward")
        );
        assert_eq!(closest("COST_TOTAL", names.into_iter()), Some("cost_total"));
        assert_eq!(closest("banana", names.into_iter()), None);
        assert_eq!(
            closest("kapa", ["kappa_coeff", "tau"].into_iter()),
            Some("kappa_coeff")
        );
        assert_eq!(closest("cost", names.into_iter()), Some("cost_total"));
    }

    #[test]
    fn values_order_numbers_numerically_and_keep_integer_precision() {
        let mut v = [
            Value::UInt(50),
            Value::Float(7.5),
            Value::Str("a".into()),
            Value::UInt(10),
            Value::Null,
        ];
        v.sort();
        let shown: Vec<String> = v.iter().map(|x| x.to_string()).collect();
        assert_eq!(shown, ["null", "7.5", "10", "50", "a"]);
        assert_ne!(Value::UInt(1 << 60), Value::UInt((1 << 60) + 1));
        assert_eq!(Value::Float(0.1).to_string(), "0.1");
        assert_eq!(Value::Float(9.0).to_string(), "9");
    }

    #[test]
    fn parameter_columns_start_with_the_run_identity() {
        let names = parameter_columns();
        assert_eq!(&names[..2], ["run_index", "master_seed"]);
        assert!(names.iter().any(|n| n == "kappa_coeff"));
        assert!(names.iter().any(|n| n == "budget"));
    }

    #[test]
    fn groups_come_in_key_order_with_rows_in_table_order() {
        let mut t = Table::new("test");
        let controllers = [Some("mf"), Some("ec"), None, Some("mf"), Some("ec")];
        t.push("c", Column::texts(controllers));
        t.push("k", Column::floats([9.0, 3.0, 1.0, 9.0, 1.0].map(Some)));
        let keys = ["c".to_owned(), "k".to_owned()];
        let groups: Vec<(String, Vec<usize>)> = group_rows(&t, &keys)
            .unwrap()
            .into_iter()
            .map(|(key, rows)| (format!("{} {}", key[0], key[1]), rows))
            .collect();
        let expected = [("null 1", vec![2]), ("ec 1", vec![4]), ("ec 3", vec![1])];
        assert_eq!(groups[..3], expected.map(|(k, r)| (k.to_owned(), r)));
        assert_eq!(groups[3], ("mf 9".to_owned(), vec![0, 3]));
        assert!(varying_columns(&t, &keys, &[0, 3]).is_empty());
        assert_eq!(varying_columns(&t, &keys, &[1, 4]), ["k"]);
    }

    #[test]
    fn files_disagreeing_on_integer_signedness_read_as_signed() {
        let part = |column: Column, file: &str| {
            let mut t = Table::new(file);
            t.push("budget", column);
            (t, PathBuf::from(file))
        };
        let signed = |v: Vec<Option<i64>>| Column(Arc::new(Int64Array::from(v)));
        let parts = [
            part(Column::uints([Some(5)]), "a"),
            part(signed(vec![Some(-1), None]), "b"),
        ];
        let t = Table::concat("both".to_owned(), &parts).unwrap();
        let budget = t.column("budget").unwrap();
        assert_eq!(*budget.array().data_type(), DataType::Int64);
        let values: Vec<Value> = (0..t.len()).map(|i| budget.value(i)).collect();
        assert_eq!(values, [Value::Int(5), Value::Int(-1), Value::Null]);
        assert_eq!(
            budget.type_name(),
            parts[0].0.column("budget").unwrap().type_name()
        );
        // A u64 beyond i64 cannot be widened: an error naming the file, never a silent null.
        let parts = [
            part(Column::uints([Some(u64::MAX)]), "a.parquet"),
            part(signed(vec![Some(1)]), "b.parquet"),
        ];
        let e = Table::concat("both".to_owned(), &parts).unwrap_err();
        assert!(e.to_string().starts_with("a.parquet: "), "{e}");
    }

    #[test]
    fn filters_compare_numbers_as_numbers_and_report_the_values_present() {
        let mut t = Table::new("test");
        t.push("kappa", Column::floats([Some(9.0), Some(3.0), Some(9.0)]));
        t.push(
            "controller",
            Column::texts([Some("ec"), Some("mf"), Some("mf")]),
        );
        let f = |s: &str| Filter::parse(s).unwrap();
        let kept = Filter::apply_all(&t, &[f("kappa=9"), f("controller=mf")]).unwrap();
        assert_eq!(kept.len(), 1);
        assert_eq!(kept.column("kappa").unwrap().value(0), Value::Float(9.0));
        let e = Filter::apply_all(&t, &[f("controller=rnd")]).unwrap_err();
        assert!(
            e.to_string()
                .contains("values of 'controller' in the data: ec, mf"),
            "{e}"
        );
        let e = Filter::apply_all(&t, &[f("kappa=high")]).unwrap_err();
        assert!(e.to_string().contains("'high' is not a number"), "{e}");
        assert!(Filter::parse("kappa").is_err());
    }
}
