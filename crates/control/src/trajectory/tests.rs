//! Trajectory tests: exact derivatives against finite differences, window smoothness, the
//! multi-sine's spread, and the feasibility check against independent IK.
#![allow(clippy::needless_range_loop)] // index loops over six axes read best as such here

use super::*;
use kinematics::{Geometry, StrokeLimits};

fn geometry() -> Geometry {
    let stroke = StrokeLimits {
        min_length_m: 1.5,
        max_length_m: 2.3,
    };
    Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).unwrap()
}

fn tilted_offset() -> Pose {
    Pose::from_rpy(Vector3::new(0.01, -0.02, 1.7), 0.1, -0.05, 0.2)
}

#[test]
fn each_axis_entry_is_the_one_its_index_names() {
    for axis in Axis::ALL {
        let mut coordinates = [0usize, 1, 2, 3, 4, 5];
        assert_eq!(*axis.entry_mut(&mut coordinates), axis.index(), "{axis:?}");
    }
}

fn rich() -> Trajectory {
    let components = [
        (Axis::X, 0.02, 0.7, 0.3),
        (Axis::Y, 0.01, 1.1, -1.0),
        (Axis::Z, 0.015, 0.4, 2.0),
        (Axis::Roll, 0.08, 0.5, 0.1),
        (Axis::Pitch, 0.06, 0.9, 0.7),
        (Axis::Yaw, 0.1, 0.3, -0.4),
        (Axis::Roll, 0.02, 1.7, 1.3),
    ]
    .map(|(axis, amplitude, frequency_hz, phase_rad)| SineComponent {
        axis,
        amplitude,
        frequency_hz,
        phase_rad,
    });
    Trajectory::new(tilted_offset(), &components, 12.0, 2.0, 3.0).unwrap()
}

fn vec3_err(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    (a - b).amax()
}

/// Spatial angular velocity from rotations at t ± h: the vee of the skew part of R₊R₋ᵀ is
/// sin θ·axis, θ·axis to O(θ³) (nalgebra's `scaled_axis` goes through acos of the trace and
/// loses half the digits at these tiny angles).
fn fd_omega(traj: &impl Fn(f64) -> TrajectorySample, t: f64, h: f64) -> Vector3<f64> {
    let (plus, minus) = (traj(t + h).pose.rotation, traj(t - h).pose.rotation);
    let m = (plus * minus.transpose()).into_inner();
    Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) / (4.0 * h)
}

fn assert_derivatives_match(f: impl Fn(f64) -> TrajectorySample, times: &[f64]) {
    let h = 1e-5;
    for &t in times {
        let s = f(t);
        let (p, m) = (f(t + h), f(t - h));
        let v_fd = (p.pose.position_m - m.pose.position_m) / (2.0 * h);
        let a_fd = (p.velocity_m_s - m.velocity_m_s) / (2.0 * h);
        let w_fd = fd_omega(&f, t, h);
        let wdot_fd = (p.angular_velocity_rad_s - m.angular_velocity_rad_s) / (2.0 * h);
        assert!(vec3_err(&s.velocity_m_s, &v_fd) < 1e-8, "v at {t}");
        assert!(vec3_err(&s.acceleration_m_s2, &a_fd) < 1e-7, "a at {t}");
        assert!(
            vec3_err(&s.angular_velocity_rad_s, &w_fd) < 1e-8,
            "ω at {t}: {} vs {}",
            s.angular_velocity_rad_s,
            w_fd
        );
        assert!(
            vec3_err(&s.angular_acceleration_rad_s2, &wdot_fd) < 1e-7,
            "ω̇ at {t}: {} vs {}",
            s.angular_acceleration_rad_s2,
            wdot_fd
        );
        let c_fd = (p.coordinates - m.coordinates) / (2.0 * h);
        let cc_fd = (p.coordinate_rates - m.coordinate_rates) / (2.0 * h);
        assert!((s.coordinate_rates - c_fd).amax() < 1e-8);
        assert!((s.coordinate_accelerations - cc_fd).amax() < 1e-7);
    }
}

