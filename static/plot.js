// A small dependency-free SVG plot of 2-D trajectories (x east, y north, equal scale).
// FtinPlot.render(container, series, legend): series = [{label, color, x: [...], y: [...], dashed, truth,
// gps, accuracy: [...], band: {t, xx, xy, yy}, endRadius, trueEnd: {x, y}}]
// Drawn at the container's own width (the card's: the plot is the page's hero), redrawn on resize.
// Zoom and pan: the wheel zooms about the cursor, a drag pans, FtinPlot.reset(container) (or a double
// click) returns to the whole walk; every path is clipped to the plot area, the axes follow.
// The legend is HTML under the plot (never over the data, names never cut, wrapping); a path's name
// is a toggle: click it to hide or show that path (compare-all's twenty models stay legible). Markers: the start is
// one green circle (the ground truth's, else where the predictions start); a prediction aligned away
// from it starts at a small circle in its own colour; the ground truth ends at a hollow grey square,
// a prediction at a triangle in its own colour. GPS fixes are drawn first, under every path: dots on a
// dotted line, inside their reported accuracy as one pale area (the circles drawn opaque inside a
// faint group, so a hundred overlapping fixes tint the plot no more than one: they used to wash it).
// How sure (docs/metrics.md, "How sure is it"): a path with `band` (its per-sample covariance, m²) is
// drawn over a pale corridor, the union of its 2-sigma ellipses every BAND_EVERY_S (wider apart on a
// long walk, at most MAX_BAND_ELLIPSES) joined by round-capped strokes as wide as the narrower of the
// two ellipses across the stroke, opaque inside one faint group as the GPS area; `endRadius` (end_radius_95_m) is a dashed
// circle around its end. Both are clipped to the plot area: a radius larger than the walk does not
// rescale the plot.
// Colours: app/viz/palette.py (START_COLOR here, the rest in util.js), no two alike.
"use strict";

