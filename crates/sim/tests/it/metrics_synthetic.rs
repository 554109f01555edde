//! The metric code on synthetic records with known answers, mirror symmetry, robustness.

use proptest::prelude::*;
use shipid_io::{Manoeuvre, Recording, Side};
use shipid_sim::metrics::{Metrics, metrics, zigzag_events};
use shipid_sim::{Dynamics, MmgModel, Replay, SimOptions, State, kvlcc2_ship, simulate};

use crate::common::simulate_manoeuvre;

/// A record whose heading, position and rudder are given as functions of time, sampled every `dt_s`.
fn record(t_end: f64, dt_s: f64, f: impl Fn(f64) -> (f64, f64, f64, f64)) -> Recording {
    let mut rec = Recording::default();
    let n = (t_end / dt_s).round() as usize;
    for i in 0..=n {
        let t = i as f64 * dt_s;
        let (x, y, psi, delta) = f(t);
        rec.t.push(t);
        rec.x0.push(x);
        rec.y0.push(y);
        rec.psi.push(psi);
        rec.u.push(1.0);
        rec.v.push(0.0);
        rec.r.push(0.0);
        rec.delta.push(delta);
    }
    rec
}

/// Rudder leaving 0 at `t1` at the ship's rudder rate towards `sign`·`amp` [rad].
fn rudder(t: f64, t1: f64, amp: f64, sign: f64) -> f64 {
    let rate = kvlcc2_ship().rudder_rate.to_radians();
    sign * (rate * (t - t1)).clamp(0.0, amp)
}

/// Mirror image port ↔ starboard: y0, ψ, v, r, δ change sign.
fn mirror(rec: &Recording) -> Recording {
    let neg = |v: &Vec<f64>| v.iter().map(|x| -x).collect::<Vec<f64>>();
    Recording {
        y0: neg(&rec.y0),
        psi: neg(&rec.psi),
        v: neg(&rec.v),
        r: neg(&rec.r),
        delta: neg(&rec.delta),
        ..rec.clone()
    }
}

fn close(a: Option<f64>, b: f64, tol: f64) -> bool {
    a.is_some_and(|a| (a - b).abs() <= tol)
}

/// Exact circle of radius `radius` entered at t1 from a straight course `course` through (x1, y1).
fn circle_record(radius: f64, course: f64, side: Side, turns_deg: f64) -> (Recording, f64) {
    let (t1, omega, u) = (5.0, 0.02, 0.7);
    let s = side.sign();
    let (x1, y1) = (12.0, -40.0);
    let t_end = t1 + turns_deg.to_radians() / omega;
    let rec = record(t_end, 0.05, |t| {
        let (dir_x, dir_y) = (course.cos(), course.sin());
        // Lateral unit vector towards the turn side.
        let (lat_x, lat_y) = (-s * course.sin(), s * course.cos());
        if t <= t1 {
            let d = u * (t - t1);
            (x1 + d * dir_x, y1 + d * dir_y, course, 0.0)
        } else {
            let a = omega * (t - t1);
            let along = radius * a.sin();
            let lateral = radius * (1.0 - a.cos());
            (
                x1 + along * dir_x + lateral * lat_x,
                y1 + along * dir_y + lateral * lat_y,
                course + s * a,
                rudder(t, t1, 35f64.to_radians(), s),
            )
        }
    });
    (rec, t1)
}

#[test]
fn exact_circle_gives_exact_turning_metrics() {
    let ship = kvlcc2_ship();
    let l = ship.lpp;
    let radius = 1.4 * l;
    for side in [Side::Starboard, Side::Port] {
        for course in [0.0, 0.5, -2.0] {
            let (rec, _) = circle_record(radius, course, side, 720.0);
            let man = Manoeuvre::Turning {
                rudder_deg: 35.0,
                side,
            };
            let m = metrics(&rec, &man, &ship);
            // Linear interpolation between samples 0.057° apart: chord error ~ R (Δψ)²/8 ≈ 1e-7 R.
            let tol = 1e-5;
            assert!(
                close(m.advance, radius / l, tol),
                "{side:?} {course}: {m:?}"
            );
            assert!(close(m.transfer, radius / l, tol), "{m:?}");
            assert!(close(m.tactical_diameter, 2.0 * radius / l, tol), "{m:?}");
            assert!(close(m.steady_diameter, 2.0 * radius / l, 1e-9), "{m:?}");
            assert_eq!((m.overshoot_1, m.t_a), (None, None));
        }
    }
}

