//! Shared drawing helpers: title, text fitting, tick counts, legend and mesh.

use super::*;

pub(super) fn text_style(size: f64) -> TextStyle<'static> {
    TextStyle::from((FONT, size).into_font()).color(&BLACK)
}

pub(super) type DrawResult<DB> =
    Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Pixel width of `text`.
pub(super) fn text_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    Ok(area.estimate_text_size(text, style)?.0)
}

/// `text`, shortened with an ellipsis until it is at most `max_width` pixels wide.
pub(super) fn fit_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
    max_width: u32,
) -> Result<String, DrawingAreaErrorKind<DB::ErrorType>> {
    if text_width(area, text, style)? <= max_width {
        return Ok(text.to_string());
    }
    let mut chars: Vec<char> = text.chars().collect();
    while !chars.is_empty() {
        chars.pop();
        let candidate: String = chars.iter().collect::<String>() + "…";
        if text_width(area, &candidate, style)? <= max_width {
            return Ok(candidate);
        }
    }
    Ok(String::new())
}

/// The area under the title (the whole figure if the title is empty), on a white background.
pub(super) fn titled_area<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<DrawingArea<DB, Shift>, DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let root = root.margin(12, 4, 4, 4);
    if title.trim().is_empty() {
        return Ok(root);
    }
    let style = text_style(TITLE_SIZE);
    let (width, _) = root.dim_in_pixel();
    let title = fit_text(&root, title, &style, width.saturating_sub(20))?;
    root.titled(&title, style)
}

/// Width the y label area needs for these ticks, their labels and the rotated axis text.
pub(super) fn y_label_area_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axis: &Axis,
    ticks: usize,
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(TICK_SIZE);
    let mut widest = 0;
    for tick in axis.ticks(ticks) {
        widest = widest.max(text_width(area, &axis.format_tick(tick), &style)?);
    }
    Ok(widest + 16 + DESC_SIZE as u32 + 12)
}

/// How many x ticks fit side by side in `plot_width` pixels without labels touching.
pub(super) fn x_tick_count<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    axis: &Axis,
    plot_width: u32,
) -> Result<usize, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(TICK_SIZE);
    for count in (2..=10).rev() {
        let ticks = axis.ticks(count);
        let mut widest = 0;
        for tick in &ticks {
            widest = widest.max(text_width(area, &axis.format_tick(*tick), &style)?);
        }
        if (widest + 24) as usize * ticks.len() <= plot_width as usize {
            return Ok(count);
        }
    }
    Ok(2)
}

/// How a legend entry's swatch looks.
#[derive(Clone, Copy)]
pub(super) enum Swatch {
    /// A line, over a translucent band if `band`.
    Line { colour: RGBColor, band: bool },
    /// A filled square.
    Block(RGBColor),
    /// A small dot.
    Dot(RGBColor),
    /// A line through a large dot.
    LineDot(RGBColor),
    /// The knee marker.
    Ring,
}

pub(super) const LEGEND_SWATCH: i32 = 28;
pub(super) const LEGEND_ROW: i32 = 26;

/// Height of one line of legend text, in pixels.
pub(super) const LEGEND_LINE: i32 = 19;

/// Width of a legend panel for these labels: the widest label, at most 30% of the figure
/// (longer labels are wrapped).
pub(super) fn legend_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    labels: &[&str],
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(LEGEND_SIZE);
    let mut widest = 0;
    for label in labels {
        widest = widest.max(text_width(area, label, &style)?);
    }
    Ok((widest + LEGEND_SWATCH as u32 + 30).min(WIDTH * 3 / 10))
}

/// `text` broken at spaces into lines at most `max_width` pixels wide; at most `max_lines`
/// lines, the last shortened with an ellipsis if it is still too long.
pub(super) fn wrap_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    style: &TextStyle,
    max_width: u32,
    max_lines: usize,
) -> Result<Vec<String>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut lines: Vec<String> = Vec::new();
    let mut current = String::new();
    for word in text.split_whitespace() {
        let candidate = if current.is_empty() {
            word.to_string()
        } else {
            format!("{current} {word}")
        };
        if current.is_empty() || text_width(area, &candidate, style)? <= max_width {
            current = candidate;
        } else {
            lines.push(std::mem::replace(&mut current, word.to_string()));
        }
    }
    if !current.is_empty() || lines.is_empty() {
        lines.push(current);
    }
    if lines.len() > max_lines.max(1) {
        let rest = lines.split_off(max_lines.max(1) - 1).join(" ");
        lines.push(rest);
    }
    lines
        .iter()
        .map(|line| fit_text(area, line, style, max_width))
        .collect()
}

