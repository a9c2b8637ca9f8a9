//! The plate coupled to legs with mass, inertia and joint friction ([`crate::legs`]).
//!
//! Each leg's joint force is affine in its plate joint's acceleration, `F_i = u_i f_i + c_i −
//! Λ_i s̈_i`, and `s̈_i` is linear in the plate's `x = [a_O; ω̇]`, so the plate's Newton–Euler
//! equations with the legs attached are one 6×6 linear system: with `M` the plate's spatial
//! inertia about the P origin and `b(ω)` its velocity terms (see `dynamics`),
//!
//! ```text
//! (M + M_L) [f; ω̇] = Q − M_L [g; 0] − b(ω),   f = a_O − g
//! ```
//!
//! (`M_L`, `Q` from [`reflect`], in P axes). Rapier then gets the joint forces `F_i` evaluated
//! at that solution, and the friction torque `−Σ τ_S,i`: applied to the plate alone they give
//! it exactly the coupled acceleration, so the accelerometer (`Evaluation`) reads the plate's
//! true acceleration. The velocities the legs' terms use are those of the instant, as for the
//! gyroscopic torque: a first solve with rapier's stored (half-step-old) velocities gives the
//! acceleration that moves them to the instant, `v(t_n) = v_{n−½} + (h/2) a`, and a second
//! solve uses those. The suspension's units ([`crate::suspension`]) add their wrench on the plate
//! to `Q`, from the same two passes (`simulator/sprung.rs`).

use control::io::LEG_COUNT;
use kinematics::Pose;
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use super::{sprung, Evaluation, LegState, Simulator};
use crate::cell_loads::{transverse_basis, CellLoads};
use crate::dynamics::Acceleration;
use crate::legs::{reflect, to_plate_axes, JointLaw, LegMotion, Legs};
use crate::world::GRAVITY_M_S2;

