//! The page from a report: k = 2, no network references, every number cell the report's.

use measure::report::{BudgetLine, Quantities, Report};

use crate::{expanded, parse, render, render_json, Context, COVERAGE_FACTOR};

fn report() -> Report {
    let estimate = Quantities {
        mass: 1498.8638046284339,
        com: [0.1494954533567817, -0.07983121975299322, 0.5013469094216518],
        inertia_com: [
            [598.6369145736345, -25.211814301020688, 59.190462538062704],
            [-25.211814301020688, 2496.018112223024, -15.828552824156787],
            [59.190462538062704, -15.828552824156787, 2700.379686936644],
        ],
    };
    let sigma = Quantities {
        mass: 0.8279402501215622,
        com: [
            0.0004724624152647656,
            0.0004845230212843297,
            0.0009907764132050523,
        ],
        inertia_com: [[1.84, 0.78, 1.14], [0.78, 2.31, 1.24], [1.14, 1.24, 1.61]],
    };
    let mut r = Report {
        estimate,
        sigma,
        ..Report::default()
    };
    r.principal.moments = [596.6485772107721, 2495.020932318224, 2703.3652042043072];
    r.principal.axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    r.error_budget = vec![BudgetLine {
        source: "noise".into(),
        sigma,
    }];
    r.run.backend = "sim".into();
    r.run.log = Some("runs/<x>.mcap".into());
    r
}

fn context() -> Context<'static> {
    Context {
        tool: "stewart 0.1.0",
        report_source: "test",
        ..Context::default()
    }
}

/// The `data-value` of the cell named `quantity`.
fn value_of(html: &str, quantity: &str) -> f64 {
    let key = format!("data-quantity=\"{quantity}\" data-value=\"");
    let start = html
        .find(&key)
        .unwrap_or_else(|| panic!("{quantity} not on the page"))
        + key.len();
    let end = start + html[start..].find('"').unwrap();
    html[start..end].parse().unwrap()
}

#[test]
fn the_expanded_uncertainty_is_twice_the_standard_one() {
    assert_eq!(COVERAGE_FACTOR, 2.0);
    assert_eq!(expanded(0.8279402501215622), 1.6558805002431244);
    let r = report();
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    for (k, key) in crate::page::KEYS.iter().enumerate() {
        let u = r.sigma.flat()[k];
        assert_eq!(value_of(&html, &format!("sigma.{key}")), u);
        assert_eq!(value_of(&html, &format!("U.{key}")), 2.0 * u);
        assert_eq!(
            value_of(&html, &format!("estimate.{key}")),
            r.estimate.flat()[k]
        );
    }
    // The printed U of the mass: 2 × 0.82794 = 1.65588 → 1.7, the value to the same place.
    assert!(html.contains(">1498.9</td>"), "value rounded to U's place");
    assert!(html.contains(">± 1.7</td>"), "U to two significant digits");
    assert!(html.contains("k = 2"));
}

#[test]
fn the_page_references_nothing_on_the_network() {
    let mut r = report();
    // A note from a report that names a URL is escaped text, still not a reference; the page's
    // own markup must hold none.
    r.budget_notes = vec!["see the manual".into()];
    let html = render_json(&r.to_json(), &context()).unwrap();
    let lower = html.to_ascii_lowercase();
    for bad in ["http://", "https://", "src=", "href=", "@import", "url("] {
        assert!(!lower.contains(bad), "the page contains {bad}");
    }
    assert!(lower.contains("content-security-policy"));
    assert!(lower.contains("default-src 'none'"));
    for figure in ["ellipsoid", "budget", "convergence", "residuals"] {
        assert!(
            html.contains(&format!("data-figure=\"{figure}\"")),
            "{figure}"
        );
    }
    assert!(html.contains("size: A4"));
}

#[test]
fn text_from_the_report_is_escaped() {
    let html = render(&parse(&report().to_json()).unwrap(), &context());
    assert!(html.contains("runs/&lt;x&gt;.mcap"));
    assert!(!html.contains("runs/<x>"));
}

#[test]
fn a_campaign_report_is_refused() {
    let e = parse("{\"reports\": [{}, {}], \"parameters\": []}").unwrap_err();
    assert!(e.to_string().contains("campaign"), "{e}");
    assert!(parse("not json").is_err());
}

