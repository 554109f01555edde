//! SVG files inlined into the page.
//!
//! The file is re-serialised element by element so that the page stays self-contained and
//! script-free whatever the file holds: `<script>`, `<foreignObject>` and `<style>` elements (a
//! style element in an inline SVG styles the whole page) are dropped with their content, as are event
//! attributes (`on…`) and references to anything outside the figure (`href` other than `#…` or a
//! `data:` image, `url(…)` other than `url(#…)`). Every `id` gets a per-figure prefix (and so every
//! reference to it) so that figures cannot collide. A root without a `viewBox` gets one from its
//! width and height so that the stylesheet can scale it down. Polylines lose consecutive duplicate
//! and collinear points: plotters writes one point per sample snapped to whole pixels, and the
//! figures of a study shrink about sixfold with nothing drawn differently.

use quick_xml::Reader;
use quick_xml::events::{BytesStart, Event};

use crate::html::esc;

/// Elements dropped with everything inside them.
const DROPPED: [&str; 6] = [
    "script",
    "foreignObject",
    "style",
    "iframe",
    "object",
    "embed",
];

/// The inline `<svg>` markup of an SVG document; `prefix` makes its ids unique on the page.
pub fn inline(svg: &str, prefix: &str) -> Result<String, String> {
    let mut reader = Reader::from_str(svg);
    reader.config_mut().trim_text(false);
    let mut out = String::with_capacity(svg.len() / 3);
    // Depth inside a dropped element (0: not inside one).
    let mut skip = 0usize;
    let mut seen_root = false;
    let mut depth = 0usize;
    loop {
        let ev = reader.read_event().map_err(|e| {
            format!(
                "not well-formed XML at byte {}: {e}",
                reader.error_position()
            )
        })?;
        match ev {
            Event::Eof => break,
            Event::Start(e) => {
                let name = name_of(&e)?;
                if skip > 0 || DROPPED.contains(&name.as_str()) {
                    skip += 1;
                    continue;
                }
                if !seen_root {
                    if name != "svg" {
                        return Err(format!("the root element is <{name}>, not <svg>"));
                    }
                    seen_root = true;
                }
                out.push_str(&open_tag(&e, &name, prefix, depth == 0)?);
                out.push('>');
                depth += 1;
            }
            Event::Empty(e) => {
                let name = name_of(&e)?;
                if skip > 0 || DROPPED.contains(&name.as_str()) {
                    continue;
                }
                if !seen_root {
                    return Err(format!(
                        "the root element is <{name}/>, not an <svg> with content"
                    ));
                }
                out.push_str(&open_tag(&e, &name, prefix, false)?);
                out.push_str("/>");
            }
            Event::End(e) => {
                if skip > 0 {
                    skip -= 1;
                    continue;
                }
                let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
                out.push_str("</");
                out.push_str(&esc(&name));
                out.push('>');
                depth = depth.saturating_sub(1);
            }
            Event::Text(t) => {
                if skip == 0 && depth > 0 {
                    // Raw XML text: already escaped, and '<' cannot occur in it.
                    out.push_str(&String::from_utf8_lossy(t.as_ref()));
                }
            }
            Event::CData(t) => {
                if skip == 0 && depth > 0 {
                    out.push_str(&esc(&String::from_utf8_lossy(t.as_ref())));
                }
            }
            Event::GeneralRef(r) => {
                if skip == 0 && depth > 0 {
                    let name = String::from_utf8_lossy(r.as_ref()).into_owned();
                    let known = matches!(name.as_str(), "lt" | "gt" | "amp" | "quot" | "apos")
                        || (name.starts_with('#')
                            && name[1..]
                                .trim_start_matches('x')
                                .chars()
                                .all(|c| c.is_ascii_hexdigit()));
                    if known {
                        out.push('&');
                        out.push_str(&name);
                        out.push(';');
                    } else {
                        out.push_str(&esc(&format!("&{name};")));
                    }
                }
            }
            // Declaration, doctype, comments and processing instructions stay out of the page.
            Event::Decl(_) | Event::DocType(_) | Event::Comment(_) | Event::PI(_) => {}
        }
    }
    if !seen_root {
        return Err("no <svg> element".into());
    }
    Ok(out)
}

fn name_of(e: &BytesStart) -> Result<String, String> {
    std::str::from_utf8(e.name().as_ref())
        .map(str::to_string)
        .map_err(|_| "an element name is not UTF-8".to_string())
}

