//! Log–log SVG plots with plotters (SVG backend only).

use plotters::prelude::*;
use std::path::Path;

/// One plotted series.
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points (x, y), both > 0.
    pub points: Vec<(f64, f64)>,
    /// Join the points with a line.
    pub line: bool,
    /// Optional text next to each point.
    pub labels: Vec<String>,
    /// Palette index.
    pub color: usize,
    /// Marker: 0 circle, 1 triangle, 2 cross.
    pub marker: u8,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(90, 90, 90),
];

/// Where the legend goes.
#[allow(dead_code)] // all four corners are offered; the report uses two today
pub enum Legend {
    /// Upper left.
    UpperLeft,
    /// Upper right.
    UpperRight,
    /// Lower left.
    LowerLeft,
    /// Lower right.
    LowerRight,
}

/// Writes a log–log plot of `series` to `path`.
pub fn loglog(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
    legend: Legend,
) -> Result<(), Box<dyn std::error::Error>> {
    let all = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (1.0, 10.0, 1.0, 10.0);
    }
    // Pad by a factor on each side (log axes); leave room for labels. The
    // axes start at 1, 2 or 5 times a power of ten: from elsewhere,
    // plotters' log ticks fell between those and the lowest decade had no
    // label (Figure 4 read 1, 2, 5, 10 only, its points at 0.2 ms).
    let (x0, y0) = (nice_below(x0 / 1.3), nice_below(y0 / 2.0));
    let (x1, y1) = (x1 * 1.6, y1 * 2.5);
    let root = SVGBackend::new(path, (960, 640)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 24))
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(90)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .x_label_formatter(&|v| fmt_tick(*v))
        .y_label_formatter(&|v| fmt_tick(*v))
        .x_labels(30)
        .y_labels(30)
        .light_line_style(WHITE)
        .bold_line_style(RGBColor(225, 225, 225))
        .draw()?;
    for s in series {
        let c = PALETTE[s.color % PALETTE.len()];
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .collect();
        let marker = s.marker;
        let anno = if s.line {
            chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
        } else {
            chart.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
        };
        // The legend shows the series' marker (and its line, if it has one).
        let line = if s.line { 20 } else { 0 };
        anno.label(s.name.clone()).legend(move |(x, y)| {
            let at = EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (line, 0)], c.stroke_width(2));
            match marker {
                1 => at + TriangleMarker::new((10, 0), 7, c.filled()).into_dyn(),
                2 => at + Cross::new((10, 0), 6, c.stroke_width(2)).into_dyn(),
                _ => at + Circle::new((10, 0), 4, c.filled()).into_dyn(),
            }
        });
        match marker {
            1 => {
                chart.draw_series(pts.iter().map(|&p| TriangleMarker::new(p, 7, c.filled())))?;
            }
            2 => {
                chart.draw_series(pts.iter().map(|&p| Cross::new(p, 6, c.stroke_width(2))))?;
            }
            _ => {
                chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
            }
        }
        if !s.labels.is_empty() {
            // Alternate above and below the point so neighbours do not collide.
            chart.draw_series(
                s.points
                    .iter()
                    .zip(&s.labels)
                    .enumerate()
                    .filter(|(_, (p, _))| p.0 > 0.0 && p.1 > 0.0)
                    .map(|(k, (&p, l))| {
                        let dy = if k % 2 == 0 { -16 } else { 6 };
                        EmptyElement::at(p)
                            + Text::new(
                                l.clone(),
                                (6, dy),
                                ("sans-serif", 13).into_font().color(&c),
                            )
                    }),
            )?;
        }
    }
    let pos = match legend {
        Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
        Legend::UpperRight => SeriesLabelPosition::UpperRight,
        Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
        Legend::LowerRight => SeriesLabelPosition::LowerRight,
    };
    chart
        .configure_series_labels()
        .position(pos)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()?;
    root.present()?;
    Ok(())
}

/// The largest of 1, 2 and 5 times a power of ten that is at most `v > 0`.
fn nice_below(v: f64) -> f64 {
    let decade = 10f64.powf(v.log10().floor());
    let m = v / decade;
    let step = if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    };
    step * decade
}

/// Tick text for 1, 2 and 5 times a power of ten; empty for other ticks
/// (log axes offer many, whose labels would overlap).
fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    let mantissa = a / 10f64.powf(a.log10().floor());
    if ![1.0, 2.0, 5.0]
        .iter()
        .any(|m| (mantissa - m).abs() < 1e-6 || (mantissa - 10.0 * m).abs() < 1e-5)
    {
        return String::new();
    }
    if a == 0.0 {
        "0".into()
    } else if (1e-2..1e5).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        format!("{v:.0e}")
    }
}
