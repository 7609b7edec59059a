//! The progress display on standard error (indicatif): the step, the
//! current generation's modules and bytes with its rate, and a bar with an
//! ETA when the final size is known in advance (the depth-first D0L plan)
//! or in a batch (jobs done of all). On when standard error is a terminal
//! (and -v is not given, and the string is not printed on the terminal); `--progress` forces it on, `--quiet` off. It
//! writes through [`crate::diag::eprint`], so a closed or full standard
//! error is ignored, never a panic.

use crate::derive::meter::Meter;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};
use std::io;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Standard error as indicatif's terminal, every write through `eprint`.
#[derive(Debug)]
struct Stderr;

impl TermLike for Stderr {
    fn width(&self) -> u16 {
        // SAFETY: TIOCGWINSZ fills a winsize; failure leaves it zeroed.
        let mut ws: libc::winsize = unsafe { std::mem::zeroed() };
        let ok = unsafe { libc::ioctl(2, libc::TIOCGWINSZ, &mut ws) } == 0;
        if ok && ws.ws_col > 0 {
            ws.ws_col
        } else {
            80
        }
    }
    fn move_cursor_up(&self, n: usize) -> io::Result<()> {
        if n > 0 {
            crate::diag::eprint(&format!("\x1b[{n}A"));
        }
        Ok(())
    }
    fn move_cursor_down(&self, n: usize) -> io::Result<()> {
        if n > 0 {
            crate::diag::eprint(&format!("\x1b[{n}B"));
        }
        Ok(())
    }
    fn move_cursor_right(&self, n: usize) -> io::Result<()> {
        if n > 0 {
            crate::diag::eprint(&format!("\x1b[{n}C"));
        }
        Ok(())
    }
    fn move_cursor_left(&self, n: usize) -> io::Result<()> {
        if n > 0 {
            crate::diag::eprint(&format!("\x1b[{n}D"));
        }
        Ok(())
    }
    fn write_line(&self, s: &str) -> io::Result<()> {
        crate::diag::eprint(&format!("{s}\n"));
        Ok(())
    }
    fn write_str(&self, s: &str) -> io::Result<()> {
        crate::diag::eprint(s);
        Ok(())
    }
    fn clear_line(&self) -> io::Result<()> {
        crate::diag::eprint("\r\x1b[2K");
        Ok(())
    }
    fn flush(&self) -> io::Result<()> {
        Ok(())
    }
}

/// Whether to show progress: `--progress` / `--quiet`, else when standard
/// error is a terminal, -v is off, and the string does not go to a
/// terminal on standard output (the bar would be drawn into it).
pub fn wanted(force_on: bool, force_off: bool, verbose: bool, to_stdout: bool) -> bool {
    use std::io::IsTerminal;
    if force_off {
        return false;
    }
    force_on
        || (!verbose && io::stderr().is_terminal() && !(to_stdout && io::stdout().is_terminal()))
}

fn bar() -> ProgressBar {
    ProgressBar::with_draw_target(
        None,
        ProgressDrawTarget::term_like_with_hz(Box::new(Stderr), 10),
    )
}

fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_spinner())
        .progress_chars("=> ")
}

/// A derivation's display: fed by a [`Meter`] and the steps done.
pub struct Derivation {
    pub meter: Arc<Meter>,
    /// Passes done (the axiom counts as 0; step k done: k).
    pub done: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    ticker: Option<std::thread::JoinHandle<()>>,
}

