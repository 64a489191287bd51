// Job view (#/jobs/<id>): 3-D PTN density map (or the terrain's materials), hazardous-area contour,
// HFD, buildings, trajectories, summary and buildings tables, density-vs-distance plot, downloads.

import * as THREE from '../vendor/three.module.js';
import { api, download, errorText } from './api.js';
import { LogScale, lut, viridis, ylOrRd, rdPu, css, ZERO_GREY, BUILDING_GREY } from './colormap.js';
import { el, sig, plusMinus, localTime, showError } from './format.js';
import { colourControl, densityLegend, keyItem, materialLegend, rampLegend } from './legend.js';
import { defaultColouring, hasMaterials, materialColors, materialEntries } from './materials.js';
import * as meshes from './meshes.js';
import { fetchPlanBoundary, planBoundaryKeys, planBoundaryLayer } from './plan_boundary.js';
import { densityProfiles, drawDensityPlot } from './plot.js';
import { parseScene } from './scene_format.js';
import { SceneView } from './scene3d.js';
import { attributionRow, attributionRows, boundaryNote, isLower, lengthText, precisionStatus, sectorLowerBounds, summaryRow, summaryRows } from './summary_text.js';
import { convert, currentUnits, energy, length, lengthUnit, onUnitsChange, speed } from './units.js';

const $ = (id) => document.getElementById(id);
const COLORS = { contour: '#111111', hfd: '#d6001c', sectors: '#ff7f0e', launch: '#d6001c' };

let view = null;  // one SceneView for the job canvas, kept across visits
let state = null;  // the displayed job: {id, scene, summary, buildingMesh, ...}
let plotCache = null;  // {state, profile}: density profiles of the displayed job

export function jobSceneView() {
  if (!view) {
    view = new SceneView($('scene-canvas'));
    wireSceneTools();
  }
  return view;
}

// ---- entry ------------------------------------------------------------------------------------

export async function enterJob(id, ctx) {
  resetPage(id);
  const status = await waitUntilDone(id, ctx);
  if (!status || !ctx.current()) return;
  const [summary, buf] = await Promise.all([api.summary(id), api.jobScene(id)]);
  if (!ctx.current()) return;
  const scene = parseScene(buf);
  renderSummary(summary, scene);
  renderBoundaryWarning(summary);
  const sv = jobSceneView();
  const built = buildJobScene(scene, summary);
  state = { id, scene, summary, ...built, meshColouring: 'density', colouring: defaultColouring('job', built.materials) };
  sv.setContent(built.group);
  sv.offset = scene.offset;
  sv.setFrame(built.frame);
  applyColouring(state.colouring);
  renderColourControl();
  renderLayerToggles(built.layers);
  renderBuildings(summary, built.buildingRgb);
  sv.render();
  ctx.firstFrame(scene.arrays.terrain_triangles.length / 3, sv);
  drawPlot();
  renderDownloads(id, status);
  await new Promise((r) => requestAnimationFrame(r));
  if (!ctx.current()) return;
  ctx.ready('job');
  loadMaps(id, ctx);
  loadPlanBoundary(id, ctx);
  if (status.links?.compare) loadComparison(id, status.links.compare, ctx);
}

export function leaveJob() {
  if (view) view.setContent(null);
  state = null;
  plotCache = null;
  $('tooltip').hidden = true;
}

function resetPage(id) {
  $('job-title').textContent = id;
  $('job-state').textContent = '';
  showError($('job-error'), '');
  renderBoundaryWarning({});
  $('summary-table').tBodies[0].replaceChildren();
  $('hfd-attribution-table').tBodies[0].replaceChildren();
  $('buildings-table').tBodies[0].replaceChildren();
  $('downloads').replaceChildren();
  $('comparison').hidden = true;
  $('comparison-table').tBodies[0].replaceChildren();
  $('legend').replaceChildren();
  $('layers').replaceChildren();
  $('colour-by').replaceChildren();
  const plot = $('density-plot');
  plot.getContext('2d').clearRect(0, 0, plot.width, plot.height);
  $('toggle-2d').textContent = 'Top view';
  if (view) {
    view.setContent(null);
    view.setTopView(false);
  }
}

