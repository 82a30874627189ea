//! Validated configuration: everything after this module sees typed values, never raw strings.

use std::path::PathBuf;

use anyhow::{anyhow, bail, Context, Result};
use isoforge::extract::Saddle;
use isoforge::grid::DType;
use isoforge::mesh::colormap::Colormap;
use isoforge::mesh::decimate::DecimateOptions;
use isoforge::mesh::post::PostProcess;
use isoforge::mesh::smooth::SmoothOptions;
use isoforge::pipeline::request::{self, AttributeSource, ColorBy, ParseError};
use isoforge::pipeline::{Adaptivity, Labels, Method, Options, Region, Request, Roi};
use isoforge::topo::Guarantee;
use isoforge::volume::catalog::{self, Builtin};
use isoforge::volume::{Inside, Iso};
use isoforge_io::write::contour::ContourFormat;
use isoforge_io::{Limits, MeshFormat, RawSpec};

use crate::args::{
    CheckArgs, ContourArgs, ConvertArgs, DemoArgs, ExtractArgs, InputArgs, PostArgs, RenderArgs, SimplifyArgs,
};

/// Where values come from.
#[derive(Clone)]
pub enum Source {
    /// A volume file; `raw` carries the layout of headerless files.
    File { path: PathBuf, raw: Option<RawSpec> },
    /// A built-in field.
    Field(Builtin),
}

#[derive(Clone)]
pub struct InputConfig {
    pub source: Source,
    pub limits: Limits,
    /// `--spacing` / `--origin` given for an image or an image stack (raw files take them in
    /// `Source::File::raw`).
    pub placement: Placement,
}

/// Where `--spacing` and `--origin` put an image's samples (unset: spacing 1, origin 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Placement {
    pub spacing: Option<[f64; 3]>,
    pub origin: Option<[f64; 3]>,
}

impl Placement {
    pub fn is_set(&self) -> bool {
        self.spacing.is_some() || self.origin.is_some()
    }
}

/// What `extract` asks the library for, attribute volumes named by their input configuration.
pub type ExtractRequest = Request<Box<InputConfig>>;

#[derive(Clone)]
pub struct ExtractConfig {
    pub input: InputConfig,
    pub output: PathBuf,
    pub format: MeshFormat,
    /// Isos, inside rule, labels, region, options (method, normals, threads), attributes, colours.
    pub request: ExtractRequest,
    /// `--mask`: the mask volume.
    pub mask: Option<InputConfig>,
    /// Vertex colours from an RGB volume on the input's grid.
    pub color_volume: Option<PathBuf>,
    pub time_json: Option<PathBuf>,
    /// Extractions to run in this process (benchmarking); the last mesh is kept.
    pub repeat: u32,
    pub require: Vec<Guarantee>,
    pub max_memory: Option<u64>,
}

/// `isoforge simplify`.
pub struct SimplifyConfig {
    pub mesh: PathBuf,
    pub output: PathBuf,
    pub format: MeshFormat,
    pub post: PostProcess,
    pub limits: Limits,
    pub threads: Option<usize>,
}

pub struct CheckConfig {
    pub mesh: PathBuf,
    pub json: bool,
    pub require: Vec<Guarantee>,
    pub examples: usize,
    pub limits: Limits,
    /// `--reference`: the mesh the Hausdorff distance is measured to.
    pub reference: Option<PathBuf>,
    /// `--self-intersections` (or `--require no-self-intersections`).
    pub self_intersections: bool,
}

pub struct DemoConfig {
    pub output: PathBuf,
    pub n: u32,
    pub json: bool,
    /// The field's own iso; options (threads).
    pub request: Request,
}

/// `isoforge view`: what to show and the request every extraction starts from (inside rule,
/// threads); the page's queries fill in method, iso and region through the same parsers.
pub struct ViewConfig {
    pub port: u16,
    /// `--max-memory`: the viewer's budget for meshes, checks and exports in flight.
    pub max_memory: Option<u64>,
    pub shown: Shown,
    pub request: Request,
}

/// What `view` shows.
pub enum Shown {
    /// The demo fields.
    Demo,
    /// A mesh file.
    Mesh(PathBuf),
    /// A volume file.
    Volume(Box<InputConfig>),
}

fn triplet<T: std::str::FromStr>(flag: &str, s: &str) -> Result<[T; 3]> {
    let v: Vec<T> = s
        .split(',')
        .map(|t| t.trim().parse::<T>().map_err(|_| anyhow!("--{flag} {s:?}: {t:?} is not a valid number")))
        .collect::<Result<_>>()?;
    v.try_into().map_err(|v: Vec<T>| anyhow!("--{flag} {s:?}: needs 3 comma-separated values, got {}", v.len()))
}

fn bytes(s: &str) -> Result<u64> {
    bytes_for("--max-bytes", s)
}

fn bytes_for(flag: &str, s: &str) -> Result<u64> {
    let t = s.trim();
    let (num, mult) = match t.char_indices().find(|(_, c)| c.is_ascii_alphabetic()) {
        Some((i, _)) => {
            let unit = t[i..].to_ascii_lowercase();
            let m: u64 = match unit.as_str() {
                "b" => 1,
                "k" | "kb" | "kib" => 1 << 10,
                "m" | "mb" | "mib" => 1 << 20,
                "g" | "gb" | "gib" => 1 << 30,
                "t" | "tb" | "tib" => 1 << 40,
                _ => bail!("{flag} {s:?}: unknown unit {unit:?} (use K, M, G, T)"),
            };
            (&t[..i], m)
        }
        None => (t, 1),
    };
    let n: u64 = num.trim().parse().map_err(|_| anyhow!("{flag} {s:?}: not a whole number of bytes"))?;
    n.checked_mul(mult).ok_or_else(|| anyhow!("{flag} {s:?}: too large"))
}

