//! Replays of recordings in a model: the whole recording with its rudder ([`crate::validate`]) or
//! in segments restarted from the recorded state (the diagnosis and the output-error refinement score
//! a model by these). No I/O.

use shipid_io::Recording;
use shipid_sim::dynamics::{FiniteDifferences, MassMatrix, NoFilter, Parametric, RudderFilter};
use shipid_sim::{
    DivergenceBounds, Dynamics, KnownEnvironment, Replay, SimOptions, SimStatus, State,
};

use crate::environment::with_recorded_inputs;
use crate::lm::solve_small;
use crate::validate::DT_OVER_L_OVER_U0;

/// Samples left out at each end of a recording of `n` samples for equation errors: there a
/// differentiator is one-sided.
pub fn differentiator_margin(n: usize) -> usize {
    (n / 50).max(5).min(n / 4)
}

/// Value at sample `i` of a least-squares quadratic in time through the `2·half + 1` samples around it
/// (the window shifted inwards at the ends of the recording): the segment's initial state with the
/// measurement noise averaged out. A plain mean would be biased wherever the signal curves (r and v
/// around a rudder reversal) and, at the first sample, by the ship's own motion (half a window of
/// travel, 0.04 L), and a replay inherits that bias for its whole horizon: the MMG reference replayed
/// on its own noise-free recordings missed them by 0.015 L with the mean.
pub fn local_quadratic_at(t: &[f64], x: &[f64], i: usize, half: usize) -> f64 {
    let n = x.len().min(t.len());
    if n == 0 {
        return f64::NAN;
    }
    let width = (2 * half + 1).min(n);
    let a = i.saturating_sub(half).min(n - width);
    let b = a + width;
    if width < 3 {
        return x[i.min(n - 1)];
    }
    // Normal equations of x ≈ c0 + c1 τ + c2 τ², τ = (t − t_i)/scale, scaled for conditioning.
    let scale = ((t[b - 1] - t[a]) / 2.0).max(f64::MIN_POSITIVE);
    let mut m = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    for k in a..b {
        let tau = (t[k] - t[i.min(n - 1)]) / scale;
        let basis = [1.0, tau, tau * tau];
        for (r, br) in basis.iter().enumerate() {
            rhs[r] += br * x[k];
            for (c, bc) in basis.iter().enumerate() {
                m[r][c] += br * bc;
            }
        }
    }
    match solve_small(&m.iter().map(|row| row.to_vec()).collect::<Vec<_>>(), &rhs) {
        Some(c) if c[0].is_finite() => c[0],
        _ => x[a..b].iter().sum::<f64>() / width as f64,
    }
}

/// Segment boundaries of a recording for the horizon.
pub fn segments(rec: &Recording, horizon_s: f64) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut a = 0;
    let n = rec.len();
    while a + 10 < n {
        let t_end = rec.t[a] + horizon_s;
        let b = rec.t.partition_point(|&t| t <= t_end).min(n);
        if b <= a + 10 {
            break;
        }
        out.push((a, b));
        a = b - 1;
    }
    out
}

/// Longest RK4 step of a segment replay ÷ (L/U0): 0.1 s for the KVLCC2 model, twice the re-simulation
/// step of `validate` ([`DT_OVER_L_OVER_U0`]). A diagnosis spends most of its time in these replays
/// (RK4 on ship motions with time constants of several seconds); on a concealed current + wind case of
/// the default data the held-out RMSEs before and after the effect agree with the 0.05 s step's to
/// 5e-8 relative (a 0.2 s step, which straddles the rudder's 0.1 s samples, to 6e-4).
pub const SEGMENT_STEP_OVER_L_OVER_U0: f64 = 2.0 * DT_OVER_L_OVER_U0;

/// Where a segment replay starts and how it steps: the recorded rudder relative to the segment's
/// start, the initial state and the RK4 step. Shared by [`replay_segment`] and
/// [`replay_segment_sensitivities`] so that both integrate the very same replay.
struct SegmentStart {
    t: Vec<f64>,
    delta: Vec<f64>,
    init: State,
    duration_s: f64,
    dt_s: f64,
}

