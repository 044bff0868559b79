//! One Parquet file written batch by batch under a temporary name, its columns encoded in
//! parallel on the rayon pool of the work (the serial encoding of a large batch's two files was
//! the largest serial part of a 2-thread `mbmf run`), and renamed into place when complete.

use std::fs::File;
use std::path::{Path, PathBuf};

use arrow::array::RecordBatch;
use arrow::datatypes::SchemaRef;
use parquet::arrow::ArrowWriter;
use parquet::arrow::arrow_writer::{
    ArrowColumnChunk, ArrowColumnWriter, ArrowLeafColumn, ArrowRowGroupWriterFactory,
    compute_leaves,
};
use parquet::basic::{Compression, ZstdLevel};
use parquet::errors::ParquetError;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::{DEFAULT_MAX_ROW_GROUP_ROW_COUNT, WriterProperties};
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::ColumnPath;
use rayon::prelude::*;

use super::{OutputError, is_repeated_column, provenance};

/// Rows of a data page: as many as the first batch written brings, between these bounds (the
/// upper one parquet-rs's default). A page is compressed when it fills, and every page still
/// open when the file closes is compressed then, after the simulation, on the job's critical
/// path: with pages of a batch's rows, each batch's pages are compressed while the next batch
/// is simulated, where pages of the default size left all of a small job's compression to its
/// end. Fewer rows would cost size (each page has its header, statistics and index entries).
const PAGE_ROWS: std::ops::RangeInclusive<usize> = 1_024..=20_000;

/// A Parquet file being written under a temporary name, renamed into place by [`finish`].
///
/// Rows gather into row groups of at most [`DEFAULT_MAX_ROW_GROUP_ROW_COUNT`] rows, as
/// parquet's `ArrowWriter` gathers them, so a file's layout does not depend on how its rows
/// were batched; each column of a row group has its own encoder, so the columns of a batch are
/// encoded side by side.
///
/// [`finish`]: ParquetSink::finish
pub struct ParquetSink {
    path: PathBuf,
    tmp: PathBuf,
    open: Option<Open>,
    metadata: Vec<(String, String)>,
}

/// The file once its first batch fixed the schema.
struct Open {
    file: SerializedFileWriter<File>,
    factory: ArrowRowGroupWriterFactory,
    schema: SchemaRef,
    /// The encoders of the row group being filled, one per leaf column, and its rows so far.
    group: Option<(Vec<ArrowColumnWriter>, usize)>,
}

impl ParquetSink {
    /// Prepares to write `path`; `metadata` goes into the file's key-value metadata.
    pub fn new(path: &Path, metadata: Vec<(String, String)>) -> ParquetSink {
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
        ParquetSink {
            path: path.to_path_buf(),
            tmp,
            open: None,
            metadata,
        }
    }

    /// The key-value metadata the file gets.
    pub fn metadata(&self) -> &[(String, String)] {
        &self.metadata
    }

    /// Appends a record batch (the first one fixes the schema).
    pub fn write(&mut self, batch: &RecordBatch) -> Result<(), OutputError> {
        let path = self.path.clone();
        let parquet = |source| OutputError::Parquet {
            path: path.clone(),
            source,
        };
        if self.open.is_none() {
            self.open = Some(self.create(batch)?);
        }
        let open = self.open.as_mut().expect("created above");
        let mut rest = batch.clone();
        while rest.num_rows() > 0 {
            let (writers, rows) = match &mut open.group {
                Some(group) => group,
                none => {
                    let index = open.file.flushed_row_groups().len();
                    let writers = open.factory.create_column_writers(index).map_err(parquet)?;
                    none.insert((writers, 0))
                }
            };
            let take = rest.num_rows().min(DEFAULT_MAX_ROW_GROUP_ROW_COUNT - *rows);
            encode(writers, &open.schema, &rest.slice(0, take)).map_err(parquet)?;
            *rows += take;
            rest = rest.slice(take, rest.num_rows() - take);
            if *rows == DEFAULT_MAX_ROW_GROUP_ROW_COUNT {
                open.flush().map_err(parquet)?;
            }
        }
        Ok(())
    }

