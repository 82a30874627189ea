//! [`StreamCheck`]: the [`MeshReport`] of [`check`](super::check) for a mesh that streams past in
//! batches, as out-of-core extraction produces it, without ever holding the mesh.
//!
//! The batches keep the [`MeshSink`] contract of the streamed walks
//! ([`FlyingEdgesWalker::stream`](crate::walk::FlyingEdgesWalker::stream)): vertices are numbered
//! from 0 in arrival order, and a batch's triangles refer to vertices of the batch before it, of
//! its own, and of the next batch only (counted walks use their own and the next batch's, walks
//! that create vertices as they go their own and the previous one's).
//!
//! ```text
//! batch        m − 1            m                m + 1
//! vertices     [b(m−1), b(m))   [b(m), b(m+1))   [b(m+1), b(m+2))
//! triangles    → m − 2 … m      → m − 1 … m + 1  → m … m + 2
//! ```
//!
//! So every triangle through a vertex of batch `m` is in batch `m − 1`, `m` or `m + 1`, and an
//! edge, a vertex fan or a vertex triple is complete once the triangles of the batch after the
//! one holding its *smallest* vertex are in. The triangles of batch `m` are examined when batch
//! `m + 1` arrives (their corners' positions are known then); the edges, fans and triples whose
//! smallest vertex lies in batch `m − 1` are then settled in increasing vertex order — the order
//! [`check`](super::check) sorts them in, so the reports agree, examples included, and differ
//! only in the rounding of the area and volume sums.
//!
//! Memory: the positions of three batches, the triangles of one, the open edges, fans and
//! triples of that window, 4 bytes per vertex for the union-find of components, and one record
//! per component.

use std::collections::HashMap;

use super::check::{doubled_area, edge_key, fans, smallest_angle};
use super::{CheckOptions, ComponentReport, EdgeFinding, Findings, MeshReport};
use crate::error::{Error, Result};
use crate::grid::Lattice;
use crate::math::Aabb;
use crate::math::UnionFind;
use crate::mesh::{ExternalError, MeshBatch, MeshSink};

/// Sums of one connected component, kept at its union-find root and merged on union.
#[derive(Debug, Clone)]
struct Component {
    vertices: usize,
    edges: usize,
    triangles: usize,
    closed: bool,
    area: f64,
    /// Σ (first corner − reference) · n over its triangles (n = doubled-area normal).
    moment: f64,
    /// Σ n: with `moment`, gives the signed volume relative to any point afterwards.
    normal_sum: [f64; 3],
    /// Its first triangle: components are listed in this order among equal sizes, as by `check`.
    first_triangle: u32,
}

impl Component {
    fn merge(&mut self, o: &Component) {
        self.vertices += o.vertices;
        self.edges += o.edges;
        self.triangles += o.triangles;
        self.closed &= o.closed;
        self.area += o.area;
        self.moment += o.moment;
        for a in 0..3 {
            self.normal_sum[a] += o.normal_sum[a];
        }
        self.first_triangle = self.first_triangle.min(o.first_triangle);
    }
}

/// Checks a mesh batch by batch (a [`MeshSink`]); [`finish`](StreamCheck::finish) gives the
/// report [`check_with`](super::check_with) gives for the whole mesh.
///
/// # Example
/// ```
/// use isoforge::topo::{CheckOptions, StreamCheck};
/// // A tetrahedron in two batches: the first batch's triangles use the second's vertex 3.
/// let mut s = StreamCheck::new(&CheckOptions::default());
/// let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
/// s.push(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], &triangles)?;
/// s.push(&[[0.0, 0.0, 1.0]], &[])?;
/// let report = s.finish()?;
/// assert!(report.is_watertight() && report.genus() == Some(0));
/// # Ok::<(), isoforge::Error>(())
/// ```
pub struct StreamCheck {
    max_examples: usize,
    lattice: Option<Lattice>,
    /// Vertices received.
    received: u64,
    /// Vertices below this have had every triangle through them examined and are settled.
    settled: u32,
    /// The first vertex of the newest batch (settled once the batch after it is examined).
    newest: u32,
    /// Positions of the vertices `settled..received`.
    positions: Vec<[f32; 3]>,
    /// The last batch's triangles, examined when the next batch (or `finish`) arrives.
    deferred: Vec<[u32; 3]>,
    /// Triangles pushed so far; `deferred` starts at `triangles - deferred.len()`.
    triangles: u64,
    uf: UnionFind,
    components: HashMap<u32, Component>,
    /// Where volumes are taken from before the mesh's box is known (the first corner seen).
    reference: Option<[f64; 3]>,
    /// Open edges: `(smaller << 32 | larger, traversed from smaller to larger)`.
    edges: Vec<(u64, bool)>,
    /// Open vertex fans: `(vertex, a, b)` for the side `a`–`b` opposite it in each triangle.
    fans: Vec<(u32, u32, u32)>,
    /// Open sorted vertex triples with their triangle.
    triples: Vec<([u32; 3], u32)>,
    peak_open: usize,
    valid: u64,
    used: u64,
    edge_count: u64,
    bounds: Aabb,
    angle_sum: f64,
    angle_min: f64,
    angles: u64,
    isolated: Findings<u32>,
    boundary: Findings<EdgeFinding>,
    non_manifold: Findings<EdgeFinding>,
    non_manifold_vertices: Findings<u32>,
    inconsistent: Findings<EdgeFinding>,
    collapsed: Findings<u32>,
    zero_area: Findings<u32>,
    duplicates: Findings<[u32; 2]>,
    scratch: (Vec<u32>, Vec<usize>),
}

