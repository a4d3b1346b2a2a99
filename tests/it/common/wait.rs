//! Bounded waits: poll a condition until it holds or the time is up; the error says what was awaited.

use std::fmt;
use std::future::Future;
use std::time::{Duration, Instant};

/// A wait that ran out of time.
pub struct Timeout {
    what: String,
    after: Duration,
}

impl fmt::Display for Timeout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "timed out after {:?} waiting for {}",
            self.after, self.what
        )
    }
}

// `unwrap` and `expect` print the Debug form: the same sentence.
impl fmt::Debug for Timeout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl std::error::Error for Timeout {}

/// The clock of one wait.
struct Deadline<'a> {
    what: &'a str,
    timeout: Duration,
    start: Instant,
}

impl Deadline<'_> {
    /// The pause before the next look, or the timeout when the time is up: a tenth of the time waited
    /// so far, from 100 µs to 50 ms, so that a short wait ends soon after its condition holds and a long
    /// one does not busy the machine; the last look is at the deadline.
    fn pause(&self) -> Result<Duration, Timeout> {
        let waited = self.start.elapsed();
        if waited >= self.timeout {
            return Err(Timeout {
                what: self.what.to_string(),
                after: self.timeout,
            });
        }
        Ok((waited / 10)
            .clamp(Duration::from_micros(100), Duration::from_millis(50))
            .min(self.timeout - waited))
    }
}

/// Polls `done` until it returns true (`Ok`) or `timeout` has passed (`Err`, naming `what`, the
/// condition awaited).
pub fn wait_until(
    what: &str,
    timeout: Duration,
    mut done: impl FnMut() -> bool,
) -> Result<(), Timeout> {
    let deadline = Deadline {
        what,
        timeout,
        start: Instant::now(),
    };
    while !done() {
        std::thread::sleep(deadline.pause()?);
    }
    Ok(())
}

/// [`wait_until`] for a condition that has to await (a zenoh query); pauses without blocking the
/// runtime.
pub async fn wait_until_async<F: Future<Output = bool>>(
    what: &str,
    timeout: Duration,
    mut done: impl FnMut() -> F,
) -> Result<(), Timeout> {
    let deadline = Deadline {
        what,
        timeout,
        start: Instant::now(),
    };
    while !done().await {
        tokio::time::sleep(deadline.pause()?).await;
    }
    Ok(())
}

#[test]
fn a_wait_ends_when_its_condition_holds_or_says_what_it_awaited() {
    let mut looks = 0;
    wait_until("the third look", Duration::from_secs(10), || {
        looks += 1;
        looks == 3
    })
    .unwrap();
    assert_eq!(looks, 3);
    let start = Instant::now();
    let e = wait_until("nothing", Duration::from_millis(30), || false).unwrap_err();
    assert!(start.elapsed() >= Duration::from_millis(30));
    assert_eq!(e.to_string(), "timed out after 30ms waiting for nothing");
}
