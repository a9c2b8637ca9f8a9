//! The search: a family of periodic multi-sines ([`Trajectory::multisine`]: harmonics of a
//! base frequency dealt out to the axes, Schroeder phases), each scaled up until the first limit
//! binds, and the one whose predicted payload sigma is smallest relative to the targets.
//!
//! **Family.** Base frequencies f₀ = n/T with T the plateau between the fades (so that the
//! plateau holds whole periods and the noise averages over them), 1–4 harmonics per axis, the
//! harmonics' amplitudes flat in position or in velocity, the six axes or the three rotations
//! alone, translations of 0.1, 0.3 or 1 m per radian of rotation; the highest frequency at
//! most [`super::Planner::max_frequency_hz`]. Then a coordinate search on the six axes' shares
//! (each ×0.6 or ×1.6, kept when the criterion drops), two sweeps.
//!
//! **Fades.** The rig description's, each shortened to at most [`MAX_FADE_SHARE`] of the
//! loaded run's excitation (for a short run), and written with the plan.
//!
//! **Scale.** The motion's size is the largest scale at which every limit holds along the
//! whole path ([`super::Planner::check`]), found by bisection on a 5 ms grid and confirmed at
//! the limits' own step; what broke first just above it is the binding limit.

use control::trajectory::{MultiSineConfig, SineComponent, Spectrum, Trajectory};
use rayon::prelude::*;

use super::{Binding, Planner, Prediction, Usage};
use rig_description::config::{AxisName, ExcitationConfig, ExcitationKind, SineConfig};

/// Largest rotation peak searched, rad (about 17°).
const MAX_SCALE_RAD: f64 = 0.3;

/// Bisection steps on the scale: the scale within 0.3 rad / 2¹² ≈ 0.004°.
const BISECTION_STEPS: usize = 12;

/// Grid of the limit checks during the search, s.
const SEARCH_STEP_S: f64 = 5e-3;

/// A designed excitation.
#[derive(Clone, Debug)]
pub struct Plan {
    /// `[excitation]` with `kind = "sines"` and the designed components (the limits and fades
    /// as in the rig description).
    pub excitation: ExcitationConfig,
    /// The loaded run's trajectory.
    pub loaded: Trajectory,
    /// The payload's predicted sigma.
    pub prediction: Prediction,
    /// How much of each limit the loaded run uses.
    pub usage: Usage,
    /// The limit that stops the motion from growing.
    pub binding: Binding,
    /// Base frequency, Hz, and harmonics per axis of the chosen shape.
    pub base_frequency_hz: f64,
    /// Harmonics per excited axis.
    pub harmonics_per_axis: usize,
    /// Candidates evaluated.
    pub evaluated: usize,
}

/// Why no plan came out.
#[derive(Clone, Debug, PartialEq)]
pub enum PlanError {
    /// No shape of the family can move at all within the limits (the first limit each broke,
    /// for the smallest motion tried).
    Infeasible(String),
    /// Durations or fades that leave no plateau.
    NoPlateau {
        /// The loaded run's duration, s.
        duration_s: f64,
        /// Fade-in plus fade-out, s.
        fades_s: f64,
    },
}

impl core::fmt::Display for PlanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Infeasible(why) => write!(
                f,
                "no excitation of the family stays within the rig's limits: {why}"
            ),
            Self::NoPlateau {
                duration_s,
                fades_s,
            } => write!(
                f,
                "an excitation of {duration_s} s has no plateau between fades of {fades_s} s in all: \
                 lengthen it (--duration) or shorten excitation.fade_s"
            ),
        }
    }
}

impl std::error::Error for PlanError {}

/// One shape of the family, at unit scale (1 rad of rotation peak).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Shape {
    base_frequency_hz: f64,
    harmonics: usize,
    spectrum: Spectrum,
    /// Peak per axis at scale 1: [x, y, z] m, [α, β, γ] rad.
    peaks: [f64; 6],
}

/// A shape scaled to its limits, and what it is predicted to give.
#[derive(Clone, Debug)]
struct Scored {
    shape: Shape,
    loaded: Trajectory,
    prediction: Prediction,
    usage: Usage,
    binding: Binding,
}

impl Scored {
    fn criterion(&self) -> f64 {
        self.prediction.worst().1
    }
}

