use std::fmt;

use crate::grid::Lattice;
use std::sync::atomic::AtomicBool;
use std::sync::atomic::AtomicU32;
use std::sync::atomic::Ordering::Relaxed;

use crate::math::{Aabb, AtomicUnionFind};
use crate::mesh::Mesh;
use crate::walk::Progress;

/// How to check.
#[derive(Debug, Clone)]
pub struct CheckOptions {
    /// How many examples each finding keeps.
    pub max_examples: usize,
    /// When given, findings also name the lattice cell they lie in.
    pub lattice: Option<Lattice>,
    /// Also look for self-intersections ([`MeshReport::self_intersections`]): exact, but it
    /// costs about as much as the rest of the check.
    pub self_intersections: bool,
}

impl CheckOptions {
    /// The default options, looking for self-intersections when `require` asks for their absence.
    pub fn for_require(require: &[Guarantee]) -> Self {
        CheckOptions { self_intersections: require.contains(&Guarantee::NoSelfIntersections), ..Self::default() }
    }
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions { max_examples: 10, lattice: None, self_intersections: false }
    }
}

/// A count and the first few examples of one kind of defect.
#[derive(Debug, Clone, PartialEq)]
pub struct Findings<T> {
    /// How many there are.
    pub count: usize,
    /// The first ones found (at most `max_examples`).
    pub examples: Vec<T>,
}

impl<T> Default for Findings<T> {
    fn default() -> Self {
        Findings { count: 0, examples: Vec::new() }
    }
}

impl<T> Findings<T> {
    pub(super) fn push(&mut self, t: T, max: usize) {
        self.count += 1;
        if self.examples.len() < max {
            self.examples.push(t);
        }
    }

    /// Adds the findings of a later piece.
    pub(super) fn append(&mut self, later: Findings<T>, max: usize) {
        self.count += later.count;
        let room = max.saturating_sub(self.examples.len());
        self.examples.extend(later.examples.into_iter().take(room));
    }
}

/// An edge named by its vertices, where it is, and (with a lattice) which cell holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct EdgeFinding {
    /// The edge's two vertices, smaller first.
    pub edge: [u32; 2],
    /// How many triangles use it.
    pub faces: usize,
    /// Its midpoint.
    pub midpoint: [f32; 3],
    /// The lattice cell containing the midpoint, when a lattice was given.
    pub cell: Option<[i64; 3]>,
}

impl EdgeFinding {
    /// The finding for edge `a`–`b` (a < b) at positions `pa`, `pb`.
    pub(super) fn new(a: u32, b: u32, faces: usize, pa: [f32; 3], pb: [f32; 3], lattice: Option<&Lattice>) -> Self {
        let midpoint = [0, 1, 2].map(|i| 0.5 * (pa[i] + pb[i]));
        let cell = lattice.map(|l| {
            let p = l.to_index(midpoint.map(|x| x as f64));
            p.map(|x| x.floor() as i64)
        });
        EdgeFinding { edge: [a, b], faces, midpoint, cell }
    }
}

impl fmt::Display for EdgeFinding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = self.midpoint;
        write!(
            f,
            "edge ({}, {}) with {} face(s) at ({}, {}, {})",
            self.edge[0], self.edge[1], self.faces, m[0], m[1], m[2]
        )?;
        if let Some(c) = self.cell {
            write!(f, " in cell ({}, {}, {})", c[0], c[1], c[2])?;
        }
        Ok(())
    }
}

/// One connected component (triangles joined through shared vertices).
#[derive(Debug, Clone, PartialEq)]
pub struct ComponentReport {
    /// Vertices used.
    pub vertices: usize,
    /// Distinct edges.
    pub edges: usize,
    /// Triangles.
    pub triangles: usize,
    /// Euler characteristic V − E + F.
    pub euler: i64,
    /// No boundary edge.
    pub closed: bool,
    /// Genus `(2 − χ) / 2` when the component is closed, manifold and oriented.
    pub genus: Option<i64>,
    /// Surface area.
    pub area: f64,
    /// Signed enclosed volume (positive when oriented outward); meaningful when closed.
    pub volume: f64,
}

