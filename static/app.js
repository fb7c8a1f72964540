// The upload page: pick a CSV and a model, POST /predict, show the trajectory, metrics and links.
"use strict";

const PRED_COLOR = "#1f77b4";
const TRUTH_COLOR = "#3c3c3c";
const $ = (id) => document.getElementById(id);

const state = { file: null, sceneUrl: null, polling: null, maxUploadMb: null };

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
  const [health, models] = await Promise.all([
    fetch("/health").then((r) => r.json()),
    fetch("/models").then((r) => r.json()),
  ]);
  state.sceneUrl = sceneHref(health.scene_url);
  state.maxUploadMb = health.max_upload_mb;
  if (state.sceneUrl) {
    $("scene-link-header").href = state.sceneUrl;
    $("scene-link-header").hidden = false;
  }
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
  const runId = newRunId();
  const form = new FormData();
  form.append("file", state.file, state.file.name);
  const xhr = new XMLHttpRequest();
  xhr.open("POST", `/predict?model=${encodeURIComponent(model)}&run_id=${runId}`);
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
      showResult(JSON.parse(xhr.responseText));
    } else {
      showError(errorText(xhr.status, xhr.responseText));
    }
  };
  xhr.onerror = () => {
    stopPolling();
    setProgress(null);
    $("run-button").disabled = false;
    showError(errorText(0, ""));
  };
  showError("");
  $("run-button").disabled = true;
  setProgress(0, "Uploading ...");
  xhr.send(form);
}

function fmt(value, digits) {
  return value === null || value === undefined ? "–" : value.toFixed(digits);
}

function showResult(result) {
  $("result").hidden = false;
  const series = [];
  if (result.ground_truth) {
    series.push({ label: "ground truth", color: TRUTH_COLOR, x: result.ground_truth.x, y: result.ground_truth.y, dashed: true });
  }
  series.push({ label: `${result.model} (predicted)`, color: PRED_COLOR, x: result.trajectory.x, y: result.trajectory.y });
  FtinPlot.render($("plot"), series);

  const table = $("metrics");
  table.textContent = "";
  const rows = result.metrics
    ? [["ATE", `${fmt(result.metrics.ate, 2)} m`], ["RTE", `${fmt(result.metrics.rte, 2)} m`], ["PDE", fmt(result.metrics.pde, 3)]]
    : [["Metrics", "no ground truth in the file"]];
  const t = result.trajectory.t;
  rows.push(["Duration", `${(t[t.length - 1] - t[0]).toFixed(1)} s`]);
  for (const [name, value] of rows) {
    const tr = table.insertRow();
    tr.insertCell().textContent = name;
    const td = tr.insertCell();
    td.textContent = value;
    td.className = "value";
  }

  const warnings = $("warnings");
  warnings.textContent = "";
  for (const w of result.warnings) {
    const li = document.createElement("li");
    li.textContent = w;
    warnings.appendChild(li);
  }
  $("result-meta").textContent =
    `Run ${result.run_id} · orientation: ${result.orientation_source} · frame: ${result.frame}`;
  $("download-link").href = result.csv_url;
  const scene = $("scene-link");
  scene.hidden = !state.sceneUrl;
  scene.href = state.sceneUrl || "#";
  scene.dataset.runId = result.run_id;
}

function setUp() {
  const zone = $("drop-zone");
  $("file-input").addEventListener("change", (e) => pickFile(e.target.files[0]));
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
  // Bring this run to the front of the 3D scene, then let the link open it.
  $("scene-link").addEventListener("click", () => {
    const runId = $("scene-link").dataset.runId;
    if (runId) fetch(`/runs/${runId}/show`, { method: "POST" });
  });
  loadModels().catch(() => showError("Could not load the model list from the server."));
}

setUp();