fn open_tag(e: &BytesStart, name: &str, prefix: &str, root: bool) -> Result<String, String> {
    let mut s = format!("<{}", esc(name));
    let (mut width, mut height, mut has_viewbox) = (None, None, false);
    for a in e.attributes() {
        let a = a.map_err(|err| format!("bad attribute in <{name}>: {err}"))?;
        let key = String::from_utf8_lossy(a.key.as_ref()).into_owned();
        let value = a
            .unescape_value()
            .map_err(|err| format!("bad attribute value in <{name}>: {err}"))?
            .into_owned();
        let lower = key.to_ascii_lowercase();
        if lower.starts_with("on") {
            continue;
        }
        let value = if lower == "id" {
            format!("{prefix}{value}")
        } else if lower == "href" || lower.ends_with(":href") || lower == "src" {
            if let Some(frag) = value.strip_prefix('#') {
                format!("#{prefix}{frag}")
            } else if value.starts_with("data:image/") && !value.starts_with("data:image/svg") {
                value
            } else {
                continue;
            }
        } else if value.contains("url(") || lower == "style" && value.contains("@import") {
            match local_urls(&value, prefix) {
                Some(v) => v,
                None => continue,
            }
        } else if lower == "points" && (name == "polyline" || name == "polygon") {
            thin_points(&value).unwrap_or(value)
        } else {
            value
        };
        if root {
            match lower.as_str() {
                "width" => width = Some(value.clone()),
                "height" => height = Some(value.clone()),
                "viewbox" => has_viewbox = true,
                _ => {}
            }
        }
        s.push(' ');
        s.push_str(&esc(&key));
        s.push_str("=\"");
        s.push_str(&esc(&value));
        s.push('"');
    }
    if root {
        if !has_viewbox {
            let px = |v: &Option<String>| {
                v.as_deref()
                    .and_then(|v| v.trim().trim_end_matches("px").parse::<f64>().ok())
            };
            if let (Some(w), Some(h)) = (px(&width), px(&height)) {
                s.push_str(&format!(" viewBox=\"0 0 {w} {h}\""));
            }
        }
        s.push_str(" role=\"img\"");
    }
    Ok(s)
}

/// `url(#x)` → `url(#<prefix>x)`; `None` when the value refers to anything else (or imports).
fn local_urls(value: &str, prefix: &str) -> Option<String> {
    if value.contains("@import") {
        return None;
    }
    let mut out = String::new();
    let mut rest = value;
    while let Some(i) = rest.find("url(") {
        out.push_str(&rest[..i + 4]);
        rest = &rest[i + 4..];
        let inner = rest.trim_start_matches(['"', '\'', ' ']);
        let quote_len = rest.len() - inner.len();
        if !inner.starts_with('#') {
            return None;
        }
        out.push_str(&rest[..quote_len]);
        out.push('#');
        out.push_str(prefix);
        rest = &inner[1..];
    }
    out.push_str(rest);
    Some(out)
}

/// A `points` list without consecutive duplicates and without middle points of straight runs;
/// `None` when it does not parse (then it is kept as it is).
fn thin_points(value: &str) -> Option<String> {
    let mut pts: Vec<(&str, f64, f64)> = Vec::new();
    for p in value.split_whitespace() {
        let (x, y) = p.split_once(',')?;
        let (x, y) = (x.parse::<f64>().ok()?, y.parse::<f64>().ok()?);
        if let Some(&(_, lx, ly)) = pts.last()
            && lx == x
            && ly == y
        {
            continue;
        }
        if pts.len() >= 2 {
            let (_, x0, y0) = pts[pts.len() - 2];
            let (_, x1, y1) = pts[pts.len() - 1];
            let cross = (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0);
            let forward = (x1 - x0) * (x - x1) >= 0.0 && (y1 - y0) * (y - y1) >= 0.0;
            if cross == 0.0 && forward {
                pts.pop();
            }
        }
        pts.push((p, x, y));
    }
    Some(pts.iter().map(|p| p.0).collect::<Vec<_>>().join(" "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_events_and_external_references_are_dropped() {
        let svg = r##"<?xml version="1.0"?><!DOCTYPE svg><svg width="10" height="5" xmlns="http://www.w3.org/2000/svg">
<script>alert(1)</script><style>body{display:none}</style>
<rect onclick="alert(2)" id="a" fill="url(#g)" width="1" height="1"/>
<image href="http://example.invalid/x.png"/><use href="#a"/><rect fill="url(http://x/y)"/>
<text>a &lt; b &amp; c</text></svg>"##;
        let out = inline(svg, "f1-").unwrap();
        assert!(!out.contains("script") && !out.contains("alert") && !out.contains("display:none"));
        assert!(!out.contains("http://example") && !out.contains("url(http"));
        assert!(out.contains("id=\"f1-a\"") && out.contains("url(#f1-g)"));
        assert!(out.contains("href=\"#f1-a\""));
        assert!(out.contains("viewBox=\"0 0 10 5\""));
        assert!(out.contains("a &lt; b &amp; c"));
        assert!(!out.contains("<?xml") && !out.contains("DOCTYPE"));
    }

    #[test]
    fn straight_runs_and_duplicates_are_thinned() {
        assert_eq!(
            thin_points("0,0 1,0 1,0 2,0 3,0 3,1 3,2 2,2 ").as_deref(),
            Some("0,0 3,0 3,2 2,2")
        );
        // A reversal on the same line is kept (it is drawn).
        assert_eq!(thin_points("0,0 2,0 1,0").as_deref(), Some("0,0 2,0 1,0"));
        assert_eq!(thin_points("a,b"), None);
    }

    #[test]
    fn a_file_that_is_not_svg_is_refused() {
        assert!(inline("<html><body/></html>", "p").is_err());
        assert!(inline("<svg><g></svg>", "p").is_err());
        assert!(inline("", "p").is_err());
    }
}
