//! `[vehicle]`: where the payload (a vehicle) stands on the plate, as the operator measured it,
//! so that the results can be given in the vehicle's own frame V as well as in P.
//!
//! V is the vehicle frame of ISO 8855: x forward, y left, z up, its origin on the ground plane
//! (the surface the tyres stand on: the plate's top when the car stands on the plate) below
//! the centre of the front axle. `origin_m` is that point in P, `orientation_deg` V's axes in P
//! as roll, pitch, yaw (the pose convention: a vector v in V's axes is `R v` in P with
//! `R = Rx(roll) Ry(pitch) Rz(yaw)`). `convention` only changes how the results are written:
//! SAE J670 turns y to the right and z down (its CG height is then −c_z).
//!
//! Or the placement is measured as the four wheels' contact points in P (`wheels_m`, a
//! survey of the tyres' contact patches' centres), from which V follows
//! ([`WheelContacts::frame`]): z up along the normal of the ground plane through them, x
//! forward from the rear axle's centre to the front axle's in that plane, the origin the front
//! axle's centre on it, and the wheelbase and track their distances.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// How the vehicle-frame results are written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum VehicleConvention {
    /// ISO 8855: x forward, y left, z up.
    #[default]
    Iso8855,
    /// SAE J670: x forward, y right, z down.
    SaeJ670,
}

impl VehicleConvention {
    /// The convention and its axes in words.
    pub fn describe(self) -> &'static str {
        match self {
            VehicleConvention::Iso8855 => "ISO 8855 (x forward, y left, z up)",
            VehicleConvention::SaeJ670 => "SAE J670 (x forward, y right, z down)",
        }
    }

    /// The signs that turn ISO 8855 axes into this convention's (a diagonal rotation).
    pub fn axis_signs(self) -> [f64; 3] {
        match self {
            VehicleConvention::Iso8855 => [1.0, 1.0, 1.0],
            VehicleConvention::SaeJ670 => [1.0, -1.0, -1.0],
        }
    }
}

/// `[vehicle]`: the vehicle frame's placement on the plate and its tolerances (one sigma):
/// `origin_m` (with `orientation_deg`, `origin_tolerance_m`, `orientation_tolerance_deg`) or
/// `wheels_m` (with `wheel_tolerance_m`), one of the two.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleConfig {
    /// V's origin in P, m: on the ground plane below the front axle's centre.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin_m: Option<[f64; 3]>,
    /// V's axes (ISO 8855) in P: roll, pitch, yaw, degrees (0, 0, 0 when omitted).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_deg: Option<[f64; 3]>,
    /// One standard deviation of each coordinate of `origin_m` as it was measured, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub origin_tolerance_m: Option<f64>,
    /// One standard deviation of V's orientation about each of its axes, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub orientation_tolerance_deg: Option<f64>,
    /// The four wheels' contact points in P, m: V, the wheelbase and the track follow.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheels_m: Option<WheelContacts>,
    /// One standard deviation of each coordinate of each contact point as surveyed, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheel_tolerance_m: Option<f64>,
    /// How the results are written (ISO 8855 unless `sae_j670`).
    #[serde(default)]
    pub convention: VehicleConvention,
    /// Distance from the front axle to the rear axle along V's x, m: gives the static
    /// front/rear load split (with `wheels_m`, their distance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheelbase_m: Option<f64>,
    /// Distance between the left and right wheels' contact centres, m: gives the static
    /// left/right load split (with `wheels_m`, the mean of the axles' tracks).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub track_m: Option<f64>,
}

/// `[vehicle.wheels_m]`: each wheel's contact point (the centre of its tyre's contact patch)
/// in P, m.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WheelContacts {
    /// Front left wheel, m.
    pub front_left: [f64; 3],
    /// Front right wheel, m.
    pub front_right: [f64; 3],
    /// Rear left wheel, m.
    pub rear_left: [f64; 3],
    /// Rear right wheel, m.
    pub rear_right: [f64; 3],
}

/// The vehicle frame four contact points give ([`WheelContacts::frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelFrame {
    /// V's origin in P: the front axle's centre on the ground plane, m.
    pub origin_m: Vector3<f64>,
    /// V's ISO 8855 axes in P, as columns: x forward, y left, z up.
    pub axes: Matrix3<f64>,
    /// The front axle's centre to the rear axle's, along x, m.
    pub wheelbase_m: f64,
    /// The mean of the front and rear axles' distances between left and right along y, m.
    pub track_m: f64,
    /// Each contact point's distance from the ground plane, m (equal for the four).
    pub out_of_plane_m: f64,
}

/// Why four contact points give no vehicle frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum WheelProblem {
    /// The points are not four distinct corners of a quadrilateral.
    Degenerate,
    /// Front and rear (or left and right) are swapped: z would point down.
    Swapped,
}

