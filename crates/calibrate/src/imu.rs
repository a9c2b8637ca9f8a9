//! The IMU's alignment against the platform's own kinematics: from a moving plate's record,
//! the matrix that takes the plate's true rate to what the gyro reads, the IMU's delay against
//! the encoders and the accelerometer's position, each with an uncertainty that counts the
//! noise and the joints' tolerance.
//!
//! **The models.** With ω and f the plate's true rate and specific force at the accelerometer,
//! in P, and the readings already turned into P by the described mounting ([`measure::feed`]):
//!
//! - gyro: ω_m(t) = G ω(t − τ) + b_g ≈ G ω(t) − τ ω̇(t) + b_g, G a general 3 × 3 matrix (the
//!   mounting's small rotation, each axis's scale error, any non-orthogonality);
//! - accelerometer: f_m(t + τ) = A (Rᵀ(a_O − g) + ([ω̇×] + [ω×]²) r) + b_a, with A the
//!   rotation of G (its skew part, [`rotation_of`]): gyro and accelerometer in one package
//!   share their axes.
//!
//! The truth comes from forward kinematics of the leg lengths: R, ω = 2 Im(q̄ ⊗ q̇), ω̇ and a_O
//! from the record's mean poses by zero-phase derivatives ([`measure::record::derivative`]). Both fits
//! are linear least squares (`normal`): (G, b_g, τ), then (r, b_a) with A and τ fixed. The
//! encoders and the load cells are taken to sample at the same instant (one controller tick),
//! so τ is also the IMU's delay against the cells.
//!
//! **What is not fitted.** The accelerometer's own scale errors: the kinematics' acceleration
//! of the plate is good only to the joints' tolerance (0.2 mm joints off the drawing move it
//! by about 5e-4 m/s² at the excitation's frequencies), which would set the scales of the
//! weakly moved axes 2e-3 to 6e-3 off, ten times worse than a datasheet's 5e-4. They stay the
//! datasheet's, in the error budget. The biases are fitted but not applied: they change with
//! every power cycle and temperature (the accelerometer's vertical offset is measured at rest
//! before each run instead, [`estimator::hold`]).
//!
//! **Uncertainty.** Each fit's noise covariance is the sandwich A⁻¹ (Σ_b s_b s_bᵀ) A⁻¹ over
//! blocks of [`BLOCK_ENTRIES`] entries, s_b a block's score Σ φ r, which holds for coloured
//! residuals. To it adds the joints' tolerance, as the budget counts it for a measurement
//! ([`measure::budget::perturb`]): each of the 36 joint coordinates moved by the tolerance gives
//! the poses the same leg lengths would have had (one Newton step of forward kinematics), the
//! fit is made again on them, and the change counts as one more independent error.

use kinematics::{Geometry, Pose};
use measure::budget::perturb::moved_poses;
use nalgebra::{DMatrix, Matrix3, Quaternion, SVector, UnitQuaternion, Vector3, Vector6};
use rig_description::calibration::imu::{rotation_of, ImuAlignment};

use crate::normal::Normal;
pub use crate::normal::BLOCK_ENTRIES;
use measure::record::derivative::{d1, d2, interior};
use measure::record::Entry;

/// Fewest entries a fit takes (two seconds at 100 Hz).
pub const MIN_ENTRIES: usize = 200;

/// Why no alignment could be fitted.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AlignmentError {
    /// Too short a record.
    #[error(
        "the run gave {got} record entries of regular motion, the IMU alignment needs at least \
         {MIN_ENTRIES} (2 s of excitation)"
    )]
    TooShort {
        /// Entries found.
        got: usize,
    },
    /// The motion does not determine every parameter (a sensor axis never moved).
    #[error(
        "the motion does not determine the {which} alignment (an axis without rate or \
         acceleration): excite all three rotations and translations"
    )]
    Unobservable {
        /// "gyro" or "accelerometer".
        which: &'static str,
    },
}

/// What one fit gives: [G (9), b_g (3), τ] and [r, b_a], their noise covariances, residuals.
struct Solution {
    gyro: SVector<f64, 13>,
    gyro_cov: DMatrix<f64>,
    accel: SVector<f64, 6>,
    accel_cov: DMatrix<f64>,
    rms: [f64; 2],
    entries: usize,
}

impl Solution {
    /// [G (9), τ].
    fn gyro_parameters(&self) -> SVector<f64, 10> {
        SVector::from_fn(|k, _| if k < 9 { self.gyro[k] } else { self.gyro[12] })
    }

