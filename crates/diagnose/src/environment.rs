//! The recorded environment in the report: which recordings carry a wind or a current (part of the
//! base: the diagnosis looks for what they do not carry), which windage turns a wind into forces, a
//! found wind or current against the recorded one, and the `--reveal` check, which conceals the
//! recorded channels on purpose and compares the verdict with them.

use serde::Serialize;
use shipid_io::{Dataset, FlowSeries};
use shipid_pipeline::environment::{ChosenWindage, WindageSource};
use shipid_sim::Effect;

use crate::verdict::Verdict;

/// A recorded flow over its samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlowSummary {
    /// Mean of the recorded speed [m/s].
    pub speed_mean_m_s: f64,
    /// Direction the mean velocity comes from [deg], earth-fixed, clockwise from north (velocities, not
    /// directions, are averaged, so a flow veering through north does not average to south).
    pub from_mean_deg: f64,
    pub speed_min_m_s: f64,
    pub speed_max_m_s: f64,
    /// Mean velocity [north, east] [m/s].
    #[serde(skip)]
    pub mean_velocity_m_s: [f64; 2],
}

/// The direction [deg, 0–360) a flow of velocity [north, east] comes from (0 for no flow, which
/// comes from nowhere).
fn from_deg(velocity: [f64; 2]) -> f64 {
    if velocity == [0.0, 0.0] {
        return 0.0;
    }
    (-velocity[1])
        .atan2(-velocity[0])
        .to_degrees()
        .rem_euclid(360.0)
}

/// The velocity [north, east] [m/s] of a flow of `speed_m_s` from `from_deg`.
fn velocity(speed_m_s: f64, from_deg: f64) -> [f64; 2] {
    let (s, c) = from_deg.to_radians().sin_cos();
    [-speed_m_s * c, -speed_m_s * s]
}

/// The smaller angle [deg, 0–180] between two directions.
pub fn angle_difference_deg(a_deg: f64, b_deg: f64) -> f64 {
    ((a_deg - b_deg + 180.0).rem_euclid(360.0) - 180.0).abs()
}

impl FlowSummary {
    /// The flow over every sample of `series` pooled; `None` without samples.
    pub fn of<'a>(series: impl IntoIterator<Item = &'a FlowSeries>) -> Option<FlowSummary> {
        let (mut n, mut sum_speed, mut sum_v) = (0usize, 0.0, [0.0; 2]);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for f in series {
            for i in 0..f.speed_m_s.len().min(f.from_rad.len()) {
                let s = f.speed_m_s[i];
                let v = f.velocity_earth(i);
                n += 1;
                sum_speed += s;
                sum_v = [sum_v[0] + v[0], sum_v[1] + v[1]];
                lo = lo.min(s);
                hi = hi.max(s);
            }
        }
        (n > 0).then(|| {
            let mean = [sum_v[0] / n as f64, sum_v[1] / n as f64];
            FlowSummary {
                speed_mean_m_s: sum_speed / n as f64,
                from_mean_deg: from_deg(mean),
                speed_min_m_s: lo,
                speed_max_m_s: hi,
                mean_velocity_m_s: mean,
            }
        })
    }
}

/// One recording's recorded flow.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordedFlow {
    pub recording: String,
    #[serde(flatten)]
    pub flow: FlowSummary,
}

/// The windage a wind is turned into forces with: the recorded wind's and the wind family's.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WindageUse {
    /// `dataset` (the data set's `[windage]`) or `assumed` (it has none).
    pub source: WindageSource,
    pub frontal_area_m2: f64,
    pub lateral_area_m2: f64,
    pub lateral_centre_x_m: f64,
    pub model: &'static str,
    /// In words, with the assumption named when there is one.
    pub description: String,
}

impl WindageUse {
    pub fn of(chosen: &ChosenWindage) -> WindageUse {
        let w = &chosen.windage;
        WindageUse {
            source: chosen.source,
            frontal_area_m2: w.frontal_area_m2,
            lateral_area_m2: w.lateral_area_m2,
            lateral_centre_x_m: w.lateral_centre_x_m,
            model: w.model.name(),
            description: chosen.describe(),
        }
    }
}

/// What the recordings carry as known inputs (absent from the report when they carry nothing).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordedEnvironment {
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub wind: Vec<RecordedFlow>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub current: Vec<RecordedFlow>,
}

