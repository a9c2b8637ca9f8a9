//! The page's figures as inline SVG, drawn here rather than by a plotting library: each is a
//! few shapes, and SVG text set in the page's own font needs no font file.
//!
//! Every figure is an `<svg>` with `data-figure="NAME"` (`ellipsoid`, `budget`, `convergence`,
//! `residuals`) so a test can find each in the rendered page.

use std::fmt::Write;

use measure::report::Report;

use crate::ellipsoid::{Ellipse, Ellipsoid};
use crate::format::{esc, significant};

/// One colour per error source, in the order of the report's budget (13 lines); further lines
/// reuse the list.
pub const SOURCE_COLOURS: [&str; 13] = [
    "#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7",
    "#9c755f", "#bab0ac", "#1b9e77", "#7570b3", "#d95f02",
];

/// Colours of the principal axes 1, 2, 3 (ascending moments).
const AXIS_COLOURS: [&str; 3] = ["#d62728", "#2ca02c", "#1f77b4"];

fn svg_open(name: &str, w: f64, h: f64, title: &str) -> String {
    format!(
        "<svg data-figure=\"{name}\" viewBox=\"0 0 {w} {h}\" \
         role=\"img\" aria-label=\"{t}\"><title>{t}</title>",
        t = esc(title)
    )
}

/// What the picture of the payload on the fixture draws.
#[derive(Clone, Copy, Debug, Default)]
pub struct Scene {
    /// The payload's equivalent ellipsoid, with its principal axes.
    pub payload: Option<Ellipsoid>,
    /// The fixture's (the tare's) equivalent ellipsoid.
    pub fixture: Option<Ellipsoid>,
    /// Radius of the plate's joint circle, m (the rig description's), drawn at z = 0.
    pub plate_radius_m: Option<f64>,
}

/// The three orthographic views (top: x right, y up; front: x right, z up; side: y right, z
/// up) of the scene in P, one scale for all three, with a scale bar.
pub fn ellipsoid_views(scene: &Scene) -> String {
    const PANEL: f64 = 210.0;
    const GAP: f64 = 16.0;
    const TOP: f64 = 18.0;
    const BOTTOM: f64 = 30.0;
    let (w, h) = (3.0 * PANEL + 2.0 * GAP, PANEL + TOP + BOTTOM);
    // The scene's extent in each P axis: the origin, the plate, each ellipsoid's bounding box.
    let mut lo = [0.0f64; 3];
    let mut hi = [0.0f64; 3];
    let mut widen = |k: usize, a: f64, b: f64| {
        lo[k] = lo[k].min(a);
        hi[k] = hi[k].max(b);
    };
    if let Some(r) = scene.plate_radius_m {
        widen(0, -r, r);
        widen(1, -r, r);
    }
    for e in [scene.payload, scene.fixture].into_iter().flatten() {
        let a = e.shape();
        for k in 0..3 {
            let half = a[(k, k)].sqrt();
            widen(k, e.centre[k] - half, e.centre[k] + half);
        }
    }
    let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.1, f64::max);
    let scale = 0.86 * PANEL / span;
    let views = [
        ("top view (x →, y ↑)", 0, 1),
        ("front view (x →, z ↑)", 0, 2),
        ("side view (y →, z ↑)", 1, 2),
    ];
    let mut s = svg_open(
        "ellipsoid",
        w,
        h,
        "The payload's equivalent ellipsoid on the fixture, three orthographic views in P",
    );
    for (n, (label, i, j)) in views.into_iter().enumerate() {
        let x0 = n as f64 * (PANEL + GAP);
        let centre = [0.5 * (lo[i] + hi[i]), 0.5 * (lo[j] + hi[j])];
        // P coordinates (u along the view's first axis, v its second) → SVG (y down).
        let px = |u: f64| x0 + PANEL / 2.0 + (u - centre[0]) * scale;
        let py = |v: f64| TOP + PANEL / 2.0 - (v - centre[1]) * scale;
        let _ = write!(
            s,
            "<rect x=\"{x0}\" y=\"{TOP}\" width=\"{PANEL}\" height=\"{PANEL}\" class=\"panel\"/>\
             <text x=\"{:.1}\" y=\"12\" class=\"label\" text-anchor=\"middle\">{label}</text>",
            x0 + PANEL / 2.0
        );
        if let Some(r) = scene.plate_radius_m {
            if j == 1 {
                let _ = write!(
                    s,
                    "<circle cx=\"{:.2}\" cy=\"{:.2}\" r=\"{:.2}\" class=\"plate\"/>",
                    px(0.0),
                    py(0.0),
                    r * scale
                );
            } else {
                let _ = write!(
                    s,
                    "<line x1=\"{:.2}\" y1=\"{:.2}\" x2=\"{:.2}\" y2=\"{:.2}\" class=\"plate-edge\"/>",
                    px(-r),
                    py(0.0),
                    px(r),
                    py(0.0)
                );
            }
        }
        if let Some(f) = scene.fixture {
            s.push_str(&ellipse(&f.outline(i, j), &px, &py, scale, "fixture"));
        }
        if let Some(p) = scene.payload {
            s.push_str(&ellipse(&p.outline(i, j), &px, &py, scale, "payload"));
            for (k, colour) in AXIS_COLOURS.iter().enumerate() {
                let [a, b] = p.axis_ends(k);
                let _ = write!(
                    s,
                    "<line x1=\"{:.2}\" y1=\"{:.2}\" x2=\"{:.2}\" y2=\"{:.2}\" stroke=\"{colour}\" \
                     class=\"axis\"/>",
                    px(a[i]),
                    py(a[j]),
                    px(b[i]),
                    py(b[j])
                );
            }
            let _ = write!(
                s,
                "<circle cx=\"{:.2}\" cy=\"{:.2}\" r=\"2.5\" class=\"com\"/>",
                px(p.centre[i]),
                py(p.centre[j])
            );
        }
        // The P origin: a small cross.
        let (ox, oy) = (px(0.0), py(0.0));
        let _ = write!(
            s,
            "<path d=\"M{:.2} {oy:.2}H{:.2}M{ox:.2} {:.2}V{:.2}\" class=\"origin\"/>",
            ox - 5.0,
            ox + 5.0,
            oy - 5.0,
            oy + 5.0
        );
    }
    // Scale bar: the largest of 0.1, 0.2, 0.5, 1, 2 m that fits a third of a panel.
    let bar = [2.0, 1.0, 0.5, 0.2, 0.1]
        .into_iter()
        .find(|m| m * scale <= PANEL / 3.0)
        .unwrap_or(0.1);
    let y = TOP + PANEL + 16.0;
    let _ = write!(
        s,
        "<path d=\"M4 {y}h{:.2}\" class=\"scalebar\"/><text x=\"{:.2}\" y=\"{:.1}\" \
         class=\"label\">{bar} m</text>",
        bar * scale,
        bar * scale + 10.0,
        y + 4.0
    );
    let legend = [
        ("payload", "payload (equivalent ellipsoid)"),
        ("fixture", "fixture (tare)"),
        ("plate-edge", "plate joint circle"),
    ];
    for (n, (class, text)) in legend.iter().enumerate() {
        let x = 170.0 + n as f64 * 170.0;
        let _ = write!(
            s,
            "<rect x=\"{x}\" y=\"{:.1}\" width=\"14\" height=\"8\" class=\"{class}\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" class=\"label\">{text}</text>",
            y - 4.0,
            x + 18.0,
            y + 4.0
        );
    }
    s.push_str("</svg>");
    s
}

