//! The suspended payload ([`crate::suspension`]) in the plate's substep.
//!
//! The units' forces depend on both bodies' positions and velocities, and enter the plate's
//! equations (`evaluate`, `coupled`, the brake's implicit rates and the hold in `hold`) as one
//! more wrench that does not depend on the plate's acceleration. They are taken at the
//! substep's start instant like every other force: a first pass with rapier's stored
//! (half-step-old) velocities gives both bodies' accelerations, which take the velocities to the
//! instant (`v(t_n) = v_{n−½} + (h/2) a`), and a second pass gives the forces rapier applies,
//! `−F_i` to the plate and `F_i` to the sprung body at the same points, plus the sprung body's
//! gyroscopic torque at its instant rate ([`GyroscopicModel::Midpoint`]).

use kinematics::Pose;
use nalgebra::Vector3;

use crate::config::GyroscopicModel;
pub(super) use crate::suspension::Motion;
use crate::suspension::UnitForces;

use super::Simulator;

/// The units' forces of the first pass and the sprung body's motion at the instant.
#[derive(Clone, Copy, Debug)]
pub(super) struct SprungStart {
    pub forces: UnitForces,
    body: Motion,
}

/// What the suspension applies over a substep: the units' forces (the plate gets their
/// opposite) and the torque on the sprung body besides them, in B.
#[derive(Clone, Copy, Debug)]
pub(super) struct SprungLoads {
    pub forces: UnitForces,
    pub torque_b: Vector3<f64>,
}

/// The units' wrench on the plate about the P origin, in P axes.
pub(super) fn plate_wrench_p(forces: &UnitForces, pose: &Pose) -> (Vector3<f64>, Vector3<f64>) {
    let w = forces.on_plate(&pose.position_m);
    let rt = pose.rotation.inverse();
    (
        rt * Vector3::new(w[0], w[1], w[2]),
        rt * Vector3::new(w[3], w[4], w[5]),
    )
}

impl Simulator {
    /// The plate's motion from rapier's stored velocities (half a step old).
    pub(super) fn plate_raw_motion(&self, pose: &Pose) -> Motion {
        let (v_com, omega) = self.world.raw_velocities();
        let p = self.model.params();
        Motion::from_com(*pose, &(p.first_moment_kg_m / p.mass_kg), &v_com, &omega)
    }

    /// The sprung body's motion from rapier's stored velocities.
    fn sprung_raw_motion(&self) -> Option<Motion> {
        let s = self.suspension.as_ref()?;
        let (pose, v_com, omega) = self.world.sprung_state()?;
        Some(Motion::from_com(pose, &s.body().com(), &v_com, &omega))
    }

    fn midpoint_gyroscopic(&self) -> bool {
        self.config.gyroscopic == GyroscopicModel::Midpoint
    }

    /// The first pass (module docs) with the plate at `plate_raw`; `None` without a suspension.
    pub(super) fn sprung_start(&self, plate_raw: &Motion) -> Option<SprungStart> {
        let s = self.suspension.as_ref()?;
        let body_raw = self.sprung_raw_motion()?;
        let forces = s.forces(plate_raw, &body_raw);
        let body = s.body_instant(
            &body_raw,
            &forces,
            self.substep_s,
            self.midpoint_gyroscopic(),
        );
        Some(SprungStart { forces, body })
    }

    /// The second pass with the plate at the instant: what rapier applies.
    pub(super) fn sprung_at(&self, start: &SprungStart, plate: &Motion) -> SprungLoads {
        match &self.suspension {
            Some(s) => SprungLoads {
                forces: s.forces(plate, &start.body),
                torque_b: if self.midpoint_gyroscopic() {
                    s.gyroscopic_torque(&start.body)
                } else {
                    Vector3::zeros()
                },
            },
            None => SprungLoads {
                forces: start.forces,
                torque_b: Vector3::zeros(),
            },
        }
    }
}
