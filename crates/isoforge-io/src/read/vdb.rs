//! OpenVDB `.vdb` files: the float and double grids of a file as plain data — 8³ leaves,
//! constant tiles, the background and the index → world transform — for a sparse grid to be
//! built from.
//!
//! Read: file format versions 222 to 225 (OpenVDB 3.0 to 13; Debian's OpenVDB 10.0.1 writes
//! 224), with or without grid offsets (files and streams); grids of the standard tree
//! (`Tree_float_5_4_3`, `Tree_double_5_4_3`: root → 32³ → 16³ → 8³ leaves), values stored raw,
//! zip (zlib) or blosc (lz4 or zlib codec, byte shuffle), with active-mask compression in all
//! seven modes and as 16-bit halves (`is_saved_as_half_float`); grid instances (a grid sharing
//! another's tree) are copied; the maps `UniformScaleMap`, `UniformScaleTranslateMap`,
//! `ScaleMap`, `ScaleTranslateMap`, `TranslationMap`, `AffineMap` and `UnitaryMap`.
//! Grids of other types (vec3, integer, bool, mask, points…) are skipped and listed in
//! [`VdbFile::skipped`]; a file without any float or double grid is refused.
//!
//! Refused with a message naming the file, the field and the value: older formats (before
//! OpenVDB 3.0), frustum and other non-linear maps, blosc codecs other than lz4 and zlib, a grid
//! of another type in a file without grid offsets (it cannot be skipped), non-finite values,
//! and anything truncated, inconsistent or larger than [`Limits`] allows. Decoded sizes are known
//! before anything is decoded and every chunk must decode to exactly its size; the output is
//! counted against the limit as it is planned (leaf by leaf, tile by tile), before it is made.
//!
//! Values are kept in the grid's own type ([`VdbLeaves::Float`] or [`VdbLeaves::Double`]):
//! f32 leaves take half the memory of f64 ones, and f32 → f64 is exact whenever a caller wants
//! doubles. Tiles, the background and [`VdbLookup::value_at`] give `f64` (exact for both).
//!
//! The writer of such files is [`crate::write::vdb`].

mod blosc;
mod input;
mod tree;

use std::collections::HashMap;
use std::io::{BufReader, Cursor};
use std::path::Path;

use crate::error::{Ctx, Result};
use crate::limits::Limits;

pub(crate) use input::shown;
use input::{Fail, ReadSeek, Res, Src};
use tree::{Budget, Storage, Value};

/// A `.vdb` file's float and double grids, in file order.
#[derive(Debug, Clone)]
pub struct VdbFile {
    /// Every float or double grid of the file, in file order.
    pub grids: Vec<VdbGrid>,
    /// The grids of other types that were skipped: (name, grid type), e.g.
    /// `("velocity", "Tree_vec3s_5_4_3")`.
    pub skipped: Vec<(String, String)>,
    /// The file format version (222 to 225).
    pub format_version: u32,
    /// The version (major, minor) of the OpenVDB library that wrote the file.
    pub library_version: (u32, u32),
}

/// One grid: metadata, transform, and its tree as leaves and tiles.
///
/// A point `ijk` is active with value `v` when a leaf holds it with its active bit set, or an
/// active tile covers it; it is inactive with the leaf's value or an inactive tile's value; a
/// point nothing covers is inactive with the background. [`VdbGrid::lookup`] answers that.
#[derive(Debug, Clone)]
pub struct VdbGrid {
    /// The grid's name (its `name` metadata, or the name it is stored under).
    pub name: String,
    /// The `class` metadata: `"level set"`, `"fog volume"`, `"staggered"`; `None` when absent
    /// or `"unknown"`.
    pub class: Option<String>,
    /// The values were stored as 16-bit halves (`is_saved_as_half_float`): they carry half
    /// precision, converted exactly.
    pub saved_as_half: bool,
    /// The value of every point not covered by a leaf or a tile (inactive).
    pub background: f64,
    /// Index → world.
    pub transform: VdbTransform,
    /// The 8³ leaves, in file order (depth first, root children by origin).
    pub leaves: VdbLeaves,
    /// Every tile of the tree that is active or whose value is not the background, in file
    /// order (root tiles first). Inactive background tiles are left out: nothing covering a
    /// point means the same.
    pub tiles: Vec<VdbTile>,
    /// The grid this one shares its tree with in the file (an OpenVDB instance): its leaves
    /// and tiles are a copy of that grid's.
    pub instance_of: Option<String>,
}