const FtinPlot = (() => {
  const SVG_NS = "http://www.w3.org/2000/svg";
  const MAX_POINTS = 4000;
  const MARGIN = { left: 56, right: 16, top: 16, bottom: 44 };
  const ZOOM_STEP = 1.2; // one wheel notch
  const views = new Map(); // container -> {series, legend, view: {cx, cy, scale} | null, hidden: Set}
  const START_COLOR = "#00aa5a";
  const TRUTH_END = "#3c3c3c";
  const GPS_AREA_OPACITY = 0.1; // the union of the accuracy circles, however many overlap
  const BAND_OPACITY = 0.16;
  const BAND_EVERY_S = 2;
  const MAX_BAND_ELLIPSES = 900; // a 1-hour walk: one every 4 s
  let clipCount = 0; // a unique clip-path id per plot drawn

  function el(name, attrs, parent) {
    const node = document.createElementNS(SVG_NS, name);
    for (const [key, value] of Object.entries(attrs || {})) node.setAttribute(key, value);
    if (parent) parent.appendChild(node);
    return node;
  }

  // Evenly spaced indices, always keeping the last point.
  function decimate(n) {
    if (n <= MAX_POINTS) return [...Array(n).keys()];
    const step = (n - 1) / (MAX_POINTS - 1);
    return [...Array(MAX_POINTS).keys()].map((i) => Math.round(i * step));
  }

  // 1-2-5 tick step giving about `count` ticks over `span`.
  function tickStep(span, count) {
    const raw = span / Math.max(count, 1);
    const magnitude = Math.pow(10, Math.floor(Math.log10(raw)));
    for (const f of [1, 2, 5, 10]) if (f * magnitude >= raw) return f * magnitude;
    return 10 * magnitude;
  }

  function bounds(series, SIZE, view) {
    let xmin = Infinity, xmax = -Infinity, ymin = Infinity, ymax = -Infinity;
    for (const s of series) {
      for (let i = 0; i < s.x.length; i++) {
        xmin = Math.min(xmin, s.x[i]); xmax = Math.max(xmax, s.x[i]);
        ymin = Math.min(ymin, s.y[i]); ymax = Math.max(ymax, s.y[i]);
      }
    }
    // Equal scale on both axes, at least 1 m of span, 5 % margin.
    const plotW = SIZE.width - SIZE.left - SIZE.right;
    const plotH = SIZE.height - SIZE.top - SIZE.bottom;
    let spanX = Math.max(xmax - xmin, 1), spanY = Math.max(ymax - ymin, 1);
    const cx = (xmin + xmax) / 2, cy = (ymin + ymax) / 2;
    const fit = { cx, cy, scale: Math.min(plotW / (spanX * 1.1), plotH / (spanY * 1.1)) };
    const v = view || fit; // zoomed or panned: the view the user chose
    spanX = plotW / v.scale; spanY = plotH / v.scale;
    return { x0: v.cx - spanX / 2, x1: v.cx + spanX / 2, y0: v.cy - spanY / 2, y1: v.cy + spanY / 2, scale: v.scale, fit };
  }

  // The samples that get an ellipse: one per BAND_EVERY_S (or wider), the last always.
  function bandRows(t) {
    const n = t.length;
    if (n < 2) return [];
    const every = Math.max(BAND_EVERY_S, (t[n - 1] - t[0]) / MAX_BAND_ELLIPSES);
    const rows = [];
    let next = t[0] + every; // not the start: its ellipse is a point
    for (let i = 1; i < n; i++) {
      if (t[i] >= next) {
        rows.push(i);
        next = t[i] + every;
      }
    }
    if (rows[rows.length - 1] !== n - 1) rows.push(n - 1);
    return rows;
  }

  // The 2x2 covariance [xx, xy; xy, yy] as its axes: larger and smaller variance, long axis angle.
  function axes(xx, xy, yy) {
    const mid = (xx + yy) / 2, half = Math.sqrt(((xx - yy) / 2) ** 2 + xy * xy);
    return { long: Math.max(mid + half, 0), short: Math.max(mid - half, 0), angle: 0.5 * Math.atan2(2 * xy, xx - yy) };
  }

  function drawBand(parent, s, px, py, scale) {
    const band = s.band;
    const g = el("g", { class: "uncertainty-band", opacity: BAND_OPACITY, "data-label": s.label }, parent);
    // Half the 2-sigma ellipse's width across the direction (nx, ny) (world, unit): 2 sqrt(n' C n).
    const across = (i, nx, ny) => 2 * Math.sqrt(Math.max(
      nx * nx * band.xx[i] + 2 * nx * ny * band.xy[i] + ny * ny * band.yy[i], 0));
    let last = null;
    for (const i of bandRows(band.t)) {
      const a = axes(band.xx[i], band.xy[i], band.yy[i]);
      const cx = px(s.x[i]), cy = py(s.y[i]);
      const ry = 2 * Math.sqrt(a.short) * scale;
      if (last) {
        // The stroke between two ellipses is as wide as the narrower of them across it: the corridor
        // never claims more than the ellipses do, and has no gaps between them.
        const dx = s.x[i] - s.x[last.i], dy = s.y[i] - s.y[last.i], d = Math.hypot(dx, dy) || 1;
        const half = Math.min(across(last.i, -dy / d, dx / d), across(i, -dy / d, dx / d)) * scale;
        el("line", { x1: last.cx.toFixed(1), y1: last.cy.toFixed(1), x2: cx.toFixed(1), y2: cy.toFixed(1),
          stroke: s.color, "stroke-linecap": "round", "stroke-width": (2 * half).toFixed(1) }, g);
      }
      // SVG's y points down: the world's angle turns the other way.
      el("ellipse", { cx: cx.toFixed(1), cy: cy.toFixed(1), rx: (2 * Math.sqrt(a.long) * scale).toFixed(1), ry: ry.toFixed(1),
        transform: `rotate(${(-a.angle * 180 / Math.PI).toFixed(1)} ${cx.toFixed(1)} ${cy.toFixed(1)})`,
        fill: s.color, class: "band-ellipse" }, g);
      last = { i, cx, cy };
    }
  }

  function drawEndRadius(parent, s, px, py, scale) {
    const last = s.x.length - 1;
    el("circle", { cx: px(s.x[last]), cy: py(s.y[last]), r: Math.max(s.endRadius * scale, 1), fill: "none",
      stroke: s.color, "stroke-width": 1.5, "stroke-dasharray": "5 4", opacity: 0.7, class: "end-radius" }, parent);
  }

  function renderLegend(legend, series, ownStarts, hidden, redraw) {
    legend.textContent = "";
    const item = (swatch, label, toggles) => {
      const span = document.createElement(toggles ? "button" : "span");
      span.className = "legend-item" + (toggles ? " legend-toggle" : "");
      span.innerHTML = swatch;
      span.append(label);
      if (toggles) {
        span.type = "button";
        span.dataset.label = label;
        span.setAttribute("aria-pressed", String(!hidden.has(label)));
        span.title = hidden.has(label) ? "Show this path" : "Hide this path";
        span.addEventListener("click", () => {
          if (hidden.has(label)) hidden.delete(label); else hidden.add(label);
          redraw();
        });
      }
      legend.appendChild(span);
    };
    for (const s of series) {
      if (s.gps) {
        item(`<svg width="26" height="12"><circle cx="13" cy="6" r="5" fill="${s.color}" fill-opacity="${GPS_AREA_OPACITY}"/><circle cx="13" cy="6" r="2.5" fill="${s.color}"/></svg>`, s.label, true);
        continue;
      }
      const dash = s.dashed ? "stroke-dasharray='6 4'" : "";
      item(`<svg width="26" height="10"><line x1="0" y1="5" x2="26" y2="5" stroke="${s.color}" stroke-width="3" ${dash}/></svg>`, s.label, true);
    }
    // Many paths (compare-all): hide every model at once, then show the few to compare.
    const models = series.filter((s) => s.model).map((s) => s.label);
    if (models.length > 2) {
      const any = models.some((label) => !hidden.has(label));
      const all = document.createElement("button");
      all.type = "button";
      all.className = "link-button legend-all";
      all.textContent = any ? "hide every model" : "show every model";
      all.addEventListener("click", () => {
        for (const label of models) if (any) hidden.add(label); else hidden.delete(label);
        redraw();
      });
      legend.appendChild(all);
    }
    const shown = series.filter((s) => !hidden.has(s.label));
    for (const s of shown.filter((b) => b.band)) {
      item(`<svg width="26" height="12"><rect x="0" y="1" width="26" height="10" rx="5" fill="${s.color}" fill-opacity="${BAND_OPACITY}"/><line x1="0" y1="6" x2="26" y2="6" stroke="${s.color}" stroke-width="2"/></svg>`,
        "2σ band (its size fitted on other walks: not this run's error)");
    }
    for (const s of shown.filter((b) => b.endRadius)) {
      item(`<svg width="14" height="14"><circle cx="7" cy="7" r="5.5" fill="none" stroke="${s.color}" stroke-width="1.5" stroke-dasharray="3 2"/></svg>`,
        `95 % end circle: ${s.endRadius >= 10 ? s.endRadius.toFixed(0) : s.endRadius.toFixed(1)} m`);
    }
    item(`<svg width="12" height="12"><circle cx="6" cy="6" r="5" fill="${START_COLOR}"/></svg>`, "start");
    if (ownStarts) {
      item(`<svg width="12" height="12"><circle cx="6" cy="6" r="3.5" fill="#666" stroke="#fff"/></svg>`,
        "predicted start, where alignment moved it (in the model's colour)");
    }
    if (shown.some((s) => s.truth)) {
      item(`<svg width="14" height="14"><rect x="2" y="2" width="10" height="10" fill="#fff" stroke="${TRUTH_END}" stroke-width="2"/></svg>`, "true end");
    }
    item(`<svg width="14" height="14"><path d="M 7 1 L 13 12 L 1 12 Z" fill="#666"/></svg>`, "predicted end (in the model's colour)");
  }

  // The plot's size: the container's width, a height that leaves the page room (at least 320 px).
  function sizeOf(container) {
    const width = Math.max(Math.round(container.clientWidth || 720), 320);
    const height = Math.round(Math.max(320, Math.min(width * 0.62, window.innerHeight * 0.7)));
    return { width, height, ...MARGIN };
  }

  function render(container, series, legend) {
    const record = views.get(container) || { hidden: new Set() };
    const labels = new Set(series.map((s) => s.label));
    for (const label of [...record.hidden]) if (!labels.has(label)) record.hidden.delete(label);
    Object.assign(record, { series, legend, view: record.series === series ? record.view : null });
    views.set(container, record);
    listen(container);
    return draw(container);
  }

  function draw(container) {
    const { series: all, legend, view, hidden } = views.get(container);
    const series = all.filter((s) => !hidden.has(s.label));
    const SIZE = sizeOf(container);
    container.textContent = "";
    const svg = el("svg", {
      width: SIZE.width,
      height: SIZE.height,
      viewBox: `0 0 ${SIZE.width} ${SIZE.height}`,
      role: "img",
      "aria-label": "trajectory plot: " + series.map((s) => s.label).join(", "),
    }, container);
    const b = bounds(series.length ? series : all, SIZE, view);
    views.get(container).bounds = b;
    views.get(container).size = SIZE;
    const px = (x) => SIZE.left + (x - b.x0) * b.scale;
    const py = (y) => SIZE.height - SIZE.bottom - (y - b.y0) * b.scale;

    const grid = el("g", { class: "grid" }, svg);
    const axis = el("g", { class: "axis" }, svg);
    const step = tickStep(Math.max(b.x1 - b.x0, b.y1 - b.y0), Math.max(6, Math.round(SIZE.width / 110)));
    for (let x = Math.ceil(b.x0 / step) * step; x <= b.x1; x += step) {
      el("line", { x1: px(x), x2: px(x), y1: SIZE.top, y2: SIZE.height - SIZE.bottom }, grid);
      el("text", { x: px(x), y: SIZE.height - SIZE.bottom + 16, "text-anchor": "middle" }, axis)
        .textContent = +x.toFixed(6);
    }
    for (let y = Math.ceil(b.y0 / step) * step; y <= b.y1; y += step) {
      el("line", { x1: SIZE.left, x2: SIZE.width - SIZE.right, y1: py(y), y2: py(y) }, grid);
      el("text", { x: SIZE.left - 6, y: py(y) + 4, "text-anchor": "end" }, axis).textContent = +y.toFixed(6);
    }
    el("text", { x: SIZE.left + (SIZE.width - SIZE.left - SIZE.right) / 2, y: SIZE.height - 8,
      "text-anchor": "middle" }, axis).textContent = "x (m)";
    el("text", { x: 14, y: SIZE.top + (SIZE.height - SIZE.top - SIZE.bottom) / 2, "text-anchor": "middle",
      transform: `rotate(-90 14 ${SIZE.top + (SIZE.height - SIZE.top - SIZE.bottom) / 2})` }, axis)
      .textContent = "y (m)";

    // Everything drawn from data stays inside the plot area, however far it is zoomed or panned.
    const id = `plot-area-${++clipCount}`;
    el("rect", { x: SIZE.left, y: SIZE.top, width: SIZE.width - SIZE.left - SIZE.right,
      height: SIZE.height - SIZE.top - SIZE.bottom }, el("clipPath", { id }, el("defs", {}, svg)));
    const area = el("g", { "clip-path": `url(#${id})`, class: "plot-area" }, svg);
    const paths = series.filter((s) => !s.gps);
    const sure = paths.filter((s) => s.band || s.endRadius);
    if (sure.length) {
      const clipped = el("g", { class: "uncertainty" }, area);
      for (const s of sure.filter((p) => p.band)) drawBand(clipped, s, px, py, b.scale);
      for (const s of sure.filter((p) => p.endRadius)) drawEndRadius(clipped, s, px, py, b.scale);
    }
    for (const s of series.filter((g) => g.gps)) drawGps(area, s, px, py, b.scale);
    for (const s of paths) {
      const points = decimate(s.x.length).map((i) => `${px(s.x[i]).toFixed(1)},${py(s.y[i]).toFixed(1)}`);
      el("polyline", {
        points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": s.dashed ? 2 : 2.5,
        "stroke-dasharray": s.dashed ? "6 4" : "none", "stroke-linejoin": "round", class: "series",
        "data-label": s.label,
      }, area);
    }
    // One start: the truth's (else the first path's); a path starting elsewhere (aligned) gets its own.
    const first = paths.find((s) => s.truth) || paths[0];
    let ownStarts = false;
    for (const s of paths) {
      const last = s.x.length - 1;
      const apart = first && Math.hypot(s.x[0] - first.x[0], s.y[0] - first.y[0]) * b.scale > 3;
      if (s === first) {
        el("circle", { cx: px(s.x[0]), cy: py(s.y[0]), r: 5, fill: START_COLOR, class: "start" }, area);
      } else if (apart) {
        ownStarts = true;
        el("circle", { cx: px(s.x[0]), cy: py(s.y[0]), r: 3.5, fill: s.color, stroke: "#fff", class: "start-own" }, area);
      }
      const ex = px(s.x[last]), ey = py(s.y[last]);
      if (s.truth) {
        el("rect", { x: ex - 6, y: ey - 6, width: 12, height: 12, fill: "#fff", stroke: s.color,
          "stroke-width": 2.5, class: "end end-truth" }, area);
      } else {
        el("path", { d: `M ${ex} ${ey - 7} L ${ex + 6.5} ${ey + 5} L ${ex - 6.5} ${ey + 5} Z`, fill: s.color,
          stroke: "#fff", "stroke-width": 1, class: "end end-predicted" }, area);
      }
    }

    if (legend) renderLegend(legend, all, ownStarts, views.get(container).hidden, () => draw(container));
    return svg;
  }

  // Wheel: zoom about the cursor; drag: pan; double click: the whole walk again. Set up once.
  function listen(container) {
    if (container.dataset.zoomable) return;
    container.dataset.zoomable = "1";
    let frame = null, drag = null;
    const redraw = () => {
      if (frame) return;
      frame = requestAnimationFrame(() => { frame = null; draw(container); });
    };
    const current = () => {
      const r = views.get(container);
      return r.view || { ...r.bounds.fit };
    };
    const world = (event) => { // the cursor in metres
      const r = views.get(container), rect = container.querySelector("svg").getBoundingClientRect();
      return { x: r.bounds.x0 + (event.clientX - rect.left - r.size.left) / r.bounds.scale,
        y: r.bounds.y0 + (r.size.height - r.size.bottom - (event.clientY - rect.top)) / r.bounds.scale };
    };
    container.addEventListener("wheel", (event) => {
      if (!views.get(container).bounds) return;
      event.preventDefault();
      const v = current(), at = world(event);
      const factor = Math.pow(ZOOM_STEP, -Math.sign(event.deltaY));
      const scale = Math.min(Math.max(v.scale * factor, v.scale / 50, 1e-3), 1e5);
      const k = v.scale / scale; // the point under the cursor stays there
      views.get(container).view = { cx: at.x + (v.cx - at.x) * k, cy: at.y + (v.cy - at.y) * k, scale };
      redraw();
    }, { passive: false });
    container.addEventListener("pointerdown", (event) => {
      if (!views.get(container).bounds || event.button !== 0) return;
      drag = { x: event.clientX, y: event.clientY, view: current() };
      container.setPointerCapture(event.pointerId);
      container.classList.add("panning");
    });
    container.addEventListener("pointermove", (event) => {
      if (!drag) return;
      const { view } = drag;
      views.get(container).view = { ...view, cx: view.cx - (event.clientX - drag.x) / view.scale,
        cy: view.cy + (event.clientY - drag.y) / view.scale };
      redraw();
    });
    const end = () => { drag = null; container.classList.remove("panning"); };
    container.addEventListener("pointerup", end);
    container.addEventListener("pointercancel", end);
    container.addEventListener("dblclick", () => reset(container));
    let width = container.clientWidth;
    new ResizeObserver(() => {
      if (container.clientWidth !== width && views.get(container)) { width = container.clientWidth; redraw(); }
    }).observe(container);
  }

  // The whole walk again (the "Reset view" button, a double click).
  function reset(container) {
    const record = views.get(container);
    if (!record) return;
    record.view = null;
    draw(container);
  }

  // How far the plot is zoomed against the whole walk (1: not zoomed), for the page and its tests.
  function zoomOf(container) {
    const r = views.get(container);
    return r && r.view && r.bounds ? r.view.scale / r.bounds.fit.scale : 1;
  }

  // GPS fixes: each fix's accuracy (metres, to scale) as one pale area, a dot, a dotted line.
  function drawGps(svg, s, px, py, scale) {
    const g = el("g", { class: "gps", "data-label": s.label }, svg);
    const area = el("g", { class: "gps-accuracy", opacity: GPS_AREA_OPACITY }, g);
    for (let i = 0; i < s.x.length; i++) {
      const a = s.accuracy ? s.accuracy[i] : null;
      if (a !== null && a !== undefined && Number.isFinite(a)) {
        el("circle", { cx: px(s.x[i]), cy: py(s.y[i]), r: Math.max(a * scale, 1), fill: s.color }, area);
      }
    }
    const points = s.x.map((x, i) => `${px(x).toFixed(1)},${py(s.y[i]).toFixed(1)}`);
    el("polyline", { points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": 1.2, "stroke-dasharray": "2 3" }, g);
    for (let i = 0; i < s.x.length; i++) {
      el("circle", { cx: px(s.x[i]), cy: py(s.y[i]), r: 2.5, fill: s.color, class: "gps-fix" }, g);
    }
  }

  return { render, reset, zoomOf, decimate, tickStep, bandRows };
})();
