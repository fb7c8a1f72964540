// Charts over time under the trajectory plot: the walk's speed (from the predicted path) with the
// accelerometer's steps as ticks, and the heading error against the ground truth where the answer
// has one. Dependency-free SVG at the container's width, like plot.js.
// FtinCharts.timeSeries(container, {series: [{t, v, color, label}], ticks: [t...], yLabel, yMin, minSpan})
// FtinCharts.speed(t, x, y): the speed in m/s every SPEED_STEP_S, over SPEED_SPAN_S (centred).
"use strict";

const FtinCharts = (() => {
  const SVG_NS = "http://www.w3.org/2000/svg";
  const HEIGHT = 150;
  const M = { left: 56, right: 16, top: 10, bottom: 30 };
  const SPEED_STEP_S = 0.5;
  const SPEED_SPAN_S = 1.0; // about two steps: the speed of walking, not of the body's sway

  function el(name, attrs, parent) {
    const node = document.createElementNS(SVG_NS, name);
    for (const [key, value] of Object.entries(attrs || {})) node.setAttribute(key, value);
    if (parent) parent.appendChild(node);
    return node;
  }

  // The position at time `at` by linear interpolation; `hint` is the index to search from (times rise).
  function positionAt(t, x, y, at, hint) {
    let i = hint;
    while (i < t.length - 2 && t[i + 1] < at) i++;
    const span = t[i + 1] - t[i] || 1;
    const f = Math.min(Math.max((at - t[i]) / span, 0), 1);
    return { x: x[i] + f * (x[i + 1] - x[i]), y: y[i] + f * (y[i + 1] - y[i]), i };
  }

  function speed(t, x, y) {
    const n = t.length;
    if (n < 2 || t[n - 1] - t[0] < SPEED_SPAN_S) return { t: [], v: [] };
    const out = { t: [], v: [] };
    let lo = 0, hi = 0;
    for (let at = t[0] + SPEED_SPAN_S / 2; at <= t[n - 1] - SPEED_SPAN_S / 2 + 1e-9; at += SPEED_STEP_S) {
      const a = positionAt(t, x, y, at - SPEED_SPAN_S / 2, lo);
      const b = positionAt(t, x, y, at + SPEED_SPAN_S / 2, hi);
      lo = a.i; hi = b.i;
      out.t.push(at);
      out.v.push(Math.hypot(b.x - a.x, b.y - a.y) / SPEED_SPAN_S);
    }
    return out;
  }

  function tickStep(span, count) {
    const raw = span / Math.max(count, 1);
    const magnitude = Math.pow(10, Math.floor(Math.log10(raw || 1)));
    for (const f of [1, 2, 5, 10]) if (f * magnitude >= raw) return f * magnitude;
    return 10 * magnitude;
  }

  // minSpan: the least the y axis spans (a phone lying still walks 0.004 m/s: drawn flat at the floor,
  // not magnified into a full-height line).
  function timeSeries(container, { series, ticks = [], yLabel, yMin = null, minSpan = 0 }) {
    container.textContent = "";
    const width = Math.max(Math.round(container.clientWidth || 720), 320);
    const finite = (v) => v !== null && Number.isFinite(v);
    const all = series.flatMap((s) => s.t);
    if (!all.length) return null;
    let t0 = Math.min(...all), t1 = Math.max(...all);
    if (ticks.length) { t0 = Math.min(t0, ...ticks); t1 = Math.max(t1, ...ticks); }
    const values = series.flatMap((s) => s.v.filter(finite));
    // yMin: the axis' floor unless a value lies below it (a signed heading error).
    let v0 = yMin !== null ? Math.min(yMin, ...values) : Math.min(...values), v1 = Math.max(...values);
    if (!(v1 > v0)) v1 = v0 + 1;
    v1 = Math.max(v1, v0 + minSpan);
    v1 += (v1 - v0) * 0.08;
    const px = (t) => M.left + ((t - t0) / (t1 - t0 || 1)) * (width - M.left - M.right);
    const py = (v) => HEIGHT - M.bottom - ((v - v0) / (v1 - v0)) * (HEIGHT - M.top - M.bottom);
    const svg = el("svg", { width, height: HEIGHT, viewBox: `0 0 ${width} ${HEIGHT}`, role: "img",
      "aria-label": `${yLabel} over time` }, container);
    const axis = el("g", { class: "axis" }, svg);
    const grid = el("g", { class: "grid" }, svg);
    const ts = tickStep(t1 - t0, Math.round(width / 90));
    for (let t = Math.ceil(t0 / ts) * ts; t <= t1; t += ts) {
      el("line", { x1: px(t), x2: px(t), y1: M.top, y2: HEIGHT - M.bottom }, grid);
      el("text", { x: px(t), y: HEIGHT - M.bottom + 14, "text-anchor": "middle" }, axis).textContent = +t.toFixed(3);
    }
    const vs = tickStep(v1 - v0, 4);
    for (let v = Math.ceil(v0 / vs) * vs; v <= v1; v += vs) {
      el("line", { x1: M.left, x2: width - M.right, y1: py(v), y2: py(v) }, grid);
      el("text", { x: M.left - 6, y: py(v) + 4, "text-anchor": "end" }, axis).textContent = +v.toFixed(3);
    }
    el("text", { x: width - M.right, y: HEIGHT - 2, "text-anchor": "end" }, axis).textContent = "time (s)";
    el("text", { x: 12, y: (HEIGHT - M.bottom + M.top) / 2, "text-anchor": "middle",
      transform: `rotate(-90 12 ${(HEIGHT - M.bottom + M.top) / 2})` }, axis).textContent = yLabel;
    if (ticks.length) {
      const g = el("g", { class: "step-ticks" }, svg);
      for (const t of ticks) {
        el("line", { x1: px(t).toFixed(1), x2: px(t).toFixed(1), y1: HEIGHT - M.bottom, y2: HEIGHT - M.bottom - 8,
          class: "step-tick" }, g);
      }
    }
    for (const s of series) {
      let d = "", pen = false;
      for (let i = 0; i < s.t.length; i++) {
        if (!finite(s.v[i])) { pen = false; continue; }
        d += `${pen ? "L" : "M"}${px(s.t[i]).toFixed(1)},${py(s.v[i]).toFixed(1)}`;
        pen = true;
      }
      el("path", { d, fill: "none", stroke: s.color, "stroke-width": 1.8, class: "series", "data-label": s.label }, svg);
    }
    return svg;
  }

  return { timeSeries, speed };
})();
