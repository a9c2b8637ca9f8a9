//! Foxglove's well-known 3D schemas (`foxglove.FrameTransform`, `foxglove.SceneUpdate`) as JSON
//! messages, and the scene of the platform: base disc, plate disc, six legs coloured by force,
//! and the payload's equivalent inertia ellipsoid at its estimated centre of mass.
//!
//! Frames: `base` is B, `platform` is P. The transform `base → platform` carries the pose (p, R):
//! a point x_P on the plate is at p + R x_P in B, which is Foxglove's convention (translation of
//! the child origin in the parent, rotation of the child in the parent).

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::Serialize;

use measure::schema::{array, boolean, int, num, object, string, Schema};

/// Name of the fixed frame.
pub const BASE_FRAME: &str = "base";
/// Name of the plate frame.
pub const PLATFORM_FRAME: &str = "platform";
/// Name of the payload's frame: origin at its estimated centre of mass, axes its principal axes.
pub const PAYLOAD_FRAME: &str = "payload_com";

/// Foxglove `time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Time {
    /// Whole seconds.
    pub sec: u64,
    /// Nanoseconds, 0..1e9.
    pub nsec: u32,
}

impl Time {
    /// From nanoseconds.
    pub fn from_ns(ns: u64) -> Self {
        Self {
            sec: ns / 1_000_000_000,
            nsec: (ns % 1_000_000_000) as u32,
        }
    }
}

/// Foxglove `Vector3` / `Point3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Xyz {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl From<Vector3<f64>> for Xyz {
    fn from(v: Vector3<f64>) -> Self {
        Self {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

/// Foxglove `Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Quat {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quat {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

impl From<UnitQuaternion<f64>> for Quat {
    fn from(q: UnitQuaternion<f64>) -> Self {
        Self {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }
    }
}

/// Foxglove `Color`, components 0..1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Color {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Alpha.
    pub a: f64,
}

/// Foxglove `Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FoxPose {
    /// Position.
    pub position: Xyz,
    /// Orientation.
    pub orientation: Quat,
}

/// `foxglove.FrameTransform`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameTransform {
    /// Time of the transform.
    pub timestamp: Time,
    /// Parent frame.
    pub parent_frame_id: String,
    /// Child frame.
    pub child_frame_id: String,
    /// Child origin in the parent, m.
    pub translation: Xyz,
    /// Child orientation in the parent.
    pub rotation: Quat,
}

/// `foxglove.CylinderPrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Cylinder {
    /// Centre and orientation (axis along local z).
    pub pose: FoxPose,
    /// Diameters along x, y at the bottom and the height along z, m.
    pub size: Xyz,
    /// Bottom diameter scale.
    pub bottom_scale: f64,
    /// Top diameter scale.
    pub top_scale: f64,
    /// Colour.
    pub color: Color,
}

/// `foxglove.SpherePrimitive` (an ellipsoid when the sizes differ).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Sphere {
    /// Centre and orientation.
    pub pose: FoxPose,
    /// Diameters along the local axes, m.
    pub size: Xyz,
    /// Colour.
    pub color: Color,
}

/// `foxglove.LinePrimitive`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Line {
    /// 0 line strip, 1 line loop, 2 line list.
    #[serde(rename = "type")]
    pub kind: u8,
    /// Origin of the points.
    pub pose: FoxPose,
    /// Thickness, m (or pixels when scale invariant).
    pub thickness: f64,
    /// Thickness in pixels instead of metres.
    pub scale_invariant: bool,
    /// Points.
    pub points: Vec<Xyz>,
    /// Colour of the whole line (when `colors` is empty).
    pub color: Color,
    /// Per-point colours.
    pub colors: Vec<Color>,
    /// Indices into `points` (empty: all in order).
    pub indices: Vec<u32>,
}

/// `foxglove.SceneEntity` with the primitive kinds this log uses (the others stay empty).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneEntity {
    /// Time of the entity.
    pub timestamp: Time,
    /// Frame the primitives are given in.
    pub frame_id: String,
    /// Identifier: replaces an earlier entity with the same id.
    pub id: String,
    /// Zero: until replaced.
    pub lifetime: Time,
    /// Follow `frame_id` as it moves.
    pub frame_locked: bool,
    /// Unused (empty).
    pub metadata: Vec<Empty>,
    /// Unused (empty).
    pub arrows: Vec<Empty>,
    /// Unused (empty).
    pub cubes: Vec<Empty>,
    /// Spheres and ellipsoids.
    pub spheres: Vec<Sphere>,
    /// Cylinders.
    pub cylinders: Vec<Cylinder>,
    /// Lines.
    pub lines: Vec<Line>,
    /// Unused (empty).
    pub triangles: Vec<Empty>,
    /// Unused (empty).
    pub texts: Vec<Empty>,
    /// Unused (empty).
    pub models: Vec<Empty>,
}

