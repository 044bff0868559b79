//! Scatter charts: points with a highlighted front and a marked knee.

use super::*;

pub(super) const POINT_COLOUR: RGBColor = RGBColor(150, 150, 150);
pub(super) const FRONT_COLOUR: RGBColor = RGBColor(178, 34, 34);

pub(super) struct ScatterFigure<'a> {
    pub(super) chart: &'a ScatterChart,
    /// Drawable points (positive on log axes) by index into `chart.points`.
    pub(super) shown: Vec<bool>,
    /// Front indices, drawable only, in order of x.
    pub(super) front: Vec<usize>,
    pub(super) x: Axis,
    pub(super) y: Axis,
}

impl<'a> ScatterFigure<'a> {
    pub(super) fn new(chart: &'a ScatterChart, figure: &str) -> Result<Self, PlotError> {
        let n = chart.points.len();
        if n == 0 {
            return Err(empty(figure, "point list"));
        }
        let xs: Vec<f64> = chart.points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = chart.points.iter().map(|p| p.1).collect();
        check_values(figure, "point x", &xs, false)?;
        check_values(figure, "point y", &ys, false)?;
        for &i in &chart.highlighted {
            check_index(figure, "highlighted", i, n)?;
        }
        if let Some(i) = chart.marked {
            check_index(figure, "marked", i, n)?;
        }
        if !chart.point_labels.is_empty() {
            check_len(figure, "point_labels", n, chart.point_labels.len())?;
        }
        let shown: Vec<bool> = chart
            .points
            .iter()
            .map(|&(x, y)| drawable(x, y, chart.log_x, chart.log_y))
            .collect();
        if !shown.contains(&true) {
            return Err(no_positive(figure, &xs, chart.log_x));
        }
        let mut front: Vec<usize> = chart
            .highlighted
            .iter()
            .copied()
            .filter(|&i| shown[i])
            .collect();
        front.sort_by(|&a, &b| {
            let (pa, pb) = (chart.points[a], chart.points[b]);
            pa.0.total_cmp(&pb.0).then(pa.1.total_cmp(&pb.1))
        });
        front.dedup();
        let visible = || {
            chart
                .points
                .iter()
                .zip(&shown)
                .filter(|(_, s)| **s)
                .map(|(p, _)| *p)
        };
        let (x_min, x_max) = extent(visible().map(|p| p.0));
        let (y_min, y_max) = extent(visible().map(|p| p.1));
        Ok(Self {
            chart,
            shown,
            front,
            x: Axis::covering(x_min, x_max, chart.log_x, true),
            y: Axis::covering(y_min, y_max, chart.log_y, true),
        })
    }

    pub(super) fn label(&self, i: usize) -> Option<&str> {
        self.chart
            .point_labels
            .get(i)
            .map(String::as_str)
            .filter(|l| !l.trim().is_empty())
    }
}

/// Pixel rectangle `(x0, y0, x1, y1)`.
pub(super) type Bounds = (i32, i32, i32, i32);

pub(super) fn overlaps(a: Bounds, b: Bounds) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

