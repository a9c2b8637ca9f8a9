//! The budget's own least-squares fit of the rigid-body equations on a run's record: the same
//! model as the estimator ([`estimator::regressor`]: Newton–Euler about the P origin, linear
//! in θ), with its own zero-phase derivative of the recorded rate ([`crate::record::derivative::d1`]) and no
//! filter, rows weighted by the estimator's equation sigmas W = diag(1/σ²).
//!
//! With A = Σ Φᵢᵀ W Φᵢ over the record and θ̂ the run's reported estimate, an error that
//! changes the equations' residual rᵢ = yᵢ − Φᵢ θ̂ by Δrᵢ moves the least-squares estimate by
//! δθ = A⁻¹ Σ Φᵢᵀ W Δrᵢ to first order (θ̂ fits the data, so only the residual's change
//! counts). The paper's six-parameter model fits J_C alone from the torques about the known
//! centre of mass, τ_C = τ − c × F; m and h stay fixed.

use estimator::regressor::{from_signals, inertia_columns, Regressor, RegressorSignals};
use estimator::{ParameterSet, ParameterVector};
use kinematics::{Geometry, Pose};
use nalgebra::{Matrix3, SMatrix, Vector3, Vector6};

use crate::record::derivative::{d1, interior};
use crate::record::Entry;

/// Which parameters the fit estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// All ten.
    Full,
    /// J_C about a known centre of mass (m, h fixed).
    Six {
        /// The known centre of mass in P, m.
        com_m: Vector3<f64>,
    },
}

impl Mode {
    /// The mode of an estimator's parameter set.
    pub fn of(p: &ParameterSet) -> Self {
        match p {
            ParameterSet::Full => Mode::Full,
            ParameterSet::InertiaAboutKnownCom { com_m, .. } => Mode::Six { com_m: *com_m },
        }
    }

    /// Indices of θ the fit estimates.
    pub fn active(&self) -> core::ops::Range<usize> {
        match self {
            Mode::Full => 0..10,
            Mode::Six { .. } => 4..10,
        }
    }
}

/// What the equations are built from besides the record.
#[derive(Clone, Copy, Debug)]
pub struct Model {
    /// The platform design (wrench map, forward kinematics).
    pub geometry: Geometry,
    /// The accelerometer's position in P, m.
    pub lever_m: Vector3<f64>,
    /// One sigma of each equation [Fx, Fy, Fz, τx, τy, τz] (the estimator's row weights).
    pub equation_sigma: Vector6<f64>,
    /// Which parameters.
    pub mode: Mode,
}

impl Model {
    /// W's diagonal: 1/σ² per row; the force rows are unused with six parameters.
    pub fn weights(&self) -> Vector6<f64> {
        let w = self.equation_sigma.map(|s| 1.0 / (s * s));
        match self.mode {
            Mode::Full => w,
            Mode::Six { com_m } => {
                // τ_C = τ − c × F adds the force noise through the lever c.
                let sf = self.equation_sigma.fixed_rows::<3>(0).max();
                let mut v = Vector6::zeros();
                for k in 3..6 {
                    let s = self.equation_sigma[k];
                    v[k] = 1.0 / (s * s + com_m.norm_squared() * sf * sf);
                }
                v
            }
        }
    }

    /// The mode's regressor of `s`: the full Φ, or for six parameters the torque-about-the-
    /// centre-of-mass rows in the tensor columns (zero elsewhere).
    pub fn regressor(&self, s: &RegressorSignals) -> Regressor {
        match self.mode {
            Mode::Full => from_signals(s),
            Mode::Six { .. } => {
                let mut phi = Regressor::zeros();
                phi.fixed_view_mut::<3, 6>(3, 4)
                    .copy_from(&inertia_columns(s));
                phi
            }
        }
    }

    /// A wrench change Δy = [ΔF; Δτ] as the change of the mode's equations.
    pub fn map_wrench(&self, dy: &Vector6<f64>) -> Vector6<f64> {
        match self.mode {
            Mode::Full => *dy,
            Mode::Six { com_m } => {
                let f = Vector3::new(dy[0], dy[1], dy[2]);
                let t = Vector3::new(dy[3], dy[4], dy[5]) - com_m.cross(&f);
                Vector6::new(0.0, 0.0, 0.0, t.x, t.y, t.z)
            }
        }
    }
}

/// A record's data as the fit reads it (a copy that a perturbation may change).
#[derive(Clone, Debug)]
pub struct Data {
    /// The record's entries.
    pub entries: Vec<Entry>,
    /// Each entry's mean pose.
    pub poses: Vec<Pose>,
    /// The model.
    pub model: Model,
}

impl Data {
    /// The data of `entries` with `model`.
    pub fn new(entries: Vec<Entry>, model: Model) -> Self {
        let poses = entries.iter().map(Entry::pose).collect();
        Self {
            entries,
            poses,
            model,
        }
    }

    /// Every entry's gyro rate.
    pub fn gyro(&self) -> Vec<Vector3<f64>> {
        self.entries.iter().map(|e| e.gyro_rad_s).collect()
    }

    /// The regressor's signals at interior entry `i` (ω̇ by [`d1`] of the recorded rate; the
    /// specific force moved from the accelerometer to the P origin,
    /// f_O = f_r − ω̇ × r − ω × (ω × r), with the averaged products).
    pub fn signals(&self, gyro: &[Vector3<f64>], i: usize, h: f64) -> RegressorSignals {
        let e = &self.entries[i];
        let mut s = RegressorSignals {
            angular_acceleration_rad_s2: d1(gyro, i, h),
            rate_products_rad2_s2: e.products,
            specific_force_m_s2: Vector3::zeros(),
        };
        let r = &self.model.lever_m;
        s.specific_force_m_s2 =
            e.accel_m_s2 - s.angular_acceleration_rad_s2.cross(r) - s.centripetal(r);
        s
    }

