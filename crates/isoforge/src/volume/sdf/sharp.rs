//! CSG test shapes with sharp features (issue 45): signed distances with exact analytic gradients,
//! each with its [`Features`] (the exact corners and sampled crease curves of the analytic shape)
//! for measuring how well a mesh keeps them ([`super::features::measure`]).
//!
//! Every shape is 1-Lipschitz. A box's distance is exact inside and out; a CSG `max` (difference,
//! intersection: `box-minus-sphere`, `fandisk`) is exact outside near the surface and a lower bound
//! on the distance inside (the errors are measured near the surface, where the value equals the
//! distance to within the curvature of the cuts); a `min` of disjoint solids (`plates`,
//! `two-spheres`) is exact everywhere. At a crease [`Field::gradient`] returns the normal of the
//! first face of the tie, deterministically.

use glam::Mat3;

use crate::math::Vec3;
use crate::volume::Field;

/// The default rotation of the shapes: 30° about (1, 2, 3), so that no corner or crease lies on
/// a lattice plane.
pub fn default_rotation() -> Mat3 {
    Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 30f32.to_radians())
}

/// A rigid frame: world point `p` is `center + rotation · local`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Where the local origin is.
    pub center: Vec3,
    /// Local to world (orthonormal).
    pub rotation: Mat3,
}

impl Frame {
    /// The default frame: the origin, [`default_rotation`].
    pub fn tilted() -> Self {
        Frame { center: Vec3::ZERO, rotation: default_rotation() }
    }
    #[inline]
    fn local(&self, p: Vec3) -> Vec3 {
        self.rotation.transpose() * (p - self.center)
    }
    #[inline]
    fn world(&self, q: Vec3) -> Vec3 {
        self.center + self.rotation * q
    }
    #[inline]
    fn world_dir(&self, v: Vec3) -> Vec3 {
        self.rotation * v
    }
}

/// The sharp features of an analytic shape.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Features {
    /// Corner points (three or more faces meet).
    pub corners: Vec<Corner>,
    /// Points on the crease curves (two faces meet at an angle), at most `spacing` apart along
    /// each curve (exactly on it: arcs are sampled, not approximated by chords).
    pub crease_points: Vec<Vec3>,
}

/// A corner of [`Features`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Corner {
    /// Where it is.
    pub point: Vec3,
    /// Whether all its faces are planes bounding a convex solid corner (a box's corner); `false`
    /// where a concave or curved cut meets it.
    pub convex: bool,
}

/// Samples the segment `a → b` at most `spacing` apart, both ends included.
fn segment(out: &mut Vec<Vec3>, a: Vec3, b: Vec3, spacing: f32) {
    let m = ((b - a).length() / spacing).ceil().max(1.0) as usize;
    out.extend((0..=m).map(|i| a.lerp(b, i as f32 / m as f32)));
}

/// Samples `f(θ)` for θ in `t0 ..= t1` on an arc of radius `r`, at most `spacing` apart.
fn arc(out: &mut Vec<Vec3>, r: f32, t0: f32, t1: f32, spacing: f32, f: impl Fn(f32) -> Vec3) {
    let m = ((t1 - t0).abs() * r / spacing).ceil().max(1.0) as usize;
    out.extend((0..=m).map(|i| f(t0 + (t1 - t0) * i as f32 / m as f32)));
}

/// Signed distance to an axis-aligned box of half sizes `half` at the origin, and its gradient
/// (at a crease or inside, the axis of the largest coordinate, the first of ties).
#[inline]
fn box_local(q: Vec3, half: Vec3) -> (f32, Vec3) {
    let d = q.abs() - half;
    let outside = d.max(Vec3::ZERO);
    let len = outside.length();
    if len > 0.0 {
        return (len + d.max_element().min(0.0), (outside / len) * q.signum());
    }
    let m = d.max_element();
    let axis = if d.x == m {
        Vec3::X
    } else if d.y == m {
        Vec3::Y
    } else {
        Vec3::Z
    };
    (m, axis * q.signum())
}

