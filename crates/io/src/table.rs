//! Turning parsed numeric columns into a validated [`Recording`]: the checks shared by the project's CSV recordings
//! and imported foreign layouts (time strictly increasing, every required column present, enough
//! samples), so both report the same problems the same way.

use std::collections::HashMap;
use std::path::Path;

use crate::error::InputError;
use crate::types::{Accelerations, Recording};
use crate::units::Quantity;

/// Fewest samples a recording may have: shorter records cannot hold a manoeuvre, and the acceleration
/// estimator needs a few points on each side of a sample.
pub const MIN_SAMPLES: usize = 20;

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
        for q in Quantity::RECORDING.iter().filter(|q| q.required()) {
            if !self.values.contains_key(q) {
                return Err(InputError::line(
                    path,
                    self.header_line(),
                    format!("missing required column `{}`", q.name()),
                ));
            }
        }
        let t = &self.values[&Quantity::T];
        for i in 1..rows {
            if t[i] <= t[i - 1] {
                let (col, name) = self
                    .column_of
                    .get(&Quantity::T)
                    .cloned()
                    .unwrap_or((1, "t".into()));
                return Err(InputError::cell(
                    path,
                    self.lines[i],
                    col,
                    &name,
                    format!(
                        "time is not strictly increasing ({} s after {} s)",
                        t[i],
                        t[i - 1]
                    ),
                ));
            }
        }
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
            accelerations,
        })
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
