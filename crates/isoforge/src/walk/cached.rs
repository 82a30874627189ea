//! The caches of a walker that advances one cell layer at a time, and the [`Cell`] they back.
//!
//! ```text
//!   plane k+1:  x_ids[1], y_ids[1]          z_ids[(j, i)]: edge (i, j, k) → (i, j, k+1)
//!   plane k:    x_ids[0], y_ids[0]          placed[1]: vertices placed by cells of layer k,
//!                                           placed[0]: by cells of layer k − 1
//!   after layer k: ids[1] → ids[0], placed[1] → placed[0], fresh slots above
//! ```
//! Slots are indexed by a point's (i, j) relative to the cached box, whose first point is
//! `origin`: dense arrays, no hashing, except for segments off the axis edges (two generations
//! of hash maps, [`SegmentCache`]). Every vertex is created once, by the first cell that asks.

use super::segment::{self, SegmentCache};
use super::{edge_hermite, push_edge_vertex, Cell, Hermite};
use crate::cube::{Axis, CellPoint, CubeEdge, EdgeKey};
use crate::mesh::{MeshBuilder, VertexId};
use crate::volume::{Iso, Volume};

/// Vertices placed by one layer of cells: for each cell its entries `(vertex, edge mask)`.
#[derive(Debug, Default)]
struct Placed {
    start: Vec<u32>,
    count: Vec<u8>,
    entries: Vec<(VertexId, u16)>,
}

impl Placed {
    fn reset(&mut self, n: usize) {
        self.start.clear();
        self.start.resize(n, 0);
        self.count.clear();
        self.count.resize(n, 0);
        self.entries.clear();
    }

    fn of(&self, cell: usize) -> &[(VertexId, u16)] {
        let (s, c) = (self.start[cell] as usize, self.count[cell] as usize);
        &self.entries[s..s + c]
    }
}

/// Per-layer caches over a box of `w × h` points starting at global `(origin[0], origin[1])`.
#[derive(Debug, Default)]
pub(crate) struct LayerCaches {
    origin: [u32; 2],
    w: usize,
    x_ids: [Vec<VertexId>; 2],
    y_ids: [Vec<VertexId>; 2],
    z_ids: Vec<VertexId>,
    segs: SegmentCache,
    /// Only used by extractors that place vertices (sized on first use).
    placed: [Placed; 2],
    /// Hermite data per edge slot, like the ids (allocated on the first request).
    hermite: Option<Box<HermiteSlots>>,
}

#[derive(Debug)]
struct HermiteSlots {
    x: [Vec<Hermite>; 2],
    y: [Vec<Hermite>; 2],
    z: Vec<Hermite>,
}

const NO_HERMITE: Hermite = Hermite { point: [f32::NAN; 3], normal: [0.0; 3] };

impl LayerCaches {
    /// Empty caches for the box of `w × h` points from `origin`.
    pub(crate) fn reset(&mut self, origin: [u32; 2], w: usize, h: usize, places: bool) {
        let n = w * h;
        self.origin = origin;
        self.w = w;
        for ids in self.x_ids.iter_mut().chain(self.y_ids.iter_mut()).chain(std::iter::once(&mut self.z_ids)) {
            ids.clear();
            ids.resize(n, VertexId::NONE);
        }
        self.segs.clear();
        if places {
            self.placed[0].reset(n);
            self.placed[1].reset(n);
        }
        self.hermite = None;
    }

    /// After a layer of cells: the top plane becomes the bottom one, fresh slots above.
    pub(crate) fn advance(&mut self, places: bool) {
        self.x_ids.swap(0, 1);
        self.y_ids.swap(0, 1);
        self.x_ids[1].fill(VertexId::NONE);
        self.y_ids[1].fill(VertexId::NONE);
        self.z_ids.fill(VertexId::NONE);
        self.segs.advance();
        if places {
            self.placed.swap(0, 1);
            let n = self.z_ids.len();
            self.placed[1].reset(n);
        }
        if let Some(h) = &mut self.hermite {
            h.x.swap(0, 1);
            h.y.swap(0, 1);
            h.x[1].fill(NO_HERMITE);
            h.y[1].fill(NO_HERMITE);
            h.z.fill(NO_HERMITE);
        }
    }

    #[inline]
    fn slot(&self, ijk: [u32; 3], e: CubeEdge) -> (Axis, usize, usize) {
        let (i, j) = ((ijk[0] - self.origin[0]) as usize, (ijk[1] - self.origin[1]) as usize);
        // r = e % 4 gives the edge's offsets on the two other axes (see cube/mod.rs).
        let (lo, hi) = ((e.0 & 1) as usize, ((e.0 >> 1) & 1) as usize);
        match e.axis() {
            Axis::X => (Axis::X, hi, (j + lo) * self.w + i),
            Axis::Y => (Axis::Y, hi, j * self.w + i + lo),
            Axis::Z => (Axis::Z, 0, (j + hi) * self.w + i + lo),
        }
    }

    #[inline]
    fn cell_index(&self, ijk: [u32; 3]) -> usize {
        (ijk[1] - self.origin[1]) as usize * self.w + (ijk[0] - self.origin[0]) as usize
    }
}

/// A cell of a layer walk: its values, and the caches that make every vertex unique.
pub(crate) struct CachedCell<'a, V> {
    pub(crate) ijk: [u32; 3],
    pub(crate) d: [f32; 8],
    pub(crate) case: u8,
    pub(crate) dims: [u32; 3],
    pub(crate) vol: &'a V,
    pub(crate) iso: Iso,
    pub(crate) caches: &'a mut LayerCaches,
    pub(crate) out: &'a mut MeshBuilder,
    /// Centre values computed so far (NaN = not yet).
    pub(crate) memo: [f32; 7],
    /// Vertices this cell placed so far.
    pub(crate) placed: u8,
}

