// The shown result: plot (with the export's GPS fixes), verdict, metrics, plausibility, messages and
// every download of the run.
"use strict";

const ORIENTATION_WORDS = {
  device: "orientation from the file",
  ground_truth: "orientation from the ground truth",
  estimated: "orientation estimated with the VQF filter",
};
const FRAME_WORDS = {
  ground_truth: "trajectory in the ground truth's frame",
  device_world: "trajectory in the phone's own world frame (no ground truth)",
};

// A result whose plot and metrics no longer match the file and model picked: take it away.
function hideResult() {
  $("result").hidden = true;
  FtinMap.hide(null);
  state.result = null;
  state.compared = [];
}

function median(values) {
  const v = values.filter((x) => x !== null && Number.isFinite(x)).sort((a, b) => a - b);
  return v.length ? v[Math.floor(v.length / 2)] : null;
}

function renderPlot() {
  const result = state.result;
  const series = [];
  if (result.ground_truth) {
    series.push({ label: "ground truth", color: TRUTH_COLOR, x: result.ground_truth.x, y: result.ground_truth.y, dashed: true, truth: true });
  }
  const gps = result.plausibility && result.plausibility.gps;
  if (gps && gps.x.length) {
    const acc = median(gps.accuracy_m);
    const label = `GPS fixes (aligned at the start${acc === null ? "" : `, median accuracy ±${acc.toFixed(0)} m`})`;
    series.push({ label, color: GPS_COLOR, x: gps.x, y: gps.y, gps: true, accuracy: gps.accuracy_m });
  }
  for (const r of [result, ...state.compared]) {
    series.push({ label: displayName(r.model), color: modelColor(r.model), x: r.trajectory.x, y: r.trajectory.y, model: r.model });
  }
  // How sure: the shown result's 2-sigma band and 95 % end circle (the compared runs' would hide the paths).
  const traj = result.trajectory, mine = series.find((s) => s.model === result.model);
  if (mine && traj.cov_xx && traj.cov_xx.length === traj.x.length) {
    mine.band = { t: traj.t, xx: traj.cov_xx, xy: traj.cov_xy, yy: traj.cov_yy };
  }
  if (mine && result.uncertainty && result.uncertainty.end_radius_95_m != null) {
    mine.endRadius = result.uncertainty.end_radius_95_m;
  }
  FtinPlot.render($("plot"), series, $("plot-legend"));
}

// One row per registered metric with a value; the path ratio's row names the lengths it compares.
function metricsRows(result) {
  const m = result.metrics;
  if (!m) return [["Metrics", "no ground truth in the file: see the plausibility figures", "", false]];
  const ratio = ratioMetric();
  const figures = pathFigures();
  const rows = [];
  for (const def of state.metrics) {
    if (figures.includes(def)) continue; // shown inside the path ratio's row
    let text = metricText(def, m[def.name]);
    if (def === ratio && m[def.name] !== null && figures.length === 2) {
      text += ` (${metricText(figures[0], m[figures[0].name])} of ${metricText(figures[1], m[figures[1].name])})`;
    }
    const flagged = (def === ratio && isPathWarning(m)) || (def === headlineMetric() && isWorseThanStill(m));
    rows.push([def.label, text, def.description, flagged]);
  }
  const headline = headlineMetric();
  if (m.stand_still && headline) {
    const still = metricText(headline, m.stand_still[headline.name]);
    rows.push(["Standing still", `${headline.label} ${still}`, "what a model that never moves scores", false]);
  }
  return rows;
}

function fillTable(table, rows) {
  table.textContent = "";
  for (const [name, value, title, flagged] of rows) {
    const tr = table.insertRow();
    tr.insertCell().textContent = name;
    const td = tr.insertCell();
    td.textContent = value;
    td.className = "value";
    if (title) tr.title = title;
    if (flagged) tr.className = "flagged";
  }
}

// The walk's verdict (ok / check / implausible): the card's one banner, coloured by its level, with
// its reasons listed beneath it (each figure said once: the standing-still comparison is among them).
// Made here, so the card needs no edit in index.html. A result without one (an older answer) keeps
// the standing-still sentence as a plain line above the metrics.
const VERDICT_MARKS = { ok: "✓", check: "⚠", implausible: "✗" };

function showWalkVerdict(verdict) {
  let line = $("walk-verdict");
  if (!line) {
    line = document.createElement("p");
    line.id = "walk-verdict";
    line.setAttribute("role", "status");
    const reasons = document.createElement("ul");
    reasons.id = "walk-reasons";
    reasons.className = "walk-reasons";
    $("result-title").after(line, reasons);
  }
  const reasons = $("walk-reasons");
  line.hidden = reasons.hidden = !verdict;
  if (!verdict) return;
  line.className = `walk-verdict level-${verdict.level}`;
  line.dataset.level = verdict.level;
  line.textContent = `${VERDICT_MARKS[verdict.level] || ""} ${verdict.says}`.trim();
  line.title = verdict.reasons.map((r) => `${r.level}: ${r.says}`).join("\n");
  // The reasons the banner's line leaves out (a reason of another level than the verdict's own).
  reasons.textContent = "";
  for (const r of verdict.reasons.filter((x) => x.level !== "ok" && !verdict.says.includes(x.says))) {
    const li = document.createElement("li");
    li.className = `level-${r.level}`;
    li.textContent = r.says;
    reasons.appendChild(li);
  }
  reasons.hidden = !reasons.children.length;
}