/// The value type of a grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VdbValueType {
    /// 32-bit floats (`Tree_float_5_4_3`).
    Float,
    /// 64-bit floats (`Tree_double_5_4_3`).
    Double,
}

/// A grid's leaves, in the grid's value type.
#[derive(Debug, Clone)]
pub enum VdbLeaves {
    /// Leaves of a float grid.
    Float(Vec<VdbLeaf<f32>>),
    /// Leaves of a double grid.
    Double(Vec<VdbLeaf<f64>>),
}

/// An 8³ block of points at `origin` (a multiple of 8 on every axis).
///
/// The value of point `origin + [x, y, z]` (each in `0..8`) is `values[(x << 6) | (y << 3) | z]`
/// (OpenVDB's order: z fastest), and it is active when bit `n % 64` of `active[n / 64]` is set
/// for that same `n`. Memory per leaf: 2 KiB of values for f32, 4 KiB for f64, plus 64 bytes of
/// mask and the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct VdbLeaf<T> {
    /// The point with the smallest coordinates.
    pub origin: [i32; 3],
    /// The 512 values, `(x << 6) | (y << 3) | z`.
    pub values: Box<[T; 512]>,
    /// Active bits, same numbering.
    pub active: [u64; 8],
}

/// A constant region: `size³` points from `origin` (a multiple of `size`) share `value` and
/// `active`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VdbTile {
    /// The point with the smallest coordinates.
    pub origin: [i32; 3],
    /// Points per edge: 8 (a tile of a 16³ node, in place of a leaf), 128 (of a 32³ node) or
    /// 4096 (of the root).
    pub size: u32,
    /// The value of every point of the tile.
    pub value: f64,
    /// Whether the tile's points are active.
    pub active: bool,
}

/// The index → world map of a grid: `world = matrix · [i, j, k, 1]ᵀ` (rows of `matrix` are
/// world x, y, z and the homogeneous row `[0, 0, 0, 1]`; the fourth column is the world
/// position of point `[0, 0, 0]`). Point `ijk` is the centre of OpenVDB's voxel `ijk`.
#[derive(Debug, Clone, PartialEq)]
pub struct VdbTransform {
    /// The file's map type, e.g. `"UniformScaleTranslateMap"`.
    pub map: String,
    /// Index → world, acting on column vectors.
    pub matrix: [[f64; 4]; 4],
}

/// Reads the float and double grids of the `.vdb` file at `path`.
///
/// # Errors
/// A [`crate::Error`] naming the file, the field and the value: see the module documentation.
pub fn read_vdb(path: &Path, limits: &Limits) -> Result<VdbFile> {
    let ctx = Ctx::new(path, "VDB");
    let input = crate::file::open(ctx, path)?;
    let len = input.len;
    let mut r = BufReader::with_capacity(64 << 10, crate::file::Bounded::new(input));
    read(ctx, &mut r, len, limits)
}

/// Reads the float and double grids of a `.vdb` file held in memory; `path_for_messages` is the
/// name errors give.
///
/// # Errors
/// As [`read_vdb`].
pub fn read_vdb_bytes(path_for_messages: &Path, bytes: &[u8], limits: &Limits) -> Result<VdbFile> {
    let ctx = Ctx::new(path_for_messages, "VDB");
    read(ctx, &mut Cursor::new(bytes), bytes.len() as u64, limits)
}

fn read(ctx: Ctx, r: &mut dyn ReadSeek, len: u64, limits: &Limits) -> Result<VdbFile> {
    read_file(&mut Src::new(r, len), limits).map_err(|f| f.into_error(ctx))
}

