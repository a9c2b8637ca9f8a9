//! The ten quantities a measurement reports, in the order every table, report and plan target
//! uses: mass, centre of mass, J_C (the inertia tensor about the centre of mass).

use estimator::Estimate;
use serde::{Deserialize, Serialize};

/// Mass, centre of mass and inertia about the centre of mass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Quantities {
    /// kg.
    pub mass: f64,
    /// Centre of mass in P, m.
    pub com: [f64; 3],
    /// J_C in P axes, kg·m².
    pub inertia_com: [[f64; 3]; 3],
}

impl Quantities {
    /// Names of the entries of [`Self::flat`], as the tables print them.
    pub const NAMES: [&'static str; 10] = [
        "mass", "com x", "com y", "com z", "J_C xx", "J_C yy", "J_C zz", "J_C xy", "J_C xz",
        "J_C yz",
    ];

    /// [m, c_x, c_y, c_z, J_xx, J_yy, J_zz, J_xy, J_xz, J_yz].
    pub fn flat(&self) -> [f64; 10] {
        let (c, j) = (self.com, self.inertia_com);
        [
            self.mass, c[0], c[1], c[2], j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2],
        ]
    }

    /// The inverse of [`Self::flat`] (J_C symmetric).
    pub fn from_flat(q: &[f64; 10]) -> Self {
        let (xx, yy, zz, xy, xz, yz) = (q[4], q[5], q[6], q[7], q[8], q[9]);
        Self {
            mass: q[0],
            com: [q[1], q[2], q[3]],
            inertia_com: [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]],
        }
    }
}

/// Principal moments (ascending) and axes (row k is the unit axis of moment k, in P).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Principal {
    /// kg·m², ascending.
    pub moments: [f64; 3],
    /// Row k: the unit axis (in P) of `moments[k]`.
    pub axes: [[f64; 3]; 3],
}

fn rows(m: &nalgebra::Matrix3<f64>) -> [[f64; 3]; 3] {
    core::array::from_fn(|r| core::array::from_fn(|c| m[(r, c)]))
}

/// Mass, centre of mass and J_C of an estimate.
pub fn quantities(e: &Estimate) -> Quantities {
    Quantities {
        mass: e.parameters.mass_kg,
        com: e.com_m.into(),
        inertia_com: rows(&e.inertia_com_kg_m2),
    }
}

/// One sigma of each entry of [`quantities`].
pub fn sigmas(e: &Estimate) -> Quantities {
    Quantities {
        mass: e.mass_sigma_kg,
        com: e.com_sigma_m.into(),
        inertia_com: rows(&e.inertia_com_sigma_kg_m2),
    }
}

/// Principal moments and axes of an estimate, as the report gives them.
pub fn principal_of(e: &Estimate) -> Principal {
    let axes = e.principal_axes;
    Principal {
        moments: e.principal_moments_kg_m2.into(),
        axes: core::array::from_fn(|k| core::array::from_fn(|r| axes[(r, k)])),
    }
}
