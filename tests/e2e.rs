//! The end-to-end tests of the commands' work, one test binary (one link of the workspace
//! instead of one per file; each file is a module, named for what it checks, and
//! `cargo test --test e2e MODULE::` runs one): simulate, estimate, import, export, reports,
//! logs and their damage, the live view, bounded reads and flags. The rig link's tests are
//! `tests/rig.rs`; `tests/no_heap_tick.rs` counts the heap with its own global allocator, alone
//! in its process.

mod support;

mod bounded_counts;
mod bounded_reads;
mod dependency_layers;
mod estimate_lost_frames;
mod estimate_reproduces;
mod export_formats;
mod flag_ranges;
mod html_report;
mod import_round_trip;
mod imu_calibration;
mod inertial_feedforward;
mod live_view;
mod log_channels;
mod log_cut_short;
mod log_damage;
mod log_foxglove_layout;
mod log_names;
mod log_schema_validation;
mod log_size;
mod lost_frames;
mod platform_points;
mod plot_figures;
mod refused_before_motion;
mod rigid_body_check;
mod simulate_accuracy;
mod simulate_bad_config;
mod static_weighing;
mod vehicle_frame;
