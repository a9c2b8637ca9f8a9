//! The result table printed at the end of a run: each quantity's estimate ± sigma, the truth
//! (when known), the error, and the error in sigmas.

use std::fmt::Write as _;

use measure::report::{Quantities, Report};

/// One row: name, unit, and accessor into [`Quantities`].
struct Row {
    name: &'static str,
    unit: &'static str,
    get: fn(&Quantities) -> f64,
}

const ROWS: [Row; 10] = [
    Row {
        name: "mass",
        unit: "kg",
        get: |q| q.mass,
    },
    Row {
        name: "com x",
        unit: "m",
        get: |q| q.com[0],
    },
    Row {
        name: "com y",
        unit: "m",
        get: |q| q.com[1],
    },
    Row {
        name: "com z",
        unit: "m",
        get: |q| q.com[2],
    },
    Row {
        name: "J_C xx",
        unit: "kg·m²",
        get: |q| q.inertia_com[0][0],
    },
    Row {
        name: "J_C yy",
        unit: "kg·m²",
        get: |q| q.inertia_com[1][1],
    },
    Row {
        name: "J_C zz",
        unit: "kg·m²",
        get: |q| q.inertia_com[2][2],
    },
    Row {
        name: "J_C xy",
        unit: "kg·m²",
        get: |q| q.inertia_com[0][1],
    },
    Row {
        name: "J_C xz",
        unit: "kg·m²",
        get: |q| q.inertia_com[0][2],
    },
    Row {
        name: "J_C yz",
        unit: "kg·m²",
        get: |q| q.inertia_com[1][2],
    },
];

/// Formats `v` with `digits` significant figures after aligning on `scale`'s magnitude.
fn fixed(v: f64, decimals: usize) -> String {
    format!("{v:.decimals$}")
}

/// Decimals that show a value of size `sigma` to two significant figures (at least 1, at most 6).
fn decimals_for(sigma: f64, value: f64) -> usize {
    let reference = if sigma > 0.0 && sigma.is_finite() {
        sigma
    } else {
        value.abs().max(1e-6) * 1e-4
    };
    let d = 1.0 - reference.log10().floor();
    d.clamp(1.0, 6.0) as usize
}

