//! The same cases computed in f32 and in f64, compared within tolerances derived from f32's
//! precision. Each case is one generic function run for both scalars, returning f64 so that
//! the two results can be subtracted.
//!
//! Notation: u = 2⁻²⁴ ≈ 6.0e-8 is f32's unit roundoff (half its machine epsilon 1.19e-7); the
//! default geometry (joint circles 1.5 m and 1.2 m, legs 1.5–2.3 m) has every coordinate, leg
//! vector component and moment arm below L = 2.3 m.

use crate::{FkOptions, Geometry, KinematicsError, Pose, Real, StrokeLimits};
use nalgebra::{Matrix6, Vector3, Vector6};
use rand::{rngs::StdRng, Rng, SeedableRng};

/// f32's unit roundoff.
const U: f64 = 5.960_464_477_539_063e-8;
/// Largest coordinate, leg length and moment arm of the default geometry, m.
const LEVER_M: f64 = 2.3;

/// The default design, built in `T` from the same literals (so the f32 design is the f64 one
/// rounded, its home height solved in f32).
fn geometry<T: Real>() -> Geometry<T> {
    let stroke = StrokeLimits {
        min_length_m: T::lit(1.5),
        max_length_m: T::lit(2.3),
    };
    match Geometry::from_radii(T::lit(1.5), T::lit(1.2), T::lit(0.35), T::lit(0.35), stroke) {
        Ok(g) => g,
        Err(e) => panic!(
            "default geometry refused in {}: {e}",
            core::any::type_name::<T>()
        ),
    }
}

/// Reachable poses about home, each coordinate drawn uniformly (seeded, so a failure repeats).
fn poses(count: usize) -> impl Iterator<Item = Pose> {
    let g = geometry::<f64>();
    let home = g.home_pose();
    let mut rng = StdRng::seed_from_u64(16);
    core::iter::repeat_with(move || {
        Pose::from_rpy(
            home.position_m
                + Vector3::new(
                    rng.random_range(-0.15..0.15),
                    rng.random_range(-0.15..0.15),
                    rng.random_range(-0.2..0.2),
                ),
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.2..0.2),
            rng.random_range(-0.3..0.3),
        )
    })
    .filter(move |pose| g.check_reachable(pose).is_ok())
    .take(count)
}

fn widen<T: Real>(v: &Vector6<T>) -> Vector6<f64> {
    v.map(T::to_f64)
}

/// IK in `T`: the leg lengths of `pose` (given in f64, rounded into `T`).
fn ik_case<T: Real>(pose: &Pose) -> Vector6<f64> {
    widen(&geometry::<T>().leg_lengths(&pose.cast()))
}

/// The Jacobian in `T` at `pose`.
fn jacobian_case<T: Real>(pose: &Pose) -> Matrix6<f64> {
    geometry::<T>().jacobian(&pose.cast()).map(T::to_f64)
}

/// FK in `T` from the leg lengths of `pose` (IK in f64, rounded into `T` as a sensor reading
/// would be), warm-started 1 cm and 0.01 rad off: the solved pose in f64, its residual and
/// iterations.
fn fk_case<T: Real>(pose: &Pose) -> Result<(Pose, f64, u32), KinematicsError> {
    let g = geometry::<T>();
    let lengths = geometry::<f64>().leg_lengths(pose).map(T::lit);
    let (roll, pitch, yaw) = pose.rpy();
    let offset = pose.position_m + Vector3::repeat(0.01);
    let guess = Pose::from_rpy(offset, roll + 0.01, pitch - 0.01, yaw + 0.01).cast();
    let solution = g.forward_kinematics(&lengths, &guess, &FkOptions::default())?;
    Ok((
        solution.pose.cast(),
        solution.residual_m.to_f64(),
        solution.iterations,
    ))
}

/// Largest singular value of J⁻¹ (1/σmin of J), computed in f64: FK's error amplification.
fn inverse_gain(pose: &Pose) -> f64 {
    let j = geometry::<f64>().jacobian(pose);
    let sigma = j.singular_values();
    1.0 / sigma.min()
}

#[test]
fn ik_in_f32_matches_f64() {
    // Each of l = p + R pᵢ − bᵢ's components sums four terms below L (the f32 inputs rounded,
    // relative u each, and three roundings in the sum), so |δl| ≤ 8 u L ≈ 1.1e-6 m; the norm
    // adds a relative 2u. Measured: 6.5e-7 m over 500 poses (5 ulp of a 1.9 m leg).
    let tolerance_m = 10.0 * U * LEVER_M;
    let mut worst: f64 = 0.0;
    for pose in poses(500) {
        let difference = (ik_case::<f32>(&pose) - ik_case::<f64>(&pose)).amax();
        worst = worst.max(difference);
    }
    eprintln!("IK f32 − f64: {worst:.2e} m (tolerance {tolerance_m:.2e} m)");
    assert!(worst < tolerance_m, "{worst:e} m");
    // The comparison sees f32's rounding at all: a perfect match would mean f64 both times.
    assert!(
        worst > U,
        "f32 IK matches f64 to {worst:e} m: not computed in f32?"
    );
}