/// Draws a legend panel: a swatch and a (wrapped) label per entry, from `top` down.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Swatch)],
    top: i32,
) -> DrawResult<DB> {
    let style = text_style(LEGEND_SIZE).pos(Pos::new(HPos::Left, VPos::Center));
    let (width, _) = area.dim_in_pixel();
    let text_room = width.saturating_sub(LEGEND_SWATCH as u32 + 22);
    let mut y = top;
    for (label, swatch) in entries {
        let (x0, x1) = (6, 6 + LEGEND_SWATCH);
        let mid = (x0 + x1) / 2;
        match *swatch {
            Swatch::Line { colour, band } => {
                if band {
                    area.draw(&Rectangle::new(
                        [(x0, y - 7), (x1, y + 7)],
                        colour.mix(0.2).filled(),
                    ))?;
                }
                area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    colour.stroke_width(3),
                ))?;
            }
            Swatch::Block(colour) => {
                let corners = [(x0 + 4, y - 8), (x1 - 4, y + 8)];
                area.draw(&Rectangle::new(corners, colour.filled()))?;
                area.draw(&Rectangle::new(corners, AXIS.stroke_width(1)))?;
            }
            Swatch::Dot(colour) => {
                area.draw(&Circle::new((mid, y), 4, colour.filled()))?;
            }
            Swatch::LineDot(colour) => {
                area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    colour.stroke_width(2),
                ))?;
                area.draw(&Circle::new((mid, y), 5, colour.filled()))?;
            }
            Swatch::Ring => {
                area.draw(&Circle::new((mid, y), 9, BLACK.stroke_width(2)))?;
            }
        }
        let lines = wrap_text(area, label, &style, text_room, 3)?;
        let count = lines.len() as i32;
        for (k, line) in lines.into_iter().enumerate() {
            let line_y = y + k as i32 * LEGEND_LINE;
            area.draw(&Text::new(line, (x1 + 10, line_y), style.clone()))?;
        }
        y += LEGEND_ROW.max(count * LEGEND_LINE + 9);
    }
    Ok(())
}

/// A plot area and, on its right, a legend area.
pub(super) type PlotAndLegend<DB> = (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>);

/// Plot area and legend area side by side (the legend on the right).
pub(super) fn split_for_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    legend_width: u32,
) -> PlotAndLegend<DB> {
    let (width, _) = area.dim_in_pixel();
    area.split_horizontally(width.saturating_sub(legend_width))
}

/// Under the title, the plot area and, on its right, a legend area wide enough for `entries`.
pub(super) fn plot_and_legend<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    entries: &[(String, Swatch)],
) -> Result<PlotAndLegend<DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let area = titled_area(root, title)?;
    let names: Vec<&str> = entries.iter().map(|(l, _)| l.as_str()).collect();
    Ok(split_for_legend(&area, legend_width(&area, &names)?))
}

/// A chart on two [`Axis`] scales.
pub(super) type XyChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<Axis, Axis>>;

/// The chart of a line or scatter panel, its mesh drawn: the y label area sized for 8 ticks,
/// as many x ticks as fit side by side.
pub(super) fn xy_chart<'a, DB: DrawingBackend>(
    plot_area: &'a DrawingArea<DB, Shift>,
    x: Axis,
    y: Axis,
    x_label: &str,
    y_label: &str,
) -> Result<XyChart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let y_ticks = 8;
    let y_area = y_label_area_width(plot_area, &y, y_ticks)?;
    let plot_width = plot_area.dim_in_pixel().0.saturating_sub(y_area + 30);
    let x_ticks = x_tick_count(plot_area, &x, plot_width)?;
    let mut chart = ChartBuilder::on(plot_area)
        .margin(14)
        .x_label_area_size(64)
        .y_label_area_size(y_area)
        .build_cartesian_2d(x, y)?;
    draw_mesh(&mut chart, x_ticks, y_ticks, x_label, y_label)?;
    Ok(chart)
}

/// Configures and draws the mesh (grid, ticks, tick labels, axis texts).
pub(super) fn draw_mesh<DB: DrawingBackend>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<Axis, Axis>>,
    x_ticks: usize,
    y_ticks: usize,
    x_label: &str,
    y_label: &str,
) -> DrawResult<DB> {
    let mut mesh = chart.configure_mesh();
    mesh.x_labels(x_ticks)
        .y_labels(y_ticks)
        .label_style(text_style(TICK_SIZE))
        .axis_desc_style(text_style(DESC_SIZE))
        .bold_line_style(GRID.stroke_width(1))
        .axis_style(AXIS.stroke_width(1));
    if x_ticks == 0 {
        mesh.disable_x_mesh();
    }
    if !x_label.trim().is_empty() {
        mesh.x_desc(x_label);
    }
    if !y_label.trim().is_empty() {
        mesh.y_desc(y_label);
    }
    mesh.draw()
}
