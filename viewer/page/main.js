// isoforge view: asks the server for each change and shows exactly what `isoforge extract` writes.
// A change aborts the requests of the one before. Large volumes come as a coarse preview first,
// then at full resolution; the mesh check (closed, manifold, defect edges) follows the mesh.
import { Renderer } from "./gl.js";
import { Orbit, spinAbout } from "./orbit.js";
import { decodeMesh, decodeCheck, summary } from "./codec.js";

const $ = (id) => document.getElementById(id);
// After a preview is drawn, the full resolution is asked for once the input rests this long, so
// dragging the slider does not start a full extraction per step.
const FULL_AFTER_MS = 120;

const state = { info: null, generation: 0, controller: null, pending: false, t: 0.5, spin: 0, framed: false, centre: [0, 0, 0] };
let renderer, orbit;

function params() {
  const p = new URLSearchParams();
  const accepted = new Set(state.info.parameters);
  const set = (key, value) => { if (accepted.has(key) && value !== "") p.set(key, value); };
  set("method", $("method").value);
  set("iso", $("iso").value);
  set("roi", $("roi").value.trim());
  set("field", $("field").value);
  set("n", $("n").value);
  if ($("field").value !== "height") set("t", state.t.toFixed(3));
  return p;
}

function exportLinks() {
  for (const f of ["ply", "obj", "stl", "glb"]) {
    const p = params();
    p.set("format", f);
    $("x-" + f).href = "/api/export?" + p.toString();
  }
}

async function fetchBuffer(url, signal) {
  const r = await fetch(url, { signal });
  const body = await r.arrayBuffer();
  if (!r.ok) throw new Error(new TextDecoder().decode(body).trim() || `${url}: HTTP ${r.status}`);
  return body;
}

const sleep = (ms, signal) => new Promise((resolve, reject) => {
  const id = setTimeout(resolve, ms);
  signal.addEventListener("abort", () => { clearTimeout(id); reject(new DOMException("aborted", "AbortError")); }, { once: true });
});

// One change: preview (volumes), full resolution, then the check. A newer change aborts it.
async function update() {
  if (state.controller) state.controller.abort();
  const controller = new AbortController();
  state.controller = controller;
  const generation = ++state.generation;
  const signal = controller.signal;
  const started = performance.now();
  const base = params();
  const timings = {};
  state.pending = true;
  try {
    const ask = (path, extra) => path + "?" + new URLSearchParams([...base, ...Object.entries(extra)]).toString();
    const load = async (level) => {
      const t0 = performance.now();
      const buffer = await fetchBuffer(ask("/api/mesh", { level }), signal);
      const t1 = performance.now();
      const mesh = decodeMesh(buffer);
      timings.parts = { fetch: t1 - t0, decode: performance.now() - t1 };
      return mesh;
    };
    let mesh = await load(state.info.kind === "volume" ? "preview" : "full");
    if (mesh.head.level === "preview") {
      await show(mesh, started, timings, generation, signal);
      await sleep(FULL_AFTER_MS, signal);
      mesh = await load("full");
    }
    // The check is computed on the server while the page draws the full resolution.
    const checked = fetchBuffer(ask("/api/check", {}), signal);
    checked.catch(() => {}); // handled below; an abort during the draw must not go unhandled
    await show(mesh, started, timings, generation, signal);
    const check = decodeCheck(await checked);
    renderer.setDefects(check.edges);
    // Over the frame already drawn, unless a new frame is coming anyway.
    if (!drawQueued) draw(true);
    showCheck(check.report, mesh.head, timings, performance.now() - started, generation);
    exportLinks();
  } catch (e) {
    if (e.name !== "AbortError") showError(e);
  } finally {
    if (generation === state.generation) state.pending = false;
  }
}

