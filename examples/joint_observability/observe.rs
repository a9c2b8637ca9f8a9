//! The information the rig's own data carry about the 36 joint coordinates, linearised at the
//! drawing by finite differences through the kinematics, beside the nuisance parameters each
//! observation shares with them.
//!
//! A joint coordinate k off by δ_k gives, for the leg lengths of the true pose x, the pose
//! forward kinematics on the drawing returns: x̂ = x + J⁻¹ (l_built(x) − l_drawn(x)) (one
//! Newton step, first order in δ). Each observation's residual then changes:
//!
//! - gyro: ω̂ − ω = Rᵀ d(δφ)/dt (δφ the small rotation of x̂ in B, R x's rotation);
//! - accelerometer: f̂ − f = −Rᵀ (δφ × (a − g)) + Rᵀ d²(δp)/dt²;
//! - load cells at rest: the forces the drawing predicts at x̂ for the known weight against
//!   those the built legs carry at x, f = M_built(x)⁻¹ W.
//!
//! Every parameter is whitened by its prior sigma; the information is Λ = I + Σ h hᵀ / σ²
//! over rows h (whitened), the posterior covariance Λ⁻¹.

use kinematics::{Geometry, Pose};
use measure::record::Entry;
use nalgebra::{DMatrix, DVector, Matrix3, Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

/// Joint coordinates: base legs 0..6 × xyz, then plate legs 0..6 × xyz (the budget's order).
pub const JOINTS: usize = 36;
/// The IMU's rotation against P (gyro and accelerometer alike).
pub const PSI: usize = 36;
/// The gyro's symmetric matrix error (scales, non-orthogonality): xx yy zz xy xz yz.
pub const GYRO_SYM: usize = 39;
pub const GYRO_BIAS: usize = 45;
pub const ACCEL_BIAS: usize = 48;
pub const ACCEL_SCALE: usize = 51;
pub const LEVER: usize = 54;
pub const DELAY: usize = 57;
pub const GAIN: usize = 58;
/// Zero offsets of the cells, one set per static series (fixture alone, with the reference).
pub const OFFSET: [usize; 2] = [64, 70];
/// Zero drift of the cells, one set per static series.
pub const DRIFT: [usize; 2] = [76, 82];
pub const FIXTURE_MASS: usize = 88;
pub const FIXTURE_COM: usize = 89;
pub const REFERENCE_MASS: usize = 92;
pub const REFERENCE_COM: usize = 93;
/// Every parameter.
pub const N: usize = 96;

/// The figures the rows and priors read.
#[derive(Clone, Copy, Debug)]
pub struct Datasheet {
    /// `platform.joint_position_tolerance_m`, m.
    pub joint_m: f64,
    /// `sensors.sample_rate_hz`.
    pub rate_hz: f64,
    /// Gyro noise density, rad/s/√Hz.
    pub gyro_density: f64,
    /// Accelerometer noise density, m/s²/√Hz.
    pub accel_density: f64,
    /// Accelerometer scale error (not fitted: its datasheet prior).
    pub accel_scale: f64,
    /// Load-cell gain error (its datasheet prior).
    pub gain: f64,
    /// Load-cell noise per sample, N.
    pub cell_noise_n: f64,
    /// Load-cell zero offset, N.
    pub cell_offset_n: f64,
    /// Load-cell zero drift, N/min.
    pub drift_n_per_min: f64,
    /// What a cell's static mean carries besides its noise (crosstalk, the legs' weight
    /// against their described figures), N.
    pub cell_floor_n: f64,
    /// The reference weight, kg.
    pub reference_kg: f64,
    /// Its certificate's sigma, kg.
    pub reference_tolerance_kg: f64,
    /// The fixture's mass (the tare's estimate), kg.
    pub fixture_kg: f64,
    /// The IMU's misalignment, rad.
    pub misalignment_rad: f64,
    /// Gyro scale error.
    pub gyro_scale: f64,
    /// Gyro bias, rad/s.
    pub gyro_bias: f64,
    /// Accelerometer bias, m/s².
    pub accel_bias: f64,
    /// The IMU's position tolerance, m.
    pub imu_position_m: f64,
    /// The IMU's delay, s.
    pub imu_skew_s: f64,
    /// The prior of what the calibrations fit freely, in datasheet figures.
    pub free: f64,
}

impl Datasheet {
    /// The same datasheet with every sensor's noise (gyro, accelerometer, load cells and their
    /// floor) divided by `k`.
    pub fn quieter(&self, k: f64) -> Self {
        Self {
            gyro_density: self.gyro_density / k,
            accel_density: self.accel_density / k,
            cell_noise_n: self.cell_noise_n / k,
            cell_floor_n: self.cell_floor_n / k,
            ..*self
        }
    }
}

/// Prior sigma of every parameter: the joints' tolerance; the datasheet's figure for what no
/// calibration fits (accelerometer scales, gains, drift, the reference's certificate);
/// `free` datasheet figures (the IMU's axes, scales, biases, position and delay, the cells'
/// zero offsets) or a loose bound (the bodies) for what the fits take freely.
pub fn priors(d: &Datasheet) -> DVector<f64> {
    let mut p = DVector::zeros(N);
    let mut set = |from: usize, n: usize, v: f64| {
        for k in from..from + n {
            p[k] = v;
        }
    };
    set(0, JOINTS, d.joint_m);
    set(PSI, 3, d.free * d.misalignment_rad);
    set(GYRO_SYM, 6, d.free * d.gyro_scale);
    set(GYRO_BIAS, 3, d.free * d.gyro_bias);
    set(ACCEL_BIAS, 3, d.free * d.accel_bias);
    set(ACCEL_SCALE, 3, d.accel_scale);
    set(LEVER, 3, d.free * d.imu_position_m);
    set(DELAY, 1, d.free * d.imu_skew_s);
    set(GAIN, 6, d.gain);
    set(OFFSET[0], 12, d.free * d.cell_offset_n);
    set(DRIFT[0], 12, d.drift_n_per_min);
    set(FIXTURE_MASS, 1, 100.0);
    set(FIXTURE_COM, 3, 0.1);
    set(REFERENCE_MASS, 1, d.reference_tolerance_kg);
    set(REFERENCE_COM, 3, 0.1);
    p
}

/// The drawing with joint `k` moved by `h`.
pub fn moved(g: &Geometry, k: usize, h: f64) -> Geometry {
    let (mut b, mut p) = (*g.base_joints_m(), *g.plate_joints_m());
    let (leg, c) = ((k % 18) / 3, k % 3);
    if k >= 18 {
        p[leg][c] += h;
    } else {
        b[leg][c] += h;
    }
    Geometry::from_points(b, p, g.stroke()).expect("a joint 0.2 mm off stays a valid platform")
}

/// The step of finite differences, m.
pub const H: f64 = 1e-5;

/// d x̂ / dδ_k at `pose` for every joint: column k = [δp; δφ] per metre.
pub fn pose_change(g: &Geometry, built: &[Geometry], pose: &Pose) -> [Vector6<f64>; JOINTS] {
    let lu = g.jacobian(pose).lu();
    let l0 = g.leg_lengths(pose);
    core::array::from_fn(|k| {
        let dl = (built[k].leg_lengths(pose) - l0) / H;
        lu.solve(&dl).expect("a regular pose")
    })
}

/// The drawing with each joint moved by the finite-difference step.
pub fn built_all(g: &Geometry) -> Vec<Geometry> {
    (0..JOINTS).map(|k| moved(g, k, H)).collect()
}

pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// Information accumulated in whitened parameters.
pub struct Information {
    /// Every parameter's prior sigma ([`priors`]).
    prior: DVector<f64>,
    /// Λ = I + Σ h hᵀ / σ², whitened.
    lambda: DMatrix<f64>,
}

impl Information {
    /// The prior alone: Λ = I.
    pub fn new(prior: DVector<f64>) -> Self {
        Self {
            prior,
            lambda: DMatrix::identity(N, N),
        }
    }

    /// One row h (unwhitened: residual per unit parameter) with noise sigma.
    pub fn row(&mut self, h: &DVector<f64>, sigma: f64) {
        let w = h.component_mul(&self.prior) / sigma;
        self.lambda.ger(1.0, &w, &w, 1.0);
    }

    /// The joints' posterior covariance, m² (Λ⁻¹'s joint block, unwhitened).
    pub fn joint_covariance(&self) -> DMatrix<f64> {
        let inv = self
            .lambda
            .clone()
            .cholesky()
            .expect("Λ = I + HᵀH is positive definite")
            .inverse();
        let mut p = inv.view((0, 0), (JOINTS, JOINTS)).into_owned();
        for i in 0..JOINTS {
            for j in 0..JOINTS {
                p[(i, j)] *= self.prior[i] * self.prior[j];
            }
        }
        p
    }
}

/// Central differences of a uniformly sampled series (interior points; the ends copy).
fn derivative<const D: usize>(
    x: &[nalgebra::SVector<f64, D>],
    h: f64,
) -> Vec<nalgebra::SVector<f64, D>> {
    let n = x.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            (x[b] - x[a]) / ((b - a) as f64 * h)
        })
        .collect()
}

