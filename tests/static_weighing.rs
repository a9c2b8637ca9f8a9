//! The brake holds' static weighing ([`measure::weigh`]) against physics it does not share
//! code with: the simulator's world, its truth read here only. With heavy legs (`--only
//! leg_dynamics`, the legs' own weight compensated by the rig description) and in the default
//! world (every imperfection on), the payload's static mass and c_x, c_y land within their
//! sigma of `[world.payload]`; and `stewart estimate` recomputes the weighing from the log's
//! brake-hold frames exactly.

use crate::support;

use ops::estimate::EstimateOptions;
use rig_description::sources::ErrorSource;

/// |static − truth| ≤ k σ for mass, c_x and c_y of `report`.
fn assert_within(report: &measure::Report, k: f64, what: &str) {
    let truth = report.truth.as_ref().expect("simulation reports the truth");
    let w = report
        .static_weighing
        .as_ref()
        .expect("a simulated session weighs both holds");
    let p = &w.payload;
    let rows = [
        ("mass", p.mass_kg, p.sigma_mass_kg, truth.mass),
        ("c_x", p.com_xy_m[0], p.sigma_com_xy_m[0], truth.com[0]),
        ("c_y", p.com_xy_m[1], p.sigma_com_xy_m[1], truth.com[1]),
    ];
    for (name, got, sigma, want) in rows {
        assert!(
            sigma > 0.0 && sigma.is_finite(),
            "{what} {name}: sigma {sigma}"
        );
        assert!(
            (got - want).abs() <= k * sigma,
            "{what} {name}: {got} ± {sigma}, truth {want} ({:.2} σ)",
            (got - want) / sigma
        );
    }
    assert!(w.check.is_some_and(|c| c.agrees), "{what}: {:?}", w.check);
}

#[test]
fn heavy_legs_and_the_default_world_weigh_the_payload_within_sigma() {
    let legs = support::simulate_with(support::SHORT, |a, _| {
        a.only = Some(ErrorSource::LegDynamics);
        a.seed = Some(3);
    });
    assert_within(&legs.report, 3.0, "--only leg_dynamics");
    let world = support::simulate_with(support::SHORT, |a, _| a.seed = Some(3));
    assert_within(&world.report, 3.0, "default world");

    // The log's brake-hold frames give the same weighing offline.
    let offline = ops::estimate::run(&EstimateOptions {
        log: world.log.clone(),
        ..EstimateOptions::default()
    })
    .unwrap_or_else(|e| panic!("{e:#}"));
    let (a, b) = (
        world.report.static_weighing.expect("online"),
        offline.report.static_weighing.expect("offline"),
    );
    assert!(
        (a.payload.mass_kg - b.payload.mass_kg).abs() < 1e-6,
        "{a:?} vs {b:?}"
    );
    assert!((a.payload.com_xy_m[0] - b.payload.com_xy_m[0]).abs() < 1e-9);
    assert!((a.payload.sigma_mass_kg - b.payload.sigma_mass_kg).abs() < 1e-6);
}
