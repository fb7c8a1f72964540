// "Compare all models": the other models on the same file, one table like the scene's, each flag
// said in words. The table is the server's (GET /compare?ids=...: metrics where the recording has
// ground truth, plausibility figures for every walk), so the CSV and ZIP links give the same rows.
// Click a column header to sort by it (again: the other way). Also here: the exports of the shown
// run beyond the basic four (GPX / GeoJSON for a walk with GPS, times on the phone's clock).
"use strict";

// The last table, {key, dir}, the latest fetch, and why a model of the last compare-all could not run.
const compareView = { table: null, sort: null, token: 0, failure: "" };

function comparedRuns() {
  return [state.result, ...state.compared].filter(Boolean);
}

// Fetch the table of the runs on the page, then draw it (a newer call wins over an older one).
function renderCompareTable() {
  const rows = comparedRuns();
  const hidden = rows.length < 2 && !state.comparing;
  $("compare-table").hidden = hidden;
  $("compare-legend").hidden = hidden;
  $("compare-downloads").hidden = true;
  const token = ++compareView.token;
  if (hidden) {
    $("compare-table").textContent = "";
    $("compare-summary").textContent = "";
    return;
  }
  const ids = rows.map((r) => r.run_id).join(",");
  fetch(`/compare?ids=${encodeURIComponent(ids)}`)
    .then(async (r) => {
      if (token !== compareView.token) return;
      if (!r.ok) {
        $("compare-summary").textContent = errorText(r.status, await r.text());
        return;
      }
      compareView.table = await r.json();
      drawCompareTable();
    })
    .catch(() => { if (token === compareView.token) $("compare-summary").textContent = errorText(0, ""); });
}

// Sort keys: a column's value, or the model's shown name; missing values last either way.
function sortedRows(table) {
  const rows = [...table.rows];
  const sort = compareView.sort;
  if (!sort) return rows;
  const value = (row) => (sort.key === "model" ? displayName(row.model) : row.values[sort.key]);
  return rows.sort((a, b) => {
    const x = value(a), y = value(b);
    if (x === null || x === undefined) return y === null || y === undefined ? 0 : 1;
    if (y === null || y === undefined) return -1;
    const order = typeof x === "string" ? x.localeCompare(y) : x - y;
    return sort.dir === "desc" ? -order : order;
  });
}

function sortBy(key) {
  const same = compareView.sort && compareView.sort.key === key;
  compareView.sort = { key, dir: same && compareView.sort.dir === "asc" ? "desc" : "asc" };
  drawCompareTable();
}

function drawCompareTable() {
  const data = compareView.table;
  const table = $("compare-table");
  table.textContent = "";
  if (!data) return;
  const head = table.createTHead().insertRow();
  const header = (c) => (c.unit ? `${c.label} ${c.unit}` : c.label);
  const sortable = [{ key: "model", label: "model", unit: "" }, ...data.columns];
  for (const c of [...sortable, { label: "verdict" }, { label: "flag" }, { label: "time s" }]) {
    const th = document.createElement("th");
    th.textContent = header(c);
    if (c.key) {
      const sort = compareView.sort && compareView.sort.key === c.key ? compareView.sort.dir : null;
      th.dataset.key = c.key;
      th.title = `${c.description || "Model"} (click to sort)`;
      th.style.cursor = "pointer";
      th.setAttribute("aria-sort", sort === "asc" ? "ascending" : sort === "desc" ? "descending" : "none");
      if (sort) th.textContent += sort === "asc" ? " ▲" : " ▼";
      th.addEventListener("click", () => sortBy(c.key));
    }
    head.appendChild(th);
  }
  const elapsed = Object.fromEntries(comparedRuns().map((r) => [r.run_id, r.elapsed_s]));
  const body = table.createTBody();
  const rows = sortedRows(data);
  for (const r of rows) {
    const tr = body.insertRow();
    tr.className = "done" + (r.flags.length ? " flagged" : "") + (r.worse_than_standing_still ? " worse" : "");
    tr.dataset.model = r.model;
    tr.dataset.runId = r.run_id;
    const swatch = `<span class="swatch" style="background:${modelColor(r.model)}"></span>`;
    tr.insertCell().innerHTML = swatch;
    tr.cells[0].append(displayName(r.model) + (r.flags.length ? " ⚠" : ""));
    tr.cells[0].title = r.model; // the API name
    const values = data.columns.map((c) => fmt(r.values[c.key], c.digits, c.scale));
    const seconds = elapsed[r.run_id];
    for (const v of [...values, r.verdict || "–", r.flags.join(", "), seconds === undefined ? "–" : seconds.toFixed(1)]) {
      const td = tr.insertCell();
      td.textContent = v;
      td.className = "value";
    }
    tr.cells[values.length + 1].title = r.verdict_says || ""; // the verdict's line
    if (r.warnings.length) tr.title = r.warnings.join("\n");
  }
  const still = data.stand_still;
  if (still && rows.length > 1) {
    const tr = body.insertRow();
    tr.className = "baseline";
    const values = data.columns.map((c) => (c.key in still ? fmt(still[c.key], c.digits, c.scale) : ""));
    for (const v of ["standing still", ...values, "", "", ""]) tr.insertCell().textContent = v;
  }
  $("compare-summary").textContent = rows.length > 1 ? [data.summary, compareView.failure].filter(Boolean).join(" ") : "";
  // The downloads list the rows in the order shown.
  const ids = encodeURIComponent(rows.map((r) => r.run_id).join(","));
  $("compare-csv").href = `/compare.csv?ids=${ids}`;
  $("compare-zip").href = `/compare.zip?ids=${ids}`;
  $("compare-downloads").hidden = rows.length < 2 || state.comparing;
}

