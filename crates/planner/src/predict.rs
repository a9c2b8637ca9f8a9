//! The covariance that the sensors' white noise will give the estimate on a planned motion,
//! before anything moves.
//!
//! The estimator solves weighted least squares on conditioned equations, `y = Φθ + e`
//! ([`estimator::conditioning`]: the same stencil and low-pass on every channel, a derivative
//! stencil for ω̇). To first order each raw noise sample nₛ of a channel enters the equation
//! error at output t as `cₜ hₜ₋ₛ nₛ`, with h the channel's conditioning impulse response and
//! cₜ its sensitivity: a leg force's noise the leg's column of the leg-force → wrench map G,
//! the accelerometer's `∂(Φθ)/∂f`, the gyro's `∂(Φθ)/∂ω̇` through the derivative stencil and
//! `∂(Φθ)/∂(ωᵢωⱼ)` through the value stencil, and, because the estimator measures the gyro's
//! error against the kinematics and takes it out at the run's two ends
//! ([`estimator::gyro_error::ends`]), ∓`∂(Φθ)/∂ω̇`/Δt through the value stencil at the last and first
//! sample (what is left of the derivative's noise is then the run's middle, Σ φ̇ ψ(n)θ:
//! predicted c_x at 2 s with gyro noise alone 7e-7 m instead of 1.6e-5). The score is then
//!
//! ```text
//! Σₜ Φₜᵀ W eₜ = Σₛ nₛ vₛ,   vₛ = Σⱼ hⱼ uₛ₊ⱼ,   uₜ = Φₜᵀ W cₜ
//! ```
//!
//! so that `Cov θ̂ = A⁻¹ (Σ_channels σ² Σₛ vₛ vₛᵀ) A⁻¹`, A = Σ Φᵀ W Φ — the sandwich the
//! estimator's residual windows measure ([`estimator::score`]), here predicted from the
//! datasheet. v is u run backwards through the conditioning (a causal filter on the reversed
//! sequence correlates with h), so the cost is linear in the samples. The accelerometer's lever
//! arm enters ω̇'s sensitivity (f_O = f_r − ω̇ × r − ω × (ω × r)); its centripetal part, second
//! order in ω, is left out, as are the gyro bias and quantisation (constant, or far below the
//! noise at the default datasheet).
//!
//! The accelerometer's vertical offset, measured as the mean reading at rest before the
//! excitation, carries that mean's noise δ into every sample alike: a constant channel, whose
//! score Σₜ uₜ δ passes the conditioning unchanged (the stencil's value weights and the
//! low-pass both have unit gain at zero frequency), adding `A⁻¹ (σ_δ² s sᵀ) A⁻¹` with
//! s = Σₜ Φₜᵀ W ∂(Φθ)/∂f_z (P's z: the vertical of a plate that tilts a degree or two). Near
//! rest f ≈ g, so δ moves the mass by m δ/g.
//!
//! When the estimator fits the load cells' zero drift ([`estimator::drift`]), its θ is
//! θ̂ − P S_r r̂, with r̂ the six rates fitted jointly with θ and the equations' constant
//! offsets. r̂ is linear in the weighted measurements, r̂ = G⁻¹ Σₜ zₜᵀ yₜ with
//!
//! ```text
//! zₜ = Ψₜ − Φₜ P S_r − (𝟙 − Φₜ P S) F_cc⁺ F_cr        (weighted rows, Ψₜ = W^½ Lₜ (t − t₀))
//! ```
//!
//! (Ψₜ the drift's rows of the conditioned leg map L, S = Σ Φₜᵀ, S_r = Σ Φₜᵀ Ψₜ, F and G the
//! drift's normal equations as [`estimator::drift`] writes them), so θ's error is
//! P Σₜ (Φₜᵀ − S_r G⁻¹ zₜᵀ) W^½ eₜ: the same sandwich with each sample's Φₜᵀ W replaced by
//! (Φₜᵀ − S_r G⁻¹ zₜᵀ) W^½, which carries the rates' price into every channel's score. The leg
//! map is taken unfiltered (it follows the pose, far slower than the cut-off), and the gyro's
//! ends, which the estimator keeps out of the offsets, are left out of zₜ.

