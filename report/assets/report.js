// Draws the study report's figures from the data in <script id="report-data"> (built by
// report/report_figures.cpp, already in the report's units) with Observable Plot (inlined with
// d3 ahead of this script). Everything drawn is text or SVG made by Plot: strings from the
// scenario (building ids) become SVG text nodes, never markup.
(function () {
  'use strict';
  const data = JSON.parse(document.getElementById('report-data').textContent);
  const u = data.units;
  // Density classes relative to the threshold (as ptn_classes.tif); hazardous in reds.
  const CLASSES = [
    [2, 'below 1/100 of the threshold', '#e8eef4'],
    [3, '1/100 to 1/10', '#b9cde0'],
    [4, '1/10 to 1', '#7fa6c9'],
    [5, '1 to 10 × the threshold (hazardous)', '#f4a582'],
    [6, '10 × the threshold and more', '#b2182b'],
  ];
  const COLOUR = Object.fromEntries(CLASSES.map(([k, , c]) => [k, c]));

  function ringsToRows(rings, tag) {
    const rows = [];
    rings.forEach((ring, i) => ring.forEach(([x, y]) => rows.push({ x, y, ring: tag + i })));
    return rows;
  }

  function circle(r, n = 180) {
    return Array.from({ length: n + 1 }, (_, k) => {
      const a = (2 * Math.PI * k) / n;
      return { x: r * Math.cos(a), y: r * Math.sin(a) };
    });
  }

  function mapPlot(width, m = data.map, boundary = true) {
    const r = m.raster;
    const buildings = [];
    (m.buildings || []).forEach((b) => b.triangles.forEach((t, i) =>
      t.forEach(([x, y]) => buildings.push({ x, y, ring: b.index + ':' + i }))));
    const labels = (m.buildings || [])
      .filter((b) => Math.abs(b.label_at[0]) <= r.x2 && Math.abs(b.label_at[1]) <= r.y2)
      .map((b) => ({ x: b.label_at[0], y: b.label_at[1], id: b.id }));
    const plot = Plot.plot({
      width, aspectRatio: 1, marginLeft: 60,
      x: { domain: [r.x1, r.x2], label: `east of the HFD origin (${u.length})` },
      y: { domain: [r.y1, r.y2], label: `north (${u.length})` },
      marks: [
        Plot.raster(Array.from(r.classes, Number), {
          width: r.width, height: r.height, x1: r.x1, x2: r.x2, y1: r.y2, y2: r.y1,
          fill: (d) => (d === 0 ? null : COLOUR[d]), imageRendering: 'pixelated',
        }),
        Plot.line(buildings, { x: 'x', y: 'y', z: 'ring', fill: '#888', stroke: '#555', strokeWidth: 0.5 }),
        Plot.text(labels, { x: 'x', y: 'y', text: 'id', dy: -8, fontSize: 9, fill: '#333' }),
        Plot.line(circle(data.hfd), { x: 'x', y: 'y', stroke: '#555', strokeWidth: 0.8 }),
        boundary ? Plot.line(ringsToRows(m.envelope, 'e'), { x: 'x', y: 'y', z: 'ring', stroke: '#000', strokeWidth: 1.4 }) : null,
        boundary ? Plot.line(ringsToRows(m.envelope_upper, 'u'), { x: 'x', y: 'y', z: 'ring', stroke: '#000', strokeDasharray: '5,3' }) : null,
        boundary ? Plot.line(ringsToRows(m.smoothed, 's'), { x: 'x', y: 'y', z: 'ring', stroke: '#b2182b', strokeWidth: 1.2, strokeDasharray: '1.5,2' }) : null,
        Plot.dot([[0, 0]], { symbol: 'cross', r: 5, stroke: '#000' }),
      ],
    });
    const legend = Plot.legend({
      color: { type: 'ordinal', domain: CLASSES.map((c) => c[1]), range: CLASSES.map((c) => c[2]) },
      swatchSize: 12,
    });
    const box = document.createElement('div');
    box.append(legend, plot);
    return box;
  }

  function wedge(k, r) {
    const pts = [{ x: 0, y: 0 }];
    for (let a = 10 * k; a <= 10 * k + 10 + 1e-9; a += 2) {
      const t = (a * Math.PI) / 180;
      pts.push({ x: r * Math.cos(t), y: r * Math.sin(t) });
    }
    pts.push({ x: 0, y: 0 });
    return pts;
  }

  function outline(key) {
    const rows = [];
    data.rose.forEach((s) => wedge(s.sector, s[key]).slice(1, -1).forEach((p) => rows.push(p)));
    if (rows.length) rows.push(rows[0]);
    return rows;
  }

  function rosePlot(width) {
    const rMax = Math.max(1, ...data.rose.map((s) => s.upper), data.band[1]);
    const wedges = [];
    data.rose.forEach((s) => wedge(s.sector, s.hfd).forEach((p) => wedges.push({ ...p, k: s.sector, cut: s.cut })));
    const ticks = d3.ticks(0, rMax, 4).filter((t) => t > 0);
    const rings = [];
    ticks.forEach((t) => circle(t, 120).forEach((p) => rings.push({ ...p, t })));
    const compass = [['N', 0, 1], ['E', 1, 0], ['S', 0, -1], ['W', -1, 0]].map(([l, x, y]) =>
      ({ l, x: 1.08 * rMax * x, y: 1.08 * rMax * y }));
    return Plot.plot({
      width: Math.min(width, 480), aspectRatio: 1, axis: null,
      x: { domain: [-1.15 * rMax, 1.15 * rMax] }, y: { domain: [-1.15 * rMax, 1.15 * rMax] },
      marks: [
        Plot.line(rings, { x: 'x', y: 'y', z: 't', stroke: '#ccc' }),
        Plot.text(ticks, { x: (t) => t * Math.cos(Math.PI / 4), y: (t) => t * Math.sin(Math.PI / 4),
          text: (t) => `${t} ${u.length}`, fontSize: 9, fill: '#666' }),
        Plot.line(wedges, { x: 'x', y: 'y', z: 'k', fill: (d) => (d.cut ? '#d6604d' : '#92c5de'), stroke: '#4393c3', strokeWidth: 0.5 }),
        Plot.line(outline('envelope'), { x: 'x', y: 'y', stroke: '#000', strokeWidth: 1.2 }),
        Plot.line(outline('upper'), { x: 'x', y: 'y', stroke: '#000', strokeDasharray: '5,3' }),
        Plot.text(compass, { x: 'x', y: 'y', text: 'l', fontWeight: 'bold' }),
      ],
    });
  }

  function profilePlot(width) {
    const p = data.profile;
    const rows = [];
    p.distance.forEach((x, k) => {
      if (p.max[k] !== null) rows.push({ x, y: p.max[k], what: 'largest triangle density' });
      if (p.mean[k] !== null) rows.push({ x, y: p.mean[k], what: 'area-weighted mean' });
    });
    return Plot.plot({
      width, height: 300, marginLeft: 60,
      x: { label: `distance from the HFD origin (${u.length})` },
      y: { type: 'log', label: `PTN density (${u.density})`, tickFormat: '~g' },
      color: { legend: true, domain: ['largest triangle density', 'area-weighted mean'], range: ['#b2182b', '#2166ac'] },
      marks: [
        Plot.rectX([data.band], { x1: (b) => b[0], x2: (b) => b[1], fill: '#eee' }),
        Plot.line(rows, { x: 'x', y: 'y', stroke: 'what', z: 'what', curve: 'step' }),
        Plot.ruleY([data.threshold], { stroke: '#000', strokeDasharray: '4,3' }),
        Plot.ruleX([data.hfd], { stroke: '#000' }),
      ],
    });
  }

  const DRAW = {
    overview: (width) => mapPlot(width, data.overview, false),
    map: (width) => mapPlot(width, data.map, true),
    rose: rosePlot,
    profile: profilePlot,
  };
  document.querySelectorAll('.plot[data-plot]').forEach((node) => {
    const draw = DRAW[node.dataset.plot];
    try {
      node.append(draw(Math.min(760, node.clientWidth || 760)));
      node.dataset.drawn = 'yes';
    } catch (e) {
      node.textContent = 'This figure could not be drawn: ' + e.message;
      node.dataset.drawn = 'failed';
    }
  });
  document.documentElement.dataset.figures = 'drawn';
})();
