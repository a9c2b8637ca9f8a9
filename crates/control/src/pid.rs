//! Leg PID: leg-length error in, axial leg force out.
//!
//! One [`Pid`] per leg, six of them in a [`PidBank`]. The law, per update with an explicit step
//! `dt` (the time between the two sensor samples, not a nominal period):
//!
//! ```text
//! e_k = r_k − y_k
//! P_k = kp·e_k
//! D_k = a·D_{k−1} − kd·(y_k − y_{k−1})/(T_f + dt),   a = T_f/(T_f + dt)
//! v_k = F_ff + P_k + I_k + D_k,      u_k = clamp(v_k, u_min, u_max)
//! I_{k+1} = I_k + ki·dt·e_k (+ anti-windup correction)
//! ```
//!
//! * The derivative acts on the measurement, not the error, so a setpoint step gives no
//!   derivative kick; it is the backward-Euler discretisation of `−kd·s/(T_f·s + 1)·y`, stable
//!   for every `T_f ≥ 0` and every `dt > 0`.
//! * The integrator is forward Euler: `I_k` uses errors up to `k − 1`, so the first update after
//!   a reset outputs `F_ff + P` only. The state is the integral *term* (newtons), not the
//!   integral of the error, so changing `ki` on the fly does not make the output jump.
//! * Anti-windup ([`AntiWindup`]): conditional integration (clamping) or back-calculation
//!   (Åström & Hägglund, *Advanced PID Control*, 2006, §3.5: `dI/dt = ki·e + (u − v)/T_t`).
//! * Bumpless start: the first update after [`Pid::reset`] has no derivative term (there is no
//!   previous measurement); after [`Pid::reset_to`] it also outputs exactly the given force, the
//!   integral term taking up the difference.

use kinematics::Real;

use crate::error::ControlError;
use crate::io::LEG_COUNT;

/// How the integrator is kept from winding up while the output saturates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AntiWindup<T = f64> {
    /// No protection: the integrator keeps integrating into saturation. Only for comparison
    /// (tests, tuning); never use it on a rig.
    None,
    /// Conditional integration: the integrator holds while the output is saturated and the
    /// error would drive it further into saturation, and the integral term is kept within
    /// `[u_min − F_ff, u_max − F_ff]`.
    Clamping,
    /// Back-calculation: `I ← I + ki·dt·e + min(dt/T_t, 1)·(u − v)`. The tracking time `T_t`
    /// (seconds, > 0) sets how fast the integrator follows the saturated output; a common choice
    /// is `√(T_i·T_d)` with `T_i = kp/ki`, `T_d = kd/kp`.
    BackCalculation {
        /// Tracking time constant `T_t`, seconds.
        tracking_time_s: T,
    },
}

/// Gains and limits of one leg PID. Plain `Copy` data; check it with [`PidConfig::validate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidConfig<T = f64> {
    /// Proportional gain, N/m.
    pub kp: T,
    /// Integral gain, N/(m·s).
    pub ki: T,
    /// Derivative gain, N·s/m.
    pub kd: T,
    /// Time constant `T_f` of the first-order filter on the derivative, seconds (0 = unfiltered).
    pub derivative_filter_s: T,
    /// Lower output limit, N.
    pub output_min_n: T,
    /// Upper output limit, N.
    pub output_max_n: T,
    /// Anti-windup scheme.
    pub anti_windup: AntiWindup<T>,
}

impl<T: Real> Default for PidConfig<T> {
    /// A starting point for a leg carrying about 250 kg of effective mass at a 1 kHz loop:
    /// closed-loop bandwidth near 10 Hz (`kp = m·ω²`, `kd = 2·0.7·m·ω`, `ki = kp·ω/10` with
    /// `ω = 2π·10 rad/s`), derivative filtered at 2 ms, ±20 kN, back-calculation with
    /// `T_t = 20 ms`. Tune per rig.
    fn default() -> Self {
        Self {
            kp: T::lit(1.0e6),
            ki: T::lit(6.0e6),
            kd: T::lit(2.2e4),
            derivative_filter_s: T::lit(0.002),
            output_min_n: T::lit(-20_000.0),
            output_max_n: T::lit(20_000.0),
            anti_windup: AntiWindup::BackCalculation {
                tracking_time_s: T::lit(0.02),
            },
        }
    }
}

impl<T: Real> PidConfig<T> {
    /// The same configuration in another precision (each value rounded to nearest).
    pub fn cast<U: Real>(&self) -> PidConfig<U> {
        let c = |v: T| U::lit(v.to_f64());
        PidConfig {
            kp: c(self.kp),
            ki: c(self.ki),
            kd: c(self.kd),
            derivative_filter_s: c(self.derivative_filter_s),
            output_min_n: c(self.output_min_n),
            output_max_n: c(self.output_max_n),
            anti_windup: match self.anti_windup {
                AntiWindup::None => AntiWindup::None,
                AntiWindup::Clamping => AntiWindup::Clamping,
                AntiWindup::BackCalculation { tracking_time_s } => AntiWindup::BackCalculation {
                    tracking_time_s: c(tracking_time_s),
                },
            },
        }
    }

