//! What `--plot DIR` draws, as plain series ([`Figures`]): each estimated quantity over time
//! with its ±1σ band and, where known, the truth (the paper's Figures 3–8), the legs'
//! tracking error and the excitation. The drawing is the front end's; these series are all it
//! needs.
//!
//! The series come either from a log ([`figures_from_log`], what `simulate` and `rig` draw)
//! or from an offline re-run ([`figures_from_reestimate`], what `estimate` draws,
//! [`figures_of_estimate`]). Time is in seconds from the
//! start of the measurement's excitation (the estimator's first sample), so settling shows at
//! negative times. `sigma_course` sets the payload's sigma the run achieved beside the one
//! `stewart plan` predicts for the log's excitation ([`course`]).

pub mod course;

use std::path::Path;

use estimator::{Estimate, InertialParameters, ParameterVector};

use measure::replay::ReplayOutcome;
use measure::TareFile;
use runlog::metadata::BodyTruth;
use runlog::read::{BodyRecord, LogContents};

pub use course::{course_csv, course_of_log, predicted_course, PredictedCourse, COURSE_POINTS};

/// Why there is nothing to draw.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The log has no sensor frames.
    #[error("the log has no sensor frames, so nothing to plot")]
    NoFrames,
    /// The log could not be read.
    #[error("{0:#}")]
    Log(anyhow::Error),
}

/// One quantity over time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParameterSeries {
    /// File stem, e.g. `J_xy`.
    pub stem: &'static str,
    /// Title, e.g. `J_C xy`.
    pub title: &'static str,
    /// Unit for the axis, e.g. `kg·m²`.
    pub unit: &'static str,
    /// Time from the excitation's start, s.
    pub time_s: Vec<f64>,
    /// The estimate.
    pub value: Vec<f64>,
    /// Its one sigma.
    pub sigma: Vec<f64>,
    /// The truth, when known.
    pub truth: Option<f64>,
}

/// The six legs' tracking error over time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrackingSeries {
    /// Time from the excitation's start, s.
    pub time_s: Vec<f64>,
    /// Desired − measured length of each leg, m.
    pub error_m: [Vec<f64>; 6],
}

/// The commanded motion over time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExcitationSeries {
    /// Time from the excitation's start, s.
    pub time_s: Vec<f64>,
    /// Desired position of the P origin in B, relative to its first value, m.
    pub position_m: [Vec<f64>; 3],
    /// Desired roll, pitch, yaw, rad.
    pub rpy_rad: [Vec<f64>; 3],
}

/// Everything the figures show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Figures {
    /// What is shown (e.g. `payload, loaded run`), for the overview's caption.
    pub subject: String,
    /// Mass, centre of mass x/y/z, J_C xx, yy, zz, xy, xz, yz.
    pub parameters: Vec<ParameterSeries>,
    /// Leg tracking error (when the log has `/legs`).
    pub tracking: Option<TrackingSeries>,
    /// Excitation (when the log has `/pose`).
    pub excitation: Option<ExcitationSeries>,
    /// The payload's sigma as `stewart plan` predicts it over the excitation, for the
    /// `sigma_course` figure beside the achieved sigma of `parameters` (when the log's rig
    /// description can be planned for and the figures are the payload's).
    pub course: Option<PredictedCourse>,
}

/// Each quantity's file stem, title and unit, in the order of the series.
pub const NAMES: [(&str, &str, &str); 10] = [
    ("mass", "mass", "kg"),
    ("com_x", "centre of mass x", "m"),
    ("com_y", "centre of mass y", "m"),
    ("com_z", "centre of mass z", "m"),
    ("J_xx", "J_C xx", "kg·m²"),
    ("J_yy", "J_C yy", "kg·m²"),
    ("J_zz", "J_C zz", "kg·m²"),
    ("J_xy", "J_C xy", "kg·m²"),
    ("J_xz", "J_C xz", "kg·m²"),
    ("J_yz", "J_C yz", "kg·m²"),
];

