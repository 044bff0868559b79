//! The analysis verbs: `mbmf pareto`, `mbmf stats`, `mbmf min-budget`, `mbmf stay`. Each reads a dataset,
//! runs one analysis of this module's siblings, prints a table and writes its results beside
//! the data (Parquet, and for `pareto` a figure), atomically.

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use clap::Args;

use super::{Failure, runtime, usage};
use crate::analysis::AnalysisError;
use crate::analysis::compare::{self, Comparison};
use crate::analysis::curves;
use crate::analysis::dataset::{self, Filter, Table, Value};
use crate::analysis::front::{self, Front};
use crate::analysis::min_budget::{self, DEFAULT_ALPHA, Level, MinBudget};
use crate::analysis::pareto::{Direction, Objective};
use crate::analysis::stay;
use crate::plot::{self, FrontChart, FrontPanel};

/// The dataset an analysis reads, and the runs it keeps.
#[derive(Debug, Clone, Args)]
pub struct Dataset {
    /// Dataset: a folder written by mbmf run (runs.parquet) or mbmf sweep (runs/part-*.parquet),
    /// or one .parquet file.
    pub dir: PathBuf,
    /// Keep only runs with COLUMN=VALUE (repeatable; every filter must hold).
    #[arg(long = "where", value_name = "COLUMN=VALUE", value_parser = Filter::parse)]
    pub filters: Vec<Filter>,
    /// Analyse a sweep that misses runs or is still being written (refused by default, so that
    /// part of a sweep is never taken for the whole); a warning says how many runs are present.
    #[arg(long)]
    pub allow_incomplete: bool,
}

impl Dataset {
    /// How to read the dataset.
    pub fn options(&self) -> dataset::ReadOptions {
        dataset::ReadOptions {
            allow_incomplete: self.allow_incomplete,
        }
    }
}

/// Prints the reader's warnings (files left out, an unfinished sweep read anyway) to stderr.
pub fn warn(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// `mbmf pareto`.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Examples:
  mbmf pareto out/kappa --objectives total_reward:max,cost_total:min
  mbmf pareto out/kappa --by interaction        # one front and knee per human type, a panel each")]
pub struct ParetoArgs {
    /// The dataset and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Objectives as NAME:max or NAME:min, comma-separated; any numeric column of the runs
    /// (e.g. interactions:min, the human's effort). Default: the paper's reward, inference cost
    /// and learning quality (entropy of the controlling expert, lower is better), plus
    /// interactions:min when the number of interactions varies in the runs.
    #[arg(long, value_delimiter = ',', value_parser = Objective::parse)]
    pub objectives: Option<Vec<Objective>>,
    /// One front and one knee per value of this column (repeatable, or comma-separated: one
    /// per combination), e.g. --by interaction; the figure gets a panel per group.
    #[arg(long, value_name = "COLUMN", value_delimiter = ',')]
    pub by: Vec<String>,
    /// Numeric column the figure colours points by (default: the swept numeric parameter with
    /// the most values, e.g. kappa_coeff).
    #[arg(long, visible_alias = "color", value_name = "COLUMN")]
    pub colour: Option<String>,
    /// Folder for pareto.parquet and its figures (default: analysis/ in the dataset's folder,
    /// beside the data files, never among them). Other --objectives, --by or --where name other
    /// files (pareto-by-interaction.parquet, pareto-task-tidy1.parquet): one analysis never
    /// replaces another's.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write no figure.
    #[arg(long)]
    pub no_plot: bool,
    /// Print one JSON object on stdout instead of the table (files written, counts, the front's
    /// rows); notes go to stderr.
    #[arg(long)]
    pub json: bool,
}

/// `mbmf stats`.
#[derive(Debug, Clone, Args)]
#[command(
    after_help = "Example: mbmf stats out/run --by controller --metric total_reward --where interaction=none"
)]
pub struct StatsArgs {
    /// The dataset and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Column whose values define the groups (e.g. controller, budget, kappa_coeff).
    #[arg(long, value_parser = super::args::column)]
    pub by: String,
    /// Numeric column to compare (e.g. total_reward, cost_total, mean_entropy_chosen).
    #[arg(long, default_value = "total_reward", value_parser = super::args::column)]
    pub metric: String,
    /// Print one JSON object on stdout instead of the tables (the groups and the pairs).
    #[arg(long)]
    pub json: bool,
}

/// `mbmf min-budget`.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Example: mbmf min-budget out/budgets --metric reward_last10")]
pub struct MinBudgetArgs {
    /// The dataset and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Numeric column to compare between budgets: total_reward (default) or reward_last10 (the
    /// accumulation rate at the end of the run).
    #[arg(long, default_value = "total_reward", value_parser = super::args::column)]
    pub metric: String,
    /// Significance level of the one-sided tests (SPEC 9: 0.05).
    #[arg(long, default_value_t = DEFAULT_ALPHA, value_parser = super::args::number, allow_hyphen_values = true)]
    pub alpha: f64,
    /// Folder for min_budget.parquet (default: analysis/ in the dataset's folder). Another
    /// --metric, --alpha or --where names another file (min_budget-reward_last10.parquet,
    /// min_budget-alpha-0.01.parquet, min_budget-interaction-takeover.parquet).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also print every budget of every group (mean, sd, the budgets that beat it).
    #[arg(long)]
    pub levels: bool,
    /// Print one JSON object on stdout instead of the table (file written, one row per group).
    #[arg(long)]
    pub json: bool,
}