/// Everything [`check`] finds.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshReport {
    /// Vertices in the mesh.
    pub vertices: usize,
    /// Triangles in the mesh (quads counted as two, see [`check_with`]).
    pub triangles: usize,
    /// Quads in the mesh (checked as two triangles each).
    pub quads: usize,
    /// Distinct undirected edges.
    pub edges: usize,
    /// Vertices no triangle uses.
    pub isolated_vertices: Findings<u32>,
    /// Edges used by one triangle.
    pub boundary_edges: Findings<EdgeFinding>,
    /// Edges used by more than two triangles.
    pub non_manifold_edges: Findings<EdgeFinding>,
    /// Vertices whose triangles form more than one fan.
    pub non_manifold_vertices: Findings<u32>,
    /// Edges whose two triangles traverse it in the same direction.
    pub inconsistent_edges: Findings<EdgeFinding>,
    /// Triangles with a repeated vertex.
    pub collapsed_triangles: Findings<u32>,
    /// Triangles of distinct vertices but zero area.
    pub zero_area_triangles: Findings<u32>,
    /// Pairs of triangles on the same three vertices.
    pub duplicate_triangles: Findings<[u32; 2]>,
    /// Connected components, largest first.
    pub components: Vec<ComponentReport>,
    /// Euler characteristic of the whole mesh (used vertices − edges + triangles).
    pub euler: i64,
    /// Total area.
    pub area: f64,
    /// Total signed volume.
    pub volume: f64,
    /// Bounding box of the used vertices.
    pub bounds: Aabb,
    /// Smallest interior angle of each non-degenerate triangle, in degrees: mean and minimum
    /// (60° for an equilateral triangle; 0 when there is no such triangle).
    pub min_angle_mean_deg: f64,
    /// The smallest of those angles.
    pub min_angle_deg: f64,
    /// Pairs `[i, j]` (i < j) of triangles that meet other than at the vertices or the edge they
    /// share (see [`self_intersections`](super::self_intersections)), when
    /// [`CheckOptions::self_intersections`] asked; examples in (i, j) order. With quads, indices
    /// past the triangles name quad halves (quad `q` is triangles `T + 2q` and `T + 2q + 1`).
    pub self_intersections: Option<Findings<[u32; 2]>>,
}

/// A property a caller can require of a mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Guarantee {
    /// No boundary edge.
    Closed,
    /// Every edge has at most two triangles and every vertex one fan.
    Manifold,
    /// Neighbouring triangles agree on orientation.
    Oriented,
    /// Closed, manifold and oriented.
    Watertight,
    /// No collapsed, zero-area or duplicate triangle.
    NoDegenerate,
    /// No two triangles meet other than at the vertices or the edge they share (holds only
    /// when [`CheckOptions::self_intersections`] looked).
    NoSelfIntersections,
}

impl Guarantee {
    /// Parses `closed`, `manifold`, `oriented`, `watertight`, `no-degenerate`,
    /// `no-self-intersections`.
    pub fn parse(s: &str) -> Option<Guarantee> {
        Some(match s {
            "closed" => Guarantee::Closed,
            "manifold" => Guarantee::Manifold,
            "oriented" => Guarantee::Oriented,
            "watertight" => Guarantee::Watertight,
            "no-degenerate" => Guarantee::NoDegenerate,
            "no-self-intersections" => Guarantee::NoSelfIntersections,
            _ => return None,
        })
    }

    /// The name `parse` accepts.
    pub fn name(self) -> &'static str {
        match self {
            Guarantee::Closed => "closed",
            Guarantee::Manifold => "manifold",
            Guarantee::Oriented => "oriented",
            Guarantee::Watertight => "watertight",
            Guarantee::NoDegenerate => "no-degenerate",
            Guarantee::NoSelfIntersections => "no-self-intersections",
        }
    }
}

impl MeshReport {
    /// No boundary edge.
    pub fn is_closed(&self) -> bool {
        self.boundary_edges.count == 0
    }
    /// No edge with more than two triangles.
    pub fn is_edge_manifold(&self) -> bool {
        self.non_manifold_edges.count == 0
    }
    /// Edge- and vertex-manifold.
    pub fn is_manifold(&self) -> bool {
        self.is_edge_manifold() && self.non_manifold_vertices.count == 0
    }
    /// Consistently oriented.
    pub fn is_oriented(&self) -> bool {
        self.inconsistent_edges.count == 0
    }
    /// Closed, manifold and oriented.
    pub fn is_watertight(&self) -> bool {
        self.is_closed() && self.is_manifold() && self.is_oriented()
    }
    /// True when `g` holds.
    pub fn holds(&self, g: Guarantee) -> bool {
        match g {
            Guarantee::Closed => self.is_closed(),
            Guarantee::Manifold => self.is_manifold(),
            Guarantee::Oriented => self.is_oriented(),
            Guarantee::Watertight => self.is_watertight(),
            Guarantee::NoDegenerate => {
                self.collapsed_triangles.count + self.zero_area_triangles.count + self.duplicate_triangles.count == 0
            }
            Guarantee::NoSelfIntersections => self.self_intersection_count() == Some(0),
        }
    }
    /// How many self-intersecting pairs, when they were looked for.
    pub fn self_intersection_count(&self) -> Option<usize> {
        self.self_intersections.as_ref().map(|f| f.count)
    }
    /// Sum of the genera of the closed components (`None` if any component is open or defective).
    pub fn genus(&self) -> Option<i64> {
        self.components.iter().map(|c| c.genus).sum()
    }
}

