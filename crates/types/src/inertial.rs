//! Inertial parameters of a rigid body: mass, first moment and inertia tensor about the P
//! origin, their centre-of-mass form, principal axes and physical consistency.

use core::fmt;
use core::ops::{Add, Sub};
use nalgebra::{Matrix3, SVector, SymmetricEigen, Vector3};

/// Number of inertial parameters of a rigid body.
pub const PARAMETER_COUNT: usize = 10;

/// θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz]: mass, first moment h = m·c and the six
/// independent entries of the inertia tensor J_O about the P origin in P axes (the layout
/// `docs/CONTRACTS.md` fixes for logs and reports).
pub type ParameterVector = SVector<f64, PARAMETER_COUNT>;

/// Positions of the inertia-tensor entries in θ, as (θ index, row, column) of J_O:
/// Jxx = θ₄, Jyy = θ₅, Jzz = θ₆, Jxy = θ₇, Jxz = θ₈, Jyz = θ₉.
pub const TENSOR_ENTRIES: [(usize, usize, usize); 6] = [
    (4, 0, 0),
    (5, 1, 1),
    (6, 2, 2),
    (7, 0, 1),
    (8, 0, 2),
    (9, 1, 2),
];

/// Mass, first moment h = m·c and inertia tensor J_O = ∫(‖r‖²𝟙 − r rᵀ) dm of a body, all about
/// the P origin and in P axes. J_O's off-diagonal entries are the tensor's (minus the products
/// of inertia). Parameters of bodies about one frame add, so a payload is (loaded − tare).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InertialParameters {
    /// Mass m, kg.
    pub mass_kg: f64,
    /// First moment h = m·c about the P origin, kg·m.
    pub first_moment_kg_m: Vector3<f64>,
    /// Inertia tensor about the P origin in P axes, kg·m² (symmetric).
    pub inertia_origin_kg_m2: Matrix3<f64>,
}

/// Principal moments (ascending) and axes of an inertia tensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principal {
    /// Principal moments, kg·m², ascending.
    pub moments_kg_m2: Vector3<f64>,
    /// Unit principal axes as columns, in the same order as the moments; each of the first two
    /// has its largest component positive and the third is their cross product, so the frame is
    /// right-handed and the choice of signs is deterministic.
    pub axes: Matrix3<f64>,
}

/// The first physical-consistency rule a parameter set breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Inconsistency {
    /// m ≤ 0 (or not finite).
    MassNotPositive,
    /// J_C, the tensor about the centre of mass, has an eigenvalue ≤ 0.
    InertiaNotPositiveDefinite,
    /// The principal moments break the triangle inequality A + B ≥ C.
    TriangleInequality,
}

impl fmt::Display for Inconsistency {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Inconsistency::MassNotPositive => "mass is not positive",
            Inconsistency::InertiaNotPositiveDefinite => {
                "inertia tensor about the centre of mass is not positive definite"
            }
            Inconsistency::TriangleInequality => {
                "principal moments break the triangle inequality (A + B >= C)"
            }
        })
    }
}

/// A rigid body described the way a user gives it: mass m, centre of mass c in P and the inertia
/// tensor J_C = ∫(‖r‖²𝟙 − r rᵀ) dm about the centre of mass, in P axes. Implemented by front
/// ends' body descriptions so that [`InertialParameters::from_body`] accepts them.
pub trait RigidBody {
    /// Mass m, kg.
    fn mass(&self) -> f64;
    /// Centre of mass c in P, m.
    fn com(&self) -> Vector3<f64>;
    /// Inertia tensor about the centre of mass J_C, in P axes, kg·m².
    fn inertia_com(&self) -> Matrix3<f64>;
}

/// Physical-consistency verdict: what a real body must satisfy. Each rule is evaluated on its
/// own (a later one is `false` when it cannot be evaluated because an earlier one failed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Consistency {
    /// m > 0.
    pub mass_positive: bool,
    /// J_C = J_O − m(‖c‖²𝟙 − c cᵀ) is positive definite.
    pub inertia_positive_definite: bool,
    /// Smallest two principal moments add up to at least the largest (with a relative slack of
    /// 1e-9 of the trace, so that an exactly planar body passes).
    pub triangle_inequality: bool,
}

