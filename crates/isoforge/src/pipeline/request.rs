//! What to extract, independent of where the input comes from: isos and the inside rule, method,
//! normals, threads, the region (ROI, `--close`, index or world output frame), labels, attributes
//! to sample and their colouring. One parser per textual form (`x0:x1,y0:y1,z0:z1`, `below`,
//! `NAME=texture:KIND`, …), shared by every front end (the CLI's flags, the viewer's queries).
//!
//! Parsers return a [`ParseError`] naming the text and the problem; the caller prefixes the
//! name of the flag or parameter (`--roi "1:2": …`, `roi="1:2": …`).

use std::borrow::Cow;
use std::fmt;
use std::str::FromStr;

use super::{Labels, Method, Options};
use crate::error::{Error, Result};
use crate::extract::PointMask;
use crate::grid::{AnyGrid, Lattice, WorldSpace};
use crate::mesh::colormap::Colormap;
use crate::mesh::post::PostProcess;
use crate::mesh::smooth::{SmoothOptions, Smoother};
use crate::mesh::Normals;
use crate::volume::texture::SolidTexture;
use crate::volume::{Inside, Iso};

/// A textual form that does not parse: the text and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    /// The text given.
    pub text: String,
    /// What is wrong, in words (`"is not a point index"`).
    pub problem: String,
}

impl ParseError {
    fn new(text: &str, problem: impl Into<String>) -> Self {
        ParseError { text: text.to_string(), problem: problem.into() }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}: {}", self.text, self.problem)
    }
}

impl std::error::Error for ParseError {}

impl From<ParseError> for Error {
    fn from(e: ParseError) -> Self {
        Error::InvalidInput(e.to_string())
    }
}

/// A validated extraction request: everything but the input itself.
///
/// `V` is how an attribute volume is named by the front end (a path with its layout in the CLI);
/// the library never opens it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Request<V = ()> {
    /// Iso values (empty: the input's default).
    pub isos: Vec<f64>,
    /// The inside rule (`None`: the input's default, [`Inside::Below`] for files).
    pub inside: Option<Inside>,
    /// One surface per label instead of isosurfaces.
    pub labels: Option<Labels>,
    /// Where to cut and how to place the volume.
    pub region: Region,
    /// Method, normals, threads (the pool is built by the library), mask.
    pub options: Options,
    /// What is sampled at the vertices, by attribute name.
    pub attributes: Vec<(String, AttributeSource<V>)>,
    /// Vertex colours from one of the attributes.
    pub color: Option<ColorBy>,
    /// Smoothing and decimation of each mesh after extraction (label surfaces: smoothing
    /// constrained by [`label_post`](crate::pipeline::label_post)).
    pub post: PostProcess,
}

impl<V> Request<V> {
    /// The isos to extract: those asked for, or `default`'s value; the inside rule asked for, or
    /// `default`'s.
    pub fn isos_or(&self, default: Iso) -> Vec<Iso> {
        let inside = self.inside.unwrap_or(default.inside);
        if self.isos.is_empty() {
            vec![Iso { value: default.value, inside }]
        } else {
            self.isos.iter().map(|&value| Iso { value, inside }).collect()
        }
    }
}

/// Checks that every iso lies within the value range `[min, max]` of the volume.
///
/// # Errors
/// [`Error::InvalidInput`] naming the first iso outside.
pub fn check_isos_in_range(isos: &[Iso], min: f64, max: f64) -> Result<()> {
    match isos.iter().find(|iso| iso.value < min || iso.value > max) {
        Some(iso) => Err(Error::InvalidInput(format!("iso {} is outside the value range [{min}, {max}]", iso.value))),
        None => Ok(()),
    }
}

/// The value that is outside every iso for `inside`, given the volume's range: padding with it
/// (`--close`) adds no surface of its own (ties count as outside).
pub fn outside_value(inside: Inside, min: f64, max: f64) -> f64 {
    match inside {
        Inside::Below => max,
        Inside::Above => min,
    }
}

/// Why an extraction has no surface: every lattice point on one side of the iso. One sentence,
/// shared by every front end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoSurface {
    /// The iso.
    pub iso: Iso,
    /// `"outside"` or `"inside"`.
    pub side: &'static str,
}

impl NoSurface {
    /// `Some` when every cell of the walk `stats` describes lies on one side of `iso`.
    pub fn of(stats: &crate::walk::WalkStats, iso: Iso) -> Option<NoSurface> {
        stats.uniform_side().map(|side| NoSurface { iso, side })
    }
}

