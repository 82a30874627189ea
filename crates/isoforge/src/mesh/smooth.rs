//! Smoothing: vertex positions filtered by the mesh's one-ring (umbrella) Laplacian, the
//! connectivity untouched: Taubin's λ|μ steps \[Taubin95\] or the windowed-sinc Chebyshev filter
//! \[Taubin96\] (VTK's `vtkWindowedSincPolyDataFilter`). Both are low-pass filters that leave the
//! lowest frequencies (the shape) in place, so unlike plain Laplacian smoothing they do not shrink.
//!
//! **Guarantees**: only positions change, so every property of the connectivity (closed,
//! manifold, oriented, components, Euler characteristic, genus) is kept; vertices on a boundary
//! edge or a non-manifold edge stay where they are; with
//! [`max_displacement`](SmoothOptions::max_displacement) (the constrained mode, for label
//! surfaces: half a lattice spacing) no vertex ends farther than that from where it started.
//! Not guaranteed: that no triangle folds over (the tests check it on extracted surfaces) or that
//! separate surfaces, smoothed apart, do not cross.

use super::Mesh;
use crate::error::{Error, Result};

/// Which low-pass filter [`smooth`] applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Smoother {
    /// Taubin's λ|μ: each iteration one shrinking step (λ > 0) and one inflating step (μ < −λ).
    Taubin,
    /// Windowed sinc: a Chebyshev approximation of the ideal low-pass filter, windowed, one
    /// polynomial degree per iteration; the default.
    #[default]
    WindowedSinc,
}

impl Smoother {
    /// The name the command line uses: `taubin`, `sinc`.
    pub fn name(self) -> &'static str {
        match self {
            Smoother::Taubin => "taubin",
            Smoother::WindowedSinc => "sinc",
        }
    }
}

/// How to smooth (see [`smooth`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothOptions {
    /// The filter.
    pub smoother: Smoother,
    /// Taubin: λ|μ pairs (default 20); windowed sinc: degree of the polynomial (default 40:
    /// fewer than about 30 terms cannot resolve a pass band of 0.1, and the surface shrinks).
    /// From 1 to [`SmoothOptions::MAX_ITERATIONS`].
    pub iterations: u32,
    /// Pass band `k_PB` in (0, 2): frequencies of the umbrella operator `K = I − W` (eigenvalues
    /// in [0, 2]) below it pass (the shape), those above are removed (staircases, noise).
    /// Windowed sinc: 0.1 (VTK's default); Taubin: 0.02 (λ = 0.5, μ = −0.505: on the test
    /// shapes 0.1 inflated the volume by 1 %).
    pub pass_band: f64,
    /// Taubin's shrinking factor λ in (0, 1); μ follows from `1/λ + 1/μ = k_PB`.
    pub lambda: f64,
    /// The constrained mode: no vertex ends farther than this (world units) from where it
    /// started (the result is projected onto that ball after each Taubin pair, and once after
    /// the sinc filter). `None`: unconstrained.
    pub max_displacement: Option<f64>,
}

impl SmoothOptions {
    /// Most iterations accepted.
    pub const MAX_ITERATIONS: u32 = 1000;

    /// `smoother` with its defaults (see the fields), λ = 0.5, unconstrained.
    pub fn new(smoother: Smoother) -> Self {
        let (iterations, pass_band) = match smoother {
            Smoother::Taubin => (20, 0.02),
            Smoother::WindowedSinc => (40, 0.1),
        };
        SmoothOptions { smoother, iterations, pass_band, lambda: 0.5, max_displacement: None }
    }

    /// The same options with `n` iterations.
    pub fn with_iterations(self, n: u32) -> Self {
        SmoothOptions { iterations: n, ..self }
    }

    /// The same options with vertices kept within `d` of where they start.
    pub fn constrained(self, d: f64) -> Self {
        SmoothOptions { max_displacement: Some(d), ..self }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the first value out of its range.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: String| Err(Error::InvalidInput(what));
        if !(1..=Self::MAX_ITERATIONS).contains(&self.iterations) {
            return bad(format!("smoothing: {} iterations, must be 1 to {}", self.iterations, Self::MAX_ITERATIONS));
        }
        if !(self.pass_band > 0.0 && self.pass_band < 2.0) {
            return bad(format!("smoothing: pass band {} must lie in (0, 2)", self.pass_band));
        }
        if !(self.lambda > 0.0 && self.lambda < 1.0) {
            return bad(format!("smoothing: lambda {} must lie in (0, 1)", self.lambda));
        }
        if let Some(d) = self.max_displacement {
            if !(d.is_finite() && d >= 0.0) {
                return bad(format!("smoothing: displacement bound {d} must be a finite number ≥ 0"));
            }
        }
        Ok(())
    }
}

