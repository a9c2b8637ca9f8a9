//! Tests of the suspension.
