//! Reading and writing data sets (`docs/data-format.md`): a TOML file beside its recordings.
//!
//! Three steps, as everywhere in the project: the raw TOML (unknown keys rejected, positions kept for
//! errors) → checked values → a [`Dataset`] in the project's conventions (midship origin, rudder positive
//! to starboard, SI). Conversions from `origin = "cg"` and `rudder_sign = -1` happen in [`Dataset::load`].

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{InputError, number};
use crate::open_water::read_open_water;
use crate::recording::read_recording;
use crate::types::{
    AddedMass, Manoeuvre, PropellerData, Recording, RudderData, Ship, Side, Windage,
};

/// The point that velocities and positions of a data set refer to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Origin {
    #[default]
    Midship,
    Cg,
    /// Another point of the hull (a sea trial's GNSS antenna): the `[reference_point]` table.
    Point,
}

/// `[reference_point]`: where the point that positions and velocities refer to lies on the hull
/// (with `origin = "point"`), in body axes from midship.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReferencePoint {
    /// Forward of midship [m] (negative aft).
    pub x_m: f64,
    /// To starboard of the centre line [m] (negative to port).
    pub y_m: f64,
}

/// `kind` of a recording entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    Zigzag,
    Turning,
    Free,
}

/// One `[[recording]]` entry as written in the file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingEntry {
    /// CSV file, relative to the data set file.
    pub file: String,
    pub kind: Kind,
    /// Commanded rudder amplitude [deg].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder: Option<f64>,
    /// Zig-zag heading check angle [deg].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<f64>,
    /// Side of the first rudder execute.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub side: Option<Side>,
}

/// A data set file as written (`docs/data-format.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetFile {
    pub name: String,
    #[serde(default)]
    pub origin: Origin,
    /// With `origin = "point"`: where that point lies.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference_point: Option<ReferencePoint>,
    #[serde(default = "one")]
    pub rudder_sign: i64,
    pub ship: Ship,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub added_mass: Option<AddedMass>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub propeller: Option<PropellerTable>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rudder: Option<RudderData>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub windage: Option<Windage>,
    #[serde(rename = "recording", default)]
    pub recordings: Vec<RecordingEntry>,
}

fn one() -> i64 {
    1
}

/// The `[propeller]` table as written: the open-water curve either as the quadratic's coefficients
/// (`k_t`) or as a CSV of points (`open_water`), at most one of them (neither: the documented default
/// curve, `types::DEFAULT_K_T`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropellerTable {
    /// Propeller diameter D_P [m].
    pub diameter_m: f64,
    /// Position forward of midship [m].
    pub x_m: f64,
    /// K_T(J) = k_t[0] + k_t[1] J + k_t[2] J².
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k_t: Option<Vec<f64>>,
    /// CSV with `J` and `K_T` columns, relative to the data set file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub open_water: Option<String>,
    /// Constant propeller rate [1/s] for recordings without an `n` column.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate_rps: Option<f64>,
}

/// A recording of a data set with the manoeuvre it performs.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetRecording {
    /// File name as given in the data set (relative to it); the recording's identity in results.
    pub file: String,
    pub manoeuvre: Manoeuvre,
    pub recording: Recording,
}

/// A loaded data set in the project's conventions.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// The data set file it was read from.
    pub path: PathBuf,
    pub name: String,
    pub ship: Ship,
    /// Added-mass derivatives about midship, when the data set gives them.
    pub added_mass: Option<AddedMass>,
    /// The propeller, when the data set gives a `[propeller]` table (the open-water file already read).
    pub propeller: Option<PropellerData>,
    /// The rudder, when the data set gives a `[rudder]` table.
    pub rudder: Option<RudderData>,
    /// The ship above water for the recorded wind, when the data set gives a `[windage]` table.
    pub windage: Option<Windage>,
    pub recordings: Vec<DatasetRecording>,
}

impl Dataset {
    /// Read a data set file and all its recordings.
    pub fn load(path: &Path) -> Result<Dataset, InputError> {
        Self::load_filtered(path, |_| true)
    }

