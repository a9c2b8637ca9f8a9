//! The payload's results in the vehicle's frame V, from the placement the operator measured
//! (`[vehicle]`, [`rig_description::config::VehicleConfig`]).
//!
//! **The change of frame.** With V's origin o in P and V's axes R in P (a vector v in V's axes
//! is R v in P; R includes the convention's axis signs, [`VehicleConvention::axis_signs`]), the
//! payload's parameters about the P origin in P axes, θ = (m, h, I_O), become in V
//!
//! ```text
//! m_V = m,   h_V = Rᵀ (h − m o),
//! I_V = Rᵀ [ I_O + (m |o|² − 2 h·o) 𝟙 + h oᵀ + o hᵀ − m o oᵀ ] R
//! ```
//!
//! (the inertia about o: Σ mᵢ (|rᵢ − o|² 𝟙 − (rᵢ − o)(rᵢ − o)ᵀ) expanded), linear in θ for a
//! given placement: θ_V = A θ, and the covariance is A Σ Aᵀ. J_C, the tensor about the centre
//! of mass, is the same body's in turned axes: Rᵀ J_C R; c_V = Rᵀ (c − o).
//!
//! **The placement's uncertainty** is one more line of the budget: each coordinate of o off by
//! `origin_tolerance_m` along P's axes, and V turned by `orientation_tolerance_deg` about each
//! of its own axes, each moving θ_V by δₖ = θ_V(placement + errorₖ) − θ_V; their Σ δₖ δₖᵀ is
//! added to A Σ Aᵀ (the error budget's rule: one sigma of each elementary error, its effects'
//! outer products summed).
//!
//! **The static load split.** With the front axle above V's origin and the rear axle
//! `wheelbase_m` behind it, the wheels `track_m` apart about V's x axis, the loads at rest on
//! level ground are F_front = m + h_x/L, F_rear = −h_x/L, F_left = m/2 + h_y/b,
//! F_right = m/2 − h_y/b (in kg; ISO axes, y left), again linear in θ_V.

use estimator::{Estimate, InertialParameters, ParameterCovariance, ParameterVector};
use nalgebra::{Matrix3, Rotation3, SMatrix, Vector3};
use rig_description::config::{VehicleConfig, VehicleConvention, WheelContacts};
use serde::{Deserialize, Serialize};

use rig_description::quantities::{principal_of, quantities, sigmas, Principal, Quantities};

/// Where V is in P: its origin and its axes (the convention's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// V's origin in P, m.
    pub origin_m: Vector3<f64>,
    /// V's axes in P (columns), the convention's signs included.
    pub rotation: Matrix3<f64>,
}

impl Placement {
    /// The placement `v` describes: its origin and orientation, or the frame its wheels'
    /// contact points give ([`WheelContacts::frame`]). `None` when the wheels give no frame
    /// (validation refuses such a description).
    pub fn of(v: &VehicleConfig) -> Option<Self> {
        let signs = Matrix3::from_diagonal(&Vector3::from(v.convention.axis_signs()));
        let (origin_m, iso) = match (&v.wheels_m, v.origin_m) {
            (Some(w), _) => {
                let f = w.frame().ok()?;
                (f.origin_m, f.axes)
            }
            (None, origin) => {
                let [r, p, y] = v.orientation_deg.unwrap_or_default().map(f64::to_radians);
                // The pose convention's roll, pitch, yaw: R = Rx Ry Rz.
                let iso = kinematics::Pose::from_rpy(Vector3::zeros(), r, p, y).rotation;
                (Vector3::from(origin?), *iso.matrix())
            }
        };
        Some(Self {
            origin_m,
            rotation: iso * signs,
        })
    }

    /// θ in V: the parameters about V's origin in V's axes (see the module docs).
    pub fn express(&self, p: &InertialParameters) -> InertialParameters {
        let (o, r) = (self.origin_m, self.rotation);
        let (m, h) = (p.mass_kg, p.first_moment_kg_m);
        let about_o = p.inertia_origin_kg_m2
            + Matrix3::identity() * (m * o.norm_squared() - 2.0 * h.dot(&o))
            + h * o.transpose()
            + o * h.transpose()
            - o * o.transpose() * m;
        InertialParameters {
            mass_kg: m,
            first_moment_kg_m: r.transpose() * (h - o * m),
            inertia_origin_kg_m2: r.transpose() * about_o * r,
        }
    }

    /// A: θ_V = A θ (each column the image of a unit θ; the map is linear).
    pub fn jacobian(&self) -> SMatrix<f64, 10, 10> {
        let mut a = SMatrix::<f64, 10, 10>::zeros();
        for k in 0..10 {
            let mut e = ParameterVector::zeros();
            e[k] = 1.0;
            let column = self
                .express(&InertialParameters::from_vector(&e))
                .to_vector();
            a.set_column(k, &column);
        }
        a
    }

