//! A run's weighing as mass and centre of mass, and the payload's: the loaded run's less the
//! tare run's, the rig's shared errors as the difference of their two changes.

use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::StaticWeighing;

/// Mass and horizontal centre of mass from a static weighing, with one sigma each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Weighed {
    /// Mass, kg.
    pub mass_kg: f64,
    /// c_x, c_y about the P origin in P axes, m.
    pub com_xy_m: [f64; 2],
    /// One sigma of `mass_kg`.
    pub sigma_mass_kg: f64,
    /// One sigma of `com_xy_m`.
    pub sigma_com_xy_m: [f64; 2],
    /// The noise's share of `sigma_mass_kg`, kg.
    pub noise_sigma_mass_kg: f64,
    /// The centre of mass's height used for h_z (from the dynamic fit, or 0), m: its share of
    /// c_x, c_y is the hold's tilt times it.
    pub com_z_used_m: f64,
}

impl StaticWeighing {
    /// (m, h_x, h_y) for a centre of mass height h_z (kg·m).
    pub fn at_height(&self, h_z: f64) -> Vector3<f64> {
        Vector3::new(
            self.values[0],
            self.values[1] + h_z * self.tilt[0],
            self.values[2] + h_z * self.tilt[1],
        )
    }

    /// This run alone: mass and c_x, c_y at height `com_z_m`, the rig's errors counted whole.
    pub fn weighed(&self, com_z_m: f64) -> Weighed {
        let v = self.at_height(self.values[0] * com_z_m);
        let mut cov = Matrix3::from(self.noise_covariance);
        for e in self.effects.iter().flat_map(|s| &s.effects) {
            let d = Vector3::from(*e);
            cov += d * d.transpose();
        }
        to_weighed(&v, &cov, self.noise_covariance[0][0], com_z_m)
    }
}

/// The payload's weighing: `loaded` (at centre of mass height `loaded_com_z_m`) less `tare`
/// (at `tare_com_z_m`). Noise adds; each shared error's change is the loaded run's less the
/// tare's (one error of the rig moves both); each cell's zero drift counts over the time from
/// the tare's hold to the loaded one's. Sources whose lists differ in length (other figures)
/// count as independent.
pub fn payload(
    loaded: &StaticWeighing,
    loaded_com_z_m: f64,
    tare: &StaticWeighing,
    tare_com_z_m: f64,
) -> Weighed {
    let v = loaded.at_height(loaded.values[0] * loaded_com_z_m)
        - tare.at_height(tare.values[0] * tare_com_z_m);
    let noise = Matrix3::from(loaded.noise_covariance) + Matrix3::from(tare.noise_covariance);
    let mut cov = noise;
    let mut add = |d: Vector3<f64>| cov += d * d.transpose();
    for l in &loaded.effects {
        match tare.effects.iter().find(|t| t.source == l.source) {
            Some(t) if t.effects.len() == l.effects.len() => {
                for (a, b) in l.effects.iter().zip(&t.effects) {
                    add(Vector3::from(*a) - Vector3::from(*b));
                }
            }
            Some(t) => {
                for e in l.effects.iter().chain(&t.effects) {
                    add(Vector3::from(*e));
                }
            }
            None => l.effects.iter().for_each(|e| add(Vector3::from(*e))),
        }
    }
    for t in &tare.effects {
        if !loaded.effects.iter().any(|l| l.source == t.source) {
            t.effects.iter().for_each(|e| add(Vector3::from(*e)));
        }
    }
    let elapsed_s = loaded.time_s - tare.time_s;
    if elapsed_s.is_finite() && elapsed_s > 0.0 {
        for d in &loaded.drift_per_s {
            add(Vector3::from(*d) * elapsed_s);
        }
    }
    let com_z = if v.x != 0.0 {
        (loaded.values[0] * loaded_com_z_m - tare.values[0] * tare_com_z_m) / v.x
    } else {
        0.0
    };
    to_weighed(&v, &cov, noise[(0, 0)], com_z)
}

/// c = h / m with its covariance through J = ∂(m, c_x, c_y)/∂(m, h_x, h_y).
fn to_weighed(v: &Vector3<f64>, cov: &Matrix3<f64>, noise_mm: f64, com_z_m: f64) -> Weighed {
    let m = v.x;
    let j = Matrix3::new(
        1.0,
        0.0,
        0.0,
        -v.y / (m * m),
        1.0 / m,
        0.0,
        -v.z / (m * m),
        0.0,
        1.0 / m,
    );
    let c = j * cov * j.transpose();
    Weighed {
        mass_kg: m,
        com_xy_m: [v.y / m, v.z / m],
        sigma_mass_kg: c[(0, 0)].max(0.0).sqrt(),
        sigma_com_xy_m: [c[(1, 1)].max(0.0).sqrt(), c[(2, 2)].max(0.0).sqrt()],
        noise_sigma_mass_kg: noise_mm.max(0.0).sqrt(),
        com_z_used_m: com_z_m,
    }
}
