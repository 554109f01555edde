//! A recording's recorded wind and current as known inputs of the pipeline (issue 27): which windage
//! turns a recorded wind into forces, the recording as the hydrodynamics see it (velocities through
//! the water, accelerations without the wind's), the wrapper every replay and validation puts around a
//! model, and the words a command says about them.
//!
//! Identification subtracts what is known (the recorded current's kinematics and the recorded wind's
//! force through the family's own mass matrix) before it fits; every later simulation of a recording
//! adds it back through [`shipid_sim::WithEnvironment`], so a model identified on windy runs is the
//! calm-water model and replays its windy runs with their wind.

use serde::{Deserialize, Serialize};
use shipid_io::deriv::accelerations_or_estimate;
use shipid_io::{
    Accelerations, AddedMass, Dataset, DatasetRecording, FlowSeries, Recording, Ship, Windage,
};
use shipid_sim::environment::{ASSUMED_WINDAGE_SOURCE, assumed_windage};
use shipid_sim::{Dynamics, KnownEnvironment, MassMatrix, RecordedRate};

use crate::error::{PipelineError, bad_input};

/// Where the windage that turns a recorded wind into forces comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum WindageSource {
    /// The data set's `[windage]` table.
    Dataset,
    /// The `[environment.windage]` the model file was identified with.
    ModelFile,
    /// Neither gives one: [`assumed_windage`] (every command that uses it says so).
    Assumed,
}

impl WindageSource {
    /// Words for warnings and reports.
    pub fn words(self) -> &'static str {
        match self {
            WindageSource::Dataset => "the data set's [windage]",
            WindageSource::ModelFile => "the windage the model was identified with",
            WindageSource::Assumed => "an assumed windage",
        }
    }
}

/// A windage and where it comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct ChosenWindage {
    pub windage: Windage,
    pub source: WindageSource,
}

impl ChosenWindage {
    /// The first windage given, in order of preference, else the assumed one for `ship`.
    pub fn first_of(
        candidates: &[(Option<&Windage>, WindageSource)],
        ship: &Ship,
    ) -> ChosenWindage {
        candidates
            .iter()
            .find_map(|(w, source)| {
                w.map(|w| ChosenWindage {
                    windage: w.clone(),
                    source: *source,
                })
            })
            .unwrap_or_else(|| ChosenWindage {
                windage: assumed_windage(ship),
                source: WindageSource::Assumed,
            })
    }

    /// The windage of a data set's recordings: its own `[windage]`, else assumed.
    pub fn of_dataset(ds: &Dataset) -> ChosenWindage {
        ChosenWindage::first_of(&[(ds.windage.as_ref(), WindageSource::Dataset)], &ds.ship)
    }

    /// Whether it is assumed.
    pub fn is_assumed(&self) -> bool {
        self.source == WindageSource::Assumed
    }

    /// One line naming the windage: areas, model and source.
    pub fn describe(&self) -> String {
        let w = &self.windage;
        format!(
            "{} (frontal {:.3} m², lateral {:.3} m², lateral centre {:.3} m, model {}, air {} kg/m³{})",
            self.source.words(),
            w.frontal_area_m2,
            w.lateral_area_m2,
            w.lateral_centre_x_m,
            w.model.name(),
            w.air_density_kg_m3,
            match (&w.source, self.source) {
                (_, WindageSource::Assumed) => format!("; {ASSUMED_WINDAGE_SOURCE}"),
                (Some(s), _) => format!("; {s}"),
                (None, _) => String::new(),
            }
        )
    }
}

/// A recording's known environment with `chosen` as the windage of a recorded wind; `None` for a calm
/// recording (neither wind nor current recorded). `file` names the recording in errors.
pub fn environment_with(
    rec: &Recording,
    chosen: &ChosenWindage,
    ship: &Ship,
    file: &str,
) -> Result<Option<KnownEnvironment>, PipelineError> {
    KnownEnvironment::of_recording(rec, Some(&chosen.windage), ship)
        .map_err(|e| bad_input(format!("{file}: {e}")))
}

