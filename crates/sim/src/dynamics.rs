//! Rigid-body Newton–Euler equations about the P origin, in P axes.
//!
//! With `f = a_O − g` the specific force of the P origin and `ω`, `ω̇` the plate's angular rate
//! and acceleration (all in P), the wrench the legs apply about the P origin is (Newton–Euler
//! about a point that is not the centre of mass, so force and torque are coupled through h):
//!
//! ```text
//! F   = m f + ω̇ × h + ω × (ω × h)
//! τ_O = J_O ω̇ + ω × (J_O ω) + h × f
//! ```
//!
//! That is `W = M [f; ω̇] + b(ω)` with the constant spatial inertia
//! `M = [[m𝟙, −[h]×], [[h]×, J_O]]` (symmetric positive definite for a physical body) and the
//! velocity terms `b = [ω × (ω × h); ω × (J_O ω)]`. The simulator uses the forward direction
//! (`[f; ω̇] = M⁻¹(W − b)`) to produce the accelerometer reading that belongs to the wrench the
//! legs apply at a sample instant; tests use the inverse direction to check rapier's motion.

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use stewart_types::InertialParameters;

/// The Newton–Euler model of one rigid body about the P origin, with its inverse precomputed.
#[derive(Clone, Copy, Debug)]
pub struct RigidBodyModel {
    params: InertialParameters,
    inertia_com: Matrix3<f64>,
    inverse: Matrix6<f64>,
}

/// Specific force of the P origin and angular acceleration, both in P.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acceleration {
    /// `f = a_O − g`, m/s².
    pub specific_force_m_s2: Vector3<f64>,
    /// `ω̇`, rad/s².
    pub angular_rad_s2: Vector3<f64>,
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

impl RigidBodyModel {
    /// Builds the model; `None` when the spatial inertia is not positive definite (which
    /// includes m ≤ 0).
    pub fn new(params: InertialParameters) -> Option<Self> {
        let m = Self::spatial_inertia(&params);
        let inverse = m.cholesky()?.inverse();
        let inertia_com = params.inertia_com_kg_m2()?;
        Some(Self {
            params,
            inertia_com,
            inverse,
        })
    }

