//! Turning parsed numeric columns into a validated [`Recording`]: the checks shared by the project's CSV recordings
//! and imported foreign layouts (time strictly increasing, every required column present, enough
//! samples), so both report the same problems the same way.

use std::collections::HashMap;
use std::path::Path;

use crate::error::{InputError, number};
use crate::types::{Accelerations, FlowSeries, Recording};
use crate::units::Quantity;
use crate::units::fmt_sig;

/// Fewest samples a recording may have: shorter records cannot hold a manoeuvre, and the acceleration
/// estimator needs a few points on each side of a sample.
pub const MIN_SAMPLES: usize = 20;

/// Shortest time step [s] (`docs/data-format.md`): 1 MHz sampling is far beyond any ship recording,
/// and accelerations estimated over shorter steps can overflow.
pub const MIN_STEP_S: f64 = 1e-6;

/// A time step longer than this many median steps is a gap (`docs/data-format.md`).
pub const GAP_FACTOR: f64 = 10.0;

/// Columns read from a file, already in SI, with the file line of every row (for error messages).
pub struct Columns {
    pub values: HashMap<Quantity, Vec<f64>>,
    /// 1-based file line of each row.
    pub lines: Vec<usize>,
    /// 1-based column number and header text of each quantity, for error messages.
    pub column_of: HashMap<Quantity, (usize, String)>,
}

impl Columns {
    /// Check and assemble a recording. Velocities given earth-fixed (`x0_dot`, `y0_dot`) are turned into
    /// body velocities with the recorded heading. Heading is unwrapped.
    pub fn into_recording(mut self, path: &Path) -> Result<Recording, InputError> {
        let rows = self.lines.len();
        if rows < MIN_SAMPLES {
            return Err(InputError::file(
                path,
                format!("too short: {rows} samples, at least {MIN_SAMPLES} are needed"),
            ));
        }
        self.check_bounds(path)?;
        if let (Some(xd), Some(yd)) = (
            self.values.remove(&Quantity::X0Dot),
            self.values.remove(&Quantity::Y0Dot),
        ) && !self.values.contains_key(&Quantity::U)
            && let Some(psi) = self.values.get(&Quantity::Psi)
        {
            let (u, v): (Vec<f64>, Vec<f64>) = psi
                .iter()
                .zip(xd.iter().zip(&yd))
                .map(|(&p, (&xd, &yd))| {
                    let (s, c) = p.sin_cos();
                    (xd * c + yd * s, -xd * s + yd * c)
                })
                .unzip();
            self.values.insert(Quantity::U, u);
            self.values.insert(Quantity::V, v);
        }
        let relative = [Quantity::RelativeWindSpeed, Quantity::RelativeWindAngle]
            .iter()
            .any(|q| self.values.contains_key(q));
        for q in Quantity::RECORDING.iter().filter(|q| q.required()) {
            if !self.values.contains_key(q) {
                let hint = if relative && matches!(q, Quantity::Psi | Quantity::U | Quantity::V) {
                    " (the relative wind columns need it too: the true wind is the relative wind turned by the heading plus the ship's velocity over ground)"
                } else {
                    ""
                };
                return Err(InputError::line(
                    path,
                    self.header_line(),
                    format!("missing required column `{}`{hint}", q.name()),
                ));
            }
        }
        let t = &self.values[&Quantity::T];
        for i in 1..rows {
            if t[i] <= t[i - 1] {
                return Err(self.time_cell(
                    path,
                    i,
                    format!(
                        "time is not strictly increasing ({} s after {} s)",
                        t[i],
                        t[i - 1]
                    ),
                ));
            }
        }
        self.check_gaps(path)?;
        self.check_accelerations_complete(path)?;
        let wind = self.wind(path)?;
        let current = self.flow(path, Quantity::CurrentSpeed, Quantity::CurrentFrom)?;
        let mut take = |q: Quantity| self.values.remove(&q);
        let mut psi = take(Quantity::Psi).unwrap_or_default();
        unwrap_angle(&mut psi);
        let accelerations = match (
            take(Quantity::UDot),
            take(Quantity::VDot),
            take(Quantity::RDot),
        ) {
            (Some(u_dot), Some(v_dot), Some(r_dot)) => Some(Accelerations {
                u_dot,
                v_dot,
                r_dot,
            }),
            _ => None,
        };
        Ok(Recording {
            t: take(Quantity::T).unwrap_or_default(),
            x0: take(Quantity::X0).unwrap_or_default(),
            y0: take(Quantity::Y0).unwrap_or_default(),
            psi,
            u: take(Quantity::U).unwrap_or_default(),
            v: take(Quantity::V).unwrap_or_default(),
            r: take(Quantity::R).unwrap_or_default(),
            delta: take(Quantity::Delta).unwrap_or_default(),
            n: take(Quantity::N),
            thrust: take(Quantity::Thrust),
            accelerations,
            wind,
            current,
        })
    }

