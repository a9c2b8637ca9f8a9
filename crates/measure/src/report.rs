//! The JSON report (`--report FILE.json`): `estimate`, `sigma`, `truth` (when known),
//! `principal`, `samples`, `excitation_s`, `convergence`, `residual_rms` (docs/log-schema.md
//! gives every field), plus rejected samples, the consistency verdict, the tare used, the
//! error budget (each source's one sigma of every quantity; `sigma` is their sum in
//! quadrature), the rigid-body check, the systematic part and the run's settings.
//!
//! Everything is for the payload alone (tare removed), `com` in metres in P, `inertia_com` = J_C
//! in kg·m² in P axes, `sigma` one standard deviation of each entry.

use estimator::Estimate;
use serde::{Deserialize, Serialize};

use crate::budget::{RunBudget, SourceEffects};
use crate::tare::TareFile;
use rig_description::config::ParamCount;
use rig_description::sources::ErrorSource;

pub use rig_description::quantities::{principal_of, quantities, sigmas, Principal, Quantities};

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

mod consistency;
pub use consistency::{consistency_of, Consistency, RawEstimate};
mod weighing;
pub use weighing::{
    apply_prior, section as static_weighing_section, static_weighing_of, PriorError,
    StaticWeighingReport, WeighingCheck,
};

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
    /// One sigma of `estimate` with every error source of the rig description: the tare run's
    /// covariance plus each elementary error's effect on the tare run alone (its error budget,
    /// [`crate::budget::payload_covariances`] with nothing to subtract), what the fixture itself
    /// is measured to. `sigma` above is the covariance alone; most of the sources cancel in the
    /// payload (loaded − tare) but not here. `null` when the tare carries no error budget.
    #[serde(default)]
    pub own_sigma: Option<Quantities>,
}

/// One source's line of the error budget.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BudgetLine {
    /// The source's id ([`rig_description::sources::ErrorSource::id`]).
    pub source: String,
    /// One sigma of each reported quantity from this source alone.
    pub sigma: Quantities,
}

/// The systematic part of `sigma` (already included in it): the error budget's sources other
/// than `noise`, `frame_loss` and `timestamp_jitter`, added in quadrature.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Systematic {
    /// One sigma of the accelerometer bias assumed (datasheet), m/s².
    pub accel_bias_sigma_m_s2: f64,
    /// One sigma of each load cell's zero offset assumed (datasheet), N.
    #[serde(default)]
    pub load_cell_bias_sigma_n: f64,
    /// One sigma of each entry from the systematic sources together.
    pub sigma: Quantities,
}

/// SHA-256 of a rig description as the log records it ([`rig_description::LoadedConfig::effective_toml`]'s
/// text), lower-case hex: what the certificate names the description by.
pub fn description_sha256(config: &rig_description::Config) -> String {
    sha256_hex(&toml::to_string(config).unwrap_or_default())
}

pub use rig_description::digest::sha256_hex;

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
    /// The tool and its version that produced this report (`stewart 0.1.0`; empty when not
    /// recorded).
    #[serde(default)]
    pub tool: String,
    /// When the measurement began, Unix seconds (UTC): the log's start (`null` when not
    /// recorded).
    #[serde(default)]
    pub started_unix_s: Option<u64>,
    /// When its last run ended, Unix seconds (UTC; `null` when not recorded, as in a
    /// re-estimate from a log).
    #[serde(default)]
    pub ended_unix_s: Option<u64>,
    /// The calibrations the measurement applied, with their dates.
    #[serde(default)]
    pub calibrations: Vec<rig_description::calibration::AppliedCalibration>,
    /// The measurement's and the rig's identification (`[certificate]`).
    #[serde(default)]
    pub certificate: rig_description::config::CertificateConfig,
    /// SHA-256 of the rig description the run used, as the log records it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description_sha256: Option<String>,
    /// The site's gravity the estimate used, m/s² (`estimator.local_gravity_m_s2`, else
    /// standard gravity).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub local_gravity_m_s2: Option<f64>,
}

/// A span of the log lost to damage.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LostSpan {
    /// Log time of the last message read before it, s from the log's first message (`null`:
    /// none before it).
    pub from_s: Option<f64>,
    /// Log time of the first message read after it, s (`null`: none after it).
    pub to_s: Option<f64>,
    /// `/sensors` frames lost in it, by the sequence numbers either side (`null`: unknown).
    pub sensor_frames: Option<u64>,
    /// What was wrong.
    pub reason: String,
}

/// A span of a measurement's `/sensors` frames, by their sequence numbers, that came out of
/// place, came again, or never came, and what was done with it.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameSpan {
    /// Measurement (`tare`, `loaded`).
    pub run: String,
    /// Sequence number of the span's first frame.
    pub first_sequence: u64,
    /// Sequence number of its last frame.
    pub last_sequence: u64,
    /// Frames in it.
    pub frames: u64,
    /// Backend time of its first frame, s (of a missing span: the frame before it).
    pub from_time_s: f64,
    /// Backend time of its last frame, s (of a missing span: the frame after it).
    pub to_time_s: f64,
    /// What was done: `put back in order`, `dropped as duplicates`, `dropped as late` (came
    /// after later frames had been used), or `missing` (no frame of the log holds it).
    pub action: String,
}