impl RecordedEnvironment {
    /// The flows the recordings of `ds` carry; `None` when none carries one.
    pub fn of(ds: &Dataset) -> Option<RecordedEnvironment> {
        let flows = |pick: fn(&shipid_io::Recording) -> Option<&FlowSeries>| -> Vec<RecordedFlow> {
            ds.recordings
                .iter()
                .filter_map(|r| {
                    Some(RecordedFlow {
                        recording: r.file.clone(),
                        flow: FlowSummary::of(pick(&r.recording))?,
                    })
                })
                .collect()
        };
        let env = RecordedEnvironment {
            wind: flows(|r| r.wind.as_ref()),
            current: flows(|r| r.current.as_ref()),
        };
        (!env.wind.is_empty() || !env.current.is_empty()).then_some(env)
    }
}

/// One recording's own wind, found by the per-recording wind family (a steady wind the recording
/// does not carry; direction earth-fixed, clockwise from north, where it comes FROM).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordingWind {
    pub recording: String,
    /// Fitted on both time halves of the recording.
    pub speed_m_s: f64,
    pub from_deg: f64,
    /// One standard error of each (Gauss–Newton, as every fitted effect's), when defined.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_standard_error_m_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub from_standard_error_deg: Option<f64>,
    /// Held-out position RMSE ÷ L of the recording's segment replays (each half judged with the
    /// wind fitted on the other half) without and with its wind.
    pub before_position_rmse_over_l: f64,
    pub after_position_rmse_over_l: f64,
}

/// A wind (or current) the diagnosis found on top of the one the recordings carry.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AgainstRecorded {
    /// `wind` or `current`.
    pub flow: &'static str,
    /// The recording whose own wind this is (a wind found per recording); absent for a flow found
    /// for all recordings.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recording: Option<String>,
    /// The steady flow the diagnosis found, which the recordings do not carry.
    pub found_speed_m_s: f64,
    pub found_from_deg: f64,
    /// The recorded flow, pooled over the recordings that carry it.
    pub recorded: FlowSummary,
    /// The single true flow (over ground, earth-fixed) that pushes as the recorded mean and the found
    /// flow together do (their velocities weighted by their speeds, as forces grow with the square of
    /// the speed): what the ship felt if the found flow is a bias of the recorded channels. Not the
    /// relative wind: the ship's own velocity through the air is left out (for a wind, the relative
    /// wind adds the ship's speed, about U0, from ahead), as both flows are true winds.
    pub felt_speed_m_s: f64,
    pub felt_from_deg: f64,
    /// Found against recorded mean as ratio of speeds and angle between directions.
    pub speed_ratio: f64,
    pub direction_difference_deg: f64,
}

/// A wind or current of the verdict's effects, as (flow word, speed, from).
fn flow_effect(e: &Effect) -> Option<(&'static str, f64, f64)> {
    match e {
        Effect::Wind(w) => Some(("wind", w.speed_m_s, w.from_deg)),
        Effect::Current(c) => Some(("current", c.speed_m_s, c.from_deg)),
        _ => None,
    }
}

/// Every found wind or current that the recordings of `ds` also carry, against the recorded one;
/// then each recording's own wind (`per_recording`) against that recording's recorded wind.
pub fn against_recorded(
    effects: &[Effect],
    per_recording: &[RecordingWind],
    ds: &Dataset,
) -> Vec<AgainstRecorded> {
    let common = effects.iter().filter_map(flow_effect).filter_map(|found| {
        let recorded = FlowSummary::of(ds.recordings.iter().filter_map(|r| match found.0 {
            "wind" => r.recording.wind.as_ref(),
            _ => r.recording.current.as_ref(),
        }))?;
        Some(against(found, recorded, None))
    });
    let own = per_recording.iter().filter_map(|w| {
        let r = ds.recordings.iter().find(|r| r.file == w.recording)?;
        let recorded = FlowSummary::of(r.recording.wind.as_ref())?;
        Some(against(
            ("wind", w.speed_m_s, w.from_deg),
            recorded,
            Some(w.recording.clone()),
        ))
    });
    common.chain(own).collect()
}

