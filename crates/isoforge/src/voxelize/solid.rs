//! A broken mesh made into a solid the inside test can trust: vertices welded, duplicate and
//! degenerate faces dropped, each connected patch oriented consistently, then outward, then
//! nested shells alternated (even–odd, so a hollow ball stays hollow).

use std::collections::HashMap;

use glam::DVec3;

use crate::mesh::bvh::Bvh;
use crate::mesh::distance::boxes;
use crate::mesh::Mesh;

use super::winding::{solid_angle, Winding};

/// The cleaned triangles, their hierarchy and what cleaning did.
pub struct Solid {
    /// Triangles in world coordinates, oriented outward.
    pub triangles: Vec<[DVec3; 3]>,
    /// The hierarchy over `triangles`.
    pub bvh: Bvh,
    /// What was repaired.
    pub repairs: Repairs,
}

/// What [`Solid::new`] changed in its input.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Repairs {
    /// Vertices merged into another at the same position.
    pub welded_vertices: usize,
    /// Faces dropped as copies of another (either orientation).
    pub duplicate_faces: usize,
    /// Faces dropped with a repeated vertex or zero area.
    pub degenerate_faces: usize,
    /// Faces reversed to agree with their neighbours or their patch's outward side.
    pub flipped_faces: usize,
    /// Patches: sets of faces joined by edges with exactly two faces.
    pub patches: usize,
    /// Patches reversed because they lie inside an odd number of other patches.
    pub nested_patches: usize,
}

impl Solid {
    /// Cleans and orients the polygons of `mesh` (quads split).
    pub fn new(mesh: &Mesh) -> Self {
        let mut repairs = Repairs::default();
        let (points, mut faces) = weld(mesh, &mut repairs);
        drop_degenerate_and_duplicates(&points, &mut faces, &mut repairs);
        let patch = orient_patches(&mut faces, &mut repairs);
        let mut triangles: Vec<[DVec3; 3]> = faces.iter().map(|f| f.map(|v| points[v as usize])).collect();
        let patches = repairs.patches;
        orient_outward(&mut triangles, &patch, patches, &mut repairs);
        // Flipping faces keeps their boxes: one hierarchy serves every step.
        let bvh = Bvh::build(&boxes(&triangles));
        let nested = nested_patches(&triangles, &bvh, &patch, patches);
        for (t, &p) in triangles.iter_mut().zip(&patch) {
            if nested[p as usize] {
                t.swap(1, 2);
            }
        }
        repairs.nested_patches = nested.iter().filter(|&&n| n).count();
        orient_small_patches(&mut triangles, &bvh, &patch, patches, &mut repairs);
        Solid { triangles, bvh, repairs }
    }

    /// The winding number, ready to evaluate.
    pub fn winding(&self) -> Winding<'_> {
        Winding::new(&self.triangles, &self.bvh)
    }
}

/// Merges vertices at bit-identical positions (−0 = +0); returns the positions and the faces.
fn weld(mesh: &Mesh, repairs: &mut Repairs) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut index: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let mut points = Vec::with_capacity(mesh.positions.len());
    let remap: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let key = p.map(|v| if v == 0.0 { 0 } else { v.to_bits() });
            *index.entry(key).or_insert_with(|| {
                points.push(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
                (points.len() - 1) as u32
            })
        })
        .collect();
    repairs.welded_vertices = mesh.positions.len() - points.len();
    let faces = mesh.all_triangles().map(|t| t.map(|v| remap[v as usize])).collect();
    (points, faces)
}

fn drop_degenerate_and_duplicates(points: &[DVec3], faces: &mut Vec<[u32; 3]>, repairs: &mut Repairs) {
    let before = faces.len();
    faces.retain(|&[a, b, c]| {
        a != b && b != c && c != a && {
            let (pa, pb, pc) = (points[a as usize], points[b as usize], points[c as usize]);
            (pb - pa).cross(pc - pa).length_squared() > 0.0
        }
    });
    repairs.degenerate_faces = before - faces.len();
    let before = faces.len();
    let mut seen = std::collections::HashSet::with_capacity(faces.len());
    faces.retain(|f| {
        let mut k = *f;
        k.sort_unstable();
        seen.insert(k)
    });
    repairs.duplicate_faces = before - faces.len();
}

/// Orients the faces of each patch (faces joined by edges with exactly two faces) like the
/// patch's first face, breadth first; returns each face's patch.
fn orient_patches(faces: &mut [[u32; 3]], repairs: &mut Repairs) -> Vec<u32> {
    // Every directed edge (min, max, face, forward?), sorted so an edge's faces are adjacent.
    let mut edges: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(3 * faces.len());
    for (f, t) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), f as u32, a < b));
        }
    }
    edges.sort_unstable();
    // Neighbours across manifold edges, with whether the pair runs the edge the same way.
    let mut adjacency: Vec<Vec<(u32, bool)>> = vec![Vec::new(); faces.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
            j += 1;
        }
        if j - i == 2 {
            let (e, g) = (edges[i], edges[i + 1]);
            let same = e.3 == g.3;
            adjacency[e.2 as usize].push((g.2, same));
            adjacency[g.2 as usize].push((e.2, same));
        }
        i = j;
    }
    let mut patch = vec![u32::MAX; faces.len()];
    let mut flip = vec![false; faces.len()];
    let mut queue = std::collections::VecDeque::new();
    let mut patches = 0u32;
    for start in 0..faces.len() {
        if patch[start] != u32::MAX {
            continue;
        }
        patch[start] = patches;
        queue.push_back(start as u32);
        while let Some(f) = queue.pop_front() {
            for &(g, same) in &adjacency[f as usize] {
                if patch[g as usize] == u32::MAX {
                    patch[g as usize] = patches;
                    // Consistent neighbours run a shared edge in opposite directions.
                    flip[g as usize] = flip[f as usize] ^ same;
                    queue.push_back(g);
                }
            }
        }
        patches += 1;
    }
    // Within a patch, flip the smaller side so the majority's orientation wins.
    let mut flipped = vec![0usize; patches as usize];
    let mut size = vec![0usize; patches as usize];
    for (f, &p) in patch.iter().enumerate() {
        size[p as usize] += 1;
        flipped[p as usize] += flip[f] as usize;
    }
    for (f, t) in faces.iter_mut().enumerate() {
        let p = patch[f] as usize;
        let majority_flipped = 2 * flipped[p] > size[p];
        if flip[f] != majority_flipped {
            t.swap(1, 2);
            repairs.flipped_faces += 1;
        }
    }
    repairs.patches = patches as usize;
    patch
}

