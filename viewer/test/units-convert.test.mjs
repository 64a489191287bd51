// Presentation units without a browser (units.js, and the summary's words in them): the same
// factors as api/units.h (read from it), the DESR 6055.09 figures, bearings of the HFD sectors,
// the selection kept in localStorage, and the summary rows in US units.
import assert from 'node:assert/strict';
import fs from 'node:fs';
import { test } from 'node:test';
import * as units from '../src/units.js';
import { boundaryNote, groundBracketRow, precisionRows, summaryRows, thresholdText } from '../src/summary_text.js';

const near = (a, b, tol, what) => assert.ok(Math.abs(a - b) <= tol, `${what}: ${a} vs ${b} (± ${tol})`);

test('the factors are api/units.h\'s, exact by definition (NIST SP 811 App. B)', () => {
  const header = fs.readFileSync(new URL('../../api/units.h', import.meta.url), 'utf8');
  const constant = (name) => Number(header.match(new RegExp(`${name} = ([0-9.e-]+);`))[1]);
  assert.equal(units.FOOT_M, constant('kFootM'));
  assert.equal(units.POUND_KG, constant('kPoundKg'));
  assert.equal(units.FOOT_POUND_J, constant('kFootPoundJ'));
  assert.equal(units.FOOT_M, 0.3048);
  near(units.POUND_KG * 9.80665, 4.4482216152605, 1e-15, 'lbf = lb × g_n');
  near(units.FOOT_M * 4.4482216152605, units.FOOT_POUND_J, 1e-15, 'ft-lb');
  near(units.SQ_FT_600_M2, 55.741824, 1e-12, '600 ft²');
  assert.deepEqual(units.length(0.3048, 'us'), { value: 1, unit: 'ft' });
  assert.deepEqual(units.length(138.8, 'si'), { value: 138.8, unit: 'm' });
  near(units.energy(79, 'us').value, 58.26741, 1e-5, '79 J in ft-lb');
  near(58 * units.FOOT_POUND_J, 78.63744, 1e-5, '58 ft-lb in J (DESR 6055.09)');
  near(units.mass(0.45359237, 'us').value, 1, 1e-15, '1 lb');
  near(units.speed(0.3048, 'us').value, 1, 1e-15, '1 ft/s');
  near(units.area(0.09290304, 'us').value, 1, 1e-15, '1 ft²');
  near(units.arealDensity(1 / 55.741824, 'us').value, 1, 1e-15, '1 per 600 ft²');
  assert.equal(units.arealDensity(1, 'us').unit, 'per 600 ft²');
  assert.equal(units.convert(null, units.length, 'us'), null);
  assert.equal(units.parseUnitSystem('us'), 'us');
  for (const bad of ['', 'US', 'imperial', undefined, null]) assert.equal(units.parseUnitSystem(bad), null);
});

test('bearings: clockwise from grid north (+y) of azimuths counter-clockwise from +x', () => {
  assert.equal(units.bearingDeg(90), 0);
  assert.equal(units.bearingDeg(0), 90);
  assert.equal(units.bearingDeg(180), 270);
  assert.equal(units.bearingDeg(-90), 180);
  assert.ok(Object.is(units.bearingDeg(450), 0), 'no -0');
  assert.equal(units.sectorBearingRange(0), '080°–090°');
  assert.equal(units.sectorBearingRange(9), '350°–360°');
  assert.equal(units.sectorBearingRange(35), '090°–100°');
  assert.equal(units.sectorBearingRange(36), '080°–090°');
  const s = Array(36).fill(false);
  assert.equal(units.sectorBearingArcs(s), '');
  s[0] = s[35] = s[8] = s[9] = true;
  assert.equal(units.sectorBearingArcs(s), '080°–100°, 350°–010°');  // as api/units.h says it
  assert.equal(units.sectorBearingArcs(Array(36).fill(true)), '000°–360°');
});

test('the selection is kept in localStorage and told to listeners; SI when nothing is stored', async () => {
  const store = new Map();
  globalThis.localStorage = { getItem: (k) => store.get(k) ?? null, setItem: (k, v) => store.set(k, v) };
  try {
    const fresh = await import(new URL('../src/units.js?fresh-1', import.meta.url));
    assert.equal(fresh.currentUnits(), 'si');
    const seen = [];
    const stop = fresh.onUnitsChange((u) => seen.push(u));
    fresh.setUnits('us');
    fresh.setUnits('us');  // no change, no call
    assert.equal(fresh.currentUnits(), 'us');
    assert.equal(store.get('fragsim.units'), 'us');
    assert.throws(() => fresh.setUnits('imperial'), /expected si or us/);
    stop();
    fresh.setUnits('si');
    assert.deepEqual(seen, ['us']);
    store.set('fragsim.units', 'us');
    const again = await import(new URL('../src/units.js?fresh-2', import.meta.url));
    assert.equal(again.currentUnits(), 'us', 'the next visit starts in the stored system');
  } finally {
    delete globalThis.localStorage;
  }
});

