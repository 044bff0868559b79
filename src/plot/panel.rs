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
    /// A dot in a ring (a front point not joined to the others).
    Ringed(RGBColor),
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

/// Most entries a legend lists: past this, colours repeat and a reader cannot match them.
pub(super) const LEGEND_MAX: usize = 10;

/// Draws a legend panel: a swatch and a (wrapped) label per entry, from `top` down. Entries
/// that would run past the bottom of the area (or past [`LEGEND_MAX`]) are left out and
/// counted in a last `+N more` line, so the text never overflows or overprints.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Swatch)],
    top: i32,
) -> DrawResult<DB> {
    let style = text_style(LEGEND_SIZE).pos(Pos::new(HPos::Left, VPos::Center));
    let (width, height) = area.dim_in_pixel();
    let text_room = width.saturating_sub(LEGEND_SWATCH as u32 + 22);
    let mut laid_out = Vec::with_capacity(entries.len());
    for (label, swatch) in entries {
        let lines = wrap_text(area, label, &style, text_room, 3)?;
        let row = LEGEND_ROW.max(lines.len() as i32 * LEGEND_LINE + 9);
        laid_out.push((lines, *swatch, row));
    }
    let bottom = height as i32 - LEGEND_ROW / 2;
    let rows_end = |k: usize| top + laid_out[..k].iter().map(|e| e.2).sum::<i32>();
    let mut shown = laid_out.len().min(LEGEND_MAX);
    // Room for the last entry's half row, and for the `+N more` line when some are left out.
    let fits = |k: usize| {
        let more = if k < laid_out.len() { LEGEND_ROW } else { 0 };
        k == 0 || rows_end(k) - laid_out[k - 1].2 / 2 + more <= bottom
    };
    while shown > 0 && !fits(shown) {
        shown -= 1;
    }
    let mut y = top;
    for (lines, swatch, row) in laid_out.iter().take(shown) {
        draw_swatch(area, *swatch, y)?;
        for (k, line) in lines.iter().enumerate() {
            let line_y = y + k as i32 * LEGEND_LINE;
            area.draw(&Text::new(
                line.clone(),
                (6 + LEGEND_SWATCH + 10, line_y),
                style.clone(),
            ))?;
        }
        y += row;
    }
    if shown < laid_out.len() {
        let more = format!("+{} more", laid_out.len() - shown);
        area.draw(&Text::new(more, (6, y), style))?;
    }
    Ok(())
}

/// Draws one legend swatch centred on height `y`.
fn draw_swatch<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    swatch: Swatch,
    y: i32,
) -> DrawResult<DB> {
    let (x0, x1) = (6, 6 + LEGEND_SWATCH);
    let mid = (x0 + x1) / 2;
    match swatch {
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
        Swatch::Ringed(colour) => {
            area.draw(&Circle::new((mid, y), 6, colour.stroke_width(2)))?;
        }
        Swatch::Ring => {
            area.draw(&Circle::new((mid, y), 9, BLACK.stroke_width(2)))?;
        }
    }
    Ok(())
}

/// Width of the colour bar's bar, in pixels.
const COLOUR_BAR_WIDTH: i32 = 18;

/// Width a colour bar over `scale` needs: its bar and tick labels, or its title if wider (at
/// most 30% of the figure; a longer title is wrapped).
pub(super) fn colour_bar_width<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: ValueScale,
    title: &str,
) -> Result<u32, DrawingAreaErrorKind<DB::ErrorType>> {
    let style = text_style(TICK_SIZE);
    let axis = colour_axis(scale);
    let mut widest = 0;
    for tick in axis.ticks(6) {
        widest = widest.max(text_width(area, &axis.format_tick(tick), &style)?);
    }
    let bar = COLOUR_BAR_WIDTH as u32 + widest + 30;
    let title = text_width(area, title, &text_style(LEGEND_SIZE))? + 16;
    Ok(bar.max(title).min(WIDTH * 3 / 10))
}

/// The axis a colour bar labels: the scale's range, no margin (widened around one value).
fn colour_axis(scale: ValueScale) -> Axis {
    if scale.hi > scale.lo {
        Axis {
            lo: scale.lo,
            hi: scale.hi,
            log: false,
        }
    } else {
        Axis::covering(scale.lo, scale.hi, false, true)
    }
}

/// Draws a vertical colour bar from `top` down: the (wrapped) title, the bar with the scale's
/// high end on top, round tick values on its right, and a short mark on its left at each of
/// `marks` (the values present in the data). Returns the bottom of the bar.
pub(super) fn draw_colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: ValueScale,
    title: &str,
    marks: &[f64],
    top: i32,
) -> Result<i32, DrawingAreaErrorKind<DB::ErrorType>> {
    let (width, height) = area.dim_in_pixel();
    let style = text_style(LEGEND_SIZE).pos(Pos::new(HPos::Left, VPos::Center));
    let lines = wrap_text(area, title, &style, width.saturating_sub(12), 3)?;
    let mut y = top;
    for line in lines {
        area.draw(&Text::new(line, (6, y), style.clone()))?;
        y += LEGEND_LINE;
    }
    let (x0, x1) = (14, 14 + COLOUR_BAR_WIDTH);
    let bar_top = y + 4;
    let bar_bottom = (height as i32 - 30).min(bar_top + 320).max(bar_top + 40);
    let steps = 64;
    let span = f64::from(bar_bottom - bar_top);
    let pixel = |f: f64| bar_bottom - (f * span).round() as i32;
    for k in 0..steps {
        let (f0, f1) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
        let colour = viridis((f0 + f1) / 2.0 * SCALE_TOP);
        area.draw(&Rectangle::new(
            [(x0, pixel(f1)), (x1, pixel(f0))],
            colour.filled(),
        ))?;
    }
    area.draw(&Rectangle::new(
        [(x0, bar_top), (x1, bar_bottom)],
        AXIS.stroke_width(1),
    ))?;
    let axis = colour_axis(scale);
    let fraction = |v: f64| {
        if scale.hi > scale.lo {
            scale.position(v) / SCALE_TOP
        } else {
            axis.fraction(v)
        }
    };
    let tick_style = text_style(TICK_SIZE).pos(Pos::new(HPos::Left, VPos::Center));
    for tick in axis.ticks(6) {
        let ty = pixel(fraction(tick));
        area.draw(&PathElement::new(
            vec![(x1, ty), (x1 + 5, ty)],
            AXIS.stroke_width(1),
        ))?;
        area.draw(&Text::new(
            axis.format_tick(tick),
            (x1 + 9, ty),
            tick_style.clone(),
        ))?;
    }
    let mut marked: Vec<i32> = marks
        .iter()
        .filter(|v| v.is_finite())
        .map(|&v| pixel(fraction(v)))
        .collect();
    marked.sort_unstable();
    marked.dedup();
    for my in marked {
        area.draw(&PathElement::new(
            vec![(x0 - 6, my), (x0 - 1, my)],
            AXIS.stroke_width(1),
        ))?;
    }
    Ok(bar_bottom)
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