    /// The temporary file and its writer, with the properties every results file has.
    fn create(&self, batch: &RecordBatch) -> Result<Open, OutputError> {
        let file = File::create(&self.tmp).map_err(|source| OutputError::Io {
            path: self.tmp.clone(),
            source,
        })?;
        let kv = self
            .metadata
            .iter()
            .map(|(k, v)| KeyValue::new(k.clone(), v.clone()))
            .collect();
        // zstd level 3 (parquet-rs's default level): about half snappy's size for these
        // repetitive parameter columns at a similar write speed.
        let mut props = WriterProperties::builder()
            .set_compression(Compression::ZSTD(ZstdLevel::default()))
            .set_data_page_row_count_limit(
                batch.num_rows().clamp(*PAGE_ROWS.start(), *PAGE_ROWS.end()),
            )
            .set_key_value_metadata(Some(kv));
        // The parameter columns repeat a run's configuration on each of its rows: plain pages
        // that zstd shrinks as well as a dictionary would, without hashing every value into one
        // (most of the cost of writing them).
        for field in batch.schema().fields() {
            if is_repeated_column(field.name()) {
                let column = ColumnPath::from(field.name().as_str());
                props = props.set_column_dictionary_enabled(column, false);
            }
        }
        let schema = batch.schema();
        // ArrowWriter sets up what a reader needs of the Arrow schema (the encoded schema in
        // the metadata, types coerced); its lower-level halves let the columns be encoded apart.
        let (file, factory) = ArrowWriter::try_new(file, schema.clone(), Some(props.build()))
            .and_then(ArrowWriter::into_serialized_writer)
            .map_err(|source| OutputError::Parquet {
                path: self.path.clone(),
                source,
            })?;
        Ok(Open {
            file,
            factory,
            schema,
            group: None,
        })
    }

    /// Flushes, syncs and renames the file into place. Returns its final path. On failure the
    /// temporary file is removed, so nothing partial is left behind.
    pub fn finish(mut self) -> Result<PathBuf, OutputError> {
        let open = self.open.take().expect("finish after at least one write");
        let result = self.close(open);
        if result.is_err() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        result
    }

    fn close(&self, mut open: Open) -> Result<PathBuf, OutputError> {
        let parquet = |source| OutputError::Parquet {
            path: self.path.clone(),
            source,
        };
        open.flush().map_err(parquet)?;
        open.file.append_key_value_metadata(KeyValue::new(
            provenance::ENDED_KEY.to_string(),
            provenance::utc(std::time::SystemTime::now()),
        ));
        let file = open.file.into_inner().map_err(parquet)?;
        file.sync_all().map_err(|source| OutputError::Io {
            path: self.tmp.clone(),
            source,
        })?;
        drop(file);
        std::fs::rename(&self.tmp, &self.path).map_err(|source| OutputError::Io {
            path: self.path.clone(),
            source,
        })?;
        Ok(self.path.clone())
    }
}

impl Open {
    /// Closes the row group being filled, its columns side by side, and appends it.
    fn flush(&mut self) -> Result<(), ParquetError> {
        let Some((writers, _)) = self.group.take() else {
            return Ok(());
        };
        let chunks: Vec<ArrowColumnChunk> = writers
            .into_par_iter()
            .map(ArrowColumnWriter::close)
            .collect::<Result<_, _>>()?;
        let mut group = self.file.next_row_group()?;
        for chunk in chunks {
            chunk.append_to_row_group(&mut group)?;
        }
        group.close()?;
        Ok(())
    }
}

/// Encodes the rows of `batch` into the column encoders of a row group, each column on its own
/// rayon task (each writer owns its column's pages, so the order of the file does not change).
fn encode(
    writers: &mut [ArrowColumnWriter],
    schema: &SchemaRef,
    batch: &RecordBatch,
) -> Result<(), ParquetError> {
    let fields = schema.fields();
    let same = |(f, c): (&arrow::datatypes::FieldRef, &arrow::array::ArrayRef)| {
        f.data_type() == c.data_type()
    };
    if batch.num_columns() != fields.len() || !fields.iter().zip(batch.columns()).all(same) {
        return Err(ParquetError::General(format!(
            "a batch of schema {} for a file of schema {schema}",
            batch.schema()
        )));
    }
    let nested: Vec<Vec<ArrowLeafColumn>> = (fields.iter().zip(batch.columns()))
        .collect::<Vec<_>>()
        .into_par_iter()
        .map(|(field, column)| compute_leaves(field, column))
        .collect::<Result<_, _>>()?;
    let leaves: Vec<ArrowLeafColumn> = nested.into_iter().flatten().collect();
    if leaves.len() != writers.len() {
        return Err(ParquetError::General(format!(
            "{} leaf columns for {} column writers",
            leaves.len(),
            writers.len()
        )));
    }
    writers
        .par_iter_mut()
        .zip(leaves.par_iter())
        .try_for_each(|(writer, leaf)| writer.write(leaf))
}

