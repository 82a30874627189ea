//! `isoforge view`: a loopback HTTP server that extracts on request, so a browser shows exactly
//! what `isoforge extract` writes. The page (`viewer/page/`, plain JavaScript and WebGL2, no
//! third-party code) is embedded in the binary as it is in the tree.
//!
//! - `GET /api/info` → JSON: what is shown (`demo`, `volume`, `mesh`), the query parameters the
//!   API accepts for it, methods, demo fields, value range and histogram of a volume.
//! - `GET /api/mesh?…&level=preview|full` → the mesh in the compact form of [`codec`]; the head
//!   holds counts and timings only. A volume larger than [`PREVIEW_POINTS`] points has a preview:
//!   the volume (or its region) block-averaged by `step` along each axis, which the page draws
//!   first while it asks for the full resolution.
//! - `GET /api/check?…` → the full check (`isoforge check --json`'s report) of the
//!   full-resolution mesh, then its defect edges (boundary and non-manifold) as vertex pairs.
//!   Deferred because it costs more than the extraction on large meshes.
//! - `GET /api/export?format=ply|obj|stl|glb&…` → the full-resolution mesh as a file.
//! - `GET /api/status` → JSON counters of the server (served, abandoned, refused requests) and
//!   its memory budget (`memory.budget`, `memory.reserved`, bytes).
//!
//! Every endpoint that extracts (`/api/mesh`, `/api/check`, `/api/export`) holds a share of one
//! memory [`Budget`]: reserved before the work from the last mesh of its level, resized to its
//! own mesh, given back once its answer is written (answers are streamed, not built whole);
//! without room for [`BUDGET_WAIT`] the answer is 503 with `Retry-After`.
//!
//! Parameters: `method`, `iso` (volumes and the demo), `roi` (volumes: `i0:i1,j0:j1,k0:k1`),
//! `field` (`metaballs|lines|height`), `n` (8–160) and `t` (animation time) for the demo. Each is
//! validated: unknown ones and out-of-range values are a 400 with the reason, so no request can
//! make the server allocate without bound.
//!
//! Work follows the page: the last full-resolution mesh and its check are kept, so the check and
//! export reuse it; full-resolution extractions and checks run one at a time, and a request
//! whose client went away (the page aborts stale ones) is dropped before it starts and before
//! its answer is encoded. An extraction once started runs to its end: the library has no
//! cancellation hook.

mod codec;
mod http;

use std::borrow::Cow;
use std::net::TcpListener;
use std::sync::atomic::AtomicU64;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use isoforge::grid::{downsample_mean, AnyGrid, AnySparse, Histogram};
use isoforge::mesh::Mesh;
use isoforge::pipeline::{self, request, Method, Region, Roi};
use isoforge::topo::{self, CheckOptions};
use isoforge::volume::catalog::Classic;
use isoforge::volume::Iso;

/// A parser's message for query parameter `key`: `roi="1:2": expected three ranges …`.
fn param(key: &str) -> impl Fn(request::ParseError) -> anyhow::Error + '_ {
    move |e| anyhow!("{key}={e}")
}
use serde_json::{json, Value};

use self::http::{Body, Request, Response, Stats};

/// What the viewer shows.
pub enum Shown {
    /// The classic demo fields.
    Demo,
    /// A volume, meshed at the requested iso.
    Volume { name: String, grid: AnyGrid },
    /// A fixed mesh.
    Mesh { name: String, mesh: Mesh },
    /// A sparse grid (an OpenVDB file), meshed at the requested iso; its previews mesh a coarser
    /// level of its pyramid.
    Sparse { name: String, grid: AnySparse },
}

/// Largest demo resolution (points per axis).
pub const MAX_N: u32 = 160;

/// Smallest demo resolution.
const MIN_N: u32 = 8;

/// Volumes (or regions) with more points than this get a preview: block means over `step`³
/// points, `step` the smallest that brings the count under this (the 512×512×450 shoulder:
/// step 4, 1.8 M points, about 1/16 of the triangles).
pub const PREVIEW_POINTS: u64 = 2_000_000;

/// At most this many defect edges are sent to the page (the report counts them all).
const MAX_DEFECT_EDGES: usize = 1 << 20;

/// The page, embedded as it is in `viewer/page/` (no build step).
const PAGE: [(&str, &str, &str); 5] = [
    ("/", include_str!("../../../../viewer/page/index.html"), "text/html; charset=utf-8"),
    ("/main.js", include_str!("../../../../viewer/page/main.js"), "text/javascript; charset=utf-8"),
    ("/gl.js", include_str!("../../../../viewer/page/gl.js"), "text/javascript; charset=utf-8"),
    ("/orbit.js", include_str!("../../../../viewer/page/orbit.js"), "text/javascript; charset=utf-8"),
    ("/codec.js", include_str!("../../../../viewer/page/codec.js"), "text/javascript; charset=utf-8"),
];

