//! Drawing [`Figures`] with plotters, the same code for the SVG and the bitmap (PNG) backend.
//!
//! The estimate's axis range is set by the settled part of the run (the second half), so the
//! first samples' wild values — the estimator starts from a weak prior — are clipped at the
//! frame instead of squashing the converged curve flat.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use plotters::coord::Shift;
use plotters::prelude::*;

use super::{ExcitationSeries, Figures, ParameterSeries, TrackingSeries};
use crate::series::{band_quads, estimate_line, finite_range, padded, time_range, value_range};

mod course;
use course::sigma_course;

/// Pixel size of a single figure.
pub const FIGURE_SIZE: (u32, u32) = (900, 500);
/// Pixel size of the overview of all ten quantities.
pub const OVERVIEW_SIZE: (u32, u32) = (1800, 820);
const EXCITATION_SIZE: (u32, u32) = (900, 700);
/// Pixel size of the `sigma_course` figure (three panels side by side).
pub const COURSE_SIZE: (u32, u32) = (1500, 520);

const FONT: &str = "sans-serif";
const LEG_COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];
const ESTIMATE: RGBColor = RGBColor(31, 119, 180);
const TRUTH: RGBColor = RGBColor(214, 39, 40);
/// The band: the estimate's colour at a quarter strength on white, opaque.
const BAND: RGBColor = RGBColor(199, 221, 236);
/// At most this many band segments per figure (about one per pixel column).
const MAX_BAND_QUADS: usize = 800;

type DrawResult<T, DB> = Result<T, DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// Writes every figure of `f` into `dir` (created if needed) as `NAME.svg` and `NAME.png`:
/// `parameters` (all ten quantities), one per quantity (`mass`, `com_x`, …, `J_yz`),
/// `tracking_error`, `excitation` and `sigma_course` (predicted against achieved sigma, when
/// `f.course` is known; its numbers also as `sigma_course.csv`). Returns the files written.
pub fn write_figures(dir: &Path, f: &Figures) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create the figure directory {}", dir.display()))?;
    let mut written = Vec::new();
    let mut both = |stem: &str,
                    size: (u32, u32),
                    draw_svg: &dyn Fn(DrawingArea<SVGBackend, Shift>) -> Result<()>,
                    draw_png: &dyn Fn(DrawingArea<BitMapBackend, Shift>) -> Result<()>|
     -> Result<()> {
        let svg = dir.join(format!("{stem}.svg"));
        draw_svg(SVGBackend::new(&svg, size).into_drawing_area())
            .with_context(|| format!("cannot draw {}", svg.display()))?;
        let png = dir.join(format!("{stem}.png"));
        draw_png(BitMapBackend::new(&png, size).into_drawing_area())
            .with_context(|| format!("cannot draw {}", png.display()))?;
        written.push(svg);
        written.push(png);
        Ok(())
    };
    if !f.parameters.is_empty() {
        both("parameters", OVERVIEW_SIZE, &|a| overview(a, f), &|a| {
            overview(a, f)
        })?;
        for p in &f.parameters {
            both(p.stem, FIGURE_SIZE, &|a| single(a, p, &f.subject), &|a| {
                single(a, p, &f.subject)
            })?;
        }
    }
    if let Some(t) = &f.tracking {
        both("tracking_error", FIGURE_SIZE, &|a| tracking(a, t), &|a| {
            tracking(a, t)
        })?;
    }
    if let Some(e) = &f.excitation {
        both("excitation", EXCITATION_SIZE, &|a| excitation(a, e), &|a| {
            excitation(a, e)
        })?;
    }
    if let Some(c) = &f.course {
        both(
            "sigma_course",
            COURSE_SIZE,
            &|a| sigma_course(a, c, &f.parameters),
            &|a| sigma_course(a, c, &f.parameters),
        )?;
        let csv = dir.join("sigma_course.csv");
        std::fs::write(&csv, crate::series::course_csv(c, &f.parameters))
            .with_context(|| format!("cannot write {}", csv.display()))?;
        written.push(csv);
    }
    Ok(written)
}

