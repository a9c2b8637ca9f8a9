//! CSV: one header row whose names carry the units, one value row. Columns: mass, centre of
//! mass in P, J_C's six entries in P axes (the tensor's, ixy = J_xy = −∫xy dm about the centre
//! of mass), then `sigma_` + each of those (one standard deviation); with `principal_axes`
//! also the principal moments of the frame's x, y, z axes and the frame's rotation as
//! roll-pitch-yaw (R = Rz·Ry·Rx) and as a unit quaternion w x y z; last, `frame`: the frame
//! in words (the vehicle's when the report has one, else P; commas written as semicolons).

use crate::{num, Payload};

/// The value columns, with their units, in order (the sigma columns repeat them with
/// `sigma_` in front).
pub const VALUE_COLUMNS: [&str; 10] = [
    "mass_kg",
    "com_x_m",
    "com_y_m",
    "com_z_m",
    "ixx_kg_m2",
    "iyy_kg_m2",
    "izz_kg_m2",
    "ixy_kg_m2",
    "ixz_kg_m2",
    "iyz_kg_m2",
];

/// The principal-frame columns of `--principal-axes`.
pub const PRINCIPAL_COLUMNS: [&str; 10] = [
    "principal_x_kg_m2",
    "principal_y_kg_m2",
    "principal_z_kg_m2",
    "roll_rad",
    "pitch_rad",
    "yaw_rad",
    "qw",
    "qx",
    "qy",
    "qz",
];

/// [mass, cx, cy, cz, ixx, iyy, izz, ixy, ixz, iyz] of a report's quantities.
fn values(q: &measure::report::Quantities) -> [f64; 10] {
    let j = &q.inertia_com;
    [
        q.mass, q.com[0], q.com[1], q.com[2], j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2],
    ]
}

/// The CSV text: header row and value row, each ending in a newline. Names and numbers hold no
/// comma or quote, so no field needs quoting.
pub fn csv(p: &Payload, principal_axes: bool) -> String {
    let mut header: Vec<String> = VALUE_COLUMNS.iter().map(|c| c.to_string()).collect();
    header.extend(VALUE_COLUMNS.iter().map(|c| format!("sigma_{c}")));
    let mut row: Vec<f64> = values(&p.estimate).to_vec();
    row.extend(values(&p.sigma));
    if principal_axes {
        header.extend(PRINCIPAL_COLUMNS.iter().map(|c| c.to_string()));
        row.extend(p.principal.moments);
        row.extend(p.principal.rpy);
        row.extend(p.principal.quat_wxyz);
    }
    let mut row: Vec<String> = row.into_iter().map(num).collect();
    // The frame in words, its commas turned to semicolons (no field needs quoting).
    header.push("frame".into());
    row.push(p.frame.replace(',', ";").replace('"', "'"));
    format!("{}\n{}\n", header.join(","), row.join(","))
}
