//! Figures of paper 003's inversion: the variation modes (with their table) and, per target, the
//! motions simulated with the network's and the refined hydrodynamics against the given indexes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use shipid_inverse::indexes::{Manoeuvres, MotionIndexes};
use shipid_inverse::modes::VariationModes;
use shipid_inverse::target::TargetShip;
use shipid_io::write::write_atomic;

use crate::error::Result;

pub fn write_modes(out: &Path, modes: &VariationModes) -> Result<()> {
    let mut csv = String::from("mode,singular_value,contribution,cumulative,weight_std\n");
    for (i, ((s, c), cum)) in modes
        .singular_values
        .iter()
        .zip(&modes.contribution)
        .zip(modes.cumulative())
        .enumerate()
    {
        let _ = writeln!(csv, "{},{s},{c},{cum},{}", i + 1, modes.weight_std[i]);
    }
    write_atomic(&out.join("modes.csv"), csv.as_bytes())?;
    let path = out.join("modes.svg");
    let n = modes.contribution.len();
    let root = SVGBackend::new(&path, (900, 550)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Self and cumulative contribution of the hydrodynamic variation modes (paper 003 Fig. 3)",
            ("sans-serif", 18),
        )
        .margin(15)
        .x_label_area_size(crate::X_LABEL_AREA_PX)
        .y_label_area_size(crate::Y_LABEL_AREA_PX)
        .build_cartesian_2d(0.5..n as f64 + 0.5, 0.0..100.0)?;
    chart
        .configure_mesh()
        .label_style(("sans-serif", crate::TICK_LABEL_PX))
        .x_desc("mode")
        .y_desc("contribution [%]")
        .x_label_formatter(&|x| format!("{x:.0}"))
        .draw()?;
    chart
        .draw_series(modes.contribution.iter().enumerate().map(|(i, c)| {
            let x = i as f64 + 1.0;
            Rectangle::new(
                [(x - 0.35, 0.0), (x + 0.35, 100.0 * c)],
                BLUE.mix(0.6).filled(),
            )
        }))?
        .label("self")
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 15, y + 5)], BLUE.mix(0.6).filled()));
    chart
        .draw_series(LineSeries::new(
            modes
                .cumulative()
                .iter()
                .enumerate()
                .map(|(i, c)| (i as f64 + 1.0, 100.0 * c)),
            RED.stroke_width(2),
        ))?
        .label("cumulative")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    chart.draw_series(DashedLineSeries::new(
        [(0.5, 95.0), (n as f64 + 0.5, 95.0)],
        6,
        4,
        BLACK.into(),
    ))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::MiddleRight)
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Fig. 6/7: per motion, the ±35° tracks with the given advance/tactical diameter (dashed), and the two
/// zig-zag headings with the given peak heading and its time (dashed).
pub struct MotionFigure {
    pub name: String,
    pub given: MotionIndexes,
    /// Simulated with the network's (clipped) weights: paper 003's result.
    pub network: Option<Manoeuvres>,
    /// Simulated with the refined weights.
    pub refined: Option<Manoeuvres>,
}

const REFINED_COLOUR: RGBColor = RGBColor(31, 119, 180);

