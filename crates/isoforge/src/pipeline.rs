//! The whole pipeline in one call: volume + iso + method → [`Mesh`].
//!
//! The one place where runtime choices become types: the sample type (matched once per grid), the
//! walker (by what the input is: a grid, any volume, a stream), the method and the mask (matched
//! once in [`run`], which calls the same generic walk for every combination).
//!
//! | input | walker | parallel |
//! |---|---|---|
//! | a grid ([`extract_grid`]) | [`FlyingEdgesWalker`] on its samples | yes |
//! | any volume or field ([`extract`], [`extract_builtin`]) | tabulated at the iso, then [`FlyingEdgesWalker`] ([`SlabWalker`] past [`Tabulated::MAX_POINTS`]) | yes (no) |
//! | a stream of slabs ([`extract_streamed`]) | [`FlyingEdgesWalker::stream`] into a [`MeshSink`] | no (I/O bound) |

use std::sync::Arc;

pub mod entry;
pub mod plan;
pub mod request;

pub use entry::{extract_request, prepare, PrepareError, Prepared, Source, Surface};
pub use plan::MemoryPlan;
pub use request::{NoSurface, ParseError, Region, Request, Roi};

use crate::cube::{CellRange, VertexKey};
use crate::error::{Error, Result};
use crate::extract::{
    AdaptiveDualContouring, BodyCentredTetrahedra, Counting, Decomposition, DualContouring, ExtendedMarchingCubes,
    Extractor, MarchingCubes, MarchingCubes33, MarchingTetrahedra, Masked, PointMask, SurfaceNets,
};
use crate::grid::{AnyGrid, AnySparse, DType, DenseGrid, Sample, SparseGrid};
use crate::mesh::post::PostProcess;
use crate::mesh::{KeyRecord, Mesh, MeshBuilder, MeshSink, WriteBehind};
use crate::volume::catalog::Builtin;
use crate::volume::{
    AnySamples, Field, FieldVisitor, GridVolume, Iso, Prefetch, Sampled, SlabSource, SparseVolume, StridedSamples,
    StridedSlabs, Tabulated, Volume,
};
use crate::walk::{
    walk_cells, walk_ranges, FlyingEdgesWalker, FollowStats, Follower, Progress, SlabWalker, StreamStats, WalkStats,
    Walker,
};

pub use crate::extract::Adaptivity;
pub use crate::mesh::Normals;

/// An extraction algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Method {
    /// Classic marching cubes ([`MarchingCubes`]): `vtkFlyingEdges3D`'s triangles.
    MarchingCubes,
    /// Marching cubes 33 ([`MarchingCubes33`]): the topology of the trilinear interpolant. The
    /// default: within 1.3× of classic MC's time on the parallel walker (docs/BENCHMARKS.md §6.1).
    #[default]
    MarchingCubes33,
    /// Marching tetrahedra, five per cell ([`MarchingTetrahedra`]).
    Tetrahedra5,
    /// Marching tetrahedra, six per cell around the main diagonal.
    Tetrahedra6,
    /// Marching tetrahedra on the body-centred lattice (cell centres added: [`BodyCentredTetrahedra`]).
    TetrahedraBcc,
    /// Surface nets ([`SurfaceNets`]): dual, one vertex per cell, quads.
    SurfaceNets,
    /// Dual contouring ([`DualContouring`]): surface nets' connectivity, each vertex fitted to
    /// the Hermite data of its cell (sharp corners and creases); triangles unless `quads`.
    DualContouring {
        /// Keep quads instead of splitting them along their shorter diagonal.
        quads: bool,
        /// One vertex per marching-cubes patch of a cell instead of one per cell
        /// ([`DualContouring::split`]; plain mode only).
        split: bool,
        /// The manifold mode ([`DualContouring::manifold`], the default); `false`: plain \[Ju02\].
        manifold: bool,
        /// Adaptive dual contouring's error bound in cell widths
        /// ([`AdaptiveDualContouring`]: an octree of merged cells); uniform (the default) when 0.
        /// Plain mode only (`manifold` and `split` false): adaptive dc is not manifold.
        adaptivity: Adaptivity,
    },
    /// Extended marching cubes ([`ExtendedMarchingCubes`]): MC33 with a feature vertex where the
    /// normals of a loop spread wider than `feature_angle` (whole degrees), creases flipped to
    /// run between feature vertices.
    ExtendedMarchingCubes {
        /// Degrees ([`ExtendedMarchingCubes::feature_angle`]).
        feature_angle: u8,
    },
}

/// `--method dc`: manifold dual contouring's triangles.
const DC: Method =
    Method::DualContouring { quads: false, split: false, manifold: true, adaptivity: Adaptivity::UNIFORM };
/// `--method emc` with the default feature angle.
const EMC: Method =
    Method::ExtendedMarchingCubes { feature_angle: crate::extract::extended::DEFAULT_FEATURE_ANGLE as u8 };

impl Method {
    /// Every method, in CLI order.
    pub const ALL: [Method; 8] = [
        Method::MarchingCubes,
        Method::MarchingCubes33,
        Method::Tetrahedra5,
        Method::Tetrahedra6,
        Method::TetrahedraBcc,
        Method::SurfaceNets,
        DC,
        EMC,
    ];