/// Checks `mesh` with default options.
pub fn check(mesh: &Mesh) -> MeshReport {
    check_with(mesh, &CheckOptions::default())
}

/// Checks `mesh`: O(T log T) time for T triangles; triangles with out-of-range indices are
/// counted as collapsed and otherwise ignored. Quads are checked as two triangles each, split
/// along the diagonal from their first vertex (the split keeps closedness, manifoldness,
/// orientation, components and the Euler characteristic; [`MeshReport::quads`] says how many
/// there were, and the counts of edges and triangles include the splits).
pub fn check_with(mesh: &Mesh, opts: &CheckOptions) -> MeshReport {
    check_with_progress(mesh, opts, None)
}

/// Stages of [`check_with_progress`]; progress is reported in units of `T` per stage.
const STAGES: u64 = 5;

/// [`check_with`], reporting progress after each of its five stages (triangles, components,
/// vertex buckets, edges with fans and duplicates, angles) in units of the triangle count: a live
/// bar for meshes of millions of triangles, which take seconds.
pub fn check_with_progress(mesh: &Mesh, opts: &CheckOptions, progress: Option<&dyn Progress>) -> MeshReport {
    if !mesh.quads.is_empty() {
        let mut split =
            Mesh { positions: mesh.positions.clone(), triangles: mesh.triangles.clone(), ..Mesh::default() };
        split.triangles.extend(mesh.quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]));
        let mut r = check_with_progress(&split, opts, progress);
        r.quads = mesh.quads.len();
        return r;
    }
    let units = (mesh.triangles.len() as u64).max(1);
    let stage = |k: u64| {
        if let Some(p) = progress {
            p.advance(k * units, STAGES * units);
        }
    };
    stage(0);
    let nv = mesh.positions.len();
    let max = opts.max_examples;
    let tris = &mesh.triangles;
    let pos = |v: u32| mesh.positions[v as usize];
    use crate::walk::flying_edges::map_tasks;

    // PASS 1 (pieces of triangles over the threads): valid triangles, the vertices they use and
    // the union-find of their vertices.
    let uf = AtomicUnionFind::new(nv);
    let used: Vec<AtomicBool> = (0..nv).map(|_| AtomicBool::new(false)).collect();
    let parts = map_tasks(ranges(tris.len(), PIECE), &|(lo, hi)| {
        let (mut valid, mut collapsed) = (Vec::with_capacity(hi - lo), Findings::default());
        for (ti, t) in (lo..).zip(&tris[lo..hi]) {
            if t.iter().any(|&v| v as usize >= nv) || t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                collapsed.push(ti as u32, max);
                continue;
            }
            valid.push(ti as u32);
            for &v in t {
                used[v as usize].store(true, Relaxed);
            }
            uf.union(t[0], t[1]);
            uf.union(t[1], t[2]);
        }
        (valid, collapsed)
    });
    let mut valid: Vec<u32> = Vec::with_capacity(tris.len());
    let mut collapsed = Findings::default();
    for (v, c) in parts {
        valid.extend(v);
        collapsed.append(c, max);
    }
    // Vertices (pieces over the threads): bounds, isolated ones, the root of each.
    let mut root = vec![0u32; nv];
    let tasks: Vec<(usize, &mut [u32])> = root.chunks_mut(PIECE).enumerate().map(|(k, r)| (k * PIECE, r)).collect();
    let parts = map_tasks(tasks, &|(lo, out): (usize, &mut [u32])| {
        let (mut bounds, mut isolated) = (Aabb::EMPTY, Findings::default());
        for (v, r) in (lo as u32..).zip(out.iter_mut()) {
            *r = uf.find(v);
            if used[v as usize].load(Relaxed) {
                let p = pos(v);
                bounds.add([p[0] as f64, p[1] as f64, p[2] as f64]);
            } else {
                isolated.push(v, max);
            }
        }
        (bounds, isolated)
    });
    let mut bounds = Aabb::EMPTY;
    let mut isolated = Findings::default();
    for (b, i) in parts {
        if !b.is_empty() {
            bounds.add(b.min);
            bounds.add(b.max);
        }
        isolated.append(i, max);
    }
    drop(uf);
    let used: Vec<bool> = used.into_iter().map(AtomicBool::into_inner).collect();
    // Volume relative to the box centre keeps the f64 sums well conditioned.
    let c = if bounds.is_empty() { [0.0; 3] } else { [0, 1, 2].map(|a| 0.5 * (bounds.min[a] + bounds.max[a])) };
    let p64 = |v: u32| {
        let p = pos(v);
        [p[0] as f64 - c[0], p[1] as f64 - c[1], p[2] as f64 - c[2]]
    };

    stage(1);

    // Component ids: union-find roots numbered in the order of the triangles that first use
    // them; each component's sums added in triangle order (the terms computed over the threads),
    // so the figures do not depend on the threads.
    let mut comp_of_root = vec![u32::MAX; nv];
    let mut comps: Vec<ComponentReport> = Vec::new();
    let blank = ComponentReport {
        vertices: 0,
        edges: 0,
        triangles: 0,
        euler: 0,
        closed: true,
        genus: None,
        area: 0.0,
        volume: 0.0,
    };
    let mut zero_area = Findings::default();
    for chunk in valid.chunks(SUM_CHUNK) {
        let terms = map_tasks(chunk.chunks(PIECE).collect(), &|piece: &[u32]| {
            piece
                .iter()
                .map(|&ti| {
                    let t = tris[ti as usize];
                    let (n, area2) = doubled_area(t.map(pos));
                    let a = p64(t[0]);
                    (area2, (a[0] * n[0] + a[1] * n[1] + a[2] * n[2]) / 6.0)
                })
                .collect::<Vec<_>>()
        });
        for (&ti, (area2, volume)) in chunk.iter().zip(terms.into_iter().flatten()) {
            let r = root[tris[ti as usize][0] as usize] as usize;
            if comp_of_root[r] == u32::MAX {
                comp_of_root[r] = comps.len() as u32;
                comps.push(blank.clone());
            }
            if area2 == 0.0 {
                zero_area.push(ti, max);
            }
            let k = &mut comps[comp_of_root[r] as usize];
            k.triangles += 1;
            k.area += 0.5 * area2;
            k.volume += volume;
        }
    }
    // From here on a vertex's component is `comp_of_root[root[v]]`.
    let mut comp_of = root;
    for (v, &u) in used.iter().enumerate() {
        let ci = comp_of_root[comp_of[v] as usize];
        comp_of[v] = ci;
        if u {
            comps[ci as usize].vertices += 1;
        }
    }
    drop(comp_of_root);

    stage(2);

    // PASS 2: each vertex's triangles, bucketed once (counts, prefix sums, fill; over the
    // threads). Each vertex then owns its edges to larger vertices, its link and the triangles
    // where it is the smallest vertex, so edges, fans and duplicates come from one pass over the
    // vertices, in vertex order (the order sorted keys would give).
    let degree: Vec<AtomicU32> = (0..nv).map(|_| AtomicU32::new(0)).collect();
    map_tasks(valid.chunks(PIECE).collect(), &|piece: &[u32]| {
        for &ti in piece {
            for &v in &tris[ti as usize] {
                degree[v as usize].fetch_add(1, Relaxed);
            }
        }
    });
    let mut start = Vec::with_capacity(nv + 1);
    let mut sum = 0usize;
    start.push(0);
    for d in &degree {
        sum += d.load(Relaxed) as usize;
        start.push(sum);
    }
    // `degree` becomes each vertex's fill cursor.
    degree.iter().for_each(|d| d.store(0, Relaxed));
    let corners: Vec<AtomicU32> = (0..sum).map(|_| AtomicU32::new(0)).collect();
    map_tasks(valid.chunks(PIECE).collect(), &|piece: &[u32]| {
        for &ti in piece {
            for &v in &tris[ti as usize] {
                let k = degree[v as usize].fetch_add(1, Relaxed) as usize;
                corners[start[v as usize] + k].store(ti, Relaxed);
            }
        }
    });
    drop(degree);
    let corners: Vec<u32> = corners.into_iter().map(AtomicU32::into_inner).collect();

    stage(3);

    let finding = |key: u64, faces: usize| {
        let (a, b) = ((key >> 32) as u32, key as u32);
        EdgeFinding::new(a, b, faces, pos(a), pos(b), opts.lattice.as_ref())
    };
    let parts = map_tasks(ranges(nv, VERTEX_PIECE), &|(lo, hi)| {
        let mut out = VertexPass::default();
        let (mut links, mut owned, mut mine) = (Vec::new(), Vec::new(), Vec::new());
        let (mut local, mut parent) = (Vec::new(), Vec::new());
        for v in lo as u32..hi as u32 {
            let around = &corners[start[v as usize]..start[v as usize + 1]];
            if around.is_empty() {
                continue;
            }
            links.clear();
            owned.clear();
            mine.clear();
            for &ti in around {
                let t = tris[ti as usize];
                let s = if t[0] == v {
                    0
                } else if t[1] == v {
                    1
                } else {
                    2
                };
                let (b, c) = (t[(s + 1) % 3], t[(s + 2) % 3]);
                links.push((v, b, c));
                // Edge v → b runs forward (smaller to larger) when b > v; edge c → v backward.
                if b > v {
                    owned.push((b, (ti << 1) | 1));
                }
                if c > v {
                    owned.push((c, ti << 1));
                }
                if v < b && v < c {
                    mine.push(([v, b.min(c), b.max(c)], ti));
                }
            }
            if fans(&links, &mut local, &mut parent) > 1 {
                out.non_manifold_vertices.push(v, max);
            }
            owned.sort_unstable();
            let ci = comp_of[v as usize];
            let mut open = false;
            let mut nedges = 0usize;
            for group in owned.chunk_by(|x, y| x.0 == y.0) {
                nedges += 1;
                let key = edge_key(v, group[0].0);
                match group.len() {
                    1 => {
                        out.boundary.push(finding(key, 1), max);
                        open = true;
                    }
                    2 => {
                        if (group[0].1 & 1) == (group[1].1 & 1) {
                            out.inconsistent.push(finding(key, 2), max);
                        }
                    }
                    n => out.non_manifold.push(finding(key, n), max),
                }
            }
            out.edges += nedges;
            match out.per_comp.last_mut() {
                Some((c, e, o)) if *c == ci => {
                    *e += nedges;
                    *o |= open;
                }
                _ => out.per_comp.push((ci, nedges, open)),
            }
            mine.sort_unstable();
            for w in mine.windows(2) {
                if w[0].0 == w[1].0 {
                    out.duplicates.push([w[0].1, w[1].1], max);
                }
            }
        }
        out
    });
    drop(corners);
    let mut all = VertexPass::default();
    for p in parts {
        all.edges += p.edges;
        all.boundary.append(p.boundary, max);
        all.non_manifold.append(p.non_manifold, max);
        all.inconsistent.append(p.inconsistent, max);
        all.non_manifold_vertices.append(p.non_manifold_vertices, max);
        all.duplicates.append(p.duplicates, max);
        for (ci, e, open) in p.per_comp {
            let k = &mut comps[ci as usize];
            k.edges += e;
            k.closed &= !open;
        }
    }
    let VertexPass {
        edges: nedges,
        boundary,
        non_manifold,
        inconsistent,
        non_manifold_vertices,
        duplicates,
        per_comp: _,
    } = all;

    stage(4);

    let vertex_manifold_ok = non_manifold_vertices.count == 0 && non_manifold.count == 0 && inconsistent.count == 0;
    for k in &mut comps {
        k.euler = k.vertices as i64 - k.edges as i64 + k.triangles as i64;
        if k.closed && vertex_manifold_ok && k.euler % 2 == 0 {
            k.genus = Some((2 - k.euler) / 2);
        }
    }
    comps.sort_by_key(|c| std::cmp::Reverse(c.triangles));
    let used_count = used.iter().filter(|&&u| u).count();
    let angles = min_angles(mesh, &valid);
    let self_intersections = opts.self_intersections.then(|| super::self_intersections(mesh, max));
    stage(STAGES);
    MeshReport {
        vertices: nv,
        triangles: mesh.triangles.len(),
        quads: 0,
        edges: nedges,
        isolated_vertices: isolated,
        boundary_edges: boundary,
        non_manifold_edges: non_manifold,
        non_manifold_vertices,
        inconsistent_edges: inconsistent,
        collapsed_triangles: collapsed,
        zero_area_triangles: zero_area,
        duplicate_triangles: duplicates,
        euler: used_count as i64 - nedges as i64 + valid.len() as i64,
        area: comps.iter().map(|c| c.area).sum(),
        volume: comps.iter().map(|c| c.volume).sum(),
        bounds,
        components: comps,
        min_angle_mean_deg: angles.0,
        min_angle_deg: angles.1,
        self_intersections,
    }
}

