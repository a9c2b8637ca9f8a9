//! Excitation trajectories: sums of sines on the six pose coordinates, faded in and out, around
//! an offset pose (the platform's home pose).
//!
//! The coordinates are `c = [x, y, z, α, β, γ]`: a translation of the P origin in B axes (m) and
//! roll, pitch, yaw (rad). The pose is
//!
//! ```text
//! p(t) = p₀ + [x, y, z]ᵀ,      R(t) = R₀ · Rx(α) · Ry(β) · Rz(γ)
//! c(t) = w(t) · Σₖ aₖ · sin(2π fₖ t + φₖ)     (components on their own axes)
//! ```
//!
//! with `w` a C² window: the quintic smoothstep `h(s) = 10s³ − 15s⁴ + 6s⁵` over the fade-in, 1 on
//! the plateau, `h` mirrored over the fade-out. Because `h`, `h′` and `h″` vanish at the window's
//! ends, pose, velocity and acceleration all start and end at rest at the offset pose, so the
//! leg forces have no step at either end.
//!
//! Velocity and acceleration are exact derivatives (no differencing). The angular velocity of
//! `Rx(α)Ry(β)Rz(γ)` in the fixed frame is `ω = α̇·eₓ + β̇·Rx eᵧ + γ̇·RxRy e_z`, and its derivative
//! `ω̇ = α̈·eₓ + β̈·Rx eᵧ + γ̈·RxRy e_z + (α̇ eₓ) × (β̇ Rx eᵧ) + (α̇ eₓ + β̇ Rx eᵧ) × (γ̇ RxRy e_z)`;
//! both are rotated by `R₀` into B.
//!
//! Two builders: [`Trajectory::paper_eq8`] (the paper's Eq. 8: `α = A₁ sin ω₁t`, `β = A₂ sin ω₂t`,
//! `γ = A₃ sin ω₃t`, no translation) and [`Trajectory::multisine`] (several harmonics of a base
//! frequency per axis, all six axes, Schroeder phases). [`Trajectory::new`] takes any components.
//! Check a trajectory with [`Trajectory::check_feasibility`] before moving.

mod feasibility;
mod ramp;

pub use feasibility::{FeasibilityLimits, FeasibilityReport};
pub use ramp::{coordinates_of, Ramp};

use kinematics::real::{self, Real};
use kinematics::{Pose, Rotation3, Vector3, Vector6};

use crate::error::ControlError;

/// Most sine components one [`Trajectory`] holds (fixed capacity: no allocation).
pub const MAX_COMPONENTS: usize = 48;

/// A pose coordinate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Translation along B's x, m.
    #[default]
    X,
    /// Translation along B's y, m.
    Y,
    /// Translation along B's z, m.
    Z,
    /// Roll α about x, rad.
    Roll,
    /// Pitch β about the once-rolled y, rad.
    Pitch,
    /// Yaw γ about the twice-turned z, rad.
    Yaw,
}

impl Axis {
    /// All six, in coordinate order.
    pub const ALL: [Axis; 6] = [
        Axis::X,
        Axis::Y,
        Axis::Z,
        Axis::Roll,
        Axis::Pitch,
        Axis::Yaw,
    ];

    /// Position in the coordinate vector `[x, y, z, α, β, γ]`.
    pub const fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
            Axis::Roll => 3,
            Axis::Pitch => 4,
            Axis::Yaw => 5,
        }
    }

    /// This axis's entry of a coordinate array ordered as [`Axis::index`] (x, y, z, roll,
    /// pitch, yaw); the match names every axis, so no index can fall outside the array.
    fn entry_mut<T>(self, coordinates: &mut [T; 6]) -> &mut T {
        let [x, y, z, roll, pitch, yaw] = coordinates;
        match self {
            Axis::X => x,
            Axis::Y => y,
            Axis::Z => z,
            Axis::Roll => roll,
            Axis::Pitch => pitch,
            Axis::Yaw => yaw,
        }
    }
}

/// One term `amplitude · sin(2π·frequency_hz·t + phase_rad)` on one axis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SineComponent<T = f64> {
    /// The coordinate it moves.
    pub axis: Axis,
    /// Amplitude, m for translations, rad for rotations.
    pub amplitude: T,
    /// Frequency, Hz (> 0).
    pub frequency_hz: T,
    /// Phase, rad.
    pub phase_rad: T,
}

