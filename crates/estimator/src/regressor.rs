//! The rigid-body regressor: Newton–Euler equations of the moving body, about the P origin in
//! P axes, written as `wrench = Φ θ` with θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz].
//!
//! ```text
//! F_legs   = m f + ω̇ × h + ω × (ω × h)
//! τ_legs,O = J_O ω̇ + ω × (J_O ω) + h × f
//! ```
//! with f = a_O − g the specific force of the P origin, and ω, ω̇ in P axes. Both sides are
//! linear in the twelve signals (ω̇, the six products ωᵢωⱼ, f) — ω itself never appears alone.
//! Conditioning filters exactly those twelve signals (see [`crate::conditioning`]), so that a
//! filtered wrench still equals the regressor of the filtered signals times θ.

use nalgebra::{SMatrix, Vector3, Vector6};
use stewart_types::PARAMETER_COUNT;

/// 6×10 regressor: rows are Fx, Fy, Fz (N) and τx, τy, τz about the P origin (N·m).
pub type Regressor = SMatrix<f64, 6, PARAMETER_COUNT>;

/// 3×6 torque regressor of the six-parameter form (tensor about the centre of mass).
pub type TorqueRegressor = SMatrix<f64, 3, 6>;

/// The signals the regressor is linear in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RegressorSignals {
    /// ω̇ in P, rad/s².
    pub angular_acceleration_rad_s2: Vector3<f64>,
    /// The products [ωx², ωy², ωz², ωxωy, ωxωz, ωyωz] (entries of ω ωᵀ), rad²/s².
    pub rate_products_rad2_s2: Vector6<f64>,
    /// Specific force a − g of the P origin in P, m/s².
    pub specific_force_m_s2: Vector3<f64>,
}

/// The six distinct entries of ω ωᵀ in tensor order [xx, yy, zz, xy, xz, yz].
pub fn rate_products(omega_rad_s: &Vector3<f64>) -> Vector6<f64> {
    let w = omega_rad_s;
    Vector6::new(
        w.x * w.x,
        w.y * w.y,
        w.z * w.z,
        w.x * w.y,
        w.x * w.z,
        w.y * w.z,
    )
}

impl RegressorSignals {
    /// Signals from ω, ω̇ and the specific force at the P origin.
    pub fn new(
        omega_rad_s: &Vector3<f64>,
        angular_acceleration_rad_s2: &Vector3<f64>,
        specific_force_m_s2: &Vector3<f64>,
    ) -> Self {
        Self {
            angular_acceleration_rad_s2: *angular_acceleration_rad_s2,
            rate_products_rad2_s2: rate_products(omega_rad_s),
            specific_force_m_s2: *specific_force_m_s2,
        }
    }

    /// The signals an error v of ω̇ alone carries: ω̇ = v, and through the accelerometer's
    /// lever arm r the specific force at the P origin f_O = f_r − ω̇ × r gains −v × r. Its
    /// regressor is ψ(v), the rows' part linear in ω̇ (the gyro's derivative noise in the
    /// noise moment, its measured error in [`crate::gyro_error::ends`] and [`crate::gyro_error::integral`]).
    pub fn angular_acceleration_error(v: &Vector3<f64>, lever_m: &Vector3<f64>) -> Self {
        Self {
            angular_acceleration_rad_s2: *v,
            rate_products_rad2_s2: Vector6::zeros(),
            specific_force_m_s2: -v.cross(lever_m),
        }
    }

    /// ω × (ω × r) = (ω ωᵀ − ‖ω‖²𝟙) r, written with the products so it stays linear in them.
    pub fn centripetal(&self, r: &Vector3<f64>) -> Vector3<f64> {
        let [xx, yy, zz, xy, xz, yz]: [f64; 6] = self.rate_products_rad2_s2.into();
        Vector3::new(
            -(yy + zz) * r.x + xy * r.y + xz * r.z,
            xy * r.x - (xx + zz) * r.y + yz * r.z,
            xz * r.x + yz * r.y - (xx + yy) * r.z,
        )
    }

    /// True when every signal is finite.
    pub fn is_finite(&self) -> bool {
        self.angular_acceleration_rad_s2
            .iter()
            .all(|v| v.is_finite())
            && self.rate_products_rad2_s2.iter().all(|v| v.is_finite())
            && self.specific_force_m_s2.iter().all(|v| v.is_finite())
    }
}

