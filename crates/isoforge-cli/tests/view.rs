//! `isoforge view` end to end, against the real binary over raw TCP: the API shows what
//! `extract` writes (decoded here from the compact binary form), previews of large volumes,
//! mesh files (issue 10), and the hardening of issue 10 item 1 (stalled and trickling clients,
//! oversize requests, foreign `Host` headers, abandoned requests).

use std::io::{BufRead, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use serde_json::Value;

fn isoforge(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_isoforge")).args(args).output().expect("run isoforge")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `isoforge view` running in the background, killed when dropped.
struct Viewer {
    child: std::process::Child,
    addr: String,
}

impl Viewer {
    fn start(args: &[&str]) -> Viewer {
        let mut child = Command::new(env!("CARGO_BIN_EXE_isoforge"))
            .arg("view")
            .args(args)
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("start isoforge view");
        let mut line = String::new();
        std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let addr = line.trim().trim_start_matches("http://").trim_end_matches('/').to_string();
        assert!(addr.starts_with("127.0.0.1:"), "view printed {line:?}");
        Viewer { child, addr }
    }

    /// (status, body) of GET `path`.
    fn get(&self, path: &str) -> (u16, Vec<u8>) {
        self.raw(format!("GET {path} HTTP/1.1\r\nHost: {}\r\n\r\n", self.addr).as_bytes())
    }

    /// (status, body) of the answer to `request`, sent as it is.
    fn raw(&self, request: &[u8]) -> (u16, Vec<u8>) {
        let mut s = TcpStream::connect(&self.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
        let _ = s.write_all(request);
        let mut raw = Vec::new();
        let _ = s.read_to_end(&mut raw);
        let Some(split) = raw.windows(4).position(|w| w == b"\r\n\r\n") else { return (0, raw) };
        let head = String::from_utf8_lossy(&raw[..split]).into_owned();
        let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
        (status, raw[split + 4..].to_vec())
    }

    fn json(&self, path: &str) -> Value {
        let (code, body) = self.get(path);
        assert_eq!(code, 200, "{path}: {}", String::from_utf8_lossy(&body));
        serde_json::from_slice(&body).unwrap()
    }

    /// The decoded `/api/mesh` answer.
    fn mesh(&self, query: &str) -> Decoded {
        let (code, body) = self.get(&format!("/api/mesh?{query}"));
        assert_eq!(code, 200, "{query}: {}", String::from_utf8_lossy(&body));
        decode_mesh(&body)
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A mesh as the page receives it, decoded: the head, dequantised positions, triangles.
struct Decoded {
    head: Value,
    positions: Vec<[f32; 3]>,
    triangles: Vec<[u32; 3]>,
}

/// The JSON head and the offset of what follows it (see src/view/codec.rs for the layout).
fn head(body: &[u8]) -> (Value, usize) {
    let n = u32::from_le_bytes(body[..4].try_into().unwrap()) as usize;
    (serde_json::from_slice(&body[4..4 + n]).unwrap(), (4 + n).div_ceil(4) * 4)
}

fn decode_mesh(body: &[u8]) -> Decoded {
    let (head, mut at) = head(body);
    let (v, t) = (head["vertices"].as_u64().unwrap() as usize, head["triangles"].as_u64().unwrap() as usize);
    let b = |k: &str, a: usize| head["box"][k][a].as_f64().unwrap() as f32;
    let u16_at = |i: usize| u16::from_le_bytes([body[i], body[i + 1]]);
    let positions = (0..v)
        .map(|i| {
            [0, 1, 2].map(|a| b("min", a) + u16_at(at + 6 * i + 2 * a) as f32 / 65535.0 * (b("max", a) - b("min", a)))
        })
        .collect();
    at = (at + 6 * v).div_ceil(4) * 4;
    at = (at + 2 * v).div_ceil(4) * 4; // normals: checked by the codec's unit tests
    let mut flat = Vec::with_capacity(3 * t);
    match head["index"]["encoding"].as_str().unwrap() {
        "u16" => {
            assert_eq!(body.len() - at, 6 * t, "u16 indices fill the rest");
            flat.extend((0..3 * t).map(|i| u16_at(at + 2 * i) as u32));
        }
        "varint" => {
            let (mut prev, mut z, mut shift) = (0i64, 0u64, 0);
            for &byte in &body[at..] {
                z |= ((byte & 0x7f) as u64) << shift;
                shift += 7;
                if byte < 0x80 {
                    prev += (z >> 1) as i64 ^ -((z & 1) as i64);
                    flat.push(u32::try_from(prev).unwrap());
                    (z, shift) = (0, 0);
                }
            }
            assert_eq!(shift, 0, "the last varint is complete");
        }
        e => panic!("index encoding {e}"),
    }
    assert_eq!(flat.len(), 3 * t, "{head}");
    let triangles = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Decoded { head, positions, triangles }
}

/// `isoforge extract ARGS -o mesh.ply`, read back.
fn extract(args: &[&str]) -> isoforge::mesh::Mesh {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.ply");
    let o = isoforge(&[&["extract"], args, &["-o", p(&out)]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    isoforge_io::read_mesh(&out, &isoforge_io::Limits::default()).unwrap()
}

/// The page's mesh is extract's: the same triangles, positions within the quantisation step.
fn assert_same(what: &str, got: &Decoded, want: &isoforge::mesh::Mesh) {
    assert_eq!((got.positions.len(), got.triangles.len()), (want.num_vertices(), want.num_triangles()), "{what}");
    assert_eq!(got.triangles, want.triangles, "{what}: triangles");
    let b = &got.head["box"];
    for (g, w) in got.positions.iter().zip(&want.positions) {
        for a in 0..3 {
            let step = (b["max"][a].as_f64().unwrap() - b["min"][a].as_f64().unwrap()) as f32 / 65535.0;
            assert!((g[a] - w[a]).abs() <= step * 0.5 + 1e-5 * w[a].abs().max(1.0), "{what}: {g:?} vs {w:?}");
        }
    }
}

#[test]
fn the_viewer_serves_what_extract_writes() {
    let demo = Viewer::start(&[]);
    let info = demo.json("/api/info");
    assert_eq!(info["kind"], "demo");
    assert_eq!(info["methods"].as_array().unwrap().len(), isoforge::pipeline::Method::ALL.len());
    // The page starts on the method `view --method` chose (default: mc33, as extract).
    assert_eq!(info["method"], "mc33");
    assert_eq!(info["fields"], serde_json::json!(["metaballs", "lines", "height"]));
    // The typed demo fields equal the catalogue's `field:` specs, through every method class.
    for (query, spec, method, iso) in [
        ("field=metaballs&n=48&t=0.25&method=mc33", "field:metaballs?n=48&t=0.25", "mc33", None),
        ("field=lines&n=32&method=mt6&iso=40", "field:lines?n=32", "mt6", Some("40")),
        ("field=height&n=24&method=mc", "field:height?n=24", "mc", None),
        ("field=metaballs&n=32&method=dc", "field:metaballs?n=32", "dc", None),
        ("field=lines&n=32&method=emc", "field:lines?n=32", "emc", None),
        ("field=height&n=24", "field:height?n=24", "mc33", None),
    ] {
        let got = demo.mesh(&format!("{query}&level=full"));
        assert_eq!(got.head["level"], "full");
        let mut args = vec!["-i", spec, "--method", method];
        if let Some(iso) = iso {
            args.extend(["--iso", iso]);
        }
        assert_same(query, &got, &extract(&args));
        assert_eq!(got.head["index"]["encoding"], "u16", "small meshes take two bytes an index");
    }
    // Every parameter is checked; nothing unbounded gets through.
    for bad in [
        "/api/mesh?n=100000",
        "/api/mesh?n=7.5",
        "/api/mesh?iso=nan",
        "/api/mesh?method=nope",
        "/api/mesh?zoom=2",
        "/api/mesh?field=sphere",
        "/api/mesh?level=half",
        "/api/mesh?n=40&n=41",
        "/api/export?format=fbx",
        "/api/check?format=ply",
    ] {
        let (code, body) = demo.get(bad);
        assert_eq!(code, 400, "{bad}: {}", String::from_utf8_lossy(&body));
    }
    assert_eq!(demo.get("/nothing-here").0, 404);
    // The page is the tree's viewer/page, embedded as it is: no build step.
    for (path, file) in [("/", "index.html"), ("/main.js", "main.js"), ("/gl.js", "gl.js"), ("/codec.js", "codec.js")] {
        let (code, body) = demo.get(path);
        assert_eq!(code, 200, "{path}");
        assert_eq!(body, std::fs::read(repo().join("viewer/page").join(file)).unwrap(), "{path}");
    }
    // Export: a PLY that reads back watertight; the check of the same mesh.
    let (code, ply) = demo.get("/api/export?format=ply&n=24");
    assert_eq!(code, 200);
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("e.ply");
    std::fs::write(&f, ply).unwrap();
    assert!(isoforge(&["check", p(&f), "--require", "watertight"]).status.success());
    let (code, body) = demo.get("/api/check?n=24");
    assert_eq!(code, 200);
    let (report, _) = head(&body);
    assert_eq!((report["closed"].as_bool(), report["manifold"].as_bool()), (Some(true), Some(true)), "{report}");
    assert_eq!(report["defect_edges"], 0);

    // A volume: iso over its range, the same mesh as extract, its open faces as defect edges.
    let vol = repo().join("testdata/volumes/u8_raw.nrrd");
    let v = Viewer::start(&[p(&vol)]);
    let info = v.json("/api/info");
    assert_eq!(info["kind"], "volume");
    assert_eq!(info["range"], serde_json::json!([0.0, 22.0]));
    assert_eq!(info["preview_step"], 1, "small volumes need no preview");
    let got = v.mesh("iso=10.5&level=preview");
    assert_eq!(got.head["level"], "full", "the preview of a small volume is the full resolution");
    let want = extract(&["-i", p(&vol), "--iso", "10.5"]);
    assert_same("volume", &got, &want);
    let (code, body) = v.get("/api/check?iso=10.5");
    assert_eq!(code, 200);
    let (report, at) = head(&body);
    let defects = report["defect_edges"].as_u64().unwrap() as usize;
    assert!(defects > 0 && report["closed"] == false, "open at the volume faces: {report}");
    assert_eq!(report["defect_edges_sent"].as_u64().unwrap() as usize, defects);
    // The defect edges sent are the edges used by one triangle, every one of them.
    let mut uses = std::collections::HashMap::new();
    for t in &want.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut boundary: Vec<[u32; 2]> = uses.into_iter().filter(|&(_, n)| n == 1).map(|((a, b), _)| [a, b]).collect();
    boundary.sort_unstable();
    let mut sent: Vec<[u32; 2]> = body[at..]
        .chunks_exact(8)
        .map(|c| [0, 4].map(|o| u32::from_le_bytes(c[o..o + 4].try_into().unwrap())))
        .collect();
    sent.sort_unstable();
    assert_eq!(sent, boundary);
    assert_eq!(v.get("/api/mesh?iso=10.5&field=lines").0, 400, "demo parameters are refused for a volume");
    assert_eq!(v.get("/api/mesh?level=full").0, 400, "a volume needs an iso");
    // A region, percent-encoded as browsers send it, equals extract --roi.
    let got = v.mesh("iso=10.5&roi=1%3A4%2C%3A%2C2%3A&level=full");
    assert_same("roi", &got, &extract(&["-i", p(&vol), "--iso", "10.5", "--roi", "1:4,:,2:"]));
    assert_eq!(v.get("/api/mesh?iso=10.5&roi=1:99,:,:").0, 400);
}

#[test]
fn issue_10_mesh_files_are_shown() {
    // Issue 10: the page sent method=mc for a mesh file and the server refused it, so the page
    // stayed blank. The server now says which parameters it accepts (none for a mesh), the page
    // sends only those (viewer/e2e.mjs opens a mesh file in Chromium).
    let mesh = repo().join("testdata/meshes/tetra_ascii.ply");
    let m = Viewer::start(&[p(&mesh)]);
    let info = m.json("/api/info");
    assert_eq!(info["kind"], "mesh");
    assert_eq!(info["parameters"], serde_json::json!([]));
    let got = m.mesh("level=preview");
    assert_eq!((got.positions.len(), got.triangles.len()), (4, 4));
    assert_same("tetra", &got, &isoforge_io::read_mesh(&mesh, &isoforge_io::Limits::default()).unwrap());
    let (code, body) = m.get("/api/check");
    assert_eq!(code, 200);
    assert_eq!(head(&body).0["closed"], true);
    let (code, body) = m.get("/api/mesh?method=mc");
    assert_eq!(code, 400);
    assert!(String::from_utf8_lossy(&body).contains("\"method\" is not accepted here"));
    assert_eq!(m.get("/api/export?format=stl").0, 200);
}

/// A NRRD of `n`³ u8 points: an egg crate, 127 + 120 sin(i/4) sin(j/4) sin(k/4) (much surface).
fn write_crate(path: &Path, n: u32) {
    let mut data = Vec::with_capacity((n * n * n) as usize);
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let s = [i, j, k].map(|x| (x as f32 / 4.0).sin()).iter().product::<f32>();
                data.push((127.0 + 120.0 * s).round() as u8);
            }
        }
    }
    let header =
        format!("NRRD0004\ntype: uint8\ndimension: 3\nsizes: {n} {n} {n}\nspacings: 0.5 0.5 0.5\nencoding: raw\n\n");
    std::fs::write(path, [header.as_bytes(), &data].concat()).unwrap();
}

#[test]
fn issue_44_sparse_files_are_shown() {
    // An OpenVDB level set: served as a volume (its values' range, iso 0 first, no histogram),
    // meshed as `extract` meshes it; regions are not offered.
    let vdb = repo().join("testdata/vdb/sphere.vdb");
    let v = Viewer::start(&[p(&vdb)]);
    let info = v.json("/api/info");
    assert_eq!((info["kind"].as_str(), info["iso"].as_f64()), (Some("volume"), Some(0.0)), "{info}");
    assert!(info["histogram"].is_null() && info["sparse"]["leaves"].as_u64() > Some(0), "{info}");
    assert_eq!(info["parameters"], serde_json::json!(["method", "iso"]));
    let full = v.mesh("iso=0&level=preview");
    assert_eq!(full.head["level"], "full", "a small grid needs no preview");
    assert!(full.triangles.len() > 100);
    assert_same("sparse", &full, &extract(&["-i", p(&vdb), "--iso", "0"]));
    assert_eq!(v.get("/api/mesh?iso=0&roi=0:4,0:4,0:4").0, 400, "no regions on sparse grids");
}

#[test]
fn issue_10_large_volumes_get_a_preview_first() {
    // Issue 10: each slider step sent the whole mesh (147 MB on the shoulder CT). Volumes over
    // 2 M points now answer a preview first: the volume block-averaged, meshed the same way.
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("crate.nrrd");
    write_crate(&vol, 130); // 2.2 M points: step 2
    let v = Viewer::start(&[p(&vol), "--inside", "above"]);
    assert_eq!(v.json("/api/info")["preview_step"], 2);
    let preview = v.mesh("iso=127.5&level=preview");
    assert_eq!((preview.head["level"].as_str(), preview.head["step"].as_u64()), (Some("preview"), Some(2)));
    // The preview is the block mean of the volume, meshed: computed here with the library.
    let grid = isoforge_io::read_volume(&vol, &isoforge_io::Limits::default()).unwrap();
    let coarse = isoforge::with_grid!(&grid, g => isoforge::grid::downsample_mean(g, 2)).unwrap();
    let want = isoforge::pipeline::extract_grid(
        &isoforge::grid::AnyGrid::F32(coarse),
        isoforge::volume::Iso::above(127.5),
        &Default::default(),
        None,
    )
    .unwrap()
    .mesh;
    assert_same("preview", &preview, &want);
    let full = v.mesh("iso=127.5&level=full");
    assert_eq!(full.head["level"], "full");
    assert_same("full", &full, &extract(&["-i", p(&vol), "--iso", "127.5", "--inside", "above"]));
    assert_eq!(full.head["index"]["encoding"], "varint", "over 65536 vertices");
    assert!(
        preview.triangles.len() * 3 < full.triangles.len(),
        "{} vs {}",
        preview.triangles.len(),
        full.triangles.len()
    );
    // The check of the full resolution reuses its mesh, and says what `isoforge check` says.
    let (code, body) = v.get("/api/check?iso=127.5");
    assert_eq!(code, 200);
    let report = head(&body).0;
    let out = dir.path().join("full.ply");
    assert!(isoforge(&["extract", "-i", p(&vol), "--iso", "127.5", "--inside", "above", "-o", p(&out)])
        .status
        .success());
    let o = isoforge(&["check", "--json", p(&out)]);
    let cli: Value = serde_json::from_slice(&o.stdout).unwrap();
    for key in ["vertices", "triangles", "edges", "closed", "manifold", "oriented", "euler", "genus"] {
        assert_eq!(report[key], cli[key], "{key}");
    }
    assert_eq!(report["components"].as_u64(), cli["components"].as_array().map(|c| c.len() as u64));
    assert_eq!(report["defect_edges"], cli["findings"]["boundary_edges"]["count"], "open at the faces");
    // A region has its own preview (or none when small).
    let r = v.mesh("iso=127.5&roi=0:130,0:130,0:65&level=preview");
    assert_eq!(r.head["level"], "full", "1.1 M points need no preview");
}

#[test]
#[cfg(unix)]
fn issue_10_stalled_and_trickling_clients_do_not_block_others() {
    // Issue 10, hardening 1: one client that never read its response (or trickled a body) froze
    // every other request.
    let v = Viewer::start(&[]);
    // A client that asks for an 11 MB export and reads nothing: a tiny receive buffer makes
    // the server's writes block once its send buffer is full.
    let stalled = stalled_client(&v.addr, "/api/export?format=obj&n=160&method=mt-bcc");
    // A client that trickles its body, and one that trickles its headers.
    let mut body = TcpStream::connect(&v.addr).unwrap();
    write!(body, "GET /api/info HTTP/1.1\r\nHost: {}\r\nContent-Length: 1000\r\n\r\n", v.addr).unwrap();
    let mut headers = TcpStream::connect(&v.addr).unwrap();
    write!(headers, "GET /api/info HTTP/1.1\r\nHost: {}\r\n", v.addr).unwrap();
    let start = Instant::now();
    let mut answered = 0;
    while start.elapsed() < Duration::from_secs(4) {
        let _ = body.write_all(b"x");
        let _ = headers.write_all(b"X-Slow: 1\r\n");
        let t = Instant::now();
        let (code, _) = v.get("/api/status");
        assert_eq!(code, 200);
        assert!(t.elapsed() < Duration::from_secs(1), "a normal request took {:?}", t.elapsed());
        answered += 1;
        std::thread::sleep(Duration::from_millis(100));
    }
    // The export is still stuck in its write (not served), the tricklers still unanswered.
    let status = v.json("/api/status");
    assert_eq!(status["served"].as_u64(), Some(answered), "{status}");
    // The tricklers are cut at the 5 s request deadline with 408.
    for (name, mut s) in [("body", body), ("headers", headers)] {
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let mut out = String::new();
        let _ = s.read_to_string(&mut out);
        assert!(out.starts_with("HTTP/1.1 408"), "{name}: {out:?}");
    }
    assert!(start.elapsed() < Duration::from_secs(8), "cut after {:?}", start.elapsed());
    drop(stalled);
}

#[test]
fn issue_10_oversize_requests_are_refused() {
    let v = Viewer::start(&[]);
    let line = format!("GET /api/info?{} HTTP/1.1\r\nHost: {}\r\n\r\n", "a=1&".repeat(3000), v.addr);
    assert_eq!(v.raw(line.as_bytes()).0, 414);
    let many =
        format!("GET /api/info HTTP/1.1\r\nHost: {}\r\n{}\r\n", v.addr, "X-Pad: 0123456789abcdef\r\n".repeat(1000));
    assert_eq!(v.raw(many.as_bytes()).0, 431);
    let body = format!("GET /api/info HTTP/1.1\r\nHost: {}\r\nContent-Length: 100000000\r\n\r\n", v.addr);
    assert_eq!(v.raw(body.as_bytes()).0, 413);
    // Query parameters are capped too.
    assert_eq!(v.get(&format!("/api/mesh?iso={}", "1".repeat(100))).0, 400);
    assert_eq!(v.get("/api/info").0, 200, "the server is still up");
}

#[test]
fn issue_10_foreign_hosts_are_refused() {
    // DNS rebinding: a page of evil.example whose name now resolves to 127.0.0.1 still sends
    // its own Host.
    let v = Viewer::start(&[]);
    let port = v.addr.rsplit(':').next().unwrap().to_string();
    let ask = |host: Option<&str>| {
        let h = host.map(|h| format!("Host: {h}\r\n")).unwrap_or_default();
        v.raw(format!("GET /api/info HTTP/1.1\r\n{h}\r\n").as_bytes()).0
    };
    assert_eq!(ask(Some(&format!("evil.example:{port}"))), 403);
    assert_eq!(ask(Some("127.0.0.1:1")), 403);
    assert_eq!(ask(Some("127.0.0.1")), 403);
    assert_eq!(ask(None), 400);
    for ok in [format!("127.0.0.1:{port}"), format!("localhost:{port}"), format!("[::1]:{port}")] {
        assert_eq!(ask(Some(&ok)), 200, "{ok}");
    }
    let (code, body) = v.raw(format!("GET / HTTP/1.1\r\nHost: evil.example:{port}\r\n\r\n").as_bytes());
    assert_eq!(code, 403, "the page too: {}", String::from_utf8_lossy(&body));
}

#[test]
fn issue_10_abandoned_requests_are_dropped() {
    // The page aborts stale requests (a new slider position); the server notices the closed
    // connection and drops the work instead of answering nobody.
    let v = Viewer::start(&[]);
    for _ in 0..3 {
        let mut s = TcpStream::connect(&v.addr).unwrap();
        write!(s, "GET /api/mesh?n=160&method=mt-bcc&level=full HTTP/1.1\r\nHost: {}\r\n\r\n", v.addr).unwrap();
    }
    let start = Instant::now();
    for asked in 0.. {
        let s = v.json("/api/status");
        if s["abandoned"].as_u64() == Some(3) {
            assert_eq!(s["served"].as_u64(), Some(asked), "only the status requests were answered: {s}");
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(20), "{s}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn issue_50_half_open_connections_do_not_lock_others_out() {
    // Issue 50: clients that send a request line and nothing more held every worker slot.
    let v = Viewer::start(&[]);
    let half: Vec<TcpStream> = (0..300)
        .map(|_| {
            let mut s = TcpStream::connect(&v.addr).unwrap();
            let _ = s.write_all(b"GET /api/info HTTP/1.1\r\n");
            s
        })
        .collect();
    for path in ["/api/info", "/", "/main.js"] {
        let t = Instant::now();
        assert_eq!(v.get(path).0, 200, "{path}");
        assert!(t.elapsed() < Duration::from_secs(1), "{path} took {:?}", t.elapsed());
    }
    drop(half);
}

#[test]
fn issue_50_malformed_input_is_closed_at_once() {
    let v = Viewer::start(&[]);
    let lf = format!("GET /api/info HTTP/1.1\nHost: {}\n\n", v.addr);
    let hello = [0x16u8, 0x03, 0x01, 0x00, 0xa5, 0x01, 0x00, 0x00, 0xa1, 0x03, 0x03];
    for (name, raw) in [("LF-only", lf.as_bytes()), ("ClientHello", &hello[..])] {
        let t = Instant::now();
        assert_eq!(v.raw(raw).0, 400, "{name}");
        assert!(t.elapsed() < Duration::from_secs(1), "{name} closed after {:?}", t.elapsed());
    }
    // An empty connection (closed without a byte) is closed at once.
    let t = Instant::now();
    let mut s = TcpStream::connect(&v.addr).unwrap();
    s.shutdown(std::net::Shutdown::Write).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    assert!(out.is_empty() && t.elapsed() < Duration::from_secs(1), "{out:?} after {:?}", t.elapsed());
    // An absurd value is named, not echoed digit by digit.
    let (code, body) = v.get("/api/mesh?t=1e300");
    let body = String::from_utf8_lossy(&body).into_owned();
    assert_eq!(code, 400, "{body}");
    assert!(body.len() < 200 && body.contains("1e300"), "{body}");
}

#[test]
#[cfg(target_os = "linux")]
fn issue_50_exports_are_streamed_and_memory_stays_bounded() {
    // Issue 50: each export was built whole in memory; 40 at once peaked at 5.5 GB.
    let v = Viewer::start(&[]);
    let hwm = || {
        let s = std::fs::read_to_string(format!("/proc/{}/status", v.child.id())).unwrap();
        let line = s.lines().find(|l| l.starts_with("VmHWM:")).unwrap().to_string();
        line.split_whitespace().nth(1).unwrap().parse::<u64>().unwrap() * 1024
    };
    let answers: Vec<Vec<u8>> = std::thread::scope(|sc| {
        let hs: Vec<_> = (153..=160)
            .map(|n| {
                let addr = v.addr.clone();
                sc.spawn(move || {
                    let mut s = TcpStream::connect(&addr).unwrap();
                    write!(s, "GET /api/export?format=obj&n={n} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
                    let mut raw = Vec::new();
                    s.read_to_end(&mut raw).unwrap();
                    raw
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for raw in &answers {
        let split = raw.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        let head = String::from_utf8_lossy(&raw[..split]);
        assert!(head.starts_with("HTTP/1.1 200"), "{head}");
        // Streamed: no Content-Length, the close ends the body; and the body is a whole OBJ.
        assert!(!head.to_ascii_lowercase().contains("content-length"), "{head}");
        assert!(raw.len() - split > 1_000_000 && raw.ends_with(b"\n"));
    }
    let peak = hwm();
    assert!(peak < 200 << 20, "peak RSS {} MiB", peak >> 20);
}

#[test]
fn issue_50_max_memory_sets_the_budget() {
    let bad = isoforge(&["view", "--max-memory", "lots"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--max-memory"), "{bad:?}");
    // A budget smaller than one mesh: each export runs alone, one after the other, all answered.
    let v = Viewer::start(&["--max-memory", "1"]);
    let v = &v;
    let codes: Vec<u16> = std::thread::scope(|sc| {
        let hs: Vec<_> =
            (0..3).map(|i| sc.spawn(move || v.get(&format!("/api/export?format=stl&n={}", 40 + i)).0)).collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(codes, [200, 200, 200]);
}

#[test]
fn issue_50_trickled_bodies_hold_no_worker() {
    // Issue 50: a body trickled byte by byte was read by a fast-lane worker until the request
    // deadline; two such clients stalled the page and /api/info for 5 s.
    let v = Viewer::start(&[]);
    let mut tricklers: Vec<TcpStream> = (0..4)
        .map(|_| {
            let mut s = TcpStream::connect(&v.addr).unwrap();
            write!(s, "GET /api/info HTTP/1.1\r\nHost: {}\r\nContent-Length: 1000\r\n\r\n", v.addr).unwrap();
            s
        })
        .collect();
    let start = Instant::now();
    while start.elapsed() < Duration::from_millis(1500) {
        for s in &mut tricklers {
            let _ = s.write_all(b"x");
        }
        let t = Instant::now();
        assert_eq!(v.get("/api/info").0, 200);
        assert!(t.elapsed() < Duration::from_secs(1), "/api/info took {:?}", t.elapsed());
        std::thread::sleep(Duration::from_millis(50));
    }
    // A body that does arrive whole is read and the request answered.
    let with_body = format!("GET /api/info HTTP/1.1\r\nHost: {}\r\nContent-Length: 5\r\n\r\nhello", v.addr);
    assert_eq!(v.raw(with_body.as_bytes()).0, 200);
}

#[test]
fn issue_50_head_of_an_export_does_no_work() {
    // Issue 50: HEAD /api/export extracted the whole mesh to answer headers only.
    let v = Viewer::start(&[]);
    let t = Instant::now();
    let mut s = TcpStream::connect(&v.addr).unwrap();
    write!(s, "HEAD /api/export?format=obj&n=160&method=mt-bcc HTTP/1.1\r\nHost: {}\r\n\r\n", v.addr).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    assert!(t.elapsed() < Duration::from_millis(500), "answered after {:?}", t.elapsed());
    assert!(out.starts_with("HTTP/1.1 405 ") && out.contains("\r\nAllow: GET\r\n"), "{out}");
    for path in ["/api/mesh?n=160", "/api/check?n=160"] {
        let (code, _) = v.raw(format!("HEAD {path} HTTP/1.1\r\nHost: {}\r\n\r\n", v.addr).as_bytes());
        assert_eq!(code, 405, "{path}");
    }
    // A bad format is refused before any work too.
    let t = Instant::now();
    assert_eq!(v.get("/api/export?format=xyz&n=160&method=mt-bcc").0, 400);
    assert!(t.elapsed() < Duration::from_millis(500), "refused after {:?}", t.elapsed());
    // Nothing was reserved or extracted: the budget is whole, and HEAD of the page still works.
    let status = v.json("/api/status");
    assert_eq!(status["memory"]["reserved"], 0, "{status}");
    assert_eq!(v.raw(format!("HEAD / HTTP/1.1\r\nHost: {}\r\n\r\n", v.addr).as_bytes()).0, 200);
}

/// A connection that sent `request` and reads nothing, its receive buffer shrunk **before it
/// connects** (the window it offers is fixed at the handshake; shrinking it afterwards leaves a
/// window of megabytes on loopback), so the server's writes block once its send buffer is full.
#[cfg(unix)]
fn stalled_client(addr: &str, request: &str) -> TcpStream {
    use std::os::unix::io::FromRawFd;
    let std::net::SocketAddr::V4(to) = addr.parse::<std::net::SocketAddr>().unwrap() else {
        panic!("the viewer listens on IPv4: {addr}")
    };
    let small: libc::c_int = 4096;
    // SAFETY: a fresh socket owned by the TcpStream made from it; an int option of the size
    // given; a sockaddr_in of its own size.
    let mut s = unsafe {
        let fd = libc::socket(libc::AF_INET, libc::SOCK_STREAM, 0);
        assert!(fd >= 0, "socket: {}", std::io::Error::last_os_error());
        let s = TcpStream::from_raw_fd(fd);
        let rc = libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_RCVBUF,
            (&small as *const libc::c_int).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        );
        assert_eq!(rc, 0, "SO_RCVBUF: {}", std::io::Error::last_os_error());
        let mut sin: libc::sockaddr_in = std::mem::zeroed();
        sin.sin_family = libc::AF_INET as libc::sa_family_t;
        sin.sin_port = to.port().to_be();
        sin.sin_addr.s_addr = u32::from(*to.ip()).to_be();
        let rc = libc::connect(
            fd,
            (&sin as *const libc::sockaddr_in).cast(),
            std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t,
        );
        assert_eq!(rc, 0, "connect {addr}: {}", std::io::Error::last_os_error());
        s
    };
    write!(s, "GET {request} HTTP/1.1\r\nHost: {addr}\r\n\r\n").unwrap();
    s
}

#[test]
#[cfg(unix)]
fn issue_50_meshes_and_checks_hold_the_memory_budget() {
    // Issue 50: only exports were under the memory budget; /api/mesh built its whole answer in
    // memory (82 MB on the shoulder CT) and any number of them ran at once. Now every
    // extracting endpoint reserves its share before it extracts and keeps it until its answer
    // is written (streamed).
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("crate.nrrd");
    write_crate(&vol, 130); // a 9 MB answer at iso 127.5
                            // A budget of one byte: one request at a time.
    let v = Viewer::start(&[p(&vol), "--inside", "above", "--max-memory", "1"]);
    let stalled = stalled_client(&v.addr, "/api/mesh?iso=127.5&level=full");
    let start = Instant::now();
    // Its share is the budget (1) while it extracts, then its answer's size while the answer
    // waits for the client: wait for any share, not for the first window alone (which a fast
    // extraction can close between two polls: CI of 342cd61 and 86d4219). The deadline is for a
    // loaded machine, not a speed.
    while v.json("/api/status")["memory"]["reserved"] == 0 {
        assert!(start.elapsed() < Duration::from_secs(60), "the stalled mesh holds no share of the budget");
        std::thread::sleep(Duration::from_millis(20));
    }
    let v = &v;
    std::thread::scope(|sc| {
        let mesh = sc.spawn(move || (v.mesh("iso=100&level=full"), Instant::now()));
        let check = sc.spawn(move || (v.get("/api/check?iso=110").0, Instant::now()));
        // While the stalled answer holds the budget, the others wait (the page is still served).
        std::thread::sleep(Duration::from_millis(1500));
        assert!(!mesh.is_finished() && !check.is_finished(), "a request ran beside the one holding the budget");
        assert_eq!(v.get("/api/info").0, 200);
        let freed = Instant::now();
        drop(stalled);
        let (decoded, t) = mesh.join().unwrap();
        assert!(t > freed && decoded.triangles.len() > 1000 && decoded.head["level"] == "full");
        let (code, t) = check.join().unwrap();
        assert!(code == 200 && t > freed);
    });
    assert_eq!(v.json("/api/status")["memory"]["reserved"], 0, "every share given back");
}

#[test]
fn issue_50_a_client_leaving_mid_export_stops_it() {
    // The client reads the head and a little of a large export, then closes: the next write
    // fails, the export stops there (counted abandoned, not served) and its share of the
    // budget is given back at once.
    let dir = tempfile::tempdir().unwrap();
    let vol = dir.path().join("crate.nrrd");
    write_crate(&vol, 130);
    let v = Viewer::start(&[p(&vol), "--inside", "above"]);
    let ask = "/api/export?format=obj&iso=127.5";
    let mut s = TcpStream::connect(&v.addr).unwrap();
    write!(s, "GET {ask} HTTP/1.1\r\nHost: {}\r\n\r\n", v.addr).unwrap();
    let mut first = vec![0u8; 64 * 1024];
    s.read_exact(&mut first).unwrap();
    assert!(first.starts_with(b"HTTP/1.1 200"));
    drop(s);
    let left = Instant::now();
    for asked in 0u64.. {
        let status = v.json("/api/status");
        if status["abandoned"] == 1 && status["memory"]["reserved"] == 0 {
            assert_eq!(status["served"], asked, "only the status requests were served: {status}");
            break;
        }
        assert!(left.elapsed() < Duration::from_secs(2), "still exporting: {status}");
        std::thread::sleep(Duration::from_millis(20));
    }
    // The whole file is far larger than what was read before the client left.
    let (code, body) = v.get(ask);
    assert!(code == 200 && body.len() > 10 * first.len(), "{code}, {} bytes", body.len());
}
