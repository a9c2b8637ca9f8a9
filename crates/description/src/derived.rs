//! What follows from a rig description beyond its own numbers: the platform's geometry built
//! from the `[platform]` table (with the refusal that names the key when the design cannot be
//! built) and the accelerometer's position once a calibration is applied.

use kinematics::{Geometry, KinematicsError, StrokeLimits};
use nalgebra::Vector3;

use crate::config::Config;
use crate::load::{ConfigError, ConfigIssue, LoadedConfig};

/// The platform design of `config`, or the reason it cannot be built (singular, unreachable
/// home, coincident joints).
pub fn geometry(loaded: &LoadedConfig) -> Result<Geometry, ConfigError> {
    let p = &loaded.config.platform;
    let stroke = StrokeLimits {
        min_length_m: p.min_leg_length_m,
        max_length_m: p.max_leg_length_m,
    };
    let built = match (&p.base_joints_m, &p.plate_joints_m) {
        (Some(base), Some(plate)) => {
            Geometry::from_points(base.map(Vector3::from), plate.map(Vector3::from), stroke)
        }
        _ => Geometry::from_radii(
            p.base_radius_m.unwrap_or(f64::NAN),
            p.plate_radius_m.unwrap_or(f64::NAN),
            p.base_pair_separation_deg.unwrap_or(f64::NAN).to_radians(),
            p.plate_pair_separation_deg.unwrap_or(f64::NAN).to_radians(),
            stroke,
        ),
    };
    let built = built.map_err(|e| ConfigError::single(geometry_issue(loaded, &e)))?;
    match p.home_height_m {
        None => Ok(built),
        Some(z) => built.with_home_height_m(z).map_err(|e| {
            let why = match e {
                KinematicsError::LegTooShort { .. } | KinematicsError::LegTooLong { .. } => {
                    format!(
                        "no leg may leave its stroke at home: {e} (the mid-stroke home is at \
                         {:.4} m)",
                        built.home_pose().position_m.z
                    )
                }
                other => format!("the design cannot be moved from a home at {z} m: {other}"),
            };
            ConfigError::single(loaded.issue("platform.home_height_m", why))
        }),
    }
}

fn geometry_issue(loaded: &LoadedConfig, e: &KinematicsError) -> ConfigIssue {
    let (key, problem) = match e {
        KinematicsError::ArchitecturallySingular { inverse_condition } => {
            let fix = if loaded.config.platform.base_joints_m.is_some() {
                "The plate's joints must be turned against the base's (each leg reaching to a \
                 neighbouring pair, not straight up), and neither body's joints may huddle near \
                 its centre against the other's: check platform.base_joints_m and \
                 platform.plate_joints_m"
            } else {
                "The plate's joint pairs must be turned against the base's: change \
                 platform.base_pair_separation_deg / platform.plate_pair_separation_deg (equal \
                 joint angles on both circles, e.g. separations adding up to 120°, are singular); \
                 and platform.plate_radius_m must not be tiny against platform.base_radius_m (or \
                 the reverse): rotations would barely change the leg lengths"
            };
            (
                "platform",
                format!(
                    "the design is singular at its home pose (inverse condition number \
                     {inverse_condition:.2e}): the plate could move with no (or too little) \
                     change of leg length. {fix}"
                ),
            )
        }
        KinematicsError::HomeUnreachable => (
            "platform.min_leg_length_m",
            "no level home pose has the mid-stroke mean leg length: the stroke is too short for \
             the joints (raise platform.min_leg_length_m / max_leg_length_m or move the joints)"
                .to_string(),
        ),
        KinematicsError::CoincidentJoints { .. } => (
            "platform",
            format!("two joints coincide: {e} (check the radii and pair separations, or the joints' points)"),
        ),
        KinematicsError::InvalidStroke { .. } => ("platform.max_leg_length_m", e.to_string()),
        _ => ("platform", e.to_string()),
    };
    loaded.issue(key, problem)
}

/// The accelerometer's position in P, m: the IMU calibration's when one is applied, else the
/// described `sensors.imu.position_m`.
pub fn accelerometer_position(config: &Config) -> Vector3<f64> {
    Vector3::from(
        config
            .calibration
            .imu_alignment()
            .map_or(config.sensors.imu.position_m, |a| {
                a.accelerometer_position_m
            }),
    )
}

