//! The memory plan: whether an extraction fits a memory budget in memory, must stream slab by
//! slab, or cannot run within it. Worst cases from the lattice and the method alone (the real
//! mesh is not known before the walk), so a budget holds whatever the data.

use std::fmt;

use super::{Method, Options};
use crate::extract::Counting;
use crate::grid::{AnySparse, Lattice};
use crate::volume::{Iso, Tabulated};

/// Most vertices per lattice point and triangles per cell of any method: body-centred
/// tetrahedra make one vertex per segment (3 axis edges per point, 8 centre–corner and 3
/// centre–centre segments per cell) and have 12 tetrahedra per cell with up to 2 triangles each.
pub const ANY_METHOD_MESH: (u64, u64) = (14, 24);
/// Marching cubes: one vertex per crossed axis edge (3 per point), and at most 5 triangles per
/// cell (the classic table's largest cases).
pub const MC_MESH: (u64, u64) = (3, 5);
/// Bytes `topo::check` holds per triangle (its edge, fan and triple lists and per-triangle ids)
/// and per vertex (union-find, flags), rounded up.
pub const CHECK_BYTES: (u64, u64) = (112, 12);
/// Flying Edges' row tables, buffers and the allocator's slack.
pub const SLACK: u64 = 64 << 20;
/// The file buffers a stream holds whatever the volume (measured with heaptrack on a streamed
/// PLY): the reader's (1 MiB), the writer's two parts (1 MiB each) and its gathered faces (up to
/// 2 MiB).
pub const STREAM_BUFFERS: u64 = 5 << 20;

/// A memory budget and what decides whether an extraction fits it in memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryPlan {
    /// The budget in bytes.
    pub bytes: u64,
    /// The method (marching cubes' meshes are bounded tighter than the others').
    pub method: Method,
    /// The walk grows per-slab meshes and stitches them (uncounted methods, any mask): about
    /// twice the mesh at its peak.
    pub grows: bool,
    /// Vertex normals are kept (12 more bytes a vertex).
    pub normals: bool,
    /// The in-memory mesh is checked (`topo::check`) too.
    pub check: bool,
    /// Fields sampled sparsely (memory follows the surface, unknown before sampling).
    pub sparse: bool,
}

/// How a volume is meshed within a [`MemoryPlan`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fit {
    /// In memory: the worst case fits.
    InMemory,
    /// Slab by slab: the worst case in memory does not fit, the stream's minimum does.
    Stream,
}

/// Why a volume cannot be meshed within a [`MemoryPlan`]; the numbers for the front end's message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refusal {
    /// A field sampled sparsely: its memory is not known before sampling.
    SparseField {
        /// Lattice points.
        points: u64,
    },
    /// A field (fields do not stream) needs more in memory.
    Field {
        /// Bytes it can need.
        need: u64,
        /// Lattice points.
        points: u64,
    },
    /// A volume read whole (it cannot stream) needs more in memory.
    ReadWhole {
        /// Bytes it can need.
        need: u64,
    },
    /// Even the stream's slabs and buffers exceed the budget.
    Stream {
        /// Bytes a stream holds at least.
        least: u64,
        /// Points of a slab along x and y.
        slab: [u32; 2],
    },
    /// A sparse grid (meshed in memory) needs more.
    Sparse {
        /// Bytes it can need.
        need: u64,
    },
}

impl MemoryPlan {
    /// The plan for `bytes` and `options` (`masked`: a mask walks by growing meshes; `check`:
    /// the mesh is checked in memory too).
    pub fn new(bytes: u64, options: &Options, masked: bool, check: bool) -> MemoryPlan {
        MemoryPlan {
            bytes,
            method: options.method,
            grows: options.method.counting() == Counting::Unknown || masked,
            normals: options.normals == crate::mesh::Normals::Gradient,
            check,
            sparse: options.sparse == Some(true) || options.follow.is_some(),
        }
    }

    /// Peak memory an in-memory extraction of samples taking `volume_bytes` on `l` could need:
    /// the samples, one bit per point, slack, and the largest mesh the method can make (twice
    /// that for the methods that grow their mesh as they go), plus `topo::check` of it with
    /// `check`. The real mesh is usually far smaller, but it is not known before the walk.
    pub fn in_memory(&self, l: &Lattice, volume_bytes: u64) -> u64 {
        let cells = l.dims().iter().map(|&d| u64::from(d.saturating_sub(1))).product::<u64>();
        self.for_cells(l.num_points(), cells, volume_bytes)
    }