/// Items per piece of the parallel passes (fixed, so results do not depend on the threads).
const PIECE: usize = 1 << 16;

/// Link edges up to which [`fans`] finds a vertex's link vertices by linear search.
const FEW_LINKS: usize = 16;

/// Vertices per piece of the vertex pass.
const VERTEX_PIECE: usize = 1 << 14;

/// Triangles whose area and volume terms are computed over the threads before being added in
/// order (bounds the buffer).
const SUM_CHUNK: usize = 1 << 20;

/// `0..n` in pieces of `piece`.
fn ranges(n: usize, piece: usize) -> Vec<(usize, usize)> {
    (0..n).step_by(piece).map(|lo| (lo, (lo + piece).min(n))).collect()
}

/// What a piece of the vertex pass finds, in vertex order.
#[derive(Default)]
struct VertexPass {
    edges: usize,
    boundary: Findings<EdgeFinding>,
    non_manifold: Findings<EdgeFinding>,
    inconsistent: Findings<EdgeFinding>,
    non_manifold_vertices: Findings<u32>,
    duplicates: Findings<[u32; 2]>,
    /// (component, edges owned, has a boundary edge) for runs of the piece's vertices.
    per_comp: Vec<(u32, usize, bool)>,
}

/// Mean and minimum over the triangles of the smallest interior angle, in degrees (triangles of
/// zero area are left out).
fn min_angles(mesh: &Mesh, triangles: &[u32]) -> (f64, f64) {
    // Summed in fixed pieces, then the pieces in order: the same figure for any thread count.
    let parts = crate::walk::flying_edges::map_tasks(triangles.chunks(PIECE).collect(), &|piece: &[u32]| {
        let (mut sum, mut min, mut n) = (0.0, f64::INFINITY, 0usize);
        for &ti in piece {
            if let Some(angle) = smallest_angle(mesh.triangles[ti as usize].map(|v| mesh.positions[v as usize])) {
                sum += angle;
                min = min.min(angle);
                n += 1;
            }
        }
        (sum, min, n)
    });
    let (sum, min, n) =
        parts.into_iter().fold((0.0, f64::INFINITY, 0usize), |(s, m, k), (ps, pm, pk)| (s + ps, m.min(pm), k + pk));
    if n == 0 {
        (0.0, 0.0)
    } else {
        (sum / n as f64, min)
    }
}

