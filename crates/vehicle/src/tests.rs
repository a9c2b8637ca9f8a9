use super::*;
use rig_description::config::VehicleConvention;

/// θ of point masses (mass, position in some frame) about that frame's origin, from the
/// definition: h = Σ mᵢ rᵢ, I = Σ mᵢ (|rᵢ|² 𝟙 − rᵢ rᵢᵀ).
fn of_points(points: &[(f64, Vector3<f64>)]) -> InertialParameters {
    let mut p = InertialParameters {
        mass_kg: 0.0,
        first_moment_kg_m: Vector3::zeros(),
        inertia_origin_kg_m2: Matrix3::zeros(),
    };
    for (m, r) in points {
        p.mass_kg += m;
        p.first_moment_kg_m += r * *m;
        p.inertia_origin_kg_m2 += (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * *m;
    }
    p
}

fn placement(convention: VehicleConvention) -> VehicleConfig {
    VehicleConfig {
        origin_m: Some([0.85, -0.12, 0.21]),
        orientation_deg: Some([1.5, -2.0, 20.0]),
        origin_tolerance_m: Some(0.0),
        orientation_tolerance_deg: Some(0.0),
        wheels_m: None,
        wheel_tolerance_m: None,
        convention,
        wheelbase_m: Some(2.6),
        track_m: Some(1.5),
    }
}

/// A car-like cloud of masses in V (ISO axes): body, engine, four wheels.
fn car() -> Vec<(f64, Vector3<f64>)> {
    vec![
        (900.0, Vector3::new(-1.2, 0.02, 0.55)),
        (250.0, Vector3::new(-0.2, -0.05, 0.45)),
        (40.0, Vector3::new(0.0, 0.75, 0.3)),
        (40.0, Vector3::new(0.0, -0.75, 0.3)),
        (40.0, Vector3::new(-2.6, 0.75, 0.3)),
        (40.0, Vector3::new(-2.6, -0.75, 0.3)),
        (130.0, Vector3::new(-1.9, 0.3, 0.8)),
    ]
}

#[test]
fn the_change_of_frame_is_the_points_own_in_either_convention() {
    for convention in [VehicleConvention::Iso8855, VehicleConvention::SaeJ670] {
        let v = placement(convention);
        let at = Placement::of(&v).unwrap();
        // The same masses placed on the plate: r_P = o + R_iso r_V.
        let iso = Placement::of(&VehicleConfig {
            convention: VehicleConvention::Iso8855,
            ..v.clone()
        })
        .unwrap();
        let in_p: Vec<_> = car()
            .iter()
            .map(|(m, r)| (*m, iso.origin_m + iso.rotation * r))
            .collect();
        // And written in the convention's axes directly.
        let signs = Vector3::from(convention.axis_signs());
        let in_v: Vec<_> = car()
            .iter()
            .map(|(m, r)| (*m, r.component_mul(&signs)))
            .collect();
        let got = at.express(&of_points(&in_p)).to_vector();
        let want = of_points(&in_v).to_vector();
        for k in 0..10 {
            assert!(
                (got[k] - want[k]).abs() < 1e-9 * want.amax(),
                "{convention:?} θ[{k}]: {} vs {}",
                got[k],
                want[k]
            );
        }
    }
}

#[test]
fn the_load_split_is_what_the_wheels_carry() {
    // Four masses at the contact points: each axle and side carries its own two.
    let wheels = [
        (300.0, Vector3::new(0.0, 0.75, 0.0)),
        (320.0, Vector3::new(0.0, -0.75, 0.0)),
        (260.0, Vector3::new(-2.6, 0.75, 0.0)),
        (250.0, Vector3::new(-2.6, -0.75, 0.0)),
    ];
    for convention in [VehicleConvention::Iso8855, VehicleConvention::SaeJ670] {
        let v = VehicleConfig {
            convention,
            ..placement(VehicleConvention::Iso8855)
        };
        let iso = Placement::of(&placement(VehicleConvention::Iso8855)).unwrap();
        let in_p: Vec<_> = wheels
            .iter()
            .map(|(m, r)| (*m, iso.origin_m + iso.rotation * r))
            .collect();
        let r = results(&v, &of_points(&in_p), &ParameterCovariance::zeros()).unwrap();
        let axle = r.axle_loads.expect("a wheelbase");
        let side = r.side_loads.expect("a track");
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        assert!(
            close(axle.loads_kg[0], 620.0) && close(axle.loads_kg[1], 510.0),
            "{axle:?}"
        );
        assert!(
            close(side.loads_kg[0], 560.0) && close(side.loads_kg[1], 570.0),
            "{side:?}"
        );
        assert!(close(r.cg_height_m[0], 0.0), "{:?}", r.cg_height_m);
    }
}

#[test]
fn the_placements_tolerance_is_a_line_of_the_budget() {
    let iso = Placement::of(&placement(VehicleConvention::Iso8855)).unwrap();
    let in_p: Vec<_> = car()
        .iter()
        .map(|(m, r)| (*m, iso.origin_m + iso.rotation * r))
        .collect();
    let theta = of_points(&in_p);
    let noise = ParameterCovariance::from_diagonal(&ParameterVector::from_element(1e-2));
    let exact = results(&placement(VehicleConvention::Iso8855), &theta, &noise).unwrap();
    assert_eq!(exact.placement_sigma.com, [0.0; 3]);
    let tolerant = VehicleConfig {
        origin_tolerance_m: Some(0.002),
        orientation_tolerance_deg: Some(0.2),
        ..placement(VehicleConvention::Iso8855)
    };
    let r = results(&tolerant, &theta, &noise).unwrap();
    // 2 mm of origin moves the centre of mass by 2 mm along each axis, and 0.2° of turn about
    // the other two axes by 0.2° × its lever arm: c_z's line at least the origin's 2 mm.
    for k in 0..3 {
        assert!(r.placement_sigma.com[k] >= 0.002, "{:?}", r.placement_sigma);
        let combined = (exact.sigma.com[k].powi(2) + r.placement_sigma.com[k].powi(2)).sqrt();
        assert!((r.sigma.com[k] - combined).abs() < 1e-12, "c[{k}]");
    }
    assert_eq!(r.placement_sigma.mass, 0.0);
}

/// The same car placed by its wheels' contact points (where the placement above puts them)
/// gets the same results as placed by its frame's origin and orientation, and its wheelbase
/// and track from the points; each point's survey tolerance is a line of the budget that
/// grows with it.
#[test]
fn the_wheels_contact_points_place_the_car_as_its_frame_does() {
    let by_frame = placement(VehicleConvention::Iso8855);
    let at = Placement::of(&by_frame).unwrap();
    let contact = |x: f64, y: f64| (at.origin_m + at.rotation * Vector3::new(x, y, 0.0)).into();
    let wheels = WheelContacts {
        front_left: contact(0.0, 0.75),
        front_right: contact(0.0, -0.75),
        rear_left: contact(-2.6, 0.75),
        rear_right: contact(-2.6, -0.75),
    };
    let by_wheels = VehicleConfig {
        origin_m: None,
        orientation_deg: None,
        origin_tolerance_m: None,
        orientation_tolerance_deg: None,
        wheels_m: Some(wheels),
        wheel_tolerance_m: Some(0.0),
        wheelbase_m: None,
        track_m: None,
        ..by_frame.clone()
    };
    let in_p: Vec<_> = car()
        .iter()
        .map(|(m, r)| (*m, at.origin_m + at.rotation * r))
        .collect();
    let theta = of_points(&in_p);
    let noise = ParameterCovariance::from_diagonal(&ParameterVector::from_element(1e-2));
    let a = results(&by_frame, &theta, &noise).unwrap();
    let b = results(&by_wheels, &theta, &noise).unwrap();
    let close = |x: f64, y: f64| (x - y).abs() < 1e-9 * (1.0 + x.abs());
    assert!(close(b.wheelbase_m.unwrap(), 2.6) && close(b.track_m.unwrap(), 1.5));
    for k in 0..3 {
        assert!(close(a.estimate.com[k], b.estimate.com[k]), "c[{k}]");
        assert!(close(a.origin_in_p_m[k], b.origin_in_p_m[k]), "o[{k}]");
        assert!(
            close(a.orientation_in_p_deg[k], b.orientation_in_p_deg[k]),
            "{:?} vs {:?}",
            a.orientation_in_p_deg,
            b.orientation_in_p_deg
        );
        for l in 0..3 {
            assert!(close(
                a.estimate.inertia_com[k][l],
                b.estimate.inertia_com[k][l]
            ));
        }
    }
    let (sa, sb) = (a.axle_loads.unwrap(), b.axle_loads.unwrap());
    assert!(close(sa.loads_kg[0], sb.loads_kg[0]) && close(sa.sigma_kg[0], sb.sigma_kg[0]));
    assert!(b.frame.contains("contact points"), "{}", b.frame);
    // The survey's tolerance: 1 mm on each coordinate of each point.
    let surveyed = |t: f64| {
        results(
            &VehicleConfig {
                wheel_tolerance_m: Some(t),
                ..by_wheels.clone()
            },
            &theta,
            &noise,
        )
        .unwrap()
    };
    let (one, two) = (surveyed(0.001), surveyed(0.002));
    assert_eq!(b.placement_sigma.com, [0.0; 3]);
    for k in 0..3 {
        // An origin moved by the front points' mean: at least half a millimetre along x, y.
        assert!(
            one.placement_sigma.com[k] > 4e-4,
            "{:?}",
            one.placement_sigma
        );
        assert!(
            close(two.placement_sigma.com[k], 2.0 * one.placement_sigma.com[k]) || {
                // Linear to first order: twice the tolerance, twice the line within 1 %.
                (two.placement_sigma.com[k] / one.placement_sigma.com[k] - 2.0).abs() < 0.02
            }
        );
    }
    let axle = one.axle_loads.unwrap();
    assert!(axle.sigma_kg[0] > sb.sigma_kg[0], "{axle:?} vs {sb:?}");
}

/// Four level wheels along P's axes give a frame turned by nothing: the frame in words says
/// 0.000°, not the −0.000° the rounding noise of the axes printed.
#[test]
fn level_wheels_along_p_print_no_negative_zero() {
    let v = VehicleConfig {
        origin_m: None,
        orientation_deg: None,
        origin_tolerance_m: None,
        orientation_tolerance_deg: None,
        wheels_m: Some(WheelContacts {
            front_left: [0.3, 0.75, 0.2],
            front_right: [0.3, -0.75, 0.2],
            rear_left: [-2.3, 0.75, 0.2],
            rear_right: [-2.3, -0.75, 0.2],
        }),
        wheel_tolerance_m: Some(0.001),
        wheelbase_m: None,
        track_m: None,
        ..placement(VehicleConvention::Iso8855)
    };
    let theta = of_points(&car());
    let r = results(&v, &theta, &ParameterCovariance::zeros()).unwrap();
    assert!(!r.frame.contains("-0.000"), "{}", r.frame);
    assert_eq!(r.orientation_in_p_deg, [0.0; 3]);
}
