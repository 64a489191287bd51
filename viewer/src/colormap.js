// Colour maps (sRGB 0..255) and scales.

// viridis (matplotlib), 16 control points, linearly interpolated.
const VIRIDIS = [
  [68, 1, 84], [72, 26, 108], [71, 47, 125], [65, 68, 135], [57, 86, 140], [49, 104, 142],
  [42, 120, 142], [35, 136, 142], [31, 152, 139], [34, 168, 132], [53, 183, 121],
  [84, 197, 104], [122, 209, 81], [165, 219, 54], [210, 226, 27], [253, 231, 37],
];
// ColorBrewer YlOrRd, sequential, for building penetrations.
const YLORRD = [
  [255, 237, 160], [254, 217, 118], [254, 178, 76], [253, 141, 60], [252, 78, 42],
  [227, 26, 28], [189, 0, 38], [128, 0, 38],
];
// ColorBrewer RdPu (upper part), for trajectory speed.
const RDPU = [[247, 104, 161], [221, 52, 151], [174, 1, 126], [122, 1, 119]];
// Muted hypsometric ramp for elevation (site preview).
const TERRAIN = [
  [84, 130, 89], [132, 163, 107], [186, 190, 134], [205, 180, 140], [176, 146, 122],
  [214, 208, 200],
];

function ramp(stops) {
  const n = stops.length - 1;
  return (t) => {
    const x = Math.min(Math.max(t, 0), 1) * n;
    const i = Math.min(Math.floor(x), n - 1);
    const f = x - i, a = stops[i], b = stops[i + 1];
    return [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])];
  };
}

export const viridis = ramp(VIRIDIS);
export const ylOrRd = ramp(YLORRD);
export const terrain = ramp(TERRAIN);
export const rdPu = ramp(RDPU);

// 256-entry Uint8 RGB lookup table of a ramp.
export function lut(fn, n = 256) {
  const out = new Uint8Array(n * 3);
  for (let i = 0; i < n; i++) {
    const c = fn(i / (n - 1));
    out[3 * i] = Math.round(c[0]);
    out[3 * i + 1] = Math.round(c[1]);
    out[3 * i + 2] = Math.round(c[2]);
  }
  return out;
}

export function css(c) {
  return `rgb(${Math.round(c[0])}, ${Math.round(c[1])}, ${Math.round(c[2])})`;
}

// Log scale lo..hi -> 0..1 (clamped).
export class LogScale {
  constructor(lo, hi) {
    this.lo = lo;
    this.hi = hi > lo ? hi : lo * 10;
    this.l0 = Math.log10(this.lo);
    this.inv = 1 / (Math.log10(this.hi) - this.l0);
  }
  t(x) {
    const t = (Math.log10(x) - this.l0) * this.inv;
    return t < 0 ? 0 : t > 1 ? 1 : t;
  }
  // Powers of ten within [lo, hi] (at least the ends).
  ticks() {
    const out = [];
    for (let e = Math.ceil(this.l0 - 1e-9); e <= Math.log10(this.hi) + 1e-9; e++) out.push(10 ** e);
    return out;
  }
}

export const ZERO_GREY = [196, 196, 196];  // zero-density terrain, light-shaded
export const BUILDING_GREY = [222, 222, 222];  // buildings with no expected penetration
