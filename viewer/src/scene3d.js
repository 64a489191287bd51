// three.js view of a site: renderer, cameras (3-D orbit and orthographic top view), on-demand
// rendering, resizing, picking and the rotation benchmark.
//
// Interactive quality: while the camera moves (between the controls' 'start' and SETTLE_MS after
// the last 'change', and during measureRotation) frames are drawn at MOTION_PIXEL_RATIO of the full
// pixel ratio and with the decimated terrain (lod.js) when one was given (setTerrainLod); once the
// view settles, one full-quality frame (full mesh, full resolution, antialiased) is drawn.
// Antialiasing: the canvas context has none (a multisampled canvas makes every frame cost 2-3
// times more in software GL, whatever its resolution); the settled frame is drawn into a 4-sample
// render target and copied to the canvas, interactive frames go to the canvas directly.
// Colours: no colour management. Every colour (materials, vertex colours, the clear colour) is an
// sRGB value written to the framebuffer as it is, so the render target (RGBA8) and the canvas hold
// the same values and the copy is exact; blending happens on sRGB values, as on a plain canvas.
//
// World coordinates are the scene's site coordinates relative to offset_m, unchanged:
// x east, y north, z up (camera.up = +z). Nothing is ever added to the GPU positions.

import * as THREE from '../vendor/three.module.js';
import { OrbitControls } from '../vendor/OrbitControls.js';

THREE.ColorManagement.enabled = false;

const UP = new THREE.Vector3(0, 0, 1);
const VIEW_DIR = new THREE.Vector3(0.25, -1, 0.85).normalize();  // camera offset: from the south
const SETTLE_MS = 200;  // full-quality frame after this long without camera change
const MOTION_PIXEL_RATIO = 0.5;  // times the full pixel ratio, while the camera moves

