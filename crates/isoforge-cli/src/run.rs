//! The commands, on validated configuration.

use std::path::Path;
use std::time::Instant;

use anyhow::{anyhow, bail, Context, Result};
use std::borrow::Cow;

use isoforge::grid::{AnyGrid, AnySparse, DType, Histogram, SparseGrid, IDENTITY};
use isoforge::mesh::post::PostProcess;
use isoforge::mesh::{ExternalError, MeshBatch, MeshSink, Normals};
use isoforge::pipeline::plan::{Fit, MemoryPlan, Refusal, Size};
use isoforge::pipeline::{self, Extraction, PrepareError, Prepared, Source as Input};
use isoforge::topo::{self, CheckOptions, Guarantee, MeshReport, StreamCheck};
use isoforge::volume::catalog::{self, Builtin};
use isoforge::volume::Iso;
use isoforge_io::write::contour::ContourFrame;
use isoforge_io::write::MeshStream;
use isoforge_io::{Limits, MeshFormat, VolumeReader};
use serde_json::json;

use isoforge::pipeline::request::{self, Attribute, AttributeSource, NoSurface};

use crate::config::{
    CheckConfig, ContourConfig, ConvertConfig, DemoConfig, ExtractConfig, InputConfig, Placement, RenderConfig,
    SimplifyConfig, Source, ViewConfig,
};
use crate::progress::{spin, Task};
use crate::report;

/// What the process exits with when the command itself succeeded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Everything asked for holds.
    Success,
    /// A requested guarantee failed (exit 1).
    CheckFailed,
}

/// A loaded input.
pub enum Loaded {
    Grid(AnyGrid),
    Field(Builtin),
    /// A sparse grid (an OpenVDB file).
    Sparse(Box<isoforge_io::SparseFile>),
    /// A volume to mesh slab by slab (it does not fit the memory budget).
    Stream(VolumeReader),
}

pub fn load(input: &InputConfig) -> Result<Loaded> {
    open_input(input, None, false)
}

/// Opens the input; with a memory budget, a volume whose in-memory extraction could exceed it
/// stays a stream; with `prefer_stream` (see [`streams_by_default`]) every volume that can
/// stream does.
fn open_input(input: &InputConfig, budget: Option<&MemoryPlan>, prefer_stream: bool) -> Result<Loaded> {
    let (path, raw) = match &input.source {
        Source::Field(f) => {
            if let Some(b) = budget {
                // Fields do not stream: the table of values and the mesh must fit.
                b.field(&f.lattice).map_err(|r| refused("the field", b, r))?;
            }
            return Ok(Loaded::Field(f.clone()));
        }
        Source::File { path, raw } => (path, raw),
    };
    let name = path.display();
    if raw.is_none() && isoforge_io::VolumeFormat::from_path(path) == Some(isoforge_io::VolumeFormat::Vdb) {
        return Ok(Loaded::Sparse(Box::new(read_sparse_within(path, &input.limits, budget)?)));
    }
    // A reader that streams opens by its header; one that decodes the file whole (images, DICOM,
    // VTI) stops at the budget instead of reading past it.
    let whole = raw.is_none() && !streams(path);
    let open_limits = match budget {
        Some(b) if whole => Limits::new(input.limits.max_bytes.min(b.bytes)),
        Some(_) => Limits::new(u64::MAX),
        None => input.limits,
    };
    let reader = open_reader(path, raw.as_ref(), &open_limits).map_err(|e| match budget {
        Some(b) if whole && b.bytes < input.limits.max_bytes && is_limit(&e) => anyhow!(
            "{name}: images, DICOM series and VTI files are read whole, and its samples need more than --max-memory {}",
            Size(b.bytes)
        ),
        _ => e,
    })?;
    if let Some(b) = budget {
        let fit = b.volume(reader.lattice(), reader.volume_bytes(), reader.dtype().size() as u64, streams(path));
        if fit.map_err(|r| refused(&name.to_string(), b, r))? == Fit::Stream {
            return Ok(Loaded::Stream(reader));
        }
    }
    if prefer_stream && reader.streams() && streams(path) && !input.placement.is_set() {
        return Ok(Loaded::Stream(reader));
    }
    let task = Task::start(format!("reading {name}"));
    let grid = reader.read_grid_with_progress(&input.limits, Some(&task))?;
    task.finish();
    Ok(Loaded::Grid(place(grid, &input.placement)?))
}

/// Reads the sparse (VDB) file `path`. Sparse files are read whole, so with a budget the reading
/// stops at it ([`MemoryPlan::sparse`] checks the mesh once the isos are known).
fn read_sparse_within(path: &Path, limits: &Limits, budget: Option<&MemoryPlan>) -> Result<isoforge_io::SparseFile> {
    let name = path.display();
    let within = match budget {
        Some(b) if b.bytes < limits.max_bytes => Limits::new(b.bytes),
        _ => *limits,
    };
    spin(format!("reading {name}"), || isoforge_io::read_sparse(path, None, &within)).map_err(|e| match budget {
        Some(b) if matches!(e, isoforge_io::Error::Limit { .. }) && b.bytes < limits.max_bytes => {
            anyhow!("{name}: sparse files are read whole, and its grid needs more than --max-memory {}", Size(b.bytes))
        }
        _ => e.into(),
    })
}

/// Whether `e` is a reader's refusal of a size over its limits.
fn is_limit(e: &anyhow::Error) -> bool {
    matches!(e.downcast_ref::<isoforge_io::Error>(), Some(isoforge_io::Error::Limit { .. }))
}

/// The memory plan's refusal of `name` (on `l`) in the CLI's words.
fn refused(name: &str, b: &MemoryPlan, r: Refusal) -> anyhow::Error {
    let (budget, method) = (Size(b.bytes), b.method.name());
    match r {
        Refusal::SparseField { points } => anyhow!(
            "--max-memory: a field sampled sparsely ({points} points) uses memory that follows its \
             surface, which is not known before sampling; drop --max-memory"
        ),
        Refusal::Field { need, points } => anyhow!(
            "--max-memory {budget}: meshing the field in memory can need {} (its {points} values \
             and the largest mesh --method {method} could make), and fields do not stream",
            Size(need)
        ),
        Refusal::ReadWhole { need } => anyhow!(
            "{name}: images, DICOM series and VTI files are read whole; with the largest mesh \
             --method {method} could make they need {}, more than --max-memory {budget}",
            Size(need)
        ),
        Refusal::Stream { least, slab: [nx, ny] } => anyhow!(
            "{name}: --max-memory {budget}: streaming it slab by slab holds at least {} (nine slabs \
             of {nx}×{ny} samples and the files' buffers, before any mesh)",
            Size(least)
        ),
        Refusal::Sparse { need } => anyhow!(
            "{name}: sparse files are meshed in memory, and with the largest mesh --method {method} could \
             make in the cells the surface may cross it can need {}, more than --max-memory {budget}",
            Size(need)
        ),
    }
}