impl fmt::Display for NoSurface {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "iso {} gives no surface: every lattice point is {} (inside is {} iso)",
            self.iso.value,
            self.side,
            self.iso.inside.name()
        )
    }
}

impl std::error::Error for NoSurface {}

// ---------------------------------------------------------------------------------------------
// Textual forms.

fn number(text: &str, problem: &str) -> Result<f64, ParseError> {
    text.trim().parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| ParseError::new(text, problem))
}

/// One iso value: a finite number that a double holds as written (`1e-400` underflows to 0 and
/// is refused, not read as 0).
///
/// # Errors
/// Not a number, not finite, or a non-zero number that rounds to zero.
pub fn parse_iso(s: &str) -> Result<f64, ParseError> {
    let v: f64 = s.trim().parse().map_err(|_| ParseError::new(s, "not a number"))?;
    if !v.is_finite() {
        return Err(ParseError::new(s, "must be a finite number"));
    }
    // A zero whose mantissa has a digit other than 0 underflowed.
    let mantissa = s.trim().split(['e', 'E']).next().unwrap_or("");
    if v == 0.0 && mantissa.chars().any(|c| ('1'..='9').contains(&c)) {
        return Err(ParseError::new(s, "is too small for a double (it would be read as 0)"));
    }
    Ok(v)
}

/// A comma-separated list of iso values, each once (`100,1e2` is one value written twice).
///
/// # Errors
/// As [`parse_iso`], naming the bad element; a value given twice, naming both spellings.
pub fn parse_isos(list: &str) -> Result<Vec<f64>, ParseError> {
    let parts: Vec<&str> = list.split(',').collect();
    let isos: Vec<f64> = parts.iter().map(|p| parse_iso(p)).collect::<Result<_, _>>()?;
    for (i, v) in isos.iter().enumerate() {
        if let Some(j) = isos[..i].iter().position(|u| u == v) {
            return Err(ParseError::new(
                list,
                format!("{:?} and {:?} are the same iso ({v}); give each once", parts[j].trim(), parts[i].trim()),
            ));
        }
    }
    Ok(isos)
}

impl FromStr for Inside {
    type Err = ParseError;
    /// `below` or `above`.
    fn from_str(s: &str) -> Result<Self, ParseError> {
        match s {
            "below" => Ok(Inside::Below),
            "above" => Ok(Inside::Above),
            _ => Err(ParseError::new(s, "must be below or above")),
        }
    }
}

impl FromStr for crate::voxelize::Output {
    type Err = ParseError;
    /// `sdf` or `occupancy`.
    fn from_str(s: &str) -> Result<Self, ParseError> {
        match s {
            "sdf" => Ok(crate::voxelize::Output::Sdf),
            "occupancy" => Ok(crate::voxelize::Output::Occupancy),
            _ => Err(ParseError::new(s, "must be sdf or occupancy")),
        }
    }
}

impl FromStr for Method {
    type Err = ParseError;
    /// A short method name (`mc`, `mc33`, …).
    fn from_str(s: &str) -> Result<Self, ParseError> {
        Method::parse(s).ok_or_else(|| {
            let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
            ParseError::new(s, format!("unknown method (available: {})", names.join(", ")))
        })
    }
}

impl FromStr for Normals {
    type Err = ParseError;
    /// `gradient` or `none`.
    fn from_str(s: &str) -> Result<Self, ParseError> {
        match s {
            "gradient" => Ok(Normals::Gradient),
            "none" => Ok(Normals::None),
            _ => Err(ParseError::new(s, "must be gradient or none")),
        }
    }
}

impl FromStr for WorldSpace {
    type Err = ParseError;
    /// `lps` or `ras`.
    fn from_str(s: &str) -> Result<Self, ParseError> {
        match s {
            "lps" => Ok(WorldSpace::Lps),
            "ras" => Ok(WorldSpace::Ras),
            _ => Err(ParseError::new(s, "must be lps or ras")),
        }
    }
}

impl FromStr for Labels {
    type Err = ParseError;
    /// `all`, or a comma-separated list of label values.
    fn from_str(s: &str) -> Result<Self, ParseError> {
        if s == "all" {
            return Ok(Labels::All);
        }
        let v = s.split(',').map(|t| number(t, "is not a finite number")).collect::<Result<Vec<f64>, _>>()?;
        if let Some(l) = v.iter().find(|l| crate::pipeline::check_label(**l).is_err()) {
            return Err(ParseError::new(s, format!("label value {l} is not an integer")));
        }
        Ok(Labels::These(v))
    }
}