/// Three centred moving averages of five entries (50 ms at 100 Hz; the window shrinks at the
/// ends): far above the excitation's frequencies.
fn smooth<const D: usize>(x: &[nalgebra::SVector<f64, D>]) -> Vec<nalgebra::SVector<f64, D>> {
    let n = x.len();
    let mut y = x.to_vec();
    for _ in 0..3 {
        let z = y.clone();
        for (i, v) in y.iter_mut().enumerate() {
            let (a, b) = (i.saturating_sub(2), (i + 2).min(n - 1));
            *v = z[a..=b].iter().sum::<nalgebra::SVector<f64, D>>() / (b - a + 1) as f64;
        }
    }
    y
}

/// Which of the IMU's readings of the motion enter.
#[derive(Clone, Copy, Debug)]
pub struct Dynamic {
    pub gyro: bool,
    pub accel: bool,
}

/// The IMU's readings during a motion of the empty plate (the record's entries), against the
/// kinematics' rate and acceleration, with the IMU calibration's parameters beside the joints.
pub fn add_motion(
    info: &mut Information,
    g: &Geometry,
    built: &[Geometry],
    entries: &[Entry],
    d: &Datasheet,
    which: Dynamic,
) {
    let n = entries.len();
    if n < 5 {
        return;
    }
    let h = (entries[n - 1].time_s - entries[0].time_s) / (n - 1) as f64;
    let poses: Vec<Pose> = entries.iter().map(|e| e.pose()).collect();
    let changes: Vec<[Vector6<f64>; JOINTS]> =
        poses.iter().map(|p| pose_change(g, built, p)).collect();
    // The motion's rate, acceleration and specific force from the kinematics, smoothed alike
    // with the joints' changes: the regressors of the nuisances then carry neither the IMU's
    // noise nor the encoders' (a noisy regressor would look independent of a smooth one and
    // fake information).
    let rot: Vec<Matrix3<f64>> = poses.iter().map(|p| *p.rotation.matrix()).collect();
    let gyro = smooth(
        &(0..n)
            .map(|i| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
                let s = rot[i].transpose() * (rot[b] - rot[a]) / ((b - a) as f64 * h);
                Vector3::new(
                    s[(2, 1)] - s[(1, 2)],
                    s[(0, 2)] - s[(2, 0)],
                    s[(1, 0)] - s[(0, 1)],
                ) * 0.5
            })
            .collect::<Vec<_>>(),
    );
    let position: Vec<Vector3<f64>> = poses.iter().map(|p| p.position_m).collect();
    let acc = smooth(&derivative(&derivative(&smooth(&position), h), h));
    let accel: Vec<Vector3<f64>> = (0..n)
        .map(|i| rot[i].transpose() * (acc[i] - GRAVITY_B_M_S2))
        .collect();
    // The IMU's rotation and the accelerometer's position act as a rotation and a
    // translation of the plate's frame: their columns go through the same differences and
    // smoothing as the joints' (an IMU turned by ψ reads Rᵀ d(Rψ)/dt = ω × ψ; one moved by
    // r, Rᵀ d²(R r)/dt² = (ω̇× + ω×ω×) r).
    let mut turn = vec![Matrix3::zeros(); n];
    let mut lever = vec![Matrix3::zeros(); n];
    for c in 0..3 {
        let e: Vec<Vector3<f64>> = rot.iter().map(|r| r.column(c).into()).collect();
        let rate = smooth(&derivative(&e, h));
        let acc = smooth(&derivative(&derivative(&smooth(&e), h), h));
        for i in 0..n {
            turn[i].set_column(c, &(rot[i].transpose() * rate[i]));
            lever[i].set_column(c, &(rot[i].transpose() * acc[i]));
        }
    }
    let gyro_dot = derivative(&gyro, h);
    let accel_dot = derivative(&accel, h);
    // Per joint: δφ's rate and δp's acceleration along the record.
    let mut phi_rate = vec![[Vector3::zeros(); JOINTS]; n];
    let mut p_acc = vec![[Vector3::zeros(); JOINTS]; n];
    for k in 0..JOINTS {
        let phi: Vec<Vector3<f64>> = changes
            .iter()
            .map(|c| c[k].fixed_rows::<3>(3).into())
            .collect();
        let p: Vec<Vector3<f64>> = changes
            .iter()
            .map(|c| c[k].fixed_rows::<3>(0).into())
            .collect();
        let rate = smooth(&derivative(&phi, h));
        let acc = smooth(&derivative(&derivative(&smooth(&p), h), h));
        for i in 0..n {
            phi_rate[i][k] = rate[i];
            p_acc[i][k] = acc[i];
        }
    }
    for i in 8..n - 8 {
        let e = &entries[i];
        let rt = poses[i].rotation.inverse();
        let samples = f64::from(e.samples.max(1));
        let (w, wd, f, fd) = (gyro[i], gyro_dot[i], accel[i], accel_dot[i]);
        let sg = d.gyro_density * (d.rate_hz / samples).sqrt();
        let sa = d.accel_density * (d.rate_hz / samples).sqrt();
        let a_minus_g = poses[i].rotation * f;
        for axis in 0..3 {
            if which.gyro {
                let mut r = DVector::zeros(N);
                for k in 0..JOINTS {
                    r[k] = (rt * phi_rate[i][k])[axis];
                }
                for c in 0..3 {
                    r[PSI + c] = turn[i][(axis, c)];
                }
                let sym = [
                    [w.x, 0.0, 0.0, w.y, w.z, 0.0],
                    [0.0, w.y, 0.0, w.x, 0.0, w.z],
                    [0.0, 0.0, w.z, 0.0, w.x, w.y],
                ];
                for c in 0..6 {
                    r[GYRO_SYM + c] = sym[axis][c];
                }
                r[GYRO_BIAS + axis] = 1.0;
                r[DELAY] = wd[axis];
                info.row(&r, sg);
            }
            if which.accel {
                let mut r = DVector::zeros(N);
                for k in 0..JOINTS {
                    let phi: Vector3<f64> = changes[i][k].fixed_rows::<3>(3).into();
                    r[k] = (rt * (skew(&a_minus_g) * phi + p_acc[i][k]))[axis];
                }
                let s = skew(&f);
                for c in 0..3 {
                    r[PSI + c] = s[(axis, c)];
                    r[LEVER + c] = lever[i][(axis, c)];
                }
                r[ACCEL_SCALE + axis] = f[axis];
                r[ACCEL_BIAS + axis] = 1.0;
                r[DELAY] = fd[axis];
                info.row(&r, sa);
            }
        }
    }
}

