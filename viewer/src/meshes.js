// Builders of three.js objects from the scene arrays (typed-array loops, no per-vertex objects).
// Positions are relative to the scene's offset_m (site frame: x east, y north, z up).

import * as THREE from '../vendor/three.module.js';
import { decimateTerrain } from './lod.js';

// ---- shading ------------------------------------------------------------------------------------

// Flat shading from screen-space derivatives: no normal attribute is stored. Colours are sRGB
// bytes shown as they are (ambient + diffuse = 1 on level ground), so they match the legend.
const LIGHT = new THREE.Vector3(-0.45, 0.55, 0.85).normalize();
const AMBIENT = 0.55;

const VERTEX = /* glsl */ `
varying vec3 vColor;
varying vec3 vWorld;
void main() {
  vColor = color;
  vec4 w = modelMatrix * vec4(position, 1.0);
  vWorld = w.xyz;
  gl_Position = projectionMatrix * viewMatrix * w;
}`;

const FRAGMENT = /* glsl */ `
uniform vec3 lightDir;
uniform float ambient;
uniform float diffuse;
varying vec3 vColor;
varying vec3 vWorld;
void main() {
  vec3 n = normalize(cross(dFdx(vWorld), dFdy(vWorld)));
  if (dot(n, cameraPosition - vWorld) < 0.0) n = -n;
  float light = ambient + diffuse * max(dot(n, lightDir), 0.0);
  gl_FragColor = vec4(min(vColor * light, vec3(1.0)), 1.0);
}`;

export function flatMaterial({ offsetSurface = false } = {}) {
  return new THREE.ShaderMaterial({
    vertexShader: VERTEX,
    fragmentShader: FRAGMENT,
    vertexColors: true,
    side: THREE.DoubleSide,
    polygonOffset: offsetSurface,
    polygonOffsetFactor: offsetSurface ? 1 : 0,
    polygonOffsetUnits: offsetSurface ? 2 : 0,
    uniforms: {
      lightDir: { value: LIGHT },
      ambient: { value: AMBIENT },
      diffuse: { value: (1 - AMBIENT) / LIGHT.z },
    },
  });
}

// ---- triangle soups ---------------------------------------------------------------------------

// Non-indexed geometry: 3 vertices per triangle, one colour per triangle (Uint8 normalised).
// triColor: Uint8Array m*3. Returns {geometry, box: THREE.Box3}.
export function triangleSoup(verts, tris, triColor) {
  const m = tris.length / 3;
  const pos = new Float32Array(m * 9);
  const col = new Uint8Array(m * 9);
  let xmin = Infinity, ymin = Infinity, zmin = Infinity, xmax = -Infinity, ymax = -Infinity, zmax = -Infinity;
  for (let t = 0, p = 0; t < m; t++) {
    const r = triColor[3 * t], g = triColor[3 * t + 1], b = triColor[3 * t + 2];
    for (let c = 0; c < 3; c++, p += 3) {
      const v = 3 * tris[3 * t + c];
      const x = verts[v], y = verts[v + 1], z = verts[v + 2];
      pos[p] = x; pos[p + 1] = y; pos[p + 2] = z;
      col[p] = r; col[p + 1] = g; col[p + 2] = b;
      if (x < xmin) xmin = x; if (x > xmax) xmax = x;
      if (y < ymin) ymin = y; if (y > ymax) ymax = y;
      if (z < zmin) zmin = z; if (z > zmax) zmax = z;
    }
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(col, 3, true));
  const box = new THREE.Box3(new THREE.Vector3(xmin, ymin, zmin), new THREE.Vector3(xmax, ymax, zmax));
  if (m === 0) box.makeEmpty();
  geometry.boundingBox = box.clone();
  geometry.boundingSphere = box.isEmpty() ? new THREE.Sphere() : box.getBoundingSphere(new THREE.Sphere());
  return { geometry, box };
}

// New per-triangle colours (Uint8Array m*3) for a soupMesh's geometry, in place.
export function setSoupColors(mesh, triColor) {
  const attr = mesh.geometry.attributes.color, col = attr.array, m = triColor.length / 3;
  for (let t = 0, p = 0; t < m; t++)
    for (let c = 0; c < 3; c++, p += 3) {
      col[p] = triColor[3 * t]; col[p + 1] = triColor[3 * t + 1]; col[p + 2] = triColor[3 * t + 2];
    }
  attr.needsUpdate = true;
}

