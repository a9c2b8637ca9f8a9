//! `--html FILE` in a real browser: the page of a real `simulate` report (and of `stewart report`
//! on that report's file), opened in headless Chromium, loads without a console error and
//! without a network request, shows every figure, and every number cell's `data-value` equals
//! the JSON report's number.
//!
//! Console messages come from Chromium's own log (`--enable-logging=stderr`: `CONSOLE` lines);
//! requests from its network log (`--log-net-log`): a request whose network isolation key is the
//! page's (`file://`) is the page's. The browser's own background requests have other keys. A
//! page with an error and a remote image shows that both detectors fire.
//!
//! Without Chromium (`/usr/bin/chromium` or `chromium` on PATH) the tests fail saying to install
//! it, unless `STEWART_SKIP_BROWSER_TESTS=1`.

use crate::support;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn chromium() -> Option<PathBuf> {
    let fixed = PathBuf::from("/usr/bin/chromium");
    if fixed.is_file() {
        return Some(fixed);
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join("chromium"))
            .find(|p| p.is_file())
    })
}

/// Chromium, or `None` when the tests are to be skipped; panics when it is missing and not.
fn browser_or_skip() -> Option<PathBuf> {
    match chromium() {
        Some(p) => Some(p),
        None if std::env::var("STEWART_SKIP_BROWSER_TESTS").as_deref() == Ok("1") => {
            eprintln!("skipped: chromium is not installed and STEWART_SKIP_BROWSER_TESTS=1");
            None
        }
        None => panic!(
            "headless Chromium is needed for the HTML report tests: install it \
             (`apt-get install -y chromium`) or set STEWART_SKIP_BROWSER_TESTS=1 to skip them"
        ),
    }
}

/// What the browser made of a page.
struct Rendered {
    /// The DOM after load (`--dump-dom`).
    dom: String,
    /// Console messages (`CONSOLE` lines of Chromium's log).
    console: Vec<String>,
    /// URLs the page requested over the network.
    requests: Vec<String>,
}

fn render(browser: &Path, page: &Path, scratch: &Path) -> Rendered {
    let profile = tempfile::tempdir_in(scratch).unwrap();
    let netlog = scratch.join(format!(
        "{}.netlog.json",
        page.file_name().unwrap().to_string_lossy()
    ));
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--host-resolver-rules=MAP * ~NOTFOUND",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg(format!("--log-net-log={}", netlog.display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs");
    assert!(out.status.success(), "chromium failed: {out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    let console = stderr
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(str::to_string)
        .collect();
    Rendered {
        dom: String::from_utf8_lossy(&out.stdout).into_owned(),
        console,
        requests: page_requests(&netlog),
    }
}

/// The network requests of the page in a Chromium net log: URL requests started with the
/// page's (`file://`) network isolation key and a URL that is not a file or data URL.
fn page_requests(netlog: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(netlog).expect("chromium wrote its net log");
    let log: Value = serde_json::from_str(&text).expect("the net log is JSON");
    let start_job = log["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"]
        .as_u64()
        .expect("the net log names URL_REQUEST_START_JOB");
    log["events"]
        .as_array()
        .expect("net log events")
        .iter()
        .filter(|e| e["type"].as_u64() == Some(start_job))
        .filter_map(|e| {
            let p = &e["params"];
            let url = p["url"].as_str()?;
            let key = p["network_isolation_key"].as_str().unwrap_or("");
            (key.starts_with("file://") && !url.starts_with("file:") && !url.starts_with("data:"))
                .then(|| url.to_string())
        })
        .collect()
}

