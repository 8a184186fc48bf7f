//! Making every node's levels on every core: a node is made as soon as its
//! children are, on rayon's pool, and the results reach the sink on the
//! calling thread in a fixed sequence ([`crate::order`]'s), so the scene is
//! the same bytes whatever the timing.
//!
//! Nothing waits for a level of the tree or a batch to finish: a unit's
//! top nodes (one or two at a time) run beside the next units' leaves. What
//! is in flight is bounded by a window over the sequence: a leaf is started
//! only while the leaves started and not yet handed to the sink hold at
//! most `window` input triangles (the first one not handed on is always
//! started, so a leaf larger than the window still runs). Inner nodes hold
//! no input of their own and start when their children are done.
//!
//! Each node's work (the seconds its `make` ran) is recorded, and with the
//! tree's dependencies gives the total work W and the critical path S
//! ([`Work`]): on N cores the phase takes at least max(W / N, S).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::Instant;

use crate::hierarchy::HNode;
use crate::spent;

/// What a node's result is waiting for: one count per child in the
/// sequence, and one for being admitted to the window.
struct Pending(Vec<AtomicU32>);

/// A made node's message to the calling thread.
enum Message<L, E> {
    Made(usize, L),
    Failed(E),
    Panicked(Box<dyn std::any::Any + Send>),
}

/// What the workers share.
struct Shared<'a, P, L, E> {
    tree: &'a [HNode],
    in_sequence: &'a [bool],
    make: &'a (dyn Fn(usize, Vec<P>) -> Result<(P, L), E> + Sync),
    pending: Pending,
    /// What each done node leaves for its parent, until the parent takes it.
    slots: Vec<Mutex<Option<P>>>,
    /// Nanoseconds each made node's `make` ran.
    nanos: Vec<AtomicU64>,
    /// Nanoseconds by kind of work ([`spent`]), over every task and
    /// the calling thread's `emit`.
    spent: Vec<AtomicU64>,
    /// Nodes started or waiting to start and not yet ended.
    queued: AtomicUsize,
    /// Set on the first failure: nodes not yet started are skipped.
    cancelled: AtomicBool,
    tx: Mutex<mpsc::Sender<Message<L, E>>>,
}

impl<'a, P: Send, L: Send, E: Send> Shared<'a, P, L, E> {
    fn children(&self, ni: usize) -> impl Iterator<Item = usize> + '_ {
        let n = &self.tree[ni];
        (n.first_child..n.first_child + n.child_count)
            .map(|c| c as usize)
            .filter(|&c| self.in_sequence[c])
    }

    fn send(&self, m: Message<L, E>) {
        // The receiver lives until every task has ended.
        let _ = self.tx.lock().unwrap_or_else(|e| e.into_inner()).send(m);
    }

    /// One of `ni`'s counts is met; starts it when that was the last.
    fn release<'s>(&'s self, scope: &rayon::Scope<'s>, ni: usize)
    where
        'a: 's,
    {
        if self.pending.0[ni].fetch_sub(1, Ordering::AcqRel) == 1 {
            self.queued.fetch_add(1, Ordering::Relaxed);
            scope.spawn(move |s| {
                self.run(s, ni);
                self.queued.fetch_sub(1, Ordering::Relaxed);
            });
        }
    }

    /// Stores a done node's part for its parent and releases the parent.
    fn done<'s>(&'s self, scope: &rayon::Scope<'s>, ni: usize, p: P)
    where
        'a: 's,
    {
        *self.slots[ni].lock().unwrap_or_else(|e| e.into_inner()) = Some(p);
        let parent = self.tree[ni].parent;
        if parent != gigawalk_scene::NO_NODE && self.in_sequence[parent as usize] {
            self.release(scope, parent as usize);
        }
    }

    /// Adds what this thread charged since `before` to the run's totals.
    fn charge(&self, before: spent::Totals) {
        let after = spent::totals();
        for (k, total) in self.spent.iter().enumerate() {
            total.fetch_add(after[k] - before[k], Ordering::Relaxed);
        }
    }

    fn take_children(&self, ni: usize) -> Vec<P> {
        self.children(ni)
            .filter_map(|c| {
                self.slots[c]
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .take()
            })
            .collect()
    }

    fn run<'s>(&'s self, scope: &rayon::Scope<'s>, ni: usize)
    where
        'a: 's,
    {
        if self.cancelled.load(Ordering::Relaxed) {
            return;
        }
        let children = self.take_children(ni);
        let (started, before) = (Instant::now(), spent::totals());
        let made = catch_unwind(AssertUnwindSafe(|| (self.make)(ni, children)));
        self.nanos[ni].store(started.elapsed().as_nanos() as u64, Ordering::Relaxed);
        self.charge(before);
        match made {
            Ok(Ok((p, l))) => {
                self.done(scope, ni, p);
                self.send(Message::Made(ni, l));
            }
            Ok(Err(e)) => {
                self.cancelled.store(true, Ordering::Relaxed);
                self.send(Message::Failed(e));
            }
            Err(panic) => {
                self.cancelled.store(true, Ordering::Relaxed);
                self.send(Message::Panicked(panic));
            }
        }
    }
}

