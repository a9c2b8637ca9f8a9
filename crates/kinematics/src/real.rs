//! The scalar the kinematics and control cores compute in: `f64` (the default everywhere) or
//! `f32` (a Cortex-M4F computes f32 in hardware and f64 in software).
//!
//! The cores are generic over [`Real`] rather than built twice behind a feature, so that one
//! `cargo test` builds and compares both precisions, and so that the downstream crates, which
//! name the types without a parameter (`Geometry`, `Pose`, …), get `f64` by the types' default
//! parameter and compute exactly what they computed before.
//!
//! [`Real`] adds to nalgebra's `RealField` what the cores need and `RealField` does not give
//! bit for bit:
//!
//! * one conversion from `f64` ([`Real::lit`]) for literals and constants, so that no `as` casts
//!   are spread through the code; for `f64` it is the identity;
//! * the transcendental functions through the `libm` crate ([`sin`], [`cos`], …): nalgebra's
//!   scalar traits call the platform's C library when `std` is on, which may round differently
//!   from `libm` in the last bit, and the cores have always computed with `libm`;
//! * the tolerances that depend on the precision (an f32 Newton iteration cannot bring a 1.9 m
//!   leg's residual to 1e-12 m: its unit in the last place there is 1.2e-7 m).

use nalgebra::RealField;

/// A floating-point scalar the cores compute in: implemented for `f64` and `f32`.
pub trait Real: RealField + Copy + Default + core::iter::Sum + 'static {
    /// Default leg-length residual at which forward kinematics stops, m
    /// ([`crate::FkOptions::tolerance_m`]). f64: 1e-12 m. f32: 2e-6 m, about 16 units in the
    /// last place of a 1.9 m leg (ulp 1.19e-7 m in [1, 2) m): Newton's residual in f32 stalls at
    /// the rounding of the six norms, a few ulp, and a tolerance at that level would fail to
    /// converge on some poses.
    const FK_TOLERANCE_M: Self;
    /// Off-diagonal tolerance of the symmetric eigensolver behind
    /// [`crate::Geometry::inverse_condition_number`]: 1e-15 in f64, f32's machine epsilon
    /// (1.19e-7) in f32.
    const EIGEN_TOLERANCE: Self;

    /// `value` in this precision (rounded to nearest for `f32`; the identity for `f64`).
    fn lit(value: f64) -> Self;
    /// This value as an `f64` (exact for both precisions): for error reports and casts.
    fn to_f64(self) -> f64;
    /// True for NaN (`RealField` gives `is_finite` but not this).
    fn is_nan(self) -> bool;

    /// sin x, by `libm`.
    fn libm_sin(self) -> Self;
    /// cos x, by `libm`.
    fn libm_cos(self) -> Self;
    /// asin x, by `libm`.
    fn libm_asin(self) -> Self;
    /// atan2(y = self, x), by `libm`.
    fn libm_atan2(self, x: Self) -> Self;
    /// √x, by `libm` (correctly rounded, as IEEE 754 requires).
    fn libm_sqrt(self) -> Self;
    /// ⌈x⌉, by `libm`.
    fn libm_ceil(self) -> Self;
    /// IEEE remainder x − n·y with n the integer nearest x/y, by `libm`.
    fn libm_remainder(self, y: Self) -> Self;
}

impl Real for f64 {
    const FK_TOLERANCE_M: f64 = 1e-12;
    const EIGEN_TOLERANCE: f64 = 1e-15;

    fn lit(value: f64) -> Self {
        value
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
    fn libm_sin(self) -> Self {
        libm::sin(self)
    }
    fn libm_cos(self) -> Self {
        libm::cos(self)
    }
    fn libm_asin(self) -> Self {
        libm::asin(self)
    }
    fn libm_atan2(self, x: Self) -> Self {
        libm::atan2(self, x)
    }
    fn libm_sqrt(self) -> Self {
        libm::sqrt(self)
    }
    fn libm_ceil(self) -> Self {
        libm::ceil(self)
    }
    fn libm_remainder(self, y: Self) -> Self {
        libm::remainder(self, y)
    }
}

impl Real for f32 {
    const FK_TOLERANCE_M: f32 = 2e-6;
    const EIGEN_TOLERANCE: f32 = f32::EPSILON;

    // The one narrowing conversion of the cores: round an f64 literal or constant to f32.
    #[allow(clippy::cast_possible_truncation)]
    fn lit(value: f64) -> Self {
        value as f32
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
    fn libm_sin(self) -> Self {
        libm::sinf(self)
    }
    fn libm_cos(self) -> Self {
        libm::cosf(self)
    }
    fn libm_asin(self) -> Self {
        libm::asinf(self)
    }
    fn libm_atan2(self, x: Self) -> Self {
        libm::atan2f(self, x)
    }
    fn libm_sqrt(self) -> Self {
        libm::sqrtf(self)
    }
    fn libm_ceil(self) -> Self {
        libm::ceilf(self)
    }
    fn libm_remainder(self, y: Self) -> Self {
        libm::remainderf(self, y)
    }
}

/// sin x in the scalar's precision, by `libm`.
pub fn sin<T: Real>(x: T) -> T {
    x.libm_sin()
}

/// cos x in the scalar's precision, by `libm`.
pub fn cos<T: Real>(x: T) -> T {
    x.libm_cos()
}

/// asin x in the scalar's precision, by `libm`.
pub fn asin<T: Real>(x: T) -> T {
    x.libm_asin()
}

/// atan2(y, x) in the scalar's precision, by `libm`.
pub fn atan2<T: Real>(y: T, x: T) -> T {
    y.libm_atan2(x)
}

/// √x in the scalar's precision, by `libm`.
pub fn sqrt<T: Real>(x: T) -> T {
    x.libm_sqrt()
}

/// ⌈x⌉ in the scalar's precision, by `libm`.
pub fn ceil<T: Real>(x: T) -> T {
    x.libm_ceil()
}

/// IEEE remainder of x by y in the scalar's precision, by `libm`.
pub fn remainder<T: Real>(x: T, y: T) -> T {
    x.libm_remainder(y)
}

/// π in the scalar's precision.
pub fn pi<T: Real>() -> T {
    T::lit(core::f64::consts::PI)
}
