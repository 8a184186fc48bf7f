//! Where the HLOD phase's time goes, by kind of work (`--stats`): each
//! thread charges the time between marks to the kind of work it is in,
//! exclusively (a BVH built inside a measurement counts as BVH, not as
//! the measurement), and [`crate::schedule`] adds each task's share to
//! the run's totals, so concurrent runs in one process do not mix.

use std::cell::RefCell;
use std::time::Instant;

/// The kinds of work charged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Welding, splitting into pieces and meshoptimizer steps.
    Simplify,
    /// Measuring a level's distance to its reference (from the level).
    Backward,
    /// Measuring the reference's distance to a level.
    Forward,
    /// The BVHs and exact-match sets the measurements query.
    Bvh,
    /// Flat regions of a measured surface ([`crate::planar`]).
    Planar,
    /// Reading a leaf's objects from the model or its spill.
    Read,
    /// Quantizing, encoding and compressing levels for the sink.
    Prepare,
    /// Merged proxies' distance fields and surfaces ([`crate::hlod`]).
    Proxy,
}

/// How many kinds there are, and their names in `--stats`.
pub(crate) const KINDS: [(Kind, &str); 8] = [
    (Kind::Simplify, "simplify"),
    (Kind::Backward, "certify level->reference"),
    (Kind::Forward, "certify reference->level"),
    (Kind::Bvh, "BVH builds"),
    (Kind::Planar, "flat regions"),
    (Kind::Read, "read objects"),
    (Kind::Prepare, "encode and compress"),
    (Kind::Proxy, "merged proxies"),
];

fn index(kind: Kind) -> usize {
    KINDS
        .iter()
        .position(|(k, _)| *k == kind)
        .expect("every kind is listed")
}

/// Nanoseconds per kind.
pub(crate) type Totals = [u64; KINDS.len()];

struct Clock {
    totals: Totals,
    /// The kinds entered and not left, innermost last.
    stack: Vec<usize>,
    since: Instant,
}

impl Clock {
    /// Charges the time since the last mark to the innermost kind.
    fn mark(&mut self) {
        let now = Instant::now();
        if let Some(&k) = self.stack.last() {
            self.totals[k] += (now - self.since).as_nanos() as u64;
        }
        self.since = now;
    }
}

thread_local! {
    static CLOCK: RefCell<Clock> = RefCell::new(Clock {
        totals: [0; KINDS.len()],
        stack: Vec::new(),
        since: Instant::now(),
    });
}

/// Runs `f`, charging its time (less what it charges to other kinds
/// inside) to `kind`.
pub(crate) fn timed<T>(kind: Kind, f: impl FnOnce() -> T) -> T {
    CLOCK.with(|c| {
        let mut c = c.borrow_mut();
        c.mark();
        c.stack.push(index(kind));
    });
    // Left even when `f` unwinds, so the stack stays balanced.
    struct Leave;
    impl Drop for Leave {
        fn drop(&mut self) {
            CLOCK.with(|c| {
                let mut c = c.borrow_mut();
                c.mark();
                c.stack.pop();
            });
        }
    }
    let _leave = Leave;
    f()
}

/// This thread's totals so far (what a task charged is the difference
/// between its end's and its start's).
pub(crate) fn totals() -> Totals {
    CLOCK.with(|c| {
        let mut c = c.borrow_mut();
        c.mark();
        c.totals
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn busy(ms: u64) {
        let t = Instant::now();
        while t.elapsed().as_millis() < ms as u128 {
            std::hint::spin_loop();
        }
    }

    #[test]
    fn nested_work_is_charged_to_the_inner_kind_only() {
        let before = totals();
        let outer = Instant::now();
        timed(Kind::Forward, || {
            busy(20);
            timed(Kind::Bvh, || busy(30));
            busy(20);
        });
        let outer = outer.elapsed().as_secs_f64() * 1e3;
        let after = totals();
        let ms = |k: Kind| (after[index(k)] - before[index(k)]) as f64 * 1e-6;
        let (bvh, forward) = (ms(Kind::Bvh), ms(Kind::Forward));
        assert!(bvh >= 30.0, "{bvh}");
        assert!(forward >= 40.0, "{forward}");
        // Charged once: the two together are no more than the whole
        // (counted twice, the BVH's 30 ms would be over it).
        assert!(bvh + forward <= outer + 0.01, "{bvh} + {forward} > {outer}");
        assert_eq!(ms(Kind::Simplify), 0.0);
    }

    #[test]
    fn a_panic_inside_leaves_the_clock_balanced() {
        let r = std::panic::catch_unwind(|| timed(Kind::Read, || panic!("bad object")));
        assert!(r.is_err());
        let before = totals();
        busy(5);
        let after = totals();
        // Nothing is entered now: the time is charged to no kind.
        assert_eq!(before, after);
    }
}
