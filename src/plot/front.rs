//! Pareto-front figures: one panel per group of configurations, points coloured by a swept
//! number on a shared colour scale, each panel's front joined and labelled without overlap,
//! its knee ringed.

use std::cell::RefCell;

use super::place::{Bounds, Wanted, marker_box, place_labels, polyline_boxes};
use super::*;

/// Ink of the front's line and of the rings around its points.
const FRONT_INK: RGBColor = RGBColor(20, 20, 20);
/// Points without a colour value (or without a colour scale).
const NO_VALUE: RGBColor = RGBColor(150, 150, 150);
/// Radii of a point, of the ring around a front point and of the knee's ring.
const POINT_RADIUS: i32 = 4;
const FRONT_RADIUS: i32 = 6;
const KNEE_RADIUS: i32 = 11;
/// Size of one panel when there are several.
const PANEL_WIDTH: u32 = 520;
const PANEL_HEIGHT: u32 = 420;
/// Height of the figure title band.
const TITLE_BAND: u32 = 44;

/// Where a panel's markers and labels landed (kept for tests of the placement).
#[derive(Debug, Clone, Default)]
pub(super) struct PanelLayout {
    /// Every point's marker box (front points with their ring, the knee with its ring).
    pub(super) markers: Vec<Bounds>,
    /// The labels drawn: the point's index and the label's box.
    pub(super) labels: Vec<(usize, Bounds)>,
    /// Front points whose label found no free spot.
    pub(super) dropped: Vec<usize>,
}

pub(super) struct PanelData<'a> {
    pub(super) panel: &'a FrontPanel,
    /// Drawable points (positive on log axes).
    pub(super) shown: Vec<bool>,
    /// Front indices, drawable only, in order of x.
    pub(super) front: Vec<usize>,
    pub(super) x: Axis,
    pub(super) y: Axis,
}

pub(super) struct FrontFigure<'a> {
    pub(super) chart: &'a FrontChart,
    pub(super) panels: Vec<PanelData<'a>>,
    /// The colour scale over every panel's values, when the chart has one.
    pub(super) scale: Option<ValueScale>,
    pub(super) columns: u32,
    pub(super) rows: u32,
    /// Filled in by `draw`, one per panel.
    pub(super) layout: RefCell<Vec<PanelLayout>>,
}

impl<'a> FrontFigure<'a> {
    pub(super) fn new(chart: &'a FrontChart, figure: &str) -> Result<Self, PlotError> {
        if chart.panels.is_empty() {
            return Err(empty(figure, "panel list"));
        }
        let mut panels = Vec::with_capacity(chart.panels.len());
        for (k, panel) in chart.panels.iter().enumerate() {
            let what = |part: &str| format!("panel {k} {part}");
            if chart.colour.is_some() {
                let (n, found) = (panel.points.len(), panel.colour_values.len());
                check_len(figure, &what("colour values"), n, found)?;
            }
            let set = PointsWithFront::new(
                figure,
                what,
                &panel.points,
                &panel.front,
                panel.knee,
                panel.labels.len(),
                chart.log_x,
                chart.log_y,
            )?;
            panels.push(PanelData {
                panel,
                shown: set.shown,
                front: set.front,
                x: set.x,
                y: set.y,
            });
        }
        let scale = chart.colour.as_ref().and_then(|_| {
            let all: Vec<f64> = chart
                .panels
                .iter()
                .flat_map(|p| p.colour_values.iter().copied())
                .collect();
            ValueScale::spanning(&all)
        });
        let n = panels.len() as u32;
        let columns = match n {
            1..=3 => n,
            _ => (f64::from(n).sqrt().ceil()) as u32,
        };
        Ok(Self {
            chart,
            panels,
            scale,
            columns,
            rows: n.div_ceil(columns),
            layout: RefCell::new(Vec::new()),
        })
    }

    /// The legend's entries: the front and the knee, when some panel has them.
    fn entries(&self) -> Vec<(String, Swatch)> {
        let mut entries = Vec::new();
        if self.panels.iter().any(|p| !p.front.is_empty()) {
            let swatch = if self.chart.join_front {
                Swatch::LineDot(FRONT_INK)
            } else {
                Swatch::Ringed(FRONT_INK)
            };
            entries.push(("Pareto front".to_owned(), swatch));
        }
        if self.panels.iter().any(|p| p.panel.knee.is_some()) {
            entries.push(("knee".to_owned(), Swatch::Ring));
        }
        entries
    }

    fn point_colour(&self, panel: &FrontPanel, i: usize) -> RGBColor {
        match (self.scale, panel.colour_values.get(i)) {
            (Some(scale), Some(&v)) if v.is_finite() => scale.colour(v),
            _ => NO_VALUE,
        }
    }

