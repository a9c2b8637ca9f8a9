//! The JSON schemas of measure's saved records that the log carries: the tare file
//! ([`TareFile`](measure::tare::TareFile), `--tare FILE` and `/run/tare`) with the error budget's inputs
//! ([`RunBudget`](measure::budget::RunBudget)) and the brake hold's static weighing
//! ([`StaticWeighing`](measure::weigh::StaticWeighing)) inside it.
//!
//! The tests serialize each type and check it against its schema, so that a field added to
//! the type and not here (or the other way round) fails.

use super::{array, boolean, int, nullable, num, numbers, object, string, Schema};

/// [`measure::tare::TareFile`]'s JSON schema: the tare file's, and the `/run/tare` channel's.
pub fn tare_file() -> Schema {
    object(
        vec![
            ("format", string("\"stewart-tare/1\"")),
            (
                "theta",
                numbers(10, "[m, hx, hy, hz, Jxx, Jyy, Jzz, Jxy, Jxz, Jyz] of the empty fixture about the P origin, P axes"),
            ),
            ("covariance", array(numbers(10, ""), Some(10), "covariance of theta")),
            ("samples", int("samples the estimate used")),
            ("residual_rms", numbers(6, "RMS residual of Fx, Fy, Fz (N), τx, τy, τz (N·m)")),
            ("base_joints_m", array(numbers(3, ""), Some(6), "base joints in B, m")),
            ("plate_joints_m", array(numbers(3, ""), Some(6), "plate joints in P, m")),
            ("config", string("scenario file")),
            ("backend", string("sim or rig")),
            (
                "accel_bias_sensitivity",
                nullable(array(
                    numbers(10, ""),
                    Some(3),
                    "d theta / d accelerometer bias along x, y, z (rows), per m/s^2",
                )),
            ),
            (
                "load_cell_offset_sensitivity",
                nullable(array(
                    numbers(10, ""),
                    Some(6),
                    "d theta / d zero offset of each load cell (rows: legs), per N",
                )),
            ),
            ("budget", nullable(run_budget())),
            (
                "covariance_windows",
                nullable(int("residual windows behind the covariance")),
            ),
            (
                "static_weighing",
                nullable(static_weighing()),
            ),
        ],
        "The empty fixture's inertial parameters, subtracted from loaded runs",
    )
}

/// [`measure::budget::RunBudget`]'s JSON schema (inside a tare file and `/run/tare`).
pub fn run_budget() -> Schema {
    object(
        vec![
            (
                "effects",
                array(
                    object(
                        vec![
                            ("source", string("error source id")),
                            (
                                "per_run",
                                boolean(
                                    "the errors are this run's own, not shared with the other run",
                                ),
                            ),
                            (
                                "effects",
                                array(
                                    numbers(10, ""),
                                    None,
                                    "change of theta from one sigma of each elementary error",
                                ),
                            ),
                        ],
                        "one source's effects",
                    ),
                    None,
                    "per systematic source",
                ),
            ),
            ("used", int("samples used")),
            ("lost", int("frames lost")),
            (
                "jitter_share",
                num("timestamp jitter's share of the statistical variance"),
            ),
            (
                "rigid_body",
                nullable(object(
                    vec![
                        ("ok", boolean("the rigid-body model explains the data")),
                        (
                            "residual_ratio",
                            nullable(num("residual rms over the expected rms")),
                        ),
                        (
                            "peak_hz",
                            nullable(num("largest peak of the residual spectrum, Hz")),
                        ),
                    ],
                    "rigid-body check",
                )),
            ),
        ],
        "the run's error-budget inputs",
    )
}

