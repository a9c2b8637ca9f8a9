//! The report read into a checked [`Payload`]: the fields `estimate` and `sigma`
//! ([`measure::report::Quantities`]: mass in kg, centre of mass in m in the platform frame P,
//! J_C = ∫(‖r‖²𝟙 − r rᵀ) dm about the centre of mass in P axes, kg·m²) and, for the
//! provenance comment, `run`. Everything else in the report is ignored, so a report with more
//! fields, or one written before a field existed, reads the same.

use measure::report::Quantities;
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;
use stewart_types::{Inconsistency, InertialParameters};

use crate::principal::PrincipalFrame;

/// Why a report cannot be exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The report file could not be read.
    #[error("cannot read the report {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The text is not JSON, or a field is missing or of the wrong type.
    #[error("the report is not a measurement report: {0}")]
    Json(String),
    /// A campaign report (`simulate --runs N`) holds many measurements, not one.
    #[error(
        "this is a campaign report (`simulate --runs`: its `reports` list holds one report per \
         run, {runs} here), not one measurement: export one run's report (`simulate --report` \
         with its seed, or `estimate LOG --report`)"
    )]
    Campaign {
        /// How many reports it holds.
        runs: usize,
    },
    /// A value is not physical (or not finite).
    #[error("{field}: {problem}")]
    Invalid {
        /// The field of the report, as a JSON path (`estimate.mass`, `sigma.com[2]`).
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The output could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
}

impl From<measure::report::ReportTextError> for ExportError {
    fn from(e: measure::report::ReportTextError) -> Self {
        match e {
            measure::report::ReportTextError::Campaign { runs } => Self::Campaign { runs },
            measure::report::ReportTextError::Json(message) => Self::Json(message),
            other => Self::Json(other.to_string()),
        }
    }
}

/// What the export reads of a report.
#[derive(Debug, Deserialize)]
struct ReportView {
    estimate: Quantities,
    sigma: Quantities,
    #[serde(default)]
    run: RunView,
    /// The vehicle-frame results, when the report has them: exported instead of P's.
    #[serde(default)]
    vehicle: Option<VehicleView>,
}

/// The report's `vehicle` section as the export reads it.
#[derive(Debug, Deserialize)]
struct VehicleView {
    frame: String,
    estimate: Quantities,
    sigma: Quantities,
}

/// The plate frame P in words, for a file without a vehicle frame.
pub const PLATE_FRAME: &str = "the plate frame P of the rig measured on: origin at the centre \
    of the plate's joint circle, in the joints' plane (or the frame the rig description's plate \
    joints are given in), z along the plate's normal, up at the home pose";

/// The part of the report's `run` the provenance comment names; any of it may be absent.
#[derive(Debug, Default, Deserialize)]
struct RunView {
    #[serde(default)]
    backend: Option<String>,
    #[serde(default)]
    seed: Option<u64>,
    #[serde(default)]
    log: Option<String>,
}

/// The payload's measured inertial element, checked: m > 0, J_C symmetric (its upper triangle
/// is used), positive definite and within the triangle inequality, every sigma finite and ≥ 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Payload {
    /// The report's `estimate`, J_C made exactly symmetric from its upper triangle.
    pub estimate: Quantities,
    /// The report's `sigma`: one standard deviation of each entry of `estimate`.
    pub sigma: Quantities,
    /// The principal frame of J_C.
    pub principal: PrincipalFrame,
    /// Where the numbers came from (the report's file and run), for the documents' comments.
    pub provenance: String,
    /// The frame of `estimate`, in words: the vehicle's when the report places the payload
    /// as a vehicle, else [`PLATE_FRAME`].
    pub frame: String,
}

/// Relative asymmetry of J_C tolerated (JSON keeps every f64, so a report's tensor is
/// symmetric to rounding).
const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// Reads the report at `path` ([`parse`]).
pub fn load(path: &std::path::Path) -> Result<Payload, ExportError> {
    let text = rig_description::bounded::read_to_string_capped(
        path,
        rig_description::bounded::REPORT_CAP_BYTES,
        "a report",
    )
    .map_err(|source| ExportError::Read {
        path: path.display().to_string(),
        source,
    })?;
    parse(&text, &path.display().to_string())
}