impl Default for SmoothOptions {
    fn default() -> Self {
        SmoothOptions::new(Smoother::default())
    }
}

/// What [`smooth`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SmoothStats {
    /// Vertices that stayed fixed (on a boundary or non-manifold edge).
    pub fixed: usize,
    /// Vertices the displacement bound held back.
    pub clamped: usize,
    /// Largest distance a vertex moved.
    pub max_moved: f64,
}

/// The one-ring of every vertex in compressed rows: the neighbours of vertex `v` are
/// `neighbours[offsets[v]..offsets[v + 1]]` (the other ends of its polygons' edges, each once;
/// quads give their four sides, not their diagonals). Built once per mesh.
#[derive(Debug, Clone, Default)]
pub struct OneRing {
    /// Row starts, one more than there are vertices.
    pub offsets: Vec<u32>,
    /// Row contents.
    pub neighbours: Vec<u32>,
    /// Vertices on an edge used by one polygon (boundary) or more than two (non-manifold).
    pub fixed: Vec<bool>,
}

impl OneRing {
    /// The one-ring of `mesh`'s polygons (indices must be in range: [`Mesh::validate`]).
    pub fn new(mesh: &Mesh) -> Self {
        let nv = mesh.positions.len();
        // Every polygon side as an undirected key; equal keys are one edge, their count its faces.
        let mut keys: Vec<u64> = Vec::with_capacity(3 * mesh.triangles.len() + 4 * mesh.quads.len());
        for p in mesh.polygons() {
            for s in 0..p.len() {
                let (a, b) = (p[s], p[(s + 1) % p.len()]);
                if a != b {
                    keys.push(crate::topo::edge_key(a, b));
                }
            }
        }
        sort_keys(&mut keys);
        let mut degree = vec![0u32; nv + 1];
        let mut fixed = vec![false; nv];
        let mut edges = Vec::with_capacity(keys.len() / 2 + 1);
        for group in keys.chunk_by(|a, b| a == b) {
            let (a, b) = ((group[0] >> 32) as usize, group[0] as u32 as usize);
            if group.len() != 2 {
                fixed[a] = true;
                fixed[b] = true;
            }
            degree[a] += 1;
            degree[b] += 1;
            edges.push((a as u32, b as u32));
        }
        let mut offsets = vec![0u32; nv + 1];
        for v in 0..nv {
            offsets[v + 1] = offsets[v] + degree[v];
        }
        let mut next = offsets.clone();
        let mut neighbours = vec![0u32; offsets[nv] as usize];
        for (a, b) in edges {
            neighbours[next[a as usize] as usize] = b;
            next[a as usize] += 1;
            neighbours[next[b as usize] as usize] = a;
            next[b as usize] += 1;
        }
        OneRing { offsets, neighbours, fixed }
    }

    /// The neighbours of `v`.
    #[inline]
    pub fn of(&self, v: usize) -> &[u32] {
        &self.neighbours[self.offsets[v] as usize..self.offsets[v + 1] as usize]
    }

    /// `W x`: each free vertex's neighbours' mean, fixed and isolated vertices their own value.
    fn average(&self, x: &[[f64; 3]], out: &mut [[f64; 3]]) {
        for_each_vertex(out, |v| {
            let ring = self.of(v);
            if self.fixed[v] || ring.is_empty() {
                return x[v];
            }
            let mut s = [0.0; 3];
            for &u in ring {
                let p = x[u as usize];
                s = [s[0] + p[0], s[1] + p[1], s[2] + p[2]];
            }
            let w = 1.0 / ring.len() as f64;
            s.map(|c| c * w)
        });
    }
}

/// Smooths `mesh` in place: positions only (and normals, recomputed from the polygons when the
/// mesh has them).
///
/// # Errors
/// [`Error::InvalidInput`] for options out of range or a mesh with indices out of range.
pub fn smooth(mesh: &mut Mesh, opts: &SmoothOptions) -> Result<SmoothStats> {
    opts.validate()?;
    mesh.validate()?;
    let ring = OneRing::new(mesh);
    smooth_with(mesh, &ring, opts)
}