/// The corners of a box of half sizes `half` (local), and its 12 edges as corner index pairs.
fn box_corners(half: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { -half.x } else { half.x },
            if i & 2 == 0 { -half.y } else { half.y },
            if i & 4 == 0 { -half.z } else { half.z },
        )
    })
}

/// The 12 edges of [`box_corners`]: index pairs differing in one bit.
fn box_edges() -> impl Iterator<Item = (usize, usize)> {
    (0..8usize).flat_map(|i| [1usize, 2, 4].into_iter().filter(move |b| i & b == 0).map(move |b| (i, i | b)))
}

/// A box in a [`Frame`] (default: half sizes 0.6 × 0.45 × 0.35 turned 30° about (1, 2, 3)):
/// exact signed distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RotatedBox {
    /// Placement.
    pub frame: Frame,
    /// Half the edge lengths (local axes).
    pub half: Vec3,
}

impl Field for RotatedBox {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        box_local(self.frame.local(p), self.half).0
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.frame.world_dir(box_local(self.frame.local(p), self.half).1)
    }
    fn lipschitz(&self) -> Option<f64> {
        Some(1.0)
    }
}

impl RotatedBox {
    /// 8 convex corners, 12 straight creases.
    pub fn features(&self, spacing: f32) -> Features {
        let c = box_corners(self.half).map(|q| self.frame.world(q));
        let mut f =
            Features { corners: c.iter().map(|&point| Corner { point, convex: true }).collect(), ..Default::default() };
        for (i, j) in box_edges() {
            segment(&mut f.crease_points, c[i], c[j], spacing);
        }
        f
    }
}

/// A capped cylinder along the local z axis of a [`Frame`] (default radius 0.4, half height 0.5,
/// tilted): exact signed distance; two circular creases.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// Placement (the axis is the local z axis).
    pub frame: Frame,
    /// Radius.
    pub radius: f32,
    /// Half the height.
    pub half_height: f32,
}

impl Cylinder {
    #[inline]
    fn eval(&self, p: Vec3) -> (f32, Vec3) {
        let q = self.frame.local(p);
        let rho = (q.x * q.x + q.y * q.y).sqrt();
        let radial = if rho > 0.0 { Vec3::new(q.x / rho, q.y / rho, 0.0) } else { Vec3::X };
        let axial = Vec3::new(0.0, 0.0, q.z.signum());
        let (dr, dz) = (rho - self.radius, q.z.abs() - self.half_height);
        let g = if dr > 0.0 && dz > 0.0 {
            (radial * dr + axial * dz).normalize()
        } else if dr >= dz {
            radial
        } else {
            axial
        };
        let outside = (dr.max(0.0).powi(2) + dz.max(0.0).powi(2)).sqrt();
        (outside + dr.max(dz).min(0.0), self.frame.world_dir(g))
    }

    /// No corners; the two rim circles.
    pub fn features(&self, spacing: f32) -> Features {
        let mut f = Features::default();
        for z in [-self.half_height, self.half_height] {
            arc(&mut f.crease_points, self.radius, 0.0, std::f32::consts::TAU, spacing, |t| {
                self.frame.world(Vec3::new(self.radius * t.cos(), self.radius * t.sin(), z))
            });
        }
        f
    }
}

/// A cube of half size `half` in a [`Frame`] minus a ball of radius `radius` centred on its
/// (+,+,+) corner (default 0.55 and 0.5, tilted): `max(box, −ball)`, exact outside, a bound
/// inside. 7 convex corners, 3 where the sphere meets the edges, 12 straight creases (three
/// shortened) and three quarter circles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxMinusSphere {
    /// Placement.
    pub frame: Frame,
    /// Half the cube's edge.
    pub half: f32,
    /// The ball's radius (below `2 · half`).
    pub radius: f32,
}