use estimator::conditioning::stencil_weights;
use estimator::filter::{Biquad, LowPass};
use estimator::regressor::{from_signals, RegressorSignals};
use estimator::ParameterVector;
use kinematics::Geometry;
use nalgebra::{SMatrix, SVector, Vector3, Vector6};

use super::motion::{leg_map, MotionPoint};

/// One sample's white noise of each channel, one sigma.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelNoise {
    /// Each load cell, N.
    pub load_cell_n: f64,
    /// Each gyro axis, rad/s.
    pub gyro_rad_s: f64,
    /// Each accelerometer axis, m/s².
    pub accel_m_s2: f64,
    /// The accelerometer's offset along gravity as the rest before the excitation measures it,
    /// m/s² ([`estimator::AccelerometerOffset`]): the mean vertical reading less gravity,
    /// subtracted from every later sample, so its noise (the per-sample noise over √(the
    /// samples at rest)) is one constant error over the whole run. 0 when the offset is not
    /// measured.
    pub accel_offset_m_s2: f64,
}

/// What the estimator does with the samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conditioning {
    /// Sample period, s.
    pub period_s: f64,
    /// Low-pass cut-off, Hz.
    pub cutoff_hz: f64,
    /// Each equation's one sigma [F; τ] (the rows' weights are its inverse squares).
    pub equation_sigma: Vector6<f64>,
    /// Accelerometer position in P, m.
    pub lever_m: Vector3<f64>,
    /// The estimator's residual half-block for a long excitation, samples (a short one's is
    /// shortened alike: [`measure::quality::half_block_samples_for`]).
    pub block_samples: u32,
    /// Whether the estimator fits the load cells' zero drift
    /// ([`estimator::EstimatorConfig::load_cell_drift`]), whose rates the prediction then
    /// pays for (the [module docs](self)).
    pub load_cell_drift: bool,
}

type Cov = SMatrix<f64, 10, 10>;