/// Orthonormal basis (columns) of the frames' own freedoms in joint space: all base joints
/// moved by one small rigid motion (t + ψ × b_i), and all plate joints likewise.
pub fn gauge(g: &Geometry) -> DMatrix<f64> {
    let mut m = DMatrix::zeros(JOINTS, 12);
    for (frame, joints) in [g.base_joints_m(), g.plate_joints_m()]
        .into_iter()
        .enumerate()
    {
        for dof in 0..6 {
            let col = frame * 6 + dof;
            for (leg, j) in joints.iter().enumerate() {
                let v = if dof < 3 {
                    Vector3::ith(dof, 1.0)
                } else {
                    Vector3::ith(dof - 3, 1.0).cross(j)
                };
                for c in 0..3 {
                    m[(frame * 18 + leg * 3 + c, col)] = v[c];
                }
            }
        }
    }
    m.qr().q()
}

/// The largest difference, over `poses` and every joint moved by `sigma`, between the pose
/// full forward kinematics on the drawing gives for the built rig's leg lengths and the
/// first-order step the information uses, relative to the step's size: a check of the
/// linearisation against an independent solver.
pub fn linearisation_error(g: &Geometry, built: &[Geometry], poses: &[Pose], sigma: f64) -> f64 {
    let options = kinematics::FkOptions {
        tolerance_m: 1e-13,
        ..Default::default()
    };
    let mut worst: f64 = 0.0;
    for pose in poses {
        let changes = pose_change(g, built, pose);
        for (k, change) in changes.iter().enumerate() {
            let lengths = moved(g, k, sigma).leg_lengths(pose);
            let Ok(fk) = g.forward_kinematics(&lengths, pose, &options) else {
                return f64::INFINITY;
            };
            let dp = fk.pose.position_m - pose.position_m;
            let dr = fk.pose.rotation * pose.rotation.inverse();
            let v = dr.scaled_axis();
            let exact = Vector6::new(dp.x, dp.y, dp.z, v.x, v.y, v.z);
            let step = change * sigma;
            worst = worst.max((exact - step).norm() / step.norm().max(1e-12));
        }
    }
    worst
}