impl BoxMinusSphere {
    #[inline]
    fn eval(&self, p: Vec3) -> (f32, Vec3) {
        let q = self.frame.local(p);
        let (b, gb) = box_local(q, Vec3::splat(self.half));
        let d = q - Vec3::splat(self.half);
        let len = d.length();
        let s = self.radius - len;
        if b >= s {
            (b, self.frame.world_dir(gb))
        } else {
            let g = if len > 0.0 { -d / len } else { -Vec3::ONE.normalize() };
            (s, self.frame.world_dir(g))
        }
    }

    /// See the type.
    pub fn features(&self, spacing: f32) -> Features {
        let (h, r) = (self.half, self.radius);
        let c = box_corners(Vec3::splat(h));
        let mut f = Features::default();
        for (i, &q) in c.iter().enumerate().take(7) {
            let _ = i;
            f.corners.push(Corner { point: self.frame.world(q), convex: true });
        }
        for axis in 0..3 {
            let mut q = Vec3::splat(h);
            q[axis] -= r;
            f.corners.push(Corner { point: self.frame.world(q), convex: false });
        }
        for (i, j) in box_edges() {
            let (a, mut b) = (c[i], c[j]);
            if j == 7 {
                b = a.lerp(b, 1.0 - r / (2.0 * h));
            }
            segment(&mut f.crease_points, self.frame.world(a), self.frame.world(b), spacing);
        }
        // On the face x_k = h, the circle of radius r around the corner, from one edge to the other.
        for k in 0..3 {
            let (u, v) = ((k + 1) % 3, (k + 2) % 3);
            arc(&mut f.crease_points, r, 0.0, std::f32::consts::FRAC_PI_2, spacing, |t| {
                let mut q = Vec3::splat(h);
                q[u] -= r * t.cos();
                q[v] -= r * t.sin();
                self.frame.world(q)
            });
        }
        f
    }
}

/// A fandisk-like CSG part in a [`Frame`]: the box `[−a, a] × [−b, b] × [−c, c]` (0.6, 0.45,
/// 0.5), minus a cylindrical groove of radius 0.2 along y whose axis lies in the top face at
/// x = −0.15, minus the slab above the plane `x + z = a + c − 0.3` (a 45° chamfer of the top edge
/// at x = a): `max(box, −cylinder, plane)`, exact outside, a bound inside. Convex and concave
/// creases, 10 convex corners and 4 where the groove meets the sides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fandisk {
    /// Placement.
    pub frame: Frame,
}

impl Fandisk {
    const HALF: Vec3 = Vec3::new(0.6, 0.45, 0.5);
    const GROOVE_X: f32 = -0.15;
    const GROOVE_R: f32 = 0.2;
    const CHAMFER: f32 = 0.3;

    #[inline]
    fn eval(&self, p: Vec3) -> (f32, Vec3) {
        let q = self.frame.local(p);
        let h = Self::HALF;
        let (mut best, mut g) = box_local(q, h);
        let d = Vec3::new(q.x - Self::GROOVE_X, 0.0, q.z - h.z);
        let len = d.length();
        let groove = Self::GROOVE_R - len;
        if groove > best {
            best = groove;
            g = if len > 0.0 { -d / len } else { Vec3::Z };
        }
        let n = Vec3::new(1.0, 0.0, 1.0) / 2f32.sqrt();
        let plane = (q.x + q.z - (h.x + h.z - Self::CHAMFER)) / 2f32.sqrt();
        if plane > best {
            best = plane;
            g = n;
        }
        (best, self.frame.world_dir(g))
    }

