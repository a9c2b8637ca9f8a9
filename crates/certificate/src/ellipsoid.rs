//! The body's equivalent ellipsoid and its orthographic outlines, for the page's picture of the
//! payload on the fixture.
//!
//! The equivalent ellipsoid is the uniform solid ellipsoid with the body's mass and inertia
//! about its centre of mass: along the principal axis u_k with moment I_k its semi-axis is
//! a_k = √(5 (I_i + I_j − I_k) / (2 m)) ({i, j, k} = {1, 2, 3}), since a uniform ellipsoid's
//! moments are I_k = m (a_i² + a_j²) / 5. Unlike the textbook inertia ellipsoid xᵀ J x = 1 it
//! has the body's own size in metres, so it can be drawn to scale on the plate.

use nalgebra::{Matrix2, Matrix3, Vector3};

/// A solid ellipsoid: centre c, principal directions and semi-axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    /// Centre, m (in P).
    pub centre: Vector3<f64>,
    /// Column k: the unit direction of semi-axis k (in P).
    pub axes: Matrix3<f64>,
    /// Semi-axes, m.
    pub semi_axes: Vector3<f64>,
}

/// An ellipse in a view's plane: centre, semi-axes and the angle of the first from the view's
/// first axis (counter-clockwise, radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    /// Centre (view coordinates, m).
    pub centre: [f64; 2],
    /// Semi-axes (r₁ ≥ r₂), m.
    pub radii: [f64; 2],
    /// Angle of r₁ from the view's first axis, radians.
    pub angle: f64,
}

impl Ellipsoid {
    /// The equivalent ellipsoid of mass `mass` (kg) with principal moments `moments` (kg·m²)
    /// about the principal directions `axes` (row k the unit axis of `moments[k]`, as the
    /// report's `principal` gives them), centred at `centre`: a_k = √(5 (I_i + I_j − I_k) /
    /// (2 m)). `None` when m ≤ 0 or a moment breaks the triangle inequality (no body has it).
    pub fn equivalent(
        mass: f64,
        centre: [f64; 3],
        moments: [f64; 3],
        axes: [[f64; 3]; 3],
    ) -> Option<Self> {
        if mass.is_nan() || mass <= 0.0 {
            return None;
        }
        let total: f64 = moments.iter().sum();
        let semi = Vector3::from_fn(|k, _| {
            let s = 5.0 * (total - 2.0 * moments[k]) / (2.0 * mass);
            if s > 0.0 && s.is_finite() {
                s.sqrt()
            } else {
                f64::NAN
            }
        });
        if semi.iter().any(|a| a.is_nan()) || !centre.iter().all(|c| c.is_finite()) {
            return None;
        }
        Some(Self {
            centre: Vector3::from(centre),
            axes: Matrix3::from_fn(|r, k| axes[k][r]),
            semi_axes: semi,
        })
    }

    /// The equivalent ellipsoid of a body given by its mass, centre of mass and J_C (symmetric,
    /// kg·m²): its principal frame by the symmetric eigen-decomposition, then
    /// [`Self::equivalent`].
    pub fn of_body(mass: f64, centre: [f64; 3], inertia_com: [[f64; 3]; 3]) -> Option<Self> {
        let j = Matrix3::from_fn(|r, c| inertia_com[r.min(c)][r.max(c)]);
        if !j.iter().all(|v| v.is_finite()) {
            return None;
        }
        let eig = j.symmetric_eigen();
        let moments = [0, 1, 2].map(|k| eig.eigenvalues[k]);
        let axes = [0, 1, 2].map(|k| [0, 1, 2].map(|r| eig.eigenvectors[(r, k)]));
        Self::equivalent(mass, centre, moments, axes)
    }

    /// The shape matrix A = R diag(a²) Rᵀ: the ellipsoid is {x : (x − c)ᵀ A⁻¹ (x − c) ≤ 1}.
    pub fn shape(&self) -> Matrix3<f64> {
        let a2 = self.semi_axes.component_mul(&self.semi_axes);
        self.axes * Matrix3::from_diagonal(&a2) * self.axes.transpose()
    }

