// Runs kept on the server (GET /runs): every upload listed with its downloads, one click to show it
// again; and the first screen, which opens on a bundled sample's result as the 3D scene does.
"use strict";

const SOURCE_WORDS = { upload: "uploaded", json: "sent as JSON", sequence: "bundled", viser: "3D scene" };

function downloadLink(href, text) {
  const a = document.createElement("a");
  a.href = href;
  a.textContent = text;
  a.className = "download";
  a.addEventListener("click", download);
  return a;
}

let keptRequest = 0; // answers that arrive out of order must not overwrite a newer list

async function refreshKeptRuns() {
  const ticket = ++keptRequest;
  let runs;
  try {
    runs = await fetch("/runs").then((r) => r.json());
  } catch (_) {
    return;
  }
  if (ticket !== keptRequest) return;
  const list = $("kept-list");
  list.textContent = "";
  $("kept").hidden = !runs.length;
  for (const run of runs) {
    const li = document.createElement("li");
    li.dataset.runId = run.run_id;
    const name = document.createElement("span");
    name.className = "kept-name";
    name.textContent = `${run.sequence} · ${displayName(run.model)}`;
    const source = document.createElement("span");
    source.className = "muted small";
    source.textContent = ` (${SOURCE_WORDS[run.source] || run.source})` +
      (run.worse_than_standing_still ? " ⚠ worse than standing still" : "");
    const show = document.createElement("button");
    show.type = "button";
    show.className = "link-button";
    show.textContent = "show";
    show.addEventListener("click", () => showKeptRun(run));
    li.append(name, source, " ", show, " · ");
    const links = [[run.csv_url, "CSV"], [run.tum_url, "TUM"], [run.ground_truth_tum_url, "ground truth TUM"], [run.metrics_url, "metrics JSON"]];
    for (const [i, [href, text]] of links.filter(([href]) => href).entries()) {
      if (i) li.append(" ");
      li.appendChild(downloadLink(href, text));
    }
    list.appendChild(li);
  }
}

async function showKeptRun(run, label, auto = false) {
  const r = await fetch(run.result_url);
  const text = await r.text();
  if (auto && state.userActed) return false;
  if (!r.ok) {
    showError(errorText(r.status, text));
    refreshKeptRuns();
    return false;
  }
  state.compared = [];
  state.source = run.source === "sequence" && run.sampleId ? { sampleId: run.sampleId } : null;
  showResult(JSON.parse(text), label || run.sequence);
  return true;
}

// The page opens on a result: the bundled sample's run already kept (the scene's first run), else a
// fresh prediction of the first bundled sample with the model trained for it. A user who picked
// something meanwhile keeps it.
async function showFirstScreen() {
  const runs = await fetch("/runs").then((r) => r.json()).catch(() => []);
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
