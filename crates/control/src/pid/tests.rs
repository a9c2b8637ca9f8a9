//! PID tests against closed forms of simple loops.

use super::*;
use proptest::prelude::*;

fn config(kp: f64, ki: f64, kd: f64) -> PidConfig {
    PidConfig {
        kp,
        ki,
        kd,
        derivative_filter_s: 0.0,
        output_min_n: -1e9,
        output_max_n: 1e9,
        anti_windup: AntiWindup::Clamping,
    }
}

/// First-order plant `T·ẋ = −x + K·u`, discretised exactly for a zero-order-held input:
/// `x⁺ = a·x + K·(1 − a)·u`, `a = e^(−dt/T)`.
struct FirstOrder {
    a: f64,
    b: f64,
    x: f64,
}

impl FirstOrder {
    fn new(gain: f64, time_constant_s: f64, dt_s: f64) -> Self {
        let a = (-dt_s / time_constant_s).exp();
        Self {
            a,
            b: gain * (1.0 - a),
            x: 0.0,
        }
    }
    fn step(&mut self, u: f64) {
        self.x = self.a * self.x + self.b * u;
    }
}

#[test]
fn p_control_of_first_order_plant_matches_closed_form() {
    // u_k = kp·(r − x_k) gives x_{k+1} = λ·x_k + b·kp·r, λ = a − b·kp, so
    // x_k = x_∞·(1 − λ^k) with x_∞ = b·kp·r/(1 − λ) = K·kp·r/(1 + K·kp).
    let (gain, tau, dt, kp, r) = (2.0, 0.1, 1e-3, 3.0, 0.05);
    let mut plant = FirstOrder::new(gain, tau, dt);
    let mut pid = Pid::new(config(kp, 0.0, 0.0)).unwrap();
    let lambda = plant.a - plant.b * kp;
    let x_inf = gain * kp * r / (1.0 + gain * kp);
    let mut worst_discrete: f64 = 0.0;
    let mut worst_continuous: f64 = 0.0;
    for k in 0..2000 {
        let t = k as f64 * dt;
        let closed = x_inf * (1.0 - lambda.powi(k));
        // The continuous loop: x(t) = x_∞·(1 − e^(−(1 + K·kp)·t/T)).
        let continuous = x_inf * (1.0 - (-(1.0 + gain * kp) * t / tau).exp());
        worst_discrete = worst_discrete.max((plant.x - closed).abs());
        worst_continuous = worst_continuous.max((plant.x - continuous).abs());
        let out = pid.update(r, plant.x, 0.0, dt).unwrap();
        assert_eq!(out.i, 0.0);
        assert_eq!(out.d, 0.0);
        plant.step(out.output);
    }
    assert!(
        worst_discrete < 1e-14,
        "discrete closed form off by {worst_discrete:e}"
    );
    // The sampled loop lags the continuous one by about half a step: O(dt/τ_cl) relative.
    let tau_cl = tau / (1.0 + gain * kp);
    assert!(
        worst_continuous < x_inf * dt / tau_cl,
        "continuous closed form off by {worst_continuous:e}"
    );
    // Proportional control alone leaves the classic steady-state error r/(1 + K·kp).
    assert!((plant.x - x_inf).abs() < 1e-12);
}

#[test]
fn pi_control_with_pole_zero_cancellation_is_first_order() {
    // With ki = kp/T the PI zero cancels the plant pole: L(s) = K·kp/(T·s), so the closed loop
    // is x(t) = r·(1 − e^(−t/τ)) with τ = T/(K·kp), and no steady-state error.
    let (gain, tau, dt, kp, r) = (1.5, 0.2, 1e-4, 4.0, 0.02);
    let ki = kp / tau;
    let mut plant = FirstOrder::new(gain, tau, dt);
    let mut pid = Pid::new(config(kp, ki, 0.0)).unwrap();
    let tau_cl = tau / (gain * kp);
    let mut worst: f64 = 0.0;
    for k in 0..20_000 {
        let t = k as f64 * dt;
        let expected = r * (1.0 - (-t / tau_cl).exp());
        worst = worst.max((plant.x - expected).abs());
        let out = pid.update(r, plant.x, 0.0, dt).unwrap();
        plant.step(out.output);
    }
    assert!(
        worst < 2.0 * r * dt / tau_cl,
        "PI response off by {worst:e}"
    );
    // Integral action removes the steady-state error (P alone would leave r/(1 + K·kp)); the
    // sampled cancellation is not exact, which leaves a tiny, slowly decaying residue.
    assert!(
        (plant.x - r).abs() < 1e-6 * r,
        "steady-state error {}",
        plant.x - r
    );
}

#[test]
fn derivative_filter_matches_closed_form_on_a_ramp() {
    // Measurement ramp y_k = c·k·dt: backward-Euler filter gives
    // D_k = −kd·c·(1 − a^k), a = T_f/(T_f + dt), counting k from the first update (D_0 = 0).
    let (kd, tf, dt, c) = (7.0, 0.01, 1e-3, 0.3);
    let mut cfg = config(0.0, 0.0, kd);
    cfg.derivative_filter_s = tf;
    let mut pid = Pid::new(cfg).unwrap();
    let a = tf / (tf + dt);
    for k in 0..200 {
        let y = c * k as f64 * dt;
        let out = pid.update(0.0, y, 0.0, dt).unwrap();
        let expected = -kd * c * (1.0 - a.powi(k));
        assert!(
            (out.d - expected).abs() < 1e-12,
            "k = {k}: {} vs {expected}",
            out.d
        );
    }
}

