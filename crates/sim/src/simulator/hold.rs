//! Holding the plate: the actuator forces that carry it at rest, the brake's implicit damping,
//! and the explicit terms' stability bounds, all with the legs' own mass and friction when the
//! legs have them.

use control::io::LEG_COUNT;
use kinematics::Pose;
use nalgebra::{Matrix3, Matrix6, SymmetricEigen, Vector3, Vector6};

use super::{LegState, Simulator};
use crate::config::GyroscopicModel;
use crate::dynamics::RigidBodyModel;
use crate::error::SimError;
use crate::world::GRAVITY_M_S2;

impl Simulator {
    /// Explicit integration of the brake's spring and of the actuators' viscous and smoothed
    /// Coulomb friction is stable when, for the lightest mode of the plate on its legs,
    /// `h² k μ ≤ 2` and `2 h c μ ≤ 2` (half the bounds of symplectic Euler), where
    /// `μ = λ_max(M⁻¹ Jᵀ J)` at the home pose, `M` the spatial inertia about the P origin and
    /// `J` the leg Jacobian in P. (The brake's damper is implicit and needs no check.) With
    /// legs, `M` includes their reflected inertia at rest, and the joints' friction (slope `c`
    /// of the smoothed law, damping matrix `D`) needs `2 h λ_max(M⁻¹ D) ≤ 2`.
    pub(super) fn check_stability(&self) -> Result<(), SimError> {
        let pose = self.geometry.home_pose();
        let legs = self.legs(&pose);
        let rt = pose.rotation.inverse();
        let mut j = Matrix6::zeros();
        for i in 0..LEG_COUNT {
            let u = rt * legs.units[i];
            let m = self.geometry.plate_joints_m()[i].cross(&u);
            for c in 0..3 {
                j[(i, c)] = u[c];
                j[(i, c + 3)] = m[c];
            }
        }
        let mut mass = RigidBodyModel::spatial_inertia(self.model.params());
        let leg_terms = self.legs_model.as_ref().map(|m| self.legs_home_terms(m));
        if let Some((m_l, _)) = &leg_terms {
            mass += m_l;
        }
        let Some(chol) = mass.cholesky() else {
            return Err(SimError::InvalidBody {
                body: "plate + payload",
                reason: "spatial inertia is not positive definite",
            });
        };
        let l_inv = chol.l().try_inverse().unwrap_or_else(Matrix6::zeros);
        let a = l_inv * j.transpose() * j * l_inv.transpose();
        let mu = SymmetricEigen::new(0.5 * (a + a.transpose()))
            .eigenvalues
            .max();
        let h = self.substep_s;
        let act = &self.config.actuator;
        if h * h * act.brake_stiffness_n_m * mu > 2.0 {
            return Err(SimError::InvalidConfig {
                field: "actuator.brake_stiffness_n_m",
                value: act.brake_stiffness_n_m,
                reason: "brake stiffness too high for the physics substep and the lightest \
                         mode of the plate (lower it or raise substeps)",
            });
        }
        let friction =
            act.viscous_friction_n_s_m + act.coulomb_friction_n / act.coulomb_velocity_scale_m_s;
        if 2.0 * h * friction * mu > 2.0 {
            return Err(SimError::InvalidConfig {
                field: "actuator.coulomb_velocity_scale_m_s",
                value: act.coulomb_velocity_scale_m_s,
                reason: "actuator friction slope (viscous + coulomb / velocity scale) too steep \
                         for the physics substep (raise the velocity scale or substeps)",
            });
        }
        if let Some(s) = &self.suspension {
            s.check_stability(h)?;
        }
        if let Some((_, damping)) = &leg_terms {
            let d = l_inv * damping * l_inv.transpose();
            let nu = SymmetricEigen::new(0.5 * (d + d.transpose()))
                .eigenvalues
                .max();
            if 2.0 * h * nu > 2.0 {
                return Err(SimError::InvalidConfig {
                    field: "legs.joint_coulomb_torque_nm",
                    value: self.config.legs.joint_coulomb_torque_nm,
                    reason: "joint friction slope (viscous + coulomb / smoothing rate) too steep \
                             for the physics substep and the lightest mode of the plate and legs",
                });
            }
        }
        Ok(())
    }