#[test]
fn jacobian_in_f32_matches_f64() {
    // Row i is [uᵢ; (R pᵢ) × uᵢ]: uᵢ = lᵢ/‖lᵢ‖ carries the relative error of lᵢ (8 u L/ℓ with
    // ℓ ≥ 1.5 m, about 12 u) and the moment arm R pᵢ (≤ 1.2 m) multiplies it, plus the cross
    // product's own roundings: |δJ| ≤ 12 u · 1.2 + 4 u · 1.2 ≈ 20 u ≈ 1.2e-6. Measured: 6.1e-7
    // over 500 poses.
    let tolerance = 20.0 * U;
    let mut worst: f64 = 0.0;
    for pose in poses(500) {
        let difference = (jacobian_case::<f32>(&pose) - jacobian_case::<f64>(&pose)).amax();
        worst = worst.max(difference);
    }
    eprintln!("Jacobian f32 − f64: {worst:.2e} (tolerance {tolerance:.2e})");
    assert!(worst < tolerance, "{worst:e}");
}

#[test]
fn jacobian_in_f32_maps_twists_as_finite_differences_of_f64_ik() {
    // The f32 Jacobian against central differences of the f64 IK (h = 1e-6: truncation h²
    // ≈ 1e-12, rounding 1e-16/h ≈ 1e-10), so the check does not rest on the f64 Jacobian.
    let g = geometry::<f64>();
    let h = 1e-6;
    for pose in poses(20) {
        let j32 = jacobian_case::<f32>(&pose);
        for k in 0..6 {
            let numeric = crate::jacobian::tests::numeric_column(&g, &pose, k, h);
            let difference = (numeric - j32.column(k)).amax();
            assert!(difference < 20.0 * U, "column {k}: {difference:e}");
        }
    }
}

#[test]
fn fk_in_f32_round_trips_and_matches_f64() {
    // FK stops when every residual is below the f32 tolerance (2e-6 m) and the lengths it
    // matches carry IK's rounding (≤ 10 u L); J⁻¹ amplifies a length error δl into a pose error
    // of at most ‖J⁻¹‖·|δl|·√6 (δl in every leg): the bound below, computed per pose from the
    // f64 Jacobian (the bound comes to 1e-5 at most here). The rotation error carries the same
    // bound in rad (the angular columns of J have moment arms near 1 m). Measured over 300
    // poses: 5.8e-7 m and 3.3e-7 rad from f64, residual at most 2.4e-7 m (2 ulp).
    let mut worst = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64, 0_u32);
    for pose in poses(300) {
        let (p32, residual, iterations) = match fk_case::<f32>(&pose) {
            Ok(solution) => solution,
            Err(e) => panic!("f32 FK failed at {pose:?}: {e}"),
        };
        let (p64, _, _) = match fk_case::<f64>(&pose) {
            Ok(solution) => solution,
            Err(e) => panic!("f64 FK failed at {pose:?}: {e}"),
        };
        let length_error = f64::from(f32::FK_TOLERANCE_M) + 10.0 * U * LEVER_M;
        let bound = inverse_gain(&pose) * length_error * 6f64.sqrt();
        let (dp, dphi) = p32.distance_to(&p64);
        let (dp_truth, dphi_truth) = p32.distance_to(&pose);
        assert!(
            dp < bound && dphi < bound && dp_truth < bound && dphi_truth < bound,
            "f32 FK {dp:e} m, {dphi:e} rad from f64 ({dp_truth:e} m, {dphi_truth:e} rad from \
             the truth), bound {bound:e}"
        );
        assert!(residual <= f64::from(f32::FK_TOLERANCE_M));
        assert!(iterations <= 6, "{iterations} iterations");
        worst = (
            worst.0.max(dp),
            worst.1.max(dphi),
            worst.2.max(bound),
            worst.3.max(residual),
            worst.4.max(iterations),
        );
    }
    eprintln!(
        "FK f32 − f64: {:.2e} m, {:.2e} rad (largest bound {:.2e}); largest f32 residual {:.2e} m, \
         iterations {}",
        worst.0, worst.1, worst.2, worst.3, worst.4
    );
}

