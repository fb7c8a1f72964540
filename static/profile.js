// Walker profiles on the page (docs/metrics.md, "A walker's own scale"): a select of the profiles that
// scales every prediction the page asks for, and under the result a "this walk was __ m" box that adds
// the shown run to a profile (POST /profiles/{name}/walks; an empty distance uses the walk's GPS).
//
// Two globals for the page's other scripts: `profileParam()` ("&profile=NAME" while a profile is
// chosen, else ""), which every prediction request adds to its query beside orientationParam(), and
// `showProfileBox(result)`, which showResult calls with every answer it shows.

(function () {
  let shownRun = null; // the run_id of the last answer the page showed

  function chosen() {
    const select = document.getElementById("profile-select");
    return select ? select.value : "";
  }

  function element(tag, props = {}, children = []) {
    const node = Object.assign(document.createElement(tag), props);
    for (const child of children) node.append(child);
    return node;
  }

  async function loadProfiles(keep) {
    const select = document.getElementById("profile-select");
    const list = document.getElementById("profile-names");
    let profiles = [];
    try {
      profiles = await fetch("/profiles").then((r) => (r.ok ? r.json() : []));
    } catch (_) { /* the page works without profiles */ }
    const current = keep !== undefined ? keep : select.value;
    select.replaceChildren(element("option", { value: "", textContent: "none — the model's own distance" }));
    list.replaceChildren();
    for (const p of profiles) {
      const walks = `${p.walks.length} walk${p.walks.length === 1 ? "" : "s"}`;
      select.append(element("option", { value: p.name, textContent: `${p.name} — ×${p.scale.toFixed(3)} (${walks})` }));
      list.append(element("option", { value: p.name }));
    }
    select.value = profiles.some((p) => p.name === current) ? current : "";
  }

  window.profileParam = () => {
    const name = chosen();
    return name ? `&profile=${encodeURIComponent(name)}` : "";
  };

  window.showProfileBox = function showBox(result) {
    shownRun = result.run_id;
    const box = document.getElementById("profile-box");
    if (!box) return;
    box.hidden = false;
    const applied = result.profile;
    document.getElementById("profile-applied").textContent = applied
      ? `Scaled by profile ${applied.name}: ×${applied.scale.toFixed(3)} from ${applied.walks} walk(s), ` +
        `distance within ±${(100 * applied.scale_sigma).toFixed(0)} %.`
      : "";
    document.getElementById("profile-status").textContent = "";
  };

  async function addWalk() {
    const status = document.getElementById("profile-status");
    const name = document.getElementById("profile-name").value.trim();
    const distance = document.getElementById("walk-distance").value.trim();
    if (!shownRun) return;
    if (!name) {
      status.textContent = "Name the walker's profile first.";
      return;
    }
    const body = { run_id: shownRun };
    if (distance) body.distance_m = Number(distance);
    try {
      const r = await fetch(`/profiles/${encodeURIComponent(name)}/walks`, {
        method: "POST",
        headers: { "Content-Type": "application/json" },
        body: JSON.stringify(body),
      });
      const text = await r.text();
      if (!r.ok) {
        status.textContent = errorText(r.status, text);
        return;
      }
      const profile = JSON.parse(text);
      const source = body.distance_m ? "" : " (from its GPS)";
      status.textContent = `Added to ${profile.name}${source}: scale ×${profile.scale.toFixed(3)} from ` +
        `${profile.walks.length} walk(s). Choose it under "Walker profile" for this walker's next walks.`;
      await loadProfiles();
    } catch (_) {
      status.textContent = errorText(0, "");
    }
  }

  function build() {
    const filter = document.getElementById("filter-select");
    if (filter) {
      const select = element("select", { id: "profile-select" });
      select.setAttribute("aria-label", "Walker profile");
      select.addEventListener("change", () => { if (typeof hideResult === "function") hideResult(); });
      filter.after(
        element("label", { className: "muted small", htmlFor: "profile-select", textContent: "Walker profile (scales the distance)" }),
        select,
      );
    }
    const result = document.getElementById("result");
    if (result) {
      const box = element("div", { id: "profile-box", className: "profile-box", hidden: true }, [
        element("label", { className: "small", htmlFor: "walk-distance" }, [
          "This walk was ",
          element("input", { id: "walk-distance", type: "number", min: "0", step: "any", placeholder: "GPS", size: 6 }),
          " m",
        ]),
        " for ",
        element("input", { id: "profile-name", placeholder: "walker", size: 10, maxLength: 64, autocomplete: "off" }),
        element("datalist", { id: "profile-names" }),
        " ",
        element("button", { id: "profile-add", type: "button", className: "secondary-button", textContent: "Add to profile" }),
        element("p", { id: "profile-applied", className: "muted small" }),
        element("p", { id: "profile-status", className: "muted small" }),
      ]);
      box.querySelector("#profile-status").setAttribute("role", "status");
      box.querySelector("#profile-name").setAttribute("list", "profile-names");
      const compare = document.getElementById("compare");
      if (compare && compare.parentNode === result) compare.before(box);
      else result.append(box);
      box.querySelector("#profile-add").addEventListener("click", addWalk);
    }
    if (filter) loadProfiles("");
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", build);
  else build();
})();
