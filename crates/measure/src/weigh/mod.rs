//! Static weighing: the brake hold's load-cell readings at the hold's pose give the mass and
//! the horizontal centre of mass of everything on the plate, before anything moves, with no
//! accelerometer in the result.
//!
//! **The wrench.** Each hold sample gives the static wrench on the plate at the P origin in P
//! axes, W = Σ fᵢ Lᵢ(pose) ([`kinematics::Geometry::wrench_in_platform`], the estimator's map)
//! plus, when the estimator compensates the legs, what the cells do not see of the legs' own
//! weight at rest ([`estimator::legs::unseen`] with zero velocity and acceleration: the same
//! code the estimator runs). W̄ is its mean over the whole hold.
//!
//! **Mass and centre of mass.** At rest the legs carry the load: F = −m g_P and τ = c × F,
//! with g_P = −g û (û = R⁻¹ ẑ, "up" in P axes, from the pose) and g the site's gravity (the
//! rig description's `estimator.local_gravity_m_s2`, else standard gravity; never the
//! accelerometer, so its bias stays out of the mass). With h = m c:
//!
//! ```text
//! m   = F·û / g
//! τ   = g h × û   ⇒   h_y = (τ_x / g + h_z u_y) / u_z,   h_x = (h_z u_x − τ_y / g) / u_z
//! ```
//!
//! h_z (the height of the centre of mass) is not observable from one pose: the moment of a
//! weight along û does not depend on where along û it acts. The result is given for h_z = 0
//! ([`StaticWeighing::values`]) with its slope (u_x/u_z, u_y/u_z) ([`StaticWeighing::tilt`]):
//! at a level pose the slope is zero and c_x, c_y follow alone; the report takes h_z from the
//! dynamic fit, whose share is tilt × h_z.
//!
//! **Why the whole hold.** Over a hold the momentum changes by ∫ (W + m g) dt = Δp, so the
//! mean over the whole hold is the static wrench when the plate is at rest at its start and
//! its end, whatever small motion happens between. A plate still sagging onto its brakes under
//! a load just put on is not at rest at the start: the load must have settled before the hold
//! (a rig's operator loads it well before; the simulator's station waits two seconds).
//!
//! **The rest's end.** The hold is what comes before the plate first moves: a sample whose
//! leg lengths differ from the first sample's by more than two readings' noise allows
//! ([`RestWatch`]) ends it, and the 0.1 s before that sample are dropped, so the stretch ends
//! at rest, not in the motion's first tenth of a second (a motion that takes longer than that
//! to move a leg by the threshold δ leaves at most m √(2 δ a) / T in the mean: 0.02 kg for
//! δ = 6 µm, a = 1.2 mm/s², T = 1 s, 1,500 kg). On a rig the brake hold ends before anything
//! moves; a foreign lab's table may start its motion sooner than `run.brake_hold_s`, and
//! its rest is then what is weighed.
//!
//! **Uncertainty.** The noise of the mean is σ²/n per wrench component, σ² from the second
//! differences of the samples, E[(x_{k+1} − 2x_k + x_{k−1})²] = 6σ² for white noise: a slow
//! drift or swing of the load hardly enters them, where it would dominate the scatter of block
//! means. The rig's errors each give one change of (m, h_x, h_y) per elementary error
//! at one sigma, by the budget's rule ([`crate::budget::perturb`]): each cell's zero offset
//! (`zero_offset_n`) and gain (`gain_error`, or the applied calibration's principal errors),
//! each of the 36 joint coordinates off by `joint_position_tolerance_m` (the pose the same leg
//! lengths give on the built rig, [`crate::budget::perturb::moved_poses`], and the built
//! rig's wrench map), and each compensated `[legs]` mass figure off by its tolerance. These
//! errors are the rig's, shared by the tare run and the loaded run: the payload's change is the
//! difference of the two runs' ([`payload`]). A cell's zero drift over the time between the two
//! holds counts per cell (`zero_drift_n_per_min`).

use estimator::legs::{unseen, LegModel, PlateMotion};
use estimator::wrench::to_vector;
use kinematics::{FkOptions, Geometry, Matrix6, Pose, Vector3, Vector6};
use serde::{Deserialize, Serialize};
use stewart_types::{GRAVITY_B_M_S2, STANDARD_GRAVITY_M_S2};

