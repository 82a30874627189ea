//! Topology repair of solids (TopoMender \[Zhou07\]): small handles cut and small tunnels filled,
//! found on skeletons.
//!
//! In: a grid and an iso (a SOG's sign grid, a voxelized mesh's distances, a scan or a label
//! mask) naming a solid. Out: the grid with the fewest points flipped so that every handle whose
//! narrowest cross-section is below `thin` is cut there and every tunnel whose narrowest
//! spanning disc is below `grow` is filled there, and a [`RepairReport`] of what was found.
//!
//! ```text
//!   points ─▶ CellComplex ─thin─▶ skeleton ─max spanning tree─▶ loops ─size < thin─▶ cut
//!   (solid)   (closed: all         (areas retracted             (one per handle,    (flip the
//!              points in it)        onto edges)                  its narrowest edge)  footprint)
//!   the same on the dual of the outside ─▶ tunnels ─size < grow─▶ fill
//! ```
//!
//! Vocabulary (the doubled grid of [`complex`]): *elements* are points, edges, faces and cells;
//! a *free pair* is an element with one coface that has none; *thinning* removes free pairs;
//! the *skeleton* is what remains; a *loop* is a skeleton edge a maximum spanning tree leaves
//! out; its *footprint* is the edges that retracted onto it — the cross-section a cut removes,
//! or (on the dual) the disc of faces a fill adds.
//!
//! The solid is the iso's inside ([`Iso`]: `value < iso`, or `value > iso` when inside is
//! above; ties outside), whose complex is closed; the outside's is the dual. The surface MC33
//! extracts at the same iso has these complexes' topology on sign-like data (ties outside keep
//! the inside 6-connected, as the closed complex is).
//!
//! The complex lives on the grid's finest points (TopoMender works on the octree's cells; the
//! areas are the same, the memory is not): a box one point larger than the solid's bounds, at
//! most [`CellComplex::MAX_ELEMENTS`] elements.

pub mod complex;
pub mod distance;
pub mod skeleton;
pub mod thin;

pub use complex::CellComplex;
pub use distance::squared_distance_to_absent;
pub use skeleton::{spanning_loops, SkeletonEdge};
pub use thin::{thin, Thinning};

use crate::error::{Error, Result};
use crate::grid::DenseGrid;
use crate::volume::{Inside, Iso};

/// What to repair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RepairOptions {
    /// Handles whose narrowest cross-section (squared model units) is below this are cut;
    /// ≤ 0 skips cutting.
    pub thin: f64,
    /// Tunnels whose narrowest spanning disc (squared model units) is below this are filled;
    /// ≤ 0 skips filling.
    pub grow: f64,
}

/// A handle (a loop of the solid) or a tunnel (a loop of the outside).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopKind {
    /// A loop through the solid: cut to remove it.
    Handle,
    /// A loop through the outside: filled to remove it.
    Tunnel,
}

impl LoopKind {
    /// "handle" or "tunnel".
    pub fn name(self) -> &'static str {
        match self {
            LoopKind::Handle => "handle",
            LoopKind::Tunnel => "tunnel",
        }
    }
}

/// One loop found, and what was done.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Operation {
    /// Handle or tunnel.
    pub kind: LoopKind,
    /// The area of its narrowest cross-section, squared model units.
    pub size: f64,
    /// Where (world coordinates of that cross-section's skeleton edge).
    pub at: [f64; 3],
    /// Whether it was cut (a handle) or filled (a tunnel).
    pub performed: bool,
    /// Lattice points flipped to do it.
    pub points_changed: u64,
}

/// One edge of a skeleton, for a skeleton file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkeletonRecord {
    /// The pass: handles (the solid's skeleton) or tunnels (the outside's).
    pub kind: LoopKind,
    /// The area retracted onto it (infinite while it bounds a face).
    pub weight: f64,
    /// Its two ends in doubled lattice coordinates of the input grid (points at even
    /// coordinates; the outside's nodes are cells, at odd ones; −1 or 2n − 1 beyond the grid).
    pub ends: [[i64; 3]; 2],
    /// Whether it was cut or filled.
    pub removed: bool,
}

