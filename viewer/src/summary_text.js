// The job's figures as a person reads them (summary.json, and the live job's `precision`): HFDs
// that the site boundary cuts carry "≥" (issue 22: the terrain ends, so nothing is known beyond
// it and the distance is only a lower bound), stop reasons and precision targets in words.
// Summaries of older jobs lack the bound keys: their figures read as they always did.
// Every function takes the presentation units u ('si' by default, or 'us': units.js); the
// summary itself is SI.

import { el, fixed, sig, plusMinus, integer } from './format.js';
import { area, arealDensity, convert, densityUnit, length, lengthUnit, sectorBearingArcs } from './units.js';

export const LOWER_BOUND_NOTE = 'lower bound: the hazardous density reaches the site boundary';

export function isLower(bound) {
  return bound === 'lower';
}

// A distance (m) to one decimal in units u, "≥ 266.4" when it is a lower bound.
export function bounded(m, bound, u = 'si') {
  return (isLower(bound) ? '≥ ' : '') + fixed(convert(m, length, u), 1);
}

// A distance with its unit: "138.8 m", "455.4 ft".
export function lengthText(m, u = 'si') {
  return `${fixed(convert(m, length, u), 1)} ${lengthUnit(u)}`;
}

// Per sector k, is hfd_by_sector_m[k] a lower bound? (36 booleans; none for older summaries)
export function sectorLowerBounds(s) {
  const b = s.hfd_by_sector_bound || [];
  return Array.from({ length: 36 }, (_, k) => isLower(b[k]));
}