    fn position(&self) -> Vector3<f64> {
        Vector3::new(self.accel[0], self.accel[1], self.accel[2])
    }
}

fn square_from_products(q: &Vector6<f64>) -> Matrix3<f64> {
    #[rustfmt::skip]
    let outer = Matrix3::new(
        q[0], q[3], q[4],
        q[3], q[1], q[5],
        q[4], q[5], q[2],
    );
    outer - Matrix3::identity() * (q[0] + q[1] + q[2])
}

/// The entries whose derivative stencils (two levels: ω from q, then ω̇) stay on a steady
/// grid, and the grid's step.
fn usable(entries: &[Entry]) -> (Vec<usize>, Vec<usize>, f64) {
    // An entry short of samples (a lost frame) has its mean off the grid by up to half a
    // sample period, which the second derivative of the position turns into a large error:
    // it breaks the record like a gap (NaN fails every regular step).
    let full = entries.iter().map(|e| e.samples).max().unwrap_or(0);
    let times: Vec<f64> = entries
        .iter()
        .map(|e| {
            if e.samples == full {
                e.time_s
            } else {
                f64::NAN
            }
        })
        .collect();
    let (idx, h) = interior(&times);
    // A block that spans a lost frame is a period longer than the others: the second
    // derivative on the nominal step would turn it into an acceleration of v·T/h². Stencils
    // keep steps within 2 % of the record's (about 0.2 ms at 100 Hz, ten times a jittered
    // block mean's spread).
    let steady = |k: usize| ((times[k + 1] - times[k]) - h).abs() <= 0.02 * h;
    let idx: Vec<usize> = idx
        .into_iter()
        .filter(|&i| (i - 2..i + 2).all(steady))
        .collect();
    let inner = idx
        .iter()
        .copied()
        .filter(|&i| i >= 2 && (i - 2..=i + 2).all(|j| idx.binary_search(&j).is_ok()))
        .collect();
    (idx, inner, h)
}

/// Both fits on `entries` at the poses `poses` (the record's, or moved by a joint's error).
fn solve(
    entries: &[Entry],
    poses: &[Pose],
    idx: &[usize],
    inner: &[usize],
    h: f64,
    gravity_b: &Vector3<f64>,
) -> Result<Solution, AlignmentError> {
    // Quaternions with consecutive signs aligned, so their derivative is the rotation's.
    let mut quats: Vec<SVector<f64, 4>> = Vec::with_capacity(poses.len());
    for p in poses {
        let q = UnitQuaternion::from_rotation_matrix(&p.rotation)
            .into_inner()
            .coords;
        let q = match quats.last() {
            Some(prev) if prev.dot(&q) < 0.0 => -q,
            _ => q,
        };
        quats.push(q);
    }
    let positions: Vec<Vector3<f64>> = poses.iter().map(|p| p.position_m).collect();
    let gyro: Vec<Vector3<f64>> = entries.iter().map(|e| e.gyro_rad_s).collect();
    let accel: Vec<Vector3<f64>> = entries.iter().map(|e| e.accel_m_s2).collect();
    // The plate's rate from the kinematics, and its derivative: ω̇ from the kinematics carries
    // about a twentieth of the gyro's derivative noise, which in the regressors (through
    // [ω̇×] r) would bias the fit towards zero (errors in variables).
    let mut rate = vec![Vector3::zeros(); entries.len()];
    for &i in idx {
        let q = Quaternion::from(quats[i]);
        let qdot = Quaternion::from(d1(&quats, i, h));
        rate[i] = (q.conjugate() * qdot).imag() * 2.0;
    }

    // Gyro: [G row-major, b_g, τ].
    let mut g_fit = Normal::<13>::new();
    for &i in inner {
        let w = rate[i];
        let wdot = d1(&rate, i, h);
        for k in 0..3 {
            let mut phi = SVector::<f64, 13>::zeros();
            for j in 0..3 {
                phi[3 * k + j] = w[j];
            }
            phi[9 + k] = 1.0;
            phi[12] = -wdot[k];
            g_fit.push(i, k, phi, gyro[i][k]);
        }
    }
    let (gx, gyro_cov, g_rms) = g_fit
        .solve()
        .ok_or(AlignmentError::Unobservable { which: "gyro" })?;
    let gyro_x = SVector::<f64, 13>::from_iterator(gx.iter().copied());
    let g = Matrix3::from_fn(|i, j| gyro_x[3 * i + j]);
    let tau = gyro_x[12];
    let a = rotation_of(&g);

    // Accelerometer: y − A s = A K r + b_a, in [r, b_a].
    let mut a_fit = Normal::<6>::new();
    for &i in inner {
        let rot = UnitQuaternion::from_quaternion(Quaternion::from(quats[i]));
        let s = rot.inverse_transform_vector(&(d2(&positions, i, h) - gravity_b));
        let k_mat = d1(&rate, i, h).cross_matrix() + square_from_products(&entries[i].products);
        let ak = a * k_mat;
        let y = accel[i] + d1(&accel, i, h) * tau - a * s;
        for row in 0..3 {
            let mut phi = SVector::<f64, 6>::zeros();
            for j in 0..3 {
                phi[j] = ak[(row, j)];
            }
            phi[3 + row] = 1.0;
            a_fit.push(i, row, phi, y[row]);
        }
    }
    let (ax, accel_cov, a_rms) = a_fit.solve().ok_or(AlignmentError::Unobservable {
        which: "accelerometer",
    })?;
    Ok(Solution {
        gyro: gyro_x,
        gyro_cov,
        accel: SVector::<f64, 6>::from_iterator(ax.iter().copied()),
        accel_cov,
        rms: [g_rms, a_rms],
        entries: inner.len(),
    })
}