    /// The short CLI name (`mc`, `mc33`, `mt5`, `mt6`, `mt-bcc`, `surface-nets`, `dc`, `emc`).
    pub fn name(self) -> &'static str {
        match self {
            Method::MarchingCubes => "mc",
            Method::MarchingCubes33 => "mc33",
            Method::Tetrahedra5 => "mt5",
            Method::Tetrahedra6 => "mt6",
            Method::TetrahedraBcc => "mt-bcc",
            Method::SurfaceNets => "surface-nets",
            Method::DualContouring { .. } => "dc",
            Method::ExtendedMarchingCubes { .. } => "emc",
        }
    }

    /// Whether the mesh is guaranteed edge- and vertex-manifold and consistently oriented (closed
    /// when the surface stays inside the lattice). Every method but surface nets and plain dual
    /// contouring, whose cells holding two sheets give them one shared vertex.
    pub fn is_manifold(self) -> bool {
        !matches!(self, Method::SurfaceNets | Method::DualContouring { manifold: false, .. })
    }

    /// Parses a short CLI name (`dc` gives manifold dual contouring's triangles, `emc` extended
    /// marching cubes at the default feature angle).
    pub fn parse(s: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Whether the method is adaptive dual contouring (a nonzero `adaptivity`): it contours the
    /// whole volume at once, so front ends load the input rather than stream it.
    pub fn is_adaptive(self) -> bool {
        matches!(self, Method::DualContouring { adaptivity, .. } if !adaptivity.is_uniform())
    }

    /// Whether the method's output is counted before it is made ([`Counting::Known`]): the
    /// Flying Edges walker then allocates the mesh exactly once, where uncounted methods (and any
    /// masked one) grow per-slab meshes and stitch them, briefly holding about twice the mesh.
    pub fn counting(self) -> Counting {
        struct Ask;
        impl ExtractorVisitor for Ask {
            type Output = Counting;
            fn visit<X: Extractor + Sync>(self, _: X) -> Counting {
                X::COUNTING
            }
        }
        with_extractor(self, Ask)
    }
}

/// Extraction options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Options {
    /// The method.
    pub method: Method,
    /// Normals or not.
    pub normals: Normals,
    /// Worker threads; `None` uses rayon's global pool (all cores). The mesh is identical for
    /// every thread count.
    pub threads: Option<usize>,
    /// Only cells whose eight corners are in this mask (any method, any walker).
    pub mask: Option<Arc<PointMask>>,
    /// Only these cells (global lattice indices); the whole lattice when `None`.
    pub range: Option<CellRange>,
    /// Which vertices' provenance keys to keep in [`Extraction::keys`] (to stitch ranges).
    pub keys: KeyRecord,
    /// Walk a sparse grid ([`SparseGrid`]) instead of the whole lattice: a field sampled only
    /// where its surface may pass ([`SparseGrid::from_field`]), a grid copied by its blocks near
    /// the surface ([`SparseGrid::from_dense`]; the same mesh). `None`: fields above
    /// [`Tabulated::MAX_POINTS`] points (whose table would not fit) are sampled sparsely, the rest
    /// densely.
    pub sparse: Option<bool>,
    /// A bound on how fast a field's values change (see [`Field::lipschitz`]), replacing the
    /// field's own: sparse sampling skips what the surface cannot reach. A field without either is
    /// sampled at every point (memory still grows with the surface).
    pub lipschitz: Option<f64>,
    /// Surface following on sparse grids ([`extract_following`]): `Some` with no points floods
    /// from seeds in every block that may be crossed (every component), with points from the
    /// cells met marching +x from each (world coordinates). Implies `sparse`.
    pub follow: Option<Vec<[f64; 3]>>,
    /// Level of the multiresolution pyramid to mesh: the lattice coarsened 2^level times (grids:
    /// means of blocks of points, [`downsample_mean`](crate::grid::downsample_mean) and
    /// [`SparseGrid::downsample`]; fields: sampled every 2^level points). 0: the lattice itself.
    pub level: u32,
}

/// A mesh and what the walk saw.
#[derive(Debug, Clone)]
pub struct Extraction {
    /// The mesh (world coordinates).
    pub mesh: Mesh,
    /// Cell counts.
    pub stats: WalkStats,
    /// Provenance of the vertices [`Options::keys`] asked for: `(vertex, key)` in vertex order.
    pub keys: Vec<(u32, VertexKey)>,
}

impl Extraction {
    /// Why there is no surface at `iso` (the iso this extraction was made at): every cell walked
    /// was on one side of it.
    pub fn no_surface(&self, iso: Iso) -> Option<NoSurface> {
        NoSurface::of(&self.stats, iso)
    }
}

/// What to do with a method's extractor: [`with_extractor`] calls `visit` with it.
pub trait ExtractorVisitor {
    /// The result.
    type Output;
    /// Called with the method's extractor.
    fn visit<X: Extractor + Sync>(self, x: X) -> Self::Output;
}

/// The one place a method becomes an extractor: calls `v` with `method`'s extractor.
pub fn with_extractor<Vis: ExtractorVisitor>(method: Method, v: Vis) -> Vis::Output {
    let tetrahedra = |decomposition| MarchingTetrahedra { decomposition };
    match method {
        Method::MarchingCubes => v.visit(MarchingCubes),
        Method::MarchingCubes33 => v.visit(MarchingCubes33),
        Method::Tetrahedra5 => v.visit(tetrahedra(Decomposition::Five)),
        Method::Tetrahedra6 => v.visit(tetrahedra(Decomposition::Six)),
        Method::TetrahedraBcc => v.visit(BodyCentredTetrahedra),
        Method::SurfaceNets => v.visit(SurfaceNets),
        // Adaptive dc is not a per-cell extractor: `adaptive` intercepts it before any walk (and
        // `run` refuses it), so only its uniform form reaches here.
        Method::DualContouring { quads, split, manifold, adaptivity: _ } => {
            v.visit(DualContouring { quads, split, manifold, ..DualContouring::default() })
        }
        Method::ExtendedMarchingCubes { feature_angle } => {
            v.visit(ExtendedMarchingCubes { feature_angle: feature_angle.into(), ..ExtendedMarchingCubes::default() })
        }
    }
}

/// Runs `opts.method` (masked if asked) with `walker`.
///
/// # Errors
/// As the walker's [`Walker::walk`].
pub fn run<V: ?Sized, W: Walker<V>>(
    walker: &mut W,
    vol: &V,
    iso: Iso,
    opts: &Options,
    out: &mut MeshBuilder,
) -> Result<WalkStats> {
    struct Run<'a, V: ?Sized, W> {
        walker: &'a mut W,
        vol: &'a V,
        iso: Iso,
        mask: Option<&'a PointMask>,
        out: &'a mut MeshBuilder,
    }
    impl<V: ?Sized, W: Walker<V>> ExtractorVisitor for Run<'_, V, W> {
        type Output = Result<WalkStats>;
        fn visit<X: Extractor + Sync>(self, x: X) -> Result<WalkStats> {
            match self.mask {
                None => self.walker.walk(self.vol, self.iso, &x, self.out),
                Some(mask) => self.walker.walk(self.vol, self.iso, &Masked { inner: x, mask }, self.out),
            }
        }
    }
    refuse_adaptive(opts.method, "a walk by cells")?;
    let mask = opts.mask.as_deref();
    with_extractor(opts.method, Run { walker, vol, iso, mask, out })
}

