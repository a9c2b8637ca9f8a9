//! Tests of the projection onto the consistent set: closed-form cases, the optimality of the
//! answer against consistent bodies built from point masses (an independent construction of
//! the consistent set), and robustness to degenerate input.

use super::*;
use crate::testkit::{random_body, PointBody};
use nalgebra::Vector4;
use rand::{rngs::StdRng, Rng, SeedableRng};

fn diagonal_body(mass: f64, moments: [f64; 3]) -> ParameterVector {
    InertialParameters::from_com(
        mass,
        Vector3::zeros(),
        Matrix3::from_diagonal(&Vector3::from(moments)),
    )
    .to_vector()
}

fn diagonal_p(v: [f64; N]) -> ParameterCovariance {
    ParameterCovariance::from_diagonal(&SVector::from(v))
}

/// ½(θ − θ̂)ᵀ P⁻¹ (θ − θ̂).
fn half_d2(theta: &ParameterVector, hat: &ParameterVector, p: &ParameterCovariance) -> f64 {
    let d = theta - hat;
    0.5 * d.dot(&p.cholesky().expect("test P is positive definite").solve(&d))
}

fn random_spd(rng: &mut StdRng, scales: &ParameterVector) -> ParameterCovariance {
    let a = SMatrix::<f64, N, N>::from_fn(|_, _| rng.random_range(-1.0..1.0));
    let s = ParameterCovariance::from_diagonal(scales);
    s * (a * a.transpose() + ParameterCovariance::identity() * 0.05) * s
}

#[test]
fn pseudo_inertia_of_a_point_mass_is_m_times_the_outer_product_of_its_homogeneous_position() {
    let r = Vector3::new(0.3, -0.2, 0.7);
    let theta = InertialParameters::point_mass(2.5, r).to_vector();
    let v = Vector4::new(r.x, r.y, r.z, 1.0);
    assert!((pseudo_inertia(&theta) - v * v.transpose() * 2.5).norm() < 1e-14);
    let back = from_pseudo_inertia(&pseudo_inertia(&theta));
    assert!((back - theta).norm() < 1e-14);
}

/// J broken by the triangle inequality only, h = 0, products zero, P diagonal: by the
/// reflections x → −x, y → −y (which keep θ̂, P and the cone) the answer has h = 0 and no
/// products, so it is the P-projection onto the half-space a·θ ≥ 0 with a = (1, 1, −1) on
/// (Jxx, Jyy, Jzz): θ* = θ̂ − (a·θ̂)/(aᵀPa) · P a.
#[test]
fn a_broken_triangle_with_diagonal_p_goes_to_the_closed_form_point() {
    let hat = diagonal_body(3.0, [1.0, 1.0, 2.2]);
    assert!(!InertialParameters::from_vector(&hat)
        .consistency()
        .is_consistent());
    let var = [1e-2, 1e-3, 1e-3, 1e-3, 1.0, 1.0, 2.0, 0.3, 0.3, 0.3];
    let p = diagonal_p(var);
    let out = nearest_consistent(&hat, &p).expect("projects");
    assert!(out.projected && out.converged);
    // a·θ̂ = −0.2, aᵀPa = 4: θ* = θ̂ + 0.05 (1, 1, −2) on the diagonal; m and h do not move.
    let mut expect = hat;
    expect[4] += 0.05;
    expect[5] += 0.05;
    expect[6] -= 0.1;
    let got = out.parameters.to_vector();
    assert!((got - expect).norm() < 1e-7, "{got} vs {expect}");
    // d² = (a·θ̂)²/(aᵀPa) = 0.01.
    assert!(
        (out.distance_sigma - 0.1).abs() < 1e-7,
        "{}",
        out.distance_sigma
    );
    assert!(out.parameters.consistency().is_consistent());
    let principal = out.parameters.principal().expect("positive mass");
    let m = principal.moments_kg_m2;
    assert!(
        (m.x + m.y - m.z).abs() < 1e-7,
        "on the triangle's boundary: {m}"
    );
}

