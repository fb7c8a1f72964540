// The upload page: pick a CSV and a model, POST /predict, show the trajectory, metrics and links.
"use strict";

const TRUTH_COLOR = "#3c3c3c";
// The 3D scene's model colours (app/viz/palette.py), in the order of the model list.
const MODEL_COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
  "#17becf", "#c800c8", "#142878", "#78003c", "#006450", "#aec7e8", "#ffbb78", "#98df8a", "#ff9896",
  "#c5b0d5", "#c49c94", "#f7b6d2", "#9edae5"];
const $ = (id) => document.getElementById(id);

const state = {
  file: null, sceneUrl: null, polling: null, maxUploadMb: null, models: [],
  metrics: [], // the registered metrics (GET /metrics): every table and row below iterates over them
  result: null, // the shown prediction (the page's own model)
  compared: [], // further predictions on the same file, from "Compare all models"
};

function modelColor(name) {
  const i = state.models.findIndex((m) => m.name === name);
  return MODEL_COLORS[(i < 0 ? 0 : i) % MODEL_COLORS.length];
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

// The scene runs on its own port; keep the page's host name so the link works from other machines.
function sceneHref(sceneUrl) {
  if (!sceneUrl) return null;
  const url = new URL(sceneUrl);
  url.hostname = window.location.hostname;
  return url.toString();
}

async function loadModels() {
  const [health, models, metrics] = await Promise.all([
    fetch("/health").then((r) => r.json()),
    fetch("/models").then((r) => r.json()),
    fetch("/metrics").then((r) => r.json()),
  ]);
  state.metrics = metrics;
  state.sceneUrl = sceneHref(health.scene_url);
  state.maxUploadMb = health.max_upload_mb;
  if (state.sceneUrl) {
    $("scene-link-header").href = state.sceneUrl;
    $("scene-link-header").hidden = false;
  }
  state.models = models;
  const select = $("model-select");
  select.textContent = "";
  for (const m of models) {
    const option = document.createElement("option");
    option.value = m.name;
    option.textContent = `${m.name} (${m.architecture}, ${m.imu_rate_hz} Hz)`;
    option.selected = m.default;
    select.appendChild(option);
  }
  if (!models.length) {
    showError("No model is loaded. " + (health.notes || []).join(" "));
  }
  describeModel(models);
  select.addEventListener("change", () => describeModel(models));
  updateRunButton();
}

function describeModel(models) {
  const m = models.find((x) => x.name === $("model-select").value);
  $("model-info").textContent = m
    ? `Window ${m.window} samples (${(m.window / m.imu_rate_hz).toFixed(2)} s)` +
      (m.trained_on ? `, trained on ${m.trained_on}` : "")
    : "";
}

function updateRunButton() {
  $("run-button").disabled = !(state.file && $("model-select").value);
}

function pickFile(file) {
  // Refuse a file above the server's limit here: the server would answer 413 before reading it,
  // and a browser still sending the body may only see the connection close.
  const limitMb = state.maxUploadMb;
  const tooLarge = file && limitMb && file.size > limitMb * 1024 * 1024;
  state.file = file && !tooLarge ? file : null;
  $("drop-zone").classList.toggle("has-file", !!state.file);
  $("drop-text").textContent = state.file
    ? `${file.name} (${(file.size / 1024).toFixed(0)} kB)`
    : "Drop a CSV here, or click to pick one";
  showError(tooLarge
    ? `${file.name} is ${(file.size / 1024 / 1024).toFixed(1)} MB; this server accepts files up to ` +
      `${limitMb} MB (FTIN_MAX_UPLOAD_MB).`
    : "");
  updateRunButton();
}

function newRunId() {
  const bytes = new Uint8Array(8);
  crypto.getRandomValues(bytes);
  return "page-" + [...bytes].map((b) => b.toString(16).padStart(2, "0")).join("");
}

// Poll GET /runs/{id} while the request runs, to show the model's progress over windows.
function pollProgress(runId) {
  state.polling = setInterval(async () => {
    try {
      const r = await fetch(`/runs/${runId}`);
      if (!r.ok) return;
      const s = await r.json();
      if (s.state === "running" && s.total > 0) {
        setProgress(s.done / s.total, `Running ${s.model}: window ${s.done} of ${s.total}`);
      }
    } catch (_) { /* the main request reports errors */ }
  }, 250);
}

function stopPolling() {
  if (state.polling) clearInterval(state.polling);
  state.polling = null;
}

function runPrediction() {
  const model = $("model-select").value;
  const file = state.file;
  const fileName = file.name;
  const runId = newRunId();
  const form = new FormData();
  form.append("file", state.file, state.file.name);
  const xhr = new XMLHttpRequest();
  xhr.open("POST", `/predict?model=${encodeURIComponent(model)}&run_id=${runId}${alignParam()}${orientationParam()}`);
  xhr.upload.onprogress = (e) => {
    if (e.lengthComputable) setProgress(e.loaded / e.total, `Uploading ${Math.round((100 * e.loaded) / e.total)} %`);
  };
  xhr.upload.onload = () => {
    setProgress(0, "Running the model ...");
    pollProgress(runId);
  };
  xhr.onload = () => {
    stopPolling();
    setProgress(null);
    $("run-button").disabled = false;
    if (xhr.status === 200) {
      state.compared = [];
      state.source = { file };
      showResult(JSON.parse(xhr.responseText), fileName);
    } else {
      hideResult();
      showError(errorText(xhr.status, xhr.responseText));
    }
  };
  xhr.onerror = () => {
    stopPolling();
    setProgress(null);
    $("run-button").disabled = false;
    hideResult();
    showError(errorText(0, ""));
  };
  showError("");
  $("run-button").disabled = true;
  setProgress(0, "Uploading ...");
  xhr.send(form);
}

function fmt(value, digits, scale = 1) {
  return value === null || value === undefined ? "–" : (value * scale).toFixed(digits);
}

// A result whose plot and metrics no longer match the file and model picked: take it away.
function hideResult() {
  $("result").hidden = true;
  state.result = null;
  state.compared = [];
}

const ORIENTATION_WORDS = {
  device: "orientation from the file",
  ground_truth: "orientation from the ground truth",
  estimated: "orientation estimated with the VQF filter",
};
const FRAME_WORDS = {
  ground_truth: "trajectory in the ground truth's frame",
  device_world: "trajectory in the phone's own world frame (no ground truth)",
};

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

function renderPlot() {
  const result = state.result;
  const series = [];
  if (result.ground_truth) {
    series.push({ label: "ground truth", color: TRUTH_COLOR, x: result.ground_truth.x, y: result.ground_truth.y, dashed: true, truth: true });
  }
  for (const r of [result, ...state.compared]) {
    series.push({ label: r.model, color: modelColor(r.model), x: r.trajectory.x, y: r.trajectory.y });
  }
  FtinPlot.render($("plot"), series, $("plot-legend"));
}

// One row per registered metric with a value; the path ratio's row names the lengths it compares.
function metricsRows(result) {
  const m = result.metrics;
  if (!m) return [["Metrics", "no ground truth in the file", "", false]];
  const ratio = ratioMetric();
  const figures = pathFigures();
  const rows = [];
  for (const def of state.metrics) {
    if (figures.includes(def)) continue; // shown inside the path ratio's row
    let text = metricText(def, m[def.name]);
    if (def === ratio && m[def.name] !== null && figures.length === 2) {
      text += ` (${metricText(figures[0], m[figures[0].name])} of ${metricText(figures[1], m[figures[1].name])})`;
    }
    rows.push([def.label, text, def.description, def === ratio && isPathWarning(m)]);
  }
  const headline = headlineMetric();
  if (m.stand_still && headline) {
    const still = metricText(headline, m.stand_still[headline.name]);
    rows.push(["Standing still", `${headline.label} ${still}`, "what a model that never moves scores", false]);
  }
  return rows;
}

function showResult(result, fileName) {
  state.result = result;
  $("result").hidden = false;
  $("expired").hidden = true;
  $("result-caption").textContent = `${fileName || result.sequence} · ${result.model}`;
  renderPlot();

  const table = $("metrics");
  table.textContent = "";
  const rows = metricsRows(result);
  const t = result.trajectory.t;
  const duration = t[t.length - 1] - t[0];
  rows.push(["Duration", `${duration.toFixed(1)} s`, "", false]);
  for (const [name, value, title, flagged] of rows) {
    const tr = table.insertRow();
    tr.insertCell().textContent = name;
    const td = tr.insertCell();
    td.textContent = value;
    td.className = "value";
    if (title) tr.title = title;
    if (flagged) tr.className = "flagged";
  }
  const m = result.metrics;
  let convention = "";
  if (m) {
    const aligned = m.alignment && m.alignment !== "none"; // alignmentText() states how
    const units = "Horizontal errors. Headline ATE: RoNIN's RMS over every coordinate; " +
      "ATE evo: evo's Euclidean RMSE (√2 × ATE); hover a row for its definition.";
    if (aligned) convention = units;
    else if (m.convention === "ronin") {
      convention = `No alignment: the prediction starts at the true start (RoNIN convention). ${units}`;
    } else convention = `Convention: ${m.convention}. ${m.convention_text}`;
    const window = m.rte_window_s || 60;
    if (duration < window) {
      convention += ` This recording is ${duration.toFixed(0)} s, shorter than the ${window} s RTE window: RTE is its whole drift scaled to ${window} s.`;
    }
  }
  const alignedText = m && m.alignment && m.alignment !== "none" ? alignmentText(m) : "";
  $("convention").textContent = [alignedText, convention].filter(Boolean).join(" ");

  fillList($("warnings"), result.warnings);
  fillList($("notes"), result.notes || []);
  $("result-meta").textContent = [
    ORIENTATION_WORDS[result.orientation_source] || `orientation: ${result.orientation_source}`,
    FRAME_WORDS[result.frame] || result.frame,
  ].join(" · ");
  showChoices(result);
  $("download-link").href = result.csv_url;
  const scene = $("scene-link");
  scene.hidden = !state.sceneUrl;
  scene.href = state.sceneUrl || "#";
  scene.dataset.runId = result.run_id;
  renderCompareTable();
}

function fillList(list, items) {
  list.textContent = "";
  for (const text of items) {
    const li = document.createElement("li");
    li.textContent = text;
    list.appendChild(li);
  }
}

// --- runs kept on the server: say so when one has expired ---------------------------------------

function showExpired(message) {
  const box = $("expired");
  box.textContent = message;
  box.hidden = false;
}

async function downloadTrajectory(event) {
  event.preventDefault();
  const link = $("download-link");
  try {
    const r = await fetch(link.getAttribute("href"));
    if (!r.ok) {
      showExpired(errorText(r.status, await r.text()));
      return;
    }
    const name = (r.headers.get("content-disposition") || "").match(/filename="([^"]+)"/);
    const url = URL.createObjectURL(await r.blob());
    const a = document.createElement("a");
    a.href = url;
    a.download = name ? name[1] : "trajectory.csv";
    document.body.appendChild(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10_000);
  } catch (_) {
    showExpired(errorText(0, ""));
  }
}