impl StreamCheck {
    /// A checker expecting vertex 0 first; `opts` as for [`check_with`](super::check_with).
    pub fn new(opts: &CheckOptions) -> Self {
        StreamCheck {
            max_examples: opts.max_examples,
            lattice: opts.lattice.clone(),
            received: 0,
            settled: 0,
            newest: 0,
            positions: Vec::new(),
            deferred: Vec::new(),
            triangles: 0,
            uf: UnionFind::new(0),
            components: HashMap::new(),
            reference: None,
            edges: Vec::new(),
            fans: Vec::new(),
            triples: Vec::new(),
            peak_open: 0,
            valid: 0,
            used: 0,
            edge_count: 0,
            bounds: Aabb::EMPTY,
            angle_sum: 0.0,
            angle_min: f64::INFINITY,
            angles: 0,
            isolated: Findings::default(),
            boundary: Findings::default(),
            non_manifold: Findings::default(),
            non_manifold_vertices: Findings::default(),
            inconsistent: Findings::default(),
            collapsed: Findings::default(),
            zero_area: Findings::default(),
            duplicates: Findings::default(),
            scratch: (Vec::new(), Vec::new()),
        }
    }

    /// Takes the next batch: its vertices (numbered on from the previous batches') and its
    /// triangles, which may use these vertices, the previous batch's and the next batch's.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when a triangle of the previous batch uses a vertex outside the
    /// batch before it, itself and this one (the batches break the contract); [`Error::Limit`]
    /// past `u32` vertex ids.
    pub fn push(&mut self, positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Result<()> {
        let first_new = self.received;
        let received = first_new + positions.len() as u64;
        if received > u64::from(u32::MAX) {
            return Err(Error::Limit { what: "streamed mesh vertices", requested: received, allowed: u32::MAX.into() });
        }
        self.received = received;
        self.uf.grow(received as usize);
        self.positions.extend_from_slice(positions);
        let deferred = std::mem::take(&mut self.deferred);
        self.examine(&deferred, false)?;
        // The batch before the one just examined is complete: the newest can still be named by
        // the triangles of the batch that arrived now.
        let older = self.newest;
        self.settle(older);
        self.newest = first_new as u32;
        self.deferred = deferred;
        self.deferred.clear();
        self.deferred.extend_from_slice(triangles);
        self.triangles += triangles.len() as u64;
        self.note_window();
        Ok(())
    }

    /// The report of the whole mesh, once the last batch is in. Triangles of the last batch that
    /// use vertices never sent count as collapsed, as [`check`](super::check) counts out-of-range
    /// indices.
    ///
    /// # Errors
    /// As [`push`](StreamCheck::push).
    pub fn finish(mut self) -> Result<MeshReport> {
        let deferred = std::mem::take(&mut self.deferred);
        self.examine(&deferred, true)?;
        self.settle(self.received as u32);
        let manifold =
            self.non_manifold_vertices.count == 0 && self.non_manifold.count == 0 && self.inconsistent.count == 0;
        let b = self.bounds;
        let centre = if b.is_empty() { [0.0; 3] } else { [0, 1, 2].map(|a| 0.5 * (b.min[a] + b.max[a])) };
        let r = self.reference.unwrap_or([0.0; 3]);
        let mut comps: Vec<(u32, ComponentReport)> = self
            .components
            .values()
            .map(|c| {
                // Σ (p − centre)·n = Σ (p − r)·n − (centre − r)·Σ n: the volume `check` takes
                // about the box centre.
                let shift: f64 = (0..3).map(|a| (centre[a] - r[a]) * c.normal_sum[a]).sum();
                let euler = c.vertices as i64 - c.edges as i64 + c.triangles as i64;
                let genus = (c.closed && manifold && euler % 2 == 0).then_some((2 - euler) / 2);
                let report = ComponentReport {
                    vertices: c.vertices,
                    edges: c.edges,
                    triangles: c.triangles,
                    euler,
                    closed: c.closed,
                    genus,
                    area: c.area,
                    volume: (c.moment - shift) / 6.0,
                };
                (c.first_triangle, report)
            })
            .collect();
        comps.sort_by_key(|(first, c)| (std::cmp::Reverse(c.triangles), *first));
        let components: Vec<ComponentReport> = comps.into_iter().map(|(_, c)| c).collect();
        Ok(MeshReport {
            vertices: self.received as usize,
            triangles: self.triangles as usize,
            quads: 0,
            edges: self.edge_count as usize,
            isolated_vertices: self.isolated,
            boundary_edges: self.boundary,
            non_manifold_edges: self.non_manifold,
            non_manifold_vertices: self.non_manifold_vertices,
            inconsistent_edges: self.inconsistent,
            collapsed_triangles: self.collapsed,
            zero_area_triangles: self.zero_area,
            duplicate_triangles: self.duplicates,
            euler: self.used as i64 - self.edge_count as i64 + self.valid as i64,
            area: components.iter().map(|c| c.area).sum(),
            volume: components.iter().map(|c| c.volume).sum(),
            bounds: self.bounds,
            components,
            min_angle_mean_deg: if self.angles == 0 { 0.0 } else { self.angle_sum / self.angles as f64 },
            min_angle_deg: if self.angles == 0 { 0.0 } else { self.angle_min },
            // Pairs anywhere in the mesh: not decidable from a window of it.
            self_intersections: None,
        })
    }

    /// The most positions, triangles, open edges, fans and triples held at once so far: the
    /// window whose size bounds the memory, besides 4 bytes per vertex and the components.
    pub fn peak_window(&self) -> usize {
        self.peak_open
    }

    /// Bytes held now: the union-find (4 per vertex so far), the window and the components.
    pub fn held_bytes(&self) -> u64 {
        use std::mem::size_of;
        let window = self.positions.capacity() * size_of::<[f32; 3]>()
            + self.deferred.capacity() * size_of::<[u32; 3]>()
            + self.edges.capacity() * size_of::<(u64, bool)>()
            + self.fans.capacity() * size_of::<(u32, u32, u32)>()
            + self.triples.capacity() * size_of::<([u32; 3], u32)>();
        // A hash map entry: key, value and about one control byte per slot at 7/8 load.
        let components = self.components.capacity() * (size_of::<(u32, Component)>() + 2);
        (self.uf.len() * size_of::<u32>() + window + components) as u64
    }

    fn note_window(&mut self) {
        let open = self.positions.len() + self.deferred.len() + self.edges.len() + self.fans.len() + self.triples.len();
        self.peak_open = self.peak_open.max(open);
    }

    fn position(&self, v: u32) -> [f32; 3] {
        self.positions[(v - self.settled) as usize]
    }

    /// Examines the triangles of one batch (the one before the newest); `last` when no batch follows.
    fn examine(&mut self, triangles: &[[u32; 3]], last: bool) -> Result<()> {
        let first = self.triangles - triangles.len() as u64;
        for (k, &t) in triangles.iter().enumerate() {
            let ti = (first + k as u64) as u32;
            if let Some(&v) = t.iter().find(|&&v| v < self.settled || (!last && u64::from(v) >= self.received)) {
                return Err(Error::InvalidInput(format!(
                    "streamed triangle {ti} uses vertex {v}, outside its batch, the one before and the \
                     next (vertices {} to {} are open)",
                    self.settled,
                    self.received.saturating_sub(1)
                )));
            }
            if t.iter().any(|&v| u64::from(v) >= self.received) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                self.collapsed.push(ti, self.max_examples);
                continue;
            }
            self.valid += 1;
            for (a, b) in [(t[0], t[1]), (t[1], t[2])] {
                if let Some((kept, absorbed)) = self.uf.union(a, b) {
                    if let Some(gone) = self.components.remove(&absorbed) {
                        match self.components.get_mut(&kept) {
                            Some(c) => c.merge(&gone),
                            None => {
                                self.components.insert(kept, gone);
                            }
                        }
                    }
                }
            }
            let p = t.map(|v| self.position(v));
            let (n, area2) = doubled_area(p);
            if area2 == 0.0 {
                self.zero_area.push(ti, self.max_examples);
            }
            let p0 = p[0].map(f64::from);
            let r = *self.reference.get_or_insert(p0);
            let root = self.uf.find(t[0]);
            let c = self.components.entry(root).or_insert(Component {
                vertices: 0,
                edges: 0,
                triangles: 0,
                closed: true,
                area: 0.0,
                moment: 0.0,
                normal_sum: [0.0; 3],
                first_triangle: ti,
            });
            c.triangles += 1;
            c.area += 0.5 * area2;
            c.moment += (0..3).map(|a| (p0[a] - r[a]) * n[a]).sum::<f64>();
            for a in 0..3 {
                c.normal_sum[a] += n[a];
            }
            if let Some(angle) = smallest_angle(p) {
                self.angle_sum += angle;
                self.angle_min = self.angle_min.min(angle);
                self.angles += 1;
            }
            for s in 0..3 {
                let (a, b, c) = (t[s], t[(s + 1) % 3], t[(s + 2) % 3]);
                self.edges.push((edge_key(a, b), a < b));
                self.fans.push((a, b, c));
            }
            let mut sorted = t;
            sorted.sort_unstable();
            self.triples.push((sorted, ti));
        }
        self.note_window();
        Ok(())
    }

