//! The legs' effects on a run's record, from the rig description's `[legs]` table and the
//! estimator's own model of what the load cells do not see ([`estimator::legs`]): the plate's
//! motion at each interior entry of the record (the pose, v and a by zero-phase derivatives of
//! the mean position, ω the mean gyro rate, ω̇ its derivative) through that model.
//!
//! When the estimator compensates the legs ([`estimator::EstimatorConfig::legs`]), the record
//! gains the same compensation, and what remains unknown is how far the built legs differ from
//! the description: each `[legs]` figure moved by its tolerance ([`tolerance`], [`moved`]).
//! Otherwise the legs' whole effect is the error.

use estimator::legs::{unseen, unseen_total, PlateMotion};
use estimator::wrench::to_vector;
use nalgebra::{Vector3, Vector6};
use stewart_types::GRAVITY_B_M_S2;

use super::fit::Data;
use crate::record::derivative::{d1, d2};
use rig_description::config::LegsConfig;

/// The legs' effects at each entry of a record (zero outside the interior).
#[derive(Clone, Debug, Default)]
pub struct LegEffects {
    /// Wrench on the plate (P axes, about the P origin) the cells miss from the legs' mass and
    /// inertia.
    pub dynamics: Vec<Vector6<f64>>,
    /// The same from the joints' friction.
    pub friction: Vec<Vector6<f64>>,
    /// Transverse force through each cell along its e₁ and e₂, N (mass and friction).
    pub transverse: Vec<[[f64; 2]; 6]>,
}

/// The plate's motion at the interior entries `idx` of `data` (step `h`); `None` elsewhere.
pub fn motions(data: &Data, idx: &[usize], h: f64) -> Vec<Option<PlateMotion>> {
    let mut out = vec![None; data.entries.len()];
    let positions: Vec<Vector3<f64>> = data.poses.iter().map(|p| p.position_m).collect();
    let gyro = data.gyro();
    for &i in idx {
        out[i] = Some(PlateMotion {
            pose: data.poses[i],
            velocity_m_s: d1(&positions, i, h),
            acceleration_m_s2: d2(&positions, i, h),
            angular_velocity_rad_s: gyro[i],
            angular_acceleration_rad_s2: d1(&gyro, i, h),
        });
    }
    out
}

/// The effects of `legs` along `motions` on the record's rig.
pub fn effects(data: &Data, motions: &[Option<PlateMotion>], legs: &LegsConfig) -> LegEffects {
    let n = motions.len();
    let mut out = LegEffects {
        dynamics: vec![Vector6::zeros(); n],
        friction: vec![Vector6::zeros(); n],
        transverse: vec![[[0.0; 2]; 6]; n],
    };
    let model = legs.model();
    for (i, m) in motions.iter().enumerate() {
        let Some(m) = m else { continue };
        let u = unseen(&data.model.geometry, &model, m, &GRAVITY_B_M_S2);
        out.dynamics[i] = to_vector(&u.dynamics);
        out.friction[i] = to_vector(&u.friction);
        out.transverse[i] = u.transverse_n;
    }
    out
}

/// The sum of [`effects`]' dynamics and friction at each entry, bit for bit, without the
/// transverse forces ([`estimator::legs::unseen_total`]): what a moved `[legs]` figure changes
/// in the wrench.
pub fn totals(
    data: &Data,
    motions: &[Option<PlateMotion>],
    legs: &LegsConfig,
) -> Vec<Vector6<f64>> {
    let model = legs.model();
    motions
        .iter()
        .map(|m| match m {
            Some(m) => to_vector(&unseen_total(
                &data.model.geometry,
                &model,
                m,
                &GRAVITY_B_M_S2,
            )),
            None => Vector6::zeros(),
        })
        .collect()
}

/// The `[legs]` figures the budget moves, in order: cylinder mass, cylinder centre, cylinder
/// inertia, rod mass, rod centre, rod inertia (the `leg_dynamics` source), Coulomb friction,
/// viscous friction (`joint_friction`).
pub const FIGURES: usize = 8;

/// One sigma of figure `k` ([`FIGURES`]) from its tolerance (zero beyond the last).
pub fn tolerance(legs: &LegsConfig, k: usize) -> f64 {
    match k {
        0 => legs.cylinder_mass_kg * legs.mass_tolerance,
        1 | 4 => legs.com_tolerance_m,
        2 => legs.cylinder_inertia_kg_m2 * legs.inertia_tolerance,
        3 => legs.rod_mass_kg * legs.mass_tolerance,
        5 => legs.rod_inertia_kg_m2 * legs.inertia_tolerance,
        6 => legs.joint_coulomb_torque_nm * legs.friction_tolerance,
        7 => legs.joint_viscous_nm_s_per_rad * legs.friction_tolerance,
        _ => 0.0,
    }
}