    /// The spatial inertia `M = [[m𝟙, −[h]×], [[h]×, J_O]]`.
    pub fn spatial_inertia(p: &InertialParameters) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        let h = skew(&p.first_moment_kg_m);
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * p.mass_kg));
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-h));
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&h);
        m.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&p.inertia_origin_kg_m2);
        m
    }

    /// The parameters this model was built from.
    pub fn params(&self) -> &InertialParameters {
        &self.params
    }

    /// The tensor about the centre of mass, `J_C = J_O − m(‖c‖²𝟙 − c cᵀ)` with `c = h / m`.
    pub fn inertia_com(&self) -> Matrix3<f64> {
        self.inertia_com
    }

    /// Velocity terms `b(ω) = [ω × (ω × h); ω × (J_O ω)]`.
    fn bias(&self, omega: &Vector3<f64>) -> Vector6<f64> {
        let h = &self.params.first_moment_kg_m;
        let f = omega.cross(&omega.cross(h));
        let t = omega.cross(&(self.params.inertia_origin_kg_m2 * omega));
        Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
    }

    /// Forward dynamics: the motion that a leg wrench (force and torque about the P origin, in P)
    /// produces at angular rate `omega` (in P).
    pub fn acceleration(
        &self,
        force_n: &Vector3<f64>,
        torque_nm: &Vector3<f64>,
        omega: &Vector3<f64>,
    ) -> Acceleration {
        let w = Vector6::new(
            force_n.x,
            force_n.y,
            force_n.z,
            torque_nm.x,
            torque_nm.y,
            torque_nm.z,
        );
        let a = self.inverse * (w - self.bias(omega));
        Acceleration {
            specific_force_m_s2: a.fixed_rows::<3>(0).into(),
            angular_rad_s2: a.fixed_rows::<3>(3).into(),
        }
    }

    /// Forward dynamics with a load whose wrench depends on the motion:
    /// `(M + M_L) [f; ω̇] = W − b(ω)`, for a load of spatial inertia `extra` (`M_L`, symmetric
    /// positive semi-definite, about the P origin in P) and a wrench `W` (about the P origin in
    /// P, with the load's part at `[f; ω̇] = 0`). Falls back to `M⁻¹(W − b)` if `M + M_L` is
    /// not positive definite.
    pub fn acceleration_loaded(
        &self,
        extra: &Matrix6<f64>,
        wrench: &Vector6<f64>,
        omega: &Vector3<f64>,
    ) -> Acceleration {
        let rhs = wrench - self.bias(omega);
        let a = match (Self::spatial_inertia(&self.params) + extra).cholesky() {
            Some(chol) => chol.solve(&rhs),
            None => self.inverse * rhs,
        };
        Acceleration {
            specific_force_m_s2: a.fixed_rows::<3>(0).into(),
            angular_rad_s2: a.fixed_rows::<3>(3).into(),
        }
    }

    /// Inverse dynamics: the leg wrench `(F, τ_O)` that produces a given motion.
    pub fn wrench(
        &self,
        accel: &Acceleration,
        omega: &Vector3<f64>,
    ) -> (Vector3<f64>, Vector3<f64>) {
        let p = &self.params;
        let (f, wd, h) = (
            &accel.specific_force_m_s2,
            &accel.angular_rad_s2,
            &p.first_moment_kg_m,
        );
        let force = p.mass_kg * f + wd.cross(h) + omega.cross(&omega.cross(h));
        let torque = p.inertia_origin_kg_m2 * wd
            + omega.cross(&(p.inertia_origin_kg_m2 * omega))
            + h.cross(f);
        (force, torque)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::BodyProperties;
    use nalgebra::Rotation3;

    fn model() -> RigidBodyModel {
        let q = Rotation3::from_euler_angles(0.4, 0.2, -0.7);
        let b = BodyProperties::from_principal(800.0, [0.3, -0.2, 0.6], [300.0, 700.0, 900.0], &q);
        RigidBodyModel::new(InertialParameters::from_body(&b)).unwrap()
    }

    #[test]
    fn forward_and_inverse_dynamics_round_trip() {
        let m = model();
        let omega = Vector3::new(0.7, -1.1, 0.4);
        let (f, t) = (
            Vector3::new(100.0, -2000.0, 9000.0),
            Vector3::new(300.0, 50.0, -700.0),
        );
        let a = m.acceleration(&f, &t, &omega);
        let (f2, t2) = m.wrench(&a, &omega);
        assert!((f2 - f).norm() < 1e-9 * f.norm());
        assert!((t2 - t).norm() < 1e-9 * t.norm());
    }

    #[test]
    fn body_at_rest_on_legs_feels_one_g_up() {
        // Legs holding the body still against gravity: F = −m g, τ_O = h × (−g) (P level).
        let m = model();
        let g = stewart_types::GRAVITY_B_M_S2;
        let p = m.params();
        let a = m.acceleration(
            &(-p.mass_kg * g),
            &p.first_moment_kg_m.cross(&(-g)),
            &Vector3::zeros(),
        );
        assert!((a.specific_force_m_s2 + g).norm() < 1e-12);
        assert!(a.angular_rad_s2.norm() < 1e-12);
    }

    #[test]
    fn free_spin_about_com_follows_euler_equations() {
        // Torque-free body with c at the origin: J ω̇ = −ω × J ω (Euler), f = 0.
        let q = Rotation3::from_euler_angles(0.1, 0.2, 0.3);
        let b = BodyProperties::from_principal(10.0, [0.0; 3], [1.0, 2.0, 2.5], &q);
        let m = RigidBodyModel::new(InertialParameters::from_body(&b)).unwrap();
        let omega = Vector3::new(1.0, 2.0, 3.0);
        let a = m.acceleration(&Vector3::zeros(), &Vector3::zeros(), &omega);
        let j = b.inertia_com();
        let want = j.try_inverse().unwrap() * (-omega.cross(&(j * omega)));
        assert!((a.angular_rad_s2 - want).norm() < 1e-12 * want.norm());
        assert!(a.specific_force_m_s2.norm() < 1e-12);
    }
}