fn nested(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// Fits the IMU's alignment to a moving plate's record entries: `gravity_b` the gravity
/// vector in B (m/s²), `geometry` the described platform and `joint_tolerance_m` one sigma of
/// each joint coordinate, counted in the covariances. See the [module docs](self).
pub fn fit(
    entries: &[Entry],
    gravity_b: &Vector3<f64>,
    geometry: &Geometry,
    joint_tolerance_m: f64,
) -> Result<ImuAlignment, AlignmentError> {
    let (idx, inner, h) = usable(entries);
    if inner.len() < MIN_ENTRIES {
        return Err(AlignmentError::TooShort { got: inner.len() });
    }
    let poses: Vec<Pose> = entries.iter().map(Entry::pose).collect();
    let base = solve(entries, &poses, &idx, &inner, h, gravity_b)?;
    let g = Matrix3::from_fn(|i, j| base.gyro[3 * i + j]);
    if g.try_inverse().is_none() {
        return Err(AlignmentError::Unobservable { which: "gyro" });
    }
    // [G, τ] and r: the noise's covariance, then each joint coordinate's change.
    let gyro_keep: Vec<usize> = (0..9).chain([12]).collect();
    let mut gyro_cov = DMatrix::from_fn(10, 10, |i, j| base.gyro_cov[(gyro_keep[i], gyro_keep[j])]);
    let mut position_cov = DMatrix::from_fn(3, 3, |i, j| base.accel_cov[(i, j)]);
    if joint_tolerance_m > 0.0 {
        for plate in [false, true] {
            for leg in 0..kinematics::LEG_COUNT {
                for coord in 0..3 {
                    let Some(moved) =
                        moved_poses(geometry, &poses, plate, leg, coord, joint_tolerance_m)
                    else {
                        continue;
                    };
                    let Ok(s) = solve(entries, &moved, &idx, &inner, h, gravity_b) else {
                        continue;
                    };
                    let dg = s.gyro_parameters() - base.gyro_parameters();
                    let dr = s.position() - base.position();
                    gyro_cov += DMatrix::from_fn(10, 10, |i, j| dg[i] * dg[j]);
                    position_cov += DMatrix::from_fn(3, 3, |i, j| dr[i] * dr[j]);
                }
            }
        }
    }
    Ok(ImuAlignment {
        gyro_matrix: core::array::from_fn(|i| core::array::from_fn(|j| g[(i, j)])),
        gyro_bias_rad_s: [base.gyro[9], base.gyro[10], base.gyro[11]],
        accel_bias_m_s2: [base.accel[3], base.accel[4], base.accel[5]],
        accelerometer_position_m: base.position().into(),
        imu_delay_s: base.gyro[12],
        gyro_covariance: nested(&gyro_cov),
        position_covariance: nested(&position_cov),
        joint_tolerance_m,
        residual_rms: base.rms,
        entries: base.entries as u64,
    })
}

#[cfg(test)]
mod tests;