    /// The recorded true wind: from the true-wind columns, or from the relative-wind columns turned
    /// into the true wind sample by sample with the recorded heading and velocities
    /// ([`crate::relative_wind`]), never both (which one would be meant is not for shipid to guess).
    fn wind(&mut self, path: &Path) -> Result<Option<FlowSeries>, InputError> {
        let true_wind = self.flow(path, Quantity::WindSpeed, Quantity::WindFrom)?;
        let relative = self.flow(
            path,
            Quantity::RelativeWindSpeed,
            Quantity::RelativeWindAngle,
        )?;
        let Some(relative) = relative else {
            return Ok(true_wind);
        };
        let (col, header) = self.column_of[&Quantity::RelativeWindSpeed].clone();
        if true_wind.is_some() {
            let (true_col, true_header) = self.column_of[&Quantity::WindSpeed].clone();
            let (angle_col, angle_header) = self.column_of[&Quantity::RelativeWindAngle].clone();
            let from_col = self.column_of[&Quantity::WindFrom].0;
            return Err(InputError::cell(
                path,
                self.header_line(),
                col,
                &header,
                format!(
                    "the recording has both a true wind (`{true_header}`, `wind_from`: columns {true_col} and {from_col}) and a relative wind (`{header}`, `{angle_header}`: columns {col} and {angle_col}); give one of them (docs/data-format.md): the relative wind is turned into the true wind on reading, and two winds for one ship would disagree"
                ),
            ));
        }
        // Required columns, checked before: a recording without them never gets here.
        let (Some(psi), Some(u), Some(v)) = (
            self.values.get(&Quantity::Psi),
            self.values.get(&Quantity::U),
            self.values.get(&Quantity::V),
        ) else {
            return Err(InputError::line(
                path,
                self.header_line(),
                "a relative wind needs the columns `psi`, `u` and `v` to be turned into the true wind",
            ));
        };
        let mut wind = FlowSeries {
            speed_m_s: Vec::with_capacity(psi.len()),
            from_rad: Vec::with_capacity(psi.len()),
        };
        let bound = Quantity::WindSpeed.bound_si();
        for i in 0..psi.len() {
            let w = crate::relative_wind::true_wind(
                crate::relative_wind::Wind {
                    speed_m_s: relative.speed_m_s[i],
                    from_rad: relative.from_rad[i],
                },
                crate::relative_wind::ShipMotion {
                    psi_rad: psi[i],
                    u_m_s: u[i],
                    v_m_s: v[i],
                },
            );
            match w {
                Some(w) if w.speed_m_s <= bound => {
                    wind.speed_m_s.push(w.speed_m_s);
                    wind.from_rad.push(w.from_rad);
                }
                _ => {
                    let what = w.map_or("not finite".to_string(), |w| {
                        format!(
                            "{} m/s, beyond the bound {bound} m/s of `wind_speed`",
                            number(w.speed_m_s)
                        )
                    });
                    return Err(InputError::cell(
                        path,
                        self.lines[i],
                        col,
                        &header,
                        format!(
                            "the true wind of this relative wind and the recorded psi, u, v is {what} (docs/data-format.md): a wrong unit or a corrupt value"
                        ),
                    ));
                }
            }
        }
        Ok(Some(wind))
    }

