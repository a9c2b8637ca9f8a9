//! The PID and the trajectories computed in f32 and in f64, compared within tolerances derived
//! from f32's precision. Each case is one generic function run for both scalars, returning f64.
//!
//! The inputs are exactly representable in f32 (drawn in f64 and rounded through f32), so the
//! comparison measures the arithmetic, not the rounding of the inputs: a leg length near 1.9 m
//! given in f32 is itself quantised to 1.2e-7 m, which a PID turns into kp·1.2e-7 m = 0.12 N
//! at the default kp (docs/firmware.md).
//!
//! u = 2⁻²⁴ ≈ 6.0e-8 is f32's unit roundoff.

use kinematics::{Geometry, Pose, Real, StrokeLimits, Vector6};

use crate::pid::{AntiWindup, PidBank, PidConfig, PidOutput};
use crate::trajectory::{FeasibilityLimits, MultiSineConfig, Ramp, SineComponent, Trajectory};

/// f32's unit roundoff.
const U: f64 = 5.960_464_477_539_063e-8;

/// `value` rounded through f32: exactly representable in both precisions.
fn exact(value: f64) -> f64 {
    f64::from(f32::lit(value))
}

fn geometry<T: Real>() -> Geometry<T> {
    let stroke = StrokeLimits {
        min_length_m: T::lit(1.5),
        max_length_m: T::lit(2.3),
    };
    match Geometry::from_radii(T::lit(1.5), T::lit(1.2), T::lit(0.35), T::lit(0.35), stroke) {
        Ok(g) => g,
        Err(e) => panic!("{e}"),
    }
}

/// The f64 home pose rounded through f32, so that both precisions start from the same pose.
fn home() -> Pose {
    geometry::<f64>().home_pose().cast::<f32>().cast()
}

fn widen_output<T: Real>(o: &PidOutput<T>) -> PidOutput {
    PidOutput {
        p: o.p.to_f64(),
        i: o.i.to_f64(),
        d: o.d.to_f64(),
        feedforward: o.feedforward.to_f64(),
        output: o.output.to_f64(),
        saturated: o.saturated,
    }
}

/// A PID bank in `T` fed one step response: each step's terms of leg 0, in f64.
fn pid_case<T: Real>(
    config: &PidConfig,
    setpoint_m: f64,
    measurements_m: &[f64],
) -> Vec<PidOutput> {
    let mut bank = match PidBank::uniform(config.cast::<T>()) {
        Ok(bank) => bank,
        Err(e) => panic!("{e}"),
    };
    let feedforward = [T::lit(exact(2500.0)); 6];
    measurements_m
        .iter()
        .map(|&y| {
            let r = [T::lit(setpoint_m); 6];
            let y = [T::lit(y); 6];
            match bank.update(&r, &y, &feedforward, T::lit(1e-3)) {
                Ok([first, ..]) => widen_output(&first),
                Err(e) => panic!("{e}"),
            }
        })
        .collect()
}