impl FromStr for SmoothOptions {
    type Err = ParseError;
    /// `taubin` or `sinc`, optionally followed by `:ITERATIONS` (`sinc:60`).
    fn from_str(s: &str) -> Result<Self, ParseError> {
        let (name, iterations) = match s.split_once(':') {
            Some((n, i)) => (n, Some(i)),
            None => (s, None),
        };
        let smoother = match name.trim() {
            "taubin" => Smoother::Taubin,
            "sinc" => Smoother::WindowedSinc,
            _ => return Err(ParseError::new(s, "must be taubin or sinc, optionally followed by :ITERATIONS")),
        };
        let mut options = SmoothOptions::new(smoother);
        if let Some(i) = iterations {
            const MAX: u32 = SmoothOptions::MAX_ITERATIONS;
            options.iterations = i.trim().parse().ok().filter(|n| (1..=MAX).contains(n)).ok_or_else(|| {
                ParseError::new(s, format!("iterations {i:?} must be a whole number from 1 to {MAX}"))
            })?;
        }
        Ok(options)
    }
}

// ---------------------------------------------------------------------------------------------
// Regions.

/// Where to cut and how to place the volume before extraction.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Region {
    /// The region of interest (`None`: the whole volume).
    pub roi: Option<Roi>,
    /// The frame to express world coordinates in (`None`: the input's).
    pub world: Option<WorldSpace>,
    /// Pads with one layer of outside points so every surface is closed.
    pub close: bool,
    /// Vertices in point indices of the input volume rather than world coordinates.
    pub index_space: bool,
}

/// A region of interest.
#[derive(Debug, Clone, PartialEq)]
pub enum Roi {
    /// Half-open point index ranges; `None` bounds take the whole axis.
    Index([(Option<u32>, Option<u32>); 3]),
    /// A world box, per axis `(lo, hi)`; `None` bounds take the lattice's extent.
    World([(Option<f64>, Option<f64>); 3]),
}

/// Splits `a:b,c:d,e:f` into three `(lo, hi)` text pairs.
fn split3(s: &str) -> Result<[(&str, &str); 3], ParseError> {
    let parts: Vec<&str> = s.split(',').collect();
    let parts: [&str; 3] =
        parts.try_into().map_err(|_| ParseError::new(s, "expected three ranges lo:hi separated by commas"))?;
    let mut out = [("", ""); 3];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = p.split_once(':').ok_or_else(|| ParseError::new(s, format!("range {p:?} has no ':'")))?;
    }
    Ok(out)
}

impl Roi {
    /// `i0:i1,j0:j1,k0:k1`: half-open point index ranges; an empty bound takes the axis' end.
    ///
    /// # Errors
    /// Not three ranges, a range without `:`, or a bound that is not a point index.
    pub fn parse_index(s: &str) -> Result<Roi, ParseError> {
        let mut r = [(None, None); 3];
        for (out, (lo, hi)) in r.iter_mut().zip(split3(s)?) {
            let num = |t: &str| -> Result<Option<u32>, ParseError> {
                if t.trim().is_empty() {
                    return Ok(None);
                }
                t.trim().parse().map(Some).map_err(|_| ParseError::new(s, format!("{t:?} is not a point index")))
            };
            *out = (num(lo)?, num(hi)?);
        }
        Ok(Roi::Index(r))
    }

    /// `x0:x1,y0:y1,z0:z1`: a world box (finite numbers, each range low to high); an empty bound
    /// takes the lattice's extent, as in [`parse_index`](Roi::parse_index).
    ///
    /// # Errors
    /// Not three ranges, a range without `:`, a bound that is not a finite number, or a range
    /// whose low bound is above its high one.
    pub fn parse_world(s: &str) -> Result<Roi, ParseError> {
        let mut r = [(None, None); 3];
        for (a, (out, (lo, hi))) in r.iter_mut().zip(split3(s)?).enumerate() {
            let num = |t: &str| -> Result<Option<f64>, ParseError> {
                if t.trim().is_empty() {
                    return Ok(None);
                }
                number(t, "").map(Some).map_err(|_| ParseError::new(s, format!("{t:?} is not a finite number")))
            };
            *out = (num(lo)?, num(hi)?);
            if let (Some(l), Some(h)) = *out {
                if l > h {
                    let axis = ["x", "y", "z"][a];
                    return Err(ParseError::new(s, format!("{axis} range {l}:{h} is reversed (low bound first)")));
                }
            }
        }
        Ok(Roi::World(r))
    }

