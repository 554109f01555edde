//! A recording's propeller rate as a known input.
//!
//! A model whose forces take the propeller rate ([`Dynamics::takes_propeller_rate`]: the MMG model's
//! thrust and rudder slipstream) holds one rate of its own, the mean of its training recordings. A
//! recording made at another rate (a faster approach, a sea trial whose rate drops in the turn) is
//! replayed at the rate it recorded: [`WithPropellerRate`] gives the wrapped model the recorded rate,
//! interpolated linearly between samples and held beyond the ends, at every evaluation. Models without
//! that input ignore it (their validation warns instead).

use shipid_io::{AddedMass, Recording, Ship};

use crate::dynamics::{Dynamics, DynamicsError, Input, State};

/// Propeller rate [1/s] over recording time.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordedRate {
    /// Recording times [s] of the samples.
    t_s: Vec<f64>,
    /// Propeller rate [1/s] per sample.
    n_hz: Vec<f64>,
    /// Recording time [s] at simulation time 0.
    origin_s: f64,
}

impl RecordedRate {
    /// The rate `rec` records in its `n` column; `None` without one, or when a value is not finite or
    /// the column's length is not the recording's (the recording's loader refuses both, so only
    /// hand-made recordings get here).
    pub fn of_recording(rec: &Recording) -> Option<RecordedRate> {
        let n = rec.n.as_ref()?;
        (n.len() == rec.t.len() && !n.is_empty() && n.iter().all(|x| x.is_finite())).then(|| {
            RecordedRate {
                t_s: rec.t.clone(),
                n_hz: n.clone(),
                origin_s: rec.t[0],
            }
        })
    }

    /// One rate `n_hz` [1/s] at all times.
    pub fn constant(n_hz: f64) -> RecordedRate {
        RecordedRate {
            t_s: vec![0.0],
            n_hz: vec![n_hz],
            origin_s: 0.0,
        }
    }

    /// The same rate for a simulation that starts at recording time `t_start_s` [s].
    pub fn replay_from(&self, t_start_s: f64) -> RecordedRate {
        RecordedRate {
            origin_s: t_start_s,
            ..self.clone()
        }
    }

    /// The rate [1/s] at simulation time `t_s`.
    pub fn at(&self, t_s: f64) -> f64 {
        crate::metrics::interp(&self.t_s, &self.n_hz, t_s + self.origin_s)
    }
}

/// A model driven by a recorded propeller rate (see the module docs).
#[derive(Debug, Clone)]
pub struct WithPropellerRate<D> {
    inner: D,
    rate: RecordedRate,
}

impl<D: Dynamics> WithPropellerRate<D> {
    /// `inner` at `rate`.
    pub fn new(inner: D, rate: RecordedRate) -> WithPropellerRate<D> {
        WithPropellerRate { inner, rate }
    }
}

impl<D: Dynamics> Dynamics for WithPropellerRate<D> {
    /// The wrapped model at the recorded rate at `input.t_s` (a rate named in the input is the
    /// recording's too: this one wins).
    fn accelerations_for(&self, state: &State, input: &Input) -> Result<[f64; 3], DynamicsError> {
        let at_rate = Input {
            propeller_rate_hz: Some(self.rate.at(input.t_s)),
            ..*input
        };
        self.inner.accelerations_for(state, &at_rate)
    }

    fn wrapped(&self) -> Option<&dyn Dynamics> {
        Some(&self.inner)
    }

    /// The rate is the recording's now: the wrapped model takes no other.
    fn takes_propeller_rate(&self) -> bool {
        false
    }

    fn ship(&self) -> &Ship {
        self.inner.ship()
    }

    fn added_mass(&self) -> &AddedMass {
        self.inner.added_mass()
    }

    /// The recorded rate at the simulation's start: what a simulated recording's `n` column holds.
    fn propeller_rate_hz(&self) -> Option<f64> {
        self.inner.propeller_rate_hz().map(|_| self.rate.at(0.0))
    }
}
