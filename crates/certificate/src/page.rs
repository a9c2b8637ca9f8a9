//! The page: head (style, no-fetch policy), then one section per part of the certificate.
//!
//! The number cells' `data-quantity` names (docs/report.md): `estimate.KEY`, `sigma.KEY`,
//! `U.KEY` (= 2·sigma), `truth.KEY`, `systematic.KEY`, `budget.SOURCE.KEY` (`budget.total.KEY`:
//! the combined u, = sigma), `tare.KEY` with KEY
//! one of [`KEYS`]; `principal.moment_K_kg_m2` and `principal.axis_K_x|y|z` (K = 1, 2, 3);
//! `residual.force_x_n` … `residual.torque_z_nm`; `samples`, `excitation_s`,
//! `samples_to_1pct`, `rejected_samples`.

use std::fmt::Write;

use measure::report::{Quantities, Report};

use crate::ellipsoid::Ellipsoid;
use crate::figures::{self, Scene};
use crate::format::{cell, esc, rounded, significant, utc};
use crate::{expanded, Context, Input, COVERAGE_FACTOR};

/// The machine names of [`Quantities::flat`]'s entries, units in the name.
pub const KEYS: [&str; 10] = [
    "mass_kg",
    "com_x_m",
    "com_y_m",
    "com_z_m",
    "J_C_xx_kg_m2",
    "J_C_yy_kg_m2",
    "J_C_zz_kg_m2",
    "J_C_xy_kg_m2",
    "J_C_xz_kg_m2",
    "J_C_yz_kg_m2",
];

/// The units of [`Quantities::flat`]'s entries, as printed.
const UNITS: [&str; 10] = [
    "kg", "m", "m", "m", "kg·m²", "kg·m²", "kg·m²", "kg·m²", "kg·m²", "kg·m²",
];

/// The quantities' names as the certificate prints them.
const LABELS: [&str; 10] = [
    "mass m",
    "centre of mass c<sub>x</sub>",
    "centre of mass c<sub>y</sub>",
    "centre of mass c<sub>z</sub>",
    "J<sub>C,xx</sub>",
    "J<sub>C,yy</sub>",
    "J<sub>C,zz</sub>",
    "J<sub>C,xy</sub>",
    "J<sub>C,xz</sub>",
    "J<sub>C,yz</sub>",
];

const STYLE: &str = include_str!("page.css");

/// The whole document.
pub fn render(input: &Input, cx: &Context<'_>) -> String {
    let r = &input.report;
    let mut s = String::with_capacity(64 * 1024);
    s.push_str(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; \
         style-src 'unsafe-inline'\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>",
    );
    s.push_str(if r.run.backend == "sim" {
        "Simulated inertia measurement (not a certificate)"
    } else {
        "Inertia measurement: certificate of the payload's inertial parameters"
    });
    s.push_str("</title>\n<style>\n");
    s.push_str(STYLE);
    if r.run.backend == "sim" {
        // In the page's margin box too: printed on every page, the last included.
        s.push_str(
            "@page { @top-center { content: \"SIMULATED: computed by stewart simulate, not \
             measured\"; color: #8a1c1c; font-weight: bold; font-size: 9pt; } }\n",
        );
    }
    s.push_str("</style>\n</head>\n<body>\n");
    if r.run.backend == "sim" {
        // Fixed, so a printer repeats it on every page: no page of a simulation passes for a
        // measurement.
        s.push_str(
            "<div class=\"simulated\">SIMULATED: computed by stewart simulate, not measured on \
             a payload</div>\n",
        );
    }
    s.push_str("<main>\n");
    header(&mut s, input, cx);
    results(&mut s, r);
    principal(&mut s, r, cx);
    budget(&mut s, r);
    convergence(&mut s, r);
    residuals(&mut s, r);
    data(&mut s, r);
    tare(&mut s, r);
    rig(&mut s, input, cx);
    provenance(&mut s, r, cx);
    s.push_str("</main>\n</body>\n</html>\n");
    s
}