/// OpenVDB's magic number, the first 8 bytes (little-endian `i64`).
const MAGIC: i64 = 0x5644_4220;
/// The oldest format read (`OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION`, OpenVDB 3.0: per-grid
/// compression flags and per-node compression modes) and the newest known (OpenVDB 13).
const FIRST_VERSION: u32 = 222;
const LAST_VERSION: u32 = 225;
/// Longest grid name, grid type or map type accepted.
const MAX_NAME: u32 = 1 << 16;
/// Metadata names longer than this are none of the few this reader looks at: skipped unread.
const MAX_META_NAME: u32 = 64;
/// The smallest grid descriptor: three empty strings and three offsets.
const MIN_DESCRIPTOR: u64 = 3 * 4 + 3 * 8;
/// The suffix of a grid type whose values are stored as halves.
const HALF_SUFFIX: &str = "_HalfFloat";
/// What separates a grid's name from the number that makes it unique in the file.
const UNIQUE_SEPARATOR: char = '\u{1e}';

fn read_file(src: &mut Src, limits: &Limits) -> Res<VdbFile> {
    let magic = src.i64("magic number")?;
    if magic != MAGIC {
        return Err(Fail::bad(format!(
            "byte 0: magic number {magic:#x} is not OpenVDB's ({MAGIC:#x}): not a .vdb file"
        )));
    }
    let version = src.u32("file format version")?;
    if !(FIRST_VERSION..=LAST_VERSION).contains(&version) {
        let which = if version < FIRST_VERSION { "older" } else { "newer" };
        return Err(Fail::unsupported(format!(
            "byte 8: file format version {version} is {which} than the versions read ({FIRST_VERSION} to \
             {LAST_VERSION}, OpenVDB 3.0 to 13); rewrite the file with OpenVDB 10 to 13"
        )));
    }
    let library_version = (src.u32("library major version")?, src.u32("library minor version")?);
    let at = src.pos();
    let offsets = match src.u8("grid offsets flag")? {
        0 => false,
        1 => true,
        f => return Err(Fail::bad(format!("byte {at}: grid offsets flag {f} (expected 0 or 1)"))),
    };
    src.skip(36, "file UUID")?;
    read_meta(src).map_err(|f| f.within("file metadata"))?;

    let at = src.pos();
    let count = src.i32("grid count")?;
    let count = u64::try_from(count).map_err(|_| Fail::bad(format!("byte {at}: grid count {count} is negative")))?;
    if count * MIN_DESCRIPTOR > src.left() {
        return Err(Fail::bad(format!(
            "byte {at}: grid count {count}: the {} bytes left hold at most {}",
            src.left(),
            src.left() / MIN_DESCRIPTOR
        )));
    }
    let mut file = VdbFile { grids: Vec::new(), skipped: Vec::new(), format_version: version, library_version };
    // The index in file.grids of each grid's unique name, for instances (a hash map: a file may
    // hold hundreds of thousands of tiny grids and instances).
    let mut unique_names: HashMap<String, usize> = HashMap::new();
    let mut budget = Budget { used: 0, allowed: limits.max_bytes };
    for n in 0..count {
        let d = read_descriptor(src, offsets).map_err(|f| f.within(format!("grid {n}")))?;
        let label = format!("grid {n} ({})", shown(&d.name));
        let value_type = match d.base_type.as_str() {
            "Tree_float_5_4_3" => Some(VdbValueType::Float),
            "Tree_double_5_4_3" => Some(VdbValueType::Double),
            _ => None,
        };
        let Some(value_type) = value_type else {
            if !offsets {
                return Err(Fail::unsupported(format!(
                    "{label}: type {}: this file has no grid offsets (it was written as a stream), so a grid \
                     of a type other than float or double cannot be skipped",
                    shown(&d.type_name)
                )));
            }
            file.skipped.push((d.name, d.type_name));
            src.seek(d.end)?;
            continue;
        };
        if offsets {
            src.set_end(d.end);
        }
        let grid = read_grid(src, &d, value_type, offsets, &file.grids, &unique_names, &mut budget)
            .map_err(|f| f.within(&label))?;
        if offsets {
            src.set_end(src.len());
            src.seek(d.end)?;
        }
        unique_names.insert(d.unique_name, file.grids.len());
        file.grids.push(grid);
    }
    if file.grids.is_empty() {
        let types: Vec<String> = file.skipped.iter().map(|(_, t)| shown(t)).collect();
        return Err(Fail::unsupported(if types.is_empty() {
            "the file holds no grid".to_string()
        } else {
            format!("the file holds no float or double grid (only {})", types.join(", "))
        }));
    }
    Ok(file)
}