// Polls a queued or running job until it is done; null if it failed or was cancelled.
async function waitUntilDone(id, ctx) {
  for (;;) {
    const s = await api.job(id);
    if (!ctx.current()) return null;
    if (s.state === 'done') {
      $('job-state').textContent = `done ${localTime(s.finished_utc)}`;
      return s;
    }
    if (s.state === 'failed' || s.state === 'cancelled') {
      const why = s.error ? `: ${s.error.code}: ${s.error.message}` : '';
      throw new Error(`job ${id} is ${s.state}${why}`);
    }
    const targets = s.precision ? ` — precision: ${precisionStatus(s.precision)}` : '';
    $('job-state').textContent = `${s.state}, ${Math.floor(100 * (s.progress || 0))} % — results appear when it is done${targets}`;
    await new Promise((r) => setTimeout(r, 1000));
  }
}

// ---- 3-D scene ----------------------------------------------------------------------------------

function buildJobScene(scene, summary) {
  const A = scene.arrays, off = scene.offset;
  const thr = summary.hfd_threshold_per_m2;
  const origin = summary.hfd_origin_m.map((v, i) => v - off[i]);
  const group = new THREE.Group();
  const layers = {};

  const density = A.density_per_m2 || new Float32Array(A.terrain_triangles.length / 3);
  let dmax = summary.max_ptn_density_per_m2 || 0;
  if (!(dmax > thr)) dmax = thr * 10;
  const scale = new LogScale(thr / 100, dmax);
  const colors = meshes.densityColors(density, scale, lut(viridis), ZERO_GREY);
  const terrain = meshes.soupMesh(A.terrain_vertices, A.terrain_triangles, colors, { offsetSurface: true });
  const materials = hasMaterials(scene) ? materialEntries(scene.materialNames, A.terrain_material) : [];
  group.add(terrain.mesh);

  const box = terrain.box, size = box.getSize(new THREE.Vector3());
  const halfDiag = 0.5 * Math.hypot(size.x, size.y);
  const lift = Math.max(0.05, halfDiag * 2e-4);

  layers.contour = meshes.lineSegments(
    meshes.contourSegments(A.terrain_vertices, A.terrain_triangles, density, thr, lift), COLORS.contour);
  const hfd = summary.hazardous_fragment_distance_m || 0;
  const sectors = summary.hfd_by_sector_m || [];
  Object.assign(layers, hfdLayers(origin[0], origin[1], origin[2] + lift, summary));
  const maxSector = Math.max(0, ...sectors);
  const radius = Math.min(halfDiag, Math.max(1.5 * Math.max(hfd, maxSector), 0.2 * halfDiag, 30));
  layers.launch = meshes.marker(origin[0], origin[1], origin[2], radius / 60, COLORS.launch);

  const b = buildBuildings(scene, summary);
  if (b.mesh) layers.buildings = b.mesh;
  let vmax = 0;
  if (A.trajectory_points && A.trajectory_offsets) {
    vmax = maxOf(A.trajectory_speed);
    layers.trajectories = meshes.trajectoryLines(A.trajectory_points, A.trajectory_offsets, A.trajectory_speed, lut(rdPu), vmax);
  }
  for (const obj of Object.values(layers)) group.add(obj);

  const frame = { target: [origin[0], origin[1], origin[2]], radius, zMax: box.max.z };
  return {
    group, layers, frame, scale, vmax, terrain: terrain.mesh, densityColors: colors, materials,
    buildingMesh: b.mesh, buildingRgb: b.rgb, buildingRange: b.range,
  };
}

// The HFD circle and the per-sector distances. A distance that the site boundary cuts (a lower
// bound: nothing is modelled beyond the terrain) is drawn dashed, so that the map never shows a cut
// HFD as an exact one; the others are drawn solid, as they always were.
function hfdLayers(cx, cy, z, summary) {
  const hfd = summary.hazardous_fragment_distance_m || 0;
  const d = summary.hfd_by_sector_m || [];
  const lower = sectorLowerBounds(summary);
  const dash = (2 * Math.PI * Math.max(hfd, ...d, 1)) / 80;  // ~50 dashes round the HFD circle
  const circle = meshes.lineSegments(meshes.circleSegments(cx, cy, z, hfd), COLORS.hfd,
    { onTop: true, order: 5, opacity: 0.95, dash: isLower(summary.hfd_bound) ? dash : 0 });
  circle.name = 'hfd';
  const style = { onTop: true, order: 4, opacity: 0.9 };
  const sectorLines = (keep, opts) =>
    meshes.lineSegments(meshes.sectorSegments(cx, cy, z, d.map((r, k) => (keep(k) ? r : 0))), COLORS.sectors, opts);
  const solid = sectorLines((k) => !lower[k], style);
  solid.name = 'sectors';
  if (!lower.some(Boolean)) return { hfd: circle, sectors: solid };
  const cut = sectorLines((k) => lower[k], { ...style, dash });
  cut.name = 'sectors-lower-bound';
  const both = new THREE.Group();
  both.add(solid, cut);
  return { hfd: circle, sectors: both };
}

