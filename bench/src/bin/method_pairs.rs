//! Methods side by side in one process: each round extracts the volume once with every method
//! (the order rotated from round to round), so the methods share the machine's moment. On a
//! shared VM whose speed moves in phases of seconds, process-per-method sweeps
//! (`bench/scripts/sweep.sh`) can put one method in a slow phase and the other in a fast one;
//! here the ratio of each round is taken between neighbouring runs, and its median is reported
//! beside the ratio of the medians. See docs/BENCHMARKS.md §6.20.
//!
//! ```text
//! cargo build --release -p isoforge-bench --bin method_pairs
//! target/release/method_pairs CT.nrrd --iso 52.3 --methods mc,mt-bcc --threads 2 --rounds 21
//! target/release/method_pairs noise.raw --dims 256,256,256 --dtype f32 --iso 0 --methods mc,mt5,mt6
//! ```
//! The first round is a warm-up and is left out. Bad arguments or input: one line on stderr, exit
//! code 2. The process keeps the memory it frees
//! ([`isoforge_io::keep_freed_memory`]), as the CLI's `extract --repeat` does.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Parser;
use isoforge::grid::DType;
use isoforge::pipeline::{self, Options};
use isoforge::volume::Iso;
use isoforge_io::{Limits, RawSpec};

#[derive(Parser)]
#[command(about = "Methods timed side by side in one process, rounds interleaved")]
struct Args {
    /// A volume file (any format `isoforge extract` reads; raw needs --dims and --dtype).
    input: PathBuf,
    /// The iso value (inside ⇔ value < iso).
    #[arg(long)]
    iso: f64,
    /// Methods, comma-separated (`mc`, `mc33`, `mt5`, `mt6`, `mt-bcc`, `surface-nets`, `dc`); the
    /// first is the reference of the ratios.
    #[arg(long, default_value = "mc,mt-bcc")]
    methods: String,
    /// Worker threads of each extraction.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Timed rounds (one warm-up round more is run first).
    #[arg(long, default_value_t = 21)]
    rounds: usize,
    /// Raw input: points per axis, `X,Y,Z`.
    #[arg(long)]
    dims: Option<String>,
    /// Raw input: sample type (`u8`, `i16`, `f32`, …).
    #[arg(long)]
    dtype: Option<String>,
}

fn main() -> ExitCode {
    isoforge_io::keep_freed_memory();
    match run(&Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("method_pairs: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Loads the volume, times the rounds, prints the table.
fn run(a: &Args) -> Result<()> {
    let methods = isoforge_bench::parse_methods(&a.methods)?;
    if methods.is_empty() || a.rounds == 0 || a.threads == 0 {
        bail!("--methods, --rounds and --threads need at least one");
    }
    let limits = Limits::default();
    let grid = match (&a.dims, &a.dtype) {
        (Some(d), Some(t)) => {
            let dims: Vec<u32> = d.split(',').map(str::parse).collect::<Result<_, _>>().context("--dims")?;
            let dims: [u32; 3] = dims.try_into().map_err(|_| anyhow::anyhow!("--dims: three sizes, X,Y,Z"))?;
            let dtype = DType::parse(t).with_context(|| format!("--dtype: unknown sample type {t:?}"))?;
            isoforge_io::read::raw::open_raw(&a.input, &RawSpec::new(dims, dtype), &limits)?.read_grid(&limits)?
        }
        (None, None) => isoforge_io::read_volume(&a.input, &limits)?,
        _ => bail!("--dims and --dtype go together (raw input)"),
    };
    let iso = Iso::below(a.iso);
    // seconds[m][round], triangles per method.
    let mut seconds = vec![Vec::with_capacity(a.rounds); methods.len()];
    let mut triangles = vec![0usize; methods.len()];
    for round in 0..=a.rounds {
        for turn in 0..methods.len() {
            let m = (round + turn) % methods.len();
            let options = Options { method: methods[m], threads: Some(a.threads), ..Options::default() };
            let start = Instant::now();
            let out = pipeline::extract_grid(&grid, iso, &options, None)?;
            let t = start.elapsed().as_secs_f64();
            triangles[m] = out.mesh.triangles.len();
            drop(out);
            if round > 0 {
                seconds[m].push(t);
            }
        }
    }
    println!(
        "{}: iso {}, {} thread(s), {} rounds (+1 warm-up), methods in rotated order each round",
        a.input.display(),
        a.iso,
        a.threads,
        a.rounds
    );
    println!(
        "| method | median ms | min ms | triangles | ÷ {0} (medians) | ÷ {0} (median per round) | per triangle |",
        methods[0].name()
    );
    println!("|---|---:|---:|---:|---:|---:|---:|");
    let base = median(&seconds[0]);
    for (m, method) in methods.iter().enumerate() {
        let med = median(&seconds[m]);
        let paired: Vec<f64> = seconds[m].iter().zip(&seconds[0]).map(|(x, b)| x / b).collect();
        let per_triangle = (med / base) * triangles[0] as f64 / triangles[m].max(1) as f64;
        println!(
            "| {} | {:.2} | {:.2} | {} | {:.2}× | {:.2}× | {:.2} |",
            method.name(),
            med * 1e3,
            seconds[m].iter().copied().fold(f64::INFINITY, f64::min) * 1e3,
            triangles[m],
            med / base,
            median(&paired),
            per_triangle
        );
    }
    Ok(())
}

/// The median of `x` (the mean of the middle two for an even count).
fn median(x: &[f64]) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}