#[test]
fn pid_terms_in_f32_match_f64_through_a_saturating_step() {
    // A 30 mm set-point step (P = 30 kN: the ±20 kN output saturates for the first steps) with
    // the leg following as a damped second-order response from 1.9 m, 1000 steps of 1 ms.
    // Tolerances per term, with the inputs exact in f32:
    // * P = kp·e: e = r − y is exact in both (Sterbenz: r and y within a factor 2), kp = 1e6 is
    //   exact in f32, so |δP| ≤ u·|P|.
    // * D = (T_f·D' − kd·Δy)/(T_f + dt): Δy exact; T_f, dt and kd rounded (u each) and four
    //   roundings, so each step adds ≤ 8u·|D|max, and the old error decays by a = T_f/(T_f+dt)
    //   = 2/3: |δD| ≤ 8u·|D|max/(1 − a) = 24u·|D|max.
    // * I accumulates ki·dt·e (and the back-calculation term) over N = 1000 steps, each sum
    //   rounding by ≤ 4u·(|I|max + |ΔI|max), nothing pulling it back (the loop is open here):
    //   |δI| ≤ 4u·N·(|I|max + |ΔI|max) ≈ 2.4e-4·|I|max.
    // * the output sums them: the sum of the three bounds plus 4u·|F|max.
    let steps = 1000;
    let measurements: Vec<f64> = (0..steps)
        .map(|k| {
            let t = f64::from(k) * 1e-3;
            let (omega, zeta) = (60.0_f64, 0.5_f64);
            let wd = omega * (1.0 - zeta * zeta).sqrt();
            let response = 1.0
                - (-zeta * omega * t).exp() * ((wd * t).cos() + zeta * omega / wd * (wd * t).sin());
            exact(1.9 + 0.03 * response + 2e-4 * (37.0 * t).sin())
        })
        .collect();
    let setpoint = exact(1.93);
    let anti_windups = [
        AntiWindup::BackCalculation {
            tracking_time_s: 0.02,
        },
        AntiWindup::Clamping,
        AntiWindup::None,
    ];
    for anti_windup in anti_windups {
        let config = PidConfig {
            anti_windup,
            ..PidConfig::default()
        };
        let single = pid_case::<f32>(&config, setpoint, &measurements);
        let double = pid_case::<f64>(&config, setpoint, &measurements);
        let max =
            |f: fn(&PidOutput) -> f64| double.iter().map(f).fold(0.0_f64, |m, v| m.max(v.abs()));
        let worst = |f: fn(&PidOutput) -> f64| {
            single
                .iter()
                .zip(&double)
                .map(|(a, b)| (f(a) - f(b)).abs())
                .fold(0.0_f64, f64::max)
        };
        let (p_max, i_max, d_max, out_max) =
            (max(|o| o.p), max(|o| o.i), max(|o| o.d), max(|o| o.output));
        let di_max = double
            .windows(2)
            .map(|w| (w[1].i - w[0].i).abs())
            .fold(0.0_f64, f64::max);
        let bound_p = U * p_max;
        let bound_d = 24.0 * U * d_max;
        let bound_i = 4.0 * U * f64::from(steps) * (i_max + di_max);
        let bound_out = bound_p + bound_d + bound_i + 4.0 * U * out_max;
        let (dp, di, dd, dout) = (
            worst(|o| o.p),
            worst(|o| o.i),
            worst(|o| o.d),
            worst(|o| o.output),
        );
        eprintln!(
            "PID f32 − f64 ({anti_windup:?}): P {dp:.1e} N (≤ {bound_p:.1e}), I {di:.1e} N (≤ {bound_i:.1e}), \
             D {dd:.1e} N (≤ {bound_d:.1e}), output {dout:.1e} N (≤ {bound_out:.1e}); |P| ≤ {p_max:.0} N, \
             |I| ≤ {i_max:.0} N, |D| ≤ {d_max:.0} N"
        );
        assert!(dp <= bound_p, "P {dp:e} > {bound_p:e}");
        assert!(dd <= bound_d, "D {dd:e} > {bound_d:e}");
        assert!(di <= bound_i, "I {di:e} > {bound_i:e}");
        assert!(dout <= bound_out, "output {dout:e} > {bound_out:e}");
        // Saturation is decided the same way wherever the output is not within rounding of a
        // limit.
        for (a, b) in single.iter().zip(&double) {
            if (b.output.abs() - 20_000.0).abs() > bound_out {
                assert_eq!(a.saturated, b.saturated);
            }
        }
        // The step saturated and the terms all took part, so the comparison covered them.
        assert!(double.iter().any(|o| o.saturated));
        assert!(
            p_max > 1e4 && i_max > 1e2 && d_max > 1e2,
            "{p_max} {i_max} {d_max}"
        );
    }
}

/// The six coordinates, their rates and accelerations of `trajectory` (built in f64, its
/// components rounded through f32) sampled in `T` at the f32-exact times `times_s`.
fn sine_case<T: Real>(components: &[SineComponent], times_s: &[f64]) -> Vec<[Vector6<f64>; 3]> {
    let components: Vec<SineComponent<T>> = components
        .iter()
        .map(|c| SineComponent {
            axis: c.axis,
            amplitude: T::lit(c.amplitude),
            frequency_hz: T::lit(c.frequency_hz),
            phase_rad: T::lit(c.phase_rad),
        })
        .collect();
    let trajectory = match Trajectory::new(
        home().cast(),
        &components,
        T::lit(44.0),
        T::lit(2.0),
        T::lit(2.0),
    ) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    times_s
        .iter()
        .map(|&t| {
            let (c, dc, ddc) = trajectory.coordinates(T::lit(t));
            [c, dc, ddc].map(|v| v.map(T::to_f64))
        })
        .collect()
}

