//! HTML building blocks: escaping, number formatting, column labels, tables, the page shell.

use std::fmt::Write as _;

/// Escape text for an HTML text node or a quoted attribute value.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// An HTML id made from data: whitespace becomes `_` (an id may hold any other character; the value
/// is escaped where it is written).
pub fn id_of(prefix: &str, s: &str) -> String {
    let body: String = s
        .chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect();
    format!("{prefix}{body}")
}

/// Significant digits of every number on the page.
const SIG: i32 = 4;

/// A number with [`SIG`] significant digits: integers as they are (up to 10⁹), fixed notation from
/// 10⁻³ to 10⁵, scientific (`1.234e-5`) outside, trailing zeros trimmed.
pub fn num(x: f64) -> String {
    if x.is_nan() {
        return "NaN".into();
    }
    if x.is_infinite() {
        return if x > 0.0 {
            "∞".into()
        } else {
            "−∞".into()
        };
    }
    if x == 0.0 {
        return "0".into();
    }
    if x.fract() == 0.0 && x.abs() < 1e9 {
        return format!("{x:.0}");
    }
    let exp = x.abs().log10().floor() as i32;
    if (-3..5).contains(&exp) {
        let decimals = (SIG - 1 - exp).max(0) as usize;
        trim_zeros(format!("{x:.decimals$}"))
    } else {
        let s = format!("{:.*e}", (SIG - 1) as usize, x);
        match s.split_once('e') {
            Some((m, e)) => format!("{}e{e}", trim_zeros(m.to_string())),
            None => s,
        }
    }
}

fn trim_zeros(s: String) -> String {
    if !s.contains('.') {
        return s;
    }
    let t = s.trim_end_matches('0').trim_end_matches('.');
    if t == "-0" { "0".into() } else { t.into() }
}

/// A table cell from a text value: numbers formatted (full value in the tooltip) and right-aligned,
/// empty values as an empty cell, text escaped.
pub fn cell(raw: &str) -> String {
    let t = raw.trim();
    if t.is_empty() {
        return "<td class=\"empty\"></td>".into();
    }
    match parse_num(t) {
        Some(x) => format!("<td class=\"n\" title=\"{}\">{}</td>", esc(t), esc(&num(x))),
        None => format!("<td>{}</td>", esc(t)),
    }
}