/// `mbmf stay`.
#[derive(Debug, Clone, Args)]
#[command(after_help = "Example:
  mbmf run --task twostep --controller mf,mb,fixed --combine mix --runs 200 --steps 2000 --tau 0.2 --lambda-mf 1 --out out/twostep
  mbmf stay out/twostep --by controller")]
pub struct StayArgs {
    /// The dataset (runs of the two-step task) and the runs kept.
    #[command(flatten)]
    pub data: Dataset,
    /// Column whose values define the groups (e.g. controller, lambda_mf, w_mb).
    #[arg(long, value_parser = super::args::column)]
    pub by: String,
    /// Folder for the figure, stay-by-COLUMN.svg and .png (the filters added to the name; default:
    /// analysis/ in the dataset's folder).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write no figure.
    #[arg(long)]
    pub no_plot: bool,
    /// Print one JSON object on stdout instead of the tables (the groups, the pairs, the files).
    #[arg(long)]
    pub json: bool,
}

/// Reads the runs of the dataset, prints the reader's warnings and applies the filters.
fn load(data: &Dataset) -> Result<Table, Failure> {
    let read = dataset::read_table(&data.dir, "runs", &data.options()).map_err(usage)?;
    warn(&read.warnings);
    if read.table.is_empty() {
        return Err(usage(anyhow!("{} holds no runs", read.table.source())));
    }
    Filter::apply_all(&read.table, &data.filters).map_err(usage)
}

/// The output folder of an analysis that writes files (`--out`, or `analysis/` beside the
/// data), checked before any work, and the runs it analyses.
fn load_for_output(data: &Dataset, out: Option<&Path>) -> Result<(PathBuf, Table), Failure> {
    let folder = out.map_or_else(|| dataset::output_folder(&data.dir), Path::to_path_buf);
    super::args::check_out_dir(&folder, "--out")?;
    Ok((folder, load(data)?))
}

/// Writes `table` as Parquet into `folder/name`, atomically, with the provenance of `schema`.
fn write_table(table: &Table, folder: &Path, name: &str, schema: &str) -> Result<PathBuf, Failure> {
    std::fs::create_dir_all(folder)
        .with_context(|| format!("cannot create output folder {}", folder.display()))
        .map_err(runtime)?;
    let batch = table
        .to_record_batch()
        .map_err(|e| runtime(anyhow!("internal error building {name}: {e}")))?;
    let metadata = crate::output::provenance(
        schema,
        &crate::output::Context {
            command: &super::command_line(),
            ..Default::default()
        },
    );
    crate::output::write_parquet(&folder.join(name), &batch, metadata).map_err(runtime)
}

fn analysis_failure(e: AnalysisError) -> Failure {
    usage(e)
}