impl SegmentStart {
    fn new(ship: &shipid_io::Ship, rec: &Recording, a: usize, b: usize) -> SegmentStart {
        let half = 5;
        let t0 = rec.t[a];
        let t: Vec<f64> = rec.t[a..b].iter().map(|x| x - t0).collect();
        let delta = rec.delta[a..b].to_vec();
        let init = State {
            u: local_quadratic_at(&rec.t, &rec.u, a, half),
            v: local_quadratic_at(&rec.t, &rec.v, a, half),
            r: local_quadratic_at(&rec.t, &rec.r, a, half),
            x0: local_quadratic_at(&rec.t, &rec.x0, a, half),
            y0: local_quadratic_at(&rec.t, &rec.y0, a, half),
            psi: local_quadratic_at(&rec.t, &rec.psi, a, half),
        };
        let duration_s = *t.last().unwrap_or(&0.0);
        // Whole steps that end on the segment's last sample (a step that fell short would leave that
        // sample unreplayed, counted as a divergence), none longer than the replay step.
        let dt_max = SEGMENT_STEP_OVER_L_OVER_U0 * ship.lpp / ship.u0;
        let dt_s = duration_s / (duration_s / dt_max - 1e-9).ceil().max(1.0);
        SegmentStart {
            t,
            delta,
            init,
            duration_s,
            dt_s,
        }
    }
}

/// Replay one segment; returns the simulated recording (possibly cut short) and status.
pub fn replay_segment(
    model: &dyn Dynamics,
    rec: &Recording,
    a: usize,
    b: usize,
) -> (Recording, bool) {
    let start = SegmentStart::new(model.ship(), rec, a, b);
    let Ok(mut ctrl) = Replay::new(start.t, start.delta) else {
        return (Recording::default(), false);
    };
    let mut opts = SimOptions::new(start.duration_s).with_step(start.dt_s, start.dt_s);
    opts.initial_rudder_rad = rec.delta[a];
    match shipid_sim::simulate(model, &mut ctrl, start.init, &opts) {
        Ok(out) => (out.recording, matches!(out.status, SimStatus::Ok)),
        Err(_) => (Recording::default(), false),
    }
}

/// [`replay_segment`] of a recording with its recorded inputs: the model feels the recorded wind and
/// current `env` (built from `rec`, see [`crate::environment`]) and, when it takes one, the recorded
/// propeller rate from the segment's start on. Without either it is [`replay_segment`] itself.
pub fn replay_segment_in(
    model: &dyn Dynamics,
    env: Option<&KnownEnvironment>,
    rec: &Recording,
    a: usize,
    b: usize,
) -> (Recording, bool) {
    let model = with_recorded_inputs(model, rec, rec.t[a], env.cloned());
    replay_segment(model.as_ref(), rec, a, b)
}

/// A segment replay with the derivatives of its pose with respect to chosen parameter directions.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SegmentSensitivities {
    /// Step times \[s\] from the segment's start (those of [`replay_segment`]'s recording).
    pub t: Vec<f64>,
    /// (x0 \[m\], y0 \[m\], ψ \[rad\]) at each step.
    pub pose: Vec<[f64; 3]>,
    /// ∂(x0, y0, ψ)/∂p at each step: `pose_sensitivity[step][3 j + axis]` for direction j.
    pub pose_sensitivity: Vec<Vec<f64>>,
    /// Whether the replay ran to the segment's end ([`replay_segment`]'s status).
    pub completed: bool,
}

/// The replay of [`replay_segment`] (same start, steps, rudder and divergence limits) integrated
/// together with its forward sensitivities S = ∂x/∂p for the parameter directions `directions`
/// (θ = θ_model + Σ_j p_j unit_j e_{index_j}, given as `(index, unit)`): each RK4 stage also gives
/// dK = (∂f/∂x) S_stage + ∂f/∂p at the stage's state, so S is the exact derivative of the
/// discretised replay (not of the differential equation), in one pass instead of one replay per
/// parameter. A model without analytic derivatives is differentiated by [`FiniteDifferences`] built
/// once for the segment. The rudder filter of the model, if any, does not depend on θ.
pub fn replay_segment_sensitivities<P: Parametric>(
    model: &P,
    rec: &Recording,
    a: usize,
    b: usize,
    directions: &[(usize, f64)],
) -> SegmentSensitivities {
    replay_segment_sensitivities_in(model, None, rec, a, b, directions)
}

/// The recorded environment's part of a stage's accelerations at simulation time `t_s` (from the
/// segment's start) and over-ground state `x`: M⁻¹ F_wind plus the current's transport terms.
fn environment_acceleration(
    env: &KnownEnvironment,
    mass: &MassMatrix,
    t_s: f64,
    x: &State,
) -> Option<[f64; 3]> {
    let mut acc = if env.has_wind() {
        mass.solve(env.wind_force(t_s, x))?
    } else {
        [0.0; 3]
    };
    let [tu, tv] = env.current_transport(t_s, x);
    acc[0] += tu;
    acc[1] += tv;
    Some(acc)
}