/// Listens on 127.0.0.1:`port` (0: any free port), prints the URL, and serves until the process
/// ends.
///
/// # Errors
/// When the port cannot be bound.
pub fn serve(port: u16, shown: Shown, base: pipeline::Request, budget: u64) -> Result<()> {
    let listener =
        TcpListener::bind(("127.0.0.1", port)).with_context(|| format!("cannot listen on 127.0.0.1:{port}"))?;
    let addr = listener.local_addr().context("the server has no address")?;
    let mut viewer = Viewer::new(shown, base);
    viewer.budget = Budget::new(budget, BUDGET_WAIT);
    let viewer = Arc::new(viewer);
    let stats = viewer.stats.clone();
    println!("http://{addr}/");
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
    http::serve(listener, http::Limits::default(), stats, Arc::new(move |req: &Request| viewer.route(req)));
    Ok(())
}

/// A mesh request, validated and typed: the library's request (method, iso, region, inside,
/// threads) and, for the demo, the field.
#[derive(Debug, Clone, PartialEq)]
struct Query {
    request: pipeline::Request,
    demo: Option<Demo>,
}

impl Query {
    fn method(&self) -> Method {
        self.request.options.method
    }
}

/// A block-averaged volume (or region) for previews.
struct Preview {
    roi: Option<Roi>,
    step: u32,
    grid: Arc<AnyGrid>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Demo {
    field: Classic,
    n: u32,
    t: f32,
}

/// The server's state: what is shown, and the work it keeps between requests.
struct Viewer {
    shown: Shown,
    /// What every query starts from: the inside rule and threads of the command line.
    base: pipeline::Request,
    /// Histogram of a volume, made once.
    histogram: Option<Histogram>,
    /// The last preview grid.
    preview: Mutex<Option<Preview>>,
    /// The last full-resolution mesh and its query.
    last_mesh: Mutex<Option<(Query, Arc<Mesh>)>>,
    /// The last check (report JSON and defect edges) and its query.
    last_check: Mutex<Option<(Query, Arc<Vec<u8>>)>>,
    /// Held while a full-resolution extraction runs (one at a time).
    extracting: Mutex<()>,
    /// Held while a check runs (one at a time).
    checking: Mutex<()>,
    stats: Arc<Stats>,
    /// The memory budget of everything that extracts (meshes, checks, exports in flight).
    budget: Arc<Budget>,
    /// Bytes of the last full-resolution mesh: the estimate of the next (the whole budget until
    /// one was made: the first runs alone).
    full_estimate: AtomicU64,
    /// Bytes of the last preview mesh: the estimate of the next.
    preview_estimate: AtomicU64,
}

/// Why a request ended without an answer: its client went away.
struct Abandoned;

/// A handler's failure: the client went away, or a message for a 400.
enum Failure {
    Abandoned,
    Bad(anyhow::Error),
    /// The memory budget stayed taken for [`BUDGET_WAIT`]: 503 with `Retry-After`.
    Busy,
}

/// Memory that the requests in flight on `/api/mesh`, `/api/check` and `/api/export` may take
/// together, bytes: their meshes, encodings and checks (the volume itself, the last mesh kept for
/// reuse and the working memory of the one full-resolution extraction running at a time come on
/// top).
pub const MEMORY_BUDGET: u64 = 1 << 30;
/// How long a request waits for room in the budget before it is answered 503.
const BUDGET_WAIT: Duration = Duration::from_secs(30);
/// What a preview reserves before its mesh is known, when no preview was made yet (a preview
/// grid has at most [`PREVIEW_POINTS`] points).
const FIRST_PREVIEW_ESTIMATE: u64 = 64 << 20;
/// A check holds its mesh and about three times it in edge tables: it reserves this many meshes.
const CHECK_MESHES: u64 = 4;

/// One memory budget for everything in flight: a request reserves before it allocates, waits
/// while the budget is taken, and gives its share back when its answer is written.
struct Budget {
    limit: u64,
    /// Longest wait for room ([`BUDGET_WAIT`]).
    wait: Duration,
    used: Mutex<u64>,
    freed: std::sync::Condvar,
}

impl Budget {
    fn new(limit: u64, wait: Duration) -> Arc<Budget> {
        Arc::new(Budget { limit, wait, used: Mutex::new(0), freed: std::sync::Condvar::new() })
    }
}

/// A share of the [`Budget`], given back when dropped.
struct Reservation {
    budget: Arc<Budget>,
    bytes: u64,
}

impl Budget {
    /// Reserves `bytes` (at most the whole budget: a larger request runs alone), waiting up to
    /// [`BUDGET_WAIT`] for room.
    fn reserve(self: &Arc<Self>, bytes: u64, abandoned: impl Fn() -> bool) -> Result<Reservation, Failure> {
        let bytes = bytes.min(self.limit);
        let until = Instant::now() + self.wait;
        let mut used = lock(&self.used);
        while *used + bytes > self.limit {
            if Instant::now() >= until {
                return Err(Failure::Busy);
            }
            used = match self.freed.wait_timeout(used, Duration::from_millis(100)) {
                Ok((g, _)) => g,
                Err(p) => p.into_inner().0,
            };
            if abandoned() {
                return Err(Failure::Abandoned);
            }
        }
        *used += bytes;
        Ok(Reservation { budget: self.clone(), bytes })
    }
}

impl Reservation {
    /// Replaces the estimate by what was really allocated (it may overshoot the budget once).
    fn resize(&mut self, bytes: u64) {
        let mut used = lock(&self.budget.used);
        *used = (*used + bytes).saturating_sub(self.bytes);
        self.bytes = bytes;
        self.budget.freed.notify_all();
    }
}

impl Drop for Reservation {
    fn drop(&mut self) {
        let mut used = lock(&self.budget.used);
        *used = used.saturating_sub(self.bytes);
        if *used == 0 {
            // Idle: give freed memory back to the system (glibc keeps freed arenas otherwise).
            #[cfg(all(target_os = "linux", target_env = "gnu"))]
            // SAFETY: malloc_trim only releases free heap pages.
            unsafe {
                libc::malloc_trim(0);
            }
        }
        self.budget.freed.notify_all();
    }
}

/// Bytes a mesh holds.
fn mesh_bytes(m: &Mesh) -> u64 {
    (m.positions.capacity() * 12 + m.normals.capacity() * 12 + m.triangles.capacity() * 12 + m.quads.capacity() * 16)
        as u64
}

/// Bytes a `/api/mesh` answer holds while it is written: its mesh, the vertex normals of the
/// encoding and one batch of bytes.
fn answer_bytes(m: &Mesh) -> u64 {
    mesh_bytes(m) + 12 * m.positions.len() as u64 + codec::BATCH_BYTES
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Bad(e)
    }
}