fn kv(s: &mut String, key: &str, value: &str) {
    let _ = write!(s, "<tr><th>{key}</th><td>{}</td></tr>", esc(value));
}

fn header(s: &mut String, input: &Input, cx: &Context<'_>) {
    let r = &input.report;
    s.push_str(if r.run.backend == "sim" {
        "<header><h1>Simulated measurement: not a certificate</h1><p class=\"sub\">Inertial \
             parameters of a simulated payload on a simulated six-legged (Stewart) platform: \
             mass, centre of mass and inertia tensor about the centre of mass</p><table \
             class=\"ident\">"
    } else {
        "<header><h1>Certificate of measurement</h1><p class=\"sub\">Inertial parameters of \
             a payload measured on a six-legged (Stewart) platform: mass, centre of mass and \
             inertia tensor about the centre of mass</p><table class=\"ident\">"
    });
    match (r.run.started_unix_s, r.run.ended_unix_s) {
        (Some(a), Some(b)) => kv(s, "measured", &format!("{} to {}", utc(a), utc(b))),
        (Some(a), None) => kv(s, "measured", &format!("from {}", utc(a))),
        _ => kv(s, "measured", "time not recorded in the report"),
    }
    if let Some(t) = cx.issued_unix_s {
        kv(s, "issued", &utc(t));
    }
    let backend = match r.run.backend.as_str() {
        "sim" => "simulation (stewart simulate)".to_string(),
        "rig" => "rig (stewart rig)".to_string(),
        other => other.to_string(),
    };
    kv(s, "measured on", &backend);
    for (_, label, value) in r.run.certificate.fields() {
        kv(s, label, value.unwrap_or("not given"));
    }
    kv(
        s,
        "local gravity",
        &r.run
            .local_gravity_m_s2
            .map_or("not recorded".to_string(), |g| format!("{g} m/s²")),
    );
    kv(s, "log", r.run.log.as_deref().unwrap_or("none recorded"));
    kv(
        s,
        "log SHA-256",
        cx.log_sha256
            .as_deref()
            .unwrap_or("not computed (the log could not be read when this page was written)"),
    );
    kv(
        s,
        "rig description SHA-256",
        r.run
            .description_sha256
            .as_deref()
            .unwrap_or("not recorded in the report"),
    );
    kv(s, "report", cx.report_source);
    kv(s, "tool", cx.tool);
    s.push_str(
        "</table><p class=\"frame\">Frame P: fixed to the plate, origin at the centre of the \
         plate joint circle, z up at the home pose. The tare (the empty fixture) is removed: \
         every result is the payload's alone.</p></header>\n",
    );
}

fn results(s: &mut String, r: &Report) {
    s.push_str("<section id=\"results\"><h2>1. Results</h2>");
    if let Some(v) = &r.vehicle {
        let _ = write!(
            s,
            "<h3>In the vehicle frame</h3><p>{}.</p>",
            esc(&capitalised(&v.frame))
        );
        quantity_table(s, "vehicle.", r, &v.estimate, &v.sigma, v.truth.as_ref());
        vehicle_lines(s, v);
        s.push_str("<h3>In the plate frame P</h3>");
    }
    quantity_table(s, "", r, &r.estimate, &r.sigma, r.truth.as_ref());
    let _ = write!(
        s,
        "<p class=\"statement\">The expanded uncertainty U is the standard uncertainty u \
         multiplied by the coverage factor k = {COVERAGE_FACTOR}, which for a normal \
         distribution corresponds to a coverage probability of about 95 %. u combines the \
         statistical part of the fit (noise, lost frames, timestamp jitter) and every \
         systematic source of the error budget (section 3) in quadrature. Values are rounded to \
         the decimal place of U's second significant digit; the data attributes of each cell \
         hold the report's full-precision numbers.{}</p>",
        if (0..10).any(|q| r.is_given(q)) {
            " The six-parameter model fits the tensor alone: the mass and the centre of mass \
             marked \"given\" are the rig description's, not measured."
        } else {
            ""
        }
    );
    let verdict = if r.consistency.problems.is_empty() {
        format!("Physical consistency: {}.", esc(&r.consistency.verdict))
    } else {
        format!(
            "Physical consistency: {} ({}).",
            esc(&r.consistency.verdict),
            esc(&r.consistency.problems.join("; "))
        )
    };
    let projected = if r.consistency.projected {
        format!(
            " The fitted estimate is not physically consistent: the values above are its \
             projection onto the consistent set, the nearest consistent body in the metric of \
             the covariance, {} from the fit (the report's <code>consistency.raw</code> holds the \
             fit).",
            r.consistency
                .distance_sigma
                .map_or("at an unknown distance".to_string(), |d| format!(
                    "{d:.2} σ"
                ))
        )
    } else {
        String::new()
    };
    let _ = write!(s, "<p>{verdict}{projected}</p>");
    conformity(s, r);
    s.push_str("</section>\n");
}