export class SceneView {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
    this.renderer.outputColorSpace = THREE.LinearSRGBColorSpace;  // no encoding: values are sRGB
    this.msaa = null;  // {target, scene, camera}: the antialiased settled frame, see renderSettled
    this.fullPixelRatio = Math.min(window.devicePixelRatio || 1, 2);
    this.renderer.setPixelRatio(this.fullPixelRatio);
    this.renderer.setClearColor(0xf4f5f7, 1);
    this.scene = new THREE.Scene();
    this.content = null;
    this.topView = false;
    this.pending = false;
    this.onRender = null;
    this.lod = null;  // {full, build, coarse}: terrain mesh and its decimated stand-in
    this.moving = false;  // drawing interactive-quality frames
    this.interacting = false;  // between the controls' 'start' and 'end'
    this.settleTimer = null;
    this.offset = [0, 0, 0];  // scene offset_m: input coordinate = world position + offset
    this.settledFrames = 0;  // full-quality frames drawn (tests wait for one after a change)
    this.makeCameras();
    this.observeSize();
  }

  makeCameras() {
    this.persp = new THREE.PerspectiveCamera(40, 1, 1, 1e5);
    this.persp.up.copy(UP);
    this.ortho = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.1, 1e5);
    this.ortho.up.set(0, 1, 0);  // north up on screen
    this.orbit = new OrbitControls(this.persp, this.canvas);
    this.orbit.maxPolarAngle = Math.PI * 0.495;
    this.orbit.zoomToCursor = true;
    this.pan = new OrbitControls(this.ortho, this.canvas);
    this.pan.enableRotate = false;
    this.pan.zoomToCursor = true;
    this.pan.mouseButtons = { LEFT: THREE.MOUSE.PAN, MIDDLE: THREE.MOUSE.DOLLY, RIGHT: THREE.MOUSE.PAN };
    this.pan.touches = { ONE: THREE.TOUCH.PAN, TWO: THREE.TOUCH.DOLLY_PAN };
    this.pan.enabled = false;
    for (const c of [this.orbit, this.pan]) this.listenTo(c);
  }

  // User input moves the camera: interactive quality until SETTLE_MS after the last change.
  // Programmatic changes (resetView) are drawn at full quality.
  listenTo(controls) {
    controls.addEventListener('start', () => {
      this.interacting = true;
      this.motion();
    });
    controls.addEventListener('change', () => {
      if (this.interacting) this.motion();
      this.requestRender();
    });
    controls.addEventListener('end', () => {
      this.interacting = false;
    });
  }

  get camera() {
    return this.topView ? this.ortho : this.persp;
  }

  get controls() {
    return this.topView ? this.pan : this.orbit;
  }

  observeSize() {
    const ro = new ResizeObserver(() => this.resize());
    ro.observe(this.canvas.parentElement);
  }

  resize() {
    const w = Math.max(1, this.canvas.clientWidth), h = Math.max(1, this.canvas.clientHeight);
    const size = this.renderer.getSize(new THREE.Vector2());
    if (size.x === w && size.y === h) return;
    this.renderer.setSize(w, h, false);
    this.updateProjection();
    this.requestRender();
  }

  updateProjection() {
    const w = Math.max(1, this.canvas.clientWidth), h = Math.max(1, this.canvas.clientHeight);
    const aspect = w / h;
    this.persp.aspect = aspect;
    this.persp.updateProjectionMatrix();
    const half = this.orthoHalf || 100;
    Object.assign(this.ortho, { left: -half * aspect, right: half * aspect, top: half, bottom: -half });
    this.ortho.updateProjectionMatrix();
  }

  // Replaces the displayed objects (disposing the old ones).
  setContent(group) {
    if (this.content) {
      this.scene.remove(this.content);
      disposeTree(this.content);
    }
    this.content = group;
    this.lod = null;
    if (group) this.scene.add(group);
    this.requestRender();
  }

  // full: the terrain mesh (in the content group); build(): its decimated stand-in (a Mesh) or
  // null. Built when the page is idle, or at the first camera motion if that comes first.
  // Called again with the same mesh after its colours changed: the old stand-in is dropped.
  setTerrainLod(full, build) {
    this.dropCoarse();
    const lod = { full, build, coarse: undefined };
    this.lod = lod;
    const idle = window.requestIdleCallback || ((f) => setTimeout(f, 300));
    idle(() => this.lod === lod && this.ensureCoarse(), { timeout: 2000 });
  }

  dropCoarse() {
    const lod = this.lod;
    if (!lod || !lod.coarse) return;
    lod.coarse.removeFromParent();
    lod.coarse.geometry.dispose();  // its material is the full mesh's
    lod.full.visible = true;
    lod.coarse = undefined;
  }

  ensureCoarse() {
    const lod = this.lod;
    if (!lod || lod.coarse !== undefined) return lod ? lod.coarse : null;
    lod.coarse = lod.build();
    if (lod.coarse) {
      lod.coarse.visible = this.moving;
      lod.full.parent.add(lod.coarse);
    }
    return lod.coarse;
  }

  // Interactive (on) or full (off) quality for the next frames.
  setMotion(on) {
    if (this.moving === on) return;
    this.moving = on;
    const coarse = on ? this.ensureCoarse() : this.lod && this.lod.coarse;
    if (coarse) {
      coarse.visible = on;
      this.lod.full.visible = !on;
    }
    this.renderer.setPixelRatio(on ? this.fullPixelRatio * MOTION_PIXEL_RATIO : this.fullPixelRatio);
  }

  motion() {
    this.setMotion(true);
    clearTimeout(this.settleTimer);
    this.settleTimer = setTimeout(() => this.settle(), SETTLE_MS);
  }

  settle() {
    clearTimeout(this.settleTimer);
    this.settleTimer = null;
    if (!this.moving) return;
    this.setMotion(false);
    this.requestRender();
  }

  // frame = {target: [x,y,z], radius, zMax}: what the home view shows.
  setFrame(frame) {
    this.frame = frame;
    this.resetView();
  }

  resetView() {
    const f = this.frame;
    if (!f) return;
    const target = new THREE.Vector3(...f.target);
    const dist = (f.radius / Math.sin(THREE.MathUtils.degToRad(this.persp.fov / 2))) * 1.05;
    this.persp.position.copy(target).addScaledVector(VIEW_DIR, dist);
    this.persp.near = Math.max(0.05, dist / 1000);
    this.persp.far = dist * 20 + f.radius * 20;
    this.orbit.target.copy(target);
    this.orthoHalf = f.radius * 1.1;
    const height = Math.max(f.zMax - target.z, 0) + f.radius * 4;
    this.ortho.position.set(target.x, target.y, target.z + height);
    this.ortho.near = 0.1;
    this.ortho.far = height * 2 + f.radius * 4;
    this.ortho.zoom = 1;
    this.pan.target.copy(target);
    this.updateProjection();
    this.orbit.update();
    this.pan.update();
    this.requestRender();
  }

  setTopView(on) {
    this.topView = on;
    this.orbit.enabled = !on;
    this.pan.enabled = on;
    this.requestRender();
  }

  requestRender() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.render();
    });
  }

  render() {
    this.resize();
    if (this.moving) this.renderer.render(this.scene, this.camera);
    else this.renderSettled();
    this.drawnTriangles = this.renderer.info.render.triangles;
    if (this.onRender) this.onRender();
  }

  // Full quality: the scene into a multisampled render target, resolved and copied to the canvas.
  renderSettled() {
    const r = this.renderer, size = r.getDrawingBufferSize(new THREE.Vector2());
    if (!this.msaa) this.msaa = makeMsaaPass(size.x, size.y);
    const target = this.msaa.target;
    if (target.width !== size.x || target.height !== size.y) target.setSize(size.x, size.y);
    r.setRenderTarget(target);
    r.render(this.scene, this.camera);
    const triangles = r.info.render.triangles;
    r.setRenderTarget(null);
    r.render(this.msaa.scene, this.msaa.camera);
    r.info.render.triangles = triangles;
    this.settledFrames++;
  }

  // Input coordinates [x, y, z] (site frame, metres) -> CSS pixels in the canvas with the current
  // camera: {x, y} from the canvas's top-left corner, clientX/clientY in the viewport, and
  // `inside` (in front of the camera and within the canvas).
  project(p) {
    const o = this.offset || [0, 0, 0];
    const cam = this.camera;
    cam.updateMatrixWorld();
    const v = new THREE.Vector3(p[0] - o[0], p[1] - o[1], p[2] - o[2]).project(cam);
    const r = this.canvas.getBoundingClientRect();
    const x = ((v.x + 1) / 2) * r.width, y = ((1 - v.y) / 2) * r.height;
    const inside = v.z >= -1 && v.z <= 1 && x >= 0 && y >= 0 && x < r.width && y < r.height;
    return { x, y, clientX: r.left + x, clientY: r.top + y, inside };
  }

  // Is the last full-quality frame on the canvas (no motion, no render pending)?
  get settled() {
    return !this.moving && !this.pending && this.settledFrames > 0;
  }

  // Client coordinates -> first intersection with `objects` (or null).
  pick(clientX, clientY, objects) {
    const r = this.canvas.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    const hits = ray.intersectObjects(objects, false);
    return hits.length ? hits[0] : null;
  }

  // Rotates the camera about the vertical through the target by `stepDeg` per animation frame at
  // interactive quality, then draws the settled full-quality frame. Resolves with {times (ms
  // between rAF callbacks of the interactive frames), settleMs (full-quality frame: render and
  // wait for the GPU), interactiveTriangles, fullTriangles (drawn per frame), pixel ratios}. The
  // 3-D view keeps the rotation (like a drag); the top view spins its up vector and is put back.
  async measureRotation(frames = 120, stepDeg = 0.5) {
    const cam = this.camera, target = this.controls.target, top = this.topView;
    const saved = { position: cam.position.clone(), up: cam.up.clone() };
    const q = new THREE.Quaternion().setFromAxisAngle(UP, THREE.MathUtils.degToRad(stepDeg));
    clearTimeout(this.settleTimer);
    this.setMotion(true);
    const interactivePixelRatio = this.renderer.getPixelRatio();
    const times = [];
    let last = await nextFrame();
    while (times.length < frames) {
      if (top) cam.up.applyQuaternion(q);
      else cam.position.sub(target).applyQuaternion(q).add(target);
      cam.lookAt(target);
      this.render();
      const now = await nextFrame();
      times.push(now - last);
      last = now;
    }
    const interactiveTriangles = this.drawnTriangles;
    if (top) {
      cam.position.copy(saved.position);
      cam.up.copy(saved.up);
    }
    const settleMs = this.timeSettledFrame();
    const fullTriangles = this.drawnTriangles;
    this.controls.update();
    return { times, settleMs, interactiveTriangles, fullTriangles, interactivePixelRatio,
      fullPixelRatio: this.renderer.getPixelRatio() };
  }

  // Draws the full-quality frame now and waits for the GPU to finish it (1-pixel readPixels).
  timeSettledFrame() {
    const t0 = performance.now();
    this.setMotion(false);
    this.render();
    const gl = this.renderer.getContext();
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    return performance.now() - t0;
  }
}

// 4-sample RGBA8 render target and a full-screen quad that copies its resolved texture.
function makeMsaaPass(width, height) {
  const target = new THREE.WebGLRenderTarget(width, height, { samples: 4 });
  const material = new THREE.MeshBasicMaterial({ map: target.texture, depthTest: false, depthWrite: false, toneMapped: false });
  const scene = new THREE.Scene();
  scene.add(new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material));
  return { target, scene, camera: new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1) };
}

function nextFrame() {
  return new Promise((resolve) => requestAnimationFrame(resolve));
}

export function disposeTree(obj) {
  obj.traverse((o) => {
    if (o.geometry) o.geometry.dispose();
    if (o.material) [].concat(o.material).forEach((m) => m.dispose());
  });
}

export function frameTimeStats(times) {
  const sorted = [...times].sort((a, b) => a - b);
  const mean = times.reduce((s, t) => s + t, 0) / Math.max(times.length, 1);
  const p95 = sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(0.95 * sorted.length))] : 0;
  return { meanMs: mean, p95Ms: p95, frames: times.length };
}