/// The known environment of `rec`, a recording of `ds`, with the data set's windage (else the assumed
/// one), and the warning to give when a recorded wind had to be turned into forces with an assumed
/// windage. `None` for a calm recording.
pub fn recording_environment(
    ds: &Dataset,
    rec: &Recording,
) -> Result<(Option<KnownEnvironment>, Option<String>), PipelineError> {
    let chosen = ChosenWindage::of_dataset(ds);
    let env = environment_with(rec, &chosen, &ds.ship, &ds.path.display().to_string())?;
    let warning = env
        .as_ref()
        .is_some_and(|e| e.has_wind() && chosen.is_assumed())
        .then(|| assumed_windage_warning(ds));
    Ok((env, warning))
}

/// The warning for a data set with recorded wind and no `[windage]`.
pub fn assumed_windage_warning(ds: &Dataset) -> String {
    format!(
        "{}: recordings carry a recorded wind but the data set has no [windage] table; the wind's force uses an assumed windage ({ASSUMED_WINDAGE_SOURCE}); give [windage] (docs/data-format.md) for the ship's own",
        ds.path.display()
    )
}

/// A recording as the hydrodynamics of an identified model see it.
#[derive(Debug, Clone)]
pub struct HydrodynamicRecording {
    /// The recording with its velocities through the water (the recorded one when no current).
    pub recording: Recording,
    /// Its accelerations (recorded, or estimated from the water-relative velocities) minus the
    /// recorded wind's M⁻¹ F_wind.
    pub accelerations: Accelerations,
    /// Whether the accelerations were estimated (not recorded).
    pub estimated: bool,
    /// Whether a recorded wind or current was removed.
    pub environment_removed: bool,
}

/// `r` (a recording of `ds`) with its recorded environment removed: velocities through the water and
/// accelerations without the wind's, through the mass matrix of `ds.ship` with `added` (the one the
/// family identifies with, so that its simulations add back exactly what was taken away). A calm
/// recording comes back as it is, with the accelerations every fit used before.
pub fn hydrodynamic_recording(
    ds: &Dataset,
    r: &DatasetRecording,
    added: &AddedMass,
) -> Result<HydrodynamicRecording, PipelineError> {
    let (env, _) = recording_environment(ds, &r.recording)?;
    let Some(env) = env else {
        let (accelerations, estimated) = accelerations_or_estimate(&r.recording, &ds.ship);
        return Ok(HydrodynamicRecording {
            recording: r.recording.clone(),
            accelerations,
            estimated,
            environment_removed: false,
        });
    };
    let water = env.water_relative(&r.recording);
    let (mut accelerations, estimated) = accelerations_or_estimate(&water, &ds.ship);
    if env.has_wind() {
        let mass = MassMatrix::new(&ds.ship, added);
        // Over-ground states: the air's velocity past the ship is the wind's minus the ship's over ground.
        let wind = env.wind_accelerations(&r.recording, &mass).ok_or_else(|| {
            bad_input(format!(
                "{}: the mass matrix of the ship with its [added_mass] is singular: the recorded wind in `{}` cannot be turned into accelerations",
                ds.path.display(),
                r.file
            ))
        })?;
        for (i, a) in wind.iter().enumerate() {
            accelerations.u_dot[i] -= a[0];
            accelerations.v_dot[i] -= a[1];
            accelerations.r_dot[i] -= a[2];
        }
    }
    Ok(HydrodynamicRecording {
        recording: water,
        accelerations,
        estimated,
        environment_removed: true,
    })
}

/// `model` feeling `env` when there is one (a replay or validation of a recording with a recorded
/// environment), else `model` itself.
pub fn with_environment<'a>(
    model: &'a dyn Dynamics,
    env: Option<KnownEnvironment>,
) -> Box<dyn Dynamics + 'a> {
    match env {
        Some(env) => Box::new(shipid_sim::WithEnvironment::new(model, env)),
        None => Box::new(model),
    }
}

