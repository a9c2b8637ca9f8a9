//! URDF, SDF and MJCF: the payload's inertial element, each in a minimal document its parsers
//! accept (a robot with one link, a model with one link, a world body), with the sigmas and
//! the provenance as comments.
//!
//! In all three the link (body) frame is the report's frame, stated in words in a comment: the
//! vehicle frame V when the report places the payload as a vehicle (docs/vehicle.md), else the
//! platform frame P. The inertial frame's origin is the centre of mass c, units are SI (kg, m,
//! kg·m², rad), and the inertia is J_C about c: in that frame's axes, or (`principal_axes`) diagonal in the principal frame R with
//! J_C = R·diag(I₁, I₂, I₃)·Rᵀ. The off-diagonal entries are the tensor's, with the minus
//! sign: ixy = J_xy = −∫(x − cx)(y − cy) dm, as URDF, SDF and MuJoCo's `fullinertia` define them.

use measure::report::Quantities;

use crate::{num, Payload};

/// The six distinct entries of J as [ixx, iyy, izz, ixy, ixz, iyz].
fn six(j: &[[f64; 3]; 3]) -> [f64; 6] {
    [j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]]
}

/// Numbers separated by single spaces.
fn list(values: &[f64]) -> String {
    values.iter().map(|v| num(*v)).collect::<Vec<_>>().join(" ")
}

/// `<!-- text -->` with `text` made a legal comment: no `--` inside (a space goes between the
/// dashes; the spaces around `text` keep a `-` at either end off the delimiters), no control
/// characters but newlines.
fn comment(indent: &str, text: &str) -> String {
    let mut t: String = text
        .chars()
        .filter(|c| *c == '\n' || !c.is_control())
        .collect();
    while t.contains("--") {
        t = t.replace("--", "- -");
    }
    format!("{indent}<!-- {t} -->\n")
}

/// The comments every XML document carries: where the numbers came from, the convention, the
/// sigmas (and, in principal axes, J_C in P for reference).
fn comments(indent: &str, p: &Payload, principal_axes: bool) -> String {
    let s = &p.sigma;
    let mut out = comment(
        indent,
        &format!(
            "payload inertial measured by stewart ({}): in {}; SI units; products of \
             inertia are the tensor's entries, ixy = Jxy = -integral of x y dm about the centre \
             of mass",
            p.provenance, p.frame
        ),
    );
    out += &comment(indent, &sigma_text(s, principal_axes));
    if principal_axes {
        out += &comment(
            indent,
            &format!(
                "J_C in P axes, ixx iyy izz ixy ixz iyz: {} kg m^2",
                list(&six(&p.estimate.inertia_com))
            ),
        );
    }
    out
}

/// The sigma comment's text: one standard deviation of each reported quantity.
pub fn sigma_text(s: &Quantities, principal_axes: bool) -> String {
    let mut t = format!(
        "one standard deviation (the report's sigma): mass {} kg; centre of mass x y z {} m; \
         J_C in P axes ixx iyy izz ixy ixz iyz {} kg m^2",
        num(s.mass),
        list(&s.com),
        list(&six(&s.inertia_com))
    );
    if principal_axes {
        t += " (of the tensor's entries in P axes; the report gives no sigma of the principal \
               moments)";
    }
    t
}

/// Origin position and orientation (roll-pitch-yaw) of the inertial frame, and its inertia
/// entries [ixx, iyy, izz, ixy, ixz, iyz].
fn frame(p: &Payload, principal_axes: bool) -> ([f64; 3], [f64; 3], [f64; 6]) {
    if principal_axes {
        let m = p.principal.moments;
        (
            p.estimate.com,
            p.principal.rpy,
            [m[0], m[1], m[2], 0.0, 0.0, 0.0],
        )
    } else {
        (p.estimate.com, [0.0; 3], six(&p.estimate.inertia_com))
    }
}

/// URDF: `<robot><link><inertial>` with `<origin xyz rpy>`, `<mass value>` and
/// `<inertia ixx ixy ixz iyy iyz izz>`.
pub fn urdf(p: &Payload, principal_axes: bool) -> String {
    let (xyz, rpy, i) = frame(p, principal_axes);
    let mut out = String::from("<?xml version=\"1.0\"?>\n<robot name=\"payload\">\n");
    out += "  <link name=\"payload\">\n    <inertial>\n";
    out += &comments("      ", p, principal_axes);
    out += &format!(
        "      <origin xyz=\"{}\" rpy=\"{}\"/>\n      <mass value=\"{}\"/>\n",
        list(&xyz),
        list(&rpy),
        num(p.estimate.mass)
    );
    out += &format!(
        "      <inertia ixx=\"{}\" ixy=\"{}\" ixz=\"{}\" iyy=\"{}\" iyz=\"{}\" izz=\"{}\"/>\n",
        num(i[0]),
        num(i[3]),
        num(i[4]),
        num(i[1]),
        num(i[5]),
        num(i[2])
    );
    out += "    </inertial>\n  </link>\n</robot>\n";
    out
}

/// SDF 1.7: `<sdf><model><link><inertial>` with `<pose>x y z roll pitch yaw</pose>` (relative
/// to the link frame, P), `<mass>` and `<inertia>` of `<ixx>` … `<izz>`.
pub fn sdf(p: &Payload, principal_axes: bool) -> String {
    let (xyz, rpy, i) = frame(p, principal_axes);
    let mut out = String::from("<?xml version=\"1.0\"?>\n<sdf version=\"1.7\">\n");
    out += "  <model name=\"payload\">\n    <link name=\"payload\">\n      <inertial>\n";
    out += &comments("        ", p, principal_axes);
    out += &format!(
        "        <pose>{} {}</pose>\n        <mass>{}</mass>\n        <inertia>\n",
        list(&xyz),
        list(&rpy),
        num(p.estimate.mass)
    );
    for (name, v) in [
        ("ixx", i[0]),
        ("ixy", i[3]),
        ("ixz", i[4]),
        ("iyy", i[1]),
        ("iyz", i[5]),
        ("izz", i[2]),
    ] {
        out += &format!("          <{name}>{}</{name}>\n", num(v));
    }
    out += "        </inertia>\n      </inertial>\n    </link>\n  </model>\n</sdf>\n";
    out
}

/// MJCF: `<mujoco><worldbody><body>` with `<inertial pos mass fullinertia="ixx iyy izz ixy
/// ixz iyz"/>`, or (`principal_axes`) `quat="w x y z" diaginertia="I₁ I₂ I₃"`.
pub fn mjcf(p: &Payload, principal_axes: bool) -> String {
    let mut out = String::from("<?xml version=\"1.0\"?>\n<mujoco model=\"payload\">\n");
    out += "  <worldbody>\n    <body name=\"payload\">\n";
    out += &comments("      ", p, principal_axes);
    let head = format!(
        "      <inertial pos=\"{}\" mass=\"{}\"",
        list(&p.estimate.com),
        num(p.estimate.mass)
    );
    out += &head;
    if principal_axes {
        out += &format!(
            " quat=\"{}\" diaginertia=\"{}\"/>\n",
            list(&p.principal.quat_wxyz),
            list(&p.principal.moments)
        );
    } else {
        out += &format!(
            " fullinertia=\"{}\"/>\n",
            list(&six(&p.estimate.inertia_com))
        );
    }
    out += "    </body>\n  </worldbody>\n</mujoco>\n";
    out
}
