//! Test helpers: an independent rigid-body model (a cloud of point masses, Newton–Euler summed
//! mass by mass) and smooth platform motions with analytic rates and accelerations.

use nalgebra::{Matrix3, Rotation3, Vector3, Vector6};
use rand::{rngs::StdRng, Rng};
use stewart_types::InertialParameters;

use stewart_types::GRAVITY_B_M_S2 as GRAVITY_B;

/// A rigid body made of point masses at fixed positions in P.
#[derive(Clone, Debug)]
pub struct PointBody {
    pub masses_kg: std::vec::Vec<f64>,
    pub positions_m: std::vec::Vec<Vector3<f64>>,
}

impl PointBody {
    /// Its inertial parameters about the P origin, summed mass by mass from the definitions
    /// (h = Σ mₖ rₖ, J_O = Σ mₖ(‖rₖ‖²𝟙 − rₖ rₖᵀ)).
    pub fn parameters(&self) -> InertialParameters {
        let mut p = InertialParameters::zero();
        for (m, r) in self.masses_kg.iter().zip(&self.positions_m) {
            p.mass_kg += m;
            p.first_moment_kg_m += r * *m;
            p.inertia_origin_kg_m2 +=
                (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * *m;
        }
        p
    }

    /// The wrench [F; τ_O] the plate must apply, by Newton's law mass by mass: each mass has
    /// specific force fₖ = f + ω̇ × rₖ + ω × (ω × rₖ) and needs mₖ fₖ, with moment rₖ × mₖ fₖ.
    /// Shares no code with the regressor.
    pub fn wrench(
        &self,
        omega: &Vector3<f64>,
        omega_dot: &Vector3<f64>,
        specific_force: &Vector3<f64>,
    ) -> Vector6<f64> {
        let mut force = Vector3::zeros();
        let mut torque = Vector3::zeros();
        for (m, r) in self.masses_kg.iter().zip(&self.positions_m) {
            let fk = specific_force + omega_dot.cross(r) + omega.cross(&omega.cross(r));
            force += fk * *m;
            torque += r.cross(&(fk * *m));
        }
        Vector6::new(force.x, force.y, force.z, torque.x, torque.y, torque.z)
    }

    /// A car-like body: 1.2 t over a 3.8 × 1.7 × 1.3 m box, centre of mass above and beside
    /// the plate centre, with products of inertia.
    pub fn vehicle_like() -> Self {
        let mut masses = std::vec::Vec::new();
        let mut positions = std::vec::Vec::new();
        let corners = [-1.0, 1.0];
        for (i, sx) in corners.iter().enumerate() {
            for (j, sy) in corners.iter().enumerate() {
                for (k, sz) in corners.iter().enumerate() {
                    masses.push(100.0 + 30.0 * i as f64 + 17.0 * j as f64 + 9.0 * k as f64);
                    positions.push(Vector3::new(
                        0.12 + 1.9 * sx + 0.1 * sy * sz,
                        -0.05 + 0.85 * sy + 0.07 * sx,
                        0.75 + 0.65 * sz + 0.05 * sx * sy,
                    ));
                }
            }
        }
        masses.push(250.0); // engine block
        positions.push(Vector3::new(1.2, 0.0, 0.5));
        Self {
            masses_kg: masses,
            positions_m: positions,
        }
    }
}

/// A random body: 4 to 9 point masses round a random centre.
pub fn random_body(rng: &mut StdRng) -> PointBody {
    let n = rng.random_range(4..10);
    let centre = Vector3::new(
        rng.random_range(-0.3..0.3),
        rng.random_range(-0.3..0.3),
        rng.random_range(0.1..0.6),
    );
    let spread = rng.random_range(0.2..1.0);
    let mut masses_kg = std::vec::Vec::new();
    let mut positions_m = std::vec::Vec::new();
    for _ in 0..n {
        masses_kg.push(rng.random_range(0.5..50.0));
        positions_m.push(
            centre
                + Vector3::new(
                    rng.random_range(-spread..spread),
                    rng.random_range(-spread..spread),
                    rng.random_range(-spread..spread),
                ),
        );
    }
    PointBody {
        masses_kg,
        positions_m,
    }
}

/// A sum of sines q(t) = Σ Aᵢ sin(ωᵢ t + φᵢ), with its first two derivatives.
#[derive(Clone, Copy, Debug, Default)]
pub struct MultiSine {
    /// (amplitude, angular frequency rad/s, phase rad), unused terms with amplitude 0.
    pub terms: [(f64, f64, f64); 4],
}

impl MultiSine {
    pub fn one(amplitude: f64, frequency_hz: f64, phase: f64) -> Self {
        let mut s = Self::default();
        s.terms[0] = (amplitude, 2.0 * core::f64::consts::PI * frequency_hz, phase);
        s
    }