/// A number written as such (not `inf`/`nan` words nor hex, which `f64::from_str` would take).
pub fn parse_num(t: &str) -> Option<f64> {
    let first = t.chars().next()?;
    if !(first.is_ascii_digit() || first == '-' || first == '+' || first == '.') {
        return None;
    }
    if t.chars()
        .any(|c| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
    {
        return None;
    }
    t.parse().ok()
}

/// Units carried by column-name suffixes, longest first.
const UNITS: [(&str, &str); 6] = [
    ("_deg_s", "deg/s"),
    ("_m_s", "m/s"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_s", "s"),
    ("_m", "m"),
];

/// A readable column label from a column name: the unit suffix in brackets (`fit_time_s` → `fit
/// time [s]`), `_over_l` as `÷ L`, abbreviations in capitals.
pub fn label(name: &str) -> String {
    let mut base = name.to_string();
    let mut unit = None;
    let mut over_l = false;
    if let Some(b) = base.strip_suffix("_over_l") {
        base = b.to_string();
        over_l = true;
    } else {
        for (suffix, u) in UNITS {
            if let Some(b) = base.strip_suffix(suffix).filter(|b| !b.is_empty()) {
                base = b.to_string();
                unit = Some(u);
                break;
            }
        }
    }
    let words: Vec<String> = base
        .split('_')
        .filter(|w| !w.is_empty())
        .map(|w| match w {
            "rmse" => "RMSE".into(),
            "mrae" => "MRAE".into(),
            "vif" => "VIF".into(),
            "rms" => "RMS".into(),
            "rel" => "rel.".into(),
            "dof" => "DOF".into(),
            "id" => "ID".into(),
            _ => w.to_string(),
        })
        .collect();
    let mut s = words.join(" ").replace("held out", "held-out");
    if over_l {
        s.push_str(" ÷ L");
    }
    if let Some(u) = unit {
        let _ = write!(s, " [{u}]");
    }
    s
}

/// A `<th>` for a column name: readable label, the name itself in the tooltip.
pub fn th(name: &str) -> String {
    format!(
        "<th scope=\"col\" title=\"{}\">{}</th>",
        esc(name),
        esc(&label(name))
    )
}

/// A status word as a coloured badge.
pub fn badge(status: &str) -> String {
    format!(
        "<span class=\"badge {}\">{}</span>",
        status_class(status),
        esc(status)
    )
}

pub fn status_class(status: &str) -> &'static str {
    let s = status.to_ascii_lowercase();
    if s == "ok" || s == "accepted" || s == "true" {
        "good"
    } else if s.contains("fail") || s.contains("diverg") || s.contains("error") {
        "bad"
    } else if s.is_empty() {
        "none"
    } else {
        "warn"
    }
}

/// A simple table from column names and text rows (formatted by [`cell`]).
pub fn table(headers: &[&str], rows: &[Vec<String>], class: &str) -> String {
    let mut s = format!(
        "<div class=\"tablewrap\"><table class=\"{}\"><thead><tr>",
        esc(class)
    );
    for h in headers {
        s.push_str(&th(h));
    }
    s.push_str("</tr></thead><tbody>");
    for r in rows {
        s.push_str("<tr>");
        for v in r {
            s.push_str(&cell(v));
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table></div>");
    s
}

/// TOML text with light highlighting: comments, table headers, keys.
pub fn toml_block(text: &str) -> String {
    let mut s = String::from("<pre class=\"code toml\">");
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('#') {
            let _ = write!(s, "<span class=\"c\">{}</span>", esc(line));
        } else if t.starts_with('[') {
            let _ = write!(s, "<span class=\"h\">{}</span>", esc(line));
        } else if let Some((k, v)) = line.split_once('=').filter(|(k, _)| {
            !k.trim().is_empty() && !k.contains('"') && !k.contains('\'') && !k.contains('{')
        }) {
            let _ = write!(s, "<span class=\"k\">{}</span>={}", esc(k), esc(v));
        } else {
            s.push_str(&esc(line));
        }
        s.push('\n');
    }
    s.push_str("</pre>");
    s
}

/// A JSON value as nested definition lists and tables (numbers formatted).
pub fn json_html(v: &serde_json::Value) -> String {
    use serde_json::Value;
    match v {
        Value::Null => "<span class=\"muted\">—</span>".into(),
        Value::Bool(b) => esc(&b.to_string()),
        Value::Number(n) => match n.as_f64() {
            Some(x) => format!("<span class=\"n\" title=\"{}\">{}</span>", n, esc(&num(x))),
            None => esc(&n.to_string()),
        },
        Value::String(s) => esc(s),
        Value::Array(a) if a.is_empty() => "<span class=\"muted\">none</span>".into(),
        Value::Array(a) if a.iter().all(|x| !x.is_object() && !x.is_array()) => {
            a.iter().map(json_html).collect::<Vec<_>>().join(", ")
        }
        Value::Array(a) => {
            let mut s = String::from("<ol class=\"jlist\">");
            for x in a {
                let _ = write!(s, "<li>{}</li>", json_html(x));
            }
            s.push_str("</ol>");
            s
        }
        Value::Object(o) if o.is_empty() => "<span class=\"muted\">none</span>".into(),
        Value::Object(o) => {
            let mut s = String::from("<dl class=\"kv\">");
            for (k, x) in o {
                let _ = write!(s, "<dt>{}</dt><dd>{}</dd>", esc(&label(k)), json_html(x));
            }
            s.push_str("</dl>");
            s
        }
    }
}

/// Labelled facts as a definition list (values escaped here).
pub fn facts(items: &[(String, String)]) -> String {
    let mut s = String::from("<dl class=\"facts\">");
    for (k, v) in items {
        let _ = write!(s, "<dt>{}</dt><dd>{}</dd>", esc(k), esc(v));
    }
    s.push_str("</dl>");
    s
}

/// A box listing warnings (none: nothing).
pub fn warnings_box(warnings: &[String]) -> String {
    if warnings.is_empty() {
        return String::new();
    }
    let mut s = format!(
        "<section id=\"warnings\" class=\"warnings\"><h2>Warnings ({})</h2><ul>",
        warnings.len()
    );
    for w in warnings {
        let _ = write!(s, "<li>{}</li>", esc(w));
    }
    s.push_str("</ul></section>");
    s
}

const STYLE: &str = r#"
:root { --fg:#1d2733; --muted:#5d6b7a; --line:#d5dce4; --zebra:#f4f7fa; --head:#e8eef4;
  --accent:#1f5f9e; --good:#1b7a3d; --good-bg:#e2f4e8; --bad:#a32020; --bad-bg:#fbe4e4;
  --warn:#8a5a00; --warn-bg:#fdf1d6; }
* { box-sizing: border-box; }
body { margin:0; color:var(--fg); background:#fff; line-height:1.45;
  font:15px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif; }
main { max-width:1320px; margin:0 auto; padding:24px 28px 60px; }
header.top { border-bottom:3px solid var(--accent); padding-bottom:12px; margin-bottom:18px; }
h1 { font-size:26px; margin:0 0 4px; }
h1 .kind { color:var(--muted); font-weight:400; }
h2 { font-size:20px; margin:32px 0 10px; padding-bottom:4px; border-bottom:1px solid var(--line); }
h3 { font-size:16px; margin:18px 0 8px; }
p.sub { margin:0 0 10px; color:var(--muted); }
a { color:var(--accent); }
nav.toc { display:flex; flex-wrap:wrap; gap:6px 16px; margin:6px 0 0; font-size:14px; }
dl.facts { display:grid; grid-template-columns:fit-content(40%) minmax(0,1fr); gap:3px 16px;
  margin:10px 0 0; }
dl.facts dt { color:var(--muted); overflow-wrap:anywhere; }
dl.facts dd { margin:0; overflow-wrap:anywhere; min-width:0; }
dl.kv { display:grid; grid-template-columns:fit-content(40%) minmax(0,1fr); gap:2px 14px; margin:0; }
dl.kv dt { color:var(--muted); overflow-wrap:anywhere; }
dl.kv dd { margin:0; overflow-wrap:anywhere; min-width:0; }
.vh { position:absolute; width:1px; height:1px; overflow:hidden; clip:rect(0 0 0 0);
  white-space:nowrap; }
ol.jlist { margin:0; padding-left:20px; }
.muted { color:var(--muted); }
.warnings { background:var(--warn-bg); border:1px solid #e7c46b; border-left:6px solid #d99a00;
  border-radius:6px; padding:4px 18px 8px; margin:18px 0; }
.warnings h2 { border:0; margin:8px 0 4px; font-size:17px; color:var(--warn); }
.warnings ul { margin:0; padding-left:20px; }
.counts { display:flex; flex-wrap:wrap; gap:10px; margin:8px 0; }
.count { border:1px solid var(--line); border-radius:6px; padding:6px 12px; min-width:110px; }
.count .v { font-size:22px; font-weight:600; display:block; }
.count.good { border-color:#9fd3b0; background:var(--good-bg); }
.count.bad { border-color:#e6a3a3; background:var(--bad-bg); }
.count.warn { border-color:#e7c46b; background:var(--warn-bg); }
.badge { display:inline-block; padding:0 7px; border-radius:9px; font-size:12.5px; font-weight:600;
  white-space:nowrap; }
.badge.good { background:var(--good-bg); color:var(--good); }
.badge.bad { background:var(--bad-bg); color:var(--bad); }
.badge.warn { background:var(--warn-bg); color:var(--warn); }
.common { font-size:14px; color:var(--muted); margin:4px 0 8px; }
.common code { color:var(--fg); }
.tablewrap { max-height:75vh; overflow:auto; border:1px solid var(--line); border-radius:6px;
  margin:6px 0 12px; }
table { border-collapse:separate; border-spacing:0; width:100%; font-size:13.5px; }
th, td { padding:4px 9px; text-align:left; vertical-align:top; border-bottom:1px solid var(--line); }
thead th { position:sticky; top:0; z-index:1; background:var(--head); font-weight:600;
  border-bottom:2px solid #b9c5d1; vertical-align:bottom; }
td.nw, code.nw { white-space:nowrap; }
td.params div { min-width:24em; }
table.narrow { width:auto; min-width:320px; }
.side { display:flex; flex-wrap:wrap; gap:0 28px; align-items:flex-start; }
.tablewrap.fit { width:fit-content; max-width:100%; }
tbody tr:nth-child(even) td { background:var(--zebra); }
tbody tr:hover td { background:#e6f0fa; }
td.n { text-align:right; font-variant-numeric:tabular-nums; white-space:nowrap; }
td.id { font-family:ui-monospace,"DejaVu Sans Mono",monospace; font-size:12.5px; white-space:nowrap; }
table.summary td.id, table.summary th.id { position:sticky; left:0; z-index:1; background:#fff;
  border-right:1px solid var(--line); }
table.summary td.id a { display:block; max-width:40vw; overflow:hidden; text-overflow:ellipsis; }
table.summary td.id .tail { display:none; }
table.summary th.id { z-index:2; background:var(--head); }
table.summary tbody tr:nth-child(even) td.id { background:var(--zebra); }
table.summary tbody tr:hover td { background:#e6f0fa; }
table.summary td { white-space:nowrap; }
summary .tests { font-weight:400; margin-left:6px; }
tr.bad td:first-child { box-shadow:inset 4px 0 0 var(--bad); }
tr.warn td:first-child { box-shadow:inset 4px 0 0 #d99a00; }
code, pre { font-family:ui-monospace,"DejaVu Sans Mono",monospace; font-size:12.5px; }
pre.code { background:#f6f8fa; border:1px solid var(--line); border-radius:6px; padding:10px 12px;
  overflow:auto; max-height:520px; margin:6px 0 12px; }
pre.toml .c { color:#6a737d; }
pre.toml .h { color:#7a3e9d; font-weight:600; }
pre.toml .k { color:#1f5f9e; }
details { border:1px solid var(--line); border-radius:6px; margin:6px 0; padding:0 12px; }
details[open] { padding-bottom:8px; }
details > summary { cursor:pointer; padding:6px 0; font-weight:600; }
details > summary code { font-weight:400; }
details details { background:#fbfcfd; }
.figs { display:flex; flex-direction:column; gap:18px; }
nav.figindex { display:flex; flex-wrap:wrap; gap:4px 8px; font-size:13px; margin:4px 0 10px; }
nav.figindex a { border:1px solid var(--line); border-radius:12px; padding:1px 9px; text-decoration:none;
  background:#f6f8fa; }
figure { margin:0; border:1px solid var(--line); border-radius:6px; padding:10px; background:#fff;
  min-width:0; }
figure svg { display:block; max-width:100%; height:auto; margin:0 auto; }
figcaption { font-size:14px; margin-top:6px; text-align:center; }
figcaption code { color:var(--muted); font-size:12px; }
figcaption code, summary code { overflow-wrap:anywhere; }
.verdict { border:1px solid var(--line); border-left:6px solid var(--accent); border-radius:6px;
  padding:10px 18px; margin:16px 0; background:#f5f9fd; }
.verdict .word { font-size:28px; font-weight:700; }
.verdict p { margin:6px 0; }
/* A phone: a label beside its value would leave the value a one-character column, and a sticky
   case column as wide as the screen would hide every other column. */
@media (max-width:600px) {
  main { padding:16px 12px 40px; }
  dl.kv, dl.facts { grid-template-columns:minmax(0,1fr); gap:0; }
  dl.kv dd, dl.facts dd { margin:0 0 6px; }
  table.summary td.id, table.summary th.id { position:static; }
  table.summary td.id .full { display:none; }
  table.summary td.id .tail { display:inline; }
}
footer { margin-top:40px; color:var(--muted); font-size:13px; border-top:1px solid var(--line);
  padding-top:8px; }
"#;

/// The whole page: head with the stylesheet, the body as given. No script, no external resource.
pub fn page(title: &str, body: &str) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <meta name=\"generator\" content=\"shipid-report\">\n<title>{}</title>\n<style>{STYLE}</style>\n\
         </head>\n<body>\n<main>\n{body}\n</main>\n</body>\n</html>\n",
        esc(title)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_have_four_significant_digits() {
        for (x, s) in [
            (0.0, "0"),
            (1.0, "1"),
            (-3.0, "-3"),
            (0.00013007600000000002, "1.301e-4"),
            (11.761444794293983, "11.76"),
            (-0.7124998373776829, "-0.7125"),
            (0.1, "0.1"),
            (5750.260212759569, "5750"),
            (47776.16433635155, "47776"),
            (1.5e12, "1.5e12"),
            (123456.7, "1.235e5"),
            (0.002, "0.002"),
        ] {
            assert_eq!(num(x), s, "{x}");
        }
    }

    #[test]
    fn labels_carry_units() {
        for (n, l) in [
            ("fit_time_s", "fit time [s]"),
            ("u_rmse_m_s", "u RMSE [m/s]"),
            ("r_rmse_deg_s", "r RMSE [deg/s]"),
            ("heading_rmse_deg", "heading RMSE [deg]"),
            ("position_rmse_over_l", "position RMSE ÷ L"),
            (
                "held_out_position_rmse_over_l",
                "held-out position RMSE ÷ L",
            ),
            ("overshoot_1_rel_error", "overshoot 1 rel. error"),
            ("case", "case"),
            ("hyper_X", "hyper X"),
        ] {
            assert_eq!(label(n), l);
        }
    }

    #[test]
    fn escaping_covers_markup_and_quotes() {
        assert_eq!(
            esc("<a href=\"x\">&'</a>"),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;&lt;/a&gt;"
        );
    }

    #[test]
    fn words_are_not_numbers() {
        assert_eq!(parse_num("inf"), None);
        assert_eq!(parse_num("NaN"), None);
        assert_eq!(parse_num("1 OS"), None);
        assert_eq!(parse_num("1.5e-3"), Some(1.5e-3));
        assert_eq!(parse_num("zz35_35_ps.csv"), None);
    }
}
