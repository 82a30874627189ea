// Camera matrices (column-major, as WebGL takes them) and orbit controls: drag to orbit about
// the target with +z up, wheel or pinch to zoom, right-drag (or shift-drag, or two fingers) to pan.

export function perspective(fovy, aspect, near, far) {
  const f = 1 / Math.tan(fovy / 2), nf = 1 / (near - far);
  return new Float32Array([f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (far + near) * nf, -1, 0, 0, 2 * far * near * nf, 0]);
}

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const unit = (a) => { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };

export function lookAt(eye, target, up) {
  const z = unit(sub(eye, target)), x = unit(cross(up, z)), y = cross(z, x);
  return new Float32Array([x[0], y[0], z[0], 0, x[1], y[1], z[1], 0, x[2], y[2], z[2], 0, -dot(x, eye), -dot(y, eye), -dot(z, eye), 1]);
}

// A rotation by `angle` about the vertical axis through `centre`.
export function spinAbout(centre, angle) {
  const c = Math.cos(angle), s = Math.sin(angle), [x, y] = centre;
  return new Float32Array([c, s, 0, 0, -s, c, 0, 0, 0, 0, 1, 0, x - c * x + s * y, y - s * x - c * y, 0, 1]);
}

export class Orbit {
  constructor(element, onChange) {
    this.el = element;
    this.onChange = onChange;
    this.fovy = (40 * Math.PI) / 180;
    this.target = [0, 0, 0];
    this.distance = 3;
    this.radius = 1;
    // The starting view of the old three.js page: from (1, −1.4, 0.9).
    this.azimuth = Math.atan2(-1.4, 1);
    this.elevation = Math.asin(0.9 / Math.hypot(1, 1.4, 0.9));
    this.pointers = new Map();
    const on = (ev, f, opts) => element.addEventListener(ev, f, opts);
    on("pointerdown", (e) => this.down(e));
    on("pointermove", (e) => this.move(e));
    on("pointerup", (e) => this.up(e));
    on("pointercancel", (e) => this.up(e));
    on("wheel", (e) => { e.preventDefault(); this.zoom(Math.exp(e.deltaY * 0.001)); }, { passive: false });
    on("contextmenu", (e) => e.preventDefault());
  }

  // Frames a bounding sphere: target at its centre, distance to see it whole.
  frame(centre, radius) {
    this.target = centre.slice();
    this.radius = Math.max(radius, 1e-6);
    this.distance = (this.radius / Math.sin(this.fovy / 2)) * 1.15;
    this.onChange();
  }

  eye() {
    const c = Math.cos(this.elevation);
    const d = [c * Math.cos(this.azimuth), c * Math.sin(this.azimuth), Math.sin(this.elevation)];
    return [0, 1, 2].map((a) => this.target[a] + this.distance * d[a]);
  }

  view() { return lookAt(this.eye(), this.target, [0, 0, 1]); }

  projection(aspect) {
    const near = Math.max(this.distance - this.radius * 4, this.distance / 1000, 1e-6);
    return perspective(this.fovy, aspect, near, this.distance + this.radius * 4);
  }

  zoom(factor) {
    this.distance = Math.min(Math.max(this.distance * factor, this.radius * 0.05), this.radius * 200);
    this.onChange();
  }

  rotate(dx, dy) {
    const h = this.el.clientHeight || 1;
    this.azimuth -= (2 * Math.PI * dx) / h;
    const limit = Math.PI / 2 - 1e-3;
    this.elevation = Math.min(limit, Math.max(-limit, this.elevation + (2 * Math.PI * dy) / h));
    this.onChange();
  }

  pan(dx, dy) {
    const h = this.el.clientHeight || 1;
    const scale = (2 * this.distance * Math.tan(this.fovy / 2)) / h;
    const z = unit(sub(this.eye(), this.target)), x = unit(cross([0, 0, 1], z)), y = cross(z, x);
    for (let a = 0; a < 3; a++) this.target[a] += (-dx * x[a] + dy * y[a]) * scale;
    this.onChange();
  }

  down(e) {
    this.el.setPointerCapture(e.pointerId);
    this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey || e.ctrlKey });
  }

  up(e) { this.pointers.delete(e.pointerId); }

  move(e) {
    const p = this.pointers.get(e.pointerId);
    if (!p) return;
    if (this.pointers.size === 1) {
      const dx = e.clientX - p.x, dy = e.clientY - p.y;
      if (p.pan) this.pan(dx, dy); else this.rotate(dx, dy);
    } else if (this.pointers.size === 2) {
      // Two fingers: the change of their distance zooms, the move of their midpoint pans.
      const [a, b] = [...this.pointers.entries()].map(([id, q]) => (id === e.pointerId ? { x: e.clientX, y: e.clientY } : q));
      const [a0, b0] = [...this.pointers.values()];
      const spread = Math.hypot(a.x - b.x, a.y - b.y), spread0 = Math.hypot(a0.x - b0.x, a0.y - b0.y);
      if (spread > 0 && spread0 > 0) this.zoom(spread0 / spread);
      this.pan((a.x + b.x - a0.x - b0.x) / 2, (a.y + b.y - a0.y - b0.y) / 2);
    }
    p.x = e.clientX; p.y = e.clientY;
  }
}