#[test]
fn steady_diameter_needs_540_degrees() {
    let ship = kvlcc2_ship();
    let man = Manoeuvre::Turning {
        rudder_deg: 35.0,
        side: Side::Starboard,
    };
    let (short, _) = circle_record(10.0, 0.0, Side::Starboard, 530.0);
    let m = metrics(&short, &man, &ship);
    assert!(
        m.tactical_diameter.is_some() && m.steady_diameter.is_none(),
        "{m:?}"
    );
    let (long, _) = circle_record(10.0, 0.0, Side::Starboard, 545.0);
    assert!(metrics(&long, &man, &ship).steady_diameter.is_some());
    let (quarter, _) = circle_record(10.0, 0.0, Side::Starboard, 80.0);
    assert_eq!(metrics(&quarter, &man, &ship), Metrics::default());
}

/// Heading starts to respond this long [s] after the first execute in [`sine_zigzag`].
const RESPONSE_S: f64 = 1.0;

/// Zig-zag heading deviation a·sin(ω(t − t1 − 1 s)) towards `side` after the first execute at t1 (the
/// heading responds one second after the rudder moves), with the rudder following the zig-zag law;
/// overshoots are a − c, t_a = 1 s + asin(c/a)/ω, the first peak π/(2ω) after the heading starts.
fn sine_zigzag(
    a_deg: f64,
    c_deg: f64,
    omega: f64,
    side: Side,
    t_end: f64,
    dt_s: f64,
    psi0: f64,
) -> Recording {
    let (a, c) = (a_deg.to_radians(), c_deg.to_radians());
    let t1 = 3.0;
    let t_start = t1 + RESPONSE_S;
    let s = side.sign();
    let t2 = t_start + (c / a).asin() / omega;
    let period = std::f64::consts::PI / omega;
    let amp = 20f64.to_radians();
    record(t_end, dt_s, |t| {
        let dev = if t <= t_start {
            0.0
        } else {
            a * (omega * (t - t_start)).sin()
        };
        // Rudder: to `side` at t1, reversed at every check crossing (every half period after t2).
        let delta = if t < t2 {
            rudder(t, t1, amp, s)
        } else {
            let k = ((t - t2) / period).floor();
            let sign = if k as i64 % 2 == 0 { -s } else { s };
            sign * amp
        };
        (0.0, 0.0, psi0 + s * dev, delta)
    })
}

#[test]
fn analytic_heading_gives_exact_overshoots_and_times() {
    let ship = kvlcc2_ship();
    let (a, c, omega) = (27.0, 20.0, 0.09);
    for side in [Side::Starboard, Side::Port] {
        let rec = sine_zigzag(a, c, omega, side, 120.0, 0.05, 0.3);
        let man = Manoeuvre::ZigZag {
            rudder_deg: 20.0,
            check_deg: c,
            side,
        };
        let m = metrics(&rec, &man, &ship);
        let scale = ship.u0 / ship.lpp;
        let t_a = RESPONSE_S + (c / a).asin() / omega;
        let t_check = RESPONSE_S + std::f64::consts::FRAC_PI_2 / omega - t_a;
        assert!(close(m.overshoot_1, a - c, 1e-5), "{side:?}: {m:?}");
        assert!(close(m.overshoot_2, a - c, 1e-5), "{m:?}");
        assert!(
            close(m.t_a, t_a * scale, 1e-4),
            "{m:?} vs t_a {}",
            t_a * scale
        );
        assert!(
            close(m.t_check, t_check * scale, 1e-4),
            "{m:?} vs t_check {}",
            t_check * scale
        );
    }
}