/// The predicted covariance of θ̂ when the estimator sees `points` of a body `theta` with the
/// channels' `noise` (see the [module docs](self)); `None` when the motion does not determine
/// all ten parameters or the conditioning is invalid.
pub fn covariance(
    points: &[MotionPoint],
    theta: &ParameterVector,
    geometry: &Geometry,
    conditioning: &Conditioning,
    noise: &ChannelNoise,
) -> Option<Cov> {
    let biquad = Biquad::butterworth(conditioning.cutoff_hz, conditioning.period_s).ok()?;
    let (value, slope) = stencil_weights(conditioning.period_s);
    let w = weights(conditioning);
    let phis: Vec<_> = points.iter().map(|p| p.regressor()).collect();
    let mut a = Cov::zeros();
    for phi in &phis {
        a += phi.transpose() * w * phi;
    }
    if !determined(&a) {
        return None;
    }
    let a_inv = a.try_inverse()?;
    let maps: Vec<_> = points.iter().map(|p| leg_map(geometry, p.pose())).collect();
    // Each sample's map from its equations' errors to the score: Φᵀ W, or with the drift
    // fitted (Φᵀ − S_r G⁻¹ zᵀ) W^½ (the module docs).
    let (scores, end_fix) = if conditioning.load_cell_drift {
        drift_scores(points, &phis, &maps, &w, &a_inv)?
    } else {
        let scores: Vec<Score> = phis.iter().map(|phi| phi.transpose() * w).collect();
        (scores, Score::zeros())
    };
    let sens = |s: RegressorSignals| -> Vector6<f64> { from_signals(&s) * theta };
    let r = conditioning.lever_m;
    let mut b = Cov::zeros();
    let mut channel = |variance: f64,
                       value_u: &dyn Fn(usize) -> SVector<f64, 10>,
                       slope_c: Option<Vector6<f64>>| {
        if variance > 0.0 {
            b += correlated_scores(&scores, &value, &slope, biquad, value_u, slope_c) * variance;
        }
    };
    for leg in 0..6 {
        channel(
            noise.load_cell_n.powi(2),
            &|t| scores[t] * maps[t].column(leg),
            None,
        );
    }
    for k in 0..3 {
        let e = Vector3::ith(k, 1.0);
        let ga = sens(RegressorSignals {
            specific_force_m_s2: e,
            ..RegressorSignals::default()
        });
        channel(noise.accel_m_s2.powi(2), &|t| scores[t] * ga, None);
        let gw = sens(RegressorSignals::angular_acceleration_error(&e, &r));
        // The estimator takes the gyro's error at the run's two ends out of its estimate
        // ([`estimator::gyro_error::ends`]): −[Φᵀ ψ(n̂)θ]/Δt, n̂ the noise through the value stencil
        // and the low-pass, i.e. ∓ψ(unit)θ/Δt on the value path at the last and first sample.
        // The drift's rates see the ends through the offsets' equations only (`end_fix`).
        let last = points.len().saturating_sub(1);
        let end = gw / conditioning.period_s;
        let products = |t: usize| -> SVector<f64, 10> {
            let w = points[t].plate.angular_velocity_rad_s;
            let c = sens(RegressorSignals {
                rate_products_rad2_s2: product_gradient(&w, k),
                ..RegressorSignals::default()
            });
            match t {
                0 if last > 0 => scores[t] * (c + end),
                t if t == last && last > 0 => scores[t] * (c - end) - end_fix * end,
                _ => scores[t] * c,
            }
        };
        channel(noise.gyro_rad_s.powi(2), &products, Some(gw));
    }
    if noise.accel_offset_m_s2 > 0.0 {
        let vertical = sens(RegressorSignals {
            specific_force_m_s2: Vector3::z(),
            ..RegressorSignals::default()
        });
        let score: SVector<f64, 10> = scores.iter().map(|s| s * vertical).sum();
        b += score * score.transpose() * noise.accel_offset_m_s2.powi(2);
    }
    let cov = a_inv * b * a_inv;
    cov.iter().all(|v| v.is_finite()).then_some(cov)
}

/// The degrees of freedom the estimator's residual windows will give each reported quantity
/// of a run on `points` with the body `theta` on the plate (mass, c, J_C's entries: the run's
/// own, as the estimator takes them): each half-block's information Σ w Φᵀ W Φ under the
/// rising and the falling window ([`estimator::window`]), window k the rising half of
/// half-block k and the falling half of k + 1, the run's first window and its unfinished
/// last half-block left out, through [`estimator::dof::HalfBlockInformation`] along w = A⁻¹ cⱼ,
/// with the score covariances the estimator gives it. `None` when the run does not determine
/// θ or gives no counted window.
pub fn degrees_of_freedom(
    points: &[MotionPoint],
    theta: &ParameterVector,
    conditioning: &Conditioning,
) -> Option<[f64; 10]> {
    let w = weights(conditioning);
    let excitation_s = points.len() as f64 * conditioning.period_s;
    let block = measure::quality::half_block_samples_for(
        conditioning.block_samples,
        excitation_s,
        conditioning.period_s,
    )
    .max(1);
    let kappa = estimator::window::mean_to_square(block);
    let shared_share = estimator::window::shared_share(block);
    let mut information = estimator::dof::HalfBlockInformation::<10>::new();
    let mut total = Cov::zeros();
    // The last finished half-block's rising and combined information.
    let mut previous: Option<(Cov, Cov)> = None;
    for (k, chunk) in points.chunks_exact(block as usize).enumerate() {
        let (mut rising, mut falling) = (Cov::zeros(), Cov::zeros());
        for (t, p) in chunk.iter().enumerate() {
            let phi = p.regressor();
            let a = phi.transpose() * w * phi;
            let (rise, fall) = estimator::window::weights(t as u32, block);
            rising += a * rise;
            falling += a * fall;
            total += a;
        }
        if let (Some(shares), Some((pending, both))) =
            (estimator::window::closing(k as u64), &previous)
        {
            let shared = shares.then(|| both * shared_share);
            information.add(&((pending + falling) / kappa), shared.as_ref(), 1.0);
        }
        previous = Some((rising, rising + falling));
    }
    if !determined(&total) {
        return None;
    }
    let p = total.try_inverse()?;
    let gradients = estimator::uncertainty::derived_jacobian(theta);
    let mut nu = [f64::NAN; 10];
    for (n, row) in nu.iter_mut().zip(gradients.row_iter()) {
        *n = information.degrees_of_freedom(&(p * row.transpose()))?;
    }
    Some(nu)
}