    /// The half-open point box `lo..hi` the region covers on `lattice`.
    ///
    /// Index ranges are taken as given (open bounds: the axis' ends). A world box keeps the lattice
    /// points inside it: its eight corners are mapped to index space (any direction matrix) and
    /// the bounds rounded inwards, with a tolerance of 1e-9 points so a face through a point keeps
    /// it; then clipped to the lattice.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the box holds no point on some axis or an index range leaves
    /// the lattice (`lo < hi <= dims` per axis).
    pub fn point_box(&self, lattice: &Lattice) -> Result<([u32; 3], [u32; 3])> {
        let dims = lattice.dims();
        let (lo, hi) = match self {
            Roi::Index(r) => ([0, 1, 2].map(|a| r[a].0.unwrap_or(0)), [0, 1, 2].map(|a| r[a].1.unwrap_or(dims[a]))),
            Roi::World(r) => {
                // Open bounds: the lattice's world box on that axis (a rotated lattice's too).
                let (wlo, whi) = lattice.world_bounds();
                let r: [(f64, f64); 3] = [0, 1, 2].map(|a| (r[a].0.unwrap_or(wlo[a]), r[a].1.unwrap_or(whi[a])));
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for c in 0..8 {
                    let w = [0, 1, 2].map(|a| if c >> a & 1 == 1 { r[a].1 } else { r[a].0 });
                    let p = lattice.to_index(w);
                    for a in 0..3 {
                        lo[a] = lo[a].min(p[a]);
                        hi[a] = hi[a].max(p[a]);
                    }
                }
                const EPS: f64 = 1e-9;
                let clip = |x: f64, a: usize| x.clamp(0.0, f64::from(dims[a])) as u32;
                (
                    [0, 1, 2].map(|a| clip((lo[a] - EPS).ceil(), a)),
                    [0, 1, 2].map(|a| clip((hi[a] + EPS).floor() + 1.0, a)),
                )
            }
        };
        if let Some(a) = (0..3).find(|&a| lo[a] >= hi[a] || hi[a] > dims[a]) {
            let what = match self {
                Roi::Index(_) => "region",
                Roi::World(_) => "world box: region",
            };
            return Err(Error::InvalidInput(format!(
                "{what} {lo:?}..{hi:?}: axis {a} must satisfy lo < hi <= {} (the lattice has {dims:?} points)",
                dims[a]
            )));
        }
        Ok((lo, hi))
    }
}

impl Region {
    /// Whether the region leaves the volume as it is.
    pub fn is_identity(&self) -> bool {
        self.roi.is_none() && self.world.is_none() && !self.close && !self.index_space
    }

    /// The region for label surfaces: the same cut and frame, without `close` (each label
    /// surface is closed by its own padding).
    pub fn for_labels(&self) -> Region {
        Region { close: false, ..self.clone() }
    }

    /// Crops `g` to the ROI ([`Roi::point_box`]), pads it with one layer of `outside` when
    /// `close`, then re-places it: unit spacing at the input's point indices (`index_space`; the
    /// padding sits at index −1) or re-expressed in the `world` frame.
    ///
    /// # Errors
    /// As [`Roi::point_box`]; [`Error::Limit`] when the padded lattice is too large;
    /// [`Error::InvalidInput`] when the lattice has no frame to convert from.
    pub fn apply(&self, g: AnyGrid, outside: f64) -> Result<AnyGrid> {
        self.apply_to(Cow::Owned(g), outside).map(Cow::into_owned)
    }

