//! The legs' own model, from the rig description's `[legs]` table alone: what the estimator
//! does not compensate of the legs' mass and of the joints' friction.
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
//! T(w) = τ_c w/√(|w|² + ε²) + c_v w (Coulomb smoothed below ε = 1 mrad/s, and viscous), the
//! signs from the recorded motion. The plate joint also passes +T(ω_l − ω_p) straight to the
//! plate.
//!
//! The estimator takes the load cell's reading as the whole leg force, along u:
//! - cell at the **plate** end: it reads F·u; unseen are F⊥ and the plate joint's torque;
//! - cell at the **base** end: it reads the base joint's axial force F_b·u with
//!   F = F_b + Σₖ mₖ (g − aₖ) (the leg's Newton equation), so the axial Σₖ mₖ (g − aₖ)·u is
//!   unseen too.
//!
//! The transverse force through the cell (for its crosstalk) is F⊥ at the plate end and
//! (F − Σₖ mₖ (g − aₖ))⊥ at the base end, in the cell's directions e₁ = u × z / |u × z| and
//! e₂ = u × e₁.

use kinematics::Geometry;
use nalgebra::{Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

use super::fit::Data;
use super::util::{d1, d2};
use crate::config::{LegsConfig, LoadCellEnd};

/// Smoothing rate of the Coulomb friction's sign, rad/s.
const COULOMB_EPS_RAD_S: f64 = 1e-3;

/// The legs' unmodelled effects at each entry of a record (zero outside the interior).
#[derive(Clone, Debug, Default)]
pub struct LegEffects {
    /// Wrench on the plate (P axes, about the P origin) the estimator misses from the legs'
    /// mass and inertia.
    pub dynamics: Vec<Vector6<f64>>,
    /// The same from the joints' friction.
    pub friction: Vec<Vector6<f64>>,
    /// Transverse force through each cell along its e₁ and e₂, N (mass and friction).
    pub transverse: Vec<[[f64; 2]; 6]>,
}

fn friction(c: &LegsConfig, w: &Vector3<f64>) -> Vector3<f64> {
    let n = (w.norm_squared() + COULOMB_EPS_RAD_S * COULOMB_EPS_RAD_S).sqrt();
    w * (c.joint_coulomb_torque_nm / n) + w * c.joint_viscous_nm_s_per_rad
}

/// The cell's transverse directions for leg direction `u` (B).
pub fn transverse_axes(u: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let z = Vector3::z();
    let e1 = u.cross(&z);
    let e1 = if e1.norm() > 1e-6 {
        e1.normalize()
    } else {
        u.cross(&Vector3::x()).normalize()
    };
    [e1, u.cross(&e1)]
}

/// The legs' effects on `data` at its interior entries `idx` (step `h`), from `legs`.
pub fn effects(data: &Data, idx: &[usize], h: f64, legs: &LegsConfig) -> LegEffects {
    let n = data.entries.len();
    let g: &Geometry = &data.model.geometry;
    let mut out = LegEffects {
        dynamics: vec![Vector6::zeros(); n],
        friction: vec![Vector6::zeros(); n],
        transverse: vec![[[0.0; 2]; 6]; n],
    };
    let gravity = Vector3::from(GRAVITY_B_M_S2);
    for leg in 0..6 {
        let b = g.base_joints_m()[leg];
        let pj = g.plate_joints_m()[leg];
        let q: Vec<Vector3<f64>> = data
            .poses
            .iter()
            .map(|p| p.position_m + p.rotation * pj)
            .collect();
        let u: Vec<Vector3<f64>> = q.iter().map(|q| (q - b).normalize()).collect();
        for &i in idx {
            let pose = &data.poses[i];
            let (ui, qi) = (u[i], q[i]);
            let len = (qi - b).norm();
            let (ud, udd, qdd) = (d1(&u, i, h), d2(&u, i, h), d2(&q, i, h));
            let w_leg = ui.cross(&ud);
            let wd_leg = ui.cross(&udd);
            let a1 = udd * legs.cylinder_com_from_base_m;
            let a2 = qdd - udd * legs.rod_com_from_plate_m;
            let r1 = ui * legs.cylinder_com_from_base_m;
            let r2 = ui * (len - legs.rod_com_from_plate_m);
            let inertial =
                (gravity - a1) * legs.cylinder_mass_kg + (gravity - a2) * legs.rod_mass_kg;
            let m_dyn = r1.cross(&((gravity - a1) * legs.cylinder_mass_kg))
                + r2.cross(&((gravity - a2) * legs.rod_mass_kg))
                - wd_leg * (legs.cylinder_inertia_kg_m2 + legs.rod_inertia_kg_m2);
            let w_plate = pose.rotation * data.entries[i].gyro_rad_s;
            let t_plate = friction(legs, &(w_leg - w_plate));
            let m_fric = -friction(legs, &w_leg) - t_plate;
            let perp = |m: Vector3<f64>| {
                let m = m - ui * m.dot(&ui);
                (m / len).cross(&ui)
            };
            let (f_dyn, f_fric) = (perp(m_dyn), perp(m_fric));
            let (missing_dyn, through_cell) = match legs.load_cell_end {
                LoadCellEnd::Plate => (f_dyn, f_dyn + f_fric),
                LoadCellEnd::Base => {
                    let axial = ui * inertial.dot(&ui);
                    let through = f_dyn + f_fric - (inertial - axial);
                    (f_dyn + axial, through)
                }
            };
            let to_p = pose.rotation.inverse();
            let wrench = |f_b: Vector3<f64>, t_b: Vector3<f64>| {
                let f = to_p * f_b;
                let t = pj.cross(&f) + to_p * t_b;
                Vector6::new(f.x, f.y, f.z, t.x, t.y, t.z)
            };
            out.dynamics[i] += wrench(missing_dyn, Vector3::zeros());
            out.friction[i] += wrench(f_fric, t_plate);
            let e = transverse_axes(&ui);
            out.transverse[i][leg] = [through_cell.dot(&e[0]), through_cell.dot(&e[1])];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::fit::{Mode, Model};
    use crate::budget::testkit;

    /// The default rig's legs (configs/default.toml) without joint friction.
    fn legs() -> LegsConfig {
        LegsConfig {
            joint_coulomb_torque_nm: 0.0,
            joint_viscous_nm_s_per_rad: 0.0,
            ..crate::load::load(None)
                .expect("the embedded default loads")
                .config
                .legs
        }
    }

    fn still_data() -> Data {
        let g = testkit::geometry();
        let e = testkit::still_entries(&g, 30);
        Data::new(
            e,
            Model {
                geometry: g,
                lever_m: Vector3::zeros(),
                equation_sigma: Vector6::from_element(1.0),
                mode: Mode::Full,
            },
        )
    }

    /// At rest, a point check by statics: each leg's weight splits between its two joints by
    /// the lever rule along the leg's horizontal projection; the plate joint's share of the
    /// rod's and cylinder's weight across the leg is what the plate-end cell misses. Summed
    /// over the legs, the missing vertical force is Σ (m₁c₁ + m₂(L − c₂))/L · g · sin²φ with
    /// φ the leg's angle to the vertical (the vertical part of the transverse force).
    #[test]
    fn at_rest_the_plate_joint_carries_the_lever_rules_share() {
        let data = still_data();
        let idx: Vec<usize> = (2..data.entries.len() - 2).collect();
        let l = legs();
        let fx = effects(&data, &idx, 0.01, &l);
        let g = &data.model.geometry;
        let pose = data.poses[10];
        let mut expected = 0.0;
        for leg in 0..6 {
            let q = pose.position_m + pose.rotation * g.plate_joints_m()[leg];
            let d = q - g.base_joints_m()[leg];
            let len = d.norm();
            let cos = d.z / len;
            let share = (l.cylinder_mass_kg * l.cylinder_com_from_base_m
                + l.rod_mass_kg * (len - l.rod_com_from_plate_m))
                / len;
            // Vertical part of the transverse share: weight·(1 − cos²) downward on the plate.
            expected -= share * 9.80665 * (1.0 - cos * cos);
        }
        let fz_b = (pose.rotation
            * Vector3::new(fx.dynamics[10][0], fx.dynamics[10][1], fx.dynamics[10][2]))
        .z;
        assert!(
            (fz_b - expected).abs() < 1e-6 * expected.abs(),
            "{fz_b} vs {expected}"
        );
        assert!(fx.friction[10].norm() < 1e-12);
        // With the cell at the base end the whole weight of both bodies is unseen along the
        // legs as well: the plate then misses (m₁ + m₂) g less the part the base carries.
        let base = LegsConfig {
            load_cell_end: LoadCellEnd::Base,
            ..l
        };
        let fb = effects(&data, &idx, 0.01, &base);
        let fz_base = (pose.rotation
            * Vector3::new(fb.dynamics[10][0], fb.dynamics[10][1], fb.dynamics[10][2]))
        .z;
        assert!(fz_base < fz_b, "{fz_base} vs {fz_b}");
    }

    #[test]
    fn massless_frictionless_legs_miss_nothing() {
        let data = still_data();
        let idx: Vec<usize> = (2..data.entries.len() - 2).collect();
        let fx = effects(&data, &idx, 0.01, &LegsConfig::default());
        assert!(fx
            .dynamics
            .iter()
            .chain(&fx.friction)
            .all(|w| w.norm() == 0.0));
        assert!(fx.transverse.iter().flatten().flatten().all(|v| *v == 0.0));
    }
}