fn limits(max_bytes: Option<&str>) -> Result<Limits> {
    Ok(match max_bytes {
        Some(s) => Limits::new(bytes(s)?),
        None => Limits::default(),
    })
}

/// `--spacing`: three positive finite numbers.
fn spacing(s: &str) -> Result<[f64; 3]> {
    let v: [f64; 3] = triplet("spacing", s)?;
    if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
        bail!("--spacing {s:?}: {x} is not a positive finite number");
    }
    Ok(v)
}

/// `--origin`: three finite numbers.
fn origin(s: &str) -> Result<[f64; 3]> {
    let v: [f64; 3] = triplet("origin", s)?;
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        bail!("--origin {s:?}: {x} is not a finite number");
    }
    Ok(v)
}

/// Whether `path` is read as an image or an image stack, which carry no geometry: a PNG or TIFF
/// file, or a folder holding PNG or TIFF files (the reader's rule: such a folder is a stack of
/// numbered slices, any other folder a DICOM series).
fn is_image_input(path: &std::path::Path) -> bool {
    let image = |p: &std::path::Path| {
        matches!(
            isoforge_io::VolumeFormat::from_path(p),
            Some(isoforge_io::VolumeFormat::Png | isoforge_io::VolumeFormat::Tiff)
        )
    };
    if path.is_dir() {
        return std::fs::read_dir(path)
            .map(|d| d.filter_map(|e| e.ok()).any(|e| e.path().is_file() && image(&e.path())))
            .unwrap_or(false);
    }
    image(path)
}

impl InputConfig {
    pub fn from_args(args: &InputArgs) -> Result<Self> {
        let a = &args.layout;
        let limits = limits(a.max_bytes.as_deref())?;
        let mut placement = Placement::default();
        if let Some(spec) = args.input.strip_prefix("field:") {
            if a.dims.is_some() || a.dtype.is_some() || a.spacing.is_some() || a.origin.is_some() {
                bail!("--dims, --dtype, --spacing and --origin describe files; {} is a built-in field", args.input);
            }
            return Ok(InputConfig { source: Source::Field(catalog::parse(spec)?), limits, placement });
        }
        let path = PathBuf::from(&args.input);
        let raw = match (&a.dims, &a.dtype) {
            (None, None) => {
                if a.endian.is_some() || a.header_bytes.is_some() {
                    bail!("--endian and --header-bytes describe raw files; pass --dims and --dtype too");
                }
                if a.spacing.is_some() || a.origin.is_some() {
                    if !is_image_input(&path) {
                        bail!(
                            "{}: --spacing and --origin place raw files and images (PNG, TIFF, folders of slices); \
                             this file carries its own geometry (raw files need --dims and --dtype too)",
                            path.display()
                        );
                    }
                    placement = Placement {
                        spacing: a.spacing.as_deref().map(spacing).transpose()?,
                        origin: a.origin.as_deref().map(origin).transpose()?,
                    };
                }
                None
            }
            (Some(d), Some(t)) => {
                let dims: [u32; 3] = triplet("dims", d)?;
                if dims.contains(&0) {
                    bail!("--dims {d:?}: every dimension must be at least 1");
                }
                let dtype = DType::parse(t)
                    .ok_or_else(|| anyhow!("--dtype {t:?}: unknown sample type (u8 i8 u16 i16 u32 i32 f32 f64)"))?;
                let mut spec = RawSpec::new(dims, dtype);
                spec.big_endian = match a.endian.as_deref() {
                    None | Some("little") => false,
                    Some("big") => true,
                    Some(e) => bail!("--endian {e:?}: must be little or big"),
                };
                spec.header_bytes = a.header_bytes.unwrap_or(0);
                if let Some(s) = &a.spacing {
                    spec.spacing = spacing(s)?;
                }
                if let Some(o) = &a.origin {
                    spec.origin = origin(o)?;
                }
                Some(spec)
            }
            _ => bail!("raw input needs both --dims and --dtype"),
        };
        Ok(InputConfig { source: Source::File { path, raw }, limits, placement })
    }

    /// Whether the command line places the samples (raw files; images given `--spacing` or
    /// `--origin`): contours are then written in those units rather than pixel indices.
    pub fn placed(&self) -> bool {
        self.placement.is_set() || matches!(&self.source, Source::File { raw: Some(_), .. })
    }
}

fn guarantees(list: &[String]) -> Result<Vec<Guarantee>> {
    list.iter()
        .filter(|s| !s.is_empty())
        .map(|s| {
            Guarantee::parse(s).ok_or_else(|| {
                anyhow!("--require {s:?}: unknown guarantee (closed, manifold, oriented, watertight, no-degenerate, no-self-intersections)")
            })
        })
        .collect()
}

/// `--threads`: at least 1 and at most [`MAX_THREADS_PER_CORE`] × the cores available; `None`
/// leaves the choice to the library (all cores).
///
/// # Errors
/// 0, or more than the cap (one line naming both).
pub fn threads(n: Option<usize>) -> Result<Option<usize>> {
    let Some(n) = n else { return Ok(None) };
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let cap = MAX_THREADS_PER_CORE * cores;
    if n == 0 {
        bail!("--threads 0: must be at least 1");
    }
    if n > cap {
        bail!("--threads {n}: at most {cap} ({MAX_THREADS_PER_CORE} × the {cores} cores available)");
    }
    Ok(Some(n))
}

