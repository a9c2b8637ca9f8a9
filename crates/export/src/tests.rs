//! Round trips: each document read back by a parser of its format that this project did not
//! write (urdf-rs, sdformat-rs, roxmltree for MJCF, csv), compared with the report's numbers
//! to 1e-9 relative; the principal frame checked by rebuilding J_C = R·diag·Rᵀ from the
//! written angles with rotation formulas written out here.

use measure::report::{Quantities, Report};
use nalgebra::{Matrix3, Vector3};

use crate::input::parse;
use crate::{render, ExportError, Format, Options, Payload};

/// J = Q·diag(d)·Qᵀ for the rotation Q = Rz(0.3)·Ry(-0.2)·Rx(0.1) (a car-like body with
/// products of inertia of both signs).
fn car_tensor(d: [f64; 3], angles: [f64; 3]) -> [[f64; 3]; 3] {
    let q = rz(angles[2]) * ry(angles[1]) * rx(angles[0]);
    let j = q * Matrix3::from_diagonal(&Vector3::from(d)) * q.transpose();
    core::array::from_fn(|r| core::array::from_fn(|c| j[(r.min(c), r.max(c))]))
}

fn rx(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
fn ry(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
fn rz(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// The rotation of a unit quaternion w x y z (the textbook formula).
fn from_quat([w, x, y, z]: [f64; 4]) -> Matrix3<f64> {
    Matrix3::new(
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    )
}

fn report_with(estimate: Quantities) -> Report {
    Report {
        estimate,
        sigma: Quantities {
            mass: 0.8125,
            com: [0.0011, 0.0009, 0.0031],
            inertia_com: [[4.5, 0.7, 1.1], [0.7, 9.25, 0.6], [1.1, 0.6, 10.5]],
        },
        ..Report::default()
    }
}

fn car() -> Quantities {
    Quantities {
        mass: 1523.456789012345,
        com: [0.123456789012345, -0.0456, 0.6123],
        inertia_com: car_tensor([612.5, 2471.25, 2693.125], [0.1, -0.2, 0.3]),
    }
}

fn payload_of(estimate: Quantities) -> Payload {
    parse(&report_with(estimate).to_json(), "r.json").expect("a physical report")
}

/// |a − b| ≤ 1e-9·scale for every pair.
fn assert_close(what: &str, got: &[f64], want: &[f64], scale: f64) {
    assert_eq!(got.len(), want.len(), "{what}: {got:?} vs {want:?}");
    for (g, w) in got.iter().zip(want) {
        let tol = 1e-9 * scale.max(w.abs());
        assert!((g - w).abs() <= tol, "{what}: {got:?} vs {want:?}");
    }
}

/// [ixx, iyy, izz, ixy, ixz, iyz].
fn six(j: &[[f64; 3]; 3]) -> [f64; 6] {
    [j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]]
}

fn numbers(text: &str) -> Vec<f64> {
    text.split_whitespace()
        .map(|t| t.parse().expect("a number"))
        .collect()
}

/// J_C rebuilt from a principal-axes export: R·diag(I)·Rᵀ.
fn rebuilt(r: Matrix3<f64>, moments: [f64; 3]) -> [f64; 6] {
    let j = r * Matrix3::from_diagonal(&Vector3::from(moments)) * r.transpose();
    six(&core::array::from_fn(|a| {
        core::array::from_fn(|b| j[(a, b)])
    }))
}

fn options(format: Format, principal_axes: bool) -> Options {
    Options {
        format,
        principal_axes,
    }
}

/// The estimate and sigma a document carries, and the J_C it implies, compared with the
/// report's (`inertia`: ixx iyy izz ixy ixz iyz as the parser read them).
fn check(p: &Payload, format: &str, mass: f64, com: [f64; 3], inertia: [f64; 6]) {
    let want = &p.estimate;
    let scale = want.inertia_com[2][2].abs();
    assert_close(&format!("{format} mass"), &[mass], &[want.mass], 0.0);
    assert_close(&format!("{format} com"), &com, &want.com, 0.0);
    assert_close(
        &format!("{format} J_C"),
        &inertia,
        &six(&want.inertia_com),
        scale,
    );
}

#[test]
fn urdf_reads_back_through_urdf_rs() {
    for principal_axes in [false, true] {
        let p = payload_of(car());
        let text = render(&p, options(Format::Urdf, principal_axes));
        let robot = urdf_rs::read_from_string(&text).expect("urdf-rs reads it");
        let link = &robot.links[0];
        let i = &link.inertial;
        let o = &i.origin;
        let moments = [i.inertia.ixx, i.inertia.iyy, i.inertia.izz];
        let j = if principal_axes {
            for off in [i.inertia.ixy, i.inertia.ixz, i.inertia.iyz] {
                assert_eq!(off, 0.0);
            }
            rebuilt(rz(o.rpy[2]) * ry(o.rpy[1]) * rx(o.rpy[0]), moments)
        } else {
            assert_eq!(*o.rpy, [0.0; 3]);
            let t = &i.inertia;
            [t.ixx, t.iyy, t.izz, t.ixy, t.ixz, t.iyz]
        };
        check(&p, "urdf", i.mass.value, *o.xyz, j);
    }
}

#[test]
fn sdf_reads_back_through_sdformat_rs() {
    for principal_axes in [false, true] {
        let p = payload_of(car());
        let text = render(&p, options(Format::Sdf, principal_axes));
        let models = sdformat_rs::read_from_string(&text).expect("sdformat-rs reads it");
        assert_eq!(models.len(), 1);
        assert_eq!(models[0].name, "payload");
        let i = models[0].links[0].inertial.as_ref().expect("an inertial");
        let pose = i.pose.value;
        let t = &i.inertia;
        let j = if principal_axes {
            for off in [t.ixy.value, t.ixz.value, t.iyz.value] {
                assert_eq!(off, 0.0);
            }
            let r = rz(pose[5]) * ry(pose[4]) * rx(pose[3]);
            rebuilt(r, [t.ixx.value, t.iyy.value, t.izz.value])
        } else {
            assert_eq!(pose[3..], [0.0; 3]);
            [
                t.ixx.value,
                t.iyy.value,
                t.izz.value,
                t.ixy.value,
                t.ixz.value,
                t.iyz.value,
            ]
        };
        check(&p, "sdf", i.mass.value, [pose[0], pose[1], pose[2]], j);
    }
}

#[test]
fn mjcf_reads_back_through_an_xml_parser_with_mujocos_attributes() {
    for principal_axes in [false, true] {
        let p = payload_of(car());
        let text = render(&p, options(Format::Mjcf, principal_axes));
        let doc = roxmltree::Document::parse(&text).expect("well-formed XML");
        let root = doc.root_element();
        assert_eq!(root.tag_name().name(), "mujoco");
        let path: Vec<&str> = doc
            .descendants()
            .find(|n| n.has_tag_name("inertial"))
            .expect("an inertial")
            .ancestors()
            .filter(|n| n.is_element())
            .map(|n| n.tag_name().name())
            .collect();
        assert_eq!(path, ["inertial", "body", "worldbody", "mujoco"]);
        let i = doc
            .descendants()
            .find(|n| n.has_tag_name("inertial"))
            .expect("an inertial");
        let attr = |name: &str| i.attribute(name).map(numbers);
        let mass = attr("mass").expect("mass")[0];
        let pos = attr("pos").expect("pos");
        let j = if principal_axes {
            assert!(i.attribute("fullinertia").is_none());
            let q: [f64; 4] = attr("quat").expect("quat").try_into().expect("4 numbers");
            let d: [f64; 3] = attr("diaginertia").expect("diag").try_into().expect("3");
            let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((norm - 1.0).abs() < 1e-12, "{q:?}");
            rebuilt(from_quat(q), d)
        } else {
            assert!(i.attribute("quat").is_none() && i.attribute("diaginertia").is_none());
            // MuJoCo's order: M11 M22 M33 M12 M13 M23.
            attr("fullinertia")
                .expect("fullinertia")
                .try_into()
                .expect("6")
        };
        check(&p, "mjcf", mass, [pos[0], pos[1], pos[2]], j);
    }
}

#[test]
fn csv_reads_back_through_the_csv_crate() {
    for principal_axes in [false, true] {
        let p = payload_of(car());
        let text = render(&p, options(Format::Csv, principal_axes));
        let mut reader = csv::Reader::from_reader(text.as_bytes());
        let header: Vec<String> = reader
            .headers()
            .expect("a header")
            .iter()
            .map(String::from)
            .collect();
        let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.expect("a row")).collect();
        assert_eq!(rows.len(), 1);
        let get = |name: &str| -> f64 {
            let k = header.iter().position(|h| h == name).expect(name);
            rows[0][k].parse().expect("a number")
        };
        let j = ["ixx", "iyy", "izz", "ixy", "ixz", "iyz"].map(|e| get(&format!("{e}_kg_m2")));
        let com = ["x", "y", "z"].map(|a| get(&format!("com_{a}_m")));
        check(&p, "csv", get("mass_kg"), com, j);
        assert_eq!(get("sigma_mass_kg"), p.sigma.mass);
        assert_eq!(get("sigma_com_z_m"), p.sigma.com[2]);
        assert_eq!(get("sigma_ixz_kg_m2"), p.sigma.inertia_com[0][2]);
        if principal_axes {
            let m = ["x", "y", "z"].map(|a| get(&format!("principal_{a}_kg_m2")));
            let r = rz(get("yaw_rad")) * ry(get("pitch_rad")) * rx(get("roll_rad"));
            check(
                &p,
                "csv rpy",
                p.estimate.mass,
                p.estimate.com,
                rebuilt(r, m),
            );
            let q = ["qw", "qx", "qy", "qz"].map(get);
            check(
                &p,
                "csv quat",
                p.estimate.mass,
                p.estimate.com,
                rebuilt(from_quat(q), m),
            );
        } else {
            assert!(!header.iter().any(|h| h == "qw"));
        }
    }
}

#[test]
fn the_sigmas_are_comments_in_every_xml_format() {
    // A report path with `--` (illegal inside an XML comment) and a trailing `-`.
    let p = parse(&report_with(car()).to_json(), "runs/a--b--.json").expect("physical");
    for format in [Format::Urdf, Format::Sdf, Format::Mjcf] {
        let text = render(&p, options(format, false));
        let doc = roxmltree::Document::parse(&text).expect("well-formed XML");
        let comments: Vec<&str> = doc
            .descendants()
            .filter(|n| n.is_comment())
            .filter_map(|n| n.text())
            .collect();
        let sigma = comments
            .iter()
            .find(|c| c.contains("standard deviation"))
            .unwrap_or_else(|| panic!("{format:?}: no sigma comment in {comments:?}"));
        // The mass sigma, the z sigma of the centre of mass and J_C's xz sigma, as written.
        for v in [0.8125, 0.0031, 1.1] {
            assert!(sigma.contains(&v.to_string()), "{format:?}: {sigma}");
        }
    }
}

/// A frame whose smallest moment's axis is P's z: ascending order would put roll-pitch-yaw at
/// its gimbal lock; the cyclic order keeps the angles exact and R proper.
#[test]
fn principal_axes_are_a_proper_rotation_away_from_gimbal_lock() {
    let tall = Quantities {
        mass: 80.0,
        com: [0.0, 0.0, 0.9],
        inertia_com: car_tensor([3.0, 12.0, 13.5], [0.0, std::f64::consts::FRAC_PI_2, 0.4]),
    };
    for (q, moments) in [
        (car(), [612.5, 2471.25, 2693.125]),
        (tall, [3.0, 12.0, 13.5]),
    ] {
        let p = payload_of(q);
        let f = p.principal;
        assert!((f.rotation.determinant() - 1.0).abs() < 1e-12);
        let r = rz(f.rpy[2]) * ry(f.rpy[1]) * rx(f.rpy[0]);
        let scale = q.inertia_com[2][2];
        assert_close("rpy", &rebuilt(r, f.moments), &six(&q.inertia_com), scale);
        let from_q = rebuilt(from_quat(f.quat_wxyz), f.moments);
        assert_close("quat", &from_q, &six(&q.inertia_com), scale);
        assert!(f.rpy[1].cos() > 0.5, "{:?}", f.rpy);
        let mut sorted = f.moments;
        sorted.sort_by(f64::total_cmp);
        assert_close("moments", &sorted, &moments, scale);
    }
    // The tall body's smallest moment is about z: its frame starts from another axis.
    assert_ne!(payload_of(tall).principal.moments[0], 3.0);
}

fn refusal(text: &str) -> ExportError {
    parse(text, "r.json").expect_err("refused")
}

#[test]
fn unphysical_reports_are_refused_naming_the_field() {
    let field = |e: ExportError| match e {
        ExportError::Invalid { field, .. } => field,
        other => panic!("{other}"),
    };
    let mut q = car();
    q.mass = 0.0;
    assert_eq!(field(refusal(&report_with(q).to_json())), "estimate.mass");
    let mut q = car();
    q.inertia_com = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]];
    assert_eq!(
        field(refusal(&report_with(q).to_json())),
        "estimate.inertia_com"
    );
    // Positive definite but A + B < C: 1 + 1 < 3.
    q.inertia_com = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 3.0]];
    let e = refusal(&report_with(q).to_json());
    assert!(e.to_string().contains("triangle"), "{e}");
    q.inertia_com = [[2.0, 0.5, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 3.0]];
    let e = refusal(&report_with(q).to_json());
    assert!(e.to_string().contains("not symmetric"), "{e}");
    let mut r = report_with(car());
    r.sigma.com[2] = -0.1;
    assert_eq!(field(refusal(&r.to_json())), "sigma.com[2]");
}