/// A `[platform]` table giving the joints as points (`base_joints_m`, `plate_joints_m`) in
/// leg order, each coordinate at full precision so it reads back bit for bit: a rig
/// description's radii form written out as the template a survey fills in (docs/rig.md).
pub fn points_table(base_m: &[[f64; 3]; 6], plate_m: &[[f64; 3]; 6]) -> String {
    let list = |points: &[[f64; 3]; 6]| {
        let rows: Vec<String> = points
            .iter()
            .map(|p| format!("[{:?}, {:?}, {:?}]", p[0], p[1], p[2]))
            .collect();
        format!("[{}]", rows.join(", "))
    };
    format!(
        "[platform]\nbase_joints_m = {}\nplate_joints_m = {}\n",
        list(base_m),
        list(plate_m)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::load::{load, load_str};

    /// The default rig's joints written out as points, each moved by `shift(leg, plate)`.
    fn default_points_toml(shift: impl Fn(usize, bool) -> [f64; 3]) -> String {
        let g = geometry(&load(None).unwrap()).unwrap();
        let moved = |points: &[Vector3<f64>; 6], plate: bool| -> [[f64; 3]; 6] {
            core::array::from_fn(|i| {
                let d = shift(i, plate);
                let p = points[i];
                [p.x + d[0], p.y + d[1], p.z + d[2]]
            })
        };
        points_table(
            &moved(g.base_joints_m(), false),
            &moved(g.plate_joints_m(), true),
        )
    }

    #[test]
    fn the_radii_form_and_its_points_build_the_same_geometry() {
        let radii = geometry(&load(None).unwrap()).unwrap();
        let loaded = load_str(&default_points_toml(|_, _| [0.0; 3]), "survey.toml").unwrap();
        assert_eq!(loaded.config.platform.base_radius_m, None);
        assert_eq!(geometry(&loaded).unwrap(), radii);
        // The effective description a log records reloads to the same points.
        let again = load_str(&loaded.effective_toml(), "log").unwrap();
        assert_eq!(geometry(&again).unwrap(), radii);
    }

    #[test]
    fn surveyed_joints_off_the_symmetric_layout_build_their_own_geometry() {
        // Each joint 1-3 cm off its drawing position, in a pattern no symmetry undoes.
        let shift = |i: usize, plate: bool| {
            let k = (i + if plate { 3 } else { 0 }) as f64;
            [
                0.01 + 0.004 * k % 0.02,
                -0.012 + 0.003 * k,
                0.002 * (k - 4.0),
            ]
        };
        let loaded = load_str(&default_points_toml(shift), "survey.toml").unwrap();
        let g = geometry(&loaded).unwrap();
        let radii = geometry(&load(None).unwrap()).unwrap();
        assert_ne!(g, radii);
        for i in 0..6 {
            let moved = (g.base_joints_m()[i] - radii.base_joints_m()[i]).norm();
            assert!(
                (0.005..0.04).contains(&moved),
                "base joint {i} moved {moved} m"
            );
        }
    }

    #[test]
    fn a_measured_home_height_is_the_home_and_one_out_of_stroke_is_refused_by_key() {
        let mid = geometry(&load(None).unwrap()).unwrap();
        let z = mid.home_pose().position_m.z - 0.05;
        let text = format!("[platform]\nhome_height_m = {z}\n");
        let g = geometry(&load_str(&text, "rig.toml").unwrap()).unwrap();
        assert_eq!(g.home_pose().position_m.z, z);
        assert!(g.home_is_given());
        let err = geometry(&load_str("[platform]\nhome_height_m = 3.0\n", "rig.toml").unwrap())
            .unwrap_err();
        let issue = &err.issues[0];
        assert_eq!(issue.key, "platform.home_height_m");
        assert!(
            issue.problem.contains("longer") && issue.problem.contains("mid-stroke home"),
            "{issue}"
        );
    }

    #[test]
    fn both_forms_in_one_file_are_refused_at_the_radius() {
        let text = format!(
            "{}base_radius_m = 1.6\n",
            default_points_toml(|_, _| [0.0; 3])
        );
        let err = load_str(&text, "car.toml").unwrap_err();
        let issue = &err.issues[0];
        assert_eq!(issue.key, "platform.base_radius_m");
        assert_eq!(issue.line, Some(4));
        assert!(issue.problem.contains("given twice"), "{issue}");
    }

    #[test]
    fn one_list_of_points_alone_is_refused_naming_the_other() {
        let text = default_points_toml(|_, _| [0.0; 3]);
        let base_only: String = text.lines().take(2).collect::<Vec<_>>().join("\n");
        let err = load_str(&base_only, "car.toml").unwrap_err();
        assert!(
            err.issues
                .iter()
                .any(|i| i.key == "platform.plate_joints_m"),
            "{err}"
        );
    }

    #[test]
    fn coplanar_joints_at_equal_angles_are_refused_as_singular() {
        // Plate joints straight above the base joints' angles: the paper's singular layout.
        let g = geometry(&load(None).unwrap()).unwrap();
        let plate = g.base_joints_m().map(|b| b * 0.8);
        let points = |p: &[Vector3<f64>; 6]| p.map(|v| [v.x, v.y, v.z]);
        let text = points_table(&points(g.base_joints_m()), &points(&plate));
        let loaded = load_str(&text, "car.toml").unwrap();
        let err = geometry(&loaded).unwrap_err();
        assert!(err.to_string().contains("singular"), "{err}");
    }
}
