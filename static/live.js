// The upload page's "Live from a phone" card: the push URL to type into Sensor Logger and the live
// sessions (GET /live/info, polled). Device and session names come from phones: set as text, never HTML.
// The URL shown is one a phone can reach (the LAN address the app answers on); when the app listens on
// this machine only, the card says so and how to restart it, and shows the local URL as such.
"use strict";

(() => {
  const POLL_MS = 1000; // with the server's 2 s of silence: "waiting for the phone" within 3 s
  const COLUMNS = ["Phone", "State", "Samples", "Rates", "Latency", "Dropped", "Distance", "Steps", "Trajectory"];
  const el = (id) => document.getElementById(id);

  function cell(row, text) {
    const td = document.createElement("td");
    td.textContent = text;
    row.appendChild(td);
    return td;
  }

  // "gyro 500 Hz · acc 100 Hz · mag 50 Hz": every sensor at its own rate (one number misled).
  function ratesText(rates) {
    const parts = Object.entries(rates || {}).filter(([, hz]) => hz != null).map(([kind, hz]) => `${kind} ${hz.toFixed(0)} Hz`);
    return parts.length ? parts.join(" · ") : "–";
  }

  function render(info) {
    el("live-url").textContent = info.lan_url || `${info.local_url} (this machine only)`;
    el("live-note").textContent =
      (info.lan_url ? `On this machine: ${info.local_url}. ` : "") + info.note;
    const table = el("live-sessions");
    table.replaceChildren();
    table.hidden = info.sessions.length === 0;
    if (table.hidden) return;
    const head = table.insertRow();
    for (const name of COLUMNS) {
      const th = document.createElement("th");
      th.textContent = name;
      head.appendChild(th);
    }
    for (const s of info.sessions) {
      const row = table.insertRow();
      row.dataset.runId = s.run_id || "";
      cell(row, s.device_id + (s.part > 1 ? ` (part ${s.part})` : ""));
      const state = s.waiting ? `waiting for the phone (nothing for ${s.silent_s.toFixed(0)} s)`
        : s.state === "live" ? "streaming" : s.state;
      cell(row, state + (s.ended_because ? `: ${s.ended_because}` : "")).className = "live-state";
      cell(row, String(s.samples));
      cell(row, ratesText(s.rates_hz));
      cell(row, s.latency_s == null ? "–" : `${s.latency_s.toFixed(2)} s`);
      cell(row, String(s.dropped_messages));
      cell(row, `${s.distance_m.toFixed(1)} m`);
      cell(row, String(s.steps));
      const links = cell(row, "");
      if (s.run_id) {
        for (const [label, path] of [["TUM", "trajectory.tum"], ["CSV", "trajectory.csv"]]) {
          const a = document.createElement("a");
          a.href = `/runs/${encodeURIComponent(s.run_id)}/${path}`;
          a.textContent = label;
          links.appendChild(a);
          links.appendChild(document.createTextNode(" "));
        }
      }
    }
  }

  async function poll() {
    try {
      const response = await fetch("/live/info");
      if (response.ok) render(await response.json());
    } catch (_) {
      // the server restarts or the network blinks: try again at the next poll
    }
    setTimeout(poll, POLL_MS);
  }

  poll();
})();