/// Runs `mbmf pareto`: one front per task and step count in the data (rewards of different
/// tasks or lengths cannot be compared) and per value of the `--by` columns, so a dataset of
/// one task and length without `--by` gives one front.
pub fn pareto(args: &ParetoArgs) -> Result<(), Failure> {
    let (folder, table) = load_for_output(&args.data, args.out.as_deref())?;
    if let Some(colour) = &args.colour {
        table.numeric(colour, "--colour").map_err(usage)?;
    }
    let pareto =
        front::pareto(&table, args.objectives.as_deref(), &args.by).map_err(analysis_failure)?;
    let fronts: Vec<(&[(String, Value)], &Front)> = pareto
        .groups
        .iter()
        .map(|g| (g.values.as_slice(), &g.front))
        .collect();
    let runs_of = |g: usize| pareto.groups[g].runs;
    if !args.json {
        if fronts.len() > 1 {
            let keys: Vec<&str> = fronts[0].0.iter().map(|(k, _)| k.as_str()).collect();
            let why = if args.by.is_empty() {
                ", whose results cannot be compared with each other"
            } else {
                ""
            };
            outln!(
                "{}: {} runs in {} groups of {}{why}: one front per group (or keep one with \
                 --where {}=VALUE)",
                table.source(),
                table.len(),
                fronts.len(),
                keys.join(" and "),
                keys[0]
            );
        }
        for (g, (values, front)) in fronts.iter().enumerate() {
            if fronts.len() > 1 {
                outln!();
            }
            print_front(front, values, runs_of(g));
        }
    }
    // Named by the runs kept, the groups and the objectives when given: `pareto.parquet` for
    // the whole dataset, `pareto-by-interaction-controller-ec.parquet` for another question.
    let stem = match &args.objectives {
        Some(objectives) => {
            // NAME.max: a name with no character replaced, so no hash (output_name).
            let names: Vec<String> = objectives
                .iter()
                .map(|o| o.to_string().replace(':', "."))
                .collect();
            format!("pareto-{}", names.join("-"))
        }
        None => "pareto".to_owned(),
    };
    let name = curves::output_name(&stem, &args.by, &args.data.filters);
    let all = pareto
        .to_table()
        .map_err(|e| runtime(anyhow!("internal error building {name}.parquet: {e}")))?;
    let path = write_table(
        &all,
        &folder,
        &format!("{name}.parquet"),
        crate::output::provenance::PARETO_SCHEMA,
    )?;
    let mut written = vec![path];
    if !args.no_plot {
        let colour = args.colour.clone().or_else(|| {
            fronts
                .iter()
                .find_map(|(_, f)| f.configs.swept_number().map(str::to_owned))
        });
        // With --by, the groups are what the reader compares: one figure, a panel each.
        // Otherwise they are tasks or lengths that cannot be compared: a figure each.
        let figures: Vec<Vec<usize>> = if args.by.is_empty() {
            (0..fronts.len()).map(|g| vec![g]).collect()
        } else {
            vec![(0..fronts.len()).collect()]
        };
        for members in figures {
            // A figure per task and length: the group's values name it beside the table's name.
            let name = if args.by.is_empty() {
                let values = fronts[members[0]].0.iter().map(|(_, v)| v.to_string());
                let stem: Vec<String> = std::iter::once(stem.clone()).chain(values).collect();
                curves::output_name(&stem.join("-"), &[], &args.data.filters)
            } else {
                name.clone()
            };
            let panels: Vec<(String, &Front)> = members
                .iter()
                .map(|&g| (group_label(fronts[g].0), fronts[g].1))
                .collect();
            match front_chart(&panels, colour.as_deref(), args.by.is_empty()) {
                Some(chart) => {
                    written.extend(plot::front_chart(&chart, &folder.join(name)).map_err(runtime)?)
                }
                None => eprintln!("note: no figure: it needs two objectives with finite means"),
            }
        }
    }
    let shown: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    if args.json {
        let json = match fronts.as_slice() {
            [(_, front)] if args.by.is_empty() => front_json(front, &[], table.len(), &shown),
            _ => grouped_json(&fronts, &table, &shown, runs_of),
        };
        outln!("{json}");
    } else {
        outln!("wrote {}", shown.join(", "));
    }
    Ok(())
}

/// `task=tidy1, steps=200`.
fn group_label(values: &[(String, Value)]) -> String {
    let parts: Vec<String> = values.iter().map(|(k, v)| format!("{k}={v}")).collect();
    parts.join(", ")
}

/// The `--json` report of `mbmf pareto` over several groups: the one-front report of each
/// group (without `verb` and `files`), with the group's values under `group`.
fn grouped_json(
    fronts: &[(&[(String, Value)], &Front)],
    table: &Table,
    files: &[String],
    runs_of: impl Fn(usize) -> usize,
) -> serde_json::Value {
    let groups: Vec<serde_json::Value> = fronts
        .iter()
        .enumerate()
        .map(|(g, (values, front))| {
            let mut report = front_json(front, values, runs_of(g), &[]);
            if let Some(map) = report.as_object_mut() {
                map.remove("verb");
                map.remove("files");
                let group: serde_json::Map<String, serde_json::Value> = values
                    .iter()
                    .map(|(k, v)| (k.clone(), serde_json::json!(v.to_string())))
                    .collect();
                map.insert("group".to_owned(), serde_json::Value::Object(group));
            }
            report
        })
        .collect();
    let objectives: Vec<String> = fronts[0]
        .1
        .objectives
        .iter()
        .map(|o| o.to_string())
        .collect();
    serde_json::json!({
        "verb": "pareto",
        "source": table.source(),
        "files": files,
        "runs": table.len(),
        "objectives": objectives,
        "groups": groups,
    })
}

/// The `--json` report of `mbmf pareto`: one row per front member, in the table's order, each
/// starting with the group's values.
fn front_json(
    front: &Front,
    group: &[(String, Value)],
    runs: usize,
    files: &[String],
) -> serde_json::Value {
    let c = &front.configs;
    let rows: Vec<serde_json::Value> = front
        .members()
        .iter()
        .map(|&i| {
            let mut row = serde_json::Map::new();
            for (k, v) in group {
                row.insert(k.clone(), serde_json::json!(v.to_string()));
            }
            for k in &c.varying {
                let value = c.key_value(i, k).map(|v| v.to_string());
                row.insert(k.clone(), serde_json::json!(value));
            }
            row.insert("n".to_owned(), serde_json::json!(c.rows[i].len()));
            for (o, objective) in front.objectives.iter().enumerate() {
                row.insert(
                    format!("{}_mean", objective.name),
                    serde_json::json!(front.objective_mean(i, o)),
                );
                row.insert(
                    format!("{}_ci95", objective.name),
                    serde_json::json!(front.objective_ci95(i, o)),
                );
            }
            row.insert("knee".to_owned(), serde_json::json!(front.knee == Some(i)));
            serde_json::Value::Object(row)
        })
        .collect();
    let objectives: Vec<String> = front.objectives.iter().map(|o| o.to_string()).collect();
    serde_json::json!({
        "verb": "pareto",
        "source": c.source.to_string(),
        "files": files,
        "runs": runs,
        "configurations": c.len(),
        "objectives": objectives,
        "front": rows,
        "knee": front.knee.map(|k| c.label(k)),
    })
}