/// A grid descriptor: names, type, and where the grid's data lies.
struct Descriptor {
    unique_name: String,
    name: String,
    type_name: String,
    base_type: String,
    half_suffix: bool,
    parent: Option<String>,
    /// Where the grid's data ends (the next descriptor), with grid offsets.
    end: u64,
}

fn read_descriptor(src: &mut Src, offsets: bool) -> Res<Descriptor> {
    let unique_name = src.string(MAX_NAME, "grid name")?;
    let type_name = src.string(MAX_NAME, "grid type")?;
    let parent = src.string(MAX_NAME, "instance parent name")?;
    let at = src.pos();
    let grid_pos = src.i64("grid position")?;
    let block_pos = src.i64("value blocks position")?;
    let end_pos = src.i64("grid end position")?;
    let here = src.pos();
    let mut end = here;
    if offsets {
        // OpenVDB writes a grid right after its descriptor and the next descriptor at its end
        // (and reads a grid from its start on: the position of its value blocks, 0 for an
        // instance, is not needed).
        let ok = u64::try_from(grid_pos).is_ok_and(|g| g == here)
            && end_pos >= grid_pos
            && u64::try_from(end_pos).is_ok_and(|e| e <= src.len());
        if !ok {
            return Err(Fail::bad(format!(
                "byte {at}: grid offsets {grid_pos}, {block_pos}, {end_pos}: expected the grid to start at byte {here} \
                 and to end within the file's {} bytes",
                src.len()
            )));
        }
        end = end_pos.unsigned_abs();
    }
    let name = unique_name.split(UNIQUE_SEPARATOR).next().unwrap_or_default().to_string();
    let (base_type, half_suffix) = match type_name.strip_suffix(HALF_SUFFIX) {
        Some(base) => (base.to_string(), true),
        None => (type_name.clone(), false),
    };
    let parent = (!parent.is_empty()).then_some(parent);
    Ok(Descriptor { unique_name, name, type_name, base_type, half_suffix, parent, end })
}

/// What the reader takes from a grid's metadata.
#[derive(Default)]
struct Meta {
    name: Option<String>,
    class: Option<String>,
    half: Option<bool>,
}

/// Reads a metadata map (a `u32` count of name, type name, `u32` size, value), keeping the
/// grid's name, class and half-float flag and skipping everything else by its size.
fn read_meta(src: &mut Src) -> Res<Meta> {
    let at = src.pos();
    let count = src.u32("metadata count")?;
    if u64::from(count) * 12 > src.left() {
        return Err(Fail::bad(format!(
            "byte {at}: metadata count {count} does not fit in the {} bytes left",
            src.left()
        )));
    }
    let mut meta = Meta::default();
    for _ in 0..count {
        let at = src.pos();
        let name = src.short_string(MAX_META_NAME, "metadata name")?;
        let type_name = src.short_string(MAX_META_NAME, "metadata type")?;
        let size = src.u32("metadata size")?;
        let entry = |detail: String| {
            Fail::bad(format!("byte {at}: metadata {}: {detail}", shown(name.as_deref().unwrap_or(""))))
        };
        match (name.as_deref(), type_name.as_deref()) {
            (Some(field @ ("name" | "class")), Some("string")) => {
                if size > MAX_NAME {
                    return Err(entry(format!("{size} bytes, over the {MAX_NAME} accepted")));
                }
                let mut bytes = Vec::new();
                src.read_vec(u64::from(size), &mut bytes, "metadata value")?;
                let text = String::from_utf8_lossy(&bytes).into_owned();
                if field == "name" {
                    meta.name = Some(text);
                } else {
                    meta.class = Some(text);
                }
            }
            (Some("is_saved_as_half_float"), Some(t)) => {
                let width = match t {
                    "bool" => 1,
                    "int32" | "float" => 4,
                    "int64" | "double" => 8,
                    _ => return Err(entry(format!("type {} (expected bool)", shown(t)))),
                };
                if size != width {
                    return Err(entry(format!("{size} bytes for a {t} (expected {width})")));
                }
                let mut bytes = [0u8; 8];
                src.fill(&mut bytes[..width as usize], "metadata value")?;
                // OpenVDB's `asBool`: any non-zero value (a float's -0.0 included, harmlessly).
                meta.half = Some(bytes.iter().any(|&b| b != 0));
            }
            _ => src.skip(u64::from(size), "metadata value")?,
        }
    }
    Ok(meta)
}

