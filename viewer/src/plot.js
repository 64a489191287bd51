// Density against distance from the HFD origin, per compass sector: computed from the terrain
// triangle centroids (area-weighted mean per distance bin) and drawn on a 2-D canvas.

import { decadeLabel } from './legend.js';
import { arealDensity, densityUnit, length, lengthUnit } from './units.js';

export const SECTORS = ['E', 'NE', 'N', 'NW', 'W', 'SW', 'S', 'SE'];  // 45° each, centred
const COLORS = ['#0072b2', '#e69f00', '#009e73', '#cc79a7', '#56b4e9', '#d55e00', '#000000', '#999933'];

// origin: [x, y] relative to the scene offset; the distance axis reaches the farthest non-zero
// density (and at least minRange, within the terrain). Returns {binWidth, rMax, means: [8][bins]}.
export function densityProfiles(verts, tris, density, origin, minRange = 0, nBins = 60) {
  const m = density.length;
  const cx = new Float64Array(m), cy = new Float64Array(m), area = new Float64Array(m), rad = new Float64Array(m);
  let rMax = 0, rAll = 0, areaSum = 0;
  for (let t = 0; t < m; t++) {
    const a = 3 * tris[3 * t], b = 3 * tris[3 * t + 1], c = 3 * tris[3 * t + 2];
    const x = (verts[a] + verts[b] + verts[c]) / 3 - origin[0];
    const y = (verts[a + 1] + verts[b + 1] + verts[c + 1]) / 3 - origin[1];
    cx[t] = x; cy[t] = y;
    area[t] = 0.5 * Math.abs((verts[b] - verts[a]) * (verts[c + 1] - verts[a + 1]) -
      (verts[c] - verts[a]) * (verts[b + 1] - verts[a + 1]));
    areaSum += area[t];
    const r = Math.sqrt(x * x + y * y);
    rad[t] = r;
    if (r > rAll) rAll = r;
    if (density[t] > 0 && r > rMax) rMax = r;
  }
  rMax = Math.min(rAll, Math.max((rMax || rAll) * 1.05, minRange));
  const binWidth = Math.max(rMax / nBins, 1.5 * Math.sqrt(areaSum / Math.max(m, 1)));
  const n = Math.max(1, Math.ceil(rMax / binWidth));
  const sum = SECTORS.map(() => new Float64Array(n)), w = SECTORS.map(() => new Float64Array(n));
  for (let t = 0; t < m; t++) {
    const bin = Math.floor(rad[t] / binWidth);
    if (bin >= n) continue;
    let az = (Math.atan2(cy[t], cx[t]) * 180) / Math.PI + 22.5;
    if (az < 0) az += 360;
    const s = Math.floor(az / 45) % 8;
    sum[s][bin] += density[t] * area[t];
    w[s][bin] += area[t];
  }
  const means = sum.map((sv, s) => sv.map((v, i) => (w[s][i] > 0 ? v / w[s][i] : 0)));
  return { binWidth, rMax: n * binWidth, means };
}

function niceStep(range, target = 6) {
  const raw = range / target, p = 10 ** Math.floor(Math.log10(raw));
  return [1, 2, 2.5, 5, 10].map((k) => k * p).find((s) => s >= raw) || 10 * p;
}

function setupCanvas(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth || 480, h = canvas.clientHeight || 300;
  canvas.width = Math.round(w * dpr);
  canvas.height = Math.round(h * dpr);
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  ctx.clearRect(0, 0, w, h);
  return { ctx, w, h };
}

// A profile (m, per m²), its threshold and HFD in units u: the plot is drawn in them.
function inUnits(profile, threshold, hfd, u) {
  if (u !== 'us') return { profile, threshold, hfd };
  const d = arealDensity(1, u).value, l = length(1, u).value;
  return {
    profile: { binWidth: profile.binWidth * l, rMax: profile.rMax * l, means: profile.means.map((s) => s.map((v) => v * d)) },
    threshold: threshold * d,
    hfd: hfd * l,
  };
}

