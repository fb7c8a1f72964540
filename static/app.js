// The upload page: pick a file (or a bundled recording) and a model, POST /predict, show the result
// (result.js), compare every model (compare.js), list the kept runs (runs.js).
"use strict";

async function loadModels() {
  const [health, models, metrics] = await Promise.all([
    fetch("/health").then((r) => r.json()),
    fetch("/models").then((r) => r.json()),
    fetch("/metrics").then((r) => r.json()),
  ]);
  state.metrics = metrics;
  state.sceneUrl = sceneHref(health.scene_url);
  state.mapTiles = health.map_tiles || "";
  state.mapAttribution = health.map_attribution || "";
  state.maxUploadMb = health.max_upload_mb;
  if (state.sceneUrl) {
    $("scene-link-header").href = state.sceneUrl;
    $("scene-link-header").hidden = false;
  }
  state.models = models;
  state.defaultWhy = health.default_model_why;
  const select = $("model-select");
  select.textContent = "";
  // First and selected: no model named, the server chooses (choices.js says who chose, and why).
  const fallback = models.find((m) => m.default);
  if (fallback) select.appendChild(defaultOption(fallback, health.default_model_why));
  for (const m of models) {
    const option = document.createElement("option");
    option.value = m.name;
    option.textContent = m.display_name === m.name ? m.name : `${m.display_name} (${m.name})`;
    option.title = `${m.display_name} (API name ${m.name})` + (m.summary ? `: ${m.summary}` : "");
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
  const picked = $("model-select").value;
  const m = models.find((x) => (picked ? x.name === picked : x.default));
  // The model in at most 25 words (GET /models' summary) where the server gives one.
  $("model-info").textContent = (picked ? "" : defaultModelWords()) + (m
    ? (m.summary ? `${m.summary} ` : "") +
      `${m.architecture}, window ${m.window} samples (${(m.window / m.imu_rate_hz).toFixed(2)} s at ${m.imu_rate_hz} Hz)` +
      (m.trained_on && !m.summary ? `, trained on ${m.trained_on}` : "") + `; API name ${m.name}`
    : "");
}

function updateRunButton() {
  $("run-button").disabled = !(state.file && state.models.length);
}

function pickFile(file) {
  state.userActed = true;
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
        setProgress(s.done / s.total, `Running ${displayName(s.model)}: window ${s.done} of ${s.total}`);
      }
    } catch (_) { /* the main request reports errors */ }
  }, 250);
}

function stopPolling() {
  if (state.polling) clearInterval(state.polling);
  state.polling = null;
}

function runPrediction() {
  state.userActed = true;
  const file = state.file;
  const runId = newRunId();
  const form = new FormData();
  form.append("file", file, file.name);
  if (filterPicked()) form.append("filter", "ekf"); // only when asked: the answer is otherwise as before
  const xhr = new XMLHttpRequest();
  xhr.open("POST", `/predict?run_id=${runId}${modelParam()}${alignParam()}${orientationParam()}${profileParam()}`);
  xhr.upload.onprogress = (e) => {
    if (e.lengthComputable) setProgress(e.loaded / e.total, `Uploading ${Math.round((100 * e.loaded) / e.total)} %`);
  };
  xhr.upload.onload = () => {
    setProgress(0, "Running the model ...");
    pollProgress(runId);
  };
  const finished = () => {
    stopPolling();
    setProgress(null);
    $("run-button").disabled = false;
    refreshKeptRuns();
  };
  xhr.onload = () => {
    finished();
    if (xhr.status === 200) {
      state.compared = [];
      state.source = { file };
      showResult(JSON.parse(xhr.responseText), file.name);
      rememberRun(runId); // the run's own address (runs.js)
    } else {
      hideResult();
      showError(errorText(xhr.status, xhr.responseText));
    }
  };
  xhr.onerror = () => {
    finished();
    hideResult();
    showError(errorText(0, ""));
  };
  showError("");
  $("run-button").disabled = true;
  setProgress(0, "Uploading ...");
  xhr.send(form);
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
    $("sample-info").textContent = o
      ? `${o.dataset.dataset}; model: ${o.dataset.model ? displayName(o.dataset.model) : "the default"}` : "";
  };
  select.addEventListener("change", describe);
  describe();
  $("samples").hidden = false;
}

async function predictSample({ auto = false } = {}) {
  if (!auto) state.userActed = true;
  const option = $("sample-select").selectedOptions[0];
  if (!option) return;
  const model = option.dataset.model;
  const button = $("sample-button");
  button.disabled = true;
  showError("");
  setProgress(0, `Running ${model ? displayName(model) : "the default model"} on ${option.dataset.name} ...`);
  try {
    // No model named: the server runs the sequence's suggested model and says so (model_choice).
    const query = `?${orientationParam().slice(1)}${filterPicked() ? "&filter=ekf" : ""}${profileParam()}`;
    const r = await fetch(`/sequences/${encodeURIComponent(option.value)}/predict${query}`, { method: "POST" });
    const text = await r.text();
    if (auto && state.userActed) return; // the user picked something else meanwhile
    if (!r.ok) {
      hideResult();
      showError(errorText(r.status, text));
      return;
    }
    state.compared = [];
    state.source = { sampleId: option.value };
    const result = JSON.parse(text);
    showResult(result, `${option.dataset.name} (bundled)`);
    if (!auto) rememberRun(result.run_id);
  } catch (_) {
    if (auto && state.userActed) return;
    hideResult();
    showError(errorText(0, ""));
  } finally {
    if (!(auto && state.userActed)) setProgress(null);
    button.disabled = false;
    refreshKeptRuns();
  }
}

// --- the filter (docs/filter.md): sent only when the EKF is picked; the result says which ran ------

function filterPicked() {
  return $("filter-select").value === "ekf";
}

function setUp() {
  const zone = $("drop-zone");
  $("file-input").addEventListener("change", (e) => pickFile(e.target.files[0]));
  $("align-select").addEventListener("change", hideResult); // numbers scored another way: stale
  $("orientation-select").addEventListener("change", hideResult); // another input: stale
  $("filter-select").addEventListener("change", hideResult); // another estimate: stale
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
  for (const id of ["download-link", "download-tum", "download-gt", "download-metrics"]) {
    $(id).addEventListener("click", download);
  }
  $("scene-link").addEventListener("click", openInScene);
  $("compare-button").addEventListener("click", compareModels);
  $("plot-reset").addEventListener("click", () => FtinPlot.reset($("plot")));
  $("delete-run").addEventListener("click", (e) => deleteRun(e.currentTarget.dataset.runId, $("expired")));
  $("sample-button").addEventListener("click", () => predictSample());
  const models = loadModels().catch(() => showError("Could not load the model list from the server."));
  const samples = loadSamples().catch(() => { /* the sample list is optional */ });
  Promise.all([models, samples]).then(() => {
    $("sample-select").dispatchEvent(new Event("change")); // its model's name, now that names are known
    refreshKeptRuns();
    return showFirstScreen();
  }).catch(() => { /* the first screen is a courtesy */ });
}

setUp();
