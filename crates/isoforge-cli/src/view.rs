//! `isoforge view`: a loopback HTTP server that extracts on request, so a browser shows exactly
//! what `isoforge extract` writes. The page (viewer/, bundled by esbuild) asks the API below.
//!
//! - `GET /api/info` → JSON: what is shown (`demo`, `volume`, `mesh`), methods, demo fields,
//!   value range and histogram of a volume.
//! - `GET /api/mesh?…` → binary: `u32` length of a JSON report, the report (vertices, triangles,
//!   closed, manifold, oriented, components, χ, genus, extraction ms, defect edges), then the
//!   positions (`f32` × 3 × V), the triangles (`u32` × 3 × T) and the defect edges (`u32` × 2 × E),
//!   all little-endian.
//! - `GET /api/export?format=ply|obj|stl|glb&…` → the same mesh as a file.
//!
//! Parameters: `method`, `iso` (volumes and the demo), `roi` (volumes: `i0:i1,j0:j1,k0:k1`), `field` (`metaballs|lines|height`), `n`
//! (8–160) and `t` (animation time) for the demo. Every parameter is validated; unknown ones and
//! out-of-range values are a 400 with the reason, so no request can make the server allocate
//! without bound. Write errors (a browser closing mid-response) are ignored.

use std::io::Cursor;
use std::time::Instant;

use anyhow::{anyhow, bail, Result};
use isoforge::grid::{AnyGrid, Histogram};
use isoforge::mesh::Mesh;
use isoforge::pipeline::{self, Method, Options};
use isoforge::topo;
use isoforge::volume::{catalog, Inside, Iso};
use serde_json::{json, Value};
use tiny_http::{Header, Request, Response, Server};

/// What the viewer shows.
pub enum Shown {
    /// The classic demo fields.
    Demo,
    /// A volume, meshed at the requested iso.
    Volume { name: String, grid: AnyGrid, inside: Inside },
    /// A fixed mesh.
    Mesh { name: String, mesh: Mesh },
}

/// Largest demo resolution (points per axis).
pub const MAX_N: u32 = 160;

/// The viewer's static files, embedded at compile time when `viewer/dist` was built.
fn asset(path: &str) -> Option<(&'static [u8], &'static str)> {
    crate::assets::ASSETS.iter().find(|(p, _, _)| *p == path).map(|(_, bytes, mime)| (*bytes, *mime))
}

/// Serves until the process ends.
pub fn serve(server: &Server, shown: &Shown) {
    for request in server.incoming_requests() {
        let url = request.url().to_string();
        let reply = route(shown, &url);
        respond(request, reply);
    }
}

enum Reply {
    Json(Value),
    Bytes(Vec<u8>, &'static str, Option<String>),
    Static(&'static [u8], &'static str),
    Error(u16, String),
}

fn respond(request: Request, reply: Reply) {
    let header = |k: &str, v: &str| Header::from_bytes(k.as_bytes(), v.as_bytes()).ok();
    let result = match reply {
        Reply::Json(v) => {
            let mut r = Response::from_string(v.to_string());
            r.add_header(header("Content-Type", "application/json").expect("static header"));
            request.respond(r)
        }
        Reply::Bytes(b, mime, file) => {
            let mut r = Response::new(200.into(), Vec::new(), Cursor::new(b.clone()), Some(b.len()), None);
            if let Some(h) = header("Content-Type", mime) {
                r.add_header(h);
            }
            if let Some(h) = file.and_then(|f| header("Content-Disposition", &format!("attachment; filename=\"{f}\"")))
            {
                r.add_header(h);
            }
            request.respond(r)
        }
        Reply::Static(b, mime) => {
            let mut r = Response::new(200.into(), Vec::new(), Cursor::new(b), Some(b.len()), None);
            if let Some(h) = header("Content-Type", mime) {
                r.add_header(h);
            }
            request.respond(r)
        }
        Reply::Error(code, msg) => request.respond(Response::from_string(msg).with_status_code(code)),
    };
    // A browser that went away mid-response is not an error of the server.
    let _ = result;
}

fn route(shown: &Shown, url: &str) -> Reply {
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    let params = match parse_query(query) {
        Ok(p) => p,
        Err(e) => return Reply::Error(400, e.to_string()),
    };
    match path {
        "/api/info" => Reply::Json(info(shown)),
        "/api/mesh" => match mesh_for(shown, &params) {
            Ok((mesh, report)) => Reply::Bytes(encode(&mesh, &report), "application/octet-stream", None),
            Err(e) => Reply::Error(400, e.to_string()),
        },
        "/api/export" => match export(shown, &params) {
            Ok((bytes, mime, file)) => Reply::Bytes(bytes, mime, Some(file)),
            Err(e) => Reply::Error(400, e.to_string()),
        },
        "/" => match asset("index.html") {
            Some((b, mime)) => Reply::Static(b, mime),
            None => Reply::Static(NOT_BUILT.as_bytes(), "text/html; charset=utf-8"),
        },
        p => match asset(p.trim_start_matches('/')) {
            Some((b, mime)) => Reply::Static(b, mime),
            None => Reply::Error(404, format!("{p}: not found")),
        },
    }
}

/// The page served when the front end was not built into this binary.
const NOT_BUILT: &str = "<!doctype html><meta charset=utf-8><title>isoforge view</title>\
<p>The viewer's page is not built into this binary. Build it, then rebuild isoforge:\
<pre>cd viewer &amp;&amp; npm ci &amp;&amp; npm run build\ncargo build --release</pre>\
<p>The API answers meanwhile: <a href=/api/info>/api/info</a>.";

fn parse_query(q: &str) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for pair in q.split('&').filter(|p| !p.is_empty()) {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        if k.len() > 32 || v.len() > 64 {
            bail!("parameter {:?}: too long", &k[..k.len().min(32)]);
        }
        out.push((decode(k)?, decode(v)?));
    }
    Ok(out)
}

