//! Smooth moves to the offset pose (settle from wherever the platform rests, park after the
//! excitation or an abort).

use kinematics::{Pose, Real, Vector3, Vector6};

use super::TrajectorySample;
use crate::error::ControlError;

/// A minimum-jerk (quintic) move of the coordinates `[x, y, z, α, β, γ]` from a start state
/// `(c₀, ċ₀, c̈₀)` to rest at the offset pose (all zero) in `T` seconds:
///
/// ```text
/// c(s) = c₀ + d₁ s + d₂/2 s² + a₃ s³ + a₄ s⁴ + a₅ s⁵,   s = t/T,  d₁ = ċ₀T,  d₂ = c̈₀T²
/// a₃ = −10c₀ − 6d₁ − 3/2·d₂,  a₄ = 15c₀ + 8d₁ + 3/2·d₂,  a₅ = −6c₀ − 3d₁ − 1/2·d₂
/// ```
///
/// which matches position, velocity and acceleration at both ends (for a start at rest it is
/// `c₀·(1 − h(s))` with the quintic smoothstep `h`). After `T` it holds the offset pose. A
/// ramp may also end at rest at coordinates `c_T ≠ 0` ([`Ramp::brake`]): the same polynomial in
/// `c − c_T`.
#[derive(Clone, Copy, Debug)]
pub struct Ramp<T = f64> {
    offset: Pose<T>,
    /// Polynomial coefficients in s, lowest order first.
    coefficients: [Vector6<T>; 6],
    /// Where the ramp comes to rest, coordinates relative to `offset`.
    target: Vector6<T>,
    duration_s: T,
}

// Written out: the derive would ask only `T: PartialEq`, and a pose compares for a `Real`.
impl<T: Real> PartialEq for Ramp<T> {
    fn eq(&self, other: &Self) -> bool {
        self.offset == other.offset
            && self.coefficients == other.coefficients
            && self.target == other.target
            && self.duration_s == other.duration_s
    }
}

impl<T: Real> Ramp<T> {
    /// From the state `(c₀, ċ₀, c̈₀)`, given as coordinates relative to `offset`, to rest at
    /// `offset` in `duration_s` (> 0).
    pub fn from_state(
        offset: Pose<T>,
        start: &Vector6<T>,
        rate: &Vector6<T>,
        acceleration: &Vector6<T>,
        duration_s: T,
    ) -> Result<Self, ControlError> {
        Self::to_rest_at(
            offset,
            start,
            rate,
            acceleration,
            Vector6::zeros(),
            duration_s,
        )
    }

    /// From the state `(c₀, ċ₀, c̈₀)` to a stop in `T = duration_s`, ending where the smooth
    /// cubic speed profile `ċ(s) = ċ₀(1 − 3s² + 2s³) + c̈₀T(s − 2s² + s³)` takes it:
    /// `c_T = c₀ + ċ₀T/2 + c̈₀T²/12`. The speed never exceeds `|ċ₀| + |c̈₀|T·4/27` on any
    /// coordinate and the deceleration is about `1.5|ċ₀|/T`: a stop from full speed that does
    /// not first swing back towards the offset (which a ramp straight to the offset does when
    /// the motion is heading away from it).
    pub fn brake(
        offset: Pose<T>,
        start: &Vector6<T>,
        rate: &Vector6<T>,
        acceleration: &Vector6<T>,
        duration_s: T,
    ) -> Result<Self, ControlError> {
        let target = start
            + rate * (T::lit(0.5) * duration_s)
            + acceleration * (duration_s * duration_s / T::lit(12.0));
        Self::to_rest_at(offset, start, rate, acceleration, target, duration_s)
    }

