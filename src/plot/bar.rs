//! Bar charts: grouped bars with error bars and significance brackets.

use super::*;

/// Gap between groups, in bar widths.
pub(super) const GROUP_GAP: f64 = 0.8;
/// Width of a drawn bar, in bar slots.
pub(super) const BAR_WIDTH: f64 = 0.76;

pub(super) struct BarFigure<'a> {
    pub(super) chart: &'a BarChart,
    /// Centre of each bar (indexed like `chart.bars`) on the x axis.
    pub(super) centres: Vec<f64>,
    pub(super) colours: Vec<RGBColor>,
    /// Group names with the x span of their bars.
    pub(super) groups: Vec<(String, f64, f64)>,
    /// `(i, j, text, height)` of each bracket.
    pub(super) brackets: Vec<(usize, usize, String, f64)>,
    pub(super) x: Axis,
    pub(super) y: Axis,
}

impl<'a> BarFigure<'a> {
    pub(super) fn new(chart: &'a BarChart, figure: &str) -> Result<Self, PlotError> {
        if chart.bars.is_empty() {
            return Err(empty(figure, "bar list"));
        }
        let values: Vec<f64> = chart.bars.iter().map(|b| b.value).collect();
        check_values(figure, "bar value", &values, false)?;
        let errors: Vec<f64> = chart.bars.iter().map(|b| b.error.unwrap_or(0.0)).collect();
        check_values(figure, "bar error", &errors, true)?;
        for (k, (i, j, _)) in chart.annotations.iter().enumerate() {
            let what = format!("annotation {k}");
            check_index(figure, &what, *i, chart.bars.len())?;
            check_index(figure, &what, *j, chart.bars.len())?;
        }

        let mut group_names: Vec<&str> = Vec::new();
        for bar in &chart.bars {
            if !group_names.contains(&bar.group.as_str()) {
                group_names.push(&bar.group);
            }
        }
        let mut centres = vec![0.0; chart.bars.len()];
        let mut groups = Vec::new();
        let mut cursor = 0.3;
        for name in group_names {
            let start = cursor;
            for (i, bar) in chart.bars.iter().enumerate() {
                if bar.group == name {
                    centres[i] = cursor + 0.5;
                    cursor += 1.0;
                }
            }
            groups.push((name.to_string(), start, cursor));
            cursor += GROUP_GAP;
        }
        let x = Axis {
            lo: 0.0,
            hi: cursor - GROUP_GAP + 0.3,
            log: false,
        };

        let tops: Vec<f64> = chart
            .bars
            .iter()
            .map(|b| (b.value + b.error.unwrap_or(0.0)).max(b.value).max(0.0))
            .collect();
        let bottoms = chart
            .bars
            .iter()
            .map(|b| (b.value - b.error.unwrap_or(0.0)).min(0.0));
        let (lowest, _) = extent(bottoms);
        let (_, highest) = extent(tops.iter().copied());
        let span = if highest > lowest {
            highest - lowest
        } else {
            1.0
        };
        // Brackets: narrow ones first, each above the bars it spans and above any bracket
        // already placed that it overlaps.
        let mut order: Vec<usize> = (0..chart.annotations.len()).collect();
        let width_of = |k: usize| {
            let (i, j, _) = &chart.annotations[k];
            (centres[*i] - centres[*j]).abs()
        };
        order.sort_by(|&a, &b| width_of(a).total_cmp(&width_of(b)));
        let mut brackets: Vec<(usize, usize, String, f64)> = Vec::new();
        for k in order {
            let (i, j, text) = &chart.annotations[k];
            let (left, right) = if centres[*i] <= centres[*j] {
                (centres[*i], centres[*j])
            } else {
                (centres[*j], centres[*i])
            };
            let inside = |c: f64| c >= left - 1e-9 && c <= right + 1e-9;
            let mut height = centres
                .iter()
                .zip(&tops)
                .filter(|(c, _)| inside(**c))
                .map(|(_, t)| *t)
                .fold(0.0, f64::max)
                + 0.04 * span;
            for (bi, bj, _, bh) in &brackets {
                let (bl, br) = (
                    centres[*bi].min(centres[*bj]),
                    centres[*bi].max(centres[*bj]),
                );
                if bl <= right + 0.5 && br >= left - 0.5 {
                    height = height.max(bh + 0.09 * span);
                }
            }
            brackets.push((*i, *j, text.clone(), height));
        }
        let bracket_top = brackets
            .iter()
            .map(|b| b.3 + 0.08 * span)
            .fold(highest, f64::max);
        let y = Axis::covering(lowest, bracket_top.max(highest), false, lowest < 0.0);
        let y = Axis {
            lo: if lowest < 0.0 { y.lo } else { 0.0 },
            ..y
        };
        let labels: Vec<&str> = chart.bars.iter().map(|b| b.label.as_str()).collect();
        Ok(Self {
            chart,
            centres,
            colours: label_colours(&labels),
            groups,
            brackets,
            x,
            y,
        })
    }
}

