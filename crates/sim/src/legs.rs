//! The legs' own dynamics: mass, inertia and joint friction between the base and the plate.
//!
//! Each leg is two slender bodies, symmetric about the leg axis `u` (unit, base joint `b` →
//! plate joint `s`, length `l`):
//!
//! - the **cylinder**, turning about the base (universal) joint: mass `m_c`, centre of mass at
//!   `d_c u` from `b`, moment of inertia `I_c` about a transverse axis through its centre of mass;
//! - the **rod**, the actuator's moving side, fixed to the plate (spherical) joint: mass `m_r`,
//!   centre of mass `d_r` from `s` towards the base, transverse moment `I_r`.
//!
//! Both turn with the leg's angular velocity `ω_L` and the rod slides by `l̇`. Their spin about
//! the leg axis is neglected (the universal joint lets the leg spin only as much as its cross
//! turns, a second-order effect for a slender leg; with no spin and axial symmetry the
//! gyroscopic terms vanish exactly). The legs have no state of their own: their motion follows
//! from the plate joint's motion (`ṡ`, `s̈`):
//!
//! ```text
//! ω_L = u × ṡ / l,   l̇ = u·ṡ,   α_L = (u × s̈ − 2 l̇ ω_L) / l,   l̈ = u·s̈ + l |ω_L|²
//! ```
//!
//! **The force the leg applies to the plate at the joint**, `F`, has
//!
//! - an axial part from the rod's Newton equation along `u`, with the actuator force `f_a`
//!   between cylinder and rod and the rod's centre of mass accelerating by
//!   `u·a_r = u·s̈ + d_r |ω_L|²` along the axis: `u·F = f_a + m_r u·g − m_r (u·s̈ + d_r |ω_L|²)`;
//! - a transverse part from the moment balance of both bodies about the base joint (a fixed
//!   point), with `H_b = K ω_L`, `K = I_c + m_c d_c² + I_r + m_r (l − d_r)²`:
//!   `l u × F = −K α_L − 2 m_r (l − d_r) l̇ ω_L + μ u × g + τ_U + τ_S`, `μ = m_c d_c + m_r (l − d_r)`,
//!   whose axial component the universal joint carries as torsion.
//!
//! Together, affine in the joint's acceleration ([`JointLaw`]):
//!
//! ```text
//! F = u f_a + c − Λ s̈,   Λ = m_r u uᵀ + (K / l²)(𝟙 − u uᵀ)
//! c = u (m_r u·g − m_r d_r |ω_L|²) + M₀ × u / l,   M₀ = 2 (K/l − m_r (l − d_r)) l̇ ω_L + μ u × g + τ_U + τ_S
//! ```
//!
//! `Λ` is the leg's inertia reflected to the plate joint: the legs' kinetic energy is
//! `½ ṡᵀ Λ ṡ = ½ K |ω_L|² + ½ m_r l̇²`.
//!
//! **Joint friction** (the smoothed Coulomb law `φ(w) = c_v w + T_c tanh(|w|/ω_s) ŵ`): the
//! universal joint applies `τ_U = −φ(ω_L)` to the leg, the spherical joint `τ_S = −φ(ω_L − ω_P)`
//! to the leg and `−τ_S` to the plate.
//!
//! **Load cells**: at the plate end a cell reads `u·F` (across it: `F` less its axial part); at
//! the base end it reads the force the base joint applies to the cylinder,
//! `F_b = F + m_c a_c + m_r a_r − (m_c + m_r) g`, i.e. the plate-end force plus the legs' weight
//! and inertia, with `a_c = d_c (α_L × u + ω_L × (ω_L × u))` and
//! `a_r = l̈ u + 2 l̇ ω_L × u + (l − d_r)(α_L × u + ω_L × (ω_L × u))`.

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};
use rig_description::config::{LegsConfig, LoadCellEnd};

