//! The one entry point: a [`Request`] and a [`Source`] → meshes, or a stream into a sink.
//!
//! ```text
//! Request + Source ─prepare (isos, value range, ROI, mask, --close, frame, memory plan)─▶ Prepared
//!     Prepared ─extract (per iso)─▶ Extraction ─no_surface, post_process─▶ Surface   (extract_request)
//!     Prepared ─stream (per iso)─▶ MeshSink                                          (slab by slab)
//! ```
//!
//! Front ends (the CLI, the viewer, Python) open files and translate arguments into these two,
//! then print; the preparation's decisions are made here once.

use std::borrow::Cow;
use std::fmt;

use super::plan::{MemoryPlan, Refusal};
use super::request::{check_isos_in_range, outside_value, NoSurface, Request};
use super::{
    extract_any_sparse, extract_any_strided, extract_builtin, extract_grid, extract_labels_with_progress,
    extract_streamed, label_post, post_process, AnySlabSource, Extraction, Options,
};
use crate::error::{Error, Result};
use crate::grid::{AnyGrid, AnySparse, Lattice, Sample};
use crate::mesh::post::PostStats;
use crate::mesh::MeshSink;
use crate::volume::catalog::Builtin;
use crate::volume::{AnySamples, Iso, SlabSource};
use crate::walk::{Progress, StreamStats};

/// What is meshed: a grid, a built-in field, a sparse grid (borrowed or owned), or a volume that
/// arrives slab by slab (a reader of a file larger than memory).
pub enum Source<'a> {
    /// A dense grid of any sample type.
    Grid(Cow<'a, AnyGrid>),
    /// A built-in field on its lattice.
    Field(Cow<'a, Builtin>),
    /// A sparse grid (an OpenVDB file's).
    Sparse(Cow<'a, AnySparse>),
    /// Slabs in the file's sample type, z by z.
    Stream(Box<dyn AnySlabSource + Send + 'a>),
    /// Samples the caller owns, in any layout (a numpy array): walked where they are
    /// ([`extract_any_strided`]); copied into a grid only for a region, a mask or labels.
    Samples(AnySamples<'a>),
}

impl Source<'_> {
    /// What the source is, for messages ("a field").
    pub fn kind(&self) -> &'static str {
        match self {
            Source::Grid(_) => "a dense grid",
            Source::Field(_) => "a field",
            Source::Sparse(_) => "a sparse grid",
            Source::Stream(_) => "a stream of slabs",
            Source::Samples(_) => "borrowed samples",
        }
    }
}

/// Which step of [`prepare`] refused the request, with the library's reason. Front ends add the
/// input's name (and their flag names) to it.
#[derive(Debug)]
pub enum PrepareError {
    /// The dense grid has no samples.
    Empty,
    /// An iso lies outside the value range ([`check_isos_in_range`]).
    Isos(Error),
    /// The ROI does not fit the lattice ([`Roi::point_box`](super::Roi::point_box)).
    Roi(Error),
    /// The mask does not fit the input ([`Region::mask`](super::request::Region::mask)).
    Mask(Error),
    /// Cropping, padding or re-placing failed ([`Region::apply`](super::request::Region::apply)).
    Region(Error),
    /// The memory plan refuses.
    Budget(Refusal),
    /// A region or a mask on a source they do not apply to (fields, sparse grids, streams).
    Unsupported {
        /// `"a region"` or `"a mask"`.
        what: &'static str,
        /// [`Source::kind`].
        source: &'static str,
    },
}

impl fmt::Display for PrepareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PrepareError::Empty => write!(f, "the volume has no samples"),
            PrepareError::Isos(e) | PrepareError::Region(e) => write!(f, "{e}"),
            PrepareError::Roi(e) => write!(f, "roi: {e}"),
            PrepareError::Mask(e) => write!(f, "mask: {e}"),
            PrepareError::Budget(r) => write!(f, "{r}"),
            PrepareError::Unsupported { what, source } => {
                write!(f, "{what} applies to dense grids in memory, not to {source}")
            }
        }
    }
}

