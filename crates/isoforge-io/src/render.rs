//! A small software renderer for pictures of meshes: orthographic camera, z-buffer, two-sided
//! Lambert shading (or normal colouring, or vertex colours), optional wireframe and a defect
//! overlay (boundary and non-manifold edges in red where visible). No GPU, no browser:
//! the same bytes on every machine, so pictures can be golden-tested.

use std::io::{self, Write};

use isoforge::mesh::Mesh;

/// Where the camera looks from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// From (+x, −y, +z) towards the centre, z up: the usual three-quarter view.
    Iso,
    /// From −y, z up.
    Front,
    /// From +z, y up.
    Top,
}

impl View {
    /// Parses `iso`, `front`, `top`.
    pub fn parse(s: &str) -> Option<View> {
        Some(match s {
            "iso" => View::Iso,
            "front" => View::Front,
            "top" => View::Top,
            _ => return None,
        })
    }
}

/// How faces are coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shading {
    /// Grey (or vertex colours when given), lit by a light near the camera.
    Lambert,
    /// The face normal mapped to RGB ((n + 1) / 2), lit the same way.
    Normal,
}

/// What to draw.
#[derive(Debug, Clone, Copy)]
pub struct RenderOptions {
    /// Image width and height in pixels.
    pub size: [u32; 2],
    /// The camera.
    pub view: View,
    /// Face colouring.
    pub shading: Shading,
    /// Draw triangle edges.
    pub wireframe: bool,
    /// Draw the visible boundary and non-manifold edges in red.
    pub defects: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions { size: [1024, 768], view: View::Iso, shading: Shading::Lambert, wireframe: false, defects: true }
    }
}

/// The largest image rendered (pixels per side).
pub const MAX_SIDE: u32 = 8192;

type V3 = [f64; 3];

fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}
fn unit(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    if l > 0.0 {
        a.map(|x| x / l)
    } else {
        a
    }
}

/// Renders `mesh` (with optional per-vertex colours) into an RGB image, row by row from the top.
pub fn render(mesh: &Mesh, colors: Option<&[[u8; 3]]>, o: &RenderOptions) -> Vec<u8> {
    let [w, h] = o.size.map(|s| s.clamp(1, MAX_SIDE) as usize);
    let background = [250u8, 250, 250];
    let img: Vec<u8> = background.iter().copied().cycle().take(w * h * 3).collect();
    if mesh.positions.is_empty() {
        return img;
    }
    // Camera frame: forward (into the picture), right, up.
    let (forward, up) = match o.view {
        View::Iso => (unit([-1.0, 1.0, -0.8]), [0.0, 0.0, 1.0]),
        View::Front => ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        View::Top => ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
    };
    let right = unit(cross(forward, up));
    let up = cross(right, forward);
    let pts: Vec<V3> = mesh.positions.iter().map(|p| p.map(f64::from)).collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &pts {
        let s = [dot(*p, right), dot(*p, up)];
        for a in 0..2 {
            lo[a] = lo[a].min(s[a]);
            hi[a] = hi[a].max(s[a]);
        }
    }
    let extent = [(hi[0] - lo[0]).max(1e-12), (hi[1] - lo[1]).max(1e-12)];
    let scale = 0.9 * (w as f64 / extent[0]).min(h as f64 / extent[1]);
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let screen = |p: V3| -> V3 {
        [
            w as f64 / 2.0 + (dot(p, right) - centre[0]) * scale,
            h as f64 / 2.0 - (dot(p, up) - centre[1]) * scale,
            dot(p, forward),
        ]
    };
    let sp: Vec<V3> = pts.iter().map(|&p| screen(p)).collect();
    let mut canvas = Canvas { w, h, img, depth: vec![f64::INFINITY; w * h] };
    // Light from over the viewer's left shoulder.
    let light = unit([0, 1, 2].map(|a| -forward[a] + 0.4 * up[a] - 0.3 * right[a]));
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|v| v as usize);
        let n = unit(cross(sub(pts[b], pts[a]), sub(pts[c], pts[a])));
        let lit = 0.25 + 0.75 * dot(n, light).abs();
        let base: [f64; 3] = match (o.shading, colors) {
            (Shading::Normal, _) => n.map(|x| (x + 1.0) / 2.0 * 255.0),
            (Shading::Lambert, Some(cs)) => {
                let m = [cs[a], cs[b], cs[c]];
                [0, 1, 2].map(|ch| (m[0][ch] as f64 + m[1][ch] as f64 + m[2][ch] as f64) / 3.0)
            }
            (Shading::Lambert, None) => [200.0, 205.0, 215.0],
        };
        let rgb = base.map(|x| (x * lit).round().clamp(0.0, 255.0) as u8);
        canvas.fill_triangle([sp[a], sp[b], sp[c]], rgb);
    }
    if o.wireframe {
        for t in &mesh.triangles {
            for k in 0..3 {
                let (p, q) = (sp[t[k] as usize], sp[t[(k + 1) % 3] as usize]);
                canvas.line(p, q, [60, 60, 70], 1);
            }
        }
    }
    if o.defects {
        let bad = isoforge::topo::defect_edges(&mesh.triangles);
        for (p, q) in bad {
            canvas.line(sp[p as usize], sp[q as usize], [220, 20, 20], 2);
        }
    }
    canvas.img
}