    /// Checks that every gain is finite and non-negative, the filter time is finite and
    /// non-negative, the output range is finite and non-empty (`min < max`), and a
    /// back-calculation tracking time is finite and positive.
    pub fn validate(&self) -> Result<(), ControlError> {
        let gains = [
            ("pid.kp", self.kp),
            ("pid.ki", self.ki),
            ("pid.kd", self.kd),
            ("pid.derivative_filter_s", self.derivative_filter_s),
        ];
        for (name, value) in gains {
            if !value.is_finite() || value < T::zero() {
                return Err(ControlError::InvalidConfig {
                    parameter: name,
                    reason: "must be finite and >= 0",
                });
            }
        }
        if !self.output_min_n.is_finite()
            || !self.output_max_n.is_finite()
            || self.output_min_n >= self.output_max_n
        {
            return Err(ControlError::InvalidConfig {
                parameter: "pid.output_min_n/output_max_n",
                reason: "must be finite with min < max",
            });
        }
        if let AntiWindup::BackCalculation { tracking_time_s } = self.anti_windup {
            if !tracking_time_s.is_finite() || tracking_time_s <= T::zero() {
                return Err(ControlError::InvalidConfig {
                    parameter: "pid.anti_windup.tracking_time_s",
                    reason: "must be finite and > 0",
                });
            }
        }
        Ok(())
    }
}

/// Each term's contribution to one update, for logging.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PidOutput<T = f64> {
    /// Proportional term `kp·e`, N.
    pub p: T,
    /// Integral term used in this output, N.
    pub i: T,
    /// Filtered derivative-on-measurement term, N.
    pub d: T,
    /// Feed-forward force added before saturation, N.
    pub feedforward: T,
    /// Saturated output `clamp(feedforward + p + i + d)`, N.
    pub output: T,
    /// True when the clamp changed the output.
    pub saturated: bool,
}

/// One leg's PID controller. See the [module docs](self) for the law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pid<T = f64> {
    config: PidConfig<T>,
    /// Integral term (N) to be used by the next update.
    integral: T,
    /// Last filtered derivative term, N.
    derivative: T,
    last_measurement: T,
    /// False until the first update after a reset: no previous measurement to differentiate.
    primed: bool,
    /// Output the first update after [`Pid::reset_to`] must produce.
    start_output: Option<T>,
}

impl<T: Real> Pid<T> {
    /// A controller in the reset state.
    pub fn new(config: PidConfig<T>) -> Result<Self, ControlError> {
        config.validate()?;
        Ok(Self::reset_state(config))
    }

    fn reset_state(config: PidConfig<T>) -> Self {
        Self {
            config,
            integral: T::zero(),
            derivative: T::zero(),
            last_measurement: T::zero(),
            primed: false,
            start_output: None,
        }
    }

    /// The configuration in use.
    pub fn config(&self) -> &PidConfig<T> {
        &self.config
    }

    /// Replaces gains and limits without resetting the state. Because the state is the integral
    /// term itself, the output does not jump when `ki` changes.
    pub fn set_config(&mut self, config: PidConfig<T>) -> Result<(), ControlError> {
        config.validate()?;
        self.config = config;
        Ok(())
    }

    /// Clears the integrator and the derivative history. The next update outputs
    /// `F_ff + P` (no integral, no derivative kick).
    pub fn reset(&mut self) {
        self.integral = T::zero();
        self.derivative = T::zero();
        self.primed = false;
        self.start_output = None;
    }

    /// Bumpless start: like [`Pid::reset`], but the next update outputs exactly `output_n`
    /// (clamped to the output range) by loading the integral term with
    /// `output_n − F_ff − P`. Use it when taking over from another controller or from brakes
    /// that were holding a known load. A non-finite `output_n` is treated as a plain reset.
    pub fn reset_to(&mut self, output_n: T) {
        self.reset();
        if output_n.is_finite() {
            self.start_output = Some(output_n);
        }
    }

    /// The integral term the next update will use, N.
    pub fn integral_term(&self) -> T {
        self.integral
    }

    /// One update. `setpoint` and `measurement` in metres, `feedforward_n` in newtons, `dt_s`
    /// the time since the previous update in seconds.
    ///
    /// Errors (state left unchanged): [`ControlError::NonFinite`] for a NaN/infinite input,
    /// [`ControlError::InvalidTimeStep`] unless `dt_s` is finite and positive.
    pub fn update(
        &mut self,
        setpoint: T,
        measurement: T,
        feedforward_n: T,
        dt_s: T,
    ) -> Result<PidOutput<T>, ControlError> {
        check_inputs(setpoint, measurement, feedforward_n, 0)?;
        check_dt(dt_s)?;
        Ok(self.update_unchecked(setpoint, measurement, feedforward_n, dt_s))
    }