async function show(mesh, started, timings, generation, signal) {
  const t0 = performance.now();
  renderer.setMesh(mesh);
  timings.parts.upload = performance.now() - t0;
  const h = mesh.head;
  if (!state.framed && h.vertices > 0) {
    const c = [0, 1, 2].map((a) => (h.box.min[a] + h.box.max[a]) / 2);
    const r = Math.hypot(...[0, 1, 2].map((a) => h.box.max[a] - h.box.min[a])) / 2;
    state.centre = c;
    orbit.frame(c, r);
    state.framed = true;
  }
  const t1 = performance.now();
  draw();
  await renderer.drawn(signal);
  const now = performance.now();
  timings[h.level] = now - started;
  timings.parts.draw = now - t1;
  const el = $("report");
  el.className = "";
  el.textContent = meshLines(h, timings).join("\n") + "\ncheck       running…";
  const s = summary(mesh);
  Object.assign(el.dataset, {
    generation, level: h.level, step: h.step, state: "mesh", vertices: h.vertices, triangles: h.triangles,
    decodedVertices: s.vertices, decodedTriangles: s.triangles, maxIndex: s.maxIndex,
    bounds: JSON.stringify([s.min, s.max]), previewMs: timings.preview ?? "", fullMs: timings.full ?? "",
    [h.level + "Step"]: h.step, [h.level + "Parts"]: JSON.stringify(Object.fromEntries(Object.entries(timings.parts).map(([k, v]) => [k, Math.round(v)]))),
  });
}

function meshLines(h, timings) {
  const level = h.level === "preview" ? `preview 1/${h.step} (full follows)` : "full resolution";
  const drawn = ["preview", "full"].filter((l) => timings[l] !== undefined).map((l) => `${l} ${timings[l].toFixed(0)}`).join(", ");
  return [
    `method      ${h.method}`, `level       ${level}`, `vertices    ${h.vertices}`, `triangles   ${h.triangles}`,
    `extraction  ${h.extraction_ms.toFixed(1)} ms`, `drawn       ${drawn} ms`,
  ];
}

function showCheck(r, h, timings, ms, generation) {
  const el = $("report");
  el.className = r.closed && r.manifold ? "" : "bad";
  const f = r.findings, lines = meshLines(h, timings);
  lines.splice(4, 0,
    `closed      ${r.closed ? "yes" : `no: ${f.boundary_edges.count} boundary edges`}`,
    `manifold    ${r.manifold ? "yes" : `no: ${f.non_manifold_edges.count} edges, ${f.non_manifold_vertices.count} vertices`}`,
    `oriented    ${r.oriented ? "yes" : "no"}`,
    `components  ${r.components}`, `χ / genus   ${r.euler} / ${r.genus ?? "-"}`);
  lines.push(`check       ${r.check_ms.toFixed(0)} ms (all ${ms.toFixed(0)} ms)`);
  if (r.defect_edges > 0) lines.push(`in red      ${r.defect_edges_sent < r.defect_edges ? `${r.defect_edges_sent} of ` : ""}${r.defect_edges} edges`);
  el.textContent = lines.join("\n");
  Object.assign(el.dataset, { generation, state: "checked", closed: r.closed, manifold: r.manifold, defects: r.defect_edges });
}

function showError(e) {
  const el = $("report");
  el.className = "bad";
  el.textContent = "error: " + (e.message || String(e));
  el.dataset.state = "error";
}

// Drawing on demand: one frame per change, continuous only while spinning or animating.
let drawQueued = false;
function requestDraw() {
  if (drawQueued) return;
  drawQueued = true;
  requestAnimationFrame(frame);
}

let last = performance.now();
function frame(now) {
  drawQueued = false;
  const dt = Math.min((now - last) / 1000, 0.1);
  last = now;
  if ($("spin").checked) state.spin += dt * 0.5;
  if ($("animate").checked && state.info.kind === "demo" && !state.pending) { state.t += dt * 0.2; update(); }
  draw();
  if ($("spin").checked || $("animate").checked) requestDraw();
}

function draw(defectsOnly = false) {
  const aspect = renderer.resize();
  const view = orbit.view();
  // The light sits above and left of the eye, as a photographer's key light.
  const eye = orbit.eye(), d = [0, 1, 2].map((a) => eye[a] - orbit.target[a]);
  const len = Math.hypot(...d) || 1;
  const light = [d[0] / len - 0.3 * view[0], d[1] / len - 0.3 * view[4], d[2] / len - 0.3 * view[8] + 0.4];
  const l = Math.hypot(...light) || 1;
  renderer.draw(view, orbit.projection(aspect), spinAbout(state.centre, state.spin), light.map((x) => x / l), defectsOnly);
}

