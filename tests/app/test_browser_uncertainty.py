"""How sure a path is, on the page in a real browser (fixtures of ``test_browser``): after an upload the
2-D plot draws the shown result's 2-sigma band (ellipses around its own samples, sized by the answer's
covariance) and the dashed 95 % circle around its end, each named in the legend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.app.test_browser import (  # noqa: F401  (browser and page are fixtures)
    browser,
    open_upload_page,
    run_file,
    screenshot,
    wait_for_result,
)
from tests.app.test_browser import page as page  # noqa: F401  (a fixture)

BAND = "#plot g.uncertainty-band"


def test_the_plot_draws_the_band_and_the_end_circle_after_an_upload(
    shipped_server, page, sample_csv_path: Path
) -> None:
    live_server = (
        shipped_server  # a walk read metres long: the tiny models' runs are implausible, circle withheld
    )
    open_upload_page(page, live_server)
    run_file(page, str(sample_csv_path))
    wait_for_result(page, "walk.csv")
    run_id = page.get_attribute("#scene-link", "data-run-id")  # the result shown
    result = page.request.get(f"{live_server.base_url}/runs/{run_id}/result").json()
    traj = result["trajectory"]
    assert traj["cov_xx"] is not None and result["uncertainty"] is not None

    ellipses = page.eval_on_selector_all(
        f"{BAND} ellipse",
        "els => els.map(e => [+e.getAttribute('cx'), +e.getAttribute('rx'), +e.getAttribute('ry')])",
    )
    t = np.asarray(traj["t"])
    assert len(ellipses) == pytest.approx((t[-1] - t[0]) / 2.0, abs=1.5)  # one every 2 s of the 20 s walk
    # The last one is the end's: its semi-axes are 2 sigma of the answer's last covariance, to scale.
    # Pixels per metre from the x axis' tick labels (their positions are exact, unlike the path's).
    ticks = page.eval_on_selector_all(
        "#plot g.axis text[text-anchor='middle']",
        "els => els.filter(e => e.textContent !== 'x (m)').map(e => [+e.textContent, +e.getAttribute('x')])",
    )
    (v0, x0), (v1, x1) = ticks[0], ticks[1]
    px_per_m = (x1 - x0) / (v1 - v0)
    xx, xy, yy = traj["cov_xx"][-1], traj["cov_xy"][-1], traj["cov_yy"][-1]
    long_m = 2 * np.sqrt(np.linalg.eigvalsh(np.array([[xx, xy], [xy, yy]])).max())
    assert ellipses[-1][1] == pytest.approx(long_m * px_per_m, rel=0.02, abs=0.15)
    assert (
        page.locator(f"{BAND}").get_attribute("data-label")
        == page.eval_on_selector_all("#plot polyline.series", "els => els.map(e => e.dataset.label)")[-1]
    )
    radius = page.get_attribute("#plot circle.end-radius", "r")
    assert float(radius) == pytest.approx(result["uncertainty"]["end_radius_95_m"] * px_per_m, rel=0.02)
    legend = page.inner_text("#plot-legend")
    # the band's coverage is a validation figure, said so; the circle is named, not claimed for this run
    assert "2σ band (its size fitted on other walks: not this run's error)" in legend
    assert "95 % end circle: " in legend
    screenshot(page, "uncertainty_band.png")


def test_the_page_says_when_the_true_end_lies_outside_the_circle(
    shipped_server, page, tmp_path: Path
) -> None:
    """The bundled walk with its ground truth stretched three-fold from its start: the true end lies far
    outside the circle, and the card says so (``uncertainty.true_end_inside`` false)."""
    from tests.app.test_end_circle_api import sample

    stretched = tmp_path / "stretched.csv"
    stretched.write_bytes(sample(truth_scale=3.0))
    open_upload_page(page, shipped_server)
    run_file(page, str(stretched))
    wait_for_result(page, "stretched.csv")
    run_id = page.get_attribute("#scene-link", "data-run-id")
    found = page.request.get(f"{shipped_server.base_url}/runs/{run_id}/result").json()["uncertainty"]
    assert found["true_end_inside"] is False and found["true_end_error_m"] > found["end_radius_95_m"]
    line = page.locator("#end-radius")
    assert line.get_attribute("data-inside") == "false"
    assert "the true end lies outside it" in line.inner_text()