impl Derivation {
    /// Show the derivation of `steps` steps.
    pub fn start(steps: u64) -> Derivation {
        let meter = Arc::new(Meter::default());
        let done = Arc::new(AtomicU64::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let (m, d, s) = (meter.clone(), done.clone(), stop.clone());
        let ticker = crate::spawn::spawn(
            std::thread::Builder::new().name("lsgen-progress".into()),
            move || tick(&m, &d, &s, steps),
        )
        .ok();
        Derivation {
            meter,
            done,
            stop,
            ticker,
        }
    }
}

impl Drop for Derivation {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.ticker.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

fn tick(meter: &Meter, done: &AtomicU64, stop: &AtomicBool, steps: u64) {
    use crate::diag::group_digits;
    let pb = bar();
    pb.set_style(style("{spinner} {prefix}: {wide_msg} {elapsed}"));
    let mut with_bar = false;
    let (mut last, mut at) = (0u64, Instant::now());
    let mut rate = 0.0f64;
    // At least one drawing, however short the run.
    loop {
        let k = done.load(Ordering::Relaxed);
        let modules = meter.modules.load(Ordering::Relaxed);
        let bytes = meter.bytes.load(Ordering::Relaxed);
        let total = meter.final_bytes.load(Ordering::Relaxed);
        // Modules (bytes, with a bar) per second over the last tick (a new generation starts
        // from 0), smoothed.
        let dt = at.elapsed().as_secs_f64();
        let count = if total > 0 { bytes } else { modules };
        if dt >= 0.05 {
            let delta = count.checked_sub(last).unwrap_or(count);
            rate = if rate == 0.0 {
                delta as f64 / dt
            } else {
                0.7 * rate + 0.3 * (delta as f64 / dt)
            };
            (last, at) = (count, Instant::now());
        }
        if total > 0 {
            // Depth first: the final string is written in one pass, its
            // size known: a bar with an ETA.
            if !with_bar {
                pb.set_style(style("{prefix} [{bar:24}] {bytes}/{total_bytes} {msg}"));
                pb.set_prefix(format!("steps 1..{steps}"));
                pb.set_length(total);
                with_bar = true;
            }
            pb.set_position(bytes);
            let eta = (total.saturating_sub(bytes) as f64 / rate.max(1.0)).min(1e9);
            pb.set_message(format!(
                "{}/s ETA {}",
                indicatif::HumanBytes(rate as u64),
                short_duration(eta as u64)
            ));
        } else {
            if meter.depth_first.load(Ordering::Relaxed) {
                pb.set_prefix(format!("steps 1..{steps} (depth first)"));
            } else {
                let step = (k + 1).min(steps.max(1));
                pb.set_prefix(format!("step {step}/{steps}"));
            }
            pb.set_message(format!(
                "{} modules, {} bytes, {} modules/s",
                group_digits(modules),
                group_digits(bytes),
                group_digits(rate as u64)
            ));
        }
        pb.tick();
        if stop.load(Ordering::Relaxed) {
            break;
        }
        // Woken early by the end of the run.
        std::thread::park_timeout(Duration::from_millis(100));
    }
    pb.finish_and_clear();
}

/// `75` -> `1m15s`, `4000` -> `1h06m`.
fn short_duration(secs: u64) -> String {
    match secs {
        0..=59 => format!("{secs}s"),
        60..=3599 => format!("{}m{:02}s", secs / 60, secs % 60),
        _ => format!("{}h{:02}m", secs / 3600, secs / 60 % 60),
    }
}

/// Jobs a second, to three significant digits at most (indicatif's
/// `{per_sec}` printed `647.5313/s`).
fn jobs_rate(per_sec: f64) -> String {
    if !per_sec.is_finite() || per_sec <= 0.0 {
        "0/s".to_string()
    } else if per_sec >= 100.0 {
        format!("{}/s", crate::diag::group_digits(per_sec.round() as u64))
    } else if per_sec >= 10.0 {
        format!("{per_sec:.1}/s")
    } else {
        format!("{per_sec:.2}/s")
    }
}

/// A batch's display: jobs done of all, with an ETA.
pub struct Batch {
    bar: ProgressBar,
}

impl Batch {
    pub fn start(jobs: u64) -> Batch {
        let bar = bar();
        bar.set_style(
            style("jobs: [{bar:30}] {pos}/{len} ({rate}), ETA {eta} [{elapsed}]").with_key(
                "rate",
                |s: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = w.write_str(&jobs_rate(s.per_sec()));
                },
            ),
        );
        bar.set_length(jobs);
        bar.enable_steady_tick(Duration::from_millis(200));
        Batch { bar }
    }

    /// One more job finished.
    pub fn job_done(&self) {
        self.bar.inc(1);
    }
}

impl Drop for Batch {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::jobs_rate;

    #[test]
    fn a_batch_rate_has_three_significant_digits_at_most() {
        assert_eq!(jobs_rate(647.5313), "648/s");
        assert_eq!(jobs_rate(12_345.6), "12,346/s");
        assert_eq!(jobs_rate(42.04), "42.0/s");
        assert_eq!(jobs_rate(3.456), "3.46/s");
        assert_eq!(jobs_rate(0.0), "0/s");
        assert_eq!(jobs_rate(f64::NAN), "0/s");
        assert_eq!(jobs_rate(f64::INFINITY), "0/s");
    }
}
