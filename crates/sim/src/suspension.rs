//! The payload as a car body on its suspension (`[world.suspension]`, [`SuspensionConfig`]).
//!
//! The payload (mass `m`, centre of mass `c`, tensor `J_C`, in P) is split at its centre of
//! mass into
//!
//! - the **unsprung** part, rigid on the plate: mass `(1 − s) m`, tensor `(1 − s) J_C`;
//! - the **sprung** body: mass `s m`, tensor `s J_C`, its own rigid body (a second rapier body
//!   whose frame coincides with P when at rest), on four spring-damper units.
//!
//! The units sit at the wheels: `a_i = c + (±w/2, ±t/2, −0.3 m)` in P (`w` the wheelbase along
//! P's x, `t` the track along P's y), attached to the body at `a_i` in its frame and to the plate
//! at `a_i` in P. With plate pose `(p, R)`, body pose `(p_b, R_b)` and the body's attachment point
//! `x_i = p_b + R_b a_i`, a unit's deflection and its rate, in P axes, are
//!
//! ```text
//! d_i = Rᵀ (x_i − p − R a_i),   ḋ_i = Rᵀ (v_b(x_i) − v_p(x_i))
//! ```
//!
//! (`v_b(x)`, `v_p(x)` the velocities of the body's and the plate's material points at `x`).
//! Each unit applies to the body, at `x_i`,
//!
//! ```text
//! F_i = R (F₀ − k d_i − c ḋ_i)
//! ```
//!
//! and `−F_i` to the plate at the same point, so the pair is a zero-moment action–reaction and
//! the units store the potential `U = Σ ½ k |d_i|² − F₀·d_i` (the plate's rotation turns `d_i`;
//! applying the reaction at `x_i` is what makes the plate's torque `−∂U/∂θ`) and dissipate
//! `Σ c |ḋ_i|²`. The stiffness is the same along P's three axes, so the body cannot drift
//! sideways or lengthways; heave sets it: `4 k = s m (2π f_b)²`, `4 c = 2 ζ √(4 k s m)`. The
//! preload `F₀ = −s m Rₕᵀ g / 4` (`Rₕ` the home pose's rotation, level) carries a quarter of
//! the body's weight at each corner; the corners lie symmetrically about the centre of mass, so
//! with P level the body rests at `d_i = 0`.

use kinematics::Pose;
use nalgebra::{Matrix3, Rotation3, Vector3, Vector6};

use crate::body::{matrix_to_rows, BodyProperties};
use crate::error::{check_non_negative, check_positive, SimError};
use crate::imperfections::SuspensionConfig;
use crate::world::GRAVITY_M_S2;

/// Height of the units' attachment points below the sprung body's centre of mass, m.
pub(crate) const UNIT_DROP_M: f64 = 0.3;

/// A rigid body's frame in motion: its pose in B, the velocity of its origin and its angular
/// velocity, both in B.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Motion {
    pub pose: Pose,
    pub v_origin: Vector3<f64>,
    pub omega: Vector3<f64>,
}

impl Motion {
    /// The motion of a frame whose centre of mass, at `com_local` in the frame, moves at `v_com`.
    pub fn from_com(
        pose: Pose,
        com_local: &Vector3<f64>,
        v_com: &Vector3<f64>,
        omega: &Vector3<f64>,
    ) -> Self {
        Self {
            pose,
            v_origin: v_com - omega.cross(&(pose.rotation * com_local)),
            omega: *omega,
        }
    }

    /// Velocity of the material point at `x` (B): `v_O + ω × (x − p)`.
    pub fn point_velocity(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.v_origin + self.omega.cross(&(x - self.pose.position_m))
    }
}

/// The four units' forces at one instant: each unit's force on the sprung body and the point
/// it acts at, in B; the plate gets the opposite force at the same point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UnitForces {
    pub points_b: [Vector3<f64>; 4],
    pub on_body_b: [Vector3<f64>; 4],
}