/// Opens the volume file `path` (raw with `raw`'s layout); opening decodes images, DICOM series
/// and VTI files whole, other readers parse a header.
fn open_reader(path: &Path, raw: Option<&isoforge_io::RawSpec>, limits: &Limits) -> Result<VolumeReader> {
    Ok(spin(format!("opening {}", path.display()), || match raw {
        Some(spec) => isoforge_io::read::raw::open_raw(path, spec, limits),
        None => isoforge_io::open_volume(path, limits),
    })?)
}

/// Whether the reader of `path` can deliver slabs one by one (see ARCHITECTURE.md, Readers):
/// not folders (DICOM, slices), PNG, TIFF or VTI, which are decoded whole.
fn streams(path: &Path) -> bool {
    use isoforge_io::VolumeFormat as F;
    !path.is_dir() && !matches!(F::from_path(path), Some(F::Png | F::Tiff | F::Vti))
}

/// Whether `extract` streams a volume file that can stream (decode, walk and write overlapping, in
/// O(nx·ny) memory) without `--max-memory`: when the streamed file is byte for byte the
/// in-memory one, i.e. one iso into PLY, STL, OBJ, OFF or glTF with nothing that needs the whole grid or mesh
/// (ROI, labels, mask, attributes, colours, `--require`'s full report) and no benchmarking flags
/// (`--repeat`, `--time-json`: their seconds are the extraction's alone). Quads are written as
/// quads on both paths.
fn streams_by_default(c: &ExtractConfig) -> bool {
    let r = &c.request;
    MeshStream::streams(c.format)
        && r.isos.len() == 1
        && c.repeat == 1
        && c.time_json.is_none()
        && r.region.is_identity()
        && r.labels.is_none()
        && needs_memory(c).is_empty()
        && c.require.is_empty()
}

/// The flags given that sample or colour the whole mesh, which a streamed extraction cannot honour.
fn needs_memory(c: &ExtractConfig) -> Vec<&'static str> {
    let r = &c.request;
    [
        (c.mask.is_some(), "--mask"),
        (!r.attributes.is_empty(), "--attribute"),
        (r.color.is_some(), "--color-by"),
        (c.color_volume.is_some(), "--color-volume"),
        (r.options.sparse == Some(true), "--sparse"),
        (r.options.follow.is_some(), "--follow"),
        (r.options.level > 0, "--level"),
        (r.options.method.is_adaptive(), "--adaptivity"),
        (r.post.smooth.is_some(), "--smooth"),
        (r.post.decimate.as_ref().is_some_and(|d| d.reduction.is_some()), "--decimate"),
        (r.post.decimate.as_ref().is_some_and(|d| d.max_error.is_some()), "--max-error"),
    ]
    .into_iter()
    .filter_map(|(given, flag)| given.then_some(flag))
    .collect()
}

/// "N triangles", and ", M quads" when the mesh has quads.
fn polygon_counts(mesh: &isoforge::mesh::Mesh) -> String {
    match mesh.num_quads() {
        0 => format!("{} triangles", mesh.num_triangles()),
        q => format!("{} triangles, {q} quads", mesh.num_triangles()),
    }
}

/// The value range of the volume at `path`, read slab by slab (for the message when a streamed
/// iso gives no surface).
fn streamed_range(input: &InputConfig) -> Option<(f64, f64)> {
    let Loaded::Stream(mut r) = open_input(input, None, true).ok()? else { return None };
    pipeline::entry::stream_value_range(&mut r).ok()?
}

/// `--spacing` / `--origin` for images: the same samples on a placed lattice.
fn place(grid: AnyGrid, p: &Placement) -> Result<AnyGrid> {
    Ok(grid.placed(p.spacing, p.origin)?)
}

fn input_name(input: &InputConfig) -> String {
    match &input.source {
        Source::File { path, .. } => path.display().to_string(),
        Source::Field(_) => "the field".to_string(),
    }
}

fn failed(report: &MeshReport, require: &[Guarantee]) -> Vec<&'static str> {
    require.iter().filter(|g| !report.holds(**g)).map(|g| g.name()).collect()
}

/// The streamed mesh goes to the file's writer and, with `--require`, to the streaming checker,
/// whose memory (4 bytes per vertex and a window) must stay within `--max-memory`.
struct Tee<'a, 'b> {
    out: &'a mut MeshStream<'b>,
    check: Option<&'a mut StreamCheck>,
    budget: u64,
}

impl MeshSink for Tee<'_, '_> {
    fn push(&mut self, batch: MeshBatch<'_>) -> Result<(), ExternalError> {
        MeshSink::push(self.out, batch)?;
        if let Some(c) = self.check.as_deref_mut() {
            // Quads are checked as two triangles each: the same edges on the surface, the same
            // components, Euler characteristic and genus.
            let mut triangles = batch.triangles.to_vec();
            triangles.extend(batch.quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]));
            c.push(batch.positions, &triangles)?;
            if c.held_bytes() > self.budget {
                return Err(format!(
                    "--require: checking the mesh needs more than --max-memory {} bytes (4 per vertex); \
                     drop --require and run `isoforge check` on the file",
                    self.budget
                )
                .into());
            }
        }
        Ok(())
    }
}

/// Out-of-core extraction of every iso in `isos`: slab by slab from the file straight into mesh
/// files that stream (one per iso; the file is read once per iso), each checked in the same pass
/// when `--require` asks. The files appear together once every iso succeeded.
fn extract_streaming(
    c: &ExtractConfig,
    mut prepared: Prepared,
    name: &str,
    batch: isoforge_io::Batch,
) -> Result<Outcome> {
    let isos = std::mem::take(&mut prepared.isos);
    if crate::outputs::one_file_for_all_isos(c, isos.len()) {
        bail!(
            "{}: several isos in one {} file need their meshes in memory (drop --max-memory, or write .ply, .stl or .off: a file per iso)",
            c.output.display(),
            c.format.name()
        );
    }
    let mut reports = Vec::new();
    for (i, &iso) in isos.iter().enumerate() {
        if i > 0 {
            // A stream is read once: each further iso reads the file again.
            let Source::File { path, raw } = &c.input.source else { bail!("internal: a streamed field") };
            prepared.source = Input::Stream(Box::new(open_reader(path, raw.as_ref(), &Limits::new(u64::MAX))?));
        }
        reports.push(stream_one(c, &mut prepared, iso, isos.len(), name, &batch)?);
    }
    batch.commit()?;
    let mut outcome = Outcome::Success;
    for (line, check) in reports {
        eprintln!("{line}");
        if let Some((output, rep)) = check {
            print!("{}", report::mesh_text(&rep));
            if verdict(&output, &rep, &c.require) != Outcome::Success {
                outcome = Outcome::CheckFailed;
            }
        }
    }
    Ok(outcome)
}