/// Designs the excitation for a loaded run of `duration_s` and a tare run of
/// `tare_duration_s` with the fades and limits of `base` (see the [module docs](self));
/// `progress(done, total)` is called as candidates finish.
pub fn design(
    planner: &Planner,
    base: &ExcitationConfig,
    duration_s: f64,
    tare_duration_s: f64,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Plan, PlanError> {
    let base = &with_short_fades(base, duration_s);
    let (fade_in, fade_out) = (base.fade_s, base.fade_out());
    let plateau = duration_s - fade_in - fade_out;
    if !(plateau > 0.0 && plateau.is_finite()) {
        return Err(PlanError::NoPlateau {
            duration_s,
            fades_s: fade_in + fade_out,
        });
    }
    let evaluate = |shape: &Shape| score(planner, shape, duration_s, tare_duration_s, base);
    let shapes = family(planner.max_frequency_hz, plateau);
    let total = shapes.len() + 24;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let tick = || {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        progress(n, total);
    };
    let results: Vec<Result<Scored, Binding>> = shapes
        .par_iter()
        .map(|s| {
            let r = evaluate(s);
            tick();
            r
        })
        .collect();
    let mut evaluated = results.len();
    let mut best: Option<Scored> = None;
    let mut first_failure = None;
    for r in results {
        match r {
            Ok(s) if best.as_ref().is_none_or(|b| s.criterion() < b.criterion()) => best = Some(s),
            Ok(_) => {}
            Err(e) => {
                first_failure.get_or_insert(e);
            }
        }
    }
    let Some(mut best) = best else {
        return Err(PlanError::Infeasible(
            first_failure.map_or_else(|| "no candidate".into(), |b| b.to_string()),
        ));
    };
    // Coordinate search on the axes' shares: the six variations of a sweep in parallel.
    for _sweep in 0..2 {
        for factor in [0.6, 1.6] {
            let trials: Vec<Shape> = (0..6)
                .filter(|&axis| best.shape.peaks[axis] > 0.0)
                .map(|axis| {
                    let mut shape = best.shape;
                    shape.peaks[axis] *= factor;
                    shape
                })
                .collect();
            let scored: Vec<Scored> = trials
                .par_iter()
                .filter_map(|s| {
                    let r = evaluate(s).ok();
                    tick();
                    r
                })
                .collect();
            evaluated += trials.len();
            for s in scored {
                if s.criterion() < best.criterion() {
                    best = s;
                }
            }
        }
    }
    progress(total, total);
    Ok(Plan {
        excitation: excitation_of(base, &best.loaded),
        base_frequency_hz: best.shape.base_frequency_hz,
        harmonics_per_axis: best.shape.harmonics,
        loaded: best.loaded,
        prediction: best.prediction,
        usage: best.usage,
        binding: best.binding,
        evaluated,
    })
}

/// Largest share of the loaded run's excitation each fade may take in a plan.
pub const MAX_FADE_SHARE: f64 = 0.125;

/// `base` with each fade at most [`MAX_FADE_SHARE`] of `duration_s`: the rig description's
/// fades (2 s by default) suit a 20 s excitation, but would leave a 5 s one a 1 s plateau
/// whose whole periods are too fast for the legs. The planned file carries the fades it
/// was designed with, so the run moves as planned; the scale search keeps the shorter fades'
/// faster start and stop within every limit.
pub(super) fn with_short_fades(base: &ExcitationConfig, duration_s: f64) -> ExcitationConfig {
    let cap = MAX_FADE_SHARE * duration_s;
    let mut e = base.clone();
    if base.fade_s > cap || base.fade_out() > cap {
        e.fade_out_s = Some(base.fade_out().min(cap));
        e.fade_s = base.fade_s.min(cap);
    }
    e
}

/// The family's shapes (see the [module docs](self)).
fn family(max_frequency_hz: f64, plateau_s: f64) -> Vec<Shape> {
    let mut shapes = Vec::new();
    for translation in [0.0, 0.1, 0.3, 1.0] {
        let axes = if translation > 0.0 { 6.0 } else { 3.0 };
        for harmonics in 1..=4usize {
            for spectrum in [Spectrum::FlatVelocity, Spectrum::FlatPosition] {
                if harmonics == 1 && spectrum == Spectrum::FlatPosition {
                    continue;
                }
                for n in 1..=40 {
                    let f0 = n as f64 / plateau_s;
                    if f0 * axes * harmonics as f64 > max_frequency_hz {
                        break;
                    }
                    let t = translation;
                    shapes.push(Shape {
                        base_frequency_hz: f0,
                        harmonics,
                        spectrum,
                        peaks: [t, t, t, 1.0, 1.0, 1.0],
                    });
                }
            }
        }
    }
    shapes
}

/// The shape at unit scale as a trajectory of `duration_s`.
fn unit_trajectory(
    planner: &Planner,
    shape: &Shape,
    duration_s: f64,
    base: &ExcitationConfig,
) -> Option<Trajectory> {
    Trajectory::multisine(
        planner.geometry.home_pose(),
        &MultiSineConfig {
            base_frequency_hz: shape.base_frequency_hz,
            harmonics_per_axis: shape.harmonics,
            peak_amplitudes: shape.peaks,
            duration_s,
            fade_in_s: base.fade_s,
            fade_out_s: base.fade_out(),
            spectrum: shape.spectrum,
        },
    )
    .ok()
}

/// `unit`'s components times `scale`, lasting `duration_s`.
fn scaled(unit: &Trajectory, scale: f64, duration_s: f64) -> Option<Trajectory> {
    let components: Vec<SineComponent> = unit
        .components()
        .iter()
        .map(|c| SineComponent {
            amplitude: c.amplitude * scale,
            ..*c
        })
        .collect();
    let (fade_in, fade_out) = unit.fades_s();
    Trajectory::new(*unit.offset(), &components, duration_s, fade_in, fade_out).ok()
}

/// Scales `shape` to its limits and predicts it; the first limit broken at the smallest scale
/// when it cannot move at all.
fn score(
    planner: &Planner,
    shape: &Shape,
    duration_s: f64,
    tare_duration_s: f64,
    base: &ExcitationConfig,
) -> Result<Scored, Binding> {
    let unit = unit_trajectory(planner, shape, duration_s, base).ok_or(Binding::Singular)?;
    let theta = planner.payload + planner.fixture;
    let com = planner.payload_com_m();
    let check = |scale: f64, step: f64| -> Result<(Trajectory, Usage), Binding> {
        let t = scaled(&unit, scale, duration_s).ok_or(Binding::Singular)?;
        planner.check(&t, &theta, &com, step).map(|u| (t, u))
    };
    let (mut lo, mut hi) = (0.0, MAX_SCALE_RAD);
    let mut binding = match check(hi, SEARCH_STEP_S) {
        Ok(_) => {
            lo = hi;
            Binding::SearchLimit {
                rotation_rad: MAX_SCALE_RAD,
            }
        }
        Err(b) => b,
    };
    if lo < hi {
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            match check(mid, SEARCH_STEP_S) {
                Ok(_) => lo = mid,
                Err(b) => {
                    hi = mid;
                    binding = b;
                }
            }
        }
    }
    // Confirm at the limits' own step, backing off where the coarse grid missed a peak.
    let mut confirmed = None;
    for _ in 0..20 {
        if lo <= 0.0 {
            break;
        }
        match check(lo, 0.0) {
            Ok(ok) => {
                confirmed = Some(ok);
                break;
            }
            Err(b) => {
                binding = b;
                lo *= 0.98;
            }
        }
    }
    let (loaded, usage) = confirmed.ok_or(binding.clone())?;
    let tare = scaled(&unit, lo, tare_duration_s).ok_or(Binding::Singular)?;
    let prediction = planner.predict(&loaded, &tare).ok_or(Binding::Kinematic(
        "the motion does not determine all ten parameters".into(),
    ))?;
    Ok(Scored {
        shape: *shape,
        loaded,
        prediction,
        usage,
        binding,
    })
}