#[test]
fn velocity_and_acceleration_are_the_exact_derivatives() {
    let traj = rich();
    // In the fade-in, on the plateau, in the fade-out, and next to the seams (at a seam the
    // jerk jumps, which costs a central difference O(h) accuracy).
    let times = [0.3, 1.0, 1.999, 2.001, 5.3, 8.7, 9.001, 10.5, 11.9];
    assert_derivatives_match(|t| traj.sample(t), &times);
}

#[test]
fn window_is_c2_and_starts_and_ends_at_rest() {
    let traj = rich();
    let d = traj.duration_s();
    for t in [-1.0, 0.0, d, d + 1.0] {
        let s = traj.sample(t);
        assert_eq!(s.pose, *traj.offset(), "t = {t}");
        assert_eq!(s.twist(), Vector6::zeros());
        assert_eq!(s.acceleration_m_s2, Vector3::zeros());
        assert_eq!(s.angular_acceleration_rad_s2, Vector3::zeros());
    }
    // w, w′, w″ continuous at the four seams (0, end of fade-in, start of fade-out, end).
    for seam in [0.0, 2.0, 9.0, 12.0] {
        let (a, b) = (traj.window(seam - 1e-9), traj.window(seam + 1e-9));
        assert!((a.0 - b.0).abs() < 1e-8);
        assert!((a.1 - b.1).abs() < 1e-7);
        assert!((a.2 - b.2).abs() < 1e-6, "w″ jumps at {seam}: {a:?} {b:?}");
    }
    // w′ and w″ by finite differences inside the fades.
    for t in [0.5, 1.5, 9.5, 11.0] {
        let h = 1e-5;
        let (w, dw, ddw) = traj.window(t);
        assert!((dw - (traj.window(t + h).0 - traj.window(t - h).0) / (2.0 * h)).abs() < 1e-8);
        assert!((ddw - (traj.window(t + h).1 - traj.window(t - h).1) / (2.0 * h)).abs() < 1e-7);
        assert!(w > 0.0 && w < 1.0);
    }
    assert_eq!(traj.window(5.0), (1.0, 0.0, 0.0));
}

#[test]
fn paper_eq8_is_three_rotational_sines() {
    let offset = geometry().home_pose();
    let traj =
        Trajectory::paper_eq8(offset, [0.05, 0.04, 0.03], [0.5, 0.7, 1.1], 20.0, 2.0).unwrap();
    for t in [3.0, 7.77, 15.0] {
        let s = traj.sample(t);
        let w = core::f64::consts::TAU;
        let expected = [
            0.05 * (w * 0.5 * t).sin(),
            0.04 * (w * 0.7 * t).sin(),
            0.03 * (w * 1.1 * t).sin(),
        ];
        let (roll, pitch, yaw) = s.pose.rpy();
        for (got, want) in [roll, pitch, yaw].iter().zip(expected) {
            assert!((got - want).abs() < 1e-12);
        }
        assert!((s.pose.position_m - offset.position_m).norm() < 1e-15);
        assert_eq!(s.velocity_m_s, Vector3::zeros());
    }
}

/// Per axis: peak, correlation with every axis, (crest factor, in-phase crest factor).
type PlateauStatistics = ([f64; 6], [[f64; 6]; 6], [(f64, f64); 6]);

/// Over one plateau period: each axis's peak, and the normalised Gram matrix of the axes and
/// each axis's crest factor (peak/rms) against the in-phase worst case Σa/rms.
fn plateau_statistics(traj: &Trajectory, config: &MultiSineConfig) -> PlateauStatistics {
    let period = 1.0 / config.base_frequency_hz;
    let n = 20_000;
    let mut peak = [0.0f64; 6];
    let mut gram = [[0.0f64; 6]; 6];
    for k in 0..n {
        let c = traj
            .coordinates(config.fade_in_s + period * k as f64 / n as f64)
            .0;
        for i in 0..6 {
            peak[i] = peak[i].max(c[i].abs());
            for j in 0..6 {
                gram[i][j] += c[i] * c[j] / n as f64;
            }
        }
    }
    let crest = core::array::from_fn(|i| {
        let rms = gram[i][i].sqrt();
        let in_phase: f64 = traj
            .components()
            .iter()
            .filter(|c| c.axis.index() == i)
            .map(|c| c.amplitude)
            .sum();
        (peak[i] / rms, in_phase / rms)
    });
    let corr = core::array::from_fn(|i| {
        core::array::from_fn(|j| gram[i][j] / (gram[i][i] * gram[j][j]).sqrt())
    });
    (peak, corr, crest)
}

