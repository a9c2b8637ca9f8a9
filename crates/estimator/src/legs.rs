//! What the load cells do not see: the wrench the legs' own mass and the joints' friction put on
//! the plate beyond the six axial readings, from the rig description's legs and the plate's
//! motion. Added to the measured wrench it compensates the legs ([`crate::EstimatorConfig::legs`]).
//!
//! Each leg i runs from its base joint bᵢ (B) to its plate joint qᵢ = p + R pᵢ along the unit
//! vector u, length L. It is two slender bodies turning together with the leg's angular
//! velocity ω_l = u × u̇ (ω̇_l = u × ü; no spin about the axis): a cylinder of mass m₁,
//! transverse inertia I₁, centre of mass at bᵢ + c₁u (acceleration c₁ü), and a rod of mass m₂,
//! I₂, centre of mass at qᵢ − c₂u (acceleration q̈ᵢ − c₂ü). With F the force the leg applies
//! to the plate at qᵢ, the leg's moment balance about the fixed base joint gives
//!
//! ```text
//! L u × F = M = Σₖ (rₖ − bᵢ) × mₖ (g − aₖ) − (I₁ + I₂) ω̇_l + τ_b + τ_r
//! ```
//! so the force across the leg is F⊥ = (M⊥ / L) × u (M⊥: M without its axial part, which the
//! universal joint carries). τ_b = −T(ω_l) is the base joint's friction on the cylinder and
//! τ_r = −T(ω_l − ω_p) the plate joint's on the rod (ω_p the plate's rate in B), with
//! T(w) = τ_c w/√(|w|² + ε²) + c_v w (Coulomb smoothed below ε = 1 mrad/s, and viscous). The
//! plate joint also passes +T(ω_l − ω_p) straight to the plate.
//!
//! The leg's motion follows from the plate's (all in B, r = R pᵢ):
//!
//! ```text
//! q̇ = v + ω_p × r            q̈ = a + ω̇_p × r + ω_p × (ω_p × r)
//! L̇ = u·q̇                    u̇ = (q̇ − L̇ u) / L
//! ü = (q̈ − u (u·q̈) − 2 L̇ u̇) / L − |u̇|² u      (from q − b = L u twice differentiated)
//! ```
//!
//! The estimator takes each cell's reading as the whole leg force, along u:
//! - cell at the **plate** end: it reads F·u; unseen are F⊥ and the plate joint's torque;
//! - cell at the **base** end: it reads the base joint's axial force F_b·u with
//!   F = F_b + Σₖ mₖ (g − aₖ) (the leg's Newton equation), so the axial Σₖ mₖ (g − aₖ)·u is
//!   unseen too.
//!
//! The transverse force through each cell is F⊥ at the plate end and (F − Σₖ mₖ (g − aₖ))⊥ at
//! the base end, along the cell's axes e₁ = u × z / |u × z| and e₂ = u × e₁ ([`transverse_axes`]):
//! what a cell's transverse sensitivity turns into a reading.

use kinematics::{Geometry, Pose, Wrench, LEG_COUNT};
use nalgebra::Vector3;

/// Smoothing rate of the Coulomb friction's sign, rad/s.
pub const COULOMB_EPS_RAD_S: f64 = 1e-3;

/// Where each leg's load cell sits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CellEnd {
    /// Between the rod and the plate joint.
    #[default]
    Plate,
    /// Between the base joint and the cylinder.
    Base,
}