    /// [`Region::apply`] on a borrowed or owned grid: an identity region keeps it as it is (no
    /// copy); a ROI or `close` makes a new grid from the borrowed one without copying it first.
    ///
    /// # Errors
    /// As [`Region::apply`].
    pub fn apply_to<'a>(&self, g: Cow<'a, AnyGrid>, outside: f64) -> Result<Cow<'a, AnyGrid>> {
        if self.is_identity() {
            return Ok(g);
        }
        let mut g = g;
        // Index-space position of the current grid's first point in the input volume.
        let mut first = [0.0f64; 3];
        if let Some(roi) = &self.roi {
            let (lo, hi) = roi.point_box(g.lattice())?;
            g = Cow::Owned(g.crop(lo, hi)?);
            first = lo.map(f64::from);
        }
        if self.close {
            g = Cow::Owned(g.pad(1, outside)?);
            first = first.map(|x| x - 1.0);
        }
        if self.index_space {
            let lattice = Lattice::with_geometry(g.lattice().dims(), [1.0; 3], first)?;
            g = Cow::Owned(g.into_owned().with_lattice(lattice)?);
        }
        if let Some(target) = self.world {
            let lattice = g.lattice().in_space(target)?;
            g = Cow::Owned(g.into_owned().with_lattice(lattice)?);
        }
        Ok(g)
    }

    /// A mask volume (non-zero: in the mask) as point flags on the input's lattice after this
    /// region: cropped like the input; a `close` border counts as in the mask (it only adds
    /// outside points).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when the mask's dims differ from `input_dims`; as [`Region::apply`].
    pub fn mask(&self, m: &AnyGrid, input_dims: [u32; 3]) -> Result<PointMask> {
        if m.lattice().dims() != input_dims {
            return Err(Error::InvalidInput(format!(
                "dims {:?} differ from the input's {input_dims:?}",
                m.lattice().dims()
            )));
        }
        let region = Region { roi: self.roi.clone(), close: self.close, ..Region::default() };
        let m = region.apply_to(Cow::Borrowed(m), 1.0)?;
        let flags: Vec<bool> = m.values_f64().map(|v| v != 0.0).collect();
        PointMask::new(m.lattice().dims(), flags)
    }
}

// ---------------------------------------------------------------------------------------------
// Attributes and colours.

/// Where an attribute comes from; `V` names a volume (the front end opens it).
#[derive(Debug, Clone, PartialEq)]
pub enum AttributeSource<V> {
    /// A co-registered volume, sampled trilinearly in world coordinates.
    Volume(V),
    /// A procedural solid texture; the scale is its feature size in world units (default: an
    /// eighth of the mesh's bounding-box diagonal).
    Texture(SolidTexture, Option<f64>),
}

impl<V> AttributeSource<V> {
    /// The same source with the volume named another way (a path opened, say).
    ///
    /// # Errors
    /// What `f` returns.
    pub fn try_map<W, E>(self, f: impl FnOnce(V) -> Result<W, E>) -> Result<AttributeSource<W>, E> {
        Ok(match self {
            AttributeSource::Volume(v) => AttributeSource::Volume(f(v)?),
            AttributeSource::Texture(t, s) => AttributeSource::Texture(t, s),
        })
    }
}

/// `NAME=VOLUME` or `NAME=texture:KIND[?scale=S]`; the volume is returned as the text given.
///
/// # Errors
/// No `=`, a name that is not letters, digits or `_`, an unknown texture, a scale that is not a
/// positive number, an unknown parameter.
pub fn parse_attribute(spec: &str) -> Result<(String, AttributeSource<String>), ParseError> {
    let bad = |problem: String| ParseError::new(spec, problem);
    let (name, src) =
        spec.split_once('=').ok_or_else(|| bad("expected NAME=VOLUME or NAME=texture:KIND".to_string()))?;
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(bad("the name must be letters, digits or _".to_string()));
    }
    let Some(t) = src.strip_prefix("texture:") else {
        return Ok((name.to_string(), AttributeSource::Volume(src.to_string())));
    };
    let (kind, query) = t.split_once('?').unwrap_or((t, ""));
    let tex = SolidTexture::parse(kind).ok_or_else(|| {
        let names: Vec<&str> = SolidTexture::ALL.iter().map(|(_, n)| *n).collect();
        bad(format!("unknown texture {kind:?} (available: {})", names.join(", ")))
    })?;
    let scale = match query.strip_prefix("scale=") {
        Some(v) => match number(v, "") {
            Ok(s) if s > 0.0 => Some(s),
            _ => return Err(bad(format!("scale {v:?} must be a positive number"))),
        },
        None if query.is_empty() => None,
        None => return Err(bad(format!("unknown parameter {query:?} (scale=S)"))),
    };
    Ok((name.to_string(), AttributeSource::Texture(tex, scale)))
}

/// Vertex colours from an attribute through a colour map.
#[derive(Debug, Clone, PartialEq)]
pub struct ColorBy {
    /// The attribute's name.
    pub attribute: String,
    /// The map.
    pub map: Colormap,
    /// The values mapped to the map's ends (`None`: the attribute's range).
    pub range: Option<(f64, f64)>,
}