function maxOf(a) {
  let m = 0;
  if (a) for (let i = 0; i < a.length; i++) if (a[i] > m) m = a[i];
  return m;
}

// Buildings coloured by expected penetrations: 0 light grey, else YlOrRd on a log scale.
function buildBuildings(scene, summary) {
  const A = scene.arrays, ids = scene.buildingIds;
  const byId = new Map((summary.buildings || []).map((b) => [b.id, b]));
  const pens = ids.map((id) => (byId.get(id) ? byId.get(id).expected_penetrations : 0));
  const pos = pens.filter((p) => p > 0);
  const range = pos.length ? [Math.min(...pos), Math.max(...pos)] : null;
  const scale = range ? new LogScale(range[0], range[1] > range[0] ? range[1] : range[0] * 10) : null;
  const rgb = new Uint8Array(Math.max(ids.length, 1) * 3);
  pens.forEach((p, i) => rgb.set((p > 0 ? ylOrRd(0.15 + 0.85 * scale.t(p)) : BUILDING_GREY).map(Math.round), 3 * i));
  if (!A.building_triangles || !A.triangle_building) return { mesh: null, rgb, range };
  const colors = meshes.buildingColors(A.triangle_building, A.triangle_surface, rgb);
  const { mesh } = meshes.soupMesh(A.building_vertices, A.building_triangles, colors);
  return { mesh, rgb, range };
}

// ---- terrain colouring: PTN density or material -------------------------------------------------

// Colours the terrain by `mode` ('density' or 'material'); the overlays stay as they are.
function applyColouring(mode) {
  if (!state) return;
  const A = state.scene.arrays, terrain = state.terrain;
  state.colouring = mode;
  const colors = mode === 'material' ? materialColors(A.terrain_material, state.materials) : state.densityColors;
  if (mode !== state.meshColouring) meshes.setSoupColors(terrain, colors);  // built with the density's
  state.meshColouring = mode;
  view.setTerrainLod(terrain, () => meshes.decimatedMesh(A.terrain_vertices, A.terrain_triangles, colors, terrain));
  renderLegend(state.scene, state.summary, state);
  view.requestRender();
}

function renderColourControl() {
  const old = !hasMaterials(state.scene);
  $('colour-by').replaceChildren(colourControl('colour-select', [
    { value: 'density', label: 'PTN density' },
    { value: 'material', label: 'Material', disabled: old,
      title: old ? 'results.h5 older than format 4: no material per triangle' : undefined },
  ], state.colouring, applyColouring));
}

// ---- legend and layer toggles -------------------------------------------------------------------

function renderLegend(scene, summary, built) {
  const traj = scene.trajectories;
  const keys = [
    keyItem(COLORS.contour, 'hazardous area (≥ threshold)'),
    ...hfdKeys(summary),
    keyItem(COLORS.launch, 'HFD origin', 'box'),
    ...(built.plan ? planBoundaryKeys(built.plan.b, built.plan.lower, currentUnits()) : []),
  ];
  if (built.colouring === 'material')
    $('legend').replaceChildren(materialLegend(built.materials), el('div', { class: 'legend-keys' }, keys));
  else
    densityLegend($('legend'), { scale: built.scale, ramp: viridis, threshold: summary.hfd_threshold_per_m2, zeroColor: ZERO_GREY, keys, units: currentUnits() });
  if (built.layers.trajectories) {
    const v = speed(built.vmax, currentUnits());
    $('legend').append(rampLegend(`trajectories (${traj.sent} of ${traj.recorded} recorded), speed (${v.unit})`, rdPu, 0, v.value));
  }
  if (built.buildingMesh) {
    const r = built.buildingRange;
    $('legend').append(r
      ? rampLegend('buildings: expected penetrations (log scale)', (t) => ylOrRd(0.15 + 0.85 * t), r[0], r[1],
        [keyItem(css(BUILDING_GREY), '0', 'box')])
      : el('div', { class: 'legend-row' }, [keyItem(css(BUILDING_GREY), 'buildings: no expected penetration', 'box')]));
  }
}