#[test]
fn a_report_without_budget_says_so() {
    let mut r = report();
    r.error_budget.clear();
    let html = render_json(&r.to_json(), &context()).unwrap();
    assert!(html.contains("The report carries no error budget."));
    assert!(!html.contains("data-figure=\"budget\""));
}

/// The calibrations the report records are listed with their dates and the tool that fitted
/// them; a report without any says none was applied. The tool that made the report is named.
#[test]
fn the_page_lists_the_applied_calibrations_with_their_dates() {
    let mut r = report();
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    assert!(html.contains("None applied"), "no calibration");
    assert!(html.contains("not recorded in the report"), "no tool");
    r.run.tool = "stewart 9.9.9".into();
    r.run.calibrations = vec![rig_description::calibration::AppliedCalibration {
        kind: "imu".into(),
        source: "cal/<imu>.toml".into(),
        calibrated_utc: "2026-11-18T11:06:40Z".into(),
        tool: "stewart 9.9.8".into(),
        sha256: "5e".repeat(32),
    }];
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    assert!(!html.contains("None applied"));
    for text in [
        "IMU alignment",
        "2026-11-18T11:06:40Z",
        "cal/&lt;imu&gt;.toml",
        "stewart 9.9.8",
        "stewart 9.9.9",
        &"5e".repeat(32),
    ] {
        assert!(html.contains(text), "{text} not on the page");
    }
}

#[test]
fn a_projected_estimate_is_said_to_be_one() {
    let plain = render(&parse(&report().to_json()).unwrap(), &context());
    assert!(!plain.contains("projection onto the consistent set"));
    let mut r = report();
    r.consistency.verdict = "inconsistent".into();
    r.consistency.problems = vec!["principal moments break the triangle inequality".into()];
    r.consistency.projected = true;
    r.consistency.distance_sigma = Some(2.5);
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    assert!(html.contains("projection onto the consistent set"));
    assert!(html.contains("2.50 σ from the fit"));
}

/// Regression, configs/paper.toml: with six parameters the mass and centre of mass are marked
/// given (not `± —`), the tensor keeps its uncertainty, and the page says why.
#[test]
fn the_six_parameter_models_given_quantities_are_marked_given() {
    let mut r = report();
    r.run.params = 6;
    r.sigma.mass = 0.0;
    r.sigma.com = [0.0; 3];
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    let u_cells = |text: &str| html.matches(text).count();
    assert_eq!(u_cells(">given</td>"), 4, "mass and com marked given");
    assert!(!html.contains("± —"), "no dash uncertainty");
    assert!(html.contains("The six-parameter model fits the tensor alone"));
    let ten = render(&parse(&report().to_json()).unwrap(), &context());
    assert_eq!(ten.matches(">given</td>").count(), 0);
}

#[test]
fn a_simulated_run_is_titled_and_marked_as_a_simulation() {
    let html = render(&parse(&report().to_json()).unwrap(), &context());
    assert!(html.contains("<h1>Simulated measurement: not a certificate</h1>"));
    assert!(
        html.contains("class=\"simulated\""),
        "the mark every printed page repeats"
    );
    assert!(html.contains("<title>Simulated inertia measurement"));
    assert!(!html.contains("Certificate of measurement"));
    let mut rig = report();
    rig.run.backend = "rig".into();
    let html = render(&parse(&rig.to_json()).unwrap(), &context());
    assert!(html.contains("<h1>Certificate of measurement</h1>"));
    assert!(!html.contains("class=\"simulated\""));
}

#[test]
fn the_measurement_time_is_the_reports_not_the_pages() {
    let mut r = report();
    // 2025-03-14 09:26:53 to 09:29:10 UTC; the page issued a year later.
    r.run.started_unix_s = Some(1_741_944_413);
    r.run.ended_unix_s = Some(1_741_944_550);
    let cx = Context {
        issued_unix_s: Some(1_773_480_413),
        ..context()
    };
    let html = render(&parse(&r.to_json()).unwrap(), &cx);
    assert!(
        html.contains("<th>measured</th><td>2025-03-14 09:26 UTC to 2025-03-14 09:29 UTC</td>"),
        "measured time from the report"
    );
    assert!(
        html.contains("<th>issued</th><td>2026-03-14"),
        "issued is the page's"
    );
    r.run.started_unix_s = None;
    r.run.ended_unix_s = None;
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    assert!(html.contains("time not recorded in the report"));
}