/// One iso of [`extract_streaming`] into its file (and `--time-json`) in `batch`: the summary
/// line, and the check report with the file's path when `--require` asks.
fn stream_one(
    c: &ExtractConfig,
    prepared: &mut Prepared,
    iso: Iso,
    count: usize,
    name: &str,
    batch: &isoforge_io::Batch,
) -> Result<(String, Option<(std::path::PathBuf, MeshReport)>)> {
    let (output, time_json) = crate::outputs::extract_paths(c, iso.value, count);
    let normals = c.request.options.normals == Normals::Gradient;
    let Some(mut out) = MeshStream::create_in(batch, &output, c.format, normals)? else {
        bail!("{}: out-of-core extraction (--max-memory) writes PLY, STL, OBJ, OFF or glTF only", output.display());
    };
    if c.require.contains(&Guarantee::NoSelfIntersections) {
        bail!(
            "{}: --require no-self-intersections needs the whole mesh in memory: drop --max-memory, or run \
             `isoforge check --self-intersections` on the file",
            output.display()
        );
    }
    let mut check = (!c.require.is_empty()).then(|| StreamCheck::new(&CheckOptions::default()));
    let mut sink = Tee { out: &mut out, check: check.as_mut(), budget: c.max_memory.unwrap_or(u64::MAX) };
    let task = Task::start(format!("meshing iso {} of {name} slab by slab", iso.value));
    let start = Instant::now();
    let stats = prepared.stream(iso, &mut sink, Some(&task))?;
    let seconds = start.elapsed().as_secs_f64();
    task.finish();
    if let Some(none) = NoSurface::of(&stats.walk, iso) {
        // The in-memory path's message when the iso is outside the values (a second pass, on failure only).
        if let Some((lo, hi)) = streamed_range(&c.input) {
            request::check_isos_in_range(&[iso], lo, hi)
                .map_err(|e| anyhow!("{name}: {e} (see `isoforge info {name}`)"))?;
        }
        bail!("{name}: {none}");
    }
    out.finish()?;
    if let Some(t) = &time_json {
        let body = json!({
            "seconds": seconds,
            "vertices": stats.vertices,
            "triangles": stats.triangles,
            "quads": stats.quads,
            "streamed": true
        });
        batch.write(t, |w| w.write_all(body.to_string().as_bytes()))?;
    }
    let quads = if stats.quads > 0 { format!(", {} quads", stats.quads) } else { String::new() };
    let line = format!(
        "{}: {} vertices, {} triangles{quads} ({}, streamed slab by slab, iso {}, reading + extraction + writing {:.3} s)",
        output.display(),
        stats.vertices,
        stats.triangles,
        c.request.options.method.name(),
        iso.value,
        seconds
    );
    let check = match check {
        Some(check) => Some((output, check.finish()?)),
        None => None,
    };
    Ok((line, check))
}

/// `topo::check` with a progress bar.
fn check_mesh(mesh: &isoforge::mesh::Mesh, opts: &CheckOptions) -> MeshReport {
    let task = Task::start("checking the mesh");
    let rep = topo::check_with_progress(mesh, opts, Some(&task));
    task.finish();
    rep
}

/// Success when every required guarantee holds; otherwise names the failures on stderr.
fn verdict(mesh: &Path, report: &MeshReport, require: &[Guarantee]) -> Outcome {
    let bad = failed(report, require);
    if bad.is_empty() {
        return Outcome::Success;
    }
    eprintln!("{}: required but failed: {}", mesh.display(), bad.join(", "));
    Outcome::CheckFailed
}

pub fn extract(c: &ExtractConfig) -> Result<Outcome> {
    let r = &c.request;
    let budget = c.max_memory.map(|bytes| MemoryPlan::new(bytes, &r.options, c.mask.is_some(), !c.require.is_empty()));
    let batch = crate::outputs::plan_extract(c)?;
    let loaded = open_input(&c.input, budget.as_ref(), streams_by_default(c))?;
    let name = input_name(&c.input);
    if let Some(labels) = &r.labels {
        return extract_labels(c, loaded, labels, &name, batch);
    }
    // What each kind of input refuses, in the flags' words (the library refuses them too).
    match &loaded {
        Loaded::Stream(_) if c.repeat > 1 => bail!("--repeat: out-of-core extraction (--max-memory) runs once"),
        Loaded::Stream(_) if !r.region.is_identity() => {
            bail!("--roi, --close and --space index need the volume in memory (drop --max-memory)")
        }
        Loaded::Stream(_) if !needs_memory(c).is_empty() => {
            bail!("{} need the volume and mesh in memory (drop --max-memory)", needs_memory(c).join(", "))
        }
        Loaded::Field(_) if !r.region.is_identity() => {
            bail!("--roi, --close and --space index apply to volume files (a field has its own lattice)")
        }
        Loaded::Field(_) if c.mask.is_some() => {
            bail!("--mask needs the volume from a file ({} is a built-in field)", input_name(&c.input))
        }
        Loaded::Sparse(_) if !r.region.is_identity() || c.mask.is_some() => {
            bail!("--roi, --close, --space index and --mask apply to dense volume files, not to {name}")
        }
        _ => {}
    }
    let mut mask = None;
    let source = match loaded {
        Loaded::Grid(g) => {
            // The mask's own checks come after the grid's (value range, ROI): read it first.
            if let Some(m) = &c.mask {
                let Loaded::Grid(mg) = load(m)? else { bail!("--mask {}: not a volume file", input_name(m)) };
                mask = Some((input_name(m), mg));
            }
            Input::Grid(Cow::Owned(g))
        }
        Loaded::Field(b) => Input::Field(Cow::Owned(b)),
        Loaded::Sparse(s) => Input::Sparse(Cow::Owned(s.grid)),
        Loaded::Stream(reader) => Input::Stream(Box::new(reader)),
    };
    let prepared =
        pipeline::prepare(r, source, mask.as_ref().map(|(_, m)| m), budget.as_ref()).map_err(|e| match e {
            PrepareError::Isos(e) => anyhow!("{name}: {e} (see `isoforge info {name}`)"),
            PrepareError::Roi(e) => anyhow::Error::new(e).context(format!("{name}: --roi")),
            PrepareError::Mask(e) => {
                anyhow::Error::new(e).context(format!("--mask {}", mask.as_ref().map_or("", |(n, _)| n)))
            }
            PrepareError::Region(e) => anyhow::Error::new(e).context(name.clone()),
            PrepareError::Budget(refusal) => match &budget {
                Some(b) => refused(&name, b, refusal),
                None => anyhow!("{name}: {refusal}"),
            },
            e => anyhow!("{name}: {e}"),
        })?;
    if matches!(prepared.source, Input::Stream(_)) {
        return extract_streaming(c, prepared, &name, batch);
    }
    let frame = match &prepared.source {
        Input::Grid(g) => g.lattice().space(),
        _ => None,
    };
    let isos = prepared.isos.clone();
    let input_lattice = prepared.input_lattice.clone();
    let attribute_grids = load_attributes(&c.request, frame)?;
    let rgb = match (&c.color_volume, &input_lattice) {
        (None, _) => None,
        (Some(_), None) => bail!("--color-volume colours meshes of volume files"),
        (Some(path), Some(l)) => {
            let v = spin(format!("reading {}", path.display()), || isoforge_io::read_tiff_rgb(path, &c.input.limits))?;
            if v.dims != l.dims() {
                bail!("--color-volume {}: dims {:?} differ from the input's {:?}", path.display(), v.dims, l.dims());
            }
            // Vertices back to voxel indices of the input, in whichever frame they were written.
            let frame = match c.request.region.world {
                Some(w) => l.in_space(w)?,
                None => l.clone(),
            };
            Some((v, frame, c.request.region.index_space))
        }
    };
    // glTF and OBJ hold several meshes: one file with a node (object) per iso; other formats
    // get a file per iso.
    let one_gltf = crate::outputs::one_file_for_all_isos(c, isos.len());
    let mut outcome = Outcome::Success;
    let mut meshes = Vec::new();
    let done = std::cell::RefCell::new(Vec::new());
    for &iso in &isos {
        let (output, time_json) = crate::outputs::extract_paths(c, iso.value, isos.len());
        let target = if one_gltf { None } else { Some(output.as_path()) };
        let job = Job {
            c,
            prepared: &prepared,
            name: &name,
            attributes: &attribute_grids,
            rgb: rgb.as_ref(),
            batch: &batch,
            done: &done,
        };
        let (o, mesh, data) = extract_one(&job, iso, target, time_json.as_deref())?;
        if o != Outcome::Success {
            outcome = o;
        }
        if one_gltf {
            meshes.push((format!("iso {}", iso.value), mesh, data));
        }
    }
    if one_gltf {
        let named: Vec<isoforge_io::NamedMesh> =
            meshes.iter().map(|(n, m, d)| isoforge_io::NamedMesh { name: n, mesh: m, data: d }).collect();
        spin(format!("writing {}", c.output.display()), || {
            if c.format == MeshFormat::Obj {
                batch.write_obj_objects(&c.output, &named)
            } else {
                batch.write_gltf(&c.output, &named, c.format == MeshFormat::Glb)
            }
        })?;
        done.borrow_mut().push(format!("{}: {} meshes (one object per iso value)", c.output.display(), named.len()));
    }
    // Every iso succeeded: now, and only now, the files appear.
    batch.commit()?;
    for line in done.take() {
        eprintln!("{line}");
    }
    Ok(outcome)
}

