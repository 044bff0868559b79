//! `mbmf plot`: mean curves per group from a dataset's series, with the change steps marked.
//! The curves come from [`crate::analysis::curves`]; this verb names the file, draws it and
//! prints what it drew.

use std::path::PathBuf;

use clap::Args;

use super::analysis::Dataset;
use super::{Failure, runtime, usage};
use crate::analysis::curves::{self, CurveMetric};
use crate::analysis::dataset;

/// `mbmf plot`.
#[derive(Debug, Clone, Args)]
#[command(
    after_help = "Example: mbmf plot out/navworld-changes --by controller --where 'schedule=1601:delete=20-21,21-20'"
)]
pub struct PlotArgs {
    /// The dataset (its runs and series tables) and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Column of the runs table whose values define the curves (e.g. controller, interaction).
    #[arg(long, value_parser = super::args::column)]
    pub by: String,
    /// What to draw: cum_reward, cum_cost or p_mb (the series' p_mb_mean).
    #[arg(long, default_value = "cum_reward", value_parser = CurveMetric::parse)]
    pub metric: CurveMetric,
    /// Folder for the SVG and PNG (default: DIR/analysis, beside the other analyses).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Title above the plot (default: the metric, the grouping column and the filters).
    #[arg(long)]
    pub title: Option<String>,
}

/// Runs `mbmf plot`: reads the curves, draws them, prints the files written.
pub fn plot(args: &PlotArgs) -> Result<(), Failure> {
    let (dir, filters) = (&args.data.dir, &args.data.filters);
    let (curves, warnings) =
        curves::read_curves(dir, &args.by, args.metric, filters, &args.data.options())
            .map_err(usage)?;
    super::analysis::warn(&warnings);
    let folder = args
        .out
        .clone()
        .unwrap_or_else(|| dataset::output_folder(dir));
    let name = curves::figure_name(args.metric, &args.by, filters);
    let title = args
        .title
        .clone()
        .unwrap_or_else(|| curves::title(args.metric, &args.by, filters));
    let paths =
        crate::plot::line_chart(&curves.chart(&title), &folder.join(name)).map_err(runtime)?;
    for c in &curves.curves {
        let runs = c.n.iter().max().copied().unwrap_or(0);
        outln!(
            "{}={}: {runs} runs, {} steps",
            args.by,
            c.label,
            c.steps.len()
        );
    }
    if !curves.change_steps.is_empty() {
        let steps: Vec<String> = curves.change_steps.iter().map(u32::to_string).collect();
        outln!("changes marked at step {}", steps.join(", "));
    }
    for path in paths {
        outln!("wrote {}", path.display());
    }
    Ok(())
}