/// Settings of [`Trajectory::multisine`]. Plain `Copy` data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MultiSineConfig<T = f64> {
    /// Base frequency f₀, Hz; the signal repeats every 1/f₀.
    pub base_frequency_hz: T,
    /// Harmonics per excited axis (≥ 1); the total over excited axes must not exceed
    /// [`MAX_COMPONENTS`].
    pub harmonics_per_axis: usize,
    /// Peak excursion per axis `[x, y, z, α, β, γ]` (m, m, m, rad, rad, rad); 0 leaves the axis
    /// still.
    pub peak_amplitudes: [T; 6],
    /// Total duration including the fades, s.
    pub duration_s: T,
    /// Fade-in time, s (> 0).
    pub fade_in_s: T,
    /// Fade-out time, s (> 0).
    pub fade_out_s: T,
    /// How the amplitude is shared among an axis's harmonics.
    pub spectrum: Spectrum,
}

/// Relative amplitudes of the harmonics within one axis of a multi-sine.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Spectrum {
    /// Equal amplitudes: the velocity and acceleration are dominated by the highest harmonic.
    FlatPosition,
    /// Amplitudes ∝ 1/frequency: every harmonic contributes the same velocity, which shares
    /// the leg-speed budget evenly (acceleration still grows with frequency).
    #[default]
    FlatVelocity,
}

impl<T: Real> Default for MultiSineConfig<T> {
    /// 0.1 Hz base (10 s period), 3 harmonics on each of the six axes (so harmonics 1–18, up to
    /// 1.8 Hz) with a flat velocity spectrum, peaks of 10 mm and 0.04 rad, 44 s with 2 s fades
    /// (four periods on the plateau). On a rig with 1.5 m / 1.2 m joint circles this asks
    /// at most 0.36 m/s of the legs.
    fn default() -> Self {
        Self {
            base_frequency_hz: T::lit(0.1),
            harmonics_per_axis: 3,
            peak_amplitudes: [0.01, 0.01, 0.01, 0.04, 0.04, 0.04].map(T::lit),
            duration_s: T::lit(44.0),
            fade_in_s: T::lit(2.0),
            fade_out_s: T::lit(2.0),
            spectrum: Spectrum::FlatVelocity,
        }
    }
}

/// Pose, velocity and acceleration of a trajectory at one instant.
#[derive(Clone, Copy, Debug)]
pub struct TrajectorySample<T = f64> {
    /// Desired pose of P in B.
    pub pose: Pose<T>,
    /// Coordinates `[x, y, z, α, β, γ]` relative to the offset pose.
    pub coordinates: Vector6<T>,
    /// Their time derivatives.
    pub coordinate_rates: Vector6<T>,
    /// Their second time derivatives.
    pub coordinate_accelerations: Vector6<T>,
    /// Velocity of the P origin, in B, m/s.
    pub velocity_m_s: Vector3<T>,
    /// Angular velocity of P, in B, rad/s.
    pub angular_velocity_rad_s: Vector3<T>,
    /// Acceleration of the P origin, in B, m/s².
    pub acceleration_m_s2: Vector3<T>,
    /// Angular acceleration of P, in B, rad/s².
    pub angular_acceleration_rad_s2: Vector3<T>,
}

// Written out: the derive would ask only `T: PartialEq`, and a pose compares for a `Real`.
impl<T: Real> PartialEq for TrajectorySample<T> {
    fn eq(&self, other: &Self) -> bool {
        self.pose == other.pose
            && self.coordinates == other.coordinates
            && self.coordinate_rates == other.coordinate_rates
            && self.coordinate_accelerations == other.coordinate_accelerations
            && self.velocity_m_s == other.velocity_m_s
            && self.angular_velocity_rad_s == other.angular_velocity_rad_s
            && self.acceleration_m_s2 == other.acceleration_m_s2
            && self.angular_acceleration_rad_s2 == other.angular_acceleration_rad_s2
    }
}

impl<T: Real> TrajectorySample<T> {
    /// `[v; ω]` in B, the twist that [`kinematics::Geometry::jacobian`] maps to leg rates.
    pub fn twist(&self) -> Vector6<T> {
        let (v, w) = (self.velocity_m_s, self.angular_velocity_rad_s);
        Vector6::new(v.x, v.y, v.z, w.x, w.y, w.z)
    }