// profile from densityProfiles; threshold and hfd (m) marked, "HFD ≥" when hfdLower (the site
// boundary cuts it: the curves stop at the terrain's edge, not where the density falls). Axes
// and labels in `units` ('si': m, per m²; 'us': ft, per 600 ft²).
export function drawDensityPlot(canvas, profileM, { threshold: thresholdM, hfd: hfdM, hfdLower = false, units = 'si' }) {
  const { profile, threshold, hfd } = inUnits(profileM, thresholdM, hfdM, units);
  const { ctx, w, h } = setupCanvas(canvas);
  const M = { l: 56, r: 74, t: 12, b: 40 };
  const pw = w - M.l - M.r, ph = h - M.t - M.b;
  let hi = threshold * 10;
  for (const s of profile.means) for (const v of s) if (v > hi) hi = v;
  const lo = threshold / 100;
  const l0 = Math.floor(Math.log10(lo)), l1 = Math.ceil(Math.log10(hi));
  const X = (r) => M.l + (r / profile.rMax) * pw;
  const Y = (v) => M.t + ph - ((Math.log10(v) - l0) / (l1 - l0)) * ph;

  ctx.font = '11px system-ui, sans-serif';
  ctx.fillStyle = '#222';
  ctx.strokeStyle = '#e3e5e8';
  ctx.lineWidth = 1;
  ctx.textAlign = 'right';
  ctx.textBaseline = 'middle';
  for (let e = l0; e <= l1; e++) {
    const y = Math.round(Y(10 ** e)) + 0.5;
    ctx.beginPath(); ctx.moveTo(M.l, y); ctx.lineTo(M.l + pw, y); ctx.stroke();
    ctx.fillText(decadeLabel(10 ** e), M.l - 5, y);
  }
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  const step = niceStep(profile.rMax);
  for (let r = 0; r <= profile.rMax + 1e-9; r += step) {
    const x = Math.round(X(r)) + 0.5;
    ctx.beginPath(); ctx.moveTo(x, M.t); ctx.lineTo(x, M.t + ph); ctx.stroke();
    ctx.fillText(String(Math.round(r)), x, M.t + ph + 4);
  }
  const xLabel = `distance from the HFD origin (${lengthUnit(units)})`, yLabel = `density (${densityUnit(units)})`;
  canvas.dataset.xLabel = xLabel;  // what the axes say, for the tests
  canvas.dataset.yLabel = yLabel;
  ctx.fillText(xLabel, M.l + pw / 2, M.t + ph + 20);
  ctx.save();
  ctx.translate(12, M.t + ph / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.fillText(yLabel, 0, -6);
  ctx.restore();

  ctx.save();
  ctx.beginPath(); ctx.rect(M.l, M.t, pw, ph); ctx.clip();
  profile.means.forEach((s, k) => drawSeries(ctx, s, profile.binWidth, X, Y, COLORS[k], lo / 10));
  ctx.strokeStyle = '#d6001c';
  ctx.lineWidth = 1.5;
  ctx.setLineDash([6, 4]);
  ctx.beginPath(); ctx.moveTo(M.l, Y(threshold)); ctx.lineTo(M.l + pw, Y(threshold)); ctx.stroke();
  if (hfd > 0) {
    ctx.setLineDash([2, 3]);
    ctx.beginPath(); ctx.moveTo(X(hfd), M.t); ctx.lineTo(X(hfd), M.t + ph); ctx.stroke();
  }
  ctx.restore();
  ctx.fillStyle = '#d6001c';
  ctx.textAlign = 'left';
  ctx.textBaseline = 'bottom';
  ctx.fillText('threshold', M.l + 4, Y(threshold) - 2);
  const label = `HFD ${hfdLower ? '≥ ' : ''}${hfd.toFixed(1)} ${lengthUnit(units)}`;
  canvas.dataset.hfdLabel = hfd > 0 ? label : '';  // what the canvas says, for the tests
  if (hfd > 0 && hfd < profile.rMax) {
    // Left of its line when it would run past the plot's right edge into the key.
    const left = X(hfd) + 4 + ctx.measureText(label).width > M.l + pw;
    ctx.textAlign = left ? 'right' : 'left';
    ctx.fillText(label, X(hfd) + (left ? -4 : 4), M.t + 12);
  }
  ctx.strokeStyle = '#888';
  ctx.lineWidth = 1;
  ctx.strokeRect(M.l + 0.5, M.t + 0.5, pw, ph);
  drawKey(ctx, M.l + pw + 10, M.t + 4);
}

function drawSeries(ctx, s, binWidth, X, Y, color, floor) {
  ctx.strokeStyle = color;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  let pen = false;
  for (let i = 0; i < s.length; i++) {
    if (!(s[i] > floor)) {
      pen = false;
      continue;
    }
    const x = X((i + 0.5) * binWidth), y = Y(s[i]);
    if (pen) ctx.lineTo(x, y);
    else ctx.moveTo(x, y);
    pen = true;
  }
  ctx.stroke();
}

function drawKey(ctx, x, y) {
  ctx.textAlign = 'left';
  ctx.textBaseline = 'middle';
  SECTORS.forEach((name, k) => {
    const yy = y + 8 + k * 16;
    ctx.strokeStyle = COLORS[k];
    ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x, yy); ctx.lineTo(x + 18, yy); ctx.stroke();
    ctx.fillStyle = '#222';
    ctx.fillText(name, x + 23, yy);
  });
  ctx.fillStyle = '#666';
  ctx.fillText('sector', x, y + 8 + 8 * 16 + 4);
  ctx.fillText('(45°)', x, y + 8 + 9 * 16);
}
