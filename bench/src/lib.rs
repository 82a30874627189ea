//! Benchmarks live in `benches/` (criterion) and `src/bin/` (timing tools: `method_pairs`); this
//! crate has no library code.
