// The job's figures as a person reads them (summary.json, and the live job's `precision`): HFDs
// that the site boundary cuts carry "≥" (issue 22: the terrain ends, so nothing is known beyond
// it and the distance is only a lower bound), stop reasons and precision targets in words.
// Summaries of older jobs lack the bound keys: their figures read as they always did.

import { el, fixed, sig, plusMinus, integer } from './format.js';

export const LOWER_BOUND_NOTE = 'lower bound: the hazardous density reaches the site boundary';

export function isLower(bound) {
  return bound === 'lower';
}

// A distance (m) to one decimal, "≥ 266.4" when it is a lower bound.
export function bounded(m, bound) {
  return (isLower(bound) ? '≥ ' : '') + fixed(m, 1);
}

// Per sector k, is hfd_by_sector_m[k] a lower bound? (36 booleans; none for older summaries)
export function sectorLowerBounds(s) {
  const b = s.hfd_by_sector_bound || [];
  return Array.from({ length: 36 }, (_, k) => isLower(b[k]));
}

// The note of a cut HFD, e.g. "HFD ≥ 266.4 m: hazardous density reaches the site boundary in 19
// of 36 sectors; extend the terrain"; null when it is not cut (or the summary predates the key).
export function boundaryNote(s) {
  const note = s.site_boundary && s.site_boundary.note;
  return typeof note === 'string' && note ? note : null;
}

const STOP_REASONS = {
  samples: 'all samples run',
  targets_met: 'precision targets met',
  max_batches: 'max_batches reached',
  max_wall_time: 'max_wall_s reached',
  cancelled: 'cancelled',
  targets_unmeetable: 'stopped: a precision target cannot be met by more histories',
};

export function stopReasonText(reason) {
  if (reason === null || reason === undefined) return '—';
  return STOP_REASONS[reason] || reason;
}

// ---- precision targets --------------------------------------------------------------------------

// "met", "UNMEETABLE" or "not met"; an unmeetable target is one no number of histories can meet
// (today: an HFD target whose band's lower end the site boundary cuts), which "not met" hides.
export function targetVerdict(t) {
  if (t.met) return 'met';
  return t.unmeetable ? 'UNMEETABLE' : 'not met';
}

// "10.57 (allowed 1) UNMEETABLE", with the target's note (why) as a sub-line when it has one.
function targetLine(t) {
  const line = `${sig(t.value, 4)} (allowed ${sig(t.allowed, 4)}) ${targetVerdict(t)}`;
  return typeof t.note === 'string' && t.note ? [line, t.note] : line;
}

function isBuildingTarget(t) {
  return String(t.figure || '').startsWith('building_');
}

function overallVerdict(p) {
  if (p.all_met) return 'all met';
  return p.any_unmeetable ? 'not all can be met' : 'not all met';
}

// Summary-table rows [key, label, value, flagged] of a precision report: the overall verdict,
// a row per non-building target, one for the building targets (met of all, like the CLI's text).
export function precisionRows(p) {
  if (!p) return [];
  const targets = p.targets || [];
  const rows = [['precision', 'Precision targets', overallVerdict(p), !!p.any_unmeetable]];
  for (const t of targets.filter((x) => !isBuildingTarget(x)))
    rows.push([`target-${t.figure}`, `target: ${t.figure}`, targetLine(t), !!t.unmeetable]);
  const b = targets.filter(isBuildingTarget);
  if (b.length) {
    const met = b.filter((t) => t.met).length;
    const bad = b.filter((t) => t.unmeetable).length;
    const text = `${met} of ${b.length} met${bad ? `, ${bad} UNMEETABLE` : ''}`;
    rows.push(['target-buildings', 'target: building figures', text, bad > 0]);
  }
  return rows;
}