const TENSOR: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// The ten reported quantities of one body, values and sigmas, in [`NAMES`] order.
fn ten(
    mass: f64,
    mass_sigma: f64,
    com: &[f64; 3],
    com_sigma: &[f64; 3],
    j: &[[f64; 3]; 3],
    j_sigma: &[[f64; 3]; 3],
) -> ([f64; 10], [f64; 10]) {
    let mut v = [0.0; 10];
    let mut s = [0.0; 10];
    v[0] = mass;
    s[0] = mass_sigma;
    v[1..4].copy_from_slice(com);
    s[1..4].copy_from_slice(com_sigma);
    for (k, (r, c)) in TENSOR.iter().enumerate() {
        v[4 + k] = j[*r][*c];
        s[4 + k] = j_sigma[*r][*c];
    }
    (v, s)
}

fn of_record(b: &BodyRecord) -> ([f64; 10], [f64; 10]) {
    ten(
        b.mass_kg,
        b.mass_sigma_kg,
        &b.com_m,
        &b.com_sigma_m,
        &b.inertia_com_kg_m2,
        &b.inertia_com_sigma_kg_m2,
    )
}

fn rows(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    core::array::from_fn(|r| core::array::from_fn(|c| m[(r, c)]))
}

fn of_estimate(e: &Estimate) -> ([f64; 10], [f64; 10]) {
    ten(
        e.parameters.mass_kg,
        e.mass_sigma_kg,
        &e.com_m.into(),
        &e.com_sigma_m.into(),
        &rows(&e.inertia_com_kg_m2),
        &rows(&e.inertia_com_sigma_kg_m2),
    )
}

fn params_of(t: &BodyTruth) -> InertialParameters {
    InertialParameters::from_vector(&ParameterVector::from_row_slice(&t.theta))
}

/// The ten quantities of a body given by θ (NaN where its mass is not positive).
fn truth_values(p: &InertialParameters) -> Option<[f64; 10]> {
    let com = p.com_m()?;
    let j = p.inertia_com_kg_m2()?;
    Some(
        ten(
            p.mass_kg,
            0.0,
            &com.into(),
            &[0.0; 3],
            &rows(&j),
            &[[0.0; 3]; 3],
        )
        .0,
    )
}

/// Which body's truth applies: the payload's (tare subtracted), everything on the plate in the
/// loaded run, or the fixture in the tare run.
fn truth_of(log: &LogContents, run: &str, payload: bool) -> Option<[f64; 10]> {
    let t = log.truth.as_ref()?;
    let p = match (run, payload) {
        ("tare", _) => params_of(&t.fixture),
        (_, true) => params_of(&t.payload),
        (_, false) => params_of(&t.fixture) + params_of(&t.payload),
    };
    truth_values(&p)
}

fn series(
    times: &[f64],
    values: &[([f64; 10], [f64; 10])],
    truth: Option<[f64; 10]>,
) -> Vec<ParameterSeries> {
    NAMES
        .iter()
        .enumerate()
        .map(|(k, (stem, title, unit))| ParameterSeries {
            stem,
            title,
            unit,
            time_s: times.to_vec(),
            value: values.iter().map(|(v, _)| v[k]).collect(),
            sigma: values.iter().map(|(_, s)| s[k]).collect(),
            truth: truth.map(|t| t[k]),
        })
        .collect()
}

/// Time origin of measurement `run`: its excitation's start, else its first frame.
fn origin_s(log: &LogContents, run: &str) -> f64 {
    log.settings_of(run)
        .and_then(|s| s.window_start_s)
        .or_else(|| log.sensors_of(run).next().map(|s| s.time_s))
        .unwrap_or(0.0)
}