#[test]
fn a_campaign_or_broken_report_is_refused() {
    let campaign = format!(
        r#"{{"runs": 2, "reports": [{0}, {0}]}}"#,
        Report::default().to_json()
    );
    assert!(matches!(
        refusal(&campaign),
        ExportError::Campaign { runs: 2 }
    ));
    let e = refusal("{\"estimate\": {\"mass\": 1.0}}");
    assert!(e.to_string().contains("estimate"), "{e}");
    let e = refusal(
        r#"{"estimate": {"mass": null, "com": [0,0,0], "inertia_com": [[1,0,0],[0,1,0],[0,0,1]]}, "sigma": {}}"#,
    );
    assert!(e.to_string().contains("estimate.mass"), "{e}");
    assert!(matches!(refusal("not json"), ExportError::Json(_)));
}

#[test]
fn an_atomic_write_replaces_the_whole_file_and_leaves_no_temporary() {
    let dir = tempfile::tempdir().expect("a directory");
    let path = dir.path().join("payload.urdf");
    std::fs::write(&path, "old").expect("write");
    crate::file::write_atomically(&path, "new text").expect("written");
    assert_eq!(std::fs::read_to_string(&path).expect("read"), "new text");
    let names: Vec<_> = std::fs::read_dir(dir.path()).expect("list").collect();
    assert_eq!(names.len(), 1);
    let missing = dir.path().join("no/such/dir/x.urdf");
    assert!(crate::file::write_atomically(&missing, "x").is_err());
}