/// A negative mass with h = 0 and a consistent tensor: J = diag(Σ, m), so only m ≥ 0 binds and
/// the answer is m* = 0⁺ with everything else unchanged.
#[test]
fn a_negative_mass_with_no_first_moment_goes_to_zero_mass() {
    let hat = diagonal_body(-0.5, [1.0, 2.0, 2.5]);
    let p = diagonal_p([0.04, 1e-3, 1e-3, 1e-3, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]);
    let out = nearest_consistent(&hat, &p).expect("projects");
    assert!(out.projected && out.converged);
    let got = out.parameters.to_vector();
    assert!(got[0] > 0.0 && got[0] < 1e-6, "mass {}", got[0]);
    assert!((1..N).all(|i| (got[i] - hat[i]).abs() < 1e-6), "{got}");
    assert!((out.distance_sigma - 0.5 / 0.2).abs() < 1e-5);
    assert!(out.parameters.consistency().is_consistent());
}

#[test]
fn a_consistent_estimate_is_returned_unchanged() {
    let hat = PointBody::vehicle_like().parameters().to_vector();
    let p = diagonal_p([1.0; N]);
    let out = nearest_consistent(&hat, &p).expect("consistent");
    assert!(!out.projected);
    assert_eq!(out.parameters.to_vector(), hat);
    assert_eq!(out.distance_sigma, 0.0);
}

/// (θ* − θ̂)ᵀ P⁻¹ (q − θ*) ≥ 0 for every q of a convex set characterises the projection onto it;
/// with q from point-mass bodies (consistent by construction), and q* + small steps that pass
/// the consistency check, no consistent point is closer to θ̂ than θ*.
fn assert_nearest(
    hat: &ParameterVector,
    p: &ParameterCovariance,
    out: &Projection,
    rng: &mut StdRng,
) {
    let star = out.parameters.to_vector();
    let best = half_d2(&star, hat, p);
    assert!((2.0 * best).sqrt() - out.distance_sigma <= 1e-6 * (1.0 + out.distance_sigma));
    let w = p.cholesky().expect("spd").inverse();
    let tol = 1e-6 * (1.0 + best);
    for _ in 0..200 {
        let q = random_body(rng).parameters().to_vector();
        let ip = (star - hat).dot(&(w * (q - star)));
        assert!(ip >= -tol, "variational inequality broken: {ip}");
        assert!(half_d2(&q, hat, p) >= best - tol);
    }
    // Neighbours of θ*: random steps of 1e-5 to 1 sigma; and, since at a corner of the set
    // (m → 0 forces h → 0) few such steps stay consistent, points of the segment to a
    // point-mass body (consistent by convexity) moved by a thousandth of that step.
    let (l, _) = square_root(p).expect("spd");
    let mut tried = 0;
    for k in 0..2000 {
        let radius = 10f64.powi(-(k % 6));
        let z = SVector::<f64, N>::from_fn(|_, _| rng.random_range(-1.0..1.0)) * radius;
        let q = if k % 2 == 0 {
            let b = random_body(rng).parameters().to_vector();
            star + (b - star) * (radius * 1e-3) + l * z * 1e-3
        } else {
            star + l * z
        };
        if InertialParameters::from_vector(&q)
            .consistency()
            .is_consistent()
        {
            tried += 1;
            assert!(
                half_d2(&q, hat, p) >= best - tol,
                "a consistent point is closer: {} < {}",
                half_d2(&q, hat, p),
                best
            );
        }
    }
    assert!(tried > 50, "too few consistent neighbours sampled: {tried}");
}

#[test]
fn a_broken_triangle_off_the_axes_is_repaired_to_the_nearest_consistent_point() {
    let mut rng = StdRng::seed_from_u64(14);
    let r = nalgebra::Rotation3::from_euler_angles(0.4, -0.3, 1.2);
    let jc = r.matrix()
        * Matrix3::from_diagonal(&Vector3::new(100.0, 150.0, 280.0))
        * r.matrix().transpose();
    let hat = InertialParameters::from_com(400.0, Vector3::new(0.1, -0.2, 0.5), jc).to_vector();
    assert_eq!(
        InertialParameters::from_vector(&hat)
            .consistency()
            .first_failure(),
        Some(stewart_types::Inconsistency::TriangleInequality)
    );
    let scales = ParameterVector::from_fn(|i, _| match i {
        0 => 0.5,
        1..=3 => 0.05,
        _ => 2.0,
    });
    let p = random_spd(&mut rng, &scales);
    let out = nearest_consistent(&hat, &p).expect("projects");
    assert!(out.projected && out.converged);
    assert!(out.parameters.consistency().is_consistent());
    assert_nearest(&hat, &p, &out, &mut rng);
}