/// `--labels`: a closed surface per label, written as one file (triangles tagged by label).
fn extract_labels(
    c: &ExtractConfig,
    loaded: Loaded,
    labels: &pipeline::Labels,
    name: &str,
    batch: isoforge_io::Batch,
) -> Result<Outcome> {
    let Loaded::Grid(g) = loaded else { bail!("{name}: --labels needs a label volume file in memory") };
    let g = pipeline::entry::prepare_labels(&c.request, Cow::Owned(g)).map_err(|e| match e {
        PrepareError::Roi(e) => anyhow::Error::new(e).context(format!("{name}: --roi")),
        PrepareError::Region(e) => anyhow::Error::new(e).context(name.to_string()),
        e => anyhow!("{name}: {e}"),
    })?;
    // Each label is a pass over the whole volume: say so before a long run (an image's grey
    // values taken for labels are hundreds of them).
    let count = match labels {
        pipeline::Labels::All => pipeline::labels_present(&g).len(),
        pipeline::Labels::These(v) => v.len(),
    };
    if count > MANY_LABELS {
        eprintln!(
            "{name}: {count} labels: one pass over the {} points for each, every surface kept until written \
             (a label volume rarely has this many: is it a label volume?)",
            g.lattice().num_points()
        );
    }
    let start = Instant::now();
    let task = Task::counting("meshing label");
    let mut surfaces = pipeline::extract_labels_with_progress(&g, labels, &c.request.options, Some(&task))
        .with_context(|| format!("{name}: --labels"))?;
    task.finish();
    let seconds = start.elapsed().as_secs_f64();
    // Label surfaces are smoothed within half a spacing, so neighbours still meet.
    let post = pipeline::label_post(&c.request.post, g.lattice());
    let mut post_lines = Vec::new();
    for (label, e) in &mut surfaces {
        let done = post_process(&mut e.mesh, &post, c.request.options.threads, name)?;
        post_lines.extend(done.lines.iter().map(|l| format!("label {label}: {l}")));
    }
    let writing = Task::start(format!("writing {}", c.output.display()));
    let mut report_rows = Vec::new();
    if matches!(c.format, MeshFormat::Glb | MeshFormat::Gltf) {
        let data = isoforge_io::MeshData::default();
        let names: Vec<String> = surfaces.iter().map(|(l, _)| format!("label {l}")).collect();
        let named: Vec<isoforge_io::NamedMesh> = surfaces
            .iter()
            .zip(&names)
            .map(|((_, e), n)| isoforge_io::NamedMesh { name: n, mesh: &e.mesh, data: &data })
            .collect();
        batch.write_gltf(&c.output, &named, c.format == MeshFormat::Glb)?;
    } else {
        // One mesh, each triangle tagged with its label.
        let (mesh, tags) = pipeline::merge_labels(&surfaces);
        let data = isoforge_io::MeshData { triangle_labels: Some(tags), ..Default::default() };
        batch.write_mesh(&c.output, &mesh, &data, c.format)?;
    }
    batch.commit()?;
    writing.finish();
    let mut outcome = Outcome::Success;
    let checking = Task::counting("checking label");
    let mut failures = Vec::new();
    for (i, (label, e)) in surfaces.iter().enumerate() {
        isoforge::walk::Progress::advance(&checking, i as u64, surfaces.len() as u64);
        let rep = topo::check_with(&e.mesh, &CheckOptions::for_require(&c.require));
        report_rows.push(format!(
            "label {label}: {} vertices, {} triangles, closed {}, manifold {}, components {}",
            e.mesh.num_vertices(),
            e.mesh.num_triangles(),
            rep.is_closed(),
            rep.is_manifold(),
            rep.components.len()
        ));
        let bad = failed(&rep, &c.require);
        if !bad.is_empty() {
            outcome = Outcome::CheckFailed;
            failures.push(format!("{}: label {label}: required but failed: {}", c.output.display(), bad.join(", ")));
        }
    }
    checking.finish();
    for f in failures {
        eprintln!("{f}");
    }
    report_rows.extend(post_lines);
    eprintln!(
        "{}: {} label surfaces ({:.3} s)\n  {}",
        c.output.display(),
        surfaces.len(),
        seconds,
        report_rows.join("\n  ")
    );
    Ok(outcome)
}

/// The `--attribute` sources, volumes read once and expressed in the mesh's frame.
fn load_attributes(
    r: &crate::config::ExtractRequest,
    frame: Option<isoforge::grid::WorldSpace>,
) -> Result<Vec<(String, Attribute)>> {
    let mut out = Vec::new();
    for (name, source) in &r.attributes {
        let a = match source {
            AttributeSource::Volume(input) => {
                let Loaded::Grid(g) = load(input)? else { bail!("--attribute {name}: not a volume file") };
                Attribute::volume_in(g, frame).with_context(|| format!("--attribute {name}"))?
            }
            AttributeSource::Texture(t, scale) => Attribute::Texture(*t, *scale),
        };
        out.push((name.clone(), a));
    }
    Ok(out)
}

