// Level of detail for camera motion: a decimated copy of a large terrain mesh, drawn while the
// camera moves (see SceneView), the full mesh being drawn again once the view settles.
//
// Method: vertex clustering on a regular xy grid (Rossignac & Borrel 1993). The terrain's xy
// bounding box is cut into square cells; every vertex is replaced by its cell's representative,
// the mean position of the cell's vertices. A triangle whose three vertices fall in fewer than
// three distinct cells collapses and is dropped; the others keep their vertex order (so their
// orientation) with the representatives as corners. Triangles landing on the same three cells
// are merged into one, coloured by the area-weighted mean of their colours (a lone triangle keeps
// its own colour, e.g. its density colour). The cell size starts at what would give
// `targetTriangles` on a regular grid (two triangles per cell) and grows until the result has at
// most `maxTriangles`. Terrains are height fields, so xy clustering keeps their shape; one pass
// over the triangles with a hash map, about 0.2 s for 1M triangles in a browser.

export const LOD_MIN_TRIANGLES = 200000;  // smaller terrains are drawn in full while moving

// verts: Float32Array n*3, tris: Uint32Array m*3, triColor: Uint8Array m*3 (sRGB bytes).
// Returns {positions: Float32Array k*9, colors: Uint8Array k*9, triangles: k, cellM} for a
// non-indexed mesh (the layout meshes.triangleSoup builds), or null when m < minTriangles.
export function decimateTerrain(verts, tris, triColor,
  { targetTriangles = 120000, maxTriangles = 150000, minTriangles = LOD_MIN_TRIANGLES } = {}) {
  const m = tris.length / 3;
  if (m < minTriangles) return null;
  const box = xyBounds(verts);
  let cell = Math.sqrt((box.w * box.h) / (targetTriangles / 2)) || 1;
  for (let attempt = 0; attempt < 8; attempt++) {
    const grid = makeGrid(box, cell);
    const clusters = clusterVertices(verts, grid);
    const merged = mergeTriangles(verts, tris, triColor, clusters.cellOf, grid.cells);
    if (merged.count <= maxTriangles || attempt === 7) return toSoup(clusters, merged, cell);
    cell *= Math.sqrt(merged.count / targetTriangles);
  }
  return null;
}

function xyBounds(verts) {
  let xmin = Infinity, ymin = Infinity, xmax = -Infinity, ymax = -Infinity;
  for (let i = 0; i < verts.length; i += 3) {
    const x = verts[i], y = verts[i + 1];
    if (x < xmin) xmin = x; if (x > xmax) xmax = x;
    if (y < ymin) ymin = y; if (y > ymax) ymax = y;
  }
  return { xmin, ymin, w: Math.max(xmax - xmin, 1e-6), h: Math.max(ymax - ymin, 1e-6) };
}

function makeGrid(box, cell) {
  const nx = Math.max(1, Math.ceil(box.w / cell) + 1), ny = Math.max(1, Math.ceil(box.h / cell) + 1);
  return { xmin: box.xmin, ymin: box.ymin, inv: 1 / cell, nx, ny, cells: nx * ny };
}

// cellOf[v] = cell index of vertex v; mean[c*3..] = mean position of cell c's vertices.
function clusterVertices(verts, grid) {
  const n = verts.length / 3, cellOf = new Int32Array(n);
  const sum = new Float64Array(grid.cells * 3), count = new Uint32Array(grid.cells);
  for (let v = 0; v < n; v++) {
    const i = Math.floor((verts[3 * v] - grid.xmin) * grid.inv);
    const j = Math.floor((verts[3 * v + 1] - grid.ymin) * grid.inv);
    const c = Math.min(j, grid.ny - 1) * grid.nx + Math.min(i, grid.nx - 1);
    cellOf[v] = c;
    sum[3 * c] += verts[3 * v]; sum[3 * c + 1] += verts[3 * v + 1]; sum[3 * c + 2] += verts[3 * v + 2];
    count[c]++;
  }
  const mean = new Float32Array(grid.cells * 3);
  for (let c = 0; c < grid.cells; c++)
    if (count[c]) for (let k = 0; k < 3; k++) mean[3 * c + k] = sum[3 * c + k] / count[c];
  return { cellOf, mean };
}

// The surviving triangles as cell triples (original vertex order) with area-weighted colour sums.
function mergeTriangles(verts, tris, triColor, cellOf, cells) {
  const m = tris.length / 3, index = new Map();
  let corners = new Int32Array(3 * 4096), rgb = new Float64Array(3 * 4096), weight = new Float64Array(4096);
  let count = 0;
  for (let t = 0; t < m; t++) {
    const a = cellOf[tris[3 * t]], b = cellOf[tris[3 * t + 1]], c = cellOf[tris[3 * t + 2]];
    if (a === b || b === c || a === c) continue;
    const key = tripleKey(a, b, c, cells);
    let k = index.get(key);
    if (k === undefined) {
      if (count === weight.length) ({ corners, rgb, weight } = grow(corners, rgb, weight));
      k = count++;
      index.set(key, k);
      corners[3 * k] = a; corners[3 * k + 1] = b; corners[3 * k + 2] = c;
    }
    const w = triangleArea(verts, tris, t) + 1e-12;
    for (let q = 0; q < 3; q++) rgb[3 * k + q] += w * triColor[3 * t + q];
    weight[k] += w;
  }
  return { count, corners, rgb, weight };
}

// Order-independent key of a cell triple (exact as long as cells^3 < 2^53, i.e. cells < 208,000).
function tripleKey(a, b, c, cells) {
  let t;
  if (a > b) { t = a; a = b; b = t; }
  if (b > c) { t = b; b = c; c = t; }
  if (a > b) { t = a; a = b; b = t; }
  return (a * cells + b) * cells + c;
}

function grow(corners, rgb, weight) {
  const n = weight.length * 2;
  const c2 = new Int32Array(3 * n), r2 = new Float64Array(3 * n), w2 = new Float64Array(n);
  c2.set(corners); r2.set(rgb); w2.set(weight);
  return { corners: c2, rgb: r2, weight: w2 };
}

function triangleArea(verts, tris, t) {
  const a = 3 * tris[3 * t], b = 3 * tris[3 * t + 1], c = 3 * tris[3 * t + 2];
  const ux = verts[b] - verts[a], uy = verts[b + 1] - verts[a + 1], uz = verts[b + 2] - verts[a + 2];
  const vx = verts[c] - verts[a], vy = verts[c + 1] - verts[a + 1], vz = verts[c + 2] - verts[a + 2];
  const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  return 0.5 * Math.sqrt(nx * nx + ny * ny + nz * nz);
}

function toSoup(clusters, merged, cellM) {
  const k = merged.count, positions = new Float32Array(k * 9), colors = new Uint8Array(k * 9);
  for (let t = 0; t < k; t++) {
    const w = merged.weight[t];
    for (let q = 0; q < 3; q++) {
      const c = 3 * merged.corners[3 * t + q], p = 9 * t + 3 * q;
      positions[p] = clusters.mean[c]; positions[p + 1] = clusters.mean[c + 1]; positions[p + 2] = clusters.mean[c + 2];
      for (let ch = 0; ch < 3; ch++) colors[p + ch] = Math.round(merged.rgb[3 * t + ch] / w);
    }
  }
  return { positions, colors, triangles: k, cellM };
}
