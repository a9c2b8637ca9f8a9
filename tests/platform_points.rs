//! A rig described by its joints' points (`[platform] base_joints_m`, `plate_joints_m`), as a
//! survey gives them: the radii form's own points measure the same to every digit, and a layout
//! off the symmetric one measures its payload.

use crate::support;

use support::{simulate_with, SHORT};

/// `[platform]` with the default rig's joints, each shifted by `shift(leg, plate)`, m.
fn points_toml(shift: impl Fn(usize, bool) -> [f64; 3]) -> String {
    let loaded = rig_description::load::load(None).unwrap();
    let g = rig_description::derived::geometry(&loaded).unwrap();
    let moved = |points: &[nalgebra::Vector3<f64>; 6], plate: bool| -> [[f64; 3]; 6] {
        std::array::from_fn(|i| {
            let d = shift(i, plate);
            [points[i].x + d[0], points[i].y + d[1], points[i].z + d[2]]
        })
    };
    rig_description::derived::points_table(
        &moved(g.base_joints_m(), false),
        &moved(g.plate_joints_m(), true),
    )
}

#[test]
fn the_radii_form_and_its_points_give_the_same_report() {
    let radii = simulate_with(SHORT, |_, _| {});
    let points = simulate_with(
        &format!("{SHORT}{}", points_toml(|_, _| [0.0; 3])),
        |_, _| {},
    );
    let (a, b) = (&radii.report, &points.report);
    assert_eq!(a.estimate, b.estimate);
    assert_eq!(a.sigma, b.sigma);
    assert_eq!(a.error_budget, b.error_budget);
    assert_eq!(a.samples, b.samples);
}

#[test]
fn surveyed_joints_off_the_symmetric_layout_measure_the_payload() {
    // Every joint 1-3 cm off the drawing, the pairs' separations unequal.
    let shift = |i: usize, plate: bool| {
        let k = (i + if plate { 6 } else { 0 }) as f64;
        let r = 0.01 + 0.02 * ((k * 0.37) % 1.0);
        let a = k * 1.1;
        [r * a.cos(), r * a.sin(), 0.0]
    };
    let scenario = format!("{SHORT}{}", points_toml(shift));
    let run = simulate_with(&scenario, |_, _| {});
    let (e, s) = (&run.report.estimate, &run.report.sigma);
    let truth = run
        .report
        .truth
        .as_ref()
        .expect("a simulation knows its truth");
    let z = (e.mass - truth.mass) / s.mass;
    assert!(
        z.abs() < 4.0,
        "mass {} ± {} kg against {}",
        e.mass,
        s.mass,
        truth.mass
    );
    for k in 0..3 {
        let z = (e.com[k] - truth.com[k]) / s.com[k];
        assert!(
            z.abs() < 4.0,
            "c[{k}] {} ± {} m against {}",
            e.com[k],
            s.com[k],
            truth.com[k]
        );
    }
}

/// A rig whose home is not the mid-stroke one (`platform.home_height_m`, as the owner
/// measures it, 3 cm higher): the simulated world and the estimator both start from it, the
/// plate's first recorded pose is there, and the payload is measured.
#[test]
fn a_measured_home_height_is_where_the_rig_starts_and_measures() {
    let mid = support::geometry().home_pose().position_m.z;
    let z = mid + 0.03;
    let run = simulate_with(
        &format!("{SHORT}[platform]\nhome_height_m = {z}\n"),
        |_, _| {},
    );
    let log = runlog::LogContents::read(&run.log).unwrap();
    let first = log.poses.first().expect("the log records the plate's pose");
    assert!(
        (first.desired.position_m[2] - z).abs() < 1e-4,
        "the plate is commanded at z = {} m first, its home is {z} m",
        first.desired.position_m[2]
    );
    let (e, s) = (&run.report.estimate, &run.report.sigma);
    let truth = run.report.truth.as_ref().expect("a simulation's truth");
    assert!(
        (e.mass - truth.mass).abs() < 4.0 * s.mass,
        "{} vs {}",
        e.mass,
        truth.mass
    );
    for k in 0..3 {
        assert!((e.com[k] - truth.com[k]).abs() < 4.0 * s.com[k], "c[{k}]");
    }
}
