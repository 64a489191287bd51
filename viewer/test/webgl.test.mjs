// Environment check, independent of the page: this chromium gives a working WebGL context
// (software, SwiftShader) whose drawing can be read back. If this fails, the other tests' blank
// canvases are the environment's fault, not the viewer's.
import assert from 'node:assert/strict';
import { after, before, test } from 'node:test';
import * as h from './harness.mjs';

let browser;
before(async () => { browser = await h.launchBrowser(); });
after(async () => { await browser?.close(); });

test('chromium renders WebGL (software) and the pixels can be read', async () => {
  const page = await h.openPage(browser, { viewport: { width: 400, height: 300 } });
  await page.setContent('<canvas id="c" width="256" height="256"></canvas>');
  const info = await page.evaluate(() => {
    const c = document.getElementById('c');
    const gl = c.getContext('webgl2', { preserveDrawingBuffer: true });
    if (!gl) return null;
    const sh = (type, src) => { const s = gl.createShader(type); gl.shaderSource(s, src); gl.compileShader(s); return s; };
    const p = gl.createProgram();
    gl.attachShader(p, sh(gl.VERTEX_SHADER, '#version 300 es\nin vec2 a; out vec2 v; void main(){ v = a; gl_Position = vec4(a, 0, 1); }'));
    gl.attachShader(p, sh(gl.FRAGMENT_SHADER, '#version 300 es\nprecision mediump float; in vec2 v; out vec4 o; void main(){ o = vec4(0.5 + 0.5 * v, 0.3, 1); }'));
    gl.linkProgram(p);
    gl.useProgram(p);
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-0.9, -0.9, 0.9, -0.9, 0, 0.9]), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
    gl.clearColor(1, 1, 1, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    const e = gl.getExtension('WEBGL_debug_renderer_info');
    return { renderer: e ? gl.getParameter(e.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER), linked: gl.getProgramParameter(p, gl.LINK_STATUS) };
  });
  assert.ok(info, 'no WebGL2 context: chromium needs --use-angle=swiftshader --enable-unsafe-swiftshader');
  assert.ok(info.linked, 'shader program did not link');
  console.log(`# WebGL renderer: ${info.renderer}`);
  const st = await h.canvasDataUrlStats(page, '#c');
  assert.ok(st.distinct > 100 && st.dominantFraction < 0.9, `triangle not drawn: ${JSON.stringify(st)}`);
  const shot = await h.canvasStats(page, '#c');
  assert.ok(shot.distinct > 100, `compositor shows no triangle: ${shot.distinct} colours`);
  await page.context().close();
});
