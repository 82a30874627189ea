//! The whole pipeline in one call: volume + iso + method → checked [`Mesh`].
//!
//! Runtime choices (sample type, built-in field, method) are matched once here; each arm calls
//! the same generic walk, monomorphised for its volume and extractor.

use crate::error::{Error, Result};
use crate::extract::{Decomposition, MarchingCubes, MarchingCubes33, MarchingTetrahedra, Masked, PointMask};
use crate::grid::{AnyGrid, DenseGrid, Sample};
use crate::mesh::{Mesh, MeshBuilder};
use crate::volume::catalog::Builtin;
use crate::volume::{Field, FieldVisitor, GridVolume, Iso, Sampled, Volume};
use crate::walk::{flying_edges, Progress, SlabWalker, WalkStats, Walker};

/// An extraction algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Method {
    /// Classic marching cubes ([`MarchingCubes`]), parallel Flying Edges on grids.
    #[default]
    MarchingCubes,
    /// Marching cubes 33 ([`MarchingCubes33`]): the topology of the trilinear interpolant.
    MarchingCubes33,
    /// Marching tetrahedra, five per cell ([`MarchingTetrahedra`]).
    Tetrahedra5,
    /// Marching tetrahedra, six per cell around the main diagonal.
    Tetrahedra6,
    /// Marching tetrahedra on the body-centred lattice (cell centres added).
    TetrahedraBcc,
}

impl Method {
    /// Every method, in CLI order.
    pub const ALL: [Method; 5] = [
        Method::MarchingCubes,
        Method::MarchingCubes33,
        Method::Tetrahedra5,
        Method::Tetrahedra6,
        Method::TetrahedraBcc,
    ];

    /// The short CLI name (`mc`, `mc33`, `mt5`, `mt6`, `mt-bcc`).
    pub fn name(self) -> &'static str {
        match self {
            Method::MarchingCubes => "mc",
            Method::MarchingCubes33 => "mc33",
            Method::Tetrahedra5 => "mt5",
            Method::Tetrahedra6 => "mt6",
            Method::TetrahedraBcc => "mt-bcc",
        }
    }

    /// Parses a short CLI name.
    pub fn parse(s: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == s)
    }

    /// The tetrahedral decomposition of an `mt*` method.
    fn decomposition(self) -> Option<Decomposition> {
        match self {
            Method::Tetrahedra5 => Some(Decomposition::Five),
            Method::Tetrahedra6 => Some(Decomposition::Six),
            Method::TetrahedraBcc => Some(Decomposition::BodyCentred),
            Method::MarchingCubes | Method::MarchingCubes33 => None,
        }
    }
}

/// Whether vertices get normals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Normals {
    /// Unit normals from the field gradient (central differences for grids).
    Gradient,
    /// No normals (`Mesh::normals` stays empty): the default, as in the peer benchmarks; viewers
    /// compute normals themselves, and gradient normals cost 30–75 % of a grid extraction.
    #[default]
    None,
}

/// Extraction options.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// The method.
    pub method: Method,
    /// Normals or not.
    pub normals: Normals,
    /// Worker threads for grid extraction; `None` uses rayon's global pool (all cores). The mesh
    /// is identical for every thread count.
    pub threads: Option<usize>,
    /// Only cells whose eight corners are in this mask (any method; runs on the slab walker).
    pub mask: Option<std::sync::Arc<PointMask>>,
}

/// A mesh and what the walk saw.
#[derive(Debug, Clone)]
pub struct Extraction {
    /// The mesh (world coordinates).
    pub mesh: Mesh,
    /// Cell counts.
    pub stats: WalkStats,
}

/// Extracts the surface of `vol` at `iso`.
///
/// # Errors
/// [`Error::InvalidInput`] when `iso` is not finite; [`Error::Limit`] when the mesh outgrows
/// `u32` indices.
pub fn extract<V: Volume>(vol: &V, iso: Iso, opts: &Options) -> Result<Extraction> {
    extract_with_progress(vol, iso, opts, None)
}