// Bring this run to the front of the 3D scene, then open it; an expired run opens nothing.
async function openInScene(event) {
  event.preventDefault();
  const link = $("scene-link");
  const runId = link.dataset.runId;
  const tab = window.open("", "_blank"); // opened now, inside the click, so no popup blocker
  try {
    const r = await fetch(`/runs/${runId}/show`, { method: "POST" });
    if (!r.ok) {
      if (tab) tab.close();
      showExpired(errorText(r.status, await r.text()));
      return;
    }
    if (tab) tab.location.href = link.href;
  } catch (_) {
    if (tab) tab.close();
    showExpired(errorText(0, ""));
  }
}

// --- "Compare all models": the other models on the same file, one table like the scene's --------

function renderCompareTable() {
  const table = $("compare-table");
  const rows = [state.result, ...state.compared].filter(Boolean);
  table.hidden = rows.length < 2 && !state.comparing;
  table.textContent = "";
  const head = table.createTHead().insertRow();
  const shown = tableMetrics();
  const header = (d) => (d.display_unit ? `${d.label} ${d.display_unit}` : d.label);
  for (const h of ["model", ...shown.map(header), "time s"]) {
    const th = document.createElement("th");
    th.textContent = h;
    head.appendChild(th);
  }
  const body = table.createTBody();
  for (const r of rows) {
    const tr = body.insertRow();
    tr.className = "done" + (isPathWarning(r.metrics) ? " flagged" : "");
    const m = r.metrics || {};
    const swatch = `<span class="swatch" style="background:${modelColor(r.model)}"></span>`;
    tr.insertCell().innerHTML = swatch;
    tr.cells[0].append(r.model + (isPathWarning(r.metrics) ? " ⚠" : ""));
    const values = shown.map((d) => fmt(m[d.name], d.digits, d.scale));
    for (const v of [...values, r.elapsed_s === undefined ? "–" : r.elapsed_s.toFixed(1)]) {
      const td = tr.insertCell();
      td.textContent = v;
      td.className = "value";
    }
    if (r.warnings && r.warnings.length) tr.title = r.warnings.join("\n");
  }
  const still = state.result && state.result.metrics && state.result.metrics.stand_still;
  if (still && rows.length > 1) {
    const tr = body.insertRow();
    tr.className = "baseline";
    for (const v of ["standing still", ...shown.map((d) => fmt(still[d.name], d.digits, d.scale)), ""]) {
      const td = tr.insertCell();
      td.textContent = v;
    }
  }
}