/// What [`repair`] found and did.
#[derive(Debug, Clone, Default)]
pub struct RepairReport {
    /// Every handle found (cut or not), thinnest first.
    pub handles: Vec<Operation>,
    /// Every tunnel found after cutting (filled or not), thinnest first.
    pub tunnels: Vec<Operation>,
    /// Lattice points flipped in all.
    pub points_changed: u64,
    /// The box of lattice points the complexes covered.
    pub box_points: [usize; 3],
    /// The skeletons' edges (empty unless asked for).
    pub skeleton: Vec<SkeletonRecord>,
    /// Thinning rounds of the two passes (0 when skipped).
    pub rounds: [u32; 2],
}

impl RepairReport {
    /// Handles cut.
    pub fn cuts(&self) -> impl Iterator<Item = &Operation> {
        self.handles.iter().filter(|o| o.performed)
    }
    /// Tunnels filled.
    pub fn fills(&self) -> impl Iterator<Item = &Operation> {
        self.tunnels.iter().filter(|o| o.performed)
    }
}

/// Cuts the small handles and fills the small tunnels of the solid inside `iso` in `grid`: every
/// flipped point's value is mirrored about the iso (`2·iso − v`, nudged to the right side), so
/// the rest of the surface does not move. With `skeleton`, the report
/// lists the skeletons' edges.
///
/// # Errors
/// [`Error::Limit`] when the solid's box needs more than [`CellComplex::MAX_ELEMENTS`]
/// elements (checked before allocating); [`Error::InvalidInput`] for a non-finite iso or
/// threshold.
pub fn repair(grid: &mut DenseGrid<f32>, iso: Iso, opts: &RepairOptions, skeleton: bool) -> Result<RepairReport> {
    if !iso.value.is_finite() || !opts.thin.is_finite() || !opts.grow.is_finite() {
        return Err(Error::InvalidInput(format!(
            "iso {}, thin {} and grow {} must be finite",
            iso.value, opts.thin, opts.grow
        )));
    }
    let lattice = grid.lattice().clone();
    let dims = lattice.dims().map(|d| d as i64);
    // The solid on the box around it, one point larger on every side (outside beyond the lattice).
    let is_solid = |v: f32| iso.offset(v as f64) < 0.0;
    let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
    for (i, &v) in grid.data().iter().enumerate() {
        if is_solid(v) {
            let p = lattice.ijk(i).map(i64::from);
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    let mut report = RepairReport::default();
    if lo[0] > hi[0] {
        return Ok(report);
    }
    let lo = lo.map(|v| v - 1);
    let n = [0, 1, 2].map(|a| (hi[a] + 1 - lo[a] + 1) as usize);
    report.box_points = n;
    let needed = CellComplex::elements_for(n, true);
    if needed > CellComplex::MAX_ELEMENTS {
        return Err(Error::Limit {
            what: "cell complex elements (the solid's box, doubled)",
            requested: needed,
            allowed: CellComplex::MAX_ELEMENTS,
        });
    }
    let in_lattice = |p: [i64; 3]| (0..3).all(|a| p[a] >= 0 && p[a] < dims[a]);
    let mut inside = vec![false; n[0] * n[1] * n[2]];
    for (k, f) in inside.iter_mut().enumerate() {
        let p = [lo[0] + (k % n[0]) as i64, lo[1] + (k / n[0] % n[1]) as i64, lo[2] + (k / (n[0] * n[1])) as i64];
        *f = in_lattice(p) && is_solid(grid.data()[lattice.linear(p.map(|v| v as u32))]);
    }
    let original = inside.clone();
    let frame = Frame { lo, n, lattice: &lattice };
    // The handles on the solid's complex, then the tunnels on the dual of what is left outside.
    if opts.thin > 0.0 {
        let records = skeleton.then_some(&mut report.skeleton);
        let (ops, rounds) = run_pass(&mut inside, &frame, Pass::Closed, LoopKind::Handle, opts.thin, records);
        report.handles = ops;
        report.rounds[0] = rounds;
    }
    if opts.grow > 0.0 {
        let records = skeleton.then_some(&mut report.skeleton);
        let (ops, rounds) = run_pass(&mut inside, &frame, Pass::Dual, LoopKind::Tunnel, opts.grow, records);
        report.tunnels = ops;
        report.rounds[1] = rounds;
    }
    // Mirror the flipped points' values about the iso.
    let data = grid.data_mut();
    for (k, (&now, &was)) in inside.iter().zip(&original).enumerate() {
        if now == was {
            continue;
        }
        let p = [lo[0] + (k % n[0]) as i64, lo[1] + (k / n[0] % n[1]) as i64, lo[2] + (k / (n[0] * n[1])) as i64];
        if !in_lattice(p) {
            continue;
        }
        report.points_changed += 1;
        let v = &mut data[lattice.linear(p.map(|v| v as u32))];
        *v = mirrored(*v, iso, now);
    }
    Ok(report)
}

/// `v` reflected about the iso, then moved one float at a time to the side `inside` asks for.
fn mirrored(v: f32, iso: Iso, inside: bool) -> f32 {
    let mut m = (2.0 * iso.value - v as f64) as f32;
    let below = iso.inside == Inside::Below;
    while (iso.offset(m as f64) < 0.0) != inside {
        // Towards the inside when it is wanted, else away from it.
        m = if below == inside { m.next_down() } else { m.next_up() };
    }
    m
}

/// Where the box sits in the input lattice.
struct Frame<'a> {
    lo: [i64; 3],
    n: [usize; 3],
    lattice: &'a crate::grid::Lattice,
}

impl Frame<'_> {
    fn world(&self, x: [i64; 3]) -> [f64; 3] {
        self.lattice.to_world(x.map(|v| v as f64 / 2.0))
    }
}