/// More worker threads than this many per core only cost memory and switching.
pub const MAX_THREADS_PER_CORE: usize = 4;

pub fn output_format(path: &std::path::Path, ascii: bool) -> Result<MeshFormat> {
    let f = MeshFormat::from_path(path).with_context(|| {
        format!("{}: unknown output format (use {})", path.display(), crate::args::mesh_extensions(false))
    })?;
    Ok(match (f, ascii) {
        (MeshFormat::Ply, true) => MeshFormat::PlyAscii,
        (MeshFormat::Stl, true) => MeshFormat::StlAscii,
        (_, true) => bail!("--ascii applies to PLY and STL output only"),
        (f, false) => f,
    })
}

/// `flag` and the parser's message: `--roi "1:2": expected three ranges …`.
fn flag(flag: &str) -> impl Fn(ParseError) -> anyhow::Error + '_ {
    move |e| anyhow!("{flag} {e}")
}

/// `method` with `--quads`, `--split`, `--no-manifold`, `--adaptivity` and `--feature-angle`
/// applied: dual contouring's and extended marching cubes' options; other methods refuse them.
fn method_options(method: Method, a: &ExtractArgs) -> Result<Method> {
    let dc = a.quads || a.split || a.no_manifold || a.adaptivity.is_some();
    match method {
        Method::DualContouring { .. } => {
            if a.feature_angle.is_some() {
                bail!("--feature-angle applies to --method emc");
            }
            let adaptivity = match a.adaptivity.as_deref() {
                Some(s) => Adaptivity::from_cells(parse_number("--adaptivity", s)?).map_err(|e| anyhow!("--{e}"))?,
                None => Adaptivity::UNIFORM,
            };
            if a.split && !adaptivity.is_uniform() {
                bail!("--adaptivity and --split: adaptive dual contouring keeps one vertex per cell");
            }
            let plain = a.split || a.no_manifold || !adaptivity.is_uniform();
            Ok(Method::DualContouring { quads: a.quads, split: a.split, manifold: !plain, adaptivity })
        }
        Method::ExtendedMarchingCubes { feature_angle } if !dc => {
            let feature_angle = match a.feature_angle.as_deref().map(|s| parse_number("--feature-angle", s)) {
                Some(Ok(d)) if (0.0..=180.0).contains(&d) && d.fract() == 0.0 => d as u8,
                Some(Ok(d)) => bail!("--feature-angle {d}: expected whole degrees from 0 to 180"),
                Some(Err(e)) => return Err(e),
                None => feature_angle,
            };
            Ok(Method::ExtendedMarchingCubes { feature_angle })
        }
        _ if a.quads => bail!("--quads applies to --method dc (surface-nets always makes quads; the others triangles)"),
        _ if a.split => bail!("--split applies to --method dc"),
        _ if a.no_manifold => bail!("--no-manifold applies to --method dc"),
        _ if a.adaptivity.is_some() => bail!("--adaptivity applies to --method dc"),
        _ if a.feature_angle.is_some() => bail!("--feature-angle applies to --method emc"),
        m => Ok(m),
    }
}

impl ExtractConfig {
    pub fn from_args(a: &ExtractArgs, threads: Option<usize>) -> Result<Self> {
        let input = InputConfig::from_args(&a.input)?;
        let format = output_format(&a.output, a.ascii)?;
        let mut isos =
            a.iso.as_deref().map(request::parse_isos).transpose().map_err(flag("--iso"))?.unwrap_or_default();
        let labels = a.labels.as_deref().map(str::parse::<Labels>).transpose().map_err(flag("--labels"))?;
        // A signed octree reads as its signs (−1 inside, +1 outside): its surface is at 0.
        let sog = Some(isoforge_io::VolumeFormat::Sog);
        if isos.is_empty()
            && matches!(&input.source, Source::File { path, raw: None } if isoforge_io::VolumeFormat::from_path(path) == sog)
        {
            isos.push(0.0);
        }
        if isos.is_empty() && labels.is_none() && matches!(input.source, Source::File { .. }) {
            bail!("--iso is required for volume files (see `isoforge info {}` for a suggestion)", a.input.input);
        }
        let request = Request {
            isos,
            inside: a.inside.as_deref().map(str::parse).transpose().map_err(flag("--inside"))?,
            labels,
            region: region(a)?,
            options: Options {
                method: method_options(a.method.parse().map_err(flag("--method"))?, a)?,
                normals: a.normals.parse().map_err(flag("--normals"))?,
                threads,
                sparse: a.sparse.then_some(true),
                lipschitz: a.lipschitz.as_deref().map(lipschitz).transpose()?,
                follow: (a.follow || !a.seed.is_empty())
                    .then(|| a.seed.iter().map(|s| seed(s)).collect::<Result<Vec<_>>>())
                    .transpose()?,
                level: a.level,
                ..Default::default()
            },
            attributes: attributes(a)?,
            color: color(a)?,
            post: post(&a.post)?,
        };
        Ok(ExtractConfig {
            input,
            output: a.output.clone(),
            format,
            request,
            mask: a
                .mask
                .as_ref()
                .map(|m| InputConfig::from_args(&InputArgs { input: m.clone(), layout: a.input.layout.clone() }))
                .transpose()?,
            color_volume: a.color_volume.clone(),
            time_json: a.time_json.clone(),
            repeat: a.repeat,
            require: guarantees(&a.require)?,
            max_memory: a.max_memory.as_deref().map(|m| bytes_for("--max-memory", m)).transpose()?,
        })
    }
}

