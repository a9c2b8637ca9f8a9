//! The systematic part of the reported uncertainty: the accelerometer's bias.
//!
//! The estimator's covariance covers the noise. A constant accelerometer bias b is not noise:
//! it tilts and scales the measured gravity the fit leans on, shifting the mass by about
//! m·b_z/g and the centre of mass by about c_z·b_xy/g. Unlike a load-cell offset it does not
//! cancel with the tare, because its effect is proportional to the mass on the plate. Its size
//! is a datasheet figure (bias stability), so its effect is a type-B uncertainty: the
//! estimator's first-order sensitivity to a constant bias
//! ([`estimator::OnlineEstimator::accel_bias_sensitivity`], from its accumulated normal-equation
//! terms; it matches three more estimators fed the samples with one sigma of bias added to
//! about 1e-4 of the effect) times one sigma along x, y and z
//! ([`crate::measurement::MeasureOutcome::accel_bias_effect`]), and the payload's share of the three
//! shifts, d = effect(loaded) − effect(tare) (the same accelerometer in both runs), adds
//! Σ d dᵀ to the covariance of θ.
//!
//! The load cells' zero offsets are treated alike: a constant offset b of one cell moves θ by
//! [`estimator::OnlineEstimator::leg_force_offset_sensitivity`] · b (exact: it reaches the
//! wrench through each sample's leg directions, which the estimator conditions alongside), with
//! b one datasheet sigma of the cell's zero offset ([`crate::setup::load_cell_bias_sigma`]). Most of it cancels
//! with the tare (the same cells in both runs); the rest — through the pose-dependent leg
//! directions, about a quarter of the spread of J_C xx and yy and of com z in the default
//! scenario — adds Σ d dᵀ over the six cells. The estimator's residual covariance leaves
//! constant offsets out (they are not noise), so nothing is counted twice.

use estimator::{Estimate, InertialParameters, OnlineEstimator, ParameterCovariance};

/// Change of θ from one sigma `bias_m_s2` of accelerometer bias along P's x, y and z (rows);
/// `None` when no bias figure is known (0).
pub fn accel_bias_effect(estimator: &OnlineEstimator, bias_m_s2: f64) -> Option<[[f64; 10]; 3]> {
    if !(bias_m_s2 > 0.0 && bias_m_s2.is_finite()) {
        return None;
    }
    let d = estimator.accel_bias_sensitivity() * bias_m_s2;
    Some(core::array::from_fn(|axis| {
        core::array::from_fn(|i| d[(i, axis)])
    }))
}

/// Change of θ from one sigma `bias_n` of zero offset on each load cell (rows: legs); `None`
/// without a figure (0) or when the estimator did not accumulate the sensitivity.
pub fn load_cell_bias_effect(estimator: &OnlineEstimator, bias_n: f64) -> Option<[[f64; 10]; 6]> {
    if !(bias_n > 0.0 && bias_n.is_finite() && estimator.config().leg_force_offsets) {
        return None;
    }
    let d = estimator.leg_force_offset_sensitivity() * bias_n;
    Some(core::array::from_fn(|leg| {
        core::array::from_fn(|i| d[(i, leg)])
    }))
}

/// Σ over the sources (accelerometer axes, load cells) of d dᵀ, with d = loaded − tare effect
/// (a missing tare effect counts as zero, which overstates the uncertainty slightly: the tare's
/// share is that of its lighter body).
pub fn bias_covariance(
    loaded_effect: Option<&[[f64; 10]]>,
    tare_effect: Option<&[[f64; 10]]>,
) -> ParameterCovariance {
    let mut c = ParameterCovariance::zeros();
    let Some(loaded) = loaded_effect else {
        return c;
    };
    for (source, effect) in loaded.iter().enumerate() {
        let d = estimator::ParameterVector::from_fn(|i, _| {
            effect[i]
                - tare_effect
                    .and_then(|t| t.get(source))
                    .map_or(0.0, |t| t[i])
        });
        if d.iter().all(|v| v.is_finite()) {
            c += d * d.transpose();
        }
    }
    c
}

/// The payload alone: loaded minus tare, with the covariance of both runs plus `systematic`.
/// Residuals and counts stay those of the loaded run.
pub fn payload_with_systematics(
    loaded: &Estimate,
    tare: &(InertialParameters, ParameterCovariance),
    systematic: &ParameterCovariance,
) -> Estimate {
    let mut e = Estimate::from_parameters(
        loaded.parameters - tare.0,
        loaded.covariance + tare.1 + systematic,
    );
    e.residual_rms = loaded.residual_rms;
    e.counts = loaded.counts;
    e
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn shifts_add_as_outer_products_of_the_payload_share() {
        let mut loaded = [[0.0; 10]; 3];
        let mut tare = [[0.0; 10]; 3];
        loaded[2][0] = 0.2; // a z bias shifts the loaded mass by 0.2 kg ...
        tare[2][0] = 0.05; // ... and the tare's by 0.05 kg: the payload's by 0.15 kg.
        loaded[0][2] = 0.03;
        let c = bias_covariance(Some(&loaded[..]), Some(&tare[..]));
        assert!((c[(0, 0)] - 0.15f64 * 0.15).abs() < 1e-15);
        assert!((c[(2, 2)] - 0.03f64 * 0.03).abs() < 1e-15);
        assert_eq!(c[(0, 2)], 0.0);
        assert_eq!(
            bias_covariance(None, Some(&tare[..])),
            ParameterCovariance::zeros()
        );
        let c = bias_covariance(Some(&loaded[..]), None);
        assert!((c[(0, 0)] - 0.04).abs() < 1e-15);
    }

    #[test]
    fn systematic_variance_reaches_the_mass_sigma() {
        let body = InertialParameters::from_com(
            1900.0,
            Vector3::new(0.1, 0.0, 0.4),
            Matrix3::from_diagonal(&Vector3::new(800.0, 2800.0, 3100.0)),
        );
        let fixture = InertialParameters::from_com(
            400.0,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(240.0, 240.0, 450.0)),
        );
        let stat = ParameterCovariance::identity() * 1e-4;
        let loaded = Estimate::from_parameters(body, stat);
        let mut sys = ParameterCovariance::zeros();
        sys[(0, 0)] = 0.0225;
        let p = payload_with_systematics(&loaded, &(fixture, stat), &sys);
        assert!((p.parameters.mass_kg - 1500.0).abs() < 1e-9);
        assert!((p.mass_sigma_kg - (2e-4f64 + 0.0225).sqrt()).abs() < 1e-12);
    }
}
