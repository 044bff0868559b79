//! The policy arithmetic of every decision (SPEC 3.3): softmax with the Eq. 8 bonus, and the
//! entropy the meta-controller reads, in rows (one state's action values) per second.
//!
//! Rows are random Q values in [0, 1) from a fixed seed, 7 actions (tidy tasks) and 8 (the
//! navigation world).
//!
//! Run: `cargo bench --bench softmax`.

#[path = "common/mod.rs"]
mod common;

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput};
use mbmf::batch::{run_rng, uniform};
use mbmf::expert::{entropy_bits, normalised_entropy, softmax_biased};

/// Rows per iteration: enough to amortise the loop, few enough to stay in L1/L2.
const ROWS: usize = 1024;

fn softmax_and_entropy(c: &mut Criterion) {
    let mut group = c.benchmark_group("softmax");
    group.throughput(Throughput::Elements(ROWS as u64));
    for n_a in [7usize, 8] {
        let mut rng = run_rng(common::SEED, n_a as u64);
        let q: Vec<f64> = (0..ROWS * n_a).map(|_| uniform(&mut rng)).collect();
        let g: Vec<u8> = (0..ROWS * n_a).map(|i| u8::from(i % 5 == 0)).collect();
        let mut p = vec![0.0; ROWS * n_a];
        for ((q, g), p) in q.chunks(n_a).zip(g.chunks(n_a)).zip(p.chunks_mut(n_a)) {
            softmax_biased(q, g, 0.1, 0.02, p);
        }
        let mut out = vec![0.0; n_a];
        group.bench_function(BenchmarkId::new("softmax_biased", n_a), |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for (q, g) in q.chunks(n_a).zip(g.chunks(n_a)) {
                    softmax_biased(black_box(q), g, 0.1, 0.02, &mut out);
                    acc += out[0];
                }
                acc
            })
        });
        group.bench_function(BenchmarkId::new("entropy_bits", n_a), |b| {
            b.iter(|| {
                p.chunks(n_a)
                    .map(|row| entropy_bits(black_box(row)))
                    .sum::<f64>()
            })
        });
        group.bench_function(BenchmarkId::new("normalised_entropy", n_a), |b| {
            b.iter(|| {
                p.chunks(n_a)
                    .map(|row| normalised_entropy(black_box(row)))
                    .sum::<f64>()
            })
        });
    }
    group.finish();
}

criterion::criterion_group! {
    name = benches;
    config = common::quick();
    targets = softmax_and_entropy
}
criterion::criterion_main!(benches);