    /// Draws one panel and returns where its markers and labels went.
    fn draw_panel<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        data: &PanelData<'_>,
        root: &DrawingArea<DB, Shift>,
    ) -> Result<PanelLayout, DrawingAreaErrorKind<DB::ErrorType>> {
        let c = self.chart;
        let panel = data.panel;
        let area = if panel.title.trim().is_empty() {
            area.clone()
        } else {
            let (width, _) = area.dim_in_pixel();
            let style = text_style(DESC_SIZE);
            let title = fit_text(area, &panel.title, &style, width.saturating_sub(20))?;
            area.titled(&title, style)?
        };
        let mut chart = xy_chart(&area, data.x, data.y, &c.x_label, &c.y_label)?;
        let points = &panel.points;
        let visible: Vec<usize> = (0..points.len()).filter(|&i| data.shown[i]).collect();
        chart.draw_series(visible.iter().map(|&i| {
            Circle::new(
                points[i],
                POINT_RADIUS as u32,
                self.point_colour(panel, i).mix(0.9).filled(),
            )
        }))?;
        if c.join_front && !data.front.is_empty() {
            let line: Vec<(f64, f64)> = data.front.iter().map(|&i| points[i]).collect();
            chart.draw_series(std::iter::once(PathElement::new(
                line,
                FRONT_INK.stroke_width(2),
            )))?;
        }
        for &i in &data.front {
            chart.draw_series([
                Circle::new(
                    points[i],
                    FRONT_RADIUS as u32,
                    self.point_colour(panel, i).filled(),
                ),
                Circle::new(points[i], FRONT_RADIUS as u32, FRONT_INK.stroke_width(2)),
            ])?;
        }
        let knee = panel.knee.filter(|&i| data.shown[i]);
        if let Some(i) = knee {
            chart.draw_series(std::iter::once(Circle::new(
                points[i],
                KNEE_RADIUS as u32,
                FRONT_INK.stroke_width(2),
            )))?;
        }

        // Labels are drawn on the root: backend coordinates less the root's origin.
        let (rx, ry) = root.get_base_pixel();
        let on_root = |(x, y): (i32, i32)| (x - rx, y - ry);
        let pixel = |i: usize| on_root(chart.backend_coord(&points[i]));
        let (x0, y1) = on_root(chart.backend_coord(&(data.x.lo, data.y.lo)));
        let (x1, y0) = on_root(chart.backend_coord(&(data.x.hi, data.y.hi)));
        let within = (x0, y0, x1, y1);
        let mut layout = PanelLayout::default();
        for &i in &visible {
            let radius = if Some(i) == knee {
                KNEE_RADIUS
            } else if data.front.contains(&i) {
                FRONT_RADIUS
            } else {
                POINT_RADIUS
            };
            layout.markers.push(marker_box(pixel(i), radius + 1));
        }
        let soft = if c.join_front {
            let front_pixels: Vec<(i32, i32)> = data.front.iter().map(|&i| pixel(i)).collect();
            polyline_boxes(&front_pixels, 1)
        } else {
            Vec::new()
        };
        // The knee's label first, then the others in order of x.
        let mut order: Vec<usize> = knee.into_iter().collect();
        order.extend(data.front.iter().copied().filter(|&i| Some(i) != knee));
        let mut texts = Vec::new();
        let mut wanted = Vec::new();
        for i in order {
            let label = panel.labels.get(i).map(|l| l.trim()).unwrap_or_default();
            let (text, size, gap) = match (Some(i) == knee, label.is_empty()) {
                (true, true) => ("knee".to_owned(), LEGEND_SIZE, KNEE_RADIUS + 3),
                (true, false) => (format!("knee ({label})"), LEGEND_SIZE, KNEE_RADIUS + 3),
                (false, true) => continue,
                (false, false) => (label.to_owned(), POINT_LABEL_SIZE, FRONT_RADIUS + 3),
            };
            let style = text_style(size);
            let (w, h) = root.estimate_text_size(&text, &style)?;
            wanted.push(Wanted {
                anchor: pixel(i),
                gap,
                size: (w as i32, h as i32),
            });
            texts.push((i, text, style));
        }
        let spots = place_labels(&wanted, &layout.markers, &soft, within);
        for ((i, text, style), spot) in texts.into_iter().zip(spots) {
            match spot {
                Some(b) => {
                    root.draw(&Text::new(text, (b.0, b.1), style))?;
                    layout.labels.push((i, b));
                }
                None => layout.dropped.push(i),
            }
        }
        Ok(layout)
    }
}

impl Figure for FrontFigure<'_> {
    fn size(&self) -> (u32, u32) {
        if self.panels.len() == 1 {
            return (WIDTH, HEIGHT);
        }
        let legend = 210;
        (
            self.columns * PANEL_WIDTH + legend,
            self.rows * PANEL_HEIGHT + TITLE_BAND,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let entries = self.entries();
        let area = titled_area(root, &self.chart.title)?;
        let mut width = {
            let names: Vec<&str> = entries.iter().map(|(l, _)| l.as_str()).collect();
            legend_width(&area, &names)?
        };
        if let (Some(scale), Some(title)) = (self.scale, &self.chart.colour) {
            width = width.max(colour_bar_width(&area, scale, title)?);
        }
        let (plots, legend_area) = split_for_legend(&area, width);
        let cells = plots.split_evenly((self.rows as usize, self.columns as usize));
        let mut layouts = Vec::with_capacity(self.panels.len());
        for (data, cell) in self.panels.iter().zip(&cells) {
            layouts.push(self.draw_panel(cell, data, root)?);
        }
        draw_legend(&legend_area, &entries, 30)?;
        if let (Some(scale), Some(title)) = (self.scale, &self.chart.colour) {
            let top = 30 + LEGEND_ROW * entries.len() as i32 + 12;
            let marks: Vec<f64> = self
                .chart
                .panels
                .iter()
                .flat_map(|p| p.colour_values.iter().copied())
                .collect();
            draw_colour_bar(&legend_area, scale, title, &marks, top)?;
        }
        *self.layout.borrow_mut() = layouts;
        Ok(())
    }
}