async function compareModels() {
  const button = $("compare-button");
  const source = state.source;
  const base = state.result;
  if (!source || !base) return;
  button.disabled = true;
  state.comparing = true;
  const others = state.models.map((m) => m.name)
    .filter((name) => name !== base.model && !state.compared.some((r) => r.model === name));
  try {
    for (const [i, name] of others.entries()) {
      setProgress(i / others.length, `Comparing: ${name} (${i + 1} of ${others.length})`);
      const started = performance.now();
      const model = encodeURIComponent(name);
      let r;
      if (source.file) {
        const form = new FormData();
        form.append("file", source.file, source.file.name);
        r = await fetch(`/predict?model=${model}${alignParam()}${orientationParam()}`, { method: "POST", body: form });
      } else {
        r = await fetch(`/sequences/${encodeURIComponent(source.sampleId)}/predict?model=${model}${alignParam()}${orientationParam()}`, { method: "POST" });
      }
      if (state.result !== base) return; // a new prediction replaced this one meanwhile
      if (!r.ok) {
        showError(`${name}: ${errorText(r.status, await r.text())}`);
        continue;
      }
      const result = await r.json();
      result.elapsed_s = (performance.now() - started) / 1000;
      state.compared.push(result);
      renderPlot();
      renderCompareTable();
    }
  } finally {
    state.comparing = false;
    setProgress(null);
    button.disabled = false;
    renderCompareTable();
  }
}

