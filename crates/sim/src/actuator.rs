//! The actuator between a force command and the force a leg applies to the plate.
//!
//! Per leg, in this order:
//!
//! 1. **Saturation**: the command is clipped to `±max_force_n`.
//! 2. **First-order lag** of corner `bandwidth_hz` (`τ = 1/(2π f_c)`), integrated exactly for a
//!    command held over a physics substep `h`: `y ← u + (y − u) e^{−h/τ}`. The force a substep
//!    applies is the lag state at the substep's *start*; the update comes after. So the force at a
//!    sample instant never depends on the command written at that instant, which is what lets
//!    the sensor channels of a sample be evaluated at consistent instants (see `simulator`).
//! 3. **Friction inside the actuator** (between motor and load cell): the output is
//!    `F = y − c_v l̇ − F_c tanh(l̇ / v_s)`, with `l̇` the leg's extension rate; the `tanh`
//!    smooths the Coulomb step over `v_s` so that explicit integration does not chatter.
//!
//! **Brake** (`enable = false`): the actuator locks like a valve closing on a hydraulic cylinder.
//! At engagement it records the leg length `L₀` and the output force `F₀`; while braked it
//! applies `F = F₀ − k (L − L₀) − c l̇`, a stiff, damped hold of the leg length that carries the
//! load it had, so a braked rig stops within a second and stays put (sagging by only the change
//! of load over `k`). The simulator evaluates the damping term implicitly, with the leg rates at
//! the end of the substep, so a heavy damper is stable whatever the body's mass; the spring term
//! is explicit (stable while `h² k / m_eff ≤ 2`, checked at construction). The lag state follows
//! the brake force, so releasing the brake is bumpless. The simulator starts braked, holding
//! the plate's static load at rest.

use serde::{Deserialize, Serialize};

use crate::error::{check_non_negative, check_positive, SimError};

/// Actuator parameters, the same for all six legs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ActuatorConfig {
    /// Corner frequency of the first-order force lag, Hz.
    pub bandwidth_hz: f64,
    /// Largest force magnitude the actuator produces, N (commands are clipped to ±this).
    pub max_force_n: f64,
    /// Viscous friction inside the actuator, N·s/m (0 = none).
    pub viscous_friction_n_s_m: f64,
    /// Coulomb friction inside the actuator, N (0 = none).
    pub coulomb_friction_n: f64,
    /// Speed over which the Coulomb friction's sign change is smoothed (`tanh`), m/s.
    pub coulomb_velocity_scale_m_s: f64,
    /// Stiffness of the brake's hold of the leg length, N/m.
    pub brake_stiffness_n_m: f64,
    /// Damping of the brake's hold, N·s/m.
    pub brake_damping_n_s_m: f64,
}

impl Default for ActuatorConfig {
    /// A stiff electro-mechanical actuator: 100 Hz force bandwidth, 20 kN, no friction; a brake
    /// of 2 MN/m and 100 kN·s/m (about critically damped for a 1.5 t car; the spring is stable
    /// with 1 ms substeps down to about 1 kg of effective mass per leg).
    fn default() -> Self {
        Self {
            bandwidth_hz: 100.0,
            max_force_n: 20_000.0,
            viscous_friction_n_s_m: 0.0,
            coulomb_friction_n: 0.0,
            coulomb_velocity_scale_m_s: 1e-3,
            brake_stiffness_n_m: 2.0e6,
            brake_damping_n_s_m: 1.0e5,
        }
    }
}

impl ActuatorConfig {
    /// Checks every field's range.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("actuator.bandwidth_hz", self.bandwidth_hz)?;
        check_positive("actuator.max_force_n", self.max_force_n)?;
        check_non_negative(
            "actuator.viscous_friction_n_s_m",
            self.viscous_friction_n_s_m,
        )?;
        check_non_negative("actuator.coulomb_friction_n", self.coulomb_friction_n)?;
        check_positive(
            "actuator.coulomb_velocity_scale_m_s",
            self.coulomb_velocity_scale_m_s,
        )?;
        check_positive("actuator.brake_stiffness_n_m", self.brake_stiffness_n_m)?;
        check_non_negative("actuator.brake_damping_n_s_m", self.brake_damping_n_s_m)?;
        Ok(())
    }
}

