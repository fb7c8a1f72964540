// The map under a walk with GPS: the predicted path and the GPS fixes in latitude / longitude on
// Leaflet (vendored in static/vendor/leaflet, no CDN), tiles from FTIN_MAP_TILES (GET /health's
// map_tiles; OpenStreetMap's by default). The path comes from the run's own GeoJSON export
// (GET /runs/{id}/trajectory.geojson: app/services/geo_exports.py anchors the prediction on the GPS
// track, the start alignment the plot shows), so the map, the GPX and the GeoJSON agree.
// Offline (no tile loads): the map box goes, and the page says the plot above is the view.
"use strict";

const FtinMap = (() => {
  let map = null, token = 0;

  function note(text) {
    $("map-note").textContent = text;
    $("map-note").hidden = !text;
  }

  function hide(reason) {
    $("map-box").hidden = !reason;
    $("map").hidden = true;
    note(reason || "");
  }

  // Called by showResult with the shown run; `anchored`: GPS fixes fall inside the walk.
  async function show(result, anchored) {
    const mine = ++token;
    if (!anchored || typeof L === "undefined") { hide(null); return; }
    if (!state.mapTiles) {
      hide("This walk has GPS, but no map is configured (FTIN_MAP_TILES is empty): the plot above shows it.");
      return;
    }
    let geo;
    try {
      const r = await fetch(`/runs/${encodeURIComponent(result.run_id)}/trajectory.geojson`);
      if (mine !== token) return;
      if (!r.ok) { hide(`No map: ${errorText(r.status, await r.text())}`); return; }
      geo = await r.json();
    } catch (_) {
      if (mine === token) hide(`No map: ${errorText(0, "")}`);
      return;
    }
    if (mine !== token) return;
    $("map-box").hidden = false;
    $("map").hidden = false;
    note("");
    if (map) map.remove();
    map = L.map($("map"), { scrollWheelZoom: true });
    let loaded = 0, failed = 0;
    const tiles = L.tileLayer(state.mapTiles, { attribution: state.mapAttribution, maxZoom: 19 });
    tiles.on("tileload", () => { loaded++; note(""); $("map").hidden = false; });
    tiles.on("tileerror", () => {
      failed++;
      if (!loaded && mine === token) {
        $("map").hidden = true;
        note(`The map's tiles could not load (offline, or ${new URL(state.mapTiles, location.href).host} ` +
          "unreachable: FTIN_MAP_TILES names them): the trajectory plot above shows the walk.");
      }
    });
    tiles.addTo(map);
    const layer = L.geoJSON(geo, {
      style: (f) => (f.properties.kind === "gps"
        ? { color: GPS_COLOR, weight: 2, dashArray: "2 5", className: "map-gps" }
        : { color: modelColor(result.model), weight: 4, className: "map-path" }),
    }).addTo(map);
    map.fitBounds(layer.getBounds(), { padding: [20, 20] });
    const prediction = geo.features.find((f) => f.properties.kind === "prediction");
    if (prediction) $("map-caption").textContent = prediction.properties.anchor_text || "";
    return { loaded: () => loaded, failed: () => failed };
  }

  return { show, hide };
})();
