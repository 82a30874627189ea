// isoforge view: asks the server for each change and shows exactly what `isoforge extract` writes.
import * as THREE from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";

const $ = (id) => document.getElementById(id);
const state = { info: null, busy: false, again: false, t: 0.5, lastReport: null };

const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
$("view").appendChild(renderer.domElement);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f4f6);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 1e6);
const controls = new OrbitControls(camera, renderer.domElement);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8888aa, 1.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
camera.add(sun);
sun.position.set(-1, 2, 3);
scene.add(camera);
const lit = new THREE.MeshStandardMaterial({ color: 0xc8ccd8, roughness: 0.6, side: THREE.DoubleSide, flatShading: false });
const byNormal = new THREE.MeshNormalMaterial({ side: THREE.DoubleSide });
const mesh = new THREE.Mesh(new THREE.BufferGeometry(), lit);
const wire = new THREE.LineSegments(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: 0x333344 }));
const defects = new THREE.LineSegments(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: 0xdd1111 }));
const group = new THREE.Group();
group.add(mesh, wire, defects);
scene.add(group);
let framed = false;

function resize() {
  const el = $("view");
  renderer.setSize(el.clientWidth, el.clientHeight);
  camera.aspect = el.clientWidth / Math.max(1, el.clientHeight);
  camera.updateProjectionMatrix();
}
window.addEventListener("resize", resize);

function params() {
  const p = new URLSearchParams();
  p.set("method", $("method").value);
  if (state.info.kind !== "mesh") p.set("iso", $("iso").value);
  if (state.info.kind === "volume" && $("roi").value.trim()) p.set("roi", $("roi").value.trim());
  if (state.info.kind === "demo") {
    p.set("field", $("field").value);
    p.set("n", $("n").value);
    if ($("field").value !== "height") p.set("t", state.t.toFixed(3));
  }
  return p;
}

function exportLinks() {
  for (const f of ["ply", "obj", "stl", "glb"]) {
    const p = params();
    p.set("format", f);
    $("x-" + f).href = "/api/export?" + p.toString();
  }
}

// One request at a time; changes during a request ask once more when it ends.
async function refresh() {
  if (state.busy) { state.again = true; return; }
  state.busy = true;
  const sent = performance.now();
  try {
    const r = await fetch("/api/mesh?" + params().toString());
    const body = await r.arrayBuffer();
    if (!r.ok) { showReport(null, new TextDecoder().decode(body)); return; }
    const n = new DataView(body).getUint32(0, true);
    const report = JSON.parse(new TextDecoder().decode(new Uint8Array(body, 4, n)));
    let at = Math.ceil((4 + n) / 4) * 4;
    const positions = new Float32Array(body, at, report.vertices * 3); at += report.vertices * 12;
    const index = new Uint32Array(body, at, report.triangles * 3); at += report.triangles * 12;
    const bad = new Uint32Array(body, at, report.defect_edges * 2);
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(positions.slice(), 3));
    g.setIndex(new THREE.BufferAttribute(index.slice(), 1));
    g.computeVertexNormals();
    mesh.geometry.dispose(); mesh.geometry = g;
    updateWire();
    const d = new THREE.BufferGeometry();
    d.setAttribute("position", new THREE.BufferAttribute(positions.slice(), 3));
    d.setIndex(new THREE.BufferAttribute(bad.slice(), 1));
    defects.geometry.dispose(); defects.geometry = d;
    if (!framed && report.vertices > 0) frame(g);
    report.roundtrip_ms = performance.now() - sent;
    showReport(report);
    exportLinks();
  } catch (e) {
    showReport(null, String(e));
  } finally {
    state.busy = false;
    if (state.again) { state.again = false; refresh(); }
  }
}

// The wireframe is built only while shown (it costs as much as the mesh itself).
function updateWire() {
  wire.geometry.dispose();
  wire.geometry = wire.visible ? new THREE.WireframeGeometry(mesh.geometry) : new THREE.BufferGeometry();
}

function frame(g) {
  g.computeBoundingSphere();
  const s = g.boundingSphere;
  controls.target.copy(s.center);
  camera.position.copy(s.center).add(new THREE.Vector3(1, -1.4, 0.9).normalize().multiplyScalar(s.radius * 3));
  camera.up.set(0, 0, 1);
  camera.near = s.radius / 100; camera.far = s.radius * 100;
  camera.updateProjectionMatrix();
  controls.update();
  framed = true;
}