/// State of one leg's actuator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct ActuatorState {
    /// Lag state (motor force), N.
    pub motor_force_n: f64,
    /// Saturated command being tracked, N.
    pub command_n: f64,
    /// Leg length held by the brake, m.
    pub hold_length_m: f64,
    /// Force carried when the brake engaged, N.
    pub hold_force_n: f64,
}

/// Six actuators sharing one configuration and one brake state.
#[derive(Clone, Debug)]
pub(crate) struct Actuators {
    config: ActuatorConfig,
    /// `e^{−h/τ}` for the physics substep `h`.
    decay: f64,
    braked: bool,
    legs: [ActuatorState; 6],
}

impl Actuators {
    /// Starts braked, holding `lengths_m` with `forces_n` (the static load).
    pub fn new_braked(
        config: ActuatorConfig,
        substep_s: f64,
        lengths_m: &[f64; 6],
        forces_n: &[f64; 6],
    ) -> Self {
        let tau = 1.0 / (2.0 * core::f64::consts::PI * config.bandwidth_hz);
        let legs = core::array::from_fn(|i| ActuatorState {
            motor_force_n: forces_n[i],
            command_n: forces_n[i],
            hold_length_m: lengths_m[i],
            hold_force_n: forces_n[i],
        });
        Self {
            config,
            decay: (-substep_s / tau).exp(),
            braked: true,
            legs,
        }
    }

    /// True while the brake is engaged.
    pub fn braked(&self) -> bool {
        self.braked
    }

    /// The configuration.
    pub fn config(&self) -> &ActuatorConfig {
        &self.config
    }

    /// Takes a new command. Engaging the brake records each leg's length and `current_forces_n`
    /// (the output at this instant); releasing it leaves the lag state at the brake force.
    pub fn command(
        &mut self,
        forces_n: &[f64; 6],
        enable: bool,
        lengths_m: &[f64; 6],
        current_forces_n: &[f64; 6],
    ) {
        let max = self.config.max_force_n;
        if !enable && !self.braked {
            for (i, leg) in self.legs.iter_mut().enumerate() {
                leg.hold_length_m = lengths_m[i];
                leg.hold_force_n = current_forces_n[i];
            }
        }
        self.braked = !enable;
        for (leg, &f) in self.legs.iter_mut().zip(forces_n) {
            leg.command_n = f.clamp(-max, max);
        }
    }

    /// The axial force each leg applies now, given its length and extension rate.
    pub fn output(&self, lengths_m: &[f64; 6], rates_m_s: &[f64; 6]) -> [f64; 6] {
        let c = &self.config;
        core::array::from_fn(|i| {
            let leg = &self.legs[i];
            let v = rates_m_s[i];
            if self.braked {
                leg.hold_force_n
                    - c.brake_stiffness_n_m * (lengths_m[i] - leg.hold_length_m)
                    - c.brake_damping_n_s_m * v
            } else {
                leg.motor_force_n
                    - c.viscous_friction_n_s_m * v
                    - c.coulomb_friction_n * (v / c.coulomb_velocity_scale_m_s).tanh()
            }
        })
    }

