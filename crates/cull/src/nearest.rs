//! The order of the nearest-first walks: traversal's queue (front to
//! back, so occluders come before what they hide) and a pick's (the first
//! hit ends the walk).

use std::cmp::Ordering;

/// A queued node with what its walk keeps beside it, ordered so that
/// `BinaryHeap` (a max-heap) pops the nearest; ties go to the lower node
/// index, so the order is deterministic.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Nearest<T> {
    pub distance: f64,
    pub node: u32,
    pub item: T,
}

impl<T> PartialEq for Nearest<T> {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl<T> Eq for Nearest<T> {}
impl<T> PartialOrd for Nearest<T> {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl<T> Ord for Nearest<T> {
    fn cmp(&self, o: &Self) -> Ordering {
        o.distance
            .total_cmp(&self.distance)
            .then(o.node.cmp(&self.node))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BinaryHeap;

    #[test]
    fn pops_nearest_first_and_ties_by_lower_node() {
        let mut heap = BinaryHeap::new();
        for (distance, node) in [(2.0, 1), (0.5, 7), (2.0, 0), (-0.0, 3), (0.0, 2)] {
            heap.push(Nearest {
                distance,
                node,
                item: (),
            });
        }
        let order: Vec<u32> = std::iter::from_fn(|| heap.pop().map(|e| e.node)).collect();
        // -0 sorts before +0 (total order), then 0.5, then the tie at 2.
        assert_eq!(order, [3, 2, 7, 0, 1]);
    }
}