fn attributes(a: &ExtractArgs) -> Result<Vec<(String, AttributeSource<Box<InputConfig>>)>> {
    let mut out: Vec<(String, AttributeSource<Box<InputConfig>>)> = Vec::new();
    for spec in &a.attribute {
        let (name, source) = request::parse_attribute(spec).map_err(flag("--attribute"))?;
        if out.iter().any(|(n, _)| *n == name) {
            bail!("--attribute {spec:?}: {name} is given twice");
        }
        let source = source.try_map(|src| -> Result<Box<InputConfig>> {
            let input = InputConfig::from_args(&InputArgs { input: src, layout: a.input.layout.clone() })?;
            if matches!(input.source, Source::Field(_)) {
                bail!("--attribute {spec:?}: attributes are sampled from volume files or texture:KIND");
            }
            if a.space == "index" {
                bail!("--attribute samples volumes in world coordinates: drop --space index");
            }
            Ok(Box::new(input))
        })?;
        out.push((name, source));
    }
    Ok(out)
}

/// `--color-by NAME --colormap MAP [--color-range LO:HI]`.
fn color(a: &ExtractArgs) -> Result<Option<ColorBy>> {
    let Some(name) = &a.color_by else {
        if a.color_range.is_some() {
            bail!("--color-range needs --color-by");
        }
        return Ok(None);
    };
    if !a.attribute.iter().any(|s| s.split_once('=').is_some_and(|(n, _)| n == name)) {
        bail!("--color-by {name:?}: no --attribute {name}=VOLUME is given");
    }
    let map = Colormap::parse(&a.colormap).ok_or_else(|| {
        let names: Vec<&str> = Colormap::ALL.iter().map(|(_, n)| *n).collect();
        anyhow!("--colormap {:?}: unknown (available: {})", a.colormap, names.join(", "))
    })?;
    let range = match &a.color_range {
        Some(s) => {
            let (lo, hi) = s.split_once(':').ok_or_else(|| anyhow!("--color-range {s:?}: expected LO:HI"))?;
            let (lo, hi) = (parse_number("--color-range", lo)?, parse_number("--color-range", hi)?);
            if hi <= lo {
                bail!("--color-range {s:?}: HI must be above LO");
            }
            Some((lo, hi))
        }
        None => None,
    };
    Ok(Some(ColorBy { attribute: name.clone(), map, range }))
}

/// `--seed X,Y,Z`: three finite numbers.
fn seed(s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s.split(',').map(|x| parse_number("--seed", x)).collect::<Result<_>>()?;
    <[f64; 3]>::try_from(v).map_err(|_| anyhow!("--seed {s:?}: expected X,Y,Z"))
}

/// `--lipschitz L`: a finite number above 0.
fn lipschitz(s: &str) -> Result<f64> {
    let l = parse_number("--lipschitz", s)?;
    if l <= 0.0 {
        bail!("--lipschitz {s}: must be above 0");
    }
    Ok(l)
}

fn parse_number(flag: &str, s: &str) -> Result<f64> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| anyhow!("{flag}: {s:?} is not a finite number"))
}

/// `--roi` or `--roi-world`, `--space`, `--world`, `--close`.
fn region(a: &ExtractArgs) -> Result<Region> {
    let roi = match (&a.roi, &a.roi_world) {
        (Some(s), _) => Some(Roi::parse_index(s).map_err(flag("--roi"))?),
        (None, Some(s)) => Some(Roi::parse_world(s).map_err(flag("--roi-world"))?),
        (None, None) => None,
    };
    let index_space = match a.space.as_str() {
        "world" => false,
        "index" => true,
        s => bail!("--space {s:?}: must be world or index"),
    };
    let world = a.world.as_deref().map(str::parse).transpose().map_err(flag("--world"))?;
    if world.is_some() && index_space {
        bail!("--world and --space index exclude each other");
    }
    Ok(Region { roi, world, close: a.close, index_space })
}

fn parse_iso(s: &str) -> Result<f64> {
    request::parse_iso(s).map_err(flag("--iso"))
}

fn parse_inside(s: &str) -> Result<Inside> {
    s.parse().map_err(flag("--inside"))
}

/// `isoforge convert`: what to read, where to write, and how to go between dense and sparse.
pub struct ConvertConfig {
    pub input: InputConfig,
    pub output: PathBuf,
    /// A `.vdb` input (read sparse; `--grid` picks the grid).
    pub sparse_input: bool,
    /// A `.vdb` output.
    pub sparse_output: bool,
    pub iso: Option<f64>,
    pub band: u32,
    /// Half-open index ranges per axis.
    pub region: Option<[[i64; 2]; 3]>,
    pub grid: Option<String>,
    pub class: isoforge_io::GridClass,
}