impl UnitForces {
    /// The units' wrench on the body about `about` (B): `[Σ F_i; Σ (x_i − about) × F_i]`.
    pub fn on_body(&self, about: &Vector3<f64>) -> Vector6<f64> {
        let mut w = Vector6::zeros();
        for (x, f) in self.points_b.iter().zip(&self.on_body_b) {
            let t = (x - about).cross(f);
            w += Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z);
        }
        w
    }

    /// The units' wrench on the plate about `about` (B): minus [`Self::on_body`].
    pub fn on_plate(&self, about: &Vector3<f64>) -> Vector6<f64> {
        -self.on_body(about)
    }

    /// The forces on the plate and their points, as rapier applies them.
    pub fn plate_loads(&self) -> [(Vector3<f64>, Vector3<f64>); 4] {
        core::array::from_fn(|i| (-self.on_body_b[i], self.points_b[i]))
    }

    /// The forces on the body and their points.
    pub fn body_loads(&self) -> [(Vector3<f64>, Vector3<f64>); 4] {
        core::array::from_fn(|i| (self.on_body_b[i], self.points_b[i]))
    }
}

/// The sprung body and its four units (module docs).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Suspension {
    /// The sprung body in its own frame (P at rest): `s m`, `c`, `s J_C`.
    body: BodyProperties,
    /// The units' attachment points `a_i`, in P (and in the body's frame).
    corners_m: [Vector3<f64>; 4],
    /// Per-unit stiffness `k`, N/m, the same along P's three axes.
    stiffness_n_m: f64,
    /// Per-unit damping `c`, N·s/m, the same along P's three axes.
    damping_n_s_m: f64,
    /// Per-unit preload on the body `F₀`, in P, N.
    preload_n: Vector3<f64>,
}

/// Checks `[world.suspension]` when it is enabled: `0 < s ≤ 1`, positive bounce frequency,
/// track and wheelbase, non-negative damping ratio.
pub(crate) fn validate(c: &SuspensionConfig) -> Result<(), SimError> {
    if !c.enabled {
        return Ok(());
    }
    check_positive("suspension.sprung_share", c.sprung_share)?;
    if c.sprung_share > 1.0 {
        return Err(SimError::InvalidConfig {
            field: "suspension.sprung_share",
            value: c.sprung_share,
            reason: "must be at most 1 (the share of the payload's mass on the springs)",
        });
    }
    check_positive("suspension.bounce_hz", c.bounce_hz)?;
    check_non_negative("suspension.damping_ratio", c.damping_ratio)?;
    check_positive("suspension.track_m", c.track_m)?;
    check_positive("suspension.wheelbase_m", c.wheelbase_m)
}

fn scaled(b: &BodyProperties, share: f64) -> BodyProperties {
    BodyProperties {
        mass_kg: share * b.mass_kg,
        com_m: b.com_m,
        inertia_com_kg_m2: matrix_to_rows(&(share * b.inertia_com())),
    }
}