function drawHistogram(counts) {
  const c = $("hist"), ctx = c.getContext("2d");
  c.width = c.clientWidth; c.height = c.clientHeight;
  const logs = counts.map((x) => Math.log1p(x)), top = Math.max(...logs, 1);
  ctx.fillStyle = "#99a";
  logs.forEach((v, i) => {
    const w = c.width / logs.length;
    ctx.fillRect(i * w, c.height * (1 - v / top), Math.max(1, w - 0.5), (c.height * v) / top);
  });
}

function setIsoRange(lo, hi, value) {
  const iso = $("iso");
  iso.min = lo; iso.max = hi; iso.step = (hi - lo) / 1000 || 1; iso.value = value;
  $("iso-val").textContent = Number(iso.value).toPrecision(5);
}

async function start() {
  try {
    renderer = new Renderer($("canvas"));
  } catch (e) {
    showError(e);
    return;
  }
  orbit = new Orbit($("canvas"), requestDraw);
  window.addEventListener("resize", requestDraw);
  state.info = await (await fetch("/api/info")).json();
  const info = state.info, accepted = new Set(info.parameters);
  $("kind").textContent = info.kind === "demo" ? "— classic demo" : "— " + info.name.split("/").pop();
  $("kind").title = info.name ?? "";
  for (const m of info.methods || []) $("method").add(new Option(m, m));
  if (info.method) $("method").value = info.method;
  for (const f of info.fields || []) $("field").add(new Option(f, f));
  $("demo-only").style.display = accepted.has("field") ? "" : "none";
  $("iso-box").style.display = accepted.has("iso") ? "" : "none";
  $("roi-box").style.display = accepted.has("roi") ? "" : "none";
  $("method-box").style.display = accepted.has("method") ? "" : "none";
  if (info.kind === "demo") setIsoRange(1, 200, info.iso);
  if (info.kind === "volume" && info.range) {
    setIsoRange(info.range[0], info.range[1], info.iso ?? (info.range[0] + info.range[1]) / 2);
    if (info.histogram) drawHistogram(info.histogram);
  }
  $("n-val").textContent = $("n").value;
  const on = (id, ev, f) => $(id).addEventListener(ev, f);
  on("iso", "input", () => { $("iso-val").textContent = Number($("iso").value).toPrecision(5); update(); });
  on("n", "input", () => { $("n-val").textContent = $("n").value; update(); });
  on("field", "change", () => { state.framed = false; update(); });
  on("method", "change", update);
  on("roi", "change", update);
  on("wire", "change", () => { renderer.setWireframe($("wire").checked); requestDraw(); });
  on("normals", "change", () => { renderer.normalColours = $("normals").checked; requestDraw(); });
  on("spin", "change", requestDraw);
  on("animate", "change", requestDraw);
  window.addEventListener("keydown", (e) => {
    if (e.target instanceof HTMLInputElement && e.target.type === "text") return;
    const bump = (id, by) => { const el = $(id); el.value = Number(el.value) + by; el.dispatchEvent(new Event("input")); };
    const cycle = (id) => { const s = $(id); s.selectedIndex = (s.selectedIndex + 1) % s.options.length; s.dispatchEvent(new Event("change")); };
    if ((e.key === "+" || e.key === "=") && accepted.has("n")) bump("n", 4);
    else if (e.key === "-" && accepted.has("n")) bump("n", -4);
    else if (e.key === "PageUp" && accepted.has("iso")) bump("iso", 20 * Number($("iso").step));
    else if (e.key === "PageDown" && accepted.has("iso")) bump("iso", -20 * Number($("iso").step));
    else if (e.key === "c" && accepted.has("method")) cycle("method");
    else if (e.key === "w") $("wire").click();
    else if (e.key === "l") $("normals").click();
    else if (e.key === "s" && accepted.has("field")) cycle("field");
    else return;
    e.preventDefault();
  });
  await update();
}

start();