impl From<Abandoned> for Failure {
    fn from(_: Abandoned) -> Self {
        Failure::Abandoned
    }
}

impl From<isoforge::Error> for Failure {
    fn from(e: isoforge::Error) -> Self {
        Failure::Bad(e.into())
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Takes `m` as soon as it is free, or gives up when the client goes away.
fn lock_or_abandon<'a, T>(m: &'a Mutex<T>, req: &Request) -> Result<MutexGuard<'a, T>, Abandoned> {
    loop {
        match m.try_lock() {
            Ok(g) => return Ok(g),
            Err(std::sync::TryLockError::Poisoned(p)) => return Ok(p.into_inner()),
            Err(std::sync::TryLockError::WouldBlock) => {
                if req.is_abandoned() {
                    return Err(Abandoned);
                }
                std::thread::sleep(Duration::from_millis(5));
            }
        }
    }
}

fn still_wanted(req: &Request) -> Result<(), Abandoned> {
    if req.is_abandoned() {
        Err(Abandoned)
    } else {
        Ok(())
    }
}

impl Viewer {
    fn new(shown: Shown, base: pipeline::Request) -> Viewer {
        let histogram = match &shown {
            Shown::Volume { grid, .. } => Histogram::of(grid, 128),
            _ => None,
        };
        Viewer {
            shown,
            base,
            histogram,
            preview: Mutex::new(None),
            last_mesh: Mutex::new(None),
            last_check: Mutex::new(None),
            extracting: Mutex::new(()),
            checking: Mutex::new(()),
            stats: Arc::new(Stats::default()),
            budget: Budget::new(MEMORY_BUDGET, BUDGET_WAIT),
            full_estimate: AtomicU64::new(u64::MAX),
            preview_estimate: AtomicU64::new(FIRST_PREVIEW_ESTIMATE),
        }
    }

    fn route(&self, req: &Request) -> Response {
        let params = match parse_query(&req.query) {
            Ok(p) => p,
            Err(e) => return Response::error(400, format!("{e:#}")),
        };
        let answer = match req.path.as_str() {
            "/api/info" => Ok(json_response(&self.info())),
            "/api/status" => Ok(json_response(&self.status())),
            "/api/mesh" => self.mesh_reply(&params, req),
            "/api/check" => self.check_reply(&params, req),
            "/api/export" => self.export_reply(&params, req),
            p => {
                return match PAGE.iter().find(|(path, _, _)| *path == p || (p == "/index.html" && *path == "/")) {
                    Some((_, text, mime)) => Response::ok(mime, Body::Static(text.as_bytes())),
                    None => Response::error(404, format!("{p}: not found")),
                }
            }
        };
        match answer {
            Ok(r) => r,
            Err(Failure::Abandoned) => Response::abandoned(),
            Err(Failure::Bad(e)) => Response::error(400, format!("{e:#}")),
            Err(Failure::Busy) => {
                let mut r = Response::error(503, "busy: requests in flight hold the memory budget, retry later");
                r.headers.push(("Retry-After", "5".into()));
                r
            }
        }
    }

