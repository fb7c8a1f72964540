// Shared by the upload page's scripts: element lookup, formatting, errors, progress, model names
// and colours. Plain scripts (no bundler): util.js, plot.js, result.js, compare.js, runs.js, app.js.
"use strict";

const TRUTH_COLOR = "#3c3c3c";
const GPS_COLOR = "#00796b";
// The 3D scene's model colours (app/viz/palette.py: no two alike), in the order of the model list.
const MODEL_COLORS = ["#1f77b4", "#ff7f0e", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#17becf",
  "#808000", "#f032e6", "#0000ff", "#003cd2", "#ff0078", "#69b400", "#960f4b", "#1e5a0f", "#964b00",
  "#1e87ff", "#ff7887", "#870096", "#b400ff"];
const $ = (id) => document.getElementById(id);

const state = {
  file: null, sceneUrl: null, polling: null, maxUploadMb: null, models: [],
  metrics: [], // the registered metrics (GET /metrics): every table and row below iterates over them
  result: null, // the shown prediction (the page's own model)
  compared: [], // further predictions on the same file, from "Compare all models"
  userActed: false, // the user picked something: the first screen's result must not replace it
};

function modelColor(name) {
  const i = state.models.findIndex((m) => m.name === name);
  return MODEL_COLORS[(i < 0 ? 0 : i) % MODEL_COLORS.length];
}

// The name people know ("RNIN · OxIOD"); the API name (file stem) where no model matches.
function displayName(name) {
  const m = state.models.find((x) => x.name === name);
  return m && m.display_name ? m.display_name : name;
}

function showError(message) {
  $("error").textContent = message;
  $("error").hidden = !message;
}

function setProgress(fraction, text) {
  $("progress").hidden = fraction === null;
  $("progress-bar").style.width = `${Math.round(100 * Math.max(0, Math.min(1, fraction || 0)))}%`;
  $("progress-text").textContent = text || "";
}

// The API reports every problem as {"detail": "..."}; fall back to the HTTP status text.
function errorText(status, body) {
  try {
    const detail = JSON.parse(body).detail;
    if (typeof detail === "string") return detail;
    if (detail) return JSON.stringify(detail);
  } catch (_) { /* not JSON */ }
  return status ? `The server answered ${status}.` : "Could not reach the server.";
}

function fmt(value, digits, scale = 1) {
  return value === null || value === undefined ? "–" : (value * scale).toFixed(digits);
}

function fillList(list, items) {
  list.textContent = "";
  for (const text of items) {
    const li = document.createElement("li");
    li.textContent = text;
    list.appendChild(li);
  }
  list.hidden = !items.length;
}

// The scene runs on its own port; keep the page's host name so the link works from other machines.
function sceneHref(sceneUrl) {
  if (!sceneUrl) return null;
  const url = new URL(sceneUrl);
  url.hostname = window.location.hostname;
  return url.toString();
}

// --- the registered metrics (GET /metrics) ---------------------------------------------------------

// A registered metric's value as shown: scaled, at its digits, with its unit ("1.23 m", "2.10 %").
function metricText(def, value) {
  const text = fmt(value, def.digits, def.scale);
  return text === "–" || !def.display_unit ? text : `${text} ${def.display_unit}`;
}

const tableMetrics = () => state.metrics.filter((d) => d.in_tables);
const headlineMetric = () => state.metrics.find((d) => d.headline) || state.metrics[0];
// The path ratio: the metric whose best is 1 (a model that barely moves reads near 0).
const ratioMetric = () => state.metrics.find((d) => d.better === "closer to 1");
// The path lengths behind the ratio: the registered figures that are no score.
const pathFigures = () => state.metrics.filter((d) => d.better === "neither");

function isPathWarning(m) {
  const def = ratioMetric();
  const r = m && def && m[def.name];
  return r !== null && r !== undefined && (r < 0.5 || r > 2);
}

const isWorseThanStill = (m) => !!(m && m.worse_than_standing_still);

// Why a model is flagged, in words (the ⚠ beside it says there is something; this says what).
function flagWords(m) {
  const words = [];
  if (isWorseThanStill(m)) words.push("worse than standing still");
  if (isPathWarning(m)) {
    const r = m[ratioMetric().name];
    words.push(r < 0.5 ? "path too short" : "path too long");
  }
  return words;
}
