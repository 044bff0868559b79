use super::place::Bounds;
use super::*;

/// A fresh, empty folder under the system temp dir, unique to this process and test.
fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mbmf-plot-{}-{test}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

fn assert_figure_files(paths: &[PathBuf], texts: &[&str]) {
    assert_eq!(paths.len(), 2);
    let svg = fs::read_to_string(&paths[0]).unwrap();
    assert!(paths[0].extension().is_some_and(|e| e == "svg"));
    assert!(
        svg.starts_with("<svg"),
        "not an SVG: {}",
        &svg[..40.min(svg.len())]
    );
    for text in texts {
        assert!(svg.contains(text), "SVG lacks '{text}'");
    }
    let png = fs::read(&paths[1]).unwrap();
    assert!(png.len() > 1000, "PNG has only {} bytes", png.len());
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    let dir = paths[0].parent().unwrap();
    for entry in fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name();
        assert!(
            !name.to_string_lossy().contains(".tmp."),
            "temporary file {name:?} left behind"
        );
    }
}

fn series(label: &str, x: Vec<f64>, y: Vec<f64>) -> Series {
    Series {
        label: label.to_string(),
        x,
        y,
        band: None,
    }
}

fn reward_chart() -> LineChart {
    let x: Vec<f64> = (0..=100).map(|i| f64::from(i) * 100.0).collect();
    let make = |label: &str, rate: f64| {
        let y: Vec<f64> = x
            .iter()
            .map(|t| rate * t * (1.0 - (-t / 3000.0).exp()))
            .collect();
        let band = y.iter().map(|v| 0.05 * v + 1.0).collect();
        Series {
            band: Some(band),
            ..series(label, x.clone(), y)
        }
    };
    LineChart {
        title: "Cumulative reward, task 1".to_string(),
        x_label: "step".to_string(),
        y_label: "cumulative reward".to_string(),
        series: vec![make("MF", 0.05), make("MB", 0.03), make("EC", 0.045)],
        log_x: false,
        log_y: false,
        x_marks: vec![5000.0],
    }
}

fn bars() -> BarChart {
    let bar = |label: &str, group: &str, value: f64| Bar {
        label: label.to_string(),
        value,
        error: Some(value * 0.1),
        group: group.to_string(),
    };
    BarChart {
        title: "Total reward by interaction".to_string(),
        y_label: "total reward".to_string(),
        bars: vec![
            bar("MF", "none", 300.0),
            bar("MB", "none", 250.0),
            bar("MF", "takeover", 420.0),
            bar("MB", "takeover", 330.0),
        ],
        annotations: vec![(0, 1, "***".to_string()), (1, 3, "n.s.".to_string())],
    }
}

fn front() -> ScatterChart {
    let points: Vec<(f64, f64)> = (0..20)
        .map(|i| {
            let c = f64::from(i);
            (
                1000.0 + c * 500.0,
                200.0 + 30.0 * c.sqrt() - (c % 3.0) * 20.0,
            )
        })
        .collect();
    ScatterChart {
        title: "Reward against cost".to_string(),
        x_label: "total cost".to_string(),
        y_label: "total reward".to_string(),
        point_labels: (0..20).map(|i| format!("κ={i}")).collect(),
        points,
        highlighted: vec![0, 3, 6, 9, 12, 15, 18],
        marked: Some(9),
        log_x: false,
        log_y: false,
    }
}

