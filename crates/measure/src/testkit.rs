//! What the crate's tests share: the reference platform.

use kinematics::{Geometry, StrokeLimits};

/// The default rig's design.
pub fn geometry() -> Geometry {
    Geometry::from_radii(
        1.5,
        1.2,
        20f64.to_radians(),
        20f64.to_radians(),
        StrokeLimits {
            min_length_m: 1.5,
            max_length_m: 2.3,
        },
    )
    .expect("reference design")
}
