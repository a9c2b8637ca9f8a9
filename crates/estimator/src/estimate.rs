//! What the estimator reports: parameters, their covariance, the centre-of-mass form with
//! one-sigma uncertainties, principal moments and axes, consistency, residuals and counts.

use crate::timebase::Timing;
use crate::uncertainty::{derive, principal_sigma, sqrt_nonneg};
use nalgebra::{Matrix3, SMatrix, Vector3, Vector6};
use stewart_types::{
    principal_of, Consistency, InertialParameters, ParameterVector, PARAMETER_COUNT,
};

/// Covariance of θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz].
pub type ParameterCovariance = SMatrix<f64, PARAMETER_COUNT, PARAMETER_COUNT>;

/// Sample counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Samples that reached the least-squares solver.
    pub used: u64,
    /// Accepted samples that only fed the conditioning: the first after a start or a gap, and
    /// those before the time window.
    pub conditioning: u64,
    /// Samples rejected (non-finite, absurd, time not increasing, numerical overflow).
    pub rejected: u64,
    /// Samples after the end of the time window (ignored).
    pub after_window: u64,
    /// Gaps longer than `max_gap_s`, each of which restarted the conditioning.
    pub restarts: u64,
    /// Sample periods without a sample (frames lost), whether bridged or in a gap that
    /// restarted; known from the sequence counter, or from the timestamps without one.
    pub lost: u64,
    /// Lost samples filled in by bridging a short gap (the rest of `lost` fell in restarts).
    pub bridged: u64,
    /// Short gaps bridged.
    pub bridged_gaps: u64,
    /// Residual windows whose scores the covariance counts (a run's first window does not;
    /// with λ < 1 the effective number, rounded down). Below
    /// [`crate::uncertainty::MIN_COVARIANCE_WINDOWS`] the covariance is P from the configured
    /// equation sigmas, a provisional figure, not a measurement.
    pub covariance_windows: u64,
    /// Samples per half-block of the residual windows
    /// ([`crate::EstimatorConfig::covariance_half_block_samples`]).
    pub covariance_half_block_samples: u64,
}

/// Stop rule for a measurement: every reported sigma below its tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConvergenceTolerances {
    /// Largest acceptable one-sigma of the mass, kg.
    pub mass_kg: f64,
    /// Largest acceptable one-sigma of each centre-of-mass coordinate, m.
    pub com_m: f64,
    /// Largest acceptable one-sigma of each entry of J_C, kg·m².
    pub inertia_kg_m2: f64,
}

/// One estimate with its uncertainty. Quantities that need a positive mass (centre of mass,
/// J_C, principal moments and axes, and their sigmas) are NaN while the mass estimate is not
/// positive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// θ about the P origin in P axes.
    pub parameters: InertialParameters,
    /// Covariance of θ.
    pub covariance: ParameterCovariance,
    /// One sigma of each entry of θ.
    pub parameter_sigma: ParameterVector,
    /// One sigma of the mass, kg.
    pub mass_sigma_kg: f64,
    /// Centre of mass in P, m.
    pub com_m: Vector3<f64>,
    /// One sigma of each coordinate of the centre of mass, m.
    pub com_sigma_m: Vector3<f64>,
    /// Inertia tensor about the centre of mass, P axes, kg·m².
    pub inertia_com_kg_m2: Matrix3<f64>,
    /// One sigma of each entry of J_C, kg·m².
    pub inertia_com_sigma_kg_m2: Matrix3<f64>,
    /// Principal moments of J_C, ascending, kg·m².
    pub principal_moments_kg_m2: Vector3<f64>,
    /// One sigma of each principal moment, kg·m².
    pub principal_moments_sigma_kg_m2: Vector3<f64>,
    /// Principal axes (columns, right-handed, same order as the moments).
    pub principal_axes: Matrix3<f64>,
    /// One sigma of the direction of each principal axis, rad (infinite for a repeated moment).
    pub principal_axes_sigma_rad: Vector3<f64>,
    /// Physical-consistency verdict.
    pub consistency: Consistency,
    /// Root-mean-square residual of each equation [Fx, Fy, Fz (N), τx, τy, τz (N·m)] with the
    /// current estimate (exponentially weighted by λ); the best detector of timing and model
    /// errors.
    pub residual_rms: Vector6<f64>,
    /// Sample counters.
    pub counts: Counts,
    /// The time base's measurements: timestamp jitter, rate error, period in use.
    pub timing: Timing,
    /// Degrees of freedom of each reported quantity's variance as the residual windows gave
    /// them ([`crate::dof`]), [m, c_x, c_y, c_z, J_C xx, yy, zz, xy, xz, yz]; `None` where
    /// none are measured (too few windows, or a quantity the model does not estimate). A
    /// payload's ([`Self::without_tare`]) are the loaded run's.
    pub degrees_of_freedom: [Option<f64>; PARAMETER_COUNT],
}

