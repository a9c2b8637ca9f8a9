//! The leg loops' inverse-dynamics feed-forward against the simulator's rigid-body dynamics
//! (rapier, heavy legs, the default car): with the load as `[plan]` describes it (the car's
//! CAD figures, not the simulated truth) the legs follow their set-points an order of
//! magnitude closer than with the static load alone.
//!
//! Figures (`cargo test --release --test inertial_feedforward -- --nocapture` prints them):
//! largest leg tracking error over 8 s of the default excitation, the default world without
//! sensor noise: 0.28 mm with the feed-forward against 6.3 mm without (docs/plan.md).

use crate::support;

use control::supervisor::Phase;
use measure::observer::{Observer, TickEvent};
use measure::Measurement;
use sim::NoisePreset;

/// The largest |desired − measured| leg length over the excitation, m.
#[derive(Default)]
struct Tracking {
    largest_m: f64,
    excitation_ticks: usize,
}

impl Observer for Tracking {
    fn tick(&mut self, e: &TickEvent<'_>) -> anyhow::Result<()> {
        if let (Phase::Excite, Some(c)) = (e.phase, e.control) {
            self.excitation_ticks += 1;
            for (d, m) in c.desired_leg_lengths_m.iter().zip(c.measured_leg_lengths_m) {
                self.largest_m = self.largest_m.max((d - m).abs());
            }
        }
        Ok(())
    }
}

/// The loaded run of the default car, noise-free, 8 s of excitation; `feedforward` switches
/// `control.inertial_feedforward`.
fn largest_tracking_error_m(feedforward: bool) -> f64 {
    let text =
        format!("[run]\nduration_s = 8.0\n[control]\ninertial_feedforward = {feedforward}\n");
    let loaded = support::config_str(&text, "inertial_feedforward.toml");
    let scenario = support::world(loaded, Some(NoisePreset::None));
    let mut tracking = Tracking::default();
    support::measure_run(&scenario, Measurement::Loaded, &mut tracking);
    assert!(
        tracking.excitation_ticks > 7000,
        "{}",
        tracking.excitation_ticks
    );
    tracking.largest_m
}

#[test]
fn the_load_feedforward_cuts_the_legs_tracking_error_tenfold() {
    let with = largest_tracking_error_m(true);
    let without = largest_tracking_error_m(false);
    println!(
        "largest leg tracking error: {:.3} mm with the load's feed-forward, {:.3} mm without",
        with * 1e3,
        without * 1e3
    );
    assert!(without > 1e-3, "without: {without} m");
    assert!(with < without / 10.0, "with {with} m, without {without} m");
    assert!(with < 5e-4, "with: {with} m");
}