fn print_front(front: &Front, group: &[(String, Value)], runs: usize) {
    let c = &front.configs;
    let objectives: Vec<String> = front.objectives.iter().map(|o| o.to_string()).collect();
    let members = front.members();
    outln!(
        "{}: {runs} runs in {} configurations; {} on the Pareto front of {}",
        c.source,
        c.len(),
        members.len(),
        objectives.join(", ")
    );
    let unranked = front.rank.iter().filter(|r| r.is_none()).count();
    if unranked > 0 {
        outln!(
            "({unranked} configurations lack a mean of some objective and are left out of the ranking)"
        );
    }
    let mut headers: Vec<String> = group.iter().map(|(k, _)| k.clone()).collect();
    headers.extend(c.varying.iter().cloned());
    headers.push("n".to_owned());
    for o in &front.objectives {
        headers.push(format!("{} ({})", o.name, o.direction));
    }
    headers.push("knee".to_owned());
    let mut rows = Vec::new();
    for &i in &members {
        let mut row: Vec<String> = group.iter().map(|(_, v)| v.to_string()).collect();
        row.extend(
            c.varying
                .iter()
                .map(|k| c.key_value(i, k).map(|v| v.to_string()).unwrap_or_default()),
        );
        row.push(c.rows[i].len().to_string());
        for o in 0..front.objectives.len() {
            row.push(mean_ci(
                front.objective_mean(i, o),
                front.objective_ci95(i, o),
            ));
        }
        row.push(if front.knee == Some(i) { "<- knee" } else { "" }.to_owned());
        rows.push(row);
    }
    let left = group.len() + c.varying.len();
    let last = headers.len() - 1;
    out!(
        "{}",
        render_aligned(&headers, &rows, |i| i < left || i == last)
    );
    outln!("(means over runs ± half-width of the 95% Student-t confidence interval)");
    if let Some(k) = front.knee {
        outln!(
            "knee (suggested): {}: the front configuration nearest the ideal point once each \
             objective is rescaled to [0, 1] over the front (pareto::knee_point)",
            c.label(k)
        );
    }
}

/// The figure of fronts, a panel per `(title, front)`: the second objective across, the first
/// up, points coloured by `colour` (a configuration column or an averaged result), front
/// points labelled. `None` with fewer than two objectives or no point with finite means.
fn front_chart(
    panels: &[(String, &Front)],
    colour: Option<&str>,
    title_group: bool,
) -> Option<FrontChart> {
    let first = panels.first()?.1;
    if first.objectives.len() < 2 {
        return None;
    }
    let mut chart_panels = Vec::with_capacity(panels.len());
    let mut xs = Vec::new();
    let mut configurations = 0;
    for (title, front) in panels {
        let c = &front.configs;
        configurations += c.len();
        let shown: Vec<usize> = (0..c.len())
            .filter(|&i| {
                front.objective_mean(i, 0).is_finite() && front.objective_mean(i, 1).is_finite()
            })
            .collect();
        if shown.is_empty() {
            continue;
        }
        let points: Vec<(f64, f64)> = shown
            .iter()
            .map(|&i| (front.objective_mean(i, 1), front.objective_mean(i, 0)))
            .collect();
        xs.extend(points.iter().map(|p| p.0));
        let position = |i: usize| shown.iter().position(|&s| s == i);
        // The colour bar names the column, so a point swept along it alone shows its value.
        let bare = colour.filter(|name| c.varying.len() == 1 && c.varying[0] == *name);
        let labels = shown
            .iter()
            .map(|&i| match bare.and_then(|name| c.key_value(i, name)) {
                Some(v) => v.to_string(),
                None => c.label(i),
            })
            .collect();
        chart_panels.push(FrontPanel {
            title: if title_group {
                String::new()
            } else {
                title.clone()
            },
            points,
            colour_values: colour.map_or_else(Vec::new, |name| {
                shown
                    .iter()
                    .map(|&i| c.number(i, name).unwrap_or(f64::NAN))
                    .collect()
            }),
            front: (0..c.len())
                .filter(|&i| front.rank[i] == Some(0))
                .filter_map(position)
                .collect(),
            knee: front.knee.and_then(position),
            labels,
        });
    }
    if chart_panels.is_empty() {
        return None;
    }
    let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let axis = |o: &Objective| {
        let better = match o.direction {
            Direction::Maximize => "higher is better",
            Direction::Minimize => "lower is better",
        };
        format!("{} (mean; {better})", o.name)
    };
    let extra = if first.objectives.len() > 2 {
        format!(", front over {} objectives", first.objectives.len())
    } else {
        String::new()
    };
    let mut title = format!("Pareto front ({configurations} configurations{extra})");
    if title_group && !panels[0].0.is_empty() {
        title = format!("{title}, {}", panels[0].0);
    }
    Some(FrontChart {
        title,
        x_label: axis(&first.objectives[1]),
        y_label: axis(&first.objectives[0]),
        colour: colour.map(str::to_owned),
        panels: chart_panels,
        join_front: first.objectives.len() == 2,
        log_x: lo > 0.0 && hi / lo >= 100.0,
        log_y: false,
    })
}