impl Figure for ScatterFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let mut entries = vec![("all points".to_string(), Swatch::Dot(POINT_COLOUR))];
        if !self.front.is_empty() {
            entries.push(("Pareto front".to_string(), Swatch::LineDot(FRONT_COLOUR)));
        }
        let knee = self.chart.marked.filter(|&i| self.shown[i]);
        if knee.is_some() {
            entries.push(("knee".to_string(), Swatch::Ring));
        }
        let c = self.chart;
        let (plot_area, legend_area) = plot_and_legend(root, &c.title, &entries)?;
        let mut chart = xy_chart(&plot_area, self.x, self.y, &c.x_label, &c.y_label)?;
        let points = &self.chart.points;
        chart.draw_series(
            points
                .iter()
                .zip(&self.shown)
                .filter(|(_, s)| **s)
                .map(|(&p, _)| Circle::new(p, 3, POINT_COLOUR.mix(0.8).filled())),
        )?;
        if !self.front.is_empty() {
            let line: Vec<(f64, f64)> = self.front.iter().map(|&i| points[i]).collect();
            chart.draw_series(std::iter::once(PathElement::new(
                line.clone(),
                FRONT_COLOUR.stroke_width(2),
            )))?;
            chart.draw_series(
                line.iter()
                    .map(|&p| Circle::new(p, 5, FRONT_COLOUR.filled())),
            )?;
        }
        if let Some(i) = knee {
            chart.draw_series(std::iter::once(Circle::new(
                points[i],
                10,
                BLACK.stroke_width(2),
            )))?;
        }

        // Labels: the knee's first, then the front's, each at the spot around its point that
        // stays in the plot, overlaps no earlier label and covers the fewest markers and line.
        let (x0, y1) = chart.backend_coord(&(self.x.lo, self.y.lo));
        let (x1, y0) = chart.backend_coord(&(self.x.hi, self.y.hi));
        let plot_bounds = (x0, y0, x1, y1);
        let mut obstacles: Vec<Bounds> = Vec::new();
        for (p, _) in points.iter().zip(&self.shown).filter(|(_, s)| **s) {
            let (px, py) = chart.backend_coord(p);
            obstacles.push((px - 4, py - 4, px + 4, py + 4));
        }
        let front_pixels: Vec<(i32, i32)> = self
            .front
            .iter()
            .map(|&i| chart.backend_coord(&points[i]))
            .collect();
        for pair in front_pixels.windows(2) {
            let ((ax, ay), (bx, by)) = (pair[0], pair[1]);
            let steps = ((bx - ax).abs().max((by - ay).abs()) / 4).max(1);
            for k in 0..=steps {
                let x = ax + (bx - ax) * k / steps;
                let y = ay + (by - ay) * k / steps;
                obstacles.push((x - 1, y - 1, x + 1, y + 1));
            }
        }
        for &(px, py) in &front_pixels {
            obstacles.push((px - 6, py - 6, px + 6, py + 6));
        }
        let mut wanted: Vec<(usize, String, f64)> = Vec::new();
        if let Some(i) = knee {
            let text = match self.label(i) {
                Some(l) => format!("knee ({l})"),
                None => "knee".to_string(),
            };
            wanted.push((i, text, LEGEND_SIZE));
        }
        for &i in &self.front {
            if Some(i) != knee
                && let Some(l) = self.label(i)
            {
                wanted.push((i, l.to_string(), POINT_LABEL_SIZE));
            }
        }
        let (fig_w, fig_h) = root.dim_in_pixel();
        let figure_bounds = (0, 0, fig_w as i32, fig_h as i32);
        let mut placed: Vec<Bounds> = Vec::new();
        for (i, text, size) in wanted {
            let style = text_style(size);
            let (w, h) = root.estimate_text_size(&text, &style)?;
            let (w, h) = (w as i32, h as i32);
            let (px, py) = chart.backend_coord(&points[i]);
            let gap = if Some(i) == knee { 13 } else { 7 };
            let spots = [
                (px + gap, py - gap - h),
                (px - gap - w, py - gap - h),
                (px + gap, py + gap),
                (px - gap - w, py + gap),
                (px - w / 2, py - gap - h),
                (px - w / 2, py + gap),
                (px + gap + 2, py - h / 2),
                (px - gap - 2 - w, py - h / 2),
            ]
            .map(|(x, y)| (x, y, x + w, y + h));
            let own = (px - 1, py - 1, px + 1, py + 1);
            let free = |b: &Bounds, within: Bounds| {
                b.0 >= within.0
                    && b.2 <= within.2
                    && b.1 >= within.1
                    && b.3 <= within.3
                    && placed.iter().all(|p| !overlaps(*b, *p))
            };
            let cost = |b: &Bounds| {
                obstacles
                    .iter()
                    .filter(|o| !overlaps(**o, own) && overlaps(*b, **o))
                    .count()
            };
            let best = |within: Bounds| {
                spots
                    .iter()
                    .filter(|b| free(b, within))
                    .min_by_key(|b| cost(b))
                    .copied()
            };
            // The knee is always labelled, if need be outside the plot.
            let spot = match best(plot_bounds) {
                Some(b) => Some(b),
                None if Some(i) == knee => best(figure_bounds).or(Some(spots[0])),
                None => None,
            };
            if let Some(b) = spot {
                placed.push(b);
                root.draw(&Text::new(text, (b.0, b.1), style))?;
            }
        }
        draw_legend(&legend_area, &entries, 30)
    }
}
