//! Benchmarks live in `benches/` (criterion) and `src/bin/` (timing tools: `method_pairs`,
//! `feature_error`); this library holds what the tools share.

use anyhow::{Context, Result};
use isoforge::pipeline::Method;

/// A `--methods` list (`mc,mc33,dc`): each name as `Method::parse` knows it.
///
/// # Errors
/// The first unknown name.
pub fn parse_methods(list: &str) -> Result<Vec<Method>> {
    list.split(',')
        .map(|s| Method::parse(s.trim()).with_context(|| format!("--methods: unknown method {s:?}")))
        .collect()
}
