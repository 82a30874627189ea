// End-to-end test of `isoforge view` in headless Chromium (Debian's chromium, driven by
// puppeteer-core): load the page, move the iso slider, switch the method, check that the report
// in the page changes and equals what `isoforge extract` writes for the same parameters, and save
// a screenshot. Prints the slider-to-mesh latency.
//   ISOFORGE=target/release/isoforge CHROMIUM=/usr/bin/chromium node viewer/e2e.mjs
import { spawn, execFileSync } from "node:child_process";
import { mkdirSync, readFileSync, existsSync } from "node:fs";
import { tmpdir } from "node:os";
import path from "node:path";
import puppeteer from "puppeteer-core";

const here = path.dirname(new URL(import.meta.url).pathname);
const isoforge = process.env.ISOFORGE || path.join(here, "../target/release/isoforge");
const chromium = process.env.CHROMIUM || "/usr/bin/chromium";
const artifacts = process.env.ARTIFACTS || path.join(here, "e2e-artifacts");
mkdirSync(artifacts, { recursive: true });

const children = [];
function fail(msg) {
  console.error("e2e: " + msg);
  for (const c of children) c.kill();
  process.exit(1);
}

function startViewer(args) {
  return new Promise((resolve, reject) => {
    const child = spawn(isoforge, ["view", "--port", "0", ...args], { stdio: ["ignore", "pipe", "inherit"] });
    children.push(child);
    child.stdout.once("data", (d) => resolve({ child, url: d.toString().trim() }));
    child.once("error", reject);
  });
}

function extractCounts(args) {
  const out = path.join(tmpdir(), "isoforge-e2e.ply"), tj = path.join(tmpdir(), "isoforge-e2e.json");
  execFileSync(isoforge, ["extract", ...args, "-o", out, "--time-json", tj], { stdio: ["ignore", "ignore", "inherit"] });
  const t = JSON.parse(readFileSync(tj, "utf8"));
  return { vertices: t.vertices, triangles: t.triangles };
}

async function pageReport(page) {
  return page.$eval("#report", (el) => ({ vertices: Number(el.dataset.vertices), triangles: Number(el.dataset.triangles), text: el.textContent }));
}

async function waitReport(page, differentFrom) {
  await page.waitForFunction((v) => {
    const el = document.getElementById("report");
    return el.dataset.vertices !== undefined && el.dataset.vertices !== v && !el.textContent.startsWith("…");
  }, { timeout: 30000 }, differentFrom === undefined ? "__none__" : String(differentFrom));
  return pageReport(page);
}

async function setValue(page, id, value, event) {
  await page.evaluate((id, value, event) => { const el = document.getElementById(id); el.value = value; el.dispatchEvent(new Event(event)); }, id, String(value), event);
}

const browser = await puppeteer.launch({
  executablePath: chromium, headless: true,
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--window-size=1200,800"],
});
const results = {};
try {
  // The demo.
  const demo = await startViewer([]);
  const page = await browser.newPage();
  await page.setViewport({ width: 1200, height: 800 });
  await page.goto(demo.url, { waitUntil: "load" });
  const first = await waitReport(page);
  const spec = (n) => `field:metaballs?n=${n}&t=0.5`;
  // Move the iso slider: the report changes and equals extract's.
  await setValue(page, "n", 64, "input");
  let r = await waitReport(page, first.vertices);
  const iso = await page.$eval("#iso", (el) => el.value);
  const t0 = Date.now();
  await setValue(page, "iso", Number(iso) * 0.8, "input");
  r = await waitReport(page, r.vertices);
  results.demo64_slider_to_mesh_ms = Date.now() - t0;
  const isoNow = await page.$eval("#iso", (el) => el.value);
  let want = extractCounts(["-i", spec(64), "--iso", isoNow]);
  if (r.vertices !== want.vertices || r.triangles !== want.triangles) fail(`iso ${isoNow}: page ${JSON.stringify(r)} vs extract ${JSON.stringify(want)}`);
  // Switch the method.
  await page.select("#method", "mt6");
  r = await waitReport(page, r.vertices);
  want = extractCounts(["-i", spec(64), "--iso", isoNow, "--method", "mt6"]);
  if (r.vertices !== want.vertices || r.triangles !== want.triangles || !r.text.includes("mt6")) fail(`mt6: page ${JSON.stringify(r)} vs extract ${JSON.stringify(want)}`);
  await page.screenshot({ path: path.join(artifacts, "viewer-demo.png") });
  results.demo = { iso: Number(isoNow), method: "mt6", vertices: r.vertices, triangles: r.triangles };
  demo.child.kill();
  // The engine CT at full resolution, when the shared data is here.
  const engine = path.join(here, "../../shared/data/volumes/volvis_engine_256x256x128.nrrd");
  if (existsSync(engine)) {
    const v = await startViewer([engine]);
    await page.goto(v.url, { waitUntil: "load" });
    let e = await waitReport(page);
    const t1 = Date.now();
    await setValue(page, "iso", 150.5, "input");
    e = await waitReport(page, e.vertices);
    results.engine_slider_to_mesh_ms = Date.now() - t1;
    want = extractCounts(["-i", engine, "--iso", "150.5"]);
    if (e.vertices !== want.vertices || e.triangles !== want.triangles) fail(`engine: page ${JSON.stringify(e)} vs extract ${JSON.stringify(want)}`);
    // A region of the volume, as extract --roi.
    await setValue(page, "roi", "0:128,:,40:", "change");
    const roiReport = await waitReport(page, e.vertices);
    want = extractCounts(["-i", engine, "--iso", "150.5", "--roi", "0:128,:,40:"]);
    if (roiReport.vertices !== want.vertices || roiReport.triangles !== want.triangles) fail(`engine roi: page ${JSON.stringify(roiReport)} vs extract ${JSON.stringify(want)}`);
    results.engine_roi = { vertices: roiReport.vertices, triangles: roiReport.triangles };
    await page.screenshot({ path: path.join(artifacts, "viewer-engine.png") });
    v.child.kill();
  } else {
    results.engine = "skipped: ../shared/data absent";
  }
} catch (e) {
  fail(String(e.stack || e));
} finally {
  await browser.close();
  for (const c of children) c.kill();
}
console.log(JSON.stringify(results));
