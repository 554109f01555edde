//! Figures of a diagnosis: per recording, the track with the segment replays of the model before and
//! after the diagnosis, and the equation-error residuals over time with the located windows shaded.

use std::path::Path;

use plotters::prelude::*;
use shipid_diagnose::SegmentTrack;
use shipid_pipeline::validate::interp;
use shipid_sim::Dynamics;

use crate::error::Result;

/// Track of a recording with the segment replays of the model before and after the diagnosis, and
/// below it the replays' position error over time: on a track many ship lengths long a mismatch of a
/// few hundredths of L is invisible, its size over time is not. The replays feel the recording's
/// recorded wind and current `env`, as the diagnosis's do.
pub fn track_figure(
    path: &Path,
    name: &str,
    rec: &shipid_io::Recording,
    env: Option<&shipid_sim::KnownEnvironment>,
    before: &dyn Dynamics,
    after: &dyn Dynamics,
    horizon_s: f64,
) -> Result<()> {
    let b = shipid_diagnose::segment_tracks(before, env, rec, horizon_s);
    let a = shipid_diagnose::segment_tracks(after, env, rec, horizon_s);
    let l = before.ship().lpp;
    let pts = |s: &SegmentTrack| -> Vec<(f64, f64)> {
        s.x0.iter()
            .zip(&s.y0)
            .map(|(n, e)| (e / l, n / l))
            .collect()
    };
    let mut xs: Vec<f64> = rec.y0.iter().map(|v| v / l).collect();
    let mut ys: Vec<f64> = rec.x0.iter().map(|v| v / l).collect();
    for s in b.iter().chain(&a) {
        xs.extend(s.y0.iter().map(|v| v / l));
        ys.extend(s.x0.iter().map(|v| v / l));
    }
    let range = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let pad = 0.05 * (hi - lo).max(1.0);
        (lo - pad, hi + pad)
    };
    let (mut x0, mut x1) = range(&xs);
    let (mut y0, mut y1) = range(&ys);
    // Equal scales on both axes (a track is a shape): widen the narrower range about its centre to the
    // plotting area's aspect (900 × 800 px less the margins, the label areas and the caption).
    let aspect = (900.0 - 30.0 - f64::from(crate::Y_LABEL_AREA_PX))
        / (800.0 - 30.0 - f64::from(crate::X_LABEL_AREA_PX) - 25.0);
    let (w, h) = (x1 - x0, y1 - y0);
    if w / h < aspect {
        let c = 0.5 * (x0 + x1);
        (x0, x1) = (c - 0.5 * h * aspect, c + 0.5 * h * aspect);
    } else {
        let c = 0.5 * (y0 + y1);
        (y0, y1) = (c - 0.5 * w / aspect, c + 0.5 * w / aspect);
    }
    let root = SVGBackend::new(path, (900, 1120)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(800);
    let mut chart = ChartBuilder::on(&top)
        .caption(
            format!("{name}: recorded track and {horizon_s:.0} s segment replays"),
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(crate::X_LABEL_AREA_PX)
        .y_label_area_size(crate::Y_LABEL_AREA_PX)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .label_style(("sans-serif", crate::TICK_LABEL_PX))
        .x_desc("east y0 / L")
        .y_desc("north x0 / L")
        .draw()?;
    // The recording under the replays, as a wide light band with a thin line on it: the replays
    // after the effect lie on it and are what the figure is for, while the band stays visible
    // around them (a plain black line under them disappeared wherever one lay on it).
    let underlay = RGBColor(150, 150, 150).mix(0.45).stroke_width(7);
    let recorded: Vec<(f64, f64)> = rec
        .x0
        .iter()
        .zip(&rec.y0)
        .map(|(n, e)| (e / l, n / l))
        .collect();
    chart.draw_series(LineSeries::new(recorded.clone(), underlay))?;
    chart
        .draw_series(LineSeries::new(recorded, BLACK.stroke_width(1)))?
        .label("recorded")
        .legend(move |(x, y)| {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (20, 0)], underlay)
                + PathElement::new(vec![(0, 0), (20, 0)], BLACK.stroke_width(1))
        });
    let red = RGBColor(214, 39, 40);
    let blue = RGBColor(31, 119, 180);
    let sides = [
        (&b, red, "model (before)"),
        (&a, blue, "model + effect (after)"),
    ];
    for (tracks, colour, label) in sides {
        for (i, s) in tracks.iter().enumerate() {
            let series = chart.draw_series(LineSeries::new(pts(s), colour.stroke_width(2)))?;
            if i == 0 {
                series
                    .label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
            }
        }
    }
    // Opaque: half transparent, the tracks ran through its text.
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE)
        .draw()?;

    // Distance between each replay and the recorded position at the same time, ÷ L.
    let errors = |tracks: &[SegmentTrack]| -> Vec<Vec<(f64, f64)>> {
        tracks
            .iter()
            .map(|s| {
                s.t_s
                    .iter()
                    .zip(s.x0.iter().zip(&s.y0))
                    .map(|(&t, (&n, &e))| {
                        let dn = n - interp(&rec.t, &rec.x0, t);
                        let de = e - interp(&rec.t, &rec.y0, t);
                        (t, dn.hypot(de) / l)
                    })
                    .collect()
            })
            .collect()
    };
    let (eb, ea) = (errors(&b), errors(&a));
    let top_error = eb
        .iter()
        .chain(&ea)
        .flatten()
        .map(|p| p.1)
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let t_end = rec.t.last().copied().unwrap_or(1.0).max(1e-3);
    let mut err_chart = ChartBuilder::on(&bottom)
        .caption(
            "position error of the segment replays ÷ L",
            ("sans-serif", 16),
        )
        .margin(15)
        .x_label_area_size(crate::X_LABEL_AREA_PX)
        .y_label_area_size(crate::Y_LABEL_AREA_PX)
        .build_cartesian_2d(0.0..t_end, 0.0..1.05 * top_error)?;
    err_chart
        .configure_mesh()
        .label_style(("sans-serif", crate::TICK_LABEL_PX))
        .x_desc("t [s]")
        .y_desc("|Δ position| / L")
        .draw()?;
    for (segs, colour) in [(&eb, red), (&ea, blue)] {
        for seg in segs.iter() {
            err_chart.draw_series(LineSeries::new(
                seg.iter().copied().filter(|p| p.1.is_finite()),
                colour.stroke_width(1),
            ))?;
        }
    }
    root.present()?;
    Ok(())
}