fn ellipse(
    e: &Ellipse,
    px: &dyn Fn(f64) -> f64,
    py: &dyn Fn(f64) -> f64,
    scale: f64,
    class: &str,
) -> String {
    // SVG's y points down, so a counter-clockwise angle in P is a negative rotation.
    format!(
        "<ellipse cx=\"{:.2}\" cy=\"{:.2}\" rx=\"{:.2}\" ry=\"{:.2}\" \
         transform=\"rotate({:.3} {:.2} {:.2})\" class=\"{class}\"/>",
        px(e.centre[0]),
        py(e.centre[1]),
        e.radii[0] * scale,
        e.radii[1] * scale,
        -e.angle.to_degrees(),
        px(e.centre[0]),
        py(e.centre[1]),
    )
}

/// Each quantity's variance split by error source: one bar per quantity, the segment of source
/// i its share σᵢ² / Σσ² (the budget's lines add in quadrature to `sigma`).
pub fn budget_shares(report: &Report) -> String {
    const LEFT: f64 = 62.0;
    const BAR: f64 = 520.0;
    const ROW: f64 = 16.0;
    let names = measure::report::Quantities::NAMES;
    let lines: Vec<[f64; 10]> = report.error_budget.iter().map(|l| l.sigma.flat()).collect();
    let legend_rows = report.error_budget.len().div_ceil(4);
    let h = 10.0 * ROW + 12.0 + legend_rows as f64 * 14.0;
    let mut s = svg_open(
        "budget",
        LEFT + BAR + 8.0,
        h,
        "Share of each error source in each quantity's variance",
    );
    for (q, name) in names.iter().enumerate() {
        let y = q as f64 * ROW;
        let total: f64 = lines.iter().map(|l| l[q] * l[q]).sum();
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" class=\"label\" text-anchor=\"end\">{}</text>",
            LEFT - 6.0,
            y + 11.0,
            esc(name)
        );
        let mut x = LEFT;
        if total > 0.0 {
            for (i, l) in lines.iter().enumerate() {
                let w = BAR * l[q] * l[q] / total;
                if w > 0.0 {
                    let _ = write!(
                        s,
                        "<rect x=\"{x:.2}\" y=\"{:.1}\" width=\"{w:.2}\" height=\"{:.1}\" \
                         fill=\"{}\"/>",
                        y + 2.0,
                        ROW - 4.0,
                        SOURCE_COLOURS[i % SOURCE_COLOURS.len()]
                    );
                }
                x += w;
            }
        }
    }
    for (i, line) in report.error_budget.iter().enumerate() {
        let (col, row) = (i % 4, i / 4);
        let x = LEFT + col as f64 * 130.0;
        let y = 10.0 * ROW + 10.0 + row as f64 * 14.0;
        let _ = write!(
            s,
            "<rect x=\"{x}\" y=\"{y}\" width=\"10\" height=\"10\" fill=\"{}\"/>\
             <text x=\"{:.1}\" y=\"{:.1}\" class=\"label\">{}</text>",
            SOURCE_COLOURS[i % SOURCE_COLOURS.len()],
            x + 14.0,
            y + 9.0,
            esc(&line.source)
        );
    }
    s.push_str("</svg>");
    s
}