/// Undirected edge `a`–`b` as one sortable key: the smaller vertex in the high half. The one
/// edge-incidence key of the crate (checks, streamed checks, defect edges).
#[inline]
pub fn edge_key(a: u32, b: u32) -> u64 {
    (u64::from(a.min(b)) << 32) | u64::from(a.max(b))
}

/// The edges of `triangles` used by other than two triangles (open or non-manifold), as vertex
/// pairs `(smaller, larger)` in increasing order: what pictures of defects draw.
pub fn defect_edges(triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut keys: Vec<u64> =
        triangles.iter().flat_map(|t| (0..3).map(move |s| edge_key(t[s], t[(s + 1) % 3]))).collect();
    keys.sort_unstable();
    keys.chunk_by(|a, b| a == b).filter(|g| g.len() != 2).map(|g| ((g[0] >> 32) as u32, g[0] as u32)).collect()
}

/// The smallest interior angle of a triangle in degrees; `None` when it has a zero-length side
/// or no positive angle.
pub(super) fn smallest_angle(p: [[f32; 3]; 3]) -> Option<f64> {
    let p = p.map(|q| q.map(f64::from));
    let len2 = |a: usize, b: usize| (0..3).map(|k| (p[a][k] - p[b][k]).powi(2)).sum::<f64>();
    let (a2, b2, c2) = (len2(1, 2), len2(0, 2), len2(0, 1));
    if a2 == 0.0 || b2 == 0.0 || c2 == 0.0 {
        return None;
    }
    // The smallest angle faces the shortest side (law of cosines).
    let (s2, o1, o2) = if a2 <= b2 && a2 <= c2 {
        (a2, b2, c2)
    } else if b2 <= c2 {
        (b2, a2, c2)
    } else {
        (c2, a2, b2)
    };
    let cos = ((o1 + o2 - s2) / (2.0 * (o1 * o2).sqrt())).clamp(-1.0, 1.0);
    let angle = cos.acos().to_degrees();
    (angle.is_finite() && angle > 0.0).then_some(angle)
}