export function soupMesh(verts, tris, triColor, opts) {
  const { geometry, box } = triangleSoup(verts, tris, triColor);
  const mesh = new THREE.Mesh(geometry, flatMaterial(opts));
  return { mesh, box };
}

// Decimated stand-in of a large terrain mesh for camera motion (lod.js), sharing `full`'s
// material; null for terrains small enough to draw in full.
export function decimatedMesh(verts, tris, triColor, full) {
  const d = decimateTerrain(verts, tris, triColor);
  if (!d) return null;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(d.positions, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(d.colors, 3, true));
  geometry.boundingBox = full.geometry.boundingBox.clone();
  geometry.boundingSphere = full.geometry.boundingSphere.clone();
  const mesh = new THREE.Mesh(geometry, full.material);
  mesh.name = 'terrain-lod';
  return mesh;
}

// ---- per-triangle colours -----------------------------------------------------------------------

// density -> colour: 0 -> zeroGrey; else lut at scale.t(d) (clamped to the scale's ends).
export function densityColors(density, scale, lut, zeroGrey) {
  const m = density.length, out = new Uint8Array(m * 3), n = lut.length / 3 - 1;
  for (let t = 0; t < m; t++) {
    const d = density[t];
    if (d > 0) {
      const i = 3 * Math.round(scale.t(d) * n);
      out[3 * t] = lut[i]; out[3 * t + 1] = lut[i + 1]; out[3 * t + 2] = lut[i + 2];
    } else {
      out[3 * t] = zeroGrey[0]; out[3 * t + 1] = zeroGrey[1]; out[3 * t + 2] = zeroGrey[2];
    }
  }
  return out;
}

// Colour by triangle centroid elevation over [zlo, zhi].
export function elevationColors(verts, tris, lut, zlo, zhi) {
  const m = tris.length / 3, out = new Uint8Array(m * 3), n = lut.length / 3 - 1;
  const k = zhi > zlo ? 1 / (zhi - zlo) : 0;
  for (let t = 0; t < m; t++) {
    const z = (verts[3 * tris[3 * t] + 2] + verts[3 * tris[3 * t + 1] + 2] + verts[3 * tris[3 * t + 2] + 2]) / 3;
    const f = Math.min(Math.max((z - zlo) * k, 0), 1);
    const i = 3 * Math.round(f * n);
    out[3 * t] = lut[i]; out[3 * t + 1] = lut[i + 1]; out[3 * t + 2] = lut[i + 2];
  }
  return out;
}

// Building triangles coloured by their building (buildingRgb: Uint8Array nb*3); windows tinted.
export function buildingColors(triBuilding, triSurface, buildingRgb) {
  const m = triBuilding.length, out = new Uint8Array(m * 3);
  for (let t = 0; t < m; t++) {
    const b = 3 * triBuilding[t], win = triSurface && triSurface[t] === 3;
    for (let c = 0; c < 3; c++) {
      const v = buildingRgb[b + c];
      out[3 * t + c] = win ? Math.round(0.55 * v + 0.45 * [110, 140, 170][c]) : v;
    }
  }
  return out;
}

// ---- lines --------------------------------------------------------------------------------------

// dash (m, > 0): dashed, dashes of that length with gaps of 0.6 of it along the segments' running
// length (the page's mark of a distance that is only a lower bound); else solid.
export function lineSegments(positions, color, { opacity = 1, onTop = false, order = 1, dash = 0 } = {}) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  const common = { color, transparent: opacity < 1 || onTop, opacity, depthTest: !onTop, depthWrite: !onTop };
  const material = dash > 0
    ? new THREE.LineDashedMaterial({ ...common, dashSize: dash, gapSize: 0.6 * dash })
    : new THREE.LineBasicMaterial(common);
  const lines = new THREE.LineSegments(geometry, material);
  if (dash > 0) lines.computeLineDistances();
  lines.renderOrder = order;
  return lines;
}

