//! Foxglove's well-known 3D messages (`foxglove.FrameTransform`, `foxglove.SceneUpdate`), as
//! the Foxglove SDK's own protobuf types with the SDK's descriptors, and the scene of the
//! platform: base disc, plate disc, six legs coloured by force, and the payload's equivalent
//! inertia ellipsoid at its estimated centre of mass.
//!
//! Frames: `base` is B, `platform` is P. The transform `base → platform` carries the pose (p, R):
//! a point x_P on the plate is at p + R x_P in B, which is Foxglove's convention (translation of
//! the child origin in the parent, rotation of the child in the parent).
//!
//! The JSON schemas here ([`frame_transform_schema`], [`scene_update_schema`]) describe these
//! messages decoded to JSON with their descriptor (the proto field names, every field, a
//! timestamp as `{seconds, nanos}`, an enum as its number): docs/log-schema.md documents them
//! and the tests validate every logged message against them.

use foxglove::messages::{
    line_primitive, Color, CylinderPrimitive, Duration, FrameTransform, LinePrimitive, Point3,
    Pose, Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Timestamp, Vector3 as FoxVector3,
};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::schema::{array, boolean, int, num, object, string, Schema};

/// Name of the fixed frame.
pub const BASE_FRAME: &str = "base";
/// Name of the plate frame.
pub const PLATFORM_FRAME: &str = "platform";
/// Name of the payload's frame: origin at its estimated centre of mass, axes its principal axes.
pub const PAYLOAD_FRAME: &str = "payload_com";

/// The Foxglove timestamp of `ns` nanoseconds since the Unix epoch: sec = ⌊ns / 10⁹⌋,
/// nsec = ns mod 10⁹ (the latest representable time past 2106, where sec leaves u32).
pub fn timestamp(ns: u64) -> Timestamp {
    u32::try_from(ns / 1_000_000_000)
        .ok()
        .and_then(|sec| Timestamp::new_checked(sec, (ns % 1_000_000_000) as u32))
        .unwrap_or(Timestamp::MAX)
}