/// The normal `(b − a) × (c − a)` of a triangle (twice its area as length) and that length. The
/// differences of `f32` positions are exact in `f64`, so the result does not depend on where the
/// mesh lies.
pub(super) fn doubled_area(p: [[f32; 3]; 3]) -> ([f64; 3], f64) {
    let [a, b, d] = p.map(|q| q.map(f64::from));
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
    let n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
    (n, (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt())
}

/// How many fans the triangles around one vertex form, from their link edges `(v, a, b)` (the
/// side opposite `v` of each triangle): 1 for a manifold vertex, whose link is one path or one
/// cycle. `local` and `parent` are scratch space.
pub(super) fn fans(links: &[(u32, u32, u32)], local: &mut Vec<u32>, parent: &mut Vec<usize>) -> usize {
    local.clear();
    if links.len() <= FEW_LINKS {
        // The usual few: distinct link vertices by linear search (no sort).
        for &(_, a, b) in links {
            for x in [a, b] {
                if !local.contains(&x) {
                    local.push(x);
                }
            }
        }
    } else {
        for &(_, a, b) in links {
            local.push(a);
            local.push(b);
        }
        local.sort_unstable();
        local.dedup();
    }
    parent.clear();
    parent.extend(0..local.len());
    let few = links.len() <= FEW_LINKS;
    let idx = |x: u32| {
        if few {
            local.iter().position(|&y| y == x).unwrap_or(0)
        } else {
            local.binary_search(&x).unwrap_or(0)
        }
    };
    fn root(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut groups = local.len();
    for &(_, a, b) in links {
        let (ra, rb) = (root(parent, idx(a)), root(parent, idx(b)));
        if ra != rb {
            parent[ra] = rb;
            groups -= 1;
        }
    }
    groups
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetra() -> Mesh {
        Mesh {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            normals: vec![],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
            quads: vec![],
        }
    }

    #[test]
    fn closed_tetrahedron() {
        let r = check(&tetra());
        assert!(r.is_watertight(), "{r:?}");
        assert_eq!(r.euler, 2);
        assert_eq!(r.genus(), Some(0));
        assert!((r.volume - 1.0 / 6.0).abs() < 1e-12, "{}", r.volume);
        assert_eq!(r.components.len(), 1);
    }

    #[test]
    fn finds_defects() {
        let mut m = tetra();
        m.triangles.pop();
        let r = check(&m);
        assert_eq!(r.boundary_edges.count, 3);
        assert!(!r.is_closed() && r.is_oriented());
        assert_eq!(r.genus(), None);

        let mut m = tetra();
        m.triangles[3] = [1, 3, 2]; // flipped
        let r = check(&m);
        assert_eq!(r.inconsistent_edges.count, 3);

        let mut m = tetra();
        m.triangles.push([1, 2, 3]);
        let r = check(&m);
        assert_eq!(r.non_manifold_edges.count, 3);
        assert_eq!(r.duplicate_triangles.count, 1);

        // Two tetrahedra sharing only a vertex: a non-manifold vertex.
        let mut m = tetra();
        m.positions.extend([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]);
        m.triangles.extend([[0, 4, 5], [0, 5, 6], [0, 6, 4], [4, 6, 5]]);
        let r = check(&m);
        assert_eq!(r.non_manifold_vertices.examples, vec![0]);
        assert!(r.is_edge_manifold() && !r.is_manifold());

        let mut m = tetra();
        m.triangles.push([0, 0, 1]);
        m.positions.push([5.0, 5.0, 5.0]);
        let r = check(&m);
        assert_eq!(r.collapsed_triangles.examples, vec![4]);
        assert_eq!(r.isolated_vertices.examples, vec![4]);
    }

    #[test]
    fn findings_name_the_cell() {
        let mut m = tetra();
        m.triangles.pop();
        let l = Lattice::with_geometry([4, 4, 4], [0.5; 3], [0.0; 3]).unwrap();
        let r = check_with(&m, &CheckOptions { max_examples: 10, lattice: Some(l), ..CheckOptions::default() });
        let f = &r.boundary_edges.examples[0];
        assert!(f.cell.is_some());
        assert!(f.to_string().contains("in cell"), "{f}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        /// Random triangle soups over few vertices (open, non-manifold, duplicated, collapsed):
        /// the bucketed pass counts what a plain map of edges and a breadth-first search of each
        /// vertex's link count.
        #[test]
        fn the_vertex_pass_agrees_with_plain_maps(
            tris in proptest::collection::vec((0u32..14, 0u32..14, 0u32..14), 0..60),
        ) {
            use std::collections::BTreeMap;
            let m = Mesh {
                positions: (0..14).map(|i| [i as f32, (i * i % 7) as f32, (i % 3) as f32]).collect(),
                triangles: tris.into_iter().map(|(a, b, c)| [a, b, c]).collect(),
                ..Mesh::default()
            };
            let r = check_with(&m, &CheckOptions { max_examples: 1000, ..CheckOptions::default() });
            let valid: Vec<(u32, [u32; 3])> = (0u32..)
                .zip(&m.triangles)
                .filter(|(_, t)| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .map(|(i, &t)| (i, t))
                .collect();
            let mut edges: BTreeMap<(u32, u32), Vec<bool>> = BTreeMap::new();
            let mut links: BTreeMap<u32, Vec<(u32, u32)>> = BTreeMap::new();
            let mut triples: BTreeMap<[u32; 3], Vec<u32>> = BTreeMap::new();
            for &(ti, t) in &valid {
                for s in 0..3 {
                    let (a, b) = (t[s], t[(s + 1) % 3]);
                    edges.entry((a.min(b), a.max(b))).or_default().push(a < b);
                    links.entry(t[s]).or_default().push((t[(s + 1) % 3], t[(s + 2) % 3]));
                }
                let mut k = t;
                k.sort_unstable();
                triples.entry(k).or_default().push(ti);
            }
            let count = |n: &dyn Fn(&Vec<bool>) -> bool| edges.values().filter(|v| n(v)).count();
            proptest::prop_assert_eq!(r.edges, edges.len());
            proptest::prop_assert_eq!(r.boundary_edges.count, count(&|v| v.len() == 1));
            proptest::prop_assert_eq!(r.non_manifold_edges.count, count(&|v| v.len() > 2));
            proptest::prop_assert_eq!(r.inconsistent_edges.count, count(&|v| v.len() == 2 && v[0] == v[1]));
            let want_edges: Vec<[u32; 2]> =
                edges.iter().filter(|(_, v)| v.len() == 1).map(|(&(a, b), _)| [a, b]).collect();
            let got_edges: Vec<[u32; 2]> = r.boundary_edges.examples.iter().map(|f| f.edge).collect();
            proptest::prop_assert_eq!(got_edges, want_edges);
            let dups: Vec<[u32; 2]> = triples.values().flat_map(|v| v.windows(2).map(|w| [w[0], w[1]])).collect();
            proptest::prop_assert_eq!(&r.duplicate_triangles.examples, &dups);
            // A vertex is manifold when its link (edges b–c) is connected: search from one end.
            let bad: Vec<u32> = links
                .iter()
                .filter(|(_, l)| {
                    let mut seen = vec![l[0].0];
                    let mut grew = true;
                    while grew {
                        grew = false;
                        for &(b, c) in l.iter() {
                            if seen.contains(&b) != seen.contains(&c) {
                                seen.push(if seen.contains(&b) { c } else { b });
                                grew = true;
                            }
                        }
                    }
                    l.iter().any(|&(b, c)| !seen.contains(&b) || !seen.contains(&c))
                })
                .map(|(&v, _)| v)
                .collect();
            proptest::prop_assert_eq!(&r.non_manifold_vertices.examples, &bad);
            let mut uf = crate::math::UnionFind::new(14);
            for &(_, t) in &valid {
                uf.union(t[0], t[1]);
                uf.union(t[1], t[2]);
            }
            let mut roots: Vec<u32> = valid.iter().map(|&(_, t)| uf.find(t[0])).collect();
            roots.sort_unstable();
            roots.dedup();
            proptest::prop_assert_eq!(r.components.len(), roots.len());
            proptest::prop_assert_eq!(r.components.iter().map(|c| c.triangles).sum::<usize>(), valid.len());
        }
    }
}