/// W, the rows' weights: each equation's inverse squared sigma (0 for a sigma of 0).
fn weights(conditioning: &Conditioning) -> SMatrix<f64, 6, 6> {
    SMatrix::from_diagonal(&conditioning.equation_sigma.map(|s| {
        if s > 0.0 {
            1.0 / (s * s)
        } else {
            0.0
        }
    }))
}

/// Smallest eigenvalue of A scaled to a unit diagonal, D^-½ A D^-½, below which the samples do
/// not determine θ (the motion so far leaves a combination of parameters unseen).
const MIN_SCALED_EIGENVALUE: f64 = 1e-12;

/// True when the information A = Σ Φᵀ W Φ determines all ten parameters: every diagonal entry
/// positive and the smallest eigenvalue of D^-½ A D^-½ (D = diag A, a unit-free measure) at
/// least [`MIN_SCALED_EIGENVALUE`]. A singular A's inverse in floating point is not a
/// prediction.
fn determined(a: &Cov) -> bool {
    let d = a.diagonal();
    if !d.iter().all(|v| *v > 0.0 && v.is_finite()) {
        return false;
    }
    let s = Cov::from_diagonal(&d.map(|v| 1.0 / v.sqrt()));
    (s * a * s).symmetric_eigenvalues().min() >= MIN_SCALED_EIGENVALUE
}

/// ∂[ωx², ωy², ωz², ωxωy, ωxωz, ωyωz]/∂ω_k.
fn product_gradient(w: &Vector3<f64>, k: usize) -> Vector6<f64> {
    match k {
        0 => Vector6::new(2.0 * w.x, 0.0, 0.0, w.y, w.z, 0.0),
        1 => Vector6::new(0.0, 2.0 * w.y, 0.0, w.x, 0.0, w.z),
        _ => Vector6::new(0.0, 0.0, 2.0 * w.z, 0.0, w.x, w.y),
    }
}

/// One sample's map from its six equations' errors to θ's score (10×6).
type Score = SMatrix<f64, 10, 6>;