/// What the data behind the report lacked: a log cut short, damaged spans, rejected samples.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DataLoss {
    /// Why the log ends before its footer (cut short), when it does.
    pub truncated: Option<String>,
    /// Spans of the log lost to damage.
    pub damaged: Vec<LostSpan>,
    /// Rejected share of the loaded run's samples: rejected / (used + rejected), 0 without
    /// samples.
    pub rejected_share: f64,
    /// Sample periods of the loaded run without a frame (lost), from the sequence counter.
    pub frames_lost: u64,
    /// Of those, the ones bridged by interpolation (short gaps); the rest fell in gaps that
    /// restarted the conditioning.
    pub frames_bridged: u64,
    /// Frames of the loaded run that came after a frame with a higher counter had been used
    /// (more than the reorder window late: `measure::reorder::REORDER_WINDOW` frames in the
    /// live run, `runlog::read::order::HOLD_FRAMES` in `stewart estimate`), dropped; frames
    /// less late are put back in sequence order.
    #[serde(default)]
    pub frames_late: u64,
    /// Frames of the loaded run whose counter had already come, dropped.
    #[serde(default)]
    pub frames_duplicate: u64,
    /// Spans of frames that came out of sequence order or came again, beyond a link's
    /// reordering of a few frames (a chunk of the log moved or written twice), and what was
    /// done with each; at most a few dozen per measurement.
    #[serde(default)]
    pub reordered: Vec<FrameSpan>,
    /// Spans of a whole `/sensors` block or more that no frame of the log holds (a chunk lost
    /// to damage or removed, a message the log's writer dropped).
    #[serde(default)]
    pub missing: Vec<FrameSpan>,
    /// Records that were lost and read from another copy, in words (the estimator's settings
    /// of a measurement whose first copy was damaged).
    #[serde(default)]
    pub recovered: Vec<String>,
    /// Gaps that restarted the conditioning.
    pub restarts: u64,
    /// What placed the samples in time: `"sequence"` (counter × period) or `"timestamps"`.
    pub time_base: String,
    /// RMS spread of the frames' timestamps about the sample grid, s.
    pub timestamp_jitter_rms_s: f64,
    /// Largest deviation of a timestamp from the grid, s.
    pub timestamp_jitter_max_s: f64,
    /// Relative error of the nominal sample rate measured by the timestamps (positive: slower).
    pub rate_error: f64,
}

/// What the estimator's covariance (the budget's `noise` line) was measured from: residual
/// windows of the loaded run and the tare ([`estimator::uncertainty::MIN_COVARIANCE_WINDOWS`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CovarianceBasis {
    /// Residual windows of the loaded run whose scores count (its first does not).
    /// A report that names these `loaded_blocks`, `tare_blocks` and `block_s` reads too.
    #[serde(alias = "loaded_blocks")]
    pub loaded_windows: u64,
    /// The same for the tare; `null` when not known (a tare file written without it).
    #[serde(alias = "tare_blocks")]
    pub tare_windows: Option<u64>,
    /// Length of one half-block, s (samples per half-block × sample period); each window
    /// spans two.
    #[serde(alias = "block_s")]
    pub half_block_s: f64,
    /// Degrees of freedom of each quantity's variance in the loaded run, in the order of
    /// [`Quantities::flat`] (mass, c, J_C xx, yy, zz, xy, xz, yz): how many the residual
    /// windows give along that quantity (`estimator::dof`; about G/1.2 for G equal windows, fewer
    /// where a few windows carry most of its information). Each sigma is scaled by its
    /// ν/(ν − 2); `null` where none were measured.
    #[serde(default)]
    pub loaded_degrees_of_freedom: [Option<f64>; 10],
}

/// The report. Field order and names are the report convention of docs/log-schema.md; fields
/// after `convergence` are extras.
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
    /// The error budget: one line per source of [`rig_description::sources::ErrorSource::ALL`], in that
    /// order; `sigma` is their sum in quadrature (covariances added).
    #[serde(default)]
    pub error_budget: Vec<BudgetLine>,
    /// What the budget could not know (a tare without its effects).
    #[serde(default)]
    pub budget_notes: Vec<String>,
    /// Whether the rigid-body model explains the loaded run's data ([`crate::budget::rigid`]);
    /// `null` when the run's record was too short to tell, or the rig description is ideal (no
    /// residual predicted to judge by).
    #[serde(default)]
    pub rigid_body: Option<crate::budget::RigidBody>,
    /// The systematic part of `sigma` (the budget's sources but the statistical ones),
    /// included in `sigma`.
    #[serde(default)]
    pub systematic: Systematic,
    /// How the run was made.
    pub run: RunInfo,
    /// What the data lacked (a log cut short or damaged, samples rejected).
    #[serde(default)]
    pub data: DataLoss,
    /// What the statistical part of `sigma` was measured from ([`crate::quality`] refuses a
    /// report with too few residual windows).
    #[serde(default)]
    pub covariance_basis: CovarianceBasis,
    /// The brake holds' static weighing of the payload and the tare, checked against the
    /// dynamic fit ([`crate::weigh`]); absent when a run had no weighing (a tare file without
    /// one, a log without its hold).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub static_weighing: Option<StaticWeighingReport>,
    /// The payload in the vehicle's frame ([`crate::vehicle`]), when the rig description
    /// places it (`[vehicle]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vehicle: Option<crate::vehicle::VehicleResults>,
    /// Conformity with each `[[certificate.nominal]]` value of the rig description, in the
    /// frame the results lead with (the vehicle's when given), by
    /// [`rig_description::quantities::DECISION_RULE`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub conformity: Vec<rig_description::quantities::Conformity>,
}