    /// The quintic from `(c₀, ċ₀, c̈₀)` to rest at `c_T = target`.
    fn to_rest_at(
        offset: Pose<T>,
        start: &Vector6<T>,
        rate: &Vector6<T>,
        acceleration: &Vector6<T>,
        target: Vector6<T>,
        duration_s: T,
    ) -> Result<Self, ControlError> {
        if !duration_s.is_finite() || duration_s <= T::zero() {
            return Err(ControlError::InvalidConfig {
                parameter: "ramp duration",
                reason: "must be finite and > 0",
            });
        }
        let all_finite = start.iter().chain(rate.iter()).chain(acceleration.iter());
        if let Some(index) = all_finite.clone().position(|v| !v.is_finite()) {
            return Err(ControlError::NonFinite {
                what: "ramp start state",
                index,
            });
        }
        if !offset.is_finite() {
            return Err(ControlError::NonFinite {
                what: "ramp offset pose",
                index: 0,
            });
        }
        let c0 = start - target;
        let d1 = rate * duration_s;
        let d2 = acceleration * (duration_s * duration_s);
        let k = T::lit;
        Ok(Self {
            offset,
            coefficients: [
                *start,
                d1,
                d2 * k(0.5),
                c0 * k(-10.0) - d1 * k(6.0) - d2 * k(1.5),
                c0 * k(15.0) + d1 * k(8.0) + d2 * k(1.5),
                c0 * k(-6.0) - d1 * k(3.0) - d2 * k(0.5),
            ],
            target,
            duration_s,
        })
    }

    /// From `pose`, at rest, to rest at `offset`. The start coordinates are the translation
    /// `p − p₀` and the roll, pitch, yaw of `R₀ᵀR`.
    pub fn from_pose(offset: Pose<T>, pose: &Pose<T>, duration_s: T) -> Result<Self, ControlError> {
        let zero = Vector6::zeros();
        Self::from_state(
            offset,
            &coordinates_of(&offset, pose),
            &zero,
            &zero,
            duration_s,
        )
    }

    /// Where the ramp comes to rest: coordinates relative to the offset (zero for a ramp to the
    /// offset).
    pub fn target(&self) -> &Vector6<T> {
        &self.target
    }

    /// Length of the move, s.
    pub fn duration_s(&self) -> T {
        self.duration_s
    }

    /// Pose, velocity and acceleration at `t_s` after the start (the start state before 0,
    /// the offset at rest after the end).
    pub fn sample(&self, t_s: T) -> TrajectorySample<T> {
        let (zero, one, k) = (T::zero(), T::one(), T::lit);
        let s = (t_s / self.duration_s).clamp(zero, one);
        let [a0, a1, a2, a3, a4, a5] = &self.coefficients;
        let c = a0 + (a1 + (a2 + (a3 + (a4 + a5 * s) * s) * s) * s) * s;
        let (dc, ddc) = if s >= one {
            (Vector6::zeros(), Vector6::zeros())
        } else {
            let ds =
                a1 + (a2 * k(2.0) + (a3 * k(3.0) + (a4 * k(4.0) + a5 * (k(5.0) * s)) * s) * s) * s;
            let dds = a2 * k(2.0) + (a3 * k(6.0) + (a4 * k(12.0) + a5 * (k(20.0) * s)) * s) * s;
            let t = self.duration_s;
            (ds / t, dds / (t * t))
        };
        // At s = 1 the polynomial is the target up to rounding; return it exactly.
        let c = if s >= one { self.target } else { c };
        TrajectorySample::from_coordinates(&self.offset, &c, &dc, &ddc)
    }
}

/// Coordinates `[x, y, z, α, β, γ]` of `pose` relative to `offset`: `p − p₀` and the roll,
/// pitch, yaw of `R₀ᵀR` (so that [`TrajectorySample::from_coordinates`] gives `pose` back).
pub fn coordinates_of<T: Real>(offset: &Pose<T>, pose: &Pose<T>) -> Vector6<T> {
    let d: Vector3<T> = pose.position_m - offset.position_m;
    let relative = Pose::new(
        Vector3::zeros(),
        offset.rotation.transpose() * pose.rotation,
    );
    let (roll, pitch, yaw) = relative.rpy();
    Vector6::new(d.x, d.y, d.z, roll, pitch, yaw)
}