/// Each sample's score map with the load cells' drift fitted, (Φₜᵀ − S_r G⁻¹ zₜᵀ) W^½ (the
/// [module docs](self)), and the share S_r G⁻¹ Ψᵀ W^½ of the last sample's drift rows that the
/// gyro's end term does not meet (the estimator adds the ends to the offsets' right-hand side
/// only, not to the rates'); `None` when a sum is not finite.
fn drift_scores(
    points: &[MotionPoint],
    phis: &[SMatrix<f64, 6, 10>],
    maps: &[nalgebra::Matrix6<f64>],
    w: &SMatrix<f64, 6, 6>,
    p: &Cov,
) -> Option<(Vec<Score>, Score)> {
    let half = w.map(f64::sqrt);
    let start = points.first().map_or(0.0, |p| p.time_s);
    let rows: Vec<SMatrix<f64, 6, 10>> = phis.iter().map(|phi| half * phi).collect();
    let psis: Vec<SMatrix<f64, 6, 6>> = points
        .iter()
        .zip(maps)
        .map(|(point, map)| half * map * (point.time_s - start))
        .collect();
    let mut s = SMatrix::<f64, 10, 6>::zeros();
    let mut sr = SMatrix::<f64, 10, 6>::zeros();
    let mut psi_sum = SMatrix::<f64, 6, 6>::zeros();
    let mut psi_psi = SMatrix::<f64, 6, 6>::zeros();
    for (phi, psi) in rows.iter().zip(&psis) {
        s += phi.transpose();
        sr += phi.tr_mul(psi);
        psi_sum += psi;
        psi_psi += psi.tr_mul(psi);
    }
    let n = rows.len() as f64;
    let ps = p * s;
    let f_cc = SMatrix::<f64, 6, 6>::identity() * n - s.tr_mul(&ps);
    let f_cr = psi_sum - ps.tr_mul(&sr);
    let f_rr = psi_psi - sr.tr_mul(&(p * sr));
    let f_cc_pinv = pseudo_inverse(&f_cc, 1e-9 * n);
    let g = f_rr - f_cr.tr_mul(&(f_cc_pinv * f_cr));
    let largest = g.symmetric_eigenvalues().max();
    if !(largest.is_finite() && largest > 0.0) {
        return None;
    }
    let g_inv = pseudo_inverse(&g, 1e-9 * largest);
    let offsets = f_cc_pinv * f_cr;
    let (p_s, p_sr) = (ps, p * sr);
    let gain = sr * g_inv;
    let scores: Vec<Score> = rows
        .iter()
        .zip(&psis)
        .map(|(phi, psi)| {
            let z = psi - phi * p_sr - (SMatrix::<f64, 6, 6>::identity() - phi * p_s) * offsets;
            (phi.transpose() - gain * z.transpose()) * half
        })
        .collect();
    let end_fix = psis
        .last()
        .map_or(Score::zeros(), |psi| gain * psi.transpose() * half);
    (scores
        .iter()
        .chain(core::iter::once(&end_fix))
        .all(|m| m.iter().all(|v| v.is_finite())))
    .then_some((scores, end_fix))
}

/// The pseudo-inverse of a symmetric matrix on its eigenvalues above `floor`: directions
/// below it are left undetermined (zero), as [`estimator::drift`] leaves them.
fn pseudo_inverse(m: &SMatrix<f64, 6, 6>, floor: f64) -> SMatrix<f64, 6, 6> {
    let eigen = ((m + m.transpose()) * 0.5).symmetric_eigen();
    let mut inverse = SMatrix::<f64, 6, 6>::zeros();
    for (value, v) in eigen
        .eigenvalues
        .iter()
        .zip(eigen.eigenvectors.column_iter())
    {
        if *value > floor {
            inverse += v * v.transpose() / *value;
        }
    }
    inverse
}

/// Σₛ vₛ vₛᵀ for one channel of unit variance whose sensitivity is `value_c(t)` through the
/// value stencil plus the constant `slope_c` through the derivative stencil, both then
/// through the low-pass: the channel's u run backwards through the conditioning. `scores`:
/// each sample's map from its equations' errors to θ's score; `value_u(t)`: the value path's
/// share of uₜ (the score map times the sensitivity).
fn correlated_scores(
    scores: &[Score],
    value: &[f64; 4],
    slope: &[f64; 4],
    biquad: Biquad,
    value_u: &dyn Fn(usize) -> SVector<f64, 10>,
    slope_c: Option<Vector6<f64>>,
) -> Cov {
    let mut filter = LowPass::<10>::new(biquad);
    filter.reset_to(&SVector::zeros());
    // The stencil's newest tap meets the newest input; backwards, the "newest" is the earliest.
    let mut held_value = [SVector::<f64, 10>::zeros(); 4];
    let mut held_slope = [SVector::<f64, 10>::zeros(); 4];
    let mut sum = Cov::zeros();
    for t in (0..scores.len()).rev() {
        let pt = scores[t];
        held_value.rotate_left(1);
        held_value[3] = value_u(t);
        let mut x: SVector<f64, 10> = (0..4).map(|j| held_value[j] * value[j]).sum();
        if let Some(c) = slope_c {
            held_slope.rotate_left(1);
            held_slope[3] = pt * c;
            x += (0..4)
                .map(|j| held_slope[j] * slope[j])
                .sum::<SVector<f64, 10>>();
        }
        let v = filter.step(&x);
        sum += v * v.transpose();
    }
    sum
}
