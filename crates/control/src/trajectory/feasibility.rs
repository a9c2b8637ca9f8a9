//! The check, before any motion, that a trajectory stays within stroke, leg speed and
//! conditioning limits everywhere.

use kinematics::{Geometry, Real, LEG_COUNT};

use super::{Ramp, Trajectory, TrajectorySample};
use crate::error::ControlError;

/// Limits for [`Trajectory::check_feasibility`]. Plain `Copy` data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeasibilityLimits<T = f64> {
    /// Every leg must stay this far inside its stroke, m (≥ 0): room for tracking error.
    pub stroke_margin_m: T,
    /// Largest allowed |leg speed| `|J·twist|ᵢ`, m/s (> 0). Keep it below the supervisor's
    /// limit so that tracking overshoot does not trip it.
    pub max_leg_speed_m_s: T,
    /// Smallest allowed inverse condition number of the scaled Jacobian
    /// ([`Geometry::inverse_condition_number`]), ≥ 0.
    pub min_inverse_condition: T,
    /// Largest sampling step, s (> 0). The check also takes at least 50 samples per period
    /// of the highest frequency.
    pub step_s: T,
}

impl<T: Real> Default for FeasibilityLimits<T> {
    /// 5 mm stroke margin, 0.4 m/s, inverse condition number ≥ 10 ×
    /// [`kinematics::SINGULARITY_THRESHOLD`], 1 ms steps.
    fn default() -> Self {
        Self {
            stroke_margin_m: T::lit(0.005),
            max_leg_speed_m_s: T::lit(0.4),
            min_inverse_condition: T::lit(10.0 * kinematics::SINGULARITY_THRESHOLD),
            step_s: T::lit(1e-3),
        }
    }
}

impl<T: Real> FeasibilityLimits<T> {
    /// Checks every field's range (see the field docs).
    pub fn validate(&self) -> Result<(), ControlError> {
        let zero = T::zero();
        let ok = self.stroke_margin_m.is_finite()
            && self.stroke_margin_m >= zero
            && self.max_leg_speed_m_s.is_finite()
            && self.max_leg_speed_m_s > zero
            && self.min_inverse_condition.is_finite()
            && self.min_inverse_condition >= zero
            && self.step_s.is_finite()
            && self.step_s > zero;
        if ok {
            Ok(())
        } else {
            Err(ControlError::InvalidConfig {
                parameter: "feasibility",
                reason: "margin >= 0, speed > 0, inverse condition >= 0, step > 0, all finite",
            })
        }
    }
}

/// What a passed check saw: the extremes over the whole trajectory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeasibilityReport<T = f64> {
    /// Samples evaluated.
    pub samples: u64,
    /// Sampling step used, s.
    pub step_s: T,
    /// Shortest length of each leg, m.
    pub min_length_m: [T; LEG_COUNT],
    /// Longest length of each leg, m.
    pub max_length_m: [T; LEG_COUNT],
    /// Largest |speed| of each leg, m/s.
    pub max_speed_m_s: [T; LEG_COUNT],
    /// Smallest inverse condition number seen.
    pub min_inverse_condition: T,
    /// When it was seen, s.
    pub min_inverse_condition_time_s: T,
}

/// More samples than this is a configuration mistake (a duration of days), not a trajectory.
const MAX_SAMPLES: f64 = 1e8;

impl<T: Real> Trajectory<T> {
    /// Samples the whole trajectory (fades included) every `step` seconds — `limits.step_s`,
    /// or less so that each period of the highest frequency gets 50 samples — and checks at
    /// each sample every leg's length against the stroke less the margin, every leg's speed
    /// `|J·[v; ω]|ᵢ` against the limit, and the inverse condition number against its
    /// threshold. The first violation is returned with its time, leg and limit.
    pub fn check_feasibility(
        &self,
        geometry: &Geometry<T>,
        limits: &FeasibilityLimits<T>,
    ) -> Result<FeasibilityReport<T>, ControlError> {
        let f_max = self.max_frequency_hz();
        let step = if f_max > T::zero() {
            limits.step_s.min(T::one() / (T::lit(50.0) * f_max))
        } else {
            limits.step_s
        };
        check_motion(geometry, limits, self.duration_s, step, |t| self.sample(t))
    }
}

