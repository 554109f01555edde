//! Rudder controllers: the standard IMO manoeuvres and the replay of a recorded rudder history.
//!
//! A controller gives the *commanded* rudder angle once per integration step; the simulation's actuator
//! moves the actual rudder towards it at the ship's rudder rate. A replayed history is the *actual*
//! rudder and bypasses the actuator ([`RudderController::prescribed`]).

use shipid_io::{Manoeuvre, Recording, Side};
use thiserror::Error;

use crate::dynamics::State;

/// Tolerance [s] for comparing the step times k·dt with an execute time.
const TIME_EPS_S: f64 = 1e-9;

/// A controller's rudder command for one integration step: the commanded angle at the start of the step
/// and, optionally, a change of command inside the step.
///
/// Switching inside the step keeps rudder executes at their exact time (an execute time off the step
/// grid, a zig-zag check angle reached between two steps) instead of up to one step late.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RudderCommand {
    /// Commanded angle [rad] from the start of the step.
    pub angle_rad: f64,
    /// `(τ, angle)`: from `τ` seconds after the start of the step on, the command is `angle` [rad].
    pub switch: Option<(f64, f64)>,
}

impl RudderCommand {
    /// The same command for the whole step.
    pub fn constant(angle_rad: f64) -> RudderCommand {
        RudderCommand {
            angle_rad,
            switch: None,
        }
    }

    /// The command `τ_s` seconds into the step.
    pub fn at(&self, tau_s: f64) -> f64 {
        match self.switch {
            Some((ts, angle)) if tau_s >= ts => angle,
            _ => self.angle_rad,
        }
    }
}

/// Source of the rudder angle during a simulation.
pub trait RudderController {
    /// Rudder command (positive turns to starboard) for the integration step `[t_s, t_s + dt_s]` that
    /// starts in `state`. Called once per step, in time order, so a controller may keep a phase.
    fn command(&mut self, t_s: f64, dt_s: f64, state: &State) -> RudderCommand;

    /// The actual rudder angle [rad] at `t_s` when the controller prescribes it directly (a replay of a
    /// recorded rudder); `None`, the default, sends [`RudderController::command`] through the
    /// rate-limited actuator.
    fn prescribed(&self, _t_s: f64) -> Option<f64> {
        None
    }
}

/// Why a controller could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ControlError {
    /// A `free` manoeuvre has no standard rudder law: replay its recorded rudder instead.
    #[error("a free manoeuvre has no rudder law: replay its recorded rudder history")]
    NeedsReplay,
    /// A manoeuvre parameter is out of range.
    #[error("invalid {name} = {value}: {reason}")]
    InvalidParameter {
        name: &'static str,
        value: f64,
        reason: &'static str,
    },
    /// The rudder history to replay is unusable.
    #[error("invalid rudder history: {0}")]
    InvalidHistory(String),
}

fn check_angle(name: &'static str, deg: f64, max: f64) -> Result<f64, ControlError> {
    if deg.is_finite() && deg > 0.0 && deg <= max {
        Ok(deg.to_radians())
    } else {
        Err(ControlError::InvalidParameter {
            name,
            value: deg,
            reason: "must be finite and in (0, limit] degrees",
        })
    }
}

fn check_time(t_execute_s: f64) -> Result<(), ControlError> {
    if t_execute_s.is_finite() && t_execute_s >= 0.0 {
        Ok(())
    } else {
        Err(ControlError::InvalidParameter {
            name: "t_execute_s",
            value: t_execute_s,
            reason: "must be finite and non-negative",
        })
    }
}

/// Zig-zag δ/ψ (IMO MSC.137(76)): neutral rudder until `t_execute_s`, then rudder to `side` by the
/// amplitude; the command reverses whenever the heading deviation from the heading at the first execute
/// reaches the check angle on the side the rudder points to.
#[derive(Debug, Clone, PartialEq)]
pub struct ZigZag {
    rudder_rad: f64,
    check_rad: f64,
    side: Side,
    t_execute_s: f64,
    /// Time [s] from the heading reaching the check angle to the command's reversal (0: at once, the
    /// standard law; a recorded zig-zag's helmsman or autopilot reacts later).
    reaction_delay_s: f64,
    /// Heading at the first execute and the sign of the current command, once executed.
    phase: Option<(f64, f64)>,
    /// Time [s] of a reversal the check has called for and the delay still holds back.
    pending_reversal_s: Option<f64>,
}

