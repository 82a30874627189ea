//! Raw command-line arguments (clap). Converted once into a validated `Config` by `config.rs`.
//!
//! Format lists in help texts are generated from the io crate's format enums, so they cannot
//! drift from what the readers and writers accept. Every numeric option takes values that start
//! with `-` (`--origin -10,0,0`, `--iso -5`), and the validation says what is wrong with them.

use std::path::PathBuf;

use clap::{Args as ClapArgs, Parser, Subcommand};
use isoforge_io::{MeshFormat, VolumeFormat};

/// Every readable volume format with its extensions: `NRRD (.nrrd .nhdr), …`.
pub fn volume_formats() -> String {
    VolumeFormat::ALL
        .iter()
        .map(|f| {
            let ext = f.extensions().join(" ");
            match f {
                VolumeFormat::Raw => format!("{} ({ext} or any name, with --dims and --dtype)", f.name()),
                _ => format!("{} ({ext})", f.name()),
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The mesh extensions, as `.ply, .obj, …`; only those `check` reads when `readable`.
pub fn mesh_extensions(readable: bool) -> String {
    let ext: Vec<String> = MeshFormat::ALL
        .iter()
        .filter(|f| !readable || f.is_readable())
        .filter_map(|f| f.extension())
        .map(|e| format!(".{e}"))
        .collect();
    match ext.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => ext.join(""),
    }
}

/// Help for `-i`: every input the CLI reads.
fn input_help() -> String {
    let fields: Vec<&str> = isoforge::volume::catalog::NAMES.iter().map(|(n, _)| *n).collect();
    format!(
        "Volume: {}; a folder of DICOM files (one series); a folder of numbered PNG or TIFF slices; \
         or a built-in field such as `field:gyroid?n=128` (fields: {})",
        volume_formats(),
        fields.join(" ")
    )
}

/// Help for `extract -o`.
fn output_help() -> String {
    format!(
        "Output mesh, format by extension: {} (binary PLY and STL; --ascii for text)",
        MeshFormat::ALL
            .iter()
            .filter_map(|f| Some(format!("{} (.{})", f.name(), f.extension()?)))
            .collect::<Vec<_>>()
            .join(", ")
    )
}

/// Help for `check MESH`.
fn mesh_input_help() -> String {
    format!("Mesh file ({})", mesh_extensions(true))
}

/// Help for `render INPUT`.
fn render_input_help() -> String {
    format!("Mesh ({}) or volume or field (as for `extract -i`)", mesh_extensions(true))
}

/// isoforge: turn volumes into meshes.
#[derive(Debug, Parser)]
#[command(name = "isoforge", version, about, long_about = None)]
pub struct Args {
    /// Worker threads for extraction (default: all cores; at most 4 per core). Output does not
    /// depend on it.
    #[arg(long, global = true, value_name = "N", allow_hyphen_values = true)]
    pub threads: Option<usize>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Extract an isosurface from a volume file or a built-in field and write a mesh.
    Extract(Box<ExtractArgs>),
    /// Describe a volume: dims, type, geometry, value range, histogram, suggested iso.
    Info(InfoArgs),
    /// Check a mesh: boundary, manifoldness, orientation, components, Euler characteristic, genus.
    Check(CheckArgs),
    /// Build the classic three-metaball field, extract it, write demo.ply and print the report.
    Demo(DemoArgs),
    /// Isolines of a 2D image (PNG, TIFF) or of one slice of a volume (marching squares), written
    /// as SVG, GeoJSON or CSV.
    Contour(ContourArgs),
    /// Convert a volume to NRRD (.nrrd) or NIfTI-1 (.nii, .nii.gz), keeping type and geometry.
    Convert(ConvertArgs),
    /// Render a mesh, or the isosurface of a volume or field, to a PNG (software, no GPU).
    Render(RenderArgs),
    /// Serve an interactive viewer on 127.0.0.1: the classic demo fields, a volume, or a mesh.
    View(ViewArgs),
    /// Turn a mesh (holes, flipped and duplicated faces, crossing pieces welcome) into a signed
    /// distance volume: .vdb (sparse level set), .nrrd, .nii, .nii.gz (dense), or a .sog octree.
    Voxelize(VoxelizeArgs),
    /// Make a closed, manifold, oriented mesh of a broken one: voxelize it, then extract the
    /// surface; prints the mesh report and the Hausdorff distance to the input.
    Repair(RepairArgs),
    /// Cut the small handles and fill the small tunnels of a solid (TopoMender): a PolyMender
    /// .sog, a mesh (voxelized first) or a volume at an iso; writes the repaired surface and
    /// reports every handle and tunnel found with its size.
    TopoRepair(TopoRepairArgs),
    /// Smooth and/or decimate a mesh file (the steps of `extract --smooth --decimate
    /// --max-error`), writing the result in any mesh format.
    Simplify(SimplifyArgs),
}

/// What `voxelize` and `repair` read and how fine their lattice is.
#[derive(Debug, Clone, ClapArgs)]
pub struct VoxelArgs {
    #[arg(value_name = "MESH", help = mesh_input_help())]
    pub mesh: PathBuf,
    /// Cells along the longest side of the mesh's box (default 128 unless --voxel-size).
    #[arg(long, value_name = "N", allow_hyphen_values = true, conflicts_with = "voxel_size")]
    pub resolution: Option<String>,
    /// The lattice's spacing, in the mesh's units.
    #[arg(long, value_name = "H", allow_hyphen_values = true)]
    pub voxel_size: Option<String>,
    /// PolyMender's octree depth: 2^D cells along the longest side (--resolution 2^D).
    #[arg(long, value_name = "D", allow_hyphen_values = true, conflicts_with_all = ["resolution", "voxel_size"])]
    pub depth: Option<String>,
    /// Half-width of the band of exact distances, in cells (default 3).
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub band: Option<String>,
    /// Largest mesh the reader and largest grid the voxelizer may allocate, in bytes (suffixes
    /// K, M, G accepted).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_bytes: Option<String>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, ClapArgs)]
pub struct VoxelizeArgs {
    #[command(flatten)]
    pub voxel: VoxelArgs,
    /// Output volume: .vdb (sparse), .nrrd, .nii, .nii.gz (dense), .sog (PolyMender's signed
    /// octree, a cube of 2^depth cells: --resolution rounded up to a power of two).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    /// What the samples hold: sdf (signed distance, negative inside) or occupancy (u8, 1 inside).
    #[arg(long = "values", value_name = "KIND", default_value = "sdf")]
    pub values: String,
}

#[derive(Debug, ClapArgs)]
pub struct RepairArgs {
    #[command(flatten)]
    pub voxel: VoxelArgs,
    /// Output mesh (.ply .obj .stl .off .glb .gltf).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
}

#[derive(Debug, ClapArgs)]
pub struct TopoRepairArgs {
    /// The solid: a PolyMender signed octree (.sog), a mesh (.ply .obj .stl .off: voxelized
    /// with --resolution), or a volume (with --iso; inside is below the iso unless --inside
    /// above).
    #[arg(value_name = "INPUT")]
    pub input: PathBuf,
    /// Cut every handle whose narrowest cross-section is smaller than this area (squared model
    /// units); 0 or less cuts none (TopoMender's ThinThresh).
    #[arg(long, value_name = "AREA", allow_hyphen_values = true)]
    pub thin: String,
    /// Fill every tunnel whose narrowest spanning disc is smaller than this area (squared model
    /// units); 0 or less fills none (TopoMender's GrowThresh).
    #[arg(long, value_name = "AREA", allow_hyphen_values = true)]
    pub grow: String,
    /// The repaired surface (.ply .obj .stl .off .glb .gltf).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    /// Also write the skeletons, TopoMender's .skt records.
    #[arg(long, value_name = "OUT.skt")]
    pub skeleton: Option<PathBuf>,
    /// Also write the repaired grid: .sog (a cube of 2^depth cells), .nrrd, .nii or .nii.gz.
    #[arg(long = "grid-out", value_name = "OUT")]
    pub grid_out: Option<PathBuf>,
    /// The iso of a volume input (a .sog's is 0; a mesh's distances are cut at 0).
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<String>,
    /// Which side of the iso is the solid: below (value < iso, default) or above (a scan's or a
    /// label mask's object).
    #[arg(long, value_name = "SIDE")]
    pub inside: Option<String>,
    /// Cells along the longest side of a mesh input's box (default 128).
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub resolution: Option<String>,
    /// Largest input the readers may allocate, in bytes (suffixes K, M, G accepted).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_bytes: Option<String>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Smoothing and decimation after extraction (`extract`, `simplify`): smoothing first, then
/// decimation; the whole mesh in memory.
#[derive(Debug, Clone, ClapArgs)]
pub struct PostArgs {
    /// Smooth the mesh: sinc (windowed sinc, 40 terms) or taubin (λ|μ, 20 pairs), optionally
    /// :ITERATIONS. Both are low-pass filters that do not shrink the surface; only positions
    /// change (topology kept); vertices on boundary edges stay. With --labels every vertex
    /// stays within half a spacing of where it was extracted.
    #[arg(long, value_name = "taubin|sinc[:ITER]")]
    pub smooth: Option<String>,
    /// Decimate the mesh: remove this fraction of its triangles (0.9 keeps a tenth) by quadric
    /// edge collapses that keep it manifold, its genus, its components and its boundary edges,
    /// and fold no triangle over.
    #[arg(long, value_name = "RATIO", allow_hyphen_values = true)]
    pub decimate: Option<String>,
    /// Decimate as far as every vertex of the mesh before decimation stays within E (world
    /// units) of the decimated surface (with --decimate: stop at whichever comes first).
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    pub max_error: Option<String>,
}

/// Where the volume comes from (`extract -i INPUT`).
#[derive(Debug, ClapArgs)]
pub struct InputArgs {
    #[arg(short = 'i', long = "input", value_name = "INPUT", help = input_help())]
    pub input: String,
    #[command(flatten)]
    pub layout: LayoutArgs,
}

/// How to read the input: the layout of raw files, and the allocation limit.
#[derive(Debug, Clone, ClapArgs)]
pub struct LayoutArgs {
    /// Raw input: points per axis, x fastest.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub dims: Option<String>,
    /// Raw input: sample type (u8 i8 u16 i16 u32 i32 f32 f64).
    #[arg(long, value_name = "TYPE")]
    pub dtype: Option<String>,
    /// Raw input: byte order.
    #[arg(long, value_name = "little|big")]
    pub endian: Option<String>,
    /// Raw input: bytes to skip before the samples.
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub header_bytes: Option<u64>,
    /// Raw input and images (PNG, TIFF, folders of slices): spacing between points (default 1:
    /// voxel-index units).
    #[arg(long, value_name = "SX,SY,SZ", allow_hyphen_values = true)]
    pub spacing: Option<String>,
    /// Raw input and images: world position of the first point (default 0,0,0).
    #[arg(long, value_name = "OX,OY,OZ", allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// Largest volume or mesh a reader may allocate, in bytes (suffixes K, M, G accepted).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_bytes: Option<String>,
}

#[derive(Debug, ClapArgs)]
pub struct ExtractArgs {
    #[command(flatten)]
    pub input: InputArgs,
    #[arg(short = 'o', long = "output", value_name = "OUTPUT", help = output_help())]
    pub output: PathBuf,
    /// Iso value, or several separated by commas (`--iso 300,1200`: one mesh per value, written to
    /// OUT-300.ply, OUT-1200.ply…). Required for volume files; built-in fields have a default.
    #[arg(long, value_name = "V[,V…]", allow_hyphen_values = true)]
    pub iso: Option<String>,
    /// Label volume: one closed surface per label (`all` = every non-zero value, or a list such
    /// as 1,4,7), triangles tagged by label (PLY face property `label`; one glTF mesh per label).
    #[arg(long, value_name = "all|L,L…", conflicts_with = "iso", allow_hyphen_values = true)]
    pub labels: Option<String>,
    /// Only the half-open index box i0:i1,j0:j1,k0:k1 of the volume (empty bounds take the whole
    /// axis, e.g. `:,:,100:200`).
    #[arg(long, value_name = "I0:I1,J0:J1,K0:K1", allow_hyphen_values = true)]
    pub roi: Option<String>,
    /// Only the lattice points inside this world box (x0:x1,y0:y1,z0:z1, in the file's units).
    #[arg(long, value_name = "X0:X1,Y0:Y1,Z0:Z1", conflicts_with = "roi", allow_hyphen_values = true)]
    pub roi_world: Option<String>,
    /// Only cells whose eight corners are non-zero in this volume (same dims as the input; cropped
    /// and padded along with it). Surfaces end, open, at the mask's boundary.
    #[arg(long, value_name = "MASKVOLUME")]
    pub mask: Option<String>,
    /// Pad the volume with one layer of outside points so surfaces touching its faces are closed.
    #[arg(long)]
    pub close: bool,
    /// Sample a co-registered volume at every vertex (trilinear, in world coordinates) and write
    /// it as vertex attribute NAME (PLY property, glTF `_NAME`); repeatable.
    #[arg(long, value_name = "NAME=VOLUME")]
    pub attribute: Vec<String>,
    /// Colour vertices by attribute NAME through --colormap (PLY red/green/blue, glTF COLOR_0,
    /// OBJ vertex colours).
    #[arg(long, value_name = "NAME")]
    pub color_by: Option<String>,
    /// Colour vertices from an 8-bit RGB TIFF stack on the input's grid (same dims; sampled
    /// trilinearly at each vertex's voxel position), e.g. a microscopy colour channel.
    #[arg(long, value_name = "RGB.tif", conflicts_with = "color_by")]
    pub color_volume: Option<PathBuf>,
    /// Colour map for --color-by: viridis, gray, hot, coolwarm.
    #[arg(long, value_name = "MAP", default_value = "viridis")]
    pub colormap: String,
    /// Attribute values mapped to the colour map's ends (default: the attribute's range on the mesh).
    #[arg(long, value_name = "LO:HI", allow_hyphen_values = true)]
    pub color_range: Option<String>,
    /// Anatomical frame of the written world coordinates: lps (DICOM, ITK) or ras (NIfTI,
    /// FreeSurfer); default: the input file's own. Needs a file that says which it uses.
    #[arg(long, value_name = "lps|ras")]
    pub world: Option<String>,
    /// Coordinates of the written vertices: world (spacing, origin and direction of the file) or
    /// index (voxel indices of the input volume).
    #[arg(long, value_name = "world|index", default_value = "world")]
    pub space: String,
    /// Which side of iso is inside: below (value < iso, default for files) or above.
    #[arg(long, value_name = "below|above")]
    pub inside: Option<String>,
    /// Extraction method: mc33 (default: marching cubes 33, the topology of the trilinear
    /// interpolant), mc (classic marching cubes: exactly vtkFlyingEdges3D's triangles), mt5 / mt6 /
    /// mt-bcc (marching tetrahedra with 5, 6 or body-centred tetrahedra per cell), surface-nets,
    /// dc (dual contouring: sharp corners and creases from the volume's gradients; manifold, with
    /// the trilinear interpolant's topology), emc (extended marching cubes: MC33 with a feature
    /// vertex where the surface bends more than --feature-angle).
    #[arg(long, default_value = "mc33", value_name = "mc33|mc|mt5|mt6|mt-bcc|surface-nets|dc|emc")]
    pub method: String,
    /// With --method dc: keep quads (one per crossed lattice edge) instead of splitting each
    /// along its shorter diagonal.
    #[arg(long)]
    pub quads: bool,
    /// With --method dc: one vertex per marching-cubes patch of a cell instead of one per cell
    /// (a cell holding two sheets gives each its own vertex: fewer non-manifold edges). Implies
    /// --no-manifold.
    #[arg(long)]
    pub split: bool,
    /// With --method dc: plain dual contouring [Ju 2002] (surface nets' connectivity: one vertex
    /// per active cell, non-manifold where a cell holds two sheets) instead of the manifold mode.
    #[arg(long)]
    pub no_manifold: bool,
    /// With --method dc: adaptive dual contouring [Ju 2002 §4]: cells merged up an octree while
    /// their vertex stays within E cell widths of their tangent planes and the topology is kept
    /// (fewer vertices, crack-free); 0 (the default): uniform. Implies --no-manifold (adaptive dc
    /// is not manifold).
    #[arg(long, value_name = "E", allow_hyphen_values = true)]
    pub adaptivity: Option<String>,
    /// With --method emc: degrees between two crossings' normals above which a cell's loop is a
    /// feature and gets a vertex of its own (default 30).
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    pub feature_angle: Option<String>,
    /// Walk a sparse grid: a built-in field sampled only near its surface (blocks of 8³ points,
    /// memory growing with the surface; skipped boxes are proven empty with --lipschitz or the
    /// field's own bound), or a volume's blocks near the surface (the same mesh as without).
    /// Fields above 2^28 points are sampled sparsely anyway.
    #[arg(long)]
    pub sparse: bool,
    /// For fields: a bound L on how fast the value changes, |f(p) − f(q)| ≤ L·|p − q| in world
    /// units (1 for a signed distance); replaces the field's own. Without one, a field with no
    /// known bound is sampled at every point (memory still grows with the surface).
    #[arg(long, value_name = "L", allow_hyphen_values = true)]
    pub lipschitz: Option<String>,
    /// Surface following (implies --sparse): flood through the cells the surface crosses from a
    /// seed in every block that may be crossed (every component), or from --seed points only.
    #[arg(long)]
    pub follow: bool,
    /// Surface following from a world point inside the object wanted (X,Y,Z; repeatable): the
    /// first crossed cell marching +x from it seeds the flood. Implies --follow.
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub seed: Vec<String>,
    /// Level of the multiresolution pyramid: the lattice coarsened 2^L times (volumes: means of
    /// blocks of 2^L³ points; fields: sampled every 2^L points). 0 (default): full resolution.
    #[arg(long, value_name = "L", default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=12), allow_hyphen_values = true)]
    pub level: u32,
    /// Vertex normals: none (default, as VTK in the peer benchmarks) or gradient (unit normals
    /// from the field gradient, written to PLY and OBJ).
    #[arg(long, default_value = "none", value_name = "none|gradient")]
    pub normals: String,
    /// Write PLY as ASCII instead of binary.
    #[arg(long)]
    pub ascii: bool,
    /// Write {"seconds", "vertices", "triangles"} of the extraction (not reading or writing) here.
    #[arg(long, value_name = "FILE")]
    pub time_json: Option<PathBuf>,
    /// Benchmarking: extract N times in this process (the volume read once), report every run in
    /// --time-json as "runs" and keep the last mesh. Like a warm loop in VTK or scikit-image; each
    /// run's mesh is freed before the next, and the process keeps freed memory for reuse.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000), allow_hyphen_values = true)]
    pub repeat: u32,
    /// Memory budget (suffixes K, M, G): unless the volume and the largest mesh the method can
    /// make (and its check, with --require) fit, a volume is meshed slab by slab from the file
    /// (raw, NRRD, NIfTI, MetaImage, MRC, VTK) into any mesh format in O(nx·ny) memory, checked
    /// as it streams (4 bytes per vertex with --require); several isos write a file each, the
    /// file read once per iso (not into one glTF or OBJ file).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_memory: Option<String>,
    /// Check the mesh after extraction and exit 1 unless these hold (closed manifold oriented watertight no-degenerate no-self-intersections).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub require: Vec<String>,
    /// --smooth, --decimate and --max-error are applied to each mesh in memory after its
    /// extraction (before --attribute sampling and --require); a streamed extraction
    /// (--max-memory) refuses them: its triangles are written as they are made.
    #[command(flatten)]
    pub post: PostArgs,
}

#[derive(Debug, ClapArgs)]
pub struct SimplifyArgs {
    #[arg(value_name = "MESH", help = mesh_input_help())]
    pub mesh: PathBuf,
    #[arg(short = 'o', long = "output", value_name = "OUTPUT", help = output_help())]
    pub output: PathBuf,
    #[command(flatten)]
    pub post: PostArgs,
    /// Write PLY or STL as ASCII instead of binary.
    #[arg(long)]
    pub ascii: bool,
    /// Largest mesh the reader may allocate, in bytes (suffixes K, M, G accepted).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_bytes: Option<String>,
}

#[derive(Debug, ClapArgs)]
pub struct InfoArgs {
    /// Volume file or built-in field (as for `extract -i`), or a TopoMender skeleton (.skt):
    /// its records by type and weights.
    #[arg(value_name = "INPUT")]
    pub input: String,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, ClapArgs)]
pub struct ContourArgs {
    /// Image (.png .tif .tiff) or volume file (as for `extract -i`; raw with --dims/--dtype).
    /// Contours are in pixel indices, or in the units of --spacing/--origin when given.
    #[arg(value_name = "INPUT")]
    pub input: String,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Iso value.
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: String,
    /// Which side of iso is inside (contours wind counter-clockwise around it, y up): below or above.
    #[arg(long, value_name = "below|above", default_value = "below")]
    pub inside: String,
    /// Axis normal to the slice of a 3D volume.
    #[arg(long, value_name = "x|y|z", default_value = "z")]
    pub axis: String,
    /// Slice index along --axis (default: the middle slice; 0 for 2D images).
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub slice: Option<u32>,
    /// Saddle cells: decider (the bilinear interpolant decides), join-inside or join-outside
    /// (fixed rules; scikit-image's `fully_connected='low'` is join-inside for inside below).
    #[arg(long, value_name = "RULE", default_value = "decider")]
    pub saddle: String,
    /// Output (.svg .geojson .json .csv).
    #[arg(short = 'o', long, value_name = "OUT")]
    pub output: PathBuf,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
}

impl ContourArgs {
    pub fn input_args(&self) -> InputArgs {
        InputArgs { input: self.input.clone(), layout: self.layout.clone() }
    }
}

#[derive(Debug, ClapArgs)]
#[command(after_help = "\
Examples:
  isoforge convert ct.nrrd ct.vdb --iso 300           dense -> sparse (blocks near iso 300 kept)
  isoforge convert ct.vdb part.nrrd --region 0:64,0:64,10:20
  isoforge convert ct.mha ct.nii.gz                   dense -> dense

Dense -> .vdb keeps, as 8x8x8 leaves, every block within --band points of a cell the iso surface
crosses (inside <=> value < iso); other blocks become constant tiles of their side's extreme
value, the outside extreme being the background. Leaf points are active, tiles inactive: meshing
the .vdb at --iso gives the mesh of the dense volume closed at its faces (`extract --close`).
.vdb -> dense writes the samples of --region (the file's index space, half-open), by default the
bounding box of the active points; it is refused before anything is allocated when the region's
samples exceed --max-bytes.")]
pub struct ConvertArgs {
    /// Volume or image file (as for `extract -i`; raw with --dims/--dtype), or an OpenVDB .vdb.
    #[arg(value_name = "INPUT")]
    pub input: String,
    /// Output volume (.nrrd .nii .nii.gz), or .vdb (sparse; needs --iso).
    #[arg(value_name = "OUTPUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Dense -> .vdb: the iso whose surface the leaves follow (inside <=> value < V).
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<String>,
    /// Dense -> .vdb: points kept around each crossed cell (at least 3, the default).
    #[arg(long, value_name = "W", allow_hyphen_values = true)]
    pub band: Option<String>,
    /// .vdb -> dense: the index box I0:I1,J0:J1,K0:K1 (half-open; default: the active points' box).
    #[arg(long, value_name = "I0:I1,J0:J1,K0:K1", allow_hyphen_values = true)]
    pub region: Option<String>,
    /// The grid read from a .vdb input (default: its first float or double grid), or the name of
    /// the grid written to a .vdb output (default: "density", "surface" for a level set).
    #[arg(long, value_name = "NAME")]
    pub grid: Option<String>,
    /// .vdb output: the grid's class (unknown, level-set, fog-volume).
    #[arg(long = "class", value_name = "CLASS", default_value = "unknown")]
    pub grid_class: String,
}

impl ConvertArgs {
    pub fn input_args(&self) -> InputArgs {
        InputArgs { input: self.input.clone(), layout: self.layout.clone() }
    }
}

#[derive(Debug, ClapArgs)]
pub struct RenderArgs {
    #[arg(value_name = "INPUT", help = render_input_help())]
    pub input: String,
    /// Output picture (.png).
    #[arg(short = 'o', long, value_name = "OUT.png")]
    pub output: PathBuf,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Iso value for volumes (fields have a default).
    #[arg(long, value_name = "V", allow_hyphen_values = true)]
    pub iso: Option<String>,
    /// Which side of iso is inside: below or above.
    #[arg(long, value_name = "below|above")]
    pub inside: Option<String>,
    /// Extraction method for volumes and fields (as for extract).
    #[arg(long, default_value = "mc33", value_name = "mc33|mc|mt5|mt6|mt-bcc|surface-nets|dc")]
    pub method: String,
    /// Camera: iso (three-quarter), front or top.
    #[arg(long, default_value = "iso", value_name = "iso|front|top")]
    pub view: String,
    /// Picture size in pixels.
    #[arg(long, default_value = "1024x768", value_name = "WxH", allow_hyphen_values = true)]
    pub size: String,
    /// Face colouring: lambert (grey, lit) or normal (normal direction as RGB).
    #[arg(long, default_value = "lambert", value_name = "lambert|normal")]
    pub shading: String,
    /// Draw the triangle edges.
    #[arg(long)]
    pub wireframe: bool,
    /// Do not draw boundary and non-manifold edges in red.
    #[arg(long)]
    pub no_defects: bool,
}

impl RenderArgs {
    pub fn input_args(&self) -> InputArgs {
        InputArgs { input: self.input.clone(), layout: self.layout.clone() }
    }
}

#[derive(Debug, ClapArgs)]
pub struct ViewArgs {
    /// Volume or mesh file (nothing: the classic demo fields).
    #[arg(value_name = "INPUT")]
    pub input: Option<String>,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Port on 127.0.0.1 (0: any free port; the URL is printed).
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub port: u16,
    /// Which side of iso is inside for a volume: below or above.
    #[arg(long, value_name = "below|above", default_value = "below")]
    pub inside: String,
    /// Memory the meshes, checks and exports in flight may hold together (default 1 GiB); a
    /// request that does not fit waits, then gets 503 with Retry-After.
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_memory: Option<String>,
}

#[derive(Debug, ClapArgs)]
pub struct CheckArgs {
    #[arg(value_name = "MESH", help = mesh_input_help())]
    pub mesh: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Exit 1 unless these hold: closed, manifold, oriented, watertight, no-degenerate, no-self-intersections.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub require: Vec<String>,
    /// How many examples to list per finding.
    #[arg(long, default_value_t = 10, allow_hyphen_values = true)]
    pub examples: usize,
    /// Largest mesh the reader may allocate, in bytes (suffixes K, M, G accepted).
    #[arg(long, value_name = "BYTES", allow_hyphen_values = true)]
    pub max_bytes: Option<String>,
    /// Also report the Hausdorff distance to this mesh (each one's vertices to the other's
    /// surface, exact point–triangle distances, in world units).
    #[arg(long, value_name = "MESH")]
    pub reference: Option<PathBuf>,
    /// Also count the pairs of triangles that meet other than at the vertices or the edge they
    /// share (exact predicates; about doubles the check's time).
    #[arg(long)]
    pub self_intersections: bool,
}

#[derive(Debug, ClapArgs)]
pub struct DemoArgs {
    /// Output mesh.
    #[arg(short = 'o', long = "output", default_value = "demo.ply")]
    pub output: PathBuf,
    /// Points per axis.
    #[arg(long, default_value_t = 64, allow_hyphen_values = true)]
    pub n: u32,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

impl InfoArgs {
    /// The input options in the shape `extract` uses.
    pub fn input_args(&self) -> InputArgs {
        InputArgs { input: self.input.clone(), layout: self.layout.clone() }
    }
}

/// A usage error from the parser as one line, like every error isoforge raises itself: clap's
/// message and tips without its usage block ("unexpected argument '--is' found; tip: a similar
/// argument exists: '--iso'"). Lists (the missing required arguments) join with commas.
pub fn usage_error_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let mut parts: Vec<String> = Vec::new();
    for paragraph in text.split("\n\n") {
        let mut lines = paragraph.lines().map(str::trim).filter(|l| !l.is_empty());
        let Some(first) = lines.next() else { continue };
        if first.starts_with("Usage:") || first.starts_with("For more information") {
            continue;
        }
        let rest: Vec<&str> = lines.collect();
        let first = first.strip_prefix("error: ").unwrap_or(first);
        parts.push(if rest.is_empty() { first.to_owned() } else { format!("{first} {}", rest.join(", ")) });
    }
    format!("{} (see --help)", parts.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Options whose values are names, paths or lists of names (not numbers).
    const NOT_NUMERIC: &[&str] = &[
        "input",
        "skeleton",
        "reference",
        "grid_out",
        "grid",
        "grid_class",
        "output",
        "dtype",
        "endian",
        "mask",
        "attribute",
        "color_by",
        "color_volume",
        "colormap",
        "world",
        "space",
        "inside",
        "method",
        "normals",
        "time_json",
        "require",
        "axis",
        "saddle",
        "view",
        "shading",
        "mesh",
        "values",
        "smooth",
    ];

    // Issue 10: `--origin -10,0,0` was taken for an unknown option.
    #[test]
    fn issue_10_every_numeric_option_takes_negative_values() {
        let root = Args::command();
        let mut checked = 0;
        for cmd in std::iter::once(&root).chain(root.get_subcommands()) {
            for arg in cmd.get_arguments() {
                let takes_value = arg.get_num_args().is_none_or(|n| n.takes_values());
                if arg.is_positional() || !takes_value || NOT_NUMERIC.contains(&arg.get_id().as_str()) {
                    continue;
                }
                if matches!(
                    arg.get_action(),
                    clap::ArgAction::SetTrue | clap::ArgAction::Help | clap::ArgAction::Version
                ) {
                    continue;
                }
                assert!(
                    arg.is_allow_hyphen_values_set(),
                    "{} --{}: a numeric option must accept values starting with '-'",
                    cmd.get_name(),
                    arg.get_id()
                );
                checked += 1;
            }
        }
        assert!(checked >= 20, "only {checked} numeric options seen");
    }
}
