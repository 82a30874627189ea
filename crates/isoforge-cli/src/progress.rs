//! Live progress on stderr for work that takes longer than about a second, only when stderr is a
//! terminal (nothing at all otherwise: no bar text in logs, pipes or tests).
//!
//! A [`Task`] starts hidden; after [`SHOW_AFTER`] a watcher thread draws it — a spinner with the
//! elapsed time until the work reports a total through [`Progress`], then a bar with percent and
//! an estimate. [`spin`] wraps a call that reports nothing (decoding a file, writing a mesh).
//!
//! `ISOFORGE_PROGRESS=never` turns progress off; `ISOFORGE_PROGRESS=always` draws it at once,
//! terminal or not (plain lines when stderr is a file or a pipe: for logs of long runs, and tests).
//! `ISOFORGE_PROGRESS_AFTER_MS=N` changes [`SHOW_AFTER`] (tests of the terminal case use 0).

use std::borrow::Cow;
use std::io::{IsTerminal, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle, TermLike};
use isoforge::walk::Progress;

/// Work shorter than this never shows anything.
pub const SHOW_AFTER: Duration = Duration::from_secs(1);

/// [`SHOW_AFTER`], or `ISOFORGE_PROGRESS_AFTER_MS` when set.
fn show_after() -> Duration {
    std::env::var("ISOFORGE_PROGRESS_AFTER_MS")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(SHOW_AFTER, Duration::from_millis)
}

/// How often a shown task redraws by itself (the spinner and the elapsed time stay live between
/// reports).
const TICK: Duration = Duration::from_millis(100);

/// When progress is drawn (`ISOFORGE_PROGRESS`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Mode {
    /// On a terminal, after [`SHOW_AFTER`] (the default).
    Auto,
    /// At once, terminal or not.
    Always,
    /// Never.
    Never,
}

fn mode() -> Mode {
    match std::env::var("ISOFORGE_PROGRESS").as_deref() {
        Ok("always") => Mode::Always,
        Ok("never") => Mode::Never,
        _ => Mode::Auto,
    }
}

/// Whether progress is drawn at all: when stderr is a terminal, unless forced.
fn enabled() -> bool {
    match mode() {
        Mode::Auto => std::io::stderr().is_terminal(),
        Mode::Always => true,
        Mode::Never => false,
    }
}

/// Where a shown task draws: the terminal, or plain lines on stderr when forced onto a file.
fn draw_target() -> ProgressDrawTarget {
    if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::term_like_with_hz(Box::new(PlainLines), 4)
    }
}

/// A "terminal" that writes each redraw as a line (no cursor movement): readable in a log.
#[derive(Debug)]
struct PlainLines;

impl TermLike for PlainLines {
    fn width(&self) -> u16 {
        100
    }
    fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
        Ok(())
    }
    fn write_line(&self, s: &str) -> std::io::Result<()> {
        self.write_str(s)
    }
    fn write_str(&self, s: &str) -> std::io::Result<()> {
        // Blank padding (how a terminal line is cleared) is not worth a log line.
        match s.trim_end() {
            "" => Ok(()),
            line => writeln!(std::io::stderr(), "{line}"),
        }
    }
    fn clear_line(&self) -> std::io::Result<()> {
        Ok(())
    }
    fn flush(&self) -> std::io::Result<()> {
        std::io::stderr().flush()
    }
}

/// How a task shows its reports.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `message [=====>    ] 42% (3s, eta 4s)`.
    Percent,
    /// `message 3 of 12 [=====>    ] (3s)`: counted items such as labels.
    Count,
}

/// A unit of work that may show progress; see the module doc.
pub struct Task {
    bar: ProgressBar,
    kind: Kind,
    /// Set once a total arrived and the bar style replaced the spinner.
    measured: AtomicBool,
    done: Arc<(Mutex<bool>, Condvar)>,
    watcher: Option<JoinHandle<()>>,
}

fn spinner_style() -> ProgressStyle {
    ProgressStyle::with_template("{spinner} {msg} ({elapsed})").unwrap_or_else(|_| ProgressStyle::default_spinner())
}

fn bar_style(kind: Kind) -> ProgressStyle {
    let template = match kind {
        Kind::Percent => "{msg} [{bar:40}] {percent}% ({elapsed}, eta {eta})",
        Kind::Count => "{msg} {pos} of {len} [{bar:40}] ({elapsed})",
    };
    ProgressStyle::with_template(template)
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar())
}

impl Task {
    /// Starts a task reported as a percentage.
    pub fn start(message: impl Into<Cow<'static, str>>) -> Task {
        Task::with_kind(message, Kind::Percent)
    }

    /// Starts a task of counted items (`message 3 of 12`).
    pub fn counting(message: impl Into<Cow<'static, str>>) -> Task {
        Task::with_kind(message, Kind::Count)
    }

    fn with_kind(message: impl Into<Cow<'static, str>>, kind: Kind) -> Task {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
        bar.set_style(spinner_style());
        bar.set_message(message);
        let done = Arc::new((Mutex::new(false), Condvar::new()));
        if mode() == Mode::Always {
            bar.set_draw_target(draw_target());
            bar.force_draw();
            bar.enable_steady_tick(TICK);
            return Task { bar, kind, measured: AtomicBool::new(false), done, watcher: None };
        }
        let watcher = enabled().then(|| {
            let (bar, done) = (bar.clone(), Arc::clone(&done));
            std::thread::spawn(move || {
                let (lock, cv) = &*done;
                let Ok(guard) = lock.lock() else { return };
                let Ok((finished, _)) = cv.wait_timeout_while(guard, show_after(), |d| !*d) else { return };
                if !*finished {
                    bar.set_draw_target(draw_target());
                    bar.enable_steady_tick(TICK);
                }
            })
        });
        Task { bar, kind, measured: AtomicBool::new(false), done, watcher }
    }

    /// Ends the task and clears its line.
    pub fn finish(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        let (lock, cv) = &*self.done;
        if let Ok(mut d) = lock.lock() {
            *d = true;
        }
        cv.notify_all();
        if let Some(w) = self.watcher.take() {
            let _ = w.join();
        }
        self.bar.finish_and_clear();
    }
}

impl Drop for Task {
    fn drop(&mut self) {
        self.stop();
    }
}

impl Progress for Task {
    fn advance(&self, done: u64, total: u64) {
        if total == 0 {
            return;
        }
        if !self.measured.swap(true, Ordering::Relaxed) {
            self.bar.set_style(bar_style(self.kind));
        }
        self.bar.set_length(total);
        // A count names the item in hand ("label 3 of 12" while the third is meshed).
        let shown = if self.kind == Kind::Count { done + 1 } else { done };
        self.bar.set_position(shown.min(total));
    }
}

/// Runs `f` as a task with a spinner (after a second, on a terminal) and returns its result.
pub fn spin<R>(message: impl Into<Cow<'static, str>>, f: impl FnOnce() -> R) -> R {
    let task = Task::start(message);
    let r = f();
    task.finish();
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without a terminal (as under `cargo test`) a task is never drawn and starts no thread.
    #[test]
    fn hidden_without_a_terminal() {
        if enabled() {
            return; // stderr is a terminal here: nothing to show about the hidden case
        }
        let t = Task::start("work");
        assert!(t.watcher.is_none());
        t.advance(1, 2);
        assert!(t.bar.is_hidden());
        assert_eq!(spin("more", || 7), 7);
    }
}
