// A small dependency-free SVG plot of 2-D trajectories (x east, y north, equal scale).
// FtinPlot.render(container, series, legend): series = [{label, color, x: [...], y: [...], dashed, truth,
// gps, accuracy: [...]}]
// The legend is HTML beside the plot (never over the data, names never cut). Markers: the start is
// one green circle (the ground truth's, else where the predictions start); a prediction aligned away
// from it starts at a small circle in its own colour; the ground truth ends at a hollow grey square,
// a prediction at a triangle in its own colour. GPS fixes are drawn first, under every path: dots on a
// dotted line, inside their reported accuracy as one pale area (the circles drawn opaque inside a
// faint group, so a hundred overlapping fixes tint the plot no more than one: they used to wash it).
// Colours: app/viz/palette.py (START_COLOR here, the rest in util.js), no two alike.
"use strict";

const FtinPlot = (() => {
  const SVG_NS = "http://www.w3.org/2000/svg";
  const MAX_POINTS = 4000;
  const SIZE = { width: 720, height: 540, left: 56, right: 16, top: 16, bottom: 44 };
  const START_COLOR = "#00aa5a";
  const TRUTH_END = "#3c3c3c";
  const GPS_AREA_OPACITY = 0.1; // the union of the accuracy circles, however many overlap

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

  function bounds(series) {
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
    const scale = Math.min(plotW / (spanX * 1.1), plotH / (spanY * 1.1));
    spanX = plotW / scale; spanY = plotH / scale;
    return { x0: cx - spanX / 2, x1: cx + spanX / 2, y0: cy - spanY / 2, y1: cy + spanY / 2, scale };
  }

  function renderLegend(legend, series, ownStarts) {
    legend.textContent = "";
    const item = (swatch, label) => {
      const span = document.createElement("span");
      span.className = "legend-item";
      span.innerHTML = swatch;
      span.append(label);
      legend.appendChild(span);
    };
    for (const s of series) {
      if (s.gps) {
        item(`<svg width="26" height="12"><circle cx="13" cy="6" r="5" fill="${s.color}" fill-opacity="${GPS_AREA_OPACITY}"/><circle cx="13" cy="6" r="2.5" fill="${s.color}"/></svg>`, s.label);
        continue;
      }
      const dash = s.dashed ? "stroke-dasharray='6 4'" : "";
      item(`<svg width="26" height="10"><line x1="0" y1="5" x2="26" y2="5" stroke="${s.color}" stroke-width="3" ${dash}/></svg>`, s.label);
    }
    item(`<svg width="12" height="12"><circle cx="6" cy="6" r="5" fill="${START_COLOR}"/></svg>`, "start");
    if (ownStarts) {
      item(`<svg width="12" height="12"><circle cx="6" cy="6" r="3.5" fill="#666" stroke="#fff"/></svg>`,
        "predicted start, where alignment moved it (in the model's colour)");
    }
    if (series.some((s) => s.truth)) {
      item(`<svg width="14" height="14"><rect x="2" y="2" width="10" height="10" fill="#fff" stroke="${TRUTH_END}" stroke-width="2"/></svg>`, "true end");
    }
    item(`<svg width="14" height="14"><path d="M 7 1 L 13 12 L 1 12 Z" fill="#666"/></svg>`, "predicted end (in the model's colour)");
  }

  function render(container, series, legend) {
    container.textContent = "";
    const svg = el("svg", {
      viewBox: `0 0 ${SIZE.width} ${SIZE.height}`,
      role: "img",
      "aria-label": "trajectory plot: " + series.map((s) => s.label).join(", "),
    }, container);
    const b = bounds(series);
    const px = (x) => SIZE.left + (x - b.x0) * b.scale;
    const py = (y) => SIZE.height - SIZE.bottom - (y - b.y0) * b.scale;

    const grid = el("g", { class: "grid" }, svg);
    const axis = el("g", { class: "axis" }, svg);
    const step = tickStep(Math.max(b.x1 - b.x0, b.y1 - b.y0), 8);
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

    const paths = series.filter((s) => !s.gps);
    for (const s of series.filter((g) => g.gps)) drawGps(svg, s, px, py, b.scale);
    for (const s of paths) {
      const points = decimate(s.x.length).map((i) => `${px(s.x[i]).toFixed(1)},${py(s.y[i]).toFixed(1)}`);
      el("polyline", {
        points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": s.dashed ? 2 : 2.5,
        "stroke-dasharray": s.dashed ? "6 4" : "none", "stroke-linejoin": "round", class: "series",
        "data-label": s.label,
      }, svg);
    }
    // One start: the truth's (else the first path's); a path starting elsewhere (aligned) gets its own.
    const first = paths.find((s) => s.truth) || paths[0];
    let ownStarts = false;
    for (const s of paths) {
      const last = s.x.length - 1;
      const apart = first && Math.hypot(s.x[0] - first.x[0], s.y[0] - first.y[0]) * b.scale > 3;
      if (s === first) {
        el("circle", { cx: px(s.x[0]), cy: py(s.y[0]), r: 5, fill: START_COLOR, class: "start" }, svg);
      } else if (apart) {
        ownStarts = true;
        el("circle", { cx: px(s.x[0]), cy: py(s.y[0]), r: 3.5, fill: s.color, stroke: "#fff", class: "start-own" }, svg);
      }
      const ex = px(s.x[last]), ey = py(s.y[last]);
      if (s.truth) {
        el("rect", { x: ex - 6, y: ey - 6, width: 12, height: 12, fill: "#fff", stroke: s.color,
          "stroke-width": 2.5, class: "end end-truth" }, svg);
      } else {
        el("path", { d: `M ${ex} ${ey - 7} L ${ex + 6.5} ${ey + 5} L ${ex - 6.5} ${ey + 5} Z`, fill: s.color,
          stroke: "#fff", "stroke-width": 1, class: "end end-predicted" }, svg);
      }
    }

    if (legend) renderLegend(legend, series, ownStarts);
    return svg;
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

  return { render, decimate, tickStep };
})();