impl ZigZag {
    /// A zig-zag `rudder_deg`/`check_deg` starting to `side` at `t_execute_s`.
    pub fn new(
        rudder_deg: f64,
        check_deg: f64,
        side: Side,
        t_execute_s: f64,
    ) -> Result<ZigZag, ControlError> {
        check_time(t_execute_s)?;
        Ok(ZigZag {
            rudder_rad: check_angle("rudder_deg", rudder_deg, 90.0)?,
            check_rad: check_angle("check_deg", check_deg, 180.0)?,
            side,
            t_execute_s,
            reaction_delay_s: 0.0,
            phase: None,
            pending_reversal_s: None,
        })
    }

    /// The same zig-zag with every reversal `delay_s` [s] after the heading reaches the check angle.
    pub fn with_reaction_delay(mut self, delay_s: f64) -> Result<ZigZag, ControlError> {
        if !(delay_s.is_finite() && delay_s >= 0.0) {
            return Err(ControlError::InvalidParameter {
                name: "reaction_delay_s",
                value: delay_s,
                reason: "must be finite and non-negative",
            });
        }
        self.reaction_delay_s = delay_s;
        Ok(self)
    }
}

impl RudderController for ZigZag {
    fn command(&mut self, t_s: f64, dt_s: f64, state: &State) -> RudderCommand {
        let amplitude = self.rudder_rad;
        let Some((psi0, sign)) = self.phase.as_mut() else {
            let to_execute = self.t_execute_s - t_s;
            if to_execute > dt_s - TIME_EPS_S {
                return RudderCommand::constant(0.0);
            }
            let first = self.side.sign() * amplitude;
            if to_execute > TIME_EPS_S {
                // Heading at the execute inside this step, extrapolated with the yaw rate.
                self.phase = Some((state.psi + state.r * to_execute, self.side.sign()));
                return RudderCommand {
                    angle_rad: 0.0,
                    switch: Some((to_execute, first)),
                };
            }
            self.phase = Some((state.psi, self.side.sign()));
            return RudderCommand::constant(first);
        };
        if let Some(t_reverse) = self.pending_reversal_s {
            let tau = t_reverse - t_s;
            if tau > dt_s - TIME_EPS_S {
                return RudderCommand::constant(*sign * amplitude);
            }
            self.pending_reversal_s = None;
            let before = *sign * amplitude;
            *sign = -*sign;
            return if tau > TIME_EPS_S {
                RudderCommand {
                    angle_rad: before,
                    switch: Some((tau, *sign * amplitude)),
                }
            } else {
                RudderCommand::constant(*sign * amplitude)
            };
        }
        // Where the heading reaches the check angle: at the start of this step, or inside it
        // (extrapolated with the yaw rate). The reversal follows the reaction delay later (at once
        // for the standard law), through the pending reversal above.
        let deviation = *sign * (state.psi - *psi0);
        let closing_rate = *sign * state.r;
        let reached = if deviation >= self.check_rad {
            Some(t_s)
        } else if closing_rate > 0.0 {
            let tau = (self.check_rad - deviation) / closing_rate;
            (tau < dt_s).then_some(t_s + tau)
        } else {
            None
        };
        match reached {
            Some(t_check) => {
                self.pending_reversal_s = Some(t_check + self.reaction_delay_s);
                self.command(t_s, dt_s, state)
            }
            None => RudderCommand::constant(*sign * amplitude),
        }
    }
}

/// Turning circle: neutral rudder until `t_execute_s`, then the rudder to `side` and held.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Turning {
    rudder_rad: f64,
    t_execute_s: f64,
}

