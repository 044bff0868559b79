//! Scatter charts: points with a highlighted front and a marked knee.

use super::place::{Bounds, Wanted, marker_box, place_labels, polyline_boxes};
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

/// Points with a front (and a marked point), validated: which can be drawn, the front's
/// drawable points in order of x, and axes covering the drawable points. `name` turns a part
/// (`points`, `x`, `y`, `front`, `marked`, `labels`) into the name errors give it.
pub(super) struct PointsWithFront {
    pub(super) shown: Vec<bool>,
    pub(super) front: Vec<usize>,
    pub(super) x: Axis,
    pub(super) y: Axis,
}

impl PointsWithFront {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        figure: &str,
        name: impl Fn(&str) -> String,
        points: &[(f64, f64)],
        front: &[usize],
        marked: Option<usize>,
        labels: usize,
        log_x: bool,
        log_y: bool,
    ) -> Result<Self, PlotError> {
        let n = points.len();
        if n == 0 {
            return Err(empty(figure, &name("points")));
        }
        let xs: Vec<f64> = points.iter().map(|p| p.0).collect();
        let ys: Vec<f64> = points.iter().map(|p| p.1).collect();
        check_values(figure, &name("x"), &xs, false)?;
        check_values(figure, &name("y"), &ys, false)?;
        for &i in front {
            check_index(figure, &name("front"), i, n)?;
        }
        if let Some(i) = marked {
            check_index(figure, &name("marked"), i, n)?;
        }
        if labels > 0 {
            check_len(figure, &name("labels"), n, labels)?;
        }
        let shown: Vec<bool> = points
            .iter()
            .map(|&(x, y)| drawable(x, y, log_x, log_y))
            .collect();
        if !shown.contains(&true) {
            return Err(no_positive(figure, &xs, log_x));
        }
        let mut front: Vec<usize> = front.iter().copied().filter(|&i| shown[i]).collect();
        front.sort_by(|&a, &b| {
            let (pa, pb) = (points[a], points[b]);
            pa.0.total_cmp(&pb.0).then(pa.1.total_cmp(&pb.1))
        });
        front.dedup();
        let visible = || {
            points
                .iter()
                .zip(&shown)
                .filter(|(_, s)| **s)
                .map(|(p, _)| *p)
        };
        let (x_min, x_max) = extent(visible().map(|p| p.0));
        let (y_min, y_max) = extent(visible().map(|p| p.1));
        Ok(Self {
            shown,
            front,
            x: Axis::covering(x_min, x_max, log_x, true),
            y: Axis::covering(y_min, y_max, log_y, true),
        })
    }
}

impl<'a> ScatterFigure<'a> {
    pub(super) fn new(chart: &'a ScatterChart, figure: &str) -> Result<Self, PlotError> {
        let name = |part: &str| {
            match part {
                "points" => "point list",
                "x" => "point x",
                "y" => "point y",
                "front" => "highlighted",
                "labels" => "point_labels",
                other => other,
            }
            .to_owned()
        };
        let set = PointsWithFront::new(
            figure,
            name,
            &chart.points,
            &chart.highlighted,
            chart.marked,
            chart.point_labels.len(),
            chart.log_x,
            chart.log_y,
        )?;
        Ok(Self {
            chart,
            shown: set.shown,
            front: set.front,
            x: set.x,
            y: set.y,
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

        // Labels: the knee's first, then the front's, each where it stays in the plot and
        // covers no marker and no earlier label (a label with no such spot is left out).
        let (rx, ry) = root.get_base_pixel();
        let pixel = |p: &(f64, f64)| {
            let (x, y) = chart.backend_coord(p);
            (x - rx, y - ry)
        };
        let (x0, y1) = pixel(&(self.x.lo, self.y.lo));
        let (x1, y0) = pixel(&(self.x.hi, self.y.hi));
        let mut obstacles: Vec<Bounds> = points
            .iter()
            .zip(&self.shown)
            .filter(|(_, s)| **s)
            .map(|(p, _)| marker_box(pixel(p), 4))
            .collect();
        let front_pixels: Vec<(i32, i32)> = self.front.iter().map(|&i| pixel(&points[i])).collect();
        obstacles.extend(front_pixels.iter().map(|&p| marker_box(p, 6)));
        if let Some(i) = knee {
            obstacles.push(marker_box(pixel(&points[i]), 11));
        }
        let soft = polyline_boxes(&front_pixels, 1);
        let mut texts = Vec::new();
        let mut wanted = Vec::new();
        let mut want = |i: usize, text: String, size: f64, gap: i32| {
            let style = text_style(size);
            let (w, h) = root.estimate_text_size(&text, &style)?;
            wanted.push(Wanted {
                anchor: pixel(&points[i]),
                gap,
                size: (w as i32, h as i32),
            });
            texts.push((text, style));
            Ok::<_, DrawingAreaErrorKind<DB::ErrorType>>(())
        };
        if let Some(i) = knee {
            let text = match self.label(i) {
                Some(l) => format!("knee ({l})"),
                None => "knee".to_string(),
            };
            want(i, text, LEGEND_SIZE, 13)?;
        }
        for &i in &self.front {
            if Some(i) != knee
                && let Some(l) = self.label(i)
            {
                want(i, l.to_string(), POINT_LABEL_SIZE, 7)?;
            }
        }
        let spots = place_labels(&wanted, &obstacles, &soft, (x0, y0, x1, y1));
        for ((text, style), spot) in texts.into_iter().zip(spots) {
            if let Some(b) = spot {
                root.draw(&Text::new(text, (b.0, b.1), style))?;
            }
        }
        draw_legend(&legend_area, &entries, 30)
    }
}
