//! Calibrations as the error budget applies them: the principal directions of a calibrated
//! IMU's and calibrated load-cell gains' covariances, and the gains' sensitivity to the joints
//! ([`super::perturb`] turns each into elementary errors).

use nalgebra::{Matrix3, Vector3, Vector6};

/// A calibrated IMU's uncertainty as the budget applies it: the principal directions of its
/// covariances, each with its sigma (√ of the eigenvalue).
#[derive(Clone, Debug, PartialEq)]
pub struct CalibratedImu {
    /// δG of unit size (Frobenius) along each eigenvector of G's 9 × 9 covariance, and its
    /// sigma.
    pub gyro_modes: Vec<(f64, Matrix3<f64>)>,
    /// Unit δr along each eigenvector of r's covariance, and its sigma (m).
    pub lever_modes: Vec<(f64, Vector3<f64>)>,
    /// One sigma of the calibrated delay, s.
    pub delay_sigma_s: f64,
}

impl CalibratedImu {
    /// The modes of `alignment`'s covariances.
    pub fn of(alignment: &rig_description::calibration::ImuAlignment) -> Self {
        let gyro = alignment.gyro_covariance_matrix();
        let g9 = gyro.view((0, 0), (9, 9)).into_owned();
        let eig = g9.symmetric_eigen();
        let gyro_modes = (0..9)
            .map(|k| {
                let v = eig.eigenvectors.column(k);
                (
                    eig.eigenvalues[k].max(0.0).sqrt(),
                    Matrix3::from_fn(|i, j| v[3 * i + j]),
                )
            })
            .collect();
        let eig = alignment.position_covariance_matrix().symmetric_eigen();
        let lever_modes = (0..3)
            .map(|k| {
                let v = eig.eigenvectors.column(k);
                (
                    eig.eigenvalues[k].max(0.0).sqrt(),
                    Vector3::new(v[0], v[1], v[2]),
                )
            })
            .collect();
        Self {
            gyro_modes,
            lever_modes,
            delay_sigma_s: alignment.gyro_sigma(9),
        }
    }
}

/// Calibrated load-cell gains' uncertainty as the budget applies it: the principal directions
/// of their 6 × 6 covariance, each with its sigma (√ of the eigenvalue). The gains' errors
/// are correlated (their mean is fixed by the reference mass, their differences by the
/// motion), so the modes, not six independent sigmas, carry what the calibration left.
///
/// The calibration's gains are blurred by the same built joints the `geometry` line moves in
/// the measurement. When the file gives each joint coordinate's change of the gains s_k
/// ([`rig_description::calibration::LoadCellGains::joint_sensitivity`]), the modes are those of the
/// covariance without the joints' part, and the `geometry` line's joint k moves the applied
/// gains by s_k with the joint ([`super::perturb::Scalar::Joint`]): one correlated effect per joint.
#[derive(Clone, Debug, PartialEq)]
pub struct CalibratedGains {
    /// Unit δg along each eigenvector, and its sigma.
    pub modes: Vec<(f64, Vector6<f64>)>,
    /// s_k per metre of joint coordinate k ([`rig_description::calibration::load_cells::joint_index`] order);
    /// empty when the file does not give them (the joints then count in the modes).
    pub joint_per_m: Vec<Vector6<f64>>,
}

impl CalibratedGains {
    /// The modes of `gains`' covariance, without the joints' part when the file gives it.
    pub fn of(gains: &rig_description::calibration::LoadCellGains) -> Self {
        let (cov, joint_per_m) = match gains.joint_share() {
            Some((without, per_m)) => (without, per_m),
            None => (gains.covariance_matrix(), Vec::new()),
        };
        let eig = cov.symmetric_eigen();
        let modes = (0..6)
            .map(|k| {
                let v = eig.eigenvectors.column(k);
                (
                    eig.eigenvalues[k].max(0.0).sqrt(),
                    Vector6::from_fn(|i, _| v[i]),
                )
            })
            .collect();
        Self { modes, joint_per_m }
    }

    /// The applied gains' change when joint coordinate (`plate`, `leg`, `coord`) is off by
    /// `offset_m` (zero when the file gives no sensitivities).
    pub fn joint_change(
        &self,
        plate: bool,
        leg: usize,
        coord: usize,
        offset_m: f64,
    ) -> Vector6<f64> {
        self.joint_per_m
            .get(rig_description::calibration::load_cells::joint_index(
                plate, leg, coord,
            ))
            .map_or_else(Vector6::zeros, |s| s * offset_m)
    }
}