impl Suspension {
    /// The suspension of `payload` per `config` (`None` when disabled), with P at the home
    /// orientation `rest` when the body rests on its preload.
    pub fn new(
        config: &SuspensionConfig,
        payload: &BodyProperties,
        rest: &Rotation3<f64>,
    ) -> Option<Self> {
        if !config.enabled {
            return None;
        }
        let s = config.sprung_share;
        let body = scaled(payload, s);
        let mass = body.mass_kg;
        let omega_n = 2.0 * core::f64::consts::PI * config.bounce_hz;
        let stiffness = mass * omega_n * omega_n / 4.0;
        let damping = 2.0 * config.damping_ratio * (4.0 * stiffness * mass).sqrt() / 4.0;
        let (hw, ht) = (0.5 * config.wheelbase_m, 0.5 * config.track_m);
        let c = payload.com();
        let corners_m = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)]
            .map(|(sx, sy)| c + Vector3::new(sx * hw, sy * ht, -UNIT_DROP_M));
        Some(Self {
            body,
            corners_m,
            stiffness_n_m: stiffness,
            damping_n_s_m: damping,
            preload_n: -(mass / 4.0) * (rest.inverse() * GRAVITY_M_S2),
        })
    }

    /// The part of `payload` that stays rigid on the plate, `(1 − s)` of it (`None` when the
    /// whole payload is sprung).
    pub fn unsprung(config: &SuspensionConfig, payload: &BodyProperties) -> Option<BodyProperties> {
        let share = 1.0 - config.sprung_share;
        (share > 0.0).then(|| scaled(payload, share))
    }

    /// The sprung body in its own frame (P at rest).
    pub fn body(&self) -> &BodyProperties {
        &self.body
    }

    /// Per-unit stiffness `k` (N/m) and damping `c` (N·s/m).
    #[cfg(test)]
    pub fn unit_constants(&self) -> (f64, f64) {
        (self.stiffness_n_m, self.damping_n_s_m)
    }

    /// The body's attachment points `x_i` and the deflections `d_i` (P axes) with the plate at
    /// `plate` and the body at `body`.
    fn deflections(&self, plate: &Pose, body: &Pose) -> ([Vector3<f64>; 4], [Vector3<f64>; 4]) {
        let rt = plate.rotation.inverse();
        let x = self.corners_m.map(|a| body.position_m + body.rotation * a);
        let d = core::array::from_fn(|i| {
            rt * (x[i] - plate.position_m - plate.rotation * self.corners_m[i])
        });
        (x, d)
    }

    /// The units' forces with the plate and the body moving as given (module docs).
    pub fn forces(&self, plate: &Motion, body: &Motion) -> UnitForces {
        let (x, d) = self.deflections(&plate.pose, &body.pose);
        let r = plate.pose.rotation;
        let rt = r.inverse();
        let on_body_b = core::array::from_fn(|i| {
            let rate = rt * (body.point_velocity(&x[i]) - plate.point_velocity(&x[i]));
            r * (self.preload_n - self.stiffness_n_m * d[i] - self.damping_n_s_m * rate)
        });
        UnitForces {
            points_b: x,
            on_body_b,
        }
    }

    /// The units' forces with the body resting on the plate at `plate` (`d_i = 0`, `ḋ_i = 0`):
    /// the preloads alone, at the plate's attachment points.
    pub fn rest_forces(&self, plate: &Pose) -> UnitForces {
        let r = plate.rotation;
        UnitForces {
            points_b: self.corners_m.map(|a| plate.position_m + r * a),
            on_body_b: [r * self.preload_n; 4],
        }
    }

    #[cfg(test)]
    /// The units' stored energy `U = Σ ½ k |d_i|² − F₀·d_i`, J.
    pub fn potential_energy(&self, plate: &Pose, body: &Pose) -> f64 {
        let (_, d) = self.deflections(plate, body);
        d.iter()
            .map(|d| 0.5 * self.stiffness_n_m * d.norm_squared() - self.preload_n.dot(d))
            .sum()
    }

    #[cfg(test)]
    /// The dampers' dissipated power `Σ c |ḋ_i|²`, W.
    pub fn damper_power(&self, plate: &Motion, body: &Motion) -> f64 {
        let (x, _) = self.deflections(&plate.pose, &body.pose);
        x.iter()
            .map(|x| {
                let rate = body.point_velocity(x) - plate.point_velocity(x);
                self.damping_n_s_m * rate.norm_squared()
            })
            .sum()
    }

    /// The body's tensor about its centre of mass, in B.
    pub fn inertia_b(&self, body: &Pose) -> Matrix3<f64> {
        let r = body.rotation.matrix();
        r * self.body.inertia_com() * r.transpose()
    }

    /// The body's centre of mass in B.
    pub fn com_b(&self, body: &Pose) -> Vector3<f64> {
        body.position_m + body.rotation * self.body.com()
    }

    /// The gyroscopic torque `−ω × (J_C ω)` on the body (B).
    pub fn gyroscopic_torque(&self, body: &Motion) -> Vector3<f64> {
        let w = &body.omega;
        -w.cross(&(self.inertia_b(&body.pose) * w))
    }

    /// The body's motion at the instant from rapier's half-step-old velocities `raw` and the
    /// units' forces there: `v(t_n) = v_{n−½} + (h/2) a`, with `a` from the units, gravity and
    /// (`gyroscopic`) the gyroscopic torque — as the plate's velocities are taken to the instant.
    pub fn body_instant(
        &self,
        raw: &Motion,
        forces: &UnitForces,
        h: f64,
        gyroscopic: bool,
    ) -> Motion {
        let com = self.com_b(&raw.pose);
        let w = forces.on_body(&com);
        let torque = Vector3::new(w[3], w[4], w[5])
            + if gyroscopic {
                self.gyroscopic_torque(raw)
            } else {
                Vector3::zeros()
            };
        let j = self.inertia_b(&raw.pose);
        let omega_dot = j.try_inverse().unwrap_or_else(Matrix3::zeros) * torque;
        let a_com = Vector3::new(w[0], w[1], w[2]) / self.body.mass_kg + GRAVITY_M_S2;
        let v_com = raw.point_velocity(&com) + 0.5 * h * a_com;
        let omega = raw.omega + 0.5 * h * omega_dot;
        Motion {
            pose: raw.pose,
            v_origin: v_com - omega.cross(&(com - raw.pose.position_m)),
            omega,
        }
    }

    /// Explicit integration of the units is stable when, for the body's stiffest mode on its
    /// units (the plate held), `h² λ_max(M⁻¹K) ≤ 2` and `2 h λ_max(M⁻¹C) ≤ 2` (half the bounds
    /// of symplectic Euler), with `M = diag(s m 𝟙, s J_C)` and `K = k Σ Gᵢᵀ Gᵢ`,
    /// `Gᵢ = [𝟙, −[a_i − c]×]` (`C` the same with `c`).
    pub fn check_stability(&self, h: f64) -> Result<(), SimError> {
        let c = self.body.com();
        let mut g = nalgebra::Matrix6::zeros();
        for a in &self.corners_m {
            let r = a - c;
            let rx = Matrix3::new(0.0, -r.z, r.y, r.z, 0.0, -r.x, -r.y, r.x, 0.0);
            let mut gi = nalgebra::Matrix3x6::zeros();
            gi.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            gi.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-rx));
            g += gi.transpose() * gi;
        }
        let mut mass = nalgebra::Matrix6::zeros();
        mass.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * self.body.mass_kg));
        mass.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&self.body.inertia_com());
        let Some(chol) = mass.cholesky() else {
            return Err(SimError::InvalidBody {
                body: "payload",
                reason: "the sprung body's spatial inertia is not positive definite",
            });
        };
        let l_inv = chol
            .l()
            .try_inverse()
            .unwrap_or_else(nalgebra::Matrix6::zeros);
        let a = l_inv * g * l_inv.transpose();
        let mu = nalgebra::SymmetricEigen::new(0.5 * (a + a.transpose()))
            .eigenvalues
            .max();
        if h * h * self.stiffness_n_m * mu > 2.0 {
            return Err(SimError::InvalidConfig {
                field: "suspension.bounce_hz",
                value: self.stiffness_n_m,
                reason: "suspension too stiff for the physics substep and the sprung body's \
                         lightest mode (lower bounce_hz or raise substeps)",
            });
        }
        if 2.0 * h * self.damping_n_s_m * mu > 2.0 {
            return Err(SimError::InvalidConfig {
                field: "suspension.damping_ratio",
                value: self.damping_n_s_m,
                reason: "suspension damping too steep for the physics substep and the sprung \
                         body's lightest mode (lower damping_ratio or raise substeps)",
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