    /// The query parameters `/api/mesh` and `/api/check` accept for what is shown.
    fn accepted(&self) -> &'static [&'static str] {
        match self.shown {
            Shown::Demo => &["method", "iso", "field", "n", "t"],
            Shown::Volume { .. } => &["method", "iso", "roi"],
            Shown::Sparse { .. } => &["method", "iso"],
            Shown::Mesh { .. } => &[],
        }
    }

    fn info(&self) -> Value {
        let methods: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        let parameters = self.accepted();
        let method = self.base.options.method.name();
        match &self.shown {
            Shown::Demo => json!({
                "kind": "demo", "parameters": parameters, "methods": methods, "method": method,
                "fields": Classic::ALL.map(|c| c.name()), "iso": isoforge::volume::classic::CLASSIC_ISO,
                "n": {"min": MIN_N, "max": MAX_N, "default": 40}
            }),
            Shown::Volume { name, grid } => {
                let h = self.histogram.as_ref();
                json!({
                    "kind": "volume", "name": name, "parameters": parameters, "methods": methods, "method": method,
                    "dims": grid.lattice().dims(), "inside": self.base.inside.unwrap_or_default().name(),
                    "range": h.map(|h| [h.min, h.max]), "histogram": h.map(|h| h.counts.clone()),
                    "iso": h.map(|h| h.surface_iso()), "preview_step": preview_step(grid.lattice().num_points()),
                })
            }
            Shown::Sparse { name, grid } => {
                let (range, stats) = (grid.value_range().map(|r| [r.min, r.max]), grid.stats());
                // A level set's surface is at 0; other grids start in the middle of their values.
                let iso = range.map(|[lo, hi]| if lo < 0.0 && hi > 0.0 { 0.0 } else { (lo + hi) / 2.0 });
                json!({
                    "kind": "volume", "name": name, "parameters": parameters, "methods": methods, "method": method,
                    "dims": grid.lattice().dims(), "inside": self.base.inside.unwrap_or_default().name(),
                    "range": range, "histogram": null, "iso": iso,
                    "preview_step": 1u32 << sparse_preview_level(grid), "sparse": { "leaves": stats.leaves, "stored_samples": stats.stored_samples, "bytes": stats.bytes },
                })
            }
            Shown::Mesh { name, mesh } => json!({
                "kind": "mesh", "name": name, "parameters": parameters,
                "vertices": mesh.num_vertices(), "triangles": mesh.num_triangles()
            }),
        }
    }

    fn status(&self) -> Value {
        use std::sync::atomic::Ordering::Relaxed;
        json!({
            "served": self.stats.served.load(Relaxed),
            "abandoned": self.stats.abandoned.load(Relaxed),
            "refused": self.stats.refused.load(Relaxed),
            "memory": { "budget": self.budget.limit, "reserved": *lock(&self.budget.used) },
        })
    }

    /// Checks `params` against what is shown (`extra` are the endpoint's own) and types them.
    fn query(&self, params: &[(String, String)], extra: &[&str]) -> Result<Query> {
        let accepted = self.accepted();
        if let Some((k, _)) =
            params.iter().find(|(k, _)| !accepted.contains(&k.as_str()) && !extra.contains(&k.as_str()))
        {
            let all: Vec<&str> = accepted.iter().chain(extra).copied().collect();
            bail!("parameter {k:?} is not accepted here (accepted: {})", all.join(", "));
        }
        let mut r = self.base.clone();
        if let Some(m) = get(params, "method") {
            r.options.method = m.parse().map_err(param("method"))?;
        }
        let iso = get(params, "iso").map(request::parse_iso).transpose().map_err(param("iso"))?;
        r.isos = iso.into_iter().collect();
        let mut q = Query { request: r, demo: None };
        match &self.shown {
            Shown::Demo => {
                let name = get(params, "field").unwrap_or("metaballs");
                let field =
                    Classic::parse(name).ok_or_else(|| anyhow!("field={name:?}: metaballs, lines or height"))?;
                let n = number(params, "n")?.unwrap_or(40.0);
                if !(MIN_N as f64..=MAX_N as f64).contains(&n) || n.fract() != 0.0 {
                    bail!("n={n:e}: a whole number from {MIN_N} to {MAX_N}");
                }
                let t = number(params, "t")?.unwrap_or(isoforge::volume::catalog::DEFAULT_TIME as f64);
                if !(-1e6..=1e6).contains(&t) {
                    bail!("t={t:e}: out of range (at most 1e6 in magnitude)");
                }
                q.demo = Some(Demo { field, n: n as u32, t: t as f32 });
            }
            Shown::Volume { grid, .. } => {
                if iso.is_none() {
                    bail!("iso is required");
                }
                if let Some(roi) = get(params, "roi").filter(|r| !r.trim().is_empty()) {
                    q.request.region.roi = Some(checked_roi(roi, grid)?);
                }
            }
            Shown::Sparse { .. } if iso.is_none() => bail!("iso is required"),
            Shown::Sparse { .. } | Shown::Mesh { .. } => {}
        }
        Ok(q)
    }

    /// True when `/api/mesh` with `level=preview` (`preview`) answers a coarser mesh than the full.
    fn has_preview(&self, q: &Query, preview: bool) -> Result<bool> {
        Ok(preview
            && match &self.shown {
                Shown::Volume { grid, .. } => {
                    let points = match &q.request.region.roi {
                        None => grid.lattice().num_points(),
                        Some(roi) => {
                            let (lo, hi) = roi.point_box(grid.lattice())?;
                            (0..3).map(|a| u64::from(hi[a] - lo[a])).product()
                        }
                    };
                    preview_step(points) > 1
                }
                Shown::Sparse { grid, .. } => sparse_preview_level(grid) > 0,
                Shown::Demo | Shown::Mesh { .. } => false,
            })
    }

    fn mesh_reply(&self, params: &[(String, String)], req: &Request) -> Result<Response, Failure> {
        use std::sync::atomic::Ordering::Relaxed;
        let level = get(params, "level").unwrap_or("full");
        let q = self.query(params, &["level"])?;
        let preview = match level {
            "full" => false,
            "preview" => true,
            l => return Err(Failure::Bad(anyhow!("level={l:?}: preview or full"))),
        };
        still_wanted(req)?;
        let estimate = if self.has_preview(&q, preview)? { &self.preview_estimate } else { &self.full_estimate };
        // A mesh of V vertices holds 12 V bytes of positions and about 24 V of triangles; the
        // encoding's normals add 12 V, a third.
        let e = estimate.load(Relaxed);
        let mut held =
            self.budget.reserve(e.saturating_add(e / 3).saturating_add(codec::BATCH_BYTES), || req.is_abandoned())?;
        let start = Instant::now();
        let sparse_level = match &self.shown {
            Shown::Sparse { grid, .. } if preview => sparse_preview_level(grid),
            _ => 0,
        };
        let (mesh, step) = match self.preview_grid(&q, preview, req)? {
            _ if sparse_level > 0 => {
                let Shown::Sparse { grid, .. } = &self.shown else { unreachable!("a level only for sparse grids") };
                let opts = pipeline::Options { level: sparse_level, ..q.request.options.clone() };
                let mesh = pipeline::extract_any_sparse(grid, self.iso(&q)?, &opts)?.mesh;
                (Arc::new(drawable(mesh)), 1 << sparse_level)
            }
            Some((grid, step)) => {
                let mesh = pipeline::extract_grid(&grid, self.iso(&q)?, &q.request.options, None)?.mesh;
                (Arc::new(drawable(mesh)), step)
            }
            None => (self.full_mesh(&q, req)?, 1),
        };
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let estimate = if step > 1 { &self.preview_estimate } else { &self.full_estimate };
        estimate.store(mesh_bytes(&mesh).max(1 << 20), Relaxed);
        held.resize(answer_bytes(&mesh));
        still_wanted(req)?;
        let head = json!({
            "level": if step > 1 { "preview" } else { "full" }, "step": step, "method": q.method().name(),
            "vertices": mesh.num_vertices(), "triangles": mesh.num_triangles(), "extraction_ms": ms,
        });
        // Streamed as it is encoded; the share of the budget is given back once it is written.
        let writer: http::Writer = Box::new(move |w: &mut dyn std::io::Write| {
            let _held = held;
            codec::write_mesh(w, &mesh, head)
        });
        Ok(Response::ok("application/octet-stream", Body::Stream(writer)))
    }

    fn iso(&self, q: &Query) -> Result<Iso> {
        let default = match (&self.shown, q.demo) {
            (Shown::Volume { .. } | Shown::Sparse { .. }, _) if q.request.isos.is_empty() => bail!("iso is required"),
            (Shown::Volume { .. } | Shown::Sparse { .. }, _) => Iso::below(0.0),
            // The demo fields keep their own inside rule.
            (_, Some(d)) => {
                let iso = d.field.builtin(MIN_N, d.t)?.iso;
                return Ok(Iso { value: q.request.isos.first().copied().unwrap_or(iso.value), inside: iso.inside });
            }
            _ => bail!("internal: no iso for a mesh; this is a bug, please report it"),
        };
        Ok(q.request.isos_or(default)[0])
    }

    /// For a preview of a large volume: its block-averaged grid (kept for the next request) and
    /// the step. `None` when the full resolution is wanted or small enough to be the preview.
    fn preview_grid(&self, q: &Query, preview: bool, req: &Request) -> Result<Option<(Arc<AnyGrid>, u32)>, Failure> {
        let Shown::Volume { grid, .. } = &self.shown else { return Ok(None) };
        let roi = &q.request.region.roi;
        let boxed = roi.as_ref().map(|r| r.point_box(grid.lattice())).transpose()?;
        let points = match boxed {
            None => grid.lattice().num_points(),
            Some((lo, hi)) => (0..3).map(|a| u64::from(hi[a] - lo[a])).product(),
        };
        let step = preview_step(points);
        if !preview || step == 1 {
            return Ok(None);
        }
        let mut cached = lock_or_abandon(&self.preview, req)?;
        if let Some(p) = cached.as_ref().filter(|p| p.roi == *roi && p.step == step) {
            return Ok(Some((p.grid.clone(), step)));
        }
        let down = |g: &AnyGrid| -> Result<AnyGrid> {
            Ok(AnyGrid::F32(isoforge::with_grid!(g, g => downsample_mean(g, step))?))
        };
        let g = Arc::new(down(&*roi_only(q).apply_to(Cow::Borrowed(grid), 0.0)?)?);
        *cached = Some(Preview { roi: roi.clone(), step, grid: g.clone() });
        Ok(Some((g, step)))
    }

    /// The full-resolution mesh: the last one when the query is the same, else extracted (one
    /// extraction at a time; a request whose client left while waiting is dropped).
    fn full_mesh(&self, q: &Query, req: &Request) -> Result<Arc<Mesh>, Failure> {
        let cached = || lock(&self.last_mesh).as_ref().filter(|(k, _)| k == q).map(|(_, m)| m.clone());
        if let Some(m) = cached() {
            return Ok(m);
        }
        let _turn = lock_or_abandon(&self.extracting, req)?;
        if let Some(m) = cached() {
            return Ok(m);
        }
        still_wanted(req)?;
        let opts = &q.request.options;
        let mesh = match (&self.shown, q.demo) {
            (Shown::Mesh { mesh, .. }, _) => mesh.clone(),
            (Shown::Volume { grid, .. }, _) => {
                // The library's cut of the region (the grid borrowed when there is no ROI).
                let cut = roi_only(q).apply_to(Cow::Borrowed(grid), 0.0)?;
                pipeline::extract_grid(&cut, self.iso(q)?, opts, None)?.mesh
            }
            (Shown::Sparse { grid, .. }, _) => pipeline::extract_any_sparse(grid, self.iso(q)?, opts)?.mesh,
            (Shown::Demo, Some(d)) => {
                pipeline::extract_builtin(&d.field.builtin(d.n, d.t)?, self.iso(q)?, opts, None)?.mesh
            }
            (Shown::Demo, None) => return Err(Failure::Bad(anyhow!("internal: a demo query without a field"))),
        };
        let mesh = Arc::new(drawable(mesh));
        *lock(&self.last_mesh) = Some((q.clone(), mesh.clone()));
        Ok(mesh)
    }

    fn check_reply(&self, params: &[(String, String)], req: &Request) -> Result<Response, Failure> {
        let q = self.query(params, &[])?;
        let cached = || lock(&self.last_check).as_ref().filter(|(k, _)| *k == q).map(|(_, b)| b.clone());
        if let Some(b) = cached() {
            return Ok(Response::ok("application/octet-stream", Body::Owned(b.to_vec())));
        }
        use std::sync::atomic::Ordering::Relaxed;
        let estimate = self.full_estimate.load(Relaxed).saturating_mul(CHECK_MESHES);
        let mut held = self.budget.reserve(estimate, || req.is_abandoned())?;
        let mesh = self.full_mesh(&q, req)?;
        self.full_estimate.store(mesh_bytes(&mesh).max(1 << 20), Relaxed);
        held.resize(mesh_bytes(&mesh) * CHECK_MESHES);
        let _turn = lock_or_abandon(&self.checking, req)?;
        if let Some(b) = cached() {
            return Ok(Response::ok("application/octet-stream", Body::Owned(b.to_vec())));
        }
        still_wanted(req)?;
        let start = Instant::now();
        let mut r =
            topo::check_with(&mesh, &CheckOptions { max_examples: MAX_DEFECT_EDGES, ..CheckOptions::default() });
        let ms = start.elapsed().as_secs_f64() * 1e3;
        // The defect edges go to the page as pairs; the JSON keeps the CLI's ten examples.
        let mut edges: Vec<[u32; 2]> = r.boundary_edges.examples.iter().map(|f| f.edge).collect();
        edges.extend(r.non_manifold_edges.examples.iter().map(|f| f.edge));
        edges.truncate(MAX_DEFECT_EDGES);
        trim_examples(&mut r, 10);
        let mut head = crate::report::mesh_json(&r);
        head["method"] = json!(q.method().name());
        head["check_ms"] = json!(ms);
        head["components"] = json!(r.components.len());
        head["defect_edges"] = json!(r.boundary_edges.count + r.non_manifold_edges.count);
        head["defect_edges_sent"] = json!(edges.len());
        let bytes = Arc::new(codec::encode_edges(&edges, &head));
        *lock(&self.last_check) = Some((q, bytes.clone()));
        still_wanted(req)?;
        Ok(Response::ok("application/octet-stream", Body::Owned(bytes.to_vec())))
    }

    fn export_reply(&self, params: &[(String, String)], req: &Request) -> Result<Response, Failure> {
        let q = self.query(params, &["format"])?;
        use std::sync::atomic::Ordering::Relaxed;
        let (mime, file) = match get(params, "format").unwrap_or("ply") {
            "ply" => ("application/octet-stream", "ply"),
            "obj" => ("text/plain; charset=utf-8", "obj"),
            "stl" => ("application/octet-stream", "stl"),
            "glb" => ("model/gltf-binary", "glb"),
            f => return Err(Failure::Bad(anyhow!("format={f:?}: ply, obj, stl or glb"))),
        };
        let mut held = self.budget.reserve(self.full_estimate.load(Relaxed), || req.is_abandoned())?;
        let mesh = self.full_mesh(&q, req)?;
        let bytes = mesh_bytes(&mesh);
        self.full_estimate.store(bytes.max(1 << 20), Relaxed);
        held.resize(bytes);
        // Streamed to the client as it is written: the body is never whole in memory.
        // The share of the budget is given back once the file is written.
        let writer: http::Writer = Box::new(move |w: &mut dyn std::io::Write| {
            let _held = held;
            match file {
                "ply" => isoforge_io::write::ply::write_ply(w, &mesh, false),
                "obj" => isoforge_io::write::obj::write_obj(w, &mesh),
                "stl" => isoforge_io::write::stl::write_stl(w, &mesh),
                _ => {
                    let data = isoforge_io::MeshData::default();
                    let named = [isoforge_io::NamedMesh { name: "isosurface", mesh: &mesh, data: &data }];
                    isoforge_io::write::gltf::write_glb(w, &named)
                }
            }
        });
        let mut r = Response::ok(mime, Body::Stream(writer));
        r.headers.push(("Content-Disposition", format!("attachment; filename=\"isosurface.{file}\"")));
        Ok(r)
    }
}