#[test]
fn a_negative_mass_with_a_first_moment_is_repaired_to_the_nearest_consistent_point() {
    let mut rng = StdRng::seed_from_u64(7);
    let mut hat = PointBody::vehicle_like().parameters().to_vector();
    hat[0] = -3.0;
    let scales = ParameterVector::from_fn(|i, _| if i == 0 { 2.0 } else { 0.5 });
    let p = random_spd(&mut rng, &scales);
    let out = nearest_consistent(&hat, &p).expect("projects");
    assert!(out.projected && out.converged);
    assert!(out.parameters.mass_kg > 0.0);
    assert!(out.parameters.consistency().is_consistent());
    assert_nearest(&hat, &p, &out, &mut rng);
}

#[test]
fn no_panic_on_non_finite_or_degenerate_input() {
    let hat = diagonal_body(3.0, [1.0, 1.0, 2.2]);
    let p = diagonal_p([1.0; N]);
    let mut nan = hat;
    nan[3] = f64::NAN;
    assert!(nearest_consistent(&nan, &p).is_none());
    let mut inf = hat;
    inf[0] = f64::INFINITY;
    assert!(nearest_consistent(&inf, &p).is_none());
    let mut p_nan = p;
    p_nan[(2, 5)] = f64::NAN;
    assert!(nearest_consistent(&hat, &p_nan).is_none());
    assert!(nearest_consistent(&hat, &ParameterCovariance::zeros()).is_none());
    assert!(nearest_consistent(&hat, &(-p)).is_none());
    // Rank one: only the mass may move much; the tensor moves at an enormous cost but the
    // answer exists and is consistent.
    let mut rank_one = ParameterCovariance::zeros();
    rank_one[(6, 6)] = 1.0;
    let out = nearest_consistent(&hat, &rank_one).expect("a singular P still projects");
    assert!(out.parameters.consistency().is_consistent());
    // The only cheap direction is Jzz: it goes down to the triangle's bound Jxx + Jyy.
    assert!((out.parameters.inertia_origin_kg_m2[(2, 2)] - 2.0).abs() < 1e-5);
    // A wildly inconsistent estimate (every entry negative).
    let wild = ParameterVector::from_element(-1e3);
    let out = nearest_consistent(&wild, &p).expect("projects");
    assert!(out.parameters.consistency().is_consistent());
}

mod properties {
    use super::{
        assert_nearest, random_body, random_spd, square_root, InertialParameters, ParameterVector,
        SVector, N,
    };
    use crate::projection::nearest_consistent;
    use proptest::prelude::*;
    use rand::{rngs::StdRng, Rng, SeedableRng};

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// Random bodies pushed out of the consistent set by a random error of many sigmas,
        /// with a random covariance: the answer is consistent and satisfies the projection's
        /// optimality condition.
        #[test]
        fn random_inconsistent_estimates_project_to_the_nearest_consistent_point(seed in 0u64..1_000_000) {
            let mut rng = StdRng::seed_from_u64(seed);
            let truth = random_body(&mut rng).parameters().to_vector();
            let scales = ParameterVector::from_fn(|i, _| match i {
                0 => truth[0] * 0.02,
                1..=3 => truth[0] * 0.01,
                _ => truth[4] * 0.1,
            });
            let p = random_spd(&mut rng, &scales);
            let (l, _) = square_root(&p).expect("spd");
            let mut hat = truth;
            for _ in 0..50 {
                let z = SVector::<f64, N>::from_fn(|_, _| rng.random_range(-30.0..30.0));
                hat = truth + l * z;
                if !InertialParameters::from_vector(&hat).consistency().is_consistent() {
                    break;
                }
            }
            let out = nearest_consistent(&hat, &p).expect("projects");
            prop_assert!(out.parameters.consistency().is_consistent());
            if out.projected {
                prop_assert!(out.converged);
                assert_nearest(&hat, &p, &out, &mut rng);
            }
        }
    }
}