    fn update_unchecked(
        &mut self,
        setpoint: T,
        measurement: T,
        feedforward_n: T,
        dt_s: T,
    ) -> PidOutput<T> {
        let c = self.config;
        let error = setpoint - measurement;
        let p = c.kp * error;
        let d = if self.primed {
            let denominator = c.derivative_filter_s + dt_s;
            (c.derivative_filter_s * self.derivative - c.kd * (measurement - self.last_measurement))
                / denominator
        } else {
            T::zero()
        };
        if let Some(start) = self.start_output.take() {
            let start = start.clamp(c.output_min_n, c.output_max_n);
            self.integral = start - feedforward_n - p - d;
        }
        let i = self.integral;
        let unsaturated = feedforward_n + p + i + d;
        let output = unsaturated.clamp(c.output_min_n, c.output_max_n);
        // A NaN cannot reach here (inputs checked), so `!=` means the clamp acted.
        let saturated = output != unsaturated;

        let increment = c.ki * dt_s * error;
        self.integral = match c.anti_windup {
            AntiWindup::None => i + increment,
            AntiWindup::Clamping => {
                let deeper = (unsaturated > c.output_max_n && increment > T::zero())
                    || (unsaturated < c.output_min_n && increment < T::zero());
                let next = if deeper { i } else { i + increment };
                next.clamp(
                    c.output_min_n - feedforward_n,
                    c.output_max_n - feedforward_n,
                )
            }
            // Without integral action there is no integrator to track the output; the
            // tracking term alone would invent one.
            AntiWindup::BackCalculation { .. } if c.ki == T::zero() => i,
            AntiWindup::BackCalculation { tracking_time_s } => {
                let gain = (dt_s / tracking_time_s).min(T::one());
                i + increment + gain * (output - unsaturated)
            }
        };
        self.derivative = d;
        self.last_measurement = measurement;
        self.primed = true;
        PidOutput {
            p,
            i,
            d,
            feedforward: feedforward_n,
            output,
            saturated,
        }
    }
}

fn check_inputs<T: Real>(
    setpoint: T,
    measurement: T,
    feedforward_n: T,
    leg: usize,
) -> Result<(), ControlError> {
    let named = [
        ("pid setpoint", setpoint),
        ("pid measurement", measurement),
        ("pid feedforward", feedforward_n),
    ];
    for (what, value) in named {
        if !value.is_finite() {
            return Err(ControlError::NonFinite { what, index: leg });
        }
    }
    Ok(())
}

fn check_dt<T: Real>(dt_s: T) -> Result<(), ControlError> {
    if dt_s.is_finite() && dt_s > T::zero() {
        Ok(())
    } else {
        Err(ControlError::InvalidTimeStep {
            dt_s: dt_s.to_f64(),
        })
    }
}

/// The six leg PIDs, updated together.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidBank<T = f64> {
    pids: [Pid<T>; LEG_COUNT],
}

impl<T: Real> PidBank<T> {
    /// Six controllers with their own configurations.
    pub fn new(configs: [PidConfig<T>; LEG_COUNT]) -> Result<Self, ControlError> {
        for config in &configs {
            config.validate()?;
        }
        Ok(Self {
            pids: configs.map(Pid::reset_state),
        })
    }

    /// Six controllers with the same configuration.
    pub fn uniform(config: PidConfig<T>) -> Result<Self, ControlError> {
        Self::new([config; LEG_COUNT])
    }

    /// The controllers, leg by leg.
    pub fn pids(&self) -> &[Pid<T>; LEG_COUNT] {
        &self.pids
    }

    /// [`Pid::reset`] on every leg.
    pub fn reset(&mut self) {
        self.pids.iter_mut().for_each(Pid::reset);
    }

    /// [`Pid::reset_to`] on every leg, with per-leg start forces.
    pub fn reset_to(&mut self, outputs_n: &[T; LEG_COUNT]) {
        for (pid, &output) in self.pids.iter_mut().zip(outputs_n) {
            pid.reset_to(output);
        }
    }

    /// Updates all six legs with one time step. All inputs are checked before any leg is
    /// touched, so an error leaves the whole bank unchanged; [`ControlError::NonFinite`] names
    /// the first offending leg.
    pub fn update(
        &mut self,
        setpoints_m: &[T; LEG_COUNT],
        measurements_m: &[T; LEG_COUNT],
        feedforward_n: &[T; LEG_COUNT],
        dt_s: T,
    ) -> Result<[PidOutput<T>; LEG_COUNT], ControlError> {
        check_dt(dt_s)?;
        for (leg, ((&r, &y), &f)) in setpoints_m
            .iter()
            .zip(measurements_m)
            .zip(feedforward_n)
            .enumerate()
        {
            check_inputs(r, y, f, leg)?;
        }
        let mut out = [PidOutput::default(); LEG_COUNT];
        for ((((pid, o), &r), &y), &f) in self
            .pids
            .iter_mut()
            .zip(out.iter_mut())
            .zip(setpoints_m)
            .zip(measurements_m)
            .zip(feedforward_n)
        {
            *o = pid.update_unchecked(r, y, f, dt_s);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests;
