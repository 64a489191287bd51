// Sites view (#/sites) and site preview (#/sites/<id>): terrain coloured by elevation or by
// material, buildings.

import * as THREE from '../vendor/three.module.js';
import { api } from './api.js';
import { lut, terrain as terrainRamp, css, BUILDING_GREY } from './colormap.js';
import { el, fixed, integer, localTime, showError } from './format.js';
import { colourControl, keyItem, materialLegend, rampLegend } from './legend.js';
import { defaultColouring, hasMaterials, materialColors, materialEntries } from './materials.js';
import * as meshes from './meshes.js';
import { parseScene } from './scene_format.js';
import { SceneView } from './scene3d.js';

const $ = (id) => document.getElementById(id);
let view = null;
let shown = null;  // the displayed site: {scene, built, colouring}

// ---- list ---------------------------------------------------------------------------------------

function extentText(e) {
  if (!e || e.length < 6) return '—';
  return `${fixed(e[3] - e[0], 0)} × ${fixed(e[4] - e[1], 0)}, z ${fixed(e[2], 1)} … ${fixed(e[5], 1)}`;
}

export async function enterSites(ctx) {
  showError($('sites-error'), '');
  const { sites } = await api.sites();
  if (!ctx.current()) return;
  const rows = sites.map((s) => el('tr', { dataset: { siteId: s.site_id }, class: 'clickable', onclick: (ev) => {
    if (ev.target.tagName !== 'A') location.hash = `#/sites/${s.site_id}`;
  } }, [
    el('td', { class: 'mono' }, el('a', { href: `#/sites/${s.site_id}`, text: s.site_id })),
    el('td', { class: 'num', text: integer(s.terrain_triangles) }),
    el('td', { class: 'num', text: integer(s.buildings) }),
    el('td', { text: extentText(s.extent_m) }),
    el('td', { class: 'num', text: integer(s.jobs_using) }),
    el('td', { text: localTime(s.created_utc), title: s.created_utc }),
  ]));
  $('sites-table').tBodies[0].replaceChildren(...rows);
  $('sites-empty').hidden = sites.length > 0;
  ctx.ready('sites');
}

// ---- preview ----------------------------------------------------------------------------------

export function siteSceneView() {
  if (!view) {
    view = new SceneView($('site-canvas'));
    $('site-toggle-2d').addEventListener('click', () => {
      view.setTopView(!view.topView);
      $('site-toggle-2d').textContent = view.topView ? '3-D view' : 'Top view';
    });
    $('site-reset-view').addEventListener('click', () => view.resetView());
  }
  return view;
}

export async function enterSite(id, ctx) {
  $('site-title').textContent = id;
  showError($('site-error'), '');
  $('site-table').tBodies[0].replaceChildren();
  $('site-legend').replaceChildren();
  $('site-colour-by').replaceChildren();
  shown = null;
  const sv = siteSceneView();
  sv.setContent(null);
  sv.setTopView(false);
  $('site-toggle-2d').textContent = 'Top view';
  const [info, buf] = await Promise.all([api.site(id), api.siteScene(id)]);
  if (!ctx.current()) return;
  const scene = parseScene(buf);
  const built = buildSiteScene(scene);
  sv.setContent(built.group);
  sv.offset = scene.offset;
  sv.setFrame(built.frame);
  renderSiteTable(info, scene);
  shown = { scene, built, colouring: defaultColouring('site', built.materials), meshColouring: 'elevation' };
  applySiteColouring(shown.colouring);
  $('site-colour-by').replaceChildren(colourControl('site-colour-select', [
    { value: 'elevation', label: 'Elevation' },
    { value: 'material', label: 'Material', disabled: !hasMaterials(scene) },
  ], shown.colouring, applySiteColouring));
  sv.render();
  ctx.firstFrame(scene.arrays.terrain_triangles.length / 3, sv);
  await new Promise((r) => requestAnimationFrame(r));
  if (ctx.current()) ctx.ready('site');
}

export function leaveSite() {
  if (view) view.setContent(null);
  shown = null;
}

// Colours the terrain by `mode` ('elevation' or 'material') and redraws the legend.
function applySiteColouring(mode) {
  if (!shown) return;
  const { scene, built } = shown, A = scene.arrays;
  const colors = mode === 'material' ? materialColors(A.terrain_material, built.materials) : built.elevationColors;
  if (mode !== shown.meshColouring) meshes.setSoupColors(built.terrain, colors);  // built by elevation
  shown.colouring = shown.meshColouring = mode;
  view.setTerrainLod(built.terrain, () => meshes.decimatedMesh(A.terrain_vertices, A.terrain_triangles, colors, built.terrain));
  $('site-legend').replaceChildren(
    mode === 'material'
      ? materialLegend(built.materials)
      : rampLegend('terrain elevation (m)', terrainRamp, built.zlo + scene.offset[2], built.zhi + scene.offset[2]),
    el('div', { class: 'legend-keys' }, [keyItem(css(BUILDING_GREY), 'buildings', 'box')]),
  );
  view.requestRender();
}

function buildSiteScene(scene) {
  const A = scene.arrays;
  let zlo = Infinity, zhi = -Infinity;
  for (let i = 2; i < A.terrain_vertices.length; i += 3) {
    const z = A.terrain_vertices[i];
    if (z < zlo) zlo = z;
    if (z > zhi) zhi = z;
  }
  const colors = meshes.elevationColors(A.terrain_vertices, A.terrain_triangles, lut(terrainRamp), zlo, zhi);
  const terrain = meshes.soupMesh(A.terrain_vertices, A.terrain_triangles, colors);
  const group = new THREE.Group();
  group.add(terrain.mesh);
  if (A.building_triangles && A.triangle_building) {
    const rgb = new Uint8Array(Math.max(scene.buildingIds.length, 1) * 3);
    for (let i = 0; i < rgb.length; i += 3) rgb.set(BUILDING_GREY, i);
    const colorsB = meshes.buildingColors(A.triangle_building, A.triangle_surface, rgb);
    group.add(meshes.soupMesh(A.building_vertices, A.building_triangles, colorsB).mesh);
  }
  const box = terrain.box, c = box.getCenter(new THREE.Vector3()), size = box.getSize(new THREE.Vector3());
  const radius = Math.max(0.55 * Math.max(size.x, size.y), 1);
  const materials = hasMaterials(scene) ? materialEntries(scene.materialNames, A.terrain_material) : [];
  return {
    group, zlo, zhi, terrain: terrain.mesh, elevationColors: colors, materials,
    frame: { target: [c.x, c.y, box.min.z], radius, zMax: box.max.z },
  };
}

function renderSiteTable(info, scene) {
  const rows = [
    ['site_id', 'Site', info.site_id],
    ['created', 'Created', localTime(info.created_utc)],
    ['triangles', 'Terrain triangles', integer(info.terrain_triangles)],
    ['buildings', 'Buildings', integer(info.buildings)],
    ['building_triangles', 'Building triangles', integer(info.building_triangles)],
    ['building_ids', 'Building ids', (info.building_ids || scene.buildingIds).join(', ') || '—'],
    ['materials', 'Materials', (info.materials || []).join(', ') || '—'],
    ['extent', 'Extent (m)', extentText(info.extent_m)],
    ['jobs_using', 'Jobs using it', integer(info.jobs_using)],
  ];
  $('site-table').tBodies[0].replaceChildren(...rows.map(([key, label, value]) =>
    el('tr', { dataset: { key } }, [el('th', { text: label }), el('td', { class: 'value', text: value })])));
}
