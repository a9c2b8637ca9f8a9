//! Links the cores into a `no_std` static library without an allocator (see Cargo.toml).
#![no_std]

use kinematics::{FkOptions, Geometry, Pose, StrokeLimits, Vector6};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

/// One kinematics tick: geometry, IK, FK from the lengths, wrench. Returns the residual.
#[no_mangle]
pub extern "C" fn proof_kinematics_tick(z_offset_m: f64) -> f64 {
    let stroke = StrokeLimits { min_length_m: 1.5, max_length_m: 2.3 };
    let Ok(geometry) = Geometry::from_radii(1.5, 1.2, 0.35, 0.35, stroke) else {
        return -1.0;
    };
    let mut pose: Pose = geometry.home_pose();
    pose.position_m.z += z_offset_m;
    let lengths = geometry.leg_lengths(&pose);
    let wrench = geometry.wrench_in_platform(&pose, &Vector6::repeat(1000.0));
    match geometry.forward_kinematics(&lengths, &geometry.home_pose(), &FkOptions::default()) {
        Ok(solution) => solution.residual_m + wrench.force_n.z * 0.0,
        Err(_) => -2.0,
    }
}
