// Runs stored on the server (GET /runs, newest first, surviving restarts): every upload listed with
// its downloads, a compare-all as one entry with its runs beneath, one click to show a run again;
// each run's own address (/runs/{id}: the page opens on it, and moves there when a run is shown);
// and the first screen, which opens on a bundled sample's result as the 3D scene does.
"use strict";

const SOURCE_WORDS = {
  upload: "uploaded", json: "sent as JSON", sequence: "bundled", viser: "3D scene", live: "live",
};
const KEPT_LIMIT = 100; // the newest runs listed on the page (GET /runs?offset= pages further)

function downloadLink(href, text) {
  const a = document.createElement("a");
  a.href = href;
  a.textContent = text;
  a.className = "download";
  a.addEventListener("click", download);
  return a;
}

let keptRequest = 0; // answers that arrive out of order must not overwrite a newer list

function keptItem(run) {
  const li = document.createElement("li");
  li.dataset.runId = run.run_id;
  const name = document.createElement("a");
  name.className = "kept-name";
  name.href = run.page_url; // its own address: a middle click opens it in a new tab
  name.textContent = `${run.sequence} · ${displayName(run.model)}`;
  name.addEventListener("click", (e) => {
    if (e.ctrlKey || e.metaKey || e.shiftKey || e.button !== 0) return;
    e.preventDefault();
    showKeptRun(run);
  });
  const source = document.createElement("span");
  source.className = "muted small";
  source.textContent = ` (${SOURCE_WORDS[run.source] || run.source}, ${new Date(run.created_s * 1000).toLocaleString()})` +
    (run.worse_than_standing_still ? " ⚠ worse than standing still" : "");
  li.append(name, source, " · ");
  const links = [[run.csv_url, "CSV"], [run.tum_url, "TUM"], [run.ground_truth_tum_url, "ground truth TUM"], [run.metrics_url, "metrics JSON"]];
  for (const [i, [href, text]] of links.filter(([href]) => href).entries()) {
    if (i) li.append(" ");
    li.appendChild(downloadLink(href, text));
  }
  const remove = document.createElement("button");
  remove.type = "button";
  remove.className = "link-button delete-button-small";
  remove.textContent = "delete";
  remove.title = "Delete this run from the server";
  remove.addEventListener("click", () => deleteRun(run.run_id, $("kept-error")));
  li.append(" · ", remove);
  return li;
}

// DELETE /runs/{id}: gone from the server (its downloads and address too). The server's own words
// where it refuses (a server without the route answers 405: said as it is).
async function deleteRun(runId, errorBox) {
  if (!runId || !window.confirm("Delete this run from the server? Its downloads and address stop working.")) return;
  errorBox.hidden = true;
  try {
    const r = await fetch(`/runs/${encodeURIComponent(runId)}`, { method: "DELETE" });
    if (!r.ok) {
      errorBox.textContent = `Could not delete the run: ${errorText(r.status, await r.text())}`;
      errorBox.hidden = false;
      return;
    }
  } catch (_) {
    errorBox.textContent = `Could not delete the run: ${errorText(0, "")}`;
    errorBox.hidden = false;
    return;
  }
  if (state.result && state.result.run_id === runId) {
    hideResult();
    if (runIdInUrl() === runId) history.pushState({}, "", "/");
  }
  refreshKeptRuns();
}

// A compare-all's runs carry the run_id it started from (group): listed beneath that run, or
// under a heading of their own when that run is not in the list (removed, or on a later page).
function keptEntries(runs) {
  const byId = new Map(runs.map((r) => [r.run_id, r]));
  const members = new Map();
  for (const r of runs) {
    if (!r.group) continue;
    if (!members.has(r.group)) members.set(r.group, []);
    members.get(r.group).push(r);
  }
  const entries = [];
  const placed = new Set();
  for (const r of runs) {
    if (r.group && byId.has(r.group)) continue; // beneath its base
    if (r.group) {
      if (placed.has(r.group)) continue;
      placed.add(r.group);
      entries.push({ base: null, group: r.group, members: members.get(r.group) });
    } else {
      entries.push({ base: r, group: r.run_id, members: members.get(r.run_id) || [] });
    }
  }
  return entries;
}