// The HFD's and the sectors' keys; dashed ones say what the dashes mean (a lower bound).
function hfdKeys(summary) {
  const hfd = lengthText(summary.hazardous_fragment_distance_m, currentUnits());
  const keys = [isLower(summary.hfd_bound)
    ? keyItem(COLORS.hfd, `HFD ≥ ${hfd} (lower bound: site boundary)`, 'dashed')
    : keyItem(COLORS.hfd, `HFD ${hfd}`)];
  keys.push(keyItem(COLORS.sectors, 'HFD per 10° sector'));
  if (sectorLowerBounds(summary).some(Boolean))
    keys.push(keyItem(COLORS.sectors, 'sector HFD ≥ (lower bound: site boundary)', 'dashed'));
  return keys;
}

function renderLayerToggles(layers) {
  const labels = { trajectories: 'trajectories', contour: 'contour', hfd: 'HFD', sectors: 'sectors', buildings: 'buildings' };
  for (const [name, label] of Object.entries(labels))
    if (layers[name]) addLayerToggle(name, label, layers[name]);
}

function addLayerToggle(name, label, obj) {
  const input = el('input', { type: 'checkbox', id: `layer-${name}`, checked: '' });
  input.addEventListener('change', () => {
    obj.visible = input.checked;
    view.requestRender();
  });
  $('layers').append(el('label', { class: 'layer' }, [input, label]));
}

// The site-plan boundary (plan_boundary.js), added when it arrives; the view stands without it.
async function loadPlanBoundary(id, ctx) {
  const st = state;
  let b;
  try {
    b = await fetchPlanBoundary(id);
  } catch (e) {
    console.warn(`plan boundary of ${id}: ${errorText(e)}`);
    return;
  }
  if (!ctx.current() || state !== st) return;
  const s = st.summary;
  const lower = { estimate: isLower(s.hfd_bound), upper: isLower((s.hfd_band_bound || [])[1]) };
  const layer = planBoundaryLayer(b, st.frame.target[2] + 0.5, lower);
  st.group.add(layer);
  st.layers.plan_boundary = layer;
  st.plan = { b, lower };  // its legend keys follow the units (renderLegend)
  addLayerToggle('plan_boundary', 'site-plan boundary', layer);
  renderLegend(st.scene, s, st);
  view.requestRender();
}

function wireSceneTools() {
  $('toggle-2d').addEventListener('click', () => {
    view.setTopView(!view.topView);
    $('toggle-2d').textContent = view.topView ? '3-D view' : 'Top view';
  });
  $('reset-view').addEventListener('click', () => view.resetView());
  const canvas = $('scene-canvas');
  let queued = null;
  canvas.addEventListener('pointermove', (ev) => {
    if (ev.buttons) return hideTooltip();
    if (!queued) requestAnimationFrame(() => { hover(queued); queued = null; });
    queued = { x: ev.clientX, y: ev.clientY };
  });
  canvas.addEventListener('pointerleave', hideTooltip);
  canvas.addEventListener('pointerdown', hideTooltip);
}

// ---- tooltip ----------------------------------------------------------------------------------

function hideTooltip() {
  $('tooltip').hidden = true;
  hideRowHighlight();
}

function hover(p) {
  if (!p || !state || !state.buildingMesh || !state.buildingMesh.visible) return hideTooltip();
  const hit = view.pick(p.x, p.y, [state.buildingMesh]);
  if (!hit) return hideTooltip();
  const bi = state.scene.arrays.triangle_building[hit.faceIndex];
  const id = state.scene.buildingIds[bi];
  const b = (state.summary.buildings || []).find((x) => x.id === id);
  const tip = $('tooltip');
  tip.replaceChildren(
    el('div', { class: 'tip-title', text: id ?? `building ${bi}` }),
    el('div', { text: b ? `impacts ${plusMinus(b.expected_impacts, b.impacts_std_error)}` : 'no figures' }),
    b ? el('div', { text: `penetrations ${plusMinus(b.expected_penetrations, b.penetrations_std_error)}` }) : null,
  );
  const r = $('scene-canvas').getBoundingClientRect();
  tip.style.left = `${p.x - r.left + 14}px`;
  tip.style.top = `${p.y - r.top + 14}px`;
  tip.hidden = false;
  hideRowHighlight();
  const row = document.querySelector(`#buildings-table tr[data-building="${CSS.escape(id ?? '')}"]`);
  if (row) row.classList.add('hover');
}

function hideRowHighlight() {
  document.querySelectorAll('#buildings-table tr.hover').forEach((tr) => tr.classList.remove('hover'));
}

// ---- tables -------------------------------------------------------------------------------------