    /// (q, q̇, q̈) at t.
    pub fn eval(&self, t: f64) -> (f64, f64, f64) {
        let mut out = (0.0, 0.0, 0.0);
        for (a, w, p) in self.terms {
            let (s, c) = (w * t + p).sin_cos();
            out.0 += a * s;
            out.1 += a * w * c;
            out.2 -= a * w * w * s;
        }
        out
    }
}

/// Platform motion: translation of the P origin in B (about `centre_m`) and roll, pitch, yaw
/// with R = Rx(α)·Ry(β)·Rz(γ), each a sum of sines.
#[derive(Clone, Copy, Debug)]
pub struct Motion {
    pub centre_m: Vector3<f64>,
    pub translation: [MultiSine; 3],
    pub rotation: [MultiSine; 3],
}

/// Exact kinematic state of the plate at one instant.
#[derive(Clone, Copy, Debug)]
pub struct MotionState {
    pub position_m: Vector3<f64>,
    pub rotation: Rotation3<f64>,
    /// ω in P.
    pub omega: Vector3<f64>,
    /// ω̇ in P.
    pub omega_dot: Vector3<f64>,
    /// a_O − g in P.
    pub specific_force: Vector3<f64>,
}

impl Motion {
    /// Several sines per axis at incommensurate frequencies (0.3–3 Hz), rotations up to
    /// ≈ 0.25 rad and translations up to ≈ 0.1 m.
    pub fn rich() -> Self {
        let ms = |t: [(f64, f64, f64); 4]| {
            let mut s = MultiSine { terms: t };
            for term in s.terms.iter_mut() {
                term.1 *= 2.0 * core::f64::consts::PI;
            }
            s
        };
        Self {
            centre_m: Vector3::new(0.0, 0.0, 1.0),
            translation: [
                ms([
                    (0.04, 0.37, 0.1),
                    (0.02, 1.3, 1.0),
                    (0.005, 2.9, 0.0),
                    (0.0, 0.0, 0.0),
                ]),
                ms([
                    (0.03, 0.53, 0.7),
                    (0.02, 1.7, 2.0),
                    (0.004, 2.3, 0.5),
                    (0.0, 0.0, 0.0),
                ]),
                ms([
                    (0.03, 0.61, 1.9),
                    (0.015, 1.1, 0.3),
                    (0.004, 3.1, 1.1),
                    (0.0, 0.0, 0.0),
                ]),
            ],
            rotation: [
                ms([
                    (0.12, 0.41, 0.0),
                    (0.05, 1.23, 0.4),
                    (0.02, 2.71, 1.3),
                    (0.0, 0.0, 0.0),
                ]),
                ms([
                    (0.10, 0.47, 1.2),
                    (0.05, 1.57, 2.2),
                    (0.02, 2.39, 0.2),
                    (0.0, 0.0, 0.0),
                ]),
                ms([
                    (0.15, 0.29, 2.1),
                    (0.06, 1.01, 0.9),
                    (0.02, 2.93, 2.7),
                    (0.0, 0.0, 0.0),
                ]),
            ],
        }
    }

    /// The paper's Eq. 8: no translation, one sine each in roll, pitch and yaw.
    pub fn paper(centre_m: Vector3<f64>) -> Self {
        Self {
            centre_m,
            translation: [MultiSine::default(); 3],
            rotation: [
                MultiSine::one(0.15, 0.5, 0.0),
                MultiSine::one(0.12, 0.7, 0.0),
                MultiSine::one(0.20, 0.3, 0.0),
            ],
        }
    }

    /// Large-angle tumbling for the angular-momentum test.
    pub fn tumbling() -> Self {
        Self {
            centre_m: Vector3::zeros(),
            translation: [MultiSine::default(); 3],
            rotation: [
                MultiSine::one(1.1, 0.9, 0.3),
                MultiSine::one(0.8, 1.3, 1.0),
                MultiSine::one(1.5, 0.6, 2.0),
            ],
        }
    }