impl<T: Real> Ramp<T> {
    /// The same check as [`Trajectory::check_feasibility`] for this move.
    pub fn check_feasibility(
        &self,
        geometry: &Geometry<T>,
        limits: &FeasibilityLimits<T>,
    ) -> Result<FeasibilityReport<T>, ControlError> {
        check_motion(geometry, limits, self.duration_s(), limits.step_s, |t| {
            self.sample(t)
        })
    }
}

fn check_motion<T: Real>(
    geometry: &Geometry<T>,
    limits: &FeasibilityLimits<T>,
    duration_s: T,
    step_s: T,
    sample: impl Fn(T) -> TrajectorySample<T>,
) -> Result<FeasibilityReport<T>, ControlError> {
    limits.validate()?;
    let intervals = kinematics::real::ceil(duration_s / step_s).to_f64();
    if intervals.is_nan() || intervals > MAX_SAMPLES {
        return Err(ControlError::InvalidConfig {
            parameter: "feasibility.step_s",
            reason: "gives more than 1e8 samples for this duration",
        });
    }
    let intervals = intervals as u64;
    let stroke = geometry.stroke();
    let low = stroke.min_length_m + limits.stroke_margin_m;
    let high = stroke.max_length_m - limits.stroke_margin_m;
    let mut report = FeasibilityReport {
        samples: 0,
        step_s,
        min_length_m: [T::lit(f64::INFINITY); LEG_COUNT],
        max_length_m: [T::lit(f64::NEG_INFINITY); LEG_COUNT],
        max_speed_m_s: [T::zero(); LEG_COUNT],
        min_inverse_condition: T::lit(f64::INFINITY),
        min_inverse_condition_time_s: T::zero(),
    };
    for k in 0..=intervals {
        let time_s = (T::lit(k as f64) * step_s).min(duration_s);
        let s = sample(time_s);
        if !s.pose.is_finite() {
            return Err(ControlError::NonFinite {
                what: "trajectory pose",
                index: 0,
            });
        }
        let lengths = geometry.leg_lengths(&s.pose);
        let speeds = geometry.jacobian(&s.pose) * s.twist();
        for (leg, (&length_m, &speed_m_s)) in lengths.iter().zip(speeds.iter()).enumerate() {
            if length_m < low || length_m > high {
                let limit_m = if length_m < low { low } else { high };
                return Err(ControlError::StrokeViolation {
                    time_s: time_s.to_f64(),
                    leg,
                    length_m: length_m.to_f64(),
                    limit_m: limit_m.to_f64(),
                });
            }
            if speed_m_s.abs() > limits.max_leg_speed_m_s {
                return Err(ControlError::LegSpeedViolation {
                    time_s: time_s.to_f64(),
                    leg,
                    speed_m_s: speed_m_s.to_f64(),
                    limit_m_s: limits.max_leg_speed_m_s.to_f64(),
                });
            }
        }
        for ((min_m, max_m), &length_m) in report
            .min_length_m
            .iter_mut()
            .zip(&mut report.max_length_m)
            .zip(lengths.iter())
        {
            *min_m = min_m.min(length_m);
            *max_m = max_m.max(length_m);
        }
        for (max_m_s, speed_m_s) in report.max_speed_m_s.iter_mut().zip(speeds.iter()) {
            *max_m_s = max_m_s.max(speed_m_s.abs());
        }
        let inverse_condition = geometry.inverse_condition_number(&s.pose);
        if inverse_condition.is_nan() || inverse_condition < limits.min_inverse_condition {
            return Err(ControlError::ConditioningViolation {
                time_s: time_s.to_f64(),
                inverse_condition: inverse_condition.to_f64(),
                threshold: limits.min_inverse_condition.to_f64(),
            });
        }
        if inverse_condition < report.min_inverse_condition {
            report.min_inverse_condition = inverse_condition;
            report.min_inverse_condition_time_s = time_s;
        }
        report.samples += 1;
    }
    Ok(report)
}