/// Runs `mbmf stats`.
pub fn stats(args: &StatsArgs) -> Result<(), Failure> {
    let table = load(&args.data)?;
    let comparison = compare::compare(&table, &args.by, &args.metric).map_err(analysis_failure)?;
    if args.json {
        outln!("{}", comparison_json(&comparison));
    } else {
        print_comparison(&comparison);
    }
    Ok(())
}

/// The `--json` report of `mbmf stats`: the groups and the Holm-corrected pairs.
fn comparison_json(c: &Comparison) -> serde_json::Value {
    let groups: Vec<serde_json::Value> = c
        .groups
        .iter()
        .map(|g| {
            serde_json::json!({
                "value": g.value.to_string(),
                "n": g.n,
                "missing": g.missing,
                "mean": g.mean,
                "sd": g.sd,
                "median": g.median,
            })
        })
        .collect();
    let pairs: Vec<serde_json::Value> = c
        .pairs
        .iter()
        .map(|p| {
            serde_json::json!({
                "a": c.groups[p.first].value.to_string(),
                "b": c.groups[p.second].value.to_string(),
                "u": p.test.u,
                "p": p.test.p_value,
                "p_holm": p.p_holm,
                "effect": p.test.effect_size,
                "method": p.test.method.name(),
            })
        })
        .collect();
    let empty: Vec<String> = c.empty.iter().map(|v| v.to_string()).collect();
    serde_json::json!({
        "verb": "stats",
        "source": c.source.to_string(),
        "metric": c.metric,
        "by": c.by,
        "groups": groups,
        "pairs": pairs,
        "left_out": empty,
        "also_varying": c.mixed,
    })
}