/// What a run's nodes cost, for [`Work::speedup`].
#[derive(Clone, Debug, Default)]
pub(crate) struct Work {
    /// Seconds each node's `make` ran (0 for nodes outside the sequence).
    pub(crate) node_seconds: Vec<f64>,
    /// Seconds the calling thread spent in `emit`: serial, in sequence.
    pub(crate) emit_seconds: f64,
    /// Seconds the window was full while fewer nodes were running or
    /// waiting to run than there are threads: cores idle because no
    /// further leaf could start (as seen at each result the sink waited
    /// for).
    pub(crate) window_starved_seconds: f64,
    /// Seconds by kind of work ([`spent::KINDS`]), tasks and `emit`
    /// together.
    pub(crate) spent: Vec<f64>,
}

impl Work {
    /// Total work: every node's seconds and the emission's.
    pub(crate) fn total(&self) -> f64 {
        self.node_seconds.iter().sum::<f64>() + self.emit_seconds
    }

    /// The critical path: the costliest chain of nodes from a leaf up to a
    /// root (a node starts only once its children are done), or the
    /// emission, which is one serial stream, if that is longer.
    pub(crate) fn span(&self, tree: &[HNode]) -> f64 {
        // Children have larger indices than their parents in the tree's
        // layout; walking from the end sees every child first.
        let mut path = self.node_seconds.clone();
        for i in (0..tree.len()).rev() {
            let n = &tree[i];
            let below = (n.first_child..n.first_child + n.child_count)
                .map(|c| path[c as usize])
                .fold(0.0f64, f64::max);
            path[i] += below;
        }
        path.iter().copied().fold(self.emit_seconds, f64::max)
    }

    /// The speed-up `cores` allow over one: W / max(W / N, S).
    pub(crate) fn speedup(&self, tree: &[HNode], cores: usize) -> f64 {
        let (w, s) = (self.total(), self.span(tree));
        if w <= 0.0 {
            return 1.0;
        }
        w / (w / cores.max(1) as f64).max(s)
    }
}

/// Makes the nodes of `sequence` (children before parents) with `make`
/// (given the parts their children in the sequence left, in child order)
/// on rayon's pool, and hands every node's result to `emit` in sequence
/// order on this thread. `cost`: a node's input triangles
/// held in flight ([`window`](self)). Returns the parts no parent in the
/// sequence took (the sequence's roots'), and the [`Work`].
///
/// The first error (from `make` or `emit`) is returned once the nodes
/// already started have ended; a panic in `make` is resumed here.
#[allow(clippy::type_complexity)]
pub(crate) fn run<P: Send, L: Send, E: Send>(
    tree: &[HNode],
    sequence: &[usize],
    window: u64,
    cost: &dyn Fn(usize) -> u64,
    make: &(dyn Fn(usize, Vec<P>) -> Result<(P, L), E> + Sync),
    emit: &mut dyn FnMut(usize, L) -> Result<(), E>,
) -> Result<(Vec<Option<P>>, Work), E> {
    let mut in_sequence = vec![false; tree.len()];
    for &ni in sequence {
        in_sequence[ni] = true;
    }
    let (tx, rx) = mpsc::channel();
    let mut shared = Shared {
        tree,
        in_sequence: &in_sequence,
        make,
        pending: Pending(Vec::new()),
        slots: (0..tree.len()).map(|_| Mutex::new(None)).collect(),
        nanos: (0..tree.len()).map(|_| AtomicU64::new(0)).collect(),
        spent: spent::KINDS.iter().map(|_| AtomicU64::new(0)).collect(),
        queued: AtomicUsize::new(0),
        cancelled: AtomicBool::new(false),
        tx: Mutex::new(tx),
    };
    shared.pending = Pending(
        (0..tree.len())
            .map(|ni| AtomicU32::new(shared.children(ni).count() as u32 + 1))
            .collect(),
    );
    let (mut emit_seconds, mut window_starved_seconds) = (0.0, 0.0);
    let threads = rayon::current_num_threads();
    let outcome = rayon::in_place_scope(|scope| -> Result<(), E> {
        let shared = &shared;
        // Whatever ends the loop early stops what has not started.
        struct Cancel<'c>(&'c AtomicBool);
        impl Drop for Cancel<'_> {
            fn drop(&mut self) {
                self.0.store(true, Ordering::Relaxed);
            }
        }
        let cancel = Cancel(&shared.cancelled);
        let mut waiting: std::collections::HashMap<usize, L> = Default::default();
        let (mut admitted, mut in_flight) = (0usize, 0u64);
        for (k, &ni) in sequence.iter().enumerate() {
            while admitted < sequence.len()
                && (admitted == k || in_flight + cost(sequence[admitted]) <= window)
            {
                let a = sequence[admitted];
                in_flight += cost(a);
                shared.release(scope, a);
                admitted += 1;
            }
            let full = admitted < sequence.len();
            let mut since = Instant::now();
            let result = loop {
                if let Some(l) = waiting.remove(&ni) {
                    break l;
                }
                let starved = full && shared.queued.load(Ordering::Relaxed) < threads;
                let message = receive(&rx);
                if starved {
                    window_starved_seconds += since.elapsed().as_secs_f64();
                }
                since = Instant::now();
                match message {
                    Message::Made(m, l) => {
                        waiting.insert(m, l);
                    }
                    Message::Failed(e) => return Err(e),
                    Message::Panicked(p) => std::panic::resume_unwind(p),
                }
            };
            let (started, before) = (Instant::now(), spent::totals());
            let emitted = emit(ni, result);
            emit_seconds += started.elapsed().as_secs_f64();
            shared.charge(before);
            emitted?;
            in_flight -= cost(ni);
        }
        std::mem::forget(cancel);
        Ok(())
    });
    outcome?;
    let work = Work {
        node_seconds: shared
            .nanos
            .iter()
            .map(|n| n.load(Ordering::Relaxed) as f64 * 1e-9)
            .collect(),
        emit_seconds,
        window_starved_seconds,
        spent: shared
            .spent
            .iter()
            .map(|n| n.load(Ordering::Relaxed) as f64 * 1e-9)
            .collect(),
    };
    let parts = shared
        .slots
        .into_iter()
        .map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()))
        .collect();
    Ok((parts, work))
}

