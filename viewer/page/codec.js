// Reads the server's binary answers (crates/isoforge-cli/src/view/codec.rs has the layout):
// a u32 length, a JSON head padded to 4 bytes, then typed arrays.

function head(buffer) {
  const n = new DataView(buffer).getUint32(0, true);
  const json = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  return { json, at: Math.ceil((4 + n) / 4) * 4 };
}

const align4 = (x) => Math.ceil(x / 4) * 4;

// Zigzag LEB128 deltas → absolute indices (see delta_varint in codec.rs). Reads past the end
// give NaN and are caught by the length check after the loop.
function varintIndices(bytes, count) {
  const out = new Uint32Array(count);
  let prev = 0, i = 0;
  for (let k = 0; k < count; k++) {
    let b = bytes[i++];
    let z = b & 0x7f;
    if (b >= 0x80) {
      b = bytes[i++]; z |= (b & 0x7f) << 7;
      if (b >= 0x80) {
        b = bytes[i++]; z |= (b & 0x7f) << 14;
        if (b >= 0x80) {
          b = bytes[i++]; z |= (b & 0x7f) << 21;
          if (b >= 0x80) { b = bytes[i++]; z += (b & 0x7f) * 268435456; } // 2^28: past 31 bits
        }
      }
    }
    prev += z & 1 ? -(z + 1) / 2 : z / 2; // zigzag: 0, 1, 2, 3 → 0, −1, 1, −2
    out[k] = prev;
  }
  if (i !== bytes.length) throw new Error(`mesh: index data has ${bytes.length} bytes, ${count} indices read ${i}`);
  return out;
}

// The mesh of /api/mesh: positions stay quantised (u16; the shader scales them into the box),
// normals stay octahedral (i8 × 2), indices become a Uint16Array or Uint32Array.
export function decodeMesh(buffer) {
  const { json, at: start } = head(buffer);
  const v = json.vertices, t = json.triangles;
  let at = start;
  const positions = new Uint16Array(buffer, at, v * 3);
  at = align4(at + v * 6);
  const normals = new Int8Array(buffer, at, v * 2);
  at = align4(at + v * 2);
  // The indices fill the rest of the buffer.
  let indices;
  if (json.index.encoding === "u16") {
    if (buffer.byteLength - at !== t * 6) throw new Error("mesh: length does not match its head");
    indices = new Uint16Array(buffer, at, t * 3);
  } else if (json.index.encoding === "varint") {
    indices = varintIndices(new Uint8Array(buffer, at), t * 3);
  } else {
    throw new Error(`mesh: unknown index encoding ${json.index.encoding}`);
  }
  return { head: json, positions, normals, indices };
}

// The check of /api/check: the report and the defect edges as vertex pairs.
export function decodeCheck(buffer) {
  const { json, at } = head(buffer);
  return { report: json, edges: new Uint32Array(buffer, at, json.defect_edges_sent * 2) };
}

// Dequantised bounds and index range of a decoded mesh (the end-to-end test compares them with
// `isoforge check`).
export function summary(mesh) {
  const { head: h, positions, indices } = mesh;
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) {
    for (let a = 0; a < 3; a++) {
      const x = h.box.min[a] + (positions[i + a] / 65535) * (h.box.max[a] - h.box.min[a]);
      if (x < lo[a]) lo[a] = x;
      if (x > hi[a]) hi[a] = x;
    }
  }
  let maxIndex = -1;
  for (let i = 0; i < indices.length; i++) if (indices[i] > maxIndex) maxIndex = indices[i];
  return { vertices: positions.length / 3, triangles: indices.length / 3, min: lo, max: hi, maxIndex };
}