/// `model` replaying `rec` with every input the recording gives it: the recorded propeller rate when
/// the model takes one (the mmg family; [`shipid_sim::WithPropellerRate`]) and the recorded wind and
/// current `env`. `t_start_s`: the recording time the simulation starts at (a segment's start; the
/// first sample for a whole replay).
pub fn with_recorded_inputs<'a>(
    model: &'a dyn Dynamics,
    rec: &Recording,
    t_start_s: f64,
    env: Option<KnownEnvironment>,
) -> Box<dyn Dynamics + 'a> {
    let rate = model
        .takes_propeller_rate()
        .then(|| RecordedRate::of_recording(rec))
        .flatten();
    let env = env.map(|e| e.replay_from(t_start_s));
    match (rate, env) {
        (Some(rate), env) => {
            let driven = shipid_sim::WithPropellerRate::new(model, rate.replay_from(t_start_s));
            match env {
                Some(env) => Box::new(shipid_sim::WithEnvironment::new(driven, env)),
                None => Box::new(driven),
            }
        }
        (None, env) => with_environment(model, env),
    }
}

/// What a model file records of the environment it was identified in (`[environment]`).
pub use shipid_model::EnvironmentRecord;

/// The `[environment]` record of a fit on the chosen recordings of `ds`: which recordings carried a
/// wind or a current that was removed, and with which windage. `None` when every one was calm.
pub fn environment_record(ds: &Dataset, chosen: &[&DatasetRecording]) -> Option<EnvironmentRecord> {
    let wind: Vec<String> = chosen
        .iter()
        .filter(|r| r.recording.wind.is_some())
        .map(|r| r.file.clone())
        .collect();
    let current: Vec<String> = chosen
        .iter()
        .filter(|r| r.recording.current.is_some())
        .map(|r| r.file.clone())
        .collect();
    if wind.is_empty() && current.is_empty() {
        return None;
    }
    let chosen_windage = ChosenWindage::of_dataset(ds);
    Some(EnvironmentRecord {
        removed: true,
        windage_assumed: !wind.is_empty() && chosen_windage.is_assumed(),
        windage: (!wind.is_empty()).then_some(chosen_windage.windage),
        wind_recordings: wind,
        current_recordings: current,
    })
}

