//! `shipid generate --recorded-wind`: a generated run with a recorded wind replays with its own wind
//! to noise level, and without it does not (issue 27, "What it must show").

use shipid_io::{Manoeuvre, Recording, Side};
use shipid_pipeline::generate::{
    DT_S, RecordedEnvironment, RecordedWind, SAMPLE_INTERVAL_S, default_windage, generate_recorded,
};
use shipid_sim::environment::{KnownEnvironment, WithEnvironment};
use shipid_sim::{Dynamics, MmgModel, Replay, SimOptions, State, simulate};

const ZZ20: Manoeuvre = Manoeuvre::ZigZag {
    rudder_deg: 20.0,
    check_deg: 20.0,
    side: Side::Port,
};

/// One generated ZZ20/20 with tank noise `noise_seed`, in the recorded wind `wind` (none: calm).
fn generated(
    wind: Option<&str>,
    noise_seed: Option<u64>,
) -> (Recording, Option<shipid_io::Windage>) {
    let env = wind.map(|w| RecordedEnvironment {
        wind: Some(w.parse::<RecordedWind>().unwrap()),
        current: None,
        windage: default_windage(),
    });
    let g = generate_recorded(noise_seed, &[], &[ZZ20], env.as_ref()).unwrap();
    (g.recordings.into_iter().next().unwrap(), g.dataset.windage)
}

/// Position RMSE ÷ L of the replay of `rec` (its recorded rudder, from its first sample) by `model`.
fn replay_error_over_l(model: &dyn Dynamics, rec: &Recording) -> f64 {
    let mut rudder = Replay::new(rec.t.clone(), rec.delta.clone()).unwrap();
    let duration_s = rec.t[rec.len() - 1] - rec.t[0];
    let out = simulate(
        model,
        &mut rudder,
        State::of_recording(rec, 0),
        &SimOptions::new(duration_s).with_step(DT_S, SAMPLE_INTERVAL_S),
    )
    .unwrap()
    .recording;
    let n = out.len().min(rec.len());
    let sum: f64 = (0..n)
        .map(|i| (out.x0[i] - rec.x0[i]).powi(2) + (out.y0[i] - rec.y0[i]).powi(2))
        .sum();
    (sum / n as f64).sqrt() / model.ship().lpp
}

/// The three replay errors: the calm run by the reference (the noise level), the windy run by the
/// reference in its recorded wind, and the windy run by the reference without it.
fn errors(wind: &str, noise_seed: Option<u64>) -> [f64; 3] {
    let model = MmgModel::kvlcc2();
    let (calm, _) = generated(None, noise_seed);
    let (windy, windage) = generated(Some(wind), noise_seed);
    let env = KnownEnvironment::of_recording(&windy, windage.as_ref(), model.ship())
        .unwrap()
        .unwrap();
    [
        replay_error_over_l(&model, &calm),
        replay_error_over_l(&WithEnvironment::new(&model, env), &windy),
        replay_error_over_l(&model, &windy),
    ]
}

/// The replay of a windy run with its own recorded wind is at the level of a calm run's replay by the
/// same model (`within` × it), and without the wind at least `apart` × that level.
fn check(wind: &str, noise_seed: Option<u64>, within: f64, apart: f64) {
    let [calm, with_wind, without_wind] = errors(wind, noise_seed);
    assert!(
        with_wind <= within * calm && without_wind >= apart * calm,
        "{wind}, noise {noise_seed:?}: calm {calm}, with its wind {with_wind}, without {without_wind} (÷ L)"
    );
}

/// Noise-free ZZ20/20, a wind of 3 ± 1 m/s from a seeded direction: position RMSE of the whole-run
/// replay 0.0026 L for the calm run (the replay's own rudder interpolation), 0.0009 L for the windy run
/// in its recorded wind, 3.8 L without it (measured 2026-11-24).
#[test]
fn a_recorded_wind_replays_exactly_with_the_wind_and_far_off_without() {
    check("mean=3,spread=1,seed=7", None, 1.0, 100.0);
}

/// With tank noise (seed 1) and a gust of intensity 0.2 (T = 2 s) written with anemometer noise: the
/// open-loop replay of the whole run drifts by the noise of its first sample and rudder, 0.54 L for
/// the calm run; 0.35 L for the windy run with its recorded (noisy) wind, 3.0 L without it (measured
/// 2026-11-24).
#[test]
fn a_gusty_recorded_wind_with_sensor_noise_replays_to_noise_level() {
    check(
        "mean=3,spread=1,seed=7,gust=0.2,gust_time=2",
        Some(1),
        1.0,
        4.0,
    );
}

/// Every run draws its own mean wind: different directions and speeds, none calm, all within
/// mean ± spread; the same seed gives the same draws.
#[test]
fn runs_draw_their_own_wind_from_the_seed() {
    let w: RecordedWind = "mean=3,spread=1,seed=7".parse().unwrap();
    let runs: Vec<(f64, f64)> = ["a.csv", "b.csv", "c.csv"]
        .iter()
        .map(|f| w.run(f))
        .collect();
    for &(speed, from) in &runs {
        assert!(
            (2.0..=4.0).contains(&speed) && (0.0..360.0).contains(&from),
            "{runs:?}"
        );
    }
    assert!(runs[0] != runs[1] && runs[1] != runs[2], "{runs:?}");
    assert_eq!(runs[0], w.run("a.csv"));
}

/// Regression: once a simulation recorded the current its model carries, `generate --effect
/// current:…` wrote the concealed current as columns, and `diagnose` took it as a known input (its
/// benchmark's twelve current cases fell to `none` or `unexplained`). A concealed effect leaves no
/// channel; a recorded one is written.
#[test]
fn a_concealed_current_is_not_written_and_a_recorded_wind_still_is() {
    use shipid_pipeline::generate::{generate_manoeuvres, generate_recorded};
    use shipid_sim::Effect;
    let current: Effect = "current:speed=0.05,from=120".parse().unwrap();
    let concealed = generate_manoeuvres(None, std::slice::from_ref(&current), &[ZZ20]).unwrap();
    for rec in &concealed.recordings {
        assert!(rec.current.is_none(), "a concealed current was written");
        assert!(rec.wind.is_none());
    }
    let wind = RecordedEnvironment {
        wind: Some("mean=4,from=90".parse::<RecordedWind>().unwrap()),
        current: None,
        windage: default_windage(),
    };
    let both = generate_recorded(None, &[current], &[ZZ20], Some(&wind)).unwrap();
    for rec in &both.recordings {
        assert!(rec.wind.is_some(), "the recorded wind is written");
        assert!(rec.current.is_none(), "the concealed current is not");
    }
}