fn check(iso: Iso, opts: &Options, dims: [u32; 3]) -> Result<()> {
    if !iso.value.is_finite() {
        return Err(Error::InvalidInput(format!("iso {}: must be a finite number", iso.value)));
    }
    if dims.iter().any(|&d| d < 2) {
        // What `NoSurface` says of a walk whose cells are all on one side, for a walk of none.
        return Err(Error::InvalidInput(format!(
            "iso {} gives no surface: the lattice has no cells ({} x {} x {} points; a surface needs two \
             points on every axis)",
            iso.value, dims[0], dims[1], dims[2]
        )));
    }
    if let Some(mask) = &opts.mask {
        if mask.dims() != dims {
            return Err(Error::InvalidInput(format!("mask dims {:?} differ from the volume's {dims:?}", mask.dims())));
        }
    }
    Ok(())
}

fn builder(opts: &Options) -> MeshBuilder {
    MeshBuilder::new(opts.normals).with_keys(opts.keys)
}

fn finish(out: MeshBuilder, stats: WalkStats) -> Result<Extraction> {
    let (mesh, keys) = out.finish_keyed()?;
    Ok(Extraction { mesh, stats, keys })
}

/// `opts.method`'s adaptive dual contouring when it asks for one (an error bound above 0),
/// checked: plain mode only, and no mask, range or vertex keys (it is not walked by cells).
///
/// # Errors
/// [`Error::InvalidInput`] when the method combines adaptivity with the manifold mode or
/// `split`, or the options with a mask, a range or keys.
fn adaptive(opts: &Options) -> Result<Option<AdaptiveDualContouring>> {
    let Method::DualContouring { quads, split, manifold, adaptivity } = opts.method else { return Ok(None) };
    if adaptivity.is_uniform() {
        return Ok(None);
    }
    let e = adaptivity.cells();
    if manifold || split {
        return Err(Error::InvalidInput(format!(
            "adaptivity {e}: adaptive dual contouring is plain dc (not manifold): use it without the manifold mode \
             or split"
        )));
    }
    if opts.mask.is_some() || opts.range.is_some() || opts.keys != KeyRecord::None {
        return Err(Error::InvalidInput(format!(
            "adaptivity {e}: adaptive dual contouring meshes the whole volume: no mask, range or vertex keys"
        )));
    }
    let dc = DualContouring { quads, split: false, manifold: false, ..DualContouring::default() };
    Ok(Some(AdaptiveDualContouring { dc, adaptivity: e }))
}

/// Adaptive dual contouring of `vol` as an [`Extraction`].
fn contour_adaptive<V: Volume + ?Sized>(
    a: &AdaptiveDualContouring,
    vol: &V,
    iso: Iso,
    opts: &Options,
) -> Result<Extraction> {
    let out = a.contour(vol, iso, opts.normals == Normals::Gradient)?;
    Ok(Extraction { mesh: out.mesh, stats: out.stats, keys: Vec::new() })
}

/// Refuses adaptive dual contouring where the volume is walked by cells (streams, surface
/// following, label surfaces, [`run`]).
fn refuse_adaptive(method: Method, what: &str) -> Result<()> {
    match method {
        Method::DualContouring { adaptivity, .. } if !adaptivity.is_uniform() => Err(Error::InvalidInput(format!(
            "adaptivity {}: adaptive dual contouring needs the whole volume at once, not {what}",
            adaptivity.cells()
        ))),
        _ => Ok(()),
    }
}

/// Extracts the surface of any volume at `iso`: tabulated at the iso and walked in parallel
/// ([`Tabulated`]), or slab by slab in O(nx·ny) memory past [`Tabulated::MAX_POINTS`].
///
/// # Errors
/// [`Error::InvalidInput`] when `iso` is not finite or the mask does not fit; [`Error::Limit`]
/// when the mesh outgrows `u32` indices.
pub fn extract<V: Volume + Sync>(vol: &V, iso: Iso, opts: &Options) -> Result<Extraction> {
    extract_with_progress(vol, iso, opts, None)
}

/// [`extract`], reporting progress per slab.
///
/// # Errors
/// As [`extract`].
pub fn extract_with_progress<V: Volume + Sync>(
    vol: &V,
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    extract_volume(vol, iso, opts, progress)
}

/// [`extract_with_progress`] on a trait object: the walks are compiled once for every volume
/// type (the table is walked as samples; only slabs and crossings ask the volume).
fn extract_volume(
    vol: &(dyn Volume + Sync),
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    check(iso, opts, vol.lattice().dims())?;
    if let Some(a) = adaptive(opts)? {
        // The values and crossings uniform dc would walk: the table's when it fits.
        return if vol.lattice().num_points() <= Tabulated::MAX_POINTS {
            let table = in_pool(opts.threads, || Tabulated::new(vol, iso))??;
            contour_adaptive(&a, &table, Iso::below(0.0), opts)
        } else {
            contour_adaptive(&a, vol, iso, opts)
        };
    }
    in_pool(opts.threads, || {
        let mut out = builder(opts);
        let stats = if vol.lattice().num_points() <= Tabulated::MAX_POINTS {
            let table = Tabulated::new(vol, iso)?;
            run(&mut walker(opts, progress), &table, Iso::below(0.0), opts, &mut out)?
        } else {
            let mut w = SlabWalker::new();
            if let Some(r) = opts.range {
                w = w.with_range(r);
            }
            if let Some(p) = progress {
                w = w.with_progress(p);
            }
            run(&mut w, vol, iso, opts, &mut out)?
        };
        finish(out, stats)
    })?
}