impl Turning {
    /// A `rudder_deg` turn to `side` executed at `t_execute_s`.
    pub fn new(rudder_deg: f64, side: Side, t_execute_s: f64) -> Result<Turning, ControlError> {
        check_time(t_execute_s)?;
        Ok(Turning {
            rudder_rad: side.sign() * check_angle("rudder_deg", rudder_deg, 90.0)?,
            t_execute_s,
        })
    }
}

impl RudderController for Turning {
    fn command(&mut self, t_s: f64, dt_s: f64, _state: &State) -> RudderCommand {
        let to_execute = self.t_execute_s - t_s;
        if to_execute > dt_s - TIME_EPS_S {
            RudderCommand::constant(0.0)
        } else if to_execute > TIME_EPS_S {
            RudderCommand {
                angle_rad: 0.0,
                switch: Some((to_execute, self.rudder_rad)),
            }
        } else {
            RudderCommand::constant(self.rudder_rad)
        }
    }
}

/// Replay of a recorded (actual) rudder history: linear interpolation in time, the first value before
/// the first sample and the last value after the last. Bypasses the rudder-rate actuator.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    t_s: Vec<f64>,
    delta_rad: Vec<f64>,
}

impl Replay {
    /// From sample times [s] (strictly increasing) and rudder angles [rad], all finite.
    pub fn new(t_s: Vec<f64>, delta_rad: Vec<f64>) -> Result<Replay, ControlError> {
        if t_s.is_empty() {
            return Err(ControlError::InvalidHistory("no samples".into()));
        }
        if t_s.len() != delta_rad.len() {
            return Err(ControlError::InvalidHistory(format!(
                "{} times but {} rudder angles",
                t_s.len(),
                delta_rad.len()
            )));
        }
        if let Some(i) = (0..t_s.len()).find(|&i| !t_s[i].is_finite() || !delta_rad[i].is_finite())
        {
            return Err(ControlError::InvalidHistory(format!(
                "non-finite value at sample {i}"
            )));
        }
        if let Some(i) = (1..t_s.len()).find(|&i| t_s[i] <= t_s[i - 1]) {
            return Err(ControlError::InvalidHistory(format!(
                "time not strictly increasing at sample {i}"
            )));
        }
        Ok(Replay { t_s, delta_rad })
    }

    /// The rudder history of a recording (its `t` and `delta`).
    pub fn from_recording(rec: &Recording) -> Result<Replay, ControlError> {
        Replay::new(rec.t.clone(), rec.delta.clone())
    }

    /// Rudder angle [rad] at `t_s`.
    pub fn at(&self, t_s: f64) -> f64 {
        crate::metrics::interp(&self.t_s, &self.delta_rad, t_s)
    }
}

impl RudderController for Replay {
    fn command(&mut self, t_s: f64, _dt_s: f64, _state: &State) -> RudderCommand {
        RudderCommand::constant(self.at(t_s))
    }

    fn prescribed(&self, t_s: f64) -> Option<f64> {
        Some(self.at(t_s))
    }
}

/// The standard controller of `manoeuvre` with its first execute at `t_execute_s` (after a steady
/// approach). A [`Manoeuvre::Free`] has none: it fails with [`ControlError::NeedsReplay`].
pub fn controller_for(
    manoeuvre: &Manoeuvre,
    t_execute_s: f64,
) -> Result<Box<dyn RudderController + Send>, ControlError> {
    controller_with_reaction_delay(manoeuvre, t_execute_s, 0.0)
}

