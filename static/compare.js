// "Compare all models": the other models on the same file, one table like the scene's, each flag
// said in words.
"use strict";

function renderCompareTable() {
  const table = $("compare-table");
  const rows = [state.result, ...state.compared].filter(Boolean);
  table.hidden = rows.length < 2 && !state.comparing;
  $("compare-legend").hidden = table.hidden;
  table.textContent = "";
  const head = table.createTHead().insertRow();
  const shown = tableMetrics();
  const header = (d) => (d.display_unit ? `${d.label} ${d.display_unit}` : d.label);
  for (const h of ["model", ...shown.map(header), "flag", "time s"]) {
    const th = document.createElement("th");
    th.textContent = h;
    head.appendChild(th);
  }
  const body = table.createTBody();
  for (const r of rows) {
    const tr = body.insertRow();
    const words = flagWords(r.metrics);
    tr.className = "done" + (words.length ? " flagged" : "") + (isWorseThanStill(r.metrics) ? " worse" : "");
    tr.dataset.model = r.model;
    const m = r.metrics || {};
    const swatch = `<span class="swatch" style="background:${modelColor(r.model)}"></span>`;
    tr.insertCell().innerHTML = swatch;
    tr.cells[0].append(displayName(r.model) + (words.length ? " ⚠" : ""));
    tr.cells[0].title = r.model; // the API name
    const values = shown.map((d) => fmt(m[d.name], d.digits, d.scale));
    for (const v of [...values, words.join(", "), r.elapsed_s === undefined ? "–" : r.elapsed_s.toFixed(1)]) {
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
    for (const v of ["standing still", ...shown.map((d) => fmt(still[d.name], d.digits, d.scale)), "", ""]) {
      const td = tr.insertCell();
      td.textContent = v;
    }
  }
  const worse = rows.filter((r) => isWorseThanStill(r.metrics)).length;
  $("compare-summary").textContent = rows.length > 1 && still
    ? `${worse} of ${rows.length} models are worse than standing still on this recording.` : "";
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
      setProgress(i / others.length, `Comparing: ${displayName(name)} (${i + 1} of ${others.length})`);
      const started = performance.now();
      const model = encodeURIComponent(name);
      let r;
      if (source.file) {
        const form = new FormData();
        form.append("file", source.file, source.file.name);
        r = await fetch(`/predict?model=${model}${alignParam()}${orientationParam()}`, { method: "POST", body: form });
      } else if (source.sampleId) {
        r = await fetch(`/sequences/${encodeURIComponent(source.sampleId)}/predict?model=${model}${alignParam()}${orientationParam()}`, { method: "POST" });
      } else {
        showError("This kept run's file is not on the page: upload it again to compare models on it.");
        return;
      }
      if (state.result !== base) return; // a new prediction replaced this one meanwhile
      if (!r.ok) {
        showError(`${displayName(name)}: ${errorText(r.status, await r.text())}`);
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
    refreshKeptRuns();
  }
}