    /// A recorded flow (wind or current) from its speed and direction columns: both or neither, the
    /// speed never negative (a direction cannot be told from a negative speed's sign convention).
    fn flow(
        &mut self,
        path: &Path,
        speed: Quantity,
        from: Quantity,
    ) -> Result<Option<FlowSeries>, InputError> {
        let (s, f) = (self.values.remove(&speed), self.values.remove(&from));
        let lone = match (&s, &f) {
            (Some(_), Some(_)) | (None, None) => None,
            (Some(_), None) => Some((speed, from)),
            (None, Some(_)) => Some((from, speed)),
        };
        let (what, direction) = match speed {
            Quantity::WindSpeed => ("wind", "the direction it comes from"),
            Quantity::RelativeWindSpeed => ("relative wind", "the angle off the bow it comes from"),
            _ => ("current", "the direction it comes from"),
        };
        if let Some((present, missing)) = lone {
            return Err(InputError::line(
                path,
                self.header_line(),
                format!(
                    "column `{}` needs the column `{}` too (a recorded {what} is its speed and {direction}, docs/data-format.md)",
                    present.name(),
                    missing.name(),
                ),
            ));
        }
        let (Some(speed_m_s), Some(from_rad)) = (s, f) else {
            return Ok(None);
        };
        if let Some(i) = speed_m_s.iter().position(|&v| v < 0.0) {
            let (col, header) = self.column_of[&speed].clone();
            return Err(InputError::cell(
                path,
                self.lines[i],
                col,
                &header,
                format!(
                    "negative {what} speed {} m/s: give the speed (≥ 0) and {direction}",
                    speed_m_s[i]
                ),
            ));
        }
        Ok(Some(FlowSeries {
            speed_m_s,
            from_rad,
        }))
    }

    /// Recorded accelerations are all three or none. Some of them alone cannot be used (the fit takes
    /// u̇, v̇, ṙ from one source, and mixing recorded with estimated ones would fit one DOF to another
    /// filter than the rest), and dropping them silently would fit estimated accelerations to a
    /// recording that says it has its own, as with a lone wind or current column.
    fn check_accelerations_complete(&self, path: &Path) -> Result<(), InputError> {
        let all = [Quantity::UDot, Quantity::VDot, Quantity::RDot];
        let (present, missing): (Vec<Quantity>, Vec<Quantity>) = all
            .iter()
            .copied()
            .partition(|q| self.values.contains_key(q));
        if present.is_empty() || missing.is_empty() {
            return Ok(());
        }
        let names = |qs: &[Quantity]| {
            qs.iter()
                .map(|q| format!("`{}`", q.name()))
                .collect::<Vec<_>>()
                .join(" and ")
        };
        let (s, verb) = if present.len() == 1 {
            ("", "needs")
        } else {
            ("s", "need")
        };
        let missing_s = if missing.len() == 1 { "" } else { "s" };
        Err(InputError::line(
            path,
            self.header_line(),
            format!(
                "column{s} {} {verb} the column{missing_s} {} too: recorded accelerations are all three of u_dot, v_dot, r_dot (docs/data-format.md); give the missing one{missing_s}, or remove the others to have all three estimated from u, v, r",
                names(&present),
                names(&missing),
            ),
        ))
    }

    /// Every value after unit conversion must be finite and within its quantity's bound
    /// ([`Quantity::bound_si`]): a huge value in a large unit (`t[min]`, 1e308) overflows to inf on
    /// conversion, and values near the limits of f64 overflow later in products the models form. Columns
    /// are checked in file order so that the first fault in the file is the one reported.
    fn check_bounds(&self, path: &Path) -> Result<(), InputError> {
        let mut columns: Vec<(&Quantity, &Vec<f64>)> = self.values.iter().collect();
        columns.sort_by_key(|(q, _)| self.column_of.get(q).map_or(usize::MAX, |c| c.0));
        let mut first: Option<(usize, usize, InputError)> = None;
        for (&q, values) in columns {
            let bound = q.bound_si();
            // `is_finite` first: NaN compares false with everything.
            let Some(i) = values
                .iter()
                .position(|v| !v.is_finite() || v.abs() > bound)
            else {
                continue;
            };
            let (col, name) = self
                .column_of
                .get(&q)
                .cloned()
                .unwrap_or((0, q.name().to_string()));
            let v = values[i];
            let message = if v.is_finite() {
                let hint = match q {
                    Quantity::Delta if !name.contains('[') => {
                        "; a rudder angle in degrees needs the header `delta[deg]`".to_string()
                    }
                    Quantity::WindFrom | Quantity::RelativeWindAngle | Quantity::CurrentFrom
                        if !name.contains('[') =>
                    {
                        format!(
                            "; a direction in degrees needs the header `{}[deg]`",
                            q.name()
                        )
                    }
                    Quantity::T => "; a clock of absolute time (Unix seconds, 1.7e9 in 2023) needs its first time subtracted: the recordings' times are seconds from any start".to_string(),
                    _ => String::new(),
                };
                format!(
                    "{} {} (after unit conversion) is beyond the bound ±{} of `{}` in docs/data-format.md: a wrong unit or a corrupt value{hint}",
                    number(v),
                    q.si_unit(),
                    q.bound_text(),
                    q.name()
                )
            } else {
                format!(
                    "the value is not finite after conversion to {} (too large for its unit)",
                    q.si_unit()
                )
            };
            let line = self.lines.get(i).copied().unwrap_or(0);
            if first
                .as_ref()
                .is_none_or(|(l, c, _)| (line, col) < (*l, *c))
            {
                first = Some((line, col, InputError::cell(path, line, col, &name, message)));
            }
        }
        first.map_or(Ok(()), |(_, _, e)| Err(e))
    }