    /// Advances the lag by one substep, after `applied_n` (from [`Self::output`]) was applied.
    pub fn advance(&mut self, applied_n: &[f64; 6]) {
        for (leg, &applied) in self.legs.iter_mut().zip(applied_n) {
            leg.motor_force_n = if self.braked {
                applied
            } else {
                leg.command_n + (leg.motor_force_n - leg.command_n) * self.decay
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn enabled(config: ActuatorConfig, h: f64) -> Actuators {
        let mut a = Actuators::new_braked(config, h, &[1.0; 6], &[0.0; 6]);
        a.command(&[0.0; 6], true, &[1.0; 6], &[0.0; 6]);
        a
    }

    #[test]
    fn lag_step_response_is_first_order() {
        let cfg = ActuatorConfig {
            bandwidth_hz: 10.0,
            ..Default::default()
        };
        let h = 1e-4;
        let mut a = enabled(cfg, h);
        a.command(&[1000.0; 6], true, &[1.0; 6], &[0.0; 6]);
        let tau = 1.0 / (2.0 * core::f64::consts::PI * 10.0);
        let steps = (tau / h).round() as usize;
        for _ in 0..steps {
            let f = a.output(&[1.0; 6], &[0.0; 6]);
            a.advance(&f);
        }
        // After one time constant a first-order lag reaches 1 − 1/e of the step.
        let f = a.output(&[1.0; 6], &[0.0; 6])[0];
        let want = 1000.0 * (1.0 - (-(steps as f64) * h / tau).exp());
        assert!((f - want).abs() < 1e-9, "{f} vs {want}");
        assert!((f - 632.1).abs() < 1.0);
    }

    #[test]
    fn saturation_and_friction() {
        let cfg = ActuatorConfig {
            bandwidth_hz: 1e6,
            max_force_n: 500.0,
            viscous_friction_n_s_m: 100.0,
            coulomb_friction_n: 20.0,
            coulomb_velocity_scale_m_s: 1e-3,
            ..Default::default()
        };
        let mut a = enabled(cfg, 1e-3);
        a.command(
            &[2000.0, -2000.0, 100.0, 0.0, 0.0, 0.0],
            true,
            &[1.0; 6],
            &[0.0; 6],
        );
        let f = a.output(&[1.0; 6], &[0.0; 6]);
        a.advance(&f);
        let rates = [0.0, 0.0, 0.5, -0.5, 0.0, 0.0];
        let f = a.output(&[1.0; 6], &rates);
        assert!((f[0] - 500.0).abs() < 1e-9);
        assert!((f[1] + 500.0).abs() < 1e-9);
        // Extending at 0.5 m/s: friction opposes, 100·0.5 + 20 (tanh saturated).
        assert!((f[2] - (100.0 - 50.0 - 20.0)).abs() < 1e-6);
        assert!((f[3] - (50.0 + 20.0)).abs() < 1e-6);
    }

    #[test]
    fn brake_holds_length_and_carries_load_bumplessly() {
        let cfg = ActuatorConfig::default();
        let mut a = enabled(cfg, 1e-3);
        a.command(&[800.0; 6], true, &[1.0; 6], &[0.0; 6]);
        for _ in 0..200 {
            let f = a.output(&[1.0; 6], &[0.0; 6]);
            a.advance(&f);
        }
        let before = a.output(&[1.0; 6], &[0.0; 6]);
        a.command(&[0.0; 6], false, &[1.0; 6], &before);
        assert!(a.braked());
        // At the held length and at rest the brake carries exactly the load it locked.
        let held = a.output(&[1.0; 6], &[0.0; 6]);
        assert_eq!(held, before);
        // Pushed 1 mm longer it pulls back with k · 1 mm; moving it damps.
        let f = a.output(&[1.001; 6], &[0.01; 6]);
        let want = before[0] - cfg.brake_stiffness_n_m * 1e-3 - cfg.brake_damping_n_s_m * 0.01;
        assert!((f[0] - want).abs() < 1e-6);
        a.advance(&held);
        // Release with a command equal to the held load: no jump.
        a.command(&held, true, &[1.0; 6], &held);
        let after = a.output(&[1.0; 6], &[0.0; 6]);
        assert!((after[0] - held[0]).abs() < 1e-9);
    }
}