impl std::error::Error for PrepareError {}

impl From<PrepareError> for Error {
    fn from(e: PrepareError) -> Error {
        match e {
            PrepareError::Isos(e) | PrepareError::Roi(e) | PrepareError::Mask(e) | PrepareError::Region(e)
                if matches!(e, Error::Limit { .. }) =>
            {
                e
            }
            e => Error::InvalidInput(e.to_string()),
        }
    }
}

/// A request made ready for a source: the isos to extract, the source cut and placed, the
/// options with the mask.
pub struct Prepared<'a> {
    /// The source after the region (ROI, `close`, index space, frame).
    pub source: Source<'a>,
    /// The isos (the request's, or the source's default: a field's own, else below 0).
    pub isos: Vec<Iso>,
    /// The request's options, with the mask on the region's lattice.
    pub options: Options,
    /// A dense grid's lattice before the region (to map vertices back to the input's voxels).
    pub input_lattice: Option<Lattice>,
}

/// Makes `request` ready for `source`: the isos (the source's default when none is asked), each
/// checked against a dense or sparse grid's value range; a dense grid's ROI checked, then the
/// `mask` volume (non-zero: in the mask, on the input's lattice) cut like the grid, then the grid
/// cropped, padded outside every iso (`close`) and re-placed; with `plan`, the memory a field or
/// a sparse grid can need checked against it.
///
/// # Errors
/// The step that refused ([`PrepareError`]); regions and masks apply to dense grids only.
pub fn prepare<'a, V>(
    request: &Request<V>,
    source: Source<'a>,
    mask: Option<&AnyGrid>,
    plan: Option<&MemoryPlan>,
) -> Result<Prepared<'a>, PrepareError> {
    let default = match &source {
        Source::Field(b) => b.iso,
        _ => Iso::below(0.0),
    };
    let isos = request.isos_or(default);
    let region = &request.region;
    let unsupported = |what, s: &Source<'_>| PrepareError::Unsupported { what, source: s.kind() };
    let mut options = request.options.clone();
    let mut input_lattice = None;
    let source = match source {
        // A region or a mask cuts a grid: the samples are copied into one.
        Source::Samples(s) if !region.is_identity() || mask.is_some() => {
            let grid = s.to_grid().map_err(PrepareError::Region)?;
            return prepare(request, Source::Grid(Cow::Owned(grid)), mask, plan);
        }
        Source::Samples(s) => {
            let range = s.value_range().ok_or(PrepareError::Empty)?;
            check_isos_in_range(&isos, range.min, range.max).map_err(PrepareError::Isos)?;
            input_lattice = Some(s.lattice().clone());
            Source::Samples(s)
        }
        Source::Grid(g) => {
            let range = g.value_range().ok_or(PrepareError::Empty)?;
            check_isos_in_range(&isos, range.min, range.max).map_err(PrepareError::Isos)?;
            if let Some(roi) = &region.roi {
                roi.point_box(g.lattice()).map_err(PrepareError::Roi)?;
            }
            if let Some(m) = mask {
                let m = region.mask(m, g.lattice().dims()).map_err(PrepareError::Mask)?;
                options.mask = Some(std::sync::Arc::new(m));
            }
            input_lattice = Some(g.lattice().clone());
            // Padding outside every iso: the range's end on the outside side (ties are outside).
            let outside = outside_value(isos[0].inside, range.min, range.max);
            Source::Grid(region.apply_to(g, outside).map_err(PrepareError::Region)?)
        }
        s if !region.is_identity() => return Err(unsupported("a region", &s)),
        s if mask.is_some() => return Err(unsupported("a mask", &s)),
        Source::Sparse(s) => {
            if let Some(range) = s.value_range() {
                check_isos_in_range(&isos, range.min, range.max).map_err(PrepareError::Isos)?;
            }
            if let Some(p) = plan {
                p.sparse_isos(&s, &isos).map_err(PrepareError::Budget)?;
            }
            Source::Sparse(s)
        }
        Source::Field(b) => {
            if let Some(p) = plan {
                p.field(&b.lattice).map_err(PrepareError::Budget)?;
            }
            Source::Field(b)
        }
        s @ Source::Stream(_) => s,
    };
    Ok(Prepared { source, isos, options, input_lattice })
}

