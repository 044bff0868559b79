//! `mbmf plot`: mean curves per group from a dataset's series, with the change steps marked;
//! or, with `--x`, response curves: a runs-table metric against a swept parameter. The curves
//! come from [`crate::analysis::curves`]; this verb names the file, draws it and prints what
//! it drew.

use std::path::{Path, PathBuf};

use anyhow::anyhow;
use clap::Args;

use super::analysis::Dataset;
use super::{Failure, runtime, usage};
use crate::analysis::curves::{self, CurveMetric};
use crate::analysis::dataset::{self, Filter};

/// `mbmf plot`.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Examples:
  mbmf plot out/navworld-changes --by controller --where 'schedule=1601:delete=20-21,21-20'
  mbmf plot out/kappa --by kappa_coeff --where interaction=none     # one curve per kappa, colour scale
  mbmf plot out/kappa --x kappa_coeff --metric total_reward --by interaction   # response curves")]
pub struct PlotArgs {
    /// The dataset (its runs and series tables) and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Column of the runs table whose values define the curves (e.g. controller, interaction);
    /// a numeric column (a swept parameter) is drawn on a colour scale with a colour bar.
    /// Optional with --x (one curve of all runs).
    #[arg(long, required_unless_present = "x", value_parser = super::args::column)]
    pub by: Option<String>,
    /// Draw a response curve instead: the mean of --metric (a numeric column of the runs
    /// table) at each value of this numeric column of the runs table (e.g. kappa_coeff,
    /// budget), with a 95% Student-t confidence band.
    #[arg(long, value_name = "COLUMN")]
    pub x: Option<String>,
    /// What to draw: over time, cum_reward (default), cum_cost or p_mb (the series'
    /// p_mb_mean); with --x, any numeric column of the runs table (default total_reward).
    #[arg(long)]
    pub metric: Option<String>,
    /// Folder for the SVG and PNG (default: DIR/analysis, beside the other analyses).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Title above the plot (default: the metric, the grouping column and the filters).
    #[arg(long)]
    pub title: Option<String>,
}

/// Runs `mbmf plot`: reads the curves, draws them, prints the files written.
pub fn plot(args: &PlotArgs) -> Result<(), Failure> {
    let folder = args
        .out
        .clone()
        .unwrap_or_else(|| dataset::output_folder(&args.data.dir));
    match (&args.x, &args.by) {
        (Some(x), by) => response(args, x, by.as_deref(), &folder),
        (None, Some(by)) => over_time(args, by, &folder),
        (None, None) => Err(usage(anyhow!("give --by COLUMN, --x COLUMN or both"))),
    }
}

/// Mean curves over time of a series column, one per group of `by`.
fn over_time(args: &PlotArgs, by: &str, folder: &Path) -> Result<(), Failure> {
    let (dir, filters) = (&args.data.dir, &args.data.filters);
    let metric = CurveMetric::parse(args.metric.as_deref().unwrap_or("cum_reward"))
        .map_err(|e| usage(anyhow!("invalid --metric: {e}")))?;
    let (curves, warnings) =
        curves::read_curves(dir, by, metric, filters, &args.data.options()).map_err(usage)?;
    super::analysis::warn(&warnings);
    let name = curves::figure_name(metric, by, filters);
    let title = args
        .title
        .clone()
        .unwrap_or_else(|| curves::title(metric, by, filters));
    let paths = crate::plot::line_chart_coloured(
        &curves.chart(&title),
        &curves.colours(),
        &folder.join(name),
    )
    .map_err(runtime)?;
    for c in &curves.curves {
        let runs = c.n.iter().max().copied().unwrap_or(0);
        // The curve's points are the series' checkpoints, not every step.
        let span = match (c.steps.first(), c.steps.last()) {
            (Some(first), Some(last)) => format!(" (steps {first} to {last})"),
            _ => String::new(),
        };
        outln!(
            "{by}={}: {runs} runs, {} checkpoints{span}",
            c.label,
            c.steps.len()
        );
    }
    super::analysis::print_mixed(&curves.mixed);
    if !curves.change_steps.is_empty() {
        let steps: Vec<String> = curves.change_steps.iter().map(u32::to_string).collect();
        outln!("changes marked at step {}", steps.join(", "));
    }
    print_written(&paths);
    Ok(())
}

/// Response curves: the mean of a runs-table metric against the swept column `x`.
fn response(args: &PlotArgs, x: &str, by: Option<&str>, folder: &Path) -> Result<(), Failure> {
    let filters: &[Filter] = &args.data.filters;
    let metric = args.metric.as_deref().unwrap_or("total_reward");
    let read = dataset::read_table(&args.data.dir, "runs", &args.data.options()).map_err(usage)?;
    super::analysis::warn(&read.warnings);
    let runs = Filter::apply_all(&read.table, filters).map_err(usage)?;
    let responses = curves::response_curves(&runs, x, metric, by).map_err(usage)?;
    let title = args
        .title
        .clone()
        .unwrap_or_else(|| curves::response_title(metric, x, by, filters));
    let (chart, colours) = responses.chart(&title);
    let name = curves::response_name(metric, x, by, filters);
    let paths =
        crate::plot::line_chart_coloured(&chart, &colours, &folder.join(name)).map_err(runtime)?;
    for c in &responses.curves {
        let group = by.map_or_else(|| c.label.clone(), |b| format!("{b}={}", c.label));
        let runs: usize = c.n.iter().sum();
        outln!("{group}: {runs} runs at {} values of {x}", c.x.len());
    }
    outln!("(mean of {metric} over runs, band: 95% Student-t confidence interval)");
    // A point averages every configuration at its x (and group): say which others vary there.
    let mut keys = vec![x.to_owned()];
    keys.extend(by.map(str::to_owned));
    let grouped = dataset::group_rows(&runs, &keys).map_err(usage)?;
    super::analysis::print_mixed(&dataset::mixed_columns(&runs, x, &grouped));
    print_written(&paths);
    Ok(())
}

fn print_written(paths: &[PathBuf]) {
    for path in paths {
        outln!("wrote {}", path.display());
    }
}