/// The statements of conformity with the rig description's nominal values, with the decision
/// rule (ISO/IEC 17025 §7.8.6), when it gives any.
fn conformity(s: &mut String, r: &Report) {
    if r.conformity.is_empty() {
        return;
    }
    let frame = if r.vehicle.is_some() {
        "the vehicle frame"
    } else {
        "the plate frame P"
    };
    let _ = write!(
        s,
        "<h3>Statement of conformity</h3><p class=\"statement\">Against the nominal values \
         the customer gave, in {frame}. Decision rule: {}.</p><table class=\"conformity\">\
         <tr><th>quantity</th><th>nominal</th><th>tolerance ±</th><th>measured</th><th>U</th>\
         <th>statement</th></tr>",
        esc(rig_description::quantities::DECISION_RULE)
    );
    for c in &r.conformity {
        let (measured, u) = crate::format::rounded(c.measured, c.expanded_uncertainty);
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{measured}</td><td>{u}</td>\
             <td class=\"verdict\">{}</td></tr>",
            esc(&c.quantity),
            crate::format::significant(c.nominal, 6),
            crate::format::significant(c.tolerance, 3),
            esc(c.verdict.describe())
        );
    }
    s.push_str("</table>");
}

/// `text` with its first letter in capitals.
fn capitalised(text: &str) -> String {
    let mut c = text.chars();
    c.next()
        .map_or(String::new(), |f| f.to_uppercase().chain(c).collect())
}