fn walker<'p>(opts: &Options, progress: Option<&'p dyn Progress>) -> FlyingEdgesWalker<'p> {
    let mut w = FlyingEdgesWalker::new();
    if let Some(r) = opts.range {
        w = w.with_range(r);
    }
    if let Some(p) = progress {
        w = w.with_progress(p);
    }
    w
}

/// Extracts from a grid of any sample type (matched once), classified in its own type by the
/// parallel [`FlyingEdgesWalker`]; the same bytes for every thread count.
///
/// # Errors
/// As [`extract`]; [`Error::InvalidInput`] when the thread pool cannot be built.
pub fn extract_grid(grid: &AnyGrid, iso: Iso, opts: &Options, progress: Option<&dyn Progress>) -> Result<Extraction> {
    check(iso, opts, grid.lattice().dims())?;
    in_pool(opts.threads, || crate::with_grid!(grid, g => grid_walk(g, iso, opts, progress)))?
}

/// [`extract_grid`]'s walk of one sample type (on the caller's pool).
fn grid_walk<S: Sample>(
    g: &DenseGrid<S>,
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    if opts.level > 0 {
        let coarse = crate::grid::downsample_mean(g, 1 << opts.level.min(31))?;
        return grid_walk(&coarse, iso, &Options { level: 0, ..opts.clone() }, progress);
    }
    if opts.sparse == Some(true) || opts.follow.is_some() {
        return extract_sparse(&SparseGrid::from_dense(g, iso), iso, opts);
    }
    if let Some(a) = adaptive(opts)? {
        return contour_adaptive(&a, &GridVolume::new(g), iso, opts);
    }
    let mut out = builder(opts);
    let stats = run(&mut walker(opts, progress), &GridVolume::new(g), iso, opts, &mut out)?;
    finish(out, stats)
}

/// [`extract_grid`] on samples the caller owns (x fastest: a C-ordered `(nz, ny, nx)` array) on
/// `lattice`, walked where they are ([`GridVolume::borrowed`]): the same mesh as a grid holding a
/// copy of them. A pyramid level or sparse walk builds its own grid from them.
///
/// # Errors
/// As [`extract_grid`]; [`Error::InvalidInput`] when there are not as many samples as points.
pub fn extract_samples<S: Sample>(
    lattice: &crate::grid::Lattice,
    samples: &[S],
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    let vol = GridVolume::borrowed(lattice.clone(), samples)?;
    check(iso, opts, lattice.dims())?;
    if opts.level > 0 || opts.sparse == Some(true) || opts.follow.is_some() {
        let grid = DenseGrid::new(lattice.clone(), samples.to_vec())?;
        return in_pool(opts.threads, || grid_walk(&grid, iso, opts, progress))?;
    }
    in_pool(opts.threads, || {
        if let Some(a) = adaptive(opts)? {
            return contour_adaptive(&a, &vol, iso, opts);
        }
        let mut out = builder(opts);
        let stats = run(&mut walker(opts, progress), &vol, iso, opts, &mut out)?;
        finish(out, stats)
    })?
}

/// [`extract_samples`] on samples in any layout ([`StridedSamples`]: a numpy array in Fortran
/// order, a view with steps or reversed axes): walked in place when packed x fastest, else
/// streamed slab by slab from where they are ([`extract_streamed`]: each slab gathered when the
/// walk needs it, a few at a time), never copied whole — the same mesh as a grid holding a copy.
/// A mask, a range, vertex keys, a pyramid level, a sparse or adaptive walk or surface following
/// need the whole grid: for those the samples are copied into one first.
///
/// # Errors
/// As [`extract_grid`].
pub fn extract_strided<S: Sample>(
    samples: &StridedSamples<'_, S>,
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    let lattice = samples.lattice();
    if let Some(packed) = samples.contiguous() {
        return extract_samples(lattice, packed, iso, opts, progress);
    }
    check(iso, opts, lattice.dims())?;
    let whole_grid = opts.mask.is_some()
        || opts.range.is_some()
        || opts.keys != KeyRecord::None
        || opts.level > 0
        || opts.sparse == Some(true)
        || opts.follow.is_some()
        || adaptive(opts)?.is_some();
    if whole_grid {
        let grid = samples.to_grid()?;
        return in_pool(opts.threads, || grid_walk(&grid, iso, opts, progress))?;
    }
    /// The streamed mesh, kept whole.
    struct Keep(Mesh);
    impl MeshSink for Keep {
        fn push(&mut self, b: crate::mesh::MeshBatch<'_>) -> std::result::Result<(), crate::mesh::ExternalError> {
            self.0.positions.extend_from_slice(b.positions);
            self.0.normals.extend_from_slice(b.normals);
            self.0.triangles.extend_from_slice(b.triangles);
            self.0.quads.extend_from_slice(b.quads);
            Ok(())
        }
    }
    let mut keep = Keep(Mesh::default());
    let stats = extract_streamed(&mut samples.slabs(), iso, opts, &mut keep, progress)?;
    Ok(Extraction { mesh: keep.0, stats: stats.walk, keys: Vec::new() })
}

/// [`extract_strided`] on samples of any type (matched once).
///
/// # Errors
/// As [`extract_strided`].
pub fn extract_any_strided(
    samples: &AnySamples<'_>,
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    crate::with_samples!(samples, s => extract_strided(s, iso, opts, progress))
}

impl<S: Sample> AnySlabSource for StridedSlabs<'_, S> {
    fn dtype(&self) -> DType {
        S::DTYPE
    }
}

/// [`extract_sparse`] on a sparse grid of either sample type (as read from a file).
///
/// # Errors
/// As [`extract_sparse`].
pub fn extract_any_sparse(grid: &AnySparse, iso: Iso, opts: &Options) -> Result<Extraction> {
    match grid {
        AnySparse::F32(g) => extract_sparse(g, iso, opts),
        AnySparse::F64(g) => extract_sparse(g, iso, opts),
    }
}

