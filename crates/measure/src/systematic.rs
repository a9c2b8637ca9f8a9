//! The estimator's exact first-order effects of the accelerometer's bias and of the load
//! cells' zero offsets, for the error budget ([`crate::budget`], which uses them for those two
//! sources in place of its own fit's: they include the estimator's own conditioning).
//!
//! The estimator's covariance covers the noise. A constant accelerometer bias b is not noise:
//! it tilts and scales the measured gravity the fit leans on, shifting the mass by about
//! m·b_z/g and the centre of mass by about c_z·b_xy/g. Unlike a load-cell offset it does not
//! cancel with the tare, because its effect is proportional to the mass on the plate. Its size
//! is a datasheet figure (bias stability), so its effect is a type-B uncertainty: the
//! estimator's first-order sensitivity to a constant bias
//! ([`estimator::OnlineEstimator::accel_bias_sensitivity`], from its accumulated normal-equation
//! terms; it matches three more estimators fed the samples with one sigma of bias added to
//! about 1e-4 of the effect) times one sigma along x, y and z.
//!
//! The load cells' zero offsets are treated alike: a constant offset b of one cell moves θ by
//! [`estimator::OnlineEstimator::leg_force_offset_sensitivity`] · b (exact: it reaches the
//! wrench through each sample's leg directions, which the estimator conditions alongside), with
//! b one datasheet sigma of the cell's zero offset ([`crate::setup::load_cell_bias_sigma`]).
//! Most of it cancels with the tare (the same cells in both runs); the budget counts the rest,
//! loaded − tare ([`crate::budget::combine`]). The estimator's residual covariance leaves
//! constant offsets out (they are not noise), so nothing is counted twice.

use estimator::OnlineEstimator;

/// Change of θ from one sigma of accelerometer bias along P's x, y and z (rows): the
/// datasheet's `bias_m_s2`, except along z where the offset was measured at rest
/// ([`OnlineEstimator::accelerometer_offset`], along gravity: P's z at rest) and that
/// measurement's sigma takes its place; `None` when nothing is known.
pub fn accel_bias_effect(estimator: &OnlineEstimator, bias_m_s2: f64) -> Option<[[f64; 10]; 3]> {
    let datasheet = if bias_m_s2.is_finite() && bias_m_s2 > 0.0 {
        bias_m_s2
    } else {
        0.0
    };
    let sigma_m_s2 = match estimator.accelerometer_offset() {
        Some(o) => [datasheet, datasheet, o.sigma_m_s2],
        None if datasheet > 0.0 => [datasheet; 3],
        None => return None,
    };
    let d = estimator.accel_bias_sensitivity();
    Some(core::array::from_fn(|axis| {
        core::array::from_fn(|i| d[(i, axis)] * sigma_m_s2[axis])
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