const summary = {
  hazardous_fragment_distance_m: 266.5, hfd_bound: 'lower',
  hazardous_fragment_distance_band_m: [248, 273.25], hfd_band_bound: ['none', 'lower'],
  hfd_by_sector_bound: Array.from({ length: 36 }, (_, k) => (k === 0 || k === 35 ? 'lower' : 'none')),
  hfd_threshold_per_m2: 1 / 55.74, hfd_origin_m: [0, 0, 1.5], max_ptn_density_per_m2: 0.1,
  site_boundary: { hfd_sectors_cut: 2, max_boundary_density_per_m2: 0.05, note: 'HFD ≥ 266.5 m: hazardous density reaches the site boundary in 2 of 36 sectors; extend the terrain' },
  buildings: [], samples: 10, histories_done: 10, batches: 1, stop_reason: 'samples', real_fragments: 5, seed: 1,
  timing: { wall_s: 1 },
};
const scene = { arrays: { terrain_triangles: new Uint32Array(6) } };

test('the summary rows in US units: ft, per 600 ft², bearings; SI as before', () => {
  const us = Object.fromEntries(summaryRows(summary, scene, 'us').map(([k, label, value]) => [k, { label, value }]));
  assert.equal(us.hfd.label, 'Hazardous fragment distance (ft)');
  assert.equal(us.hfd.value[0], `≥ ${(266.5 / 0.3048).toFixed(1)}`);  // 874.3
  assert.equal(us.hfd_band.value, '813.6 – ≥ 896.5');
  assert.equal(us.threshold.label, 'Density threshold (per 600 ft²)');
  assert.equal(us.threshold.value, '1 (1 per 600 ft²)');
  assert.equal(us.max_density.value, '5.574');
  assert.equal(us.site_boundary.value,
    'hazardous in 2 of 36 sectors, bearings 080°–100° (density there up to 2.787 per 600 ft², 2.8 × the threshold)');
  assert.equal(us.hfd_origin.value, '0.0, 0.0, 1.5', 'site coordinates stay in metres');
  const si = Object.fromEntries(summaryRows(summary, scene).map(([k, label, value]) => [k, { label, value }]));
  assert.equal(si.hfd.label, 'Hazardous fragment distance (m)');
  assert.equal(si.hfd.value[0], '≥ 266.5');
  assert.equal(si.threshold.value, '0.01794 (1 per 55.74 m²)');
  assert.equal(thresholdText(1 / 55.741824, 'us'), '1 (1 per 600 ft²)');
  assert.equal(boundaryNote(summary), summary.site_boundary.note);
  assert.equal(boundaryNote(summary, 'us'),
    'HFD ≥ 874.3 ft: hazardous density reaches the site boundary in 2 of 36 sectors; extend the terrain');
});

test('length precision targets and the ground bracket in ft', () => {
  const p = { all_met: false, targets: [{ figure: 'hfd_half_band_m', value: 4.5, allowed: 3, met: false }] };
  const [, row] = precisionRows(p, 'us');
  assert.equal(row[1], 'target: hfd_half_band');
  assert.equal(row[2], '14.76 ft (allowed 9.843 ft) not met');
  assert.equal(precisionRows(p)[1][2], '4.5 (allowed 3) not met');
  const b = {
    ground_bracket: {
      hfd_range_m: [139.24, 421.83], hfd_range_bound: 'none', nominal: { hfd_m: 156.91 }, histories_per_run: 20,
      rows: [{ constant: 'roughness_deg', low: { value: 0, hfd_m: 421.83 }, high: { value: 5, hfd_m: 139.24 } }],
    },
  };
  const [, label, value] = groundBracketRow(b, 'us');
  assert.equal(label, 'HFD over the ground model’s ranges (ft)');
  assert.deepEqual(value.slice(0, 2), ['456.8 – 1384.0', 'nominal 514.8 ft at 20 histories per run']);
  assert.equal(value[2], 'widest: roughness_deg 1384.0 ft at 0, 456.8 ft at 5');
});
