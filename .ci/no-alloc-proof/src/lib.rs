//! Links the three cores and the shared types into a `no_std` static library without an
//! allocator (see Cargo.toml) and calls their per-tick functions, so that the linker sees every
//! path a tick can take; the kinematics and the control pieces also in their f32 instantiation.
#![no_std]

use control::controller::{Controller, ControllerConfig};
use control::io::SensorFrame;
use control::pid::{PidBank, PidConfig};
use control::trajectory::{MultiSineConfig, Trajectory};
use estimator::{EstimatorConfig, OnlineEstimator, Sample};
use kinematics::{FkOptions, Geometry, StrokeLimits, Vector3, Vector6};
use stewart_types::{InertialParameters, STANDARD_GRAVITY_M_S2};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

fn geometry() -> Option<Geometry> {
    let stroke = StrokeLimits {
        min_length_m: 1.5,
        max_length_m: 2.3,
    };
    Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke).ok()
}

/// Kinematics: IK, FK from the lengths, wrench. Returns the FK residual (negative on error).
#[no_mangle]
pub extern "C" fn proof_kinematics_tick(z_offset_m: f64) -> f64 {
    let Some(geometry) = geometry() else {
        return -1.0;
    };
    let mut pose = geometry.home_pose();
    pose.position_m.z += z_offset_m;
    let lengths = geometry.leg_lengths(&pose);
    let _ = geometry.wrench_in_platform(&pose, &Vector6::repeat(1000.0));
    match geometry.forward_kinematics(&lengths, &geometry.home_pose(), &FkOptions::default()) {
        Ok(solution) => solution.residual_m,
        Err(_) => -2.0,
    }
}

/// The f32 instantiation of the kinematics and of the control pieces generic over the scalar
/// (IK, FK, the PID bank, a trajectory sample), as a Cortex-M4F firmware would link them.
/// Returns the first leg's PID output, N (NaN on any error).
#[no_mangle]
pub extern "C" fn proof_f32_tick(time_s: f32, measured_m: f32) -> f32 {
    let stroke = StrokeLimits {
        min_length_m: 1.5_f32,
        max_length_m: 2.3,
    };
    let Ok(geometry) = Geometry::from_radii(1.5_f32, 1.2, 0.35, 0.35, stroke) else {
        return f32::NAN;
    };
    let Ok(trajectory) =
        Trajectory::multisine(geometry.home_pose(), &MultiSineConfig::<f32>::default())
    else {
        return f32::NAN;
    };
    let desired = trajectory.sample(time_s).pose;
    let lengths = geometry.leg_lengths(&desired);
    if geometry
        .forward_kinematics(&lengths, &geometry.home_pose(), &FkOptions::default())
        .is_err()
    {
        return f32::NAN;
    }
    let Ok(mut pids) = PidBank::uniform(PidConfig::<f32>::default()) else {
        return f32::NAN;
    };
    match pids.update(&lengths.into(), &[measured_m; 6], &[0.0; 6], 1e-3) {
        Ok([first, ..]) => first.output,
        Err(_) => f32::NAN,
    }
}

/// A full control-and-estimation tick on `ticks` synthetic frames at rest: controller (FK,
/// trajectory, IK, PIDs, supervisor) and estimator (wrench, conditioning, regressor, RLS).
/// Returns the estimated mass (NaN on any error).
#[no_mangle]
pub extern "C" fn proof_full_ticks(ticks: u32, leg_force_n: f64) -> f64 {
    let Some(geometry) = geometry() else {
        return f64::NAN;
    };
    let Ok(trajectory) = Trajectory::multisine(geometry.home_pose(), &MultiSineConfig::default())
    else {
        return f64::NAN;
    };
    let config = ControllerConfig::default();
    let Ok(mut controller) = Controller::new(geometry, trajectory, config) else {
        return f64::NAN;
    };
    let Ok(mut estimator) =
        OnlineEstimator::new(EstimatorConfig::new(geometry, config.sample_period_s))
    else {
        return f64::NAN;
    };
    let home = geometry.home_pose();
    let lengths = geometry.leg_lengths(&home);
    for k in 0..ticks {
        let frame = SensorFrame {
            sequence: u64::from(k),
            time_s: f64::from(k) * config.sample_period_s,
            leg_lengths_m: lengths.into(),
            leg_forces_n: [leg_force_n; 6],
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, STANDARD_GRAVITY_M_S2],
            ..SensorFrame::default()
        };
        let out = controller.tick(&frame);
        let sample = Sample {
            time_s: frame.time_s,
            sequence: Some(frame.sequence),
            pose: out.measured_pose.unwrap_or(home),
            leg_forces_n: Vector6::from(frame.leg_forces_n),
            gyro_rad_s: Vector3::from(frame.gyro_rad_s),
            accel_m_s2: Vector3::from(frame.accel_m_s2),
        };
        let _ = estimator.update(&sample);
    }
    estimator.estimate().parameters.mass_kg
}

/// Shared types: the consistency check of a parameter set (eigen-decomposition of J_C) on a
/// point mass `mass_kg` at height `height_m` above the P origin plus a 1 kg·m² sphere about it.
/// Returns 1 when consistent, 0 when not.
#[no_mangle]
pub extern "C" fn proof_parameters_consistent(mass_kg: f64, height_m: f64) -> u32 {
    let sphere =
        InertialParameters::from_com(1.0, Vector3::zeros(), kinematics::Matrix3::identity());
    let point = InertialParameters::point_mass(mass_kg, Vector3::new(0.0, 0.0, height_m));
    u32::from((sphere + point).consistency().is_consistent())
}