#[test]
fn format_names_round_trip() {
    for f in Format::ALL {
        assert_eq!(Format::from_name(f.name()), Some(f));
    }
    assert_eq!(Format::from_name("obj"), None);
}

#[test]
fn every_file_states_its_frame_in_words_and_a_vehicle_report_exports_in_the_vehicle_frame() {
    let mut report = report_with(car());
    let plain = parse(&report.to_json(), "r.json").unwrap();
    for format in [Format::Urdf, Format::Sdf, Format::Mjcf] {
        let text = render(&plain, options(format, false));
        assert!(text.contains("plate frame P"), "{format:?}: {text}");
    }
    // A vehicle section: its numbers are exported, its frame named.
    let mut in_v = car();
    in_v.com = [-1.25, 0.02, 0.55];
    report.vehicle = Some(measure::vehicle::VehicleResults {
        frame: "vehicle frame V, ISO 8855 (x forward, y left, z up): origin here".into(),
        estimate: in_v,
        sigma: report.sigma,
        ..Default::default()
    });
    let p = parse(&report.to_json(), "r.json").unwrap();
    assert_eq!(p.estimate.com, in_v.com);
    for format in [Format::Urdf, Format::Sdf, Format::Mjcf] {
        let text = render(&p, options(format, false));
        assert!(
            text.contains("in the vehicle frame V, ISO 8855"),
            "{format:?}: {text}"
        );
    }
    let csv = render(&p, options(Format::Csv, false));
    let mut reader = csv::Reader::from_reader(csv.as_bytes());
    let header = reader.headers().unwrap().clone();
    let row = reader.records().next().unwrap().unwrap();
    let k = header
        .iter()
        .position(|h| h == "frame")
        .expect("a frame column");
    assert!(
        row[k].starts_with("the vehicle frame V; ISO 8855"),
        "{}",
        &row[k]
    );
}