/// The legs' mass properties and the joints' friction, all six legs alike (the rig
/// description's `[legs]`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LegModel {
    /// Where the load cell sits.
    pub cell_end: CellEnd,
    /// Cylinder (turns about the base joint) mass m₁, kg.
    pub cylinder_mass_kg: f64,
    /// Its centre of mass from the base joint, c₁, m.
    pub cylinder_com_from_base_m: f64,
    /// Its transverse moment of inertia about its centre of mass, I₁, kg·m².
    pub cylinder_inertia_kg_m2: f64,
    /// Rod (slides out to the plate joint) mass m₂, kg.
    pub rod_mass_kg: f64,
    /// Its centre of mass from the plate joint, c₂, m.
    pub rod_com_from_plate_m: f64,
    /// Its transverse moment of inertia about its centre of mass, I₂, kg·m².
    pub rod_inertia_kg_m2: f64,
    /// Coulomb friction torque τ_c of every joint, N·m.
    pub joint_coulomb_torque_nm: f64,
    /// Viscous friction c_v of every joint, N·m·s/rad.
    pub joint_viscous_nm_s_per_rad: f64,
}

impl LegModel {
    /// True when every figure is finite and none is negative.
    pub fn is_valid(&self) -> bool {
        [
            self.cylinder_mass_kg,
            self.cylinder_com_from_base_m,
            self.cylinder_inertia_kg_m2,
            self.rod_mass_kg,
            self.rod_com_from_plate_m,
            self.rod_inertia_kg_m2,
            self.joint_coulomb_torque_nm,
            self.joint_viscous_nm_s_per_rad,
        ]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0)
    }

    /// The same legs with only their mass properties (no friction).
    pub fn without_friction(&self) -> Self {
        Self {
            joint_coulomb_torque_nm: 0.0,
            joint_viscous_nm_s_per_rad: 0.0,
            ..*self
        }
    }

    /// The joints' friction torque T(w) for a relative rate w.
    pub fn friction_nm(&self, w: &Vector3<f64>) -> Vector3<f64> {
        let n = libm::sqrt(w.norm_squared() + COULOMB_EPS_RAD_S * COULOMB_EPS_RAD_S);
        w * (self.joint_coulomb_torque_nm / n) + w * self.joint_viscous_nm_s_per_rad
    }
}

/// The plate's motion at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlateMotion {
    /// Pose of P in B.
    pub pose: Pose,
    /// Velocity of the P origin, in B, m/s.
    pub velocity_m_s: Vector3<f64>,
    /// Acceleration of the P origin, in B, m/s² (not the specific force: gravity excluded).
    pub acceleration_m_s2: Vector3<f64>,
    /// Angular velocity, in P, rad/s (the gyro's axes).
    pub angular_velocity_rad_s: Vector3<f64>,
    /// Angular acceleration, in P, rad/s².
    pub angular_acceleration_rad_s2: Vector3<f64>,
}

impl PlateMotion {
    /// True when every entry is finite.
    pub fn is_finite(&self) -> bool {
        self.pose.is_finite()
            && [
                self.velocity_m_s,
                self.acceleration_m_s2,
                self.angular_velocity_rad_s,
                self.angular_acceleration_rad_s2,
            ]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()))
    }
}

/// What the cells miss at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unseen {
    /// The wrench (P axes, about the P origin) the legs' mass and inertia add on the plate
    /// beyond the cells' readings.
    pub dynamics: Wrench,
    /// The same from the joints' friction.
    pub friction: Wrench,
    /// Force across each cell along its axes e₁, e₂ ([`transverse_axes`]), N: mass and friction.
    pub transverse_n: [[f64; 2]; LEG_COUNT],
}

impl Unseen {
    /// Nothing missed.
    pub fn zero() -> Self {
        Self {
            dynamics: zero_wrench(),
            friction: zero_wrench(),
            transverse_n: [[0.0; 2]; LEG_COUNT],
        }
    }

    /// Both parts together: what to add to the measured wrench.
    pub fn total(&self) -> Wrench {
        Wrench {
            force_n: self.dynamics.force_n + self.friction.force_n,
            torque_nm: self.dynamics.torque_nm + self.friction.torque_nm,
        }
    }
}