/// The coarsest pyramid level a sparse grid's preview needs: each level quarters the stored
/// samples of a surface (halves each axis of a band), so the smallest `L` that brings them
/// under [`PREVIEW_POINTS`] (0: no preview), at most 4.
/// The query's ROI as a region (the viewer cuts, never pads or re-places).
fn roi_only(q: &Query) -> Region {
    Region { roi: q.request.region.roi.clone(), ..Region::default() }
}

fn sparse_preview_level(grid: &AnySparse) -> u32 {
    preview_level(grid.stats().stored_samples)
}

/// [`sparse_preview_level`] for `stored` samples.
fn preview_level(stored: u64) -> u32 {
    (0..4).find(|&l| stored >> (2 * l) <= PREVIEW_POINTS).unwrap_or(4)
}

/// The smallest block size that brings `points` under [`PREVIEW_POINTS`] (1: no preview).
fn preview_step(points: u64) -> u32 {
    let mut step = 1u32;
    while points / (step as u64).pow(3) > PREVIEW_POINTS {
        step += 1;
    }
    step
}

/// Keeps at most `max` examples of each finding.
fn trim_examples(r: &mut topo::MeshReport, max: usize) {
    r.isolated_vertices.examples.truncate(max);
    r.boundary_edges.examples.truncate(max);
    r.non_manifold_edges.examples.truncate(max);
    r.non_manifold_vertices.examples.truncate(max);
    r.inconsistent_edges.examples.truncate(max);
    r.collapsed_triangles.examples.truncate(max);
    r.zero_area_triangles.examples.truncate(max);
    r.duplicate_triangles.examples.truncate(max);
}

