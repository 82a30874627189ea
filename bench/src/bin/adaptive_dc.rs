//! Adaptive dual contouring against uniform plain dc on the catalogue's CSG shapes (issue 45):
//! for each shape, `n` and error bound E (cell widths; 0 = uniform), the mesh of the library's
//! pipeline (`extract_builtin`, `--method dc --adaptivity E`): vertices and the ratio to uniform,
//! the largest vertex deviation `|f(v)| / |∇f(v)|` in cell widths h (the analytic field: its
//! distance to the surface), the corner and crease errors
//! ([`isoforge::volume::sdf::features::measure`], in h), closedness, components and Euler
//! characteristic beside uniform's, and the median time of `--runs` extractions. Prints a
//! markdown table. See docs/BENCHMARKS.md §19.
//!
//! ```text
//! cargo build -p isoforge-bench --bin adaptive_dc      # --release for release figures
//! target/debug/adaptive_dc --shapes rotated-box,fandisk,cylinder --n 64,128 --e 0,0.1,0.25,0.5
//! ```
//! Bad arguments: one line on stderr, exit 2.

use std::fmt::Write as _;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Parser;
use isoforge::math::Vec3;
use isoforge::mesh::Mesh;
use isoforge::pipeline::{self, Adaptivity, Method, Options};
use isoforge::topo;
use isoforge::volume::catalog::{self, Builtin};
use isoforge::volume::sdf::features::{measure, FeatureErrors};
use isoforge::volume::sdf::Features;
use isoforge::volume::{Field, FieldVisitor};

#[derive(Parser)]
#[command(about = "Vertices, deviation and feature errors of adaptive dual contouring")]
struct Args {
    /// Catalogue shapes, comma-separated (any `field:` spec without `n`).
    #[arg(long, default_value = "rotated-box,fandisk,cylinder")]
    shapes: String,
    /// Points per axis, comma-separated.
    #[arg(long, default_value = "64,128")]
    n: String,
    /// Error bounds in cell widths, comma-separated (0: uniform plain dc, the ratio's base).
    #[arg(long, default_value = "0,0.1,0.25,0.5")]
    e: String,
    /// Worker threads of each extraction (uniform dc's walk; adaptive dc runs on one).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Timed extractions per row (the median is printed).
    #[arg(long, default_value_t = 3)]
    runs: usize,
}

fn main() -> ExitCode {
    match run(&Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("adaptive_dc: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn list<T: std::str::FromStr>(flag: &str, s: &str) -> Result<Vec<T>> {
    s.split(',').map(|x| x.trim().parse::<T>().ok().with_context(|| format!("--{flag}: bad value {x:?}"))).collect()
}

/// The largest `|f(v)| / |∇f(v)|` over the mesh's vertices, in world units.
fn max_deviation(b: &Builtin, m: &Mesh) -> f64 {
    struct Go<'a>(&'a Mesh);
    impl FieldVisitor for Go<'_> {
        type Output = f64;
        fn visit<F: Field + Clone + Sync>(self, f: &F) -> f64 {
            self.0.positions.iter().fold(0.0f64, |m, &p| {
                let p = Vec3::from(p);
                m.max(f64::from((f.value(p) / f.gradient(p).length().max(1e-6)).abs()))
            })
        }
    }
    b.field.visit(Go(m))
}

fn features(b: &Builtin, m: &Mesh, f: &Features, h: f64) -> FeatureErrors {
    struct Go<'a>(&'a Mesh, &'a Features, f64);
    impl FieldVisitor for Go<'_> {
        type Output = FeatureErrors;
        fn visit<F: Field + Clone + Sync>(self, f: &F) -> FeatureErrors {
            measure(self.0, self.1, f, self.2)
        }
    }
    b.field.visit(Go(m, f, h))
}

fn run(a: &Args) -> Result<()> {
    let shapes: Vec<String> = a.shapes.split(',').map(|s| s.trim().to_string()).collect();
    let ns: Vec<u32> = list("n", &a.n)?;
    let es: Vec<f64> = list("e", &a.e)?;
    if a.runs == 0 {
        bail!("--runs 0: at least one run");
    }
    let mut out = String::new();
    writeln!(
        out,
        "| shape | n | E (h) | vertices | uniform / adaptive | max deviation (h) | corner (h) | convex corner (h) | \
         crease (h) | closed | components | Euler | median ms |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|---|---|")?;
    for shape in &shapes {
        for &n in &ns {
            let sep = if shape.contains('?') { '&' } else { '?' };
            let b = catalog::parse(&format!("{shape}{sep}n={n}"))?;
            let h = b.lattice.spacing()[0];
            let feats = b.field.sharp_features((h / 8.0) as f32).unwrap_or_default();
            let mut base = None;
            for &e in &es {
                let method = Method::DualContouring {
                    quads: false,
                    split: false,
                    manifold: false,
                    adaptivity: Adaptivity::from_cells(e)?,
                };
                let opts = Options { method, threads: Some(a.threads), ..Default::default() };
                let mut times = Vec::new();
                let mut mesh = None;
                for _ in 0..a.runs {
                    let t = Instant::now();
                    let m = pipeline::extract_builtin(&b, b.iso, &opts, None)?.mesh;
                    times.push(t.elapsed().as_secs_f64() * 1e3);
                    mesh = Some(m);
                }
                times.sort_by(f64::total_cmp);
                let m = mesh.context("no run")?;
                let v = m.positions.len();
                let base_v = *base.get_or_insert(v);
                let r = topo::check(&m);
                let fe = features(&b, &m, &feats, h);
                let opt = |x: Option<f64>| x.map_or("–".to_string(), |x| format!("{x:.3}"));
                writeln!(
                    out,
                    "| {shape} | {n} | {e} | {v} | {:.2}× | {:.3} | {} | {} | {} | {} | {} | {} | {:.0} |",
                    base_v as f64 / v.max(1) as f64,
                    max_deviation(&b, &m) / h,
                    opt(fe.corner),
                    opt(fe.convex_corner),
                    opt(fe.crease),
                    if r.is_closed() { "yes" } else { "no" },
                    r.components.len(),
                    r.euler,
                    times[times.len() / 2],
                )?;
            }
        }
    }
    print!("{out}");
    Ok(())
}