/// A cell's transverse axes for leg direction `u` (B): e₁ = u × z / |u × z| (u × x for a
/// vertical leg) and e₂ = u × e₁.
pub fn transverse_axes(u: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let e1 = u.cross(&Vector3::z());
    let e1 = if e1.norm() > 1e-6 {
        e1 / e1.norm()
    } else {
        let x = u.cross(&Vector3::x());
        let n = x.norm();
        if n > 0.0 {
            x / n
        } else {
            Vector3::y()
        }
    };
    [e1, u.cross(&e1)]
}

fn zero_wrench() -> Wrench {
    Wrench {
        force_n: Vector3::zeros(),
        torque_nm: Vector3::zeros(),
    }
}

/// The cells' unseen wrench for `legs` on the rig `geometry` at the plate's `motion`, gravity
/// `gravity_b_m_s2` (in B): the sum of [`unseen_of_leg`] over the six legs.
pub fn unseen(
    geometry: &Geometry,
    legs: &LegModel,
    motion: &PlateMotion,
    gravity_b_m_s2: &Vector3<f64>,
) -> Unseen {
    let mut out = Unseen::zero();
    let frame = MotionFrame::of(motion);
    for (leg, transverse) in out.transverse_n.iter_mut().enumerate() {
        let one = leg_terms(geometry, leg, legs, motion, &frame, gravity_b_m_s2, true);
        out.dynamics.force_n += one.dynamics.force_n;
        out.dynamics.torque_nm += one.dynamics.torque_nm;
        out.friction.force_n += one.friction.force_n;
        out.friction.torque_nm += one.friction.torque_nm;
        *transverse = one.transverse_n;
    }
    out
}

/// [`unseen`]'s [`Unseen::total`] alone, bit for bit: the same sums without the transverse
/// forces (two axes a leg, [`transverse_axes`]), which compensating a wrench does not need.
pub fn unseen_total(
    geometry: &Geometry,
    legs: &LegModel,
    motion: &PlateMotion,
    gravity_b_m_s2: &Vector3<f64>,
) -> Wrench {
    let (mut dynamics, mut friction) = (zero_wrench(), zero_wrench());
    let frame = MotionFrame::of(motion);
    for leg in 0..LEG_COUNT {
        let one = leg_terms(geometry, leg, legs, motion, &frame, gravity_b_m_s2, false);
        dynamics.force_n += one.dynamics.force_n;
        dynamics.torque_nm += one.dynamics.torque_nm;
        friction.force_n += one.friction.force_n;
        friction.torque_nm += one.friction.torque_nm;
    }
    Unseen {
        dynamics,
        friction,
        transverse_n: [[0.0; 2]; LEG_COUNT],
    }
    .total()
}

/// What every leg's terms share at one instant: the plate's rotation R (P → B), its inverse,
/// and the angular velocity and acceleration in B, ω_B = R ω_P and ω̇_B = R ω̇_P.
struct MotionFrame {
    to_p: nalgebra::Rotation3<f64>,
    w_b: Vector3<f64>,
    wd_b: Vector3<f64>,
}

impl MotionFrame {
    fn of(motion: &PlateMotion) -> Self {
        let rot = motion.pose.rotation;
        Self {
            to_p: rot.inverse(),
            w_b: rot * motion.angular_velocity_rad_s,
            wd_b: rot * motion.angular_acceleration_rad_s2,
        }
    }
}

/// [`unseen`] of leg `leg` alone (its transverse force in `transverse_n[leg]`, the others
/// zero). A leg of zero length, or an index beyond the sixth, contributes nothing.
pub fn unseen_of_leg(
    geometry: &Geometry,
    leg: usize,
    legs: &LegModel,
    motion: &PlateMotion,
    gravity_b_m_s2: &Vector3<f64>,
) -> Unseen {
    let frame = MotionFrame::of(motion);
    let one = leg_terms(geometry, leg, legs, motion, &frame, gravity_b_m_s2, true);
    let mut out = Unseen::zero();
    out.dynamics = one.dynamics;
    out.friction = one.friction;
    if let Some(transverse) = out.transverse_n.get_mut(leg) {
        *transverse = one.transverse_n;
    }
    out
}