impl Consistency {
    /// True when every rule holds.
    pub fn is_consistent(&self) -> bool {
        self.first_failure().is_none()
    }

    /// The first rule that fails, in the order mass, definiteness, triangle inequality.
    pub fn first_failure(&self) -> Option<Inconsistency> {
        if !self.mass_positive {
            Some(Inconsistency::MassNotPositive)
        } else if !self.inertia_positive_definite {
            Some(Inconsistency::InertiaNotPositiveDefinite)
        } else if !self.triangle_inequality {
            Some(Inconsistency::TriangleInequality)
        } else {
            None
        }
    }
}

/// ‖c‖²𝟙 − c cᵀ: the tensor of a unit point mass at c, the term of the parallel-axis theorem
/// J_O = J_C + m(‖c‖²𝟙 − c cᵀ).
pub fn parallel_axis(c: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::identity() * c.norm_squared() - c * c.transpose()
}

fn symmetric_part(m: &Matrix3<f64>) -> Matrix3<f64> {
    (m + m.transpose()) * 0.5
}

/// Principal moments and axes of a symmetric 3×3 tensor (its symmetric part is used).
/// `None` when an entry is not finite or the eigen-solver does not converge.
pub fn principal_of(tensor: &Matrix3<f64>) -> Option<Principal> {
    if !tensor.iter().all(|v| v.is_finite()) {
        return None;
    }
    let eig = SymmetricEigen::try_new(symmetric_part(tensor), f64::EPSILON, 200)?;
    let [e0, e1, e2]: [f64; 3] = eig.eigenvalues.into();
    let [v0, v1, v2]: [[f64; 3]; 3] = eig.eigenvectors.into();
    // Three (moment, axis) pairs put in ascending order by a fixed sorting network; a pair moves
    // only past a strictly smaller moment, so equal moments keep the solver's order.
    let (p0, p1) = ascending((e0, v0), (e1, v1));
    let (p1, p2) = ascending(p1, (e2, v2));
    let (p0, p1) = ascending(p0, p1);
    let a0 = largest_component_positive(Vector3::from(p0.1));
    let a1 = largest_component_positive(Vector3::from(p1.1));
    let a2 = a0.cross(&a1);
    Some(Principal {
        moments_kg_m2: Vector3::new(p0.0, p1.0, p2.0),
        axes: Matrix3::from_columns(&[a0, a1, a2]),
    })
}

/// The pair (a, b) with the smaller key first; `a` stays first unless b's key is strictly smaller.
fn ascending<T>(a: (f64, T), b: (f64, T)) -> ((f64, T), (f64, T)) {
    if b.0 < a.0 {
        (b, a)
    } else {
        (a, b)
    }
}

/// v or −v, whichever has its largest-magnitude component (the first one, on a tie) positive.
fn largest_component_positive(v: Vector3<f64>) -> Vector3<f64> {
    let largest = v.iter().fold(
        0.0_f64,
        |best, &x| if x.abs() > best.abs() { x } else { best },
    );
    if largest < 0.0 {
        -v
    } else {
        v
    }
}

impl InertialParameters {
    /// All ten parameters zero (an empty body; the identity of tare arithmetic).
    pub fn zero() -> Self {
        Self {
            mass_kg: 0.0,
            first_moment_kg_m: Vector3::zeros(),
            inertia_origin_kg_m2: Matrix3::zeros(),
        }
    }

    /// From θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz].
    pub fn from_vector(theta: &ParameterVector) -> Self {
        let [m, hx, hy, hz, jxx, jyy, jzz, jxy, jxz, jyz]: [f64; PARAMETER_COUNT] = (*theta).into();
        Self {
            mass_kg: m,
            first_moment_kg_m: Vector3::new(hx, hy, hz),
            // Matrix3::new takes the entries row by row; the layout is TENSOR_ENTRIES'.
            inertia_origin_kg_m2: Matrix3::new(jxx, jxy, jxz, jxy, jyy, jyz, jxz, jyz, jzz),
        }
    }