/// The found flow `(word, speed, from)` against the `recorded` one.
fn against(
    (flow, speed, from): (&'static str, f64, f64),
    recorded: FlowSummary,
    recording: Option<String>,
) -> AgainstRecorded {
    // The found flow acts as a force of its own beside the recorded one's, and a wind's force grows
    // with the square of its speed: the single flow that pushes as both do adds their velocities
    // weighted by their speeds (exact for flows from one direction, with the ship's own speed
    // through the air left out: a flow over ground, not the relative wind).
    let f = velocity(speed, from);
    let m = recorded.mean_velocity_m_s;
    let (sm, sf) = (m[0].hypot(m[1]), speed);
    let pressure = [sm * m[0] + sf * f[0], sm * m[1] + sf * f[1]];
    let p = pressure[0].hypot(pressure[1]);
    AgainstRecorded {
        flow,
        recording,
        found_speed_m_s: speed,
        found_from_deg: from,
        recorded,
        felt_speed_m_s: p.sqrt(),
        felt_from_deg: from_deg(pressure),
        speed_ratio: speed / recorded.speed_mean_m_s.max(f64::MIN_POSITIVE),
        direction_difference_deg: angle_difference_deg(from, recorded.from_mean_deg),
    }
}

impl AgainstRecorded {
    /// One sentence for the explanation.
    pub fn sentence(&self) -> String {
        let (whose, they) = match &self.recording {
            Some(r) => (format!("{r} carries"), "it does"),
            None => ("the recordings carry".to_string(), "they do"),
        };
        format!(
            "{whose} a {flow} of {:.2} m/s from {:.0}° (mean) as a known input; the {flow} found is one {they} not carry, {:.2} m/s from {:.0}° ({:.0} % of the recorded speed, {:.0}° from its direction): together the ship felt {:.2} m/s from {:.0}°, so the recorded {flow} channels (or the windage) may be off",
            self.recorded.speed_mean_m_s,
            self.recorded.from_mean_deg,
            self.found_speed_m_s,
            self.found_from_deg,
            100.0 * self.speed_ratio,
            self.direction_difference_deg,
            self.felt_speed_m_s,
            self.felt_from_deg,
            flow = self.flow
        )
    }
}

/// The recorded channels `--reveal` left out on purpose.
#[derive(Debug, Clone, PartialEq)]
pub struct Concealed {
    pub wind: Option<FlowSummary>,
    pub current: Option<FlowSummary>,
    /// The recordings whose channels were removed.
    pub recordings: Vec<String>,
    /// Each recording's concealed wind, for recordings that carried one.
    pub wind_per_recording: Vec<(String, FlowSummary)>,
}

/// Remove every recorded wind and current from `ds` (the diagnosis then sees recordings without
/// them) and return what was removed; `None` when no recording carries either.
pub fn conceal(ds: &mut Dataset) -> Option<Concealed> {
    let wind = FlowSummary::of(
        ds.recordings
            .iter()
            .filter_map(|r| r.recording.wind.as_ref()),
    );
    let current = FlowSummary::of(
        ds.recordings
            .iter()
            .filter_map(|r| r.recording.current.as_ref()),
    );
    let wind_per_recording = ds
        .recordings
        .iter()
        .filter_map(|r| Some((r.file.clone(), FlowSummary::of(r.recording.wind.as_ref())?)))
        .collect();
    let mut recordings = Vec::new();
    for r in &mut ds.recordings {
        let had = r.recording.wind.take().is_some() | r.recording.current.take().is_some();
        if had {
            recordings.push(r.file.clone());
        }
    }
    (!recordings.is_empty()).then_some(Concealed {
        wind,
        current,
        recordings,
        wind_per_recording,
    })
}

/// A concealed flow against what the diagnosis found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RevealedFlow {
    /// The recorded channels that were concealed, pooled over their recordings.
    pub recorded: FlowSummary,
    /// The flow the diagnosis found, when it found one of this kind.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub found_speed_m_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub found_from_deg: Option<f64>,
    /// Found minus recorded mean speed [m/s].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub speed_error_m_s: Option<f64>,
    /// Angle between the found direction and the recorded mean velocity's [deg, 0–180].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction_error_deg: Option<f64>,
}

/// One recording's concealed wind against the wind found for it: its own (per-recording wind) or
/// the one found for all recordings.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RevealedRecordingWind {
    pub recording: String,
    #[serde(flatten)]
    pub wind: RevealedFlow,
}

/// The `--reveal` check: the verdict on recordings whose wind and current were concealed, against the
/// concealed channels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RevealCheck {
    /// The recordings whose channels were concealed.
    pub recordings: Vec<String>,
    /// The verdicts that name what was concealed (`none` when the concealed flows were calm).
    pub expected: Vec<Verdict>,
    pub verdict: Verdict,
    pub verdict_right: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wind: Option<RevealedFlow>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub current: Option<RevealedFlow>,
    /// Each recording's concealed wind against the wind found for it (when more than one recording
    /// carried a wind: trials meet a different wind on every run).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub wind_per_recording: Vec<RevealedRecordingWind>,
}

