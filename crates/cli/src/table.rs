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

/// The table as text, one quantity per line.
pub fn render(report: &Report) -> String {
    let mut out = String::new();
    let with_truth = report.truth.is_some();
    let _ = write!(
        out,
        "{:<8} {:<6} {:>28}",
        "quantity", "unit", "estimate ± 1σ"
    );
    if with_truth {
        let _ = write!(out, " {:>13} {:>12} {:>7}", "truth", "error", "err/σ");
    }
    out.push('\n');
    for row in &ROWS {
        let est = (row.get)(&report.estimate);
        let sig = (row.get)(&report.sigma);
        let d = decimals_for(sig, est);
        let cell = format!("{} ± {}", fixed(est, d), fixed(sig, d));
        let _ = write!(out, "{:<8} {:<6} {:>28}", row.name, row.unit, cell);
        if let Some(truth) = &report.truth {
            let t = (row.get)(truth);
            let err = est - t;
            let z = if sig > 0.0 { err / sig } else { f64::NAN };
            let _ = write!(
                out,
                " {:>13} {:>12} {:>7.2}",
                fixed(t, d),
                fixed(err, d + 1),
                z
            );
        }
        out.push('\n');
    }
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
    out
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
    fn no_truth_columns_without_truth() {
        let text = render(&Report::default());
        assert!(!text.contains("truth"));
    }
}