/// Extracts from a sparse grid ([`SparseGrid`]): the cell ranges its leaves make active
/// ([`SparseGrid::active_ranges`]) walked in parallel on windows of their samples and stitched by
/// vertex key ([`walk_ranges`]). The mesh has the vertices and polygons of the same samples stored
/// densely and walked by [`extract_grid`], numbered by range instead of by row; the memory is the
/// grid's and the mesh's.
///
/// # Errors
/// As [`extract`]; [`Error::InvalidInput`] with a mask or a range (not supported on sparse grids).
pub fn extract_sparse<S: Sample>(grid: &SparseGrid<S>, iso: Iso, opts: &Options) -> Result<Extraction> {
    if opts.level > 0 {
        let mut coarse = grid.downsample()?;
        for _ in 1..opts.level {
            coarse = coarse.downsample()?;
        }
        return extract_sparse(&coarse, iso, &Options { level: 0, ..opts.clone() });
    }
    if let Some(points) = &opts.follow {
        let seeds = if points.is_empty() { Seeds::Tree } else { Seeds::Points(points) };
        return in_pool(opts.threads, || extract_following(grid, iso, opts, seeds).map(|(e, _)| e))?;
    }
    check(iso, opts, grid.lattice().dims())?;
    if opts.mask.is_some() || opts.range.is_some() {
        return Err(Error::InvalidInput("a sparse grid is walked by its active blocks: no mask or range".into()));
    }
    if let Some(a) = adaptive(opts)? {
        return contour_adaptive(&a, &SparseVolume::new(grid), iso, opts);
    }
    struct Go<'a, S> {
        grid: &'a SparseGrid<S>,
        iso: Iso,
        opts: &'a Options,
    }
    impl<S: Sample> ExtractorVisitor for Go<'_, S> {
        type Output = Result<Extraction>;
        fn visit<X: Extractor + Sync>(self, x: X) -> Result<Extraction> {
            let ranges = self.grid.active_ranges(self.iso, x.visits_uniform_cells());
            let (m, stats) = walk_ranges(self.grid, &ranges, self.iso, &x, self.opts.normals, self.opts.keys)?;
            Ok(Extraction { mesh: m.mesh, stats, keys: m.keys })
        }
    }
    in_pool(opts.threads, || with_extractor(opts.method, Go { grid, iso, opts }))?
}

/// Where surface following starts ([`extract_following`]).
#[derive(Debug, Clone, Copy)]
pub enum Seeds<'a> {
    /// Every component: seeds found in the blocks the grid's bounds say may be crossed.
    Tree,
    /// The components met marching along +x from each of these world points (points inside
    /// the objects wanted).
    Points(&'a [[f64; 3]]),
}

/// Surface following on a sparse grid: the cells the surface crosses, flooded from `seeds`
/// ([`Follower`]), walked one by one. With [`Seeds::Tree`] the mesh has the polygons and vertices
/// of [`extract_sparse`] (numbered in cell order); with points, only the components met. Returns
/// what the flood visited: every crossed cell of those components once, and the cells examined
/// to find seeds.
///
/// # Errors
/// As [`extract`]; [`Error::InvalidInput`] for `mt-bcc` (it meshes cells whose corners agree, which
/// a flood over crossed cells never reaches), a mask or a range.
pub fn extract_following<S: Sample>(
    grid: &SparseGrid<S>,
    iso: Iso,
    opts: &Options,
    seeds: Seeds<'_>,
) -> Result<(Extraction, FollowStats)> {
    check(iso, opts, grid.lattice().dims())?;
    refuse_adaptive(opts.method, "surface following")?;
    if opts.mask.is_some() || opts.range.is_some() {
        return Err(Error::InvalidInput("surface following floods from seeds: no mask or range".into()));
    }
    if opts.method == Method::TetrahedraBcc {
        return Err(Error::InvalidInput(
            "surface following visits the cells the surface crosses; mt-bcc also meshes cells whose corners agree: \
             walk the whole grid instead"
                .into(),
        ));
    }
    let vol = SparseVolume::new(grid);
    let mut follower = Follower::new(&vol, iso);
    match seeds {
        Seeds::Tree => follower.flood_ranges(&grid.active_ranges(iso, false)),
        Seeds::Points(points) => points.iter().for_each(|&p| follower.flood_from_point(p)),
    }
    let (cells, stats) = follower.finish();
    if cells.is_empty() {
        return Err(Error::InvalidInput(match seeds {
            Seeds::Tree => format!("no surface at iso {}: no cell of the grid is crossed", iso.value),
            Seeds::Points(_) => {
                format!("no surface at iso {}: marching +x from the seeds met no cell the surface crosses", iso.value)
            }
        }));
    }
    struct Go<'a, S> {
        vol: SparseVolume<'a, S>,
        iso: Iso,
        cells: &'a [[u32; 3]],
        out: MeshBuilder,
    }
    impl<S: Sample> ExtractorVisitor for Go<'_, S> {
        type Output = Result<Extraction>;
        fn visit<X: Extractor + Sync>(mut self, x: X) -> Result<Extraction> {
            let stats = walk_cells(&self.vol, self.iso, &x, self.cells, &mut self.out)?;
            finish(self.out, stats)
        }
    }
    let e = with_extractor(opts.method, Go { vol, iso, cells: &cells, out: builder(opts) })?;
    Ok((e, stats))
}

/// A source of slabs in whichever sample type its file stores (a volume reader).
pub trait AnySlabSource:
    SlabSource<u8>
    + SlabSource<i8>
    + SlabSource<u16>
    + SlabSource<i16>
    + SlabSource<u32>
    + SlabSource<i32>
    + SlabSource<f32>
    + SlabSource<f64>
{
    /// The stored sample type (the one `read_slab` is called with).
    fn dtype(&self) -> DType;
}

/// Slabs a streamed extraction reads ahead in a background thread ([`Prefetch`]).
pub const PREFETCH_SLABS: usize = 4;

/// Batches of a streamed mesh copied and waiting for the sink's thread (see [`extract_streamed`]).
pub const WRITE_BEHIND_BATCHES: usize = 4;