    /// The mode's regressor and measurement at interior entry `i`.
    pub fn equation(&self, gyro: &[Vector3<f64>], i: usize, h: f64) -> (Regressor, Vector6<f64>) {
        let s = self.signals(gyro, i, h);
        let y = self.entries[i].wrench;
        (self.model.regressor(&s), self.model.map_wrench(&y))
    }

    /// The residuals y − Φ θ at the interior entries `idx`.
    pub fn residuals(&self, idx: &[usize], h: f64, theta: &ParameterVector) -> Vec<Vector6<f64>> {
        let gyro = self.gyro();
        idx.iter()
            .map(|&i| {
                let (phi, y) = self.equation(&gyro, i, h);
                y - phi * theta
            })
            .collect()
    }
}

/// The fit of one record. See the [module docs](self).
#[derive(Clone, Debug)]
pub struct Fit {
    /// Interior entries (two neighbours each side in a regular stretch).
    pub idx: Vec<usize>,
    /// The record's step, s.
    pub h: f64,
    /// Φᵢ at each interior entry.
    pub phi: Vec<Regressor>,
    /// rᵢ = yᵢ − Φᵢ θ̂.
    pub r0: Vec<Vector6<f64>>,
    /// The θ the residuals are taken about: the mode's θ̂.
    pub theta: ParameterVector,
    /// A⁻¹ on the active parameters (zero elsewhere).
    pub a_inv: SMatrix<f64, 10, 10>,
    /// W's diagonal.
    pub weights: Vector6<f64>,
}

/// θ in the mode's form: the estimate's θ for ten parameters; for six, J_C's entries in the
/// tensor slots (what τ_C = J_C ω̇ + ω × (J_C ω) is linear in).
pub fn mode_theta(mode: &Mode, theta: &ParameterVector) -> ParameterVector {
    match mode {
        Mode::Full => *theta,
        Mode::Six { .. } => {
            let p = estimator::InertialParameters::from_vector(theta);
            let jc: Matrix3<f64> = p.inertia_com_kg_m2().unwrap_or_else(Matrix3::zeros);
            let mut t = ParameterVector::zeros();
            t[4] = jc[(0, 0)];
            t[5] = jc[(1, 1)];
            t[6] = jc[(2, 2)];
            t[7] = jc[(0, 1)];
            t[8] = jc[(0, 2)];
            t[9] = jc[(1, 2)];
            t
        }
    }
}

impl Fit {
    /// The fit of `data` about the run's estimate `theta` (θ about the P origin); `None`
    /// when the record is too short or the normal equations singular.
    pub fn new(data: &Data, theta: &ParameterVector) -> Option<Self> {
        let times: Vec<f64> = data.entries.iter().map(|e| e.time_s).collect();
        let (idx, h) = interior(&times);
        if idx.len() < 20 {
            return None;
        }
        let weights = data.model.weights();
        let theta = mode_theta(&data.model.mode, theta);
        let gyro = data.gyro();
        let mut a = SMatrix::<f64, 10, 10>::zeros();
        let mut phis = Vec::with_capacity(idx.len());
        let mut r0 = Vec::with_capacity(idx.len());
        for &i in &idx {
            let (phi, y) = data.equation(&gyro, i, h);
            a += phi.transpose() * SMatrix::<f64, 6, 6>::from_diagonal(&weights) * phi;
            r0.push(y - phi * theta);
            phis.push(phi);
        }
        let a_inv = invert_active(&a, data.model.mode.active())?;
        Some(Self {
            idx,
            h,
            phi: phis,
            r0,
            theta,
            a_inv,
            weights,
        })
    }

    /// δθ = A⁻¹ Σ Φᵢᵀ W Δrᵢ for residual changes `dr` at the interior entries.
    pub fn effect(&self, dr: &[Vector6<f64>]) -> ParameterVector {
        let mut g = ParameterVector::zeros();
        for (phi, d) in self.phi.iter().zip(dr) {
            g += phi.tr_mul(&d.component_mul(&self.weights));
        }
        self.a_inv * g
    }

    /// The residual change of perturbed data against the base fit's: r(ε) − r(0).
    pub fn residual_change(&self, perturbed: &Data) -> Vec<Vector6<f64>> {
        perturbed
            .residuals(&self.idx, self.h, &self.theta)
            .iter()
            .zip(&self.r0)
            .map(|(r, r0)| r - r0)
            .collect()
    }

    /// The least-squares θ of `data` itself on this fit's entries (in the mode's form), for
    /// checks against a second fit: A⁻¹ Σ Φᵀ W y with `data`'s own Φ and A.
    pub fn solve(data: &Data) -> Option<ParameterVector> {
        let f = Fit::new(data, &ParameterVector::zeros())?;
        // With θ = 0 the residual is y.
        Some(f.effect(&f.r0))
    }
}

/// The inverse of `a` restricted to the `active` block (Cholesky), zero elsewhere.
fn invert_active(
    a: &SMatrix<f64, 10, 10>,
    active: core::ops::Range<usize>,
) -> Option<SMatrix<f64, 10, 10>> {
    let n = active.len();
    let o = active.start;
    let sub = nalgebra::DMatrix::from_fn(n, n, |r, c| a[(o + r, o + c)]);
    let inv = sub.cholesky()?.inverse();
    let mut out = SMatrix::<f64, 10, 10>::zeros();
    for r in 0..n {
        for c in 0..n {
            out[(o + r, o + c)] = inv[(r, c)];
        }
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}