// --- bundled recordings: each with the model trained on that kind of data ----------------------

async function loadSamples() {
  const sequences = await fetch("/sequences").then((r) => r.json());
  const usable = sequences.filter((s) => !s.error && s.has_ground_truth);
  if (!usable.length) return;
  const select = $("sample-select");
  select.textContent = "";
  for (const s of usable) {
    const option = document.createElement("option");
    option.value = s.id;
    option.textContent = `${s.name} (${Math.round(s.duration_s)} s)`;
    option.dataset.model = s.suggested_model || "";
    option.dataset.name = s.name;
    option.dataset.dataset = s.dataset_label || s.dataset;
    select.appendChild(option);
  }
  const describe = () => {
    const o = select.selectedOptions[0];
    $("sample-info").textContent = o ? `${o.dataset.dataset}; model: ${o.dataset.model || "the default"}` : "";
  };
  select.addEventListener("change", describe);
  describe();
  $("samples").hidden = false;
}

async function predictSample() {
  const option = $("sample-select").selectedOptions[0];
  if (!option) return;
  const model = option.dataset.model;
  const button = $("sample-button");
  button.disabled = true;
  showError("");
  setProgress(0, `Running ${model || "the default model"} on ${option.dataset.name} ...`);
  try {
    // No model named: the server runs the sequence's suggested model and says so (model_choice).
    const query = `?${orientationParam().slice(1)}`;
    const r = await fetch(`/sequences/${encodeURIComponent(option.value)}/predict${query}`, { method: "POST" });
    const text = await r.text();
    if (!r.ok) {
      hideResult();
      showError(errorText(r.status, text));
      return;
    }
    state.compared = [];
    state.source = { sampleId: option.value };
    showResult(JSON.parse(text), `${option.dataset.name} (bundled)`);
  } catch (_) {
    hideResult();
    showError(errorText(0, ""));
  } finally {
    setProgress(null);
    button.disabled = false;
  }
}