fn fail<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> anyhow::Error {
    anyhow!("plotting failed: {e}")
}

fn overview<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, f: &Figures) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(fail)?;
    let root = root
        .titled(&format!("Estimates ± 1σ: {}", f.subject), (FONT, 24))
        .map_err(fail)?;
    let cells = root.split_evenly((2, 5));
    for (cell, p) in cells.iter().zip(&f.parameters) {
        parameter(cell, p, 15).map_err(fail)?;
    }
    root.present().map_err(fail)
}

fn single<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    p: &ParameterSeries,
    subject: &str,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(fail)?;
    let root = root.titled(subject, (FONT, 16)).map_err(fail)?;
    parameter(&root, p, 20).map_err(fail)?;
    root.present().map_err(fail)
}

fn parameter<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &ParameterSeries,
    font: u32,
) -> DrawResult<(), DB> {
    let (x0, x1) = time_range(&p.time_s);
    let (y0, y1) = value_range(p);
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{} ({})", p.title, p.unit), (FONT, font + 4))
        .margin(8)
        .x_label_area_size(font * 2 + 6)
        .y_label_area_size(font * 4 + 10)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("time from excitation start (s)")
        .y_desc(p.unit)
        .label_style((FONT, font))
        .axis_desc_style((FONT, font))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    // The ±σ band as opaque quads between consecutive samples (one large polygon trips the
    // bitmap backend's scanline fill; opaque quads leave no seams where they meet).
    let quads = band_quads(p, (y0, y1), MAX_BAND_QUADS)
        .into_iter()
        .map(|q| Polygon::new(q.to_vec(), BAND.filled()));
    chart
        .draw_series(quads)?
        .label("±1σ")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], BAND.filled()));
    let line = estimate_line(p, (y0, y1));
    chart
        // One pixel wide: the bitmap backend draws wider lines as polygons, whose fill spikes
        // out of the frame on the near-vertical steps of the first samples.
        .draw_series(LineSeries::new(line, ESTIMATE.stroke_width(1)))?
        .label("estimate")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], ESTIMATE.stroke_width(2)));
    if let Some(t) = p.truth.filter(|t| t.is_finite()) {
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0, t), (x1, t)],
                8,
                5,
                TRUTH.stroke_width(2),
            ))?
            .label("truth")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], TRUTH.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, font))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.5))
        .draw()?;
    Ok(())
}

/// Lines sharing one time axis, scaled by `scale` into `unit`.
fn lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    caption: &str,
    unit: &str,
    time_s: &[f64],
    series: &[(&str, &[f64])],
    scale: f64,
) -> DrawResult<(), DB> {
    let (x0, x1) = time_range(time_s);
    let (y0, y1) = padded(
        finite_range(series.iter().flat_map(|(_, v)| v.iter().map(|x| x * scale)))
            .unwrap_or((-1.0, 1.0)),
    );
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 22))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .x_desc("time from excitation start (s)")
        .y_desc(unit)
        .label_style((FONT, 16))
        .axis_desc_style((FONT, 16))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (k, (name, values)) in series.iter().enumerate() {
        let colour = LEG_COLOURS[k % LEG_COLOURS.len()];
        let points: Vec<(f64, f64)> = time_s
            .iter()
            .zip(values.iter())
            .filter(|(t, v)| t.is_finite() && v.is_finite())
            .map(|(t, v)| (*t, v * scale))
            .collect();
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(1)))?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.5))
        .draw()?;
    Ok(())
}

fn tracking<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, t: &TrackingSeries) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(fail)?;
    let names = ["leg 1", "leg 2", "leg 3", "leg 4", "leg 5", "leg 6"];
    let series: Vec<(&str, &[f64])> = names
        .iter()
        .zip(&t.error_m)
        .map(|(n, v)| (*n, v.as_slice()))
        .collect();
    lines(
        &root,
        "Leg tracking error (desired − measured length)",
        "mm",
        &t.time_s,
        &series,
        1e3,
    )
    .map_err(fail)?;
    root.present().map_err(fail)
}