    /// See the type.
    pub fn features(&self, spacing: f32) -> Features {
        let (a, b, c) = (Self::HALF.x, Self::HALF.y, Self::HALF.z);
        let (x0, r, s) = (Self::GROOVE_X, Self::GROOVE_R, Self::CHAMFER);
        let w = |x: f32, y: f32, z: f32| self.frame.world(Vec3::new(x, y, z));
        let mut f = Features::default();
        let mut corner = |point, convex| f.corners.push(Corner { point, convex });
        for y in [-b, b] {
            corner(w(-a, y, -c), true);
            corner(w(a, y, -c), true);
            corner(w(-a, y, c), true);
            corner(w(a - s, y, c), true);
            corner(w(a, y, c - s), true);
            corner(w(x0 - r, y, c), false);
            corner(w(x0 + r, y, c), false);
        }
        let pts = &mut f.crease_points;
        for y in [-b, b] {
            // Bottom edge along x, vertical edges, top edges either side of the groove, chamfer side.
            segment(pts, w(-a, y, -c), w(a, y, -c), spacing);
            segment(pts, w(-a, y, -c), w(-a, y, c), spacing);
            segment(pts, w(a, y, -c), w(a, y, c - s), spacing);
            segment(pts, w(-a, y, c), w(x0 - r, y, c), spacing);
            segment(pts, w(x0 + r, y, c), w(a - s, y, c), spacing);
            segment(pts, w(a - s, y, c), w(a, y, c - s), spacing);
            arc(pts, r, 0.0, std::f32::consts::PI, spacing, |t| w(x0 + r * t.cos(), y, c - r * t.sin()));
        }
        for x in [-a, a] {
            segment(pts, w(x, -b, -c), w(x, b, -c), spacing);
        }
        for (x, z) in [(-a, c), (a - s, c), (a, c - s), (x0 - r, c), (x0 + r, c)] {
            segment(pts, w(x, -b, z), w(x, b, z), spacing);
        }
        f
    }
}

/// `Field` for a CSG shape whose `eval` gives its signed distance (exact outside, a bound of
/// Lipschitz constant 1 inside) and its gradient together.
macro_rules! csg_field {
    ($($shape:ty),*) => {$(
        impl Field for $shape {
            #[inline]
            fn value(&self, p: Vec3) -> f32 {
                self.eval(p).0
            }
            fn gradient(&self, p: Vec3) -> Vec3 {
                self.eval(p).1
            }
            fn lipschitz(&self) -> Option<f64> {
                Some(1.0)
            }
        }
    )*};
}

csg_field!(Cylinder, BoxMinusSphere, Fandisk);

/// `count` thin square plates (half size 0.7, thickness `thickness`), parallel, `gap` apart
/// centre to centre along the local z axis of a [`Frame`] (default 2 plates 0.4 apart, 0.3 cell
/// widths thick, tilted): the union of their exact distances (exact: they are disjoint).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plates {
    /// Placement (the plates' normal is the local z axis).
    pub frame: Frame,
    /// Number of plates (1 to [`Plates::MAX`]).
    pub count: u32,
    /// Thickness (world units).
    pub thickness: f32,
    /// Centre-to-centre distance (world units; above `thickness`).
    pub gap: f32,
}

impl Plates {
    /// Most plates.
    pub const MAX: u32 = 8;
    const HALF: f32 = 0.7;

    fn plate(&self, i: u32) -> RotatedBox {
        let z = self.gap * (i as f32 - (self.count - 1) as f32 / 2.0);
        RotatedBox {
            frame: Frame { center: self.frame.world(Vec3::new(0.0, 0.0, z)), rotation: self.frame.rotation },
            half: Vec3::new(Self::HALF, Self::HALF, self.thickness / 2.0),
        }
    }

    #[inline]
    fn nearest(&self, p: Vec3) -> (f32, RotatedBox) {
        let mut best = (f32::INFINITY, self.plate(0));
        for i in 0..self.count {
            let b = self.plate(i);
            let v = b.value(p);
            if v < best.0 {
                best = (v, b);
            }
        }
        best
    }

    /// Each plate's 8 corners and 12 creases.
    pub fn features(&self, spacing: f32) -> Features {
        let mut f = Features::default();
        for i in 0..self.count {
            let g = self.plate(i).features(spacing);
            f.corners.extend(g.corners);
            f.crease_points.extend(g.crease_points);
        }
        f
    }
}

impl Field for Plates {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self.nearest(p).0
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.nearest(p).1.gradient(p)
    }
    fn lipschitz(&self) -> Option<f64> {
        Some(1.0)
    }
}

