//! Sharp-feature errors of the methods on the catalogue's CSG shapes (issue 45): for each shape,
//! `n` and method, the mesh from the library's pipeline (`extract_builtin`) measured against the
//! analytic shape in cell widths h ([`isoforge::volume::sdf::features::measure`]): corner error
//! (max over the true corners of the distance to the nearest vertex; all corners, and the convex
//! ones only), crease error (max over crease samples h/8 apart of the distance to the nearest
//! mesh edge), field error (max |field(vertex)| / h), triangles (quads count as two) and the
//! check report's manifoldness. Prints a markdown table. See docs/BENCHMARKS.md §16.
//!
//! ```text
//! cargo build --release -p isoforge-bench --bin feature_error
//! target/release/feature_error --methods mc,mc33,dc,surface-nets --n 32,64,128
//! target/release/feature_error --dump /tmp/grids   # also writes SHAPE-N.npy (f32, [z][y][x]) and SHAPE-N.json
//! ```
//! `--methods` takes any name `Method::parse` accepts. Bad arguments: one line on stderr, exit 2.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Parser;
use isoforge::math::Vec3;
use isoforge::pipeline::{self, Options};
use isoforge::volume::catalog::{self, Builtin};
use isoforge::volume::sdf::features::{measure, FeatureErrors};
use isoforge::volume::sdf::Features;
use isoforge::volume::{Field, FieldVisitor};

/// The CSG shapes of the catalogue, in table order.
const SHAPES: &str = "rotated-box,cylinder,box-minus-sphere,fandisk,plates,two-spheres";

#[derive(Parser)]
#[command(about = "Corner, crease and field errors of the methods on the sharp CSG shapes")]
struct Args {
    /// Catalogue shapes, comma-separated (any `field:` spec without `n`, e.g. `plates?count=3`).
    #[arg(long, default_value = SHAPES)]
    shapes: String,
    /// Points per axis, comma-separated.
    #[arg(long, default_value = "32,64,128")]
    n: String,
    /// Methods, comma-separated (any name the library's `Method::parse` accepts).
    #[arg(long, default_value = "mc,mc33,dc,surface-nets")]
    methods: String,
    /// Worker threads of each extraction.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Also write each sampled grid (`SHAPE-N.npy`, f32, shape (n, n, n) indexed `[z][y][x]`, the
    /// lattice spanning [-1, 1]³) and its features (`SHAPE-N.json`) into this directory, for
    /// `bench/scripts/feature_error_peers.py`.
    #[arg(long)]
    dump: Option<PathBuf>,
    /// Instead of the table: read world points (raw little-endian f32 triples) from this file,
    /// write the field's values at them (raw f32) to `FILE.values`, for the first shape and `n`
    /// (the peers script's field error).
    #[arg(long)]
    eval_points: Option<PathBuf>,
}