    /// Read a data set but only the recordings whose file name `keep` accepts.
    pub fn load_filtered(path: &Path, keep: impl Fn(&str) -> bool) -> Result<Dataset, InputError> {
        let text = crate::recording::read_text(path)?;
        let file = parse_dataset(path, &text)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let propeller = file
            .propeller
            .as_ref()
            .map(|p| propeller_data(path, dir, p))
            .transpose()?;
        let mut recordings = Vec::new();
        let mut opened: Vec<(usize, FileIdentity)> = Vec::new();
        let mut copies: Vec<(usize, u64)> = Vec::new();
        // The data set's index of each recording read (`keep` may skip some).
        let mut entries: Vec<usize> = Vec::new();
        for (i, entry) in file.recordings.iter().enumerate() {
            if !keep(&entry.file) {
                continue;
            }
            let manoeuvre = manoeuvre_of(path, i, entry)?;
            let csv = dir.join(&entry.file);
            if let Some(why) = crate::recording::not_a_file(&csv) {
                return Err(InputError::key(
                    path,
                    format!("recording[{i}].file"),
                    format!("recording file `{}` {why}", csv.display()),
                ));
            }
            // Different names of one file (a link, `sub/../a.csv`, a hard link) are caught here, where
            // the files exist.
            if let Ok(real) = csv.canonicalize() {
                let real = file_identity(&real);
                if let Some((j, _)) = opened.iter().find(|(_, p)| *p == real) {
                    return Err(InputError::key(
                        path,
                        format!("recording[{i}].file"),
                        format!(
                            "`{}` is the same file as recording[{j}].file `{}`; list each recording once",
                            entry.file, file.recordings[*j].file
                        ),
                    ));
                }
                opened.push((i, real));
            }
            let mut recording = read_recording(&csv)?;
            if let Some(p) = &file.propeller
                && p.rate_rps.is_none()
                && recording.n.is_none()
            {
                return Err(InputError::key(
                    path,
                    "propeller.rate_rps",
                    format!(
                        "needed: recording[{i}] `{}` has no `n` column, and the model family that uses [propeller] needs the propeller rate (give the constant rate_rps, or record n)",
                        entry.file
                    ),
                ));
            }
            // A copy of a file under another name is the same recording counted twice.
            let fingerprint = samples_fingerprint(&recording);
            if let Some((j, _)) = copies.iter().find(|(_, f)| *f == fingerprint) {
                return Err(InputError::key(
                    path,
                    format!("recording[{i}].file"),
                    format!(
                        "`{}` holds the same samples as recording[{j}].file `{}` (a copy): list each recording once",
                        entry.file, file.recordings[*j].file
                    ),
                ));
            }
            copies.push((i, fingerprint));
            to_project_conventions(&mut recording, &file);
            crate::consistency::check_channels(
                &csv,
                &recording,
                &manoeuvre,
                file.ship.lpp,
                file.ship.u0,
            )?;
            if let Some(p) = &file.propeller {
                crate::consistency::check_advance_ratio(
                    &csv,
                    &recording,
                    p.diameter_m,
                    file.ship.u0,
                )?;
            }
            if let Some(p) = &propeller {
                crate::consistency::check_propeller_loading(
                    &csv,
                    &recording,
                    p,
                    file.ship.rho,
                    file.ship.u0,
                )?;
            }
            entries.push(i);
            recordings.push(DatasetRecording {
                file: entry.file.clone(),
                manoeuvre,
                recording,
            });
        }
        refuse_near_copies(path, &recordings, &entries)?;
        // Added masses of a data set at another point of the hull (a GNSS antenna) are given about
        // midship: nobody computes them about an antenna.
        let added_mass = file.added_mass.map(|a| match file.origin {
            Origin::Midship | Origin::Point => a,
            Origin::Cg => added_mass_cg_to_midship(a, file.ship.xg),
        });
        Ok(Dataset {
            path: path.to_path_buf(),
            name: file.name,
            ship: file.ship,
            added_mass,
            propeller,
            rudder: file.rudder,
            windage: file.windage,
            recordings,
        })
    }

    /// The recording with this file name.
    pub fn recording(&self, file: &str) -> Option<&DatasetRecording> {
        // As written in the data set first; then as the loader opens it, so that `sub/a.csv` names
        // an entry written `./sub//a.csv` (it was refused as "not in the data set").
        self.recordings.iter().find(|r| r.file == file).or_else(|| {
            let wanted = normalised(file);
            self.recordings
                .iter()
                .find(|r| normalised(&r.file) == wanted)
        })
    }
}

/// What loading `ds` noticed that does not make it unusable, one message each (naming the data set
/// file and the key): a `[propeller] rate_rps` that no recording uses because every one records `n`
/// (a rate 5 1/s beside a recorded 11.85 1/s was ignored without a word).
pub fn load_notes(ds: &Dataset) -> Vec<String> {
    let mut notes = Vec::new();
    if let Some(rate) = ds.propeller.as_ref().and_then(|p| p.rate_rps)
        && !ds.recordings.is_empty()
        && ds.recordings.iter().all(|r| r.recording.n.is_some())
    {
        let recorded: Vec<f64> = ds
            .recordings
            .iter()
            .filter_map(|r| r.recording.n.as_ref())
            .flatten()
            .copied()
            .filter(|n| n.is_finite())
            .collect();
        let median = crate::consistency::upper_median(&recorded).unwrap_or(f64::NAN);
        let differs = if (rate / median - 1.0).abs() > 0.02 {
            ", a different rate: check which one is the ship's"
        } else {
            ""
        };
        notes.push(format!(
            "{}: key `propeller.rate_rps` = {} 1/s is not used: every recording has an `n` column (median {} 1/s){differs}",
            ds.path.display(),
            number(rate),
            number(four_digits(median))
        ));
    }
    notes
}

