//! `corofem plot RESULT.json`: a result's history drawn as an SVG, one
//! panel per quantity over time (Newton iterations for a static solve).
//!
//! The SVG is written by hand: polylines, axes with rounded ticks, a
//! legend per panel. No plotting library, so the program's dependencies
//! stay as they are.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::error::{CliError, CliResult};

/// One curve: its legend and its points `(x, y)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points in history order.
    pub points: Vec<(f64, f64)>,
}

/// One panel: a y axis shared by its curves.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Title, with the unit.
    pub title: String,
    /// The curves.
    pub series: Vec<Series>,
}

/// The panels of a result, read from its JSON.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// The first line of the picture: scene, method, size.
    pub title: String,
    /// The x axis' label.
    pub x_label: String,
    /// Panels from top to bottom.
    pub panels: Vec<Panel>,
}

/// Reads `result` and writes its SVG to `out` (default: the result's path
/// with the extension `.svg`). Returns the path written.
pub fn plot(result: &Path, out: Option<&Path>) -> CliResult<PathBuf> {
    let name = result.display().to_string();
    let text = std::fs::read_to_string(result)
        .map_err(|e| CliError(format!("{name}: cannot read the result file: {e}")))?;
    let json: Value = serde_json::from_str(&text).map_err(|e| {
        CliError(format!(
            "{name}: not a JSON result file (line {}, column {}): {e}",
            e.line(),
            e.column()
        ))
    })?;
    let figure = figure(&json).map_err(|why| CliError(format!("{name}: {why}")))?;
    let out = out.map_or_else(|| result.with_extension("svg"), Path::to_path_buf);
    std::fs::write(&out, svg(&figure))
        .map_err(|e| CliError(format!("{}: cannot write the plot: {e}", out.display())))?;
    Ok(out)
}

/// A number at `key` of a history record.
fn number(record: &Value, key: &str) -> Option<f64> {
    record.get(key).and_then(Value::as_f64)
}

/// The length of the vector at `key` of a history record.
fn magnitude(v: Option<&Value>) -> Option<f64> {
    let a = v?.as_array()?;
    let mut sum = 0.0;
    for x in a {
        let x = x.as_f64()?;
        sum += x * x;
    }
    Some(sum.sqrt())
}

/// The panels of a `corofem-result 1` document.
pub fn figure(json: &Value) -> Result<Figure, String> {
    let format = json.get("format").and_then(Value::as_str);
    if format != Some(crate::result::FORMAT) {
        return Err(format!(
            "format = {}: expected \"{}\" (a file written by corofem run)",
            format.map_or("(missing)".to_owned(), |f| format!("{f:?}")),
            crate::result::FORMAT
        ));
    }
    let history = json
        .get("history")
        .and_then(Value::as_array)
        .ok_or("history: missing or not a list of records")?;
    if history.is_empty() {
        return Err("history = []: nothing to plot".into());
    }
    let is_static = json.get("static").is_some();
    let x_of = |r: &Value| {
        if is_static {
            number(r, "step")
        } else {
            number(r, "t")
        }
    };
    let mut xs = Vec::with_capacity(history.len());
    for (i, r) in history.iter().enumerate() {
        xs.push(x_of(r).ok_or_else(|| {
            format!(
                "history[{i}]: missing {}",
                if is_static { "step" } else { "t" }
            )
        })?);
    }
    let curve = |name: &str, y: &dyn Fn(&Value) -> Option<f64>| -> Result<Series, String> {
        let mut points = Vec::with_capacity(history.len());
        for (i, (r, &x)) in history.iter().zip(&xs).enumerate() {
            let v = y(r).ok_or_else(|| format!("history[{i}]: missing or bad {name}"))?;
            points.push((x, v));
        }
        Ok(Series {
            name: name.to_owned(),
            points,
        })
    };
    let mut panels = vec![Panel {
        title: "energy (J)".into(),
        series: vec![
            curve("kinetic_energy", &|r| number(r, "kinetic_energy"))?,
            curve("elastic_energy", &|r| number(r, "elastic_energy"))?,
        ],
    }];
    let mut forces = vec![
        curve("|support_force|", &|r| magnitude(r.get("support_force")))?,
        curve("|tool_force|", &|r| magnitude(r.get("tool_force")))?,
    ];
    let probes = history[0]
        .get("probe_forces")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    for p in 0..probes {
        forces.push(curve(&format!("|[[probe]] #{}|", p + 1), &|r| {
            magnitude(r.get("probe_forces")?.as_array()?.get(p))
        })?);
    }
    // A force that stays zero (no tool, nothing fixed) only clutters.
    forces.retain(|s| s.points.iter().any(|p| p.1 != 0.0));
    if !forces.is_empty() {
        panels.push(Panel {
            title: "force (N)".into(),
            series: forces,
        });
    }
    panels.push(Panel {
        title: "nodes in contact".into(),
        series: vec![curve("contacts", &|r| number(r, "contacts"))?],
    });
    let mut cg = vec![curve("cg_iterations", &|r| number(r, "cg_iterations"))?];
    if is_static {
        cg[0].name = "cg_iterations per Newton iteration".into();
    }
    panels.push(Panel {
        title: "CG iterations".into(),
        series: cg,
    });
    let scene = json.get("scene").and_then(Value::as_str).unwrap_or("?");
    let method = json.get("method").and_then(Value::as_str).unwrap_or("?");
    let count = |k: &str| {
        json.get("mesh")
            .and_then(|m| m.get(k))
            .and_then(Value::as_u64)
            .unwrap_or(0)
    };
    let steps = json.get("steps").and_then(Value::as_u64).unwrap_or(0);
    let what = if is_static {
        format!("static, {steps} Newton iterations")
    } else {
        format!("{steps} steps")
    };
    Ok(Figure {
        title: format!(
            "{scene}: {method}, {} nodes, {} tets, {what}",
            count("nodes"),
            count("tets")
        ),
        x_label: if is_static {
            "Newton iteration".into()
        } else {
            "t (s)".into()
        },
        panels,
    })
}