#[test]
fn setpoint_step_gives_no_derivative_kick() {
    let mut cfg = config(5.0, 1.0, 100.0);
    cfg.derivative_filter_s = 0.001;
    let mut pid = Pid::new(cfg).unwrap();
    for _ in 0..10 {
        pid.update(0.1, 0.1, 0.0, 1e-3).unwrap();
    }
    let before = pid.update(0.1, 0.1, 0.0, 1e-3).unwrap();
    let after = pid.update(0.2, 0.1, 0.0, 1e-3).unwrap();
    assert_eq!(after.d, 0.0);
    // The output moves by the proportional step only (the integrator has not seen it yet).
    assert!((after.output - before.output - 5.0 * 0.1).abs() < 1e-12);
}

#[test]
fn first_update_after_reset_has_no_derivative_kick() {
    let mut cfg = config(2.0, 0.0, 50.0);
    cfg.derivative_filter_s = 0.002;
    let mut pid = Pid::new(cfg).unwrap();
    pid.update(0.5, 0.1, 0.0, 1e-3).unwrap();
    pid.update(0.5, 0.2, 0.0, 1e-3).unwrap();
    pid.reset();
    // The measurement jumped by 0.3 m since the last update; a derivative would be huge.
    let out = pid.update(0.5, 0.5, 0.0, 1e-3).unwrap();
    assert_eq!(out.d, 0.0);
    assert_eq!(out.i, 0.0);
}

#[test]
fn reset_to_starts_bumplessly_at_the_given_output() {
    let mut cfg = config(1000.0, 5000.0, 20.0);
    cfg.derivative_filter_s = 0.002;
    let mut pid = Pid::new(cfg).unwrap();
    let held = 1234.5;
    pid.reset_to(held);
    let dt = 1e-3;
    let first = pid.update(0.50, 0.49, 100.0, dt).unwrap();
    assert!((first.output - held).abs() < 1e-9);
    assert_eq!(first.d, 0.0);
    assert!(!first.saturated);
    // Holding still: the next output moves only by the integrator's one-step increment.
    let second = pid.update(0.50, 0.49, 100.0, dt).unwrap();
    let increment = 5000.0 * dt * 0.01;
    assert!((second.output - held - increment).abs() < 1e-9);
}

#[test]
fn reset_to_is_clamped_to_the_output_range() {
    let mut cfg = config(1.0, 1.0, 0.0);
    cfg.output_max_n = 10.0;
    let mut pid = Pid::new(cfg).unwrap();
    pid.reset_to(50.0);
    let out = pid.update(0.0, 0.0, 0.0, 1e-3).unwrap();
    assert_eq!(out.output, 10.0);
}

/// Runs a saturated PI loop on `T·ẋ = −x + u` with |u| ≤ 1: the setpoint 2 is out of reach for
/// `hold_s`, then drops to 0.5. Returns (largest |I| seen, time to get and stay within 2 % of 0.5).
fn windup_run(anti_windup: AntiWindup) -> (f64, f64) {
    let (tau, dt, hold_s, after_s) = (0.1, 1e-3, 5.0, 20.0);
    let cfg = PidConfig {
        kp: 2.0,
        ki: 20.0,
        kd: 0.0,
        derivative_filter_s: 0.0,
        output_min_n: -1.0,
        output_max_n: 1.0,
        anti_windup,
    };
    let mut pid = Pid::new(cfg).unwrap();
    let mut plant = FirstOrder::new(1.0, tau, dt);
    let mut max_integral: f64 = 0.0;
    let hold_steps = (hold_s / dt) as usize;
    let total = hold_steps + (after_s / dt) as usize;
    let mut last_outside = hold_steps;
    for k in 0..total {
        let r = if k < hold_steps { 2.0 } else { 0.5 };
        let out = pid.update(r, plant.x, 0.0, dt).unwrap();
        assert!(out.output.abs() <= 1.0);
        max_integral = max_integral.max(pid.integral_term().abs());
        plant.step(out.output);
        if k >= hold_steps && (plant.x - 0.5).abs() > 0.01 {
            last_outside = k;
        }
    }
    (max_integral, (last_outside - hold_steps) as f64 * dt)
}

#[test]
fn anti_windup_bounds_the_integrator_and_the_recovery() {
    let (wound, slow) = windup_run(AntiWindup::None);
    // Without protection the integral grows like ki·(r − x)·t ≈ 20·1·5 = 100.
    assert!(wound > 50.0, "unprotected integrator reached only {wound}");
    for scheme in [
        AntiWindup::Clamping,
        AntiWindup::BackCalculation {
            tracking_time_s: 0.05,
        },
    ] {
        let (integral, recovery_s) = windup_run(scheme);
        assert!(integral <= 2.0, "{scheme:?}: integral reached {integral}");
        // The unsaturated loop settles with τ ≈ 0.05 s; allow a generous few tenths.
        assert!(recovery_s < 0.5, "{scheme:?}: recovery took {recovery_s} s");
        assert!(slow > 5.0 * recovery_s, "{scheme:?}: no better than windup");
    }
}