/// Equation-error residuals of one recording over time (each DOF ÷ its noise scale), with the located
/// windows shaded.
pub fn residual_figure(
    path: &Path,
    name: &str,
    t: &[f64],
    e: &[[f64; 3]],
    windows: &[&shipid_diagnose::Located],
) -> Result<()> {
    let root = SVGBackend::new(path, (1000, 800)).into_drawing_area();
    root.fill(&WHITE)?;
    let (t0, t1) = (
        t.first().copied().unwrap_or(0.0),
        t.last()
            .copied()
            .unwrap_or(1.0)
            .max(t.first().copied().unwrap_or(0.0) + 1.0),
    );
    let panels = root.split_evenly((3, 1));
    let dofs = ["surge", "sway", "yaw"];
    for (d, panel) in panels.iter().enumerate() {
        let lim = e
            .iter()
            .map(|x| x[d].abs())
            .fold(1.0f64, f64::max)
            .min(10.0);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                if d == 0 {
                    let shaded = match windows.is_empty() {
                        true => "no mismatch located in this recording",
                        false => "shaded: located mismatch",
                    };
                    format!("{name}: equation-error residual ÷ noise scale ({shaded})")
                } else {
                    String::new()
                },
                ("sans-serif", 18),
            )
            .margin(10)
            .x_label_area_size(crate::X_LABEL_AREA_PX)
            .y_label_area_size(crate::Y_LABEL_AREA_PX)
            .build_cartesian_2d(t0..t1, -lim..lim)?;
        chart
            .configure_mesh()
            .label_style(("sans-serif", crate::TICK_LABEL_PX))
            .x_desc("t [s]")
            .y_desc(dofs[d])
            .draw()?;
        let shade = RGBColor(255, 200, 120).mix(0.5);
        for w in windows.iter().filter(|w| w.dof == dofs[d]) {
            chart.draw_series(std::iter::once(Rectangle::new(
                [(w.t_start, -lim), (w.t_end, lim)],
                shade.filled(),
            )))?;
        }
        chart.draw_series(LineSeries::new(
            t.iter().zip(e).map(|(&t, x)| (t, x[d].clamp(-lim, lim))),
            BLACK.stroke_width(1),
        ))?;
    }
    root.present()?;
    Ok(())
}