/// Extracts a volume that arrives slab by slab (larger than memory), handing the mesh to `sink`
/// as it is produced, in O(nx·ny) memory. Every method; no mask or range.
///
/// Unless [`Options::threads`] is `Some(1)` (or the machine has one core), the slabs are read
/// (decoded) [`PREFETCH_SLABS`] ahead by a background thread ([`Prefetch`]) and the batches are
/// written behind by another ([`WriteBehind`], [`WRITE_BEHIND_BATCHES`] in flight) while the
/// walker works on the current slab; the mesh, and the order `sink` receives it in, are the same
/// either way.
///
/// # Errors
/// As [`extract`]; [`Error::External`] from the source or the sink.
pub fn extract_streamed(
    src: &mut (dyn AnySlabSource + Send),
    iso: Iso,
    opts: &Options,
    sink: &mut (dyn MeshSink + Send),
    progress: Option<&dyn Progress>,
) -> Result<StreamStats> {
    let dims = SlabSource::<u8>::lattice(src).dims();
    check(iso, opts, dims)?;
    refuse_adaptive(opts.method, "a streamed walk")?;
    if opts.mask.is_some() || opts.range.is_some() {
        return Err(Error::InvalidInput("streamed extraction walks the whole volume: no mask or range".into()));
    }
    /// A streamed walk with the method's extractor (no mask: never a masked copy of the walk).
    struct Streamed<'a, 'p, S> {
        src: &'a mut dyn SlabSource<S>,
        sink: &'a mut dyn MeshSink,
        walker: FlyingEdgesWalker<'p>,
        iso: Iso,
        normals: Normals,
    }
    impl<S: Sample> ExtractorVisitor for Streamed<'_, '_, S> {
        type Output = Result<StreamStats>;
        fn visit<X: Extractor + Sync>(self, x: X) -> Result<StreamStats> {
            self.walker.stream(self.src, self.iso, &x, self.normals, self.sink)
        }
    }
    fn go<S: Sample + Send>(
        src: &mut (dyn SlabSource<S> + Send),
        iso: Iso,
        opts: &Options,
        sink: &mut (dyn MeshSink + Send),
        progress: Option<&dyn Progress>,
    ) -> Result<StreamStats> {
        let walk = |src: &mut dyn SlabSource<S>, sink: &mut dyn MeshSink| {
            let w = Streamed { src, sink, walker: walker(opts, progress), iso, normals: opts.normals };
            with_extractor(opts.method, w)
        };
        let cores = || std::thread::available_parallelism().map_or(1, |n| n.get());
        if opts.threads.unwrap_or_else(cores) >= 2 {
            std::thread::scope(|s| {
                let mut behind = WriteBehind::spawn(s, sink, WRITE_BEHIND_BATCHES);
                let stats = walk(&mut Prefetch::spawn(s, src, PREFETCH_SLABS), &mut behind)?;
                behind.finish().map_err(Error::External)?;
                Ok(stats)
            })
        } else {
            walk(src, sink)
        }
    }
    crate::with_dtype!(src.dtype(), S => go::<S>(src, iso, opts, sink, progress))
}

/// Which labels of a label volume to mesh.
#[derive(Debug, Clone, PartialEq)]
pub enum Labels {
    /// Every value present except 0 (the background).
    All,
    /// These values.
    These(Vec<f64>),
}