impl ConvertConfig {
    pub fn from_args(a: &ConvertArgs) -> Result<Self> {
        let input = InputConfig::from_args(&a.input_args())?;
        let is_vdb =
            |p: &std::path::Path| isoforge_io::VolumeFormat::from_path(p) == Some(isoforge_io::VolumeFormat::Vdb);
        let sparse_input = matches!(&input.source, Source::File { path, raw: None } if is_vdb(path));
        let sparse_output = is_vdb(&a.output);
        let iso = a.iso.as_deref().map(parse_iso).transpose()?;
        let least = isoforge::grid::sparse::SURFACE_MARGIN;
        let band = match a.band.as_deref() {
            None => least,
            Some(w) => w
                .trim()
                .parse::<u32>()
                .map_err(|_| anyhow!("--band {w:?}: expected a whole number of points (at least {least})"))?,
        };
        if band < least {
            bail!(
                "--band {band}: at least {} points (a walk reads that far around a crossed cell)",
                isoforge::grid::sparse::SURFACE_MARGIN
            );
        }
        let region = a.region.as_deref().map(parse_region).transpose()?;
        let class = match a.grid_class.as_str() {
            "unknown" => isoforge_io::GridClass::Unknown,
            "level-set" => isoforge_io::GridClass::LevelSet,
            "fog-volume" => isoforge_io::GridClass::FogVolume,
            c => bail!("--class {c:?}: expected unknown, level-set or fog-volume"),
        };
        let dense_to_sparse = sparse_output && !sparse_input;
        if dense_to_sparse && iso.is_none() {
            bail!(
                "{}: writing a .vdb from a dense volume needs --iso (the leaves follow that surface)",
                a.output.display()
            );
        }
        if !dense_to_sparse && (iso.is_some() || a.band.is_some()) {
            bail!("--iso and --band apply to a dense input written as .vdb");
        }
        let sparse_to_dense = sparse_input && !sparse_output;
        if region.is_some() && !sparse_to_dense {
            bail!("--region applies to a .vdb input written as a dense volume");
        }
        if a.grid_class != "unknown" && !sparse_output {
            bail!("--class applies to a .vdb output");
        }
        Ok(ConvertConfig {
            input,
            output: a.output.clone(),
            sparse_input,
            sparse_output,
            iso,
            band,
            region,
            grid: a.grid.clone(),
            class,
        })
    }
}

/// `I0:I1,J0:J1,K0:K1` → half-open ranges, each start below its end.
fn parse_region(s: &str) -> Result<[[i64; 2]; 3]> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != 3 {
        bail!("--region {s:?}: expected I0:I1,J0:J1,K0:K1 (three half-open index ranges)");
    }
    let mut out = [[0i64; 2]; 3];
    for (a, part) in parts.iter().enumerate() {
        let axis = ["x", "y", "z"][a];
        let (lo, hi) =
            part.split_once(':').ok_or_else(|| anyhow!("--region {s:?}: axis {axis}: {part:?} is not START:END"))?;
        let num = |t: &str| {
            t.trim()
                .parse::<i32>()
                .map_err(|_| anyhow!("--region {s:?}: axis {axis}: {t:?} is not an index (a 32-bit integer)"))
        };
        let (lo, hi) = (num(lo)?, num(hi)?);
        if lo >= hi {
            bail!("--region {s:?}: axis {axis}: {lo}:{hi} holds no point (half-open: START < END)");
        }
        out[a] = [i64::from(lo), i64::from(hi)];
    }
    Ok(out)
}

pub struct ContourConfig {
    /// With `--spacing`/`--origin` (raw files, images) contours are written in those units,
    /// otherwise in pixel indices.
    pub input: InputConfig,
    pub iso: Iso,
    pub axis: usize,
    pub slice: Option<u32>,
    pub saddle: Saddle,
    pub output: PathBuf,
    pub format: ContourFormat,
    pub json: bool,
}

impl ContourConfig {
    pub fn from_args(a: &ContourArgs) -> Result<Self> {
        let input = InputConfig::from_args(&a.input_args())?;
        if matches!(input.source, Source::Field(_)) {
            bail!("{}: contour reads images and volume files; mesh fields with `isoforge extract`", a.input);
        }
        let format = ContourFormat::from_path(&a.output).ok_or_else(|| {
            anyhow!("{}: unknown contour format (expected .svg, .geojson, .json or .csv)", a.output.display())
        })?;
        let axis = match a.axis.as_str() {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            s => bail!("--axis {s:?}: must be x, y or z"),
        };
        let saddle = match a.saddle.as_str() {
            "decider" => Saddle::Decider,
            "join-inside" => Saddle::JoinInside,
            "join-outside" => Saddle::JoinOutside,
            s => bail!("--saddle {s:?}: must be decider, join-inside or join-outside"),
        };
        Ok(ContourConfig {
            input,
            iso: Iso { value: parse_iso(&a.iso)?, inside: parse_inside(&a.inside)? },
            axis,
            slice: a.slice,
            saddle,
            output: a.output.clone(),
            format,
            json: a.json,
        })
    }
}

pub struct RenderConfig {
    /// A mesh file, or a volume/field to extract first.
    pub mesh: Option<PathBuf>,
    pub input: Option<InputConfig>,
    /// Iso (at most one), inside rule, method, threads.
    pub request: Request,
    pub render: isoforge_io::render::RenderOptions,
    pub output: PathBuf,
}