fn spatial(top: &Vector3<f64>, bottom: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(top.x, top.y, top.z, bottom.x, bottom.y, bottom.z)
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The legs' motions and laws with the P origin moving at `v_origin` and the plate turning at
/// `omega` (both in B).
fn laws_at(
    model: &Legs,
    base: &[Vector3<f64>; 6],
    pose: &Pose,
    legs: &LegState,
    v_origin: &Vector3<f64>,
    omega: &Vector3<f64>,
) -> ([LegMotion; 6], [JointLaw; 6]) {
    let motions: [LegMotion; 6] = core::array::from_fn(|i| {
        let arm = &legs.arms_m[i];
        LegMotion::new(
            &base[i],
            &(pose.position_m + arm),
            &(v_origin + omega.cross(arm)),
        )
    });
    let laws = core::array::from_fn(|i| model.law(&motions[i], omega, &GRAVITY_M_S2));
    (motions, laws)
}

impl Simulator {
    /// The plate's acceleration with the legs' laws `laws` and plate rate `omega` (B): the
    /// coupled system of the module docs, with the suspension's wrench `units` (force and
    /// torque about the P origin, in P) added to `Q`.
    #[allow(clippy::too_many_arguments)]
    fn coupled_acceleration(
        &self,
        pose: &Pose,
        legs: &LegState,
        laws: &[JointLaw; 6],
        omega: &Vector3<f64>,
        forces: &[f64; 6],
        units: Option<(Vector3<f64>, Vector3<f64>)>,
    ) -> Acceleration {
        let (m_l, q) = reflect(laws, &legs.arms_m, omega, Some(forces));
        let w0 = q - m_l * spatial(&GRAVITY_M_S2, &Vector3::zeros());
        let rt = pose.rotation.inverse();
        let (m_p, mut w_p) = to_plate_axes(rt.matrix(), &m_l, &w0);
        if let Some((f, t)) = units {
            w_p += spatial(&f, &t);
        }
        self.model.acceleration_loaded(&m_p, &w_p, &(rt * omega))
    }

    /// [`Simulator::evaluate`] with the legs' dynamics (module docs).
    pub(super) fn evaluate_coupled(
        &self,
        model: &Legs,
        pose: &Pose,
        legs: &LegState,
        forces: &[f64; 6],
    ) -> Evaluation {
        let base = self.geometry.base_joints_m();
        let r = pose.rotation;
        let p = self.model.params();
        let (v_com, omega_raw) = self.world.raw_velocities();
        let v_raw = v_com - omega_raw.cross(&(r * (p.first_moment_kg_m / p.mass_kg)));
        let (_, laws) = laws_at(model, base, pose, legs, &v_raw, &omega_raw);
        let start = self.suspension.as_ref().and_then(|_| {
            self.sprung_start(&sprung::Motion {
                pose: *pose,
                v_origin: v_raw,
                omega: omega_raw,
            })
        });
        let units = start
            .as_ref()
            .map(|s| sprung::plate_wrench_p(&s.forces, pose));
        let first = self.coupled_acceleration(pose, legs, &laws, &omega_raw, forces, units);
        let half = 0.5 * self.substep_s;
        let omega = omega_raw + half * (r * first.angular_rad_s2);
        let v_origin = v_raw + half * (r * first.specific_force_m_s2 + GRAVITY_M_S2);
        let (motions, laws) = laws_at(model, base, pose, legs, &v_origin, &omega);
        let sprung_loads = start.as_ref().map(|s| {
            self.sprung_at(
                s,
                &sprung::Motion {
                    pose: *pose,
                    v_origin,
                    omega,
                },
            )
        });
        let units = sprung_loads
            .as_ref()
            .map(|s| sprung::plate_wrench_p(&s.forces, pose));
        let acceleration = self.coupled_acceleration(pose, legs, &laws, &omega, forces, units);
        let a_origin = r * acceleration.specific_force_m_s2 + GRAVITY_M_S2;
        let omega_dot = r * acceleration.angular_rad_s2;
        let mut e = Evaluation {
            forces_n: *forces,
            plate_axial_n: [0.0; 6],
            cell_n: [0.0; 6],
            cell_loads: CellLoads::default(),
            joint_forces_b: [Vector3::zeros(); 6],
            joint_torque_b: Vector3::zeros(),
            omega_p: r.inverse() * omega,
            acceleration,
            sprung: sprung_loads,
        };
        for i in 0..LEG_COUNT {
            let arm = &legs.arms_m[i];
            let s_acc = a_origin + omega_dot.cross(arm) + omega.cross(&omega.cross(arm));
            let force = laws[i].force(forces[i], &s_acc);
            let cell = model.cell(&motions[i], &force, &s_acc, &GRAVITY_M_S2);
            let (e1, e2) = transverse_basis(&motions[i].unit);
            e.plate_axial_n[i] = motions[i].unit.dot(&force);
            e.cell_n[i] = cell.axial_n;
            e.cell_loads.transverse_n[i] = [cell.transverse_n.dot(&e1), cell.transverse_n.dot(&e2)];
            e.joint_forces_b[i] = force;
            e.joint_torque_b -= laws[i].spherical_torque_nm;
        }
        e
    }

    /// The legs' reflected inertia and wrench at `pose` with the P origin moving at
    /// `v_origin` (B) and the plate at rest otherwise, without the actuators, about the P
    /// origin in B ([`reflect`]).
    pub(super) fn legs_at_rest(
        &self,
        model: &Legs,
        pose: &Pose,
        legs: &LegState,
        v_origin: &Vector3<f64>,
    ) -> (Matrix6<f64>, Vector6<f64>) {
        let zero = Vector3::zeros();
        let base = self.geometry.base_joints_m();
        let (_, laws) = laws_at(model, base, pose, legs, v_origin, &zero);
        reflect(&laws, &legs.arms_m, &zero, None)
    }

    /// The legs' reflected inertia and wrench without the actuators about the plate's centre
    /// of mass `com_b` (relative to the P origin, B), with rapier's velocities: the terms
    /// [`Simulator::implicit_brake_rates`] adds to the plate's.
    pub(super) fn legs_about_com(
        &self,
        model: &Legs,
        pose: &Pose,
        legs: &LegState,
        com_b: &Vector3<f64>,
        v_com: &Vector3<f64>,
        omega: &Vector3<f64>,
    ) -> (Matrix6<f64>, Vector6<f64>) {
        let v_origin = v_com - omega.cross(com_b);
        let base = self.geometry.base_joints_m();
        let (_, laws) = laws_at(model, base, pose, legs, &v_origin, omega);
        let arms = legs.arms_m.map(|a| a - com_b);
        reflect(&laws, &arms, omega, None)
    }

    /// At the home pose at rest, in P about the P origin: the legs' reflected inertia `M_L`
    /// and the joints' friction slope as a damping matrix `D = c Σ (A_Uᵀ A_U + A_Sᵀ A_S)`, with
    /// `ω_L = A_U q̇ = (1/l) [u]× [𝟙, −[p]×] q̇` the leg's rate (universal joint) and
    /// `A_S = A_U − [0, 𝟙]` the spherical joint's relative rate, `c` the slope of the smoothed
    /// friction law ([`Legs::friction_slope`]).
    pub(super) fn legs_home_terms(&self, model: &Legs) -> (Matrix6<f64>, Matrix6<f64>) {
        let pose = self.geometry.home_pose();
        let legs = self.legs(&pose);
        let rt = pose.rotation.inverse();
        let (m_l, q) = self.legs_at_rest(model, &pose, &legs, &Vector3::zeros());
        let (m_p, _) = to_plate_axes(rt.matrix(), &m_l, &q);
        let mut damping = Matrix6::zeros();
        for i in 0..LEG_COUNT {
            let u = rt * legs.units[i];
            let p = self.geometry.plate_joints_m()[i];
            let mut s = nalgebra::Matrix3x6::zeros();
            s.fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&Matrix3::identity());
            s.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(&p)));
            let a_u = skew(&u) * s / legs.lengths_m[i];
            let mut a_s = a_u;
            let mut w = a_s.fixed_view_mut::<3, 3>(0, 3);
            w -= Matrix3::identity();
            damping += a_u.transpose() * a_u + a_s.transpose() * a_s;
        }
        (m_p, model.friction_slope() * damping)
    }
}