function renderSummary(s, scene) {
  const u = currentUnits();
  $('summary-table').tBodies[0].replaceChildren(...summaryRows(s, scene, u).map(summaryRow));
  $('hfd-alone-unit').textContent = lengthUnit(u);
  const rows = attributionRows(s, u);
  $('hfd-attribution').hidden = rows.length === 0;
  $('hfd-attribution-table').tBodies[0].replaceChildren(...rows.map(attributionRow));
}

// A cut HFD changes what the whole study means, so its note heads the page, not a table row.
function renderBoundaryWarning(summary) {
  const note = boundaryNote(summary, currentUnits());
  const box = $('job-warning');
  box.replaceChildren(...(note ? [el('strong', { text: 'Warning: ' }), note] : []));
  box.hidden = !note;
}

function renderBuildings(s, rgb) {
  const ids = state.scene.buildingIds;
  const ke = (j) => convert(j, energy, currentUnits());
  $('residual-ke-unit').textContent = energy(0, currentUnits()).unit;
  const rows = (s.buildings || []).map((b) => {
    const i = ids.indexOf(b.id);
    const sw = el('span', { class: 'swatch box' });
    if (i >= 0) sw.style.backgroundColor = css([rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]]);
    return el('tr', { dataset: { building: b.id } }, [
      el('td', {}, sw),
      el('td', { class: 'mono', text: b.id }),
      el('td', { class: 'num impacts', text: plusMinus(b.expected_impacts, b.impacts_std_error) }),
      el('td', { class: 'num penetrations', text: plusMinus(b.expected_penetrations, b.penetrations_std_error) }),
      el('td', { class: 'num residual-ke', text: plusMinus(ke(b.residual_ke_j), ke(b.residual_ke_std_error_j)) }),
    ]);
  });
  $('buildings-table').tBodies[0].replaceChildren(...rows);
  if (!rows.length)
    $('buildings-table').tBodies[0].append(el('tr', {}, el('td', { colspan: '5', class: 'muted', text: 'no buildings' })));
}

// ---- plot ---------------------------------------------------------------------------------------


function drawPlot() {
  if (!state) return;
  const A = state.scene.arrays, s = state.summary;
  if (!plotCache || plotCache.state !== state) {
    const origin = s.hfd_origin_m.map((v, i) => v - state.scene.offset[i]);
    const density = A.density_per_m2 || new Float32Array(A.terrain_triangles.length / 3);
    const minRange = 1.15 * (s.hazardous_fragment_distance_m || 0);
    plotCache = { state, profile: densityProfiles(A.terrain_vertices, A.terrain_triangles, density, origin, minRange) };
  }
  drawDensityPlot($('density-plot'), plotCache.profile, {
    threshold: s.hfd_threshold_per_m2, hfd: s.hazardous_fragment_distance_m, hfdLower: isLower(s.hfd_bound),
    units: currentUnits(),
  });
}

// ---- paired comparison (docs/comparison.md): a job submitted with compare_with ----------------

async function loadComparison(id, path, ctx) {
  const st = state;
  let c;
  try {
    c = await api.comparison(id);
  } catch (e) {
    console.warn(`comparison of ${id}: ${errorText(e)}`);
    return;
  }
  if (!ctx.current() || state !== st) return;
  st.comparison = c;
  renderComparison(c);
  const group = el('div', { class: 'download-group', id: 'comparison-downloads' }, [
    el('span', { class: 'muted', text: 'Comparison:' }),
    downloadLink(path, `${id}_compare.json`, 'compare.json'),
    downloadLink(`${path}.h5`, `${id}_compare.h5`, 'compare.h5', 'density difference'),
  ]);
  $('downloads').append(group);
}

// A compare.json figure: base, variant, difference ± paired se, unpaired se (counts as given).
function comparisonRow(label, f, conv = (x) => x) {
  return el('tr', {}, [
    el('td', { text: label }),
    el('td', { class: 'num', text: sig(conv(f.base)) }),
    el('td', { class: 'num', text: sig(conv(f.variant)) }),
    el('td', { class: 'num difference', text: plusMinus(conv(f.difference), conv(f.paired_std_error)) }),
    el('td', { class: 'num', text: f.unpaired_std_error === undefined ? '—' : sig(conv(f.unpaired_std_error), 2) }),
  ]);
}