/// The table as text, one quantity per line: in the vehicle frame first when the rig
/// description places the vehicle, then in the plate frame P.
pub fn render(report: &Report) -> String {
    let mut out = String::new();
    if let Some(v) = &report.vehicle {
        let _ = writeln!(out, "in the {}:", v.frame);
        out += &quantity_rows(&v.estimate, &v.sigma, v.truth.as_ref(), &|k| {
            report.is_given(k)
        });
        out += &vehicle_lines(v);
        let _ = writeln!(out, "in the plate frame P:");
    }
    out += &quantity_rows(
        &report.estimate,
        &report.sigma,
        report.truth.as_ref(),
        &|k| report.is_given(k),
    );
    let p = &report.principal;
    let _ = writeln!(
        out,
        "principal moments: {:.2}, {:.2}, {:.2} kg·m²",
        p.moments[0], p.moments[1], p.moments[2]
    );
    let _ = write!(
        out,
        "samples: {}   excitation: {:.1} s   within 1 % after: {}   residual rms: ",
        report.samples,
        report.excitation_s,
        report
            .convergence
            .samples_to_1pct
            .map_or("never".to_string(), |n| format!("{n} samples")),
    );
    let f = report.residual_rms.force_n;
    let t = report.residual_rms.torque_nm;
    let _ = writeln!(
        out,
        "force {:.3}/{:.3}/{:.3} N, torque {:.3}/{:.3}/{:.3} N·m",
        f[0], f[1], f[2], t[0], t[1], t[2]
    );
    let _ = writeln!(
        out,
        "tare: {}   consistency: {}{}",
        match (&report.tare.source[..], &report.tare.file) {
            (_, Some(f)) => format!("from {f}"),
            (s, None) => s.to_string(),
        },
        report.consistency.verdict,
        if report.consistency.problems.is_empty() {
            String::new()
        } else {
            format!(" ({})", report.consistency.problems.join("; "))
        }
    );
    if let Some(line) = projection_line(&report.consistency) {
        let _ = writeln!(out, "{line}");
    }
    for c in &report.conformity {
        let (measured, u) =
            inertial_certificate::format::rounded(c.measured, c.expanded_uncertainty);
        let _ = writeln!(
            out,
            "conformity: {} {measured} (U {u}) against {} ± {}: {} (guarded acceptance, U = 2σ)",
            c.quantity,
            c.nominal,
            c.tolerance,
            c.verdict.describe()
        );
    }
    if let Some((name, nu)) = measure::quality::heavy_tailed(
        &Quantities::NAMES,
        &report.covariance_basis.loaded_degrees_of_freedom,
    ) {
        let _ = writeln!(
            out,
            "{name}'s sigma rests on {nu:.1} degrees of freedom of the residual windows \
             (fewer than {:.0}: its error can reach several sigmas more often than a normal \
             one's); a longer excitation gives more",
            measure::quality::HEAVY_TAIL_DEGREES_OF_FREEDOM
        );
    }
    if let Some(w) = &report.static_weighing {
        let p = &w.payload;
        let compared = match &w.check {
            Some(c) => {
                let [m, x, y] = c.z;
                format!("dynamic − static: {m:+.1}, {x:+.1}, {y:+.1} σ")
            }
            None => "not compared (the fit takes the mass and centre of mass as given)".into(),
        };
        let _ = writeln!(
            out,
            "static weighing (brake holds): mass {:.3} ± {:.3} kg, c_x {:.2} ± {:.2} mm, c_y \
             {:.2} ± {:.2} mm; {compared}",
            p.mass_kg,
            p.sigma_mass_kg,
            p.com_xy_m[0] * 1e3,
            p.sigma_com_xy_m[0] * 1e3,
            p.com_xy_m[1] * 1e3,
            p.sigma_com_xy_m[1] * 1e3,
        );
        if let Some(warning) = w.warning() {
            let _ = writeln!(out, "warning: {warning}");
        }
    }
    out
}

/// One row per quantity: estimate ± sigma, and the truth, error and error in sigmas when the
/// truth is known; `is_given(k)`: quantity k is the rig description's, not measured.
fn quantity_rows(
    estimate: &Quantities,
    sigma: &Quantities,
    truth: Option<&Quantities>,
    is_given: &dyn Fn(usize) -> bool,
) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "{:<8} {:<6} {:>28}",
        "quantity", "unit", "estimate ± 1σ"
    );
    if truth.is_some() {
        let _ = write!(out, " {:>13} {:>12} {:>7}", "truth", "error", "err/σ");
    }
    out.push('\n');
    for (k, row) in ROWS.iter().enumerate() {
        let est = (row.get)(estimate);
        let sig = (row.get)(sigma);
        let d = decimals_for(sig, est);
        let given = is_given(k);
        let cell = if given {
            format!("{} (given)", fixed(est, d))
        } else {
            format!("{} ± {}", fixed(est, d), fixed(sig, d))
        };
        let _ = write!(out, "{:<8} {:<6} {:>28}", row.name, row.unit, cell);
        if let Some(truth) = truth {
            let t = (row.get)(truth);
            let err = est - t;
            let z = if sig > 0.0 && !given {
                format!("{:.2}", err / sig)
            } else {
                "-".into()
            };
            let _ = write!(
                out,
                " {:>13} {:>12} {:>7}",
                fixed(t, d),
                fixed(err, d + 1),
                z
            );
        }
        out.push('\n');
    }
    out
}

