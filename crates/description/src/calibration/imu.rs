//! The IMU's alignment against the platform's own kinematics as a calibration file holds it:
//! the matrix G that takes the plate's true rate to what the gyro reads, the IMU's delay τ and
//! the accelerometer's position r, each with its covariance (measure's `calibration::imu`
//! fits it; docs/calibration.md).

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};
use serde::{Deserialize, Serialize};

/// The fitted IMU alignment. Matrices are row-major.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuAlignment {
    /// G: the gyro's reading in P (after the described mounting) is G ω + b_g.
    pub gyro_matrix: [[f64; 3]; 3],
    /// b_g, rad/s (reported, not applied).
    pub gyro_bias_rad_s: [f64; 3],
    /// b_a, m/s² (reported, not applied).
    pub accel_bias_m_s2: [f64; 3],
    /// r: the accelerometer's position in P, m.
    pub accelerometer_position_m: [f64; 3],
    /// τ: the IMU's readings are this late against the encoders and load cells, s.
    pub imu_delay_s: f64,
    /// Covariance of [G (9, row-major), τ]: noise and joints' tolerance.
    pub gyro_covariance: Vec<Vec<f64>>,
    /// Covariance of r, m²: noise and joints' tolerance.
    pub position_covariance: Vec<Vec<f64>>,
    /// The joints' tolerance counted, m.
    pub joint_tolerance_m: f64,
    /// RMS residual of the gyro's fit, rad/s, and of the accelerometer's, m/s² (smoothed
    /// record entries).
    pub residual_rms: [f64; 2],
    /// Record entries fitted.
    pub entries: u64,
}

/// Names of the gyro's fitted parameters, in the covariance's order.
pub const GYRO_PARAMETERS: [&str; 10] = [
    "G xx", "G xy", "G xz", "G yx", "G yy", "G yz", "G zx", "G zy", "G zz", "tau",
];

/// The rotation of a near-identity matrix M: exp([θ×]) with θ the axial vector of M's skew
/// part (M − Mᵀ)/2 (the polar decomposition's rotation to first order in M − I).
pub fn rotation_of(m: &Matrix3<f64>) -> Matrix3<f64> {
    let theta = Vector3::new(
        0.5 * (m[(2, 1)] - m[(1, 2)]),
        0.5 * (m[(0, 2)] - m[(2, 0)]),
        0.5 * (m[(1, 0)] - m[(0, 1)]),
    );
    *Rotation3::new(theta).matrix()
}

impl ImuAlignment {
    /// G as a matrix.
    pub fn gyro(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.gyro_matrix[i][j])
    }

    /// A: the accelerometer's reading in P is A f + b_a, A the rotation of G
    /// ([`rotation_of`]: one package, the gyro's axes).
    pub fn accel(&self) -> Matrix3<f64> {
        rotation_of(&self.gyro())
    }

    /// One sigma of the gyro's parameter `k` ([`GYRO_PARAMETERS`]).
    pub fn gyro_sigma(&self, k: usize) -> f64 {
        diagonal(&self.gyro_covariance, k)
    }

    /// One sigma of the accelerometer position's coordinate `k`, m.
    pub fn position_sigma(&self, k: usize) -> f64 {
        diagonal(&self.position_covariance, k)
    }

    /// The covariance of [G (9), τ] as a matrix (zero where the file is short).
    pub fn gyro_covariance_matrix(&self) -> DMatrix<f64> {
        matrix(&self.gyro_covariance, 10)
    }

    /// The covariance of r as a matrix (zero where the file is short).
    pub fn position_covariance_matrix(&self) -> DMatrix<f64> {
        matrix(&self.position_covariance, 3)
    }
}

fn matrix(rows: &[Vec<f64>], n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(n, n, |i, j| {
        rows.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
    })
}

fn diagonal(cov: &[Vec<f64>], k: usize) -> f64 {
    cov.get(k)
        .and_then(|row| row.get(k))
        .map_or(f64::NAN, |v| v.max(0.0).sqrt())
}