#[test]
fn multisine_spreads_harmonics_and_meets_the_peaks() {
    for spectrum in [Spectrum::FlatVelocity, Spectrum::FlatPosition] {
        let config = MultiSineConfig {
            spectrum,
            harmonics_per_axis: 4,
            ..MultiSineConfig::default()
        };
        let traj = Trajectory::multisine(geometry().home_pose(), &config).unwrap();
        let f0 = config.base_frequency_hz;
        let k_per_axis = config.harmonics_per_axis;
        assert_eq!(traj.components().len(), 6 * k_per_axis);
        // Every component is a distinct harmonic of f0.
        let mut seen = [false; MAX_COMPONENTS + 1];
        for c in traj.components() {
            let k = c.frequency_hz / f0;
            assert!((k - k.round()).abs() < 1e-9);
            let k = k.round() as usize;
            assert!(!seen[k], "harmonic {k} used twice");
            seen[k] = true;
        }
        let (peak, corr, crest) = plateau_statistics(&traj, &config);
        for i in 0..6 {
            // The grid-found peak may lie a hair below the true one.
            let want = config.peak_amplitudes[i];
            assert!(
                (peak[i] - want).abs() < 2e-3 * want,
                "axis {i}: {} vs {want}",
                peak[i]
            );
            for j in 0..6 {
                if i != j {
                    assert!(
                        corr[i][j].abs() < 1e-9,
                        "axes {i},{j} correlate: {}",
                        corr[i][j]
                    );
                }
            }
            let (crest, in_phase) = crest[i];
            std::println!("{spectrum:?} axis {i}: crest {crest:.3}, in phase {in_phase:.3}");
            // Schroeder phases beat the in-phase worst case clearly when the harmonics carry
            // equal power; with 1/f amplitudes the first harmonic dominates anyway.
            let factor = match spectrum {
                Spectrum::FlatPosition => 0.7,
                Spectrum::FlatVelocity => 0.9,
            };
            assert!(
                crest < factor * in_phase,
                "axis {i} crest factor {crest} vs {in_phase}"
            );
        }
    }
}

#[test]
fn multisine_skips_still_axes_and_refuses_too_many_components() {
    let config = MultiSineConfig {
        peak_amplitudes: [0.0, 0.0, 0.01, 0.05, 0.0, 0.05],
        harmonics_per_axis: 3,
        ..MultiSineConfig::default()
    };
    let traj = Trajectory::multisine(geometry().home_pose(), &config).unwrap();
    assert_eq!(traj.components().len(), 9);
    assert!(traj
        .components()
        .iter()
        .all(|c| matches!(c.axis, Axis::Z | Axis::Roll | Axis::Yaw)));
    let too_many = MultiSineConfig {
        harmonics_per_axis: 9,
        ..MultiSineConfig::default()
    };
    assert_eq!(
        Trajectory::multisine(geometry().home_pose(), &too_many),
        Err(ControlError::TooManyComponents {
            max: MAX_COMPONENTS
        })
    );
}

#[test]
fn invalid_trajectories_are_refused() {
    let offset = geometry().home_pose();
    let c = [SineComponent {
        axis: Axis::Roll,
        amplitude: 0.1,
        frequency_hz: 1.0,
        phase_rad: 0.0,
    }];
    assert!(Trajectory::new(offset, &c, 10.0, 0.0, 1.0).is_err());
    assert!(Trajectory::new(offset, &c, 3.0, 2.0, 2.0).is_err());
    let mut bad = c;
    bad[0].frequency_hz = 0.0;
    assert!(Trajectory::new(offset, &bad, 10.0, 1.0, 1.0).is_err());
    bad[0].frequency_hz = 1.0;
    bad[0].amplitude = f64::NAN;
    assert!(Trajectory::new(offset, &bad, 10.0, 1.0, 1.0).is_err());
    let many = [c[0]; MAX_COMPONENTS + 1];
    assert!(Trajectory::new(offset, &many, 10.0, 1.0, 1.0).is_err());
}

