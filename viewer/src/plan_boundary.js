// The site-plan hazard boundary (GET /v1/jobs/{id}/plan_boundary; docs/gis.md "Site-plan
// boundary"): the envelope of the sector HFDs, the same for density + 1 se, and the smoothed
// contour, drawn as lines at the HFD origin's height over the terrain (on top, like the HFD
// circle), one layer with a toggle and a legend key each. A boundary the site's edge cuts is
// dashed, as every lower bound on the page is.

import * as THREE from '../vendor/three.module.js';
import { request } from './api.js';
import { lengthText } from './summary_text.js';
import { keyItem } from './legend.js';
import * as meshes from './meshes.js';

export const PLAN_COLORS = { envelope: '#6a1b9a', upper: '#ce93d8', smoothed: '#00897b' };

export function fetchPlanBoundary(id) {
  return request(`/v1/jobs/${encodeURIComponent(id)}/plan_boundary`);
}

// Every ring of `polygons` ([[[x, y], ...] rings] per polygon, closed implicitly) as segments at
// height z.
export function ringSegments(polygons, z) {
  const out = [];
  for (const rings of polygons)
    for (const ring of rings)
      for (let i = 0; i < ring.length; i++) {
        const a = ring[i], b = ring[(i + 1) % ring.length];
        out.push(a[0], a[1], z, b[0], b[1], z);
      }
  return new Float32Array(out);
}

// lower: {estimate, upper} true where the site boundary cuts that figure (summary hfd_bound,
// hfd_band_bound[1]). Named lines: 'plan-envelope', 'plan-envelope-upper', 'plan-smoothed'.
export function planBoundaryLayer(b, z, lower) {
  const group = new THREE.Group();
  group.name = 'plan-boundary';
  const dash = (2 * Math.PI * Math.max(1, b.envelope_upper.max_radius_m)) / 80;
  const add = (name, polygons, color, cut) => {
    if (!polygons.length) return;
    const line = meshes.lineSegments(ringSegments(polygons, z), color,
      { onTop: true, order: 3, opacity: 0.95, dash: cut ? dash : 0 });
    line.name = name;
    group.add(line);
  };
  add('plan-envelope-upper', b.envelope_upper.polygons, PLAN_COLORS.upper, lower.upper);
  add('plan-envelope', b.envelope.polygons, PLAN_COLORS.envelope, lower.estimate);
  add('plan-smoothed', b.smoothed.polygons, PLAN_COLORS.smoothed, lower.estimate);
  return group;
}

// The legend's keys, distances in the selected units `u` ('si' | 'us': units.js).
export function planBoundaryKeys(b, lower, u = 'si') {
  if (!b.envelope_upper.polygons.length) return [];
  const kind = (cut) => (cut ? 'dashed' : 'line');
  const ge = (cut) => (cut ? '≥ ' : '');
  const len = (m) => lengthText(m, u);
  const longer = b.smoothed_hfd_m - b.exact_hfd_m;
  return [
    keyItem(PLAN_COLORS.envelope, `sector envelope, to ${ge(lower.estimate)}${len(b.envelope.max_radius_m)}`, kind(lower.estimate)),
    keyItem(PLAN_COLORS.upper, `sector envelope of density + 1 se, to ${ge(lower.upper)}${len(b.envelope_upper.max_radius_m)}`, kind(lower.upper)),
    keyItem(PLAN_COLORS.smoothed, `smoothed boundary (closing ${len(b.smoothing_m)}; reach ${len(b.smoothed_hfd_m)}, +${len(longer)})`, kind(lower.estimate)),
  ];
}
