// End-to-end test of `isoforge view` in headless Chromium (Debian's chromium, driven by
// puppeteer-core). For the demo, a mesh file, the engine CT and the 512×512×450 shoulder CT: load
// the page, change iso / resolution / method / region, and check that what the page decoded and
// reports equals what `isoforge extract` and `isoforge check` say for the same parameters. Prints
// the slider latencies the page measured (change → preview drawn, change → full resolution drawn)
// and saves screenshots. The CTs are skipped with a message when ../shared/data is absent.
//   ISOFORGE=target/release/isoforge CHROMIUM=/usr/bin/chromium node viewer/e2e.mjs
import { spawn, execFileSync } from "node:child_process";
import { mkdirSync, mkdtempSync, readFileSync, existsSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import path from "node:path";
import puppeteer from "puppeteer-core";

const here = path.dirname(new URL(import.meta.url).pathname);
const isoforge = process.env.ISOFORGE || path.join(here, "../target/release/isoforge");
const chromium = process.env.CHROMIUM || "/usr/bin/chromium";
const artifacts = process.env.ARTIFACTS || path.join(here, "e2e-artifacts");
const data = process.env.ISOFORGE_DATA || path.join(here, "../../shared/data/volumes");
const scratch = mkdtempSync(path.join(tmpdir(), "isoforge-e2e-"));
mkdirSync(artifacts, { recursive: true });

const children = [];
function fail(msg) {
  console.error("e2e: FAILED: " + msg);
  for (const c of children) c.kill();
  rmSync(scratch, { recursive: true, force: true });
  process.exit(1);
}

function startViewer(args) {
  return new Promise((resolve, reject) => {
    const child = spawn(isoforge, ["view", "--port", "0", ...args], { stdio: ["ignore", "pipe", "inherit"] });
    children.push(child);
    child.stdout.once("data", (d) => resolve({ child, url: d.toString().trim() }));
    child.once("error", reject);
    child.once("exit", (code) => reject(new Error(`isoforge view ${args.join(" ")} exited with ${code}`)));
  });
}

// Counts and bounds of `isoforge extract … -o mesh.ply`, read back by `isoforge check --json`.
function extract(args) {
  const out = path.join(scratch, "extract.ply");
  execFileSync(isoforge, ["extract", ...args, "-o", out], { stdio: ["ignore", "ignore", "inherit"] });
  return check(out);
}

function check(file) {
  let text;
  try {
    text = execFileSync(isoforge, ["check", "--json", file], { stdio: ["ignore", "pipe", "inherit"], maxBuffer: 1 << 30 });
  } catch (e) {
    text = e.stdout; // exit 1: the mesh is not closed; the report is there all the same
  }
  const r = JSON.parse(text);
  return { vertices: r.vertices, triangles: r.triangles, bounds: r.bounds, closed: r.closed, manifold: r.manifold,
    defects: r.findings.boundary_edges.count + r.findings.non_manifold_edges.count };
}

const dataset = (page) => page.$eval("#report", (el) => ({ ...el.dataset, text: el.textContent }));

// Runs `change` in the page, then waits until the page has drawn the full resolution and shown
// the check for a newer generation than before.
async function after(page, change, ...args) {
  const before = Number((await dataset(page)).generation || 0);
  await page.evaluate(change, ...args);
  await page.waitForFunction((g) => {
    const d = document.getElementById("report").dataset;
    return Number(d.generation) > g && (d.state === "checked" || d.state === "error");
  }, { timeout: 180000 }, before);
  const d = await dataset(page);
  if (d.state === "error") fail(d.text);
  return d;
}

const setValue = (id, value, event) => {
  const el = document.getElementById(id);
  el.value = value;
  el.dispatchEvent(new Event(event));
};

// The page's mesh equals extract's: counts in the head, counts decoded, bounds within quantisation.
function same(where, d, want) {
  const got = { vertices: Number(d.vertices), triangles: Number(d.triangles) };
  if (got.vertices !== want.vertices || got.triangles !== want.triangles) fail(`${where}: page ${JSON.stringify(got)} vs extract ${JSON.stringify(want)}`);
  if (Number(d.decodedVertices) !== want.vertices || Number(d.decodedTriangles) !== want.triangles) fail(`${where}: decoded ${d.decodedVertices} / ${d.decodedTriangles}`);
  if (want.vertices > 0 && Number(d.maxIndex) !== want.vertices - 1) fail(`${where}: largest decoded index ${d.maxIndex}`);
  const [lo, hi] = JSON.parse(d.bounds);
  for (let a = 0; a < 3; a++) {
    const tol = (want.bounds.max[a] - want.bounds.min[a]) / 65535 + 1e-5 * Math.max(1, Math.abs(want.bounds.max[a]));
    if (Math.abs(lo[a] - want.bounds.min[a]) > tol || Math.abs(hi[a] - want.bounds.max[a]) > tol) fail(`${where}: bounds ${d.bounds} vs ${JSON.stringify(want.bounds)}`);
  }
  if (d.closed !== String(want.closed) || d.manifold !== String(want.manifold) || Number(d.defects) !== want.defects) fail(`${where}: check ${d.closed}/${d.manifold}/${d.defects} vs ${JSON.stringify(want)}`);
}

async function status(url) {
  return (await fetch(new URL("/api/status", url))).json();
}

const browser = await puppeteer.launch({
  executablePath: chromium, headless: true,
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--window-size=1200,800",
    "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync"],
});
const results = {};
try {
  const page = await browser.newPage();
  page.on("pageerror", (e) => fail("page error: " + e.message));
  await page.setViewport({ width: 1200, height: 800 });
  const open = async (url) => {
    await page.goto(url, { waitUntil: "load" });
    await page.waitForFunction(() => ["checked", "error"].includes(document.getElementById("report").dataset.state), { timeout: 180000 });
    const d = await dataset(page);
    if (d.state === "error") fail(d.text);
    return d;
  };

  // The demo: resolution, iso, method; the same mesh as extract.
  const demo = await startViewer([]);
  await open(demo.url);
  const spec = (n) => `field:metaballs?n=${n}&t=0.5`;
  await after(page, setValue, "n", 64, "input");
  const iso = await page.$eval("#iso", (el) => Number(el.value) * 0.8);
  let d = await after(page, setValue, "iso", iso, "input");
  const isoNow = await page.$eval("#iso", (el) => el.value);
  same("demo", d, extract(["-i", spec(64), "--iso", isoNow]));
  results.demo_slider_drawn_ms = Number(d.fullMs);
  await page.select("#method", "mt6");
  d = await page.waitForFunction(() => document.getElementById("report").dataset.state === "checked" && document.getElementById("report").textContent.includes("mt6"), { timeout: 60000 }).then(() => dataset(page));
  same("demo mt6", d, extract(["-i", spec(64), "--iso", isoNow, "--method", "mt6"]));
  await page.screenshot({ path: path.join(artifacts, "viewer-demo.png") });
  results.demo = { iso: Number(isoNow), method: "mt6", vertices: Number(d.vertices), triangles: Number(d.triangles) };
  demo.child.kill();

  // A mesh file, open at the volume's faces: shown as it is, its boundary in red, no method asked.
  const ply = path.join(scratch, "open.ply");
  execFileSync(isoforge, ["extract", "-i", path.join(here, "../testdata/volumes/u8_raw.nrrd"), "--iso", "10.5", "-o", ply], { stdio: "ignore" });
  const m = await startViewer([ply]);
  d = await open(m.url);
  same("mesh file", d, check(ply));
  if (Number(d.defects) === 0) fail("mesh file: the open mesh shows no defect edges");
  if (await page.$eval("#method-box", (el) => el.style.display !== "none")) fail("mesh file: the method selector is shown");
  await page.screenshot({ path: path.join(artifacts, "viewer-mesh.png") });
  results.mesh_file = { vertices: Number(d.vertices), triangles: Number(d.triangles), defect_edges: Number(d.defects) };
  m.child.kill();

  // CT volumes: slider steps, timed by the page from the input event to the mesh drawn.
  const slider = async (name, file, isos, extra) => {
    if (!existsSync(file)) { results[name] = `skipped: ${file} absent`; return; }
    const v = await startViewer([file]);
    await open(v.url);
    const steps = [];
    for (const iso of isos) {
      d = await after(page, setValue, "iso", iso, "input");
      const isoShown = Number(await page.$eval("#iso", (el) => el.value));
      const preview = d.previewMs !== "";
      steps.push({
        iso: isoShown,
        preview_drawn_ms: preview ? Math.round(Number(d.previewMs)) : null,
        preview_step: preview ? Number(d.previewStep) : null,
        preview_parts_ms: preview ? JSON.parse(d.previewParts) : null,
        full_drawn_ms: Math.round(Number(d.fullMs)),
        full_parts_ms: JSON.parse(d.fullParts),
      });
    }
    const last = await page.$eval("#iso", (el) => el.value);
    same(`${name} iso ${last}`, d, extract(["-i", file, "--iso", last]));
    // Moves while the full resolution is on its way: the page aborts it, the server drops it (once
    // its extraction ends), and the last position is what is shown.
    const before = await status(v.url);
    for (const iso of [isos[0], isos[1]]) {
      const g = Number((await dataset(page)).generation);
      await page.evaluate(setValue, "iso", iso, "input");
      await page.waitForFunction((g) => { const d = document.getElementById("report").dataset; return Number(d.generation) > g && d.level === "preview"; }, { timeout: 60000 }, g);
      await new Promise((r) => setTimeout(r, 300));
    }
    d = await after(page, setValue, "iso", isos[isos.length - 1], "input");
    same(`${name} after quick moves`, d, extract(["-i", file, "--iso", await page.$eval("#iso", (el) => el.value)]));
    const dropped = (await status(v.url)).abandoned - before.abandoned;
    if (name === "shoulder" && dropped < 1) fail("shoulder: no aborted full-resolution request reached the server as abandoned");
    results[name] = { steps, full_requests_abandoned: dropped, vertices: Number(d.vertices), triangles: Number(d.triangles) };
    if (extra) await extra(v, d);
    await page.screenshot({ path: path.join(artifacts, `viewer-${name}.png`) });
    v.child.kill();
  };
  const engine = path.join(data, "volvis_engine_256x256x128.nrrd");
  await slider("engine", engine, [120, 180, 150.5], async () => {
    const r = await after(page, setValue, "roi", "0:128,:,40:", "change");
    same("engine roi", r, extract(["-i", engine, "--iso", await page.$eval("#iso", (el) => el.value), "--roi", "0:128,:,40:"]));
    results.engine.roi = { vertices: Number(r.vertices), triangles: Number(r.triangles) };
  });
  await slider("shoulder", path.join(data, "vhp_shoulder_ct_512x512x450.nrrd"), [60, 80, 46.3184]);
} catch (e) {
  fail(String(e.stack || e));
} finally {
  await browser.close();
  for (const c of children) c.kill();
  rmSync(scratch, { recursive: true, force: true });
}
console.log(JSON.stringify(results, null, 1));
console.log("e2e: ok");