fn main() -> ExitCode {
    match run(&Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("feature_error: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// The builtin for `shape` at `n` points per axis.
fn builtin(shape: &str, n: u32) -> Result<Builtin> {
    let sep = if shape.contains('?') { '&' } else { '?' };
    Ok(catalog::parse(&format!("{shape}{sep}n={n}"))?)
}

/// The features of `b`, crease samples an eighth of a cell apart.
fn features(b: &Builtin, h: f64) -> Result<Features> {
    b.field.sharp_features((h / 8.0) as f32).context("not a sharp CSG shape (no features)")
}

/// Measures a mesh against the concrete field.
struct Measure<'a> {
    mesh: &'a isoforge::mesh::Mesh,
    features: &'a Features,
    h: f64,
}

impl FieldVisitor for Measure<'_> {
    type Output = FeatureErrors;
    fn visit<F: Field + Clone + Sync>(self, f: &F) -> FeatureErrors {
        measure(self.mesh, self.features, f, self.h)
    }
}

/// Samples the concrete field on the lattice, x fastest.
struct Sample(Vec<[f32; 3]>);

impl FieldVisitor for Sample {
    type Output = Vec<f32>;
    fn visit<F: Field + Clone + Sync>(self, f: &F) -> Vec<f32> {
        self.0.iter().map(|&p| f.value(Vec3::from_array(p))).collect()
    }
}

fn cell(x: Option<f64>) -> String {
    x.map_or("–".into(), |v| format!("{v:.3}"))
}

fn run(a: &Args) -> Result<()> {
    let methods = isoforge_bench::parse_methods(&a.methods)?;
    let ns: Vec<u32> = a.n.split(',').map(|s| s.trim().parse()).collect::<Result<_, _>>().context("--n")?;
    let shapes: Vec<&str> = a.shapes.split(',').map(str::trim).collect();
    if methods.is_empty() || ns.is_empty() || a.threads == 0 {
        bail!("--methods, --n and --threads need at least one");
    }
    if let Some(path) = &a.eval_points {
        let b = builtin(shapes[0], ns[0]).with_context(|| format!("--shapes: {}", shapes[0]))?;
        let bytes = std::fs::read(path).with_context(|| format!("--eval-points {}", path.display()))?;
        if bytes.len() % 12 != 0 {
            bail!("--eval-points {}: {} bytes is not a whole number of f32 triples", path.display(), bytes.len());
        }
        let f = |c: &[u8]| f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        let points: Vec<[f32; 3]> = bytes.chunks_exact(12).map(|c| [f(&c[0..4]), f(&c[4..8]), f(&c[8..12])]).collect();
        let values = b.field.visit(Sample(points));
        let out: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut name = path.clone().into_os_string();
        name.push(".values");
        std::fs::write(&name, out).with_context(|| format!("{}", PathBuf::from(&name).display()))?;
        return Ok(());
    }
    if let Some(d) = &a.dump {
        std::fs::create_dir_all(d).with_context(|| format!("--dump {}", d.display()))?;
    }
    println!("| shape | n | method | triangles | corner (h) | convex corner (h) | crease (h) | field (h) | non-manifold e/v | boundary edges |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for shape in &shapes {
        for &n in &ns {
            let b = builtin(shape, n).with_context(|| format!("--shapes: {shape}"))?;
            let h = b.lattice.spacing()[0];
            let f = features(&b, h).with_context(|| format!("--shapes: {shape}"))?;
            if let Some(d) = &a.dump {
                dump(d, shape, n, &b, &f)?;
            }
            for &m in &methods {
                let opts = Options { method: m, threads: Some(a.threads), ..Default::default() };
                let out = pipeline::extract_builtin(&b, b.iso, &opts, None)
                    .with_context(|| format!("{shape} n={n} {}", m.name()))?;
                let e = b.field.visit(Measure { mesh: &out.mesh, features: &f, h });
                let r = isoforge::topo::check(&out.mesh);
                println!(
                    "| {shape} | {n} | {} | {} | {} | {} | {} | {} | {}/{} | {} |",
                    m.name(),
                    out.mesh.num_split_triangles(),
                    cell(e.corner),
                    cell(e.convex_corner),
                    cell(e.crease),
                    cell(e.field),
                    r.non_manifold_edges.count,
                    r.non_manifold_vertices.count,
                    r.boundary_edges.count,
                );
            }
        }
    }
    Ok(())
}

/// Writes `SHAPE-N.npy` and `SHAPE-N.json` (features, h) into `dir`.
fn dump(dir: &std::path::Path, shape: &str, n: u32, b: &Builtin, f: &Features) -> Result<()> {
    let stem: String = shape.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' }).collect();
    let h = b.lattice.spacing()[0];
    let mut points = Vec::with_capacity((n as usize).pow(3));
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                points.push([x, y, z].map(|i| (-1.0 + i as f64 * h) as f32));
            }
        }
    }
    let values = b.field.visit(Sample(points));
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({n}, {n}, {n}), }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let npy = dir.join(format!("{stem}-{n}.npy"));
    std::fs::write(&npy, bytes).with_context(|| format!("{}", npy.display()))?;
    let mut json = String::new();
    let pts = |it: &mut dyn Iterator<Item = Vec3>| -> String {
        it.map(|p| format!("[{},{},{}]", p.x, p.y, p.z)).collect::<Vec<_>>().join(",")
    };
    write!(
        json,
        "{{\"shape\":\"{shape}\",\"n\":{n},\"h\":{h},\"origin\":-1.0,\"corners\":[{}],\"convex\":[{}],\"crease_points\":[{}]}}",
        pts(&mut f.corners.iter().map(|c| c.point)),
        f.corners.iter().map(|c| c.convex.to_string()).collect::<Vec<_>>().join(","),
        pts(&mut f.crease_points.iter().copied()),
    )?;
    let path = dir.join(format!("{stem}-{n}.json"));
    std::fs::write(&path, json).with_context(|| format!("{}", path.display()))?;
    Ok(())
}
