//! Synthetic runs for the budget's tests: a rigid body moved by sines, its samples from an
//! independent Newton–Euler (F = m(f + ω̇ × c + ω × (ω × c)), τ_O = c × F + J_C ω̇ + ω × J_C ω),
//! the rates from finite differences of the rotation, the leg forces by solving the legs' map;
//! an error can be added to the samples themselves, for checks against a second fit.

use estimator::{InertialParameters, Sample};
use kinematics::{FkOptions, Geometry, Pose};
use nalgebra::{Matrix3, Rotation3, Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

use crate::record::{Entry, RunRecord};

pub use crate::testkit::geometry;

/// The default rig description's legs (the embedded `configs/default.toml`).
pub fn default_legs() -> rig_description::config::LegsConfig {
    rig_description::load::load(None)
        .expect("the embedded default loads")
        .config
        .legs
}

/// `n` entries of a platform at rest at home, 10 ms apart.
pub fn still_entries(g: &Geometry, n: usize) -> Vec<Entry> {
    let mut r = RunRecord::new(*g, 1e-2, n);
    for k in 0..n {
        r.push(&Sample {
            time_s: k as f64 * 0.01,
            sequence: Some(k as u64),
            pose: g.home_pose(),
            leg_forces_n: Vector6::from_element(3000.0),
            gyro_rad_s: Vector3::zeros(),
            accel_m_s2: Vector3::new(0.0, 0.0, 9.80665),
        });
    }
    r.entries()
}

/// The car-like body of the default scenario plus its fixture.
pub fn body() -> InertialParameters {
    InertialParameters::from_com(
        1900.0,
        Vector3::new(0.12, -0.06, 0.41),
        Matrix3::new(
            840.0, -25.0, 60.0, -25.0, 2740.0, -15.0, 60.0, -15.0, 3150.0,
        ),
    )
}

/// A synthetic run.
#[derive(Clone, Debug)]
pub struct Synth {
    /// The body on the plate.
    pub body: InertialParameters,
    /// The accelerometer's position in P, m.
    pub lever_m: Vector3<f64>,
    /// Length, s.
    pub duration_s: f64,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// Translation amplitude, m, and rotation amplitude, rad.
    pub amplitude: (f64, f64),
    /// Frequencies of x, y, z, roll, pitch, yaw, Hz.
    pub frequencies: [f64; 6],
    /// The joints as built (forces and leg lengths); the record's pose is solved with the
    /// described design.
    pub built: Option<Geometry>,
    /// Noise (gyro rad/s, accelerometer m/s², load cell N per sample) and seed.
    pub noise: Option<([f64; 3], u64)>,
}

impl Default for Synth {
    fn default() -> Self {
        Self {
            body: body(),
            lever_m: Vector3::new(0.3, -0.2, 0.1),
            duration_s: 12.0,
            rate_hz: 1000.0,
            amplitude: (0.015, 2f64.to_radians()),
            frequencies: [0.3, 0.7, 1.1, 0.5, 0.9, 1.7],
            built: None,
            noise: None,
        }
    }
}

/// The true state at `t`: pose, ω and ω̇ in P, specific force of the P origin in P.
pub struct State {
    /// Pose.
    pub pose: Pose,
    /// ω in P.
    pub omega: Vector3<f64>,
    /// ω̇ in P.
    pub omega_dot: Vector3<f64>,
    /// a − g of the P origin, in P.
    pub specific_force: Vector3<f64>,
}

impl Synth {
    fn pose(&self, g: &Geometry, t: f64) -> Pose {
        let (a, r) = self.amplitude;
        let w = self.frequencies.map(|f| 2.0 * core::f64::consts::PI * f);
        let home = g.home_pose().position_m;
        Pose::from_rpy(
            home + Vector3::new(
                a * (w[0] * t).sin(),
                a * (w[1] * t).sin(),
                a * (w[2] * t).sin(),
            ),
            r * (w[3] * t).sin(),
            r * (w[4] * t).sin(),
            r * (w[5] * t).sin(),
        )
    }

    fn omega(&self, g: &Geometry, t: f64) -> Vector3<f64> {
        // ω in P: vee(Rᵀ Ṙ), Ṙ by a fourth-order central difference.
        let d = 1e-4;
        let r = |t: f64| *self.pose(g, t).rotation.matrix();
        let rd = (r(t - 2.0 * d) - r(t - d) * 8.0 + r(t + d) * 8.0 - r(t + 2.0 * d)) / (12.0 * d);
        let s = r(t).transpose() * rd;
        Vector3::new(
            s[(2, 1)] - s[(1, 2)],
            s[(0, 2)] - s[(2, 0)],
            s[(1, 0)] - s[(0, 1)],
        ) * 0.5
    }

    /// The true state at `t` on design `g`.
    pub fn state(&self, g: &Geometry, t: f64) -> State {
        let pose = self.pose(g, t);
        let d = 1e-4;
        let w = |t: f64| self.omega(g, t);
        let omega_dot =
            (w(t - 2.0 * d) - w(t - d) * 8.0 + w(t + d) * 8.0 - w(t + 2.0 * d)) / (12.0 * d);
        let (a, _) = self.amplitude;
        let f = self.frequencies.map(|f| 2.0 * core::f64::consts::PI * f);
        let acc = Vector3::new(
            -a * f[0] * f[0] * (f[0] * t).sin(),
            -a * f[1] * f[1] * (f[1] * t).sin(),
            -a * f[2] * f[2] * (f[2] * t).sin(),
        );
        let g_b = Vector3::from(GRAVITY_B_M_S2);
        State {
            pose,
            omega: w(t),
            omega_dot,
            specific_force: pose.rotation.inverse() * (acc - g_b),
        }
    }

    /// The wrench [F; τ_O] the body needs, P axes.
    pub fn wrench(&self, s: &State) -> Vector6<f64> {
        let m = self.body.mass_kg;
        let c = self.body.com_m().unwrap_or_default();
        let jc = self.body.inertia_com_kg_m2().unwrap_or_else(Matrix3::zeros);
        let (w, wd) = (s.omega, s.omega_dot);
        let f = (s.specific_force + wd.cross(&c) + w.cross(&w.cross(&c))) * m;
        let t = c.cross(&f) + jc * wd + w.cross(&(jc * w));
        Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
    }

    /// The samples on the described design `g`, each passed through `corrupt` (with its
    /// index) after the physics and before the noise.
    pub fn samples(
        &self,
        g: &Geometry,
        mut corrupt: impl FnMut(u64, &State, &mut Sample),
    ) -> Vec<Sample> {
        let n = (self.duration_s * self.rate_hz) as u64;
        let built = self.built.unwrap_or(*g);
        let mut rng = self
            .noise
            .map(|(_, seed)| seed.wrapping_mul(6364136223846793005) | 1);
        let mut gauss = move || -> f64 {
            let Some(s) = rng.as_mut() else { return 0.0 };
            let mut u = || {
                *s ^= *s << 13;
                *s ^= *s >> 7;
                *s ^= *s << 17;
                ((*s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (2.0 * core::f64::consts::PI * b).cos()
        };
        let mut guess = g.home_pose();
        (0..n)
            .map(|k| {
                let t = k as f64 / self.rate_hz;
                let s = self.state(&built, t);
                let y = self.wrench(&s);
                let l = built.jacobian(&s.pose).transpose();
                // Jᵀ f = [F; τ] in B; the body's wrench is in P.
                let r = s.pose.rotation;
                let fb = r * Vector3::new(y[0], y[1], y[2]);
                let tb = r * Vector3::new(y[3], y[4], y[5]);
                let forces = l
                    .lu()
                    .solve(&Vector6::new(fb.x, fb.y, fb.z, tb.x, tb.y, tb.z))
                    .expect("regular pose");
                let pose = if self.built.is_some() {
                    let lengths = built.leg_lengths(&s.pose);
                    let p = g
                        .forward_kinematics(&lengths, &guess, &FkOptions::default())
                        .expect("pose")
                        .pose;
                    guess = p;
                    p
                } else {
                    s.pose
                };
                let rv = self.lever_m;
                let (w, wd) = (s.omega, s.omega_dot);
                let mut sample = Sample {
                    time_s: t,
                    sequence: Some(k),
                    pose,
                    leg_forces_n: forces,
                    gyro_rad_s: w,
                    accel_m_s2: s.specific_force + wd.cross(&rv) + w.cross(&w.cross(&rv)),
                };
                corrupt(k, &s, &mut sample);
                if let Some((sig, _)) = self.noise {
                    for a in 0..3 {
                        sample.gyro_rad_s[a] += sig[0] * gauss();
                        sample.accel_m_s2[a] += sig[1] * gauss();
                    }
                    for leg in 0..6 {
                        sample.leg_forces_n[leg] += sig[2] * gauss();
                    }
                }
                sample
            })
            .collect()
    }

    /// The record of `samples` on `g`.
    pub fn record(&self, g: &Geometry, samples: &[Sample]) -> RunRecord {
        let mut r = RunRecord::new(*g, 1.0 / self.rate_hz, samples.len());
        for s in samples {
            r.push(s);
        }
        r
    }
}

/// A rotation of `angle` about P's axis `axis`.
pub fn turn(axis: usize, angle: f64) -> Rotation3<f64> {
    Rotation3::new(Vector3::ith(axis, angle))
}
