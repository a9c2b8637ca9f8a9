//! The budget's effects against independent checks on synthetic runs.
