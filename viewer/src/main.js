// Entry point: hash router, navigation, error reporting, perf hooks (window.fragsimViewer).
//   #/jobs (default)   #/jobs/<job_id>   #/sites   #/sites/<site_id>

import { api, errorText } from './api.js';
import { enterJob, leaveJob } from './job_view.js';
import { enterJobs, leaveJobs } from './jobs_view.js';
import { enterSite, enterSites, leaveSite } from './sites_view.js';
import { frameTimeStats } from './scene3d.js';
import { showError } from './format.js';
import { currentUnits, setUnits } from './units.js';

const $ = (id) => document.getElementById(id);

const perf = {
  loadMs: null,
  triangles: 0,
  frameTimesMs: [],
  sceneView: null,
  async measureRotation(frames = 120) {
    if (!perf.sceneView) throw new Error('no 3-D view on this page');
    const { times, ...rest } = await perf.sceneView.measureRotation(frames);
    perf.frameTimesMs = times;
    return { ...frameTimeStats(times), ...rest };
  },
  // Test hooks: input coordinates [x, y, z] -> {x, y} CSS pixels in the current 3-D canvas
  // (see SceneView.project), and the canvas's render state {settled, settledFrames, topView}.
  project(p) {
    if (!perf.sceneView) throw new Error('no 3-D view on this page');
    return perf.sceneView.project(p);
  },
  // The 3-D view's named line overlays (the HFD circle 'hfd', 'sectors', 'sectors-lower-bound'):
  // [{name, material (its three.js type: LineDashedMaterial when dashed), segments, visible (it
  // and its parents: a layer toggle hides the group)}].
  lines() {
    const out = [];
    perf.sceneView?.content?.traverse((o) => {
      if (!o.isLineSegments || !o.name) return;
      let visible = true;
      o.traverseAncestors((a) => { visible &&= a.visible; });
      const segments = o.geometry.attributes.position.count / 2;
      out.push({ name: o.name, material: o.material.type, segments, visible: visible && o.visible });
    });
    return out;
  },
  renderState() {
    const v = perf.sceneView;
    return v ? { settled: v.settled, settledFrames: v.settledFrames, topView: v.topView, moving: v.moving } : null;
  },
};
window.fragsimViewer = perf;

const ROUTES = [
  { re: /^#\/jobs\/([^/]+)$/, view: 'view-job', nav: 'nav-jobs', enter: (m, ctx) => enterJob(decodeURIComponent(m[1]), ctx), leave: leaveJob, error: 'job-error' },
  { re: /^#\/sites\/([^/]+)$/, view: 'view-site', nav: 'nav-sites', enter: (m, ctx) => enterSite(decodeURIComponent(m[1]), ctx), leave: leaveSite, error: 'site-error' },
  { re: /^#\/sites\/?$/, view: 'view-sites', nav: 'nav-sites', enter: (m, ctx) => enterSites(ctx), error: 'sites-error' },
  { re: /^#\/jobs\/?$/, view: 'view-jobs', nav: 'nav-jobs', enter: (m, ctx) => enterJobs(ctx), leave: leaveJobs, error: 'jobs-error' },
];

let generation = 0;
let active = null;

function routeFor(hash) {
  for (const r of ROUTES) {
    const m = hash.match(r.re);
    if (m) return { route: r, match: m };
  }
  return null;
}

// ctx handed to a view: is this route still the current one; signal first frame / ready.
function makeContext(gen, t0) {
  return {
    current: () => gen === generation,
    firstFrame(triangles, sceneView) {
      if (gen !== generation) return;
      perf.loadMs = performance.now() - t0;
      perf.triangles = triangles;
      perf.sceneView = sceneView;
    },
    ready(name) {
      if (gen === generation) document.body.dataset.ready = name;
    },
  };
}

async function dispatch() {
  const hash = location.hash || '#/jobs';
  const found = routeFor(hash);
  if (!found) {
    location.replace('#/jobs');
    return;
  }
  const t0 = performance.now();
  const gen = ++generation;
  if (active && active.leave) active.leave();
  active = found.route;
  delete document.body.dataset.ready;
  delete document.body.dataset.error;
  perf.loadMs = null;
  perf.triangles = 0;
  perf.sceneView = null;
  for (const s of document.querySelectorAll('main > section')) s.hidden = s.id !== found.route.view;
  for (const a of document.querySelectorAll('nav a')) a.classList.toggle('active', a.id === found.route.nav);
  try {
    await found.route.enter(found.match, makeContext(gen, t0));
  } catch (e) {
    if (gen !== generation) return;
    const msg = errorText(e);
    console.error(e);
    document.body.dataset.error = msg;
    showError($(found.route.error), msg);
  }
}

async function showVersion() {
  try {
    const h = await api.health();
    $('version').textContent = `fragsimd ${h.version}${h.git_sha ? ` (${h.git_sha})` : ''}`;
  } catch {
    $('version').textContent = 'fragsimd: not reachable';
  }
}

// The units selector in the header (units.js): the views listen for the change.
function wireUnits() {
  const select = $('units-select');
  select.value = currentUnits();
  select.addEventListener('change', () => setUnits(select.value));
}

window.addEventListener('hashchange', dispatch);
wireUnits();
showVersion();
dispatch();