/// Reads a report's JSON text; `source` names it in the provenance comment.
pub fn parse(text: &str, source: &str) -> Result<Payload, ExportError> {
    let value = measure::report::one_measurement(text).map_err(ExportError::from)?;
    let view: ReportView = serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        ExportError::Json(format!("`{path}`: {}", e.into_inner()))
    })?;
    let mut provenance = format!("report {source}");
    if let Some(b) = &view.run.backend {
        provenance.push_str(&format!(", backend {b}"));
    }
    if let Some(s) = view.run.seed {
        provenance.push_str(&format!(", seed {s}"));
    }
    if let Some(l) = &view.run.log {
        provenance.push_str(&format!(", log {l}"));
    }
    match view.vehicle {
        Some(v) => {
            let mut p = checked(v.estimate, v.sigma, provenance)?;
            p.frame = format!("the {}", v.frame);
            Ok(p)
        }
        None => checked(view.estimate, view.sigma, provenance),
    }
}

/// Every number of `q` with its JSON path under `prefix`.
fn entries(prefix: &str, q: &Quantities) -> Vec<(String, f64)> {
    let mut out = vec![(format!("{prefix}.mass"), q.mass)];
    for (i, v) in q.com.iter().enumerate() {
        out.push((format!("{prefix}.com[{i}]"), *v));
    }
    for (r, row) in q.inertia_com.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            out.push((format!("{prefix}.inertia_com[{r}][{c}]"), *v));
        }
    }
    out
}

fn invalid(field: &str, problem: String) -> ExportError {
    ExportError::Invalid {
        field: field.to_string(),
        problem,
    }
}

/// The checks of [`Payload`], in the order: finite, sigma ≥ 0, m > 0, J_C symmetric, then the
/// consistency rule of [`InertialParameters::consistency`] (J_C positive definite, A + B ≥ C).
pub fn checked(
    estimate: Quantities,
    sigma: Quantities,
    provenance: String,
) -> Result<Payload, ExportError> {
    for (field, v) in entries("estimate", &estimate) {
        if !v.is_finite() {
            return Err(invalid(&field, format!("{v} is not a finite number")));
        }
    }
    for (field, v) in entries("sigma", &sigma) {
        if !(v.is_finite() && v >= 0.0) {
            return Err(invalid(
                &field,
                format!("{v} is not a standard deviation (finite, not negative)"),
            ));
        }
    }
    if estimate.mass <= 0.0 {
        return Err(invalid(
            "estimate.mass",
            format!("{} kg is not a positive mass", estimate.mass),
        ));
    }
    let j = Matrix3::from_fn(|r, c| estimate.inertia_com[r][c]);
    let scale = j.amax();
    for (r, c) in [(0, 1), (0, 2), (1, 2)] {
        if (j[(r, c)] - j[(c, r)]).abs() > SYMMETRY_TOLERANCE * scale {
            return Err(invalid(
                "estimate.inertia_com",
                format!(
                    "not symmetric: [{r}][{c}] = {} but [{c}][{r}] = {}",
                    j[(r, c)],
                    j[(c, r)]
                ),
            ));
        }
    }
    let j = Matrix3::from_fn(|r, c| j[(r.min(c), r.max(c))]);
    let com = Vector3::from(estimate.com);
    let body = InertialParameters::from_com(estimate.mass, com, j);
    let moments = stewart_types::principal_of(&j)
        .map(|p| {
            let m = p.moments_kg_m2;
            format!("principal moments {} {} {} kg m^2", m.x, m.y, m.z)
        })
        .unwrap_or_default();
    match body.consistency().first_failure() {
        None => {}
        Some(Inconsistency::MassNotPositive) => {
            return Err(invalid("estimate.mass", "not a positive mass".into()))
        }
        Some(fail) => {
            return Err(invalid(
                "estimate.inertia_com",
                format!("J_C is not a body's: {fail} ({moments})"),
            ))
        }
    }
    let principal = PrincipalFrame::of(&j).ok_or_else(|| {
        invalid(
            "estimate.inertia_com",
            "its principal axes do not form a proper rotation (det +1)".into(),
        )
    })?;
    let mut estimate = estimate;
    estimate.inertia_com = core::array::from_fn(|r| core::array::from_fn(|c| j[(r, c)]));
    Ok(Payload {
        estimate,
        sigma,
        principal,
        provenance,
        frame: PLATE_FRAME.into(),
    })
}