impl WheelProblem {
    /// In words, with what to check.
    pub fn describe(self) -> &'static str {
        match self {
            WheelProblem::Degenerate => {
                "the four contact points do not span a wheelbase and a track (two coincide, \
                 or they lie on one line): give each wheel's contact point in P"
            }
            WheelProblem::Swapped => {
                "the contact points as labelled give a ground plane whose up points away \
                 from the plate's z: front and rear, or left and right, are swapped"
            }
        }
    }
}

impl WheelContacts {
    /// V from the four points. The ground plane is the one through their centroid parallel
    /// to both diagonals (front right − rear left, front left − rear right): the four points
    /// lie equally far from it, which no other plane beats. Its normal, oriented by the
    /// labels (the diagonals' cross product points up for x forward, y left), is z; x is the
    /// rear axle's centre to the front axle's, projected into the plane; y = z × x.
    pub fn frame(&self) -> Result<WheelFrame, WheelProblem> {
        let p = |a: [f64; 3]| Vector3::from(a);
        let (fl, fr, rl, rr) = (
            p(self.front_left),
            p(self.front_right),
            p(self.rear_left),
            p(self.rear_right),
        );
        let centroid = (fl + fr + rl + rr) / 4.0;
        let normal = (fr - rl).cross(&(fl - rr));
        let front = (fl + fr) / 2.0;
        let rear = (rl + rr) / 2.0;
        let scale = (front - rear).norm().max((fl - fr).norm());
        if !(normal.norm() > 1e-6 * scale * scale && scale > 0.0) {
            return Err(WheelProblem::Degenerate);
        }
        let z = normal.normalize();
        if z.z <= 0.0 {
            return Err(WheelProblem::Swapped);
        }
        let forward = front - rear;
        let along = forward - z * forward.dot(&z);
        let wheelbase_m = along.norm();
        if wheelbase_m <= 1e-3 * scale {
            return Err(WheelProblem::Degenerate);
        }
        let x = along / wheelbase_m;
        let y = z.cross(&x);
        let track_m = 0.5 * ((fl - fr).dot(&y) + (rl - rr).dot(&y));
        if track_m <= 1e-3 * scale {
            return Err(WheelProblem::Swapped);
        }
        Ok(WheelFrame {
            origin_m: front - z * (front - centroid).dot(&z),
            axes: Matrix3::from_columns(&[x, y, z]),
            wheelbase_m,
            track_m,
            out_of_plane_m: (fl - centroid).dot(&z).abs(),
        })
    }

    /// The points in the order front left, front right, rear left, rear right.
    pub fn points(&self) -> [[f64; 3]; 4] {
        [
            self.front_left,
            self.front_right,
            self.rear_left,
            self.rear_right,
        ]
    }