#[test]
fn too_short_records_leave_metrics_undefined() {
    let ship = kvlcc2_ship();
    let (a, c, omega) = (27.0, 20.0, 0.09);
    let man = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: c,
        side: Side::Starboard,
    };
    let first_peak = 3.0 + RESPONSE_S + std::f64::consts::FRAC_PI_2 / omega;
    // Ends on the rise towards the second peak: overshoot 2 undefined, even though the heading is past
    // the check angle.
    let rec = sine_zigzag(a, c, omega, Side::Starboard, first_peak + 30.0, 0.05, 0.0);
    let m = metrics(&rec, &man, &ship);
    assert!(m.overshoot_1.is_some() && m.overshoot_2.is_none(), "{m:?}");
    let json = serde_json::to_string(&m).unwrap();
    assert!(
        !json.contains("overshoot_2") && json.contains("overshoot_1") && !json.contains("advance"),
        "{json}"
    );
    // Ends before the first peak: only t_a.
    let rec = sine_zigzag(a, c, omega, Side::Starboard, first_peak - 2.0, 0.05, 0.0);
    let m = metrics(&rec, &man, &ship);
    assert!(
        m.t_a.is_some() && m.overshoot_1.is_none() && m.t_check.is_none(),
        "{m:?}"
    );
}

#[test]
fn wrong_side_free_empty_and_nan_records_give_no_metrics() {
    let ship = kvlcc2_ship();
    let rec = sine_zigzag(27.0, 20.0, 0.09, Side::Starboard, 100.0, 0.05, 0.0);
    let port = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: Side::Port,
    };
    assert_eq!(metrics(&rec, &port, &ship), Metrics::default());
    let stbd = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: Side::Starboard,
    };
    assert_eq!(metrics(&rec, &Manoeuvre::Free, &ship), Metrics::default());
    assert_eq!(
        metrics(&Recording::default(), &stbd, &ship),
        Metrics::default()
    );
    let mut bad = rec.clone();
    bad.psi[100] = f64::NAN;
    assert_eq!(metrics(&bad, &stbd, &ship), Metrics::default());
    let mut unordered = rec.clone();
    unordered.t[50] = unordered.t[49];
    assert_eq!(metrics(&unordered, &stbd, &ship), Metrics::default());
    assert_eq!(serde_json::to_string(&Metrics::default()).unwrap(), "{}");
}

#[test]
fn metric_code_is_mirror_symmetric_on_simulations() {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    for man in [
        Manoeuvre::ZigZag {
            rudder_deg: 10.0,
            check_deg: 10.0,
            side: Side::Starboard,
        },
        Manoeuvre::Turning {
            rudder_deg: 35.0,
            side: Side::Starboard,
        },
    ] {
        let out = simulate_manoeuvre(&model, &man, &SimOptions::new(400.0));
        let mirrored_man = match man {
            Manoeuvre::ZigZag {
                rudder_deg,
                check_deg,
                ..
            } => Manoeuvre::ZigZag {
                rudder_deg,
                check_deg,
                side: Side::Port,
            },
            Manoeuvre::Turning { rudder_deg, .. } => Manoeuvre::Turning {
                rudder_deg,
                side: Side::Port,
            },
            Manoeuvre::Free => unreachable!(),
        };
        let m = metrics(&out.recording, &man, &ship);
        let mm = metrics(&mirror(&out.recording), &mirrored_man, &ship);
        assert_eq!(m, mm);
        assert!(
            m.entries().iter().filter(|e| e.1.is_some()).count() >= 4,
            "{m:?}"
        );
    }
}

