// three.js view of a site: renderer, cameras (3-D orbit and orthographic top view), on-demand
// rendering, resizing, picking and the rotation benchmark.
//
// World coordinates are the scene's site coordinates relative to offset_m, unchanged:
// x east, y north, z up (camera.up = +z). Nothing is ever added to the GPU positions.

import * as THREE from '../vendor/three.module.js';
import { OrbitControls } from '../vendor/OrbitControls.js';

const UP = new THREE.Vector3(0, 0, 1);
const VIEW_DIR = new THREE.Vector3(0.25, -1, 0.85).normalize();  // camera offset: from the south

export class SceneView {
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.renderer.setClearColor(0xf4f5f7, 1);
    this.scene = new THREE.Scene();
    this.content = null;
    this.topView = false;
    this.pending = false;
    this.onRender = null;
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
    for (const c of [this.orbit, this.pan]) c.addEventListener('change', () => this.requestRender());
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
    if (group) this.scene.add(group);
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
    this.renderer.render(this.scene, this.camera);
    if (this.onRender) this.onRender();
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

  // Rotates the camera about the vertical through the target by `stepDeg` per animation frame,
  // rendering each frame; resolves with the frame times (ms between rAF callbacks). The 3-D view
  // keeps the rotation (like a drag); the top view spins its up vector and is put back after.
  measureRotation(frames = 120, stepDeg = 0.5) {
    const cam = this.camera, target = this.controls.target, top = this.topView;
    const saved = { position: cam.position.clone(), up: cam.up.clone() };
    const q = new THREE.Quaternion().setFromAxisAngle(UP, THREE.MathUtils.degToRad(stepDeg));
    const times = [];
    return new Promise((resolve) => {
      let last = null;
      const step = (now) => {
        if (last !== null) times.push(now - last);
        last = now;
        if (times.length >= frames) {
          if (top) {
            cam.position.copy(saved.position);
            cam.up.copy(saved.up);
          }
          this.controls.update();
          this.requestRender();
          resolve(times);
          return;
        }
        if (top) cam.up.applyQuaternion(q);
        else cam.position.sub(target).applyQuaternion(q).add(target);
        cam.lookAt(target);
        this.render();
        requestAnimationFrame(step);
      };
      requestAnimationFrame(step);
    });
  }
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