    /// The sample for coordinates `c` and their derivatives about `offset` (see the
    /// [module docs](self) for the formulas).
    pub fn from_coordinates(
        offset: &Pose<T>,
        c: &Vector6<T>,
        rates: &Vector6<T>,
        accelerations: &Vector6<T>,
    ) -> Self {
        let [x, y, z, roll, pitch, yaw]: [T; 6] = (*c).into();
        let [vx, vy, vz, roll_rate, pitch_rate, yaw_rate]: [T; 6] = (*rates).into();
        let [ax, ay, az, roll_acc, pitch_acc, yaw_acc]: [T; 6] = (*accelerations).into();
        let relative = Pose::from_rpy(Vector3::zeros(), roll, pitch, yaw).rotation;
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), roll);
        let pitch_axis = rx * Vector3::y();
        let yaw_axis = Vector3::new(
            real::sin(pitch),
            -real::sin(roll) * real::cos(pitch),
            real::cos(roll) * real::cos(pitch),
        );
        let roll_part = Vector3::x() * roll_rate;
        let roll_pitch = roll_part + pitch_axis * pitch_rate;
        let omega = roll_pitch + yaw_axis * yaw_rate;
        let omega_dot = Vector3::x() * roll_acc
            + pitch_axis * pitch_acc
            + yaw_axis * yaw_acc
            + roll_part.cross(&(pitch_axis * pitch_rate))
            + roll_pitch.cross(&(yaw_axis * yaw_rate));
        let r0 = offset.rotation;
        Self {
            pose: Pose::new(offset.position_m + Vector3::new(x, y, z), r0 * relative),
            coordinates: *c,
            coordinate_rates: *rates,
            coordinate_accelerations: *accelerations,
            velocity_m_s: Vector3::new(vx, vy, vz),
            angular_velocity_rad_s: r0 * omega,
            acceleration_m_s2: Vector3::new(ax, ay, az),
            angular_acceleration_rad_s2: r0 * omega_dot,
        }
    }
}

/// Quintic smoothstep `h(s) = 10s³ − 15s⁴ + 6s⁵` on [0, 1] with its first two derivatives
/// (with respect to s); 0 below, 1 above, so that `h, h′, h″` are continuous everywhere.
pub fn smoothstep<T: Real>(s: T) -> (T, T, T) {
    let (zero, one) = (T::zero(), T::one());
    let k = T::lit;
    if s <= zero {
        (zero, zero, zero)
    } else if s >= one {
        (one, zero, zero)
    } else {
        let s2 = s * s;
        (
            s2 * s * (k(10.0) - k(15.0) * s + k(6.0) * s2),
            k(30.0) * s2 * (one - k(2.0) * s + s2),
            k(60.0) * s * (one - k(3.0) * s + k(2.0) * s2),
        )
    }
}

/// A sum of sines per axis with a C² fade-in and fade-out around an offset pose. See the
/// [module docs](self).
#[derive(Clone, Copy, Debug)]
pub struct Trajectory<T = f64> {
    offset: Pose<T>,
    components: [SineComponent<T>; MAX_COMPONENTS],
    count: usize,
    duration_s: T,
    fade_in_s: T,
    fade_out_s: T,
}

// Written out: the derive would ask only `T: PartialEq`, and a pose compares for a `Real`.
impl<T: Real> PartialEq for Trajectory<T> {
    fn eq(&self, other: &Self) -> bool {
        self.offset == other.offset
            && self.components == other.components
            && self.count == other.count
            && self.duration_s == other.duration_s
            && self.fade_in_s == other.fade_in_s
            && self.fade_out_s == other.fade_out_s
    }
}