#[test]
fn replay_of_its_own_rudder_reproduces_a_zigzag() {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let man = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: Side::Port,
    };
    let opts = SimOptions::new(150.0);
    let original = simulate_manoeuvre(&model, &man, &opts);
    let mut replay = Replay::from_recording(&original.recording).unwrap();
    let replayed = simulate(&model, &mut replay, State::approach(ship.u0), &opts).unwrap();
    let (a, b) = (&original.recording, &replayed.recording);
    assert_eq!(a.len(), b.len());
    // The replay interpolates the rudder linearly between the 0.05 s samples; the actuator's kinks
    // (rudder reaching its angle, reversals) fall inside steps, so the runs differ slightly.
    let max_pos = (0..a.len())
        .map(|i| (a.x0[i] - b.x0[i]).hypot(a.y0[i] - b.y0[i]))
        .fold(0.0, f64::max);
    let max_psi = (0..a.len())
        .map(|i| (a.psi[i] - b.psi[i]).abs())
        .fold(0.0, f64::max);
    assert!(
        max_pos < 1e-3 * ship.lpp,
        "max position difference {max_pos} m"
    );
    assert!(
        max_psi.to_degrees() < 0.01,
        "max heading difference {}°",
        max_psi.to_degrees()
    );
    let (ma, mb) = (metrics(a, &man, &ship), metrics(b, &man, &ship));
    assert!(
        (ma.overshoot_1.unwrap() - mb.overshoot_1.unwrap()).abs() < 0.01,
        "{ma:?} {mb:?}"
    );
    assert!(
        (ma.overshoot_2.unwrap() - mb.overshoot_2.unwrap()).abs() < 0.01,
        "{ma:?} {mb:?}"
    );
    assert_eq!(a.delta, b.delta);
}

