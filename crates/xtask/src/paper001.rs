//! Paper 001 Tab. 6 and Fig. 9–12 on the HSVA KVLCC2 tests: the sparse GP and the chen2021 parametric
//! model (LSQ), both trained on 15/5+20/5+30/5+35/5, predict the 25/5 zig-zag from its recorded initial
//! state with its recorded rudder (multi-step prediction). Run by `cargo xtask paper001`.
//!
//! Two integrations of the same models: RK4 at 0.05 s (shipid's `simulate`/`validate`) and explicit
//! Euler at the 20 Hz sampling instants with the rudder of the current sample (paper 001 §2.1).
//! Writes `tab6.md` (RMSE of u, v [10⁻² m/s], r [10⁻² °/s] over the run, maximum track error over the
//! first 100 s, times, and the one-step acceleration RMSE without integration) and `hsva_25_5.svg`
//! (u, v, r and track, recorded vs predicted).

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, Result};
use plotters::prelude::*;
use shipid_estimators::Solver;
use shipid_io::{Dataset, Recording};
use shipid_sim::{AbkowitzDynamics, Dynamics, SimStatus, State};

use shipid_pipeline::fit::{EstimatorSpec, WindowSpec, fit_dataset, load_set};
use shipid_pipeline::fit_gp::fit_gp_dataset;
use shipid_pipeline::validate::{interp, replay};

pub const TRAINING: [&str; 4] = [
    "z15_05_sb.csv",
    "z20_05_sb.csv",
    "z30_05_sb.csv",
    "z35_05_sb.csv",
];
pub const VALIDATION: &str = "z25_05_sb.csv";
/// Horizon of the track-error figure of paper 001 §4.3 [s].
pub const TRACK_HORIZON_S: f64 = 100.0;

/// A predicted time series at its own time stamps (from 0 at the record's start).
pub struct Predicted {
    pub t: Vec<f64>,
    pub u: Vec<f64>,
    pub v: Vec<f64>,
    pub r: Vec<f64>,
    pub x0: Vec<f64>,
    pub y0: Vec<f64>,
    /// Where the prediction stopped early (non-finite state), if it did.
    pub stopped_at_s: Option<f64>,
}

impl Predicted {
    fn from_recording(rec: &Recording, status: &SimStatus) -> Predicted {
        Predicted {
            t: rec.t.clone(),
            u: rec.u.clone(),
            v: rec.v.clone(),
            r: rec.r.clone(),
            x0: rec.x0.clone(),
            y0: rec.y0.clone(),
            stopped_at_s: match status {
                SimStatus::Ok => None,
                SimStatus::Diverged { t_s, .. } => Some(*t_s),
            },
        }
    }
}

/// Explicit Euler at the recording's sample instants with its rudder (paper 001's integration).
pub fn euler_replay(model: &dyn Dynamics, rec: &Recording) -> Predicted {
    let t0 = rec.t[0];
    let mut s = State::of_recording(rec, 0);
    let mut p = Predicted {
        t: vec![],
        u: vec![],
        v: vec![],
        r: vec![],
        x0: vec![],
        y0: vec![],
        stopped_at_s: None,
    };
    for k in 0..rec.len() {
        p.t.push(rec.t[k] - t0);
        p.u.push(s.u);
        p.v.push(s.v);
        p.r.push(s.r);
        p.x0.push(s.x0);
        p.y0.push(s.y0);
        if k + 1 == rec.len() {
            break;
        }
        let dt = rec.t[k + 1] - rec.t[k];
        let acc = match model.accelerations(&s, rec.delta[k]) {
            Ok(a) if a.iter().all(|v| v.is_finite()) => a,
            _ => {
                p.stopped_at_s = Some(rec.t[k] - t0);
                break;
            }
        };
        let kin = s.kinematics();
        s = State {
            u: s.u + dt * acc[0],
            v: s.v + dt * acc[1],
            r: s.r + dt * acc[2],
            x0: s.x0 + dt * kin[0],
            y0: s.y0 + dt * kin[1],
            psi: s.psi + dt * kin[2],
        };
        if !s.is_finite() {
            p.stopped_at_s = Some(rec.t[k + 1] - t0);
            break;
        }
    }
    p
}