impl<T: Real> Trajectory<T> {
    /// A trajectory of the given components. Errors: more than [`MAX_COMPONENTS`], a
    /// non-finite amplitude or phase, a non-positive frequency, a non-finite offset, fades not
    /// positive, or fades longer together than the duration.
    pub fn new(
        offset: Pose<T>,
        components: &[SineComponent<T>],
        duration_s: T,
        fade_in_s: T,
        fade_out_s: T,
    ) -> Result<Self, ControlError> {
        if components.len() > MAX_COMPONENTS {
            return Err(ControlError::TooManyComponents {
                max: MAX_COMPONENTS,
            });
        }
        if !offset.is_finite() {
            return Err(ControlError::NonFinite {
                what: "trajectory offset pose",
                index: 0,
            });
        }
        for (index, c) in components.iter().enumerate() {
            if !c.amplitude.is_finite() || !c.phase_rad.is_finite() {
                return Err(ControlError::NonFinite {
                    what: "trajectory component",
                    index,
                });
            }
            if !c.frequency_hz.is_finite() || c.frequency_hz <= T::zero() {
                return Err(ControlError::InvalidConfig {
                    parameter: "trajectory.frequency_hz",
                    reason: "must be finite and > 0",
                });
            }
        }
        if !(fade_in_s.is_finite()
            && fade_in_s > T::zero()
            && fade_out_s.is_finite()
            && fade_out_s > T::zero())
        {
            return Err(ControlError::InvalidConfig {
                parameter: "trajectory.fade_in_s/fade_out_s",
                reason: "must be finite and > 0",
            });
        }
        if !duration_s.is_finite() || fade_in_s + fade_out_s > duration_s {
            return Err(ControlError::InvalidConfig {
                parameter: "trajectory.duration_s",
                reason: "must be finite and at least fade_in_s + fade_out_s",
            });
        }
        let mut stored = [SineComponent::default(); MAX_COMPONENTS];
        for (slot, c) in stored.iter_mut().zip(components) {
            *slot = *c;
        }
        Ok(Self {
            offset,
            components: stored,
            count: components.len(),
            duration_s,
            fade_in_s,
            fade_out_s,
        })
    }

    /// The paper's Eq. 8: `α = A₁ sin(2π f₁ t)`, `β = A₂ sin(2π f₂ t)`, `γ = A₃ sin(2π f₃ t)`,
    /// `x = y = z = 0` (relative to `offset`), with the fades of this module.
    pub fn paper_eq8(
        offset: Pose<T>,
        amplitudes_rad: [T; 3],
        frequencies_hz: [T; 3],
        duration_s: T,
        fade_s: T,
    ) -> Result<Self, ControlError> {
        let [a_roll, a_pitch, a_yaw] = amplitudes_rad;
        let [f_roll, f_pitch, f_yaw] = frequencies_hz;
        let sine = |axis, amplitude, frequency_hz| SineComponent {
            axis,
            amplitude,
            frequency_hz,
            phase_rad: T::zero(),
        };
        let components = [
            sine(Axis::Roll, a_roll, f_roll),
            sine(Axis::Pitch, a_pitch, f_pitch),
            sine(Axis::Yaw, a_yaw, f_yaw),
        ];
        Self::new(offset, &components, duration_s, fade_s, fade_s)
    }

    /// A periodic multi-sine on every axis with a non-zero peak. Harmonics of f₀ are dealt out
    /// to the excited axes in turn (axis j of n gets harmonics j+1, j+1+n, j+1+2n, …), so no two
    /// axes share a frequency and the axes are uncorrelated over a period, which keeps the
    /// identification regressor well conditioned. Within an axis the K harmonics get relative
    /// amplitudes by [`Spectrum`] and Schroeder's low-crest-factor phases (Schroeder, IEEE
    /// Trans. Inf. Theory 16, 1970; for equal amplitudes on consecutive harmonics
    /// `φₖ = −π·k(k−1)/K`, here generalised to the axis's spaced harmonics), refined by a short
    /// coordinate search on the grid peak (two sweeps over each phase in steps of 30°; only
    /// accepted when the peak drops). The amplitudes are then
    /// scaled so that the axis's peak over one period (found on a grid of 64 points per period
    /// of its highest harmonic) equals the requested peak. The fade window only lowers the
    /// peak (the fade adds velocity, though: check the result with
    /// [`Trajectory::check_feasibility`]).
    pub fn multisine(offset: Pose<T>, config: &MultiSineConfig<T>) -> Result<Self, ControlError> {
        let f0 = config.base_frequency_hz;
        if !f0.is_finite() || f0 <= T::zero() {
            return Err(ControlError::InvalidConfig {
                parameter: "multisine.base_frequency_hz",
                reason: "must be finite and > 0",
            });
        }
        let k_per_axis = config.harmonics_per_axis;
        if k_per_axis == 0 {
            return Err(ControlError::InvalidConfig {
                parameter: "multisine.harmonics_per_axis",
                reason: "must be >= 1",
            });
        }
        for (index, &peak) in config.peak_amplitudes.iter().enumerate() {
            if !peak.is_finite() || peak < T::zero() {
                return Err(ControlError::NonFinite {
                    what: "multisine peak amplitude (finite, >= 0)",
                    index,
                });
            }
        }
        let excited = config
            .peak_amplitudes
            .iter()
            .filter(|&&a| a > T::zero())
            .count();
        if excited.saturating_mul(k_per_axis) > MAX_COMPONENTS {
            return Err(ControlError::TooManyComponents {
                max: MAX_COMPONENTS,
            });
        }
        let mut components = [SineComponent::default(); MAX_COMPONENTS];
        let mut count = 0;
        let excited_axes = Axis::ALL
            .iter()
            .zip(config.peak_amplitudes)
            .filter(|(_, peak)| *peak > T::zero());
        for (slot, (&axis, peak)) in excited_axes.enumerate() {
            let first = count;
            for k in 1..=k_per_axis {
                let harmonic = T::lit((slot + 1 + (k - 1) * excited) as f64);
                if let Some(c) = components.get_mut(count) {
                    *c = SineComponent {
                        axis,
                        amplitude: match config.spectrum {
                            Spectrum::FlatPosition => T::one(),
                            Spectrum::FlatVelocity => T::one() / harmonic,
                        },
                        frequency_hz: f0 * harmonic,
                        phase_rad: T::zero(),
                    };
                    count += 1;
                }
            }
            let axis_components = components.get_mut(first..count).unwrap_or_default();
            schroeder_phases(axis_components, f0);
            refine_phases(axis_components, f0);
            let unit_peak = peak_over_period(axis_components, f0);
            let scale = if unit_peak > T::zero() {
                peak / unit_peak
            } else {
                T::zero()
            };
            for c in axis_components.iter_mut() {
                c.amplitude *= scale;
            }
        }
        Self::new(
            offset,
            components.get(..count).unwrap_or_default(),
            config.duration_s,
            config.fade_in_s,
            config.fade_out_s,
        )
    }