/// `x` rounded to four significant digits, for a message.
fn four_digits(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(3 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// Parse and check a data set file's text; `path` names it in errors.
pub fn parse_dataset(path: &Path, text: &str) -> Result<DatasetFile, InputError> {
    let file: DatasetFile = toml::from_str(text).map_err(|e| InputError::toml(path, text, &e))?;
    if file.rudder_sign != 1 && file.rudder_sign != -1 {
        return Err(InputError::key(
            path,
            "rudder_sign",
            format!("must be 1 or -1, not {}", file.rudder_sign),
        ));
    }
    check_ship(path, &file.ship)?;
    let s = &file.ship;
    if let Some((key, message)) = hardware_fault_placed(
        s,
        file.propeller.as_ref().map(|p| (p.diameter_m, p.x_m)),
        file.rudder.as_ref().map(|r| (r.area_m2, r.span_m, r.x_m)),
    ) {
        return Err(InputError::key(path, key, message));
    }

    check_reference_point(path, &file)?;
    if let Some(a) = &file.added_mass {
        check_added_mass(path, a, s)?;
    }
    check_distinct_recordings(path, &file.recordings)?;
    if let Some(p) = &file.propeller {
        check_propeller(path, p, s.lpp)?;
        if let Some(msg) = p
            .rate_rps
            .and_then(|n| crate::consistency::rate_rps_problem(n, p.diameter_m, s.u0))
        {
            return Err(InputError::key(path, "propeller.rate_rps", msg));
        }
    }
    if let Some(r) = &file.rudder {
        check_rudder(path, r, s.lpp)?;
    }
    if let Some(w) = &file.windage {
        check_windage(path, w, s.lpp)?;
    }
    for (i, entry) in file.recordings.iter().enumerate() {
        manoeuvre_of(path, i, entry)?;
    }
    Ok(file)
}

/// The checks of a `[ship]` table wherever it is read (a data set, a model file): every key a
/// positive finite number within its physical range, x_G on the hull, and the proportions of a ship.
pub fn check_ship(path: &Path, s: &Ship) -> Result<(), InputError> {
    let positive = [
        ("lpp", s.lpp),
        ("beam", s.beam),
        ("draft", s.draft),
        ("displacement", s.displacement),
        ("rho", s.rho),
        ("kzz", s.kzz),
        ("u0", s.u0),
        ("rudder_rate", s.rudder_rate),
    ];
    for (key, value) in positive {
        if !(value.is_finite() && value > 0.0) {
            return Err(InputError::key(
                path,
                format!("ship.{key}"),
                format!("must be a positive number, not {}", number(value)),
            ));
        }
    }
    if !s.xg.is_finite() || s.xg.abs() > s.lpp {
        return Err(InputError::key(
            path,
            "ship.xg",
            format!(
                "must be a finite distance within the ship length, not {}",
                number(s.xg)
            ),
        ));
    }
    check_ship_ranges(path, s)?;
    check_ship_proportions(path, s)
}

/// Physical ranges of the ship keys (`docs/data-format.md`): from a small tank model to the largest
/// ships with a wide margin. Outside them a value is a wrong unit or a typo, and prime scaling by it
/// (division by L, U0, the mass) would overflow or vanish downstream.
pub const SHIP_RANGES: [(&str, f64, f64, &str); 8] = [
    ("lpp", 1e-2, 1e4, "m"),
    ("beam", 1e-3, 1e4, "m"),
    ("draft", 1e-3, 1e4, "m"),
    ("displacement", 1e-9, 1e10, "m³"),
    ("rho", 500.0, 2000.0, "kg/m³"),
    ("kzz", 1e-3, 1e4, "m"),
    ("u0", 1e-3, 1e3, "m/s"),
    // Steering gears turn at 2.3 °/s at least at full scale (SOLAS II-1/29), faster at model scale:
    // below 1 °/s the rate is in rad/s or a typo.
    ("rudder_rate", 1.0, 1e4, "deg/s"),
];

/// `origin = "point"` needs its `[reference_point]` on the hull; the table means nothing with
/// another origin.
fn check_reference_point(path: &Path, file: &DatasetFile) -> Result<(), InputError> {
    match (file.origin, file.reference_point) {
        (Origin::Point, None) => Err(InputError::key(
            path,
            "reference_point",
            "origin = \"point\" needs a [reference_point] table with x_m (forward of midship) and y_m (to starboard) [m]",
        )),
        (Origin::Point, Some(p)) => {
            let s = &file.ship;
            for (key, value, limit, what) in [
                ("x_m", p.x_m, s.lpp, "ship.lpp"),
                ("y_m", p.y_m, s.beam, "ship.beam"),
            ] {
                if !(value.is_finite() && value.abs() <= limit) {
                    return Err(InputError::key(
                        path,
                        format!("reference_point.{key}"),
                        format!(
                            "must be a finite distance from midship within {what} = {limit} m (a point on the hull), not {}",
                            number(value)
                        ),
                    ));
                }
            }
            Ok(())
        }
        (origin, Some(_)) => Err(InputError::key(
            path,
            "reference_point",
            format!(
                "only with origin = \"point\" (this data set says origin = \"{}\")",
                match origin {
                    Origin::Cg => "cg",
                    _ => "midship",
                }
            ),
        )),
        _ => Ok(()),
    }
}

fn check_ship_ranges(path: &Path, s: &Ship) -> Result<(), InputError> {
    let values = [
        s.lpp,
        s.beam,
        s.draft,
        s.displacement,
        s.rho,
        s.kzz,
        s.u0,
        s.rudder_rate,
    ];
    for ((key, lo, hi, unit), v) in SHIP_RANGES.iter().zip(values) {
        if !(*lo..=*hi).contains(&v) {
            return Err(InputError::key(
                path,
                format!("ship.{key}"),
                format!(
                    "{} {unit} is outside the physical range {} … {} {unit} (a wrong unit?)",
                    number(v),
                    number(*lo),
                    number(*hi)
                ),
            ));
        }
    }
    Ok(())
}

/// Each ship key may be within its range and the ship still impossible: a displacement given as the
/// mass in tonnes (block coefficient 800), a length in mm beside a beam in m, a radius of gyration of
/// 25 L. Every fitted coefficient is scaled by these, so the proportions are checked too, with margins
/// wide enough for barges, catamarans and fine naval hulls.
fn check_ship_proportions(path: &Path, s: &Ship) -> Result<(), InputError> {
    let block = s.displacement / (s.lpp * s.beam * s.draft);
    // Proportions of the hull first: a length in another unit shows there, not as a block coefficient.
    let checks = [
        (
            "ship.beam",
            s.lpp / s.beam,
            (1.0, 30.0),
            "length-beam ratio L/B",
            "ships have about 3 … 12; L and B in different units?",
        ),
        (
            "ship.draft",
            s.beam / s.draft,
            (0.3, 40.0),
            "beam-draft ratio B/T",
            "ships have about 2 … 6; B and T in different units?",
        ),
        (
            "ship.displacement",
            block,
            (0.1, 1.05),
            "block coefficient ∇/(L B T)",
            "ships have about 0.35 … 0.9; a mass in t or kg given as the volume in m³, or L, B, T in another unit?",
        ),
        (
            "ship.xg",
            s.xg / s.lpp,
            (-0.25, 0.25),
            "centre of gravity x_G/L",
            "ships have about −0.05 … +0.05 (from midship, positive forward); x_G from the aft perpendicular, or in another unit?",
        ),
        (
            "ship.kzz",
            s.kzz / s.lpp,
            (0.05, 1.0),
            "yaw radius of gyration k_zz/L",
            "ships have about 0.2 … 0.3; k_zz is a radius in m, not a moment of inertia",
        ),
    ];
    for (key, value, (lo, hi), what, hint) in checks {
        if !(lo..=hi).contains(&value) {
            return Err(InputError::key(
                path,
                key,
                format!(
                    "gives a {what} of {} (accepted {} … {}): {hint}",
                    three_digits(value),
                    number(lo),
                    number(hi)
                ),
            ));
        }
    }
    Ok(())
}

/// A rudder span beyond this many drafts is a unit slip (mm for m): a rudder reaches below the keel
/// only a little, and a ship trimmed in ballast has a shallower draft beside the same rudder, hence
/// the margin; the rudder's aspect ratio, which sets its lift slope, would take it at face value.
pub const MAX_RUDDER_SPAN_OVER_DRAFT: f64 = 2.0;

/// Propeller and rudder sizes no ship has, as (key, message): a propeller diameter not shorter than
/// the ship or beyond [`MAX_RUDDER_SPAN_OVER_DRAFT`] drafts, a rudder area of half the hull's lateral
/// area L T or more, a rudder span beyond [`MAX_RUDDER_SPAN_OVER_DRAFT`] drafts or below the
/// propeller's diameter. The checks of a data set's `[propeller]` and `[rudder]` and of a model
/// file's (the mmg family's); positivity and finiteness are the caller's. With the positions at
/// hand, call [`hardware_fault_placed`], which adds theirs.
pub fn hardware_fault(
    ship: &Ship,
    propeller_diameter_m: Option<f64>,
    rudder_area_and_span_m: Option<(f64, f64)>,
) -> Option<(&'static str, String)> {
    if let Some(d) = propeller_diameter_m
        && d >= ship.lpp
    {
        return Some((
            "propeller.diameter_m",
            format!(
                "{} m is not shorter than the ship (ship.lpp = {} m): a wrong unit?",
                number(d),
                number(ship.lpp)
            ),
        ));
    }
    // A propeller works below the waterline: one several drafts across is a unit slip, and it
    // would be taken for the rudder span's fault below.
    if let Some(d) = propeller_diameter_m
        && d / ship.draft > MAX_RUDDER_SPAN_OVER_DRAFT
    {
        return Some((
            "propeller.diameter_m",
            format!(
                "{} m is {} × the draft ship.draft = {} m (a propeller's diameter is about 0.5 … 0.8 × the draft; at most {MAX_RUDDER_SPAN_OVER_DRAFT} × is accepted): a wrong unit?",
                number(d),
                three_digits(d / ship.draft),
                number(ship.draft)
            ),
        ));
    }
    let (area, span) = rudder_area_and_span_m?;
    let share = area / (ship.lpp * ship.draft);
    if share.is_finite() && share > 0.5 {
        return Some((
            "rudder.area_m2",
            format!(
                "{} m² is {} × L T (rudders have about 1/70 … 1/30 of it): a wrong unit?",
                number(area),
                three_digits(share)
            ),
        ));
    }
    let drafts = span / ship.draft;
    if drafts.is_finite() && drafts > MAX_RUDDER_SPAN_OVER_DRAFT {
        return Some((
            "rudder.span_m",
            format!(
                "{} m is {} × the draft ship.draft = {} m (a rudder's span is about the draft or less; at most {MAX_RUDDER_SPAN_OVER_DRAFT} × is accepted): a wrong unit?",
                number(span),
                three_digits(drafts),
                number(ship.draft)
            ),
        ));
    }
    // η = D/H_R is the share of the rudder span in the propeller's slipstream: above 1 the MMG
    // rudder inflow takes more than the whole slipstream (a 0.05 m span behind a 0.216 m propeller
    // turned in 0.89 L with "status ok").
    if let Some(d) = propeller_diameter_m
        && span < d
    {
        return Some((
            "rudder.span_m",
            format!(
                "{} m is smaller than the propeller's diameter propeller.diameter_m = {} m: the share of the rudder in the slipstream, η = D/H_R = {}, would exceed 1 (a rudder's span is about 1.2 … 2 × the diameter); rudder.span_m or propeller.diameter_m in another unit?",
                number(span),
                number(d),
                three_digits(d / span)
            ),
        ));
    }
    None
}

/// [`hardware_fault`] with the positions of the propeller (diameter, x) and the rudder (area, span,
/// x), forward of midship: the MMG structure is a stern propeller with the rudder behind it in its
/// slipstream, so a propeller or rudder at or forward of midship is a sign slip (aft is negative; a
/// rudder at +3.5 m instead of −3.5 m doubled the predicted turn), and a rudder forward of the
/// propeller gets no slipstream. Positions within the ship are the caller's.
pub fn hardware_fault_placed(
    ship: &Ship,
    propeller: Option<(f64, f64)>,
    rudder: Option<(f64, f64, f64)>,
) -> Option<(&'static str, String)> {
    if let Some(fault) = hardware_fault(
        ship,
        propeller.map(|(d, _)| d),
        rudder.map(|(area, span, _)| (area, span)),
    ) {
        return Some(fault);
    }
    // A position off the hull has its own message at the caller.
    let on_hull = |x: f64| x.is_finite() && x.abs() <= ship.lpp;
    let propeller = propeller.filter(|p| on_hull(p.1));
    let rudder = rudder.filter(|r| on_hull(r.2));
    for (key, x, what) in [
        ("propeller.x_m", propeller.map(|p| p.1), "propeller"),
        ("rudder.x_m", rudder.map(|r| r.2), "rudder"),
    ] {
        if let Some(x) = x
            && x >= 0.0
        {
            return Some((
                key,
                format!(
                    "{} m is at or forward of midship, where the MMG model has no {what}: positions are forward of midship, aft is negative ({})",
                    number(x),
                    if x == 0.0 {
                        "0 is midship itself".to_string()
                    } else {
                        format!("a sign slip? write {}", number(-x))
                    }
                ),
            ));
        }
    }
    if let (Some((_, x_p)), Some((_, _, x_r))) = (propeller, rudder)
        && x_r >= x_p
    {
        return Some((
            "rudder.x_m",
            format!(
                "{} m puts the rudder forward of the propeller (propeller.x_m = {} m): the MMG rudder sits behind the propeller, in its slipstream (aft is more negative; the two positions swapped?)",
                number(x_r),
                number(x_p)
            ),
        ));
    }
    None
}

/// A ratio as a message shows it: three significant digits.
fn three_digits(x: f64) -> String {
    match x.abs() {
        a if a >= 100.0 => format!("{x:.0}"),
        a if a >= 10.0 => format!("{x:.1}"),
        a if a >= 1.0 => format!("{x:.2}"),
        _ => format!("{x:.3}"),
    }
}

/// Added masses are finite and at most 100 times the ship's mass (times L, L² for the moment terms):
/// real hulls have about 0.02 … 1 times, so anything beyond is a unit or sign-of-magnitude slip that
/// would dominate every fitted force.
pub fn check_added_mass(path: &Path, a: &AddedMass, s: &Ship) -> Result<(), InputError> {
    let m = s.mass_kg();
    let l = s.lpp;
    let entries = [
        ("X_udot", a.X_udot, m, "kg"),
        ("Y_vdot", a.Y_vdot, m, "kg"),
        ("Y_rdot", a.Y_rdot, m * l, "kg m"),
        ("N_vdot", a.N_vdot, m * l, "kg m"),
        ("N_rdot", a.N_rdot, m * l * l, "kg m²"),
    ];
    for (key, value, scale, unit) in entries {
        // The diagonal derivatives are minus the added masses, which are positive for any body.
        if matches!(key, "X_udot" | "Y_vdot" | "N_rdot") && value > 0.0 {
            return Err(InputError::key(
                path,
                format!("added_mass.{key}"),
                format!(
                    "{} {unit} is positive; it is a derivative, minus the added mass (write {})",
                    number(value),
                    number(-value)
                ),
            ));
        }
        if !value.is_finite() || value.abs() > 100.0 * scale {
            return Err(InputError::key(
                path,
                format!("added_mass.{key}"),
                format!(
                    "{} {unit} is not a finite added mass within 100 × the ship's (±{} {unit} for this ship)",
                    number(value),
                    number(100.0 * scale)
                ),
            ));
        }
    }
    // The sway-yaw block of the mass matrix about midship must be positive definite: a ship that
    // accelerates against the force pushing it simulates without a word (`Y_vdot = 1e6`: "ok").
    let m22 = m - a.Y_vdot;
    let m33 = m * (s.kzz * s.kzz + s.xg * s.xg) - a.N_rdot;
    let (m23, m32) = (m * s.xg - a.Y_rdot, m * s.xg - a.N_vdot);
    if !(m22 > 0.0 && m33 > 0.0 && m22 * m33 - m23 * m32 > 0.0) {
        return Err(InputError::key(
            path,
            "added_mass",
            "with these added masses the sway-yaw mass matrix of the ship is not positive definite (the ship would accelerate against the force that pushes it): check the signs and units of Y_vdot, Y_rdot, N_vdot and N_rdot",
        ));
    }
    Ok(())
}

/// A hash of every sample of the channels that define a motion: equal for a copy of a file, also
/// when the copy's clock or track starts elsewhere (time and positions are taken from their first
/// sample, to a micro-unit, so the subtraction's rounding does not tell copies apart).
/// A recording that holds a part of another's samples (cut, thinned, rewritten, its track turned):
/// refused as the byte-for-byte copy is, naming the span of the other it holds.
fn refuse_near_copies(
    path: &Path,
    recordings: &[DatasetRecording],
    entries: &[usize],
) -> Result<(), InputError> {
    let indexes: Vec<crate::copies::CopyIndex> = recordings
        .iter()
        .map(|r| crate::copies::CopyIndex::new(&r.recording))
        .collect();
    for later in 1..recordings.len() {
        for earlier in 0..later {
            let (a, b) = (&recordings[earlier], &recordings[later]);
            let found = crate::copies::copied_span(&a.recording, &indexes[earlier], &b.recording)
                .map(|span| (a, b, entries[earlier], span))
                .or_else(|| {
                    crate::copies::copied_span(&b.recording, &indexes[later], &a.recording)
                        .map(|span| (b, a, entries[later], span))
                });
            if let Some((whole, part, whole_entry, (t0, t1))) = found {
                return Err(InputError::key(
                    path,
                    format!("recording[{}].file", entries[later]),
                    format!(
                        "`{}` holds the samples of recording[{whole_entry}].file `{}` from t = {t0:.2} s to {t1:.2} s of its clock (a cut, thinned or rewritten copy, or one with its track turned): list each recording once",
                        part.file, whole.file
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn samples_fingerprint(rec: &Recording) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for channel in [&rec.t, &rec.x0, &rec.y0] {
        let first = channel.first().copied().unwrap_or(0.0);
        channel.len().hash(&mut h);
        channel
            .iter()
            .for_each(|x| (((x - first) * 1e6).round() as i64).hash(&mut h));
    }
    for channel in [&rec.psi, &rec.u, &rec.v, &rec.r, &rec.delta] {
        channel.len().hash(&mut h);
        channel.iter().for_each(|x| x.to_bits().hash(&mut h));
    }
    h.finish()
}

/// What makes two paths one file: the canonical path, and on Unix the device and inode too, which
/// a hard link shares under another name.
#[derive(Debug, PartialEq)]
enum FileIdentity {
    Path(PathBuf),
    #[cfg(unix)]
    Inode(u64, u64),
}

fn file_identity(canonical: &Path) -> FileIdentity {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let Ok(m) = std::fs::metadata(canonical) {
            return FileIdentity::Inode(m.dev(), m.ino());
        }
    }
    FileIdentity::Path(canonical.to_path_buf())
}

/// A recording file name without `.` components and repeated separators: `./a.csv`, `a.csv` and
/// `sub//a.csv` name files the way the loader opens them.
fn normalised(file: &str) -> String {
    file.split(['/', '\\'])
        .filter(|c| !c.is_empty() && *c != ".")
        .collect::<Vec<_>>()
        .join("/")
}

/// Each recording may be listed once: a second entry would count it twice in fits and validation,
/// and results keyed by file name would keep only one of them.
fn check_distinct_recordings(path: &Path, entries: &[RecordingEntry]) -> Result<(), InputError> {
    let mut seen: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for (i, e) in entries.iter().enumerate() {
        if let Some(j) = seen.insert(normalised(&e.file), i) {
            return Err(InputError::key(
                path,
                format!("recording[{i}].file"),
                format!(
                    "`{}` is the same file as recording[{j}].file `{}`; list each recording once",
                    e.file, entries[j].file
                ),
            ));
        }
    }
    Ok(())
}

fn positive(path: &Path, key: &str, value: f64) -> Result<(), InputError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(InputError::key(
            path,
            key,
            format!("must be a positive number, not {}", number(value)),
        ))
    }
}

/// A position along the hull: finite and within one ship length of midship.
fn position(path: &Path, key: &str, value: f64, lpp: f64) -> Result<(), InputError> {
    if value.is_finite() && value.abs() <= lpp {
        Ok(())
    } else {
        Err(InputError::key(
            path,
            key,
            format!(
                "must be a finite distance from midship within the ship length ship.lpp = {lpp} m, not {}",
                number(value)
            ),
        ))
    }
}

fn check_propeller(path: &Path, p: &PropellerTable, lpp: f64) -> Result<(), InputError> {
    positive(path, "propeller.diameter_m", p.diameter_m)?;
    position(path, "propeller.x_m", p.x_m, lpp)?;
    if let Some(n) = p.rate_rps {
        positive(path, "propeller.rate_rps", n)?;
    }
    match (&p.k_t, &p.open_water) {
        // Neither: the documented default curve (`types::DEFAULT_K_T`), said wherever it is used.
        (None, None) => Ok(()),
        (Some(_), Some(_)) => Err(InputError::key(
            path,
            "propeller",
            "give either `k_t` or `open_water`, not both",
        )),
        (Some(k), None) => {
            if k.len() != 3 {
                return Err(InputError::key(
                    path,
                    "propeller.k_t",
                    format!(
                        "must hold three coefficients [k0, k1, k2] of K_T(J) = k0 + k1 J + k2 J², not {}",
                        k.len()
                    ),
                ));
            }
            if let Some(bad) = k.iter().find(|v| !v.is_finite()) {
                return Err(InputError::key(
                    path,
                    "propeller.k_t",
                    format!("coefficients must be finite, not {bad}"),
                ));
            }
            if k[0] <= 0.0 {
                return Err(InputError::key(
                    path,
                    "propeller.k_t",
                    format!(
                        "K_T at J = 0 (the first coefficient) must be positive, not {}",
                        k[0]
                    ),
                ));
            }
            let k = [k[0], k[1], k[2]];
            if let Some(problem) = crate::open_water::k_t_coefficients_problem(&k) {
                return Err(InputError::key(path, "propeller.k_t", problem));
            }
            Ok(())
        }
        (None, Some(f)) if f.trim().is_empty() => Err(InputError::key(
            path,
            "propeller.open_water",
            "must name a CSV file",
        )),
        (None, Some(_)) => Ok(()),
    }
}

fn check_rudder(path: &Path, r: &RudderData, lpp: f64) -> Result<(), InputError> {
    positive(path, "rudder.area_m2", r.area_m2)?;
    positive(path, "rudder.span_m", r.span_m)?;
    position(path, "rudder.x_m", r.x_m, lpp)
}

fn check_windage(path: &Path, w: &Windage, lpp: f64) -> Result<(), InputError> {
    positive(path, "windage.frontal_area_m2", w.frontal_area_m2)?;
    positive(path, "windage.lateral_area_m2", w.lateral_area_m2)?;
    position(
        path,
        "windage.lateral_centre_x_m",
        w.lateral_centre_x_m,
        lpp,
    )?;
    // Air between a high-altitude lake and a cold, dense sea-level day, with room to spare.
    if !(0.5..=2.0).contains(&w.air_density_kg_m3) {
        return Err(InputError::key(
            path,
            "windage.air_density_kg_m3",
            format!(
                "must lie between 0.5 and 2.0 kg/m³ (sea level: 1.225), not {}",
                number(w.air_density_kg_m3)
            ),
        ));
    }
    for (key, value) in [
        ("windage.length_overall_m", w.length_overall_m),
        ("windage.lateral_centre_height_m", w.lateral_centre_height_m),
        ("windage.height_m", w.height_m),
        ("windage.lateral_perimeter_m", w.lateral_perimeter_m),
    ] {
        if let Some(v) = value {
            positive(path, key, v)?;
        }
    }
    // Isherwood's regression has no default for these: refused at load, not at the first wind.
    if w.model == crate::types::WindModel::Isherwood1973 {
        for (key, value, what) in [
            (
                "windage.length_overall_m",
                w.length_overall_m,
                "length overall [m]",
            ),
            (
                "windage.lateral_perimeter_m",
                w.lateral_perimeter_m,
                "perimeter of the lateral projection above water [m]",
            ),
        ] {
            if value.is_none() {
                return Err(InputError::key(
                    path,
                    key,
                    format!(
                        "model = \"isherwood1973\" needs the {what} (docs/data-format.md, [windage])"
                    ),
                ));
            }
        }
    }
    if let Some(a) = w.superstructure_lateral_area_m2
        && !(a.is_finite() && a >= 0.0 && a <= w.lateral_area_m2)
    {
        return Err(InputError::key(
            path,
            "windage.superstructure_lateral_area_m2",
            format!(
                "must lie between 0 and windage.lateral_area_m2 = {} m², not {}",
                w.lateral_area_m2,
                number(a)
            ),
        ));
    }
    Ok(())
}

/// A checked `[propeller]` table → [`PropellerData`], reading the open-water CSV beside the data set.
fn propeller_data(
    path: &Path,
    dir: &Path,
    p: &PropellerTable,
) -> Result<PropellerData, InputError> {
    let (k_t, open_water) = match (&p.k_t, &p.open_water) {
        (Some(k), _) => ([k[0], k[1], k[2]], None),
        (None, Some(f)) => {
            let csv = dir.join(f);
            if let Some(why) = crate::recording::not_a_file(&csv) {
                return Err(InputError::key(
                    path,
                    "propeller.open_water",
                    format!("open-water file `{}` {why}", csv.display()),
                ));
            }
            let (k, curve) = read_open_water(&csv, f)?;
            if k[0] <= 0.0 {
                return Err(InputError::file(
                    &csv,
                    format!(
                        "the quadratic through the open-water points gives K_T = {} at J = 0; it must be positive",
                        k[0]
                    ),
                ));
            }
            (k, Some(curve))
        }
        (None, None) => (crate::types::DEFAULT_K_T, None),
    };
    let k_t_default = (p.k_t.is_none() && p.open_water.is_none())
        .then(|| crate::types::DEFAULT_K_T_SOURCE.to_string());
    Ok(PropellerData {
        diameter_m: p.diameter_m,
        x_m: p.x_m,
        k_t,
        open_water,
        k_t_default,
        rate_rps: p.rate_rps,
    })
}

fn manoeuvre_of(path: &Path, i: usize, e: &RecordingEntry) -> Result<Manoeuvre, InputError> {
    // A key the kind has no use for was silently ignored (a `turning` entry with a `check`): it
    // says the entry means another manoeuvre than the one it is read as.
    let unused: &[(&str, bool)] = match e.kind {
        Kind::Zigzag => &[],
        Kind::Turning => &[("check", e.check.is_some())],
        Kind::Free => &[
            ("rudder", e.rudder.is_some()),
            ("check", e.check.is_some()),
            ("side", e.side.is_some()),
        ],
    };
    if let Some((key, _)) = unused.iter().find(|(_, given)| *given) {
        return Err(InputError::key(
            path,
            format!("recording[{i}].{key}"),
            format!(
                "does not apply to kind = \"{}\" (a zigzag has rudder, check and side; a turning circle rudder and side; a free manoeuvre none)",
                kind_word(e.kind)
            ),
        ));
    }
    // The standard manoeuvres' controllers take a rudder up to 90° and a check angle up to 180°; a
    // larger value failed later as a "diverged" simulation instead of as the input it is.
    let need = |key: &str, v: Option<f64>| -> Result<f64, InputError> {
        let limit_deg = if key == "check" { 180.0 } else { 90.0 };
        match v {
            Some(x) if x.is_finite() && x > 0.0 && x <= limit_deg => Ok(x),
            Some(x) if x.is_finite() && x > limit_deg => Err(InputError::key(
                path,
                format!("recording[{i}].{key}"),
                format!("{x}° is above the {limit_deg}° a {key} angle can be (in degrees?)"),
            )),
            Some(x) => Err(InputError::key(
                path,
                format!("recording[{i}].{key}"),
                format!("must be a positive angle in degrees, not {x}"),
            )),
            None => Err(InputError::key(
                path,
                format!("recording[{i}].{key}"),
                format!("required for kind = \"{}\"", kind_word(e.kind)),
            )),
        }
    };
    let side = || {
        e.side.ok_or_else(|| {
            InputError::key(
                path,
                format!("recording[{i}].side"),
                format!(
                    "required for kind = \"{}\" (\"port\" or \"starboard\")",
                    kind_word(e.kind)
                ),
            )
        })
    };
    Ok(match e.kind {
        Kind::Zigzag => Manoeuvre::ZigZag {
            rudder_deg: need("rudder", e.rudder)?,
            check_deg: need("check", e.check)?,
            side: side()?,
        },
        Kind::Turning => Manoeuvre::Turning {
            rudder_deg: need("rudder", e.rudder)?,
            side: side()?,
        },
        Kind::Free => Manoeuvre::Free,
    })
}

fn kind_word(k: Kind) -> &'static str {
    match k {
        Kind::Zigzag => "zigzag",
        Kind::Turning => "turning",
        Kind::Free => "free",
    }
}

/// The data set entry that describes a manoeuvre (inverse of the loader's interpretation).
pub fn entry_for(file: &str, m: &Manoeuvre) -> RecordingEntry {
    match *m {
        Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side,
        } => RecordingEntry {
            file: file.into(),
            kind: Kind::Zigzag,
            rudder: Some(rudder_deg),
            check: Some(check_deg),
            side: Some(side),
        },
        Manoeuvre::Turning { rudder_deg, side } => RecordingEntry {
            file: file.into(),
            kind: Kind::Turning,
            rudder: Some(rudder_deg),
            check: None,
            side: Some(side),
        },
        Manoeuvre::Free => RecordingEntry {
            file: file.into(),
            kind: Kind::Free,
            rudder: None,
            check: None,
            side: None,
        },
    }
}

/// Rudder sign and reference point of the source → the project's (midship, rudder + to starboard).
fn to_project_conventions(rec: &mut Recording, file: &DatasetFile) {
    if file.rudder_sign == -1 {
        rec.delta.iter_mut().for_each(|d| *d = -*d);
    }
    match (file.origin, file.reference_point) {
        (Origin::Cg, _) => cg_to_midship(rec, file.ship.xg),
        (Origin::Point, Some(p)) => point_to_midship(rec, p.x_m, p.y_m),
        _ => {}
    }
}

/// Midship lies x_G aft of the centre of gravity: [`point_to_midship`] from (x_G, 0).
pub fn cg_to_midship(rec: &mut Recording, xg_m: f64) {
    point_to_midship(rec, xg_m, 0.0);
}

/// Positions and velocities of the hull point (`x_m` forward, `y_m` to starboard of midship) → of
/// midship. The point moves with the hull: its velocity in body axes is (u − r y, v + r x), its
/// position is midship's plus (x, y) turned by the heading; r is the same everywhere.
pub fn point_to_midship(rec: &mut Recording, x_m: f64, y_m: f64) {
    for i in 0..rec.len() {
        let (s, c) = rec.psi[i].sin_cos();
        rec.x0[i] -= x_m * c - y_m * s;
        rec.y0[i] -= x_m * s + y_m * c;
        rec.u[i] += y_m * rec.r[i];
        rec.v[i] -= x_m * rec.r[i];
    }
    if let Some(a) = rec.accelerations.as_mut() {
        for i in 0..a.v_dot.len() {
            a.u_dot[i] += y_m * a.r_dot[i];
            a.v_dot[i] -= x_m * a.r_dot[i];
        }
    }
}

/// Added-mass derivatives about the centre of gravity → about midship. With midship velocities
/// ν_M = (u, v_M, r) and v_G = v_M + x_G r, kinetic energy invariance gives A_M = Hᵀ A_G H with
/// H = [[1,0,0],[0,1,x_G],[0,0,1]].
pub fn added_mass_cg_to_midship(a: AddedMass, xg_m: f64) -> AddedMass {
    AddedMass {
        X_udot: a.X_udot,
        Y_vdot: a.Y_vdot,
        Y_rdot: a.Y_rdot + xg_m * a.Y_vdot,
        N_vdot: a.N_vdot + xg_m * a.Y_vdot,
        N_rdot: a.N_rdot + xg_m * (a.Y_rdot + a.N_vdot) + xg_m * xg_m * a.Y_vdot,
    }
}