#[test]
fn fk_in_f32_often_fails_at_the_f64_tolerance() {
    // Why the tolerance depends on the precision: in f32 a residual below 1e-12 m means all six
    // rounded lengths equal the measured ones exactly, which Newton reaches on some poses and
    // circles around on others (ulp 1.19e-7 m at 1.9 m); each miss would be a fault in the
    // loop. Lengths from f64 IK rounded into f32, as a sensor gives them.
    let g = geometry::<f32>();
    let strict = FkOptions {
        tolerance_m: 1e-12,
        ..FkOptions::default()
    };
    let (mut strict_failures, mut default_failures) = (0, 0);
    let count = 200;
    for pose in poses(count) {
        let lengths = geometry::<f64>().leg_lengths(&pose).map(f32::lit);
        let guess = pose.cast();
        match g.forward_kinematics(&lengths, &guess, &strict) {
            Err(KinematicsError::FkDidNotConverge { .. }) => strict_failures += 1,
            Err(e) => panic!("{e}"),
            Ok(_) => {}
        }
        if g.forward_kinematics(&lengths, &guess, &FkOptions::default())
            .is_err()
        {
            default_failures += 1;
        }
    }
    eprintln!(
        "f32 FK at 1e-12 m: {strict_failures} of {count} fail; at 2e-6 m: {default_failures}"
    );
    assert!(strict_failures > count / 10, "{strict_failures} of {count}");
    assert_eq!(default_failures, 0);
}

#[test]
fn cold_fk_in_f32_finds_a_stroke_end() {
    // Continuation from home to every leg at its minimum, in f32: up to 40 Newton solves in a
    // row, each warm-started from the last, so rounding must not accumulate across them.
    let lengths = Vector6::repeat(1.5);
    let cold =
        |options: FkOptions<f32>| geometry::<f32>().forward_kinematics_cold(&lengths, &options);
    let options = FkOptions {
        max_jump_m: 0.05,
        max_jump_rad: 0.05,
        ..FkOptions::default()
    };
    let p32: Pose = match cold(options) {
        Ok(solution) => solution.pose.cast(),
        Err(e) => panic!("{e}"),
    };
    let p64 = match geometry::<f64>().forward_kinematics_cold(&lengths.cast(), &options.cast()) {
        Ok(solution) => solution.pose,
        Err(e) => panic!("{e}"),
    };
    let (dp, dphi) = p32.distance_to(&p64);
    let bound =
        inverse_gain(&p64) * (f64::from(f32::FK_TOLERANCE_M) + 10.0 * U * LEVER_M) * 6f64.sqrt();
    assert!(
        dp < bound && dphi < bound,
        "{dp:e} m, {dphi:e} rad, bound {bound:e}"
    );
}

#[test]
fn wrench_and_conditioning_in_f32_match_f64() {
    // w = Jᵀf: each component sums six products of a Jacobian entry (error ≤ 20 u, above) and a
    // force near 1 kN, so |δw| ≤ 6 · 20 u · |f|max + 6 u |w| ≈ 130 u · 1.1 kN ≈ 9e-3 N. The
    // inverse condition number comes from the eigenvalues of JᵀJ in f32; an eigenvalue carries
    // an absolute error of a few u·λmax, so the ratio σmin/σmax moves by about
    // u/(2 (σmin/σmax)) ≈ 1e-6 at home's 0.2: allow 1e-5. Measured over 200 poses: 9.1e-4 N and
    // 3.1e-7.
    let forces = Vector6::new(1000.0, 900.0, 1100.0, 1050.0, 980.0, 1020.0);
    let case = |pose: &Pose| {
        let g32 = geometry::<f32>();
        let p32: Pose<f32> = pose.cast();
        let w32 = g32.wrench_in_platform(&p32, &forces.cast());
        let w64 = geometry::<f64>().wrench_in_platform(pose, &forces);
        let dw = (w32.force_n.cast::<f64>() - w64.force_n)
            .amax()
            .max((w32.torque_nm.cast::<f64>() - w64.torque_nm).amax());
        let dc = (f64::from(g32.inverse_condition_number(&p32))
            - geometry::<f64>().inverse_condition_number(pose))
        .abs();
        (dw, dc)
    };
    let (mut worst_w, mut worst_c) = (0.0_f64, 0.0_f64);
    for pose in poses(200) {
        let (dw, dc) = case(&pose);
        worst_w = worst_w.max(dw);
        worst_c = worst_c.max(dc);
    }
    eprintln!("wrench f32 − f64: {worst_w:.2e} N; inverse condition: {worst_c:.2e}");
    assert!(worst_w < 130.0 * U * 1100.0, "{worst_w:e} N");
    assert!(worst_c < 1e-5, "{worst_c:e}");
}
