// A small dependency-free SVG plot of 2-D trajectories (x east, y north, equal scale).
// FtinPlot.render(container, series): series = [{label, color, x: [...], y: [...], dashed}]
"use strict";

const FtinPlot = (() => {
  const SVG_NS = "http://www.w3.org/2000/svg";
  const MAX_POINTS = 4000;
  const SIZE = { width: 720, height: 540, left: 56, right: 16, top: 16, bottom: 44 };

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

  function render(container, series) {
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

    for (const s of series) {
      const points = decimate(s.x.length).map((i) => `${px(s.x[i]).toFixed(1)},${py(s.y[i]).toFixed(1)}`);
      el("polyline", {
        points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": s.dashed ? 2 : 2.5,
        "stroke-dasharray": s.dashed ? "6 4" : "none", "stroke-linejoin": "round", class: "series",
        "data-label": s.label,
      }, svg);
      const last = s.x.length - 1;
      el("circle", { cx: px(s.x[0]), cy: py(s.y[0]), r: 5, fill: "#00aa5a", class: "start" }, svg);
      el("rect", { x: px(s.x[last]) - 5, y: py(s.y[last]) - 5, width: 10, height: 10, fill: "#c81e1e",
        class: "end" }, svg);
    }

    const legend = el("g", { class: "legend" }, svg);
    const items = [...series.map((s) => [s.label, s.color, s.dashed]), ["start", "#00aa5a"], ["end", "#c81e1e"]];
    items.forEach(([label, color, dashed], i) => {
      const y = SIZE.top + 8 + i * 18;
      el("line", { x1: SIZE.width - 170, x2: SIZE.width - 146, y1: y, y2: y, stroke: color, "stroke-width": 3,
        "stroke-dasharray": dashed ? "6 4" : "none" }, legend);
      el("text", { x: SIZE.width - 140, y: y + 4 }, legend).textContent = label;
    });
    return svg;
  }

  return { render, decimate, tickStep };
})();
