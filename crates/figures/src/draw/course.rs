//! The `sigma_course` figure: the payload's predicted and achieved sigma over the excitation.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{fail, finite_range, DrawResult, FONT, LEG_COLOURS};
use crate::{ParameterSeries, PredictedCourse, NAMES};
use anyhow::Result;

/// The quantity groups of `sigma_course`: title, unit, scale into it, and their indices in the
/// ten quantities.
const COURSE_GROUPS: [(&str, &str, f64, &[usize]); 3] = [
    ("mass", "kg", 1.0, &[0]),
    ("centre of mass", "mm", 1e3, &[1, 2, 3]),
    ("J_C", "kg·m²", 1.0, &[4, 5, 6, 7, 8, 9]),
];

/// Predicted (thick) against achieved (thin) one sigma of each quantity over the excitation,
/// one panel per group, the sigma on a log scale.
pub(super) fn sigma_course<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    c: &PredictedCourse,
    achieved: &[ParameterSeries],
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(fail)?;
    let root = root
        .titled(
            "Payload sigma over the excitation: predicted by stewart plan (thick) and achieved (thin)",
            (FONT, 20),
        )
        .map_err(fail)?;
    for (area, group) in root.split_evenly((1, 3)).iter().zip(COURSE_GROUPS) {
        course_panel(area, c, achieved, group).map_err(fail)?;
    }
    root.present().map_err(fail)
}

fn course_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    c: &PredictedCourse,
    achieved: &[ParameterSeries],
    (title, unit, scale, members): (&str, &str, f64, &[usize]),
) -> DrawResult<(), DB> {
    let x1 = c.time_s.last().copied().unwrap_or(1.0).max(1e-3);
    let positive = |t: &f64, v: &f64| *t > 0.0 && *t <= x1 && v.is_finite() && *v > 0.0;
    let predicted = |k: usize| -> Vec<(f64, f64)> {
        c.time_s
            .iter()
            .zip(&c.sigma[k])
            .filter(|(t, v)| positive(t, v))
            .map(|(t, v)| (*t, v * scale))
            .collect()
    };
    let measured = |k: usize| -> Vec<(f64, f64)> {
        achieved.get(k).map_or(Vec::new(), |p| {
            let step = (p.time_s.len() / 2000).max(1);
            p.time_s
                .iter()
                .zip(&p.sigma)
                .step_by(step)
                .filter(|(t, v)| positive(t, v))
                .map(|(t, v)| (*t, v * scale))
                .collect()
        })
    };
    // y range: the predicted curves and the achieved sigma after the first tenth of the run
    // (the estimator's first samples' sigma is its prior's, decades above).
    let values = members.iter().flat_map(|&k| {
        predicted(k)
            .into_iter()
            .chain(measured(k).into_iter().filter(|(t, _)| *t > 0.1 * x1))
            .map(|(_, v)| v)
    });
    let (lo, hi) = finite_range(values).unwrap_or((1e-6, 1.0));
    let (y0, y1) = (lo / 1.5, hi * 1.5);
    let mut chart = ChartBuilder::on(area)
        .caption(format!("{title} ({unit})"), (FONT, 20))
        .margin(8)
        .x_label_area_size(40)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..x1, (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("time from excitation start (s)")
        .y_desc(format!("one sigma ({unit})"))
        .y_label_formatter(&|v| two_significant(*v))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 14))
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (i, &k) in members.iter().enumerate() {
        let colour = LEG_COLOURS[i % LEG_COLOURS.len()];
        let name = NAMES[k].1;
        let clamp = |pts: Vec<(f64, f64)>| -> Vec<(f64, f64)> {
            pts.into_iter().map(|(t, v)| (t, v.clamp(y0, y1))).collect()
        };
        chart
            .draw_series(LineSeries::new(clamp(predicted(k)), colour.stroke_width(3)))?
            .label(format!("{name}: predicted"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(3))
            });
        chart
            .draw_series(LineSeries::new(clamp(measured(k)), colour.stroke_width(1)))?
            .label(format!("{name}: achieved"))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(1))
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 11))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.5))
        .draw()?;
    Ok(())
}

/// A tick label with two significant digits (a log axis's ticks are not round in binary).
fn two_significant(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return String::new();
    }
    let decimals = (1.0 - v.log10().floor()).max(0.0) as usize;
    format!("{v:.decimals$}")
}

#[cfg(test)]
mod tests {
    #[test]
    fn tick_labels_keep_two_significant_digits() {
        assert_eq!(super::two_significant(0.7000000000000001), "0.70");
        assert_eq!(super::two_significant(0.012), "0.012");
        assert_eq!(super::two_significant(250.0), "250");
    }
}