/// Reads one float or double grid from its data: compression flags, metadata, transform, tree.
#[allow(clippy::too_many_arguments)]
fn read_grid(
    src: &mut Src,
    d: &Descriptor,
    value_type: VdbValueType,
    offsets: bool,
    earlier: &[VdbGrid],
    unique_names: &HashMap<String, usize>,
    budget: &mut Budget,
) -> Res<VdbGrid> {
    let at = src.pos();
    let compression = src.u32("compression flags")?;
    let known = tree::COMPRESS_ZIP | tree::COMPRESS_ACTIVE_MASK | tree::COMPRESS_BLOSC;
    if compression & !known != 0 {
        return Err(Fail::unsupported(format!("byte {at}: compression flags {compression:#x}: unknown bits")));
    }
    let meta = read_meta(src).map_err(|f| f.within("metadata"))?;
    let transform = read_transform(src).map_err(|f| f.within("transform"))?;
    // OpenVDB takes the half flag from the metadata (the type's suffix only seeds it).
    let half = meta.half.unwrap_or(false);
    let name = meta.name.unwrap_or_else(|| d.name.clone());
    let class = meta.class.filter(|c| c != "unknown");
    let _ = d.half_suffix;

    if let Some(parent) = &d.parent {
        let Some(p) = unique_names.get(parent).and_then(|&i| earlier.get(i)) else {
            return Err(Fail::bad(format!(
                "instance of {}, which is not an earlier float or double grid",
                shown(parent)
            )));
        };
        if p.value_type() != value_type {
            return Err(Fail::bad(format!(
                "{:?} instance of the {:?} grid {}",
                value_type,
                p.value_type(),
                shown(parent)
            )));
        }
        let bytes = p.leaf_count() as u64
            * match value_type {
                VdbValueType::Float => tree::leaf_bytes::<f32>(),
                VdbValueType::Double => tree::leaf_bytes::<f64>(),
            }
            + p.tiles.len() as u64 * tree::tile_bytes();
        budget.take(bytes, || format!("the copy of {} this instance shares", shown(parent)))?;
        return Ok(VdbGrid {
            name,
            class,
            saved_as_half: half,
            background: p.background,
            transform,
            leaves: p.leaves.clone(),
            tiles: p.tiles.clone(),
            instance_of: Some(p.name.clone()),
        });
    }

    let at = src.pos();
    let buffers = src.i32("buffer count")?;
    if buffers != 1 {
        return Err(Fail::unsupported(format!("byte {at}: buffer count {buffers} (OpenVDB writes 1)")));
    }
    let storage = Storage { compression, half, offsets };
    let (background, leaves, tiles) = match value_type {
        VdbValueType::Float => tree_parts::<f32>(src, storage, budget)?,
        VdbValueType::Double => tree_parts::<f64>(src, storage, budget)?,
    };
    Ok(VdbGrid { name, class, saved_as_half: half, background, transform, leaves, tiles, instance_of: None })
}

fn tree_parts<T: Value>(src: &mut Src, storage: Storage, budget: &mut Budget) -> Res<(f64, VdbLeaves, Vec<VdbTile>)> {
    let t = tree::read_tree::<T>(src, storage, budget)?;
    Ok((t.background.to_f64(), T::wrap(t.leaves), t.tiles))
}