impl Drop for ParquetSink {
    fn drop(&mut self) {
        // An unfinished sink (error or panic) removes its temporary file.
        if self.open.is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes one record batch to `path` atomically.
pub fn write_parquet(
    path: &Path,
    batch: &RecordBatch,
    metadata: Vec<(String, String)>,
) -> Result<PathBuf, OutputError> {
    let mut sink = ParquetSink::new(path, metadata);
    sink.write(batch)?;
    sink.finish()
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use arrow::array::{Array, Float64Array, Int64Array, StringArray};
    use arrow::datatypes::{DataType, Field, Schema};
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

    use super::*;

    fn batch(from: i64, rows: usize) -> RecordBatch {
        let schema = Schema::new(vec![
            Field::new("run_index", DataType::Int64, false),
            Field::new("task", DataType::Utf8, false),
            Field::new("p_mb_mean", DataType::Float64, true),
        ]);
        let index: Vec<i64> = (from..from + rows as i64).collect();
        let task: Vec<&str> = index
            .iter()
            .map(|i| if i % 2 == 0 { "tidy1" } else { "tidy2" })
            .collect();
        let p: Vec<Option<f64>> = index
            .iter()
            .map(|&i| (i % 3 != 0).then_some(i as f64 / 7.0))
            .collect();
        RecordBatch::try_new(
            Arc::new(schema),
            vec![
                Arc::new(Int64Array::from(index)),
                Arc::new(StringArray::from(task)),
                Arc::new(Float64Array::from(p)),
            ],
        )
        .expect("batch")
    }

    #[test]
    fn batches_written_in_turn_read_back_as_one_row_group_with_their_values_and_metadata() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        let mut sink = ParquetSink::new(&path, vec![("mbmf_run_id".into(), "x".into())]);
        let parts = [batch(0, 5), batch(5, 0), batch(5, 1000), batch(1005, 3)];
        for b in &parts {
            sink.write(b).unwrap();
        }
        assert_eq!(sink.finish().unwrap(), path);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary file left"
        );
        let builder = ParquetRecordBatchReaderBuilder::try_new(File::open(&path).unwrap()).unwrap();
        let meta = builder.metadata().clone();
        assert_eq!(meta.num_row_groups(), 1);
        let kv = meta.file_metadata().key_value_metadata().unwrap();
        assert!(
            kv.iter()
                .any(|k| k.key == "mbmf_run_id" && k.value.as_deref() == Some("x"))
        );
        assert!(kv.iter().any(|k| k.key == provenance::ENDED_KEY));
        let read: Vec<RecordBatch> = builder.build().unwrap().map(Result::unwrap).collect();
        let all = arrow::compute::concat_batches(&read[0].schema(), &read).unwrap();
        let expected = arrow::compute::concat_batches(&parts[0].schema(), &parts).unwrap();
        assert_eq!(all.num_rows(), 1008);
        for c in 0..3 {
            assert_eq!(
                all.column(c).to_data(),
                expected.column(c).to_data(),
                "column {c}"
            );
        }
        assert_eq!(
            all.column(2).null_count(),
            336,
            "every third run has no p_mb_mean"
        );
    }

    #[test]
    fn each_page_holds_the_rows_of_a_first_batch_so_that_pages_fill_as_batches_come() {
        let pages = |batch_rows: usize, batches: usize| {
            let dir = tempfile::tempdir().unwrap();
            let path = dir.path().join("t.parquet");
            let mut sink = ParquetSink::new(&path, vec![]);
            for b in 0..batches {
                sink.write(&batch((b * batch_rows) as i64, batch_rows))
                    .unwrap();
            }
            sink.finish().unwrap();
            let options = parquet::arrow::arrow_reader::ArrowReaderOptions::new()
                .with_page_index_policy(parquet::file::metadata::PageIndexPolicy::Required);
            let builder = ParquetRecordBatchReaderBuilder::try_new_with_options(
                File::open(&path).unwrap(),
                options,
            )
            .unwrap();
            let index = builder.metadata().offset_index().expect("an offset index");
            index[0][0].page_locations().len()
        };
        // Below parquet-rs's default of 20,000 rows a page, which would hold them all in one.
        assert_eq!(pages(3_000, 4), 4);
        // A tiny first batch does not cut pages of a few rows; a huge one keeps the default.
        assert_eq!(pages(10, 300), 3);
        assert_eq!(pages(30_000, 1), 2);
    }

    #[test]
    fn rows_past_the_row_group_limit_start_a_new_row_group() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        let mut sink = ParquetSink::new(&path, vec![]);
        let first = DEFAULT_MAX_ROW_GROUP_ROW_COUNT - 10;
        sink.write(&batch(0, first)).unwrap();
        sink.write(&batch(first as i64, 25)).unwrap();
        sink.finish().unwrap();
        let builder = ParquetRecordBatchReaderBuilder::try_new(File::open(&path).unwrap()).unwrap();
        let groups: Vec<i64> = builder
            .metadata()
            .row_groups()
            .iter()
            .map(|g| g.num_rows())
            .collect();
        assert_eq!(groups, [DEFAULT_MAX_ROW_GROUP_ROW_COUNT as i64, 15]);
    }

    #[test]
    fn a_batch_of_another_schema_is_refused_and_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.parquet");
        let mut sink = ParquetSink::new(&path, vec![]);
        sink.write(&batch(0, 4)).unwrap();
        let other = RecordBatch::try_new(
            Arc::new(Schema::new(vec![Field::new(
                "run_index",
                DataType::Utf8,
                false,
            )])),
            vec![Arc::new(StringArray::from(vec!["a"]))],
        )
        .unwrap();
        let err = sink.write(&other).expect_err("another schema");
        let cause = std::error::Error::source(&err).map(ToString::to_string);
        assert!(
            cause.as_deref().is_some_and(|c| c.contains("schema")),
            "{err}: {cause:?}"
        );
        drop(sink);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "{err}");
    }
}