#[test]
fn back_calculation_without_integral_action_adds_no_integral() {
    let mut cfg = config(10.0, 0.0, 0.0);
    cfg.output_max_n = 1.0;
    cfg.anti_windup = AntiWindup::BackCalculation {
        tracking_time_s: 0.01,
    };
    let mut pid = Pid::new(cfg).unwrap();
    for _ in 0..100 {
        let out = pid.update(1.0, 0.0, 0.0, 1e-3).unwrap();
        assert!(out.saturated);
        assert_eq!(out.i, 0.0);
    }
}

#[test]
fn invalid_inputs_are_refused_and_leave_state_unchanged() {
    let mut pid = Pid::new(config(1.0, 1.0, 1.0)).unwrap();
    pid.update(1.0, 0.0, 0.0, 1e-3).unwrap();
    let before = pid;
    assert!(matches!(
        pid.update(f64::NAN, 0.0, 0.0, 1e-3),
        Err(ControlError::NonFinite { .. })
    ));
    assert!(matches!(
        pid.update(0.0, f64::INFINITY, 0.0, 1e-3),
        Err(ControlError::NonFinite { .. })
    ));
    for dt in [0.0, -1e-3, f64::NAN] {
        assert!(matches!(
            pid.update(0.0, 0.0, 0.0, dt),
            Err(ControlError::InvalidTimeStep { .. })
        ));
    }
    assert_eq!(pid, before);
}

#[test]
fn invalid_configs_are_refused() {
    let good = config(1.0, 1.0, 1.0);
    let mut bad = good;
    bad.kp = -1.0;
    assert_eq!(
        Pid::new(bad).unwrap_err().kind(),
        crate::ErrorKind::InvalidConfig
    );
    let mut bad = good;
    bad.output_min_n = 2.0;
    bad.output_max_n = 1.0;
    assert!(Pid::new(bad).is_err());
    let mut bad = good;
    bad.anti_windup = AntiWindup::BackCalculation {
        tracking_time_s: 0.0,
    };
    assert!(Pid::new(bad).is_err());
    assert!(PidConfig::<f64>::default().validate().is_ok());
}

#[test]
fn bank_refuses_a_bad_leg_without_touching_the_others() {
    let mut bank = PidBank::uniform(config(1.0, 10.0, 0.0)).unwrap();
    let r = [0.1; LEG_COUNT];
    let mut y = [0.0; LEG_COUNT];
    bank.update(&r, &y, &[0.0; LEG_COUNT], 1e-3).unwrap();
    let before = bank;
    y[4] = f64::NAN;
    assert_eq!(
        bank.update(&r, &y, &[0.0; LEG_COUNT], 1e-3),
        Err(ControlError::NonFinite {
            what: "pid measurement",
            index: 4
        })
    );
    assert_eq!(bank, before);
}

#[test]
fn bank_legs_are_independent_and_equal_to_single_pids() {
    let cfgs = core::array::from_fn(|i| config(1.0 + i as f64, 0.5 * i as f64, 0.1));
    let mut bank = PidBank::new(cfgs).unwrap();
    let mut singles = cfgs.map(|c| Pid::new(c).unwrap());
    for k in 0..50 {
        let r: [f64; LEG_COUNT] = core::array::from_fn(|i| 0.01 * i as f64);
        let y: [f64; LEG_COUNT] = core::array::from_fn(|i| 0.001 * (k * i) as f64);
        let ff: [f64; LEG_COUNT] = core::array::from_fn(|i| 3.0 * i as f64);
        let outs = bank.update(&r, &y, &ff, 1e-3).unwrap();
        for i in 0..LEG_COUNT {
            assert_eq!(outs[i], singles[i].update(r[i], y[i], ff[i], 1e-3).unwrap());
        }
    }
}

proptest! {
    #[test]
    fn output_never_leaves_its_range(
        steps in proptest::collection::vec((-1e3f64..1e3, -1e3f64..1e3, -1e4f64..1e4, 1e-6f64..1.0), 1..50),
        back_calc in any::<bool>(),
    ) {
        let mut cfg = config(1e3, 1e4, 1e2);
        cfg.output_min_n = -500.0;
        cfg.output_max_n = 700.0;
        cfg.derivative_filter_s = 1e-3;
        if back_calc {
            cfg.anti_windup = AntiWindup::BackCalculation { tracking_time_s: 0.01 };
        }
        let mut pid = Pid::new(cfg).unwrap();
        for (r, y, ff, dt) in steps {
            let out = pid.update(r, y, ff, dt).unwrap();
            prop_assert!(out.output >= -500.0 && out.output <= 700.0);
            prop_assert!(out.output.is_finite());
            prop_assert_eq!(out.saturated, out.output != out.feedforward + out.p + out.i + out.d);
        }
    }
}
