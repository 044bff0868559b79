//! A front end of the library in a few lines: 4 runs of EC and of MF on tidy1 with a takeover
//! human, written as the committed runs.parquet / series.parquet pair of the folder given as
//! the first argument (default `out/run_library`). Builds without the `cli` feature:
//! `cargo run --release --no-default-features --example run_library -- /tmp/out`.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use mbmf::params::{Controller, Interaction, Params, Profile};
use mbmf::run::{Job, execute};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or("out/run_library".into());
    let spec = Arc::new(mbmf::env::load("tidy1")?);
    let configs = [Controller::Ec, Controller::Mf].map(|controller| {
        let mut params = Params {
            controller,
            steps: 1_000,
            babbling: 100,
            ..Params::default()
        };
        params.human.interaction = Interaction::Takeover;
        params.human.budget = 20;
        params.profile = Profile::Custom;
        params
    });
    let job = Job {
        runs: 4,
        seed: 7,
        ..Job::new("tidy1", spec, configs.to_vec(), &out)
    };
    // A server would set the flag from a cancel request and report progress to its client.
    let stop = AtomicBool::new(false);
    let done = execute(job, &stop, |_agent_steps| {})?;
    for warning in &done.warnings {
        eprintln!("warning: {warning}");
    }
    for row in &done.rows {
        println!(
            "{}: {} runs, total reward {:.1} ± {:.1}",
            row.controller.name(),
            row.runs,
            row.reward.0,
            row.reward.1
        );
    }
    println!(
        "wrote {} and {}",
        done.files[0].display(),
        done.files[1].display()
    );
    Ok(())
}