impl RenderConfig {
    pub fn from_args(a: &RenderArgs, threads: Option<usize>) -> Result<Self> {
        let ext = a.output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        if ext.as_deref() != Some("png") {
            bail!("{}: render writes .png pictures", a.output.display());
        }
        let (w, h) = a
            .size
            .split_once('x')
            .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)))
            .filter(|&(w, h)| {
                (1..=isoforge_io::render::MAX_SIDE).contains(&w) && (1..=isoforge_io::render::MAX_SIDE).contains(&h)
            })
            .ok_or_else(|| anyhow!("--size {:?}: expected WxH, each 1..={}", a.size, isoforge_io::render::MAX_SIDE))?;
        let view = isoforge_io::render::View::parse(&a.view)
            .ok_or_else(|| anyhow!("--view {:?}: must be iso, front or top", a.view))?;
        let shading = match a.shading.as_str() {
            "lambert" => isoforge_io::render::Shading::Lambert,
            "normal" => isoforge_io::render::Shading::Normal,
            s => bail!("--shading {s:?}: must be lambert or normal"),
        };
        let method: Method = a.method.parse().map_err(flag("--method"))?;
        let (mesh, input) = if is_mesh_file(&a.input) {
            (Some(PathBuf::from(&a.input)), None)
        } else {
            (None, Some(InputConfig::from_args(&a.input_args())?))
        };
        let iso = a.iso.as_deref().map(parse_iso).transpose()?;
        if iso.is_none() && matches!(input.as_ref().map(|i| &i.source), Some(Source::File { .. })) {
            bail!("--iso is required to render a volume file");
        }
        Ok(RenderConfig {
            mesh,
            input,
            request: Request {
                isos: iso.into_iter().collect(),
                inside: a.inside.as_deref().map(parse_inside).transpose()?,
                options: Options { method, threads, ..Options::default() },
                ..Request::default()
            },
            render: isoforge_io::render::RenderOptions {
                size: [w, h],
                view,
                shading,
                wireframe: a.wireframe,
                defects: !a.no_defects,
            },
            output: a.output.clone(),
        })
    }
}

/// Whether `input` names a mesh file (a mesh extension that is not also a volume's).
fn is_mesh_file(input: &str) -> bool {
    let path = std::path::Path::new(input);
    !input.starts_with("field:")
        && MeshFormat::from_path(path).is_some()
        && isoforge_io::VolumeFormat::from_path(path).is_none()
}

impl ViewConfig {
    pub fn from_args(a: &crate::args::ViewArgs, threads: Option<usize>) -> Result<Self> {
        let inside: Inside = a.inside.parse().map_err(flag("--inside"))?;
        let shown = match &a.input {
            None => Shown::Demo,
            Some(input) if is_mesh_file(input) => Shown::Mesh(PathBuf::from(input)),
            Some(input) => {
                let cfg = InputConfig::from_args(&InputArgs { input: input.clone(), layout: a.layout.clone() })?;
                if matches!(cfg.source, Source::Field(_)) {
                    bail!("{input}: view shows volume files, meshes, or (without INPUT) the demo fields");
                }
                Shown::Volume(Box::new(cfg))
            }
        };
        let request =
            Request { inside: Some(inside), options: Options { threads, ..Options::default() }, ..Request::default() };
        let max_memory = a.max_memory.as_deref().map(|m| bytes_for("--max-memory", m)).transpose()?;
        Ok(ViewConfig { port: a.port, max_memory, shown, request })
    }
}

/// `--smooth`, `--decimate`, `--max-error`.
fn post(a: &PostArgs) -> Result<PostProcess> {
    let smooth = a.smooth.as_deref().map(str::parse::<SmoothOptions>).transpose().map_err(flag("--smooth"))?;
    let reduction = a.decimate.as_deref().map(|s| parse_number("--decimate", s)).transpose()?;
    if let Some(r) = reduction {
        if !(0.0..=1.0).contains(&r) {
            bail!("--decimate {r}: the fraction of triangles to remove must lie in [0, 1] (0.9 keeps a tenth)");
        }
    }
    let max_error = a.max_error.as_deref().map(|s| parse_number("--max-error", s)).transpose()?;
    if let Some(e) = max_error {
        if e < 0.0 {
            bail!("--max-error {e}: must be ≥ 0 (a distance in world units)");
        }
    }
    let decimate = (reduction.is_some() || max_error.is_some()).then(|| DecimateOptions {
        reduction,
        max_error,
        ..DecimateOptions::default()
    });
    let post = PostProcess { smooth, decimate };
    post.validate()?;
    Ok(post)
}

impl SimplifyConfig {
    pub fn from_args(a: &SimplifyArgs, threads: Option<usize>) -> Result<Self> {
        let post = post(&a.post)?;
        if post.is_identity() {
            bail!("simplify: nothing to do (give --smooth, --decimate or --max-error)");
        }
        Ok(SimplifyConfig {
            mesh: a.mesh.clone(),
            output: a.output.clone(),
            format: output_format(&a.output, a.ascii)?,
            post,
            limits: limits(a.max_bytes.as_deref())?,
            threads,
        })
    }
}

impl CheckConfig {
    pub fn from_args(a: &CheckArgs) -> Result<Self> {
        Ok(CheckConfig {
            mesh: a.mesh.clone(),
            json: a.json,
            require: guarantees(&a.require)?,
            examples: a.examples,
            limits: limits(a.max_bytes.as_deref())?,
            reference: a.reference.clone(),
            self_intersections: a.self_intersections
                || guarantees(&a.require)?.contains(&Guarantee::NoSelfIntersections),
        })
    }
}

impl DemoConfig {
    pub fn from_args(a: &DemoArgs, threads: Option<usize>) -> Result<Self> {
        if !(2..=1024).contains(&a.n) {
            bail!("--n {}: must be from 2 to 1024", a.n);
        }
        output_format(&a.output, false)?;
        Ok(DemoConfig {
            output: a.output.clone(),
            n: a.n,
            json: a.json,
            request: Request { options: Options { threads, ..Options::default() }, ..Request::default() },
        })
    }
}

/// What `voxelize` and `repair` share: the mesh, the lattice's fineness, the band, the limits.
pub struct VoxelConfig {
    pub mesh: PathBuf,
    pub resolution: isoforge::voxelize::Resolution,
    pub band: f64,
    pub limits: Limits,
    pub json: bool,
}

