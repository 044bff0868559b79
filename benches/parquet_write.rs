//! Writing results (`output::runs_batch`, `output::series_batch` and the Parquet encoder), in
//! rows per second: what `mbmf run` does after each batch.
//!
//! The batch is 256 finished tidy1 runs of `ec` (10,000 steps, a checkpoint every 100: 256 run
//! rows and 25,600 series rows), simulated once outside the timed loop.
//!
//! Run: `cargo bench --bench parquet_write`.

#[path = "common/mod.rs"]
mod common;

use std::sync::Arc;

use criterion::{Criterion, Throughput};
use mbmf::output::{runs_batch, series_batch, write_parquet};
use mbmf::params::Controller;

const RUNS: usize = 256;

fn parquet_write(c: &mut Criterion) {
    let spec = Arc::new(mbmf::env::load("tidy1").expect("built in"));
    let params = common::params(&spec, Controller::Ec);
    let mut batch = common::prepared(&spec, params, RUNS, 0, 2);
    common::pool(2).install(|| batch.run_to_end());
    let dir = tempfile::tempdir().expect("a temporary folder");
    let series_rows = series_batch(&batch).expect("series").num_rows() as u64;

    let mut group = c.benchmark_group("parquet_write");
    group.throughput(Throughput::Elements(RUNS as u64));
    group.bench_function("runs", |b| {
        b.iter(|| {
            let table = runs_batch(&batch).expect("runs table");
            write_parquet(&dir.path().join("runs.parquet"), &table, Vec::new()).expect("written")
        })
    });
    group.throughput(Throughput::Elements(series_rows));
    group.bench_function("series", |b| {
        b.iter(|| {
            let table = series_batch(&batch).expect("series table");
            write_parquet(&dir.path().join("series.parquet"), &table, Vec::new()).expect("written")
        })
    });
    group.finish();
}

criterion::criterion_group! {
    name = benches;
    config = common::quick();
    targets = parquet_write
}
criterion::criterion_main!(benches);