// The note of a cut HFD, e.g. "HFD ≥ 266.4 m: hazardous density reaches the site boundary in 19
// of 36 sectors; extend the terrain"; null when it is not cut (or the summary predates the key).
// The stored note is in metres: in US units it is said again in feet, in the same words.
export function boundaryNote(s, u = 'si') {
  const sb = s.site_boundary;
  const note = sb && sb.note;
  if (!(typeof note === 'string' && note)) return null;
  if (u === 'si') return note;
  return `HFD ≥ ${lengthText(s.hazardous_fragment_distance_m, u)}: hazardous density reaches the ` +
    `site boundary in ${sb.hfd_sectors_cut} of 36 sectors; extend the terrain`;
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

// A length target ("..._m") in US units: its figure without "_m", its values in ft.
function isLengthTarget(t, u) {
  return u === 'us' && /_m$/.test(String(t.figure || ''));
}

function targetFigure(t, u) {
  return isLengthTarget(t, u) ? t.figure.slice(0, -2) : t.figure;
}

// "10.57 (allowed 1) UNMEETABLE", with the target's note (why) as a sub-line when it has one.
function targetLine(t, u) {
  const ft = isLengthTarget(t, u);
  const v = (x) => (ft ? `${sig(convert(x, length, u), 4)} ft` : sig(x, 4));
  const line = `${v(t.value)} (allowed ${v(t.allowed)}) ${targetVerdict(t)}`;
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
export function precisionRows(p, u = 'si') {
  if (!p) return [];
  const targets = p.targets || [];
  const rows = [['precision', 'Precision targets', overallVerdict(p), !!p.any_unmeetable]];
  for (const t of targets.filter((x) => !isBuildingTarget(x)))
    rows.push([`target-${t.figure}`, `target: ${targetFigure(t, u)}`, targetLine(t, u), !!t.unmeetable]);
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

// "hazardous in 19 of 36 sectors (density there up to 0.0471 per m², 2.6 × the threshold)"; in
// US units the cut sectors are named by bearing and the density is per 600 ft².
function boundaryText(s, sb, thr, u) {
  const cut = sb.hfd_sectors_cut || 0;
  const edge = sb.max_boundary_density_per_m2;
  let where = cut > 0 ? `hazardous in ${cut} of 36 sectors` : 'not reached';
  if (u === 'us' && cut > 0 && Array.isArray(s.hfd_by_sector_bound))
    where += `, bearings ${sectorBearingArcs(s.hfd_by_sector_bound.map(isLower))}`;
  if (!(edge > 0)) return `${where} (no hazardous density on its triangles)`;
  return `${where} (density there up to ${sig(convert(edge, arealDensity, u), 4)} ${densityUnit(u)}, ${sig(edge / thr, 2)} × the threshold)`;
}

function leftSiteText(left) {
  const n = left.histories || 0;
  const tail = n > 0 ? ': where they land is not modelled' : '';
  return `${plusMinus(left.fragments, left.fragments_std_error)} real fragments (${integer(n)} histories)${tail}`;
}

// The HFD rows: distance, band, and (newer summaries) the site boundary and the hazardous
// fragments that left the site.
function hfdRows(s, u) {
  const band = s.hazardous_fragment_distance_band_m || [null, null];
  const bb = s.hfd_band_bound || [];
  const cut = isLower(s.hfd_bound);
  const hfd = bounded(s.hazardous_fragment_distance_m, s.hfd_bound, u);
  const unit = lengthUnit(u);
  const rows = [
    ['hfd', `Hazardous fragment distance (${unit})`, cut ? [hfd, LOWER_BOUND_NOTE] : hfd, cut],
    ['hfd_band', `HFD band, mean ∓ 1 se (${unit})`, `${bounded(band[0], bb[0], u)} – ${bounded(band[1], bb[1], u)}`, bb.some(isLower)],
  ];
  const bracket = groundBracketRow(s, u);
  if (bracket) rows.push(bracket);
  const sb = s.site_boundary, left = sb && sb.left_site_hazardous;
  if (sb) rows.push(['site_boundary', 'Site boundary', boundaryText(s, sb, s.hfd_threshold_per_m2, u), sb.hfd_sectors_cut > 0]);
  if (left) rows.push(['left_site_hazardous', 'Left the site while hazardous', leftSiteText(left), left.histories > 0]);
  return rows;
}

// settings.ground_bracket (issue 23): the HFD over the ground model's uncertain constants, e.g.
// "139.2 – 421.8" with the widest row as a sub-line; flagged, since the nominal HFD alone would
// read as more certain than the ground model is. null without a bracket.
export function groundBracketRow(s, u = 'si') {
  const b = s.ground_bracket;
  if (!b || !Array.isArray(b.hfd_range_m)) return null;
  const lower = isLower(b.hfd_range_bound);
  const range = `${bounded(b.hfd_range_m[0], b.hfd_range_bound, u)} – ${bounded(b.hfd_range_m[1], b.hfd_range_bound, u)}`;
  const top = (b.rows || [])[0];
  // The constants' values stay as the scenario gives them (SI).
  const widest = top
    ? `widest: ${top.constant} ${lengthText(top.low.hfd_m, u)} at ${top.low.value}, ${lengthText(top.high.hfd_m, u)} at ${top.high.value}`
    : 'no rows';
  const note = `${widest}${b.cancelled ? ' (incomplete: cancelled)' : ''}${lower ? '; some ends are lower bounds' : ''}`;
  // Its runs may have fewer histories than the study, and the HFD depends on that: the range is
  // read against its own nominal run, which is said with it.
  const nominal = `nominal ${lengthText(b.nominal && b.nominal.hfd_m, u)} at ${integer(b.histories_per_run)} histories per run`;
  return ['ground_bracket', `HFD over the ground model’s ranges (${lengthUnit(u)})`, [range, nominal, note], true];
}

// "0.01794 (1 per 55.74 m²)" / "1 (1 per 600 ft²)": the threshold in units u.
export function thresholdText(thr, u = 'si') {
  const a = area(1 / thr, u);
  return `${sig(convert(thr, arealDensity, u), 4)} (1 per ${sig(a.value, 4)} ${a.unit})`;
}

// Rows [key, label, value, flagged] of the job view's summary table. The HFD origin is a
// position in the site's coordinates: it stays in metres in either system.
export function summaryRows(s, scene, u = 'si') {
  const thr = s.hfd_threshold_per_m2;
  const traj = scene.trajectories;
  const rows = [
    ...hfdRows(s, u),
    ['hfd_origin', 'HFD origin x, y, z (m)', (s.hfd_origin_m || []).map((v) => fixed(v, 1)).join(', ')],
    ['threshold', `Density threshold (${densityUnit(u)})`, thresholdText(thr, u)],
    ['max_density', `Max PTN density (${densityUnit(u)})`, sig(convert(s.max_ptn_density_per_m2, arealDensity, u), 4)],
    ['buildings', 'Buildings', String((s.buildings || []).length)],
    ['samples', 'Samples', integer(s.samples)],
    ['histories', 'Histories simulated', integer(s.histories_done)],
    ['batches', 'Batches', integer(s.batches)],
    ['stop_reason', 'Stop reason', stopReasonText(s.stop_reason), s.stop_reason === 'targets_unmeetable'],
    ...precisionRows(s.precision, u),
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
export function attributionRows(s, u = 'si') {
  const a = s.hfd_attribution;
  if (!a) return [];
  const at = a.at_hfd || null;
  const rows = [];
  for (const m of a.mechanisms || []) {
    const f = (a.by_mechanism || {})[m] || {};
    rows.push([`mechanism-${m}`, MECHANISMS[m] || m, bounded(f.hfd_m, f.hfd_bound, u),
      percent(at && at.share_by_mechanism ? at.share_by_mechanism[m] : null)]);
  }
  (a.by_group || []).forEach((g, i) => {
    rows.push([`group-${i}`, `group ${g.group}`, bounded(g.hfd_m, g.hfd_bound, u),
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