use crate::budget::Figures;
use rig_description::sources::ErrorSource;

mod payload;
#[cfg(test)]
mod tests;

pub use payload::{payload, Weighed};

/// Fewest hold samples a weighing needs.
pub const MIN_SAMPLES: u64 = 20;

/// The change of (m, h_x, h_y) from one sigma of each elementary error of one source.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WeighEffects {
    /// The source's id ([`ErrorSource::id`]).
    pub source: String,
    /// δ(m kg, h_x kg·m, h_y kg·m) per elementary error, in a fixed order for given figures.
    pub effects: Vec<[f64; 3]>,
}

/// One run's static weighing (everything on the plate).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StaticWeighing {
    /// Hold samples averaged.
    pub samples: u64,
    /// Backend time of the hold's middle, s.
    pub time_s: f64,
    /// Gravity used, m/s².
    pub gravity_m_s2: f64,
    /// û, up in P axes at the hold's pose.
    pub up_in_p: [f64; 3],
    /// Mean static wrench [Fx, Fy, Fz, τx, τy, τz] at the P origin, P axes, N and N·m.
    pub wrench: [f64; 6],
    /// (m kg, h_x kg·m, h_y kg·m) for h_z = 0.
    pub values: [f64; 3],
    /// ∂(h_x, h_y)/∂h_z = (u_x/u_z, u_y/u_z).
    pub tilt: [f64; 2],
    /// Covariance of `values` from the readings' noise.
    pub noise_covariance: [[f64; 3]; 3],
    /// The rig's errors, shared by every run on the rig.
    pub effects: Vec<WeighEffects>,
    /// δ(m, h_x, h_y) per second of one sigma of each cell's zero drift.
    pub drift_per_s: Vec<[f64; 3]>,
}

/// (m, h_x, h_y) of a static wrench `w` at up vector `up` (P axes), gravity `g`, for a centre
/// of mass height h_z = `h_z` kg·m (see the [module docs](self)).
pub fn mass_and_moments(w: &Vector6<f64>, up: &Vector3<f64>, g: f64, h_z: f64) -> [f64; 3] {
    let f = Vector3::new(w[0], w[1], w[2]);
    let m = f.dot(up) / g;
    let h_y = (w[3] / g + h_z * up.y) / up.z;
    let h_x = (h_z * up.x - w[4] / g) / up.z;
    [m, h_x, h_y]
}

/// The static wrench of one sample: W = Σ fᵢ Lᵢ(pose) plus the legs' unseen weight at rest
/// when `legs` are compensated, [Fx, Fy, Fz, τx, τy, τz] in P axes about the P origin.
pub fn static_wrench(
    geometry: &Geometry,
    legs: Option<&LegModel>,
    pose: &Pose,
    leg_forces_n: &Vector6<f64>,
) -> Vector6<f64> {
    let mut w = to_vector(&geometry.wrench_in_platform(pose, leg_forces_n));
    if let Some(legs) = legs {
        let rest = PlateMotion {
            pose: *pose,
            velocity_m_s: Vector3::zeros(),
            acceleration_m_s2: Vector3::zeros(),
            angular_velocity_rad_s: Vector3::zeros(),
            angular_acceleration_rad_s2: Vector3::zeros(),
        };
        w += to_vector(&unseen(geometry, legs, &rest, &GRAVITY_B_M_S2).total());
    }
    w
}

/// The site's gravity of the rig description: `estimator.local_gravity_m_s2`, else standard
/// gravity.
pub fn gravity_of(config: &rig_description::Config) -> f64 {
    config
        .estimator
        .local_gravity_m_s2
        .filter(|g| g.is_finite() && *g > 0.0)
        .unwrap_or(STANDARD_GRAVITY_M_S2)
}

/// Where the rest at a run's start ends: the first sample whose leg lengths differ from the
/// first sample's by more than `threshold_m` on any leg; the `guard_samples` before it are
/// dropped too (see the [module docs](self), "The rest's end").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestWatch {
    /// The largest change of a leg's length from the first sample that is still rest, m.
    pub threshold_m: f64,
    /// Samples before the first moving one that are not weighed.
    pub guard_samples: usize,
}

