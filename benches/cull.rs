//! Criterion benches of the culling core (being written).

fn main() {}
