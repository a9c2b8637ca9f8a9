//! What each load cell is loaded with beyond the axial force it reads: the force across its
//! axis, which the legs' own weight and inertia and the joints' friction put through it and
//! which a cell with transverse sensitivity partly reports.

use nalgebra::Vector3;

/// The transverse force through each leg's load cell, in the leg's transverse basis
/// ([`transverse_basis`]), N. Zero for massless, frictionless legs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct CellLoads {
    /// Components along `e₁` and `e₂` of [`transverse_basis`] for each leg.
    pub transverse_n: [[f64; 2]; 6],
}

/// Two unit vectors across the leg axis `u` (unit, base → plate, in B), fixed to the leg's
/// orientation: `e₁ = normalize(u × z_B)` (horizontal), or `normalize(u × x_B)` for a vertical
/// leg; `e₂ = u × e₁`. A cell's two transverse sensitivities act along these.
#[allow(dead_code)]
pub(crate) fn transverse_basis(u: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let mut e1 = u.cross(&Vector3::z());
    if e1.norm() < 1e-6 {
        e1 = u.cross(&Vector3::x());
    }
    let e1 = e1.normalize();
    (e1, u.cross(&e1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_basis_is_orthonormal_and_across_the_leg() {
        for u in [
            Vector3::new(0.3, -0.2, 0.93),
            Vector3::z(),
            Vector3::new(1.0, 0.0, 0.0),
        ] {
            let u = u.normalize();
            let (e1, e2) = transverse_basis(&u);
            assert!((e1.norm() - 1.0).abs() < 1e-12 && (e2.norm() - 1.0).abs() < 1e-12);
            assert!(e1.dot(&u).abs() < 1e-12 && e2.dot(&u).abs() < 1e-12);
            assert!(e1.dot(&e2).abs() < 1e-12);
        }
    }
}