// Hazardous-area contour: the edges of triangles with density >= thr whose other side is below
// thr or the mesh boundary (an edge used by exactly one hazardous triangle). Lifted by `lift` m.
export function contourSegments(verts, tris, density, thr, lift) {
  const nv = verts.length / 3, count = new Map();
  for (let t = 0; t < density.length; t++) {
    if (!(density[t] >= thr)) continue;
    for (let e = 0; e < 3; e++) {
      const a = tris[3 * t + e], b = tris[3 * t + ((e + 1) % 3)];
      const key = a < b ? a * nv + b : b * nv + a;
      count.set(key, (count.get(key) || 0) + 1);
    }
  }
  const out = [];
  for (const [key, n] of count) {
    if (n !== 1) continue;
    const a = Math.floor(key / nv), b = key - a * nv;
    out.push(verts[3 * a], verts[3 * a + 1], verts[3 * a + 2] + lift,
      verts[3 * b], verts[3 * b + 1], verts[3 * b + 2] + lift);
  }
  return new Float32Array(out);
}

// Circle of radius r about (cx, cy) at height z, as segments.
export function circleSegments(cx, cy, z, r, n = 180) {
  const out = new Float32Array(n * 6);
  for (let i = 0; i < n; i++) {
    const a0 = (2 * Math.PI * i) / n, a1 = (2 * Math.PI * (i + 1)) / n;
    out.set([cx + r * Math.cos(a0), cy + r * Math.sin(a0), z, cx + r * Math.cos(a1), cy + r * Math.sin(a1), z], 6 * i);
  }
  return out;
}

// Per-sector HFD: sector k (azimuth [10k, 10k+10) deg from +x toward +y): a radial segment at
// 10k+5 deg of length d[k] and an arc across the sector at d[k].
export function sectorSegments(cx, cy, z, d, arcSteps = 4) {
  const out = [];
  const pt = (a, r) => [cx + r * Math.cos(a), cy + r * Math.sin(a), z];
  d.forEach((r, k) => {
    if (!(r > 0)) return;
    const rad = Math.PI / 180;
    out.push(cx, cy, z, ...pt((10 * k + 5) * rad, r));
    for (let s = 0; s < arcSteps; s++)
      out.push(...pt((10 * k + (10 * s) / arcSteps) * rad, r), ...pt((10 * k + (10 * (s + 1)) / arcSteps) * rad, r));
  });
  return new Float32Array(out);
}

// Recorded trajectories as line segments (positions used as they are, index pairs per step),
// coloured per point by speed through `colorLut` (Uint8 RGB) over [0, vmax].
export function trajectoryLines(points, offsets, speed, colorLut, vmax) {
  const k = offsets.length - 1;
  let nseg = 0;
  for (let i = 0; i < k; i++) nseg += Math.max(0, offsets[i + 1] - offsets[i] - 1);
  const index = new Uint32Array(2 * nseg);
  let p = 0;
  for (let i = 0; i < k; i++)
    for (let j = offsets[i]; j + 1 < offsets[i + 1]; j++) {
      index[p++] = j;
      index[p++] = j + 1;
    }
  // sRGB values as they are: the page renders without colour management (scene3d.js).
  const rgb = Float32Array.from(colorLut, (v) => v / 255);
  const n = points.length / 3, col = new Float32Array(n * 3), top = colorLut.length / 3 - 1;
  for (let j = 0; j < n; j++) {
    const f = speed && vmax > 0 ? Math.min(speed[j] / vmax, 1) : 1;
    const c = 3 * Math.round(f * top);
    col[3 * j] = rgb[c]; col[3 * j + 1] = rgb[c + 1]; col[3 * j + 2] = rgb[c + 2];
  }
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(points, 3));
  geometry.setAttribute('color', new THREE.BufferAttribute(col, 3));
  geometry.setIndex(new THREE.BufferAttribute(index, 1));
  const material = new THREE.LineBasicMaterial({ vertexColors: true, transparent: true, opacity: 0.6, depthWrite: false });
  const lines = new THREE.LineSegments(geometry, material);
  lines.renderOrder = 2;
  return lines;
}

// Launch point: a small octahedron on a vertical post.
export function marker(x, y, z, size, color) {
  const g = new THREE.Group();
  const head = new THREE.Mesh(new THREE.OctahedronGeometry(size), new THREE.MeshBasicMaterial({ color }));
  head.position.set(x, y, z + size * 2.5);
  const post = lineSegments(new Float32Array([x, y, z, x, y, z + size * 2.5]), color);
  g.add(head, post);
  return g;
}