// Worse than standing still, in words: only where no walk verdict says it already (one banner).
function showVerdict(m, verdict) {
  const box = $("verdict");
  const text = m && m.standing_still_text;
  box.hidden = !text || !!verdict;
  box.className = "verdict-line small" + (isWorseThanStill(m) ? " flagged" : "");
  box.textContent = text ? (isWorseThanStill(m) ? "⚠ " : "") + text : "";
  $("scope-note").textContent = (m && m.scope_note) || "";
  $("scope-note").hidden = !(m && m.scope_note);
}

// Figures that need no ground truth: a phone walk's only check (and GPS where the export has it).
function showPlausibility(p) {
  const figures = p ? [...p.figures, ...(p.gps ? p.gps.figures : [])] : [];
  $("plausibility").hidden = !figures.length;
  const counted = ["steps", "fixes", "deg", "steps/min"];
  const label = (name) => name.replace(/_/g, " ").replace(/^gps/, "GPS").replace(/^./, (c) => c.toUpperCase());
  fillTable($("plausibility-table"), figures.map((f) => [
    label(f.name),
    f.value === null ? "–" : `${f.value.toFixed(counted.includes(f.unit) ? 0 : 2)} ${f.unit}`,
    f.description,
    false,
  ]));
  fillList($("plausibility-warnings"), p ? p.warnings : []);
}

function convention(m, duration) {
  if (!m) return "";
  const aligned = m.alignment && m.alignment !== "none"; // alignmentText() states how
  const units = "Horizontal errors. Headline ATE: RoNIN's RMS over every coordinate; " +
    "ATE evo: evo's Euclidean RMSE (√2 × ATE); hover a row for its definition.";
  let text = units;
  if (!aligned && m.convention === "ronin") {
    text = `No alignment: the prediction starts at the true start (RoNIN convention). ${units}`;
  } else if (!aligned) text = `Convention: ${m.convention}. ${m.convention_text}`;
  const window = m.rte_window_s || 60;
  if (duration < window) {
    text += ` This recording is ${duration.toFixed(0)} s, shorter than the ${window} s RTE window: RTE is its whole drift scaled to ${window} s.`;
  }
  return [aligned ? alignmentText(m) : "", text].filter(Boolean).join(" ");
}

// How sure: the radius around the predicted end that holds the true end with 95 % (docs/metrics.md,
// "How sure is it"), under the verdict; how it was calibrated in its tooltip. No radius where the
// server withholds it (an implausible walk: uncertainty.withheld_reason says why); with ground truth,
// whether the true end lies inside (uncertainty.true_end_inside).
function endRadiusText(uncertainty) {
  const r = uncertainty.end_radius_95_m;
  if (r === null || r === undefined) {
    const why = uncertainty.withheld_reason || "";
    return why && why[0].toUpperCase() + why.slice(1);
  }
  let text = `Ends within ${r >= 10 ? r.toFixed(0) : r.toFixed(1)} m of here (95 %)`;
  if (uncertainty.true_end_inside === true) text += "; the true end lies inside this circle.";
  else if (uncertainty.true_end_inside === false) text += ", but the true end lies outside it: this walk is read worse than the circle claims.";
  return text;
}

function showUncertainty(uncertainty, verdict) {
  let line = $("end-radius");
  if (!line) {
    line = document.createElement("p");
    line.id = "end-radius";
    line.className = "end-radius";
    ($("walk-reasons") || $("result-title")).after(line);
  }
  let text = uncertainty ? endRadiusText(uncertainty) : "";
  // The banner names the circle already: the line only adds whether the true end lies inside.
  if (verdict && verdict.says.includes("(95 %)") && uncertainty && uncertainty.true_end_inside == null) text = "";
  line.hidden = !text;
  line.textContent = text;
  line.dataset.inside = uncertainty && uncertainty.true_end_inside != null ? String(uncertainty.true_end_inside) : "";
  line.title = uncertainty ? uncertainty.calibration || "" : "";
}

// Under the plot: the loop closure (a walk back to its start), the speed over time with the steps as
// ticks, and the heading error over time where the answer has one (ground truth).
function loopClosureText(p) {
  const loop = p && p.loop_closure;
  if (!loop) return "";
  const gap = loop.gap_m >= 10 ? loop.gap_m.toFixed(0) : loop.gap_m.toFixed(1);
  return `The loop closes within ${gap} m (${(100 * loop.share).toFixed(1)} % of the ${loop.path_m.toFixed(0)} m path).`;
}