impl Figure for BarFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        // Texts are placed on `root` from the chart's backend coordinates, which are the
        // whole figure's: within a panel, `root` starts elsewhere.
        let (bx, by) = root.get_base_pixel();
        let shift = |(x, y): (i32, i32)| (x - bx, y - by);
        let area = titled_area(root, &self.chart.title)?;
        let y_ticks = 8;
        let y_area = y_label_area_width(&area, &self.y, y_ticks)?;
        let margin = 14;
        // Do the bar labels fit under their bars? If not, a legend names the colours.
        let label_style = text_style(TICK_SIZE);
        let plot_width = area.dim_in_pixel().0.saturating_sub(y_area + 2 * margin);
        let slot = f64::from(plot_width) / (self.x.hi - self.x.lo);
        let mut widest = 0;
        for bar in &self.chart.bars {
            widest = widest.max(text_width(&area, &bar.label, &label_style)?);
        }
        let labels_fit = f64::from(widest + 6) <= slot;
        let mut unique: Vec<(String, RGBColor)> = Vec::new();
        for (bar, colour) in self.chart.bars.iter().zip(&self.colours) {
            if !unique.iter().any(|(l, _)| *l == bar.label) {
                unique.push((bar.label.clone(), *colour));
            }
        }
        let (plot_area, legend_area) = if labels_fit {
            (area.clone(), None)
        } else {
            let names: Vec<&str> = unique.iter().map(|(l, _)| l.as_str()).collect();
            let (p, l) = split_for_legend(&area, legend_width(&area, &names)?);
            (p, Some(l))
        };
        let show_groups = self.groups.len() > 1 || !self.groups[0].0.trim().is_empty();
        let rows = u32::from(labels_fit) + u32::from(show_groups);
        let mut chart = ChartBuilder::on(&plot_area)
            .margin(margin)
            .x_label_area_size(10 + 28 * rows.max(1))
            .y_label_area_size(y_area)
            .build_cartesian_2d(self.x, self.y)?;
        draw_mesh(&mut chart, 0, y_ticks, "", &self.chart.y_label)?;
        if self.y.lo < 0.0 {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(self.x.lo, 0.0), (self.x.hi, 0.0)],
                AXIS.stroke_width(1),
            )))?;
        }
        let half = BAR_WIDTH / 2.0;
        for ((bar, &c), colour) in self.chart.bars.iter().zip(&self.centres).zip(&self.colours) {
            let corners = [(c - half, 0.0), (c + half, bar.value)];
            chart.draw_series([
                Rectangle::new(corners, colour.filled()),
                Rectangle::new(corners, AXIS.stroke_width(1)),
            ])?;
            if let Some(e) = bar.error.filter(|&e| e > 0.0) {
                let (lo, hi) = (bar.value - e, bar.value + e);
                let cap = 0.12;
                chart.draw_series([
                    PathElement::new(vec![(c, lo), (c, hi)], BLACK.stroke_width(2)),
                    PathElement::new(vec![(c - cap, lo), (c + cap, lo)], BLACK.stroke_width(2)),
                    PathElement::new(vec![(c - cap, hi), (c + cap, hi)], BLACK.stroke_width(2)),
                ])?;
            }
        }
        let note_style = text_style(NOTE_SIZE).pos(Pos::new(HPos::Center, VPos::Bottom));
        for (i, j, text, height) in &self.brackets {
            let (a, b) = (self.centres[*i], self.centres[*j]);
            if i != j {
                let drop = 0.025 * (self.y.hi - self.y.lo);
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![
                        (a, height - drop),
                        (a, *height),
                        (b, *height),
                        (b, height - drop),
                    ],
                    BLACK.stroke_width(1),
                )))?;
            }
            let (px, py) = shift(chart.backend_coord(&((a + b) / 2.0, *height)));
            root.draw(&Text::new(text.clone(), (px, py - 3), note_style.clone()))?;
        }
        // Labels under the plot: bar labels (if they fit), then group names.
        let below = shift(chart.backend_coord(&(self.x.lo, self.y.lo))).1 + 8;
        let top_style = label_style.pos(Pos::new(HPos::Center, VPos::Top));
        let mut row_y = below;
        if labels_fit {
            for (bar, &c) in self.chart.bars.iter().zip(&self.centres) {
                let (px, _) = shift(chart.backend_coord(&(c, 0.0)));
                root.draw(&Text::new(
                    bar.label.clone(),
                    (px, row_y),
                    top_style.clone(),
                ))?;
            }
            row_y += 28;
        }
        if show_groups {
            // The largest size at which every group name fits its group (and half of each gap).
            let spans: Vec<(i32, i32)> = self
                .groups
                .iter()
                .map(|(_, start, end)| {
                    let left = shift(chart.backend_coord(&(*start, 0.0))).0;
                    let right = shift(chart.backend_coord(&(*end, 0.0))).0;
                    (left, right)
                })
                .collect();
            let gap = chart.backend_coord(&(GROUP_GAP, 0.0)).0 - chart.backend_coord(&(0.0, 0.0)).0;
            let room = |(left, right): (i32, i32)| (right - left + gap - 4).max(0) as u32;
            let mut size = DESC_SIZE;
            for candidate in [DESC_SIZE, TICK_SIZE, em(13.0)] {
                size = candidate;
                let style = text_style(candidate);
                let mut fits = true;
                for ((name, _, _), span) in self.groups.iter().zip(&spans) {
                    fits &= text_width(root, name, &style)? <= room(*span);
                }
                if fits {
                    break;
                }
            }
            let group_style = text_style(size).pos(Pos::new(HPos::Center, VPos::Top));
            for ((name, _, _), &(left, right)) in self.groups.iter().zip(&spans) {
                let name = fit_text(root, name, &group_style, room((left, right)))?;
                root.draw(&Text::new(
                    name,
                    ((left + right) / 2, row_y),
                    group_style.clone(),
                ))?;
            }
        }
        if let Some(legend_area) = legend_area {
            let entries: Vec<(String, Swatch)> = unique
                .into_iter()
                .map(|(label, colour)| (label, Swatch::Block(colour)))
                .collect();
            draw_legend(&legend_area, &entries, 30)?;
        }
        Ok(())
    }
}