/// One leg's share of [`Unseen`]: its two wrenches and the transverse force through its cell.
struct LegTerms {
    dynamics: Wrench,
    friction: Wrench,
    transverse_n: [f64; 2],
}

/// [`unseen_of_leg`]'s terms at the plate's `motion` (its `frame`); all zero for a leg of zero
/// length or an index beyond the sixth; the transverse force only when `transverse`.
fn leg_terms(
    geometry: &Geometry,
    leg: usize,
    legs: &LegModel,
    motion: &PlateMotion,
    frame: &MotionFrame,
    gravity_b_m_s2: &Vector3<f64>,
    transverse: bool,
) -> LegTerms {
    let mut out = LegTerms {
        dynamics: zero_wrench(),
        friction: zero_wrench(),
        transverse_n: [0.0; 2],
    };
    let (Some(pj), Some(bj)) = (
        geometry.plate_joints_m().get(leg),
        geometry.base_joints_m().get(leg),
    ) else {
        return out;
    };
    let rot = motion.pose.rotation;
    let to_p = frame.to_p;
    let w_p = frame.w_b;
    let wd_p = frame.wd_b;
    let g = *gravity_b_m_s2;
    let (m1, c1, m2, c2) = (
        legs.cylinder_mass_kg,
        legs.cylinder_com_from_base_m,
        legs.rod_mass_kg,
        legs.rod_com_from_plate_m,
    );
    let r = rot * pj;
    let d = motion.pose.position_m + r - bj;
    let len = d.norm();
    if !(len > 0.0 && len.is_finite()) {
        return out;
    }
    let u = d / len;
    let qd = motion.velocity_m_s + w_p.cross(&r);
    let qdd = motion.acceleration_m_s2 + wd_p.cross(&r) + w_p.cross(&w_p.cross(&r));
    let len_d = u.dot(&qd);
    let ud = (qd - u * len_d) / len;
    let udd = (qdd - u * u.dot(&qdd) - ud * (2.0 * len_d)) / len - u * ud.norm_squared();
    let w_leg = u.cross(&ud);
    let wd_leg = u.cross(&udd);
    let a1 = udd * c1;
    let a2 = qdd - udd * c2;
    let inertial = (g - a1) * m1 + (g - a2) * m2;
    let m_dyn = (u * c1).cross(&((g - a1) * m1)) + (u * (len - c2)).cross(&((g - a2) * m2))
        - wd_leg * (legs.cylinder_inertia_kg_m2 + legs.rod_inertia_kg_m2);
    let t_plate = legs.friction_nm(&(w_leg - w_p));
    let m_fric = -legs.friction_nm(&w_leg) - t_plate;
    let across = |m: Vector3<f64>| (m - u * m.dot(&u)).cross(&u) / len;
    let (f_dyn, f_fric) = (across(m_dyn), across(m_fric));
    let (unseen_dyn, through_cell) = match legs.cell_end {
        CellEnd::Plate => (f_dyn, f_dyn + f_fric),
        CellEnd::Base => {
            let axial = u * inertial.dot(&u);
            (f_dyn + axial, f_dyn + f_fric - (inertial - axial))
        }
    };
    let wrench = |f_b: Vector3<f64>, t_b: Vector3<f64>| {
        let f = to_p * f_b;
        Wrench {
            force_n: f,
            torque_nm: pj.cross(&f) + to_p * t_b,
        }
    };
    out.dynamics = wrench(unseen_dyn, Vector3::zeros());
    out.friction = wrench(f_fric, t_plate);
    if transverse {
        let [e1, e2] = transverse_axes(&u);
        out.transverse_n = [through_cell.dot(&e1), through_cell.dot(&e2)];
    }
    out
}

#[cfg(test)]
#[path = "legs_tests.rs"]
mod tests;
