// A small WebGL2 renderer for one indexed mesh: two-sided lighting (a headlight plus a sky/ground
// term; back faces in a warm tint, so the inside of an open surface reads as inside), or normal
// colours; optional wireframe; defect edges in red on top. Positions arrive quantised (u16) and
// normals octahedral (i8 × 2), as the server sends them: the vertex shader decodes both.

const VERTEX = `#version 300 es
layout(location = 0) in vec3 aQ;   // quantised position in [0, 1]
layout(location = 1) in vec2 aOct; // octahedral normal in [-1, 1]
uniform vec3 uMin, uSize;
uniform mat4 uModel, uView, uProj;
out vec3 vNormal;
vec3 octahedral(vec2 e) {
  vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
  float t = max(-n.z, 0.0);
  n.x += n.x >= 0.0 ? -t : t;
  n.y += n.y >= 0.0 ? -t : t;
  return normalize(n);
}
void main() {
  vec4 world = uModel * vec4(uMin + aQ * uSize, 1.0);
  vNormal = mat3(uModel) * octahedral(aOct);
  gl_Position = uProj * uView * world;
}`;

const SURFACE = `#version 300 es
precision highp float;
in vec3 vNormal;
uniform int uMode;     // 0 lit, 1 normal colours
uniform vec3 uLight;   // towards the light, world space
out vec4 colour;
void main() {
  vec3 n = normalize(vNormal);
  if (!gl_FrontFacing) n = -n;
  if (uMode == 1) { colour = vec4(0.5 + 0.5 * n, 1.0); return; }
  vec3 base = gl_FrontFacing ? vec3(0.78, 0.80, 0.86) : vec3(0.86, 0.66, 0.46);
  float diffuse = max(dot(n, uLight), 0.0);
  float sky = 0.5 + 0.5 * n.z;
  float shine = pow(max(dot(n, uLight), 0.0), 48.0) * 0.2;
  colour = vec4(base * (0.22 + 0.18 * sky + 0.7 * diffuse) + shine, 1.0);
}`;

const LINES = `#version 300 es
precision highp float;
uniform vec3 uColour;
out vec4 colour;
void main() { colour = vec4(uColour, 1.0); }`;

function compile(gl, vs, fs) {
  const program = gl.createProgram();
  for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error("shader: " + gl.getShaderInfoLog(s));
    gl.attachShader(program, s);
  }
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error("program: " + gl.getProgramInfoLog(program));
  const uniforms = {};
  const n = gl.getProgramParameter(program, gl.ACTIVE_UNIFORMS);
  for (let i = 0; i < n; i++) {
    const name = gl.getActiveUniform(program, i).name;
    uniforms[name] = gl.getUniformLocation(program, name);
  }
  return { program, uniforms };
}

// The edges of every triangle, each once for a closed oriented mesh: a triangle adds its edge
// (a, b) when a < b, and the neighbour that runs the edge as (b, a) skips it. Boundary and
// non-manifold edges are drawn anyway, in red.
function wireIndices(indices) {
  const out = new (indices.BYTES_PER_ELEMENT === 2 ? Uint16Array : Uint32Array)(indices.length * 2);
  let k = 0;
  for (let i = 0; i < indices.length; i += 3) {
    const a = indices[i], b = indices[i + 1], c = indices[i + 2];
    if (a < b) { out[k++] = a; out[k++] = b; }
    if (b < c) { out[k++] = b; out[k++] = c; }
    if (c < a) { out[k++] = c; out[k++] = a; }
  }
  return out.subarray(0, k);
}