/// The next message; on one of rayon's threads, runs other tasks while
/// none has come (blocking a worker could leave no one to send it).
fn receive<M>(rx: &mpsc::Receiver<M>) -> M {
    loop {
        match rx.try_recv() {
            Ok(m) => return m,
            Err(mpsc::TryRecvError::Disconnected) => unreachable!("the sender lives in the scope"),
            Err(mpsc::TryRecvError::Empty) => {}
        }
        match rayon::yield_now() {
            // Not one of rayon's threads: nothing to run here.
            None => {
                return rx
                    .recv()
                    .unwrap_or_else(|_| unreachable!("the sender lives in the scope"))
            }
            Some(rayon::Yield::Executed) => {}
            Some(rayon::Yield::Idle) => {
                if let Ok(m) = rx.recv_timeout(std::time::Duration::from_millis(1)) {
                    return m;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_scene::{Aabb, NO_NODE};

    /// 0 -> (1, 2), 1 -> (3, 4), 2 -> (5, 6, 7); leaves 3-7.
    fn tree() -> Vec<HNode> {
        let node = |parent: u32, first_child: u32, child_count: u32, depth: u32| HNode {
            bounds: Aabb::EMPTY,
            parent,
            first_child,
            child_count,
            object: (child_count == 0).then_some(0),
            depth,
        };
        vec![
            node(NO_NODE, 1, 2, 1),
            node(0, 3, 2, 2),
            node(0, 5, 3, 2),
            node(1, 0, 0, 3),
            node(1, 0, 0, 3),
            node(2, 0, 0, 3),
            node(2, 0, 0, 3),
            node(2, 0, 0, 3),
        ]
    }

    const SEQUENCE: [usize; 8] = [3, 4, 5, 6, 7, 1, 2, 0];

    /// [`run`] over [`SEQUENCE`], the window open.
    #[allow(clippy::type_complexity)]
    fn run_all(
        tree: &[HNode],
        make: &(dyn Fn(usize, Vec<u32>) -> Result<(u32, String), String> + Sync),
        emit: &mut dyn FnMut(usize, String) -> Result<(), String>,
    ) -> Result<(Vec<Option<u32>>, Work), String> {
        run(tree, &SEQUENCE, u64::MAX, &|_| 1, make, emit)
    }

    /// Each node's part is the number of leaves below it; its result
    /// names it and what its children left.
    fn count(
        tree: &[HNode],
    ) -> impl Fn(usize, Vec<u32>) -> Result<(u32, String), String> + Sync + '_ {
        move |ni, children: Vec<u32>| {
            let n = &tree[ni];
            assert_eq!(children.len(), n.child_count as usize, "node {ni}");
            let leaves = if n.child_count == 0 {
                1
            } else {
                children.iter().sum()
            };
            Ok((leaves, format!("{ni}:{leaves}")))
        }
    }

    #[test]
    fn every_node_is_made_after_its_children_and_handed_on_in_sequence() {
        let tree = tree();
        for window in [0, 1, 3, u64::MAX] {
            let mut seen = Vec::new();
            let (left, work) = run(
                &tree,
                &SEQUENCE,
                window,
                &|ni| u64::from(tree[ni].child_count == 0),
                &count(&tree),
                &mut |ni, made: String| {
                    seen.push((ni, made));
                    Ok(())
                },
            )
            .unwrap();
            let names: Vec<&str> = seen.iter().map(|(_, s)| s.as_str()).collect();
            assert_eq!(
                names,
                ["3:1", "4:1", "5:1", "6:1", "7:1", "1:2", "2:3", "0:5"],
                "window {window}"
            );
            // Only the root's part is left: every other went to a parent.
            assert_eq!(left[0], Some(5));
            assert!(left[1..].iter().all(Option::is_none));
            assert_eq!(work.node_seconds.len(), tree.len());
        }
    }

    #[test]
    fn a_shards_sequence_leaves_its_roots_parts() {
        let tree = tree();
        // Node 1's subtree alone: its parent is not in the sequence.
        let (left, _) = run(
            &tree,
            &[3, 4, 1],
            u64::MAX,
            &|_| 0,
            &count(&tree),
            &mut |_, _: String| Ok(()),
        )
        .unwrap();
        assert_eq!(left[1], Some(2));
        assert!(left[0].is_none() && left[2].is_none());
    }

    #[test]
    fn the_first_failure_is_returned_and_nothing_above_it_is_made() {
        let tree = tree();
        let made = AtomicU32::new(0);
        let make = |ni: usize, children: Vec<u32>| {
            made.fetch_add(1, Ordering::Relaxed);
            if ni == 6 {
                return Err(format!("node {ni} is broken"));
            }
            count(&tree)(ni, children)
        };
        let mut handed = Vec::new();
        let err = run_all(&tree, &make, &mut |ni, _| {
            handed.push(ni);
            Ok(())
        })
        .unwrap_err();
        assert_eq!(err, "node 6 is broken");
        // Node 2 and the root wait for node 6 and are never made; nothing
        // after node 5 in the sequence reaches the sink.
        assert!(made.load(Ordering::Relaxed) <= 6);
        assert!(!handed.contains(&6) && !handed.contains(&2) && !handed.contains(&0));
    }

    #[test]
    fn an_error_from_the_sink_stops_the_run() {
        let tree = tree();
        let err = run_all(&tree, &count(&tree), &mut |ni, _| {
            if ni == 5 {
                Err("disk full".to_string())
            } else {
                Ok(())
            }
        })
        .unwrap_err();
        assert_eq!(err, "disk full");
    }

    #[test]
    fn a_panic_while_making_a_node_reaches_the_caller() {
        let tree = tree();
        let r = catch_unwind(AssertUnwindSafe(|| {
            let make = |ni, children| {
                assert_ne!(ni, 1, "node 1 cannot be made");
                count(&tree)(ni, children)
            };
            run_all(&tree, &make, &mut |_, _| Ok(()))
        }));
        let panic = r.unwrap_err();
        let message = panic.downcast_ref::<String>().cloned().unwrap_or_default();
        assert!(message.contains("node 1 cannot be made"), "{message}");
    }

    #[test]
    fn work_and_span_follow_the_tree() {
        let tree = tree();
        let mut node_seconds = vec![0.0; tree.len()];
        // The chain 0-2-5 costs 1 + 2 + 4 = 7 of 15 in all.
        for (ni, s) in [
            (0, 1.0),
            (1, 1.0),
            (2, 2.0),
            (3, 3.0),
            (4, 1.0),
            (5, 4.0),
            (6, 1.0),
            (7, 1.0),
        ] {
            node_seconds[ni] = s;
        }
        let work = Work {
            node_seconds,
            emit_seconds: 1.0,
            window_starved_seconds: 0.0,
            spent: Vec::new(),
        };
        assert_eq!(work.total(), 15.0);
        assert_eq!(work.span(&tree), 7.0);
        assert_eq!(work.speedup(&tree, 1), 1.0);
        assert_eq!(work.speedup(&tree, 2), 2.0);
        assert!((work.speedup(&tree, 16) - 15.0 / 7.0).abs() < 1e-12);
        // A sink slower than every chain is the span.
        let slow_sink = Work {
            emit_seconds: 9.0,
            ..work
        };
        assert_eq!(slow_sink.span(&tree), 9.0);
    }
}