impl Report {
    /// Whether quantity `k` ([`Quantities::flat`]'s order) is given by the rig description
    /// rather than measured ([`ParamCount::given`]: the six-parameter model's mass and centre
    /// of mass).
    pub fn is_given(&self, k: usize) -> bool {
        ParamCount::try_from(self.run.params).is_ok_and(|p| p.given(k))
    }

    /// One sigma of every quantity from the error source `id` alone (its line of
    /// `error_budget`); `None` when the budget has no such line.
    pub fn budget_line(&self, id: &str) -> Option<&Quantities> {
        self.error_budget
            .iter()
            .find(|l| l.source == id)
            .map(|l| &l.sigma)
    }

    /// The rules of [`crate::quality`]: did the loaded run measure anything, and did the
    /// loaded run and the tare give enough residual windows for an honest sigma?
    pub fn check_quality(&self) -> Result<(), crate::quality::QualityError> {
        crate::quality::check(self.samples, self.rejected_samples)?;
        let b = &self.covariance_basis;
        crate::quality::check_covariance("loaded", b.loaded_windows, b.half_block_s)?;
        if let Some(tare) = b.tare_windows {
            crate::quality::check_covariance("tare", tare, b.half_block_s)?;
        }
        Ok(())
    }

    /// Pretty JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }
}

/// Why a report file's text is not one measurement's report.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ReportTextError {
    /// The text is not JSON.
    #[error("the report is not a measurement report: {0}")]
    Json(String),
    /// A campaign report (`simulate --runs N`): one report per run in its `reports` list.
    #[error("a campaign report of {runs} runs, not one measurement")]
    Campaign {
        /// How many reports it holds.
        runs: usize,
    },
}

/// A report file's `text` as JSON, refused when it is not JSON or is a campaign report (a
/// `reports` list and no `estimate`): what every reader of a single measurement's report
/// (the HTML page, the model export) starts from.
pub fn one_measurement(text: &str) -> Result<serde_json::Value, ReportTextError> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| ReportTextError::Json(e.to_string()))?;
    if value.get("estimate").is_none() {
        if let Some(reports) = value.get("reports").and_then(|r| r.as_array()) {
            return Err(ReportTextError::Campaign {
                runs: reports.len(),
            });
        }
    }
    Ok(value)
}

/// Where the subtracted tare came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TareKind {
    /// A tare run in the same invocation (or the same log).
    Measured,
    /// A tare file.
    File,
}

/// Everything a report is made from: the loaded measurement, the tare, the systematic part's
/// inputs and how the run was made. `simulate`, `rig` and `estimate` fill it from their own
/// sources and call [`build`], so their reports cannot drift apart.
#[derive(Clone, Debug)]
pub struct ReportInputs<'a> {
    /// The loaded run's final estimate (everything on the plate).
    pub loaded: &'a Estimate,
    /// θ after every used sample of the loaded run.
    pub theta_history: &'a ThetaHistory,
    /// Excitation time of the loaded run, s.
    pub excitation_s: f64,
    /// Loaded-run frames whose forward kinematics failed (counted as rejected).
    pub fk_failures: u64,
    /// The tare subtracted.
    pub tare: &'a TareFile,
    /// Where it came from.
    pub tare_kind: TareKind,
    /// The tare file's path, when one was given.
    pub tare_path: Option<String>,
    /// The loaded run's error-budget inputs ([`crate::budget::analyse`]); `None` counts every
    /// systematic effect of the loaded run as zero.
    pub loaded_budget: Option<&'a RunBudget>,
    /// The tare run's, when it was measured in the same sequence or log; `None` takes the tare
    /// file's own ([`TareFile::budget`], else its accelerometer-bias and load-cell-offset
    /// sensitivities alone).
    pub tare_budget: Option<&'a RunBudget>,
    /// The accelerometer bias's one sigma assumed, m/s².
    pub accel_bias_sigma_m_s2: f64,
    /// The load cells' zero-offset sigma assumed, N.
    pub load_cell_bias_sigma_n: f64,
    /// 10 or 6 parameters (which ones count for `samples_to_1pct`).
    pub params: ParamCount,
    /// The payload's truth, where known.
    pub truth: Option<Quantities>,
    /// How the run was made.
    pub run: RunInfo,
    /// The loaded run's static weighing ([`crate::weigh`]), when it has one.
    pub loaded_weighing: Option<&'a crate::weigh::StaticWeighing>,
    /// The rig description the run was measured with: the vehicle's placement (`[vehicle]`,
    /// [`crate::vehicle`]), the certificate's identification, the site's gravity and the
    /// description's SHA-256 for the report's `run`.
    pub description: Option<&'a rig_description::Config>,
}