impl<'a, V: Volume> CachedCell<'a, V> {
    /// A cell of the current layer.
    #[inline]
    pub(crate) fn new(
        ijk: [u32; 3],
        d: [f32; 8],
        case: u8,
        vol: &'a V,
        iso: Iso,
        caches: &'a mut LayerCaches,
        out: &'a mut MeshBuilder,
    ) -> Self {
        CachedCell { ijk, d, case, dims: vol.lattice().dims(), vol, iso, caches, out, memo: [f32::NAN; 7], placed: 0 }
    }
}

impl<V: Volume> Cell for CachedCell<'_, V> {
    #[inline]
    fn ijk(&self) -> [u32; 3] {
        self.ijk
    }
    #[inline]
    fn values(&self) -> &[f32; 8] {
        &self.d
    }
    #[inline]
    fn case(&self) -> u8 {
        self.case
    }

    fn hermite(&mut self, e: CubeEdge) -> Hermite {
        let (axis, layer, at) = self.caches.slot(self.ijk, e);
        let n = self.caches.z_ids.len();
        let slots = self.caches.hermite.get_or_insert_with(|| {
            Box::new(HermiteSlots {
                x: [vec![NO_HERMITE; n], vec![NO_HERMITE; n]],
                y: [vec![NO_HERMITE; n], vec![NO_HERMITE; n]],
                z: vec![NO_HERMITE; n],
            })
        });
        let slot = match axis {
            Axis::X => &mut slots.x[layer][at],
            Axis::Y => &mut slots.y[layer][at],
            Axis::Z => &mut slots.z[at],
        };
        if slot.point[0].is_nan() {
            let [c0, c1] = e.corners();
            let key = EdgeKey::of_cell(self.ijk, e);
            *slot = edge_hermite(self.vol, key, self.d[c0 as usize], self.d[c1 as usize], self.iso);
        }
        *slot
    }

    #[inline]
    fn edge_vertex(&mut self, e: CubeEdge) -> VertexId {
        let (axis, layer, at) = self.caches.slot(self.ijk, e);
        let slot = match axis {
            Axis::X => &mut self.caches.x_ids[layer][at],
            Axis::Y => &mut self.caches.y_ids[layer][at],
            Axis::Z => &mut self.caches.z_ids[at],
        };
        if *slot != VertexId::NONE {
            return *slot;
        }
        let [c0, c1] = e.corners();
        let key = EdgeKey::of_cell(self.ijk, e);
        let id = push_edge_vertex(self.vol, key, self.d[c0 as usize], self.d[c1 as usize], self.iso, self.out);
        *slot = id;
        id
    }

    #[inline]
    fn has_neighbour(&self, face: u8) -> bool {
        segment::has_neighbour(self.dims, self.ijk, face)
    }

    #[inline]
    fn point_value(&mut self, p: CellPoint) -> f32 {
        segment::point_value(self.vol, self.iso, self.ijk, &self.d, &mut self.memo, p)
    }

    fn segment_vertex(&mut self, a: CellPoint, b: CellPoint) -> VertexId {
        if let Some(e) = CellPoint::axis_edge(a, b) {
            return self.edge_vertex(e);
        }
        let (vol, iso) = (self.vol, self.iso);
        let (key, d0, d1) = segment::cell_segment(vol, iso, self.ijk, &self.d, &mut self.memo, (a, b));
        if let Some(id) = self.caches.segs.get(&key) {
            return id;
        }
        let id = segment::push_segment_vertex(vol, key, d0, d1, iso, self.out);
        self.caches.segs.insert(key, id);
        id
    }

    fn place_vertex(&mut self, local: [f32; 3], edges: u16) -> VertexId {
        let n = self.placed;
        self.placed += 1;
        let id = segment::push_cell_vertex(self.vol, self.iso, self.ijk, n, local, self.out);
        let c = self.caches.cell_index(self.ijk);
        let layer = &mut self.caches.placed[1];
        if !layer.start.is_empty() {
            if layer.count[c] == 0 {
                layer.start[c] = layer.entries.len() as u32;
            }
            layer.count[c] += 1;
            layer.entries.push((id, edges));
        }
        id
    }

    fn placed_vertex(&mut self, offset: [i8; 3], e: CubeEdge) -> Option<VertexId> {
        let key = EdgeKey::of_cell(self.ijk, e);
        let cell = segment::neighbour(self.ijk, offset)?;
        let ne = key.in_cell(cell)?;
        let (ox, oy) = (self.caches.origin[0], self.caches.origin[1]);
        if cell[0] < ox || cell[1] < oy || offset[2] < -1 || offset[2] > 0 {
            return None;
        }
        let layer = &self.caches.placed[(offset[2] + 1) as usize];
        if layer.start.is_empty() {
            return None;
        }
        let c = self.caches.cell_index(cell);
        layer.of(c).iter().find(|(_, m)| m & (1 << ne.0) != 0).map(|&(v, _)| v)
    }

    #[inline]
    fn push_triangle(&mut self, t: [VertexId; 3]) {
        self.out.push_triangle(t);
    }

    #[inline]
    fn push_quad(&mut self, q: [VertexId; 4]) {
        self.out.push_quad(q);
    }
}
