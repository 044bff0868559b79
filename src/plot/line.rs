//! Line charts: curves with optional bands, a legend on the right.

use super::*;

pub(super) struct LineSeries {
    pub(super) label: String,
    pub(super) colour: RGBColor,
    pub(super) points: Vec<(f64, f64)>,
    /// `(x, y - band, y + band)` per point, if the series has a band.
    pub(super) band: Option<Vec<(f64, f64, f64)>>,
}

pub(super) struct LineFigure<'a> {
    pub(super) chart: &'a LineChart,
    pub(super) series: Vec<LineSeries>,
    /// The colour scale and its title, when the series are coloured by a number.
    pub(super) scale: Option<(ValueScale, String, Vec<f64>)>,
    pub(super) x: Axis,
    pub(super) y: Axis,
}

/// Series with at most this many points get a marker on each point.
pub(super) const MARKER_LIMIT: usize = 25;

impl<'a> LineFigure<'a> {
    pub(super) fn new(chart: &'a LineChart, figure: &str) -> Result<Self, PlotError> {
        Self::with_colours(chart, &LineColours::Labels, figure)
    }

    pub(super) fn with_colours(
        chart: &'a LineChart,
        colours: &LineColours,
        figure: &str,
    ) -> Result<Self, PlotError> {
        if chart.series.is_empty() {
            return Err(empty(figure, "series list"));
        }
        for s in &chart.series {
            let name = |part: &str| format!("series '{}' {part}", s.label);
            if s.x.is_empty() {
                return Err(empty(figure, &format!("series '{}'", s.label)));
            }
            check_len(figure, &name("y"), s.x.len(), s.y.len())?;
            check_values(figure, &name("x"), &s.x, false)?;
            check_values(figure, &name("y"), &s.y, false)?;
            if let Some(band) = &s.band {
                check_len(figure, &name("band"), s.x.len(), band.len())?;
                check_values(figure, &name("band"), band, true)?;
            }
        }
        check_values(figure, "x_marks", &chart.x_marks, false)?;
        let (colours, scale) = match colours {
            LineColours::Labels => {
                let labels: Vec<&str> = chart.series.iter().map(|s| s.label.as_str()).collect();
                (label_colours(&labels), None)
            }
            LineColours::Scale { title, values } => {
                check_len(figure, "colour values", chart.series.len(), values.len())?;
                check_values(figure, "colour values", values, false)?;
                let scale =
                    ValueScale::spanning(values).ok_or_else(|| empty(figure, "colour values"))?;
                let colours = values.iter().map(|&v| scale.colour(v)).collect();
                (colours, Some((scale, title.clone(), values.clone())))
            }
        };
        let series: Vec<LineSeries> = chart
            .series
            .iter()
            .zip(colours)
            .map(|(s, colour)| {
                let keep: Vec<usize> = (0..s.x.len())
                    .filter(|&i| drawable(s.x[i], s.y[i], chart.log_x, chart.log_y))
                    .collect();
                LineSeries {
                    label: s.label.clone(),
                    colour,
                    points: keep.iter().map(|&i| (s.x[i], s.y[i])).collect(),
                    band: s.band.as_ref().map(|b| {
                        keep.iter()
                            .map(|&i| (s.x[i], s.y[i] - b[i], s.y[i] + b[i]))
                            .collect()
                    }),
                }
            })
            .collect();
        if series.iter().all(|s| s.points.is_empty()) {
            let xs: Vec<f64> = chart.series.iter().flat_map(|s| s.x.clone()).collect();
            return Err(no_positive(figure, &xs, chart.log_x));
        }
        let (x_min, x_max) = extent(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let ys = series.iter().flat_map(|s| {
            let band = s.band.iter().flatten().flat_map(|&(_, lo, hi)| [lo, hi]);
            s.points.iter().map(|p| p.1).chain(band)
        });
        let (y_min, y_max) = extent(ys.filter(|&y| !chart.log_y || y > 0.0));
        Ok(Self {
            chart,
            series,
            scale,
            x: Axis::covering(x_min, x_max, chart.log_x, true),
            y: Axis::covering(y_min, y_max, chart.log_y, true),
        })
    }
}

impl Figure for LineFigure<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB> {
        let entries: Vec<(String, Swatch)> = self
            .series
            .iter()
            .map(|s| {
                let swatch = Swatch::Line {
                    colour: s.colour,
                    band: s.band.is_some(),
                };
                (s.label.clone(), swatch)
            })
            .collect();
        let c = self.chart;
        let (plot_area, legend_area) = match &self.scale {
            None => plot_and_legend(root, &c.title, &entries)?,
            Some((scale, title, _)) => {
                let area = titled_area(root, &c.title)?;
                let width = colour_bar_width(&area, *scale, title)?;
                split_for_legend(&area, width)
            }
        };
        let mut chart = xy_chart(&plot_area, self.x, self.y, &c.x_label, &c.y_label)?;
        for &x in &self.chart.x_marks {
            if x >= self.x.lo && x <= self.x.hi {
                chart.draw_series(std::iter::once(PathElement::new(
                    vec![(x, self.y.lo), (x, self.y.hi)],
                    AXIS.mix(0.6).stroke_width(2),
                )))?;
            }
        }
        // Tens of curves (a swept parameter): lighter bands and no markers, or the bands
        // bury each other and the markers hide the lines.
        let crowded = self.series.len() > LEGEND_MAX;
        let band_alpha = if crowded { 0.07 } else { 0.18 };
        for s in &self.series {
            if let Some(band) = &s.band {
                if band.len() >= 2 {
                    let outline: Vec<(f64, f64)> = band
                        .iter()
                        .map(|&(x, _, hi)| (x, hi))
                        .chain(band.iter().rev().map(|&(x, lo, _)| (x, lo)))
                        .collect();
                    chart.draw_series(std::iter::once(Polygon::new(
                        outline,
                        s.colour.mix(band_alpha).filled(),
                    )))?;
                } else if let Some(&(x, lo, hi)) = band.first() {
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(x, lo), (x, hi)],
                        s.colour.mix(0.5).stroke_width(6),
                    )))?;
                }
            }
        }
        for s in &self.series {
            chart.draw_series(std::iter::once(PathElement::new(
                s.points.clone(),
                s.colour.stroke_width(2),
            )))?;
            if s.points.len() <= MARKER_LIMIT && !crowded {
                chart.draw_series(
                    s.points
                        .iter()
                        .map(|&p| Circle::new(p, 4, s.colour.filled())),
                )?;
            }
        }
        match &self.scale {
            None => draw_legend(&legend_area, &entries, 30),
            Some((scale, title, values)) => {
                draw_colour_bar(&legend_area, *scale, title, values, 30).map(|_| ())
            }
        }
    }
}