impl VoxelConfig {
    fn from_args(a: &crate::args::VoxelArgs) -> Result<Self> {
        use isoforge::voxelize::Resolution;
        let resolution =
            match (&a.resolution, &a.voxel_size) {
                (Some(n), _) => {
                    let cells = n.trim().parse::<u32>().ok().filter(|&c| (1..=16_384).contains(&c));
                    Resolution::Cells(cells.ok_or_else(|| {
                        anyhow!("--resolution {n:?}: expected a whole number of cells from 1 to 16384")
                    })?)
                }
                (None, Some(h)) => {
                    let v = h.trim().parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0);
                    Resolution::Spacing(v.ok_or_else(|| anyhow!("--voxel-size {h:?}: expected a positive length"))?)
                }
                (None, None) => match &a.depth {
                    Some(d) => {
                        let depth = d.trim().parse::<u32>().ok().filter(|&d| (1..=14).contains(&d));
                        Resolution::Cells(
                            1 << depth.ok_or_else(|| anyhow!("--depth {d:?}: expected a whole number from 1 to 14"))?,
                        )
                    }
                    None => Resolution::Cells(128),
                },
            };
        let band = match a.band.as_deref() {
            None => isoforge::voxelize::VoxelizeOptions::default().band,
            Some(w) => w
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| (1.0..=64.0).contains(v))
                .ok_or_else(|| anyhow!("--band {w:?}: expected a number of cells from 1 to 64"))?,
        };
        Ok(VoxelConfig {
            mesh: a.mesh.clone(),
            resolution,
            band,
            limits: limits(a.max_bytes.as_deref())?,
            json: a.json,
        })
    }
}

/// `isoforge voxelize`.
pub struct VoxelizeConfig {
    pub voxel: VoxelConfig,
    pub output: PathBuf,
    /// A `.vdb` output (sparse); dense otherwise.
    pub sparse: bool,
    /// A `.sog` output (PolyMender's signed octree: a cube of 2^depth cells).
    pub octree: bool,
    pub values: isoforge::voxelize::Output,
}

impl VoxelizeConfig {
    pub fn from_args(a: &crate::args::VoxelizeArgs) -> Result<Self> {
        use isoforge_io::VolumeFormat;
        let voxel = VoxelConfig::from_args(&a.voxel)?;
        let values: isoforge::voxelize::Output = a.values.parse().map_err(flag("--values"))?;
        let format = VolumeFormat::from_path(&a.output);
        let (sparse, octree) = match format {
            Some(VolumeFormat::Vdb) => (true, false),
            Some(VolumeFormat::Sog) => (false, true),
            Some(VolumeFormat::Nrrd | VolumeFormat::Nifti) => (false, false),
            _ => bail!("{}: voxelize writes .vdb, .sog, .nrrd, .nii or .nii.gz", a.output.display()),
        };
        if octree && values == isoforge::voxelize::Output::Occupancy {
            bail!("--values occupancy: a .sog output holds signs and vertices; write occupancy as .nrrd or .nii");
        }
        if octree && voxel.resolution.cells().is_none_or(|n| n > 1024) {
            bail!(
                "{}: a .sog output needs --resolution N (cells, at most 1024; rounded up to a power of two)",
                a.output.display()
            );
        }
        if sparse && values == isoforge::voxelize::Output::Occupancy {
            bail!("--values occupancy: a .vdb output holds signed distances (a level set); write occupancy as .nrrd or .nii");
        }
        Ok(VoxelizeConfig { voxel, output: a.output.clone(), sparse, octree, values })
    }
}

/// `isoforge repair`.
pub struct RepairConfig {
    pub voxel: VoxelConfig,
    pub output: PathBuf,
    pub format: MeshFormat,
}

impl RepairConfig {
    pub fn from_args(a: &crate::args::RepairArgs) -> Result<Self> {
        let voxel = VoxelConfig::from_args(&a.voxel)?;
        let format = output_format(&a.output, false)?;
        Ok(RepairConfig { voxel, output: a.output.clone(), format })
    }
}

/// What `topo-repair` reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolidInput {
    /// A PolyMender signed octree: its signs at iso 0.
    Sog,
    /// A mesh, voxelized into signed distances on this many cells along its longest side.
    Mesh(u32),
    /// A volume at an iso.
    Volume,
}

/// `isoforge topo-repair`.
pub struct TopoRepairConfig {
    pub input: PathBuf,
    pub kind: SolidInput,
    pub iso: isoforge::volume::Iso,
    pub options: isoforge::mend::RepairOptions,
    pub output: PathBuf,
    pub format: MeshFormat,
    pub skeleton: Option<PathBuf>,
    pub grid_out: Option<PathBuf>,
    pub limits: Limits,
    pub json: bool,
}