    /// The contacts from points in [`Self::points`]' order.
    pub fn from_points(p: [[f64; 3]; 4]) -> Self {
        Self {
            front_left: p[0],
            front_right: p[1],
            rear_left: p[2],
            rear_right: p[3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A car of wheelbase 2.6 m and track 1.5 m, its front axle at x = 0.8 m in P, facing
    /// P's −x (yaw 180°), standing 0.2 m above P's origin.
    fn facing_back() -> WheelContacts {
        WheelContacts {
            front_left: [0.8, -0.75, 0.2],
            front_right: [0.8, 0.75, 0.2],
            rear_left: [3.4, -0.75, 0.2],
            rear_right: [3.4, 0.75, 0.2],
        }
    }

    #[test]
    fn four_level_wheels_give_the_frame_drawn() {
        let f = facing_back().frame().unwrap();
        assert!((f.origin_m - Vector3::new(0.8, 0.0, 0.2)).norm() < 1e-12);
        let expected = Matrix3::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
        assert!((f.axes - expected).norm() < 1e-12, "{}", f.axes);
        assert!((f.wheelbase_m - 2.6).abs() < 1e-12);
        assert!((f.track_m - 1.5).abs() < 1e-12);
        assert!(f.out_of_plane_m < 1e-12);
    }

    /// A plate tilted by 2° about P's y: the frame tilts with the contact points, the
    /// distances are the ones along the ground, and one wheel 4 mm off the plane shares its
    /// offset equally among the four (1 mm each).
    #[test]
    fn a_tilted_plane_and_a_raised_wheel() {
        let t = 2f64.to_radians();
        let (c, s) = (t.cos(), t.sin());
        let turn = |x: f64, y: f64| [c * x, y, -s * x];
        let mut w = WheelContacts {
            front_left: turn(2.6, 0.75),
            front_right: turn(2.6, -0.75),
            rear_left: turn(0.0, 0.75),
            rear_right: turn(0.0, -0.75),
        };
        let f = w.frame().unwrap();
        assert!((f.axes.column(0) - Vector3::new(c, 0.0, -s)).norm() < 1e-12);
        assert!((f.axes.column(2) - Vector3::new(s, 0.0, c)).norm() < 1e-12);
        assert!((f.wheelbase_m - 2.6).abs() < 1e-12 && (f.track_m - 1.5).abs() < 1e-12);
        w.rear_right[2] += 0.004;
        let raised = w.frame().unwrap();
        assert!((raised.out_of_plane_m - 0.001).abs() < 2e-5, "{raised:?}");
    }

    #[test]
    fn swapped_or_collapsed_wheels_are_refused() {
        let w = facing_back();
        let swapped = WheelContacts {
            front_left: w.rear_left,
            front_right: w.rear_right,
            rear_left: w.front_left,
            rear_right: w.front_right,
        };
        assert_eq!(swapped.frame(), Err(WheelProblem::Swapped));
        let on_a_line = WheelContacts::from_points([
            [0.8, 0.0, 0.2],
            [1.0, 0.0, 0.2],
            [3.4, 0.0, 0.2],
            [3.6, 0.0, 0.2],
        ]);
        assert_eq!(on_a_line.frame(), Err(WheelProblem::Degenerate));
        let one_point = WheelContacts::from_points([[1.0, 2.0, 0.0]; 4]);
        assert_eq!(one_point.frame(), Err(WheelProblem::Degenerate));
    }

    /// The `[vehicle]` table `body` loaded as a rig description's: its refusals as
    /// (dotted key, problem).
    fn refusals(body: &str) -> Vec<(String, String)> {
        match crate::load::load_str(&format!("[vehicle]\n{body}"), "car.toml") {
            Ok(_) => Vec::new(),
            Err(e) => e.issues.into_iter().map(|i| (i.key, i.problem)).collect(),
        }
    }

    const WHEELS: &str = "wheel_tolerance_m = 0.001\n[vehicle.wheels_m]\n\
        front_left = [0.8, -0.75, 0.2]\nfront_right = [0.8, 0.75, 0.2]\n\
        rear_left = [3.4, -0.75, 0.2]\nrear_right = [3.4, 0.75, 0.2]\n";

    #[test]
    fn the_wheels_form_loads_and_refuses_what_it_derives() {
        assert_eq!(refusals(WHEELS), Vec::<(String, String)>::new());
        let both = refusals(&format!("origin_m = [0.8, 0.0, 0.2]\n{WHEELS}"));
        assert!(
            both.iter()
                .any(|(k, p)| k == "vehicle.wheels_m" && p.contains("given twice")),
            "{both:?}"
        );
        let derived = refusals(&format!("wheelbase_m = 2.6\n{WHEELS}"));
        assert!(
            derived
                .iter()
                .any(|(k, p)| k == "vehicle.wheelbase_m" && p.contains("follows from")),
            "{derived:?}"
        );
        let untoleranced = refusals(&WHEELS.replace("wheel_tolerance_m = 0.001\n", ""));
        assert!(
            untoleranced
                .iter()
                .any(|(k, p)| k == "vehicle.wheel_tolerance_m" && p.contains("missing")),
            "{untoleranced:?}"
        );
        let neither = refusals("origin_tolerance_m = 0.002\n");
        assert!(
            neither
                .iter()
                .any(|(k, p)| k == "vehicle.origin_m" && p.contains("wheels_m")),
            "{neither:?}"
        );
    }

    #[test]
    fn swapped_labels_and_a_wheel_off_the_ground_are_refused_with_the_check() {
        let swapped = refusals(
            &WHEELS
                .replace("front_", "x_")
                .replace("rear_", "front_")
                .replace("x_", "rear_"),
        );
        assert!(
            swapped
                .iter()
                .any(|(k, p)| k == "vehicle.wheels_m" && p.contains("swapped")),
            "{swapped:?}"
        );
        // 0.26 m typed for 0.2 m on one wheel: each point 15 mm off the plane.
        let raised = refusals(&WHEELS.replace(
            "rear_right = [3.4, 0.75, 0.2]",
            "rear_right = [3.4, 0.75, 0.26]",
        ));
        assert!(
            raised
                .iter()
                .any(|(k, p)| k == "vehicle.wheels_m" && p.contains("off one plane")),
            "{raised:?}"
        );
        // Within the surface's and the survey's allowance: 4 mm on one wheel.
        let within = refusals(&WHEELS.replace(
            "rear_right = [3.4, 0.75, 0.2]",
            "rear_right = [3.4, 0.75, 0.204]",
        ));
        assert_eq!(within, Vec::<(String, String)>::new());
    }
}