/// [`smooth`] with a one-ring already built for this mesh's connectivity.
///
/// # Errors
/// As [`smooth`]; also when `ring` was built for a different number of vertices.
pub fn smooth_with(mesh: &mut Mesh, ring: &OneRing, opts: &SmoothOptions) -> Result<SmoothStats> {
    opts.validate()?;
    let nv = mesh.positions.len();
    if ring.fixed.len() != nv {
        return Err(Error::InvalidInput(format!("one-ring of {} vertices for a mesh of {nv}", ring.fixed.len())));
    }
    // Work in f64 about the bounding box's centre: the filters are linear and keep constants, so
    // the shift changes nothing but the rounding.
    let centre = centre_of(&mesh.positions);
    let original: Vec<[f64; 3]> = mesh.positions.iter().map(|p| [0, 1, 2].map(|a| p[a] as f64 - centre[a])).collect();
    let mut x = original.clone();
    let mut clamped = vec![false; nv];
    match opts.smoother {
        Smoother::Taubin => {
            let mu = 1.0 / (opts.pass_band - 1.0 / opts.lambda);
            let mut wx = vec![[0.0; 3]; nv];
            for _ in 0..opts.iterations {
                for factor in [opts.lambda, mu] {
                    // x ← x + factor · (W x − x)
                    ring.average(&x, &mut wx);
                    for (w, p) in wx.iter_mut().zip(&x) {
                        *w = [0, 1, 2].map(|a| p[a] + factor * (w[a] - p[a]));
                    }
                    std::mem::swap(&mut x, &mut wx);
                }
                if let Some(d) = opts.max_displacement {
                    clamp(&mut x, &original, d, &mut clamped);
                }
            }
        }
        Smoother::WindowedSinc => {
            let c = sinc_coefficients(opts.iterations as usize, opts.pass_band);
            // Chebyshev recurrence on W = I − K: T₀ = x, T₁ = W x, Tᵢ₊₁ = 2 W Tᵢ − Tᵢ₋₁;
            // the result is Σ cᵢ Tᵢ.
            let mut prev = x.clone();
            let mut cur = vec![[0.0; 3]; nv];
            ring.average(&prev, &mut cur);
            let mut next = vec![[0.0; 3]; nv];
            let mut sum: Vec<[f64; 3]> = prev.iter().map(|p| p.map(|v| v * c[0])).collect();
            add_scaled(&mut sum, &cur, c[1]);
            for &ci in &c[2..] {
                ring.average(&cur, &mut next);
                for (n, p) in next.iter_mut().zip(&prev) {
                    *n = [0, 1, 2].map(|a| 2.0 * n[a] - p[a]);
                }
                add_scaled(&mut sum, &next, ci);
                std::mem::swap(&mut prev, &mut cur);
                std::mem::swap(&mut cur, &mut next);
            }
            x = sum;
            // Fixed vertices are fixed points of W, so Σ cᵢ = 1 returns them; restore them
            // exactly all the same (rounding).
            for v in 0..nv {
                if ring.fixed[v] {
                    x[v] = original[v];
                }
            }
            if let Some(d) = opts.max_displacement {
                clamp(&mut x, &original, d, &mut clamped);
            }
        }
    }
    let mut max_moved: f64 = 0.0;
    for (v, p) in x.iter().enumerate() {
        let o = original[v];
        max_moved = max_moved.max(((p[0] - o[0]).powi(2) + (p[1] - o[1]).powi(2) + (p[2] - o[2]).powi(2)).sqrt());
        mesh.positions[v] = [0, 1, 2].map(|a| (p[a] + centre[a]) as f32);
    }
    if !mesh.normals.is_empty() {
        mesh.normals = vertex_normals(mesh);
    }
    Ok(SmoothStats {
        fixed: ring.fixed.iter().filter(|&&f| f).count(),
        clamped: clamped.iter().filter(|&&c| c).count(),
        max_moved,
    })
}

