//! The IMU's alignment against the platform's own kinematics: from a moving plate's record,
//! the matrices that take the plate's true rate and specific force to what the IMU reads, the
//! accelerometer's position and the IMU's delay against the encoders, each with its covariance.
//!
//! **The models.** With ω and f the plate's true rate and specific force at the accelerometer,
//! in P, and the readings already turned into P by the described mounting ([`crate::feed`]):
//!
//! - gyro: ω_m(t) = G ω(t − τ) + b_g ≈ G ω(t) − τ ω̇_m(t) + b_g;
//! - accelerometer: f_m(t + τ) = A f(t) + b_a, f = Rᵀ(a_O − g) + ([ω̇×] + [ω×]²) r.
//!
//! G and A are general 3 × 3 matrices (the mounting's small rotation, each axis's scale error
//! and any non-orthogonality), r the accelerometer's position in P, τ the IMU's delay (one for
//! both sensors of one package), b the biases. The truth comes from forward kinematics of the
//! leg lengths: R and a_O from the record's mean poses by zero-phase derivatives
//! ([`crate::budget::util`]), ω = 2 Im(q̄ ⊗ q̇). The gyro's equations are linear in
//! (G, b_g, τ); the accelerometer's in (A, b_a) for a given r and in r for a given A, solved by
//! two Gauss–Newton passes from A = I. The encoders and the load cells are taken to sample at
//! the same instant (one controller tick), so τ is also the IMU's delay against the cells.
//!
//! **Uncertainty.** Each fit's covariance is the sandwich A⁻¹ (Σ_b s_b s_bᵀ) A⁻¹ over blocks of
//! [`BLOCK_ENTRIES`] entries, s_b the block's score Σ φ r: it holds whatever the residuals are
//! (the gyro's white noise, the derivative's coloured noise of the encoders), as long as they
//! are short-correlated against a block. What it cannot see is a systematic error common to
//! the kinematics and the motion: joints built off the drawing tilt the forward kinematics'
//! pose by about the joint tolerance over the plate's radius (0.2 mm over 1 m: 2e-4 rad).
//!
//! **What is applied.** The matrices, the position and the delay describe the build and stay;
//! the biases change with every power cycle and temperature, so they are reported and not
//! applied (the accelerometer's vertical offset is measured at rest before each run instead,
//! [`estimator::hold`]).

use nalgebra::{DMatrix, DVector, Matrix3, Quaternion, SVector, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::budget::record::Entry;
use crate::budget::util::{d1, d2, interior};

/// Entries per block of the sandwich covariance: 0.4 s at the record's 100 Hz, long against
/// the derivatives' stencils and the smoothing's reach, short against a 20 s run.
pub const BLOCK_ENTRIES: usize = 40;

/// Fewest interior entries a fit takes (two seconds at 100 Hz).
pub const MIN_ENTRIES: usize = 200;

/// The fitted IMU alignment. Matrices are row-major; covariances are over the parameter
/// vectors of [`GYRO_PARAMETERS`] and [`ACCEL_PARAMETERS`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuAlignment {
    /// G: the gyro's reading in P (after the described mounting) is G ω + b_g.
    pub gyro_matrix: [[f64; 3]; 3],
    /// b_g, rad/s (reported, not applied).
    pub gyro_bias_rad_s: [f64; 3],
    /// A: the accelerometer's reading in P is A f + b_a.
    pub accel_matrix: [[f64; 3]; 3],
    /// b_a, m/s² (reported, not applied).
    pub accel_bias_m_s2: [f64; 3],
    /// r: the accelerometer's position in P, m.
    pub accelerometer_position_m: [f64; 3],
    /// τ: the IMU's readings are this late against the encoders and load cells, s.
    pub imu_delay_s: f64,
    /// Covariance of [G (9, row-major), τ].
    pub gyro_covariance: Vec<Vec<f64>>,
    /// Covariance of [A (9, row-major), r (3)].
    pub accel_covariance: Vec<Vec<f64>>,
    /// RMS residual of the gyro's fit, rad/s, and of the accelerometer's, m/s² (per record
    /// entry).
    pub residual_rms: [f64; 2],
    /// Record entries fitted.
    pub entries: u64,
}

/// Names of the gyro's fitted parameters, in the covariance's order.
pub const GYRO_PARAMETERS: [&str; 10] = [
    "G xx", "G xy", "G xz", "G yx", "G yy", "G yz", "G zx", "G zy", "G zz", "tau",
];