    /// Settles the vertices `settled..upto` and the edges, fans and triples whose smallest vertex
    /// is one of them (every triangle through them has been examined), then drops their positions.
    fn settle(&mut self, upto: u32) {
        if upto <= self.settled {
            return;
        }
        let max = self.max_examples;

        // Edges: a group of equal keys is one undirected edge.
        self.edges.sort_unstable();
        let n = self.edges.partition_point(|&(key, _)| ((key >> 32) as u32) < upto);
        let mut i = 0;
        while i < n {
            let key = self.edges[i].0;
            let mut j = i;
            while j < n && self.edges[j].0 == key {
                j += 1;
            }
            let (a, b, faces) = ((key >> 32) as u32, key as u32, j - i);
            self.edge_count += 1;
            let root = self.uf.find(a);
            let finding = EdgeFinding::new(a, b, faces, self.position(a), self.position(b), self.lattice.as_ref());
            match faces {
                1 => self.boundary.push(finding, max),
                2 if self.edges[i].1 == self.edges[i + 1].1 => self.inconsistent.push(finding, max),
                2 => {}
                _ => self.non_manifold.push(finding, max),
            }
            if let Some(c) = self.components.get_mut(&root) {
                c.edges += 1;
                c.closed &= faces != 1;
            }
            i = j;
        }
        self.edges.drain(..n);

        // Vertices in order: used ones (with a fan) count, are bounded and must form one fan.
        self.fans.sort_unstable();
        let n = self.fans.partition_point(|&(v, _, _)| v < upto);
        let mut i = 0;
        for v in self.settled..upto {
            let mut j = i;
            while j < n && self.fans[j].0 == v {
                j += 1;
            }
            if j == i {
                self.isolated.push(v, max);
                continue;
            }
            self.used += 1;
            let p = self.position(v);
            self.bounds.add(p.map(f64::from));
            let root = self.uf.find(v);
            if let Some(c) = self.components.get_mut(&root) {
                c.vertices += 1;
            }
            let (local, parent) = &mut self.scratch;
            if fans(&self.fans[i..j], local, parent) > 1 {
                self.non_manifold_vertices.push(v, max);
            }
            i = j;
        }
        self.fans.drain(..n);

        // Duplicate triangles: equal sorted triples (same smallest vertex, so settled together).
        self.triples.sort_unstable();
        let n = self.triples.partition_point(|&(t, _)| t[0] < upto);
        for w in self.triples[..n].windows(2) {
            if w[0].0 == w[1].0 {
                self.duplicates.push([w[0].1, w[1].1], max);
            }
        }
        self.triples.drain(..n);

        self.positions.drain(..(upto - self.settled) as usize);
        self.settled = upto;
    }
}

impl MeshSink for StreamCheck {
    fn push(&mut self, batch: MeshBatch<'_>) -> std::result::Result<(), ExternalError> {
        if !batch.quads.is_empty() {
            return Err("the streamed checker takes triangles (triangulate quads first)".into());
        }
        StreamCheck::push(self, batch.positions, batch.triangles).map_err(Into::into)
    }
}
