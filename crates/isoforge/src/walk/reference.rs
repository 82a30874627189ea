use std::collections::HashMap;

use super::segment;
use super::{
    cell_crossing, edge_crossing, edge_hermite, push_edge_vertex, wants_cell, Cell, Hermite, WalkStats, Walker,
};
use crate::cube::{case_of, CellPoint, CubeEdge, EdgeKey, SegmentKey, CORNER_OFFSETS};
use crate::error::{Error, Result};
use crate::extract::{Extractor, Placed};
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// The test oracle walker: no caches. For every cell it refills the two slabs it needs and
/// recomputes each crossing; vertices are joined by [`EdgeKey`] in a map, and a recomputed
/// crossing that differs from the first one (by a single bit) is reported as an internal error.
///
/// Slow by design (O(cells · nx · ny)); use it on small lattices only.
#[derive(Debug, Default)]
pub struct ReferenceWalker;

impl<V: Volume> Walker<V> for ReferenceWalker {
    fn walk<X: Extractor + Sync>(&mut self, vol: &V, iso: Iso, x: &X, out: &mut MeshBuilder) -> Result<WalkStats> {
        let lattice = vol.lattice().clone();
        if !lattice.has_cells() {
            return Ok(WalkStats::default());
        }
        out.set_reverse_winding(lattice.is_mirrored());
        let [nx, ny, nz] = lattice.dims();
        let mut keyed = Keyed::default();
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let (mut s0, mut s1) = (vec![0.0; lattice.slab_len()], vec![0.0; lattice.slab_len()]);
                    vol.fill_slab(k, iso, &mut s0);
                    vol.fill_slab(k + 1, iso, &mut s1);
                    let d = CORNER_OFFSETS.map(|o| {
                        let s = if o[2] == 0 { &s0 } else { &s1 };
                        s[(j + o[1]) as usize * nx as usize + (i + o[0]) as usize]
                    });
                    keyed.visit(vol, iso, x, [i, j, k], d, out);
                }
            }
        }
        keyed.finish()
    }
}

/// Walks exactly `cells` of `vol` (sorted (z, y, x), each once) with `x` at `iso`, as the
/// reference walker does (values from [`Volume::value_at_point`] at the corners, vertices joined
/// by key in maps) but computing each crossing once: what surface following walks, the cells it
/// found.
///
/// # Errors
/// [`Error::Internal`] when a crossing is not reproducible.
pub(crate) fn walk_cells<V: Volume + ?Sized, X: Extractor>(
    vol: &V,
    iso: Iso,
    x: &X,
    cells: &[[u32; 3]],
    out: &mut MeshBuilder,
) -> Result<WalkStats> {
    out.set_reverse_winding(vol.lattice().is_mirrored());
    // A vertex's crossing is computed once: the oracle's check that it reproduces is the
    // reference walker's business, not the flood's (a lookup instead of a root refinement).
    let mut keyed = Keyed { trust: true, ..Keyed::default() };
    for &c in cells {
        let d = CORNER_OFFSETS.map(|o| vol.value_at_point([0, 1, 2].map(|a| c[a] + o[a]), iso));
        keyed.visit(vol, iso, x, c, d, out);
    }
    keyed.finish()
}

/// Vertices placed per cell: `(vertex, edge mask, world position)`.
type PlacedMap = HashMap<[u32; 3], Vec<(VertexId, u16, [f32; 3])>, Fast>;

/// The maps' hasher: lattice keys need no DoS resistance.
type Fast = std::hash::BuildHasherDefault<crate::math::KeyHasher>;

/// The maps of a walk without caches: vertices by key, placed vertices by cell.
#[derive(Default)]
struct Keyed {
    ids: HashMap<EdgeKey, (VertexId, [f32; 3]), Fast>,
    seg_ids: HashMap<SegmentKey, (VertexId, [f32; 3]), Fast>,
    placed: PlacedMap,
    mismatch: Option<String>,
    stats: WalkStats,
    /// Whether a vertex met again is taken by its key alone (no recomputed crossing to compare).
    trust: bool,
}

impl Keyed {
    /// Cell `ijk` with offset values `d`: counted, and handed to `x` when it wants it.
    fn visit<V: Volume + ?Sized, X: Extractor>(
        &mut self,
        vol: &V,
        iso: Iso,
        x: &X,
        ijk: [u32; 3],
        d: [f32; 8],
        out: &mut MeshBuilder,
    ) {
        let case = case_of(&d);
        self.stats.cells += 1;
        match case {
            0 => self.stats.cells_outside += 1,
            255 => self.stats.cells_inside += 1,
            _ => {}
        }
        if wants_cell(x, case) {
            let mut cell = RefCell {
                ijk,
                dims: vol.lattice().dims(),
                d,
                case,
                vol,
                iso,
                ids: &mut self.ids,
                seg_ids: &mut self.seg_ids,
                placed: &mut self.placed,
                n_placed: 0,
                memo: [f32::NAN; 7],
                out,
                mismatch: &mut self.mismatch,
                trust: self.trust,
            };
            x.place(&mut cell);
            x.process(&mut cell);
        }
    }