/// Width of one panel of a [`BarPanels`] figure.
const PANEL_WIDTH: u32 = 480;
/// Height of one panel.
const PANEL_HEIGHT: u32 = 420;
/// Height of the band holding the figure's title.
const TITLE_BAND: u32 = 40;

/// Bar charts side by side, a panel each, in a grid of at most three columns.
pub(super) struct PanelsFigure<'a> {
    pub(super) chart: &'a BarPanels,
    pub(super) panels: Vec<BarFigure<'a>>,
    pub(super) columns: u32,
    pub(super) rows: u32,
}

impl<'a> PanelsFigure<'a> {
    pub(super) fn new(chart: &'a BarPanels, figure: &str) -> Result<Self, PlotError> {
        if chart.panels.is_empty() {
            return Err(empty(figure, "panel list"));
        }
        let mut panels = chart
            .panels
            .iter()
            .map(|p| BarFigure::new(p, figure))
            .collect::<Result<Vec<_>, _>>()?;
        // One y axis for every panel: bars of different groups are compared by height across
        // panels, which axes of their own would mislead.
        let lo = panels.iter().map(|p| p.y.lo).fold(f64::INFINITY, f64::min);
        let hi = panels
            .iter()
            .map(|p| p.y.hi)
            .fold(f64::NEG_INFINITY, f64::max);
        for panel in &mut panels {
            panel.y = Axis { lo, hi, log: false };
        }
        let n = panels.len() as u32;
        let columns = n.min(3);
        Ok(Self {
            chart,
            panels,
            columns,
            rows: n.div_ceil(columns),
        })
    }
}

impl Figure for PanelsFigure<'_> {
    fn size(&self) -> (u32, u32) {
        (
            self.columns * PANEL_WIDTH,
            self.rows * PANEL_HEIGHT + TITLE_BAND,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let area = titled_area(root, &self.chart.title)?;
        let cells = area.split_evenly((self.rows as usize, self.columns as usize));
        for (panel, cell) in self.panels.iter().zip(&cells) {
            panel.draw(cell)?;
        }
        Ok(())
    }
}