#[test]
fn zigzag_events_list_every_overshoot() {
    let ship = kvlcc2_ship();
    let (a, c, omega) = (27.0, 20.0, 0.09);
    let rec = sine_zigzag(a, c, omega, Side::Port, 300.0, 0.05, 0.0);
    let ev = zigzag_events(&rec, 20.0, c, Side::Port, &ship).unwrap();
    // A half period of 34.9 s: executes at t2, t2 + 34.9, … up to 300 s; overshoots up to the last peak.
    assert!(ev.executes_s.len() >= 8, "{:?}", ev.executes_s);
    assert!(ev.overshoots.len() >= 7);
    for w in ev.executes_s[1..].windows(2) {
        assert!((w[1] - w[0] - std::f64::consts::PI / omega).abs() < 1e-3);
    }
    assert!(
        ev.overshoots
            .iter()
            .all(|o| (o.angle_deg - (a - c)).abs() < 1e-5)
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Overshoots of sinusoidal heading histories with random amplitude, check angle, period, sampling
    /// and side are a − c to within the peak interpolation error, and port/starboard mirror images agree.
    #[test]
    fn sinusoid_overshoots(a_over_c in 1.05f64..3.0, c in 1.0f64..35.0, omega in 0.02f64..0.3, dt in 0.02f64..0.5, stbd in any::<bool>()) {
        let ship = kvlcc2_ship();
        let side = if stbd { Side::Starboard } else { Side::Port };
        let a = a_over_c * c;
        let t_end = 3.0 + RESPONSE_S + 2.2 * std::f64::consts::PI / omega;
        let rec = sine_zigzag(a, c, omega, side, t_end, dt, 0.0);
        let man = Manoeuvre::ZigZag { rudder_deg: 20.0, check_deg: c, side };
        let m = metrics(&rec, &man, &ship);
        // Parabola through samples of a sine: vertex error ≲ a (ω dt)⁴ / 10 plus the sampling phase.
        let tol = 1e-3 + a * (omega * dt).powi(4) / 4.0;
        prop_assert!(close(m.overshoot_1, a - c, tol), "{:?} vs {}", m, a - c);
        prop_assert!(close(m.overshoot_2, a - c, tol), "{:?} vs {}", m, a - c);
        let other = if stbd { Side::Port } else { Side::Starboard };
        let mm = metrics(&mirror(&rec), &Manoeuvre::ZigZag { rudder_deg: 20.0, check_deg: c, side: other }, &ship);
        prop_assert_eq!(m, mm);
    }
}

/// The reference model's zig-zag with its reversals `delay_s` after each check, sampled as a recording
/// (every 0.1 s, as the default data).
fn zigzag_with_reaction_delay(rudder_deg: f64, check_deg: f64, delay_s: f64) -> Recording {
    let model = MmgModel::kvlcc2();
    let mut zz = shipid_sim::ZigZag::new(rudder_deg, check_deg, Side::Port, 5.0)
        .unwrap()
        .with_reaction_delay(delay_s)
        .unwrap();
    simulate(
        &model,
        &mut zz,
        State::approach(model.ship().u0),
        &SimOptions::new(120.0).with_step(0.05, 0.1),
    )
    .unwrap()
    .recording
}

#[test]
fn a_zigzag_reversed_late_measures_its_reaction_delay() {
    use shipid_sim::metrics::check_reaction_delay_s;
    let ship = kvlcc2_ship();
    let check = |rudder_deg: f64, delay_s: f64| {
        let rec = zigzag_with_reaction_delay(rudder_deg, rudder_deg, delay_s);
        let measured = check_reaction_delay_s(&rec, rudder_deg, rudder_deg, Side::Port, &ship)
            .unwrap_or_else(|| panic!("{rudder_deg}°, {delay_s} s: no reversal measured"));
        assert!(
            (measured - delay_s).abs() < 2e-3,
            "{rudder_deg}°/{rudder_deg}°, delay {delay_s} s: measured {measured} s"
        );
    };
    for rudder_deg in [10.0, 20.0, 35.0] {
        for delay_s in [0.0, 0.13, 0.3, 1.0] {
            check(rudder_deg, delay_s);
        }
    }
    // A later reversal makes a larger overshoot: the delay matters to the metric it is measured for.
    let os = |delay_s| {
        let rec = zigzag_with_reaction_delay(20.0, 20.0, delay_s);
        metrics(
            &rec,
            &Manoeuvre::ZigZag {
                rudder_deg: 20.0,
                check_deg: 20.0,
                side: Side::Port,
            },
            &ship,
        )
        .overshoot_1
        .unwrap()
    };
    assert!(os(0.5) > os(0.0) + 0.3, "{} vs {}", os(0.5), os(0.0));
    // Not a zig-zag that reverses: nothing to measure.
    let turn = record(60.0, 0.1, |t| (t, 0.0, 0.01 * t, rudder(t, 5.0, 0.6, 1.0)));
    assert_eq!(
        check_reaction_delay_s(&turn, 35.0, 35.0, Side::Starboard, &ship),
        None
    );
}

#[test]
fn a_negative_reaction_delay_is_refused() {
    for bad in [-0.1, f64::NAN, f64::INFINITY] {
        let err = shipid_sim::ZigZag::new(20.0, 20.0, Side::Port, 5.0)
            .unwrap()
            .with_reaction_delay(bad)
            .unwrap_err();
        assert!(err.to_string().contains("reaction_delay_s"), "{err}");
    }
}

/// `rec`'s rudder as a real encoder reports it: quantised to `step_rad`, and on the approach
/// (before `t_execute_s`) jittering by one step about neutral, first towards `first_jitter` (±1).
fn quantised_jittering_rudder(
    rec: &Recording,
    step_rad: f64,
    t_execute_s: f64,
    first_jitter: f64,
) -> Recording {
    let jitter = [
        first_jitter,
        0.0,
        -first_jitter,
        0.0,
        0.0,
        first_jitter,
        -first_jitter,
        0.0,
    ];
    let delta = rec
        .t
        .iter()
        .zip(&rec.delta)
        .enumerate()
        .map(|(i, (&t, &d))| {
            let q = (d / step_rad).round() * step_rad;
            if t < t_execute_s - 0.2 {
                q + jitter[i % jitter.len()] * step_rad
            } else {
                q
            }
        })
        .collect();
    Recording {
        delta,
        ..rec.clone()
    }
}

/// Regression (`rudder-jitter-false-execute`): an encoder step of 0.0098 rad (0.56°) is above the 0.5°
/// execute threshold, so a rudder jittering by one step at neutral took the first execute from the
/// jitter: a jitter towards the other side left the record without metrics, one towards the turn
/// moved the execute (and the origin of every metric) into the approach.
#[test]
fn a_rudder_jittering_by_one_encoder_step_at_neutral_does_not_fake_the_first_execute() {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let step_rad = 0.0098;
    // A 10 s approach: the jitter has time to fake an execute.
    let check = |man: Manoeuvre, first_jitter: f64| {
        let mut c = shipid_sim::controller_for(&man, 10.0).unwrap();
        let clean = simulate(
            &model,
            c.as_mut(),
            State::approach(ship.u0),
            &SimOptions::new(300.0),
        )
        .unwrap()
        .recording;
        let quantised = quantised_jittering_rudder(&clean, step_rad, 10.0, first_jitter);
        let (a, b) = (
            metrics(&clean, &man, &ship),
            metrics(&quantised, &man, &ship),
        );
        assert!(
            a.entries().iter().filter(|e| e.1.is_some()).count() >= 3,
            "{man:?}: {a:?}"
        );
        for ((key, want), (_, got)) in a.entries().iter().zip(b.entries()) {
            match (want, got) {
                (Some(w), Some(g)) => assert!(
                    (w - g).abs() <= 0.01 * w.abs().max(1.0),
                    "{man:?}, jitter {first_jitter}: {key} {g} against {w} with a clean rudder"
                ),
                (None, None) => {}
                _ => panic!("{man:?}, jitter {first_jitter}: {key} {got:?} against {want:?}"),
            }
        }
    };
    for side in [Side::Starboard, Side::Port] {
        for first_jitter in [1.0, -1.0] {
            check(
                Manoeuvre::ZigZag {
                    rudder_deg: 20.0,
                    check_deg: 20.0,
                    side,
                },
                first_jitter,
            );
            check(
                Manoeuvre::Turning {
                    rudder_deg: 35.0,
                    side,
                },
                first_jitter,
            );
        }
    }
}

/// Why a record has no first execute, as the overshoot-count errors of `fit` and studies say it.
#[test]
fn a_record_without_a_first_execute_says_why() {
    let check = |rec: &Recording, side: Side, expected: Option<&str>| {
        let got = shipid_sim::metrics::missing_execute_reason(rec, 20.0, side);
        match expected {
            None => assert_eq!(got, None),
            Some(e) => assert!(got.as_deref().is_some_and(|g| g.contains(e)), "{got:?}"),
        }
    };
    let stbd = sine_zigzag(27.0, 20.0, 0.09, Side::Starboard, 100.0, 0.05, 0.0);
    check(&stbd, Side::Starboard, None);
    check(
        &stbd,
        Side::Port,
        Some("first put over to starboard, while the data set declares port"),
    );
    let still = record(50.0, 0.1, |t| (t, 0.0, 0.0, 0.004));
    check(&still, Side::Port, Some("never moves more than 5.0°"));
}

/// `rec` carried along by a uniform current of `speed_m_s` from `from_deg` (earth-fixed): its track
/// drifts, its velocities over ground gain the current, and it records the current's columns.
fn in_current(rec: &Recording, speed_m_s: f64, from_deg: f64) -> Recording {
    let from = from_deg.to_radians();
    let (cn, ce) = (-speed_m_s * from.cos(), -speed_m_s * from.sin());
    let t0 = rec.t[0];
    let mut out = rec.clone();
    for i in 0..rec.len() {
        let dt = rec.t[i] - t0;
        out.x0[i] += cn * dt;
        out.y0[i] += ce * dt;
        let (s, c) = rec.psi[i].sin_cos();
        out.u[i] += cn * c + ce * s;
        out.v[i] += -cn * s + ce * c;
    }
    out.current = Some(shipid_io::FlowSeries {
        speed_m_s: vec![speed_m_s; rec.len()],
        from_rad: vec![from; rec.len()],
    });
    out
}

/// Regression (`metrics-ignore-recorded-current`): a turn recorded in a 0.5 m/s current was measured
/// on its drifting track over ground (steady diameter −13 %, advance +8 %) although the recording
/// carried the current; trials measure it through the water, and a simulation of the same ship in
/// calm water gave the through-water values.
#[test]
fn a_recorded_current_is_taken_out_of_the_metrics() {
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let check = |man: Manoeuvre| {
        let calm = simulate_manoeuvre(&model, &man, &SimOptions::new(600.0)).recording;
        let want = metrics(&calm, &man, &ship);
        assert!(
            want.entries().iter().filter(|e| e.1.is_some()).count() >= 4,
            "{want:?}"
        );
        for from_deg in [0.0, 200.0] {
            let got = metrics(&in_current(&calm, 0.5 * ship.u0, from_deg), &man, &ship);
            for ((key, w), (_, g)) in want.entries().iter().zip(got.entries()) {
                assert!(
                    match (w, g) {
                        (Some(w), Some(g)) => (w - g).abs() <= 1e-6 * w.abs().max(1.0),
                        (None, None) => true,
                        _ => false,
                    },
                    "{man:?}, current from {from_deg}°: {key} {g:?} against {w:?} in calm water"
                );
            }
        }
    };
    check(Manoeuvre::Turning {
        rudder_deg: 35.0,
        side: Side::Port,
    });
    check(Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: Side::Starboard,
    });
}