fn tracking_and_excitation(
    log: &LogContents,
    run: &str,
    t0: f64,
) -> (Option<TrackingSeries>, Option<ExcitationSeries>) {
    let legs: Vec<_> = log.legs.iter().filter(|l| l.run == run).collect();
    let tracking = (!legs.is_empty()).then(|| TrackingSeries {
        time_s: legs.iter().map(|l| l.time_s - t0).collect(),
        error_m: core::array::from_fn(|i| legs.iter().map(|l| l.error_m[i]).collect()),
    });
    let poses: Vec<_> = log.poses.iter().filter(|p| p.run == run).collect();
    let excitation = poses.first().map(|first| {
        let p0 = first.desired.position_m;
        ExcitationSeries {
            time_s: poses.iter().map(|p| p.time_s - t0).collect(),
            position_m: core::array::from_fn(|i| {
                poses
                    .iter()
                    .map(|p| p.desired.position_m[i] - p0[i])
                    .collect()
            }),
            rpy_rad: core::array::from_fn(|i| poses.iter().map(|p| p.desired.rpy_rad[i]).collect()),
        }
    });
    (tracking, excitation)
}

/// The measurement to show: `loaded` when the log has it, else the last one.
pub fn main_run(log: &LogContents) -> Option<String> {
    let runs = log.runs();
    if runs.iter().any(|r| r == "loaded") {
        Some("loaded".into())
    } else {
        runs.last().cloned()
    }
}

/// Figures from a log's own channels: the online `/estimate` (the payload's when a tare was
/// known, else everything on the plate), `/legs`, `/pose` and `/run/truth`.
pub fn figures_from_log(log: &LogContents) -> Result<Figures, Error> {
    let run = main_run(log).ok_or(Error::NoFrames)?;
    let t0 = origin_s(log, &run);
    let estimates: Vec<_> = log.estimates.iter().filter(|e| e.run == run).collect();
    let payload = estimates.last().is_some_and(|e| e.payload.is_some());
    let times: Vec<f64> = estimates.iter().map(|e| e.time_s - t0).collect();
    let values: Vec<_> = estimates
        .iter()
        .map(|e| match (&e.payload, payload) {
            (Some(p), true) => of_record(p),
            _ => of_record(&e.body),
        })
        .collect();
    let (tracking, excitation) = tracking_and_excitation(log, &run, t0);
    Ok(Figures {
        subject: subject(&run, payload),
        parameters: series(&times, &values, truth_of(log, &run, payload)),
        tracking,
        excitation,
        course: (payload && run == "loaded")
            .then(|| course_of_log(log))
            .flatten(),
    })
}

fn subject(run: &str, payload: bool) -> String {
    if payload {
        format!("payload (tare subtracted), {run} run")
    } else {
        format!("everything on the plate, {run} run")
    }
}

/// Figures from an offline re-run (`replay`) of measurement `run`, with `tare` subtracted.
pub fn figures_from_reestimate(
    log: &LogContents,
    run: &str,
    replay: &ReplayOutcome,
    tare: &TareFile,
) -> Figures {
    let t0 = origin_s(log, run);
    let (tp, tc) = (tare.parameters(), tare.covariance_matrix());
    let times: Vec<f64> = replay.trace.iter().map(|p| p.time_s - t0).collect();
    let values: Vec<_> = replay
        .trace
        .iter()
        .map(|p| of_estimate(&p.estimate.without_tare(&tp, &tc)))
        .collect();
    let (tracking, excitation) = tracking_and_excitation(log, run, t0);
    Figures {
        subject: subject(run, true),
        parameters: series(&times, &values, truth_of(log, run, true)),
        tracking,
        excitation,
        course: (run == "loaded").then(|| course_of_log(log)).flatten(),
    }
}

/// The figures of an `estimate` run on the log at `log_path` (read whole: the figures show
/// its 1 kHz channels too), with the rig description `estimate` was given for a log whose
/// metadata was lost.
pub fn figures_of_estimate(
    log_path: &Path,
    estimate: &ops::estimate::EstimateOutcome,
) -> Result<Figures, Error> {
    let mut log = LogContents::read(log_path).map_err(Error::Log)?;
    log.or_metadata_of(estimate.rig.as_ref())
        .map_err(Error::Log)?;
    let loaded = &estimate.loaded;
    Ok(figures_from_reestimate(
        &log,
        &loaded.run,
        &loaded.replay,
        &estimate.tare,
    ))
}