    /// The offset (home) pose the motion is centred on.
    pub fn offset(&self) -> &Pose<T> {
        &self.offset
    }

    /// The sine components.
    pub fn components(&self) -> &[SineComponent<T>] {
        self.components.get(..self.count).unwrap_or_default()
    }

    /// Total duration including the fades, s.
    pub fn duration_s(&self) -> T {
        self.duration_s
    }

    /// Fade-in and fade-out times, s.
    pub fn fades_s(&self) -> (T, T) {
        (self.fade_in_s, self.fade_out_s)
    }

    /// Highest component frequency, Hz (0 without components).
    pub fn max_frequency_hz(&self) -> T {
        self.components().iter().fold(T::zero(), |m, c| {
            if c.frequency_hz > m {
                c.frequency_hz
            } else {
                m
            }
        })
    }

    /// The window `w(t)` and its first two time derivatives.
    pub fn window(&self, t_s: T) -> (T, T, T) {
        let zero = T::zero();
        if !(t_s > zero && t_s < self.duration_s) {
            return (zero, zero, zero);
        }
        let (fin, fout) = (self.fade_in_s, self.fade_out_s);
        let (a, da, dda) = smoothstep(t_s / fin);
        let (b, db, ddb) = smoothstep((self.duration_s - t_s) / fout);
        // Both factors are 1 on the plateau and the fades do not overlap, so the product is the
        // window and its derivatives follow by the product rule.
        let (da, dda) = (da / fin, dda / (fin * fin));
        let (db, ddb) = (-db / fout, ddb / (fout * fout));
        (
            a * b,
            da * b + a * db,
            dda * b + T::lit(2.0) * da * db + a * ddb,
        )
    }

    /// Coordinates relative to the offset and their first two derivatives at `t_s` (0 outside
    /// `[0, duration]`).
    pub fn coordinates(&self, t_s: T) -> (Vector6<T>, Vector6<T>, Vector6<T>) {
        let zero = T::zero();
        let mut g = [zero; 6];
        let mut dg = [zero; 6];
        let mut ddg = [zero; 6];
        let (w, dw, ddw) = self.window(t_s);
        if w == zero && dw == zero && ddw == zero {
            return (Vector6::zeros(), Vector6::zeros(), Vector6::zeros());
        }
        let two_pi = T::lit(2.0) * real::pi::<T>();
        for c in self.components() {
            let omega = two_pi * c.frequency_hz;
            let angle = omega * t_s + c.phase_rad;
            let (s, co) = (real::sin(angle), real::cos(angle));
            *c.axis.entry_mut(&mut g) += c.amplitude * s;
            *c.axis.entry_mut(&mut dg) += c.amplitude * omega * co;
            *c.axis.entry_mut(&mut ddg) -= c.amplitude * omega * omega * s;
        }
        let (g, dg, ddg) = (Vector6::from(g), Vector6::from(dg), Vector6::from(ddg));
        (
            g * w,
            g * dw + dg * w,
            g * ddw + dg * (T::lit(2.0) * dw) + ddg * w,
        )
    }