#[test]
fn default_multisine_is_feasible_on_a_typical_rig() {
    let g = geometry();
    let traj = Trajectory::multisine(g.home_pose(), &MultiSineConfig::default()).unwrap();
    let limits = FeasibilityLimits::default();
    let report = traj.check_feasibility(&g, &limits).unwrap();
    assert!(report.samples as f64 >= traj.duration_s() / limits.step_s);
    for leg in 0..6 {
        assert!(report.min_length_m[leg] >= 1.505 && report.max_length_m[leg] <= 2.295);
        assert!(report.max_speed_m_s[leg] <= 0.4 && report.max_speed_m_s[leg] > 0.0);
    }
    assert!(report.min_inverse_condition >= limits.min_inverse_condition);
}

#[test]
fn stroke_violation_names_the_first_time_and_leg() {
    let g = geometry();
    let traj = Trajectory::paper_eq8(g.home_pose(), [0.0, 0.0, 0.9], [0.2; 3], 10.0, 2.0).unwrap();
    let limits = FeasibilityLimits {
        max_leg_speed_m_s: 10.0,
        min_inverse_condition: 0.0,
        ..FeasibilityLimits::default()
    };
    let Err(ControlError::StrokeViolation {
        time_s,
        leg,
        length_m,
        limit_m,
    }) = traj.check_feasibility(&g, &limits)
    else {
        panic!("large yaw passed the stroke check");
    };
    // Independent IK at the reported time and one step earlier.
    let stroke = g.stroke();
    let now = g.leg_lengths(&traj.sample(time_s).pose)[leg];
    assert_eq!(now, length_m);
    assert!(limit_m == stroke.min_length_m + 0.005 || limit_m == stroke.max_length_m - 0.005);
    assert!(now < stroke.min_length_m + 0.005 || now > stroke.max_length_m - 0.005);
    let before = g.leg_lengths(&traj.sample(time_s - 1e-3).pose);
    assert!(before
        .iter()
        .all(|&l| l >= stroke.min_length_m + 0.005 && l <= stroke.max_length_m - 0.005));
}

#[test]
fn leg_speed_violation_matches_differentiated_ik() {
    let g = geometry();
    let c = [SineComponent {
        axis: Axis::Z,
        amplitude: 0.01,
        frequency_hz: 10.0,
        phase_rad: 0.0,
    }];
    let traj = Trajectory::new(g.home_pose(), &c, 5.0, 1.0, 1.0).unwrap();
    let Err(ControlError::LegSpeedViolation {
        time_s,
        leg,
        speed_m_s,
        limit_m_s,
    }) = traj.check_feasibility(&g, &FeasibilityLimits::default())
    else {
        panic!("0.63 m/s vertical motion passed a 0.4 m/s limit");
    };
    assert_eq!(limit_m_s, 0.4);
    let h = 1e-6;
    let fd = (g.leg_lengths(&traj.sample(time_s + h).pose)[leg]
        - g.leg_lengths(&traj.sample(time_s - h).pose)[leg])
        / (2.0 * h);
    assert!((fd - speed_m_s).abs() < 1e-6, "{fd} vs {speed_m_s}");
    assert!(speed_m_s.abs() > 0.4 && time_s < 1.0, "in the fade-in");
}

#[test]
fn conditioning_violation_is_reported() {
    let g = geometry();
    let home = g.inverse_condition_number(&g.home_pose());
    let traj = Trajectory::paper_eq8(g.home_pose(), [0.01, 0.01, 0.01], [0.5, 0.6, 0.7], 4.0, 1.0)
        .unwrap();
    let limits = FeasibilityLimits {
        min_inverse_condition: home * 1.01,
        ..FeasibilityLimits::default()
    };
    assert_eq!(
        traj.check_feasibility(&g, &limits),
        Err(ControlError::ConditioningViolation {
            time_s: 0.0,
            inverse_condition: home,
            threshold: home * 1.01
        })
    );
    let err = traj.check_feasibility(&g, &limits).unwrap_err();
    assert_eq!(err.kind(), crate::ErrorKind::Infeasible);
}