/// Percent-decoding of a query component (`%3A` → `:`, `+` → space).
fn decode(s: &str) -> Result<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'%' => {
                let hex = s.get(i + 1..i + 3).and_then(|h| u8::from_str_radix(h, 16).ok());
                out.push(hex.ok_or_else(|| anyhow!("{s:?}: bad percent escape"))?);
                i += 3;
            }
            b'+' => {
                out.push(b' ');
                i += 1;
            }
            c => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).map_err(|_| anyhow!("{s:?}: not UTF-8"))
}

fn info(shown: &Shown) -> Value {
    let methods: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
    match shown {
        Shown::Demo => json!({
            "kind": "demo", "methods": methods, "fields": ["metaballs", "lines", "height"],
            "iso": 48.0, "n": {"min": 8, "max": MAX_N, "default": 40}
        }),
        Shown::Volume { name, grid, .. } => {
            let h = Histogram::of(grid, 128);
            json!({
                "kind": "volume", "name": name, "methods": methods, "dims": grid.lattice().dims(),
                "range": h.as_ref().map(|h| [h.min, h.max]), "histogram": h.as_ref().map(|h| h.counts.clone()),
                "iso": h.as_ref().map(|h| h.surface_iso()),
            })
        }
        Shown::Mesh { name, mesh } => json!({
            "kind": "mesh", "name": name, "vertices": mesh.num_vertices(), "triangles": mesh.num_triangles()
        }),
    }
}

fn get<'a>(params: &'a [(String, String)], key: &str) -> Option<&'a str> {
    params.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

fn number(params: &[(String, String)], key: &str) -> Result<Option<f64>> {
    match get(params, key) {
        None => Ok(None),
        Some(v) => {
            let x: f64 = v.parse().map_err(|_| anyhow!("{key}={v:?}: not a number"))?;
            if !x.is_finite() {
                bail!("{key}={v:?}: must be finite");
            }
            Ok(Some(x))
        }
    }
}

/// Extracts what the parameters ask for, and checks it.
fn mesh_for(shown: &Shown, params: &[(String, String)]) -> Result<(Mesh, Value)> {
    let allowed: &[&str] = match shown {
        Shown::Demo => &["method", "iso", "field", "n", "t", "format"],
        Shown::Volume { .. } => &["method", "iso", "roi", "format"],
        Shown::Mesh { .. } => &["format"],
    };
    if let Some((k, _)) = params.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
        bail!("parameter {k:?} is not accepted here (accepted: {})", allowed.join(", "));
    }
    let method = match get(params, "method") {
        None => Method::MarchingCubes,
        Some(m) => Method::parse(m).ok_or_else(|| anyhow!("method={m:?}: unknown"))?,
    };
    let opts = Options { method, ..Options::default() };
    let start = Instant::now();
    let mesh = match shown {
        Shown::Demo => {
            let field = get(params, "field").unwrap_or("metaballs");
            if !["metaballs", "lines", "height"].contains(&field) {
                bail!("field={field:?}: metaballs, lines or height");
            }
            let n = number(params, "n")?.unwrap_or(40.0);
            if !(8.0..=MAX_N as f64).contains(&n) || n.fract() != 0.0 {
                bail!("n={n}: a whole number from 8 to {MAX_N}");
            }
            let t = number(params, "t")?.unwrap_or(0.5);
            if !(-1e6..=1e6).contains(&t) {
                bail!("t={t}: out of range");
            }
            let spec = if field == "height" { format!("{field}?n={n}") } else { format!("{field}?n={n}&t={t}") };
            let b = catalog::parse(&spec)?;
            let iso = Iso { value: number(params, "iso")?.unwrap_or(b.iso.value), inside: b.iso.inside };
            pipeline::extract_builtin(&b, iso, &opts, None)?.mesh
        }
        Shown::Volume { grid, inside, .. } => {
            let iso = Iso { value: number(params, "iso")?.ok_or_else(|| anyhow!("iso is required"))?, inside: *inside };
            match get(params, "roi").filter(|r| !r.is_empty()) {
                None => pipeline::extract_grid(grid, iso, &opts, None)?.mesh,
                Some(roi) => {
                    let (lo, hi) = parse_roi(roi, grid.lattice().dims())?;
                    pipeline::extract_grid(&grid.crop(lo, hi)?, iso, &opts, None)?.mesh
                }
            }
        }
        Shown::Mesh { mesh, .. } => mesh.clone(),
    };
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let r = topo::check(&mesh);
    let report = json!({
        "vertices": r.vertices, "triangles": r.triangles, "closed": r.is_closed(), "manifold": r.is_manifold(),
        "oriented": r.is_oriented(), "components": r.components.len(), "euler": r.euler, "genus": r.genus(),
        "boundary_edges": r.boundary_edges.count, "non_manifold_edges": r.non_manifold_edges.count,
        "extraction_ms": ms, "method": method.name(),
    });
    Ok((mesh, report))
}