fn vector(v: Vector3<f64>) -> FoxVector3 {
    FoxVector3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn point(v: Vector3<f64>) -> Point3 {
    Point3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

fn quaternion(q: UnitQuaternion<f64>) -> Quaternion {
    Quaternion {
        x: q.i,
        y: q.j,
        z: q.k,
        w: q.w,
    }
}

const IDENTITY: Quaternion = Quaternion {
    x: 0.0,
    y: 0.0,
    z: 0.0,
    w: 1.0,
};

fn pose(position: Vector3<f64>, orientation: Quaternion) -> Option<Pose> {
    Some(Pose {
        position: Some(vector(position)),
        orientation: Some(orientation),
    })
}

fn time_schema(d: &'static str) -> Schema {
    object(
        vec![
            ("seconds", int("whole seconds since the Unix epoch")),
            ("nanos", int("nanoseconds, 0..1e9")),
        ],
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

/// JSON schema of `foxglove.FrameTransform` decoded to JSON (see the module docs).
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

/// JSON schema of `foxglove.SceneUpdate` decoded to JSON (the primitive kinds this log fills;
/// the others are always empty).
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

fn disc(radius_m: f64, thickness_m: f64, z_m: f64, color: Color) -> CylinderPrimitive {
    CylinderPrimitive {
        pose: pose(Vector3::new(0.0, 0.0, z_m), IDENTITY),
        size: Some(vector(Vector3::new(
            2.0 * radius_m,
            2.0 * radius_m,
            thickness_m,
        ))),
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: Some(color),
    }
}

fn entity(time: Timestamp, frame: &str, id: &str) -> SceneEntity {
    SceneEntity {
        timestamp: Some(time),
        frame_id: frame.into(),
        id: id.into(),
        // Zero: until replaced.
        lifetime: Some(Duration::new(0, 0)),
        frame_locked: true,
        ..SceneEntity::default()
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
    time: Timestamp,
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
        points.push(point(geometry.base_joints_m[i]));
        points.push(point(top));
        colors.push(c);
        colors.push(c);
    }
    legs.lines.push(LinePrimitive {
        r#type: line_primitive::Type::LineList as i32,
        pose: pose(Vector3::zeros(), IDENTITY),
        thickness: 0.06,
        scale_invariant: false,
        points,
        color: Some(Color {
            r: 0.6,
            g: 0.6,
            b: 0.6,
            a: 1.0,
        }),
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
            e.spheres.push(SpherePrimitive {
                pose: pose(
                    p.com_m,
                    quaternion(UnitQuaternion::from_rotation_matrix(&rot)),
                ),
                size: Some(vector(Vector3::from(semi) * 2.0)),
                color: Some(Color {
                    r: 0.95,
                    g: 0.7,
                    b: 0.2,
                    a: 0.6,
                }),
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
    time: Timestamp,
    position_m: Vector3<f64>,
    rotation: &nalgebra::Rotation3<f64>,
) -> FrameTransform {
    FrameTransform {
        timestamp: Some(time),
        parent_frame_id: BASE_FRAME.into(),
        child_frame_id: PLATFORM_FRAME.into(),
        translation: Some(vector(position_m)),
        rotation: Some(quaternion(UnitQuaternion::from_rotation_matrix(rotation))),
    }
}

/// The `platform → payload_com` transform: the payload's estimated centre of mass, with its
/// principal axes (right-handed, ascending moments along x, y, z). `None` while the estimate
/// has no centre of mass (mass not positive) or J_C is not finite.
pub fn payload_transform(time: Timestamp, payload: &InertiaEllipsoid) -> Option<FrameTransform> {
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
        timestamp: Some(time),
        parent_frame_id: PLATFORM_FRAME.into(),
        child_frame_id: PAYLOAD_FRAME.into(),
        translation: Some(vector(payload.com_m)),
        rotation: Some(quaternion(UnitQuaternion::from_rotation_matrix(&rot))),
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

    /// `message` encoded, then decoded by `prost-reflect` with the SDK's descriptor, as the
    /// JSON form the schemas describe (every field, a timestamp as `{seconds, nanos}`).
    fn decoded<T: foxglove::Encode>(message: &T) -> serde_json::Value {
        use prost_reflect::{DescriptorPool, DynamicMessage, ReflectMessage, Value};
        fn json(v: &Value) -> serde_json::Value {
            match v {
                Value::F64(x) => serde_json::json!(x),
                Value::I64(x) => serde_json::json!(x),
                Value::I32(x) | Value::EnumNumber(x) => serde_json::json!(x),
                Value::U32(x) => serde_json::json!(x),
                Value::Bool(x) => serde_json::json!(x),
                Value::String(x) => serde_json::json!(x),
                Value::List(l) => serde_json::Value::Array(l.iter().map(json).collect()),
                Value::Message(m) => serde_json::Value::Object(
                    m.descriptor()
                        .fields()
                        .map(|f| (f.name().to_string(), json(&m.get_field(&f))))
                        .collect(),
                ),
                other => panic!("a type the scene does not use: {other:?}"),
            }
        }
        let schema = T::get_schema().unwrap();
        let descriptor = DescriptorPool::decode(&schema.data[..])
            .unwrap()
            .get_message_by_name(&schema.name)
            .unwrap();
        let mut bytes = Vec::new();
        message.encode(&mut bytes).unwrap();
        let m = DynamicMessage::decode(descriptor, &bytes[..]).unwrap();
        assert_eq!(m.unknown_fields().count(), 0);
        json(&Value::Message(m))
    }

    #[test]
    fn messages_match_their_schemas() {
        let rot = nalgebra::Rotation3::from_euler_angles(0.1, -0.05, 0.2);
        let p = Vector3::new(0.01, 0.0, 1.8);
        let tf = platform_transform(timestamp(1_500_000_123), p, &rot);
        let v = decoded(&tf);
        frame_transform_schema().check(&v).unwrap();
        assert_eq!(v["timestamp"]["seconds"], 1);
        assert_eq!(v["timestamp"]["nanos"], 500_000_123);
        assert_eq!(v["translation"]["z"], 1.8);

        let payload = InertiaEllipsoid {
            mass_kg: 1500.0,
            com_m: Vector3::new(0.1, 0.0, 0.5),
            inertia_com_kg_m2: Matrix3::from_diagonal(&Vector3::new(600.0, 2500.0, 2700.0)),
        };
        let s = scene(
            timestamp(0),
            &geometry(),
            p,
            &rot,
            &[1e3; 6],
            Some(&payload),
        );
        let v = decoded(&s);
        scene_update_schema().check(&v).unwrap();
        assert_eq!(s.entities.len(), 4);
        assert_eq!(v["entities"][2]["lines"][0]["type"], 2, "a line list");
        assert_eq!(
            v["entities"][2]["lines"][0]["points"]
                .as_array()
                .unwrap()
                .len(),
            12
        );
    }

    #[test]
    fn timestamps_split_nanoseconds() {
        let t = timestamp(1_735_689_599_999_999_999);
        assert_eq!((t.sec(), t.nsec()), (1_735_689_599, 999_999_999));
        assert_eq!(timestamp(u64::MAX), Timestamp::MAX);
    }

    /// The legs' top points are p + R pᵢ: each line's length is the leg length.
    #[test]
    fn leg_lines_join_the_joints() {
        let g = geometry();
        let rot = nalgebra::Rotation3::from_euler_angles(0.05, 0.02, -0.1);
        let p = Vector3::new(0.0, 0.02, 1.7);
        let s = scene(timestamp(0), &g, p, &rot, &[0.0; 6], None);
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
        let tf = payload_transform(timestamp(0), &p).unwrap();
        assert_eq!(tf.child_frame_id, PAYLOAD_FRAME);
        assert_eq!(tf.translation, Some(vector(p.com_m)));
        let r = tf.rotation.unwrap();
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(r.w, r.x, r.y, r.z));
        let m = q.to_rotation_matrix();
        let local = m.matrix().transpose() * p.inertia_com_kg_m2 * m.matrix();
        let expect = Matrix3::from_diagonal(&Vector3::new(400.0, 900.0, 1200.0));
        assert!((local - expect).norm() < 1e-9, "{local}");
        frame_transform_schema().check(&decoded(&tf)).unwrap();
        let none = InertiaEllipsoid { mass_kg: -1.0, ..p };
        assert!(payload_transform(timestamp(0), &none).is_none());
    }
}