/// Which complex a pass thins.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pass {
    /// The closed side's complex; a performed loop takes its footprint's points out of it.
    Closed,
    /// The dual of the open side; a performed loop puts its footprint's faces' points in.
    Dual,
}

/// Thins one complex, finds its loops and performs those under `threshold`.
fn run_pass(
    inside: &mut [bool],
    frame: &Frame,
    pass: Pass,
    kind: LoopKind,
    threshold: f64,
    records: Option<&mut Vec<SkeletonRecord>>,
) -> (Vec<Operation>, u32) {
    let mut c = match pass {
        Pass::Closed => CellComplex::of_solid(frame.n, inside),
        Pass::Dual => CellComplex::dual_of_complement(frame.n, inside),
    };
    let spacing = frame.lattice.spacing();
    let d2 = squared_distance_to_absent(&c, spacing.map(|h| h / 2.0));
    let t = thin(&mut c);
    // The surface lies between the last point of a side and the first of the other: half a
    // spacing beyond the solid's complex and short of the outside's, on average (measured on
    // tori: without this, handles come out at 0.5–0.75 of π r², tunnels at 1.2–1.3 of π (R − r)²).
    let half = spacing.iter().sum::<f64>() / 6.0;
    let bias = if pass == Pass::Closed { half } else { -half };
    let edges = spanning_loops(&c, |e| {
        let r = local_thickness(&c, &d2, e, spacing).sqrt() + bias;
        std::f64::consts::PI * r.max(0.0).powi(2)
    });
    // Doubled box coordinates of an element of this complex (the dual's are shifted by one).
    let shift = |x: [usize; 3]| match pass {
        Pass::Closed => x.map(|v| v as i64),
        Pass::Dual => x.map(|v| v as i64 - 1),
    };
    let to_input = |x: [usize; 3]| {
        let b = shift(x);
        [0, 1, 2].map(|a| b[a] + 2 * frame.lo[a])
    };
    let reach = 2.0 * spacing.iter().copied().fold(0.0, f64::max);
    let mut loops: Vec<&SkeletonEdge> = edges.iter().filter(|e| e.closes_loop && e.weight.is_finite()).collect();
    loops.sort_by(|a, b| a.weight.total_cmp(&b.weight).then(a.element.cmp(&b.element)));
    let euler = |inside: &[bool]| CellComplex::of_solid(frame.n, inside).euler();
    let mut chi = if loops.iter().any(|e| e.weight < threshold) { euler(inside) } else { 0 };
    let mut ops = Vec::new();
    let mut done = std::collections::HashSet::new();
    for e in loops {
        let x = c.coords(e.element);
        let at = frame.world(to_input(x));
        let mut op = Operation { kind, size: e.weight, at, performed: false, points_changed: 0 };
        if e.weight < threshold {
            let b = shift(x);
            let axis = (0..3).find(|&a| x[a] % 2 == 1).expect("an edge");
            let radius = 2.0 * (d2[e.element] as f64).sqrt() + reach;
            let centre = b.map(|v| v as f64 / 2.0);
            // A cross-section across the edge's axis first, then across the others: the first
            // that removes exactly one loop (the solid's Euler characteristic up by one) stays.
            for plane in [axis, (axis + 1) % 3, (axis + 2) % 3] {
                let flipped = match pass {
                    // The solid's section through the edge's lower point leaves it.
                    Pass::Closed => {
                        let (mut p, mut q) = (b, b);
                        p[axis] -= 1;
                        q[axis] += 1;
                        flood_plane(inside, frame, plane, &[p, q], centre, radius, true)
                    }
                    // The outside's section through the face the dual edge crosses joins the
                    // solid (a face beyond the box has nothing to fill).
                    Pass::Dual => {
                        let corners: Vec<[i64; 3]> = (0..8)
                            .map(|k| {
                                [0, 1, 2].map(|a| {
                                    b[a] + if b[a] % 2 == 0 {
                                        0
                                    } else if k >> a & 1 == 0 {
                                        -1
                                    } else {
                                        1
                                    }
                                })
                            })
                            .collect();
                        flood_plane(inside, frame, plane, &corners, centre, radius, false)
                    }
                };
                if flipped.is_empty() {
                    continue;
                }
                let after = euler(inside);
                if after == chi + 1 {
                    chi = after;
                    op.performed = true;
                    done.insert(e.element);
                    op.points_changed = flipped.len() as u64;
                    break;
                }
                for k in flipped {
                    inside[k] = !inside[k];
                }
            }
        }
        ops.push(op);
    }
    ops.sort_by(|a, b| a.size.total_cmp(&b.size));
    if let Some(records) = records {
        records.extend(edges.iter().map(|e| SkeletonRecord {
            kind,
            weight: e.weight,
            ends: e.ends.map(|p| to_input(c.coords(p))),
            removed: done.contains(&e.element),
        }));
    }
    (ops, t.rounds)
}