/// The loaded run's samples as a line, the span before the estimate stayed within 1 % of its
/// final value shaded, and the mark where it did (`samples_to_1pct`).
pub fn convergence(report: &Report) -> String {
    const LEFT: f64 = 10.0;
    const BAR: f64 = 560.0;
    let mut s = svg_open(
        "convergence",
        LEFT * 2.0 + BAR,
        58.0,
        "Samples of the loaded run until every parameter stayed within 1 % of its final value",
    );
    let n = report.samples.max(1) as f64;
    let _ = write!(
        s,
        "<rect x=\"{LEFT}\" y=\"14\" width=\"{BAR}\" height=\"14\" class=\"run\"/>"
    );
    match report.convergence.samples_to_1pct {
        Some(k) => {
            let x = LEFT + BAR * (k as f64 / n).clamp(0.0, 1.0);
            let t = report.excitation_s * k as f64 / n;
            let _ = write!(
                s,
                "<rect x=\"{LEFT}\" y=\"14\" width=\"{:.2}\" height=\"14\" class=\"settling\"/>\
                 <path d=\"M{x:.2} 8V34\" class=\"mark\"/>\
                 <text x=\"{:.2}\" y=\"48\" class=\"label\" text-anchor=\"{}\">within 1 % from \
                 sample {k} (≈ {} s)</text>",
                x - LEFT,
                x,
                if x > LEFT + BAR * 0.7 { "end" } else { "start" },
                significant(t, 3)
            );
        }
        None => {
            let _ = write!(
                s,
                "<text x=\"{LEFT}\" y=\"48\" class=\"label\">never within 1 % of the final value</text>"
            );
        }
    }
    let _ = write!(
        s,
        "<text x=\"{LEFT}\" y=\"10\" class=\"label\">sample 1</text>\
         <text x=\"{:.1}\" y=\"10\" class=\"label\" text-anchor=\"end\">sample {} ({} s)</text></svg>",
        LEFT + BAR,
        report.samples,
        significant(report.excitation_s, 4)
    );
    s
}

/// The fit residual's RMS per equation: force x, y, z (N) and torque x, y, z (N·m), each group
/// on its own scale.
pub fn residuals(report: &Report) -> String {
    const H: f64 = 110.0;
    let groups = [
        ("force", "N", report.residual_rms.force_n),
        ("torque", "N·m", report.residual_rms.torque_nm),
    ];
    let mut s = svg_open(
        "residuals",
        580.0,
        H + 40.0,
        "RMS of the fit residual per equation",
    );
    for (g, (name, unit, values)) in groups.iter().enumerate() {
        let x0 = 20.0 + g as f64 * 290.0;
        let top = values
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        // The tallest bar stops short of the top, leaving room for its value.
        let scale = if top > 0.0 { (H - 16.0) / top } else { 0.0 };
        let _ = write!(
            s,
            "<path d=\"M{x0} {:.1}h250\" class=\"baseline\"/>",
            H + 10.0
        );
        for (k, (axis, v)) in ["x", "y", "z"].iter().zip(values).enumerate() {
            let bh = if v.is_finite() { v * scale } else { 0.0 };
            let x = x0 + 15.0 + k as f64 * 80.0;
            let _ = write!(
                s,
                "<rect x=\"{x}\" y=\"{:.2}\" width=\"50\" height=\"{bh:.2}\" class=\"bar\"/>\
                 <text x=\"{:.1}\" y=\"{:.2}\" class=\"label\" text-anchor=\"middle\">{}</text>\
                 <text x=\"{:.1}\" y=\"{:.1}\" class=\"label\" text-anchor=\"middle\">{name} {axis}, {unit}</text>",
                H + 10.0 - bh,
                x + 25.0,
                H + 6.0 - bh,
                significant(*v, 3),
                x + 25.0,
                H + 24.0
            );
        }
    }
    s.push_str("</svg>");
    s
}