impl RestWatch {
    /// Seconds before the first moving sample that are not weighed.
    pub const GUARD_S: f64 = 0.1;

    /// The watch for `config`'s encoders and sample rate: a leg moved when its length changed
    /// by more than 6 √2 σ (two readings' noise) plus two quantisation steps.
    pub fn of(config: &rig_description::Config) -> Self {
        let encoder = &config.sensors.encoder;
        Self {
            threshold_m: 6.0 * std::f64::consts::SQRT_2 * encoder.noise_m
                + 2.0 * encoder.resolution_m,
            guard_samples: (Self::GUARD_S * config.sensors.sample_rate_hz).round() as usize,
        }
    }
}

/// One sample held back until the rest is known to have lasted past it.
#[derive(Clone, Copy, Debug)]
struct Pending {
    time_s: f64,
    wrench: Vector6<f64>,
    forces: Vector6<f64>,
    lengths: Vector6<f64>,
    pose: Pose,
}

/// Accumulates one hold's samples; [`Weigher::finish`] gives the weighing. Reserved up front:
/// [`Weigher::push`] never allocates.
#[derive(Clone, Debug)]
pub struct Weigher {
    geometry: Geometry,
    legs: Option<LegModel>,
    gravity_m_s2: f64,
    watch: Option<RestWatch>,
    /// The first sample's leg lengths, the rest's reference.
    first_lengths: Option<Vector6<f64>>,
    /// The plate moved: nothing more is weighed.
    moved: bool,
    /// The last `guard_samples` samples, weighed once the rest outlasts them.
    pending: std::collections::VecDeque<Pending>,
    n: u64,
    sum_w: Vector6<f64>,
    sum_f: Vector6<f64>,
    sum_len: Vector6<f64>,
    /// The last two wrenches, for the second differences.
    previous: [Option<Vector6<f64>>; 2],
    /// Σ d dᵀ of the second differences d, and their count.
    second: Matrix6<f64>,
    second_n: u64,
    last_pose: Option<Pose>,
    first_s: f64,
    last_s: f64,
}

impl Weigher {
    /// A weigher on `geometry`, the legs compensated as `legs`, at gravity `gravity_m_s2`.
    pub fn new(geometry: Geometry, legs: Option<LegModel>, gravity_m_s2: f64) -> Self {
        Self {
            geometry,
            legs,
            gravity_m_s2,
            watch: None,
            first_lengths: None,
            moved: false,
            pending: std::collections::VecDeque::new(),
            n: 0,
            sum_w: Vector6::zeros(),
            sum_f: Vector6::zeros(),
            sum_len: Vector6::zeros(),
            previous: [None; 2],
            second: Matrix6::zeros(),
            second_n: 0,
            last_pose: None,
            first_s: f64::NAN,
            last_s: f64::NAN,
        }
    }

    /// The weigher of `config`'s rig, weighing the rest only ([`RestWatch::of`]).
    pub fn of(config: &rig_description::Config, geometry: Geometry) -> Self {
        Self::new(
            geometry,
            crate::setup::leg_model(config),
            gravity_of(config),
        )
        .watching(RestWatch::of(config))
    }

    /// Weighs only the samples before the plate first moves, by `watch`.
    pub fn watching(mut self, watch: RestWatch) -> Self {
        self.pending = std::collections::VecDeque::with_capacity(watch.guard_samples + 1);
        self.watch = Some(watch);
        self
    }