function showReport(r, error) {
  const el = $("report");
  if (!r) { el.textContent = "error: " + error; el.className = "bad"; return; }
  state.lastReport = r;
  el.className = r.closed && r.manifold ? "" : "bad";
  el.textContent =
    `method      ${r.method}\nvertices    ${r.vertices}\ntriangles   ${r.triangles}\n` +
    `closed      ${r.closed ? "yes" : "no"} (${r.boundary_edges} boundary edges)\n` +
    `manifold    ${r.manifold ? "yes" : "no"} (${r.non_manifold_edges} non-manifold edges)\n` +
    `components  ${r.components}\nχ / genus   ${r.euler} / ${r.genus ?? "-"}\n` +
    `extraction  ${r.extraction_ms.toFixed(1)} ms (round trip ${r.roundtrip_ms.toFixed(0)} ms)`;
  el.dataset.vertices = r.vertices;
  el.dataset.triangles = r.triangles;
}

function drawHistogram(counts) {
  const c = $("hist"), ctx = c.getContext("2d");
  c.width = c.clientWidth; c.height = c.clientHeight;
  const logs = counts.map((x) => Math.log1p(x)), top = Math.max(...logs, 1);
  ctx.fillStyle = "#99a";
  logs.forEach((v, i) => {
    const w = c.width / logs.length;
    ctx.fillRect(i * w, c.height * (1 - v / top), Math.max(1, w - 0.5), c.height * v / top);
  });
}

function setIsoRange(lo, hi, value) {
  const iso = $("iso");
  iso.min = lo; iso.max = hi; iso.step = (hi - lo) / 1000 || 1; iso.value = value;
  $("iso-val").textContent = Number(iso.value).toPrecision(5);
}

async function start() {
  resize();
  state.info = await (await fetch("/api/info")).json();
  const info = state.info;
  $("kind").textContent = info.kind === "demo" ? "— classic demo" : "— " + info.name;
  for (const m of info.methods || ["mc"]) $("method").add(new Option(m, m));
  $("demo-only").style.display = info.kind === "demo" ? "" : "none";
  $("iso-box").style.display = info.kind === "mesh" ? "none" : "";
  $("roi-box").style.display = info.kind === "volume" ? "" : "none";
  if (info.kind === "demo") setIsoRange(1, 200, info.iso);
  if (info.kind === "volume" && info.range) { setIsoRange(info.range[0], info.range[1], info.iso ?? (info.range[0] + info.range[1]) / 2); drawHistogram(info.histogram); }
  $("n-val").textContent = $("n").value;
  const on = (id, ev, f) => $(id).addEventListener(ev, f);
  on("iso", "input", () => { $("iso-val").textContent = Number($("iso").value).toPrecision(5); refresh(); });
  on("n", "input", () => { $("n-val").textContent = $("n").value; refresh(); });
  on("field", "change", () => { framed = false; refresh(); });
  on("method", "change", refresh);
  on("roi", "change", refresh);
  on("wire", "change", () => { wire.visible = $("wire").checked; updateWire(); });
  on("normals", "change", () => { mesh.material = $("normals").checked ? byNormal : lit; });
  wire.visible = false;
  window.addEventListener("keydown", (e) => {
    const bump = (id, by) => { const el = $(id); el.value = Number(el.value) + by; el.dispatchEvent(new Event("input")); };
    if (e.key === "+" || e.key === "=") bump("n", 4);
    else if (e.key === "-") bump("n", -4);
    else if (e.key === "PageUp") bump("iso", 20 * Number($("iso").step));
    else if (e.key === "PageDown") bump("iso", -20 * Number($("iso").step));
    else if (e.key === "c") { const m = $("method"); m.selectedIndex = (m.selectedIndex + 1) % m.options.length; m.dispatchEvent(new Event("change")); }
    else if (e.key === "w") $("wire").click();
    else if (e.key === "l") $("normals").click();
    else if (e.key === "s") { const f = $("field"); f.selectedIndex = (f.selectedIndex + 1) % f.options.length; f.dispatchEvent(new Event("change")); }
  });
  await refresh();
  let last = performance.now();
  renderer.setAnimationLoop((now) => {
    const dt = (now - last) / 1000; last = now;
    if ($("spin").checked) group.rotation.z += dt * 0.5;
    if ($("animate").checked && info.kind === "demo" && !state.busy) { state.t += dt * 0.2; refresh(); }
    controls.update();
    renderer.render(scene, camera);
  });
}

start();