/// The squared radius of the largest ball around an element near `e` (within two doubled
/// steps) that holds `e` and fits in the complex before thinning: the solid's reach around `e`
/// even where the skeleton runs a step off the middle.
fn local_thickness(c: &CellComplex, d2: &[f32], e: usize, spacing: [f64; 3]) -> f64 {
    let x = c.coords(e).map(|v| v as i64);
    let d = c.dims().map(|v| v as i64);
    let mut best = d2[e] as f64;
    for dz in -2..=2i64 {
        for dy in -2..=2i64 {
            for dx in -2..=2i64 {
                let y = [x[0] + dx, x[1] + dy, x[2] + dz];
                if (0..3).any(|a| y[a] < 0 || y[a] >= d[a]) {
                    continue;
                }
                let r2 = d2[c.index(y.map(|v| v as usize))] as f64;
                let gap = [dx, dy, dz].iter().zip(spacing).map(|(&k, h)| (k as f64 * h / 2.0).powi(2)).sum::<f64>();
                if gap <= r2 && r2 > best {
                    best = r2;
                }
            }
        }
    }
    best
}

/// Flips the points of the plane across `axis` that hold `from`, reachable from `starts`
/// (doubled box coordinates of points) through in-plane neighbours holding `from`, within
/// `radius` (world units) of `centre` (box point coordinates); the indices flipped.
fn flood_plane(
    inside: &mut [bool],
    frame: &Frame,
    axis: usize,
    starts: &[[i64; 3]],
    centre: [f64; 3],
    radius: f64,
    from: bool,
) -> Vec<usize> {
    let n = frame.n.map(|v| v as i64);
    let h = frame.lattice.spacing();
    let within = |p: [i64; 3]| {
        (0..3).all(|a| p[a] >= 0 && p[a] < n[a])
            && (0..3).filter(|&a| a != axis).map(|a| ((p[a] as f64 - centre[a]) * h[a]).powi(2)).sum::<f64>()
                <= radius * radius
    };
    let index = |p: [i64; 3]| (p[0] + n[0] * (p[1] + n[1] * p[2])) as usize;
    let mut stack: Vec<[i64; 3]> = Vec::new();
    let mut flipped = Vec::new();
    for s in starts {
        if s.iter().any(|v| v % 2 != 0) {
            continue;
        }
        let p = s.map(|v| v / 2);
        if within(p) && inside[index(p)] == from {
            inside[index(p)] = !from;
            flipped.push(index(p));
            stack.push(p);
        }
    }
    while let Some(p) = stack.pop() {
        for a in (0..3).filter(|&a| a != axis) {
            for d in [-1, 1] {
                let mut q = p;
                q[a] += d;
                if within(q) && inside[index(q)] == from {
                    inside[index(q)] = !from;
                    flipped.push(index(q));
                    stack.push(q);
                }
            }
        }
    }
    flipped
}

#[cfg(test)]
mod tests;