/// Every `data-quantity` with its `data-value` in a DOM.
fn page_numbers(dom: &str) -> BTreeMap<String, f64> {
    let mut out = BTreeMap::new();
    let mut rest = dom;
    while let Some(k) = rest.find("data-quantity=\"") {
        rest = &rest[k + "data-quantity=\"".len()..];
        let name = &rest[..rest.find('"').unwrap()];
        let tag_end = rest.find('>').unwrap();
        let tag = &rest[..tag_end];
        let v = tag
            .find("data-value=\"")
            .map(|i| &tag[i + "data-value=\"".len()..])
            .unwrap_or_else(|| panic!("{name} has no data-value"));
        let v: f64 = v[..v.find('"').unwrap()]
            .parse()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(
            out.insert(name.to_string(), v).is_none(),
            "{name} twice on the page"
        );
    }
    out
}

/// The numbers the page must show, read from the JSON report by the names of docs/report.md.
fn expected_numbers(report: &Value) -> BTreeMap<String, f64> {
    let keys = [
        ("mass_kg", "/mass"),
        ("com_x_m", "/com/0"),
        ("com_y_m", "/com/1"),
        ("com_z_m", "/com/2"),
        ("J_C_xx_kg_m2", "/inertia_com/0/0"),
        ("J_C_yy_kg_m2", "/inertia_com/1/1"),
        ("J_C_zz_kg_m2", "/inertia_com/2/2"),
        ("J_C_xy_kg_m2", "/inertia_com/0/1"),
        ("J_C_xz_kg_m2", "/inertia_com/0/2"),
        ("J_C_yz_kg_m2", "/inertia_com/1/2"),
    ];
    let mut out = BTreeMap::new();
    let num = |v: &Value, path: &str| {
        v.pointer(path)
            .and_then(Value::as_f64)
            .unwrap_or_else(|| panic!("{path} in the report"))
    };
    let mut quantities = |prefix: &str, q: &Value| {
        for (key, path) in keys {
            out.insert(format!("{prefix}.{key}"), num(q, path));
        }
    };
    quantities("estimate", &report["estimate"]);
    quantities("sigma", &report["sigma"]);
    quantities("budget.total", &report["sigma"]);
    quantities("systematic", &report["systematic"]["sigma"]);
    quantities("tare", &report["tare"]["estimate"]);
    if !report["truth"].is_null() {
        quantities("truth", &report["truth"]);
    }
    let vehicle = &report["vehicle"];
    if vehicle.is_object() {
        quantities("vehicle.estimate", &vehicle["estimate"]);
        quantities("vehicle.sigma", &vehicle["sigma"]);
        if !vehicle["truth"].is_null() {
            quantities("vehicle.truth", &vehicle["truth"]);
        }
    }
    for line in report["error_budget"].as_array().unwrap() {
        quantities(
            &format!("budget.{}", line["source"].as_str().unwrap()),
            &line["sigma"],
        );
    }
    for (key, path) in keys {
        out.insert(format!("U.{key}"), 2.0 * num(&report["sigma"], path));
    }
    if vehicle.is_object() {
        for (key, path) in keys {
            out.insert(
                format!("vehicle.U.{key}"),
                2.0 * num(&vehicle["sigma"], path),
            );
        }
    }
    for k in 0..3 {
        out.insert(
            format!("principal.moment_{}_kg_m2", k + 1),
            num(report, &format!("/principal/moments/{k}")),
        );
        for (c, axis) in ["x", "y", "z"].iter().enumerate() {
            out.insert(
                format!("principal.axis_{}_{axis}", k + 1),
                num(report, &format!("/principal/axes/{k}/{c}")),
            );
        }
    }
    for (c, axis) in ["x", "y", "z"].iter().enumerate() {
        out.insert(
            format!("residual.force_{axis}_n"),
            num(report, &format!("/residual_rms/force_n/{c}")),
        );
        out.insert(
            format!("residual.torque_{axis}_nm"),
            num(report, &format!("/residual_rms/torque_nm/{c}")),
        );
    }
    for key in ["samples", "excitation_s", "rejected_samples"] {
        out.insert(key.into(), num(report, &format!("/{key}")));
    }
    if let Some(k) = report["convergence"]["samples_to_1pct"].as_f64() {
        out.insert("samples_to_1pct".into(), k);
    }
    out
}

