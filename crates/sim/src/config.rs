//! Top-level simulator configuration, embeddable as a TOML section.

use serde::{Deserialize, Serialize};

use rig_description::config::LegsConfig;

use crate::actuator::ActuatorConfig;
use crate::error::{check_non_negative, check_positive, SimError};
use crate::imperfections::SuspensionConfig;
use crate::sensors::SensorConfig;

/// Longest physics substep allowed, s: the physics runs at a time step of 1 ms or less.
pub const MAX_SUBSTEP_S: f64 = 1e-3;

/// How the gyroscopic torque `−ω × (J_C ω)` enters the integration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GyroscopicModel {
    /// We apply it as an external torque each substep, evaluated at the angular velocity of the
    /// substep's start instant (`ω_{n−½} + (h/2) ω̇`), so the kick is the Newton–Euler
    /// acceleration at that instant. Second order: the leg wrench matches Newton–Euler on
    /// rapier's motion to about 10⁻⁸ on a tumbling motion.
    #[default]
    Midpoint,
    /// Rapier's built-in gyroscopic forces: explicit, evaluated after the force kick, with its
    /// momentum-norm cap. First order: about 3·10⁻⁴ of the torque at 1 rad/s with 0.5 ms steps.
    Rapier,
}

/// Everything about the simulated rig except its geometry and bodies.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// Sensor sampling and control rate, Hz (one `read`/`write` pair per sample).
    pub sample_rate_hz: f64,
    /// Physics substeps per sample; the substep `1 / (sample_rate_hz · substeps)` must be at
    /// most 1 ms.
    pub substeps: u32,
    /// Who integrates the gyroscopic torque (`midpoint` or `rapier`).
    pub gyroscopic: GyroscopicModel,
    /// Actuator model.
    pub actuator: ActuatorConfig,
    /// Sensor models.
    pub sensors: SensorConfig,
    /// The legs' mass properties, joint friction and the load cells' end (the rig
    /// description's `[legs]` as the world's switches leave it; zero masses and friction:
    /// massless, frictionless legs, forces along the leg lines).
    pub legs: LegsConfig,
    /// The payload as a car body on its suspension (the world's `[world.suspension]`; off: the
    /// payload is rigid on the plate). See `crate::suspension`.
    pub suspension: SuspensionConfig,
}

impl Default for SimConfig {
    /// 1 kHz sampling with two 0.5 ms physics substeps per sample, midpoint gyroscopic torque,
    /// default actuators, the `realistic` sensors, massless, frictionless legs and a rigid
    /// payload.
    fn default() -> Self {
        Self {
            sample_rate_hz: 1000.0,
            substeps: 2,
            gyroscopic: GyroscopicModel::Midpoint,
            actuator: ActuatorConfig::default(),
            sensors: SensorConfig::default(),
            legs: LegsConfig::default(),
            suspension: SuspensionConfig::default(),
        }
    }
}

impl SimConfig {
    /// Time between samples, s.
    pub fn sample_period_s(&self) -> f64 {
        1.0 / self.sample_rate_hz
    }

    /// Physics substep, s.
    pub fn substep_s(&self) -> f64 {
        self.sample_period_s() / f64::from(self.substeps.max(1))
    }

    /// Checks every field's range (including the actuator and sensor sections).
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("sample_rate_hz", self.sample_rate_hz)?;
        if self.substeps == 0 {
            return Err(SimError::InvalidConfig {
                field: "substeps",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        if self.substep_s() > MAX_SUBSTEP_S * (1.0 + 1e-12) {
            return Err(SimError::InvalidConfig {
                field: "substeps",
                value: f64::from(self.substeps),
                reason: "the physics substep 1/(sample_rate_hz·substeps) must be at most 1 ms",
            });
        }
        self.actuator.validate()?;
        self.sensors.validate()?;
        let l = &self.legs;
        for (field, value) in [
            ("legs.cylinder_mass_kg", l.cylinder_mass_kg),
            ("legs.cylinder_com_from_base_m", l.cylinder_com_from_base_m),
            ("legs.cylinder_inertia_kg_m2", l.cylinder_inertia_kg_m2),
            ("legs.rod_mass_kg", l.rod_mass_kg),
            ("legs.rod_com_from_plate_m", l.rod_com_from_plate_m),
            ("legs.rod_inertia_kg_m2", l.rod_inertia_kg_m2),
            ("legs.joint_coulomb_torque_nm", l.joint_coulomb_torque_nm),
            (
                "legs.joint_viscous_nm_s_per_rad",
                l.joint_viscous_nm_s_per_rad,
            ),
        ] {
            check_non_negative(field, value)?;
        }
        crate::suspension::validate(&self.suspension)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::SimErrorKind;

    #[test]
    fn embeds_in_toml_with_defaults_and_refuses_unknown_keys() {
        let text = "sample_rate_hz = 500.0\nsubsteps = 4\ngyroscopic = \"rapier\"\n\
                    [actuator]\nbandwidth_hz = 40.0\n\
                    [sensors.accelerometer]\nmount_m = [0.1, 0.0, 0.2]\n";
        let cfg: SimConfig = toml::from_str(text).unwrap();
        assert_eq!(cfg.substeps, 4);
        assert_eq!(cfg.gyroscopic, GyroscopicModel::Rapier);
        assert_eq!(cfg.actuator.bandwidth_hz, 40.0);
        assert_eq!(
            cfg.actuator.max_force_n,
            ActuatorConfig::default().max_force_n
        );
        assert_eq!(cfg.sensors.accelerometer.mount_m, [0.1, 0.0, 0.2]);
        assert_eq!(cfg.sensors.gyro, SensorConfig::default().gyro);
        cfg.validate().unwrap();
        let back: SimConfig = toml::from_str(&toml::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(back, cfg);
        for bad in [
            "sample_rate_hz = 1000.0\nsubstep = 2\n",
            "[actuator]\nbandwidth = 40.0\n",
            "[sensors.load_cell]\nnoise_n = 1.0\n",
            "gyroscopic = \"exact\"\n",
        ] {
            assert!(
                toml::from_str::<SimConfig>(bad).is_err(),
                "accepted {bad:?}"
            );
        }
    }

    #[test]
    fn defaults_are_valid_and_bad_values_name_their_field() {
        SimConfig::default().validate().unwrap();
        let cfg = SimConfig {
            sample_rate_hz: 500.0,
            substeps: 1,
            ..Default::default()
        };
        match cfg.validate() {
            Err(
                e @ SimError::InvalidConfig {
                    field: "substeps", ..
                },
            ) => {
                assert_eq!(e.kind(), SimErrorKind::InvalidConfig)
            }
            other => panic!("{other:?}"),
        }
        let mut cfg = SimConfig::default();
        cfg.actuator.bandwidth_hz = f64::NAN;
        assert!(matches!(
            cfg.validate(),
            Err(SimError::InvalidConfig {
                field: "actuator.bandwidth_hz",
                ..
            })
        ));
        let mut cfg = SimConfig::default();
        cfg.sensors.load_cell.noise_sigma_n = -1.0;
        assert!(matches!(
            cfg.validate(),
            Err(SimError::InvalidConfig {
                field: "sensors.load_cell.noise_sigma_n",
                ..
            })
        ));
    }
}