/// Names of the accelerometer's fitted parameters, in the covariance's order.
pub const ACCEL_PARAMETERS: [&str; 12] = [
    "A xx", "A xy", "A xz", "A yx", "A yy", "A yz", "A zx", "A zy", "A zz", "r x", "r y", "r z",
];

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
        /// Interior entries found.
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

/// Passes of the moving average [`smooth`] applies.
const SMOOTHING_PASSES: usize = 3;

/// Width of each pass, entries: three passes of five are close to a Gaussian of 2.4 entries
/// (24 ms at 100 Hz), which keeps the excitation (gain 0.96 at 1.9 Hz, alike on both sides of
/// every equation) and removes the second derivative's noise near the record's Nyquist rate.
const SMOOTHING_WIDTH: usize = 5;

/// One linear least-squares problem, one equation φᵀ x = y per record entry and component.
///
/// Every equation is linear in the signals, so a moving average applied alike to y and to
/// every column of φ keeps it exact; it takes out of the regressors the noise of the
/// kinematics' second derivative (blue, most of it far above the excitation), which would
/// otherwise bias the fit towards zero (errors in variables).
struct Normal<const P: usize> {
    /// (record entry, component, φ, y).
    rows: Vec<(usize, usize, SVector<f64, P>, f64)>,
}

/// The moving average of `SMOOTHING_PASSES` passes over consecutive entries of one
/// component; entries within the averages' reach of a break in the record are dropped.
fn smooth<const P: usize>(
    rows: &[(usize, SVector<f64, P>, f64)],
) -> Vec<(usize, SVector<f64, P>, f64)> {
    let mut out = Vec::new();
    let mut start = 0;
    while start < rows.len() {
        let mut end = start + 1;
        while end < rows.len() && rows[end].0 == rows[end - 1].0 + 1 {
            end += 1;
        }
        let mut run: Vec<(usize, SVector<f64, P>, f64)> = rows[start..end].to_vec();
        for _ in 0..SMOOTHING_PASSES {
            if run.len() < SMOOTHING_WIDTH {
                run.clear();
                break;
            }
            run = run
                .windows(SMOOTHING_WIDTH)
                .map(|w| {
                    let n = w.len() as f64;
                    let phi = w.iter().map(|r| r.1).sum::<SVector<f64, P>>() / n;
                    let y = w.iter().map(|r| r.2).sum::<f64>() / n;
                    (w[w.len() / 2].0, phi, y)
                })
                .collect();
        }
        out.extend(run);
        start = end;
    }
    out
}

impl<const P: usize> Normal<P> {
    fn new() -> Self {
        Self { rows: Vec::new() }
    }

    /// One equation φᵀ x = y of record entry `entry`, component `component`.
    fn push(&mut self, entry: usize, component: usize, phi: SVector<f64, P>, y: f64) {
        self.rows.push((entry, component, phi, y));
    }

    /// The solution, the sandwich covariance and the residual rms of the smoothed equations;
    /// `None` when singular.
    fn solve(&self) -> Option<(DVector<f64>, DMatrix<f64>, f64)> {
        let mut rows: Vec<(usize, SVector<f64, P>, f64)> = Vec::new();
        for component in 0..3 {
            let one: Vec<(usize, SVector<f64, P>, f64)> = self
                .rows
                .iter()
                .filter(|r| r.1 == component)
                .map(|r| (r.0, r.2, r.3))
                .collect();
            rows.extend(smooth(&one));
        }
        rows.sort_by_key(|r| r.0);
        let mut info = DMatrix::<f64>::zeros(P, P);
        let mut rhs = DVector::<f64>::zeros(P);
        for (_, phi, y) in &rows {
            info += phi * phi.transpose();
            rhs += phi * *y;
        }
        let scale = DVector::from_iterator(
            P,
            (0..P).map(|i| {
                let d = info[(i, i)];
                if d > 0.0 {
                    1.0 / d.sqrt()
                } else {
                    0.0
                }
            }),
        );
        let s = DMatrix::from_diagonal(&scale);
        let scaled = &s * &info * &s;
        let eig = scaled.clone().symmetric_eigen();
        let (lo, hi) = eig
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        // NaN in the information fails this too.
        if lo.partial_cmp(&(1e-10 * hi)) != Some(core::cmp::Ordering::Greater) {
            return None;
        }
        let inv = &s * scaled.try_inverse()? * &s;
        let x = &inv * &rhs;
        let xs = SVector::<f64, P>::from_iterator(x.iter().copied());
        let mut scores = DMatrix::zeros(P, P);
        let mut block = DVector::zeros(P);
        let mut current = None;
        let mut blocks = 0usize;
        let mut sum_sq = 0.0;
        for (entry, phi, y) in &rows {
            let r = y - phi.dot(&xs);
            sum_sq += r * r;
            let b = entry / BLOCK_ENTRIES;
            if current != Some(b) {
                scores += &block * block.transpose();
                block.fill(0.0);
                current = Some(b);
                blocks += 1;
            }
            for (k, p) in phi.iter().enumerate() {
                block[k] += p * r;
            }
        }
        scores += &block * block.transpose();
        // Blocks' scores scatter about the fitted θ, not the true one: n/(n − p) undoes it.
        let dof = blocks.saturating_sub(P).max(1) as f64;
        let cov = &inv * scores * &inv * (blocks as f64 / dof);
        let rms = (sum_sq / rows.len().max(1) as f64).sqrt();
        Some((x, cov, rms))
    }
}