    /// One hold sample: its time, pose and (gain-corrected) leg forces. Non-finite samples
    /// are skipped; with a [`RestWatch`], so is every sample from the guard before the plate's
    /// first motion on.
    pub fn push(&mut self, time_s: f64, pose: &Pose, leg_forces_n: &Vector6<f64>) {
        let w = static_wrench(&self.geometry, self.legs.as_ref(), pose, leg_forces_n);
        if self.moved || !(w.iter().all(|v| v.is_finite()) && time_s.is_finite()) {
            return;
        }
        let lengths = self.geometry.leg_lengths(pose);
        let sample = Pending {
            time_s,
            wrench: w,
            forces: *leg_forces_n,
            lengths,
            pose: *pose,
        };
        let Some(watch) = self.watch else {
            self.add(&sample);
            return;
        };
        let first = *self.first_lengths.get_or_insert(lengths);
        if (lengths - first).amax() > watch.threshold_m {
            self.moved = true;
            self.pending.clear();
            return;
        }
        if self.pending.len() == watch.guard_samples {
            if let Some(oldest) = self.pending.pop_front() {
                self.add(&oldest);
            }
        }
        if watch.guard_samples == 0 {
            self.add(&sample);
        } else {
            self.pending.push_back(sample);
        }
    }

    /// Adds a sample at rest to the sums.
    fn add(&mut self, s: &Pending) {
        if self.n == 0 {
            self.first_s = s.time_s;
        }
        self.last_s = s.time_s;
        self.n += 1;
        self.sum_w += s.wrench;
        self.sum_f += s.forces;
        self.sum_len += s.lengths;
        self.last_pose = Some(s.pose);
        if let [Some(a), Some(b)] = self.previous {
            let d = s.wrench - b * 2.0 + a;
            self.second += d * d.transpose();
            self.second_n += 1;
        }
        self.previous = [self.previous[1], Some(s.wrench)];
    }

    /// Samples weighed: those at rest, the guard's included while the plate has not moved.
    pub fn samples(&self) -> u64 {
        self.n + self.pending.len() as u64
    }

    /// Whether the plate moved (by the [`RestWatch`]) since the first sample.
    pub fn moved(&self) -> bool {
        self.moved
    }

    /// The weighing with the rig description's `figures`; `None` with fewer than
    /// [`MIN_SAMPLES`] samples or a plate not carried upright (u_z ≤ 0.5).
    pub fn finish(&self, figures: &Figures) -> Option<StaticWeighing> {
        if !self.pending.is_empty() {
            // The hold ended at rest: the guard's samples are rest too.
            let mut all = self.clone();
            while let Some(s) = all.pending.pop_front() {
                all.add(&s);
            }
            return all.finish(figures);
        }
        if self.n < MIN_SAMPLES || self.second_n == 0 {
            return None;
        }
        let n = self.n as f64;
        let last = self.last_pose?;
        // The hold's pose: forward kinematics of the mean leg lengths.
        let lengths = self.sum_len / n;
        let pose = self
            .geometry
            .forward_kinematics(&lengths, &last, &FkOptions::default())
            .map_or(last, |s| s.pose);
        let up = pose.rotation.inverse() * Vector3::z();
        if up.z <= 0.5 {
            return None;
        }
        let g = self.gravity_m_s2;
        let w = self.sum_w / n;
        let forces = self.sum_f / n;
        let at = |w: &Vector6<f64>| Vector3::from(mass_and_moments(w, &up, g, 0.0));
        let values = at(&w);
        // Cov W̄ = Σ / n with Σ = E[d dᵀ] / 6, mapped through the (linear) wrench → values.
        let cov_w = self.second / (6.0 * self.second_n as f64 * n);
        let map = nalgebra::Matrix3x6::from_fn(|r, c| {
            let mut e = Vector6::zeros();
            e[c] = 1.0;
            at(&e)[r]
        });
        let noise = map * cov_w * map.transpose();
        let effects = self.effects(figures, &pose, &forces, &w, &up, &values);
        let drift_per_s = (0..6)
            .map(|i| {
                let sigma = figures.sensors.load_cell.zero_drift_n_per_min / 60.0;
                let dw = self.unit_wrench(&pose, i) * sigma;
                at(&dw).into()
            })
            .collect();
        Some(StaticWeighing {
            samples: self.n,
            time_s: 0.5 * (self.first_s + self.last_s),
            gravity_m_s2: g,
            up_in_p: up.into(),
            wrench: w.into(),
            values: values.into(),
            tilt: [up.x / up.z, up.y / up.z],
            noise_covariance: noise.into(),
            effects,
            drift_per_s,
        })
    }