/// The tare's budget inputs when the sequence gave none: the tare file's own, else a partial
/// one from its accelerometer-bias and load-cell-offset sensitivities (with a note), else none.
fn tare_budget_of(i: &ReportInputs<'_>, notes: &mut Vec<String>) -> Option<RunBudget> {
    if let Some(b) = i.tare_budget {
        return Some(b.clone());
    }
    if let Some(b) = &i.tare.budget {
        return Some(b.clone());
    }
    let accel = i.tare.accel_bias_effect(i.accel_bias_sigma_m_s2);
    let cells = i.tare.load_cell_bias_effect(i.load_cell_bias_sigma_n);
    if accel.is_none() && cells.is_none() {
        return None;
    }
    notes.push(
        "the tare file carries only its accelerometer-bias and load-cell-offset sensitivities: \
         its share of the other sources counts as zero, which overstates them"
            .to_string(),
    );
    let mut effects = Vec::new();
    if let Some(a) = accel {
        effects.push(SourceEffects {
            per_run: false,
            source: ErrorSource::AccelBias.id().into(),
            effects: a.to_vec(),
        });
    }
    if let Some(c) = cells {
        effects.push(SourceEffects {
            per_run: false,
            source: ErrorSource::LoadCellOffset.id().into(),
            effects: c.to_vec(),
        });
    }
    Some(RunBudget {
        effects,
        ..RunBudget::default()
    })
}

/// True for the sources of the estimator's own covariance.
pub fn is_statistical(source: ErrorSource) -> bool {
    matches!(
        source,
        ErrorSource::Noise | ErrorSource::FrameLoss | ErrorSource::TimestampJitter
    )
}

/// The report of the payload alone: loaded minus tare, its covariance the error budget's
/// ([`crate::budget::combine`]): the statistical part (both runs' covariances, split into
/// noise, frame loss and timestamp jitter) plus each systematic source's Σ d dᵀ with
/// d = loaded effect − tare effect. Each budget line is one sigma of every quantity from that
/// source's covariance through the same Jacobian as `sigma` ([`Estimate::from_parameters`]),
/// so the lines' variances add up to `sigma`'s.
pub fn build(i: &ReportInputs<'_>) -> Report {
    let tare_params = (i.tare.parameters(), i.tare.covariance_matrix());
    let mut notes = Vec::new();
    let tare_budget = tare_budget_of(i, &mut notes);
    let empty = RunBudget::default();
    let (covariances, more) = crate::budget::payload_covariances(
        i.loaded_budget.unwrap_or(&empty),
        &i.loaded.covariance,
        tare_budget.as_ref(),
        &tare_params.1,
    );
    notes.extend(more);
    let theta = i.loaded.parameters - tare_params.0;
    let total: estimator::ParameterCovariance = covariances.iter().map(|c| c.covariance).sum();
    let systematic: estimator::ParameterCovariance = covariances
        .iter()
        .filter(|c| !is_statistical(c.source))
        .map(|c| c.covariance)
        .sum();
    let mut payload = Estimate::from_parameters(theta, total);
    payload.residual_rms = i.loaded.residual_rms;
    payload.counts = i.loaded.counts;
    let error_budget = covariances
        .iter()
        .map(|c| BudgetLine {
            source: c.source.id().into(),
            sigma: sigmas(&Estimate::from_parameters(theta, c.covariance)),
        })
        .collect();
    let systematic_only = Estimate::from_parameters(theta, systematic);
    let (consistency, reported) = consistency_of(&payload);
    let tare_estimate = Estimate::from_parameters(tare_params.0, tare_params.1);
    let tare_own_sigma = tare_budget.as_ref().map(|b| {
        let (alone, _) = crate::budget::payload_covariances(
            b,
            &tare_params.1,
            Some(&empty),
            &estimator::ParameterCovariance::zeros(),
        );
        let own: estimator::ParameterCovariance = alone.iter().map(|c| c.covariance).sum();
        sigmas(&Estimate::from_parameters(tare_params.0, own))
    });
    let vehicle = i
        .description
        .and_then(|d| d.vehicle.as_ref())
        .and_then(|v| {
            let mut r = crate::vehicle::results(v, &reported.parameters, &total)?;
            r.truth = i
                .truth
                .zip(crate::vehicle::Placement::of(v))
                .map(|(t, at)| at.quantities(&t));
            Some(r)
        });
    let estimate = quantities(&reported);
    let sigma = sigmas(&payload);
    let conformity = i.description.map_or(Vec::new(), |d| {
        let (e, s) = vehicle
            .as_ref()
            .map_or((&estimate, &sigma), |v| (&v.estimate, &v.sigma));
        rig_description::quantities::conformity(&d.certificate.nominal, e, s)
    });
    Report {
        vehicle,
        conformity,
        estimate,
        sigma,
        truth: i.truth,
        principal: principal_of(&reported),
        samples: i.loaded.counts.used,
        excitation_s: i.excitation_s,
        convergence: Convergence {
            samples_to_1pct: i
                .theta_history
                .samples_to_1pct(Some(&i.tare.theta), i.params),
        },
        residual_rms: ResidualRms {
            force_n: [0, 1, 2].map(|k| i.loaded.residual_rms[k]),
            torque_nm: [3, 4, 5].map(|k| i.loaded.residual_rms[k]),
        },
        rejected_samples: i.loaded.counts.rejected + i.fk_failures,
        data: DataLoss {
            rejected_share: crate::quality::rejected_share(
                i.loaded.counts.used,
                i.loaded.counts.rejected + i.fk_failures,
            ),
            frames_lost: i.loaded.counts.lost,
            frames_bridged: i.loaded.counts.bridged,
            restarts: i.loaded.counts.restarts,
            time_base: if i.loaded.timing.from_sequence {
                "sequence".into()
            } else {
                "timestamps".into()
            },
            timestamp_jitter_rms_s: i.loaded.timing.jitter_rms_s,
            timestamp_jitter_max_s: i.loaded.timing.jitter_max_s,
            rate_error: i.loaded.timing.rate_error,
            ..DataLoss::default()
        },
        consistency,
        tare: TareUsed {
            source: match i.tare_kind {
                TareKind::Measured => "measured".into(),
                TareKind::File => "file".into(),
            },
            file: i.tare_path.clone(),
            theta: i.tare.theta,
            sigma: core::array::from_fn(|k| i.tare.covariance[k][k].max(0.0).sqrt()),
            estimate: quantities(&tare_estimate),
            own_sigma: tare_own_sigma,
        },
        error_budget,
        budget_notes: notes,
        rigid_body: i.loaded_budget.and_then(|b| b.rigid_body),
        systematic: Systematic {
            accel_bias_sigma_m_s2: i.accel_bias_sigma_m_s2,
            load_cell_bias_sigma_n: i.load_cell_bias_sigma_n,
            sigma: sigmas(&systematic_only),
        },
        run: RunInfo {
            certificate: i
                .description
                .map(|d| d.certificate.clone())
                .unwrap_or_default(),
            description_sha256: i.description.map(description_sha256),
            local_gravity_m_s2: i.description.map(crate::weigh::gravity_of),
            ..i.run.clone()
        },
        covariance_basis: CovarianceBasis {
            loaded_windows: i.loaded.counts.covariance_windows,
            tare_windows: i.tare.covariance_windows,
            half_block_s: i.loaded.counts.covariance_half_block_samples as f64
                * i.loaded.timing.period_s,
            loaded_degrees_of_freedom: i
                .loaded
                .degrees_of_freedom
                .map(|nu| nu.filter(|v| v.is_finite())),
        },
        static_weighing: i.loaded_weighing.zip(i.tare.static_weighing.as_ref()).map(
            |(loaded, tare)| {
                let (q, s) = (quantities(&reported), sigmas(&payload));
                let fitted = (!i.params.given(0))
                    .then_some(([q.mass, q.com[0], q.com[1]], [s.mass, s.com[0], s.com[1]]));
                static_weighing_section(
                    loaded,
                    tare,
                    &i.loaded.parameters.to_vector().into(),
                    &i.tare.theta,
                    fitted,
                )
            },
        ),
    }
}