/// Angular speed over which the joints' Coulomb torque changes sign (`tanh(|w| / ω_s)`), rad/s.
///
/// Below it the Coulomb friction acts as a viscous one of slope `T_c / ω_s` (1000 N·m·s/rad for
/// 1 N·m), which explicit integration with 1 ms steps keeps stable for any leg of more than
/// about 1 kg·m² about its base joint (`h T_c / (ω_s I) ≤ 2`; checked at construction against
/// the plate's and legs' lightest mode). Legs turn at about 0.01 to 0.1 rad/s while the plate is
/// excited, so the smoothing changes the dissipated power only near the reversals.
pub(crate) const JOINT_FRICTION_SMOOTHING_RAD_S: f64 = 1e-3;

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// The motion of one leg at an instant, in B.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LegMotion {
    /// Unit vector base joint → plate joint.
    pub unit: Vector3<f64>,
    /// Joint centre to joint centre, m.
    pub length_m: f64,
    /// Extension rate `l̇ = u·ṡ`, m/s.
    pub rate_m_s: f64,
    /// Angular velocity without spin `ω_L = u × ṡ / l`, rad/s.
    pub omega_rad_s: Vector3<f64>,
}

impl LegMotion {
    /// The leg between `base` and the plate joint at `joint` moving at `joint_velocity`.
    pub fn new(base: &Vector3<f64>, joint: &Vector3<f64>, joint_velocity: &Vector3<f64>) -> Self {
        let d = joint - base;
        let length_m = d.norm();
        let unit = if length_m > 0.0 {
            d / length_m
        } else {
            Vector3::z()
        };
        let omega_rad_s = if length_m > 0.0 {
            unit.cross(joint_velocity) / length_m
        } else {
            Vector3::zeros()
        };
        Self {
            unit,
            length_m,
            rate_m_s: unit.dot(joint_velocity),
            omega_rad_s,
        }
    }

    /// `α_L = (u × s̈ − 2 l̇ ω_L) / l` and `l̈ = u·s̈ + l |ω_L|²` for the joint acceleration `s̈`.
    pub fn accelerations(&self, joint_accel: &Vector3<f64>) -> (Vector3<f64>, f64) {
        let (u, l, w) = (&self.unit, self.length_m, &self.omega_rad_s);
        let alpha = (u.cross(joint_accel) - 2.0 * self.rate_m_s * w) / l;
        (alpha, u.dot(joint_accel) + l * w.norm_squared())
    }
}

/// The force one leg applies to the plate at its joint, affine in the joint's acceleration:
/// `F = u f_a + c − Λ s̈` (module docs), and the friction torque of the spherical joint.
#[derive(Clone, Copy, Debug)]
pub(crate) struct JointLaw {
    /// Leg axis `u`.
    pub unit: Vector3<f64>,
    /// Reflected inertia `Λ`, kg.
    pub inertia_kg: Matrix3<f64>,
    /// `c`: weight, velocity terms and friction, without the actuator, N.
    pub bias_n: Vector3<f64>,
    /// Torque the spherical joint applies to the leg, `τ_S` (the plate gets `−τ_S`), N·m.
    pub spherical_torque_nm: Vector3<f64>,
}

impl JointLaw {
    /// `F = u f_a + c − Λ s̈`.
    pub fn force(&self, actuator_n: f64, joint_accel: &Vector3<f64>) -> Vector3<f64> {
        self.unit * actuator_n + self.bias_n - self.inertia_kg * joint_accel
    }
}

/// The legs' mass properties and joint friction, the same for all six.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Legs {
    config: LegsConfig,
}

/// What a load cell is loaded with: the axial force it reads (compression positive) and the
/// force across it (in B), both as the force transmitted from the base towards the plate.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellForce {
    pub axial_n: f64,
    pub transverse_n: Vector3<f64>,
}

impl Legs {
    /// The legs of `config`; `None` when they are massless and frictionless (the plate then
    /// carries the actuator forces along the leg lines alone).
    pub fn new(config: LegsConfig) -> Option<Self> {
        let c = &config;
        let active = [
            c.cylinder_mass_kg,
            c.cylinder_inertia_kg_m2,
            c.rod_mass_kg,
            c.rod_inertia_kg_m2,
            c.joint_coulomb_torque_nm,
            c.joint_viscous_nm_s_per_rad,
        ]
        .iter()
        .any(|v| *v != 0.0);
        active.then_some(Self { config })
    }

