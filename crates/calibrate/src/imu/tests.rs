//! The alignment fit against a motion written independently of it: a plate turning and moving
//! along sines, its rate and angular acceleration from finite differences of the rotation
//! matrix (not the fit's quaternion formula), its acceleration analytic, and readings made
//! with a known G, A, r, τ and biases.

use super::*;
use nalgebra::{Rotation3, UnitQuaternion};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal as Gauss};
use rig_description::calibration::imu::GYRO_PARAMETERS;

const H: f64 = 0.01;

fn rotation(t: f64) -> Rotation3<f64> {
    let a = 0.02;
    Rotation3::new(Vector3::new(
        a * (2.0 * 0.9 * std::f64::consts::PI * t).sin(),
        a * (2.0 * 1.3 * std::f64::consts::PI * t + 0.4).sin(),
        a * (2.0 * 1.7 * std::f64::consts::PI * t + 1.1).sin(),
    ))
}

fn position(t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let w = [0.7, 1.1, 1.5].map(|f| 2.0 * std::f64::consts::PI * f);
    let amp = [0.01, 0.008, 0.006];
    let p = Vector3::from_fn(|i, _| amp[i] * (w[i] * t).sin());
    let a = Vector3::from_fn(|i, _| -amp[i] * w[i] * w[i] * (w[i] * t).sin());
    (p + Vector3::new(0.0, 0.0, 1.2), a)
}

/// Body rate and its derivative by central differences of R(t) (step 1e-5 s).
fn rate(t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let d = 1e-5;
    let w = |t: f64| {
        let r = rotation(t);
        let rd = (rotation(t + d).matrix() - rotation(t - d).matrix()) / (2.0 * d);
        let s = r.matrix().transpose() * rd;
        Vector3::new(s[(2, 1)], s[(0, 2)], s[(1, 0)])
    };
    (w(t), (w(t + d) - w(t - d)) / (2.0 * d))
}

struct Truth {
    g: Matrix3<f64>,
    a: Matrix3<f64>,
    r: Vector3<f64>,
    tau: f64,
}

fn truth() -> Truth {
    Truth {
        g: Rotation3::new(Vector3::new(8e-4, -6e-4, 1e-3)).matrix()
            * Matrix3::from_diagonal(&Vector3::new(1.0 + 4e-4, 1.0 - 7e-4, 1.0 + 2e-4)),
        // One package: the accelerometer's axes are the gyro's.
        a: *Rotation3::new(Vector3::new(8e-4, -6e-4, 1e-3)).matrix(),
        r: Vector3::new(0.12, -0.05, 0.03),
        tau: 1.2e-4,
    }
}

fn record(truth: &Truth, seconds: f64, gyro_noise: f64, accel_noise: f64, seed: u64) -> Vec<Entry> {
    let g_b = Vector3::new(0.0, 0.0, -9.81);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let gn = Gauss::new(0.0, gyro_noise.max(1e-300)).unwrap();
    let an = Gauss::new(0.0, accel_noise.max(1e-300)).unwrap();
    let n = (seconds / H) as usize;
    (0..n)
        .map(|k| {
            let t = k as f64 * H;
            let late = t - truth.tau;
            let (w, wdot) = rate(late);
            let (_, acc) = position(late);
            let f = rotation(late).inverse() * (acc - g_b)
                + wdot.cross(&truth.r)
                + w.cross(&w.cross(&truth.r));
            let gyro = truth.g * w
                + Vector3::new(1e-4, -2e-4, 5e-5)
                + Vector3::from_fn(|_, _| gn.sample(&mut rng));
            let accel = truth.a * f
                + Vector3::new(2e-3, -1e-3, 3e-3)
                + Vector3::from_fn(|_, _| an.sample(&mut rng));
            Entry {
                time_s: t,
                samples: 1,
                position_m: position(t).0,
                quaternion: *UnitQuaternion::from_rotation_matrix(&rotation(t)).quaternion(),
                gyro_rad_s: gyro,
                products: measure::record::derivative::products(&gyro),
                accel_m_s2: accel,
                ..Entry::default()
            }
        })
        .collect()
}

fn errors(fit: &ImuAlignment, truth: &Truth) -> ([f64; 10], [f64; 3]) {
    let g = fit.gyro() - truth.g;
    let r = Vector3::from(fit.accelerometer_position_m) - truth.r;
    let gyro = core::array::from_fn(|k| {
        if k < 9 {
            g[(k / 3, k % 3)]
        } else {
            fit.imu_delay_s - truth.tau
        }
    });
    (gyro, r.into())
}

fn fitted(entries: &[Entry]) -> ImuAlignment {
    let g = measure::testkit::geometry();
    fit(entries, &Vector3::new(0.0, 0.0, -9.81), &g, 0.0).unwrap()
}