/// `[excitation]` of `base` with the components of `trajectory` as `kind = "sines"`.
pub fn excitation_of(base: &ExcitationConfig, trajectory: &Trajectory) -> ExcitationConfig {
    use control::trajectory::Axis;
    let sines = trajectory
        .components()
        .iter()
        .map(|c| {
            let (axis, rotation) = match c.axis {
                Axis::X => (AxisName::X, false),
                Axis::Y => (AxisName::Y, false),
                Axis::Z => (AxisName::Z, false),
                Axis::Roll => (AxisName::Roll, true),
                Axis::Pitch => (AxisName::Pitch, true),
                Axis::Yaw => (AxisName::Yaw, true),
            };
            SineConfig {
                axis,
                amplitude_deg: rotation.then(|| c.amplitude.to_degrees()),
                amplitude_m: (!rotation).then_some(c.amplitude),
                frequency_hz: c.frequency_hz,
                phase_deg: c.phase_rad.to_degrees(),
            }
        })
        .collect();
    ExcitationConfig {
        kind: ExcitationKind::Sines,
        sines,
        ..base.clone()
    }
}

/// The excitation file `stewart plan --out` writes: `header` as comments, then the
/// `[excitation]` table of `excitation` (its unused `multisine` table left out: the file is
/// laid over the rig description, [`rig_description::load::LoadedConfig::with_excitation_file`]).
pub fn excitation_file(excitation: &ExcitationConfig, header: &str) -> String {
    let mut table = toml::Table::new();
    if let Ok(toml::Value::Table(mut e)) = toml::Value::try_from(excitation) {
        if excitation.kind == ExcitationKind::Sines {
            e.remove("multisine");
        }
        table.insert("excitation".into(), toml::Value::Table(e));
    }
    let mut text: String = header.lines().map(|l| format!("# {l}\n")).collect();
    text.push('\n');
    text.push_str(&toml::to_string(&table).unwrap_or_default());
    text
}
