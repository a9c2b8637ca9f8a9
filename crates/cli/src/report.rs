//! The JSON report (`--report FILE.json`), in exactly the shape DESIGN.md gives, plus extra
//! fields (residual, rejected samples, consistency verdict, the tare used, run settings).
//!
//! Everything is for the payload alone (tare removed), `com` in metres in P, `inertia_com` = J_C
//! in kg·m² in P axes, `sigma` one standard deviation of each entry.

use serde::{Deserialize, Serialize};

/// Mass, centre of mass and inertia about the centre of mass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quantities {
    /// kg.
    pub mass: f64,
    /// Centre of mass in P, m.
    pub com: [f64; 3],
    /// J_C in P axes, kg·m².
    pub inertia_com: [[f64; 3]; 3],
}

/// Principal moments (ascending) and axes (row k is the unit axis of moment k, in P).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Principal {
    /// kg·m², ascending.
    pub moments: [f64; 3],
    /// Row k: the unit axis (in P) of `moments[k]`.
    pub axes: [[f64; 3]; 3],
}

/// How fast the estimate settled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    /// First sample after which every parameter stays within 1 % of its final value; `null`
    /// if never.
    pub samples_to_1pct: Option<u64>,
}

/// RMS of the fit residual per equation, on the loaded run's data (the best detector of timing
/// and model errors).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ResidualRms {
    /// Force equations x, y, z, N.
    pub force_n: [f64; 3],
    /// Torque equations x, y, z (about the P origin), N·m.
    pub torque_nm: [f64; 3],
}

/// Physical-consistency verdict on the payload estimate.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Consistency {
    /// `"consistent"` or `"inconsistent"`.
    pub verdict: String,
    /// What failed, if anything (mass not positive, J_C not positive definite, triangle
    /// inequality broken).
    pub problems: Vec<String>,
}

/// The tare (empty fixture) subtracted from the loaded estimate.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TareUsed {
    /// `"measured"` (tare run in this invocation), `"file"`, or `"none"`.
    pub source: String,
    /// The tare file, when one was loaded.
    pub file: Option<String>,
    /// The fixture's parameters θ about the P origin ([m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz,
    /// Jyz]).
    pub theta: [f64; 10],
    /// One standard deviation of each entry of `theta`.
    pub sigma: [f64; 10],
    /// The fixture's mass, centre of mass and J_C.
    pub estimate: Quantities,
}

/// The systematic part of `sigma` (already included in it): the accelerometer bias's effect.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Systematic {
    /// One sigma of the accelerometer bias assumed (datasheet), m/s².
    pub accel_bias_sigma_m_s2: f64,
    /// One sigma of each entry due to that bias alone.
    pub sigma: Quantities,
}

/// How the run was made (enough to repeat it).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunInfo {
    /// Scenario file, or the embedded default.
    pub config: String,
    /// Random seed.
    pub seed: u64,
    /// Noise preset.
    pub noise: String,
    /// 10 or 6.
    pub params: u8,
    /// MCAP log written, if any.
    pub log: Option<String>,
    /// Backend that produced the data (`"sim"`, `"rig"`).
    pub backend: String,
}

/// The report. Field order and names follow DESIGN.md; fields after `convergence` are extras.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The payload's estimate.
    pub estimate: Quantities,
    /// One standard deviation of each entry of `estimate`.
    pub sigma: Quantities,
    /// Ground truth, only where it is known (simulation).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub truth: Option<Quantities>,
    /// Principal moments and axes of the estimated J_C.
    pub principal: Principal,
    /// Samples the loaded run's estimator used.
    pub samples: u64,
    /// Excitation time of the loaded run, s.
    pub excitation_s: f64,
    /// Convergence of the loaded run's estimate.
    pub convergence: Convergence,
    /// Fit residual, RMS per equation.
    pub residual_rms: ResidualRms,
    /// Samples refused by the estimator's input checks (non-finite, out of range, gaps).
    pub rejected_samples: u64,
    /// Physical-consistency verdict.
    pub consistency: Consistency,
    /// The tare subtracted.
    pub tare: TareUsed,
    /// The systematic part of `sigma` (accelerometer bias), included in `sigma`.
    #[serde(default)]
    pub systematic: Systematic,
    /// How the run was made.
    pub run: RunInfo,
}

impl Report {
    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The DESIGN.md shape: these keys, these nestings, these array sizes.
    #[test]
    fn json_has_the_design_shape() {
        let report = Report {
            truth: Some(Quantities::default()),
            ..Report::default()
        };
        let v: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
        for part in ["estimate", "sigma", "truth"] {
            assert!(v[part]["mass"].is_number(), "{part}.mass");
            assert_eq!(v[part]["com"].as_array().unwrap().len(), 3);
            let j = v[part]["inertia_com"].as_array().unwrap();
            assert_eq!(j.len(), 3);
            assert!(j.iter().all(|r| r.as_array().unwrap().len() == 3));
        }
        assert_eq!(v["principal"]["moments"].as_array().unwrap().len(), 3);
        assert_eq!(v["principal"]["axes"].as_array().unwrap().len(), 3);
        assert!(v["samples"].is_u64());
        assert!(v["excitation_s"].is_number());
        assert!(v["convergence"]["samples_to_1pct"].is_null());
    }

    #[test]
    fn truth_is_absent_when_unknown() {
        let v: serde_json::Value = serde_json::from_str(&Report::default().to_json()).unwrap();
        assert!(v.get("truth").is_none());
    }

    #[test]
    fn round_trips() {
        let mut report = Report::default();
        report.estimate.mass = 1500.25;
        report.convergence.samples_to_1pct = Some(42);
        let back: Report = serde_json::from_str(&report.to_json()).unwrap();
        assert_eq!(back, report);
    }
}