    /// The memory an in-memory extraction of `cells` cells and `points` points, whose samples
    /// take `volume_bytes`, can need at most.
    pub fn for_cells(&self, points: u64, cells: u64, volume_bytes: u64) -> u64 {
        let ((per_point, per_cell), growth) = (
            if self.method == Method::MarchingCubes { MC_MESH } else { ANY_METHOD_MESH },
            if self.grows { 2 } else { 1 },
        );
        let (vertices, triangles) = (per_point.saturating_mul(points), per_cell.saturating_mul(cells));
        let vertex_bytes = if self.normals { 24 } else { 12 };
        let mesh =
            vertices.saturating_mul(vertex_bytes).saturating_add(triangles.saturating_mul(12)).saturating_mul(growth);
        let check = if self.check {
            triangles.saturating_mul(CHECK_BYTES.0).saturating_add(vertices.saturating_mul(CHECK_BYTES.1))
        } else {
            0
        };
        volume_bytes.saturating_add(points / 8).saturating_add(SLACK).saturating_add(mesh).saturating_add(check)
    }

    /// The memory meshing the sparse grid `g` at `iso` in memory can need at most: its samples
    /// and the largest mesh the method could make in the blocks of cells the surface may cross.
    pub fn sparse(&self, g: &AnySparse, iso: Iso) -> u64 {
        let ranges = match g {
            AnySparse::F32(g) => g.active_ranges_in(iso, true, 1),
            AnySparse::F64(g) => g.active_ranges_in(iso, true, 1),
        };
        let count = |extra: u32| -> u64 {
            ranges.iter().map(|r| (0..3).map(|a| u64::from(r.hi[a] - r.lo[a] + extra)).product::<u64>()).sum()
        };
        self.for_cells(count(1), count(0), g.stats().bytes)
    }

    /// Whether a field on `lattice` fits: fields do not stream, so its table of values (4 bytes
    /// a point) and the largest mesh must fit; a field sampled sparsely is refused (its memory
    /// follows a surface not known before sampling).
    ///
    /// # Errors
    /// [`Refusal::SparseField`] or [`Refusal::Field`].
    pub fn field(&self, lattice: &Lattice) -> Result<(), Refusal> {
        let points = lattice.num_points();
        if self.sparse || points > Tabulated::MAX_POINTS {
            return Err(Refusal::SparseField { points });
        }
        let need = self.in_memory(lattice, points.saturating_mul(4));
        if need > self.bytes {
            return Err(Refusal::Field { need, points });
        }
        Ok(())
    }

    /// How a volume of `volume_bytes` samples (`sample_bytes` each) on `lattice` is meshed:
    /// in memory when its worst case fits, else slab by slab when `streams` (its reader can) and
    /// the stream's minimum fits.
    ///
    /// # Errors
    /// [`Refusal::ReadWhole`] (it cannot stream) or [`Refusal::Stream`].
    pub fn volume(
        &self,
        lattice: &Lattice,
        volume_bytes: u64,
        sample_bytes: u64,
        streams: bool,
    ) -> Result<Fit, Refusal> {
        let need = self.in_memory(lattice, volume_bytes);
        if need <= self.bytes {
            return Ok(Fit::InMemory);
        }
        if !streams {
            return Err(Refusal::ReadWhole { need });
        }
        let least = stream_minimum(lattice, sample_bytes);
        if least > self.bytes {
            let [nx, ny, _] = lattice.dims();
            return Err(Refusal::Stream { least, slab: [nx, ny] });
        }
        Ok(Fit::Stream)
    }

    /// Whether meshing the sparse grid `g` at every iso of `isos` fits.
    ///
    /// # Errors
    /// [`Refusal::Sparse`] with the largest need.
    pub fn sparse_isos(&self, g: &AnySparse, isos: &[Iso]) -> Result<(), Refusal> {
        let need = isos.iter().map(|&iso| self.sparse(g, iso)).max().unwrap_or(0);
        if need > self.bytes {
            return Err(Refusal::Sparse { need });
        }
        Ok(())
    }
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Refusal::SparseField { points } => write!(
                f,
                "a field sampled sparsely ({points} points) uses memory that follows its surface, which is not \
                 known before sampling"
            ),
            Refusal::Field { need, points } => {
                write!(
                    f,
                    "meshing the field ({points} values) in memory can need {}, and fields do not stream",
                    Size(need)
                )
            }
            Refusal::ReadWhole { need } => {
                write!(f, "the volume is read whole, and with the largest mesh it can need {}", Size(need))
            }
            Refusal::Stream { least, slab: [nx, ny] } => {
                write!(f, "streaming it slab by slab ({nx}×{ny} points) holds at least {} before any mesh", Size(least))
            }
            Refusal::Sparse { need } => write!(f, "the sparse grid meshed in memory can need {}", Size(need)),
        }
    }
}

