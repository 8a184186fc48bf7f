//! The order of the nearest-first walks: traversal's queue (front to
//! back, so occluders come before what they hide) and a pick's (the first
//! hit ends the walk).

use std::cmp::Ordering;

/// A queued node with what its walk keeps beside it, ordered so that
/// `BinaryHeap` (a max-heap) pops the nearest; ties go to the lower node
/// index, so the order is deterministic.
///
/// The distance is kept as `f64::total_cmp`'s integer key, so a heap's
/// comparisons (about twice the log of its length a pop) are integer
/// compares in the same order.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Nearest<T> {
    key: i64,
    pub node: u32,
    pub item: T,
}

/// `f64::total_cmp`'s key: integers ordered as the floats' total order.
/// The map is its own inverse.
fn total_key(bits: i64) -> i64 {
    bits ^ ((((bits >> 63) as u64) >> 1) as i64)
}

impl<T> Nearest<T> {
    pub fn new(distance: f64, node: u32, item: T) -> Self {
        Nearest {
            key: total_key(distance.to_bits() as i64),
            node,
            item,
        }
    }

    pub fn distance(&self) -> f64 {
        f64::from_bits(total_key(self.key) as u64)
    }
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
        o.key.cmp(&self.key).then(o.node.cmp(&self.node))
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
            heap.push(Nearest::new(distance, node, ()));
        }
        let order: Vec<u32> = std::iter::from_fn(|| heap.pop().map(|e| e.node)).collect();
        // -0 sorts before +0 (total order), then 0.5, then the tie at 2.
        assert_eq!(order, [3, 2, 7, 0, 1]);
    }

    #[test]
    fn keys_order_as_total_cmp_and_give_the_distance_back() {
        let xs = [
            f64::NEG_INFINITY,
            -2.5,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            1e-300,
            0.5,
            1.0,
            3e10,
            f64::MAX,
            f64::INFINITY,
        ];
        for a in xs {
            let ka = Nearest::new(a, 0, ());
            assert_eq!(ka.distance().to_bits(), a.to_bits());
            for b in xs {
                let kb = Nearest::new(b, 0, ());
                assert_eq!(ka.key.cmp(&kb.key), a.total_cmp(&b), "{a} against {b}");
            }
        }
    }
}