/// A label volume made ready for [`extract_labels_with_progress`]: the ROI checked, the grid cut
/// and placed by the request's region without `close` (each label surface is closed by its own
/// padding).
///
/// # Errors
/// [`PrepareError::Roi`] or [`PrepareError::Region`].
pub fn prepare_labels<'a, V>(request: &Request<V>, grid: Cow<'a, AnyGrid>) -> Result<Cow<'a, AnyGrid>, PrepareError> {
    if let Some(roi) = &request.region.roi {
        roi.point_box(grid.lattice()).map_err(PrepareError::Roi)?;
    }
    request.region.for_labels().apply_to(grid, 0.0).map_err(PrepareError::Region)
}

impl Prepared<'_> {
    /// One in-memory extraction at `iso` (the library call for the source's kind).
    ///
    /// # Errors
    /// As [`extract_grid`], [`extract_builtin`], [`extract_any_sparse`]; [`Error::InvalidInput`]
    /// for a stream (use [`Prepared::stream`]).
    pub fn extract(&self, iso: Iso, progress: Option<&dyn Progress>) -> Result<Extraction> {
        match &self.source {
            Source::Grid(g) => extract_grid(g, iso, &self.options, progress),
            Source::Field(b) => extract_builtin(b, iso, &self.options, progress),
            Source::Sparse(s) => extract_any_sparse(s, iso, &self.options),
            Source::Samples(s) => extract_any_strided(s, iso, &self.options, progress),
            Source::Stream(_) => Err(Error::InvalidInput("a stream of slabs is meshed by streaming it".into())),
        }
    }

    /// Streams the source's slabs at `iso` into `sink` ([`extract_streamed`]). A stream is read
    /// once: a second iso needs a new source.
    ///
    /// # Errors
    /// As [`extract_streamed`]; [`Error::InvalidInput`] when the source is in memory.
    pub fn stream(
        &mut self,
        iso: Iso,
        sink: &mut (dyn MeshSink + Send),
        progress: Option<&dyn Progress>,
    ) -> Result<StreamStats> {
        match &mut self.source {
            Source::Stream(src) => extract_streamed(src.as_mut(), iso, &self.options, sink, progress),
            s => Err(Error::InvalidInput(format!("{} is meshed in memory, not streamed", s.kind()))),
        }
    }
}