    /// θ = [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] (off-diagonal entries taken from the
    /// tensor's symmetric part).
    pub fn to_vector(&self) -> ParameterVector {
        let j = symmetric_part(&self.inertia_origin_kg_m2);
        let h = &self.first_moment_kg_m;
        // mRC is row R, column C of J_O, in the order of TENSOR_ENTRIES.
        ParameterVector::from([
            self.mass_kg,
            h.x,
            h.y,
            h.z,
            j.m11,
            j.m22,
            j.m33,
            j.m12,
            j.m13,
            j.m23,
        ])
    }

    /// From mass, centre of mass c (m, in P) and the tensor about the centre of mass J_C:
    /// h = m·c, J_O = J_C + m(‖c‖²𝟙 − c cᵀ) (parallel-axis theorem).
    pub fn from_com(mass_kg: f64, com_m: Vector3<f64>, inertia_com_kg_m2: Matrix3<f64>) -> Self {
        Self {
            mass_kg,
            first_moment_kg_m: com_m * mass_kg,
            inertia_origin_kg_m2: symmetric_part(&inertia_com_kg_m2)
                + parallel_axis(&com_m) * mass_kg,
        }
    }

    /// Of a body given by mass, centre of mass and J_C: [`Self::from_com`] with its values.
    pub fn from_body<B: RigidBody + ?Sized>(body: &B) -> Self {
        Self::from_com(body.mass(), body.com(), body.inertia_com())
    }

    /// θ as a plain array, in the order of [`Self::to_vector`]:
    /// [m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz].
    pub fn theta(&self) -> [f64; PARAMETER_COUNT] {
        self.to_vector().into()
    }

    /// A point mass at `position_m` (in P).
    pub fn point_mass(mass_kg: f64, position_m: Vector3<f64>) -> Self {
        Self::from_com(mass_kg, position_m, Matrix3::zeros())
    }

    /// True when every parameter is finite.
    pub fn is_finite(&self) -> bool {
        self.to_vector().iter().all(|v| v.is_finite())
    }

    /// Centre of mass c = h/m in P, m; `None` unless m is positive and finite.
    pub fn com_m(&self) -> Option<Vector3<f64>> {
        if self.mass_kg > 0.0 && self.mass_kg.is_finite() {
            Some(self.first_moment_kg_m / self.mass_kg)
        } else {
            None
        }
    }

    /// Tensor about the centre of mass, J_C = J_O − (‖h‖²𝟙 − h hᵀ)/m, kg·m²; `None` unless m is
    /// positive and finite.
    pub fn inertia_com_kg_m2(&self) -> Option<Matrix3<f64>> {
        let c = self.com_m()?;
        Some(symmetric_part(&self.inertia_origin_kg_m2) - parallel_axis(&c) * self.mass_kg)
    }

    /// Principal moments and axes of J_C; `None` unless m is positive and every entry finite.
    pub fn principal(&self) -> Option<Principal> {
        principal_of(&self.inertia_com_kg_m2()?)
    }

    /// Physical-consistency verdict (m > 0, J_C positive definite, triangle inequality).
    pub fn consistency(&self) -> Consistency {
        let mass_positive = self.mass_kg > 0.0 && self.is_finite();
        let principal = if mass_positive {
            self.principal()
        } else {
            None
        };
        let (pd, tri) = match principal {
            Some(p) => {
                let m = p.moments_kg_m2;
                let slack = 1e-9 * (m.x.abs() + m.y.abs() + m.z.abs());
                (m.x > 0.0, m.x + m.y + slack >= m.z)
            }
            None => (false, false),
        };
        Consistency {
            mass_positive,
            inertia_positive_definite: pd,
            triangle_inequality: pd && tri,
        }
    }
}

