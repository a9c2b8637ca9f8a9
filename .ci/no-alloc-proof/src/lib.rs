//! Links the three cores, the rig core and the shared types into a `no_std` static library
//! without an allocator (see Cargo.toml) and calls their per-tick functions, so that the linker
//! sees every path a tick can take; the kinematics and the control pieces also in their f32
//! instantiation.
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

/// The rig core: a keyed core opens a session from a host's `Hello`, takes one command and
/// runs `ticks` periods on a sensed frame at rest, encoding every frame into a static outbox.
/// Returns the bytes the core emitted (0 when the session did not open).
#[no_mangle]
pub extern "C" fn proof_rig_tick(ticks: u32, leg_length_m: f64) -> u32 {
    use rig::codec::{self, Auth, MAX_FRAME_LEN};
    use rig::firmware::{CoreConfig, CoreKey, Outbox, RigCore};
    use rig::wire::{identity_from_str, Command, Hello, Limits, Message, SensorLayout};

    static mut OUTBOX: Outbox<u8> = Outbox::new();
    const KEY: &[u8] = b"no-alloc proof key, 32 bytes....";
    const MS: u64 = 1_000_000;
    let Ok(key) = CoreKey::new(KEY) else {
        return 0;
    };
    let config = CoreConfig {
        identity: identity_from_str("no-alloc proof"),
        layout: SensorLayout {
            leg_count: 6,
            imu_present: true,
            accel_position_m: [0.0; 3],
        },
        limits: Limits {
            stroke_min_m: 1.5,
            stroke_max_m: 2.3,
            speed_max_m_s: 0.5,
            force_min_n: -5000.0,
            force_max_n: 5000.0,
        },
        sample_period_ns: MS,
        watchdog_ns: 20 * MS,
        session_timeout_ns: 1000 * MS,
        key: Some(key),
        enforce_motion_limits: true,
        speed_window: 10,
        seed: u64::from(ticks),
    };
    let Ok(mut rig) = RigCore::<u8>::new(config) else {
        return 0;
    };
    // SAFETY: the only reference to OUTBOX, on the one thread that runs this function.
    let out = unsafe { &mut *core::ptr::addr_of_mut!(OUTBOX) };
    let mut frame = [0u8; MAX_FRAME_LEN];
    let hello = Message::Hello(Hello {
        host_nonce: 1,
        key_id: Some(codec::key_id(KEY)),
    });
    let auth = Auth {
        key: KEY,
        session_id: 0,
    };
    let Ok(n) = codec::encode(&hello, Some(&auth), &mut frame) else {
        return 0;
    };
    rig.receive(0, 1, frame.get(..n).unwrap_or(&[]), out);
    out.clear();
    let Some(session) = rig.session() else {
        return 0;
    };
    let command = Message::Command(Command {
        sequence: 1,
        sensor_sequence: 0,
        leg_forces_n: [100.0; 6],
        enable: true,
    });
    let auth = Auth {
        key: KEY,
        session_id: session.session_id,
    };
    let Ok(n) = codec::encode(&command, Some(&auth), &mut frame) else {
        return 0;
    };
    rig.receive(0, 1, frame.get(..n).unwrap_or(&[]), out);
    let sensors = SensorFrame {
        leg_lengths_m: [leg_length_m; 6],
        accel_m_s2: [0.0, 0.0, STANDARD_GRAVITY_M_S2],
        ..SensorFrame::default()
    };
    let mut sent = 0u32;
    for k in 0..ticks {
        let _ = rig.tick(u64::from(k) * MS, &sensors, out);
        for f in out.frames() {
            sent = sent.saturating_add(u32::try_from(f.bytes().len()).unwrap_or(u32::MAX));
        }
        out.clear();
    }
    sent
}