// One line for a running job: "0 of 1 targets met; hfd_half_band_m UNMEETABLE: <note>".
export function precisionStatus(p) {
  if (!p || !p.targets) return '';
  const met = p.targets.filter((t) => t.met).length;
  const bad = p.targets.filter((t) => t.unmeetable)
    .map((t) => `${t.figure} UNMEETABLE${t.note ? `: ${t.note}` : ''}`);
  return [`${met} of ${p.targets.length} targets met`, ...bad].join('; ');
}

// ---- summary table ------------------------------------------------------------------------------

// "hazardous in 19 of 36 sectors (density there up to 0.0471 per m², 2.6 × the threshold)".
function boundaryText(sb, thr) {
  const cut = sb.hfd_sectors_cut || 0;
  const edge = sb.max_boundary_density_per_m2;
  const where = cut > 0 ? `hazardous in ${cut} of 36 sectors` : 'not reached';
  if (!(edge > 0)) return `${where} (no hazardous density on its triangles)`;
  return `${where} (density there up to ${sig(edge, 4)} per m², ${sig(edge / thr, 2)} × the threshold)`;
}

function leftSiteText(left) {
  const n = left.histories || 0;
  const tail = n > 0 ? ': where they land is not modelled' : '';
  return `${plusMinus(left.fragments, left.fragments_std_error)} real fragments (${integer(n)} histories)${tail}`;
}

// The HFD rows: distance, band, and (newer summaries) the site boundary and the hazardous
// fragments that left the site.
function hfdRows(s) {
  const band = s.hazardous_fragment_distance_band_m || [null, null];
  const bb = s.hfd_band_bound || [];
  const cut = isLower(s.hfd_bound);
  const hfd = bounded(s.hazardous_fragment_distance_m, s.hfd_bound);
  const rows = [
    ['hfd', 'Hazardous fragment distance (m)', cut ? [hfd, LOWER_BOUND_NOTE] : hfd, cut],
    ['hfd_band', 'HFD band, mean ∓ 1 se (m)', `${bounded(band[0], bb[0])} – ${bounded(band[1], bb[1])}`, bb.some(isLower)],
  ];
  const bracket = groundBracketRow(s);
  if (bracket) rows.push(bracket);
  const sb = s.site_boundary, left = sb && sb.left_site_hazardous;
  if (sb) rows.push(['site_boundary', 'Site boundary', boundaryText(sb, s.hfd_threshold_per_m2), sb.hfd_sectors_cut > 0]);
  if (left) rows.push(['left_site_hazardous', 'Left the site while hazardous', leftSiteText(left), left.histories > 0]);
  return rows;
}

// settings.ground_bracket (issue 23): the HFD over the ground model's uncertain constants, e.g.
// "139.2 – 421.8" with the widest row as a sub-line; flagged, since the nominal HFD alone would
// read as more certain than the ground model is. null without a bracket.
export function groundBracketRow(s) {
  const b = s.ground_bracket;
  if (!b || !Array.isArray(b.hfd_range_m)) return null;
  const lower = isLower(b.hfd_range_bound);
  const range = `${bounded(b.hfd_range_m[0], b.hfd_range_bound)} – ${bounded(b.hfd_range_m[1], b.hfd_range_bound)}`;
  const top = (b.rows || [])[0];
  const widest = top
    ? `widest: ${top.constant} ${fixed(top.low.hfd_m, 1)} m at ${top.low.value}, ${fixed(top.high.hfd_m, 1)} m at ${top.high.value}`
    : 'no rows';
  const note = `${widest}${b.cancelled ? ' (incomplete: cancelled)' : ''}${lower ? '; some ends are lower bounds' : ''}`;
  // Its runs may have fewer histories than the study, and the HFD depends on that: the range is
  // read against its own nominal run, which is said with it.
  const nominal = `nominal ${fixed(b.nominal && b.nominal.hfd_m, 1)} m at ${integer(b.histories_per_run)} histories per run`;
  return ['ground_bracket', 'HFD over the ground model’s ranges (m)', [range, nominal, note], true];
}