    /// Lᵢ at `pose`: the wrench of a unit force in leg `i`.
    fn unit_wrench(&self, pose: &Pose, i: usize) -> Vector6<f64> {
        let mut e = Vector6::zeros();
        e[i] = 1.0;
        to_vector(&self.geometry.wrench_in_platform(pose, &e))
    }

    /// Every shared source's δ(m, h_x, h_y) per elementary error (see the module docs).
    fn effects(
        &self,
        figures: &Figures,
        pose: &Pose,
        forces: &Vector6<f64>,
        w: &Vector6<f64>,
        up: &Vector3<f64>,
        values: &Vector3<f64>,
    ) -> Vec<WeighEffects> {
        let g = self.gravity_m_s2;
        let at = |w: &Vector6<f64>| mass_and_moments(w, up, g, 0.0);
        let cell = &figures.sensors.load_cell;
        let offsets = (0..6)
            .map(|i| at(&(self.unit_wrench(pose, i) * cell.zero_offset_n)))
            .collect();
        let gains = match &figures.load_cells {
            Some(c) => c
                .modes
                .iter()
                .map(|(sigma, v)| {
                    let dw: Vector6<f64> = (0..6)
                        .map(|i| self.unit_wrench(pose, i) * (sigma * v[i] * forces[i]))
                        .sum();
                    at(&dw)
                })
                .collect(),
            None => (0..6)
                .map(|i| at(&(self.unit_wrench(pose, i) * (cell.gain_error * forces[i]))))
                .collect(),
        };
        let mut joints = Vec::with_capacity(36);
        for plate in [false, true] {
            for leg in 0..6 {
                for coord in 0..3 {
                    joints
                        .push(self.joint_effect(figures, pose, forces, values, plate, leg, coord));
                }
            }
        }
        let legs = match (&self.legs, figures.legs_compensated) {
            (Some(model), true) => (0..crate::budget::legs::FIGURES)
                .filter(|k| *k != 2 && *k != 5 && *k < 6)
                .map(|k| {
                    let by = crate::budget::legs::tolerance(&figures.legs, k);
                    let moved = LegModel {
                        cell_end: model.cell_end,
                        ..crate::budget::legs::moved(&figures.legs, k, by).model()
                    };
                    let dw = static_wrench(&self.geometry, Some(&moved), pose, forces) - w;
                    at(&dw)
                })
                .collect(),
            _ => Vec::new(),
        };
        [
            (ErrorSource::LoadCellOffset, offsets),
            (ErrorSource::LoadCellScale, gains),
            (ErrorSource::Geometry, joints),
            (ErrorSource::LegDynamics, legs),
        ]
        .into_iter()
        .map(|(source, effects)| WeighEffects {
            source: source.id().into(),
            effects,
        })
        .collect()
    }

    /// δ(m, h_x, h_y) of one joint coordinate off by the tolerance: the pose the hold's leg
    /// lengths give on the built rig, and the built rig's wrench map there.
    #[allow(clippy::too_many_arguments)]
    fn joint_effect(
        &self,
        figures: &Figures,
        pose: &Pose,
        forces: &Vector6<f64>,
        values: &Vector3<f64>,
        plate: bool,
        leg: usize,
        coord: usize,
    ) -> [f64; 3] {
        let tol = figures.joint_tolerance_m;
        if tol <= 0.0 {
            return [0.0; 3];
        }
        let moved = crate::budget::perturb::moved_poses(
            &self.geometry,
            core::slice::from_ref(pose),
            plate,
            leg,
            coord,
            tol,
        );
        let built = {
            let mut b = *self.geometry.base_joints_m();
            let mut p = *self.geometry.plate_joints_m();
            let joints = if plate { &mut p } else { &mut b };
            joints[leg][coord] += tol;
            self.geometry.with_joints(b, p).ok()
        };
        let (Some(moved), Some(built)) = (moved, built) else {
            return [0.0; 3];
        };
        let Some(moved) = moved.first() else {
            return [0.0; 3];
        };
        let w = static_wrench(&built, self.legs.as_ref(), moved, forces);
        let up = moved.rotation.inverse() * Vector3::z();
        let v = mass_and_moments(&w, &up, self.gravity_m_s2, 0.0);
        [v[0] - values.x, v[1] - values.y, v[2] - values.z]
    }
}
