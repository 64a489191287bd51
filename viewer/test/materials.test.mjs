// Terrain colouring by material without a browser (materials.js): the legend's entries, the
// per-triangle colours, the palette and the pages' default colouring.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { MATERIAL_PALETTE, defaultColouring, hasMaterials, materialColors, materialEntries } from '../src/materials.js';

const names = ['concrete_wall', 'gravel', 'metal_roof', 'soil'];

test('the legend lists each material the terrain uses, in index order, with its colour and count', () => {
  const material = Uint8Array.from([3, 3, 1, 3, 1, 3]);  // soil, gravel: the walls' and roofs' are not on the terrain
  const entries = materialEntries(names, material);
  assert.deepEqual(entries.map((e) => [e.index, e.name, e.triangles]), [[1, 'gravel', 2], [3, 'soil', 4]]);
  assert.deepEqual(entries.map((e) => e.color), [MATERIAL_PALETTE[0], MATERIAL_PALETTE[1]]);
  const rgb = materialColors(material, entries);
  assert.equal(rgb.length, 3 * material.length);
  for (let t = 0; t < material.length; t++)
    assert.deepEqual(Array.from(rgb.subarray(3 * t, 3 * t + 3)), material[t] === 1 ? MATERIAL_PALETTE[0] : MATERIAL_PALETTE[1], `triangle ${t}`);
});

test('the palette is Okabe–Ito: distinct colours, orange first, black last', () => {
  const hex = MATERIAL_PALETTE.map((c) => '#' + c.map((v) => v.toString(16).padStart(2, '0')).join('').toUpperCase());
  assert.equal(new Set(hex).size, hex.length);
  assert.deepEqual(hex.slice(0, 7), ['#E69F00', '#56B4E9', '#009E73', '#F0E442', '#0072B2', '#D55E00', '#CC79A7']);
  assert.equal(hex.at(-1), '#000000');
});

test('more materials than colours: the palette repeats; u16 indices work as u8 ones', () => {
  const many = Array.from({ length: 300 }, (_, k) => `m${k}`);
  const material = Uint16Array.from({ length: 300 }, (_, k) => 299 - k);
  const entries = materialEntries(many, material);
  assert.equal(entries.length, 300);
  assert.equal(entries[0].name, 'm0');
  assert.deepEqual(entries[MATERIAL_PALETTE.length].color, MATERIAL_PALETTE[0]);
  assert.equal(entries[299].name, 'm299');
});

test('default colouring: density on a job; material on a site with several terrain materials', () => {
  const one = materialEntries(names, Uint8Array.from([3, 3]));
  const two = materialEntries(names, Uint8Array.from([3, 1]));
  assert.equal(defaultColouring('job', two), 'density');
  assert.equal(defaultColouring('site', two), 'material');
  assert.equal(defaultColouring('site', one), 'elevation');
  assert.equal(defaultColouring('site', []), 'elevation');
});

test('an old results file (no terrain_material) has no materials to colour by', () => {
  assert.deepEqual(materialEntries([], null), []);
  assert.equal(hasMaterials({ arrays: {}, materialNames: [] }), false);
  assert.equal(hasMaterials({ arrays: { terrain_material: new Uint8Array(2) }, materialNames: ['soil'] }), true);
});