export class Renderer {
  constructor(canvas) {
    const gl = canvas.getContext("webgl2", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    this.canvas = canvas;
    this.surface = compile(gl, VERTEX, SURFACE);
    this.lines = compile(gl, VERTEX, LINES);
    this.vao = gl.createVertexArray();
    this.buffers = { position: gl.createBuffer(), normal: gl.createBuffer(), triangles: gl.createBuffer(), wire: gl.createBuffer(), defects: gl.createBuffer() };
    this.counts = { triangles: 0, wire: 0, defects: 0 };
    this.types = { triangles: gl.UNSIGNED_INT, wire: gl.UNSIGNED_INT, defects: gl.UNSIGNED_INT };
    this.box = { min: [0, 0, 0], size: [0, 0, 0] };
    this.indices = null;
    this.wireframe = false;
    this.normalColours = false;
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.position);
    gl.vertexAttribPointer(0, 3, gl.UNSIGNED_SHORT, true, 0, 0);
    gl.enableVertexAttribArray(0);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.normal);
    gl.vertexAttribPointer(1, 2, gl.BYTE, true, 0, 0);
    gl.enableVertexAttribArray(1);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LEQUAL);
    gl.clearColor(0.957, 0.957, 0.965, 1);
  }

  // A decoded mesh (codec.js decodeMesh): replaces the shown one; defect edges are cleared.
  setMesh(mesh) {
    const gl = this.gl, h = mesh.head;
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.position);
    gl.bufferData(gl.ARRAY_BUFFER, mesh.positions, gl.STATIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffers.normal);
    gl.bufferData(gl.ARRAY_BUFFER, mesh.normals, gl.STATIC_DRAW);
    this.upload("triangles", mesh.indices);
    this.box = { min: h.box.min, size: [0, 1, 2].map((a) => h.box.max[a] - h.box.min[a]) };
    this.indices = mesh.indices;
    this.upload("wire", this.wireframe ? wireIndices(mesh.indices) : new Uint32Array(0));
    this.upload("defects", new Uint32Array(0));
  }

  // Defect edges as vertex pairs of the current mesh.
  setDefects(pairs) { this.upload("defects", pairs); }

  // The wireframe's index buffer exists only while it is shown (it is as large as the mesh's).
  setWireframe(on) {
    this.wireframe = on;
    this.upload("wire", on && this.indices ? wireIndices(this.indices) : new Uint32Array(0));
  }

  upload(which, indices) {
    const gl = this.gl;
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers[which]);
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    this.counts[which] = indices.length;
    this.types[which] = indices.BYTES_PER_ELEMENT === 2 ? gl.UNSIGNED_SHORT : gl.UNSIGNED_INT;
  }

  resize() {
    const dpr = Math.min(window.devicePixelRatio || 1, 2);
    const w = Math.max(1, Math.round(this.canvas.clientWidth * dpr)), h = Math.max(1, Math.round(this.canvas.clientHeight * dpr));
    if (this.canvas.width !== w || this.canvas.height !== h) { this.canvas.width = w; this.canvas.height = h; }
    return w / h;
  }

  // Draws with camera matrices `view`, `proj`, `model` and the direction towards the light.
  // With `defectsOnly`, draws just the defect edges over the last frame (drawn with the same
  // matrices; the drawing buffer, depth included, is preserved): a large mesh is not drawn
  // again when its check arrives.
  draw(view, proj, model, light, defectsOnly = false) {
    const gl = this.gl;
    gl.viewport(0, 0, this.canvas.width, this.canvas.height);
    gl.bindVertexArray(this.vao);
    const common = (p) => {
      gl.useProgram(p.program);
      gl.uniformMatrix4fv(p.uniforms.uView, false, view);
      gl.uniformMatrix4fv(p.uniforms.uProj, false, proj);
      gl.uniformMatrix4fv(p.uniforms.uModel, false, model);
      gl.uniform3fv(p.uniforms.uMin, this.box.min);
      gl.uniform3fv(p.uniforms.uSize, this.box.size);
    };
    if (defectsOnly) {
      common(this.lines);
      gl.uniform3fv(this.lines.uniforms.uColour, [0.87, 0.07, 0.07]);
      this.elements("defects", gl.LINES);
      return;
    }
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    common(this.surface);
    gl.uniform1i(this.surface.uniforms.uMode, this.normalColours ? 1 : 0);
    gl.uniform3fv(this.surface.uniforms.uLight, light);
    // Pushed back a little so lines on the surface pass the depth test.
    gl.enable(gl.POLYGON_OFFSET_FILL);
    gl.polygonOffset(1, 1);
    this.elements("triangles", gl.TRIANGLES);
    gl.disable(gl.POLYGON_OFFSET_FILL);
    common(this.lines);
    if (this.wireframe) {
      gl.uniform3fv(this.lines.uniforms.uColour, [0.2, 0.2, 0.27]);
      this.elements("wire", gl.LINES);
    }
    gl.uniform3fv(this.lines.uniforms.uColour, [0.87, 0.07, 0.07]);
    this.elements("defects", gl.LINES);
  }

  elements(which, mode) {
    const gl = this.gl;
    if (this.counts[which] === 0) return;
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, this.buffers[which]);
    gl.drawElements(mode, this.counts[which], this.types[which], 0);
  }

  // Resolves once the GPU has finished the commands issued so far (a fence, polled: the page
  // stays responsive while a software renderer works through millions of triangles); rejects
  // when `signal` aborts.
  drawn(signal) {
    const gl = this.gl, fence = gl.fenceSync(gl.SYNC_GPU_COMMANDS_COMPLETE, 0);
    gl.flush();
    return new Promise((resolve, reject) => {
      const poll = () => {
        if (signal.aborted) { gl.deleteSync(fence); reject(new DOMException("aborted", "AbortError")); return; }
        if (gl.getSyncParameter(fence, gl.SYNC_STATUS) === gl.SIGNALED) { gl.deleteSync(fence); resolve(); return; }
        setTimeout(poll, 4);
      };
      poll();
    });
  }
}