pub fn motions_figure(path: &PathBuf, target: &TargetShip, figures: &[MotionFigure]) -> Result<()> {
    let rows = figures.len().max(1);
    let root = SVGBackend::new(path, (1500, 420 * rows as u32)).into_drawing_area();
    root.fill(&WHITE)?;
    let l = target.lpp_m;
    let tl = target.lpp_m / target.u0_m_s;
    for (area_row, f) in root.split_evenly((rows, 3)).chunks(3).zip(figures) {
        let (name, q) = (&f.name, f.given.0);
        let sims = [(&f.network, RED), (&f.refined, REFINED_COLOUR)];
        // Turning tracks: x = lateral / L, y = advance / L.
        let mut c = ChartBuilder::on(&area_row[0])
            .caption(
                format!("{} {name}: ±35° turns", target.name),
                ("sans-serif", 16),
            )
            .margin(10)
            .x_label_area_size(crate::X_LABEL_AREA_PX)
            .y_label_area_size(crate::Y_LABEL_AREA_PX)
            .build_cartesian_2d(-5.5..5.5, -1.0..6.0)?;
        c.configure_mesh()
            .label_style(("sans-serif", crate::TICK_LABEL_PX))
            .x_desc("y0 / L")
            .y_desc("x0 / L")
            .draw()?;
        for ((m, colour), label) in sims
            .iter()
            .zip(["network's weights (paper 003)", "refined by re-simulation"])
            .filter_map(|((m, c), label)| m.as_ref().map(|m| ((m, *c), label)))
        {
            for (k, rec) in [&m.turn_p35, &m.turn_m35].into_iter().enumerate() {
                let end = rec
                    .psi
                    .iter()
                    .position(|p| (p - rec.psi[0]).abs() > std::f64::consts::PI * 1.1)
                    .unwrap_or(rec.len());
                let series = c.draw_series(LineSeries::new(
                    (0..end).map(|i| (rec.y0[i] / l, rec.x0[i] / l)),
                    colour.stroke_width(2),
                ))?;
                if k == 0 {
                    series.label(label).legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                    });
                }
            }
        }
        for (k, (ad, dt)) in [(q[0], q[1]), (q[3], q[4])].into_iter().enumerate() {
            let given = c.draw_series(DashedLineSeries::new(
                [(0.0, ad), (dt, ad)],
                5,
                4,
                BLACK.into(),
            ))?;
            if k == 0 {
                given
                    .label("given index (advance, tactical diameter, peak ψ and its time)")
                    .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 8, y)], BLACK));
            }
            c.draw_series(DashedLineSeries::new(
                [(dt, -1.0), (dt, 6.0)],
                5,
                4,
                BLACK.into(),
            ))?;
        }
        c.configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE)
            .border_style(BLACK)
            .label_font(("sans-serif", 11))
            .draw()?;
        for (k, (side, peak, t_idx)) in [(1.0, q[5], q[6]), (-1.0, q[7], q[8])]
            .into_iter()
            .enumerate()
        {
            let t_max = 16.0;
            let mut c = ChartBuilder::on(&area_row[1 + k])
                .caption(
                    format!(
                        "{name}: {}20/20 zig-zag",
                        if side > 0.0 { "+" } else { "−" }
                    ),
                    ("sans-serif", 16),
                )
                .margin(10)
                .x_label_area_size(crate::X_LABEL_AREA_PX)
                .y_label_area_size(crate::Y_LABEL_AREA_PX)
                .build_cartesian_2d(0.0..t_max, -55.0..55.0)?;
            c.configure_mesh()
                .label_style(("sans-serif", crate::TICK_LABEL_PX))
                .x_desc("t U0 / L")
                .y_desc("ψ (coloured), δ (grey) [deg]")
                .draw()?;
            for (m, colour) in sims.iter().filter_map(|(m, c)| m.as_ref().map(|m| (m, c))) {
                let rec = if side > 0.0 {
                    &m.zigzag_p20
                } else {
                    &m.zigzag_m20
                };
                // Points past the axis would be drawn on its edge, as a vertical line.
                let shown = rec.t.iter().take_while(|&&t| t / tl <= t_max).count();
                c.draw_series(LineSeries::new(
                    rec.t[..shown]
                        .iter()
                        .zip(&rec.psi)
                        .map(|(t, p)| (t / tl, (p - rec.psi[0]).to_degrees())),
                    colour.stroke_width(2),
                ))?;
                c.draw_series(LineSeries::new(
                    rec.t[..shown]
                        .iter()
                        .zip(&rec.delta)
                        .map(|(t, d)| (t / tl, d.to_degrees())),
                    RGBColor(127, 127, 127).stroke_width(1),
                ))?;
            }
            // Given: first peak ψ = ±20·ratio; the time marks the first (+20) or second (−20) peak.
            let psi_peak = side * 20.0 * peak;
            c.draw_series(DashedLineSeries::new(
                [(0.0, psi_peak), (t_max, psi_peak)],
                5,
                4,
                BLACK.into(),
            ))?;
            c.draw_series(DashedLineSeries::new(
                [(t_idx, -55.0), (t_idx, 55.0)],
                5,
                4,
                BLACK.into(),
            ))?;
        }
    }
    root.present()?;
    Ok(())
}