/// samples_to_1pct: the 1-based index of the first sample after which every estimated parameter
/// stays within 1 % of its final value (`None` without samples). `tare` is subtracted from each
/// θ; with the 6-parameter model only the tensor entries count (m and h are not estimated).
pub fn samples_to_1pct(
    history: &[[f64; 10]],
    tare: Option<&[f64; 10]>,
    params: ParamCount,
) -> Option<u64> {
    let last = history.last()?;
    let sub = |t: &[f64; 10]| -> [f64; 10] {
        match tare {
            Some(z) => core::array::from_fn(|i| t[i] - z[i]),
            None => *t,
        }
    };
    let fin = sub(last);
    let range = params.estimated();
    let within = |t: &[f64; 10]| {
        let t = sub(t);
        range
            .clone()
            .all(|i| (t[i] - fin[i]).abs() <= 0.01 * fin[i].abs())
    };
    let last_outside = history.iter().rposition(|t| !within(t));
    Some(match last_outside {
        None => 1,
        Some(k) => k as u64 + 2,
    })
}

/// θ's history kept for [`samples_to_1pct`] in bounded memory: every sample until
/// [`ThetaHistory::CAPACITY`] are kept, then every other one of those (the stride doubles),
/// and so on; the last θ is always kept. With stride 1 the statistic is exact; with stride s it
/// is an upper bound at most s − 1 samples above the exact one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ThetaHistory {
    kept: Vec<[f64; 10]>,
    stride: u64,
    count: u64,
    last: Option<[f64; 10]>,
}

impl ThetaHistory {
    /// Samples kept at most (5 MB): a 60 s run at 1 kHz is kept whole.
    pub const CAPACITY: usize = 1 << 16;

    /// An empty history with room reserved for `samples` (at most [`Self::CAPACITY`]), so that
    /// pushing that many never allocates (the online loop's per-sample path stays heap-free).
    pub fn with_room_for(samples: usize) -> Self {
        Self {
            kept: Vec::with_capacity(samples.min(Self::CAPACITY)),
            ..Self::default()
        }
    }

    /// θ after one more used sample.
    pub fn push(&mut self, theta: [f64; 10]) {
        let stride = self.stride.max(1);
        if self.count.is_multiple_of(stride) {
            self.kept.push(theta);
            if self.kept.len() >= Self::CAPACITY {
                let mut k = 0;
                self.kept.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride = stride * 2;
            }
        }
        self.count += 1;
        self.last = Some(theta);
    }

    /// Samples pushed.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// True before the first sample.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Every how many samples one is kept.
    pub fn stride(&self) -> u64 {
        self.stride.max(1)
    }

