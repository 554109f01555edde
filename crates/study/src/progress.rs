//! Progress of a run on stderr: a bar on a terminal; plain lines otherwise (a log, a pipe, CI), where
//! a bar is hidden and a long run would otherwise say nothing until it ends.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

/// A plain line is printed each time this share of the cases has finished …
const LINE_EVERY_SHARE: f64 = 0.05;
/// … or this long after the previous line, whichever comes first.
const LINE_EVERY: Duration = Duration::from_secs(10);

/// Where a run stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tally {
    pub total: usize,
    pub done: usize,
    /// Of `done`, the cases computed in this run (the rest were finished earlier and reused).
    pub computed: usize,
    /// Of `done`, the cases whose fit could not be computed, and those with a diverged prediction.
    pub failed: usize,
    pub diverged: usize,
    pub elapsed_s: f64,
}

impl Tally {
    /// `progress: 120/800 cases, 3 failed, 1 diverged, elapsed 40 s, about 226 s left`; the time left
    /// is the rate of this run's computed cases applied to those still to do.
    pub fn line(&self) -> String {
        let left = self.total - self.done;
        let eta = if self.computed > 0 && left > 0 {
            format!(
                ", about {:.0} s left",
                self.elapsed_s / self.computed as f64 * left as f64
            )
        } else {
            String::new()
        };
        format!(
            "progress: {}/{} cases, {} failed, {} diverged, elapsed {:.0} s{eta}",
            self.done, self.total, self.failed, self.diverged, self.elapsed_s
        )
    }
}

/// Whether a plain line is due: the last case, another [`LINE_EVERY_SHARE`] of the cases since the
/// previous line, or [`LINE_EVERY`] since it.
pub fn line_due(
    done: usize,
    total: usize,
    last_line_done: usize,
    since_last_line: Duration,
) -> bool {
    let step = ((total as f64 * LINE_EVERY_SHARE).ceil() as usize).max(1);
    done == total || done >= last_line_done + step || since_last_line >= LINE_EVERY
}

enum Display {
    Hidden,
    Bar(ProgressBar),
    Lines,
}

struct State {
    done: usize,
    computed: usize,
    failed: usize,
    diverged: usize,
    last_line_done: usize,
    last_line: Instant,
}

/// Counts finished cases and shows them (shared by the worker threads).
pub struct Progress {
    total: usize,
    started: Instant,
    display: Display,
    state: Mutex<State>,
}

impl Progress {
    /// `show`: a bar when stderr is a terminal, plain lines when not; nothing when `show` is false.
    pub fn new(total: usize, show: bool) -> Progress {
        let display = match (show, std::io::stderr().is_terminal()) {
            (false, _) => Display::Hidden,
            (true, true) => {
                let bar = ProgressBar::new(total as u64);
                bar.set_style(
                    ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} cases  {msg}  elapsed {elapsed} eta {eta}",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
                Display::Bar(bar)
            }
            (true, false) => Display::Lines,
        };
        let now = Instant::now();
        Progress {
            total,
            started: now,
            display,
            state: Mutex::new(State {
                done: 0,
                computed: 0,
                failed: 0,
                diverged: 0,
                last_line_done: 0,
                last_line: now,
            }),
        }
    }

    /// One more case finished (`computed`: in this run, not reused; `failed`: its fit could not be
    /// computed; `diverged`: a prediction of its model diverged).
    pub fn case_done(&self, computed: bool, failed: bool, diverged: bool) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        s.done += 1;
        s.computed += usize::from(computed);
        s.failed += usize::from(failed);
        s.diverged += usize::from(diverged);
        match &self.display {
            Display::Hidden => {}
            Display::Bar(bar) => {
                bar.set_message(format!("{} fit failed, {} diverged", s.failed, s.diverged));
                bar.inc(1);
            }
            Display::Lines => {
                if line_due(s.done, self.total, s.last_line_done, s.last_line.elapsed()) {
                    let tally = Tally {
                        total: self.total,
                        done: s.done,
                        computed: s.computed,
                        failed: s.failed,
                        diverged: s.diverged,
                        elapsed_s: self.started.elapsed().as_secs_f64(),
                    };
                    eprintln!("{}", tally.line());
                    s.last_line_done = s.done;
                    s.last_line = Instant::now();
                }
            }
        }
    }

    pub fn finish(&self) {
        if let Display::Bar(bar) = &self.display {
            bar.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_due(done: usize, total: usize, last: usize, since_s: u64, expected: bool) {
        assert_eq!(
            line_due(done, total, last, Duration::from_secs(since_s)),
            expected,
            "{done}/{total}, last line at {last}, {since_s} s ago"
        );
    }

    #[test]
    fn plain_lines_come_every_five_percent_every_ten_seconds_and_at_the_end() {
        check_due(39, 800, 0, 1, false);
        check_due(40, 800, 0, 1, true);
        check_due(41, 800, 40, 9, false);
        check_due(41, 800, 40, 10, true);
        check_due(800, 800, 799, 0, true);
        // Small runs: every case.
        check_due(1, 3, 0, 0, true);
    }

    #[test]
    fn a_line_says_where_the_run_stands_and_how_long_is_left() {
        let tally = Tally {
            total: 800,
            done: 120,
            computed: 100,
            failed: 3,
            diverged: 1,
            elapsed_s: 40.0,
        };
        assert_eq!(
            tally.line(),
            "progress: 120/800 cases, 3 failed, 1 diverged, elapsed 40 s, about 272 s left"
        );
        let all_reused = Tally {
            computed: 0,
            ..tally
        };
        assert_eq!(
            all_reused.line(),
            "progress: 120/800 cases, 3 failed, 1 diverged, elapsed 40 s"
        );
    }
}