/// Regression (`finding-steady-approach-warning`): the approach check read the speed change from two
/// samples, so 2 % of U0 of noise on a steady approach looked like an acceleration. The change is a
/// line fitted over the L/U0 before the execute, with its standard error from the scatter.
#[test]
fn the_approach_change_is_told_from_the_noise() {
    use shipid_sim::metrics::approach;
    let model = MmgModel::kvlcc2();
    let ship = *model.ship();
    let man = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 20.0,
        side: Side::Starboard,
    };
    let mut c = shipid_sim::controller_for(&man, 20.0).unwrap();
    let clean = simulate(
        &model,
        c.as_mut(),
        State::approach(ship.u0),
        &SimOptions::new(100.0),
    )
    .unwrap()
    .recording;
    // Deterministic noise of ±2 % of U0 on u.
    let mut noisy = clean.clone();
    for (i, u) in noisy.u.iter_mut().enumerate() {
        // A deterministic scatter in [−1, 1).
        let r = ((i as f64 * 12.9898).sin() * 43758.5453).rem_euclid(1.0);
        *u += 0.02 * ship.u0 * (2.0 * r - 1.0);
    }
    // The same approach accelerating by 10 % of U0 over the L/U0 before the execute.
    let mut accelerating = clean.clone();
    let t_l = ship.lpp / ship.u0;
    for (u, t) in accelerating.u.iter_mut().zip(&clean.t) {
        *u -= 0.1 * ship.u0 * ((20.0 - t) / t_l).max(0.0);
    }
    let check = |rec: &Recording, changing: bool| {
        let a = approach(rec, &man, &ship).unwrap();
        let significant = a.change_ratio.abs() > 0.02_f64.max(3.0 * a.change_standard_error);
        assert_eq!(significant, changing, "{a:?}");
        assert!((a.speed_ratio - 1.0).abs() < 0.05, "{a:?}");
    };
    check(&clean, false);
    check(&noisy, false);
    check(&accelerating, true);
}