/// Reads a transform: the map's type name and its parameters.
fn read_transform(src: &mut Src) -> Res<VdbTransform> {
    let at = src.pos();
    let map = src.string(MAX_NAME, "map type")?;
    // OpenVDB's maps act on row vectors: world = [i j k] · diag(scale) + translation, or
    // [i j k 1] · M. `matrix` holds the transpose, acting on column vectors.
    let mut matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let (scale, translation) = match map.as_str() {
        "UniformScaleMap" | "ScaleMap" => {
            let scale = src.vec3("scale")?;
            src.skip(4 * 24, "derived scale vectors")?; // voxel size, inverse, 1/s², 1/2s
            (scale, [0.0; 3])
        }
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let translation = src.vec3("translation")?;
            let scale = src.vec3("scale")?;
            src.skip(4 * 24, "derived scale vectors")?;
            (scale, translation)
        }
        "TranslationMap" => ([1.0; 3], src.vec3("translation")?),
        "AffineMap" | "UnitaryMap" => {
            let mut m = [[0.0; 4]; 4];
            for row in &mut m {
                for v in row.iter_mut() {
                    *v = src.f64("matrix")?;
                }
            }
            if m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0 {
                return Err(Fail::unsupported(format!(
                    "byte {at}: {map} matrix column 4 is {:?}, not [0, 0, 0, 1]: a projective map",
                    [m[0][3], m[1][3], m[2][3], m[3][3]]
                )));
            }
            for (r, row) in m.iter().enumerate() {
                for (c, &v) in row.iter().enumerate() {
                    matrix[c][r] = v;
                }
            }
            check_matrix(&matrix, &map, at)?;
            return Ok(VdbTransform { map, matrix });
        }
        "NonlinearFrustumMap" => {
            return Err(Fail::unsupported(format!(
            "byte {at}: map {map}: frustum transforms are not supported (only linear maps: scale, translation, affine)"
        )))
        }
        _ => {
            return Err(Fail::unsupported(format!(
                "byte {at}: map type {} is not supported (UniformScaleMap, UniformScaleTranslateMap, ScaleMap, \
                 ScaleTranslateMap, TranslationMap, AffineMap, UnitaryMap)",
                shown(&map)
            )))
        }
    };
    for a in 0..3 {
        matrix[a][a] = scale[a];
        matrix[a][3] = translation[a];
    }
    check_matrix(&matrix, &map, at)?;
    Ok(VdbTransform { map, matrix })
}

/// Fails unless the index → world matrix is finite and invertible.
fn check_matrix(m: &[[f64; 4]; 4], map: &str, at: u64) -> Res<()> {
    if m.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Fail::bad(format!("byte {at}: {map}: index → world matrix {m:?} is not finite")));
    }
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if det == 0.0 || !det.is_finite() {
        return Err(Fail::bad(format!("byte {at}: {map}: index → world matrix {m:?} is singular")));
    }
    Ok(())
}

impl VdbGrid {
    /// The value type of the grid's tree.
    pub fn value_type(&self) -> VdbValueType {
        match self.leaves {
            VdbLeaves::Float(_) => VdbValueType::Float,
            VdbLeaves::Double(_) => VdbValueType::Double,
        }
    }

    /// The number of leaves.
    pub fn leaf_count(&self) -> usize {
        match &self.leaves {
            VdbLeaves::Float(l) => l.len(),
            VdbLeaves::Double(l) => l.len(),
        }
    }

    /// The leaves' origins and active bits (for either value type).
    fn leaf_masks(&self) -> Vec<([i32; 3], [u64; 8])> {
        match &self.leaves {
            VdbLeaves::Float(l) => l.iter().map(|l| (l.origin, l.active)).collect(),
            VdbLeaves::Double(l) => l.iter().map(|l| (l.origin, l.active)).collect(),
        }
    }

    /// The number of active points (OpenVDB's active voxel count): active leaf points and the
    /// points of active tiles.
    pub fn active_count(&self) -> u64 {
        let leaves: u64 = self.leaf_masks().iter().flat_map(|(_, m)| m).map(|w| u64::from(w.count_ones())).sum();
        let tiles: u64 = self.tiles.iter().filter(|t| t.active).map(|t| u64::from(t.size).pow(3)).sum();
        leaves + tiles
    }