/// The attributes at the mesh's (world) vertices, and the colours `--color-by` asks for.
fn vertex_data(
    r: &crate::config::ExtractRequest,
    mesh: &isoforge::mesh::Mesh,
    attributes: &[(String, Attribute)],
) -> isoforge_io::MeshData {
    let mut data = isoforge_io::MeshData::default();
    for (name, attribute) in attributes {
        let s = attribute.sample(&mesh.positions);
        if s.outside > 0 {
            eprintln!(
                "--attribute {name}: {} of {} vertices lie outside its volume (given the nearest value)",
                s.outside,
                s.values.len()
            );
        }
        data.scalars.push((name.clone(), s.values));
    }
    if let Some(by) = &r.color {
        if let Some((_, values)) = data.scalars.iter().find(|(n, _)| *n == by.attribute) {
            data.colors = Some(by.colors(values));
        }
    }
    data
}

/// Labels beyond which `--labels` warns before meshing (each label is a pass over the volume).
const MANY_LABELS: usize = 64;

/// What every iso of one `extract` run shares.
#[derive(Clone, Copy)]
struct Job<'a> {
    c: &'a ExtractConfig,
    /// The input, its isos, the options with the mask.
    prepared: &'a Prepared<'a>,
    name: &'a str,
    attributes: &'a [(String, Attribute)],
    /// `--color-volume`: the colours, the input lattice in the output frame, and whether the
    /// vertices are already voxel indices.
    rgb: Option<&'a (isoforge_io::RgbVolume, isoforge::grid::Lattice, bool)>,
    /// The command's outputs, committed together at the end.
    batch: &'a isoforge_io::Batch,
    /// One summary line per written file, printed after the commit.
    done: &'a std::cell::RefCell<Vec<String>>,
}

/// One extraction of an in-memory input at `iso`, written to `output` when given; returns the
/// mesh too (for files holding several).
fn extract_one(
    job: &Job,
    iso: Iso,
    output: Option<&Path>,
    time_json: Option<&Path>,
) -> Result<(Outcome, isoforge::mesh::Mesh, isoforge_io::MeshData)> {
    let Job { c, prepared, name, attributes, rgb, batch, done } = *job;
    let mut runs = Vec::with_capacity(c.repeat as usize);
    let mut last: Option<Extraction> = None;
    for _ in 0..c.repeat {
        drop(last.take()); // as a warm loop elsewhere: the previous mesh is freed before the next run
        let task = Task::start(format!("extracting iso {} ({})", iso.value, c.request.options.method.name()));
        let start = Instant::now();
        last = Some(prepared.extract(iso, Some(&task)).with_context(|| name.to_string())?);
        runs.push(start.elapsed().as_secs_f64());
        task.finish();
    }
    // Quads (dual methods) stay quads: PLY, OBJ and OFF write them, STL and glTF split them.
    let mut out = last.ok_or_else(|| anyhow!("internal: --repeat ran no extraction"))?;
    let seconds = runs.last().copied().unwrap_or_default();
    if let Some(none) = out.no_surface(iso) {
        bail!("{name}: {none}");
    }
    let post = post_process(&mut out.mesh, &c.request.post, c.request.options.threads, name)?;
    let mut data = vertex_data(&c.request, &out.mesh, attributes);
    if let Some((v, lattice, index_space)) = rgb {
        let at = |p: [f32; 3]| {
            let p = p.map(f64::from);
            if *index_space {
                p
            } else {
                lattice.to_index(p)
            }
        };
        data.colors = Some(out.mesh.positions.iter().map(|&p| v.sample(at(p))).collect());
    }
    if let Some(output) = output {
        spin(format!("writing {}", output.display()), || batch.write_mesh(output, &out.mesh, &data, c.format))?;
    }
    if let Some(t) = time_json {
        let body = json!({
            "seconds": seconds,
            "post_seconds": post.seconds(),
            "runs": runs,
            "vertices": out.mesh.num_vertices(),
            "triangles": out.mesh.num_triangles(),
            "quads": out.mesh.num_quads()
        });
        batch.write(t, |w| w.write_all(body.to_string().as_bytes()))?;
    }
    let shown = output.unwrap_or(&c.output);
    // Said once the batch is committed: before that the file does not exist.
    done.borrow_mut().push(format!(
        "{}: {} vertices, {} ({} method, iso {}, extraction {:.3} s){}",
        shown.display(),
        out.mesh.num_vertices(),
        polygon_counts(&out.mesh),
        c.request.options.method.name(),
        iso.value,
        seconds,
        post.text()
    ));
    if c.require.is_empty() {
        return Ok((Outcome::Success, out.mesh, data));
    }
    let rep = check_mesh(&out.mesh, &CheckOptions::for_require(&c.require));
    print!("{}", report::mesh_text(&rep));
    Ok((verdict(shown, &rep, &c.require), out.mesh, data))
}