/// `x` rounded to `digits` significant digits, as data written with `%.{digits}g` read back.
fn round_significant(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// The reference model's 20°/10° zig-zag (sampled every 0.1 s) with the top of its first overshoot cut
/// flat over `half_width` samples either side of the peak sample and `shape(k)` added to the k-th
/// sample of that plateau (k = 0, 1, …): a heading that creeps along a plateau, as the HSVA z20_10_sb
/// record does around its first overshoot.
fn zigzag_with_a_plateau(half_width: usize, shape: impl Fn(usize) -> f64) -> Recording {
    let m = MmgModel::kvlcc2();
    let man = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 10.0,
        side: Side::Starboard,
    };
    let opts = SimOptions::new(60.0).with_step(0.05, 0.1);
    let mut rec = simulate_manoeuvre(&m, &man, &opts).recording;
    rec.accelerations = None;
    let ev = zigzag_events(&rec, 20.0, 10.0, Side::Starboard, m.ship()).unwrap();
    let i_peak = rec.t.partition_point(|&t| t < ev.overshoots[0].t_s);
    let top = rec.psi[i_peak - 1].max(rec.psi[i_peak]);
    let first = i_peak - half_width;
    for k in 0..=2 * half_width {
        rec.psi[first + k] = top + shape(k);
    }
    rec
}