async function refreshKeptRuns() {
  const ticket = ++keptRequest;
  let runs, total;
  try {
    const r = await fetch(`/runs?limit=${KEPT_LIMIT}`);
    runs = await r.json();
    total = Number(r.headers.get("x-total-count") || runs.length);
  } catch (_) {
    return;
  }
  if (ticket !== keptRequest) return;
  const list = $("kept-list");
  list.textContent = "";
  $("kept").hidden = !runs.length;
  for (const entry of keptEntries(runs)) {
    let li;
    if (entry.base) {
      li = keptItem(entry.base);
    } else {
      li = document.createElement("li");
      li.dataset.group = entry.group;
      li.textContent = `${entry.members[0].sequence}: compare of ${entry.members.length} models`;
    }
    if (entry.members.length) {
      li.classList.add("kept-compare");
      const caption = document.createElement("div");
      caption.className = "muted small";
      caption.textContent = `compared with ${entry.members.length} other model${entry.members.length > 1 ? "s" : ""}:`;
      const sub = document.createElement("ul");
      sub.className = "kept-list kept-group";
      for (const m of entry.members) sub.appendChild(keptItem(m));
      li.append(caption, sub);
    }
    list.appendChild(li);
  }
  $("kept-more").textContent = total > runs.length
    ? `The newest ${runs.length} of ${total} stored runs are listed (GET /runs?offset=${runs.length} lists more).` : "";
}

// --- each run's address: /runs/{id} opens the page on it ----------------------------------------

function runIdInUrl() {
  const m = window.location.pathname.match(/^\/runs\/([A-Za-z0-9_-]{6,64})\/?$/);
  return m ? m[1] : null;
}

// The page now shows run `runId`: its address goes in the history (so Back returns to the last one),
// unless it is there already.
function rememberRun(runId) {
  if (!runId || runIdInUrl() === runId) return;
  history.pushState({ runId }, "", `/runs/${encodeURIComponent(runId)}`);
}

async function showKeptRun(run, label, auto = false, remember = true) {
  const r = await fetch(run.result_url || `/runs/${encodeURIComponent(run.run_id)}/result`);
  const text = await r.text();
  if (auto && state.userActed) return false;
  if (!r.ok) {
    showError(errorText(r.status, text));
    refreshKeptRuns();
    return false;
  }
  state.compared = [];
  const option = run.sequence_id && [...$("sample-select").options].find((o) => o.value === run.sequence_id);
  const sampleId = run.sampleId || (option && option.value);
  state.source = run.source === "sequence" && sampleId ? { sampleId } : null;
  showError("");
  showResult(JSON.parse(text), label || run.sequence);
  if (remember && !auto) rememberRun(run.run_id);
  return true;
}

// Opened at /runs/{id} (a bookmark, a shared link, Back): that run, or why it cannot be shown.
async function showRunInUrl() {
  const runId = runIdInUrl();
  if (!runId) return false;
  state.userActed = true; // the first screen must not replace it
  let summary = null;
  try {
    const runs = await fetch(`/runs?limit=${KEPT_LIMIT}`).then((r) => r.json());
    summary = runs.find((r) => r.run_id === runId) || null;
  } catch (_) { /* the result alone still shows */ }
  const shown = await showKeptRun(summary || { run_id: runId }, summary ? summary.sequence : undefined, false, false);
  if (!shown) hideResult();
  return true;
}

window.addEventListener("popstate", () => {
  if (runIdInUrl() && (!state.result || state.result.run_id !== runIdInUrl())) showRunInUrl();
});

// The page opens on a result: the run its address names; else the bundled sample's run already kept
// (the scene's first run), else a fresh prediction of the first bundled sample with the model
// trained for it. A user who picked something meanwhile keeps it.
async function showFirstScreen() {
  if (await showRunInUrl()) return;
  const runs = await fetch("/runs?limit=20").then((r) => r.json()).catch(() => []);
  const bundled = runs.find((r) => r.source === "sequence");
  if (state.userActed) return;
  if (bundled) {
    const option = [...$("sample-select").options].find((o) => o.dataset.name === bundled.sequence);
    if (option) bundled.sampleId = option.value;
    await showKeptRun(bundled, `${bundled.sequence} (bundled)`, true);
    return;
  }
  if ($("sample-select").options.length) await predictSample({ auto: true });
}