/// The `recorded` flow against the one `found` (speed, from), if any.
fn revealed(recorded: FlowSummary, found: Option<(f64, f64)>) -> RevealedFlow {
    RevealedFlow {
        recorded,
        found_speed_m_s: found.map(|x| x.0),
        found_from_deg: found.map(|x| x.1),
        speed_error_m_s: found.map(|x| x.0 - recorded.speed_mean_m_s),
        direction_error_deg: found.map(|x| angle_difference_deg(x.1, recorded.from_mean_deg)),
    }
}

/// The check of a diagnosis with `verdict`, `effects` (for all recordings) and `per_recording`
/// winds (each recording's own) against what was `concealed`. With winds found per recording the
/// verdict is right only if every recording whose concealed wind blew has its wind named.
pub fn reveal(
    verdict: Verdict,
    effects: &[Effect],
    per_recording: &[RecordingWind],
    concealed: &Concealed,
) -> RevealCheck {
    let found = |word: &str| {
        effects
            .iter()
            .filter_map(flow_effect)
            .find(|(w, _, _)| *w == word)
            .map(|(_, s, f)| (s, f))
    };
    let flow = |word: &str, recorded: Option<FlowSummary>| {
        recorded.map(|recorded| revealed(recorded, found(word)))
    };
    let own = |recording: &str| {
        per_recording
            .iter()
            .find(|w| w.recording == recording)
            .map(|w| (w.speed_m_s, w.from_deg))
    };
    let wind_per_recording: Vec<RevealedRecordingWind> = if concealed.wind_per_recording.len() > 1 {
        concealed
            .wind_per_recording
            .iter()
            .map(|(recording, recorded)| RevealedRecordingWind {
                recording: recording.clone(),
                wind: revealed(*recorded, own(recording).or(found("wind"))),
            })
            .collect()
    } else {
        Vec::new()
    };
    let every_own_named = per_recording.is_empty()
        || concealed
            .wind_per_recording
            .iter()
            .filter(|(_, w)| w.speed_max_m_s > 0.0)
            .all(|(r, _)| own(r).is_some());
    // A concealed flow that never blew is no effect to find.
    let blew = |s: &Option<FlowSummary>| s.is_some_and(|s| s.speed_max_m_s > 0.0);
    let mut expected = Vec::new();
    if blew(&concealed.wind) {
        expected.push(Verdict::Wind);
    }
    if blew(&concealed.current) {
        expected.push(Verdict::Current);
    }
    if expected.is_empty() {
        expected.push(Verdict::None);
    }
    RevealCheck {
        recordings: concealed.recordings.clone(),
        verdict_right: expected.contains(&verdict) && every_own_named,
        expected,
        verdict,
        // Winds found per recording are compared run by run; a mean of them is no wind at all.
        wind: if per_recording.is_empty() {
            flow("wind", concealed.wind)
        } else {
            None
        },
        current: flow("current", concealed.current),
        wind_per_recording,
    }
}

impl RevealedFlow {
    /// `  {label}: recorded … from …°{mean}, found …` for the command's output.
    fn line(&self, label: &str, mean: &str) -> String {
        let r = &self.recorded;
        match (self.found_speed_m_s, self.found_from_deg) {
            (Some(s), Some(d)) => format!(
                "  {label}: recorded {:.3} m/s from {:.0}°{mean}, found {s:.3} m/s from {d:.0}°: speed error {:+.3} m/s, direction error {:.0}°",
                r.speed_mean_m_s,
                r.from_mean_deg,
                self.speed_error_m_s.unwrap_or(f64::NAN),
                self.direction_error_deg.unwrap_or(f64::NAN)
            ),
            _ => format!(
                "  {label}: recorded {:.3} m/s from {:.0}°{mean}, none found",
                r.speed_mean_m_s, r.from_mean_deg
            ),
        }
    }
}