/// Two balls of radius `radius` on the x axis, `gap` apart surface to surface, the middle of
/// the gap at `(mid, 0, 0)` (the catalogue puts it on a lattice plane, the gap a tenth of a
/// cell): the union of their exact distances. Smooth: no features.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwoSpheres {
    /// The x of the gap's middle.
    pub mid: f32,
    /// Radius of each ball.
    pub radius: f32,
    /// Gap between the surfaces.
    pub gap: f32,
}

impl TwoSpheres {
    /// The two centres.
    pub fn centers(&self) -> [Vec3; 2] {
        let d = self.radius + self.gap / 2.0;
        [Vec3::new(self.mid - d, 0.0, 0.0), Vec3::new(self.mid + d, 0.0, 0.0)]
    }

    #[inline]
    fn nearest(&self, p: Vec3) -> (f32, Vec3) {
        let [a, b] = self.centers();
        let (da, db) = ((p - a).length(), (p - b).length());
        if da <= db {
            (da - self.radius, a)
        } else {
            (db - self.radius, b)
        }
    }
}

impl Field for TwoSpheres {
    #[inline]
    fn value(&self, p: Vec3) -> f32 {
        self.nearest(p).0
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        (p - self.nearest(p).1).normalize_or_zero()
    }
    fn lipschitz(&self) -> Option<f64> {
        Some(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::central_difference;

    fn check_on_features<F: Field>(f: &F, features: &Features) {
        for c in &features.corners {
            assert!(f.value(c.point).abs() < 1e-5, "corner {:?}: {}", c.point, f.value(c.point));
        }
        for &p in &features.crease_points {
            assert!(f.value(p).abs() < 1e-5, "crease {p:?}: {}", f.value(p));
        }
    }

    fn check_gradients<F: Field>(f: &F) {
        // Away from creases the analytic gradient is the central difference's.
        let mut checked = 0;
        for i in 0..200 {
            let t = i as f32;
            let p = Vec3::new((t * 0.377).sin(), (t * 0.713).sin(), (t * 1.131).sin()) * 0.95;
            let (g, c) = (f.gradient(p), central_difference(f, p));
            if (c.length() - 1.0).abs() < 1e-2 {
                assert!((g - c).length() < 2e-2, "{p:?}: {g:?} vs {c:?}");
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked}");
    }

    #[test]
    fn features_lie_on_the_surface_and_gradients_are_exact() {
        let b = RotatedBox { frame: Frame::tilted(), half: Vec3::new(0.6, 0.45, 0.35) };
        check_on_features(&b, &b.features(0.01));
        check_gradients(&b);
        assert_eq!(b.features(0.01).corners.len(), 8);
        let c = Cylinder { frame: Frame::tilted(), radius: 0.4, half_height: 0.5 };
        check_on_features(&c, &c.features(0.01));
        check_gradients(&c);
        let s = BoxMinusSphere { frame: Frame::tilted(), half: 0.55, radius: 0.5 };
        check_on_features(&s, &s.features(0.01));
        check_gradients(&s);
        assert_eq!(s.features(0.01).corners.iter().filter(|c| c.convex).count(), 7);
        let fd = Fandisk { frame: Frame::tilted() };
        check_on_features(&fd, &fd.features(0.01));
        check_gradients(&fd);
        assert_eq!(fd.features(0.01).corners.len(), 14);
        let p = Plates { frame: Frame::tilted(), count: 3, thickness: 0.02, gap: 0.3 };
        check_on_features(&p, &p.features(0.01));
        assert_eq!(p.features(0.01).corners.len(), 24);
        let t = TwoSpheres { mid: 0.01, radius: 0.4, gap: 0.005 };
        check_gradients(&t);
        assert!(t.value(Vec3::new(0.01, 0.0, 0.0)) > 0.0);
        assert!((t.value(Vec3::new(0.01, 0.0, 0.0)) - 0.0025).abs() < 1e-6);
    }
}