/// Torque rows of J ω̇ + ω × (J ω) for the six tensor entries [Jxx, Jyy, Jzz, Jxy, Jxz, Jyz]
/// (tensor entries: Jxy = −∫xy dm). With the paper's products of inertia (Ixy = −Jxy) the
/// columns of Jxy, Jxz, Jyz change sign, which gives the paper's Eq. 14 (in the products of
/// inertia Ixy = ∫xy dm) as derived from τ = J ω̇ + ω × (J ω).
pub fn inertia_columns(s: &RegressorSignals) -> TorqueRegressor {
    let a = &s.angular_acceleration_rad_s2;
    let [xx, yy, zz, xy, xz, yz]: [f64; 6] = s.rate_products_rad2_s2.into();
    #[rustfmt::skip]
    let m = TorqueRegressor::new(
        a.x, -yz,  yz,  a.y - xz, a.z + xy, yy - zz,
        xz,  a.y, -xz,  a.x + yz, zz - xx,  a.z - xy,
        -xy, xy,   a.z, xx - yy,  a.x - yz, a.y + xz,
    );
    m
}

/// The full 6×10 regressor from the twelve signals.
pub fn from_signals(s: &RegressorSignals) -> Regressor {
    let a = &s.angular_acceleration_rad_s2;
    let f = &s.specific_force_m_s2;
    let [xx, yy, zz, xy, xz, yz]: [f64; 6] = s.rate_products_rad2_s2.into();
    let mut phi = Regressor::zeros();
    // Force rows: m f + ([ω̇]× + ω ωᵀ − ‖ω‖²𝟙) h.
    #[rustfmt::skip]
    let force_h = nalgebra::Matrix3::new(
        -(yy + zz), xy - a.z,   xz + a.y,
        xy + a.z,  -(xx + zz),  yz - a.x,
        xz - a.y,   yz + a.x,  -(xx + yy),
    );
    // Torque rows: h × f = −[f]× h.
    #[rustfmt::skip]
    let torque_h = nalgebra::Matrix3::new(
        0.0,   f.z, -f.y,
        -f.z,  0.0,  f.x,
        f.y,  -f.x,  0.0,
    );
    phi.fixed_view_mut::<3, 1>(0, 0).copy_from(f);
    phi.fixed_view_mut::<3, 3>(0, 1).copy_from(&force_h);
    phi.fixed_view_mut::<3, 3>(3, 1).copy_from(&torque_h);
    phi.fixed_view_mut::<3, 6>(3, 4)
        .copy_from(&inertia_columns(s));
    phi
}

/// The 6×10 rigid-body regressor Φ(ω, ω̇, f) with [F; τ_O] = Φ θ.
pub fn rigid_body(
    omega_rad_s: &Vector3<f64>,
    angular_acceleration_rad_s2: &Vector3<f64>,
    specific_force_m_s2: &Vector3<f64>,
) -> Regressor {
    from_signals(&RegressorSignals::new(
        omega_rad_s,
        angular_acceleration_rad_s2,
        specific_force_m_s2,
    ))
}