/// Without noise the fit recovers every parameter to the derivatives' truncation error.
#[test]
fn recovers_a_known_alignment_from_clean_readings() {
    let t = truth();
    let fit = fitted(&record(&t, 20.0, 0.0, 0.0, 1));
    let (ge, re) = errors(&fit, &t);
    for (k, e) in ge.iter().enumerate().take(9) {
        assert!(e.abs() < 1e-5, "{}: {e:e}", GYRO_PARAMETERS[k]);
    }
    assert!(ge[9].abs() < 2e-6, "tau: {:e}", ge[9]);
    for (k, e) in re.iter().enumerate() {
        assert!(e.abs() < 1e-5, "r {k}: {e:e}");
    }
    assert!((fit.accel() - t.a).norm() < 1e-5);
    assert!((fit.gyro_bias_rad_s[1] + 2e-4).abs() < 1e-6);
    assert!((fit.accel_bias_m_s2[2] - 3e-3).abs() < 1e-5);
}

/// With white noise of a default IMU averaged over 10 samples, over 80 seeds the errors have
/// mean z² near 1 for every parameter (each in [0.56, 1.60]) and none beyond 4 sigma. For
/// honest sigmas 80·(mean z²) is χ² with 80 degrees of freedom, inside that band with
/// probability 99.9 % (0.05 % either side): sigmas √2 too wide (mean z² 0.5) or too narrow
/// (2) fall outside it.
#[test]
fn reported_sigmas_cover_the_errors_of_noisy_readings() {
    let t = truth();
    let seeds = 80;
    let mut z2g = [0.0; 10];
    let mut z2r = [0.0; 3];
    for seed in 0..seeds {
        let entries = record(&t, 20.0, 5e-4, 4e-3, seed);
        let fit = fitted(&entries);
        let (ge, re) = errors(&fit, &t);
        for k in 0..10 {
            let z = ge[k] / fit.gyro_sigma(k);
            assert!(z.abs() < 4.0, "seed {seed} {}: z {z}", GYRO_PARAMETERS[k]);
            z2g[k] += z * z / seeds as f64;
        }
        for k in 0..3 {
            let z = re[k] / fit.position_sigma(k);
            assert!(z.abs() < 4.0, "seed {seed} r {k}: z {z}");
            z2r[k] += z * z / seeds as f64;
        }
    }
    for (k, z2) in z2g.iter().enumerate() {
        assert!(
            (0.56..1.60).contains(z2),
            "{}: mean z² {z2}",
            GYRO_PARAMETERS[k]
        );
    }
    for (k, z2) in z2r.iter().enumerate() {
        assert!((0.56..1.60).contains(z2), "r {k}: mean z² {z2}");
    }
}

#[test]
fn a_plate_at_rest_is_refused_as_unobservable() {
    let entries: Vec<Entry> = (0..500)
        .map(|k| Entry {
            time_s: k as f64 * H,
            samples: 1,
            position_m: Vector3::new(0.0, 0.0, 1.2),
            quaternion: Quaternion::identity(),
            accel_m_s2: Vector3::new(0.0, 0.0, 9.81),
            ..Entry::default()
        })
        .collect();
    let g = measure::testkit::geometry();
    let down = Vector3::new(0.0, 0.0, -9.81);
    assert!(matches!(
        fit(&entries, &down, &g, 2e-4),
        Err(AlignmentError::Unobservable { .. })
    ));
    assert!(matches!(
        fit(&entries[..50], &down, &g, 2e-4),
        Err(AlignmentError::TooShort { .. })
    ));
}

/// The joints' tolerance counts in the covariance: on the platform of the budget's tests,
/// moving through its workspace, 0.2 mm joints widen every sigma, and a zero tolerance adds
/// nothing.
#[test]
fn the_joints_tolerance_widens_the_sigmas() {
    let g = measure::testkit::geometry();
    let home = g.home_pose();
    let t = truth();
    let mut entries = record(&t, 20.0, 5e-4, 4e-3, 3);
    for e in &mut entries {
        e.position_m += home.position_m - Vector3::new(0.0, 0.0, 1.2);
    }
    let down = Vector3::new(0.0, 0.0, -9.81);
    let none = fit(&entries, &down, &g, 0.0).unwrap();
    let some = fit(&entries, &down, &g, 2e-4).unwrap();
    for (k, name) in GYRO_PARAMETERS.iter().enumerate() {
        assert!(some.gyro_sigma(k) >= none.gyro_sigma(k), "{name}");
    }
    for k in 0..3 {
        assert!(some.position_sigma(k) > none.position_sigma(k), "r {k}");
    }
    assert_eq!(some.gyro_matrix, none.gyro_matrix);
}