/// The labels present in `grid` (every distinct value but 0), ascending.
pub fn labels_present(grid: &AnyGrid) -> Vec<f64> {
    let mut v: Vec<f64> = grid.values_f64().filter(|&x| x != 0.0).collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// One closed surface per label of a label volume: the boundary of the points equal to the label,
/// meshed at 0.5 on the label's indicator, padded with one outside layer so every surface is
/// closed even where the label touches the volume's faces. Neighbouring labels get two
/// coincident, independently closed surfaces.
///
/// # Errors
/// [`Error::InvalidInput`] when a label does not occur or more than 4096 labels are asked for; as
/// [`extract_grid`] otherwise.
pub fn extract_labels(grid: &AnyGrid, labels: &Labels, opts: &Options) -> Result<Vec<(f64, Extraction)>> {
    extract_labels_with_progress(grid, labels, opts, None)
}

/// [`extract_labels`], reporting `advance(i, n)` before label `i` of `n` and `advance(n, n)` at
/// the end.
///
/// # Errors
/// As [`extract_labels`].
pub fn extract_labels_with_progress(
    grid: &AnyGrid,
    labels: &Labels,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Vec<(f64, Extraction)>> {
    const MAX_LABELS: usize = 4096;
    let present = labels_present(grid);
    let wanted = match labels {
        Labels::All => present.clone(),
        Labels::These(v) => v.clone(),
    };
    for &l in wanted.iter().chain(&present) {
        check_label(l)?;
    }
    if wanted.len() > MAX_LABELS {
        return Err(Error::InvalidInput(format!("{} labels: at most {MAX_LABELS} surfaces in one run", wanted.len())));
    }
    if let Some(l) = wanted.iter().find(|l| !present.contains(l)) {
        return Err(Error::InvalidInput(format!("label {l} does not occur in the volume")));
    }
    let mut out = Vec::with_capacity(wanted.len());
    let total = wanted.len() as u64;
    for (i, &label) in wanted.iter().enumerate() {
        if let Some(p) = progress {
            p.advance(i as u64, total);
        }
        let lattice = grid.lattice().clone();
        let data: Vec<u8> = grid.values_f64().map(|v| u8::from(v == label)).collect();
        let indicator = DenseGrid::new(lattice, data)?.pad(1, 0)?;
        out.push((label, extract_grid(&AnyGrid::U8(indicator), Iso::above(0.5), opts, None)?));
    }
    if let Some(p) = progress {
        p.advance(total, total);
    }
    Ok(out)
}

/// Label values are whole numbers that fit the `i32` of a mesh file's triangle labels: 1.5 and
/// 1.7 would be meshed as two surfaces and written as one label 1.
///
/// # Errors
/// [`Error::InvalidInput`] naming the value (`label value 1.5 is not an integer`).
pub fn check_label(l: f64) -> Result<()> {
    if l.fract() != 0.0 || !l.is_finite() {
        return Err(Error::InvalidInput(format!(
            "label value {l} is not an integer (a label volume holds whole numbers; for an intensity volume use --iso)"
        )));
    }
    if l < i32::MIN as f64 || l > i32::MAX as f64 {
        return Err(Error::InvalidInput(format!("label value {l} does not fit a 32-bit label")));
    }
    Ok(())
}

/// The post-processing of label surfaces: `post` with smoothing constrained to move no vertex
/// farther than half the smallest spacing of `lattice` (the issue's "half a voxel"), so that
/// neighbouring labels' surfaces, coincident before, stay close where they meet.
pub fn label_post(post: &PostProcess, lattice: &crate::grid::Lattice) -> PostProcess {
    let h = lattice.spacing().into_iter().fold(f64::INFINITY, f64::min);
    post.constrained(0.5 * h)
}

/// Smooths and decimates `mesh` as `post` asks ([`PostProcess::apply`]) on a pool of `threads`
/// workers (rayon's global pool when `None`), as extractions run.
///
/// # Errors
/// As [`PostProcess::apply`].
pub fn post_process(
    mesh: &mut Mesh,
    post: &PostProcess,
    threads: Option<usize>,
) -> Result<crate::mesh::post::PostStats> {
    in_pool(threads, || post.apply(mesh))?
}

/// Label surfaces as one triangle mesh: the surfaces' vertices and triangles one after the
/// other (quads of dual methods split), and each triangle's label (label values converted to
/// `i32`, rounding toward zero, as label formats store them).
pub fn merge_labels(surfaces: &[(f64, Extraction)]) -> (Mesh, Vec<i32>) {
    let mut mesh = Mesh::default();
    let mut tags = Vec::new();
    for (label, e) in surfaces {
        let split;
        let m = if e.mesh.quads.is_empty() {
            &e.mesh
        } else {
            let mut t = e.mesh.clone();
            t.triangulate();
            split = t;
            &split
        };
        let base = mesh.positions.len() as u32;
        mesh.positions.extend_from_slice(&m.positions);
        mesh.normals.extend_from_slice(&m.normals);
        mesh.triangles.extend(m.triangles.iter().map(|t| t.map(|v| v + base)));
        tags.extend(std::iter::repeat_n(*label as i32, m.triangles.len()));
    }
    (mesh, tags)
}

/// Runs `f` on a pool of `threads` workers (rayon's global pool when `None`). Pools are built
/// once per thread count and kept for the process (a viewer or a warm loop re-extracts often;
/// starting threads each time cost more than small extractions).
fn in_pool<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    #[cfg(feature = "parallel")]
    if let Some(n) = threads {
        return Ok(pool(n.max(1))?.install(f));
    }
    let _ = threads;
    Ok(f())
}

/// The process's pool of `n` workers, built on first use.
#[cfg(feature = "parallel")]
fn pool(n: usize) -> Result<std::sync::Arc<rayon::ThreadPool>> {
    use std::sync::{Arc, Mutex, PoisonError};
    static POOLS: Mutex<Vec<(usize, Arc<rayon::ThreadPool>)>> = Mutex::new(Vec::new());
    let mut pools = POOLS.lock().unwrap_or_else(PoisonError::into_inner);
    if let Some((_, p)) = pools.iter().find(|(m, _)| *m == n) {
        return Ok(Arc::clone(p));
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map_err(|e| Error::InvalidInput(format!("cannot start {n} worker threads: {e}")))?;
    let p = Arc::new(p);
    pools.push((n, Arc::clone(&p)));
    Ok(p)
}

/// Extracts a built-in field on its lattice (matched once).
///
/// # Errors
/// As [`extract`].
pub fn extract_builtin(b: &Builtin, iso: Iso, opts: &Options, progress: Option<&dyn Progress>) -> Result<Extraction> {
    struct Go<'a> {
        b: &'a Builtin,
        iso: Iso,
        opts: &'a Options,
        progress: Option<&'a dyn Progress>,
    }
    impl FieldVisitor for Go<'_> {
        type Output = Result<Extraction>;
        fn visit<F: Field + Clone + Sync>(self, field: &F) -> Self::Output {
            let lipschitz = self.opts.lipschitz.or_else(|| field.lipschitz());
            let lattice = coarsened(&self.b.lattice, self.opts.level)?;
            let opts = &Options { level: 0, ..self.opts.clone() };
            let sampled = Sampled::new(field.clone(), lattice);
            let large = sampled.lattice().num_points() > Tabulated::MAX_POINTS;
            if opts.sparse.unwrap_or(large) || opts.follow.is_some() {
                let grid = in_pool(opts.threads, || SparseGrid::from_field(&sampled, self.iso, lipschitz))??;
                return extract_sparse(&grid, self.iso, opts);
            }
            extract_with_progress(&sampled, self.iso, opts, self.progress)
        }
    }
    b.field.visit(Go { b, iso, opts, progress })
}

