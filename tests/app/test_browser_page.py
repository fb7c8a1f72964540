"""The page shows the walk (issue 52), in a real browser at 1400 x 900 (fixtures of ``test_browser``;
skips without chromium or playwright): the trajectory plot is the card's hero (at least 55 % of its
width, zoom and pan, paths toggled from the legend), no card's content overflows, speed over time
under it, the walk on a map when it has GPS (and the plain plot, said so, when the tiles cannot
load), compare-all from a page upload's own address fills its table, and a run's delete button
answers with the server's words.

The GPS walk is the synthetic Sensor Logger export of ``tests.utils.phone_walk`` (the real exports
in the shared data have an empty Location.csv). Tiles come from the app itself (``LOCAL_TILES`` in
``tests/app/conftest.py``): the tests run offline."""

from __future__ import annotations

from pathlib import Path

from tests.app.test_browser import (  # noqa: F401  (browser is a fixture)
    browser,
    open_page_at,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.utils.phone_walk import sensorlogger_walk_zip

VIEWPORT = {"width": 1400, "height": 900}
MEASURE = """() => {
  const card = document.getElementById('result');
  const plot = document.querySelector('#plot svg').getBoundingClientRect().width;
  const inner = card.clientWidth - parseFloat(getComputedStyle(card).paddingLeft)
    - parseFloat(getComputedStyle(card).paddingRight);
  const overflowing = [...document.querySelectorAll('.card')].filter((c) => !c.hidden)
    .filter((c) => c.scrollWidth > c.clientWidth).map((c) => `${c.id}: ${c.scrollWidth} > ${c.clientWidth}`);
  // a select fits its options: the widest option's text and the arrow inside the select's box
  const ctx = document.createElement('canvas').getContext('2d');
  const tight = [...document.querySelectorAll('select')].filter((s) => s.offsetParent).flatMap((s) => {
    ctx.font = getComputedStyle(s).font;
    return [...s.options].filter((o) => ctx.measureText(o.textContent).width + 28 > s.clientWidth)
      .map((o) => `${s.id}: ${o.textContent}`);
  });
  return {plot, card: card.clientWidth, inner, overflowing, tight};
}"""


def _page(chromium, base_url: str):
    context = chromium.new_context(viewport=VIEWPORT)
    page = context.new_page()
    outside: list[str] = []
    page.on(
        "request",
        lambda r: (
            outside.append(r.url)
            if not r.url.startswith(base_url)
            and not r.url.startswith(("data:", "blob:", "http://127.0.0.1:9/"))
            else None
        ),
    )
    return context, page, outside


def test_the_plot_is_the_hero_the_map_shows_the_walk_and_compare_works_on_its_address(
    live_server,
    browser,  # noqa: F811  (the fixture)
    tmp_path: Path,
) -> None:
    export = tmp_path / "phone_walk.zip"
    export.write_bytes(sensorlogger_walk_zip())
    context, page, outside = _page(browser, live_server.base_url)
    try:
        open_page_at(page, live_server.base_url)
        run_file(page, str(export))
        wait_for_result(page, "phone_walk.zip")
        page.wait_for_selector("#map .leaflet-tile-loaded", timeout=15_000)
        m = page.evaluate(MEASURE)
        assert m["plot"] >= 0.55 * m["card"], m  # the hero: not a thumbnail in a corner
        assert m["overflowing"] == [], m["overflowing"]  # the GPS legend and the push URL wrap
        assert m["tight"] == [], m["tight"]  # every select shows its options whole

        # zoom about the cursor with the wheel, pan by dragging, back with "Reset view"
        box = page.locator("#plot svg").bounding_box()
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.mouse.wheel(0, -300)
        page.wait_for_function("() => FtinPlot.zoomOf(document.getElementById('plot')) > 1.1")
        ticks = page.eval_on_selector_all("#plot .axis text", "ts => ts.map((t) => t.textContent)")
        page.mouse.down()
        page.mouse.move(box["x"] + box["width"] / 2 + 120, box["y"] + box["height"] / 2 + 40, steps=4)
        page.mouse.up()
        page.wait_for_timeout(100)
        assert page.eval_on_selector_all("#plot .axis text", "ts => ts.map((t) => t.textContent)") != ticks
        page.click("#plot-reset")
        assert page.evaluate("FtinPlot.zoomOf(document.getElementById('plot'))") == 1

        # a path hidden and shown again from its name in the legend
        model = page.evaluate("displayName(state.result.model)")
        toggle = page.locator(f"#plot-legend button.legend-toggle[data-label='{model}']")
        toggle.click()
        assert toggle.get_attribute("aria-pressed") == "false"
        assert page.locator(f"#plot polyline.series[data-label='{model}']").count() == 0
        toggle.click()
        assert page.locator(f"#plot polyline.series[data-label='{model}']").count() == 1

        # speed over time under the plot; the walk on the map, in latitude / longitude from its GeoJSON
        assert page.locator("#speed-chart path.series").count() == 1 and page.is_visible("#speed-box")
        assert page.locator("#map .leaflet-overlay-pane path.map-path").count() == 1
        assert page.locator("#map .leaflet-overlay-pane path.map-gps").count() == 1
        assert page.is_visible("#map") and page.is_hidden("#map-note")
        assert "OpenStreetMap" in page.inner_text("#map .leaflet-control-attribution")
        screenshot(page, "page_hero_map.png")

        # the run's own address, opened afresh (the file is no longer on the page): compare-all still works
        run_id = page.evaluate("state.result.run_id")
        page.goto(f"{live_server.base_url}/runs/{run_id}")
        wait_for_result(page, "phone_walk")
        page.click("#compare-button")
        page.wait_for_function(
            "() => document.querySelectorAll('#compare-table tbody tr.done').length === 2", timeout=60_000
        )
        assert page.evaluate("state.compared.length") == 1
        assert page.locator("#plot polyline.series").count() == 2  # both models drawn
        assert page.evaluate(MEASURE)["overflowing"] == []
    finally:
        context.close()
    assert outside == [], f"the page fetched from outside: {outside}"


def test_offline_the_map_gives_way_to_the_plot_and_says_so(
    make_settings,
    server_control,
    browser,  # noqa: F811  (the fixture)
    tmp_path: Path,
) -> None:
    export = tmp_path / "phone_walk.zip"
    export.write_bytes(sensorlogger_walk_zip())
    # Tiles from a port nothing answers on: what a machine without internet sees of OpenStreetMap's.
    live = server_control.start(make_settings(map_tiles="http://127.0.0.1:9/{z}/{x}/{y}.png"))
    context, page, outside = _page(browser, live.base_url)
    page.on("dialog", lambda dialog: dialog.accept())
    try:
        open_page_at(page, live.base_url)
        run_file(page, str(export))
        wait_for_result(page, "phone_walk.zip")
        page.wait_for_selector("#map-note:not([hidden])", timeout=15_000)
        assert "could not load" in page.inner_text("#map-note") and "plot above" in page.inner_text(
            "#map-note"
        )
        assert page.is_hidden("#map") and page.is_visible("#plot svg")
        assert page.locator("#map .leaflet-overlay-pane path.map-path").count() == 1  # the layer is there
        screenshot(page, "page_map_offline.png")

        # delete: the server's answer in words (405 where the route is absent, else the run is gone)
        run_id = page.evaluate("state.result.run_id")
        with page.expect_response(lambda r: r.request.method == "DELETE") as answer:
            page.click("#delete-run")
        if answer.value.ok:
            page.wait_for_selector("#result", state="hidden")
            page.wait_for_function(
                f"() => !document.querySelector(\"#kept-list li[data-run-id='{run_id}']\")"
            )
        else:
            page.wait_for_selector("#expired:not([hidden])")
            words = page.inner_text("#expired")
            assert words.startswith("Could not delete the run: ") and answer.value.json()["detail"] in words
    finally:
        context.close()
        server_control.stop(live)
    assert outside == [], f"the page fetched from outside: {outside}"