    /// The legs of `config` even when massless and frictionless, to run the coupled path.
    #[cfg(test)]
    pub fn forced(config: LegsConfig) -> Self {
        Self { config }
    }

    /// `K(l) = I_c + m_c d_c² + I_r + m_r (l − d_r)²`, the legs' moment of inertia about the base
    /// joint, and `μ(l) = m_c d_c + m_r (l − d_r)`, their first moment along the axis.
    fn moments(&self, length_m: f64) -> (f64, f64) {
        let c = &self.config;
        let arm = length_m - c.rod_com_from_plate_m;
        let k = c.cylinder_inertia_kg_m2
            + c.cylinder_mass_kg * c.cylinder_com_from_base_m.powi(2)
            + c.rod_inertia_kg_m2
            + c.rod_mass_kg * arm * arm;
        let mu = c.cylinder_mass_kg * c.cylinder_com_from_base_m + c.rod_mass_kg * arm;
        (k, mu)
    }

    /// Joint friction torque `φ(w) = c_v w + T_c tanh(|w| / ω_s) ŵ` opposing a relative rotation
    /// `w` (the joint applies `−φ(w)`).
    pub fn friction_nm(&self, w: &Vector3<f64>) -> Vector3<f64> {
        let c = &self.config;
        let n = w.norm();
        let coulomb = if n > 0.0 {
            c.joint_coulomb_torque_nm * (n / JOINT_FRICTION_SMOOTHING_RAD_S).tanh() / n
        } else {
            0.0
        };
        (c.joint_viscous_nm_s_per_rad + coulomb) * w
    }

    /// Largest slope of [`Self::friction_nm`], N·m·s/rad: `c_v + T_c / ω_s`.
    pub fn friction_slope(&self) -> f64 {
        let c = &self.config;
        c.joint_viscous_nm_s_per_rad + c.joint_coulomb_torque_nm / JOINT_FRICTION_SMOOTHING_RAD_S
    }

    /// The joint law of a leg moving as `m`, with the plate turning at `plate_omega` (B) under
    /// gravity `g` (module docs).
    pub fn law(&self, m: &LegMotion, plate_omega: &Vector3<f64>, g: &Vector3<f64>) -> JointLaw {
        let c = &self.config;
        let (u, l, ld, w) = (&m.unit, m.length_m, m.rate_m_s, &m.omega_rad_s);
        let (k, mu) = self.moments(l);
        let tau_u = -self.friction_nm(w);
        let tau_s = -self.friction_nm(&(w - plate_omega));
        let arm = l - c.rod_com_from_plate_m;
        let m0 = 2.0 * (k / l - c.rod_mass_kg * arm) * ld * w + mu * u.cross(g) + tau_u + tau_s;
        let axial = c.rod_mass_kg * (u.dot(g) - c.rod_com_from_plate_m * w.norm_squared());
        let uu = u * u.transpose();
        JointLaw {
            unit: *u,
            inertia_kg: c.rod_mass_kg * uu + (k / (l * l)) * (Matrix3::identity() - uu),
            bias_n: u * axial + m0.cross(u) / l,
            spherical_torque_nm: tau_s,
        }
    }

    /// The load cell's forces for a leg moving as `m` with joint acceleration `joint_accel`,
    /// transmitting `joint_force` to the plate (module docs: plate end `F`, base end `F_b`).
    pub fn cell(
        &self,
        m: &LegMotion,
        joint_force: &Vector3<f64>,
        joint_accel: &Vector3<f64>,
        g: &Vector3<f64>,
    ) -> CellForce {
        let u = &m.unit;
        let f = match self.config.load_cell_end {
            LoadCellEnd::Plate => *joint_force,
            LoadCellEnd::Base => joint_force + self.inertia_and_weight(m, joint_accel, g),
        };
        let axial_n = u.dot(&f);
        CellForce {
            axial_n,
            transverse_n: f - u * axial_n,
        }
    }