impl Add for InertialParameters {
    type Output = InertialParameters;
    /// Parameters of two bodies about the same frame add.
    fn add(self, rhs: Self) -> Self {
        Self::from_vector(&(self.to_vector() + rhs.to_vector()))
    }
}

impl Sub for InertialParameters {
    type Output = InertialParameters;
    /// Tare subtraction: payload = loaded − tare (both about the P origin, in P axes).
    fn sub(self, rhs: Self) -> Self {
        Self::from_vector(&(self.to_vector() - rhs.to_vector()))
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;

    fn cuboid(mass: f64, a: f64, b: f64, c: f64) -> Matrix3<f64> {
        Matrix3::from_diagonal(&Vector3::new(
            mass * (b * b + c * c) / 12.0,
            mass * (a * a + c * c) / 12.0,
            mass * (a * a + b * b) / 12.0,
        ))
    }

    #[test]
    fn vector_round_trip_and_tensor_sign_convention() {
        let theta = ParameterVector::from_column_slice(&[
            3.0, 0.1, -0.2, 0.3, 4.0, 5.0, 6.0, -0.4, 0.5, -0.6,
        ]);
        let p = InertialParameters::from_vector(&theta);
        assert_eq!(p.to_vector(), theta);
        assert_eq!(p.inertia_origin_kg_m2[(1, 0)], -0.4);
        // Two unit masses at (1,1,0) and (−1,−1,0): products ∫xy dm = 2, so the tensor's
        // entry Jxy = −2.
        let q = InertialParameters::point_mass(1.0, Vector3::new(1.0, 1.0, 0.0))
            + InertialParameters::point_mass(1.0, Vector3::new(-1.0, -1.0, 0.0));
        assert_eq!(q.inertia_origin_kg_m2[(0, 1)], -2.0);
        assert_eq!(q.inertia_origin_kg_m2[(2, 2)], 4.0);
    }

    #[test]
    fn tensor_entries_name_the_positions_from_vector_and_to_vector_use() {
        for (k, r, c) in TENSOR_ENTRIES {
            let mut theta = ParameterVector::zeros();
            theta[k] = 1.0;
            let j = InertialParameters::from_vector(&theta).inertia_origin_kg_m2;
            let mut expect = Matrix3::zeros();
            expect[(r, c)] = 1.0;
            expect[(c, r)] = 1.0;
            assert_eq!(j, expect, "θ{k}");
            let mut p = InertialParameters::zero();
            p.inertia_origin_kg_m2 = expect;
            assert_eq!(p.to_vector(), theta, "θ{k}");
        }
    }

    #[test]
    fn principal_axes_have_their_largest_component_positive_and_form_a_right_handed_frame() {
        // diag(3, 1, 2): ascending moments 1, 2, 3 along y, z, x; the first two axes are +y and
        // +z whatever sign the solver returns, and the third is y × z = +x.
        let p = principal_of(&Matrix3::from_diagonal(&Vector3::new(3.0, 1.0, 2.0))).unwrap();
        assert_eq!(p.moments_kg_m2, Vector3::new(1.0, 2.0, 3.0));
        let expect = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        assert!((p.axes - expect).norm() < 1e-15, "{}", p.axes);
    }

    #[test]
    fn com_form_round_trips_through_the_parallel_axis_theorem() {
        let jc = cuboid(2.0, 0.3, 0.5, 0.7);
        let c = Vector3::new(0.2, -0.1, 0.4);
        let p = InertialParameters::from_com(2.0, c, jc);
        assert!((p.com_m().unwrap() - c).norm() < 1e-15);
        assert!((p.inertia_com_kg_m2().unwrap() - jc).norm() < 1e-15);
        // Independent check of one entry: Jzz about O = Jzz,C + m (cx² + cy²).
        let expect = jc[(2, 2)] + 2.0 * (0.2f64.powi(2) + 0.1f64.powi(2));
        assert!((p.inertia_origin_kg_m2[(2, 2)] - expect).abs() < 1e-15);
        assert!(InertialParameters::zero().com_m().is_none());
    }

    #[test]
    fn principal_axes_of_a_rotated_cuboid() {
        let jc = cuboid(1.0, 0.2, 0.6, 0.4); // moments ordered y < z < x
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -0.5, 1.1);
        let rotated = r.matrix() * jc * r.matrix().transpose();
        let p = principal_of(&rotated).unwrap();
        let expect = [jc[(1, 1)], jc[(2, 2)], jc[(0, 0)]];
        for k in 0..3 {
            assert!((p.moments_kg_m2[k] - expect[k]).abs() < 1e-15, "{k}");
        }
        // First axis is the cuboid's y axis, up to sign.
        let y = r.matrix().column(1).into_owned();
        assert!((p.axes.column(0).dot(&y).abs() - 1.0).abs() < 1e-12);
        assert!((p.axes.determinant() - 1.0).abs() < 1e-12);
        let recomposed = p.axes * Matrix3::from_diagonal(&p.moments_kg_m2) * p.axes.transpose();
        assert!((recomposed - rotated).norm() < 1e-14);
    }