#[test]
fn multisine_in_f32_matches_f64() {
    // Each component's angle ω t + φ is rounded twice (product, sum) and 2π·f once more: its
    // error is ≤ 4u·(ω t_max + |φ|), ≈ 4u·(2π·1.8 Hz·44 s + π) ≈ 1.2e-4 rad at the end of the
    // default run (the angle grows with time, so f32's absolute resolution of it shrinks:
    // the reason a long excitation should keep t small, e.g. wrap it per period). A coordinate
    // then errs by ≤ Σ aₖ·δangleₖ (plus the window's few u), its rate by Σ aₖωₖ·δangleₖ, its
    // acceleration by Σ aₖωₖ²·δangleₖ; the bound below sums those per axis, doubled for the
    // window's product and the sums' own roundings.
    let trajectory = match Trajectory::multisine(home(), &MultiSineConfig::default()) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let components: Vec<SineComponent> = trajectory
        .components()
        .iter()
        .map(|c| SineComponent {
            amplitude: exact(c.amplitude),
            frequency_hz: exact(c.frequency_hz),
            phase_rad: exact(c.phase_rad),
            ..*c
        })
        .collect();
    let times: Vec<f64> = (0..44 * 64).map(|k| f64::from(k) / 64.0).collect();
    let single = sine_case::<f32>(&components, &times);
    let double = sine_case::<f64>(&components, &times);
    for (order, name) in ["coordinate", "rate", "acceleration"].iter().enumerate() {
        for axis in 0..6 {
            let bound: f64 = 2.0
                * components
                    .iter()
                    .filter(|c| c.axis.index() == axis)
                    .map(|c| {
                        let omega = 2.0 * core::f64::consts::PI * c.frequency_hz;
                        let angle_error = 4.0 * U * (omega * 44.0 + c.phase_rad.abs());
                        c.amplitude.abs() * omega.powi(order as i32) * angle_error
                    })
                    .sum::<f64>();
            let worst = single
                .iter()
                .zip(&double)
                .map(|(a, b)| (a[order][axis] - b[order][axis]).abs())
                .fold(0.0_f64, f64::max);
            if axis == 3 {
                eprintln!("multisine f32 − f64, roll {name}: {worst:.1e} (≤ {bound:.1e})");
            }
            assert!(worst <= bound, "axis {axis} {name}: {worst:e} > {bound:e}");
        }
    }
}

#[test]
fn multisine_built_in_f32_reaches_its_peaks() {
    // The construction itself in f32 (Schroeder phases, the 30° search on a grid, the scaling
    // to the requested peak): each axis's peak over the plateau matches the request as closely
    // as the grid allows (the f64 construction meets it to the grid's 64 points per period).
    let config = MultiSineConfig::<f32>::default();
    let trajectory = match Trajectory::multisine(home().cast::<f32>(), &config) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let reference = match Trajectory::multisine(home(), &MultiSineConfig::default()) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    assert_eq!(trajectory.components().len(), reference.components().len());
    let mut peaks32 = [0.0_f64; 6];
    let mut peaks64 = [0.0_f64; 6];
    for k in 0..(40 * 1000) {
        let t = 2.0 + f64::from(k) * 1e-3;
        let (c32, _, _) = trajectory.coordinates(f32::lit(t));
        let (c64, _, _) = reference.coordinates(t);
        for axis in 0..6 {
            peaks32[axis] = peaks32[axis].max(f64::from(c32[axis]).abs());
            peaks64[axis] = peaks64[axis].max(c64[axis].abs());
        }
    }
    for axis in 0..6 {
        let requested = MultiSineConfig::<f64>::default().peak_amplitudes[axis];
        // f64's own construction sits within 2 % of the request on a 1 ms grid; f32's must too.
        let relative = (peaks32[axis] - requested).abs() / requested;
        eprintln!(
            "multisine built in f32, axis {axis}: peak {:.6e} (f64 {:.6e}, requested {requested:e})",
            peaks32[axis], peaks64[axis]
        );
        assert!(relative < 0.02, "axis {axis}: {relative:e}");
        assert!(((peaks64[axis] - requested) / requested).abs() < 0.02);
    }
}

/// A brake from the state `(c0, rate, acceleration)` and the ramp from there to the offset,
/// both in `T` over `duration_s`, sampled at `times_s`: coordinates, rates, accelerations.
fn ramp_case<T: Real>(
    state: &[Vector6<f64>; 3],
    duration_s: f64,
    times_s: &[f64],
) -> Vec<[Vector6<f64>; 3]> {
    let [c0, rate, acceleration] = state.map(|v| v.map(T::lit));
    let offset = home().cast::<T>();
    let duration = T::lit(duration_s);
    let brake = Ramp::brake(offset, &c0, &rate, &acceleration, duration);
    let ramp = Ramp::from_state(offset, &c0, &rate, &acceleration, duration);
    let (Ok(brake), Ok(ramp)) = (brake, ramp) else {
        panic!("ramp refused");
    };
    let widen = |s: crate::trajectory::TrajectorySample<T>| {
        [
            s.coordinates,
            s.coordinate_rates,
            s.coordinate_accelerations,
        ]
        .map(|v| v.map(T::to_f64))
    };
    times_s
        .iter()
        .flat_map(|&t| {
            [
                widen(brake.sample(T::lit(t))),
                widen(ramp.sample(T::lit(t))),
            ]
        })
        .collect()
}