    /// The smallest and largest active points (inclusive), or `None` when none is active.
    pub fn active_bounds(&self) -> Option<[[i32; 3]; 2]> {
        let mut lo = [i32::MAX; 3];
        let mut hi = [i32::MIN; 3];
        let mut any = false;
        let mut add = |a: [i32; 3], b: [i32; 3]| {
            any = true;
            for k in 0..3 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        };
        for (origin, mask) in self.leaf_masks() {
            for (w, &word) in mask.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    let n = w * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let p = leaf_point(origin, n);
                    add(p, p);
                }
            }
        }
        for t in self.tiles.iter().filter(|t| t.active) {
            // Tiles are aligned to their size, so the last point does not overflow.
            let last = t.origin.map(|c| c.saturating_add_unsigned(t.size - 1));
            add(t.origin, last);
        }
        any.then_some([lo, hi])
    }

    /// A lookup of any point's value (hash maps of the leaves and tiles).
    pub fn lookup(&self) -> VdbLookup<'_> {
        let leaves = self.leaf_masks().iter().enumerate().map(|(n, (o, _))| (*o, n)).collect();
        let tiles = self.tiles.iter().map(|t| ((t.origin, t.size), *t)).collect();
        VdbLookup { grid: self, leaves, tiles }
    }
}

/// The point `n` (OpenVDB's `(x << 6) | (y << 3) | z`) of the leaf at `origin`.
fn leaf_point(origin: [i32; 3], n: usize) -> [i32; 3] {
    let local = [(n >> 6) & 7, (n >> 3) & 7, n & 7];
    [0, 1, 2].map(|a| origin[a] + local[a] as i32)
}

impl<T: Copy> VdbLeaf<T> {
    /// Points per edge.
    pub const DIM: i32 = 8;

    /// The index into `values` and `active` of point `ijk`, or `None` when the leaf does not
    /// hold it.
    pub fn offset(&self, ijk: [i32; 3]) -> Option<usize> {
        let mut n = 0usize;
        for a in 0..3 {
            let d = ijk[a].checked_sub(self.origin[a])?;
            if !(0..Self::DIM).contains(&d) {
                return None;
            }
            n = (n << 3) | d as usize;
        }
        Some(n)
    }

    /// The value of point `ijk`, or `None` when the leaf does not hold it.
    pub fn value_at(&self, ijk: [i32; 3]) -> Option<T> {
        self.offset(ijk).and_then(|n| self.values.get(n).copied())
    }

    /// Whether point `ijk` is held by the leaf and active.
    pub fn is_active(&self, ijk: [i32; 3]) -> bool {
        self.offset(ijk).is_some_and(|n| self.is_active_at(n))
    }

    /// Whether point number `n` (`(x << 6) | (y << 3) | z`) is active.
    pub fn is_active_at(&self, n: usize) -> bool {
        self.active.get(n / 64).is_some_and(|w| w >> (n % 64) & 1 == 1)
    }

    /// The number of active points.
    pub fn active_count(&self) -> u32 {
        self.active.iter().map(|w| w.count_ones()).sum()
    }
}

impl VdbTransform {
    /// The world position of index-space point `ijk` (fractional indices allowed).
    pub fn index_to_world(&self, ijk: [f64; 3]) -> [f64; 3] {
        let m = &self.matrix;
        [0, 1, 2].map(|r| m[r][0] * ijk[0] + m[r][1] * ijk[1] + m[r][2] * ijk[2] + m[r][3])
    }
}

/// Point lookups in a grid: [`VdbGrid::lookup`].
pub struct VdbLookup<'a> {
    grid: &'a VdbGrid,
    leaves: HashMap<[i32; 3], usize>,
    tiles: HashMap<([i32; 3], u32), VdbTile>,
}

impl VdbLookup<'_> {
    /// The value of point `ijk` and whether it is active: from its leaf, else from the tile
    /// covering it, else the background (inactive).
    pub fn value_at(&self, ijk: [i32; 3]) -> (f64, bool) {
        let origin = ijk.map(|c| c & !7);
        if let Some(&n) = self.leaves.get(&origin) {
            let found = match &self.grid.leaves {
                VdbLeaves::Float(l) => l.get(n).and_then(|l| Some((f64::from(l.value_at(ijk)?), l.is_active(ijk)))),
                VdbLeaves::Double(l) => l.get(n).and_then(|l| Some((l.value_at(ijk)?, l.is_active(ijk)))),
            };
            if let Some(found) = found {
                return found;
            }
        }
        for size in [8u32, 128, 4096] {
            let origin = ijk.map(|c| c & !(size as i32 - 1));
            if let Some(t) = self.tiles.get(&(origin, size)) {
                return (t.value, t.active);
            }
        }
        (self.grid.background, false)
    }
}