    /// Exact state at t. ω = α̇ Rzᵀ Ryᵀ eₓ + β̇ Rzᵀ e_y + γ̇ e_z, differentiated term by term
    /// for ω̇ (dRzᵀ/dt = −γ̇[e_z]× Rzᵀ, dRyᵀ/dt = −β̇[e_y]× Ryᵀ).
    pub fn state(&self, t: f64) -> MotionState {
        let (a, ad, add) = self.rotation[0].eval(t);
        let (b, bd, bdd) = self.rotation[1].eval(t);
        let (g, gd, gdd) = self.rotation[2].eval(t);
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), a);
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), b);
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), g);
        let rotation = rx * ry * rz;
        let ex = Vector3::x();
        let ey = Vector3::y();
        let ez = Vector3::z();
        let u = rz.inverse() * (ry.inverse() * ex);
        let v = rz.inverse() * ey;
        let omega = u * ad + v * bd + ez * gd;
        let du = -ez.cross(&u) * gd - rz.inverse() * ey.cross(&(ry.inverse() * ex)) * bd;
        let dv = -ez.cross(&v) * gd;
        let omega_dot = u * add + du * ad + v * bdd + dv * bd + ez * gdd;
        let mut p = self.centre_m;
        let mut acc = Vector3::zeros();
        for k in 0..3 {
            let (q, _, qdd) = self.translation[k].eval(t);
            p[k] += q;
            acc[k] = qdd;
        }
        MotionState {
            position_m: p,
            rotation,
            omega,
            omega_dot,
            specific_force: rotation.inverse() * (acc - GRAVITY_B),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The analytic ω, ω̇ and specific force agree with differences of R(t) and p(t).
    #[test]
    fn motion_derivatives_match_differences() {
        for motion in [Motion::rich(), Motion::tumbling()] {
            let h = 1e-5;
            for k in 0..50 {
                let t = 0.173 * k as f64;
                let s = motion.state(t);
                let (sp, sm) = (motion.state(t + h), motion.state(t - h));
                let rdot = (sp.rotation.matrix() - sm.rotation.matrix()) / (2.0 * h);
                let w = s.rotation.matrix().transpose() * rdot; // [ω]×
                let omega = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
                assert!((omega - s.omega).norm() < 1e-7 * (1.0 + s.omega.norm()));
                let wd = (sp.omega - sm.omega) / (2.0 * h);
                assert!((wd - s.omega_dot).norm() < 1e-6 * (1.0 + s.omega_dot.norm()));
                let acc = (sp.position_m - 2.0 * s.position_m + sm.position_m) / (h * h);
                let f = s.rotation.inverse() * (acc - GRAVITY_B);
                assert!((f - s.specific_force).norm() < 1e-3);
            }
        }
    }

    /// The point-mass body's parameters obey the parallel-axis theorem (a sanity check of the
    /// helper itself).
    #[test]
    fn point_body_parameters_are_consistent() {
        let p = PointBody::vehicle_like().parameters();
        assert!(p.consistency().is_consistent());
        assert!((p.mass_kg - 1274.0).abs() < 1e-9);
    }
}

/// A mid-sized test rig: base radius 1.5 m, plate 1.0 m, legs 1.3–2.3 m.
pub fn test_geometry() -> kinematics::Geometry {
    kinematics::Geometry::from_radii(
        1.5,
        1.0,
        0.4,
        0.4,
        kinematics::StrokeLimits {
            min_length_m: 1.3,
            max_length_m: 2.3,
        },
    )
    .expect("test geometry")
}

/// Gaussian noise levels of a synthetic rig's sensors (one sigma).
#[derive(Clone, Copy, Debug, Default)]
pub struct SensorNoise {
    pub leg_force_n: f64,
    pub gyro_rad_s: f64,
    pub accel_m_s2: f64,
}

/// A synthetic sample of the plate carrying `body` along `motion` at time t: exact wrench from
/// the point masses, turned into leg forces by solving Jᵀ f = w (B axes), accelerometer at
/// `accel_position_m`, plus Gaussian noise.
pub fn synthetic_sample(
    geometry: &kinematics::Geometry,
    body: &PointBody,
    motion: &Motion,
    t: f64,
    accel_position_m: &Vector3<f64>,
    noise: &SensorNoise,
    rng: &mut StdRng,
) -> crate::online::Sample {
    use rand_distr::{Distribution, Normal};
    let s = motion.state(t);
    let w = body.wrench(&s.omega, &s.omega_dot, &s.specific_force);
    let pose = kinematics::Pose::new(s.position_m, s.rotation);
    let r = s.rotation;
    let wb = Vector6::from_iterator(
        (r * Vector3::new(w[0], w[1], w[2]))
            .iter()
            .chain((r * Vector3::new(w[3], w[4], w[5])).iter())
            .copied(),
    );
    let jt = geometry.jacobian(&pose).transpose();
    let mut forces = jt.lu().solve(&wb).expect("non-singular pose");
    let acc = s.specific_force
        + s.omega_dot.cross(accel_position_m)
        + s.omega.cross(&s.omega.cross(accel_position_m));
    let mut gyro = s.omega;
    let mut accel = acc;
    let mut draw = |sigma: f64| {
        if sigma > 0.0 {
            Normal::new(0.0, sigma).expect("sigma").sample(rng)
        } else {
            0.0
        }
    };
    for k in 0..6 {
        forces[k] += draw(noise.leg_force_n);
    }
    for k in 0..3 {
        gyro[k] += draw(noise.gyro_rad_s);
        accel[k] += draw(noise.accel_m_s2);
    }
    crate::online::Sample {
        time_s: t,
        sequence: None,
        pose,
        leg_forces_n: forces,
        gyro_rad_s: gyro,
        accel_m_s2: accel,
    }
}