impl TopoRepairConfig {
    pub fn from_args(a: &crate::args::TopoRepairArgs) -> Result<Self> {
        use isoforge::volume::{Inside, Iso};
        use isoforge_io::VolumeFormat;
        let area = |flag: &str, v: &str| {
            v.trim().parse::<f64>().ok().filter(|x| x.is_finite()).ok_or_else(|| {
                anyhow!("{flag} {v:?}: expected an area in squared model units (a finite number; 0 or less skips)")
            })
        };
        let options = isoforge::mend::RepairOptions { thin: area("--thin", &a.thin)?, grow: area("--grow", &a.grow)? };
        let kind =
            if MeshFormat::from_path(&a.input).is_some() {
                let n =
                    match a.resolution.as_deref() {
                        None => 128,
                        Some(n) => n.trim().parse::<u32>().ok().filter(|c| (2..=512).contains(c)).ok_or_else(|| {
                            anyhow!("--resolution {n:?}: expected a whole number of cells from 2 to 512")
                        })?,
                    };
                SolidInput::Mesh(n)
            } else if VolumeFormat::from_path(&a.input) == Some(VolumeFormat::Sog) {
                SolidInput::Sog
            } else {
                SolidInput::Volume
            };
        if kind != SolidInput::Volume {
            if a.iso.is_some() || a.inside.is_some() {
                bail!(
                    "--iso and --inside apply to volume inputs ({} holds signs: inside is below 0)",
                    a.input.display()
                );
            }
        } else if a.resolution.is_some() {
            bail!("--resolution applies to mesh inputs ({} is a volume)", a.input.display());
        }
        let iso = match (kind, a.iso.as_deref()) {
            (SolidInput::Volume, None) => bail!("{}: a volume needs --iso V (the solid's boundary)", a.input.display()),
            (SolidInput::Volume, Some(v)) => v
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| anyhow!("--iso {v:?}: expected a finite number"))?,
            _ => 0.0,
        };
        let inside = match a.inside.as_deref() {
            None => Inside::Below,
            Some(s) => s.parse::<Inside>().map_err(|_| anyhow!("--inside {s:?}: expected below or above"))?,
        };
        if let Some(p) = &a.skeleton {
            if !p.to_string_lossy().to_ascii_lowercase().ends_with(".skt") {
                bail!("{}: --skeleton writes TopoMender's .skt records; name the file .skt", p.display());
            }
        }
        if let Some(p) = &a.grid_out {
            if !matches!(VolumeFormat::from_path(p), Some(VolumeFormat::Sog | VolumeFormat::Nrrd | VolumeFormat::Nifti))
            {
                bail!("{}: --grid-out writes .sog, .nrrd, .nii or .nii.gz", p.display());
            }
        }
        Ok(TopoRepairConfig {
            input: a.input.clone(),
            kind,
            iso: Iso { value: iso, inside },
            options,
            output: a.output.clone(),
            format: output_format(&a.output, false)?,
            skeleton: a.skeleton.clone(),
            grid_out: a.grid_out.clone(),
            limits: limits(a.max_bytes.as_deref())?,
            json: a.json,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_sizes_and_triplets() {
        assert_eq!(bytes("2GiB").unwrap(), 2 << 30);
        assert_eq!(bytes("512").unwrap(), 512);
        assert!(bytes("12Q").is_err());
        assert_eq!(triplet::<u32>("dims", "1, 2,3").unwrap(), [1, 2, 3]);
        assert!(triplet::<u32>("dims", "1,2").is_err());
        assert!(triplet::<u32>("dims", "1,-2,3").is_err());
    }

    fn parse(argv: &[&str]) -> crate::args::Args {
        <crate::args::Args as clap::Parser>::try_parse_from(argv).unwrap()
    }

    // Issue 10 (hardening 8): `--threads` built rayon's global pool and `Options.threads` stayed
    // `None`; now it is checked and reaches the library through `Options.threads`.
    #[test]
    fn issue_10_threads_reach_the_library_options() {
        let a = parse(&["isoforge", "--threads", "3", "extract", "-i", "field:sphere", "-o", "s.ply"]);
        let crate::args::Command::Extract(e) = &a.command else { panic!("extract") };
        let c = ExtractConfig::from_args(e, threads(a.threads).unwrap()).unwrap();
        assert_eq!(c.request.options.threads, Some(3));
        let a = parse(&["isoforge", "render", "field:sphere", "-o", "s.png", "--threads", "2"]);
        let crate::args::Command::Render(r) = &a.command else { panic!("render") };
        assert_eq!(RenderConfig::from_args(r, threads(a.threads).unwrap()).unwrap().request.options.threads, Some(2));
        let a = parse(&["isoforge", "demo", "--threads", "1"]);
        let crate::args::Command::Demo(d) = &a.command else { panic!("demo") };
        assert_eq!(DemoConfig::from_args(d, threads(a.threads).unwrap()).unwrap().request.options.threads, Some(1));
        let a = parse(&["isoforge", "--threads", "2", "view", "--inside", "above"]);
        let crate::args::Command::View(v) = &a.command else { panic!("view") };
        let v = ViewConfig::from_args(v, threads(a.threads).unwrap()).unwrap();
        assert_eq!((v.request.options.threads, v.request.inside), (Some(2), Some(Inside::Above)));

        let cores = std::thread::available_parallelism().unwrap().get();
        assert_eq!(threads(None).unwrap(), None);
        assert_eq!(threads(Some(MAX_THREADS_PER_CORE * cores)).unwrap(), Some(MAX_THREADS_PER_CORE * cores));
        let e = threads(Some(MAX_THREADS_PER_CORE * cores + 1)).unwrap_err().to_string();
        assert!(e.contains(&format!("at most {}", MAX_THREADS_PER_CORE * cores)), "{e}");
        assert!(threads(Some(0)).unwrap_err().to_string().contains("at least 1"));
    }

    #[test]
    fn spacing_and_origin_must_be_finite_and_spacing_positive() {
        assert_eq!(spacing("0.5,1,2").unwrap(), [0.5, 1.0, 2.0]);
        assert_eq!(origin("-10,0,1e3").unwrap(), [-10.0, 0.0, 1000.0]);
        for bad in ["0,1,1", "-1,1,1", "inf,1,1", "1,1"] {
            assert!(spacing(bad).is_err(), "{bad}");
        }
        assert!(origin("nan,0,0").is_err());
    }
}