    fn finish(self) -> Result<WalkStats> {
        match self.mismatch {
            Some(key) => Err(Error::Internal(format!("crossing on {key} is not reproducible"))),
            None => Ok(self.stats),
        }
    }
}

struct RefCell<'a, V: ?Sized> {
    ijk: [u32; 3],
    dims: [u32; 3],
    d: [f32; 8],
    case: u8,
    vol: &'a V,
    iso: Iso,
    ids: &'a mut HashMap<EdgeKey, (VertexId, [f32; 3]), Fast>,
    seg_ids: &'a mut HashMap<SegmentKey, (VertexId, [f32; 3]), Fast>,
    placed: &'a mut PlacedMap,
    n_placed: u8,
    memo: [f32; 7],
    out: &'a mut MeshBuilder,
    mismatch: &'a mut Option<String>,
    trust: bool,
}

impl<V: Volume + ?Sized> Cell for RefCell<'_, V> {
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    fn values(&self) -> &[f32; 8] {
        &self.d
    }
    fn case(&self) -> u8 {
        self.case
    }
    fn hermite(&mut self, e: CubeEdge) -> Hermite {
        let [c0, c1] = e.corners();
        edge_hermite(self.vol, EdgeKey::of_cell(self.ijk, e), self.d[c0 as usize], self.d[c1 as usize], self.iso)
            .on_edge(e)
    }
    fn crossing(&mut self, e: CubeEdge) -> [f32; 3] {
        cell_crossing(self.vol, self.ijk, e, &self.d, self.iso)
    }
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let (d0, d1) = (self.d[c0 as usize], self.d[c1 as usize]);
        if let Some(&(id, first)) = self.ids.get(&key) {
            if !self.trust {
                let (p, _) = edge_crossing(self.vol, key, d0, d1, self.iso);
                if p.map(f32::to_bits) != first.map(f32::to_bits) {
                    *self.mismatch = Some(format!("{key:?}"));
                }
            }
            return id;
        }
        // The crossing kept to compare with later computations (none when trusted).
        let p = if self.trust { [0.0; 3] } else { edge_crossing(self.vol, key, d0, d1, self.iso).0 };
        let id = push_edge_vertex(self.vol, key, d0, d1, self.iso, self.out);
        self.ids.insert(key, (id, p));
        id
    }
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        self.out.push_triangle(t);
    }
    fn has_neighbour(&self, face: u8) -> bool {
        segment::has_neighbour(self.dims, self.ijk, face)
    }
    fn point_value(&mut self, p: CellPoint) -> f32 {
        segment::point_value(self.vol, self.iso, self.ijk, &self.d, &mut self.memo, p)
    }
    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        if let Some(e) = CellPoint::axis_edge(a, b) {
            return self.edge_vertex(e);
        }
        let (vol, iso) = (self.vol, self.iso);
        let (key, d0, d1) = segment::cell_segment(vol, iso, self.ijk, &self.d, &mut self.memo, (a, b));
        let point = || segment::world_point(vol, segment::segment_point(vol, key, d0, d1, iso));
        if let Some(&(id, first)) = self.seg_ids.get(&key) {
            if !self.trust && point().map(f32::to_bits) != first.map(f32::to_bits) {
                *self.mismatch = Some(format!("{key:?}"));
            }
            return id;
        }
        let p = if self.trust { [0.0; 3] } else { point() };
        let id = segment::push_segment_vertex(vol, key, d0, d1, iso, self.out);
        self.seg_ids.insert(key, (id, p));
        id
    }
    fn place_vertex(&mut self, local: [f32; 3], edges: u16) -> VertexId {
        let n = self.n_placed;
        self.n_placed += 1;
        let (id, w) = segment::push_cell_vertex(self.vol, self.iso, self.ijk, n, local, self.out);
        self.placed.entry(self.ijk).or_default().push((id, edges, w));
        id
    }
    fn placed(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<Placed> {
        let key = EdgeKey::of_cell(self.ijk, e);
        let cell = segment::neighbour(self.ijk, offset)?;
        let ne = key.in_cell(cell)?;
        let entries = self.placed.get(&cell)?;
        entries.iter().find(|(_, m, _)| m & (1 << ne.0) != 0).map(|&(vertex, edges, point)| Placed {
            vertex,
            point,
            edges,
        })
    }
    fn push_quad(&mut self, q: [VertexId; 4]) {
        self.out.push_quad(q);
    }
}