/// [`extract`], reporting progress per slab.
///
/// # Errors
/// As [`extract`].
pub fn extract_with_progress<V: Volume>(
    vol: &V,
    iso: Iso,
    opts: &Options,
    progress: Option<&dyn Progress>,
) -> Result<Extraction> {
    if !iso.value.is_finite() {
        return Err(Error::InvalidInput(format!("iso {}: must be a finite number", iso.value)));
    }
    let mut out = MeshBuilder::new(opts.normals == Normals::Gradient);
    let mut walker = SlabWalker::new();
    if let Some(p) = progress {
        walker = walker.with_progress(p);
    }
    if let Some(mask) = &opts.mask {
        if mask.dims() != vol.lattice().dims() {
            return Err(Error::InvalidInput(format!(
                "mask dims {:?} differ from the volume's {:?}",
                mask.dims(),
                vol.lattice().dims()
            )));
        }
    }
    let stats = match (opts.method, opts.method.decomposition(), &opts.mask) {
        (_, Some(decomposition), None) => walker.walk(vol, iso, &mut MarchingTetrahedra { decomposition }, &mut out)?,
        (_, Some(decomposition), Some(m)) => {
            let mut x = Masked { inner: MarchingTetrahedra { decomposition }, mask: m };
            walker.walk(vol, iso, &mut x, &mut out)?
        }
        (Method::MarchingCubes33, _, None) => walker.walk(vol, iso, &mut MarchingCubes33, &mut out)?,
        (Method::MarchingCubes33, _, Some(m)) => {
            walker.walk(vol, iso, &mut Masked { inner: MarchingCubes33, mask: m }, &mut out)?
        }
        (_, _, None) => walker.walk(vol, iso, &mut MarchingCubes, &mut out)?,
        (_, _, Some(m)) => walker.walk(vol, iso, &mut Masked { inner: MarchingCubes, mask: m }, &mut out)?,
    };
    Ok(Extraction { mesh: out.finish()?, stats })
}

/// Extracts from a grid of any sample type (matched once) with the parallel Flying Edges walker
/// ([`flying_edges`]): the same mesh as [`extract`] on a [`GridVolume`] up to vertex numbering,
/// and the same bytes for every thread count.
///
/// # Errors
/// As [`extract`]; [`Error::InvalidInput`] when the thread pool cannot be built.
pub fn extract_grid(grid: &AnyGrid, iso: Iso, opts: &Options, progress: Option<&dyn Progress>) -> Result<Extraction> {
    fn go<S: Sample>(
        g: &DenseGrid<S>,
        iso: Iso,
        opts: &Options,
        progress: Option<&dyn Progress>,
    ) -> Result<Extraction> {
        let normals = opts.normals == Normals::Gradient;
        if opts.method != Method::MarchingCubes || opts.mask.is_some() {
            // The other methods and masks run on the serial slab walker.
            return extract_with_progress(&GridVolume::new(g), iso, opts, progress);
        }
        let (mesh, stats) = flying_edges(g, iso, &MarchingCubes, normals)?;
        Ok(Extraction { mesh, stats })
    }
    if !iso.value.is_finite() {
        return Err(Error::InvalidInput(format!("iso {}: must be a finite number", iso.value)));
    }
    let run = || crate::with_grid!(grid, g => go(g, iso, opts, progress));
    let out = in_pool(opts.threads, run)?;
    if let Some(p) = progress {
        p.advance(1, 1);
    }
    out
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
/// meshed with marching cubes at 0.5 on the label's indicator, padded with one outside layer so
/// every surface is closed even where the label touches the volume's faces. Neighbouring labels
/// get two coincident, independently closed surfaces.
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
        let o = Options { method: opts.method, ..opts.clone() };
        out.push((label, extract_grid(&AnyGrid::U8(indicator), Iso::above(0.5), &o, None)?));
    }
    if let Some(p) = progress {
        p.advance(total, total);
    }
    Ok(out)
}

/// Runs `f` on a pool of `threads` workers (rayon's global pool when `None`).
fn in_pool<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    #[cfg(feature = "parallel")]
    if let Some(n) = threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
            .map_err(|e| Error::InvalidInput(format!("cannot start {n} worker threads: {e}")))?;
        return Ok(pool.install(f));
    }
    let _ = threads;
    Ok(f())
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
            extract_with_progress(
                &Sampled::new(field.clone(), self.b.lattice.clone()),
                self.iso,
                self.opts,
                self.progress,
            )
        }
    }
    b.field.visit(Go { b, iso, opts, progress })
}
