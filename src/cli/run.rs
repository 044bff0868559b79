//! `mbmf run`: one configuration (or a few controllers), simulated and written as runs.parquet
//! and series.parquet, with a summary table.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Result, anyhow};
use clap::Args;

use super::args::{ParamArgs, batch_size, explain, load_task, runs_count, seed};
use super::{Failure, progress, signal, usage};
use crate::env::registry;
use crate::params::{Controller, CostModel, Params, Profile};
use crate::run;
use crate::schedule::Schedule;
use crate::sweep::file::{UserProfile, load_profiles};

/// `mbmf run`.
#[derive(Debug, Clone, Args)]
pub struct RunArgs {
    /// The task (the list is the task registry's).
    #[arg(long, default_value = "tidy1", help = registry::short_help(), long_help = registry::help())]
    pub task: String,
    /// keyStates.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub key_states: Option<PathBuf>,
    /// spaces.txt of a json: task, if not beside the model file.
    #[arg(long)]
    pub spaces: Option<PathBuf>,
    /// Controllers, comma-separated.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "mf,mb,rnd,ec"
    )]
    pub controller: Vec<Controller>,
    /// Runs per controller, 1 to 1000000.
    #[arg(long, default_value_t = 20, value_parser = runs_count, allow_negative_numbers = true)]
    pub runs: u32,
    /// Master seed; with the run index it fixes each run's random stream.
    #[arg(long, default_value_t = 1, value_parser = seed, allow_negative_numbers = true)]
    pub seed: u64,
    /// Output folder for runs.parquet and series.parquet (created if needed).
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// Replace the results of an earlier run in --out (refused without it).
    #[arg(long)]
    pub force: bool,
    /// Runs simulated at once, >= 1 (lowered if a batch would not fit in memory); results do
    /// not depend on it.
    #[arg(long, default_value_t = 4096, value_parser = batch_size, allow_negative_numbers = true)]
    pub batch_size: usize,
    /// No progress bar and no notes on stderr; the table and the files written still print on
    /// stdout, and warnings and errors on stderr.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print one JSON object on stdout instead of the table (files written, counts, timing and
    /// the per-controller rows); progress and notes stay on stderr.
    #[arg(long)]
    pub json: bool,
    /// A named human; the human's flags (--interaction, --budget, --zeta, --forget,
    /// --reward-source) override its fields.
    #[arg(long, value_enum)]
    pub profile: Option<Profile>,
    /// A profile file ([profiles.NAME] tables, as mbmf fit-human writes): the human of its
    /// profile --profile-name (or of its only profile); the human's flags override its fields.
    #[arg(long, value_name = "FILE", conflicts_with = "profile")]
    pub profile_file: Option<PathBuf>,
    /// Which profile of --profile-file to use (needed when it holds several).
    #[arg(long, value_name = "NAME", requires = "profile_file")]
    pub profile_name: Option<String>,
    /// Every other parameter.
    #[command(flatten)]
    pub params: ParamArgs,
    /// A change during the run at experiment step STEP (repeatable; events at one step apply in
    /// the order given): world=json:PATH, goal=S[:R], delete=S-T,..., boxes=PERM (tidy1),
    /// interaction=, budget= (left), forget=, zeta=, profile=, reward_source=.
    /// Example: --change 1601:goal=34 --change 1601:world=json:PATH
    #[arg(long = "change", value_name = "STEP:KEY=VALUE")]
    pub change: Vec<String>,
    /// Also write trace.parquet: one row per experiment step of every run (state, action,
    /// reward, who chose, P(MB), the human's interaction; about 30 bytes per row in memory).
    #[arg(long)]
    pub trace: bool,
}