/// Reverses every patch whose signed volume (about its own centre) is negative.
fn orient_outward(triangles: &mut [[DVec3; 3]], patch: &[u32], patches: usize, repairs: &mut Repairs) {
    let mut centre = vec![DVec3::ZERO; patches];
    let mut count = vec![0.0f64; patches];
    for (t, &p) in triangles.iter().zip(patch) {
        centre[p as usize] += (t[0] + t[1] + t[2]) / 3.0;
        count[p as usize] += 1.0;
    }
    for (c, n) in centre.iter_mut().zip(&count) {
        *c /= n.max(1.0);
    }
    let mut volume = vec![0.0f64; patches];
    for (t, &p) in triangles.iter().zip(patch) {
        let o = centre[p as usize];
        volume[p as usize] += (t[0] - o).dot((t[1] - o).cross(t[2] - o));
    }
    for (t, &p) in triangles.iter_mut().zip(patch) {
        if volume[p as usize] < 0.0 {
            t.swap(1, 2);
            repairs.flipped_faces += 1;
        }
    }
}

/// Patches of fewer faces than this are oriented by the field of the others, not by their own
/// signed volume (a face cut off by holes has none).
const SMALL_PATCH: usize = 32;

/// Faces sampled per patch to find its nesting depth.
const DEPTH_SAMPLES: usize = 32;

/// The large patches that lie inside an odd number of others: nine in ten of their sampled
/// faces at the same odd depth (a patch crossing another, mostly outside it, is a union).
fn nested_patches(triangles: &[[DVec3; 3]], bvh: &Bvh, patch: &[u32], patches: usize) -> Vec<bool> {
    let mut nested = vec![false; patches];
    if patches < 2 {
        return nested;
    }
    let winding = Winding::new(triangles, bvh);
    for (p, faces) in patch_faces(patch, patches).iter().enumerate() {
        if faces.len() < SMALL_PATCH {
            continue;
        }
        let stride = faces.len().div_ceil(DEPTH_SAMPLES);
        let mut depths: Vec<i64> = faces
            .iter()
            .step_by(stride)
            .map(|&f| {
                // Just outside the face (a hair along its normal), where a closed patch adds
                // nothing and the others add their nesting depth. (On the face itself its own
                // solid angle is ±2π, the two sides' limits.)
                let t = &triangles[f as usize];
                let n = (t[1] - t[0]).cross(t[2] - t[0]);
                let hair = 1e-4 * n.length().sqrt();
                winding.at((t[0] + t[1] + t[2]) / 3.0 + hair * n.normalize()).round() as i64
            })
            .collect();
        depths.sort_unstable();
        let median = depths[depths.len() / 2];
        let agree = depths.iter().filter(|&&d| d == median).count();
        nested[p] = median % 2 != 0 && 10 * agree >= 9 * depths.len();
    }
    nested
}

/// Reverses the small patches whose normals point up the winding number of everything else
/// (toward the inside): a face cut off by holes takes the side of the surface around it.
fn orient_small_patches(triangles: &mut [[DVec3; 3]], bvh: &Bvh, patch: &[u32], patches: usize, repairs: &mut Repairs) {
    let groups = patch_faces(patch, patches);
    let flip: Vec<bool> = {
        let winding = Winding::new(triangles, bvh);
        groups
            .iter()
            .map(|faces| {
                if faces.len() >= SMALL_PATCH || patches < 2 {
                    return false;
                }
                // The others' winding number a face's size in front of and behind each face;
                // the patch's own share is taken out exactly.
                let mut vote = 0.0;
                for &f in faces {
                    let t = &triangles[f as usize];
                    let n = (t[1] - t[0]).cross(t[2] - t[0]);
                    let step = n.length().sqrt().max(1e-300);
                    let c = (t[0] + t[1] + t[2]) / 3.0;
                    let others = |q: DVec3| {
                        let own: f64 = faces.iter().map(|&g| solid_angle(&triangles[g as usize], q)).sum();
                        winding.at(q) - own / (4.0 * std::f64::consts::PI)
                    };
                    vote += others(c + step * n.normalize()) - others(c - step * n.normalize());
                }
                vote > 0.0
            })
            .collect()
    };
    for (t, &p) in triangles.iter_mut().zip(patch) {
        if flip[p as usize] {
            t.swap(1, 2);
            repairs.flipped_faces += 1;
        }
    }
}

/// Each patch's faces.
fn patch_faces(patch: &[u32], patches: usize) -> Vec<Vec<u32>> {
    let mut groups = vec![Vec::new(); patches];
    for (f, &p) in patch.iter().enumerate() {
        groups[p as usize].push(f as u32);
    }
    groups
}