/// Column titles of a text table.
fn titles(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

fn print_comparison(c: &Comparison) {
    outln!(
        "{}: {} by {} (two-sided Wilcoxon-Mann-Whitney tests, Holm-corrected over {} pair{})",
        c.source,
        c.metric,
        c.by,
        c.pairs.len(),
        if c.pairs.len() == 1 { "" } else { "s" }
    );
    let headers = titles(&[c.by.as_str(), "n", "mean", "sd", "median"]);
    let rows: Vec<Vec<String>> = c
        .groups
        .iter()
        .map(|g| {
            let mut n = g.n.to_string();
            if g.missing > 0 {
                n.push_str(&format!(" (+{} missing)", g.missing));
            }
            vec![
                g.value.to_string(),
                n,
                num(g.mean),
                num(g.sd),
                num(g.median),
            ]
        })
        .collect();
    out!("{}", render(&headers, &rows, 1));
    outln!();
    let headers = titles(&["a", "b", "U", "p", "p_holm", "", "effect", "method"]);
    let rows: Vec<Vec<String>> = c
        .pairs
        .iter()
        .map(|p| {
            vec![
                c.groups[p.first].value.to_string(),
                c.groups[p.second].value.to_string(),
                num(p.test.u),
                pval(p.test.p_value),
                pval(p.p_holm),
                crate::analysis::stats::significance_stars(p.p_holm).to_owned(),
                format!("{:+.3}", p.test.effect_size),
                p.test.method.name().to_owned(),
            ]
        })
        .collect();
    out!("{}", render_aligned(&headers, &rows, |i| i < 2 || i == 5));
    outln!(
        "U = Mann-Whitney U of a; effect = rank-biserial correlation P(a > b) - P(a < b), in \
         [-1, 1]; * p_holm < 0.05, ** < 0.01, *** < 0.001; exact = exact null distribution \
         (small samples, no ties), normal = normal approximation with tie and continuity \
         correction"
    );
    if !c.empty.is_empty() {
        let values: Vec<String> = c.empty.iter().map(|v| v.to_string()).collect();
        outln!(
            "left out ({} has no value): {} = {}",
            c.metric,
            c.by,
            values.join(", ")
        );
    }
    print_mixed(&c.mixed);
}

/// The parameters that vary within the compared groups, if any, and how to hold them fixed.
pub(super) fn print_mixed(mixed: &[String]) {
    if !mixed.is_empty() {
        outln!(
            "within groups these parameters also vary: {}; add --where COLUMN=VALUE to compare \
             like with like",
            mixed.join(", ")
        );
    }
}

/// Runs `mbmf stay`: the stay table per group, the tests between groups and the classic figure.
pub fn stay(args: &StayArgs) -> Result<(), Failure> {
    let (folder, table) = if args.no_plot {
        (PathBuf::new(), load(&args.data)?)
    } else {
        load_for_output(&args.data, args.out.as_deref())?
    };
    let result = stay::stay(&table, &args.by).map_err(analysis_failure)?;
    let mut files = Vec::new();
    if !args.no_plot {
        let name = curves::output_name("stay", std::slice::from_ref(&args.by), &args.data.filters);
        files = plot::bar_panels(&stay_chart(&result), &folder.join(name))
            .map_err(|e| runtime(anyhow!(e)))?;
    }
    if args.json {
        outln!("{}", stay_json(&result, &files));
    } else {
        print_stay(&result);
        for f in &files {
            outln!("wrote {}", f.display());
        }
    }
    Ok(())
}

/// The classic two-step figure: per group a panel, the stay probability after a rewarded and
/// after an unrewarded trial, common and rare transitions side by side, with standard errors.
fn stay_chart(s: &stay::Stay) -> plot::BarPanels {
    let panels = s
        .groups
        .iter()
        .map(|g| {
            let bar = |column: usize, label: &str, group: &str| plot::Bar {
                label: label.to_owned(),
                // A kind no trial of the group had draws no bar (0).
                value: Some(g.columns[column].mean)
                    .filter(|m| m.is_finite())
                    .map_or(0.0, |m| m.clamp(0.0, 1.0)),
                error: Some(g.columns[column].sem).filter(|e| e.is_finite()),
                group: group.to_owned(),
            };
            plot::BarChart {
                title: format!("{}={} ({} runs)", s.by, g.value, g.runs),
                y_label: "stay probability".to_owned(),
                bars: vec![
                    bar(0, "common", "rewarded"),
                    bar(1, "rare", "rewarded"),
                    bar(2, "common", "unrewarded"),
                    bar(3, "rare", "unrewarded"),
                ],
                annotations: vec![],
            }
        })
        .collect();
    plot::BarPanels {
        title: "Two-step task: stay probability by the previous trial's reward and transition"
            .to_owned(),
        panels,
    }
}

/// The `--json` report of `mbmf stay`.
fn stay_json(s: &stay::Stay, files: &[PathBuf]) -> serde_json::Value {
    let groups: Vec<serde_json::Value> = s
        .groups
        .iter()
        .map(|g| {
            let mut columns = serde_json::Map::new();
            for (name, c) in stay::COLUMNS.iter().zip(&g.columns) {
                columns.insert(
                    (*name).to_owned(),
                    serde_json::json!({"n": c.n, "mean": c.mean, "ci95": c.ci95, "sem": c.sem}),
                );
            }
            serde_json::json!({"value": g.value.to_string(), "runs": g.runs, "columns": columns})
        })
        .collect();
    let pairs: Vec<serde_json::Value> = s
        .pairs
        .iter()
        .map(|p| {
            serde_json::json!({
                "column": stay::COLUMNS[p.column],
                "a": s.groups[p.first].value.to_string(),
                "b": s.groups[p.second].value.to_string(),
                "u": p.test.u,
                "p": p.test.p_value,
                "p_holm": p.p_holm,
                "effect": p.test.effect_size,
                "method": p.test.method.name(),
            })
        })
        .collect();
    let files: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    serde_json::json!({
        "verb": "stay",
        "source": s.source,
        "by": s.by,
        "groups": groups,
        "pairs": pairs,
        "files": files,
        "also_varying": s.mixed,
    })
}

fn print_stay(s: &stay::Stay) {
    outln!(
        "{}: stay probabilities by {} (mean over runs ± 95% CI; SPEC 13)",
        s.source,
        s.by
    );
    let mut headers = vec![s.by.clone(), "runs".to_owned()];
    headers.extend(["rc", "rr", "uc", "ur", "reward effect", "interaction"].map(String::from));
    let rows: Vec<Vec<String>> = s
        .groups
        .iter()
        .map(|g| {
            let mut row = vec![g.value.to_string(), g.runs.to_string()];
            row.extend(g.columns.iter().map(|c| mean_ci(c.mean, c.ci95)));
            row
        })
        .collect();
    out!("{}", render(&headers, &rows, 1));
    outln!(
        "rc, rr, uc, ur: the first-stage action repeats the previous trial's after a rewarded (r) \
         or unrewarded (u) trial whose transition was common (c) or rare (r); reward effect = \
         (rc + rr - uc - ur) / 2 (model-free), interaction = (rc - rr - uc + ur) / 2 \
         (model-based)"
    );
    if !s.pairs.is_empty() {
        outln!();
        let headers = titles(&["column", "a", "b", "U", "p", "p_holm", "", "effect"]);
        let rows: Vec<Vec<String>> = s
            .pairs
            .iter()
            .map(|p| {
                vec![
                    stay::COLUMNS[p.column].to_owned(),
                    s.groups[p.first].value.to_string(),
                    s.groups[p.second].value.to_string(),
                    num(p.test.u),
                    pval(p.test.p_value),
                    pval(p.p_holm),
                    crate::analysis::stats::significance_stars(p.p_holm).to_owned(),
                    format!("{:+.3}", p.test.effect_size),
                ]
            })
            .collect();
        out!("{}", render_aligned(&headers, &rows, |i| i < 3 || i == 6));
        outln!(
            "two-sided Wilcoxon-Mann-Whitney tests per column, Holm-corrected over the pairs of \
             that column; effect = P(a > b) - P(a < b)"
        );
    }
    print_mixed(&s.mixed);
}

/// Runs `mbmf min-budget`.
pub fn min_budget(args: &MinBudgetArgs) -> Result<(), Failure> {
    let (folder, table) = load_for_output(&args.data, args.out.as_deref())?;
    let result =
        min_budget::min_budget(&table, &args.metric, args.alpha).map_err(analysis_failure)?;
    if !args.json {
        print_min_budget(&result, args.levels);
    }
    // Named by the metric when not the default, and by the runs kept.
    let mut stem = if args.metric == "total_reward" {
        "min_budget".to_owned()
    } else {
        format!("min_budget-{}", args.metric)
    };
    if args.alpha != DEFAULT_ALPHA {
        stem += &format!("-alpha-{}", args.alpha);
    }
    let name = curves::output_name(&stem, &[], &args.data.filters);
    let path = write_table(
        &result.to_table(),
        &folder,
        &format!("{name}.parquet"),
        crate::output::provenance::MIN_BUDGET_SCHEMA,
    )?;
    if args.json {
        outln!("{}", min_budget_json(&result, &path));
    } else {
        outln!("wrote {}", path.display());
    }
    Ok(())
}

/// The `--json` report of `mbmf min-budget`: one row per group, as in the table.
fn min_budget_json(r: &MinBudget, path: &Path) -> serde_json::Value {
    let rows: Vec<serde_json::Value> = r
        .groups
        .iter()
        .enumerate()
        .map(|(g, group)| {
            let mut row = serde_json::Map::new();
            for k in &r.shown {
                let value = r.key_value(g, k).map(|v| v.to_string());
                row.insert(k.clone(), serde_json::json!(value));
            }
            let chosen = &group.levels[group.chosen];
            let best = &group.levels[group.best];
            let budgets: Vec<u64> = group.levels.iter().map(|l| l.budget).collect();
            row.insert("budgets".to_owned(), serde_json::json!(budgets));
            row.insert("min_budget".to_owned(), serde_json::json!(chosen.budget));
            row.insert("mean".to_owned(), serde_json::json!(chosen.mean));
            row.insert("best_budget".to_owned(), serde_json::json!(best.budget));
            row.insert("best_mean".to_owned(), serde_json::json!(best.mean));
            serde_json::Value::Object(row)
        })
        .collect();
    serde_json::json!({
        "verb": "min-budget",
        "source": r.source.to_string(),
        "metric": r.metric,
        "alpha": r.alpha,
        "files": [path.display().to_string()],
        "groups": rows,
    })
}

fn print_min_budget(r: &MinBudget, levels: bool) {
    outln!(
        "{}: minimal budget of {} (SPEC 9: the smallest budget that no larger budget beats with \
         a higher mean and a one-sided Mann-Whitney p < {}; no multiple-comparison correction)",
        r.source,
        r.metric,
        r.alpha
    );
    let mut headers: Vec<String> = r.shown.clone();
    for h in [
        "budgets",
        "min budget",
        "mean",
        "best budget",
        "best mean",
        "p vs larger budgets (budget: p)",
    ] {
        headers.push(h.to_owned());
    }
    let mut rows = Vec::new();
    let mut notes = Vec::new();
    for (g, group) in r.groups.iter().enumerate() {
        let mut row = row_label(r, g);
        let chosen = &group.levels[group.chosen];
        let best = &group.levels[group.best];
        let budgets: Vec<String> = group.levels.iter().map(|l| l.budget.to_string()).collect();
        row.push(budgets.join(","));
        row.push(chosen.budget.to_string());
        row.push(num(chosen.mean));
        row.push(best.budget.to_string());
        row.push(num(best.mean));
        let ps: Vec<String> = chosen
            .vs_larger
            .iter()
            .map(|v| format!("{}: {}", v.budget, pval(v.p_value)))
            .collect();
        row.push(if ps.is_empty() {
            "(largest budget)".to_owned()
        } else {
            ps.join(", ")
        });
        rows.push(row);
        if !group.not_monotone.is_empty() {
            let label: Vec<String> = row_label(r, g);
            let detail: Vec<String> = group
                .levels
                .iter()
                .filter(|l| group.not_monotone.contains(&l.budget))
                .map(|l| format!("{} is beaten by {}", l.budget, beaten_by(l)))
                .collect();
            notes.push(format!(
                "not monotone for {}: above the minimal budget {}, {}",
                label.join(" "),
                chosen.budget,
                detail.join("; ")
            ));
        }
    }
    let (keys, last) = (r.shown.len(), headers.len() - 1);
    out!(
        "{}",
        render_aligned(&headers, &rows, |i| i < keys || i == last)
    );
    outln!(
        "budget 0 = runs with budget 0 or interaction none, shared by every interaction type; \
         p = one-sided test that the larger budget's values are greater"
    );
    for n in notes {
        outln!("{n}");
    }
    if r.baseline_only > 0 {
        outln!(
            "({} parameter combinations have only budget-0 runs and are not shown)",
            r.baseline_only
        );
    }
    if levels {
        for (g, group) in r.groups.iter().enumerate() {
            outln!();
            outln!("{}", row_label(r, g).join(" "));
            let headers = titles(&["budget", "n", "mean", "sd", "qualifies", "beaten by"]);
            let rows: Vec<Vec<String>> = group
                .levels
                .iter()
                .map(|l| {
                    vec![
                        l.budget.to_string(),
                        l.n.to_string(),
                        num(l.mean),
                        num(l.sd),
                        if l.qualifies { "yes" } else { "no" }.to_owned(),
                        beaten_by(l),
                    ]
                })
                .collect();
            out!("{}", render_aligned(&headers, &rows, |i| i == 5));
        }
    }
}

/// The larger budgets that beat `level`, with their p-values: `40 (p = 0.01), 80 (p = 0.002)`.
fn beaten_by(level: &Level) -> String {
    let by: Vec<String> = level
        .vs_larger
        .iter()
        .filter(|v| v.beats)
        .map(|v| format!("{} (p = {})", v.budget, pval(v.p_value)))
        .collect();
    by.join(", ")
}

fn row_label(r: &MinBudget, g: usize) -> Vec<String> {
    r.shown
        .iter()
        .map(|k| r.key_value(g, k).map(|v| v.to_string()).unwrap_or_default())
        .collect()
}

/// A number with four significant digits, scientific notation outside [1e-3, 1e7); `-` for
/// NaN.
fn num(x: f64) -> String {
    match decimals(x) {
        Some(d) => format!("{x:.d$}"),
        None if x.is_finite() => format!("{x:.3e}"),
        None => "-".to_owned(),
    }
}

/// Decimals that show `x` with four significant digits, or `None` where [`num`] uses
/// scientific notation (or `x` is not finite).
fn decimals(x: f64) -> Option<usize> {
    if !x.is_finite() {
        return None;
    }
    if x == 0.0 {
        return Some(0);
    }
    let magnitude = x.abs().log10().floor();
    (-3.0..7.0)
        .contains(&magnitude)
        .then(|| (3.0 - magnitude).max(0.0) as usize)
}

/// `mean ± ci` with both at the mean's precision, or the mean alone when the interval is
/// undefined.
fn mean_ci(mean: f64, ci: f64) -> String {
    if !ci.is_finite() {
        return num(mean);
    }
    match decimals(mean) {
        Some(d) => format!("{mean:.d$} ± {ci:.d$}"),
        None => format!("{} ± {ci:.3e}", num(mean)),
    }
}

/// A p-value: four decimals, scientific below 1e-4.
fn pval(p: f64) -> String {
    if !p.is_finite() {
        "-".to_owned()
    } else if p < 1e-4 {
        format!("{p:.2e}")
    } else {
        format!("{p:.4}")
    }
}

/// A plain-text table: the first `left` columns left-aligned, the others right-aligned.
pub(super) fn render(headers: &[String], rows: &[Vec<String>], left: usize) -> String {
    render_aligned(headers, rows, |i| i < left)
}

/// A plain-text table: columns for which `left` holds are left-aligned, others right-aligned.
fn render_aligned(
    headers: &[String],
    rows: &[Vec<String>],
    left: impl Fn(usize) -> bool,
) -> String {
    let width = |s: &str| s.chars().count();
    let mut widths: Vec<usize> = headers.iter().map(|h| width(h)).collect();
    for row in rows {
        for (w, cell) in widths.iter_mut().zip(row) {
            *w = (*w).max(width(cell));
        }
    }
    let line = |cells: &[String]| -> String {
        let parts: Vec<String> = cells
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(i, (cell, &w))| {
                let pad = " ".repeat(w - width(cell));
                if left(i) {
                    format!("{cell}{pad}")
                } else {
                    format!("{pad}{cell}")
                }
            })
            .collect();
        format!("{}\n", parts.join("  ").trim_end())
    };
    let mut out = line(headers);
    for row in rows {
        out.push_str(&line(row));
    }
    out
}
