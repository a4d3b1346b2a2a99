//! Blocks of particles on one or more threads. The cloud is cut into blocks of [`BLOCK`] particles
//! whatever the thread count; threads take whole blocks, and the blocks' sums are added in block order
//! afterwards, so the result has the same bits on one thread or many.

use super::kernels::BLOCK;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};

/// Below this many particles a pass stays on the calling thread: a thread costs ~20 µs to start, and
/// on a busy machine a helper may wait milliseconds for a core, which only a long pass can afford.
pub(super) const PARALLEL_FROM: usize = 64 * BLOCK;

/// Columns that can be cut at a particle index.
pub(super) trait Split: Sized + Send {
    fn split_at(self, mid: usize) -> (Self, Self);
}

impl Split for &[f64] {
    fn split_at(self, mid: usize) -> (Self, Self) {
        <[f64]>::split_at(self, mid)
    }
}

impl Split for &mut [f64] {
    fn split_at(self, mid: usize) -> (Self, Self) {
        self.split_at_mut(mid)
    }
}

impl Split for &[u32] {
    fn split_at(self, mid: usize) -> (Self, Self) {
        <[u32]>::split_at(self, mid)
    }
}

impl<T: Split, const K: usize> Split for [T; K] {
    fn split_at(self, mid: usize) -> (Self, Self) {
        let mut tails: [Option<T>; K] = [const { None }; K];
        let mut k = 0;
        let heads = self.map(|c| {
            let (h, t) = c.split_at(mid);
            tails[k] = Some(t);
            k += 1;
            h
        });
        (heads, tails.map(|t| t.expect("every column was split")))
    }
}

impl<A: Split, B: Split> Split for (A, B) {
    fn split_at(self, mid: usize) -> (Self, Self) {
        let (a0, a1) = self.0.split_at(mid);
        let (b0, b1) = self.1.split_at(mid);
        ((a0, b0), (a1, b1))
    }
}

static MAX_THREADS: AtomicUsize = AtomicUsize::new(0);

/// At most this many threads per pass of any particle filter of this process (0: one per core, the
/// default). Benchmarks use it; the estimates are the same bits whatever it is.
pub fn set_max_threads(n: usize) {
    MAX_THREADS.store(n, Ordering::Relaxed);
}

/// The threads a pass over `n` particles uses when the filter does not say: every core (or
/// [`set_max_threads`]) from `PARALLEL_FROM` particles on, else one.
pub fn auto_threads(n: usize) -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    if n < PARALLEL_FROM {
        return 1;
    }
    let cores = *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |c| c.get()));
    match MAX_THREADS.load(Ordering::Relaxed) {
        0 => cores,
        m => m,
    }
}

/// `f(k, block k of view)` over the `len` particles of `view`, block by block, blocks `first..` on
/// this thread; `fold` gets the results in block order.
fn sequential<V: Split, P>(
    view: V,
    len: usize,
    first: u64,
    f: &(impl Fn(u64, V) -> P + Sync),
    fold: &mut impl FnMut(P),
) {
    let (mut rest, mut start, mut k) = (view, 0, first);
    while start < len {
        let m = BLOCK.min(len - start);
        let (head, tail) = rest.split_at(m);
        fold(f(k, head));
        rest = tail;
        start += m;
        k += 1;
    }
}

/// `f(k, block k)` for every block of `view` (`len` particles) on up to `threads` threads, `fold` of
/// the results in block order. The blocks are handed out one at a time from a queue: a thread that
/// the machine's load keeps from running leaves its share to the others instead of holding the pass
/// up (this thread takes blocks too).
pub(super) fn blocks<V: Split, P: Send>(
    threads: usize,
    len: usize,
    view: V,
    f: impl Fn(u64, V) -> P + Sync,
    mut fold: impl FnMut(P),
) {
    let n_blocks = len.div_ceil(BLOCK);
    let threads = threads.clamp(1, n_blocks.max(1));
    if threads == 1 {
        sequential(view, len, 0, &f, &mut fold);
        return;
    }
    let mut parts = Vec::with_capacity(n_blocks);
    let (mut rest, mut start) = (view, 0);
    while start < len {
        let m = BLOCK.min(len - start);
        let (head, tail) = rest.split_at(m);
        parts.push(head);
        rest = tail;
        start += m;
    }
    let queue = Mutex::new(parts.into_iter().enumerate());
    let work = || {
        let mut done = Vec::new();
        loop {
            let next = queue.lock().map(|mut q| q.next()).unwrap_or(None);
            match next {
                Some((k, part)) => done.push((k, f(k as u64, part))),
                None => return done,
            }
        }
    };
    let mut results: Vec<Option<P>> = (0..n_blocks).map(|_| None).collect();
    std::thread::scope(|s| {
        let helpers: Vec<_> = (1..threads).map(|_| s.spawn(work)).collect();
        let mut all = work();
        for h in helpers {
            match h.join() {
                Ok(done) => all.extend(done),
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
        for (k, p) in all {
            results[k] = Some(p);
        }
    });
    for p in results.into_iter().flatten() {
        fold(p);
    }
}
