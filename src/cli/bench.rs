//! `mbmf bench`: the headline speed figures of this machine, and (`--growth`) the grid:N growth
//! study, printed as they are measured.

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::anyhow;
use clap::Args;

use super::{Failure, runtime, usage};
use crate::bench::{
    GROWTH_CONTROLLERS, GROWTH_RUNS, GROWTH_STEPS, GrowthPoint, WINDOW, growth, growth_sizes,
    memory_per_instance, paired, pool, rule_at_steady_state, state_by_rule, steady_rate, whole_run,
    write_growth,
};
use crate::env;
use crate::params::{Combine, Controller, Params};

/// `mbmf bench`.
#[derive(Debug, Clone, Args)]
pub struct BenchArgs {
    /// Also measure growth on grid:N worlds (100 to --growth-max states, all four controllers):
    /// writes growth.csv and log-log charts (growth_time, growth_memory) into --out. A few
    /// minutes more.
    #[arg(long)]
    pub growth: bool,
    /// Largest grid of the growth study, in states.
    #[arg(long, default_value_t = 10_000)]
    pub growth_max: usize,
    /// Folder for the growth study's CSV and charts.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    /// Print one JSON object (every rate and the memory per instance) instead of the tables,
    /// for scripts that track the figures over time.
    #[arg(long)]
    pub json: bool,
    /// Also time every rule on TASK (any --task of mbmf run, for example the authors'
    /// navigation world as json:PATH), beside tidy1, tidy2 and twostep. Repeatable.
    #[arg(long = "task", value_name = "TASK")]
    pub tasks: Vec<String>,
}