/// The smallest and largest finite value, if any.
pub fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// A range around `(lo, hi)` padded by 10 %, never empty.
pub fn padded((lo, hi): (f64, f64)) -> (f64, f64) {
    let span = hi - lo;
    let pad = if span > 0.0 {
        0.1 * span
    } else {
        0.05 * lo.abs().max(1e-6)
    };
    (lo - pad, hi + pad)
}

/// The time axis: the finite times' range, never empty.
pub fn time_range(t: &[f64]) -> (f64, f64) {
    match finite_range(t.iter().copied()) {
        Some((a, b)) if b > a => (a, b),
        Some((a, _)) => (a, a + 1.0),
        None => (0.0, 1.0),
    }
}

/// The value axis: the settled half of the estimate with its band, and the truth, so the
/// first samples' wild values (the estimator starts from a weak prior) are clipped at the
/// frame instead of squashing the converged curve flat.
pub fn value_range(p: &ParameterSeries) -> (f64, f64) {
    let n = p.value.len();
    let from = n / 2;
    let band = (from..n).flat_map(|i| {
        let (v, s) = (p.value[i], p.sigma.get(i).copied().unwrap_or(0.0));
        let s = if s.is_finite() { s } else { 0.0 };
        [v - s, v + s]
    });
    let r = finite_range(band.chain(p.truth))
        .or_else(|| finite_range(p.value.iter().copied()))
        .unwrap_or((0.0, 1.0));
    padded(r)
}

/// The ±σ band of `p` as quads between consecutive picked samples, at most about
/// `max_quads` (every sample, or every n-th and the last), each corner clamped into
/// `[lo, hi]`; a quad with a non-finite end is left out.
pub fn band_quads(
    p: &ParameterSeries,
    (lo, hi): (f64, f64),
    max_quads: usize,
) -> Vec<[(f64, f64); 4]> {
    let clamp = |v: f64| v.clamp(lo, hi);
    let step = (p.value.len() / max_quads.max(1)).max(1);
    let finite = |i: usize| {
        let s = p.sigma.get(i).copied().unwrap_or(f64::NAN);
        (p.time_s[i].is_finite() && p.value[i].is_finite() && s.is_finite())
            .then(|| (p.time_s[i], clamp(p.value[i] - s), clamp(p.value[i] + s)))
    };
    let picks: Vec<usize> = (0..p.value.len())
        .step_by(step)
        .chain(p.value.len().checked_sub(1))
        .collect();
    picks
        .windows(2)
        .filter_map(|w| {
            let ((t0, lo0, hi0), (t1, lo1, hi1)) = (finite(w[0])?, finite(w[1])?);
            Some([(t0, lo0), (t0, hi0), (t1, hi1), (t1, lo1)])
        })
        .collect()
}

/// The estimate of `p` as a line: its finite samples, clamped into `[lo, hi]`.
pub fn estimate_line(p: &ParameterSeries, (lo, hi): (f64, f64)) -> Vec<(f64, f64)> {
    p.time_s
        .iter()
        .zip(&p.value)
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .map(|(t, v)| (*t, v.clamp(lo, hi)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_follow_the_settled_half() {
        let p = ParameterSeries {
            value: vec![1e6, -1e6, 10.0, 10.0],
            sigma: vec![1e6, 1e6, 1.0, 1.0],
            time_s: vec![0.0, 1.0, 2.0, 3.0],
            truth: Some(10.5),
            ..ParameterSeries::default()
        };
        let (lo, hi) = value_range(&p);
        assert!(lo < 9.0 && lo > 8.0, "{lo}");
        assert!(hi > 11.0 && hi < 12.0, "{hi}");
        let empty = ParameterSeries::default();
        let (lo, hi) = value_range(&empty);
        assert!(hi > lo);
    }
}