/// RMSE of u, v [m/s], r [rad/s] over the samples the prediction reached, and the largest distance
/// between predicted and recorded positions over the first `horizon_s` [m].
pub fn errors(p: &Predicted, rec: &Recording, horizon_s: f64) -> ([f64; 3], f64) {
    let t0 = rec.t[0];
    let end = p.t.last().copied().unwrap_or(-1.0);
    let mut sq = [0.0; 3];
    let mut n = 0usize;
    let mut track_max: f64 = 0.0;
    for i in 0..rec.len() {
        let t = rec.t[i] - t0;
        if t > end + 1e-9 {
            break;
        }
        let at = |y: &[f64]| interp(&p.t, y, t);
        sq[0] += (at(&p.u) - rec.u[i]).powi(2);
        sq[1] += (at(&p.v) - rec.v[i]).powi(2);
        sq[2] += (at(&p.r) - rec.r[i]).powi(2);
        n += 1;
        if t <= horizon_s {
            track_max = track_max.max((at(&p.x0) - rec.x0[i]).hypot(at(&p.y0) - rec.y0[i]));
        }
    }
    let n = n.max(1) as f64;
    (sq.map(|s| (s / n).sqrt()), track_max)
}

/// RMSE of the model's accelerations against the estimated ones of the recording, state and rudder taken
/// from the recording at every sample (one-step, no integration): [u̇ m/s², v̇ m/s², ṙ rad/s²].
pub fn one_step_rmse(model: &dyn Dynamics, rec: &Recording, ship: &shipid_io::Ship) -> [f64; 3] {
    let (acc, _) = shipid_io::deriv::accelerations_or_estimate(rec, ship);
    let mut sq = [0.0; 3];
    let mut n = 0usize;
    for i in 0..rec.len() {
        let s = State::of_recording(rec, i);
        if let Ok(a) = model.accelerations(&s, rec.delta[i]) {
            sq[0] += (a[0] - acc.u_dot[i]).powi(2);
            sq[1] += (a[1] - acc.v_dot[i]).powi(2);
            sq[2] += (a[2] - acc.r_dot[i]).powi(2);
            n += 1;
        }
    }
    sq.map(|x| (x / n.max(1) as f64).sqrt())
}

struct Row {
    model: String,
    integration: &'static str,
    rmse: [f64; 3],
    track_max_m: f64,
    predict_s: f64,
    stopped_at_s: Option<f64>,
    paper: &'static str,
}