/// The least memory a streamed extraction of a volume on `lattice` with samples of
/// `sample_bytes` holds whatever the data: its slabs of samples (the walker's five and the
/// read-ahead's four), three planes of bits and two of row counts, and the files' buffers; the
/// slabs' meshes come on top, as large as the surface makes them.
pub fn stream_minimum(lattice: &Lattice, sample_bytes: u64) -> u64 {
    let [nx, ny, _] = lattice.dims().map(u64::from);
    let samples = (nx * ny).saturating_mul(sample_bytes).saturating_mul(9);
    let bits = 3 * ny * nx.div_ceil(64) * 8;
    let rows = 2 * ny * 40;
    samples.saturating_add(bits).saturating_add(rows).saturating_add(STREAM_BUFFERS)
}

/// A byte count for a message: in KiB below 1 MiB, in MiB below 10 GiB, else in GiB (rounded up).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Size(pub u64);

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            b if b < 1 << 20 => write!(f, "{} KiB", b.div_ceil(1 << 10)),
            b if b < 10 << 30 => write!(f, "{} MiB", b.div_ceil(1 << 20)),
            b => write!(f, "{} GiB", b.div_ceil(1 << 30)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{AnyGrid, DenseGrid};

    /// The per-point and per-cell maxima budgets are planned with hold for every method on
    /// random lattices with ties (seeded), with and without an outside border.
    #[test]
    fn issue_10_mesh_bounds_hold_for_every_method() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let levels = [-2.0f32, -1.0, -0.5, 0.0, 0.25, 1.0, 3.0];
        for case in 0..300 {
            let dims = [2 + next() % 5, 2 + next() % 5, 2 + next() % 5].map(|d| d as u32);
            let border = case % 2 == 0;
            let values: Vec<f32> = (0..dims.iter().product::<u32>()).map(|_| levels[(next() % 7) as usize]).collect();
            let inner = Lattice::new(dims).unwrap();
            let outer = if border { dims.map(|d| d + 2) } else { dims };
            let g = DenseGrid::from_fn(Lattice::new(outer).unwrap(), |p| {
                if !border {
                    values[inner.linear(p)]
                } else if p.iter().zip(dims).all(|(&x, d)| x >= 1 && x <= d) {
                    values[inner.linear([p[0] - 1, p[1] - 1, p[2] - 1])]
                } else {
                    5.0
                }
            });
            let g = AnyGrid::from(g);
            let points = g.lattice().num_points();
            let cells: u64 = outer.iter().map(|&d| u64::from(d - 1)).product();
            for method in Method::ALL {
                let opts = Options { method, ..Default::default() };
                let m = super::super::extract_grid(&g, Iso::below(0.1), &opts, None).unwrap().mesh;
                let (per_point, per_cell) = if method == Method::MarchingCubes { MC_MESH } else { ANY_METHOD_MESH };
                assert!(
                    m.num_vertices() as u64 <= per_point * points,
                    "{}: {} vertices",
                    method.name(),
                    m.num_vertices()
                );
                assert!(
                    m.num_triangles() as u64 <= per_cell * cells,
                    "{}: {} triangles",
                    method.name(),
                    m.num_triangles()
                );
            }
        }
        // Marching cubes' largest case.
        let most = (0..256).map(|c| crate::extract::marching_cubes::TRI_TABLE[c].triangles().len()).max();
        assert_eq!(most, Some(MC_MESH.1 as usize));
    }

    #[test]
    fn a_volume_fits_in_memory_streams_or_is_refused() {
        let l = Lattice::new([100, 100, 100]).unwrap();
        let plan = |bytes| MemoryPlan::new(bytes, &Options::default(), false, false);
        let need = plan(0).in_memory(&l, 4_000_000);
        assert_eq!(plan(need).volume(&l, 4_000_000, 4, true), Ok(Fit::InMemory));
        assert_eq!(plan(need - 1).volume(&l, 4_000_000, 4, true), Ok(Fit::Stream));
        assert_eq!(plan(need - 1).volume(&l, 4_000_000, 4, false), Err(Refusal::ReadWhole { need }));
        let least = stream_minimum(&l, 4);
        assert_eq!(least, 9 * 100 * 100 * 4 + 3 * 100 * 2 * 8 + 2 * 100 * 40 + STREAM_BUFFERS);
        assert_eq!(plan(least - 1).volume(&l, 4_000_000, 4, true), Err(Refusal::Stream { least, slab: [100, 100] }));
        // Normals, a check and a growing walk only add.
        let more = MemoryPlan { normals: true, check: true, grows: true, ..plan(0) };
        assert!(more.in_memory(&l, 4_000_000) > need);
    }

    #[test]
    fn sizes_read_in_the_largest_sensible_unit() {
        assert_eq!(Size(1).to_string(), "1 KiB");
        assert_eq!(Size(1 << 20).to_string(), "1 MiB");
        assert_eq!(Size((10 << 30) + 1).to_string(), "11 GiB");
    }
}