impl ColorBy {
    /// The colours of `values`.
    pub fn colors(&self, values: &[f32]) -> Vec<[u8; 3]> {
        let (lo, hi) = self.range.unwrap_or_else(|| {
            values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(f64::from(v)), b.max(f64::from(v))))
        });
        self.map.colors(values, lo, hi)
    }
}

/// An attribute ready to sample.
#[derive(Debug, Clone)]
pub enum Attribute {
    /// A volume, sampled trilinearly at world points.
    Volume(AnyGrid),
    /// A solid texture and its scale.
    Texture(SolidTexture, Option<f64>),
}

/// An attribute's values at the vertices.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    /// One value per vertex.
    pub values: Vec<f32>,
    /// Vertices outside the attribute volume's box (given the nearest value there).
    pub outside: usize,
}

impl Attribute {
    /// A volume attribute expressed in the mesh's frame `frame`: an RAS volume for an LPS input
    /// (or the reverse) is re-expressed first; volumes or inputs without a frame are taken as
    /// they are.
    ///
    /// # Errors
    /// As [`Lattice::in_space`].
    pub fn volume_in(g: AnyGrid, frame: Option<WorldSpace>) -> Result<Attribute> {
        Ok(Attribute::Volume(match (frame, g.lattice().space()) {
            (Some(want), Some(have)) if want != have => {
                let l = g.lattice().in_space(want)?;
                g.with_lattice(l)?
            }
            _ => g,
        }))
    }