/// `lattice` sampled every 2^level points: the same origin and direction, spacing 2^level times
/// larger, the points that fit.
///
/// # Errors
/// [`Error::InvalidInput`] when an axis would keep fewer than 2 points.
fn coarsened(lattice: &crate::grid::Lattice, level: u32) -> Result<crate::grid::Lattice> {
    if level == 0 {
        return Ok(lattice.clone());
    }
    let step = 1u64 << level.min(31);
    let dims = lattice.dims().map(|n| ((n as u64 - 1) / step + 1) as u32);
    if dims.iter().any(|&n| n < 2) {
        return Err(Error::InvalidInput(format!(
            "level {level}: a lattice of {:?} points keeps {dims:?} points, fewer than 2 on an axis",
            lattice.dims()
        )));
    }
    crate::grid::Lattice::with_geometry(dims, lattice.spacing().map(|s| s * step as f64), lattice.origin())?
        .with_direction(lattice.direction())
        .map(|l| l.with_space(lattice.space()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Lattice;

    /// Zero copy (issue 48): samples walked where the caller keeps them give the bytes of a grid
    /// holding a copy, for every method, integer and float samples, with a level and sparsely.
    #[test]
    fn issue_48_borrowed_samples_mesh_as_their_copy() {
        let l = Lattice::with_geometry([9, 7, 6], [0.5, 1.0, 2.0], [1.0, -2.0, 0.0]).unwrap();
        let value = |p: [u32; 3]| {
            let d = [p[0] as f64 - 4.0, p[1] as f64 - 3.2, p[2] as f64 - 2.6];
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        };
        let floats = DenseGrid::from_fn(l.clone(), |p| value(p) as f32);
        let ints = DenseGrid::from_fn(l.clone(), |p| value(p).round() as u16);
        for method in Method::ALL {
            for opts in [
                Options { method, ..Options::default() },
                Options { method, level: 1, ..Options::default() },
                Options { method, sparse: Some(true), ..Options::default() },
            ] {
                let iso = Iso::below(6.5);
                let want = extract_grid(&AnyGrid::from(floats.clone()), iso, &opts, None).unwrap().mesh;
                let got = extract_samples(&l, floats.data(), iso, &opts, None).unwrap().mesh;
                assert_eq!(got, want, "{} level {} sparse {:?}", method.name(), opts.level, opts.sparse);
                let want = extract_grid(&AnyGrid::from(ints.clone()), iso, &opts, None).unwrap().mesh;
                let got = extract_samples(&l, ints.data(), iso, &opts, None).unwrap().mesh;
                assert_eq!(got, want, "u16 {}", method.name());
                assert!(got.num_triangles() + got.num_quads() > 0, "{}", method.name());
            }
        }
        let e = extract_samples(&l, &floats.data()[1..], Iso::below(6.5), &Options::default(), None).unwrap_err();
        assert_eq!(e.to_string(), "377 samples for a lattice of [9, 7, 6] points");
    }

    /// The counted methods are the ones the Flying Edges walker allocates exactly for: the
    /// table-driven and value-counted ones; the body-centred tetrahedra and surface nets name
    /// segments or neighbours' vertices.
    #[test]
    fn counting_is_that_of_the_methods_extractor() {
        let counted: Vec<Method> = Method::ALL.into_iter().filter(|m| m.counting() == Counting::Known).collect();
        assert_eq!(counted, [Method::MarchingCubes, Method::MarchingCubes33, Method::Tetrahedra5, Method::Tetrahedra6]);
        assert_eq!(Method::SurfaceNets.counting(), SurfaceNets::COUNTING);
    }

    /// Two labels side by side in a 6×4×4 volume: one closed surface each, merged into one mesh
    /// whose triangles carry their label, with indices offset past the earlier surfaces.
    #[test]
    fn label_surfaces_merge_with_their_tags() {
        let g: AnyGrid =
            DenseGrid::from_fn(Lattice::new([6, 4, 4]).unwrap(), |p| if p[0] < 3 { 3u8 } else { 7 }).into();
        for method in [Method::MarchingCubes, Method::SurfaceNets] {
            let opts = Options { method, ..Options::default() };
            let surfaces = extract_labels(&g, &Labels::All, &opts).unwrap();
            assert_eq!(surfaces.iter().map(|s| s.0).collect::<Vec<_>>(), [3.0, 7.0]);
            let (mesh, tags) = merge_labels(&surfaces);
            assert!(mesh.quads.is_empty());
            assert_eq!(tags.len(), mesh.triangles.len());
            let first = {
                let mut m = surfaces[0].1.mesh.clone();
                m.triangulate();
                m
            };
            let n0 = first.triangles.len();
            assert!(n0 > 0 && tags[..n0].iter().all(|&t| t == 3) && tags[n0..].iter().all(|&t| t == 7));
            assert_eq!(mesh.triangles[..n0], first.triangles[..]);
            let base = first.positions.len() as u32;
            assert!(mesh.triangles[n0..].iter().flatten().all(|&v| v >= base));
            assert_eq!(mesh.positions.len(), base as usize + surfaces[1].1.mesh.positions.len());
            for (l, e) in &surfaces {
                assert!(crate::topo::check(&e.mesh).is_closed(), "label {l}");
            }
        }
        assert!(extract_labels(&g, &Labels::These(vec![5.0]), &Options::default()).is_err());
    }

    /// Issue 49: label values that are not whole numbers are refused, naming the value (1.5 and
    /// 1.7 were meshed apart and written as one label 1).
    #[test]
    fn issue_49_non_integer_labels_are_refused() {
        let g: AnyGrid = DenseGrid::from_fn(Lattice::new([6, 4, 4]).unwrap(), |p| match p[0] {
            0 | 1 => 0.0f32,
            2 | 3 => 1.5,
            _ => 1.7,
        })
        .into();
        for labels in [Labels::All, Labels::These(vec![1.5])] {
            let e = extract_labels(&g, &labels, &Options::default()).unwrap_err().to_string();
            assert!(e.contains("label value 1.5 is not an integer"), "{e}");
        }
        assert!(check_label(3e9).unwrap_err().to_string().contains("does not fit"));
        assert!(check_label(-7.0).is_ok());
    }

    /// Label surfaces are smoothed within half the smallest spacing.
    #[test]
    fn label_smoothing_is_constrained_to_half_a_spacing() {
        use crate::mesh::smooth::{SmoothOptions, Smoother};
        let l = Lattice::with_geometry([4, 4, 4], [0.5, 2.0, 1.0], [0.0; 3]).unwrap();
        let post = PostProcess { smooth: Some(SmoothOptions::new(Smoother::Taubin)), decimate: None };
        assert_eq!(label_post(&post, &l).smooth.unwrap().max_displacement, Some(0.25));
        let tight = PostProcess { smooth: Some(SmoothOptions::new(Smoother::Taubin).constrained(0.1)), decimate: None };
        assert_eq!(label_post(&tight, &l).smooth.unwrap().max_displacement, Some(0.1));
        assert!(label_post(&PostProcess::default(), &l).is_identity());
    }

    /// `Options.threads` is honoured: the extraction runs on a pool of that many workers.
    #[cfg(feature = "parallel")]
    #[test]
    fn threads_option_sizes_the_pool() {
        assert_eq!(in_pool(Some(3), rayon::current_num_threads).unwrap(), 3);
        assert_eq!(in_pool(Some(1), rayon::current_num_threads).unwrap(), 1);
        assert_eq!(in_pool(None, rayon::current_num_threads).unwrap(), rayon::current_num_threads());
    }
}