function renderComparison(c) {
  const u = currentUnits();
  const len = (m) => convert(m, length, u);
  const h = c.hfd || {};
  const rows = [comparisonRow(`HFD (${lengthUnit(u)}; se: jackknife)`,
    { base: h.base_m, variant: h.variant_m, difference: h.difference_m, paired_std_error: h.paired_std_error_m }, len)];
  let unchanged = 0;
  for (const b of c.buildings || []) {
    const moved = ['impacts', 'penetrations'].some((k) => b[k].difference !== 0 || b[k].paired_std_error !== 0);
    if (!moved) {
      unchanged += 1;
      continue;
    }
    rows.push(comparisonRow(`${b.id}: impacts`, b.impacts), comparisonRow(`${b.id}: penetrations`, b.penetrations));
  }
  $('comparison-table').tBodies[0].replaceChildren(...rows);
  $('comparison-what').textContent = `The same histories flown over the base site and this one (docs/comparison.md). Changed: ${
    (c.changed || []).join(', ') || 'nothing'}.`;
  const notes = [...(unchanged ? [`${unchanged} other buildings: the same histories hit them in both sites (difference 0).`] : []),
    ...(c.limitations || [])];
  $('comparison-notes').textContent = notes.join(' ');
  $('comparison').hidden = false;
}

// ---- units (units.js): every figure the page shows again in the selected system -----------------

onUnitsChange(() => {
  if (!state) return;
  renderSummary(state.summary, state.scene);
  renderBoundaryWarning(state.summary);
  renderLegend(state.scene, state.summary, state);
  renderBuildings(state.summary, state.buildingRgb);
  drawPlot();
  document.getElementById('report-list')?.replaceChildren(...reportLinks(state.id));
  if (state.comparison) renderComparison(state.comparison);
});

window.addEventListener('resize', () => {
  if (state) drawPlot();
});

// ---- downloads ----------------------------------------------------------------------------------

function downloadLink(path, name, label, note) {
  const a = el('a', { href: path, download: name, class: 'download', text: label });
  a.addEventListener('click', async (ev) => {
    ev.preventDefault();
    a.classList.add('busy');
    try {
      await download(path, name);
    } catch (e) {
      showError($('job-error'), `download ${name}: ${errorText(e)}`);
    } finally {
      a.classList.remove('busy');
    }
  });
  return el('span', { class: 'download-item' }, [a, note ? el('span', { class: 'muted small', text: note }) : null]);
}

function renderDownloads(id, status) {
  const links = status.links || {};
  $('downloads').replaceChildren(
    el('div', { class: 'download-group' }, [
      downloadLink(links.summary || `/v1/jobs/${id}/summary`, `${id}_summary.json`, 'summary.json'),
      downloadLink(links.results_h5 || `/v1/jobs/${id}/results.h5`, `${id}.h5`, 'results.h5', 'HDF5'),
    ]),
    el('div', { id: 'maps-list', class: 'download-group' }, el('span', { class: 'muted', text: 'GIS files: preparing…' })),
    el('div', { id: 'report-list', class: 'download-group' }, reportLinks(id)),
  );
}

// The study report (docs/report.md) in the units selected now; made by the daemon on the first
// request (the PDF by its headless chromium, a few seconds).
function reportLinks(id) {
  const u = currentUnits();
  return [
    el('span', { class: 'muted', text: 'Study report:' }),
    downloadLink(`/v1/jobs/${id}/report.html?units=${u}`, `${id}_report-${u}.html`, 'report.html', 'one page, offline'),
    downloadLink(`/v1/jobs/${id}/report.pdf?units=${u}`, `${id}_report-${u}.pdf`, 'report.pdf', 'A4'),
  ];
}

async function loadMaps(id, ctx) {
  const box = () => document.getElementById('maps-list');
  try {
    const maps = await api.maps(id);
    if (!ctx.current() || !box()) return;
    const items = (maps.files || []).map((f) =>
      downloadLink(f.url, `${id}_${f.name}`, f.name, `${sig(f.bytes / 1e6, 2)} MB`));
    box().replaceChildren(el('span', { class: 'muted', text: 'GIS:' }), ...items,
      ...(maps.notes || []).map((n) => el('span', { class: 'muted small', text: n })));
  } catch (e) {
    if (!ctx.current() || !box()) return;
    const retry = el('button', { type: 'button', text: 'retry' });
    retry.addEventListener('click', () => {
      box().replaceChildren(el('span', { class: 'muted', text: 'GIS files: preparing…' }));
      loadMaps(id, ctx);
    });
    box().replaceChildren(el('span', { class: 'error', text: `GIS files: ${errorText(e)}` }), retry);
  }
}