    #[test]
    fn consistency_names_the_failing_rule() {
        let good = InertialParameters::from_com(
            2.0,
            Vector3::new(0.1, 0.2, 0.3),
            cuboid(2.0, 1.0, 1.0, 1.0),
        );
        assert!(good.consistency().is_consistent());
        let mut neg = good;
        neg.mass_kg = -1.0;
        assert_eq!(
            neg.consistency().first_failure(),
            Some(Inconsistency::MassNotPositive)
        );
        let not_pd = InertialParameters::from_com(
            1.0,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -0.1)),
        );
        assert_eq!(
            not_pd.consistency().first_failure(),
            Some(Inconsistency::InertiaNotPositiveDefinite)
        );
        let bad_triangle = InertialParameters::from_com(
            1.0,
            Vector3::zeros(),
            Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 2.5)),
        );
        assert_eq!(
            bad_triangle.consistency().first_failure(),
            Some(Inconsistency::TriangleInequality)
        );
        // A thin plate (planar body) sits exactly on the triangle bound and passes.
        let plate = InertialParameters::from_com(1.0, Vector3::zeros(), cuboid(1.0, 0.4, 0.9, 0.0));
        assert!(plate.consistency().is_consistent());
        let mut nan = good;
        nan.first_moment_kg_m.x = f64::NAN;
        assert!(!nan.consistency().is_consistent());
    }

    struct Cuboid;

    impl RigidBody for Cuboid {
        fn mass(&self) -> f64 {
            2.0
        }
        fn com(&self) -> Vector3<f64> {
            Vector3::new(1.0, 2.0, 3.0)
        }
        fn inertia_com(&self) -> Matrix3<f64> {
            Matrix3::zeros()
        }
    }

    #[test]
    fn a_body_moves_to_the_p_origin_by_the_parallel_axis_theorem() {
        // A point mass at c has J_O = m(‖c‖²𝟙 − c cᵀ): Jxx = m(cy² + cz²), Jxy = −m cx cy.
        assert_eq!(
            InertialParameters::from_body(&Cuboid).theta(),
            [2.0, 2.0, 4.0, 6.0, 26.0, 20.0, 10.0, -4.0, -6.0, -12.0]
        );
    }

    #[test]
    fn tare_arithmetic_is_exact_in_a_common_frame() {
        let a = InertialParameters::from_com(
            5.0,
            Vector3::new(0.1, 0.0, 0.2),
            cuboid(5.0, 0.5, 0.4, 0.3),
        );
        let b = InertialParameters::from_com(
            1.0,
            Vector3::new(-0.3, 0.2, 0.05),
            cuboid(1.0, 0.9, 0.9, 0.1),
        );
        let back = (a + b) - b;
        assert!((back.to_vector() - a.to_vector()).norm() < 1e-14);
    }
}