/// Placeholder for primitive kinds the log never fills.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Empty {}

/// `foxglove.SceneUpdate`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SceneUpdate {
    /// Always empty: entities are replaced by id.
    pub deletions: Vec<Empty>,
    /// Entities to add or replace.
    pub entities: Vec<SceneEntity>,
}

fn time_schema(d: &'static str) -> Schema {
    object(
        vec![("sec", int("whole seconds")), ("nsec", int("nanoseconds"))],
        d,
    )
}

fn xyz_schema(d: &'static str) -> Schema {
    object(vec![("x", num("")), ("y", num("")), ("z", num(""))], d)
}

fn quat_schema() -> Schema {
    object(
        vec![
            ("x", num("")),
            ("y", num("")),
            ("z", num("")),
            ("w", num("")),
        ],
        "unit quaternion",
    )
}

fn color_schema() -> Schema {
    object(
        vec![
            ("r", num("")),
            ("g", num("")),
            ("b", num("")),
            ("a", num("")),
        ],
        "colour, 0..1",
    )
}

fn pose_schema() -> Schema {
    object(
        vec![
            ("position", xyz_schema("m")),
            ("orientation", quat_schema()),
        ],
        "pose",
    )
}

/// JSON schema of `foxglove.FrameTransform`.
pub fn frame_transform_schema() -> Schema {
    object(
        vec![
            ("timestamp", time_schema("time of the transform")),
            ("parent_frame_id", string("parent frame")),
            ("child_frame_id", string("child frame")),
            ("translation", xyz_schema("child origin in the parent, m")),
            ("rotation", quat_schema()),
        ],
        "A transform between two reference frames",
    )
}

/// JSON schema of `foxglove.SceneUpdate` (the fields this log uses).
pub fn scene_update_schema() -> Schema {
    let unused = || array(object(vec![], ""), None, "unused, always empty");
    let entity = object(
        vec![
            ("timestamp", time_schema("time of the entity")),
            ("frame_id", string("frame of reference")),
            (
                "id",
                string("identifier; replaces an entity with the same id"),
            ),
            ("lifetime", time_schema("zero: until replaced")),
            ("frame_locked", boolean("follow the frame as it moves")),
            ("metadata", unused()),
            ("arrows", unused()),
            ("cubes", unused()),
            (
                "spheres",
                array(
                    object(
                        vec![
                            ("pose", pose_schema()),
                            ("size", xyz_schema("diameters, m")),
                            ("color", color_schema()),
                        ],
                        "foxglove.SpherePrimitive",
                    ),
                    None,
                    "",
                ),
            ),
            (
                "cylinders",
                array(
                    object(
                        vec![
                            ("pose", pose_schema()),
                            ("size", xyz_schema("diameters x, y and height z, m")),
                            ("bottom_scale", num("")),
                            ("top_scale", num("")),
                            ("color", color_schema()),
                        ],
                        "foxglove.CylinderPrimitive",
                    ),
                    None,
                    "",
                ),
            ),
            (
                "lines",
                array(
                    object(
                        vec![
                            ("type", int("0 strip, 1 loop, 2 list")),
                            ("pose", pose_schema()),
                            ("thickness", num("m")),
                            ("scale_invariant", boolean("")),
                            ("points", array(xyz_schema("m"), None, "")),
                            ("color", color_schema()),
                            ("colors", array(color_schema(), None, "per point")),
                            ("indices", array(int(""), None, "")),
                        ],
                        "foxglove.LinePrimitive",
                    ),
                    None,
                    "",
                ),
            ),
            ("triangles", unused()),
            ("texts", unused()),
            ("models", unused()),
        ],
        "foxglove.SceneEntity",
    );
    object(
        vec![
            ("deletions", unused()),
            (
                "entities",
                array(entity, None, "entities to add or replace"),
            ),
        ],
        "An update to the entities displayed in a 3D scene",
    )
}