    /// `m_c a_c + m_r a_r − (m_c + m_r) g`: what the base joint carries beyond the plate joint.
    fn inertia_and_weight(
        &self,
        m: &LegMotion,
        joint_accel: &Vector3<f64>,
        g: &Vector3<f64>,
    ) -> Vector3<f64> {
        let c = &self.config;
        let (u, l, ld, w) = (&m.unit, m.length_m, m.rate_m_s, &m.omega_rad_s);
        let (alpha, ldd) = m.accelerations(joint_accel);
        let turn = alpha.cross(u) + w.cross(&w.cross(u));
        let a_c = c.cylinder_com_from_base_m * turn;
        let a_r = ldd * u + 2.0 * ld * w.cross(u) + (l - c.rod_com_from_plate_m) * turn;
        c.cylinder_mass_kg * a_c + c.rod_mass_kg * a_r - (c.cylinder_mass_kg + c.rod_mass_kg) * g
    }

    /// The legs' kinetic energy `½ K |ω_L|² + ½ m_r l̇²`, J.
    #[cfg(test)]
    pub fn kinetic_energy(&self, m: &LegMotion) -> f64 {
        let (k, _) = self.moments(m.length_m);
        0.5 * k * m.omega_rad_s.norm_squared() + 0.5 * self.config.rod_mass_kg * m.rate_m_s.powi(2)
    }
}

/// The six legs' laws seen by the plate, about a reference point `O` with joint arms `arms`
/// (`s_i − O`) and the plate turning at `omega`, all in one frame: with `x = [a_O; ω̇]` (true
/// accelerations), `s̈_i = S_i x + q_i`, `S_i = [𝟙, −[r_i]×]`, `q_i = ω × (ω × r_i)`, the legs'
/// wrench on the plate about `O` is `W = Q − M_L x` with
///
/// ```text
/// M_L = Σ S_iᵀ Λ_i S_i,   Q = Σ S_iᵀ (u_i f_i + c_i − Λ_i q_i) − [0; Σ τ_S,i]
/// ```
///
/// (`S_iᵀ F = [F; r_i × F]`). `actuator_n = None` leaves the actuator forces out of `Q`.
pub(crate) fn reflect(
    laws: &[JointLaw; 6],
    arms: &[Vector3<f64>; 6],
    omega: &Vector3<f64>,
    actuator_n: Option<&[f64; 6]>,
) -> (Matrix6<f64>, Vector6<f64>) {
    let mut m = Matrix6::zeros();
    let mut q = Vector6::zeros();
    for (i, (law, r)) in laws.iter().zip(arms).enumerate() {
        let rx = skew(r);
        let lam = &law.inertia_kg;
        // S = [𝟙, −[r]×]; Sᵀ = [𝟙; [r]×].
        let mut block = |r0: usize, c0: usize, b: Matrix3<f64>| {
            let mut v = m.fixed_view_mut::<3, 3>(r0, c0);
            v += b;
        };
        block(0, 0, *lam);
        block(0, 3, -lam * rx);
        block(3, 0, rx * lam);
        block(3, 3, -rx * lam * rx);
        let f_a = actuator_n.map_or(0.0, |f| f[i]);
        let force = law.unit * f_a + law.bias_n - lam * omega.cross(&omega.cross(r));
        let torque = r.cross(&force) - law.spherical_torque_nm;
        q += Vector6::new(force.x, force.y, force.z, torque.x, torque.y, torque.z);
    }
    (m, q)
}

/// `diag(Rᵀ, Rᵀ) M diag(R, R)` and `diag(Rᵀ, Rᵀ) v`: a spatial matrix and vector from B into P
/// axes (same reference point).
pub(crate) fn to_plate_axes(
    rt: &Matrix3<f64>,
    m: &Matrix6<f64>,
    v: &Vector6<f64>,
) -> (Matrix6<f64>, Vector6<f64>) {
    let mut t = Matrix6::zeros();
    t.fixed_view_mut::<3, 3>(0, 0).copy_from(rt);
    t.fixed_view_mut::<3, 3>(3, 3).copy_from(rt);
    (t * m * t.transpose(), t * v)
}

#[cfg(test)]
pub(crate) mod tests;