/// The windowed Chebyshev coefficients `c₀ … c_N` of the ideal low-pass filter with pass band
/// `k_pb` in the variable `1 − k` (k ∈ [0, 2] the frequency), scaled so that they sum to 1: the
/// filter passes k = 0 (translations) unchanged \[Taubin96\].
///
/// The window is Blackman's, not the Hamming window of \[Taubin96\] and VTK: a closed surface's
/// volume follows the cube of the filter's gain on its lowest frequencies, and Hamming's
/// pass-band ripple (0.4 % at 40 terms, pass band 0.1) grew a sphere's volume by 1 %; Blackman's
/// is 0.04 %.
fn sinc_coefficients(n: usize, k_pb: f64) -> Vec<f64> {
    use std::f64::consts::PI;
    let theta = (1.0 - k_pb).acos();
    let mut c: Vec<f64> = (0..=n)
        .map(|i| {
            let ideal = if i == 0 { theta / PI } else { 2.0 * (i as f64 * theta).sin() / (i as f64 * PI) };
            let x = i as f64 * PI / (n as f64 + 1.0);
            let window = 0.42 + 0.5 * x.cos() + 0.08 * (2.0 * x).cos();
            ideal * window
        })
        .collect();
    let total: f64 = c.iter().sum();
    c.iter_mut().for_each(|x| *x /= total);
    c
}

/// `sum += s · x`.
fn add_scaled(sum: &mut [[f64; 3]], x: &[[f64; 3]], s: f64) {
    for (o, p) in sum.iter_mut().zip(x) {
        for a in 0..3 {
            o[a] += s * p[a];
        }
    }
}

/// Projects each `x[v]` onto the ball of radius `d` about `original[v]`, marking the ones moved.
fn clamp(x: &mut [[f64; 3]], original: &[[f64; 3]], d: f64, clamped: &mut [bool]) {
    for ((p, o), c) in x.iter_mut().zip(original).zip(clamped) {
        let delta = [p[0] - o[0], p[1] - o[1], p[2] - o[2]];
        let len = (delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]).sqrt();
        if len > d {
            let s = d / len;
            *p = [0, 1, 2].map(|a| o[a] + delta[a] * s);
            *c = true;
        }
    }
}

/// Centre of the bounding box of `positions` (the origin for an empty mesh).
pub(crate) fn centre_of(positions: &[[f32; 3]]) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a] as f64);
            hi[a] = hi[a].max(p[a] as f64);
        }
    }
    if positions.is_empty() {
        return [0.0; 3];
    }
    [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]))
}