    /// Pose, velocity and acceleration at trajectory time `t_s` (the offset pose at rest
    /// outside `[0, duration]`).
    pub fn sample(&self, t_s: T) -> TrajectorySample<T> {
        let (c, dc, ddc) = self.coordinates(t_s);
        TrajectorySample::from_coordinates(&self.offset, &c, &dc, &ddc)
    }
}

/// Schroeder's phases for components in increasing frequency: each harmonic is placed where a
/// chirp sweeping the band once per period, spending time in proportion to power, passes its
/// frequency. With power shares `p_l = a_l²/Σa²` and harmonic numbers `m_k = f_k/f₀`:
/// `φ₁ = 0`, `φ_{k+1} = φ_k − 2π·(m_{k+1} − m_k)·Σ_{l≤k} p_l`, which for consecutive harmonics is
/// Schroeder's `φₖ = −2π·Σ_{l<k} (k − l)·p_l`.
fn schroeder_phases<T: Real>(components: &mut [SineComponent<T>], f0: T) {
    let total: T = components.iter().map(|c| c.amplitude * c.amplitude).sum();
    if total <= T::zero() {
        return;
    }
    let two_pi = T::lit(2.0) * real::pi::<T>();
    let mut share_sum = T::zero();
    let mut phase = T::zero();
    let mut previous_hz: Option<T> = None;
    for c in components.iter_mut() {
        if let Some(f) = previous_hz {
            let spacing = (c.frequency_hz - f) / f0;
            phase = real::remainder(phase - two_pi * spacing * share_sum, two_pi);
        }
        c.phase_rad = phase;
        share_sum += c.amplitude * c.amplitude / total;
        previous_hz = Some(c.frequency_hz);
    }
}

/// Lowers the crest factor from Schroeder's start: for each phase but the first (a common
/// phase shift only moves the signal in time), try the other eleven multiples of 30° added to
/// it and keep any that lowers the grid peak; two sweeps. Deterministic, construction time only.
fn refine_phases<T: Real>(components: &mut [SineComponent<T>], f0: T) {
    let mut best = peak_over_period(components, f0);
    for _sweep in 0..2 {
        for index in 1..components.len() {
            let Some(original) = components.get(index).map(|c| c.phase_rad) else {
                continue;
            };
            let mut chosen = original;
            for step in 1..12 {
                let candidate = original + real::pi::<T>() * T::lit(f64::from(step)) / T::lit(6.0);
                if let Some(c) = components.get_mut(index) {
                    c.phase_rad = candidate;
                }
                let peak = peak_over_period(components, f0);
                if peak < best {
                    best = peak;
                    chosen = candidate;
                }
            }
            if let Some(c) = components.get_mut(index) {
                c.phase_rad = real::remainder(chosen, T::lit(2.0) * real::pi::<T>());
            }
        }
    }
}

/// Largest |Σ aₖ sin(2π fₖ t + φₖ)| over one period 1/f₀, on a grid of 64 points per period of
/// the highest harmonic (at most 64·[`MAX_COMPONENTS`]·… points; bounded by the harmonic
/// numbers, which are at most [`MAX_COMPONENTS`]).
fn peak_over_period<T: Real>(components: &[SineComponent<T>], f0: T) -> T {
    let f_max = components.iter().fold(f0, |m, c| {
        if c.frequency_hz > m {
            c.frequency_hz
        } else {
            m
        }
    });
    let steps = 64 * real::ceil(f_max / f0).to_f64() as usize;
    let period = T::one() / f0;
    let two_pi = T::lit(2.0) * real::pi::<T>();
    let mut peak = T::zero();
    for n in 0..steps {
        let t = period * T::lit(n as f64) / T::lit(steps as f64);
        let value: T = components
            .iter()
            .map(|c| c.amplitude * real::sin(two_pi * c.frequency_hz * t + c.phase_rad))
            .sum();
        peak = peak.max(value.abs());
    }
    peak
}

#[cfg(test)]
mod tests;
