// Legends drawn into a container: a colour bar (canvas) with ticks, and a key of line symbols.

import { css, LogScale } from './colormap.js';
import { el, sig } from './format.js';
import { arealDensity, densityUnit } from './units.js';

const BAR_W = 280, BAR_H = 14, PAD = 10;

function superscript(n) {
  const map = { '-': '⁻', 0: '⁰', 1: '¹', 2: '²', 3: '³', 4: '⁴', 5: '⁵', 6: '⁶', 7: '⁷', 8: '⁸', 9: '⁹' };
  return String(n).split('').map((c) => map[c] || c).join('');
}

export function decadeLabel(x) {
  const e = Math.round(Math.log10(x));
  if (e >= -2 && e <= 3) return String(10 ** e >= 1 ? 10 ** e : Number((10 ** e).toFixed(-e)));
  return '10' + superscript(e);
}

function barCanvas(width, height) {
  const c = document.createElement('canvas');
  const dpr = window.devicePixelRatio || 1;
  c.width = Math.round(width * dpr);
  c.height = Math.round(height * dpr);
  c.style.width = width + 'px';
  c.style.height = height + 'px';
  const ctx = c.getContext('2d');
  ctx.scale(dpr, dpr);
  return { c, ctx };
}

// Log colour bar: ramp(t) over scale [lo, hi], decade ticks, a marker at `mark` (threshold).
function logBar(scale, ramp, mark) {
  const height = BAR_H + 34;
  const { c, ctx } = barCanvas(BAR_W + 2 * PAD, height);
  for (let x = 0; x < BAR_W; x++) {
    ctx.fillStyle = css(ramp(x / (BAR_W - 1)));
    ctx.fillRect(PAD + x, 14, 1, BAR_H);
  }
  ctx.strokeStyle = '#555';
  ctx.strokeRect(PAD + 0.5, 14.5, BAR_W - 1, BAR_H - 1);
  ctx.fillStyle = '#222';
  ctx.font = '11px system-ui, sans-serif';
  ctx.textAlign = 'center';
  for (const v of scale.ticks()) {
    const x = PAD + scale.t(v) * (BAR_W - 1);
    ctx.fillRect(Math.round(x), 14 + BAR_H, 1, 4);
    ctx.fillText(decadeLabel(v), x, 14 + BAR_H + 15);
  }
  if (mark) {
    const x = Math.round(PAD + scale.t(mark.value) * (BAR_W - 1)) + 0.5;
    ctx.strokeStyle = '#d6001c';
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(x, 9);
    ctx.lineTo(x, 14 + BAR_H + 2);
    ctx.stroke();
    ctx.fillStyle = '#d6001c';
    ctx.fillText(mark.label, Math.min(Math.max(x, PAD + 30), BAR_W - 20), 8);
  }
  return c;
}

function swatch(color, kind = 'box') {
  const s = el('span', { class: 'swatch ' + kind });
  if (kind === 'line' || kind === 'dashed') s.style.borderTopColor = color;
  else s.style.backgroundColor = color;
  return s;
}

// kind: 'line', 'dashed' (a lower bound in the 3-D view) or 'box'.
export function keyItem(color, label, kind = 'line') {
  return el('span', { class: 'key-item' }, [swatch(color, kind), label]);
}

// The threshold as the legend says it: "threshold 0.01794 per m² (1 per 55.74 m²)", or in US
// units "threshold 1 per 600 ft²" (the threshold's own unit: 1 per 600 ft² is the definition).
export function thresholdLabel(threshold, units = 'si') {
  if (units !== 'us') return `threshold ${sig(threshold, 4)} per m² (1 per ${sig(1 / threshold, 4)} m²)`;
  return `threshold ${sig(arealDensity(threshold, units).value, 4)} ${densityUnit(units)}`;
}

// PTN density legend: colour bar, threshold, zero swatch, and `keys` (line symbols). The scale
// is per m² (the colours); in US units the bar is labelled per 600 ft² (the same colours: a log
// scale times a constant).
export function densityLegend(container, { scale, ramp, threshold, zeroColor, keys = [], units = 'si' }) {
  const k = arealDensity(1, units).value;
  const shown = k === 1 ? scale : new LogScale(scale.lo * k, scale.hi * k);
  container.replaceChildren(
    el('div', { class: 'legend-title', text: `PTN hazardous fragment density (${densityUnit(units)}), log scale` }),
    logBar(shown, ramp, { value: threshold * k, label: 'threshold' }),
    el('div', { class: 'legend-row' }, [
      keyItem(css(zeroColor), '0', 'box'),
      el('span', { class: 'threshold', text: thresholdLabel(threshold, units) }),
    ]),
    el('div', { class: 'legend-row small muted', text: `below ${sig(shown.lo)}: lowest colour` }),
    el('div', { class: 'legend-keys' }, keys),
  );
}

// A titled colour ramp from lo to hi (labels at the ends), plus `extra` items after it.
export function rampLegend(title, ramp, lo, hi, extra = []) {
  const { c, ctx } = barCanvas(150, 10);
  for (let x = 0; x < 150; x++) {
    ctx.fillStyle = css(ramp(x / 149));
    ctx.fillRect(x, 0, 1, 10);
  }
  return el('div', { class: 'legend-ramp' }, [
    el('div', { class: 'small', text: title }),
    el('div', { class: 'legend-row' }, [
      el('span', { class: 'small', text: sig(lo) }), c, el('span', { class: 'small', text: sig(hi) }), ...extra,
    ]),
  ]);
}

// Terrain material legend: a swatch and the name of each material the terrain uses
// (materials.js materialEntries), in index order, with its share of the triangles.
export function materialLegend(entries) {
  const total = entries.reduce((n, e) => n + e.triangles, 0) || 1;
  return el('div', { class: 'legend-materials' }, [
    el('div', { class: 'legend-title', text: 'Terrain material' }),
    el('div', { class: 'legend-keys' }, entries.map((e) =>
      el('span', { class: 'key-item material', dataset: { material: e.name }, title: `${e.triangles} triangles` }, [
        swatch(css(e.color), 'box'), e.name,
        el('span', { class: 'small muted', text: ` ${sig(100 * e.triangles / total, 2)} %` }),
      ]))),
  ]);
}

// "Colour: [select]": options [{value, label, disabled, title}], calls onChange(value).
export function colourControl(id, options, value, onChange) {
  const select = el('select', { id, 'aria-label': 'terrain colour' }, options.map((o) =>
    el('option', { value: o.value, text: o.label, ...(o.disabled ? { disabled: '' } : {}), ...(o.title ? { title: o.title } : {}) })));
  select.value = value;
  select.addEventListener('change', () => onChange(select.value));
  return el('label', { class: 'colour-by' }, ['Colour: ', select]);
}