fn excitation<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, e: &ExcitationSeries) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(fail)?;
    let (top, bottom) = root.split_vertically(EXCITATION_SIZE.1 / 2);
    let position: Vec<(&str, &[f64])> = ["x", "y", "z"]
        .iter()
        .zip(&e.position_m)
        .map(|(n, v)| (*n, v.as_slice()))
        .collect();
    lines(
        &top,
        "Excitation: desired translation of the plate",
        "mm",
        &e.time_s,
        &position,
        1e3,
    )
    .map_err(fail)?;
    let rotation: Vec<(&str, &[f64])> = ["roll", "pitch", "yaw"]
        .iter()
        .zip(&e.rpy_rad)
        .map(|(n, v)| (*n, v.as_slice()))
        .collect();
    lines(
        &bottom,
        "Excitation: desired rotation of the plate",
        "deg",
        &e.time_s,
        &rotation,
        180.0 / std::f64::consts::PI,
    )
    .map_err(fail)?;
    root.present().map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PredictedCourse;

    fn figures() -> Figures {
        let time_s: Vec<f64> = (0..200).map(|i| i as f64 * 0.05 - 1.0).collect();
        let value: Vec<f64> = time_s
            .iter()
            .map(|t| 1500.0 + 300.0 * (-t.max(0.0)).exp())
            .collect();
        let sigma: Vec<f64> = time_s
            .iter()
            .map(|t| if *t < 0.0 { f64::NAN } else { 50.0 / (1.0 + t) })
            .collect();
        let p = ParameterSeries {
            stem: "mass",
            title: "mass",
            unit: "kg",
            time_s: time_s.clone(),
            value,
            sigma,
            truth: Some(1500.0),
        };
        Figures {
            subject: "test".into(),
            parameters: vec![p; 10],
            tracking: Some(TrackingSeries {
                time_s: time_s.clone(),
                error_m: core::array::from_fn(|k| {
                    time_s.iter().map(|t| 1e-4 * (t + k as f64).sin()).collect()
                }),
            }),
            excitation: Some(ExcitationSeries {
                time_s: time_s.clone(),
                position_m: core::array::from_fn(|k| {
                    time_s
                        .iter()
                        .map(|t| 0.01 * (t * (k + 1) as f64).sin())
                        .collect()
                }),
                rpy_rad: core::array::from_fn(|k| {
                    time_s
                        .iter()
                        .map(|t| 0.02 * (t * (k + 2) as f64).cos())
                        .collect()
                }),
            }),
            course: Some(PredictedCourse {
                time_s: (1..=8).map(|k| k as f64).collect(),
                sigma: core::array::from_fn(|_| (1..=8).map(|k| 40.0 / k as f64).collect()),
            }),
        }
    }

    #[test]
    fn draws_every_figure_in_both_formats() {
        let dir = tempfile::tempdir().unwrap();
        let files = write_figures(dir.path(), &figures()).unwrap();
        // overview + 10 quantities (all named `mass` here, so written over) + tracking +
        // excitation + sigma course, each twice, and the course's CSV.
        assert_eq!(files.len(), 2 * (1 + 10 + 3) + 1);
        let course = std::fs::read_to_string(dir.path().join("sigma_course.svg")).unwrap();
        assert!(course.contains("mass: predicted") && course.contains("J_C yz: achieved"));
        assert!(course.contains("centre of mass (mm)"));
        let png = std::fs::read(dir.path().join("sigma_course.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let svg = std::fs::read_to_string(dir.path().join("parameters.svg")).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("truth") && svg.contains("estimate"));
        let png = std::fs::read(dir.path().join("tracking_error.png")).unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}