/// Runs `mbmf bench`.
pub fn command(args: &BenchArgs) -> Result<(), Failure> {
    super::args::check_out_dir(&args.out, "--out")?;
    if args.growth && !(100..=env::grid::MAX_STATES).contains(&args.growth_max) {
        return Err(usage(anyhow!(
            "--growth-max must be between 100 and {} states, not {}",
            env::grid::MAX_STATES,
            args.growth_max
        )));
    }
    if args.json && args.growth {
        return Err(usage(anyhow!(
            "--json prints the headline figures only; the --growth study writes its figures to \
             growth.csv in --out: run it without --json"
        )));
    }
    // Every task is loaded before anything is timed, so a bad one is refused at once.
    let mut tasks = Vec::new();
    for task in RULE_TASKS
        .iter()
        .map(|t| t.to_string())
        .chain(args.tasks.clone())
    {
        let spec = env::load(&task).map_err(|e| usage(anyhow!("--task {task}: {e}")))?;
        tasks.push((task, Arc::new(spec)));
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut report = Report {
        text: !args.json,
        rates: Vec::new(),
        wholes: Vec::new(),
        state: Vec::new(),
    };
    say!(
        report,
        "mbmf bench: {} thread(s) available; medians of timed windows, setup not timed",
        cores
    );
    let memory = headline(cores, &tasks, &mut report).map_err(runtime)?;
    if args.json {
        let rates: Vec<serde_json::Value> = report
            .rates
            .iter()
            .map(|r| {
                serde_json::json!({
                    "task": r.task,
                    "controller": r.controller.name(),
                    "combine": combine_name(r.combine),
                    "runs": r.runs,
                    "threads": r.threads,
                    "steps_per_s": r.steps_per_s,
                    "time_over_ec": r.time_over_ec,
                })
            })
            .collect();
        let json = serde_json::json!({
            "verb": "bench",
            "threads_available": cores,
            "window": "steady state: the last 1,000 steps of each run, median of timed windows",
            "rates": rates,
            "whole_commands": report.wholes.iter().map(|w| serde_json::json!({
                "task": "tidy1",
                "controller": w.controller.name(),
                "runs": w.runs,
                "agent_steps": w.agent_steps,
                "threads": w.threads,
                "seconds": w.seconds,
            })).collect::<Vec<_>>(),
            "memory": {
                "runs": 10_000,
                "state_bytes_per_run": memory.layout_bytes,
                "resident_bytes_per_run": memory.rss_bytes,
                "state_bytes_per_run_by_rule": report.state.iter().map(|(c, combine, bytes)| serde_json::json!({
                    "controller": c.name(),
                    "combine": combine_name(*combine),
                    "bytes": bytes,
                })).collect::<Vec<_>>(),
            },
        });
        outln!("{json:#}");
    }
    if args.growth {
        let sizes = growth_sizes(args.growth_max);
        outln!();
        outln!(
            "growth on grid:N, whole runs ({GROWTH_STEPS} steps), {GROWTH_RUNS} runs, one thread:"
        );
        outln!(
            "  {:>7} {:<10} {:>12} {:>12} {:>10} {:>10} {:>12}",
            "states",
            "controller",
            "us/step",
            "KiB/run",
            "reward",
            "known",
            "sweeps/VI"
        );
        let points = growth(&sizes, &GROWTH_CONTROLLERS, growth_row).map_err(runtime)?;
        outln!();
        for path in write_growth(&points, &args.out).map_err(runtime)? {
            outln!("wrote {}", path.display());
        }
    }
    Ok(())
}

/// Paper defaults for `controller` on tidy1.
fn tidy1_params(controller: Controller) -> Params {
    Params {
        controller,
        ..Params::default()
    }
}

/// The tasks every rule is timed on, before those `--task` adds.
const RULE_TASKS: [&str; 3] = ["tidy1", "tidy2", "twostep"];

/// One measured rate: agent-steps per second at steady state.
struct Rate {
    task: String,
    controller: Controller,
    combine: Combine,
    runs: usize,
    threads: usize,
    steps_per_s: f64,
    /// Time per agent-step over EC's on the same task, from paired windows (the rules' table).
    time_over_ec: Option<f64>,
}

/// One whole command timed.
struct Whole {
    controller: Controller,
    runs: u32,
    agent_steps: u64,
    threads: usize,
    seconds: f64,
}

/// What `mbmf bench` measured, printed as it goes unless `--json` asks for one object at the end.
struct Report {
    text: bool,
    rates: Vec<Rate>,
    wholes: Vec<Whole>,
    /// Bytes of state per tidy1 run of each rule.
    state: Vec<(Controller, Combine, usize)>,
}

/// `outln!` when the report prints its tables.
macro_rules! say {
    ($report:expr) => {
        if $report.text {
            outln!();
        }
    };
    ($report:expr, $($arg:tt)*) => {
        if $report.text {
            outln!($($arg)*);
        }
    };
}
use say;

fn headline(
    cores: usize,
    tasks: &[(String, Arc<env::Spec>)],
    report: &mut Report,
) -> anyhow::Result<crate::bench::Memory> {
    let spec = Arc::new(env::load("tidy1")?);
    say!(report);
    say!(
        report,
        "tidy1, steady state (the last 1,000 of 11,000 steps), one thread:"
    );
    say!(
        report,
        "  {:<10} {:>6} {:>16}",
        "controller",
        "runs",
        "steps/s"
    );
    for (controller, runs) in [
        (Controller::Mf, 1024),
        (Controller::Mb, 1024),
        (Controller::Rnd, 1024),
        (Controller::Ec, 1024),
    ] {
        let rate = steady_rate(&spec, tidy1_params(controller), runs, &[1], WINDOW, 9)?[0];
        say!(
            report,
            "  {:<10} {:>6} {:>16}",
            controller.name(),
            runs,
            thousands(rate)
        );
        report.rates.push(Rate {
            task: "tidy1".to_string(),
            controller,
            combine: Combine::Select,
            runs,
            threads: 1,
            steps_per_s: rate,
            time_over_ec: None,
        });
    }

    // Every rule of SPEC 4 and 12, and `combine = mix` where it applies, on each task (the
    // two-step task's runs are 402 steps: the window is the whole run), beside EC, timed first.
    let rules = crate::bench::every_rule();
    for (k, (task, spec)) in tasks.iter().enumerate() {
        // A task of --task may be far larger than the built-in ones (the navigation world's MB
        // plans over stochastic outcomes at every step): fewer runs keep its table to seconds.
        let runs = if k < RULE_TASKS.len() { 1024 } else { 64 };
        say!(report);
        say!(
            report,
            "{task}, steady state, one thread, {runs} runs, every rule:"
        );
        say!(
            report,
            "  {:<20} {:>16} {:>14}",
            "controller",
            "steps/s",
            "time / ec's"
        );
        // Each rule's windows alternate with EC's, and its time against EC's is the median of
        // the pairs' ratios: a slow spell of a shared machine weighs on both alike.
        let one = pool(1)?;
        let steady = |rule| rule_at_steady_state(spec, task, rule, runs);
        let ec = steady((Controller::Ec, Combine::Select))?;
        for &(controller, combine) in &rules {
            let timed = if (controller, combine) == (Controller::Ec, Combine::Select) {
                paired(&ec, &ec, &one, 5)
            } else {
                paired(&ec, &steady((controller, combine))?, &one, 5)
            };
            let name = match combine {
                Combine::Select => controller.name().to_string(),
                Combine::Mix => format!("{} (mix)", controller.name()),
            };
            say!(
                report,
                "  {name:<20} {:>16} {:>13.2}x",
                thousands(timed.rate),
                timed.time_over_base
            );
            report.rates.push(Rate {
                task: task.clone(),
                controller,
                combine,
                runs,
                threads: 1,
                steps_per_s: timed.rate,
                time_over_ec: Some(timed.time_over_base),
            });
        }
    }

    let mut threads = vec![1, 2];
    if cores > 2 {
        threads.push(cores);
    }
    let runs = 2048;
    say!(report);
    say!(
        report,
        "ec on tidy1, steady state, {runs} runs, by thread count:"
    );
    let rates = steady_rate(
        &spec,
        tidy1_params(Controller::Ec),
        runs,
        &threads,
        WINDOW,
        9,
    )?;
    for (t, rate) in threads.iter().zip(&rates) {
        say!(
            report,
            "  {t:>3} thread(s) {:>16} steps/s  ({:.2}x one thread)",
            thousands(*rate),
            rate / rates[0]
        );
        report.rates.push(Rate {
            task: "tidy1".to_string(),
            controller: Controller::Ec,
            combine: Combine::Select,
            runs,
            threads: *t,
            steps_per_s: *rate,
            time_over_ec: None,
        });
    }

    // What a user waits for: whole commands, writing included, on 1 and 2 threads.
    say!(report);
    say!(
        report,
        "whole mbmf run commands on tidy1 (median of 3, files written), by thread count:"
    );
    let scratch = tempfile::tempdir()?;
    // The workloads of benches/peers: MF at 4,096 runs x (1,000 babbling + 2,000 steps), EC's
    // early phase at 1,024 x 1,000 steps without babbling.
    let workloads = [
        (Controller::Mf, 4096, 1000, 2000),
        (Controller::Ec, 1024, 0, 1000),
    ];
    for (controller, runs, babbling, steps) in workloads {
        let params = Params {
            babbling,
            steps,
            ..tidy1_params(controller)
        };
        let whole = whole_run("tidy1", params, runs, &[1, 2], 3, scratch.path())?;
        let one = whole.seconds[0].1;
        let steps = u64::from(runs) * crate::pipeline::run_steps(&params);
        for &(threads, seconds) in &whole.seconds {
            say!(
                report,
                "  {:<4} {runs:>5} runs x {:>5} steps  {threads} thread(s) {seconds:>7.3} s  ({:.2}x one thread)",
                controller.name(),
                crate::pipeline::run_steps(&params),
                one / seconds
            );
            report.wholes.push(Whole {
                controller,
                runs,
                agent_steps: steps,
                threads,
                seconds,
            });
        }
    }

    say!(report);
    let memory = memory_per_instance(&spec, 10_000)?;
    say!(
        report,
        "memory: 10,000 tidy1 runs hold {:.1} KiB of state each{}",
        memory.layout_bytes as f64 / 1024.0,
        match memory.rss_bytes {
            Some(rss) => format!("; resident memory grew by {:.1} KiB per run", rss / 1024.0),
            None => String::new(),
        }
    );
    report.state = state_by_rule(&spec)?;
    if report.text {
        let each: Vec<String> = report
            .state
            .iter()
            .map(|(c, combine, bytes)| {
                let mix = if *combine == Combine::Mix { "-mix" } else { "" };
                format!("{}{mix} {:.1}", c.name(), *bytes as f64 / 1024.0)
            })
            .collect();
        outln!("state per tidy1 run, KiB: {}", each.join(", "));
    }
    Ok(memory)
}

/// A `combine` value as `mbmf run --combine` spells it.
fn combine_name(combine: Combine) -> &'static str {
    match combine {
        Combine::Select => "select",
        Combine::Mix => "mix",
    }
}

fn growth_row(point: &GrowthPoint) {
    outln!(
        "  {:>7} {:<10} {:>12.3} {:>12.1} {:>10.1} {:>10.0} {:>12.2}",
        point.states,
        point.controller.name(),
        point.seconds_per_step * 1e6,
        point.bytes_per_run as f64 / 1024.0,
        point.reward,
        point.known_states,
        point.sweeps_per_call
    );
}

/// `1234567.8` as `1,234,568`.
fn thousands(x: f64) -> String {
    let digits = format!("{:.0}", x.max(0.0));
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_groups_digits_by_three() {
        assert_eq!(thousands(0.0), "0");
        assert_eq!(thousands(999.4), "999");
        assert_eq!(thousands(1_234_567.8), "1,234,568");
    }
}