/// [`replay_segment_sensitivities`] of a recording with a recorded environment `env` (built from
/// `rec`): the replay of [`replay_segment_in`]. The model is evaluated at the state through the water,
/// so its ∂a/∂(u, v) also moves with ψ (the current turns in body axes); the known wind and transport
/// accelerations depend on θ not at all and on the state through ∂/∂(u, v, r, ψ) by central
/// differences. Without `env` the replay is [`replay_segment_sensitivities`]'s, step for step.
pub fn replay_segment_sensitivities_in<P: Parametric>(
    model: &P,
    env: Option<&KnownEnvironment>,
    rec: &Recording,
    a: usize,
    b: usize,
    directions: &[(usize, f64)],
) -> SegmentSensitivities {
    let env = env.map(|e| e.replay_from(rec.t[a]));
    let mass = MassMatrix::new(model.ship(), model.added_mass());
    let mut out = SegmentSensitivities::default();
    let start = SegmentStart::new(model.ship(), rec, a, b);
    let ship = *model.ship();
    let (dt, duration) = (start.dt_s, start.duration_s);
    if !(dt.is_finite() && dt > 0.0 && duration.is_finite() && start.init.is_finite()) {
        return out;
    }
    let Ok(ctrl) = Replay::new(start.t, start.delta) else {
        return out;
    };
    let mut filter = model.model_rudder_filter();
    let filter: &mut dyn RudderFilter = match filter.as_mut() {
        Some(f) => f.as_mut(),
        None => &mut NoFilter,
    };
    let steps = (duration / dt).round() as usize;
    let n = directions.len();
    let n_theta = model.parameters().len();
    let mut d_theta = vec![[0.0; 3]; n_theta];
    // Sensitivities row-major over the six states (u, v, r, x0, y0, ψ), n directions each.
    let mut sens = vec![0.0; 6 * n];
    let mut stage_sens = vec![0.0; 6 * n];
    let mut dk: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; 6 * n]);
    let mut state = start.init;
    let bounds = DivergenceBounds::default();
    let fd = (!model.analytic_sensitivities())
        .then(|| FiniteDifferences::new(model, directions.iter().map(|&(j, _)| j)));
    // Steps of the central differences of the environment's accelerations: u, v, r and ψ.
    let fd_steps = [
        1e-6 * ship.u0,
        1e-6 * ship.u0,
        1e-6 * ship.u0 / ship.lpp,
        1e-6,
    ];
    // One stage at `t_s`: the derivative at `x` and, in `dk_out`, (∂f/∂x) `s` + ∂f/∂p.
    let mut stage =
        |t_s: f64, x: &State, delta: f64, s: &[f64], dk_out: &mut [f64]| -> Option<[f64; 6]> {
            let mut d_state = [[0.0; 3]; 3];
            // ∂a/∂ψ: zero in still water and air.
            let mut d_psi = [0.0; 3];
            let hydro_state = match &env {
                Some(e) => e.through_water(t_s, x),
                None => *x,
            };
            let mut acc = match &fd {
                Some(fd) => fd.sensitivities(&hydro_state, delta, &mut d_state, &mut d_theta),
                None => model.sensitivities(&hydro_state, delta, &mut d_state, &mut d_theta),
            }
            .ok()?;
            if let Some(e) = &env {
                // u_w = u − u_c(ψ), v_w = v − v_c(ψ), with ∂u_c/∂ψ = v_c and ∂v_c/∂ψ = −u_c.
                let [uc, vc] = e.current_body(t_s, x.psi);
                for d in 0..3 {
                    d_psi[d] = -d_state[d][0] * vc + d_state[d][1] * uc;
                }
                let known = environment_acceleration(e, &mass, t_s, x)?;
                for (k, h) in fd_steps.iter().enumerate() {
                    let shifted = |sign: f64| {
                        let mut y = *x;
                        match k {
                            0 => y.u += sign * h,
                            1 => y.v += sign * h,
                            2 => y.r += sign * h,
                            _ => y.psi += sign * h,
                        }
                        environment_acceleration(e, &mass, t_s, &y)
                    };
                    let (plus, minus) = (shifted(1.0)?, shifted(-1.0)?);
                    for d in 0..3 {
                        let g = (plus[d] - minus[d]) / (2.0 * h);
                        if k < 3 {
                            d_state[d][k] += g;
                        } else {
                            d_psi[d] += g;
                        }
                    }
                }
                (0..3).for_each(|d| acc[d] += known[d]);
            }
            if !acc.iter().all(|v| v.is_finite()) {
                return None;
            }
            let kin = x.kinematics();
            let (sin, cos) = x.psi.sin_cos();
            let (su, rest) = s.split_at(n);
            let (sv, rest) = rest.split_at(n);
            let (sr, rest) = rest.split_at(n);
            let (_, rest) = rest.split_at(n);
            let (_, spsi) = rest.split_at(n);
            let (dv, rest) = dk_out.split_at_mut(n);
            let (dvv, rest) = rest.split_at_mut(n);
            let (dvr, rest) = rest.split_at_mut(n);
            let (dx0, rest) = rest.split_at_mut(n);
            let (dy0, dpsi) = rest.split_at_mut(n);
            let dx_dpsi = -x.u * sin - x.v * cos;
            let dy_dpsi = x.u * cos - x.v * sin;
            for j in 0..n {
                let (index, unit) = directions[j];
                let b = d_theta.get(index).copied().unwrap_or([0.0; 3]);
                let (u, v, r, p) = (su[j], sv[j], sr[j], spsi[j]);
                dv[j] = d_state[0][0] * u
                    + d_state[0][1] * v
                    + d_state[0][2] * r
                    + d_psi[0] * p
                    + b[0] * unit;
                dvv[j] = d_state[1][0] * u
                    + d_state[1][1] * v
                    + d_state[1][2] * r
                    + d_psi[1] * p
                    + b[1] * unit;
                dvr[j] = d_state[2][0] * u
                    + d_state[2][1] * v
                    + d_state[2][2] * r
                    + d_psi[2] * p
                    + b[2] * unit;
                dx0[j] = cos * u - sin * v + dx_dpsi * p;
                dy0[j] = sin * u + cos * v + dy_dpsi * p;
                dpsi[j] = r;
            }
            Some([acc[0], acc[1], acc[2], kin[0], kin[1], kin[2]])
        };
    let axpy = |y: &[f64; 6], h: f64, k: &[f64; 6]| {
        State::from_array(std::array::from_fn(|i| y[i] + h * k[i]))
    };
    let axpy_sens = |out: &mut [f64], s: &[f64], h: f64, k: &[f64]| {
        out.iter_mut()
            .zip(s.iter().zip(k))
            .for_each(|(o, (x, d))| *o = x + h * d);
    };
    for k in 0..=steps {
        let t = k as f64 * dt;
        let last = k == steps;
        let h = if last { 0.0 } else { dt };
        let recorded = [0.0, 0.5 * h, h].map(|tau| ctrl.at(t + tau));
        let effective = filter.step(t, h, recorded);
        if !recorded.iter().chain(&effective).all(|d| d.is_finite()) {
            return out;
        }
        let y = state.to_array();
        let [dk1, dk2, dk3, dk4] = &mut dk;
        let Some(k1) = stage(t, &state, effective[0], &sens, dk1) else {
            return out;
        };
        out.t.push(t);
        out.pose.push([state.x0, state.y0, state.psi]);
        out.pose_sensitivity.push(
            (0..n)
                .flat_map(|j| [sens[3 * n + j], sens[4 * n + j], sens[5 * n + j]])
                .collect(),
        );
        if last {
            out.completed = true;
            return out;
        }
        axpy_sens(&mut stage_sens, &sens, 0.5 * dt, dk1);
        let Some(k2) = stage(
            t + 0.5 * dt,
            &axpy(&y, 0.5 * dt, &k1),
            effective[1],
            &stage_sens,
            dk2,
        ) else {
            return out;
        };
        axpy_sens(&mut stage_sens, &sens, 0.5 * dt, dk2);
        let Some(k3) = stage(
            t + 0.5 * dt,
            &axpy(&y, 0.5 * dt, &k2),
            effective[1],
            &stage_sens,
            dk3,
        ) else {
            return out;
        };
        axpy_sens(&mut stage_sens, &sens, dt, dk3);
        let Some(k4) = stage(t + dt, &axpy(&y, dt, &k3), effective[2], &stage_sens, dk4) else {
            return out;
        };
        state = State::from_array(std::array::from_fn(|i| {
            y[i] + dt / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
        }));
        for (i, x) in sens.iter_mut().enumerate() {
            *x += dt / 6.0 * (dk1[i] + 2.0 * (dk2[i] + dk3[i]) + dk4[i]);
        }
        if diverged(&state, &bounds, ship.u0, ship.lpp) {
            return out;
        }
    }
    out
}

/// The divergence limits of the simulation loop ([`DivergenceBounds`]), as it applies them after
/// each step, so that a sensitivity replay stops where [`replay_segment`] does.
fn diverged(s: &State, b: &DivergenceBounds, u0: f64, lpp: f64) -> bool {
    !s.is_finite()
        || s.speed() > b.max_speed_over_u0 * u0
        || s.v.abs() > b.max_sway_over_u0 * u0
        || s.r.abs() * lpp / u0 > b.max_yaw_rate_prime
}