/// One table of the ten quantities (value, U, unit, u, the truth where known); each cell's
/// data key is the report's path under `prefix`.
fn quantity_table(
    s: &mut String,
    prefix: &str,
    r: &Report,
    estimate: &measure::report::Quantities,
    sigma: &measure::report::Quantities,
    truth: Option<&measure::report::Quantities>,
) {
    let (e, u) = (estimate.flat(), sigma.flat());
    let truth = truth.map(|t| t.flat());
    let _ = write!(
        s,
        "<table class=\"results\"><thead><tr>\
         <th>quantity</th><th>value</th><th>expanded uncertainty U (k = {k})</th><th>unit</th>\
         <th>standard uncertainty u</th>{}</tr></thead><tbody>",
        if truth.is_some() {
            "<th>simulated truth</th><th>|value − truth| / U</th>"
        } else {
            ""
        },
        k = COVERAGE_FACTOR
    );
    for q in 0..10 {
        let big_u = expanded(u[q]);
        let (vt, ut) = rounded(e[q], big_u);
        let uncertainty = if r.is_given(q) {
            "given".to_string()
        } else {
            format!("± {ut}")
        };
        let _ = write!(
            s,
            "<tr><th>{}</th>{}{}<td>{}</td>{}",
            LABELS[q],
            cell(&format!("{prefix}estimate.{}", KEYS[q]), e[q], &vt),
            cell(&format!("{prefix}U.{}", KEYS[q]), big_u, &uncertainty),
            UNITS[q],
            cell(
                &format!("{prefix}sigma.{}", KEYS[q]),
                u[q],
                &significant(u[q], 2)
            ),
        );
        if let Some(t) = &truth {
            let ratio = (e[q] - t[q]).abs() / big_u;
            let _ = write!(
                s,
                "{}<td class=\"num\">{}</td>",
                cell(
                    &format!("{prefix}truth.{}", KEYS[q]),
                    t[q],
                    &significant(t[q], 6)
                ),
                if ratio.is_finite() && !r.is_given(q) {
                    format!("{ratio:.2}")
                } else {
                    "—".into()
                }
            );
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table>");
}

/// The centre of gravity against the car and the static load split, with U (k = 2).
fn vehicle_lines(s: &mut String, v: &measure::vehicle::VehicleResults) {
    let (c, u) = (v.estimate.com, v.sigma.com);
    let mm = |x: f64, sigma: f64| {
        let (value, big_u) = rounded(x * 1e3, expanded(sigma * 1e3));
        format!("{value} ± {big_u} mm")
    };
    let side = c[1] * v.convention.axis_signs()[1];
    let _ = write!(
        s,
        "<p>Centre of gravity: {} above the ground plane, {} behind the front axle, {} {} of \
         the centreline (expanded uncertainties, k = {COVERAGE_FACTOR}, the placement's \
         tolerance included).",
        mm(v.cg_height_m[0], v.cg_height_m[1]),
        mm(-c[0], u[0]),
        mm(side.abs(), u[1]),
        if side >= 0.0 { "left" } else { "right" }
    );
    for (name, split, ends) in [
        ("axle", &v.axle_loads, ["front", "rear"]),
        ("side", &v.side_loads, ["left", "right"]),
    ] {
        if let Some(l) = split {
            let kg = |i: usize| {
                let (value, big_u) = rounded(l.loads_kg[i], expanded(l.sigma_kg[i]));
                format!("{value} ± {big_u} kg")
            };
            let _ = write!(
                s,
                " Static {name} loads: {} {} ({:.2} %), {} {}.",
                ends[0],
                kg(0),
                100.0 * l.share,
                ends[1],
                kg(1)
            );
        }
    }
    s.push_str("</p>");
}

fn principal(s: &mut String, r: &Report, cx: &Context<'_>) {
    s.push_str(
        "<section id=\"principal\"><h2>2. Principal moments and axes</h2><table><thead><tr>\
         <th></th><th>moment, kg·m²</th><th>axis x</th><th>axis y</th><th>axis z</th></tr>\
         </thead><tbody>",
    );
    for k in 0..3 {
        let m = r.principal.moments[k];
        let _ = write!(
            s,
            "<tr><th>I<sub>{n}</sub></th>{}",
            cell(
                &format!("principal.moment_{}_kg_m2", k + 1),
                m,
                &significant(m, 6)
            ),
            n = k + 1
        );
        for (c, a) in ["x", "y", "z"].iter().zip(r.principal.axes[k]) {
            s.push_str(&cell(
                &format!("principal.axis_{}_{c}", k + 1),
                a,
                &format!("{a:.5}"),
            ));
        }
        s.push_str("</tr>");
    }
    s.push_str(
        "</tbody></table><p>The moments (ascending) and unit axes (in P) are those of the \
         estimated J<sub>C</sub>; the report states no uncertainty for them.</p>",
    );
    let e = &r.estimate;
    let payload = Ellipsoid::equivalent(e.mass, e.com, r.principal.moments, r.principal.axes);
    let t = &r.tare.estimate;
    let fixture = Ellipsoid::of_body(t.mass, t.com, t.inertia_com);
    let scene = Scene {
        payload,
        fixture,
        plate_radius_m: cx
            .rig
            .and_then(|c| c.platform.joint_radii_m())
            .map(|(_, plate)| plate),
    };
    let _ = writeln!(
        s,
        "<figure>{}<figcaption>The payload's equivalent ellipsoid (the uniform solid ellipsoid \
         of the same mass and J<sub>C</sub>; semi-axis a<sub>k</sub> = √(5 (I<sub>i</sub> + \
         I<sub>j</sub> − I<sub>k</sub>) / 2m)) at its centre of mass, its principal axes \
         1, 2, 3 in red, green, blue; the fixture's (the tare's) in grey; {}; + the P origin. \
         One scale in all three views.{}</figcaption></figure></section>",
        figures::ellipsoid_views(&scene),
        if scene.plate_radius_m.is_some() {
            "the plate joint circle dashed"
        } else {
            "no plate drawn (no rig description was given to the writer)"
        },
        if payload.is_none() {
            " The payload's moments break the triangle inequality: no ellipsoid has them, none \
             is drawn."
        } else {
            ""
        }
    );
}

fn budget(s: &mut String, r: &Report) {
    s.push_str("<section id=\"budget\"><h2>3. Error budget</h2>");
    if r.error_budget.is_empty() {
        s.push_str("<p>The report carries no error budget.</p></section>\n");
        return;
    }
    s.push_str(
        "<p>Standard uncertainty (k = 1) of each quantity from each error source alone; the \
         lines add in quadrature to the combined standard uncertainty u.</p>\
         <table class=\"budget\"><thead><tr><th>source</th>",
    );
    for q in 0..10 {
        let _ = write!(
            s,
            "<th>{}<br><span class=\"unit\">{}</span></th>",
            LABELS[q], UNITS[q]
        );
    }
    s.push_str("</tr></thead><tbody>");
    let row = |s: &mut String, label: &str, prefix: &str, q: &Quantities, class: &str| {
        let _ = write!(s, "<tr class=\"{class}\"><th>{}</th>", esc(label));
        for (k, v) in q.flat().iter().enumerate() {
            s.push_str(&cell(
                &format!("{prefix}.{}", KEYS[k]),
                *v,
                &significant(*v, 2),
            ));
        }
        s.push_str("</tr>");
    };
    for line in &r.error_budget {
        row(
            s,
            &line.source,
            &format!("budget.{}", line.source),
            &line.sigma,
            "",
        );
    }
    row(
        s,
        "systematic part",
        "systematic",
        &r.systematic.sigma,
        "sum",
    );
    row(s, "combined u", "budget.total", &r.sigma, "sum");
    let _ = write!(
        s,
        "</tbody></table><figure>{}<figcaption>Share of each source in each quantity's variance \
         (u<sub>i</sub>² / u²).</figcaption></figure><p>Assumed one-sigma figures: accelerometer \
         bias {} m/s², load-cell zero offset {} N.</p>",
        figures::budget_shares(r),
        significant(r.systematic.accel_bias_sigma_m_s2, 3),
        significant(r.systematic.load_cell_bias_sigma_n, 3)
    );
    if !r.budget_notes.is_empty() {
        s.push_str("<ul class=\"notes\">");
        for n in &r.budget_notes {
            let _ = write!(s, "<li>{}</li>", esc(n));
        }
        s.push_str("</ul>");
    }
    s.push_str("</section>\n");
}

fn convergence(s: &mut String, r: &Report) {
    s.push_str("<section id=\"convergence\"><h2>4. Convergence</h2><table class=\"kv\">");
    let _ = write!(
        s,
        "<tr><th>samples used (loaded run)</th>{}</tr>\
         <tr><th>excitation time, s</th>{}</tr>\
         <tr><th>samples until every parameter stayed within 1 % of its final value</th>{}</tr>\
         <tr><th>residual windows behind u (loaded run, tare), half-block length</th><td>{}, {}, {} s</td></tr>",
        cell("samples", r.samples as f64, &r.samples.to_string()),
        cell("excitation_s", r.excitation_s, &significant(r.excitation_s, 5)),
        match r.convergence.samples_to_1pct {
            Some(k) => cell("samples_to_1pct", k as f64, &k.to_string()),
            None => "<td>never</td>".into(),
        },
        r.covariance_basis.loaded_windows,
        r.covariance_basis
            .tare_windows
            .map(|b| b.to_string())
            .unwrap_or_else(|| "not recorded".into()),
        significant(r.covariance_basis.half_block_s, 3)
    );
    // The fewest degrees of freedom behind a sigma (the loaded run's), and which quantity.
    if let Some((name, nu)) = measure::quality::fewest_degrees_of_freedom(
        &Quantities::NAMES,
        &r.covariance_basis.loaded_degrees_of_freedom,
    ) {
        let _ = write!(
            s,
            "<tr><th>fewest degrees of freedom behind a sigma (loaded run)</th><td>{} ({})</td></tr>",
            significant(nu, 2),
            esc(name)
        );
    }
    let _ = writeln!(
        s,
        "</table><figure>{}<figcaption>The loaded run's samples; shaded: before the estimate \
         settled within 1 %. The estimate's course in time is in the log (channel \
         /estimate); <code>stewart estimate LOG --plot DIR</code> draws it.</figcaption>\
         </figure></section>",
        figures::convergence(r)
    );
}

fn residuals(s: &mut String, r: &Report) {
    s.push_str(
        "<section id=\"residuals\"><h2>5. Residuals</h2><table><thead><tr><th>RMS of the fit \
         residual</th><th>x</th><th>y</th><th>z</th></tr></thead><tbody>",
    );
    for (name, key, unit, v) in [
        ("force", "force", "n", r.residual_rms.force_n),
        ("torque", "torque", "nm", r.residual_rms.torque_nm),
    ] {
        let _ = write!(
            s,
            "<tr><th>{name}, {}</th>",
            if unit == "n" { "N" } else { "N·m" }
        );
        for (c, x) in ["x", "y", "z"].iter().zip(v) {
            s.push_str(&cell(
                &format!("residual.{key}_{c}_{unit}"),
                x,
                &significant(x, 3),
            ));
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table>");
    let _ = write!(s, "<figure>{}</figure>", figures::residuals(r));
    match &r.rigid_body {
        Some(b) => {
            let _ = write!(
                s,
                "<p>Rigid-body check: {}: the residual's RMS is {} times the noise's predicted, \
                 its spectrum's largest peak at {} Hz.</p>",
                if b.ok {
                    "the rigid-body model explains the data"
                } else {
                    "the rigid-body model does NOT explain the data (a loose or sprung payload?)"
                },
                significant(b.residual_ratio, 3),
                significant(b.peak_hz, 3)
            );
        }
        None => s.push_str(
            "<p>Rigid-body check: not made (the run's record was too short, or the rig \
             description is ideal, with no noise and no tolerances, so no residual is predicted \
             to judge the fit's by).</p>",
        ),
    }
    s.push_str("</section>\n");
}

fn data(s: &mut String, r: &Report) {
    let d = &r.data;
    let _ = write!(
        s,
        "<section id=\"data\"><h2>6. The data</h2><table class=\"kv\">\
         <tr><th>samples rejected by the input checks</th>{}</tr>\
         <tr><th>rejected share</th><td>{} %</td></tr>\
         <tr><th>frames lost (bridged), restarts</th><td>{} ({}), {}</td></tr>\
         <tr><th>frames late, duplicate (dropped)</th><td>{}, {}</td></tr>\
         <tr><th>time base</th><td>{}</td></tr>\
         <tr><th>timestamp jitter RMS (max), s</th><td>{} ({})</td></tr>\
         <tr><th>sample rate error</th><td>{}</td></tr>\
         <tr><th>log cut short</th><td>{}</td></tr></table>",
        cell(
            "rejected_samples",
            r.rejected_samples as f64,
            &r.rejected_samples.to_string()
        ),
        significant(100.0 * d.rejected_share, 3),
        d.frames_lost,
        d.frames_bridged,
        d.restarts,
        d.frames_late,
        d.frames_duplicate,
        esc(&d.time_base),
        significant(d.timestamp_jitter_rms_s, 3),
        significant(d.timestamp_jitter_max_s, 3),
        significant(d.rate_error, 3),
        esc(d.truncated.as_deref().unwrap_or("no")),
    );
    if !d.damaged.is_empty() {
        s.push_str("<p>Spans of the log lost to damage:</p><ul class=\"notes\">");
        for span in &d.damaged {
            let t = |v: Option<f64>| v.map(|x| format!("{x:.3} s")).unwrap_or("?".into());
            let _ = write!(
                s,
                "<li>{} – {}: {}</li>",
                t(span.from_s),
                t(span.to_s),
                esc(&span.reason)
            );
        }
        s.push_str("</ul>");
    }
    frame_spans(
        s,
        "Spans of frames out of sequence order or written twice, and what was done:",
        &d.reordered,
    );
    frame_spans(s, "Spans of frames no record of the log holds:", &d.missing);
    if !d.recovered.is_empty() {
        s.push_str("<p>Records lost and read from another copy:</p><ul class=\"notes\">");
        for what in &d.recovered {
            let _ = write!(s, "<li>{}</li>", esc(what));
        }
        s.push_str("</ul>");
    }
    s.push_str("</section>\n");
}

/// A list of the frame spans `spans` under `title`, nothing when there are none.
fn frame_spans(s: &mut String, title: &str, spans: &[measure::report::FrameSpan]) {
    if spans.is_empty() {
        return;
    }
    let _ = write!(s, "<p>{}</p><ul class=\"notes\">", esc(title));
    for span in spans {
        let _ = write!(
            s,
            "<li>{}: frames {}–{} ({}), {:.3}–{:.3} s: {}</li>",
            esc(&span.run),
            span.first_sequence,
            span.last_sequence,
            span.frames,
            span.from_time_s,
            span.to_time_s,
            esc(&span.action)
        );
    }
    s.push_str("</ul>");
}

fn tare(s: &mut String, r: &Report) {
    let t = &r.tare;
    let _ = write!(
        s,
        "<section id=\"tare\"><h2>7. Tare (the empty fixture, subtracted)</h2><p>Source: {}{}.</p>\
         <table><thead><tr>",
        esc(&t.source),
        t.file
            .as_deref()
            .map(|f| format!(", file {}", esc(f)))
            .unwrap_or_default()
    );
    for q in 0..10 {
        let _ = write!(s, "<th>{}, {}</th>", LABELS[q], UNITS[q]);
    }
    s.push_str("</tr></thead><tbody><tr>");
    for (k, v) in t.estimate.flat().iter().enumerate() {
        s.push_str(&cell(&format!("tare.{}", KEYS[k]), *v, &significant(*v, 5)));
    }
    s.push_str("</tr></tbody></table></section>\n");
}

fn rig(s: &mut String, input: &Input, cx: &Context<'_>) {
    s.push_str("<section id=\"rig\"><h2>8. The rig</h2><table class=\"kv\">");
    if let Some(st) = &input.rig {
        if let Some(a) = &st.address {
            kv(s, "rig address", a);
        }
        if let Some(i) = &st.identity {
            kv(s, "rig identity", &i.to_string());
        }
        if let Some(p) = st.sample_period_s {
            kv(s, "rig sample period, s", &significant(p, 4));
        }
    }
    kv(s, "rig description (report)", &input.report.run.config);
    match (cx.rig, cx.rig_source) {
        (Some(c), src) => {
            if let Some(src) = src {
                kv(s, "rig description read for this page", src);
            }
            let p = &c.platform;
            let joints = if p.base_joints_m.is_some() {
                "surveyed points"
            } else {
                "three pairs on each circle"
            };
            if let Some((base, plate)) = p.joint_radii_m() {
                kv(
                    s,
                    "joints: base, plate radius",
                    &format!("{joints}, {base:.4} m, {plate:.4} m"),
                );
            }
            kv(
                s,
                "leg length range",
                &format!("{} – {} m", p.min_leg_length_m, p.max_leg_length_m),
            );
            kv(
                s,
                "sample rate",
                &format!("{} Hz", c.sensors.sample_rate_hz),
            );
            let lc = &c.sensors.load_cell;
            kv(
                s,
                "load cells (datasheet)",
                &format!(
                    "noise {} N, zero offset after calibration {} N, gain error {}, transverse \
                     sensitivity {}",
                    lc.noise_n, lc.zero_offset_n, lc.gain_error, lc.transverse_sensitivity
                ),
            );
            kv(
                s,
                "gyro (datasheet)",
                &format!(
                    "{}, scale error {}",
                    imu_noise(
                        c.sensors.gyro.noise_density_rad_s_sqrt_hz,
                        c.sensors.gyro.noise_rms_rad_s,
                        "rad/s"
                    ),
                    c.sensors.gyro.scale_error
                ),
            );
            kv(
                s,
                "accelerometer (datasheet)",
                &format!(
                    "{}, bias {} m/s², scale error {}",
                    imu_noise(
                        c.sensors.accelerometer.noise_density_m_s2_sqrt_hz,
                        c.sensors.accelerometer.noise_rms_m_s2,
                        "m/s²"
                    ),
                    c.sensors.accelerometer.bias_m_s2,
                    c.sensors.accelerometer.scale_error
                ),
            );
            kv(
                s,
                "IMU position in P",
                &format!("{:?} m", c.sensors.imu.position_m),
            );
        }
        (None, _) => kv(
            s,
            "rig figures",
            "not given to the writer of this page (stewart report --rig FILE adds them)",
        ),
    }
    s.push_str("</table><h3>Calibrations</h3>");
    let calibrations = &input.report.run.calibrations;
    if calibrations.is_empty() {
        s.push_str(
            "<p class=\"calibrations\">None applied: the uncertainty above counts the residual \
             errors the rig description's datasheet figures state (load-cell zero offset and \
             gain after calibration, IMU misalignment, …).</p>",
        );
    } else {
        s.push_str(
            "<table class=\"calibrations\"><tr><th>calibration</th><th>taken</th><th>from</th>\
             <th>fitted by</th><th>SHA-256 (as applied)</th></tr>",
        );
        for c in calibrations {
            let kind = match c.kind.as_str() {
                "imu" => "IMU alignment (axes, gyro scales, accelerometer position, delay)",
                "load_cells" => "load-cell gains (reference mass)",
                other => other,
            };
            let digest = if c.sha256.is_empty() {
                "not recorded in the report"
            } else {
                c.sha256.as_str()
            };
            s.push_str(&format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"digest\">{}</td></tr>",
                esc(kind),
                esc(&c.calibrated_utc),
                esc(&c.source),
                esc(&c.tool),
                esc(digest)
            ));
        }
        s.push_str(
            "</table><p class=\"calibrations\">Each applied calibration's own uncertainty, not \
             the datasheet's figure, counts in the error budget's lines of what it calibrates \
             (docs/calibration.md).</p>",
        );
    }
    s.push_str("</section>\n");
}

fn provenance(s: &mut String, r: &Report, cx: &Context<'_>) {
    s.push_str("<section id=\"provenance\"><h2>9. Provenance</h2><table class=\"kv\">");
    let measured_by = if r.run.tool.is_empty() {
        "not recorded in the report"
    } else {
        r.run.tool.as_str()
    };
    kv(s, "report made by", measured_by);
    kv(s, "page written by", cx.tool);
    kv(s, "report", cx.report_source);
    kv(s, "log", r.run.log.as_deref().unwrap_or("none recorded"));
    kv(s, "rig description", &r.run.config);
    kv(s, "backend", &r.run.backend);
    if r.run.backend == "sim" {
        kv(
            s,
            "simulated world: seed, sensor grade",
            &format!("{}, {}", r.run.seed, r.run.noise),
        );
    }
    kv(s, "parameters estimated", &r.run.params.to_string());
    s.push_str("</table></section>\n");
}

/// An IMU channel's noise as the rig description gives it: a density or one sample's rms.
fn imu_noise(density: Option<f64>, rms: Option<f64>, unit: &str) -> String {
    match (density, rms) {
        (_, Some(r)) => format!("noise {r} {unit} per sample"),
        (Some(d), None) => format!("noise density {d} {unit}/√Hz"),
        (None, None) => "noise not given".into(),
    }
}
