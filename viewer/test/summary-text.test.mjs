// The summary's words without a browser: summary_text.js rows that need no DOM.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { groundBracketRow } from '../src/summary_text.js';

const row = (constant, lo, hi) => ({
  constant,
  low: { value: 0, hfd_m: lo, hfd_bound: 'none' },
  high: { value: 5, hfd_m: hi, hfd_bound: 'none' },
});

test('the ground-model bracket reads as a range, flagged, with its widest row', () => {
  const s = {
    ground_bracket: {
      hfd_range_m: [139.24, 421.83], hfd_range_bound: 'none', cancelled: false,
      nominal: { hfd_m: 156.91 }, histories_per_run: 80000,
      rows: [row('roughness_deg', 421.83, 139.24), row('exit_angle_ratio', 391.8, 139.2)],
    },
  };
  const [key, , value, flagged] = groundBracketRow(s);
  assert.equal(key, 'ground_bracket');
  assert.equal(value[0], '139.2 – 421.8');
  assert.equal(value[1], 'nominal 156.9 m at 80,000 histories per run');
  assert.match(value[2], /^widest: roughness_deg 421\.8 m at 0, 139\.2 m at 5$/);
  assert.equal(flagged, true);
});

test('a cut end reads as a lower bound; a cancelled bracket says so; none without one', () => {
  const s = {
    ground_bracket: { hfd_range_m: [100, 300], hfd_range_bound: 'lower', cancelled: true, rows: [] },
  };
  const [, , value] = groundBracketRow(s);
  assert.equal(value[0], '≥ 100.0 – ≥ 300.0');
  assert.match(value[2], /cancelled/);
  assert.match(value[2], /lower bounds/);
  assert.equal(groundBracketRow({}), null);
});