fn json_response(v: &Value) -> Response {
    Response::ok("application/json", Body::Owned(v.to_string().into_bytes()))
}

fn parse_query(q: &str) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    for pair in q.split('&').filter(|p| !p.is_empty()) {
        let (k, v) = pair.split_once('=').unwrap_or((pair, ""));
        if k.len() > 32 || v.len() > 64 {
            bail!("parameter {:?}: too long", k.get(..k.len().min(32)).unwrap_or(""));
        }
        let k = decode(k)?;
        if out.iter().any(|(seen, _)| *seen == k) {
            bail!("parameter {k:?} given twice");
        }
        out.push((k, decode(v)?));
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

fn get<'a>(params: &'a [(String, String)], key: &str) -> Option<&'a str> {
    params.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

fn number(params: &[(String, String)], key: &str) -> Result<Option<f64>> {
    match get(params, key) {
        None => Ok(None),
        Some(v) => {
            let x: f64 = v.trim().parse().map_err(|_| anyhow!("{key}={v:?}: not a number"))?;
            if !x.is_finite() {
                bail!("{key}={v:?}: must be finite");
            }
            Ok(Some(x))
        }
    }
}

/// `roi=i0:i1,j0:j1,k0:k1`: parsed and checked as `extract --roi` is ([`Roi::parse_index`],
/// [`Roi::point_box`]), and holding at least two points per axis (a mesh needs a cell).
fn checked_roi(text: &str, grid: &AnyGrid) -> Result<Roi> {
    let roi = Roi::parse_index(text).map_err(param("roi"))?;
    let (lo, hi) = roi.point_box(grid.lattice()).map_err(|e| anyhow!("roi={text:?}: {e}"))?;
    if let Some(a) = (0..3).find(|&a| hi[a] - lo[a] < 2) {
        bail!("roi={text:?}: axis {a} range {}:{} must hold at least 2 points", lo[a], hi[a]);
    }
    Ok(roi)
}