    /// The attribute at each of `positions` (world coordinates).
    pub fn sample(&self, positions: &[[f32; 3]]) -> Samples {
        match self {
            Attribute::Volume(g) => {
                let mut outside = 0usize;
                let values = positions
                    .iter()
                    .map(|p| {
                        let (v, inside) = g.value_at_world(p.map(f64::from));
                        outside += usize::from(!inside);
                        v as f32
                    })
                    .collect();
                Samples { values, outside }
            }
            Attribute::Texture(t, scale) => {
                let (lo, hi) = positions.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
                    ([0, 1, 2].map(|a| lo[a].min(p[a])), [0, 1, 2].map(|a| hi[a].max(p[a])))
                });
                let diag = (0..3).map(|a| f64::from(hi[a] - lo[a]).powi(2)).sum::<f64>().sqrt();
                let s = scale.unwrap_or(if diag > 0.0 { diag / 8.0 } else { 1.0 }) as f32;
                let values = positions.iter().map(|p| t.at(crate::math::Vec3::from(*p) / s)).collect();
                Samples { values, outside: 0 }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::DenseGrid;

    #[test]
    fn index_rois_parse_with_open_bounds() {
        assert_eq!(
            Roi::parse_index("1:4,:,2:").unwrap(),
            Roi::Index([(Some(1), Some(4)), (None, None), (Some(2), None)])
        );
        let e = Roi::parse_index("1:2,:").unwrap_err();
        assert_eq!(e.to_string(), "\"1:2,:\": expected three ranges lo:hi separated by commas");
        assert!(Roi::parse_index("1-2,:,:").unwrap_err().problem.contains("has no ':'"));
        assert!(Roi::parse_index("a:b,:,:").unwrap_err().problem.contains("\"a\" is not a point index"));
        assert!(Roi::parse_index("-1:2,:,:").is_err());
        assert!(Roi::parse_world("0:1,0:1,nan:1").unwrap_err().problem.contains("not a finite number"));
    }

    #[test]
    fn issue_50_one_rule_for_every_argument() {
        // World ranges: reversed is an error like a reversed index range; empty bounds take the
        // lattice's extent like --roi's.
        let e = Roi::parse_world("40:30,0:1,0:1").unwrap_err();
        assert!(e.problem.contains("x range 40:30 is reversed"), "{e}");
        let l = Lattice::with_geometry([5, 6, 7], [1.0; 3], [10.0, 0.0, 0.0]).unwrap();
        let open = Roi::parse_world(":,2:,:3").unwrap();
        assert_eq!(open.point_box(&l).unwrap(), ([0, 2, 0], [5, 6, 4]));
        assert_eq!(Roi::parse_world("11:,:,:").unwrap().point_box(&l).unwrap(), ([1, 0, 0], [5, 6, 7]));
        // Isos: underflow is refused, not read as 0; a value given twice is refused, whatever
        // its spelling; 0 itself is fine.
        assert!(parse_iso("1e-400").unwrap_err().problem.contains("too small"));
        assert!(parse_iso("-0.0001e-320").is_err());
        assert_eq!(parse_iso("0e-400").unwrap(), 0.0);
        assert_eq!(parse_iso("-0.0").unwrap(), 0.0);
        let e = parse_isos("100,50,1e2").unwrap_err();
        assert!(e.problem.contains("\"100\" and \"1e2\" are the same iso"), "{e}");
        assert_eq!(parse_isos("1,2").unwrap(), vec![1.0, 2.0]);
    }

    #[test]
    fn index_boxes_are_half_open_and_must_fit() {
        let l = Lattice::new([5, 6, 7]).unwrap();
        assert_eq!(Roi::parse_index("1:4,:,2:").unwrap().point_box(&l).unwrap(), ([1, 0, 2], [4, 6, 7]));
        // hi is exclusive: 4:5 is the last point.
        assert_eq!(Roi::parse_index("4:5,:,:").unwrap().point_box(&l).unwrap(), ([4, 0, 0], [5, 6, 7]));
        for bad in ["1:9,:,:", "3:3,:,:", "4:2,:,:", ":,:,7:"] {
            let e = Roi::parse_index(bad).unwrap().point_box(&l).unwrap_err().to_string();
            assert!(e.contains("must satisfy lo < hi"), "{bad}: {e}");
        }
    }

    #[test]
    fn world_boxes_round_inwards_and_clip_to_the_lattice() {
        // Points at x = 10, 10.5, 11, … (spacing 0.5, origin 10).
        let l = Lattice::with_geometry([6, 4, 4], [0.5, 1.0, 1.0], [10.0, 0.0, 0.0]).unwrap();
        let b = |s: &str| Roi::parse_world(s).unwrap().point_box(&l);
        // 10.4..11.6 holds 10.5, 11, 11.5: indices 1..4.
        assert_eq!(b("10.4:11.6,0:3,0:3").unwrap(), ([1, 0, 0], [4, 4, 4]));
        // A face through a point keeps it (within the tolerance).
        assert_eq!(b("10.5:11,0:3,0:3").unwrap(), ([1, 0, 0], [3, 4, 4]));
        // Reversed bounds are refused when parsed (issue 50), like reversed index ranges.
        assert!(Roi::parse_world("11:10.5,3:0,0:3").is_err());
        // Beyond the lattice: clipped.
        assert_eq!(b("-100:100,-1:1.5,2:99").unwrap(), ([0, 0, 2], [6, 2, 4]));
        // Between two points, or entirely outside: empty.
        assert!(b("10.6:10.9,0:3,0:3").unwrap_err().to_string().contains("axis 0"));
        assert!(b("10:12,50:60,0:3").unwrap_err().to_string().contains("axis 1"));
    }

    fn ramp() -> AnyGrid {
        let l = Lattice::with_geometry([4, 3, 3], [2.0, 1.0, 1.0], [100.0, 0.0, 0.0]).unwrap();
        DenseGrid::from_fn(l, |p| p[0] as f32 + 10.0 * p[1] as f32 + 100.0 * p[2] as f32).into()
    }

    #[test]
    fn regions_crop_close_and_place() {
        let roi = Some(Roi::parse_index("1:3,1:,:").unwrap());
        let r = Region { roi: roi.clone(), ..Region::default() };
        let g = r.apply(ramp(), 0.0).unwrap();
        assert_eq!(g.lattice().dims(), [2, 2, 3]);
        assert_eq!(g.lattice().origin(), [102.0, 1.0, 0.0]);
        assert_eq!(g.get_f64([0, 0, 0]), 11.0);
        // Closed and in index space: the border at index −1, outside value around.
        let r = Region { roi, close: true, index_space: true, ..Region::default() };
        let g = r.apply(ramp(), -5.0).unwrap();
        assert_eq!(g.lattice().dims(), [4, 4, 5]);
        assert_eq!(g.lattice().origin(), [0.0, 0.0, -1.0]);
        assert_eq!(g.lattice().spacing(), [1.0; 3]);
        assert_eq!(g.get_f64([0, 0, 0]), -5.0);
        assert_eq!(g.get_f64([1, 1, 1]), 11.0);
        assert!(Region::default().is_identity());
        assert!(!r.for_labels().close);
    }

    #[test]
    fn masks_follow_the_region_and_check_dims() {
        let m: AnyGrid = DenseGrid::from_fn(Lattice::new([4, 3, 3]).unwrap(), |p| u8::from(p[0] >= 2)).into();
        let r = Region { roi: Some(Roi::parse_index("1:,:,:").unwrap()), close: true, ..Region::default() };
        let mask = r.mask(&m, [4, 3, 3]).unwrap();
        assert_eq!(mask.dims(), [5, 5, 5]);
        assert!(mask.contains([0, 0, 0]), "the border is in the mask");
        assert!(!mask.contains([1, 1, 1]), "point 1 of the input is not");
        assert!(mask.contains([2, 1, 1]));
        assert!(r.mask(&m, [4, 3, 4]).unwrap_err().to_string().contains("differ from the input's"));
    }

    #[test]
    fn attributes_are_trilinear_at_world_points() {
        // f = x + 10 y + 100 z in index units, x spacing 2 from 100: linear, so the trilinear
        // interpolant is exact: at world (101, 0.5, 1.25) the index point is (0.5, 0.5, 1.25).
        let a = Attribute::Volume(ramp());
        let s = a.sample(&[[101.0, 0.5, 1.25], [104.0, 2.0, 2.0], [200.0, 0.0, 0.0]]);
        assert_eq!(s.values[0], 0.5 + 5.0 + 125.0);
        assert_eq!(s.values[1], 2.0 + 20.0 + 200.0);
        // Outside the box: the nearest point's value (x index 3), counted.
        assert_eq!(s.values[2], 3.0);
        assert_eq!(s.outside, 1);
    }

    #[test]
    fn attribute_specs_and_colours() {
        assert_eq!(parse_attribute("d=vol.nrrd").unwrap(), ("d".into(), AttributeSource::Volume("vol.nrrd".into())));
        let (_, t) = parse_attribute("t=texture:noise?scale=2").unwrap();
        assert!(matches!(t, AttributeSource::Texture(_, Some(s)) if s == 2.0));
        for bad in ["novalue", "a b=x", "t=texture:plaid", "t=texture:noise?scale=-1", "t=texture:noise?x=1"] {
            assert!(parse_attribute(bad).is_err(), "{bad}");
        }
        let by = ColorBy { attribute: "d".into(), map: Colormap::parse("gray").unwrap(), range: None };
        let c = by.colors(&[1.0, 3.0, 2.0]);
        assert_eq!(c[0], [0, 0, 0]);
        assert_eq!(c[1], [255, 255, 255]);
    }

    #[test]
    fn textual_forms_and_isos() {
        assert_eq!("above".parse::<Inside>().unwrap(), Inside::Above);
        assert_eq!("under".parse::<Inside>().unwrap_err().to_string(), "\"under\": must be below or above");
        assert_eq!("mt5".parse::<Method>().unwrap(), Method::Tetrahedra5);
        assert!("xx".parse::<Method>().unwrap_err().problem.contains("available: mc, mc33"));
        assert_eq!(parse_isos("1, 2.5").unwrap(), vec![1.0, 2.5]);
        assert_eq!(parse_isos("1,x").unwrap_err().text, "x");
        assert!(parse_iso("inf").unwrap_err().problem.contains("finite"));
        assert_eq!("3,4".parse::<Labels>().unwrap(), Labels::These(vec![3.0, 4.0]));
        let e = "3,1.5".parse::<Labels>().unwrap_err().to_string();
        assert!(e.contains("label value 1.5 is not an integer"), "{e}");
        let r: Request = Request { isos: vec![], inside: Some(Inside::Above), ..Request::default() };
        assert_eq!(r.isos_or(Iso::below(48.0)), vec![Iso { value: 48.0, inside: Inside::Above }]);
        let isos = [Iso::below(1.0), Iso::below(9.0)];
        assert!(check_isos_in_range(&isos, 0.0, 10.0).is_ok());
        assert_eq!(
            check_isos_in_range(&isos, 0.0, 5.0).unwrap_err().to_string(),
            "iso 9 is outside the value range [0, 5]"
        );
        assert_eq!(outside_value(Inside::Below, 0.0, 5.0), 5.0);
    }

    #[test]
    fn no_surface_names_the_side() {
        let s = crate::walk::WalkStats { cells: 8, cells_outside: 8, ..Default::default() };
        let n = NoSurface::of(&s, Iso::below(5.0)).unwrap();
        assert_eq!(n.to_string(), "iso 5 gives no surface: every lattice point is outside (inside is below iso)");
        let s = crate::walk::WalkStats { cells: 8, cells_outside: 7, ..Default::default() };
        assert_eq!(NoSurface::of(&s, Iso::below(5.0)), None);
    }
}
