//! The batch's progress bar on stderr: runs done out of the design, cached and
//! failed counts, elapsed time and an ETA from the mean wall time of the runs
//! finished so far (cache hits excluded, they cost nothing). Redrawn in place
//! at most twice a second; shown only when
//! [`crate::scenes::protocol::progress_enabled`] (not `--quiet`, stderr a
//! terminal). Wall-clock time never reaches any output file. With several
//! workers the ETA divides by the observed throughput, so it accounts for them.

use std::io::Write;
use std::time::{Duration, Instant};

/// Width of the bar in characters.
const BAR: usize = 30;

/// A progress bar over the runs of a batch.
#[derive(Debug)]
pub struct BatchProgress {
    enabled: bool,
    total: usize,
    cached: usize,
    to_run: usize,
    finished: usize,
    failed: usize,
    started: Instant,
    last: Option<Instant>,
    note: Option<String>,
}

impl BatchProgress {
    /// A bar over `total` runs of which `cached` were complete before the batch
    /// started; draws nothing unless `enabled`.
    pub fn new(enabled: bool, total: usize, cached: usize) -> BatchProgress {
        let mut p = BatchProgress {
            enabled,
            total,
            cached,
            to_run: total - cached,
            finished: 0,
            failed: 0,
            started: Instant::now(),
            last: None,
            note: None,
        };
        p.draw(true);
        p
    }

    /// Records one finished run (failed or not) and redraws.
    pub fn finished_one(&mut self, failed: bool) {
        self.finished += 1;
        self.failed += usize::from(failed);
        self.draw(self.finished == self.to_run);
    }

    /// Redraws (elapsed time and ETA move on between finished runs).
    pub fn tick(&mut self) {
        self.draw(false);
    }

    /// Sets what the line adds after the ETA (e.g. Slurm's pending reasons)
    /// and redraws when it changed.
    pub fn set_note(&mut self, note: Option<String>) {
        if note != self.note {
            self.note = note;
            self.draw(true);
        }
    }

    /// Ends the bar's line.
    pub fn finish(&mut self) {
        if self.enabled {
            eprintln!();
        }
    }

    fn draw(&mut self, force: bool) {
        if !self.enabled {
            return;
        }
        let now = Instant::now();
        if !force
            && self
                .last
                .is_some_and(|l| now - l < Duration::from_millis(500))
        {
            return;
        }
        self.last = Some(now);
        let line = self.line(now - self.started);
        let mut err = std::io::stderr().lock();
        // \r returns to the line start, ESC[K clears what an older, longer line left.
        let _ = write!(err, "\r{line}\x1b[K");
        let _ = err.flush();
    }

    /// The bar's text after `elapsed` wall time.
    pub fn line(&self, elapsed: Duration) -> String {
        let done = self.cached + self.finished;
        let filled = (BAR * done).checked_div(self.total).unwrap_or(BAR);
        let eta = if self.finished == 0 {
            "ETA -".to_string()
        } else {
            let per_run = elapsed.as_secs_f64() / self.finished as f64;
            format!(
                "ETA {}",
                clock(per_run * (self.to_run - self.finished) as f64)
            )
        };
        let note = self
            .note
            .as_deref()
            .map_or_else(String::new, |n| format!("  {n}"));
        format!(
            "batch [{}{}] {done}/{}  cached {}  failed {}  elapsed {}  {eta}{note}",
            "#".repeat(filled),
            "-".repeat(BAR - filled),
            self.total,
            self.cached,
            self.failed,
            clock(elapsed.as_secs_f64()),
        )
    }
}

/// Seconds as `1h02m03s`, `2m03s` or `3s`.
fn clock(seconds: f64) -> String {
    let s = seconds.round() as u64;
    match (s / 3600, s / 60 % 60, s % 60) {
        (0, 0, sec) => format!("{sec}s"),
        (0, m, sec) => format!("{m}m{sec:02}s"),
        (h, m, sec) => format!("{h}h{m:02}m{sec:02}s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eta_extrapolates_the_mean_run_time() {
        let mut p = BatchProgress::new(false, 10, 2);
        p.finished_one(false);
        p.finished_one(true);
        // 2 of 8 runs took 60 s: 6 more take 180 s.
        let line = p.line(Duration::from_secs(60));
        assert_eq!(
            line,
            "batch [############------------------] 4/10  cached 2  failed 1  elapsed 1m00s  ETA 3m00s"
        );
        assert_eq!(clock(3723.0), "1h02m03s");
        p.set_note(Some("queued: Resources 6".to_string()));
        assert!(p
            .line(Duration::from_secs(60))
            .ends_with("ETA 3m00s  queued: Resources 6"));
    }
}