/// [`measure::weigh::StaticWeighing`]'s JSON schema (in the tare file and on `/run/tare`).
pub fn static_weighing() -> Schema {
    let triples = |d| array(numbers(3, ""), None, d);
    object(
        vec![
            ("samples", int("hold samples averaged")),
            ("time_s", num("backend time of the hold's middle, s")),
            ("gravity_m_s2", num("gravity used, m/s^2")),
            ("up_in_p", numbers(3, "up in P axes at the hold's pose")),
            (
                "wrench",
                numbers(
                    6,
                    "mean static wrench Fx Fy Fz (N) tx ty tz (N m), P origin, P axes",
                ),
            ),
            ("values", numbers(3, "m (kg), h_x, h_y (kg m) for h_z = 0")),
            ("tilt", numbers(2, "d(h_x, h_y)/d h_z")),
            (
                "noise_covariance",
                array(
                    numbers(3, ""),
                    Some(3),
                    "covariance of values from the noise",
                ),
            ),
            (
                "effects",
                array(
                    object(
                        vec![
                            ("source", string("error source id")),
                            (
                                "effects",
                                triples("change of values from one sigma of each elementary error"),
                            ),
                        ],
                        "one source's effects",
                    ),
                    None,
                    "the rig's shared errors",
                ),
            ),
            (
                "drift_per_s",
                triples("change of values per second of one sigma of each cell's zero drift"),
            ),
        ],
        "The brake hold's static weighing of everything on the plate",
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use measure::budget::{RigidBody, RunBudget, SourceEffects};
    use measure::tare::{TareFile, TARE_FORMAT};
    use measure::weigh::{StaticWeighing, WeighEffects};

    fn tare() -> TareFile {
        TareFile {
            format: TARE_FORMAT.into(),
            theta: [400.0, 0.0, 0.0, 20.0, 300.0, 300.0, 450.0, 0.0, 0.0, 0.0],
            covariance: [[1e-4; 10]; 10],
            samples: 1000,
            residual_rms: [1.0; 6],
            base_joints_m: [[0.5, 0.0, 0.0]; 6],
            plate_joints_m: [[0.3, 0.0, 0.0]; 6],
            config: "x.toml".into(),
            backend: "sim".into(),
            accel_bias_sensitivity: None,
            load_cell_offset_sensitivity: None,
            budget: None,
            covariance_windows: None,
            static_weighing: None,
        }
    }

    /// Every optional part present: the sensitivities, the budget (with and without its
    /// rigid-body check) and the static weighing.
    fn full_tare(rigid_body: Option<RigidBody>) -> TareFile {
        let mut e = [0.0; 10];
        e[4] = 0.125;
        TareFile {
            accel_bias_sensitivity: Some([[0.5; 10]; 3]),
            load_cell_offset_sensitivity: Some([[0.25; 10]; 6]),
            budget: Some(RunBudget {
                effects: vec![SourceEffects {
                    per_run: true,
                    source: "geometry".into(),
                    effects: vec![e; 36],
                }],
                used: 29_000,
                lost: 30,
                jitter_share: 1e-3,
                rigid_body,
            }),
            covariance_windows: Some(40),
            static_weighing: Some(StaticWeighing {
                samples: 200,
                time_s: 1.5,
                gravity_m_s2: 9.81,
                up_in_p: [0.0, 0.0, 1.0],
                wrench: [0.0, 0.0, 3924.0, 0.0, 0.0, 0.0],
                values: [400.0, 0.0, 0.0],
                tilt: [0.0, 0.0],
                noise_covariance: [[1e-6; 3]; 3],
                effects: vec![WeighEffects {
                    source: "load_cell_gain".into(),
                    effects: vec![[0.1, 0.0, 0.0]; 6],
                }],
                drift_per_s: vec![[1e-3, 0.0, 0.0]; 6],
            }),
            ..tare()
        }
    }

    #[test]
    fn a_tare_file_matches_its_schema_with_and_without_its_optional_parts() {
        let rigid = RigidBody {
            ok: true,
            residual_ratio: 0.7,
            peak_hz: 1.1,
        };
        for t in [tare(), full_tare(None), full_tare(Some(rigid))] {
            let v = serde_json::to_value(&t).unwrap();
            assert_eq!(tare_file().check(&v), Ok(()), "{v}");
        }
    }

    #[test]
    fn a_tare_file_missing_a_field_or_with_another_is_refused() {
        let mut v = serde_json::to_value(full_tare(None)).unwrap();
        v["static_weighing"].as_object_mut().unwrap().remove("tilt");
        let err = tare_file().check(&v).unwrap_err();
        assert!(
            err.contains("$.static_weighing: missing property `tilt`"),
            "{err}"
        );

        let mut v = serde_json::to_value(full_tare(None)).unwrap();
        v["budget"]["effects"][0]["extra"] = serde_json::json!(1);
        let err = tare_file().check(&v).unwrap_err();
        assert!(
            err.contains("$.budget.effects[0]: property `extra`"),
            "{err}"
        );
    }
}
