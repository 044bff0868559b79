//! A front end of the library in a few lines: 4 runs of EC and of MF on tidy1 with a takeover
//! human, written as the committed runs.parquet / series.parquet pair of the folder given as
//! the first argument (default `out/run_library`). Builds without the `cli` feature:
//! `cargo run --release --no-default-features --example run_library -- /tmp/out`.
//! (`tests/library.rs` runs this job and compares it with `mbmf run`'s.)

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use mbmf::params::{Controller, Interaction, Params, Profile};
use mbmf::run::{Job, execute};

/// EC and MF with a takeover human of budget 20, 4 runs each of 1,000 steps after 100 of
/// babbling, seed 7: what `mbmf run --controller ec,mf --interaction takeover --budget 20
/// --steps 1000 --babbling 100 --runs 4 --seed 7 --out OUT` asks.
pub fn job(out: &Path) -> Result<Job, mbmf::env::EnvError> {
    let spec = Arc::new(mbmf::env::load("tidy1")?);
    let configs = [Controller::Ec, Controller::Mf].map(|controller| {
        let mut params = Params {
            controller,
            steps: 1_000,
            babbling: 100,
            // Human fields set without a named profile describe a custom human.
            profile: Profile::Custom,
            ..Params::default()
        };
        params.human.interaction = Interaction::Takeover;
        params.human.budget = 20;
        params
    });
    Ok(Job {
        runs: 4,
        seed: 7,
        ..Job::new("tidy1", spec, configs.to_vec(), out)
    })
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or("out/run_library".into());
    // A server would set the flag from a cancel request and report progress to its client.
    let stop = AtomicBool::new(false);
    let done = execute(job(Path::new(&out))?, &stop, |_agent_steps| {})?;
    for warning in &done.warnings {
        eprintln!("warning: {warning}");
    }
    for row in &done.rows {
        let (mean, sd) = row.reward;
        let name = row.controller.name();
        println!(
            "{name}: {} runs, total reward {mean:.1} ± {sd:.1}",
            row.runs
        );
    }
    let [runs, series] = &done.files;
    println!("wrote {} and {}", runs.display(), series.display());
    Ok(())
}