/// `legs` with figure `k` ([`FIGURES`]) moved by `by` (unchanged beyond the last).
pub fn moved(legs: &LegsConfig, k: usize, by: f64) -> LegsConfig {
    let mut l = *legs;
    let field = match k {
        0 => &mut l.cylinder_mass_kg,
        1 => &mut l.cylinder_com_from_base_m,
        2 => &mut l.cylinder_inertia_kg_m2,
        3 => &mut l.rod_mass_kg,
        4 => &mut l.rod_com_from_plate_m,
        5 => &mut l.rod_inertia_kg_m2,
        6 => &mut l.joint_coulomb_torque_nm,
        7 => &mut l.joint_viscous_nm_s_per_rad,
        _ => return l,
    };
    *field += by;
    l
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::budget::fit::{Mode, Model};
    use crate::budget::testkit;

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

    /// On a plate at rest the record's motion is rest (zero rates), and the effects are the
    /// model's at that pose: the legs' weight across them, which pulls the plate down.
    #[test]
    fn a_still_record_gives_the_weight_across_the_legs() {
        let data = still_data();
        let idx: Vec<usize> = (2..data.entries.len() - 2).collect();
        let m = motions(&data, &idx, 0.01);
        assert!(m[0].is_none() && m[10].is_some());
        let rest = m[10].expect("interior");
        assert!(rest.velocity_m_s.norm() < 1e-9 && rest.acceleration_m_s2.norm() < 1e-9);
        let legs = testkit::default_legs();
        let fx = effects(&data, &m, &legs);
        let fz_b = (data.poses[10].rotation
            * Vector3::new(fx.dynamics[10][0], fx.dynamics[10][1], fx.dynamics[10][2]))
        .z;
        assert!(fz_b < -1.0, "{fz_b}");
        assert_eq!(fx.dynamics[0], Vector6::zeros());
        let none = effects(&data, &m, &LegsConfig::default());
        assert!(none
            .dynamics
            .iter()
            .chain(&none.friction)
            .all(|w| w.norm() == 0.0));
    }

    /// A moved figure's wrench change takes the totals alone: the effects' dynamics plus
    /// friction bit for bit, zero where the record has no motion.
    #[test]
    fn the_totals_are_the_effects_sum_bit_for_bit() {
        let data = still_data();
        let idx: Vec<usize> = (2..data.entries.len() - 2).collect();
        let m = motions(&data, &idx, 0.01);
        let legs = moved(&testkit::default_legs(), 6, 0.3);
        let fx = effects(&data, &m, &legs);
        let totals = totals(&data, &m, &legs);
        assert_eq!(totals.len(), fx.dynamics.len());
        for (i, t) in totals.iter().enumerate() {
            assert_eq!(*t, fx.dynamics[i] + fx.friction[i], "entry {i}");
        }
        assert!(totals[10].norm() > 1.0);
    }

    /// Each perturbation moves its own figure, by its tolerance, and nothing else.
    #[test]
    fn each_perturbation_moves_one_figure_by_its_tolerance() {
        let legs = testkit::default_legs();
        let figures = |l: &LegsConfig| {
            [
                l.cylinder_mass_kg,
                l.cylinder_com_from_base_m,
                l.cylinder_inertia_kg_m2,
                l.rod_mass_kg,
                l.rod_com_from_plate_m,
                l.rod_inertia_kg_m2,
                l.joint_coulomb_torque_nm,
                l.joint_viscous_nm_s_per_rad,
            ]
        };
        let before = figures(&legs);
        for k in 0..FIGURES {
            let step = tolerance(&legs, k);
            let after = figures(&moved(&legs, k, step));
            for j in 0..FIGURES {
                let expected = if j == k { before[j] + step } else { before[j] };
                assert_eq!(after[j], expected, "figure {j} of perturbation {k}");
            }
            assert!(step > 0.0, "perturbation {k}");
        }
        assert_eq!(tolerance(&legs, FIGURES), 0.0);
        assert_eq!(figures(&moved(&legs, FIGURES, 1.0)), before);
        assert_eq!(tolerance(&legs, 0), 28.0 * 0.02);
        assert_eq!(tolerance(&legs, 4), 0.01);
        assert_eq!(tolerance(&legs, 6), 0.3);
    }
}