/// Area-weighted unit vertex normals of `mesh`'s polygons (quads as their two triangles along
/// the diagonal from the first vertex); zero for vertices no polygon with area uses.
pub fn vertex_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let mut n = vec![[0.0f64; 3]; mesh.positions.len()];
    let p = |v: u32| mesh.positions[v as usize].map(f64::from);
    let mut add = |t: [u32; 3]| {
        let [a, b, c] = t.map(p);
        let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let f = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]];
        for v in t {
            for k in 0..3 {
                n[v as usize][k] += f[k];
            }
        }
    };
    mesh.triangles.iter().for_each(|&t| add(t));
    mesh.quads.iter().for_each(|&[a, b, c, d]| {
        add([a, b, c]);
        add([a, c, d]);
    });
    n.iter()
        .map(|v| {
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if len > 0.0 {
                v.map(|c| (c / len) as f32)
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// Sorts edge keys (in parallel when enabled).
pub(crate) fn sort_keys(keys: &mut [u64]) {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        keys.par_sort_unstable();
    }
    #[cfg(not(feature = "parallel"))]
    keys.sort_unstable();
}

/// `out[v] = f(v)` for every vertex, in parallel chunks when enabled.
fn for_each_vertex(out: &mut [[f64; 3]], f: impl Fn(usize) -> [f64; 3] + Sync) {
    const CHUNK: usize = 4096;
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(i, chunk)| {
            for (j, o) in chunk.iter_mut().enumerate() {
                *o = f(i * CHUNK + j);
            }
        });
    }
    #[cfg(not(feature = "parallel"))]
    out.iter_mut().enumerate().for_each(|(v, o)| *o = f(v));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::{self, Distance};
    use crate::topo;

    /// Unit normal directions of every triangle.
    fn face_normals(mesh: &Mesh) -> Vec<[f64; 3]> {
        mesh.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| mesh.positions[v as usize].map(f64::from));
                let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
                let w = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
                [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
            })
            .collect()
    }

    /// Smooths `shape`'s staircase with `opts` and checks the promises: the mean distance
    /// to the true surface drops by ≥ 30 %, the enclosed volume changes by ≤ 1 %, the topology
    /// report's connectivity is unchanged and no triangle turns by more than 90°.
    fn smooths(shape: Distance, opts: &SmoothOptions) -> (f64, f64) {
        let mut mesh = shapes::binary([32; 3], shape);
        let before = topo::check(&mesh);
        assert!(before.is_watertight(), "{before:?}");
        let d0 = shapes::mean_distance(&mesh, shape);
        let n0 = face_normals(&mesh);
        smooth(&mut mesh, opts).unwrap();
        let after = topo::check(&mesh);
        let d1 = shapes::mean_distance(&mesh, shape);
        let drop = 1.0 - d1 / d0;
        let dv = (after.volume / before.volume - 1.0).abs();
        assert!(drop >= 0.3, "{opts:?}: mean distance {d0} → {d1} ({:.1} % less)", 100.0 * drop);
        assert!(dv <= 0.01, "{opts:?}: volume {} → {} ({:.2} %)", before.volume, after.volume, 100.0 * dv);
        assert_eq!(
            (after.is_watertight(), after.genus(), after.components.len(), after.euler),
            (before.is_watertight(), before.genus(), before.components.len(), before.euler)
        );
        assert_eq!(after.zero_area_triangles.count, 0);
        for (i, (a, b)) in n0.iter().zip(face_normals(&mesh)).enumerate() {
            let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
            assert!(dot > 0.0, "{opts:?}: triangle {i} {:?} turned over", mesh.triangles[i]);
        }
        (drop, dv)
    }

    #[test]
    fn sinc_and_taubin_smooth_staircases_without_shrinking() {
        for shape in [shapes::sphere as Distance, shapes::torus] {
            for smoother in [Smoother::WindowedSinc, Smoother::Taubin] {
                let (drop, dv) = smooths(shape, &SmoothOptions::new(smoother));
                println!("{smoother:?}: mean distance −{:.1} %, volume change {:.2} %", 100.0 * drop, 100.0 * dv);
            }
        }
    }

    /// The constrained mode keeps every vertex within its bound and still smooths.
    #[test]
    fn constrained_vertices_stay_within_their_bound() {
        for smoother in [Smoother::WindowedSinc, Smoother::Taubin] {
            let mut mesh = shapes::binary([32; 3], shapes::sphere);
            let start = mesh.positions.clone();
            let d0 = shapes::mean_distance(&mesh, shapes::sphere);
            let stats = smooth(&mut mesh, &SmoothOptions::new(smoother).constrained(0.25)).unwrap();
            assert!(stats.max_moved <= 0.25 + 1e-6, "{stats:?}");
            for (p, q) in start.iter().zip(&mesh.positions) {
                let d = (0..3).map(|a| (p[a] - q[a]) as f64).map(|x| x * x).sum::<f64>().sqrt();
                assert!(d <= 0.25 + 1e-5, "{smoother:?}: moved {d}");
            }
            assert!(shapes::mean_distance(&mesh, shapes::sphere) < 0.8 * d0, "{smoother:?}");
        }
    }

    /// Vertices on boundary edges do not move; the others do.
    #[test]
    fn boundary_vertices_stay_fixed() {
        let mut mesh = shapes::binary([32; 3], shapes::sphere);
        mesh.triangles.retain(|t| t.iter().all(|&v| mesh.positions[v as usize][2] < 20.0));
        let ring = OneRing::new(&mesh);
        let start = mesh.positions.clone();
        let stats = smooth(&mut mesh, &SmoothOptions::default()).unwrap();
        assert!(stats.fixed > 0);
        let mut moved = 0;
        for v in 0..start.len() {
            if ring.fixed[v] {
                assert_eq!(start[v], mesh.positions[v], "boundary vertex {v} moved");
            } else if start[v] != mesh.positions[v] {
                moved += 1;
            }
        }
        assert!(moved > start.len() / 2);
    }

    /// The filter passes constants: coefficients sum to 1, and a flat grid stays flat.
    #[test]
    fn sinc_filter_passes_the_lowest_frequency() {
        for n in [1, 2, 5, 20, 100] {
            let c = sinc_coefficients(n, 0.1);
            assert_eq!(c.len(), n + 1);
            assert!((c.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
        assert!(SmoothOptions { iterations: 0, ..Default::default() }.validate().is_err());
        assert!(SmoothOptions { pass_band: 2.0, ..Default::default() }.validate().is_err());
        assert!(SmoothOptions::default().constrained(-1.0).validate().is_err());
    }
}