function showTimeCharts(result) {
  $("loop-closure").textContent = loopClosureText(result.plausibility);
  $("loop-closure").hidden = !$("loop-closure").textContent;
  const traj = result.trajectory;
  const speed = FtinCharts.speed(traj.t, traj.x, traj.y);
  const steps = (result.plausibility && result.plausibility.step_times_s) || [];
  $("speed-box").hidden = !speed.t.length;
  $("steps-caption").textContent = steps.length ? `; ticks: the ${steps.length} steps the accelerometer counted` : "";
  if (speed.t.length) {
    FtinCharts.timeSeries($("speed-chart"), {
      series: [{ t: speed.t, v: speed.v, color: modelColor(result.model), label: displayName(result.model) }],
      ticks: steps, yLabel: "m/s", yMin: 0, minSpan: 1.5, // a walk's 1-1.5 m/s fills it
    });
  }
  const heading = result.heading_error;
  $("heading-box").hidden = !(heading && heading.t_s && heading.t_s.length);
  if (!$("heading-box").hidden) {
    const after = heading.median_after_2min_deg;
    $("heading-caption").textContent = `Heading error against the ground truth (median over ${heading.window_s} s ` +
      `windows: ${heading.median_deg.toFixed(1)}°` + (after == null ? "" : `, after the first 2 min ${after.toFixed(1)}°`) + ")";
    FtinCharts.timeSeries($("heading-chart"), {
      series: [{ t: heading.t_s, v: heading.deg, color: modelColor(result.model), label: displayName(result.model) }],
      yLabel: "°", yMin: 0, minSpan: 10,
    });
  }
}

// Which filter ran (docs/filter.md): a line only where the EKF did.
function showFilter(result) {
  const box = $("filter-text");
  const ekf = result && result.filter === "ekf";
  box.hidden = !ekf;
  box.textContent = ekf
    ? "Filter: EKF — the model re-read on the filter's tilt (the model's velocity is its measurement; the notes say where its tilt was not used)."
    : "";
}

function showResult(result, label) {
  state.result = result;
  $("result").hidden = false;
  $("expired").hidden = true;
  $("result-caption").textContent = `${label || result.sequence} · ${displayName(result.model)}`;
  showWalkVerdict(result.verdict);
  showUncertainty(result.uncertainty, result.verdict);
  showFilter(result);
  renderPlot();
  showTimeCharts(result);
  FtinMap.show(result, anchoredOnGps(result));
  showProfileBox(result);
  $("delete-run").dataset.runId = result.run_id;
  const t = result.trajectory.t;
  const duration = t[t.length - 1] - t[0];
  const m = result.metrics;
  showVerdict(m, result.verdict);
  fillTable($("metrics"), metricsRows(result)); // the duration is among the plausibility figures
  $("convention").textContent = convention(m, duration);
  showPlausibility(result.plausibility);
  // Each message once: the plausibility panel shows its own warnings.
  // and a warning the verdict's banner or its reasons already say ("worse than standing still") goes.
  const own = new Set(result.plausibility ? result.plausibility.warnings : []);
  const said = result.verdict
    ? [result.verdict.says, ...result.verdict.reasons.map((r) => r.says)].map((x) => x.toLowerCase()) : [];
  const new_ = (w) => !said.some((x) => x.length > 20 && w.toLowerCase().includes(x));
  fillList($("warnings"), result.warnings.filter((w) => !own.has(w) && new_(w)));
  fillList($("notes"), result.notes || []);
  $("result-meta").textContent = [
    ORIENTATION_WORDS[result.orientation_source] || `orientation: ${result.orientation_source}`,
    FRAME_WORDS[result.frame] || result.frame,
    result.z_note || "",
  ].filter(Boolean).join(" · ");
  showChoices(result);
  showDownloads(result);
  const scene = $("scene-link");
  scene.hidden = !state.sceneUrl;
  scene.href = state.sceneUrl || "#";
  scene.dataset.runId = result.run_id;
  renderCompareTable();
}

// --- downloads: CSV, TUM, ground truth TUM, metrics JSON, and how to compare them in evo ----------

function showDownloads(result) {
  $("download-link").href = result.csv_url;
  $("download-tum").href = result.tum_url;
  $("download-metrics").href = result.metrics_url;
  $("download-gt").hidden = !result.ground_truth_tum_url;
  $("download-gt").href = result.ground_truth_tum_url || "#";
  $("evo-line").hidden = !result.ground_truth_tum_url;
  showExportDownloads(result); // compare.js: GPX / GeoJSON, the clock of CSV and TUM
}

function showExpired(message) {
  const box = $("expired");
  box.textContent = message;
  box.hidden = false;
}

// Fetch first, so that a run dropped from memory says so instead of saving an error page.
async function download(event) {
  event.preventDefault();
  const link = event.currentTarget;
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
    a.download = name ? name[1] : link.getAttribute("download") || "download";
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
  const tab = window.open("", "_blank"); // opened now, inside the click, so no popup blocker
  try {
    const r = await fetch(`/runs/${link.dataset.runId}/show`, { method: "POST" });
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