/// `i0:i1,j0:j1,k0:k1` (half-open voxel indices; empty bounds take the whole axis), as in
/// `extract --roi`.
fn parse_roi(roi: &str, dims: [u32; 3]) -> Result<([u32; 3], [u32; 3])> {
    let parts: Vec<&str> = roi.split(',').collect();
    if parts.len() != 3 {
        bail!("roi={roi:?}: expected i0:i1,j0:j1,k0:k1");
    }
    let (mut lo, mut hi) = ([0u32; 3], dims);
    for (a, part) in parts.iter().enumerate() {
        let (l, h) = part.split_once(':').ok_or_else(|| anyhow!("roi={roi:?}: {part:?} has no ':'"))?;
        let num = |t: &str, default: u32| -> Result<u32> {
            if t.trim().is_empty() {
                Ok(default)
            } else {
                t.trim().parse().map_err(|_| anyhow!("roi={roi:?}: {t:?} is not a voxel index"))
            }
        };
        lo[a] = num(l, 0)?;
        hi[a] = num(h, dims[a])?;
    }
    Ok((lo, hi))
}

/// The report, then positions, triangles and defect edges (boundary or non-manifold).
fn encode(mesh: &Mesh, report: &Value) -> Vec<u8> {
    let mut uses: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut defects: Vec<(u32, u32)> = uses.into_iter().filter(|&(_, n)| n != 2).map(|(e, _)| e).collect();
    defects.sort_unstable();
    let mut report = report.clone();
    report["defect_edges"] = json!(defects.len());
    let head = report.to_string().into_bytes();
    let mut out = Vec::with_capacity(4 + head.len() + mesh.positions.len() * 12 + mesh.triangles.len() * 12);
    out.extend_from_slice(&(head.len() as u32).to_le_bytes());
    out.extend_from_slice(&head);
    while out.len() % 4 != 0 {
        out.push(b' ');
    }
    for p in &mesh.positions {
        for x in p {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        for v in t {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for (a, b) in defects {
        out.extend_from_slice(&a.to_le_bytes());
        out.extend_from_slice(&b.to_le_bytes());
    }
    out
}

fn export(shown: &Shown, params: &[(String, String)]) -> Result<(Vec<u8>, &'static str, String)> {
    let format = get(params, "format").unwrap_or("ply");
    let (mesh, _) = mesh_for(shown, params)?;
    let data = isoforge_io::MeshData::default();
    let mut bytes = Vec::new();
    let (mime, file) = match format {
        "ply" => (
            isoforge_io::write::ply::write_ply(&mut bytes, &mesh, false).map(|_| "application/octet-stream"),
            "isosurface.ply",
        ),
        "obj" => (isoforge_io::write::obj::write_obj(&mut bytes, &mesh).map(|_| "text/plain"), "isosurface.obj"),
        "stl" => (
            isoforge_io::write::stl::write_stl(&mut bytes, &mesh).map(|_| "application/octet-stream"),
            "isosurface.stl",
        ),
        "glb" => {
            let named = [isoforge_io::NamedMesh { name: "isosurface", mesh: &mesh, data: &data }];
            (isoforge_io::write::gltf::write_glb(&mut bytes, &named).map(|_| "model/gltf-binary"), "isosurface.glb")
        }
        f => bail!("format={f:?}: ply, obj, stl or glb"),
    };
    Ok((bytes, mime?, file.to_string()))
}