/// The vehicle's centre of gravity against the car, the static load split and what the
/// placement's tolerance adds.
fn vehicle_lines(v: &measure::vehicle::VehicleResults) -> String {
    let mut out = String::new();
    let (c, s) = (v.estimate.com, v.sigma.com);
    // y points left in ISO 8855, right in SAE J670.
    let side = c[1] * v.convention.axis_signs()[1];
    let _ = writeln!(
        out,
        "centre of gravity: {:.1} ± {:.1} mm above the ground, {:.1} ± {:.1} mm behind the \
         front axle, {:.1} ± {:.1} mm {} of the centreline",
        v.cg_height_m[0] * 1e3,
        v.cg_height_m[1] * 1e3,
        -c[0] * 1e3,
        s[0] * 1e3,
        side.abs() * 1e3,
        s[1] * 1e3,
        if side >= 0.0 { "left" } else { "right" }
    );
    for (name, split, ends) in [
        ("axle", &v.axle_loads, ["front", "rear"]),
        ("side", &v.side_loads, ["left", "right"]),
    ] {
        if let Some(l) = split {
            let _ = writeln!(
                out,
                "static {name} loads: {} {:.1} ± {:.1} kg ({:.2} %), {} {:.1} ± {:.1} kg",
                ends[0],
                l.loads_kg[0],
                l.sigma_kg[0],
                100.0 * l.share,
                ends[1],
                l.loads_kg[1],
                l.sigma_kg[1]
            );
        }
    }
    let p = v.placement_sigma.com;
    let _ = writeln!(
        out,
        "the placement's tolerance in these sigmas: com {:.2}/{:.2}/{:.2} mm",
        p[0] * 1e3,
        p[1] * 1e3,
        p[2] * 1e3
    );
    out
}

/// The line that says the printed estimate is the fit's projection onto the consistent set,
/// and how far it moved; `None` when the estimate is the fit itself.
pub fn projection_line(c: &measure::report::Consistency) -> Option<String> {
    if !c.projected {
        return None;
    }
    Some(format!(
        "estimate projected onto the physically consistent set: the nearest consistent body to \
         the fit, {} from it in the covariance's metric (the fit is the report's consistency.raw)",
        c.distance_sigma
            .map_or("an unknown distance".to_string(), |d| format!("{d:.2} σ"))
    ))
}

/// The error budget as a table: one row per source of the report's `error_budget`, columns
/// mass, com x/y/z, J_C xx yy zz xy xz yz (each one sigma of that quantity from that source
/// alone), and a total row, the rows added in quadrature: the report's sigma.
pub fn render_budget(report: &Report) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "\nerror budget (one sigma per source)\n{:<20}",
        "source"
    );
    for row in &ROWS {
        let _ = write!(out, " {:>9}", row.name);
    }
    out.push('\n');
    let _ = write!(out, "{:<20}", "");
    for row in &ROWS {
        let _ = write!(out, " {:>9}", row.unit);
    }
    out.push('\n');
    let cells = |out: &mut String, name: &str, q: &Quantities| {
        let _ = write!(out, "{name:<20}");
        for row in &ROWS {
            let _ = write!(out, " {:>9.2e}", (row.get)(q));
        }
        out.push('\n');
    };
    for line in &report.error_budget {
        cells(&mut out, &line.source, &line.sigma);
    }
    cells(&mut out, "total", &report.sigma);
    for note in &report.budget_notes {
        let _ = writeln!(out, "note: {note}");
    }
    out
}

/// Warns on standard error when the rigid-body check says the model does not explain the
/// data, naming the frequency of the residual's largest peak.
pub fn warn_rigid_body(report: &Report) {
    if let Some(w) = rigid_body_warning(report) {
        eprintln!("warning: {w}");
    }
}