/// The profile of `--profile-file` that `--profile-name` names (or its only one).
fn file_profile(args: &RunArgs) -> Result<Option<UserProfile>> {
    let Some(path) = &args.profile_file else {
        return Ok(None);
    };
    let profiles = load_profiles(path).map_err(|e| anyhow!("--profile-file: {e}"))?;
    let names = || {
        profiles
            .iter()
            .map(|u| u.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let chosen = match &args.profile_name {
        Some(name) => {
            let wanted = name.trim().to_ascii_lowercase().replace('_', "-");
            profiles.iter().find(|u| u.name == wanted).ok_or_else(|| {
                anyhow!(
                    "--profile-name {name}: {} has no such profile; its profiles: {}",
                    path.display(),
                    names()
                )
            })?
        }
        None if profiles.len() == 1 => &profiles[0],
        None => {
            return Err(anyhow!(
                "--profile-file {} holds {} profiles: choose one with --profile-name ({})",
                path.display(),
                profiles.len(),
                names()
            ));
        }
    };
    Ok(Some(chosen.clone()))
}

/// The validated parameters of each controller's runs, in `--controller` order.
fn controller_params(args: &RunArgs) -> Result<Vec<Params>> {
    let mut all = Vec::new();
    let from_file = file_profile(args)?;
    for &controller in &args.controller {
        let profile = args.profile.unwrap_or(Profile::None);
        let mut params = Params {
            controller,
            human: profile.human(controller).unwrap_or_default(),
            profile,
            reward_source: profile.reward_source().unwrap_or_default(),
            steps: registry::default_steps(&args.task),
            babbling: registry::default_babbling(&args.task),
            ..Params::default()
        };
        if let Some(user) = &from_file {
            if let Some(key) = user.apply_human(&mut params) {
                return Err(anyhow!(
                    "--profile-file: profile '{}' sets {}, which is not the human's; mbmf run \
                     takes the human's parameters from a profile file (use the profile in a \
                     sweep file for the others)",
                    user.name,
                    key.name()
                ));
            }
            params.profile = Profile::Custom;
        }
        args.params.apply(&mut params);
        // Setting the human's fields without a profile describes a custom human.
        if args.profile.is_none() && args.params.given.iter().any(|(p, _)| p.in_human) {
            params.profile = Profile::Custom;
        }
        params.validate().map_err(explain)?;
        all.push(params);
    }
    Ok(all)
}

/// `mbmf run`: every input is checked (flags, task files, the output folder, memory) before the
/// first step is simulated, so a mistake fails in a second rather than after the runs.
pub fn run(args: &RunArgs) -> Result<(), Failure> {
    let spec = load_task(
        &args.task,
        args.key_states.as_deref(),
        args.spaces.as_deref(),
    )
    .map_err(usage)?;
    let params = controller_params(args).map_err(usage)?;
    let schedule = Schedule::from_events(args.change.iter().map(String::as_str))
        .map_err(|e| usage(anyhow!("--change: {e}")))?;
    let job = run::Job {
        runs: args.runs,
        seed: args.seed,
        schedule,
        force: args.force,
        batch_size: args.batch_size,
        set: args.params.given.iter().map(|(p, _)| p.name).collect(),
        command: super::command_line(),
        trace: args.trace,
        ..run::Job::new(&args.task, Arc::new(spec), params, &args.out)
    };
    let mut checked = run::Run::new(job).map_err(failure)?;
    for warning in checked.warnings() {
        eprintln!("warning: {warning}");
    }
    let note = checked.size().map_err(failure)?;
    if let Some(note) = note
        && !args.quiet
    {
        eprintln!("note: {note}");
    }
    let total = checked.job().total();
    // Measured seconds are no operation counts: the table's heading says which it sums.
    let wallclock = checked
        .job()
        .configs
        .iter()
        .any(|p| p.cost_model == CostModel::Wallclock);
    let cost_unit = if wallclock { "s" } else { "ops" };
    let agent_steps = checked.job().agent_steps();
    let batch_size = checked.batch_size();
    let stop = signal::install();
    let open = checked.open().map_err(failure)?;
    let staging = open.staging().to_path_buf();
    signal::remove_on_forced_exit(staging.clone());
    if (batch_size as u64) < (args.batch_size as u64).min(total) && !args.quiet {
        eprintln!(
            "note: simulating {batch_size} runs at a time instead of {} so that a batch fits in \
             memory (results do not depend on it)",
            args.batch_size
        );
    }
    let bar = progress::bar(agent_steps, args.quiet, false);
    let done = open.simulate(stop, |n| bar.inc(n));
    bar.finish_and_clear();
    signal::keep_on_forced_exit(&staging);
    let done = done.map_err(|e| interrupted(e, &args.out))?;
    let [runs_path, series_path] = &done.files;
    if args.json {
        let mut files = serde_json::json!({
            "runs": runs_path.display().to_string(),
            "series": series_path.display().to_string(),
        });
        if let Some(trace) = &done.trace {
            files["trace"] = trace.display().to_string().into();
        }
        let report = serde_json::json!({
            "verb": "run",
            "task": args.task,
            "out": args.out.display().to_string(),
            "files": files,
            "runs": done.runs,
            "batch_size": batch_size,
            "seconds": done.seconds,
            "controllers": json_rows(&done.rows),
        });
        outln!("{report}");
    } else {
        out!(
            "{}",
            table(
                &done.rows,
                &args.task,
                done.runs as usize,
                done.seconds,
                cost_unit
            )
        );
        match &done.trace {
            Some(trace) => outln!(
                "wrote {}, {} and {}",
                runs_path.display(),
                series_path.display(),
                trace.display()
            ),
            None => outln!(
                "wrote {} and {}",
                runs_path.display(),
                series_path.display()
            ),
        }
    }
    Ok(())
}

/// A failure of the run entry, with the exit code of its kind; configuration errors name the
/// flags and schedule errors `--change`, as the other verbs' do.
fn failure(error: run::RunError) -> Failure {
    match error {
        run::RunError::Invalid(e) => usage(explain(e)),
        run::RunError::Change(e) => usage(anyhow!("--change: {e}")),
        e => super::failure(e),
    }
}

/// A failure of the simulation; after a signal, one saying that nothing was written (the
/// staging folder was removed) and that earlier results are untouched.
fn interrupted(error: run::RunError, out: &Path) -> Failure {
    if !matches!(error, run::RunError::Interrupted(_)) {
        return failure(error);
    }
    let earlier = if out.join("runs.parquet").exists() {
        "the results already there are untouched"
    } else {
        "it holds no results"
    };
    Failure {
        code: signal::exit_code(),
        error: anyhow!(
            "interrupted by {}: nothing was written to {} ({earlier}); run the command again to \
             start over",
            signal::received(),
            out.display()
        ),
    }
}

/// The table's rows as JSON objects: means and sample standard deviations (null where no run
/// has a value).
fn json_rows(rows: &[run::Row]) -> Vec<serde_json::Value> {
    rows.iter()
        .map(|row| {
            let (m, ms) = row.share.unwrap_or((f64::NAN, f64::NAN));
            let (w, ws) = row.weight.unwrap_or((f64::NAN, f64::NAN));
            let mut object = serde_json::json!({
                "controller": row.controller.name(),
                "combine": if row.mixes { "mix" } else { "select" },
                "runs": row.runs,
                "total_reward_mean": row.reward.0,
                "total_reward_sd": row.reward.1,
                "total_cost_mean": row.cost.0,
                "total_cost_sd": row.cost.1,
                "mb_share_mean": m,
                "mb_share_sd": ms,
                "p_mb_mean": w,
                "p_mb_sd": ws,
            });
            // The task's headline metrics (twostep's stay effects), named by their columns.
            for h in &row.headline {
                let (mean, sd) = h.value.unwrap_or((f64::NAN, f64::NAN));
                object[format!("{}_mean", h.column)] = mean.into();
                object[format!("{}_sd", h.column)] = sd.into();
            }
            object
        })
        .collect()
}

/// A share or weight in [0, 1] to three decimals, unless it is too small to show there but not
/// 0 (Lee 2014's P(MB) on tidy1 is about 3e-4): then with three significant digits, so that a
/// weight that is not 0 never reads as one.
fn share_figure(x: f64) -> String {
    if x != 0.0 && x.abs() < 5e-4 {
        format!("{x:.2e}")
    } else {
        format!("{x:.3}")
    }
}

/// The table: mean ± standard deviation per controller ("-" where no run has a value). With
/// `combine = mix` no expert is drawn, so a line under the table gives the weight P(MB) the
/// share column cannot show.
fn table(rows: &[run::Row], task: &str, runs: usize, seconds: f64, cost_unit: &str) -> String {
    use std::fmt::Write as _;
    let width = rows
        .iter()
        .map(|r| label(r).len())
        .max()
        .unwrap_or(0)
        .max(10);
    let mut out = String::new();
    let _ = writeln!(out, "{task}: {runs} runs in {seconds:.2} s");
    let _ = writeln!(
        out,
        "{:<width$} {:>5} {:>22} {:>26} {:>18}",
        "controller",
        "runs",
        "total reward",
        format!("total cost ({cost_unit})"),
        "MB share"
    );
    for row in rows {
        let ((r, rs), (c, cs)) = (row.reward, row.cost);
        let share = match row.share {
            None => format!("{:>18}", "-"),
            Some((m, ms)) => format!("{:>8} ± {}", share_figure(m), share_figure(ms)),
        };
        let _ = writeln!(
            out,
            "{:<width$} {:>5} {:>12.1} ± {:<7.1} {:>15.4e} ± {:<8.2e} {share}",
            label(row),
            row.runs,
            r,
            rs,
            c,
            cs,
        );
    }
    let weights: Vec<String> = rows
        .iter()
        .filter(|row| row.mixes)
        .filter_map(|row| {
            let (w, ws) = row.weight?;
            Some(format!(
                "{} {} ± {}",
                row.controller.name(),
                share_figure(w),
                share_figure(ws)
            ))
        })
        .collect();
    if !weights.is_empty() {
        let _ = writeln!(
            out,
            "mix: no expert is drawn; MB share counts the decisions weighted P(MB) > 1/2. Mean \
             P(MB): {}",
            weights.join(", ")
        );
    }
    // vpi values each action by one expert: its P(MB) is the share of actions MB valued, and
    // its MB share the decisions in which MB inferred at all (SPEC 12.4); the two differ.
    if let Some(row) = rows.iter().find(|r| r.controller == Controller::Vpi)
        && let Some((w, ws)) = row.weight
    {
        let _ = writeln!(
            out,
            "vpi: MB share counts the decisions in which MB valued at least one action. Mean \
             P(MB), the share of actions it valued: {} ± {}",
            share_figure(w),
            share_figure(ws)
        );
    }
    headline(&mut out, rows, task, width);
    out
}

/// A row's controller as the tables name it: `(mix)` after a rule that mixed.
fn label(row: &run::Row) -> String {
    let name = row.controller.name();
    if row.mixes {
        format!("{name} (mix)")
    } else {
        name.to_string()
    }
}

/// The task's headline metrics per controller (twostep's reward effect and interaction), as
/// a second table under the first, with the task's line on where to go further.
fn headline(out: &mut String, rows: &[run::Row], task: &str, width: usize) {
    use std::fmt::Write as _;
    let Some(first) = rows.first().filter(|r| !r.headline.is_empty()) else {
        return;
    };
    let note = registry::find(task).map_or("", |t| t.headline_note);
    let _ = writeln!(out, "{note}");
    let _ = write!(out, "{:<width$}", "controller");
    for h in &first.headline {
        let _ = write!(out, " {:>22}", h.heading);
    }
    let _ = writeln!(out);
    for row in rows {
        let _ = write!(out, "{:<width$}", label(row));
        for h in &row.headline {
            let cell = match h.value {
                None => "-".to_string(),
                Some((m, sd)) => format!("{m:.3} ± {sd:.3}"),
            };
            let _ = write!(out, " {cell:>22}");
        }
        let _ = writeln!(out);
    }
}

#[cfg(test)]
mod tests {
    use super::share_figure;

    #[test]
    fn a_small_share_keeps_its_digits_and_zero_stays_zero() {
        assert_eq!(share_figure(0.0), "0.000");
        assert_eq!(share_figure(0.25), "0.250");
        assert_eq!(share_figure(1.0), "1.000");
        assert_eq!(share_figure(0.0005), "0.001");
        assert_eq!(share_figure(0.000_296_4), "2.96e-4");
        assert_eq!(share_figure(1.5e-9), "1.50e-9");
    }
}