/// The mesh as the page draws it: triangles only (quads of dual methods split).
fn drawable(mut mesh: isoforge::mesh::Mesh) -> isoforge::mesh::Mesh {
    mesh.triangulate();
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_memory_budget_makes_exports_wait_then_refuses() {
        let b = Budget::new(100, Duration::from_millis(300));
        let first = b.reserve(80, || false).ok().unwrap();
        // No room: waits, then Busy (503 + Retry-After).
        let t = Instant::now();
        assert!(matches!(b.reserve(40, || false), Err(Failure::Busy)));
        assert!(t.elapsed() >= Duration::from_millis(300));
        // An abandoned request stops waiting.
        assert!(matches!(b.reserve(40, || true), Err(Failure::Abandoned)));
        // Room is given back when the first answer is written; a waiter gets it.
        let b2 = b.clone();
        let waiter = std::thread::spawn(move || b2.reserve(40, || false).is_ok());
        std::thread::sleep(Duration::from_millis(50));
        drop(first);
        assert!(waiter.join().unwrap());
        assert_eq!(*lock(&b.used), 0);
        // Larger than the whole budget: runs alone.
        let big = b.reserve(1000, || false).ok().unwrap();
        assert_eq!(*lock(&b.used), 100);
        drop(big);
        // resize follows what was really allocated.
        let mut r = b.reserve(10, || false).ok().unwrap();
        r.resize(70);
        assert_eq!(*lock(&b.used), 70);
    }

    #[test]
    fn sparse_previews_take_the_level_that_brings_samples_under_the_budget() {
        assert_eq!(preview_level(PREVIEW_POINTS), 0);
        assert_eq!(preview_level(PREVIEW_POINTS + 1), 1);
        assert_eq!(preview_level(4 * PREVIEW_POINTS), 1);
        assert_eq!(preview_level(4 * PREVIEW_POINTS + 4), 2);
        assert_eq!(preview_level(u64::MAX), 4, "at most four levels");
    }

    #[test]
    fn preview_steps_bring_points_under_the_budget() {
        assert_eq!(preview_step(100), 1);
        assert_eq!(preview_step(PREVIEW_POINTS), 1);
        assert_eq!(preview_step(256 * 256 * 128), 2);
        assert_eq!(preview_step(512 * 512 * 450), 4);
        assert_eq!(preview_step(512 * 512 * 361), 4);
    }

    #[test]
    fn regions_are_checked_against_the_dims() {
        let g: AnyGrid =
            isoforge::grid::DenseGrid::<u8>::new(isoforge::grid::Lattice::new([5, 6, 7]).unwrap(), vec![0; 210])
                .unwrap()
                .into();
        let roi = checked_roi("1:4,:,2:", &g).unwrap();
        assert_eq!(roi.point_box(g.lattice()).unwrap(), ([1, 0, 2], [4, 6, 7]));
        for bad in ["1:99,:,:", "3:4,:,:", ":,:", "a:b,:,:", "4:2,:,:"] {
            assert!(checked_roi(bad, &g).is_err(), "{bad}");
        }
        assert!(checked_roi(":,:", &g).unwrap_err().to_string().starts_with("roi=\":,:\": expected three ranges"));
    }

    #[test]
    fn queries_are_decoded_and_checked() {
        let p = parse_query("roi=1%3A4%2C%3A%2C2%3A&iso=10.5").unwrap();
        assert_eq!(get(&p, "roi"), Some("1:4,:,2:"));
        assert!(parse_query("iso=1&iso=2").is_err());
        assert!(parse_query("iso=%zz").is_err());
        assert!(parse_query(&format!("iso={}", "1".repeat(65))).is_err());
    }
}
