//! One size of the sparse-memory figures (issue 44, docs/BENCHMARKS.md §8): a built-in field sampled
//! sparsely at `n³` points and meshed, in this process; prints one JSON line with the sampling and
//! extraction times, the grid's counts and bytes, the mesh's size and the peak resident memory
//! (VmHWM) after each step. `bench/peers/sparse_vs_openvdb.py` runs it per size in fresh
//! processes beside OpenVDB.
//!
//! ```text
//! cargo build --release -p isoforge-bench --bin sparse_sizes
//! target/release/sparse_sizes 'field:sphere?n=1024' --method mc --threads 2
//! target/release/sparse_sizes 'field:gyroid?n=1024&periods=8&clip=0.9' --method mc
//! ```
//! Bad arguments: one line on stderr, exit code 2.

use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Parser;
use isoforge::grid::SparseGrid;
use isoforge::pipeline::{self, Method, Options};
use isoforge::volume::catalog;
use isoforge::volume::{Field, FieldVisitor, Sampled};

#[derive(Parser)]
#[command(about = "A built-in field sampled sparsely and meshed: times, counts, peak memory as JSON")]
struct Args {
    /// A built-in field (`field:NAME?n=N&…`, as for `isoforge extract -i`).
    field: String,
    /// Extraction method.
    #[arg(long, default_value = "mc")]
    method: String,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Lipschitz bound (default: the field's own).
    #[arg(long)]
    lipschitz: Option<f64>,
}

/// The process's peak resident set so far, in bytes (Linux; 0 elsewhere).
fn peak_rss() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1).and_then(|kb| kb.parse::<u64>().ok()))
        })
        .map_or(0, |kb| kb * 1024)
}

fn run(a: &Args) -> Result<()> {
    let spec = a.field.strip_prefix("field:").context("the input must be field:NAME?…")?;
    let b = catalog::parse(spec)?;
    let Some(method) = Method::parse(&a.method) else { bail!("--method {}: unknown", a.method) };
    struct Go<'a>(&'a catalog::Builtin, &'a Args, Method);
    impl FieldVisitor for Go<'_> {
        type Output = Result<serde_json::Value>;
        fn visit<F: Field + Clone + Sync>(self, field: &F) -> Self::Output {
            let Go(b, a, method) = self;
            let pool = rayon::ThreadPoolBuilder::new().num_threads(a.threads).build()?;
            let lipschitz = a.lipschitz.or_else(|| field.lipschitz());
            let sampled = Sampled::new(field.clone(), b.lattice.clone());
            let t = Instant::now();
            let grid = pool.install(|| SparseGrid::from_field(&sampled, b.iso, lipschitz))?;
            let sample_s = t.elapsed().as_secs_f64();
            let rss_grid = peak_rss();
            let s = grid.stats();
            let opts = Options { method, threads: Some(a.threads), ..Options::default() };
            let t = Instant::now();
            let e = pipeline::extract_sparse(&grid, b.iso, &opts)?;
            let extract_s = t.elapsed().as_secs_f64();
            Ok(serde_json::json!({
                "field": a.field, "points_per_axis": b.lattice.dims()[0], "method": method.name(),
                "threads": a.threads, "lipschitz": lipschitz,
                "sample_s": sample_s, "extract_s": extract_s,
                "leaves": s.leaves, "stored_samples": s.stored_samples, "nodes": s.nodes,
                "grid_bytes": s.bytes, "bytes_per_stored_sample": s.bytes as f64 / s.stored_samples.max(1) as f64,
                "vertices": e.mesh.num_vertices(), "triangles": e.mesh.num_triangles(), "quads": e.mesh.num_quads(),
                "active_cells": e.stats.active_cells(),
                "peak_rss_after_sampling": rss_grid, "peak_rss": peak_rss(),
            }))
        }
    }
    let out = b.field.visit(Go(&b, a, method))?;
    println!("{out}");
    Ok(())
}

fn main() -> ExitCode {
    let a = match Args::try_parse() {
        Ok(a) => a,
        Err(e) if e.use_stderr() => {
            eprintln!("{}", e.to_string().lines().next().unwrap_or("bad arguments"));
            return ExitCode::from(2);
        }
        Err(e) => {
            print!("{e}");
            return ExitCode::SUCCESS;
        }
    };
    match run(&a) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sparse_sizes: {e:#}");
            ExitCode::from(2)
        }
    }
}