    /// Actuator forces that hold the plate at rest at `pose` against gravity:
    /// `Jᵀ f = −W_gravity − Q_rest − W_units`, `Q_rest` the wrench the legs' own weight puts on
    /// the plate at rest (zero for massless legs; [`crate::legs::reflect`]) and `W_units` that
    /// of a suspension's units with the sprung body resting on them (their preloads: the sprung
    /// body's weight with P level; [`crate::suspension`]).
    pub(super) fn static_forces(&self, pose: &Pose, legs: &LegState) -> Result<[f64; 6], SimError> {
        let p = self.model.params();
        let weight = p.mass_kg * GRAVITY_M_S2;
        let com_b = pose.rotation * (p.first_moment_kg_m / p.mass_kg);
        let need_force = -weight;
        let need_torque = -com_b.cross(&weight);
        let mut jt = Matrix6::zeros();
        for i in 0..LEG_COUNT {
            let m = legs.arms_m[i].cross(&legs.units[i]);
            for c in 0..3 {
                jt[(c, i)] = legs.units[i][c];
                jt[(c + 3, i)] = m[c];
            }
        }
        let mut rhs = Vector6::new(
            need_force.x,
            need_force.y,
            need_force.z,
            need_torque.x,
            need_torque.y,
            need_torque.z,
        );
        if let Some(model) = &self.legs_model {
            // The legs' own weight at rest, carried through the joints: `Jᵀ f + Q_rest = −W`.
            rhs -= self.legs_at_rest(model, pose, legs, &Vector3::zeros()).1;
        }
        if let Some(s) = &self.suspension {
            // The sprung body resting on its units: their preloads, its weight at home.
            rhs -= s.rest_forces(pose).on_plate(&pose.position_m);
        }
        let f = jt
            .lu()
            .solve(&rhs)
            .filter(|f| f.iter().all(|v| v.is_finite()))
            .ok_or(SimError::InvalidConfig {
                field: "geometry",
                value: f64::NAN,
                reason: "the leg Jacobian is singular at the pose",
            })?;
        Ok(core::array::from_fn(|i| f[i]))
    }

    /// Leg rates at the end of the coming substep when the brake's damper acts with them
    /// (backward Euler for the damping, so any damping is stable).
    ///
    /// With `q̇ = [v_C; ω]` (in B), `M = diag(m𝟙, I_B)`, leg rates `l̇ = G q̇` (row i
    /// `[uᵢᵀ, ((R pᵢ + p − C) × uᵢ)ᵀ]`) and the brake force `F = F_s − c G q̇⁺`, rapier's step
    /// `q̇⁺ = q̇ + h M⁻¹(Gᵀ F + Q)` gives `(M + h c GᵀG) q̇⁺ = M q̇ + h (Gᵀ F_s + Q)`, with `Q`
    /// gravity and the gyroscopic torque. With legs of mass `M` and `Q` gain the legs' reflected
    /// inertia and their wrench without the actuators ([`crate::legs::reflect`] about `C`);
    /// with a suspension `Q` gains its units' wrench (explicit, at rapier's velocities).
    pub(super) fn implicit_brake_rates(&self, pose: &Pose, legs: &LegState) -> [f64; 6] {
        let spring = self.actuators.output(&legs.lengths_m, &[0.0; 6]);
        let c = self.actuators.config().brake_damping_n_s_m;
        let p = self.model.params();
        let com_b = pose.rotation * (p.first_moment_kg_m / p.mass_kg);
        let inertia_b =
            pose.rotation.matrix() * self.inertia_com * pose.rotation.matrix().transpose();
        let (v_com, omega) = self.world.raw_velocities();
        let mut g = Matrix6::zeros();
        for i in 0..LEG_COUNT {
            let m = (legs.arms_m[i] - com_b).cross(&legs.units[i]);
            for k in 0..3 {
                g[(i, k)] = legs.units[i][k];
                g[(i, k + 3)] = m[k];
            }
        }
        let mut mass = Matrix6::zeros();
        mass.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * p.mass_kg));
        mass.fixed_view_mut::<3, 3>(3, 3).copy_from(&inertia_b);
        let qd = Vector6::new(v_com.x, v_com.y, v_com.z, omega.x, omega.y, omega.z);
        let gyro = match self.config.gyroscopic {
            GyroscopicModel::Midpoint => -omega.cross(&(inertia_b * omega)),
            GyroscopicModel::Rapier => Vector3::zeros(),
        };
        let weight = p.mass_kg * GRAVITY_M_S2;
        let q = Vector6::new(weight.x, weight.y, weight.z, gyro.x, gyro.y, gyro.z);
        let h = self.substep_s;
        let (mass, mut q) = match &self.legs_model {
            Some(model) => {
                let (m_l, q_l) = self.legs_about_com(model, pose, legs, &com_b, &v_com, &omega);
                (mass + m_l, q + q_l)
            }
            None => (mass, q),
        };
        if self.suspension.is_some() {
            if let Some(start) = self.sprung_start(&self.plate_raw_motion(pose)) {
                q += start.forces.on_plate(&(pose.position_m + com_b));
            }
        }
        let a = mass + h * c * g.transpose() * g;
        let b = mass * qd + h * (g.transpose() * Vector6::from(spring) + q);
        match a.cholesky() {
            Some(chol) => {
                let rates = g * chol.solve(&b);
                core::array::from_fn(|i| rates[i])
            }
            None => legs.rates_m_s,
        }
    }
}