    /// [`samples_to_1pct`] of the history: exact while every sample is kept, else rounded up
    /// to the next kept sample.
    pub fn samples_to_1pct(&self, tare: Option<&[f64; 10]>, params: ParamCount) -> Option<u64> {
        let last = self.last?;
        let stride = self.stride();
        // The kept samples, then the last (the final value every sample is compared with).
        let mut h = self.kept.clone();
        h.push(last);
        let n = samples_to_1pct(&h, tare, params)?;
        // n − 2 is the index in `h` of the last sample outside the band (n = 1: none).
        Some(if n <= 1 {
            1
        } else if n as usize - 2 >= self.kept.len() {
            self.count
        } else {
            ((n - 2) * stride + stride + 1).min(self.count)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `from_flat` puts each entry back where `flat` took it from, J_C symmetric.
    #[test]
    fn flat_and_from_flat_are_inverse() {
        let q = Quantities {
            mass: 1.0,
            com: [2.0, 3.0, 4.0],
            inertia_com: [[5.0, 8.0, 9.0], [8.0, 6.0, 10.0], [9.0, 10.0, 7.0]],
        };
        assert_eq!(
            q.flat(),
            [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0]
        );
        assert_eq!(Quantities::from_flat(&q.flat()), q);
    }

    /// The documented shape: these keys, these nestings, these array sizes.
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

    /// The shared builder: payload = loaded − tare, its covariance loaded + tare + the bias's
    /// Σ d dᵀ (d = loaded effect − tare effect), the counters and the tare's own figures.
    #[test]
    fn build_subtracts_the_tare_and_adds_the_systematic_part() {
        use estimator::{InertialParameters, ParameterCovariance};
        use nalgebra::{Matrix3, Vector3};
        let fixture = InertialParameters::from_com(
            400.0,
            Vector3::new(0.0, 0.0, 0.05),
            Matrix3::from_diagonal(&Vector3::new(240.0, 240.0, 450.0)),
        );
        let payload = InertialParameters::from_com(
            1500.0,
            Vector3::new(0.15, -0.08, 0.5),
            Matrix3::new(
                600.0, -25.0, 60.0, -25.0, 2500.0, -15.0, 60.0, -15.0, 2700.0,
            ),
        );
        let stat = ParameterCovariance::identity() * 1e-4;
        let mut loaded = Estimate::from_parameters(payload + fixture, stat * 2.0);
        loaded.counts.used = 1000;
        loaded.counts.rejected = 3;
        let tare_estimate = Estimate::from_parameters(fixture, stat);
        let tare =
            TareFile::from_estimate(&tare_estimate, &[[0.0; 3]; 6], &[[0.0; 3]; 6], "x", "sim");
        let mut loaded_effect = [[0.0; 10]; 3];
        let mut tare_effect = [[0.0; 10]; 3];
        loaded_effect[2][0] = 0.2;
        tare_effect[2][0] = 0.05;
        let budget = |e: [[f64; 10]; 3]| RunBudget {
            effects: vec![SourceEffects {
                per_run: false,
                source: "accel_bias".into(),
                effects: e.to_vec(),
            }],
            ..RunBudget::default()
        };
        let (loaded_budget, tare_budget) = (budget(loaded_effect), budget(tare_effect));
        let mut history = ThetaHistory::default();
        for theta in [
            [0.0; 10],
            tare.theta,
            (payload + fixture).to_vector().into(),
        ] {
            history.push(theta);
        }
        let r = build(&ReportInputs {
            loaded: &loaded,
            theta_history: &history,
            excitation_s: 60.0,
            fk_failures: 2,
            tare: &tare,
            tare_kind: TareKind::Measured,
            tare_path: None,
            loaded_budget: Some(&loaded_budget),
            tare_budget: Some(&tare_budget),
            accel_bias_sigma_m_s2: 1e-3,
            load_cell_bias_sigma_n: 0.0,
            params: ParamCount::Ten,
            truth: None,
            run: RunInfo::default(),
            loaded_weighing: None,
            description: None,
        });
        assert!((r.estimate.mass - 1500.0).abs() < 1e-9);
        assert!((r.estimate.com[2] - 0.5).abs() < 1e-12);
        assert!((r.estimate.inertia_com[0][2] - 60.0).abs() < 1e-9);
        // σ(m)² = 2e-4 (loaded) + 1e-4 (tare) + 0.15² (bias on the payload's share).
        assert!((r.sigma.mass - (3e-4f64 + 0.0225).sqrt()).abs() < 1e-12);
        assert!((r.systematic.sigma.mass - 0.15).abs() < 1e-12);
        assert_eq!(r.systematic.accel_bias_sigma_m_s2, 1e-3);
        // The budget: one line per source, the bias's line the systematic part, the noise's
        // the two runs' covariances (no frames lost), and the lines add up to `sigma`.
        assert_eq!(r.error_budget.len(), ErrorSource::ALL.len());
        let line = |id: &str| *r.budget_line(id).unwrap();
        assert!((line("accel_bias").mass - 0.15).abs() < 1e-12);
        assert!((line("noise").mass - 3e-4f64.sqrt()).abs() < 1e-12);
        assert_eq!(line("geometry").mass, 0.0);
        assert_budget_adds_up(&r);
        assert_eq!((r.samples, r.rejected_samples), (1000, 5));
        assert_eq!(r.tare.source, "measured");
        assert!((r.tare.estimate.mass - 400.0).abs() < 1e-9);
        assert!((r.tare.sigma[0] - 1e-2).abs() < 1e-15);
        // Only the last of three samples is within 1 % of the final payload.
        assert_eq!(r.convergence.samples_to_1pct, Some(3));
    }

    /// A saved tare's sensitivities stand in for the tare run's effects (scaled by the sigma
    /// the loaded run assumes); an explicit effect wins; without either the share is zero.
    #[test]
    fn a_saved_tare_counts_its_share_of_the_load_cell_offsets() {
        use estimator::{InertialParameters, ParameterCovariance};
        use nalgebra::{Matrix3, Vector3};
        let fixture = InertialParameters::from_com(
            400.0,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(240.0, 240.0, 450.0)),
        );
        let body = InertialParameters::from_com(
            1900.0,
            Vector3::new(0.1, 0.0, 0.4),
            Matrix3::from_diagonal(&Vector3::new(800.0, 2800.0, 3100.0)),
        );
        let stat = ParameterCovariance::identity() * 1e-6;
        let loaded = Estimate::from_parameters(body, stat);
        let mut per_sigma = [[0.0; 10]; 6];
        per_sigma[4][0] = 0.02; // the tare run: 0.02 kg per 2 N on cell 4.
        let plain = TareFile::from_estimate(
            &Estimate::from_parameters(fixture, stat),
            &[[0.0; 3]; 6],
            &[[0.0; 3]; 6],
            "x",
            "rig",
        );
        let saved = plain
            .clone()
            .with_bias_effects(None, 0.0, Some(&per_sigma), 2.0);
        let mut loaded_effect = [[0.0; 10]; 6];
        loaded_effect[4][0] = 0.1; // the loaded run at 4 N: the tare's share is 0.04 kg.
        let cells = |e: [[f64; 10]; 6]| RunBudget {
            effects: vec![SourceEffects {
                per_run: false,
                source: "load_cell_offset".into(),
                effects: e.to_vec(),
            }],
            ..RunBudget::default()
        };
        let loaded_budget = cells(loaded_effect);
        let explicit = cells([[0.0; 10]; 6]);
        let systematic_mass = |tare: &TareFile, tare_effect: Option<RunBudget>| {
            build(&ReportInputs {
                loaded: &loaded,
                theta_history: &ThetaHistory::default(),
                excitation_s: 1.0,
                fk_failures: 0,
                tare,
                tare_kind: TareKind::File,
                tare_path: None,
                loaded_budget: Some(&loaded_budget),
                tare_budget: tare_effect.as_ref(),
                accel_bias_sigma_m_s2: 0.0,
                load_cell_bias_sigma_n: 4.0,
                params: ParamCount::Ten,
                truth: None,
                run: RunInfo::default(),
                loaded_weighing: None,
                description: None,
            })
            .systematic
            .sigma
            .mass
        };
        assert!((systematic_mass(&saved, None) - 0.06).abs() < 1e-12);
        assert!((systematic_mass(&plain, None) - 0.1).abs() < 1e-12);
        assert!((systematic_mass(&saved, Some(explicit)) - 0.1).abs() < 1e-12);
    }

    /// Σ over the budget's lines of σ² equals `sigma`² for every quantity.
    fn assert_budget_adds_up(r: &Report) {
        let flat = |q: &Quantities| {
            let mut v = vec![q.mass];
            v.extend(q.com);
            v.extend(q.inertia_com.iter().flatten());
            v
        };
        let total = flat(&r.sigma);
        let mut sum = vec![0.0; total.len()];
        for line in &r.error_budget {
            for (s, v) in sum.iter_mut().zip(flat(&line.sigma)) {
                *s += v * v;
            }
        }
        for (k, (s, t)) in sum.iter().zip(&total).enumerate() {
            assert!(
                (s.sqrt() - t).abs() <= 1e-9 * t.max(1e-12),
                "entry {k}: {} vs {t}",
                s.sqrt()
            );
        }
    }

    /// A full budget (every source, statistical shares) adds up to the report's sigma.
    #[test]
    fn the_budget_adds_up_to_sigma() {
        use estimator::{InertialParameters, ParameterCovariance};
        use nalgebra::{Matrix3, Vector3};
        let body = InertialParameters::from_com(
            1900.0,
            Vector3::new(0.12, -0.06, 0.41),
            Matrix3::new(
                840.0, -25.0, 60.0, -25.0, 2740.0, -15.0, 60.0, -15.0, 3150.0,
            ),
        );
        let fixture = InertialParameters::from_com(
            400.0,
            Vector3::new(0.0, 0.0, 0.05),
            Matrix3::from_diagonal(&Vector3::new(240.0, 240.0, 450.0)),
        );
        let mut stat = ParameterCovariance::identity() * 1e-3;
        stat[(0, 4)] = 2e-4;
        stat[(4, 0)] = 2e-4;
        let loaded = Estimate::from_parameters(body, stat);
        let tare = TareFile::from_estimate(
            &Estimate::from_parameters(fixture, stat * 0.5),
            &[[0.0; 3]; 6],
            &[[0.0; 3]; 6],
            "x",
            "sim",
        );
        let budget = |k: f64| RunBudget {
            effects: ErrorSource::ALL
                .iter()
                .map(|s| SourceEffects {
                    per_run: false,
                    source: s.id().into(),
                    effects: (0..3)
                        .map(|j| core::array::from_fn(|i| k * ((i + j) as f64 * 0.37).sin() * 0.01))
                        .collect(),
                })
                .collect(),
            used: 10_000,
            lost: 40,
            jitter_share: 0.02,
            rigid_body: None,
        };
        let (lb, tb) = (budget(1.0), budget(0.3));
        let r = build(&ReportInputs {
            loaded: &loaded,
            theta_history: &ThetaHistory::default(),
            excitation_s: 1.0,
            fk_failures: 0,
            tare: &tare,
            tare_kind: TareKind::Measured,
            tare_path: None,
            loaded_budget: Some(&lb),
            tare_budget: Some(&tb),
            accel_bias_sigma_m_s2: 1e-3,
            load_cell_bias_sigma_n: 4.0,
            params: ParamCount::Ten,
            truth: None,
            run: RunInfo::default(),
            loaded_weighing: None,
            description: None,
        });
        assert!(r.budget_notes.is_empty(), "{:?}", r.budget_notes);
        assert!(r
            .error_budget
            .iter()
            .all(|l| l.sigma.inertia_com[0][0] > 0.0));
        assert_budget_adds_up(&r);
        // The fixture's own mass sigma: its covariance (the statistical sources) plus every
        // other source's three effects on the tare alone (0.3 × 0.01 sin(0.37 j) on the mass),
        // none cancelled.
        let effects: f64 = (0..3)
            .map(|j| (0.3 * (j as f64 * 0.37).sin() * 0.01).powi(2))
            .sum();
        let systematic = ErrorSource::ALL
            .iter()
            .filter(|s| !is_statistical(**s))
            .count();
        let own = (0.5e-3 + systematic as f64 * effects).sqrt();
        let got = r.tare.own_sigma.expect("the tare has a budget").mass;
        assert!((got - own).abs() < 1e-12 * own, "{got} against {own}");
        assert!(got > r.tare.sigma[0]);
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

    /// A report naming the covariance basis's fields `loaded_blocks`, `tare_blocks` and
    /// `block_s` reads into the fields they mean.
    #[test]
    fn a_saved_report_with_the_block_names_reads_as_windows() {
        let mut json: serde_json::Value =
            serde_json::from_str(&Report::default().to_json()).unwrap();
        json["covariance_basis"] = serde_json::json!({
            "loaded_blocks": 23, "tare_blocks": 7, "block_s": 0.25,
            "loaded_degrees_of_freedom": [null, null, null, null, null, null, null, null, null, null]
        });
        let back: Report = serde_json::from_value(json).unwrap();
        assert_eq!(back.covariance_basis.loaded_windows, 23);
        assert_eq!(back.covariance_basis.tare_windows, Some(7));
        assert_eq!(back.covariance_basis.half_block_s, 0.25);
    }

    #[test]
    fn a_report_with_too_few_residual_windows_is_refused() {
        let mut r = Report {
            samples: 2000,
            covariance_basis: CovarianceBasis {
                loaded_windows: 6,
                tare_windows: Some(70),
                half_block_s: 0.4,
                loaded_degrees_of_freedom: [None; 10],
            },
            ..Report::default()
        };
        assert_eq!(r.check_quality(), Ok(()));
        r.covariance_basis.tare_windows = Some(2);
        let e = r.check_quality().unwrap_err();
        assert!(e.to_string().contains("tare run"), "{e}");
        // A tare file without the count is not held against the report.
        r.covariance_basis.tare_windows = None;
        assert_eq!(r.check_quality(), Ok(()));
        r.covariance_basis.loaded_windows = 5;
        assert!(matches!(
            r.check_quality(),
            Err(crate::quality::QualityError::TooShort {
                run: "loaded",
                windows: 5,
                ..
            })
        ));
    }

    #[test]
    fn samples_to_1pct_finds_the_last_excursion() {
        let mut h = vec![[1.0; 10]; 10];
        h[3][5] = 1.2;
        h[6][0] = 0.985;
        // Sample 7 (index 6) is outside, so from sample 8 on all stay within 1 %.
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Ten), Some(8));
        // Only the tensor entries count with six parameters: index 3's entry 5 is the last.
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Six), Some(5));
        assert_eq!(samples_to_1pct(&[], None, ParamCount::Ten), None);
        assert_eq!(samples_to_1pct(&h[..1], None, ParamCount::Ten), Some(1));
    }

    #[test]
    fn samples_to_1pct_subtracts_the_tare() {
        // Loaded θ 102 → 100 with a tare of 99: the payload goes 3 → 1, far outside 1 %.
        let h = vec![[102.0; 10], [100.0; 10], [100.0; 10]];
        let tare = [99.0; 10];
        assert_eq!(samples_to_1pct(&h, Some(&tare), ParamCount::Ten), Some(2));
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Ten), Some(2));
        let h = vec![[100.5; 10], [100.0; 10]];
        assert_eq!(samples_to_1pct(&h, None, ParamCount::Ten), Some(1));
        assert_eq!(samples_to_1pct(&h, Some(&tare), ParamCount::Ten), Some(2));
    }
}
