//! Whole-estimator tests.
