//! The progress line of a run on stderr (only when stderr is a terminal): the scenario step,
//! the simulated time and how many of the plan's pairs are coupled. Log lines are written
//! above it ([`LogWriter`]), so logs and the line do not mix.

use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use puzzlebot_assembly::{PairStatus, PairType, RunState, ScenarioRunner};
use puzzlebot_protocol::RobotId;

/// What a run is doing, for its progress line.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Progress {
    /// Index of the current scenario step (0-based); `steps` when finished.
    pub step: usize,
    /// Steps of the scenario.
    pub steps: usize,
    /// The current step's label.
    pub label: String,
    /// Pairs of the plan the host counts as connected.
    pub connected: usize,
    /// Pairs of the plan.
    pub pairs: usize,
    /// Every pair of the plan with its status, by pair index (the live page draws them).
    pub plan: Vec<PlanPair>,
}

/// One pair of the plan and its status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlanPair {
    /// Robot with the anchor or knob.
    pub a: RobotId,
    /// Robot with the opening or hole.
    pub b: RobotId,
    /// Anchor-opening or knob-hole.
    pub kind: PairType,
    /// Status the host gives it.
    pub status: PairStatus,
}

impl Progress {
    /// The progress of an assembly scenario run.
    pub fn of_runner(runner: &ScenarioRunner) -> Progress {
        let steps = &runner.scenario().steps;
        let step = match runner.state() {
            RunState::Running { index } | RunState::Failed { index, .. } => *index,
            RunState::Finished => steps.len(),
        };
        let pairs = runner.coordinator().pairs();
        Progress {
            step,
            steps: steps.len(),
            label: steps.get(step).map_or("done", |s| s.label.as_str()).into(),
            connected: pairs
                .iter()
                .filter(|p| p.status == PairStatus::Connected)
                .count(),
            pairs: pairs.len(),
            plan: pairs
                .iter()
                .map(|p| PlanPair {
                    a: p.pair.a,
                    b: p.pair.b,
                    kind: p.pair.kind,
                    status: p.status,
                })
                .collect(),
        }
    }

    /// The line at simulated time `t` (s): `step 3/7 move 0.5 m · 52.1 s · pairs coupled 4 of 5`.
    pub fn line(&self, t: f64) -> String {
        format!(
            "step {}/{} {} · {t:.1} s · pairs coupled {} of {}",
            (self.step + 1).min(self.steps),
            self.steps,
            self.label,
            self.connected,
            self.pairs
        )
    }
}

/// Redraws at most this often (wall time).
const REDRAW: Duration = Duration::from_millis(100);

/// The line on the terminal.
struct Line {
    bar: indicatif::ProgressBar,
    next_draw: Instant,
}

static SHOWN: AtomicBool = AtomicBool::new(false);
static LINE: Mutex<Option<Line>> = Mutex::new(None);

/// Shows the progress line while it lives; dropping it clears the line.
pub struct Shown(());

impl Drop for Shown {
    fn drop(&mut self) {
        SHOWN.store(false, Ordering::Relaxed);
        if let Ok(mut l) = LINE.lock() {
            if let Some(l) = l.take() {
                l.bar.finish_and_clear();
            }
        }
    }
}

/// Show the progress line of the runs that follow on stderr, if stderr is a terminal.
pub fn show() -> Shown {
    if std::io::stderr().is_terminal() {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        if let Ok(mut l) = LINE.lock() {
            *l = Some(Line {
                bar,
                next_draw: Instant::now(),
            });
            SHOWN.store(true, Ordering::Relaxed);
        }
    }
    Shown(())
}

/// Called by the control loops every command period at run time `t` (s): redraws the line
/// with `progress()` (the time alone when it gives none) when one is shown and it is time to.
pub fn observe(t: f64, progress: impl FnOnce() -> Option<Progress>) {
    if !SHOWN.load(Ordering::Relaxed) {
        return;
    }
    let Ok(mut l) = LINE.try_lock() else {
        return;
    };
    let Some(line) = l.as_mut() else {
        return;
    };
    let now = Instant::now();
    if now < line.next_draw {
        return;
    }
    line.next_draw = now + REDRAW;
    let text = match progress() {
        Some(p) => p.line(t),
        None => format!("{t:.1} s"),
    };
    line.bar.set_message(text);
    line.bar.tick();
}

/// Writes to stderr above the progress line (the log writer of the `puzzlebot` binary).
pub struct LogWriter;

impl Write for LogWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let write = || std::io::stderr().write(buf);
        if !SHOWN.load(Ordering::Relaxed) {
            return write();
        }
        match LINE.lock() {
            Ok(l) => match l.as_ref() {
                Some(line) => line.bar.suspend(write),
                None => write(),
            },
            Err(_) => write(),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        std::io::stderr().flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_names_the_step_the_time_and_the_coupled_pairs() {
        let p = Progress {
            step: 2,
            steps: 7,
            label: "move 0.5 m".into(),
            connected: 4,
            pairs: 5,
            plan: Vec::new(),
        };
        assert_eq!(
            p.line(52.149),
            "step 3/7 move 0.5 m · 52.1 s · pairs coupled 4 of 5"
        );
        let done = Progress {
            step: 7,
            label: "done".into(),
            ..p
        };
        assert!(done.line(68.0).starts_with("step 7/7 done"));
        // Without a terminal nothing is shown and observing is a no-op.
        if !std::io::stderr().is_terminal() {
            let _shown = show();
            observe(1.0, || panic!("not asked for progress without a line"));
        }
    }
}