    /// The outline of the orthographic projection onto the P axes `i` (the view's first axis)
    /// and `j` (its second): the ellipse whose shape matrix is A's 2×2 block on (i, j), as
    /// the projection of {c + R diag(a) s : ‖s‖ ≤ 1} is {c' + Q s' : ‖s'‖ ≤ 1} with
    /// Q Qᵀ = P A Pᵀ.
    pub fn outline(&self, i: usize, j: usize) -> Ellipse {
        let a = self.shape();
        let m = Matrix2::new(a[(i, i)], a[(i, j)], a[(j, i)], a[(j, j)]);
        let (p, q, r) = (m[(0, 0)], m[(1, 1)], m[(0, 1)]);
        let mean = 0.5 * (p + q);
        let half = (0.25 * (p - q) * (p - q) + r * r).sqrt();
        Ellipse {
            centre: [self.centre[i], self.centre[j]],
            radii: [(mean + half).max(0.0).sqrt(), (mean - half).max(0.0).sqrt()],
            angle: 0.5 * (2.0 * r).atan2(p - q),
        }
    }

    /// The ends of semi-axis `k` (c ± a_k u_k).
    pub fn axis_ends(&self, k: usize) -> [Vector3<f64>; 2] {
        let d = self.axes.column(k) * self.semi_axes[k];
        [self.centre - d, self.centre + d]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform ellipsoid's moments I_k = m (a_i² + a_j²) / 5 come back as the semi-axes they
    /// were made from (an independent formula: the solid ellipsoid's tabulated inertia).
    #[test]
    fn a_uniform_ellipsoid_gives_back_its_semi_axes() {
        let (m, a) = (1200.0, [0.4, 0.9, 1.6]);
        let moment = |i: usize, j: usize| m * (a[i] * a[i] + a[j] * a[j]) / 5.0;
        let moments = [moment(1, 2), moment(0, 2), moment(0, 1)];
        let e = Ellipsoid::equivalent(
            m,
            [0.0; 3],
            moments,
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        )
        .unwrap();
        for (k, want) in a.iter().enumerate() {
            assert!(
                (e.semi_axes[k] - want).abs() < 1e-12,
                "{k}: {}",
                e.semi_axes
            );
        }
        // No body: one moment larger than the other two together.
        assert!(Ellipsoid::equivalent(m, [0.0; 3], [1.0, 1.0, 3.0], [[0.0; 3]; 3]).is_none());
        assert!(Ellipsoid::equivalent(0.0, [0.0; 3], moments, [[0.0; 3]; 3]).is_none());
    }

    /// The projected outline's extent along each view axis, and along a diagonal, equals the
    /// largest extent of points sampled on the ellipsoid's surface (the support function,
    /// computed without the 2×2 block).
    #[test]
    fn the_outline_bounds_the_ellipsoid_seen_along_an_axis() {
        let j = [
            [600.0, -25.0, 60.0],
            [-25.0, 2500.0, -15.0],
            [60.0, -15.0, 2700.0],
        ];
        let e = Ellipsoid::of_body(1500.0, [0.15, -0.08, 0.5], j).unwrap();
        let r = e.axes * Matrix3::from_diagonal(&e.semi_axes);
        for (i, jj) in [(0, 1), (0, 2), (1, 2)] {
            let o = e.outline(i, jj);
            for phi in [0.0f64, 0.7, 1.3, 2.2] {
                let dir = [phi.cos(), phi.sin()];
                // Support of the ellipse in direction d: √(d₁² r₁² cos² … ) via its rotated
                // axes.
                let (c, s) = (o.angle.cos(), o.angle.sin());
                let along = dir[0] * c + dir[1] * s;
                let across = -dir[0] * s + dir[1] * c;
                let support = ((along * o.radii[0]).powi(2) + (across * o.radii[1]).powi(2)).sqrt();
                let mut best = f64::MIN;
                let n = 200;
                for a in 0..n {
                    for b in 0..=n / 2 {
                        let (th, ph) = (
                            a as f64 / n as f64 * std::f64::consts::TAU,
                            b as f64 / (n / 2) as f64 * std::f64::consts::PI,
                        );
                        let s3 = Vector3::new(ph.sin() * th.cos(), ph.sin() * th.sin(), ph.cos());
                        let p = r * s3;
                        best = best.max(p[i] * dir[0] + p[jj] * dir[1]);
                    }
                }
                assert!(
                    (best - support).abs() < 2e-3 * support,
                    "view ({i},{jj}) φ {phi}: sampled {best} outline {support}"
                );
            }
        }
    }
}