pub fn info(input: &InputConfig, json_out: bool) -> Result<Outcome> {
    if let Source::File { path, raw: None } = &input.source {
        if path.to_string_lossy().to_ascii_lowercase().ends_with(".skt") {
            return skeleton_info(path, &input.limits, json_out);
        }
    }
    let name = input_name(input);
    let loaded = load(input)?;
    let (lattice, kind) = match &loaded {
        Loaded::Grid(g) => (g.lattice().clone(), g.dtype().to_string()),
        Loaded::Field(b) => (b.lattice.clone(), "field (f32)".to_string()),
        Loaded::Stream(r) => (r.lattice().clone(), r.dtype().to_string()),
        Loaded::Sparse(s) => (
            s.grid.lattice().clone(),
            format!("sparse {}", if matches!(s.grid, AnySparse::F32(_)) { "f32" } else { "f64" }),
        ),
    };
    let (lo, hi) = lattice.world_bounds();
    let mut v = json!({
        "input": name,
        "dims": lattice.dims(),
        "type": kind,
        "spacing": lattice.spacing(),
        "origin": lattice.origin(),
        "space": lattice.space().map(|s| s.name()),
        "direction": lattice.direction(),
        "world_bounds": { "min": lo, "max": hi },
        "points": lattice.num_points(),
    });
    let hist = match &loaded {
        Loaded::Grid(g) => spin("histogram", || Histogram::of(g, 256)),
        Loaded::Stream(_) => None,
        Loaded::Sparse(s) => {
            let st = s.grid.stats();
            v["sparse"] = json!({
                "grid": s.name, "class": s.class, "other_grids": s.others,
                "active_points": s.active_points, "leaves": st.leaves, "stored_samples": st.stored_samples,
                "nodes": st.nodes, "tiles": st.child_tiles + st.root_tiles, "bytes": st.bytes,
                "index_origin": s.grid.index_origin(),
            });
            if let Some(r) = s.grid.value_range() {
                v["value_range"] = json!([r.min, r.max]);
            }
            None
        }
        Loaded::Field(b) => {
            v["default_iso"] = json!(b.iso.value);
            v["inside"] = json!(b.iso.inside.name());
            None
        }
    };
    if let Some(h) = &hist {
        v["value_range"] = json!([h.min, h.max]);
        v["mean"] = json!(h.mean);
        v["percentiles"] = json!({ "p1": h.quantile(0.01), "p50": h.quantile(0.5), "p99": h.quantile(0.99) });
        v["suggested_iso"] = json!(h.surface_iso());
        v["otsu"] = json!(h.otsu());
    }
    if json_out {
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(Outcome::Success);
    }
    let d = lattice.dims();
    let s = lattice.spacing();
    let o = lattice.origin();
    println!("input:       {name}");
    println!("dims:        {} x {} x {} ({} points), {kind}", d[0], d[1], d[2], lattice.num_points());
    println!("spacing:     {} {} {}", s[0], s[1], s[2]);
    println!("origin:      {} {} {}", o[0], o[1], o[2]);
    if let Some(space) = lattice.space() {
        println!(
            "space:       {} (world coordinates in millimetres, +x +y +z towards {})",
            space.name(),
            match space {
                isoforge::grid::WorldSpace::Lps => "left, posterior, superior",
                isoforge::grid::WorldSpace::Ras => "right, anterior, superior",
            }
        );
    }
    if lattice.direction() != IDENTITY {
        println!("direction:   {:?}{}", lattice.direction(), if lattice.is_mirrored() { " (mirrored)" } else { "" });
    }
    println!("world:       ({:.4}, {:.4}, {:.4}) to ({:.4}, {:.4}, {:.4})", lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    if let Loaded::Field(b) = &loaded {
        println!("default iso: {} (inside {})", b.iso.value, b.iso.inside.name());
    }
    if let Loaded::Sparse(s) = &loaded {
        let st = s.grid.stats();
        let class = s.class.as_deref().map(|c| format!(", {c}")).unwrap_or_default();
        println!(
            "grid:        {}{class}{}",
            s.name,
            if s.others.is_empty() { String::new() } else { format!(" (also in the file: {})", s.others.join(", ")) }
        );
        println!(
            "sparse:      {} active points; {} leaves of 8³ ({} samples), {} nodes, {} tiles, {:.1} MiB",
            s.active_points,
            st.leaves,
            st.stored_samples,
            st.nodes,
            st.child_tiles + st.root_tiles,
            st.bytes as f64 / 1048576.0
        );
        let o = s.grid.index_origin();
        println!("index:       lattice point 0 is the file's index ({}, {}, {})", o[0], o[1], o[2]);
        if let Some(r) = s.grid.value_range() {
            println!("values:      {} to {}", r.min, r.max);
        }
    }
    if let Some(h) = &hist {
        println!("values:      {} to {}, mean {:.4}", h.min, h.max, h.mean);
        println!("percentiles: 1% {:.4}   50% {:.4}   99% {:.4}", h.quantile(0.01), h.quantile(0.5), h.quantile(0.99));
        let (iso, otsu) = (h.surface_iso(), h.otsu());
        if iso == otsu {
            println!("suggested iso: {iso:.4} (Otsu)");
        } else {
            println!(
                "suggested iso: {iso:.4} (Otsu without the padding at the range's end; over all values: {otsu:.4})"
            );
        }
        println!("histogram (16 bins, log scale):");
        let coarse: Vec<u64> = h.counts.chunks(16).map(|c| c.iter().sum()).collect();
        let max = coarse.iter().copied().max().unwrap_or(1).max(1) as f64;
        let w = (h.max - h.min) / coarse.len() as f64;
        for (b, &c) in coarse.iter().enumerate() {
            let bar = if c == 0 { 0 } else { (1.0 + 39.0 * (c as f64).ln() / max.ln().max(1e-9)).round() as usize };
            println!("  {:>12.4} {:>12} {}", h.min + b as f64 * w, c, "#".repeat(bar));
        }
    }
    Ok(Outcome::Success)
}

/// What `post_process` did: one line per step, and the seconds they took.
struct PostDone {
    lines: Vec<String>,
    seconds: f64,
}

impl PostDone {
    fn seconds(&self) -> f64 {
        self.seconds
    }

    /// `; smoothed …; decimated …` for a summary line (empty when nothing was done).
    fn text(&self) -> String {
        self.lines.iter().map(|l| format!("; {l}")).collect()
    }
}

/// `--smooth`, `--decimate`, `--max-error` on one mesh (the library's steps), with a spinner.
fn post_process(
    mesh: &mut isoforge::mesh::Mesh,
    post: &PostProcess,
    threads: Option<usize>,
    name: &str,
) -> Result<PostDone> {
    if post.is_identity() {
        return Ok(PostDone { lines: Vec::new(), seconds: 0.0 });
    }
    let stats = spin("smoothing and decimating", || pipeline::post_process(mesh, post, threads))
        .with_context(|| name.to_string())?;
    let seconds = stats.smooth.as_ref().map_or(0.0, |s| s.1) + stats.decimate.as_ref().map_or(0.0, |d| d.1);
    Ok(PostDone { lines: stats.lines(post), seconds })
}

/// `info` of a TopoMender skeleton (`.skt`): records by type, passes, the weights' range.
fn skeleton_info(path: &Path, limits: &Limits, json_out: bool) -> Result<Outcome> {
    let s = isoforge_io::read_skt(path, limits)?;
    let c = s.counts();
    let range = s.weight_range();
    if json_out {
        let v = json!({
            "input": path.display().to_string(),
            "format": "skt",
            "passes": s.passes,
            "records": s.records.len(),
            "counts": { "handle_kept": c[0], "handle_cut": c[1], "tunnel_kept": c[2], "tunnel_filled": c[3] },
            "weights": range.map(|(lo, hi)| json!({ "min": lo, "max": hi })),
            "infinite_weights": s.unbounded(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(Outcome::Success);
    }
    println!("input:       {}", path.display());
    println!("format:      TopoMender skeleton (.skt): {} records in {} passes", s.records.len(), s.passes);
    println!("solid:       {} edges kept, {} cut (handles)", c[0], c[1]);
    println!("outside:     {} edges kept, {} filled (tunnels)", c[2], c[3]);
    match range {
        Some((lo, hi)) => println!(
            "weights:     {lo} to {hi} squared units; {} infinite (edges still bounding a face)",
            s.unbounded()
        ),
        None => println!("weights:     none finite; {} infinite", s.unbounded()),
    }
    Ok(Outcome::Success)
}
pub fn simplify(c: &SimplifyConfig) -> Result<Outcome> {
    let batch = crate::outputs::plan_one(&c.output, "-o", Some(c.format), None, Some(&c.mesh))?;
    let name = c.mesh.display().to_string();
    let mut mesh = spin(format!("reading {name}"), || isoforge_io::read_mesh(&c.mesh, &c.limits))?;
    let (v0, p0) = (mesh.num_vertices(), polygon_counts(&mesh));
    let done = post_process(&mut mesh, &c.post, c.threads, &name)?;
    spin(format!("writing {}", c.output.display()), || {
        batch.write_mesh(&c.output, &mesh, &Default::default(), c.format)
    })?;
    batch.commit()?;
    eprintln!(
        "{}: {} vertices, {} (from {v0} vertices, {p0}){}",
        c.output.display(),
        mesh.num_vertices(),
        polygon_counts(&mesh),
        done.text()
    );
    Ok(Outcome::Success)
}

pub fn check(c: &CheckConfig) -> Result<Outcome> {
    let mesh = spin(format!("reading {}", c.mesh.display()), || isoforge_io::read_mesh(&c.mesh, &c.limits))?;
    let reference = match &c.reference {
        Some(r) => Some((r, spin(format!("reading {}", r.display()), || isoforge_io::read_mesh(r, &c.limits))?)),
        None => None,
    };
    let rep = check_mesh(
        &mesh,
        &CheckOptions { max_examples: c.examples, self_intersections: c.self_intersections, ..CheckOptions::default() },
    );
    let distance =
        reference.as_ref().map(|(_, r)| spin("measuring the Hausdorff distance", || topo::hausdorff(&mesh, r)));
    if c.json {
        let mut v = report::mesh_json(&rep);
        v["file"] = json!(c.mesh.display().to_string());
        v["failed"] = json!(failed(&rep, &c.require));
        if let (Some((path, _)), Some(h)) = (&reference, distance) {
            v["reference"] = json!({
                "file": path.display().to_string(),
                "hausdorff": h.max(),
                "to_reference": h.forward,
                "from_reference": h.backward,
                "mean": h.mean,
            });
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("file:        {}", c.mesh.display());
        print!("{}", report::mesh_text(&rep));
        if let (Some((path, _)), Some(h)) = (&reference, distance) {
            println!(
                "reference:   {}: Hausdorff {:.6} (to it {:.6}, from it {:.6}, mean {:.6}; vertices to surfaces)",
                path.display(),
                h.max(),
                h.forward,
                h.backward,
                h.mean
            );
        }
    }
    Ok(verdict(&c.mesh, &rep, &c.require))
}

pub fn demo(c: &DemoConfig) -> Result<Outcome> {
    let format = crate::config::output_format(&c.output, false)?;
    let batch = crate::outputs::plan_one(&c.output, "-o", Some(format), None, None)?;
    let b = catalog::parse(&format!("metaballs?n={}", c.n))?;
    let start = Instant::now();
    let task = Task::start("extracting the demo field");
    let iso = c.request.isos_or(b.iso)[0];
    let out = pipeline::extract_builtin(&b, iso, &c.request.options, Some(&task))?;
    task.finish();
    let seconds = start.elapsed().as_secs_f64();
    spin("writing the demo mesh", || batch.write_mesh(&c.output, &out.mesh, &Default::default(), format))?;
    batch.commit()?;
    let rep = check_mesh(&out.mesh, &CheckOptions::default());
    if c.json {
        let mut v = report::mesh_json(&rep);
        v["output"] = json!(c.output.display().to_string());
        v["seconds"] = json!(seconds);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "isoforge demo: the classic three-metaball field (charges 0.5, 1, 1.5; iso 48) on a {0}x{0}x{0} lattice",
            c.n
        );
        println!("method:      {}, extraction {:.3} s", c.request.options.method.name(), seconds);
        println!("output:      {}", c.output.display());
        print!("{}", report::mesh_text(&rep));
    }
    Ok(if rep.is_watertight() { Outcome::Success } else { Outcome::CheckFailed })
}

/// The image of slice `k` along `axis` of `grid` (the axes that remain, in order, x fastest).
/// The axes that remain in a slice normal to `axis`, in order.
fn in_plane(axis: usize) -> (usize, usize) {
    match axis {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    }
}

fn slice_of(grid: &AnyGrid, axis: usize, k: u32) -> ([u32; 2], Vec<f64>) {
    let d = grid.lattice().dims();
    let (u, v) = in_plane(axis);
    let mut values = Vec::with_capacity(d[u] as usize * d[v] as usize);
    for b in 0..d[v] {
        for a in 0..d[u] {
            let mut p = [0u32; 3];
            p[axis] = k;
            p[u] = a;
            p[v] = b;
            values.push(grid.get_f64(p));
        }
    }
    ([d[u], d[v]], values)
}

pub fn contour(c: &ContourConfig) -> Result<Outcome> {
    let batch = crate::outputs::plan_one(&c.output, "-o", None, Some(&c.input), None)?;
    let name = input_name(&c.input);
    let Loaded::Grid(grid) = load(&c.input)? else { bail!("{name}: contour needs an image or a volume file") };
    let dims = grid.lattice().dims();
    let axis_name = ["x", "y", "z"][c.axis];
    let k = match c.slice {
        Some(k) if k >= dims[c.axis] => {
            bail!("{name}: --slice {k} is outside 0..{} along {axis_name}", dims[c.axis])
        }
        Some(k) => k,
        None => dims[c.axis] / 2,
    };
    // The slice is meshed as f64 (8 bytes a sample): it counts against --max-bytes too.
    let [u, v] = match c.axis {
        0 => [dims[1], dims[2]],
        1 => [dims[0], dims[2]],
        _ => [dims[0], dims[1]],
    };
    let slice_bytes = u as u64 * v as u64 * 8;
    if slice_bytes > c.input.limits.max_bytes {
        bail!(
            "{name}: slice {axis_name} = {k} ({u} x {v}) needs {slice_bytes} bytes as f64, over the limit of {} bytes (raise it with --max-bytes)",
            c.input.limits.max_bytes
        );
    }
    let (size, values) = slice_of(&grid, c.axis, k);
    let (lo, hi) = values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    if c.iso.value < lo || c.iso.value > hi {
        bail!("{name}: iso {} is outside the value range [{lo}, {hi}] of slice {axis_name} = {k}", c.iso.value);
    }
    let start = Instant::now();
    let lines = isoforge::extract::marching_squares(size, &values, c.iso, c.saddle);
    let seconds = start.elapsed().as_secs_f64();
    // Pixel indices, or the units --spacing/--origin give the two in-plane axes.
    let frame = if c.input.placed() {
        let (u, v) = in_plane(c.axis);
        let l = grid.lattice();
        ContourFrame { dims: size, origin: [l.origin()[u], l.origin()[v]], spacing: [l.spacing()[u], l.spacing()[v]] }
    } else {
        ContourFrame::pixels(size)
    };
    let lines: Vec<_> = lines.iter().map(|l| frame.place(l)).collect();
    batch
        .write(&c.output, |w| isoforge_io::write::contour::write_contours(w, &lines, c.format, &frame, c.iso.value))?;
    batch.commit()?;
    let closed = lines.iter().filter(|l| l.closed).count();
    let length: f64 = lines.iter().map(|l| l.length()).sum::<f64>() + 0.0; // no "-0" for no contour
    let points: usize = lines.iter().map(|l| l.points.len()).sum();
    if c.json {
        let v = json!({
            "input": name, "axis": axis_name, "slice": k, "size": size, "iso": c.iso.value,
            "origin": frame.origin, "spacing": frame.spacing,
            "contours": lines.len(), "closed": closed, "open": lines.len() - closed,
            "points": points, "length": length, "seconds": seconds,
        });
        println!("{v}");
    } else {
        println!(
            "{}: {} contours ({closed} closed, {} open), {points} points, total length {length:.3} {} \
             (slice {axis_name} = {k} of {name}, {} x {}, iso {})",
            c.output.display(),
            lines.len(),
            lines.len() - closed,
            if c.input.placed() { "units" } else { "px" },
            size[0],
            size[1],
            c.iso.value
        );
    }
    Ok(Outcome::Success)
}

/// `isoforge convert`: dense → dense (a format change), dense → `.vdb` (sparse near `--iso`),
/// `.vdb` → dense (a region) or `.vdb` → `.vdb` (the grid rewritten).
pub fn convert(c: &ConvertConfig) -> Result<Outcome> {
    let (input, output) = (&c.input, c.output.as_path());
    let batch = crate::outputs::plan_one(output, "the output", None, Some(input), None)?;
    let name = input_name(input);
    if c.sparse_input {
        let Source::File { path, .. } = &input.source else { bail!("internal: a .vdb input is a file") };
        let file =
            spin(format!("reading {name}"), || isoforge_io::read_sparse(path, c.grid.as_deref(), &input.limits))?;
        if c.sparse_output {
            let opts = isoforge_io::VdbWriteOptions {
                name: file.name.clone(),
                class: class_of(file.class.as_deref()),
                value_type: match &file.grid {
                    AnySparse::F32(_) => isoforge_io::read::vdb::VdbValueType::Float,
                    AnySparse::F64(_) => isoforge_io::read::vdb::VdbValueType::Double,
                },
            };
            spin(format!("writing {}", output.display()), || match &file.grid {
                AnySparse::F32(g) => batch.write_sparse(output, g, &opts),
                AnySparse::F64(g) => batch.write_sparse(output, g, &opts),
            })?;
            batch.commit()?;
            eprintln!("{}: grid {:?}, {} leaves from {name}", output.display(), file.name, file.grid.stats().leaves);
            return Ok(Outcome::Success);
        }
        let grid = isoforge_io::dense_region(path, &file, c.region, &input.limits)?;
        spin(format!("writing {}", output.display()), || batch.write_volume(output, &grid))?;
        batch.commit()?;
        let d = grid.lattice().dims();
        eprintln!(
            "{}: {} x {} x {} {} samples of grid {:?} from {name}",
            output.display(),
            d[0],
            d[1],
            d[2],
            grid.dtype(),
            file.name
        );
        return Ok(Outcome::Success);
    }
    let Loaded::Grid(grid) = load(input)? else { bail!("{name}: convert reads volume and image files, not fields") };
    if let (true, Some(iso)) = (c.sparse_output, c.iso) {
        let default_name = if c.class == isoforge_io::GridClass::LevelSet { "surface" } else { "density" };
        // Integers beyond 2²⁴ and doubles keep their precision as doubles.
        let value_type = match grid.dtype() {
            DType::F64 | DType::U32 | DType::I32 => isoforge_io::read::vdb::VdbValueType::Double,
            _ => isoforge_io::read::vdb::VdbValueType::Float,
        };
        let opts = isoforge_io::VdbWriteOptions {
            name: c.grid.clone().unwrap_or_else(|| default_name.to_string()),
            class: c.class,
            value_type,
        };
        let leaves = spin(format!("writing {}", output.display()), || {
            isoforge::with_grid!(&grid, g => {
                let sparse = SparseGrid::from_dense_band(g, Iso::below(iso), c.band);
                batch.write_sparse(output, &sparse, &opts).map(|()| sparse.num_leaves())
            })
        })?;
        batch.commit()?;
        eprintln!("{}: grid {:?}, {leaves} leaves of 8³ near iso {iso} from {name}", output.display(), opts.name);
        return Ok(Outcome::Success);
    }
    spin(format!("writing {}", output.display()), || batch.write_volume(output, &grid))?;
    batch.commit()?;
    let d = grid.lattice().dims();
    eprintln!("{}: {} x {} x {} {} samples from {name}", output.display(), d[0], d[1], d[2], grid.dtype());
    Ok(Outcome::Success)
}

/// The writer's class for a class read from a file.
fn class_of(class: Option<&str>) -> isoforge_io::GridClass {
    match class {
        Some("level set") => isoforge_io::GridClass::LevelSet,
        Some("fog volume") => isoforge_io::GridClass::FogVolume,
        _ => isoforge_io::GridClass::Unknown,
    }
}

pub fn render(c: &RenderConfig) -> Result<Outcome> {
    let batch = crate::outputs::plan_one(&c.output, "-o", None, c.input.as_ref(), c.mesh.as_deref())?;
    let mesh = match (&c.mesh, &c.input) {
        (Some(path), _) => {
            spin(format!("reading {}", path.display()), || isoforge_io::read_mesh(path, &Limits::default()))?
        }
        (None, Some(input)) => {
            let name = input_name(input);
            // The input as it is (render takes no region, mask or budget).
            let (source, default_iso) = match load(input)? {
                Loaded::Grid(g) => (Input::Grid(Cow::Owned(g)), Iso::below(0.0)),
                Loaded::Field(b) => {
                    let iso = b.iso;
                    (Input::Field(Cow::Owned(b)), iso)
                }
                Loaded::Sparse(s) => (Input::Sparse(Cow::Owned(s.grid)), Iso::below(0.0)),
                Loaded::Stream(_) => bail!("{name}: too large to mesh in memory"),
            };
            let iso = c.request.isos_or(default_iso)[0];
            let options = c.request.options.clone();
            let prepared = Prepared { source, isos: vec![iso], options, input_lattice: None };
            let task = Task::start(format!("extracting iso {} ({})", iso.value, prepared.options.method.name()));
            let mesh = prepared.extract(iso, Some(&task)).with_context(|| name.clone())?.mesh;
            task.finish();
            mesh
        }
        (None, None) => bail!("internal: render has no input"),
    };
    spin(format!("rendering {}", c.output.display()), || batch.write_render(&c.output, &mesh, None, &c.render))?;
    batch.commit()?;
    let [w, h] = c.render.size;
    eprintln!("{}: {w} x {h} picture of {} triangles", c.output.display(), mesh.num_triangles());
    Ok(Outcome::Success)
}

pub fn view(c: &ViewConfig) -> Result<Outcome> {
    use crate::config::Shown as Input;
    use crate::view::Shown;
    let shown = match &c.shown {
        Input::Demo => Shown::Demo,
        Input::Mesh(path) => {
            let mesh =
                spin(format!("reading {}", path.display()), || isoforge_io::read_mesh(path, &Limits::default()))?;
            Shown::Mesh { name: path.display().to_string(), mesh }
        }
        Input::Volume(input) => {
            let name = input_name(input);
            match load(input)? {
                Loaded::Grid(grid) => Shown::Volume { name, grid },
                Loaded::Sparse(file) => Shown::Sparse { name, grid: file.grid },
                _ => bail!("{name}: view shows volume files, meshes, or (without INPUT) the demo fields"),
            }
        }
    };
    crate::view::serve(c.port, shown, c.request.clone(), c.max_memory.unwrap_or(crate::view::MEMORY_BUDGET))?;
    Ok(Outcome::Success)
}