/// The picture being drawn and its depth buffer.
struct Canvas {
    w: usize,
    h: usize,
    img: Vec<u8>,
    depth: Vec<f64>,
}

impl Canvas {
    fn fill_triangle(&mut self, v: [V3; 3], rgb: [u8; 3]) {
        let (w, h) = (self.w, self.h);
        let area = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        let x0 = v.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
        let x1 = (v.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max).ceil() as usize).min(w.saturating_sub(1));
        let y0 = v.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
        let y1 = (v.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max).ceil() as usize).min(h.saturating_sub(1));
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let e = |a: V3, b: V3| (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]);
                let (w0, w1, w2) = (e(v[1], v[2]) / area, e(v[2], v[0]) / area, e(v[0], v[1]) / area);
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let z = w0 * v[0][2] + w1 * v[1][2] + w2 * v[2][2];
                let i = y * w + x;
                if z < self.depth[i] {
                    self.depth[i] = z;
                    self.img[3 * i..3 * i + 3].copy_from_slice(&rgb);
                }
            }
        }
    }

    /// A line of `width` pixels, drawn where it is not behind the surface.
    fn line(&mut self, p: V3, q: V3, rgb: [u8; 3], width: i64) {
        let (w, h) = (self.w, self.h);
        let steps = ((q[0] - p[0]).abs().max((q[1] - p[1]).abs()).ceil() as usize).clamp(1, 4 * (w + h));
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            let (x, y, z) = (p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t, p[2] + (q[2] - p[2]) * t);
            for dy in 0..width {
                for dx in 0..width {
                    let (xi, yi) = (x as i64 + dx, y as i64 + dy);
                    if xi < 0 || yi < 0 || xi >= w as i64 || yi >= h as i64 {
                        continue;
                    }
                    let i = yi as usize * w + xi as usize;
                    // A small bias lets the edges of visible faces win against their own face.
                    let d = self.depth[i];
                    if z > d + 1e-6 * (1.0 + d.abs()) + 1e-3 {
                        continue;
                    }
                    self.img[3 * i..3 * i + 3].copy_from_slice(&rgb);
                }
            }
        }
    }
}

/// Writes an RGB image as PNG.
pub fn write_png(w: &mut dyn Write, rgb: &[u8], size: [u32; 2]) -> io::Result<()> {
    let mut enc = png::Encoder::new(w, size[0], size[1]);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut writer = enc.write_header().map_err(io::Error::other)?;
    writer.write_image_data(rgb).map_err(io::Error::other)?;
    writer.finish().map_err(io::Error::other)
}