async function compareModels() {
  const button = $("compare-button");
  const source = state.source;
  const base = state.result;
  if (!base) {
    $("compare-summary").textContent = "No result is shown: predict a recording first, then compare every model on it.";
    return;
  }
  button.disabled = true;
  state.comparing = true;
  let failure = "";
  compareView.failure = "";
  const others = state.models.map((m) => m.name)
    .filter((name) => name !== base.model && !state.compared.some((r) => r.model === name));
  try {
    for (const [i, name] of others.entries()) {
      setProgress(i / others.length, `Comparing: ${displayName(name)} (${i + 1} of ${others.length})`);
      const started = performance.now();
      const model = `${encodeURIComponent(name)}&group=${encodeURIComponent(base.run_id)}`; // listed under base
      let r;
      if (source && source.file) {
        const form = new FormData();
        form.append("file", source.file, source.file.name);
        r = await fetch(`/predict?model=${model}${alignParam()}${orientationParam()}${profileParam()}`, { method: "POST", body: form });
      } else if (source && source.sampleId) {
        r = await fetch(`/sequences/${encodeURIComponent(source.sampleId)}/predict?model=${model}${alignParam()}${orientationParam()}${profileParam()}`, { method: "POST" });
      } else {
        // A run opened from its address (/runs/...): its file is not on the page, but the server keeps
        // the recording with the run; it answers why where it cannot (expired: 410).
        r = await fetch(`/runs/${encodeURIComponent(base.run_id)}/predict?model=${model}${alignParam()}${orientationParam()}${profileParam()}`, { method: "POST" });
      }
      if (state.result !== base) return; // a new prediction replaced this one meanwhile
      if (!r.ok) {
        failure = `${displayName(name)}: ${errorText(r.status, await r.text())}`;
        compareView.failure = failure;
        $("compare-summary").textContent = failure; // beside the button, where the user looks
        if (r.status === 404 || r.status === 410) return; // the recording is gone: no model can run on it
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
    if (failure && !state.compared.length) $("compare-summary").textContent = failure; // not cleared
    refreshKeptRuns();
  }
}

// --- exports of the shown run: GPX / GeoJSON (a walk with GPS), times on the phone's clock ---------

// GPS anchors a walk when some fixes fall inside it: then the distance to GPS is a number.
function anchoredOnGps(result) {
  const gps = result.plausibility && result.plausibility.gps;
  const rms = gps && gps.figures.find((f) => f.name === "gps_distance_rms");
  return !!(rms && rms.value !== null);
}

// Called by showDownloads (result.js) after it has set the four basic links.
function showExportDownloads(result) {
  const base = `/runs/${result.run_id}`;
  const geo = anchoredOnGps(result);
  for (const [id, href] of [["download-gpx", `${base}/trajectory.gpx`], ["download-geojson", `${base}/trajectory.geojson`]]) {
    $(id).hidden = !geo;
    $(id).href = geo ? href : "#";
  }
  const epoch = $("epoch-clock").checked ? "?clock=epoch" : "";
  $("download-link").href = result.csv_url + epoch;
  $("download-tum").href = result.tum_url + epoch;
}

for (const id of ["compare-csv", "compare-zip", "download-gpx", "download-geojson"]) {
  $(id).addEventListener("click", download);
}
$("epoch-clock").addEventListener("change", () => { if (state.result) showExportDownloads(state.result); });
