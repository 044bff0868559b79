//! Time per agent-step of some rules against EC's, at steady state, on some tasks: the rules'
//! table of `mbmf bench` for a chosen few, with as many paired windows as asked (more pairs, a
//! steadier median). For trying one change to the step against a saved binary of the one
//! before: build this example at both, and run them in turn.
//!
//! `cargo run --release --example rule_ratios -- tidy1,tidy2 fixed,vpi 9`
//!
//! Arguments: tasks (any `--task` of `mbmf run`), controllers (names as `--controller` takes
//! them, `-mix` appended for `combine = mix`: `fixed-mix`), the pairs of windows per rule
//! (default 9) and the runs (default 1,024, as `mbmf bench`; 16 runs stay in cache from one
//! window to the next, which leaves the arithmetic alone). Each line gives the median over the
//! pairs of the rule's time over EC's, and the rule's median rate.

use std::process::ExitCode;
use std::sync::Arc;

use mbmf::bench::{paired, pool, rule_at_steady_state};
use mbmf::params::{Combine, Controller};

/// Large tables on huge pages, as the `mbmf` binary allocates them (`src/huge_pages.rs`): the
/// steps are timed with the TLB misses of a user's run (and of `mbmf bench`), not those of 4 KiB
/// pages.
#[global_allocator]
static ALLOCATOR: mbmf::huge_pages::HugePageSystem = mbmf::huge_pages::HugePageSystem;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: rule_ratios TASK[,TASK...] CONTROLLER[,CONTROLLER...] [PAIRS [RUNS]]";
    let (Some(tasks), Some(rules)) = (args.first(), args.get(1)) else {
        eprintln!("{usage}");
        return ExitCode::from(2);
    };
    let Ok(pairs) = args.get(2).map_or(Ok(9), |p| p.parse::<usize>()) else {
        eprintln!("PAIRS must be a whole number of windows; {usage}");
        return ExitCode::from(2);
    };
    let Ok(runs @ 1..) = args.get(3).map_or(Ok(1024), |r| r.parse::<usize>()) else {
        eprintln!("RUNS must be a whole number of runs, at least 1; {usage}");
        return ExitCode::from(2);
    };
    let mut controllers = Vec::new();
    for name in rules.split(',') {
        // `fixed-mix`: the rule under `combine = mix`, as `mbmf bench --json` names it.
        let (name, combine) = match name.strip_suffix("-mix") {
            Some(rule) => (rule, Combine::Mix),
            None => (name, Combine::Select),
        };
        match Controller::ALL.iter().find(|c| c.name() == name) {
            Some(&c) if combine == Combine::Select || c.combines() => {
                controllers.push((c, combine));
            }
            Some(_) => {
                eprintln!("{name} does not combine: `{name}-mix` is no rule");
                return ExitCode::from(2);
            }
            None => {
                let known: Vec<_> = Controller::ALL.iter().map(|c| c.name()).collect();
                eprintln!("unknown controller {name:?}; known: {}", known.join(", "));
                return ExitCode::from(2);
            }
        }
    }
    match ratios(tasks, &controllers, pairs, runs) {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(1)
        }
    }
}

/// Prints each rule's time over EC's on each task.
fn ratios(
    tasks: &str,
    controllers: &[(Controller, Combine)],
    pairs: usize,
    runs: usize,
) -> Result<(), String> {
    let one = pool(1).map_err(|e| e.to_string())?;
    for task in tasks.split(',') {
        let spec = Arc::new(mbmf::env::load(task).map_err(|e| e.to_string())?);
        let steady =
            |rule| rule_at_steady_state(&spec, task, rule, runs).map_err(|e| e.to_string());
        let ec = steady((Controller::Ec, Combine::Select))?;
        for &(controller, combine) in controllers {
            let timed = paired(&ec, &steady((controller, combine))?, &one, pairs);
            let mix = if combine == Combine::Mix { "-mix" } else { "" };
            println!(
                "{task}, {runs} runs, {}{mix}: {:.3}x ec's time ({:.2} M steps/s)",
                controller.name(),
                timed.time_over_base,
                timed.rate / 1e6
            );
        }
    }
    Ok(())
}