/// The issue: the page left out what the JSON report says about the frames, so a measurement
/// whose log lost or reordered a chunk printed as a clean one. The spans put back in order,
/// dropped or missing, and the records read from another copy, are listed with their frames.
#[test]
fn the_frames_reordered_missing_and_recovered_are_on_the_page() {
    let mut r = report();
    let span = |action: &str, first: u64| measure::report::FrameSpan {
        run: "loaded".into(),
        first_sequence: first,
        last_sequence: first + 99,
        frames: 100,
        from_time_s: first as f64 * 1e-3,
        to_time_s: (first + 99) as f64 * 1e-3,
        action: action.into(),
    };
    r.data.reordered = vec![span("put back in order", 4000)];
    r.data.missing = vec![span("missing", 9000)];
    r.data.recovered = vec!["the loaded measurement's estimator settings".into()];
    r.data.frames_late = 3;
    r.data.frames_duplicate = 100;
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    assert!(
        html.contains("<li>loaded: frames 4000–4099 (100), 4.000–4.099 s: put back in order</li>"),
        "reordered span"
    );
    assert!(html.contains("frames 9000–9099 (100), 9.000–9.099 s: missing"));
    assert!(html.contains("<li>the loaded measurement&#39;s estimator settings</li>"));
    assert!(html.contains("<th>frames late, duplicate (dropped)</th><td>3, 100</td>"));
    // A clean report lists none of them.
    let clean = render(&parse(&report().to_json()).unwrap(), &context());
    assert!(!clean.contains("Spans of frames"));
    assert!(!clean.contains("read from another copy"));
}

/// What identifies the measurement (ISO/IEC 17025 §7.8.2) is on the page: the certificate's
/// number, the customer, the item, the operator, the rig and its serial, the site's gravity,
/// the log's and the rig description's SHA-256; a missing one says so.
#[test]
fn the_page_identifies_the_measurement_the_rig_and_the_files() {
    let mut r = report();
    r.run.certificate = rig_description::config::CertificateConfig {
        number: Some("IM-2026-0117".into()),
        customer: Some("Acme <Motors>".into()),
        item: Some("VIN WVWZZZ1KZ6W000001".into()),
        operator: Some("J. Doe".into()),
        rig_id: Some("hexapod 2".into()),
        rig_serial: None,
        nominal: Vec::new(),
    };
    r.run.local_gravity_m_s2 = Some(9.80912);
    r.run.description_sha256 = Some("ab".repeat(32));
    let cx = Context {
        log_sha256: Some("cd".repeat(32)),
        ..context()
    };
    let html = render(&parse(&r.to_json()).unwrap(), &cx);
    for text in [
        "IM-2026-0117",
        "Acme &lt;Motors&gt;",
        "VIN WVWZZZ1KZ6W000001",
        "J. Doe",
        "hexapod 2",
        "9.80912 m/s²",
        &"ab".repeat(32),
        &"cd".repeat(32),
        "counter(pages)",
    ] {
        assert!(html.contains(text), "{text} not on the page");
    }
    let serial = html.find("rig serial number").expect("the serial's row");
    assert!(
        html[serial..].starts_with("rig serial number</th><td>not given"),
        "{}",
        &html[serial..serial + 80]
    );
}

#[test]
fn nominal_values_get_a_statement_of_conformity_with_its_rule() {
    use rig_description::quantities::{Conformity, Verdict};
    let mut r = report();
    let plain = render(&parse(&r.to_json()).unwrap(), &context());
    assert!(!plain.contains("Statement of conformity"));
    r.conformity = vec![
        Conformity {
            quantity: "mass".into(),
            nominal: 1500.0,
            tolerance: 5.0,
            measured: 1498.86,
            expanded_uncertainty: 0.64,
            verdict: Verdict::Conforms,
        },
        Conformity {
            quantity: "com z".into(),
            nominal: 0.45,
            tolerance: 0.01,
            measured: 0.5013,
            expanded_uncertainty: 0.0004,
            verdict: Verdict::DoesNotConform,
        },
    ];
    let html = render(&parse(&r.to_json()).unwrap(), &context());
    for text in [
        "Statement of conformity",
        "guarded acceptance",
        "conforms",
        "does not conform",
        "com z",
        "the plate frame P",
    ] {
        assert!(html.contains(text), "{text} not on the page");
    }
}