/// [`controller_for`] with a zig-zag's reversals `reaction_delay_s` [s] after each check (a recorded
/// zig-zag's own delay, [`crate::metrics::check_reaction_delay_s`]); other manoeuvres ignore it.
pub fn controller_with_reaction_delay(
    manoeuvre: &Manoeuvre,
    t_execute_s: f64,
    reaction_delay_s: f64,
) -> Result<Box<dyn RudderController + Send>, ControlError> {
    match *manoeuvre {
        Manoeuvre::ZigZag {
            rudder_deg,
            check_deg,
            side,
        } => Ok(Box::new(
            ZigZag::new(rudder_deg, check_deg, side, t_execute_s)?
                .with_reaction_delay(reaction_delay_s)?,
        )),
        Manoeuvre::Turning { rudder_deg, side } => {
            Ok(Box::new(Turning::new(rudder_deg, side, t_execute_s)?))
        }
        Manoeuvre::Free => Err(ControlError::NeedsReplay),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replay_interpolates_and_holds_the_ends() {
        let r = Replay::new(vec![1.0, 2.0, 4.0], vec![0.0, 0.2, -0.2]).unwrap();
        assert_eq!(r.at(0.0), 0.0);
        assert!((r.at(1.5) - 0.1).abs() < 1e-15);
        assert!((r.at(3.0) - 0.0).abs() < 1e-15);
        assert_eq!(r.at(4.0), -0.2);
        assert_eq!(r.at(100.0), -0.2);
    }

    #[test]
    fn replay_rejects_bad_histories() {
        assert!(Replay::new(vec![], vec![]).is_err());
        assert!(Replay::new(vec![0.0, 0.0], vec![0.0, 0.0]).is_err());
        assert!(Replay::new(vec![0.0, 1.0], vec![0.0]).is_err());
        assert!(Replay::new(vec![0.0, 1.0], vec![0.0, f64::NAN]).is_err());
    }

    #[test]
    fn zigzag_reverses_at_the_check_angle() {
        let dt = 0.1;
        let ten = 10f64.to_radians();
        let mut z = ZigZag::new(10.0, 10.0, Side::Port, 1.0).unwrap();
        let mut s = State::approach(1.0);
        assert_eq!(z.command(0.5, dt, &s), RudderCommand::constant(0.0));
        assert_eq!(z.command(1.0, dt, &s), RudderCommand::constant(-ten));
        s.psi = -9.0f64.to_radians();
        s.r = -1f64.to_radians();
        // 1° to go at 1°/s: no reversal within this step.
        assert_eq!(z.command(2.0, dt, &s), RudderCommand::constant(-ten));
        // 0.05° to go at 1°/s: reversal 0.05 s into the step.
        s.psi = -9.95f64.to_radians();
        let c = z.command(2.1, dt, &s);
        assert_eq!(c.angle_rad, -ten);
        let (tau, after) = c.switch.unwrap();
        assert!((tau - 0.05).abs() < 1e-12 && after == ten);
        // Beyond the port check, but the rudder already points to starboard: no new reversal.
        s.psi = -10.5f64.to_radians();
        assert_eq!(z.command(2.2, dt, &s), RudderCommand::constant(ten));
        // Reached the starboard check between steps (late): reversal at once.
        s.psi = 10.1f64.to_radians();
        s.r = 0.0;
        assert_eq!(z.command(4.0, dt, &s), RudderCommand::constant(-ten));
    }

    #[test]
    fn execute_off_the_step_grid_switches_inside_the_step() {
        let mut t = Turning::new(35.0, Side::Starboard, 1.03).unwrap();
        let s = State::approach(1.0);
        assert_eq!(t.command(0.95, 0.05, &s), RudderCommand::constant(0.0));
        let c = t.command(1.0, 0.05, &s);
        let (tau, angle) = c.switch.unwrap();
        assert!((tau - 0.03).abs() < 1e-12 && angle == 35f64.to_radians());
        assert_eq!(c.at(0.02), 0.0);
        assert_eq!(
            t.command(1.05, 0.05, &s),
            RudderCommand::constant(35f64.to_radians())
        );
    }

    #[test]
    fn free_manoeuvre_needs_replay() {
        assert!(matches!(
            controller_for(&Manoeuvre::Free, 0.0),
            Err(ControlError::NeedsReplay)
        ));
        let bad = Manoeuvre::Turning {
            rudder_deg: f64::NAN,
            side: Side::Port,
        };
        assert!(matches!(
            controller_for(&bad, 0.0),
            Err(ControlError::InvalidParameter { .. })
        ));
    }
}