/// The fixed parts of the scene: joint positions and radii.
#[derive(Clone, Debug)]
pub struct SceneGeometry {
    /// Base joints in B, m.
    pub base_joints_m: [Vector3<f64>; 6],
    /// Plate joints in P, m.
    pub plate_joints_m: [Vector3<f64>; 6],
    /// Base circle radius, m.
    pub base_radius_m: f64,
    /// Plate circle radius, m.
    pub plate_radius_m: f64,
    /// Force at which a leg is drawn fully red (blue at minus this), N.
    pub force_scale_n: f64,
}

/// The payload's estimated inertia drawn as the solid ellipsoid of the same mass and J_C.
#[derive(Clone, Copy, Debug)]
pub struct InertiaEllipsoid {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Centre of mass in P, m.
    pub com_m: Vector3<f64>,
    /// J_C in P axes, kg·m².
    pub inertia_com_kg_m2: Matrix3<f64>,
}

/// Leg colour: blue (pulling) → grey (zero) → red (pushing).
fn force_color(force_n: f64, scale_n: f64) -> Color {
    let s = if scale_n > 0.0 {
        (force_n / scale_n).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let grey = 0.6;
    if s >= 0.0 {
        Color {
            r: grey + (1.0 - grey) * s,
            g: grey * (1.0 - s),
            b: grey * (1.0 - s),
            a: 1.0,
        }
    } else {
        Color {
            r: grey * (1.0 + s),
            g: grey * (1.0 + s),
            b: grey - (1.0 - grey) * s,
            a: 1.0,
        }
    }
}

fn disc(radius_m: f64, thickness_m: f64, z_m: f64, color: Color) -> Cylinder {
    Cylinder {
        pose: FoxPose {
            position: Xyz {
                x: 0.0,
                y: 0.0,
                z: z_m,
            },
            orientation: Quat::default(),
        },
        size: Xyz {
            x: 2.0 * radius_m,
            y: 2.0 * radius_m,
            z: thickness_m,
        },
        bottom_scale: 1.0,
        top_scale: 1.0,
        color,
    }
}

fn entity(time: Time, frame: &str, id: &str) -> SceneEntity {
    SceneEntity {
        timestamp: time,
        frame_id: frame.into(),
        id: id.into(),
        lifetime: Time::default(),
        frame_locked: true,
        metadata: vec![],
        arrows: vec![],
        cubes: vec![],
        spheres: vec![],
        cylinders: vec![],
        lines: vec![],
        triangles: vec![],
        texts: vec![],
        models: vec![],
    }
}

/// Semi-axes of the uniform solid ellipsoid with mass m and principal moments I:
/// I₁ = m(b² + c²)/5 etc., so a² = 5(I₂ + I₃ − I₁)/(2m). `None` when not physical.
pub fn ellipsoid_semi_axes(mass_kg: f64, moments: [f64; 3]) -> Option<[f64; 3]> {
    if mass_kg.is_nan() || mass_kg <= 0.0 {
        return None;
    }
    let [i1, i2, i3] = moments;
    let sq = [i2 + i3 - i1, i1 + i3 - i2, i1 + i2 - i3].map(|s| 5.0 * s / (2.0 * mass_kg));
    if sq.iter().all(|s| s.is_finite() && *s > 0.0) {
        Some(sq.map(f64::sqrt))
    } else {
        None
    }
}

/// The scene at one instant: base, plate, legs (leg line from bᵢ to p + R pᵢ in B, coloured by
/// the measured force) and, when given, the payload's inertia ellipsoid.
pub fn scene(
    time: Time,
    geometry: &SceneGeometry,
    position_m: Vector3<f64>,
    rotation: &nalgebra::Rotation3<f64>,
    leg_forces_n: &[f64; 6],
    payload: Option<&InertiaEllipsoid>,
) -> SceneUpdate {
    let mut base = entity(time, BASE_FRAME, "base");
    base.cylinders.push(disc(
        geometry.base_radius_m * 1.1,
        0.05,
        -0.025,
        Color {
            r: 0.35,
            g: 0.35,
            b: 0.4,
            a: 1.0,
        },
    ));
    let mut plate = entity(time, PLATFORM_FRAME, "plate");
    plate.cylinders.push(disc(
        geometry.plate_radius_m * 1.1,
        0.04,
        -0.02,
        Color {
            r: 0.55,
            g: 0.6,
            b: 0.7,
            a: 0.9,
        },
    ));
    let mut legs = entity(time, BASE_FRAME, "legs");
    let mut points = Vec::with_capacity(12);
    let mut colors = Vec::with_capacity(12);
    for (i, force_n) in leg_forces_n.iter().enumerate() {
        let top = position_m + rotation * geometry.plate_joints_m[i];
        let c = force_color(*force_n, geometry.force_scale_n);
        points.push(Xyz::from(geometry.base_joints_m[i]));
        points.push(Xyz::from(top));
        colors.push(c);
        colors.push(c);
    }
    legs.lines.push(Line {
        kind: 2,
        pose: FoxPose::default(),
        thickness: 0.06,
        scale_invariant: false,
        points,
        color: Color {
            r: 0.6,
            g: 0.6,
            b: 0.6,
            a: 1.0,
        },
        colors,
        indices: vec![],
    });
    let mut entities = vec![base, plate, legs];
    if let Some(p) = payload {
        let eig = p.inertia_com_kg_m2.symmetric_eigen();
        let moments = [eig.eigenvalues[0], eig.eigenvalues[1], eig.eigenvalues[2]];
        if let Some(semi) = ellipsoid_semi_axes(p.mass_kg, moments) {
            let mut axes = eig.eigenvectors;
            if axes.determinant() < 0.0 {
                axes.column_mut(2).neg_mut();
            }
            let rot = nalgebra::Rotation3::from_matrix_unchecked(axes);
            let mut e = entity(time, PLATFORM_FRAME, "payload_inertia");
            e.spheres.push(Sphere {
                pose: FoxPose {
                    position: Xyz::from(p.com_m),
                    orientation: Quat::from(UnitQuaternion::from_rotation_matrix(&rot)),
                },
                size: Xyz {
                    x: 2.0 * semi[0],
                    y: 2.0 * semi[1],
                    z: 2.0 * semi[2],
                },
                color: Color {
                    r: 0.95,
                    g: 0.7,
                    b: 0.2,
                    a: 0.6,
                },
            });
            entities.push(e);
        }
    }
    SceneUpdate {
        deletions: vec![],
        entities,
    }
}

/// The `base → platform` transform of pose (p, R).
pub fn platform_transform(
    time: Time,
    position_m: Vector3<f64>,
    rotation: &nalgebra::Rotation3<f64>,
) -> FrameTransform {
    FrameTransform {
        timestamp: time,
        parent_frame_id: BASE_FRAME.into(),
        child_frame_id: PLATFORM_FRAME.into(),
        translation: Xyz::from(position_m),
        rotation: Quat::from(UnitQuaternion::from_rotation_matrix(rotation)),
    }
}

/// The `platform → payload_com` transform: the payload's estimated centre of mass, with its
/// principal axes (right-handed, ascending moments along x, y, z). `None` while the estimate
/// has no centre of mass (mass not positive) or J_C is not finite.
pub fn payload_transform(time: Time, payload: &InertiaEllipsoid) -> Option<FrameTransform> {
    if payload.mass_kg.is_nan()
        || payload.mass_kg <= 0.0
        || !payload.com_m.iter().all(|v| v.is_finite())
        || !payload.inertia_com_kg_m2.iter().all(|v| v.is_finite())
    {
        return None;
    }
    let eig = payload.inertia_com_kg_m2.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|a, b| eig.eigenvalues[*a].total_cmp(&eig.eigenvalues[*b]));
    let mut axes = Matrix3::from_columns(&order.map(|k| eig.eigenvectors.column(k).into_owned()));
    if axes.determinant() < 0.0 {
        axes.column_mut(2).neg_mut();
    }
    let rot = nalgebra::Rotation3::from_matrix_unchecked(axes);
    Some(FrameTransform {
        timestamp: time,
        parent_frame_id: PLATFORM_FRAME.into(),
        child_frame_id: PAYLOAD_FRAME.into(),
        translation: Xyz::from(payload.com_m),
        rotation: Quat::from(UnitQuaternion::from_rotation_matrix(&rot)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> SceneGeometry {
        let ring = |r: f64, off: f64| {
            core::array::from_fn(|i| {
                let a = off + i as f64 * core::f64::consts::PI / 3.0;
                Vector3::new(r * a.cos(), r * a.sin(), 0.0)
            })
        };
        SceneGeometry {
            base_joints_m: ring(1.5, 0.1),
            plate_joints_m: ring(1.2, 0.6),
            base_radius_m: 1.5,
            plate_radius_m: 1.2,
            force_scale_n: 10_000.0,
        }
    }

    #[test]
    fn messages_match_their_schemas() {
        let rot = nalgebra::Rotation3::from_euler_angles(0.1, -0.05, 0.2);
        let p = Vector3::new(0.01, 0.0, 1.8);
        let tf = platform_transform(Time::from_ns(1_500_000_123), p, &rot);
        let v = serde_json::to_value(&tf).unwrap();
        frame_transform_schema().check(&v).unwrap();
        assert_eq!(v["timestamp"]["sec"], 1);
        assert_eq!(v["timestamp"]["nsec"], 500_000_123);

        let payload = InertiaEllipsoid {
            mass_kg: 1500.0,
            com_m: Vector3::new(0.1, 0.0, 0.5),
            inertia_com_kg_m2: Matrix3::from_diagonal(&Vector3::new(600.0, 2500.0, 2700.0)),
        };
        let s = scene(
            Time::default(),
            &geometry(),
            p,
            &rot,
            &[1e3; 6],
            Some(&payload),
        );
        let v = serde_json::to_value(&s).unwrap();
        scene_update_schema().check(&v).unwrap();
        assert_eq!(s.entities.len(), 4);
    }

    /// The legs' top points are p + R pᵢ: each line's length is the leg length.
    #[test]
    fn leg_lines_join_the_joints() {
        let g = geometry();
        let rot = nalgebra::Rotation3::from_euler_angles(0.05, 0.02, -0.1);
        let p = Vector3::new(0.0, 0.02, 1.7);
        let s = scene(Time::default(), &g, p, &rot, &[0.0; 6], None);
        let line = &s.entities[2].lines[0];
        for i in 0..6 {
            let a = &line.points[2 * i];
            let b = &line.points[2 * i + 1];
            let len = ((b.x - a.x).powi(2) + (b.y - a.y).powi(2) + (b.z - a.z).powi(2)).sqrt();
            let expect = (p + rot * g.plate_joints_m[i] - g.base_joints_m[i]).norm();
            assert!((len - expect).abs() < 1e-12);
        }
    }

    /// A uniform solid ellipsoid's own moments give back its semi-axes.
    #[test]
    fn ellipsoid_axes_invert_the_moments() {
        let (m, a, b, c) = (10.0, 0.3, 0.5, 0.9);
        let i = [
            m * (b * b + c * c) / 5.0,
            m * (a * a + c * c) / 5.0,
            m * (a * a + b * b) / 5.0,
        ];
        let s = ellipsoid_semi_axes(m, i).unwrap();
        for (got, want) in s.iter().zip([a, b, c]) {
            assert!((got - want).abs() < 1e-12);
        }
        assert!(ellipsoid_semi_axes(1.0, [1.0, 1.0, 3.0]).is_none());
    }

    #[test]
    fn colours_run_blue_grey_red() {
        assert!(force_color(1e4, 1e4).r > 0.99);
        assert!(force_color(-1e4, 1e4).b > 0.99);
        let z = force_color(0.0, 1e4);
        assert!((z.r - z.b).abs() < 1e-12);
    }

    /// The payload frame sits at the centre of mass with its x axis along the smallest
    /// principal moment: J_C seen in that frame is diagonal and ascending.
    #[test]
    fn payload_frame_is_principal() {
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.7);
        let d = Matrix3::from_diagonal(&Vector3::new(900.0, 400.0, 1200.0));
        let p = InertiaEllipsoid {
            mass_kg: 1500.0,
            com_m: Vector3::new(0.1, -0.05, 0.5),
            inertia_com_kg_m2: r.matrix() * d * r.matrix().transpose(),
        };
        let tf = payload_transform(Time::default(), &p).unwrap();
        assert_eq!(tf.child_frame_id, PAYLOAD_FRAME);
        assert_eq!(tf.translation, Xyz::from(p.com_m));
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
            tf.rotation.w,
            tf.rotation.x,
            tf.rotation.y,
            tf.rotation.z,
        ));
        let m = q.to_rotation_matrix();
        let local = m.matrix().transpose() * p.inertia_com_kg_m2 * m.matrix();
        let expect = Matrix3::from_diagonal(&Vector3::new(400.0, 900.0, 1200.0));
        assert!((local - expect).norm() < 1e-9, "{local}");
        let v = serde_json::to_value(&tf).unwrap();
        frame_transform_schema().check(&v).unwrap();
        let none = InertiaEllipsoid { mass_kg: -1.0, ..p };
        assert!(payload_transform(Time::default(), &none).is_none());
    }
}