/// Axis ticks: about `n` round values (1, 2 or 5 times a power of ten)
/// covering `[lo, hi]`, and the range they span.
pub fn ticks(lo: f64, hi: f64, n: usize) -> (Vec<f64>, f64, f64) {
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else if lo == 0.0 {
        // Zero throughout: the axis from 0 to 1.
        (0.0, 1.0)
    } else {
        // A constant: a range around it.
        let pad = lo.abs() * 0.5;
        (lo - pad, lo + pad)
    };
    let raw = (hi - lo) / n.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).floor();
    let last = (hi / step).ceil();
    let ticks = (0..=((last - first) as usize))
        .map(|k| (first + k as f64) * step)
        .collect();
    (ticks, first * step, last * step)
}

/// A tick label: short, without float noise (`0.30000000000000004` → `0.3`).
fn label(x: f64) -> String {
    if x == 0.0 {
        return "0".into();
    }
    let a = x.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{x:.6}");
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        let s = format!("{x:.3e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        format!("{m}e{e}")
    }
}

/// Escapes text for SVG.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Colours of the curves in a panel, in order.
const COLOURS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];

/// The figure as an SVG document.
pub fn svg(f: &Figure) -> String {
    const W: f64 = 860.0;
    const LEFT: f64 = 80.0;
    const RIGHT: f64 = 200.0;
    const PANEL: f64 = 150.0;
    const GAP: f64 = 46.0;
    const TOP: f64 = 58.0;
    let plot_w = W - LEFT - RIGHT;
    let h = TOP + f.panels.len() as f64 * (PANEL + GAP) + 10.0;
    let (x_lo, x_hi) = f
        .panels
        .iter()
        .flat_map(|p| &p.series)
        .flat_map(|s| &s.points)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
    let (xt, x0, x1) = ticks(x_lo, x_hi, 8);
    let mut o = String::new();
    let _ = writeln!(
        o,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{h}" viewBox="0 0 {W} {h}" font-family="sans-serif" font-size="12">"#
    );
    let _ = writeln!(o, r#"<rect width="{W}" height="{h}" fill="white"/>"#);
    let _ = writeln!(
        o,
        r#"<text x="{LEFT}" y="20" font-size="14">{}</text>"#,
        esc(&f.title)
    );
    for (k, panel) in f.panels.iter().enumerate() {
        let top = TOP + k as f64 * (PANEL + GAP);
        let (y_lo, y_hi) = panel
            .series
            .iter()
            .flat_map(|s| &s.points)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                (lo.min(p.1), hi.max(p.1))
            });
        // Energies, magnitudes and counts are never negative: their axis
        // starts at 0.
        let y_lo = if y_lo >= 0.0 { 0.0 } else { y_lo };
        let (yt, y0, y1) = ticks(y_lo, y_hi, 4);
        let px = |x: f64| LEFT + (x - x0) / (x1 - x0) * plot_w;
        let py = |y: f64| top + PANEL - (y - y0) / (y1 - y0) * PANEL;
        let _ = writeln!(
            o,
            r#"<g class="panel"><text x="{LEFT}" y="{}" font-weight="bold">{}</text>"#,
            top - 6.0,
            esc(&panel.title)
        );
        let _ = writeln!(
            o,
            r##"<rect x="{LEFT}" y="{top}" width="{plot_w}" height="{PANEL}" fill="none" stroke="#888"/>"##
        );
        for &y in &yt {
            let _ = writeln!(
                o,
                r##"<line x1="{LEFT}" x2="{}" y1="{y:.2}" y2="{y:.2}" stroke="#eee"/><text x="{}" y="{:.2}" text-anchor="end">{}</text>"##,
                LEFT + plot_w,
                LEFT - 6.0,
                py(y) + 4.0,
                label(y),
                y = py(y)
            );
        }
        for &x in &xt {
            let _ = writeln!(
                o,
                r##"<line x1="{x:.2}" x2="{x:.2}" y1="{top}" y2="{}" stroke="#eee"/><text x="{x:.2}" y="{}" text-anchor="middle">{}</text>"##,
                top + PANEL,
                top + PANEL + 15.0,
                label(x),
                x = px(x)
            );
        }
        for (i, s) in panel.series.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let mut pts = String::with_capacity(s.points.len() * 16);
            for &(x, y) in &s.points {
                let _ = write!(pts, "{:.2},{:.2} ", px(x), py(y));
            }
            let _ = writeln!(
                o,
                r#"<polyline class="series" fill="none" stroke="{colour}" stroke-width="1.5" points="{}"/>"#,
                pts.trim_end()
            );
            let ly = top + 14.0 + i as f64 * 16.0;
            let lx = LEFT + plot_w + 12.0;
            let _ = writeln!(
                o,
                r#"<line x1="{lx}" x2="{}" y1="{ly}" y2="{ly}" stroke="{colour}" stroke-width="2"/><text x="{}" y="{}">{}</text>"#,
                lx + 18.0,
                lx + 24.0,
                ly + 4.0,
                esc(&s.name)
            );
        }
        let _ = writeln!(o, "</g>");
    }
    let _ = writeln!(
        o,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        LEFT + plot_w / 2.0,
        h - 6.0,
        esc(&f.x_label)
    );
    o.push_str("</svg>\n");
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        let (t, lo, hi) = ticks(0.0, 0.93, 4);
        assert_eq!(t, vec![0.0, 0.5, 1.0]);
        assert_eq!((lo, hi), (0.0, 1.0));
        let (t, lo, hi) = ticks(0.0, 0.93, 8);
        assert_eq!(t.len(), 6, "{t:?}"); // steps of 0.2
        assert_eq!((lo, hi), (0.0, 1.0));
        let (t, lo, hi) = ticks(-3.2, 17.0, 4);
        assert_eq!((lo, hi), (-10.0, 20.0));
        assert_eq!(t, vec![-10.0, 0.0, 10.0, 20.0]);
        // A constant gets a range around it; zero, the range 0 to 1.
        let (_, lo, hi) = ticks(2.0, 2.0, 4);
        assert!(lo < 2.0 && hi > 2.0);
        assert_eq!(ticks(0.0, 0.0, 4).1..ticks(0.0, 0.0, 4).2, 0.0..1.0);
        assert_eq!(label(0.6000000000000001), "0.6");
        assert_eq!(label(1.5e-7), "1.5e-7");
    }

    #[test]
    fn a_wrong_file_is_named() {
        let e = figure(&serde_json::json!({"format": "x"})).unwrap_err();
        assert!(
            e.starts_with("format = \"x\": expected \"corofem-result 1\""),
            "{e}"
        );
        let e = figure(&serde_json::json!({"format": "corofem-result 1"})).unwrap_err();
        assert_eq!(e, "history: missing or not a list of records");
        let e = figure(&serde_json::json!({"format": "corofem-result 1", "history": [{"t": 0.0}]}))
            .unwrap_err();
        assert_eq!(e, "history[0]: missing or bad kinetic_energy");
    }
}
