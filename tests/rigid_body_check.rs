//! The rigid-body check end to end: a car body bouncing on its suspension is flagged in the
//! report, naming the frequency of the residual's peak, and a rigid payload passes.

use crate::support;

use support::{simulate_with, SHORT};

#[test]
fn a_payload_on_its_suspension_is_flagged_and_a_rigid_one_passes() {
    let bouncing = simulate_with(
        &format!("{SHORT}[world.suspension]\nenabled = true\n"),
        |_, _| {},
    );
    let check = bouncing
        .report
        .rigid_body
        .expect("a loaded run carries the check");
    assert!(!check.ok, "{check:?}");
    assert!(check.residual_ratio > 3.0, "{check:?}");
    // The bounce (1.3 Hz) is forced by the excitation's lines (0.1–1.8 Hz): the residual peaks
    // on a line near it.
    assert!((0.8..=2.0).contains(&check.peak_hz), "{check:?}");

    let rigid = simulate_with(SHORT, |_, _| {});
    let check = rigid
        .report
        .rigid_body
        .expect("a loaded run carries the check");
    assert!(check.ok, "{check:?}");
    // With the legs compensated what remains is the sensors' noise, which the check predicts.
    assert!(check.residual_ratio < 1.5, "{check:?}");
}
