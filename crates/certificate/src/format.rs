//! Text on the page: escaping, number cells with their data attributes, rounding to the
//! uncertainty, the UTC date.

/// `s` with the characters HTML gives a meaning (`& < > " '`) escaped, for text and attribute
/// values.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// The full-precision form of `v` for a `data-value` attribute: Rust's shortest decimal that
/// reads back as the same f64 (`NaN`, `inf` and `-inf` for the non-finite).
pub fn full(v: f64) -> String {
    format!("{v:?}")
}

/// The decimal step U is rounded to: two significant digits of U, 10^(⌊log₁₀ U⌋ − 1); `None`
/// when U is not positive and finite.
fn step_of(u: f64) -> Option<f64> {
    (u > 0.0 && u.is_finite()).then(|| 10f64.powi(u.log10().floor() as i32 - 1))
}

/// `value` and its expanded uncertainty `u` as a certificate writes them: U to two
/// significant digits, the value to the same decimal place (GUM 7.2.6). Without a usable U the
/// value gets six significant digits and U is `—`.
pub fn rounded(value: f64, u: f64) -> (String, String) {
    let Some(step) = step_of(u) else {
        return (significant(value, 6), "—".into());
    };
    let decimals = (-step.log10().round()).max(0.0) as usize;
    let round = |x: f64| (x / step).round() * step;
    let text = |x: f64| {
        let s = format!("{:.*}", decimals, round(x));
        // −0.00 reads as a sign the data does not have.
        if s.trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            s.trim_start_matches('-').to_string()
        } else {
            s
        }
    };
    (text(value), text(u))
}

/// `v` to `digits` significant digits, plain decimals between 1e-4 and 1e6, else an exponent.
pub fn significant(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v == 0.0 {
        return "0".into();
    }
    let e = v.abs().log10().floor() as i32;
    if !(-4..6).contains(&e) {
        return format!("{:.*e}", digits.saturating_sub(1), v);
    }
    let decimals = (digits as i32 - 1 - e).max(0) as usize;
    format!("{v:.decimals$}")
}

/// A table cell holding `text`, with the quantity's name and its full-precision value for
/// machines (`data-quantity`, `data-value`).
pub fn cell(quantity: &str, value: f64, text: &str) -> String {
    format!(
        "<td class=\"num\" data-quantity=\"{}\" data-value=\"{}\">{}</td>",
        esc(quantity),
        full(value),
        esc(text)
    )
}

/// The UTC date and time of `unix_s` seconds after the epoch, `YYYY-MM-DD hh:mm UTC`.
pub fn utc(unix_s: u64) -> String {
    let t = rig_description::calendar::UtcTime::from_unix_s(unix_s);
    format!(
        "{:04}-{:02}-{:02} {:02}:{:02} UTC",
        t.year, t.month, t.day, t.hour, t.minute
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_rounded_to_two_digits_of_u() {
        assert_eq!(rounded(1498.8638, 1.6558), ("1498.9".into(), "1.7".into()));
        assert_eq!(
            rounded(0.1494954, 0.000944),
            ("0.14950".into(), "0.00094".into())
        );
        assert_eq!(rounded(2496.018, 46.3), ("2496".into(), "46".into()));
        assert_eq!(rounded(2496.018, 463.0), ("2500".into(), "460".into()));
        assert_eq!(rounded(-0.0001, 0.5), ("0.00".into(), "0.50".into()));
        assert_eq!(rounded(3.0, 0.0).1, "—");
    }

    #[test]
    fn full_precision_reads_back_exactly() {
        for v in [1498.8638046284339, 1e-20, -0.07983121975299322, 2.0 / 3.0] {
            assert_eq!(full(v).parse::<f64>().unwrap(), v);
        }
    }

    /// Known dates: the epoch, a leap day, and the end of a century year.
    #[test]
    fn utc_dates() {
        assert_eq!(utc(0), "1970-01-01 00:00 UTC");
        assert_eq!(
            utc(951_782_400 + 3_600 * 13 + 60 * 7),
            "2000-02-29 13:07 UTC"
        );
        assert_eq!(utc(4_102_358_400), "2099-12-31 00:00 UTC");
    }

    #[test]
    fn escapes() {
        assert_eq!(
            esc("<a href=\"x\">&'"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;"
        );
    }
}
