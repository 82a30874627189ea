//! Raw command-line arguments (clap). Converted once into a validated `Config` by `config.rs`.

use std::path::PathBuf;

use clap::{Args as ClapArgs, Parser, Subcommand};

/// isoforge: turn volumes into meshes.
#[derive(Debug, Parser)]
#[command(name = "isoforge", version, about, long_about = None)]
pub struct Args {
    /// Worker threads for every command (default: all cores). Output does not depend on it.
    #[arg(long, global = true, value_name = "N")]
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
}

/// Where the volume comes from (`extract -i INPUT`).
#[derive(Debug, ClapArgs)]
pub struct InputArgs {
    /// Volume file (.nrrd .nhdr .nii .nii.gz .mha .mhd, or raw with --dims/--dtype) or a
    /// built-in field such as `field:gyroid?n=128` (fields: sphere torus box gyroid metaballs lines height).
    #[arg(short = 'i', long = "input", value_name = "INPUT")]
    pub input: String,
    #[command(flatten)]
    pub layout: LayoutArgs,
}

/// How to read the input: the layout of raw files, and the allocation limit.
#[derive(Debug, Clone, ClapArgs)]
pub struct LayoutArgs {
    /// Raw input: points per axis, x fastest.
    #[arg(long, value_name = "X,Y,Z")]
    pub dims: Option<String>,
    /// Raw input: sample type (u8 i8 u16 i16 u32 i32 f32 f64).
    #[arg(long, value_name = "TYPE")]
    pub dtype: Option<String>,
    /// Raw input: byte order.
    #[arg(long, value_name = "little|big")]
    pub endian: Option<String>,
    /// Raw input: bytes to skip before the samples.
    #[arg(long, value_name = "N")]
    pub header_bytes: Option<u64>,
    /// Raw input: spacing between points (default 1: voxel-index units).
    #[arg(long, value_name = "SX,SY,SZ")]
    pub spacing: Option<String>,
    /// Raw input: world position of the first point.
    #[arg(long, value_name = "OX,OY,OZ")]
    pub origin: Option<String>,
    /// Largest volume or mesh a reader may allocate, in bytes (suffixes K, M, G accepted).
    #[arg(long, value_name = "BYTES")]
    pub max_bytes: Option<String>,
}

#[derive(Debug, ClapArgs)]
pub struct ExtractArgs {
    #[command(flatten)]
    pub input: InputArgs,
    /// Output mesh (.ply .obj .stl .off).
    #[arg(short = 'o', long = "output", value_name = "OUTPUT")]
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
    #[arg(long, value_name = "I0:I1,J0:J1,K0:K1")]
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
    /// Extraction method: mc (classic marching cubes, parallel Flying Edges on grids), mc33
    /// (topology of the trilinear interpolant), mt5 / mt6 / mt-bcc (marching tetrahedra with 5, 6
    /// or body-centred tetrahedra per cell).
    #[arg(long, default_value = "mc", value_name = "mc|mc33|mt5|mt6|mt-bcc")]
    pub method: String,
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
    /// --time-json as "runs" and keep the last mesh. Like a warm loop in VTK or scikit-image.
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    /// Memory budget (suffixes K, M, G): a volume whose in-memory extraction would not fit is
    /// meshed slab by slab from the file (raw, NRRD, NIfTI, MetaImage; binary PLY output), using
    /// O(nx·ny) memory.
    #[arg(long, value_name = "BYTES")]
    pub max_memory: Option<String>,
    /// Check the mesh after extraction and exit 1 unless these hold (closed manifold oriented watertight no-degenerate).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub require: Vec<String>,
}

#[derive(Debug, ClapArgs)]
pub struct InfoArgs {
    /// Volume file or built-in field (as for `extract -i`).
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
    #[arg(value_name = "INPUT")]
    pub input: String,
    #[command(flatten)]
    pub layout: LayoutArgs,
    /// Iso value.
    #[arg(long, value_name = "V")]
    pub iso: String,
    /// Which side of iso is inside (contours wind counter-clockwise around it, y up): below or above.
    #[arg(long, value_name = "below|above", default_value = "below")]
    pub inside: String,
    /// Axis normal to the slice of a 3D volume.
    #[arg(long, value_name = "x|y|z", default_value = "z")]
    pub axis: String,
    /// Slice index along --axis (default: the middle slice; 0 for 2D images).
    #[arg(long, value_name = "K")]
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
pub struct ConvertArgs {
    /// Volume or image file (as for `extract -i`; raw with --dims/--dtype).
    #[arg(value_name = "INPUT")]
    pub input: String,
    /// Output volume (.nrrd .nii .nii.gz).
    #[arg(value_name = "OUTPUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub layout: LayoutArgs,
}

impl ConvertArgs {
    pub fn input_args(&self) -> InputArgs {
        InputArgs { input: self.input.clone(), layout: self.layout.clone() }
    }
}

#[derive(Debug, ClapArgs)]
pub struct RenderArgs {
    /// Mesh (.ply .obj .stl .off) or volume/field (as for `extract -i`).
    #[arg(value_name = "INPUT")]
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
    /// Extraction method for volumes and fields.
    #[arg(long, default_value = "mc", value_name = "mc|mc33|mt5|mt6|mt-bcc")]
    pub method: String,
    /// Camera: iso (three-quarter), front or top.
    #[arg(long, default_value = "iso", value_name = "iso|front|top")]
    pub view: String,
    /// Picture size in pixels.
    #[arg(long, default_value = "1024x768", value_name = "WxH")]
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
    #[arg(long, default_value_t = 0)]
    pub port: u16,
    /// Which side of iso is inside for a volume: below or above.
    #[arg(long, value_name = "below|above", default_value = "below")]
    pub inside: String,
}

#[derive(Debug, ClapArgs)]
pub struct CheckArgs {
    /// Mesh file (.ply .obj .stl .off).
    #[arg(value_name = "MESH")]
    pub mesh: PathBuf,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Exit 1 unless these hold: closed, manifold, oriented, watertight, no-degenerate.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub require: Vec<String>,
    /// How many examples to list per finding.
    #[arg(long, default_value_t = 10)]
    pub examples: usize,
    #[arg(long, value_name = "BYTES")]
    pub max_bytes: Option<String>,
}

#[derive(Debug, ClapArgs)]
pub struct DemoArgs {
    /// Output mesh.
    #[arg(short = 'o', long = "output", default_value = "demo.ply")]
    pub output: PathBuf,
    /// Points per axis.
    #[arg(long, default_value_t = 64)]
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