/// The warning of [`warn_rigid_body`], if any.
pub fn rigid_body_warning(report: &Report) -> Option<String> {
    let r = report.rigid_body.filter(|r| !r.ok)?;
    Some(format!(
        "the rigid-body model does not explain the data: the fit residual is {:.1} times what \
         the sensors' noise and the modelled errors predict, with its largest peak at {:.2} Hz \
         (a payload that moves on the plate, e.g. a car body bouncing on its suspension); the \
         estimate and its sigma assume a rigid payload",
        r.residual_ratio, r.peak_hz
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shows_every_quantity_and_the_error() {
        let mut report = Report::default();
        report.estimate.mass = 1500.3;
        report.sigma.mass = 0.2;
        report.truth = Some(Quantities {
            mass: 1500.0,
            ..Quantities::default()
        });
        let text = render(&report);
        assert_eq!(text.lines().filter(|l| l.contains("kg·m²")).count(), 7);
        let mass = text.lines().find(|l| l.starts_with("mass")).unwrap();
        assert!(mass.contains("1500.30 ± 0.20"), "{mass}");
        assert!(mass.contains("0.300"), "{mass}");
        assert!(mass.contains("1.50"), "{mass}");
    }

    #[test]
    fn the_budget_table_has_a_row_per_source_and_the_total() {
        let mut report = Report::default();
        report.sigma.mass = 0.5;
        report.error_budget = rig_description::sources::ErrorSource::ALL
            .iter()
            .map(|s| measure::report::BudgetLine {
                source: s.id().into(),
                sigma: Quantities {
                    mass: 0.1,
                    ..Quantities::default()
                },
            })
            .collect();
        let text = render_budget(&report);
        for s in rig_description::sources::ErrorSource::ALL {
            assert!(text.lines().any(|l| l.starts_with(s.id())), "{s}");
        }
        let total = text.lines().find(|l| l.starts_with("total")).unwrap();
        assert!(total.contains("5.00e-1"), "{total}");
        assert!(text.lines().next().is_some_and(str::is_empty));
        assert!(text.contains("J_C yz"));
    }

    #[test]
    fn a_failed_rigid_body_check_names_the_frequency() {
        let mut report = Report::default();
        assert_eq!(rigid_body_warning(&report), None);
        report.rigid_body = Some(measure::budget::RigidBody {
            ok: false,
            residual_ratio: 12.0,
            peak_hz: 1.3,
        });
        let w = rigid_body_warning(&report).unwrap();
        assert!(w.contains("1.30 Hz"), "{w}");
    }

    #[test]
    fn a_projected_estimate_says_so() {
        let mut report = Report::default();
        assert!(!render(&report).contains("projected"));
        report.consistency.projected = true;
        report.consistency.distance_sigma = Some(1.234);
        let text = render(&report);
        let line = text.lines().find(|l| l.contains("projected")).unwrap();
        assert!(
            line.contains("1.23 σ") && line.contains("consistency.raw"),
            "{line}"
        );
    }

    /// Regression, configs/paper.toml: the six-parameter model's mass and centre of mass are
    /// shown as given, with no z (not `± 0.00` and a NaN err/σ).
    #[test]
    fn the_six_parameter_models_given_mass_shows_no_sigma() {
        let mut report = Report::default();
        report.run.params = 6;
        report.estimate.mass = 1500.0;
        report.estimate.inertia_com[0][0] = 600.01;
        report.sigma.inertia_com[0][0] = 0.005;
        report.truth = Some(Quantities {
            mass: 1500.0,
            inertia_com: [[600.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
            ..Quantities::default()
        });
        let text = render(&report);
        let mass = text.lines().find(|l| l.starts_with("mass")).unwrap();
        assert!(mass.contains("(given)") && !mass.contains('±'), "{mass}");
        assert!(!text.contains("NaN"), "{text}");
        let xx = text.lines().find(|l| l.starts_with("J_C xx")).unwrap();
        assert!(xx.contains('±') && xx.contains("2.00"), "{xx}");
    }

    #[test]
    fn no_truth_columns_without_truth() {
        let text = render(&Report::default());
        assert!(!text.contains("truth"));
    }
}