/// The paper's six-parameter form (Eq. 14, derived from the equation below):
/// τ_C = J_C ω̇ + ω × (J_C ω) about the centre of mass, for [Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] as tensor entries.
pub fn torque_about_com(
    omega_rad_s: &Vector3<f64>,
    angular_acceleration_rad_s2: &Vector3<f64>,
) -> TorqueRegressor {
    inertia_columns(&RegressorSignals::new(
        omega_rad_s,
        angular_acceleration_rad_s2,
        &Vector3::zeros(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testkit::{random_body, Motion};
    use nalgebra::Matrix3;
    use rand::{rngs::StdRng, Rng, SeedableRng};
    use stewart_types::InertialParameters;

    fn random_vec(rng: &mut StdRng, scale: f64) -> Vector3<f64> {
        Vector3::new(
            rng.random_range(-scale..scale),
            rng.random_range(-scale..scale),
            rng.random_range(-scale..scale),
        )
    }

    /// Regressor times θ equals the wrench summed over the point masses of an independent
    /// body model, for random states.
    #[test]
    fn matches_point_mass_newton_euler() {
        let mut rng = StdRng::seed_from_u64(7);
        for _ in 0..200 {
            let body = random_body(&mut rng);
            let theta = body.parameters().to_vector();
            let w = random_vec(&mut rng, 2.0);
            let wd = random_vec(&mut rng, 5.0);
            let f = random_vec(&mut rng, 12.0);
            let got = rigid_body(&w, &wd, &f) * theta;
            let expect = body.wrench(&w, &wd, &f);
            let scale = 1.0 + expect.norm();
            assert!((got - expect).norm() < 1e-12 * scale, "{got} vs {expect}");
        }
    }

    /// Torque rows against finite differences of angular momentum. About the centre of mass
    /// (here the P origin, h = 0) τ = dL/dt with L = R J_C ω in space, so a fourth-order
    /// difference of L along a large-angle tumble must equal R·(Φ_τ θ); the six-parameter form
    /// must give the same torque.
    #[test]
    fn torque_rows_match_the_rate_of_change_of_angular_momentum() {
        let jc = Matrix3::new(2.0, -0.3, 0.1, -0.3, 3.0, 0.25, 0.1, 0.25, 4.5);
        let theta = InertialParameters::from_com(1.0, Vector3::zeros(), jc).to_vector();
        let motion = Motion::tumbling();
        let h = 1e-3;
        let l = |t: f64| {
            let s = motion.state(t);
            s.rotation * (jc * s.omega)
        };
        let mut worst: f64 = 0.0;
        let mut scale: f64 = 0.0;
        for k in 0..400 {
            let t = 0.0123 * k as f64;
            let dl =
                (l(t - 2.0 * h) - 8.0 * l(t - h) + 8.0 * l(t + h) - l(t + 2.0 * h)) / (12.0 * h);
            let s = motion.state(t);
            let tau = rigid_body(&s.omega, &s.omega_dot, &s.specific_force) * theta;
            let tau = s.rotation * Vector3::new(tau[3], tau[4], tau[5]);
            worst = worst.max((tau - dl).norm());
            scale = scale.max(dl.norm());
            let j6 = nalgebra::Vector6::new(
                jc[(0, 0)],
                jc[(1, 1)],
                jc[(2, 2)],
                jc[(0, 1)],
                jc[(0, 2)],
                jc[(1, 2)],
            );
            let paper = s.rotation * (torque_about_com(&s.omega, &s.omega_dot) * j6);
            assert!((paper - tau).norm() < 1e-12 * (1.0 + tau.norm()));
        }
        assert!(scale > 10.0, "motion too gentle to test: {scale}");
        assert!(worst < 1e-8 * scale, "worst {worst} of {scale}");
    }

    /// The paper's Eq. 14 in the products of inertia Ixy = ∫xy dm, rows derived from
    /// τ_C = J_C ω̇ + ω × (J_C ω), is the same map up to the sign of the product columns.
    #[test]
    fn six_parameter_form_equals_the_papers_eq_14() {
        let mut rng = StdRng::seed_from_u64(3);
        for _ in 0..50 {
            let w = random_vec(&mut rng, 2.0);
            let a = random_vec(&mut rng, 3.0);
            let (x, y, z) = (w.x, w.y, w.z);
            #[rustfmt::skip]
            let paper = TorqueRegressor::new(
                a.x, -y * z, y * z, x * z - a.y, -x * y - a.z, z * z - y * y,
                // Rows 2 and 3 as printed: d/dt of the first matrix minus the second.
                z * x, a.y, -x * z, -a.x - y * z, -(z * z - x * x), -a.z + x * y,
                -x * y, x * y, a.z, -(x * x - y * y), -a.x + y * z, -a.y - z * x,
            );
            // Sign of the product columns flips between Ixy (paper) and Jxy (tensor entry).
            let mut flipped = paper;
            for c in 3..6 {
                for r in 0..3 {
                    flipped[(r, c)] = -flipped[(r, c)];
                }
            }
            let ours = torque_about_com(&w, &a);
            assert!((ours - flipped).norm() < 1e-12, "{ours} vs {flipped}");
        }
    }

    #[test]
    fn centripetal_term_matches_the_cross_products() {
        let mut rng = StdRng::seed_from_u64(11);
        for _ in 0..20 {
            let w = random_vec(&mut rng, 3.0);
            let r = random_vec(&mut rng, 1.0);
            let s = RegressorSignals::new(&w, &Vector3::zeros(), &Vector3::zeros());
            assert!((s.centripetal(&r) - w.cross(&w.cross(&r))).norm() < 1e-13);
        }
    }
}