    /// Quantities (mass, centre of mass, J_C in P) written in V: c_V = Rᵀ (c − o),
    /// J_V = Rᵀ J_C R.
    pub fn quantities(&self, q: &Quantities) -> Quantities {
        let r = self.rotation;
        let c = r.transpose() * (Vector3::from(q.com) - self.origin_m);
        let j = r.transpose() * Matrix3::from_fn(|i, k| q.inertia_com[i][k]) * r;
        Quantities {
            mass: q.mass,
            com: c.into(),
            inertia_com: core::array::from_fn(|i| core::array::from_fn(|k| j[(i, k)])),
        }
    }

    /// The placement turned by `angle_rad` about V's own axis `axis`.
    fn turned(&self, axis: usize, angle_rad: f64) -> Self {
        let mut w = Vector3::zeros();
        w[axis] = angle_rad;
        Self {
            origin_m: self.origin_m,
            rotation: self.rotation * Rotation3::new(w).matrix(),
        }
    }
}

/// The static load on the wheels, kg, with one sigma each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LoadSplit {
    /// Front and rear axle (or left and right side), kg.
    pub loads_kg: [f64; 2],
    /// One sigma of each, kg.
    pub sigma_kg: [f64; 2],
    /// The first's share of the mass.
    pub share: f64,
}

/// The payload in the vehicle frame: the report's `vehicle` section.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VehicleResults {
    /// The frame in words: the convention, its axes and where its origin is.
    pub frame: String,
    /// The axes' convention.
    pub convention: VehicleConvention,
    /// V's origin in P, as given or as the wheels' contact points give it, m.
    pub origin_in_p_m: [f64; 3],
    /// V's axes (ISO 8855) in P, roll, pitch, yaw, degrees.
    pub orientation_in_p_deg: [f64; 3],
    /// The wheelbase the axle loads use (given, or from the contact points), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wheelbase_m: Option<f64>,
    /// The track the side loads use (given, or from the contact points), m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub track_m: Option<f64>,
    /// Mass, centre of mass in V (m) and J_C in V's axes (kg·m²).
    pub estimate: Quantities,
    /// One sigma of each entry, the placement's tolerance included.
    pub sigma: Quantities,
    /// The placement's share of `sigma` alone (its line of the budget).
    pub placement_sigma: Quantities,
    /// The world's truth in V, where known (simulation).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<Quantities>,
    /// Principal moments and axes of J_C, axes in V.
    pub principal: Principal,
    /// The centre of gravity's height above the ground plane, m, and its sigma.
    pub cg_height_m: [f64; 2],
    /// Front and rear axle loads at rest, when `wheelbase_m` is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axle_loads: Option<LoadSplit>,
    /// Left and right side loads at rest, when `track_m` is given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side_loads: Option<LoadSplit>,
}

/// A placement with the wheel distances the load split takes.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Frame {
    placement: Placement,
    wheelbase_m: Option<f64>,
    track_m: Option<f64>,
}

impl Frame {
    /// The frame `v` gives: the wheels' distances as given, or as their contact points give.
    fn of(v: &VehicleConfig) -> Option<Self> {
        let placement = Placement::of(v)?;
        let (wheelbase_m, track_m) = match &v.wheels_m {
            Some(w) => {
                let f = w.frame().ok()?;
                (Some(f.wheelbase_m), Some(f.track_m))
            }
            None => (v.wheelbase_m, v.track_m),
        };
        Some(Self {
            placement,
            wheelbase_m,
            track_m,
        })
    }

    /// The frames one sigma of each measured coordinate away: each coordinate of the origin
    /// along P's axes and a turn about each of V's axes, or each coordinate of each contact
    /// point.
    fn tolerance_cases(&self, v: &VehicleConfig) -> Vec<Self> {
        let mut out = Vec::new();
        match &v.wheels_m {
            Some(w) => {
                let t = v.wheel_tolerance_m.unwrap_or(0.0);
                for wheel in 0..4 {
                    for axis in 0..3 {
                        let mut points = w.points();
                        points[wheel][axis] += t;
                        let moved = VehicleConfig {
                            wheels_m: Some(WheelContacts::from_points(points)),
                            ..v.clone()
                        };
                        out.extend(Self::of(&moved));
                    }
                }
            }
            None => {
                let turn = v.orientation_tolerance_deg.unwrap_or(0.0).to_radians();
                for axis in 0..3 {
                    let mut shifted = *self;
                    shifted.placement.origin_m[axis] += v.origin_tolerance_m.unwrap_or(0.0);
                    out.push(shifted);
                    out.push(Self {
                        placement: self.placement.turned(axis, turn),
                        ..*self
                    });
                }
            }
        }
        out
    }
}