#[test]
fn ramp_and_brake_in_f32_match_f64() {
    // Horner's rule on a quintic with |s| ≤ 1 errs by ≤ 2·5·u·Σ|aⱼ| (two roundings per step,
    // five steps), and Σ|aⱼ| ≤ 32|c₀ − c_T| + 18|ċ₀T| + 4|c̈₀T²| + |c₀| from the coefficients'
    // formula; the rate's polynomial carries the factors j (Σ j|aⱼ| ≤ 5Σ|aⱼ|) and a division
    // by T, the acceleration's j(j−1) (≤ 20Σ|aⱼ|) and T². The target c_T of the brake adds its
    // own few u. Bound: 10u·Σ|aⱼ|·{1, 5/T, 20/T²}, with Σ|aⱼ| taken at its largest over the
    // coordinates and the inputs exact in f32 (the coefficients' own rounding is in the 10u).
    let state = [
        Vector6::new(0.01, -0.02, 0.015, 0.03, -0.01, 0.02),
        Vector6::new(0.12, 0.05, -0.2, 0.3, 0.25, -0.1),
        Vector6::new(-0.8, 1.1, 0.4, -2.0, 1.5, 0.7),
    ]
    .map(|v| v.map(exact));
    let duration_s = 0.625;
    let times: Vec<f64> = (0..=700).map(|k| f64::from(k) / 1024.0).collect();
    let single = ramp_case::<f32>(&state, duration_s, &times);
    let double = ramp_case::<f64>(&state, duration_s, &times);
    let [c0, rate, acceleration] = &state;
    let coefficient_sum = (0..6)
        .map(|i| {
            let target = c0[i].abs()
                + rate[i].abs() * duration_s / 2.0
                + acceleration[i].abs() * duration_s * duration_s / 12.0;
            33.0 * (c0[i].abs() + target)
                + 18.0 * rate[i].abs() * duration_s
                + 4.0 * acceleration[i].abs() * duration_s * duration_s
        })
        .fold(0.0_f64, f64::max);
    let bounds = [1.0, 5.0 / duration_s, 20.0 / (duration_s * duration_s)]
        .map(|f| 10.0 * U * coefficient_sum * f);
    for (order, name) in ["coordinate", "rate", "acceleration"].iter().enumerate() {
        let worst = single
            .iter()
            .zip(&double)
            .map(|(a, b)| (a[order] - b[order]).amax())
            .fold(0.0_f64, f64::max);
        let bound = bounds.get(order).copied().unwrap_or(0.0);
        eprintln!("ramp/brake f32 − f64, {name}: {worst:.1e} (≤ {bound:.1e})");
        assert!(worst <= bound, "{name}: {worst:e} > {bound:e}");
    }
    // The brake ends at rest where its formula says, in f32 too.
    let last = single.iter().rev().nth(1).map(|s| s[1].amax());
    assert_eq!(last, Some(0.0));
}

#[test]
fn feasibility_in_f32_matches_f64() {
    // The check samples IK and J·twist in f32: lengths err by ≤ 10u·2.3 m (kinematics' IK
    // bound) plus the coordinate error (≤ 1e-6 m, above); speeds by the Jacobian's 20u times
    // the twist plus the rate error, ≤ 1e-4 relative (the rate bound of the multisine test
    // over its largest rate). Allow 3e-6 m and 2e-4 relative on the speeds.
    let trajectory = match Trajectory::multisine(home(), &MultiSineConfig::default()) {
        Ok(t) => t,
        Err(e) => panic!("{e}"),
    };
    let components: Vec<SineComponent<f32>> = trajectory
        .components()
        .iter()
        .map(|c| SineComponent {
            axis: c.axis,
            amplitude: f32::lit(c.amplitude),
            frequency_hz: f32::lit(c.frequency_hz),
            phase_rad: f32::lit(c.phase_rad),
        })
        .collect();
    let single = Trajectory::new(home().cast::<f32>(), &components, 44.0, 2.0, 2.0)
        .and_then(|t| t.check_feasibility(&geometry::<f32>(), &FeasibilityLimits::default()));
    let double = trajectory.check_feasibility(&geometry::<f64>(), &FeasibilityLimits::default());
    let (Ok(single), Ok(double)) = (single, double) else {
        panic!("feasibility refused");
    };
    assert_eq!(single.samples, double.samples);
    for leg in 0..6 {
        let dl = (f64::from(single.min_length_m[leg]) - double.min_length_m[leg])
            .abs()
            .max((f64::from(single.max_length_m[leg]) - double.max_length_m[leg]).abs());
        let dv = (f64::from(single.max_speed_m_s[leg]) - double.max_speed_m_s[leg]).abs()
            / double.max_speed_m_s[leg];
        if leg == 0 {
            eprintln!(
                "feasibility f32 − f64, leg 1: lengths {dl:.1e} m, peak speed {dv:.1e} relative"
            );
        }
        assert!(dl < 3e-6, "leg {leg}: {dl:e} m");
        assert!(dv < 2e-4, "leg {leg}: {dv:e}");
    }
}