/// Words on what a fit or validation does with the recorded environment of `recordings` (of `ds`):
/// per recording with a wind or current, that it is taken as a known input and with which windage.
/// Empty when every recording is calm.
pub fn environment_notes<'a>(
    ds: &Dataset,
    recordings: impl IntoIterator<Item = &'a DatasetRecording>,
    chosen: &ChosenWindage,
    what: &str,
) -> Vec<String> {
    // One note per kind of flow, naming its recordings: a data set of windy runs says it once.
    let mut by_flows: Vec<(&'static str, bool, Vec<&str>)> = Vec::new();
    for r in recordings {
        let (wind, current) = (r.recording.wind.is_some(), r.recording.current.is_some());
        let calm = |f: &Option<FlowSeries>| f.as_ref().is_none_or(FlowSeries::is_calm);
        let (wind_calm, current_calm) = (calm(&r.recording.wind), calm(&r.recording.current));
        let flows = match (wind, current) {
            (false, false) => continue,
            (true, true) if wind_calm && current_calm => "a recorded calm (wind and current zero)",
            (true, true) => "a recorded wind and current",
            (true, false) if wind_calm => "a recorded calm (wind zero throughout)",
            (true, false) => "a recorded wind",
            _ if current_calm => "a recorded calm (current zero throughout)",
            _ => "a recorded current",
        };
        match by_flows.iter_mut().find(|(f, _, _)| *f == flows) {
            Some((_, _, files)) => files.push(&r.file),
            None => by_flows.push((flows, wind, vec![&r.file])),
        }
    }
    by_flows
        .into_iter()
        .map(|(flows, wind, files)| {
            let windage = if wind {
                format!(", the wind's force with {}", chosen.describe())
            } else {
                String::new()
            };
            let (which, verb) = match files.as_slice() {
                [one] => (format!("`{one}`"), "carries"),
                many => (
                    format!(
                        "{} recordings ({})",
                        many.len(),
                        many.iter()
                            .map(|f| format!("`{f}`"))
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                    "carry",
                ),
            };
            format!(
                "{}: {which} {verb} {flows}; {what} takes it as a known input{windage}",
                ds.path.display()
            )
        })
        .collect()
}

/// How deep `base = …` chains of augmented model files are followed for their `[environment]`.
const MAX_BASE_DEPTH: usize = 8;

/// The `[environment]` a model file records (an augmented file's base's, when it has none of its
/// own); `None` for `mmg:…`, a file without one, or one that cannot be read (the loader names that
/// fault).
pub fn model_environment(spec: &str) -> Option<EnvironmentRecord> {
    let mut path = std::path::PathBuf::from(spec);
    for _ in 0..MAX_BASE_DEPTH {
        if spec.starts_with("mmg:") || !path.is_file() {
            return None;
        }
        let table = toml::from_str::<toml::Table>(&std::fs::read_to_string(&path).ok()?).ok()?;
        if let Some(env) = table.get("environment") {
            return env.clone().try_into().ok();
        }
        // Relative to the file that names it, as the loader resolves it.
        let base = table.get("base")?.as_str()?;
        path = match path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.join(base),
            _ => std::path::PathBuf::from(base),
        };
    }
    None
}

/// `[environment]` as TOML text, to append to a model file whose own format has no such table (the
/// mmg and sparse-GP files); the loaders read it apart ([`model_environment`]) and give the rest to
/// the format's reader ([`without_environment_table`]).
pub fn environment_table_text(record: &EnvironmentRecord) -> Result<String, PipelineError> {
    let mut table = toml::Table::new();
    table.insert(
        "environment".into(),
        toml::Value::try_from(record).map_err(crate::error::failed)?,
    );
    let text = toml::to_string(&table).map_err(crate::error::failed)?;
    Ok(format!(
        "\n# The recorded wind and current removed from the training recordings before identification (issue 27).\n{text}"
    ))
}

/// The text of the model file at `path` as its family's reader takes it ([`without_environment_table`]:
/// a fit in a recorded wind appends `[environment]`, which the mmg and sparse-GP formats do not
/// have), and its `kind` (`None` when missing or the text is not TOML: the reader names the fault).
pub fn model_file_family_text(
    path: &std::path::Path,
) -> Result<(String, Option<String>), shipid_io::InputError> {
    let text = std::fs::read_to_string(path)
        .map(|t| without_environment_table(&t))
        .map_err(|e| shipid_io::InputError::read(path, &e))?;
    let kind = toml::from_str::<toml::Table>(&text)
        .ok()
        .and_then(|t| t.get("kind").and_then(|k| k.as_str()).map(String::from));
    Ok((text, kind))
}

/// `text` with its `[environment]` table (and sub-tables) blanked line by line, so that a reader of a
/// format without it sees the rest with every line where it was (its error messages name the right
/// line).
pub fn without_environment_table(text: &str) -> String {
    let header = |line: &str| {
        let l = line.trim();
        let name = l
            .strip_prefix("[[")
            .and_then(|x| x.strip_suffix("]]"))
            .or_else(|| l.strip_prefix('[').and_then(|x| x.strip_suffix(']')));
        name.map(|n| n.trim().to_string())
    };
    let mut inside = false;
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        if let Some(name) = header(line) {
            inside = name == "environment" || name.starts_with("environment.");
        }
        if inside {
            if line.ends_with('\n') {
                out.push('\n');
            }
        } else {
            out.push_str(line);
        }
    }
    out
}