// Rows [key, label, value, flagged] of the job view's summary table.
export function summaryRows(s, scene) {
  const thr = s.hfd_threshold_per_m2;
  const traj = scene.trajectories;
  const rows = [
    ...hfdRows(s),
    ['hfd_origin', 'HFD origin x, y, z (m)', (s.hfd_origin_m || []).map((v) => fixed(v, 1)).join(', ')],
    ['threshold', 'Density threshold (per m²)', `${sig(thr, 4)} (1 per ${sig(1 / thr, 4)} m²)`],
    ['max_density', 'Max PTN density (per m²)', sig(s.max_ptn_density_per_m2, 4)],
    ['buildings', 'Buildings', String((s.buildings || []).length)],
    ['samples', 'Samples', integer(s.samples)],
    ['histories', 'Histories simulated', integer(s.histories_done)],
    ['batches', 'Batches', integer(s.batches)],
    ['stop_reason', 'Stop reason', stopReasonText(s.stop_reason), s.stop_reason === 'targets_unmeetable'],
    ...precisionRows(s.precision),
    ['real_fragments', 'Real fragments', sig(s.real_fragments, 6)],
    ['wall_time', 'Wall time (s)', fixed(s.timing && s.timing.wall_s, 2)],
    ['seed', 'Seed', String(s.seed)],
    ['triangles', 'Terrain triangles', integer(scene.arrays.terrain_triangles.length / 3)],
  ];
  if (traj) rows.push(['trajectories', 'Trajectories shown', `${integer(traj.sent)} of ${integer(traj.recorded)} recorded`]);
  return rows;
}

// ---- what sets the HFD (issue 23) --------------------------------------------------------------

const MECHANISMS = {
  direct_flight: 'direct flight',
  after_ricochet: 'flight after a ricochet',
  ground: 'ground phase (slide, roll)',
};

// "92 %", "<1 %" for a share above 0 that would read as 0, "—" when there is none.
export function percent(x) {
  if (typeof x !== 'number') return '—';
  if (x > 0 && x < 0.005) return '<1 %';
  return `${Math.round(100 * x)} %`;
}

// Rows [key, label, HFD alone, share at the HFD's triangle] of the attribution table: a row per
// mechanism and per group, and the reason when per-group figures were omitted. None for
// summaries that predate hfd_attribution.
export function attributionRows(s) {
  const a = s.hfd_attribution;
  if (!a) return [];
  const at = a.at_hfd || null;
  const rows = [];
  for (const m of a.mechanisms || []) {
    const f = (a.by_mechanism || {})[m] || {};
    rows.push([`mechanism-${m}`, MECHANISMS[m] || m, bounded(f.hfd_m, f.hfd_bound),
      percent(at && at.share_by_mechanism ? at.share_by_mechanism[m] : null)]);
  }
  (a.by_group || []).forEach((g, i) => {
    rows.push([`group-${i}`, `group ${g.group}`, bounded(g.hfd_m, g.hfd_bound),
      percent(at && at.share_by_group ? at.share_by_group[i] : null)]);
  });
  if (typeof a.by_group_omitted_reason === 'string' && a.by_group_omitted_reason)
    rows.push(['groups-omitted', 'groups', `omitted: ${a.by_group_omitted_reason}`, '—']);
  return rows;
}

export function attributionRow([key, label, hfd, share]) {
  return el('tr', { dataset: { key } }, [
    el('th', { text: label }), el('td', { class: 'num', text: hfd }), el('td', { class: 'num', text: share }),
  ]);
}

// A table row: value is text, or [text, sub-line]; `flagged` rows (a lower bound, an unmeetable
// target) are marked for the eye.
export function summaryRow([key, label, value, flagged]) {
  const [text, ...subs] = Array.isArray(value) ? value : [value];
  const lines = subs.filter((x) => x).map((x) => el('div', { class: 'small sub-line', text: x }));
  const td = el('td', { class: 'value' }, [text, ...lines]);
  return el('tr', { dataset: { key }, class: flagged ? 'flagged' : null }, [el('th', { text: label }), td]);
}