#[test]
fn a_line_chart_writes_an_svg_and_a_png_with_its_title_and_labels() {
    let dir = temp_dir("line");
    let paths = line_chart(&reward_chart(), &dir.join("reward")).unwrap();
    assert_eq!(paths, vec![dir.join("reward.svg"), dir.join("reward.png")]);
    assert_figure_files(
        &paths,
        &["Cumulative reward, task 1", "MF", "MB", "EC", "step"],
    );
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_bar_chart_writes_both_files_with_labels_groups_and_marks() {
    let dir = temp_dir("bar");
    let paths = bar_chart(&bars(), &dir.join("bars")).unwrap();
    assert_figure_files(
        &paths,
        &[
            "Total reward by interaction",
            "MF",
            "MB",
            "takeover",
            "***",
            "n.s.",
        ],
    );
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_scatter_chart_writes_both_files_with_front_and_knee_labels() {
    let dir = temp_dir("scatter");
    let paths = scatter_chart(&front(), &dir.join("pareto")).unwrap();
    assert_figure_files(
        &paths,
        &["Reward against cost", "Pareto front", "knee (κ=9)"],
    );
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_dotted_file_name_keeps_its_dots_and_missing_folders_are_created() {
    let dir = temp_dir("dotted");
    let base = dir.join("sub").join("kappa_0.5");
    let paths = line_chart(&reward_chart(), &base).unwrap();
    assert_eq!(paths[0], dir.join("sub").join("kappa_0.5.svg"));
    assert!(paths[1].exists());
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_single_point_is_drawn_in_every_chart_kind() {
    let dir = temp_dir("single");
    let line = LineChart {
        series: vec![Series {
            band: Some(vec![0.5]),
            ..series("rnd", vec![3.0], vec![7.0])
        }],
        ..reward_chart()
    };
    assert_figure_files(&line_chart(&line, &dir.join("line")).unwrap(), &["rnd"]);
    let bar = BarChart {
        bars: vec![Bar {
            label: "EC".to_string(),
            value: 0.0,
            error: None,
            group: String::new(),
        }],
        annotations: vec![(0, 0, "*".to_string())],
        ..bars()
    };
    assert_figure_files(&bar_chart(&bar, &dir.join("bar")).unwrap(), &["EC"]);
    let scatter = ScatterChart {
        points: vec![(1.0, 1.0)],
        highlighted: vec![0],
        marked: Some(0),
        point_labels: vec![],
        ..front()
    };
    assert_figure_files(
        &scatter_chart(&scatter, &dir.join("scatter")).unwrap(),
        &["knee"],
    );
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn log_axes_leave_out_non_positive_values() {
    let dir = temp_dir("log");
    let chart = LineChart {
        series: vec![series(
            "MB",
            vec![0.0, 1.0, 10.0, 100.0],
            vec![-1.0, 5.0, 50.0, 5e6],
        )],
        log_x: true,
        log_y: true,
        ..reward_chart()
    };
    assert_figure_files(&line_chart(&chart, &dir.join("log")).unwrap(), &["MB"]);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_log_axis_without_positive_values_is_an_error() {
    let dir = temp_dir("log-error");
    let chart = LineChart {
        series: vec![series("MB", vec![1.0, 2.0], vec![0.0, -3.0])],
        log_y: true,
        ..reward_chart()
    };
    let err = line_chart(&chart, &dir.join("x")).unwrap_err();
    assert!(
        matches!(err, PlotError::NoPositiveValues { axis: "y", .. }),
        "{err}"
    );
    let scatter = ScatterChart {
        points: vec![(-1.0, 1.0)],
        highlighted: vec![],
        marked: None,
        point_labels: vec![],
        log_x: true,
        ..front()
    };
    let err = scatter_chart(&scatter, &dir.join("y")).unwrap_err();
    assert!(
        matches!(err, PlotError::NoPositiveValues { axis: "x", .. }),
        "{err}"
    );
    assert_eq!(
        fs::read_dir(&dir).unwrap().count(),
        0,
        "no file for a failed figure"
    );
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn empty_inputs_are_errors() {
    let dir = temp_dir("empty");
    let no_series = LineChart {
        series: vec![],
        ..reward_chart()
    };
    let err = line_chart(&no_series, &dir.join("a")).unwrap_err();
    assert!(matches!(err, PlotError::Empty { .. }), "{err}");
    let empty_series = LineChart {
        series: vec![series("MF", vec![], vec![])],
        ..reward_chart()
    };
    let err = line_chart(&empty_series, &dir.join("b")).unwrap_err();
    assert!(err.to_string().contains("series 'MF'"), "{err}");
    let no_bars = BarChart {
        bars: vec![],
        ..bars()
    };
    assert!(matches!(
        bar_chart(&no_bars, &dir.join("c")),
        Err(PlotError::Empty { .. })
    ));
    let no_points = ScatterChart {
        points: vec![],
        ..front()
    };
    assert!(matches!(
        scatter_chart(&no_points, &dir.join("d")),
        Err(PlotError::Empty { .. })
    ));
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn nan_and_infinite_values_are_errors_naming_the_value() {
    let dir = temp_dir("nan");
    let chart = LineChart {
        series: vec![series("EC", vec![1.0, 2.0], vec![1.0, f64::NAN])],
        ..reward_chart()
    };
    let err = line_chart(&chart, &dir.join("a")).unwrap_err();
    assert!(
        matches!(&err, PlotError::InvalidValue { index: 1, what, .. } if what == "series 'EC' y"),
        "{err}"
    );
    let chart = LineChart {
        x_marks: vec![f64::NAN],
        ..reward_chart()
    };
    let err = line_chart(&chart, &dir.join("marks")).unwrap_err();
    assert!(
        matches!(&err, PlotError::InvalidValue { what, .. } if what == "x_marks"),
        "{err}"
    );
    let mut bar = bars();
    bar.bars[2].error = Some(f64::INFINITY);
    let err = bar_chart(&bar, &dir.join("b")).unwrap_err();
    assert!(
        matches!(err, PlotError::InvalidValue { index: 2, .. }),
        "{err}"
    );
    let mut scatter = front();
    scatter.points[4].0 = f64::NAN;
    let err = scatter_chart(&scatter, &dir.join("c")).unwrap_err();
    assert!(
        matches!(err, PlotError::InvalidValue { index: 4, .. }),
        "{err}"
    );
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn mismatched_lengths_bad_indices_and_negative_bands_are_errors() {
    let dir = temp_dir("shape");
    let chart = LineChart {
        series: vec![series("MF", vec![1.0, 2.0], vec![1.0])],
        ..reward_chart()
    };
    let err = line_chart(&chart, &dir.join("a")).unwrap_err();
    assert!(matches!(
        err,
        PlotError::LengthMismatch {
            expected: 2,
            found: 1,
            ..
        }
    ));
    let chart = LineChart {
        series: vec![Series {
            band: Some(vec![1.0, -1.0]),
            ..series("MF", vec![1.0, 2.0], vec![1.0, 2.0])
        }],
        ..reward_chart()
    };
    let err = line_chart(&chart, &dir.join("b")).unwrap_err();
    assert!(err.to_string().contains(">= 0"), "{err}");
    let mut bar = bars();
    bar.annotations.push((0, 9, "*".to_string()));
    let err = bar_chart(&bar, &dir.join("c")).unwrap_err();
    assert!(matches!(
        err,
        PlotError::IndexOutOfRange {
            index: 9,
            len: 4,
            ..
        }
    ));
    let scatter = ScatterChart {
        point_labels: vec!["a".to_string()],
        ..front()
    };
    let err = scatter_chart(&scatter, &dir.join("d")).unwrap_err();
    assert!(matches!(err, PlotError::LengthMismatch { .. }), "{err}");
    let scatter = ScatterChart {
        marked: Some(20),
        ..front()
    };
    let err = scatter_chart(&scatter, &dir.join("e")).unwrap_err();
    assert!(matches!(err, PlotError::IndexOutOfRange { .. }), "{err}");
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn controllers_keep_their_colour_whatever_the_other_series() {
    let a = label_colours(&["MF", "MB", "other"]);
    let b = label_colours(&["mb takeover", "mf", "RND", "ec"]);
    assert_eq!(a[0], b[1]);
    assert_eq!(a[1], b[0]);
    assert_eq!(label_colours(&["x", "y"])[0], label_colours(&["z", "x"])[1]);
    let many: Vec<String> = (0..8).map(|i| format!("label {i}")).collect();
    let colours = label_colours(&many);
    for (i, c) in colours.iter().enumerate() {
        assert!(!colours[..i].contains(c), "colour repeated within a figure");
    }
}

#[test]
fn labels_naming_one_controller_get_distinct_shades_with_the_bare_name_first() {
    let colours = label_colours(&["EC, takeover", "EC", "ec congratulation", "EC"]);
    let ec = FIXED_COLOURS[3].1;
    assert_eq!(colours[1], ec);
    assert_eq!(colours[3], ec);
    assert_ne!(colours[0], ec);
    assert_ne!(colours[2], ec);
    assert_ne!(colours[0], colours[2]);
}

#[test]
fn extreme_values_draw_without_panicking() {
    let dir = temp_dir("extreme");
    let chart = LineChart {
        series: vec![series("MF", vec![-1e300, 1e300], vec![1e-300, 1e300])],
        log_y: true,
        ..reward_chart()
    };
    assert!(line_chart(&chart, &dir.join("huge")).is_ok());
    assert!(log_ticks(1e-300, f64::INFINITY, 8).is_empty());
    assert!(linear_ticks(f64::NEG_INFINITY, 1.0, 8).is_empty());
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn text_is_measured_with_the_embedded_font() {
    let font = font().unwrap();
    let (_, narrow) = text::layout_glyphs(font, "iii", em(16.0));
    let (_, wide) = text::layout_glyphs(font, "WWW", em(16.0));
    assert!(wide > 2.0 * narrow, "WWW {wide} px, iii {narrow} px");
    // DejaVu Sans "M" advances 0.863 em.
    let (_, m) = text::layout_glyphs(font, "M", em(100.0));
    assert!((m - 86.3).abs() < 0.5, "M is {m} px wide at 100 px per em");
}

#[test]
fn tick_values_are_round_and_print_short() {
    assert_eq!(
        linear_ticks(0.0, 10.0, 6),
        vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    );
    assert_eq!(log_ticks(1.0, 1000.0, 8), vec![1.0, 10.0, 100.0, 1000.0]);
    assert_eq!(log_ticks(1.0, 10.0, 8), vec![1.0, 2.0, 5.0, 10.0]);
    assert!(log_ticks(1e-3, 1e9, 7).len() <= 7);
    assert_eq!(format_number(0.1 + 0.2), "0.3");
    assert_eq!(format_number(2500.0), "2500");
    assert_eq!(format_number(1e8), "1e8");
    assert_eq!(format_number(-0.0), "0");
    assert_eq!(format_number(2.5e-5), "2.5e-5");
    let costs = Axis {
        lo: 1.0,
        hi: 1e8,
        log: true,
    };
    assert_eq!(costs.format_tick(100.0), "1e2", "one axis, one notation");
}

#[test]
fn the_colour_scale_runs_from_viridis_dark_end_through_its_middle() {
    // Viridis' published ends and middle (matplotlib: #440154, #21918c, #fde725).
    assert_eq!(viridis(0.0), RGBColor(0x44, 0x01, 0x54));
    assert_eq!(viridis(0.5), RGBColor(0x21, 0x91, 0x8c));
    assert_eq!(viridis(1.0), RGBColor(0xfd, 0xe7, 0x25));
    // Out of range and NaN are clamped, never a panic.
    assert_eq!(viridis(-3.0), viridis(0.0));
    assert_eq!(viridis(7.0), viridis(1.0));
    assert_eq!(viridis(f64::NAN), viridis(0.0));
    // Halfway between the first two stops (68,1,84) and (72,36,117).
    assert_eq!(viridis(0.05), RGBColor(70, 19, 101));

    // A data scale over 0..20: the low end dark, the high end at SCALE_TOP (0.9, stop 9:
    // #bddf26, before the pale last tenth), the middle at 0.45 (between stops 4 and 5).
    let scale = ValueScale::spanning(&[5.0, 0.0, 20.0, f64::NAN]).unwrap();
    assert_eq!((scale.lo, scale.hi), (0.0, 20.0));
    assert_eq!(scale.colour(0.0), viridis(0.0));
    assert_eq!(scale.colour(20.0), RGBColor(0xbd, 0xdf, 0x26));
    let RGBColor(r, g, b) = scale.colour(10.0);
    for (got, want) in [(r, 37.5), (g, 132.5), (b, 141.0)] {
        assert!((f64::from(got) - want).abs() <= 0.5, "{got} vs {want}");
    }
    // One value takes the middle of the visible range; no finite value, no scale.
    let single = ValueScale::spanning(&[3.0, 3.0]).unwrap();
    assert_eq!(single.colour(3.0), viridis(SCALE_TOP / 2.0));
    assert!(ValueScale::spanning(&[f64::NAN]).is_none());
}

/// A crowded front: 40 front points on a tight curve with long labels, among 80 other points.
fn crowded_front() -> FrontChart {
    let mut points = Vec::new();
    let mut front = Vec::new();
    for i in 0..40 {
        let t = f64::from(i) / 39.0;
        front.push(points.len());
        points.push((1000.0 + 4000.0 * t, 100.0 + 150.0 * t.sqrt()));
    }
    for i in 0..80 {
        let t = f64::from(i) / 79.0;
        points.push((
            1200.0 + 4000.0 * t,
            90.0 + 120.0 * t.sqrt() - f64::from(i % 5) * 6.0,
        ));
    }
    let n = points.len();
    FrontChart {
        title: "crowded".to_owned(),
        x_label: "cost".to_owned(),
        y_label: "reward".to_owned(),
        colour: Some("kappa_coeff".to_owned()),
        panels: vec![FrontPanel {
            title: String::new(),
            colour_values: (0..n).map(|i| (i % 41) as f64 * 0.5).collect(),
            labels: (0..n)
                .map(|i| format!("kappa_coeff={}", i as f64 * 0.5))
                .collect(),
            points,
            front,
            knee: Some(20),
        }],
        join_front: true,
        log_x: false,
        log_y: false,
    }
}

#[test]
fn front_labels_never_overlap_each_other_or_any_point_and_crowded_ones_are_dropped() {
    let font = font().unwrap();
    for panels in [1, 4] {
        let chart = FrontChart {
            panels: (0..panels)
                .map(|k| FrontPanel {
                    title: format!("interaction={k}"),
                    ..crowded_front().panels[0].clone()
                })
                .collect(),
            ..crowded_front()
        };
        let figure = FrontFigure::new(&chart, "crowded").unwrap();
        let svg = draw_svg(&figure, font, Path::new("crowded.svg")).unwrap();
        let layouts = figure.layout.borrow();
        assert_eq!(layouts.len(), panels);
        for layout in layouts.iter() {
            assert_eq!(layout.markers.len(), 120);
            let labels: Vec<Bounds> = layout.labels.iter().map(|(_, b)| *b).collect();
            assert!(labels.len() >= 3, "only {} labels placed", labels.len());
            assert!(!layout.dropped.is_empty(), "40 labels cannot all fit");
            assert_eq!(labels.len() + layout.dropped.len(), 40);
            assert_eq!(layout.labels[0].0, 20, "the knee is labelled first");
            for (k, a) in labels.iter().enumerate() {
                for b in &labels[k + 1..] {
                    assert!(!place::overlaps(*a, *b), "labels {a:?} and {b:?} overlap");
                }
                for m in &layout.markers {
                    assert!(!place::overlaps(*a, *m), "label {a:?} covers marker {m:?}");
                }
            }
        }
        // Boxes are the glyphs' real extent: the knee's label is as wide as DejaVu sets it.
        let (_, width) = text::layout_glyphs(font, "knee (kappa_coeff=10)", LEGEND_SIZE);
        let (x0, _, x1, _) = layouts[0].labels[0].1;
        assert_eq!(x1 - x0, width.ceil() as i32);
        assert!(svg.contains("knee (kappa_coeff=10)"));
    }
}

#[test]
fn a_long_categorical_legend_is_cut_with_a_count_and_a_numeric_one_becomes_a_colour_bar() {
    let dir = temp_dir("legend");
    let chart = LineChart {
        series: (0..41)
            .map(|k| {
                series(
                    &format!("group {k}"),
                    vec![0.0, 1.0],
                    vec![0.0, f64::from(k)],
                )
            })
            .collect(),
        ..reward_chart()
    };
    let paths = line_chart(&chart, &dir.join("many")).unwrap();
    let svg = fs::read_to_string(&paths[0]).unwrap();
    assert!(
        svg.contains(&format!("+{} more", 41 - LEGEND_MAX)),
        "no count of the rest"
    );
    assert!(svg.contains("\ngroup 9\n") && !svg.contains("\ngroup 10\n"));

    let colours = LineColours::Scale {
        title: "kappa_coeff".to_owned(),
        values: (0..41).map(|k| f64::from(k) * 0.5).collect(),
    };
    let paths = line_chart_coloured(&chart, &colours, &dir.join("scale")).unwrap();
    let svg = fs::read_to_string(&paths[0]).unwrap();
    assert!(svg.contains("\nkappa_coeff\n") && !svg.contains("group 0"));
    // The curves take the scale's ends: the first viridis' dark end, the last SCALE_TOP.
    let hex = |RGBColor(r, g, b): RGBColor| format!("stroke=\"#{r:02X}{g:02X}{b:02X}\"");
    assert!(svg.contains(&hex(viridis(0.0))), "{}", hex(viridis(0.0)));
    assert!(svg.contains(&hex(viridis(SCALE_TOP))));
    let wrong = LineColours::Scale {
        title: "k".to_owned(),
        values: vec![1.0],
    };
    assert!(matches!(
        line_chart_coloured(&chart, &wrong, &dir.join("wrong")),
        Err(PlotError::LengthMismatch { .. })
    ));
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bar_panels_share_one_y_axis_covering_the_tallest_bar() {
    let panel = |scale: f64| {
        BarChart {
            title: format!("scale {scale}"),
            ..bars()
        }
        .scaled(scale)
    };
    let chart = BarPanels {
        title: "panels".to_string(),
        panels: vec![panel(0.001), panel(1.0)],
    };
    let figure = bar::PanelsFigure::new(&chart, "panels").unwrap();
    let (small, tall) = (&figure.panels[0].y, &figure.panels[1].y);
    assert_eq!((small.lo, small.hi), (tall.lo, tall.hi));
    assert_eq!(small.lo, 0.0);
    // The tallest bar, 420 with a 10 % error bar, fits under the shared top.
    assert!(tall.hi >= 462.0, "top {}", tall.hi);
    // Each panel alone would have had its own top, a thousand times lower for the first.
    let alone = bar::BarFigure::new(&chart.panels[0], "alone").unwrap();
    assert!(alone.y.hi < 1.0, "top alone {}", alone.y.hi);
}

impl BarChart {
    /// The chart with every value and error multiplied by `k`.
    fn scaled(mut self, k: f64) -> Self {
        for bar in &mut self.bars {
            bar.value *= k;
            bar.error = bar.error.map(|e| e * k);
        }
        self
    }
}