/// The value range of a streamed volume, read slab by slab (`None` when it has no values): for
/// the message when a streamed iso gives no surface.
///
/// # Errors
/// [`Error::External`] from the source.
pub fn stream_value_range(src: &mut dyn AnySlabSource) -> Result<Option<(f64, f64)>> {
    fn go<S: Sample>(src: &mut dyn SlabSource<S>) -> Result<Option<(f64, f64)>> {
        let [nx, ny, nz] = src.lattice().dims();
        let mut slab = vec![S::from_f64(0.0); nx as usize * ny as usize];
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for _ in 0..nz {
            src.read_slab(&mut slab).map_err(Error::External)?;
            for v in &slab {
                let v = v.to_f64();
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        Ok((lo <= hi).then_some((lo, hi)))
    }
    crate::with_dtype!(src.dtype(), S => go::<S>(src))
}

/// One surface of [`extract_request`].
#[derive(Debug, Clone)]
pub struct Surface {
    /// The iso, or the label (label surfaces are `Iso::below` the label's value).
    pub iso: Iso,
    /// The mesh after post-processing, and what the walk saw.
    pub extraction: Extraction,
    /// What smoothing and decimation did.
    pub post: PostStats,
}

/// The whole request on an in-memory source in one call: [`prepare`], then each iso extracted
/// ([`Prepared::extract`]), refused when it gives no surface ([`NoSurface`]) and post-processed;
/// with `request.labels`, one surface per label of the (dense) label volume, post-processed
/// within half a spacing ([`label_post`]).
///
/// # Errors
/// [`prepare`]'s refusals (as [`Error::InvalidInput`], or [`Error::Limit`]); the walk's;
/// [`Error::InvalidInput`] with the [`NoSurface`] sentence; a stream (use [`Prepared::stream`]).
pub fn extract_request<V>(
    request: &Request<V>,
    source: Source<'_>,
    mask: Option<&AnyGrid>,
    progress: Option<&dyn Progress>,
) -> Result<Vec<Surface>> {
    let threads = request.options.threads;
    if let Some(labels) = &request.labels {
        let g = match source {
            Source::Grid(g) => g,
            Source::Samples(s) => Cow::Owned(s.to_grid()?),
            s => return Err(Error::InvalidInput(format!("labels need a dense label volume, not {}", s.kind()))),
        };
        let g = prepare_labels(request, g)?;
        let post = label_post(&request.post, g.lattice());
        let surfaces = extract_labels_with_progress(&g, labels, &request.options, progress)?;
        return surfaces
            .into_iter()
            .map(|(label, mut extraction)| {
                let post = post_process(&mut extraction.mesh, &post, threads)?;
                Ok(Surface { iso: Iso::below(label), extraction, post })
            })
            .collect();
    }
    let prepared = prepare(request, source, mask, None)?;
    let mut out = Vec::with_capacity(prepared.isos.len());
    for &iso in &prepared.isos {
        let mut extraction = prepared.extract(iso, progress)?;
        if let Some(none) = NoSurface::of(&extraction.stats, iso) {
            return Err(Error::InvalidInput(none.to_string()));
        }
        let post = post_process(&mut extraction.mesh, &request.post, threads)?;
        out.push(Surface { iso, extraction, post });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::DenseGrid;
    use crate::mesh::MeshBatch;
    use crate::pipeline::{request::Roi, Method};

    /// A ball of radius 3 on a 10³ lattice (distances from the centre minus 3).
    fn ball() -> AnyGrid {
        let l = Lattice::new([10, 10, 10]).unwrap();
        AnyGrid::F32(DenseGrid::from_fn(l, |p| {
            let d = p.map(|x| x as f32 - 4.5);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - 3.0
        }))
    }

    fn request(isos: &[f64]) -> Request {
        Request { isos: isos.to_vec(), ..Request::default() }
    }

    #[test]
    fn a_grid_and_a_request_give_extract_grids_meshes() {
        let g = ball();
        for method in ["mc", "mc33", "dc"].map(|m| m.parse::<Method>().unwrap()) {
            let mut r = request(&[0.0, 1.0]);
            r.options.method = method;
            let surfaces = extract_request(&r, Source::Grid(Cow::Borrowed(&g)), None, None).unwrap();
            assert_eq!(surfaces.len(), 2);
            for s in &surfaces {
                let direct = extract_grid(&g, s.iso, &r.options, None).unwrap();
                assert_eq!(s.extraction.mesh, direct.mesh, "{} at {}", method.name(), s.iso.value);
                assert!(s.extraction.mesh.num_triangles() + s.extraction.mesh.num_quads() > 0);
            }
        }
    }

    #[test]
    fn an_identity_region_borrows_and_a_roi_crops() {
        let g = ball();
        let p = prepare(&request(&[0.0]), Source::Grid(Cow::Borrowed(&g)), None, None).unwrap();
        assert!(matches!(p.source, Source::Grid(Cow::Borrowed(_))));
        let mut r = request(&[0.0]);
        r.region.roi = Some(Roi::parse_index("0:5,0:10,0:10").unwrap());
        r.region.close = true;
        let p = prepare(&r, Source::Grid(Cow::Borrowed(&g)), None, None).unwrap();
        let Source::Grid(cut) = &p.source else { panic!("a grid") };
        // The region's points plus a border of one outside point; the input lattice is kept.
        assert_eq!(cut.lattice().dims(), [7, 12, 12]);
        assert_eq!(p.input_lattice.as_ref().map(Lattice::dims), Some([10, 10, 10]));
        // The same samples as the owned path, padded with the range's end (outside below).
        assert!(*cut.as_ref() == r.region.apply(g.clone(), g.value_range().unwrap().max).unwrap());
    }

    #[test]
    fn refusals_name_their_step() {
        let g = ball();
        let e = prepare(&request(&[99.0]), Source::Grid(Cow::Borrowed(&g)), None, None).err().unwrap();
        assert!(matches!(e, PrepareError::Isos(_)), "{e}");
        assert!(e.to_string().starts_with("iso 99 is outside the value range ["), "{e}");
        let mut r = request(&[0.0]);
        r.region.roi = Some(Roi::parse_index("0:20,0:10,0:10").unwrap());
        let e = prepare(&r, Source::Grid(Cow::Borrowed(&g)), None, None).err().unwrap();
        assert!(matches!(e, PrepareError::Roi(_)), "{e}");
        let small = AnyGrid::F32(DenseGrid::from_fn(Lattice::new([4, 4, 4]).unwrap(), |_| 1.0));
        let e = prepare(&request(&[0.0]), Source::Grid(Cow::Borrowed(&g)), Some(&small), None).err().unwrap();
        assert_eq!(e.to_string(), "mask: dims [4, 4, 4] differ from the input's [10, 10, 10]");
        let field = crate::volume::catalog::parse("sphere").unwrap();
        let e = prepare(&r, Source::Field(Cow::Owned(field)), None, None).err().unwrap();
        assert_eq!(e.to_string(), "a region applies to dense grids in memory, not to a field");
        // No surface is one sentence, from every front end.
        let least = g.value_range().unwrap().min;
        let e = extract_request(&request(&[least]), Source::Grid(Cow::Borrowed(&g)), None, None).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("iso {least} gives no surface: every lattice point is outside (inside is below iso)")
        );
    }

    #[test]
    fn a_budget_too_small_for_a_field_is_refused_as_the_plan_says() {
        let field = crate::volume::catalog::parse("sphere").unwrap();
        let plan = MemoryPlan::new(1 << 20, &Options::default(), false, false);
        let want = plan.field(&field.lattice).unwrap_err();
        let e = prepare(&request(&[]), Source::Field(Cow::Borrowed(&field)), None, Some(&plan)).err().unwrap();
        assert!(matches!(e, PrepareError::Budget(r) if r == want), "{e}");
        let roomy = MemoryPlan { bytes: u64::MAX, ..plan };
        let p = prepare(&request(&[]), Source::Field(Cow::Borrowed(&field)), None, Some(&roomy)).unwrap();
        assert_eq!(p.isos, vec![field.iso]);
    }

    #[test]
    fn borrowed_samples_in_any_layout_give_the_grid_s_surfaces() {
        use crate::volume::StridedSamples;
        let AnyGrid::F32(g) = ball() else { unreachable!() };
        // The ball's samples in Fortran order (z fastest).
        let [nx, ny, nz] = g.lattice().dims().map(|d| d as usize);
        let mut fortran = vec![0f32; nx * ny * nz];
        for (lin, &v) in g.data().iter().enumerate() {
            let [x, y, z] = g.lattice().ijk(lin).map(|c| c as usize);
            fortran[(x * ny + y) * nz + z] = v;
        }
        let strides = [(ny * nz) as isize, nz as isize, 1];
        let samples = StridedSamples::new(g.lattice().clone(), &fortran, 0, strides).unwrap();
        let grid = AnyGrid::F32(g.clone());
        let mut r = request(&[0.0, 1.0]);
        r.options.method = Method::MarchingCubes33;
        let of = |src: Source<'_>, r: &Request| extract_request(r, src, None, None).unwrap();
        let want = of(Source::Grid(Cow::Borrowed(&grid)), &r);
        let got = of(Source::Samples(AnySamples::F32(samples.clone())), &r);
        assert_eq!(got.len(), 2);
        for (a, b) in got.iter().zip(&want) {
            assert_eq!(a.extraction.mesh, b.extraction.mesh);
        }
        // The value range is checked as a grid's.
        let far = request(&[9.0]);
        let e = extract_request(&far, Source::Samples(AnySamples::F32(samples.clone())), None, None).unwrap_err();
        let e2 = extract_request(&far, Source::Grid(Cow::Borrowed(&grid)), None, None).unwrap_err();
        assert_eq!(e.to_string(), e2.to_string());
        // A region copies the samples into a grid first: the same surfaces.
        r.region.roi = Some(Roi::Index([(Some(1), Some(9)); 3]));
        let want = of(Source::Grid(Cow::Borrowed(&grid)), &r);
        let got = of(Source::Samples(AnySamples::F32(samples)), &r);
        assert_eq!(got[0].extraction.mesh, want[0].extraction.mesh);
        assert!(want[0].extraction.mesh.num_triangles() > 0);
    }

    /// Slabs of a grid, z by z (a file reader's part in the CLI).
    struct Slabs {
        grid: DenseGrid<f32>,
        z: usize,
    }

    impl<S: Sample> SlabSource<S> for Slabs {
        fn lattice(&self) -> &Lattice {
            self.grid.lattice()
        }
        fn read_slab(&mut self, out: &mut [S]) -> Result<(), crate::mesh::ExternalError> {
            let n = out.len();
            for (o, v) in out.iter_mut().zip(&self.grid.data()[self.z * n..(self.z + 1) * n]) {
                *o = S::from_f64(f64::from(*v));
            }
            self.z += 1;
            Ok(())
        }
    }

    impl AnySlabSource for Slabs {
        fn dtype(&self) -> crate::grid::DType {
            crate::grid::DType::F32
        }
    }

    /// A sink keeping the streamed mesh.
    #[derive(Default)]
    struct Gather(crate::mesh::Mesh);

    impl MeshSink for Gather {
        fn push(&mut self, b: MeshBatch<'_>) -> Result<(), crate::mesh::ExternalError> {
            // Vertices are numbered over all batches.
            self.0.positions.extend_from_slice(b.positions);
            self.0.triangles.extend_from_slice(b.triangles);
            Ok(())
        }
    }

    #[test]
    fn a_streamed_source_gives_the_in_memory_mesh() {
        let AnyGrid::F32(g) = ball() else { unreachable!() };
        let mut r = request(&[0.5]);
        r.options.threads = Some(1);
        let src = Slabs { grid: g.clone(), z: 0 };
        let mut p = prepare(&r, Source::Stream(Box::new(src)), None, None).unwrap();
        let mut sink = Gather::default();
        let stats = p.stream(Iso::below(0.5), &mut sink, None).unwrap();
        let direct = extract_grid(&AnyGrid::F32(g.clone()), Iso::below(0.5), &r.options, None).unwrap().mesh;
        assert_eq!(stats.triangles, direct.num_triangles() as u64);
        assert_eq!(sink.0.positions, direct.positions);
        assert_eq!(sink.0.triangles, direct.triangles);
        let range = g.value_range().unwrap();
        let mut again = Slabs { grid: g, z: 0 };
        assert_eq!(stream_value_range(&mut again).unwrap(), Some((range.min, range.max)));
    }
}