#[test]
fn ramp_moves_from_a_moving_state_to_rest_at_the_offset() {
    let traj = rich();
    let start = traj.sample(6.3);
    let ramp = Ramp::from_state(
        *traj.offset(),
        &start.coordinates,
        &start.coordinate_rates,
        &start.coordinate_accelerations,
        2.5,
    )
    .unwrap();
    let s0 = ramp.sample(0.0);
    assert!((s0.coordinates - start.coordinates).amax() < 1e-15);
    assert!((s0.twist() - start.twist()).amax() < 1e-12);
    assert!((s0.angular_acceleration_rad_s2 - start.angular_acceleration_rad_s2).amax() < 1e-12);
    let end = ramp.sample(2.5);
    assert_eq!(end.pose, *traj.offset());
    assert_eq!(end.twist(), Vector6::zeros());
    // Continuity at the end from inside.
    let near = ramp.sample(2.5 - 1e-6);
    assert!(near.coordinates.amax() < 1e-12 && near.coordinate_rates.amax() < 1e-8);
    assert_derivatives_match(|t| ramp.sample(t), &[0.2, 1.0, 2.0]);
}

#[test]
fn brake_stops_where_its_cubic_speed_profile_takes_it() {
    let traj = rich();
    let start = traj.sample(6.3);
    let (c, v, a) = (
        start.coordinates,
        start.coordinate_rates,
        start.coordinate_accelerations,
    );
    let t = 0.6;
    let brake = Ramp::brake(*traj.offset(), &c, &v, &a, t).unwrap();
    let s0 = brake.sample(0.0);
    assert!((s0.coordinates - c).amax() < 1e-15);
    assert!((s0.coordinate_rates - v).amax() < 1e-12);
    assert!((s0.coordinate_accelerations - a).amax() < 1e-12);
    // ∫₀ᵀ ċ dt of ċ(s) = ċ₀(1 − 3s² + 2s³) + c̈₀T(s − 2s² + s³), by the trapezoid rule.
    let n = 20_000;
    let profile = |s: f64| {
        v * (1.0 - 3.0 * s * s + 2.0 * s * s * s) + a * (t * (s - 2.0 * s * s + s * s * s))
    };
    let mut travel = Vector6::zeros();
    for i in 0..n {
        let (s0, s1) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
        travel += (profile(s0) + profile(s1)) * (0.5 * t / n as f64);
    }
    assert!((brake.target() - (c + travel)).amax() < 1e-9);
    let end = brake.sample(t);
    assert_eq!(end.coordinates, *brake.target());
    assert_eq!(end.twist(), Vector6::zeros());
    // The speed follows the cubic profile all the way (no overshoot of the quintic's own).
    for k in 0..=10 {
        let s = k as f64 / 10.0;
        assert!((brake.sample(s * t).coordinate_rates - profile(s)).amax() < 1e-12);
    }
    assert_derivatives_match(|time| brake.sample(time), &[0.1, 0.3, 0.5]);
}

#[test]
fn ramp_from_a_pose_starts_there() {
    let offset = tilted_offset();
    let pose = Pose::from_rpy(Vector3::new(0.05, 0.0, 1.6), 0.2, 0.1, -0.1);
    let ramp = Ramp::from_pose(offset, &pose, 1.0).unwrap();
    let (dp, dr) = ramp.sample(0.0).pose.distance_to(&pose);
    assert!(dp < 1e-15 && dr < 1e-12, "{dp} {dr}");
    let mid = ramp.sample(0.5).coordinates;
    // Half-way by the smoothstep (h(1/2) = 1/2), every coordinate is halved.
    assert!((mid - coordinates_of(&offset, &pose) * 0.5).amax() < 1e-12);
    assert!(Ramp::from_pose(offset, &pose, 0.0).is_err());
}