/// Regression (probe13 finding 3): on a flat-topped heading peak the first overshoot's time took the
/// first sample of a tie and the last of a creep a few 1e-7 rad high, so t_check moved by the plateau's
/// length (−4.9 % on HSVA z20_10_sb) when the data were written with 6 significant digits. The peak is
/// now the vertex over the whole plateau: ties, creeps below the heading's resolution and rounding to 6
/// significant digits move t_check by less than a sample interval.
#[test]
fn t_check_of_a_flat_topped_peak_does_not_depend_on_the_seventh_digit() {
    let ship = kvlcc2_ship();
    let man = Manoeuvre::ZigZag {
        rudder_deg: 20.0,
        check_deg: 10.0,
        side: Side::Starboard,
    };
    let creep = 3e-7; // rad over the plateau, as HSVA's 3e-5° over 0.45 s
    let flat = zigzag_with_a_plateau(5, |_| 0.0);
    let variants: [(&str, Recording); 5] = [
        (
            "creeping up",
            zigzag_with_a_plateau(5, |k| creep * k as f64 / 10.0),
        ),
        (
            "creeping down",
            zigzag_with_a_plateau(5, |k| -creep * k as f64 / 10.0),
        ),
        (
            "creeping up, saturating",
            zigzag_with_a_plateau(5, |k| -creep * (-(k as f64) / 3.0).exp()),
        ),
        (
            "wider by a tie",
            zigzag_with_a_plateau(5, |k| if k == 0 { -1e-8 } else { 0.0 }),
        ),
        ("rounded to 6 significant digits", {
            let mut r = zigzag_with_a_plateau(5, |k| creep * k as f64 / 10.0);
            r.psi.iter_mut().for_each(|p| *p = round_significant(*p, 6));
            r
        }),
    ];
    let base = metrics(&flat, &man, &ship);
    for (case, rec) in &variants {
        check_peak_moves_less_than_a_sample(case, &base, &metrics(rec, &man, &ship), 0.1, &ship);
    }
}

/// t_check of `got` is within one sample interval `dt_s` of `base`'s, and overshoot_1 within 1e-3°.
fn check_peak_moves_less_than_a_sample(
    case: &str,
    base: &Metrics,
    got: &Metrics,
    dt_s: f64,
    ship: &shipid_io::Ship,
) {
    let (Some(t0), Some(t1)) = (base.t_check, got.t_check) else {
        panic!("{case}: t_check {:?} vs {:?}", base.t_check, got.t_check);
    };
    let sample = dt_s * ship.u0 / ship.lpp;
    assert!(
        (t1 - t0).abs() <= sample,
        "{case}: t_check {t1} vs {t0} (one sample = {sample} L/U0)"
    );
    let (Some(o0), Some(o1)) = (base.overshoot_1, got.overshoot_1) else {
        panic!(
            "{case}: overshoot_1 {:?} vs {:?}",
            base.overshoot_1, got.overshoot_1
        );
    };
    assert!((o1 - o0).abs() <= 1e-3, "{case}: overshoot_1 {o1} vs {o0}");
}