fn stewart(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_stewart"))
        .args(args)
        .output()
        .expect("stewart runs");
    assert!(out.status.success(), "stewart {args:?}: {out:?}");
}

/// The detectors fire: a page with a script error, a console error and a remote image gives
/// console lines and the image's request.
#[test]
fn the_browser_checks_catch_an_error_and_a_request() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = support::scratch_dir();
    let page = dir.path().join("bad.html");
    std::fs::write(
        &page,
        "<!DOCTYPE html><html><head><title>bad</title></head><body>\
         <img src=\"http://example.invalid/x.png\">\
         <script>console.error('logged'); throw new Error('thrown');</script></body></html>",
    )
    .unwrap();
    let r = render(&browser, &page, dir.path());
    assert!(
        r.console.iter().any(|l| l.contains("logged")),
        "{:?}",
        r.console
    );
    assert!(
        r.console.iter().any(|l| l.contains("thrown")),
        "{:?}",
        r.console
    );
    assert_eq!(r.requests, ["http://example.invalid/x.png"]);
}

/// The page of a real simulated run, written by `simulate --html` and by `stewart report`,
/// its payload placed as a vehicle (the vehicle-frame table first).
#[test]
fn a_simulated_reports_page_renders_clean_with_the_reports_numbers() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let scratch = support::Scratch::new(&format!(
        "{}[vehicle]\norigin_m = [0.3, 0.0, 0.2]\norigin_tolerance_m = 0.002\n\
         orientation_tolerance_deg = 0.2\nwheelbase_m = 2.6\ntrack_m = 1.5\n",
        support::SHORT
    ));
    let (json, html, again) = (
        scratch.path("r.json"),
        scratch.path("r.html"),
        scratch.path("again.html"),
    );
    let s = |p: &Path| p.to_str().unwrap().to_string();
    stewart(&[
        "simulate",
        "--quiet",
        "--config",
        scratch.config_str(),
        "--log",
        &s(&scratch.path("r.mcap")),
        "--report",
        &s(&json),
        "--html",
        &s(&html),
    ]);
    stewart(&["report", &s(&json), "--html", &s(&again)]);
    let report: Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let expected = expected_numbers(&report);
    for page in [&html, &again] {
        let text = std::fs::read_to_string(page).unwrap();
        let lower = text.to_ascii_lowercase();
        assert!(
            !lower.contains("http://") && !lower.contains("https://"),
            "{} references a URL",
            page.display()
        );
        let r = render(&browser, page, scratch.dir.path());
        assert!(r.console.is_empty(), "console: {:#?}", r.console);
        assert!(r.requests.is_empty(), "requests: {:#?}", r.requests);
        for figure in ["ellipsoid", "budget", "convergence", "residuals"] {
            let at = r
                .dom
                .find(&format!("<svg data-figure=\"{figure}\""))
                .unwrap_or_else(|| panic!("figure {figure} not in the DOM"));
            let body = &r.dom[at..at + r.dom[at..].find("</svg>").unwrap()];
            assert!(
                body.contains("<rect") || body.contains("<ellipse"),
                "figure {figure} draws nothing"
            );
        }
        assert!(
            r.dom.contains("<ellipse"),
            "the ellipsoid views draw ellipses"
        );
        assert!(r.dom.contains("k = 2"));
        assert!(
            r.dom.contains("In the vehicle frame") && r.dom.contains("Static axle loads"),
            "the vehicle frame's results are on the page"
        );
        let shown = page_numbers(&r.dom);
        for (name, want) in &expected {
            let got = shown
                .get(name)
                .unwrap_or_else(|| panic!("{name} is not on the page"));
            assert_eq!(got, want, "{name}");
        }
        for name in shown.keys() {
            assert!(expected.contains_key(name), "{name} is not in the report");
        }
    }
}