/// The static load split's weights: F = w · θ_V for the front axle, rear axle, left side,
/// right side (see the module docs), when the wheelbase and track are known.
fn split_weights(frame: &Frame, convention: VehicleConvention) -> [Option<ParameterVector>; 4] {
    let unit = |k: usize| {
        let mut e = ParameterVector::zeros();
        e[k] = 1.0;
        e
    };
    // In SAE axes y points right: the left side's load takes −h_y.
    let left = convention.axis_signs()[1];
    let axle = frame
        .wheelbase_m
        .map(|l| (unit(0) + unit(1) / l, -unit(1) / l));
    let side = frame.track_m.map(|b| {
        (
            unit(0) * 0.5 + unit(2) * (left / b),
            unit(0) * 0.5 - unit(2) * (left / b),
        )
    });
    [
        axle.map(|a| a.0),
        axle.map(|a| a.1),
        side.map(|s| s.0),
        side.map(|s| s.1),
    ]
}

/// The results of the payload `theta` (P) with covariance `covariance` in the frame `v`
/// describes (see the module docs); `None` when `v` gives no frame (four wheels that span
/// none: validation refuses such a description).
pub fn results(
    v: &VehicleConfig,
    theta: &InertialParameters,
    covariance: &ParameterCovariance,
) -> Option<VehicleResults> {
    let frame = Frame::of(v)?;
    let placement = frame.placement;
    let a = placement.jacobian();
    let theta_v = placement.express(theta);
    let base = theta_v.to_vector();
    let weights = split_weights(&frame, v.convention);
    let mut errors = ParameterCovariance::zeros();
    let mut split_errors = [0.0; 4];
    for moved in frame.tolerance_cases(v) {
        let theta_moved = moved.placement.express(theta).to_vector();
        let d = theta_moved - base;
        errors += d * d.transpose();
        for (k, (w, w_moved)) in weights
            .iter()
            .zip(split_weights(&moved, v.convention))
            .enumerate()
        {
            if let (Some(w), Some(w_moved)) = (w, w_moved) {
                split_errors[k] += (w_moved.dot(&theta_moved) - w.dot(&base)).powi(2);
            }
        }
    }
    let statistical = a * covariance * a.transpose();
    let total = statistical + errors;
    let estimate = Estimate::from_parameters(theta_v, total);
    let placement_only = Estimate::from_parameters(theta_v, errors);
    let q = quantities(&estimate);
    let s = sigmas(&estimate);
    // Up is +z in ISO 8855, −z in SAE J670.
    let up = v.convention.axis_signs()[2];
    let load = |k: usize| {
        let w = weights[k]?;
        let variance = (w.transpose() * statistical * w)[0].max(0.0) + split_errors[k];
        Some((w.dot(&base), variance.sqrt()))
    };
    let split = |first: usize, second: usize| {
        let ((f, sf), (r, sr)) = (load(first)?, load(second)?);
        Some(LoadSplit {
            loads_kg: [f, r],
            sigma_kg: [sf, sr],
            share: f / theta_v.mass_kg,
        })
    };
    // The placement as the results give it: V's origin and its ISO axes in P.
    let iso =
        placement.rotation * Matrix3::from_diagonal(&Vector3::from(v.convention.axis_signs()));
    let (roll, pitch, yaw) = kinematics::Pose {
        position_m: Vector3::zeros(),
        rotation: Rotation3::from_matrix_unchecked(iso),
    }
    .rpy();
    // Angles below the printed precision are zero, not −0.000°.
    let orientation_deg = [roll, pitch, yaw].map(|a| {
        let d = a.to_degrees();
        if d.abs() < 5e-10 {
            0.0
        } else {
            d
        }
    });
    let origin = placement.origin_m;
    let measured_as = match &v.wheels_m {
        Some(_) => format!(
            " (from the four wheels' contact points: wheelbase {:.4} m, track {:.4} m)",
            frame.wheelbase_m.unwrap_or(f64::NAN),
            frame.track_m.unwrap_or(f64::NAN)
        ),
        None => String::new(),
    };
    Some(VehicleResults {
        frame: format!(
            "vehicle frame V, {}: origin on the ground plane below the front axle's centre, at \
             ({:.4}, {:.4}, {:.4}) m in the plate frame P, axes turned by roll {:.3}°, pitch \
             {:.3}°, yaw {:.3}° from P's{measured_as}",
            v.convention.describe(),
            origin[0],
            origin[1],
            origin[2],
            orientation_deg[0],
            orientation_deg[1],
            orientation_deg[2]
        ),
        convention: v.convention,
        origin_in_p_m: origin.into(),
        orientation_in_p_deg: orientation_deg,
        wheelbase_m: frame.wheelbase_m,
        track_m: frame.track_m,
        estimate: q,
        sigma: s,
        placement_sigma: sigmas(&placement_only),
        truth: None,
        principal: principal_of(&estimate),
        cg_height_m: [up * q.com[2], s.com[2]],
        axle_loads: split(0, 1),
        side_loads: split(2, 3),
    })
}

#[cfg(test)]
mod tests;
