//! Free TCP ports on 127.0.0.1 for the tests: one file, included by the service's `tests/it` and by
//! the lab's `tests/lab` (`#[path]`), which are separate crates.

use std::collections::BTreeSet;
use std::net::TcpListener;
use std::sync::Mutex;

/// A TCP port on 127.0.0.1 that was free a moment ago, and that no other test of this binary has been
/// given (the tests run in parallel in one process: two of them must not both listen on one port).
/// Taken below the kernel's ephemeral range (32768 and up on Linux), where `bind(0)` and every outgoing
/// connection get theirs: a zenoh client connecting elsewhere cannot take it between now and the
/// service's bind, as it could take a port `bind(0)` had just handed out.
pub fn free_port() -> u16 {
    static GIVEN: Mutex<BTreeSet<u16>> = Mutex::new(BTreeSet::new());
    const LOW: u32 = 20_000;
    const SPAN: u32 = 12_000;
    // Where this process starts in the span (another test binary starts elsewhere), then a stride
    // prime to the span.
    let start = std::process::id().wrapping_mul(7_919) % SPAN;
    // One lock over the check and the insertion: two tests asking at once were both given a port
    // when each checked it before either had inserted it.
    let mut given = GIVEN.lock().unwrap_or_else(|e| e.into_inner());
    for k in 0..SPAN {
        let port = (LOW + (start + k * 4_001) % SPAN) as u16;
        if given.contains(&port) || TcpListener::bind(("127.0.0.1", port)).is_err() {
            continue;
        }
        given.insert(port);
        return port;
    }
    panic!("no free port on 127.0.0.1 in {LOW}..{}", LOW + SPAN)
}