function setUp() {
  const zone = $("drop-zone");
  $("file-input").addEventListener("change", (e) => pickFile(e.target.files[0]));
  $("align-select").addEventListener("change", hideResult); // numbers scored another way: stale
  $("orientation-select").addEventListener("change", hideResult); // another input: stale
  zone.addEventListener("keydown", (e) => {
    if (e.key === "Enter" || e.key === " ") $("file-input").click();
  });
  for (const name of ["dragenter", "dragover"]) {
    zone.addEventListener(name, (e) => { e.preventDefault(); zone.classList.add("dragging"); });
  }
  for (const name of ["dragleave", "drop"]) {
    zone.addEventListener(name, () => zone.classList.remove("dragging"));
  }
  zone.addEventListener("drop", (e) => {
    e.preventDefault();
    if (e.dataTransfer.files.length) pickFile(e.dataTransfer.files[0]);
  });
  $("run-button").addEventListener("click", runPrediction);
  $("download-link").addEventListener("click", downloadTrajectory);
  $("scene-link").addEventListener("click", openInScene);
  $("compare-button").addEventListener("click", compareModels);
  $("sample-button").addEventListener("click", predictSample);
  loadSamples().catch(() => { /* the sample list is optional */ });
  loadModels().catch(() => showError("Could not load the model list from the server."));
}

setUp();

// --- alignment: the align option of POST /predict, and what was fitted -------------------------
function alignParam() {
  const select = $("align-select");
  return select && select.value ? `&align=${encodeURIComponent(select.value)}` : "";
}

function alignmentText(m) {
  if (!m || !m.alignment) return "";
  const heading = m.heading_deg == null ? "" : ` Fitted heading: ${m.heading_deg.toFixed(1)}°.`;
  const words = {
    none: "Aligned: none (raw, RoNIN).",
    start: `Aligned: start — heading and start fitted on the first ${(m.align_window_s || 0).toFixed(0)} s only; the ground truth is drawn aligned.`,
    se2: "Aligned: SE(2) over the whole trajectory (like evo --align); the ground truth is drawn aligned.",
    se3: "Aligned: SE(3) over the whole trajectory (like evo --align); the ground truth is drawn aligned.",
  };
  return (words[m.alignment] || `Aligned: ${m.alignment}.`) + heading;
}