fn cross(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// [ω×]² = ω ωᵀ − |ω|² I from the mean products [xx, yy, zz, xy, xz, yz].
fn square_from_products(q: &Vector6<f64>) -> Matrix3<f64> {
    #[rustfmt::skip]
    let outer = Matrix3::new(
        q[0], q[3], q[4],
        q[3], q[1], q[5],
        q[4], q[5], q[2],
    );
    outer - Matrix3::identity() * (q[0] + q[1] + q[2])
}

fn rows_of(v: &DVector<f64>, at: usize) -> [[f64; 3]; 3] {
    core::array::from_fn(|i| core::array::from_fn(|j| v[at + 3 * i + j]))
}

fn nested(m: &DMatrix<f64>) -> Vec<Vec<f64>> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| m[(i, j)]).collect())
        .collect()
}

/// Fits the IMU's alignment to a moving plate's record entries, `gravity_b` the gravity
/// vector in B (m/s²). See the [module docs](self).
pub fn fit(entries: &[Entry], gravity_b: &Vector3<f64>) -> Result<ImuAlignment, AlignmentError> {
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
    let steady = |k: usize| {
        let step = times[k + 1] - times[k];
        (step - h).abs() <= 0.02 * h
    };
    let idx: Vec<usize> = idx
        .into_iter()
        .filter(|&i| (i - 2..i + 2).all(steady))
        .collect();
    if idx.len() < MIN_ENTRIES {
        return Err(AlignmentError::TooShort { got: idx.len() });
    }
    // Quaternions with consecutive signs aligned, so their derivative is the rotation's.
    let mut quats: Vec<SVector<f64, 4>> = Vec::with_capacity(entries.len());
    for e in entries {
        let q = e.quaternion.normalize().coords;
        let q = match quats.last() {
            Some(prev) if prev.dot(&q) < 0.0 => -q,
            _ => q,
        };
        quats.push(q);
    }
    let positions: Vec<Vector3<f64>> = entries.iter().map(|e| e.position_m).collect();
    let gyro: Vec<Vector3<f64>> = entries.iter().map(|e| e.gyro_rad_s).collect();
    let accel: Vec<Vector3<f64>> = entries.iter().map(|e| e.accel_m_s2).collect();

    // The plate's rate from the kinematics at every interior entry, and its derivative where
    // the rate's own stencil is interior too: ω̇ from the kinematics carries about a twentieth
    // of the gyro's derivative noise, which in the regressors (through [ω̇×] r) would bias the
    // fit towards zero (errors in variables).
    let mut rate = vec![Vector3::zeros(); entries.len()];
    for &i in &idx {
        let q = Quaternion::from(quats[i]);
        let qdot = Quaternion::from(d1(&quats, i, h));
        rate[i] = (q.conjugate() * qdot).imag() * 2.0;
    }
    let inner: Vec<usize> = idx
        .iter()
        .copied()
        .filter(|&i| i >= 2 && (i - 2..=i + 2).all(|j| idx.binary_search(&j).is_ok()))
        .collect();
    if inner.len() < MIN_ENTRIES {
        return Err(AlignmentError::TooShort { got: inner.len() });
    }

    // Gyro: [G row-major, b_g, τ].
    let mut g_fit = Normal::<13>::new();
    for &i in &inner {
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
    let (gx, gcov, g_rms) = g_fit
        .solve()
        .ok_or(AlignmentError::Unobservable { which: "gyro" })?;
    let g = Matrix3::from_fn(|i, j| gx[3 * i + j]);
    let tau = gx[12];
    if g.try_inverse().is_none() {
        return Err(AlignmentError::Unobservable { which: "gyro" });
    }

    // Accelerometer: [A row-major, b_a, r], two passes from A = I.
    let mut a: Matrix3<f64> = Matrix3::identity();
    let mut r = Vector3::zeros();
    let mut result = None;
    for _ in 0..3 {
        let mut a_fit = Normal::<15>::new();
        for &i in &inner {
            let rot = nalgebra::UnitQuaternion::from_quaternion(Quaternion::from(quats[i]));
            let a_o = d2(&positions, i, h);
            let s = rot.inverse_transform_vector(&(a_o - gravity_b));
            let wdot = d1(&rate, i, h);
            let k_mat = cross(&wdot) + square_from_products(&entries[i].products);
            let ak: Matrix3<f64> = a * k_mat;
            let y = accel[i] + d1(&accel, i, h) * tau;
            // y = A s + A K r + b: linear in A with A K r taken at the last pass's r, and in r
            // with A at the last pass's A; the A-part of A K r is moved to the A columns.
            let f = s + k_mat * r;
            for row in 0..3 {
                let mut phi = SVector::<f64, 15>::zeros();
                for j in 0..3 {
                    phi[3 * row + j] = f[j];
                    phi[12 + j] = ak[(row, j)];
                }
                phi[9 + row] = 1.0;
                // A K r already counts in the A columns through f: take it out of y.
                let y_row = y[row] + (ak * r)[row];
                a_fit.push(i, row, phi, y_row);
            }
        }
        let (ax, acov, a_rms) = a_fit.solve().ok_or(AlignmentError::Unobservable {
            which: "accelerometer",
        })?;
        a = Matrix3::from_fn(|i, j| ax[3 * i + j]);
        r = Vector3::new(ax[12], ax[13], ax[14]);
        result = Some((ax, acov, a_rms));
    }
    let (ax, acov, a_rms) = result.ok_or(AlignmentError::Unobservable {
        which: "accelerometer",
    })?;
    let pick = |m: &DMatrix<f64>, keep: &[usize]| {
        DMatrix::from_fn(keep.len(), keep.len(), |i, j| m[(keep[i], keep[j])])
    };
    let gyro_keep: Vec<usize> = (0..9).chain([12]).collect();
    let accel_keep: Vec<usize> = (0..9).chain(12..15).collect();
    Ok(ImuAlignment {
        gyro_matrix: rows_of(&gx, 0),
        gyro_bias_rad_s: [gx[9], gx[10], gx[11]],
        accel_matrix: rows_of(&ax, 0),
        accel_bias_m_s2: [ax[9], ax[10], ax[11]],
        accelerometer_position_m: [ax[12], ax[13], ax[14]],
        imu_delay_s: tau,
        gyro_covariance: nested(&pick(&gcov, &gyro_keep)),
        accel_covariance: nested(&pick(&acov, &accel_keep)),
        residual_rms: [g_rms, a_rms],
        entries: inner.len() as u64,
    })
}

impl ImuAlignment {
    /// G as a matrix.
    pub fn gyro(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.gyro_matrix[i][j])
    }

    /// A as a matrix.
    pub fn accel(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.accel_matrix[i][j])
    }

    /// One sigma of the gyro's parameter `k` ([`GYRO_PARAMETERS`]).
    pub fn gyro_sigma(&self, k: usize) -> f64 {
        diagonal(&self.gyro_covariance, k)
    }

    /// One sigma of the accelerometer's parameter `k` ([`ACCEL_PARAMETERS`]).
    pub fn accel_sigma(&self, k: usize) -> f64 {
        diagonal(&self.accel_covariance, k)
    }
}

fn diagonal(cov: &[Vec<f64>], k: usize) -> f64 {
    cov.get(k)
        .and_then(|row| row.get(k))
        .map_or(f64::NAN, |v| v.max(0.0).sqrt())
}

#[cfg(test)]
#[path = "imu_tests.rs"]
mod tests;