impl RevealCheck {
    /// Lines for the command's output.
    pub fn lines(&self) -> Vec<String> {
        let words: Vec<&str> = self.expected.iter().map(|v| v.word()).collect();
        let mut out = vec![format!(
            "reveal: the recorded wind/current of {} recording(s) was concealed; verdict {} ({}: expected {})",
            self.recordings.len(),
            self.verdict,
            if self.verdict_right { "right" } else { "wrong" },
            words.join(" or ")
        )];
        for (word, f) in [("wind", &self.wind), ("current", &self.current)] {
            if let Some(f) = f {
                out.push(f.line(word, " (mean)"));
            }
        }
        for w in &self.wind_per_recording {
            out.push(w.wind.line(&format!("wind on {}", w.recording), ""));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(speed: &[f64], from_deg: &[f64]) -> FlowSeries {
        FlowSeries {
            speed_m_s: speed.to_vec(),
            from_rad: from_deg.iter().map(|d| d.to_radians()).collect(),
        }
    }

    #[test]
    fn a_wind_veering_through_north_averages_to_north() {
        // Regression guard: averaging the directions 350° and 10° gives 180°.
        let s = FlowSummary::of([&series(&[2.0, 2.0], &[350.0, 10.0])]).unwrap();
        assert!(angle_difference_deg(s.from_mean_deg, 0.0) < 1e-9, "{s:?}");
        assert_eq!((s.speed_min_m_s, s.speed_max_m_s), (2.0, 2.0));
    }

    #[test]
    fn the_reveal_check_scores_the_found_wind_against_the_concealed_one() {
        let concealed = Concealed {
            wind: FlowSummary::of([&series(&[3.0, 3.0], &[80.0, 80.0])]),
            current: None,
            recordings: vec!["a.csv".into()],
            wind_per_recording: Vec::new(),
        };
        let found: Effect = "wind:speed=2.5,from=100".parse().unwrap();
        let check = reveal(Verdict::Wind, &[found], &[], &concealed);
        assert!(check.verdict_right);
        let w = check.wind.unwrap();
        assert!((w.speed_error_m_s.unwrap() + 0.5).abs() < 1e-9);
        assert!((w.direction_error_deg.unwrap() - 20.0).abs() < 1e-9);
        let wrong = reveal(Verdict::Current, &[], &[], &concealed);
        assert!(!wrong.verdict_right && wrong.wind.unwrap().found_speed_m_s.is_none());
    }

    fn own(recording: &str, speed_m_s: f64, from_deg: f64) -> RecordingWind {
        RecordingWind {
            recording: recording.into(),
            speed_m_s,
            from_deg,
            speed_standard_error_m_s: None,
            from_standard_error_deg: None,
            before_position_rmse_over_l: 0.1,
            after_position_rmse_over_l: 0.01,
        }
    }

    /// Two recordings whose concealed winds are (speed, from) `a` and `b`, checked against the
    /// `found` winds per recording: whether the verdict `wind` is right, and each recording's
    /// direction error.
    fn check_own(
        a: (f64, f64),
        b: (f64, f64),
        found: &[RecordingWind],
        expected: (bool, [Option<f64>; 2]),
    ) {
        let flow = |(s, f): (f64, f64)| FlowSummary::of([&series(&[s, s], &[f, f])]).unwrap();
        let concealed = Concealed {
            wind: FlowSummary::of([&series(&[a.0, b.0], &[a.1, b.1])]),
            current: None,
            recordings: vec!["a.csv".into(), "b.csv".into()],
            wind_per_recording: vec![("a.csv".into(), flow(a)), ("b.csv".into(), flow(b))],
        };
        let check = reveal(Verdict::Wind, &[], found, &concealed);
        let errors: Vec<Option<f64>> = check
            .wind_per_recording
            .iter()
            .map(|w| w.wind.direction_error_deg.map(|d| d.round()))
            .collect();
        assert_eq!(
            (check.verdict_right, errors.as_slice()),
            (expected.0, &expected.1[..])
        );
        // Winds found per recording are compared run by run, never as a pooled mean.
        assert_eq!(check.wind.is_some(), found.is_empty());
    }

    #[test]
    fn the_reveal_check_scores_each_recordings_own_wind() {
        let found = [own("a.csv", 3.0, 95.0), own("b.csv", 4.0, 250.0)];
        check_own(
            (3.0, 90.0),
            (4.0, 270.0),
            &found,
            (true, [Some(5.0), Some(20.0)]),
        );
        // A recording whose wind blew but was not named: the verdict is not right.
        check_own(
            (3.0, 90.0),
            (4.0, 270.0),
            &found[..1],
            (false, [Some(5.0), None]),
        );
        // A calm recording needs no wind of its own.
        check_own(
            (3.0, 90.0),
            (0.0, 0.0),
            &found[..1],
            (true, [Some(5.0), None]),
        );
    }
}
