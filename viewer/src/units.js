// Presentation units (docs/units.md), mirroring api/units.h: SI, or US customary as US
// explosives-safety practice states its figures (DoD 6055.09-M / DESR 6055.09: distances in ft,
// energies in ft-lb, fragment densities per 600 ft²). SI stays the unit of summary.json, the
// scene and the API: these functions only convert a figure for display and name its unit.
//
// Factors, exact by definition (NIST SP 811, Appendix B), the same as api/units.h:
//   1 ft = 0.3048 m; 1 lb = 0.45359237 kg; 1 lbf = 4.4482216152605 N, so
//   1 ft-lb = 1.3558179483314004 J; 600 ft² = 55.741824 m².
//
// The selected system is kept in localStorage ("fragsim.units") and applies to every page.

export const FOOT_M = 0.3048;
export const POUND_KG = 0.45359237;
export const FOOT_POUND_J = 1.3558179483314004;
export const SQ_FT_600_M2 = 600 * FOOT_M * FOOT_M;  // 55.741824 m²

export const UNIT_SYSTEMS = ['si', 'us'];
const STORAGE_KEY = 'fragsim.units';

// 'si' | 'us', or null for anything else.
export function parseUnitSystem(name) {
  return UNIT_SYSTEMS.includes(name) ? name : null;
}

// {value, unit} of a figure in system u.
export function length(m, u) {
  return u === 'us' ? { value: m / FOOT_M, unit: 'ft' } : { value: m, unit: 'm' };
}
export function energy(j, u) {
  return u === 'us' ? { value: j / FOOT_POUND_J, unit: 'ft-lb' } : { value: j, unit: 'J' };
}
export function mass(kg, u) {
  return u === 'us' ? { value: kg / POUND_KG, unit: 'lb' } : { value: kg, unit: 'kg' };
}
export function speed(mps, u) {
  return u === 'us' ? { value: mps / FOOT_M, unit: 'ft/s' } : { value: mps, unit: 'm/s' };
}
export function area(m2, u) {
  return u === 'us' ? { value: m2 / (FOOT_M * FOOT_M), unit: 'ft²' } : { value: m2, unit: 'm²' };
}
export function arealDensity(perM2, u) {
  return u === 'us' ? { value: perM2 * SQ_FT_600_M2, unit: 'per 600 ft²' } : { value: perM2, unit: 'per m²' };
}

// The unit of a quantity in system u: lengthUnit('us') = 'ft'.
export const lengthUnit = (u) => length(0, u).unit;
export const densityUnit = (u) => arealDensity(0, u).unit;

// A value converted with `fn` (length, arealDensity, ...); null/undefined/NaN stay as they are,
// so that the formatters still print their dash.
export function convert(x, fn, u) {
  return typeof x === 'number' && Number.isFinite(x) ? fn(x, u).value : x;
}

// The compass bearing (degrees clockwise from +y, taken as grid north, in [0, 360)) of an
// azimuth counter-clockwise from +x, as the HFD sectors are numbered (core/run/hfd.h).
export function bearingDeg(azimuthCcwFromXDeg) {
  let b = ((90 - azimuthCcwFromXDeg) % 360) + 0;  // + 0: no -0
  if (b < 0) b += 360;
  return b >= 360 ? 0 : b;
}

const deg3 = (b) => String(Math.round(b)).padStart(3, '0');

// HFD sector k (azimuth [10k, 10k + 10) from +x) as the bearing range it covers, clockwise:
// "080°–090°" for sector 0.
export function sectorBearingRange(k) {
  const from = bearingDeg(10 * k + 10);
  const to = bearingDeg(10 * k) || 360;
  return `${deg3(from)}°–${deg3(to)}°`;
}

// The sectors marked true (36 booleans) as arcs of adjacent sectors in order of bearing:
// "080°–100°, 350°–010°"; "000°–360°" when all are; "" when none is (api/units.h, the same text).
export function sectorBearingArcs(sectors) {
  const n = sectors.length;
  const on = (k) => !!sectors[((k % n) + n) % n];
  const count = sectors.filter(Boolean).length;
  if (count === 0) return '';
  if (count === n) return '000°–360°';
  const arcs = [];
  for (let first = 0; first < n; first++) {
    if (!on(first) || on(first - 1)) continue;
    let last = first;
    while (on(last + 1)) last++;
    const from = bearingDeg(10 * last + 10), to = bearingDeg(10 * first) || 360;
    arcs.push([from, `${deg3(from)}°–${deg3(to)}°`]);
  }
  return arcs.sort((a, b) => a[0] - b[0]).map((a) => a[1]).join(', ');
}

// ---- the page's selection ------------------------------------------------------------------------

const listeners = new Set();

function stored() {
  try {
    return parseUnitSystem(globalThis.localStorage?.getItem(STORAGE_KEY)) || 'si';
  } catch {
    return 'si';  // storage refused (privacy settings): SI, not persisted
  }
}

let current = stored();

export function currentUnits() {
  return current;
}

// Selects u ('si' | 'us'), keeps it for the next visit and tells the listeners.
export function setUnits(u) {
  const next = parseUnitSystem(u);
  if (!next) throw new Error(`units: expected si or us, got ${JSON.stringify(u)}`);
  try {
    globalThis.localStorage?.setItem(STORAGE_KEY, next);
  } catch {
    // not persisted; the page still switches
  }
  if (next === current) return;
  current = next;
  for (const fn of listeners) fn(next);
}

// fn(u) after every change; returns the function that stops it.
export function onUnitsChange(fn) {
  listeners.add(fn);
  return () => listeners.delete(fn);
}