impl Estimate {
    /// All derived fields from θ and its covariance; residuals zero and counts empty.
    pub fn from_parameters(
        parameters: InertialParameters,
        covariance: ParameterCovariance,
    ) -> Self {
        let theta = parameters.to_vector();
        let covariance = (covariance + covariance.transpose()) * 0.5;
        let parameter_sigma = covariance.diagonal().map(sqrt_nonneg);
        let [mass_sigma_kg, ..]: [f64; PARAMETER_COUNT] = parameter_sigma.into();
        let nan3 = Vector3::from_element(f64::NAN);
        let nan33 = Matrix3::from_element(f64::NAN);
        let mut e = Estimate {
            parameters,
            covariance,
            parameter_sigma,
            mass_sigma_kg,
            com_m: nan3,
            com_sigma_m: nan3,
            inertia_com_kg_m2: nan33,
            inertia_com_sigma_kg_m2: nan33,
            principal_moments_kg_m2: nan3,
            principal_moments_sigma_kg_m2: nan3,
            principal_axes: nan33,
            principal_axes_sigma_rad: nan3,
            consistency: parameters.consistency(),
            residual_rms: Vector6::zeros(),
            counts: Counts::default(),
            timing: Timing::default(),
            degrees_of_freedom: [None; PARAMETER_COUNT],
        };
        if let Some(d) = derive(&theta, &covariance) {
            e.com_m = d.com_m;
            e.com_sigma_m = d.com_sigma_m;
            e.inertia_com_kg_m2 = d.inertia_com_kg_m2;
            e.inertia_com_sigma_kg_m2 = d.inertia_com_sigma_kg_m2;
            if let Some(p) = principal_of(&d.inertia_com_kg_m2) {
                let jc_cov: SMatrix<f64, 6, 6> = d.covariance.fixed_view::<6, 6>(4, 4).into_owned();
                let (ms, axs) = principal_sigma(&p, &jc_cov);
                e.principal_moments_kg_m2 = p.moments_kg_m2;
                e.principal_moments_sigma_kg_m2 = ms;
                e.principal_axes = p.axes;
                e.principal_axes_sigma_rad = axs;
            }
        }
        e
    }

    /// Mass estimate, kg.
    pub fn mass_kg(&self) -> f64 {
        self.parameters.mass_kg
    }

    /// The payload alone: this (loaded) estimate minus a tare measured with the empty fixture,
    /// both about the P origin. The tare's covariance adds (independent measurements).
    /// Residuals and counts stay those of the loaded run.
    pub fn without_tare(
        &self,
        tare: &InertialParameters,
        tare_covariance: &ParameterCovariance,
    ) -> Estimate {
        let mut e =
            Estimate::from_parameters(self.parameters - *tare, self.covariance + tare_covariance);
        e.residual_rms = self.residual_rms;
        e.counts = self.counts;
        e.degrees_of_freedom = self.degrees_of_freedom;
        e
    }

    /// True when every sigma is finite and below its tolerance (and the mass is positive, so
    /// that the centre-of-mass quantities exist).
    pub fn converged(&self, tolerances: &ConvergenceTolerances) -> bool {
        let below = |v: f64, tol: f64| v.is_finite() && v <= tol;
        below(self.mass_sigma_kg, tolerances.mass_kg)
            && self.com_sigma_m.iter().all(|v| below(*v, tolerances.com_m))
            && self
                .inertia_com_sigma_kg_m2
                .iter()
                .all(|v| below(*v, tolerances.inertia_kg_m2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_fields_and_convergence() {
        let p = InertialParameters::from_com(
            2.0,
            Vector3::new(0.1, 0.0, 0.3),
            Matrix3::from_diagonal(&Vector3::new(1.0, 2.0, 2.5)),
        );
        let cov = ParameterCovariance::identity() * 1e-6;
        let e = Estimate::from_parameters(p, cov);
        assert!((e.com_m - Vector3::new(0.1, 0.0, 0.3)).norm() < 1e-15);
        assert!((e.principal_moments_kg_m2 - Vector3::new(1.0, 2.0, 2.5)).norm() < 1e-12);
        assert!((e.mass_sigma_kg - 1e-3).abs() < 1e-15);
        // σ(cx)² = σ(hx)²/m² + (hx/m²)² σ(m)² with hx = 0.2.
        let expect = libm::sqrt(1e-6 / 4.0 + (0.2f64 / 4.0).powi(2) * 1e-6);
        assert!((e.com_sigma_m.x - expect).abs() < 1e-15);
        let loose = ConvergenceTolerances {
            mass_kg: 1e-2,
            com_m: 1e-2,
            inertia_kg_m2: 1e-2,
        };
        let tight = ConvergenceTolerances {
            mass_kg: 1e-4,
            ..loose
        };
        assert!(e.converged(&loose));
        assert!(!e.converged(&tight));
        // A broken covariance never passes for a converged one.
        let mut broken = cov;
        broken[(0, 0)] = f64::NAN;
        assert!(!Estimate::from_parameters(p, broken).converged(&loose));
        // A non-positive mass has no centre of mass and never converges.
        let z = Estimate::from_parameters(InertialParameters::zero(), cov);
        assert!(z.com_m.x.is_nan() && !z.converged(&loose));
    }
}