/// Fit both models, predict the validation run, write the table and the figure into `out`.
pub fn run(dataset: &Path, out: &Path, similarity: f64) -> Result<String> {
    faer::set_global_parallelism(faer::Par::Seq);
    let ds = Dataset::load(dataset).with_context(|| format!("loading {}", dataset.display()))?;
    let training: Vec<String> = TRAINING.iter().map(|s| s.to_string()).collect();
    let rec = &ds
        .recording(VALIDATION)
        .with_context(|| format!("{VALIDATION} is not in {}", dataset.display()))?
        .recording;
    let (_, gp, report) = fit_gp_dataset(&ds, &training, WindowSpec::Whole, similarity)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let set = load_set("chen2021").map_err(|e| anyhow::anyhow!("{e}"))?;
    let param = fit_dataset(
        &ds,
        set,
        &EstimatorSpec::named("lsq"),
        &training,
        WindowSpec::Whole,
        Solver::Fast,
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let param = AbkowitzDynamics(param.model);
    let gp_name = format!("sparse GP ({} points, d_gen {similarity})", report.kept);
    let mut rows = Vec::new();
    let mut one_step = Vec::new();
    let mut figure_series = Vec::new();
    // The GP's identification range (its sparse points' coverage) over the recorded validation states
    // and over the states of its own RK4 prediction: whether the prediction leaves the neighbourhood
    // of the training data that the recorded run stays in.
    let mut coverage: Option<(f64, f64)> = None;
    for (name, model, paper) in [
        (
            gp_name.as_str(),
            &gp as &dyn Dynamics,
            "0.25 / 0.35 / 7.25 / 0.59",
        ),
        (
            "chen2021 LSQ",
            &param as &dyn Dynamics,
            "0.58 / 0.39 / 7.65 / 3.21",
        ),
    ] {
        one_step.push((name.to_string(), one_step_rmse(model, rec, &ds.ship)));
        let started = Instant::now();
        let sim = replay(model, rec);
        let rk4_s = started.elapsed().as_secs_f64();
        if coverage.is_none() {
            coverage = Some((
                shipid_pipeline::range::gp_outside_fraction(&gp, rec),
                shipid_pipeline::range::gp_outside_fraction(&gp, &sim.recording),
            ));
        }
        let rk4 = Predicted::from_recording(&sim.recording, &sim.status);
        let started = Instant::now();
        let euler = euler_replay(model, rec);
        let euler_s = started.elapsed().as_secs_f64();
        for (integration, p, secs) in [
            ("RK4, 0.05 s", &rk4, rk4_s),
            ("Euler, 20 Hz samples", &euler, euler_s),
        ] {
            let (rmse, track_max_m) = errors(p, rec, TRACK_HORIZON_S);
            rows.push(Row {
                model: name.to_string(),
                integration,
                rmse,
                track_max_m,
                predict_s: secs,
                stopped_at_s: p.stopped_at_s,
                paper,
            });
        }
        figure_series.push((name.to_string(), rk4));
    }
    let mut md = format!(
        "Validation on {VALIDATION} ({:.0} s), trained on {} ({} samples; the GP kept {}: sparsified in {:.3} s, three GPs trained in {:.3} s on one thread).\n\n\
         | model | integration | u [10⁻² m/s] | v [10⁻² m/s] | r [10⁻² °/s] | max track error, first {TRACK_HORIZON_S:.0} s [m] | prediction time [s] | paper 001 (u / v / r / track) |\n|---|---|---|---|---|---|---|---|\n",
        rec.t[rec.len() - 1] - rec.t[0],
        TRAINING.join(" + "),
        report.candidates,
        report.kept,
        report.sparsify_time_s,
        report.train_time_s,
    );
    for r in &rows {
        md.push_str(&format!(
            "| {}{} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {} |\n",
            r.model,
            r.stopped_at_s
                .map(|t| format!(" (stopped at {t:.1} s)"))
                .unwrap_or_default(),
            r.integration,
            100.0 * r.rmse[0],
            100.0 * r.rmse[1],
            100.0 * r.rmse[2].to_degrees(),
            r.track_max_m,
            r.predict_s,
            r.paper
        ));
    }
    if let Some((recorded, predicted)) = coverage {
        md.push_str(&format!(
            "\nThe GP's identification range (no sparse point d_gen-similar = outside): {:.1} % of the recorded {VALIDATION} states and {:.1} % of the states of the GP's own RK4 prediction lie outside it.\n",
            100.0 * recorded,
            100.0 * predicted
        ));
    }
    md.push_str(
        "\nOne-step accelerations on the validation run (recorded state and rudder, no integration), RMSE against the estimated accelerations:\n\n\
         | model | u̇ [10⁻³ m/s²] | v̇ [10⁻³ m/s²] | ṙ [10⁻³ °/s²] |\n|---|---|---|---|\n",
    );
    for (name, e) in &one_step {
        md.push_str(&format!(
            "| {name} | {:.3} | {:.3} | {:.3} |\n",
            1e3 * e[0],
            1e3 * e[1],
            1e3 * e[2].to_degrees()
        ));
    }
    std::fs::create_dir_all(out)?;
    shipid_io::write::write_atomic(&out.join("tab6.md"), md.as_bytes())?;
    figure(&out.join("hsva_25_5.svg"), rec, &figure_series)
        .map_err(|e| anyhow::anyhow!("figure: {e}"))?;
    Ok(md)
}

fn figure(path: &Path, rec: &Recording, series: &[(String, Predicted)]) -> Result<()> {
    const FONT: &str = "sans-serif";
    let colours = [RGBColor(31, 119, 180), RGBColor(214, 39, 40)];
    let root = SVGBackend::new(path, (1400, 1000)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("HSVA KVLCC2 {VALIDATION}: recorded vs predicted with the recorded rudder (RK4)"),
        (FONT, 22),
    )?;
    let panels = root.split_evenly((2, 2));
    let t0 = rec.t[0];
    let t_rec: Vec<f64> = rec.t.iter().map(|t| t - t0).collect();
    type Panel = (
        &'static str,
        fn(&Recording) -> Vec<f64>,
        fn(&Predicted) -> Vec<f64>,
    );
    let quantities: [Panel; 3] = [
        ("u [m/s]", |r| r.u.clone(), |p| p.u.clone()),
        ("v [m/s]", |r| r.v.clone(), |p| p.v.clone()),
        (
            "r [deg/s]",
            |r| r.r.iter().map(|x| x.to_degrees()).collect(),
            |p| p.r.iter().map(|x| x.to_degrees()).collect(),
        ),
    ];
    for (k, (label, get_rec, get_pred)) in quantities.iter().enumerate() {
        let yr = get_rec(rec);
        let preds: Vec<Vec<f64>> = series.iter().map(|(_, p)| get_pred(p)).collect();
        let (mut lo, mut hi) = yr
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let pad = 0.15 * (hi - lo).max(1e-6);
        lo -= pad;
        hi += pad;
        let mut chart = ChartBuilder::on(&panels[k])
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..t_rec[t_rec.len() - 1], lo..hi)?;
        chart
            .configure_mesh()
            .x_desc("time t [s]")
            .y_desc(*label)
            .axis_desc_style((FONT, 15))
            .draw()?;
        chart
            .draw_series(LineSeries::new(
                t_rec.iter().copied().zip(yr.iter().copied()),
                BLACK.stroke_width(2),
            ))?
            .label("recorded")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        for ((name, p), (vals, c)) in series.iter().zip(preds.iter().zip(colours)) {
            chart
                .draw_series(LineSeries::new(
                    p.t.iter()
                        .copied()
                        .zip(vals.iter().copied())
                        .filter(|(_, v)| *v >= lo && *v <= hi),
                    c.stroke_width(2),
                ))?
                .label(name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.6))
            .border_style(BLACK)
            .label_font((FONT, 13))
            .position(SeriesLabelPosition::LowerLeft)
            .draw()?;
    }
    // Track: east y0 horizontal, north x0 vertical, equal scales.
    let all_e = rec
        .y0
        .iter()
        .chain(series.iter().flat_map(|(_, p)| p.y0.iter()));
    let all_n = rec
        .x0
        .iter()
        .chain(series.iter().flat_map(|(_, p)| p.x0.iter()));
    let (e0, e1) = all_e.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(*v), b.max(*v))
    });
    let (n0, n1) = all_n.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(*v), b.max(*v))
    });
    let half = 0.55 * (e1 - e0).max(n1 - n0).max(1e-3);
    let (ec, nc) = (0.5 * (e0 + e1), 0.5 * (n0 + n1));
    let mut chart = ChartBuilder::on(&panels[3])
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(ec - half..ec + half, nc - half..nc + half)?;
    chart
        .configure_mesh()
        .x_desc("y0 (east) [m]")
        .y_desc("x0 (north) [m]")
        .axis_desc_style((FONT, 15))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            rec.y0.iter().copied().zip(rec.x0.iter().copied()),
            BLACK.stroke_width(2),
        ))?
        .label("recorded")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    for ((name, p), c) in series.iter().zip(colours) {
        chart
            .draw_series(LineSeries::new(
                p.y0.iter().copied().zip(p.x0.iter().copied()),
                c.stroke_width(2),
            ))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.6))
        .border_style(BLACK)
        .label_font((FONT, 13))
        .position(SeriesLabelPosition::UpperLeft)
        .draw()?;
    root.present()?;
    Ok(())
}