    /// A step shorter than [`MIN_STEP_S`] is not a ship's sampling; a step longer than [`GAP_FACTOR`]
    /// times the median step is a gap (lost samples), an error: the
    /// acceleration estimate and every replay would bridge it with invented motion.
    fn check_gaps(&self, path: &Path) -> Result<(), InputError> {
        let t = &self.values[&Quantity::T];
        let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        if steps.is_empty() {
            return Ok(());
        }
        steps.sort_by(f64::total_cmp);
        let median = steps[steps.len() / 2];
        for i in 1..t.len() {
            let step = t[i] - t[i - 1];
            if step < MIN_STEP_S {
                return Err(self.time_cell(
                    path,
                    i,
                    format!(
                        "a time step of {} s after {} s is shorter than {MIN_STEP_S} s: no ship recording samples that fast (a wrong unit?), and derivatives over it would overflow",
                        number(step),
                        number(t[i - 1])
                    ),
                ));
            }
            if step > GAP_FACTOR * median {
                // Many long steps are no lost samples but a logger that writes in bursts (three
                // samples 10 ms apart every 0.5 s): "gap" would send the user looking for lost data.
                let long = steps.iter().filter(|&&s| s > GAP_FACTOR * median).count();
                let bursts = long * 10 >= steps.len();
                let what = if bursts {
                    format!(
                        "uneven sampling: {long} of the {} steps are more than {GAP_FACTOR} × the median step {} s, the first {} s after {} s (line {}): the samples come in bursts; resample the recording to a regular step",
                        steps.len(),
                        fmt_sig(median),
                        fmt_sig(step),
                        number(t[i - 1]),
                        self.lines[i - 1],
                    )
                } else {
                    format!(
                        "gap in time: {} s after {} s (line {}), a step of {} s, more than {GAP_FACTOR} × the median step {} s",
                        number(t[i]),
                        number(t[i - 1]),
                        self.lines[i - 1],
                        fmt_sig(step),
                        fmt_sig(median)
                    )
                };
                return Err(self.time_cell(path, i, what));
            }
        }
        Ok(())
    }

    /// An error at row `i`'s time cell, in the column the time was read from.
    fn time_cell(&self, path: &Path, i: usize, message: String) -> InputError {
        let (col, name) = self
            .column_of
            .get(&Quantity::T)
            .cloned()
            .unwrap_or((1, "t".into()));
        InputError::cell(path, self.lines[i], col, &name, message)
    }

    fn header_line(&self) -> usize {
        self.lines.first().map_or(1, |l| l.saturating_sub(1).max(1))
    }
}

/// Remove 2π jumps so that the heading is continuous (a wrapped heading is allowed in files).
pub fn unwrap_angle(psi: &mut [f64]) {
    use std::f64::consts::{PI, TAU};
    let mut offset = 0.0;
    let mut prev = match psi.first() {
        Some(&p) => p,
        None => return,
    };
    for p in psi.iter_mut().skip(1) {
        let raw = *p;
        let step = raw - prev;
        if step > PI {
            offset -= TAU;
        } else if step < -PI {
            offset += TAU;
        }
        prev = raw;
        *p = raw + offset;
    }
}

/// Parse one cell as a finite number, or say exactly what is wrong with it.
pub fn parse_cell(text: &str) -> Result<f64, String> {
    let text = text.trim();
    if text.is_empty() {
        return Err("empty cell".to_string());
    }
    match text.parse::<f64>() {
        Ok(x) if x.is_nan() => Err("NaN value".to_string()),
        Ok(x) if x.is_infinite() => Err(format!("infinite value `{text}`")),
        Ok(x) => Ok(x),
        Err(_) => Err(format!("not a number: `{text}`")),
    }
}

/// A quoted cell such as `"0,5"` is one field with a decimal comma.
pub fn with_comma_hint(message: String, cell: &str) -> String {
    let c = cell.trim();
    if c.contains(',') && c.replacen(',', ".", 1).parse::<f64>().is_ok() {
        format!(
            "{message} (a decimal comma? write `{}`)",
            c.replacen(',', ".", 1)
        )
    } else {
        message
    }
}
