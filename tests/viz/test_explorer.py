"""``ltdsim view``'s page (ltdsim.viz.explorer): its decimation keeps every coupler's
extremes, its envelope is the result's own, its size stays bounded, and in a real
headless Chromium its cursors move what they should."""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

import ltdsim
from ltdsim.viz import explorer
from ltdsim.viz.explorer import PageData, build_page, extreme_samples, minmax_line, write_page

from conftest import ROOT

SHORT = ROOT / "scenarios" / "short-train.toml"


@pytest.fixture(scope="module")
def short_result():
    """The short train's first 5 s (5001 samples at 1 ms: 2000 bins, so decimated)."""
    sc = ltdsim.load_scenario(SHORT).with_overrides({"solver.t_end": 5.0})
    return ltdsim.simulate(sc)


values = st.floats(-1e7, 1e7, allow_nan=False, width=64)


@st.composite
def samples_and_bins(draw):
    n = draw(st.integers(1, 400))
    k = draw(st.integers(1, 6))
    x = draw(arrays(np.float64, (n, k), elements=values))
    return x, draw(st.integers(1, n + 5))


@settings(max_examples=300, deadline=None)
@given(samples_and_bins())
def test_the_decimation_keeps_every_columns_max_and_min_in_every_bin(case):
    x, bins = case
    edges = explorer.bin_edges(len(x), bins)
    assert edges[0] == 0 and edges[-1] == len(x) and np.all(np.diff(edges) >= 1)
    first, second = extreme_samples(x, edges)
    a, b = np.take_along_axis(x, first, 0), np.take_along_axis(x, second, 0)
    # each bin: its two samples lie in it, in time order, and are its min and max
    for k in range(len(edges) - 1):
        block = x[edges[k]:edges[k + 1]]
        assert np.all((edges[k] <= first[k]) & (first[k] <= second[k])
                      & (second[k] < edges[k + 1]))
        assert np.array_equal(np.maximum(a[k], b[k]), block.max(axis=0))
        assert np.array_equal(np.minimum(a[k], b[k]), block.min(axis=0))
    # so over the run: every column's true max and min survive
    assert np.array_equal(np.maximum(a, b).max(axis=0), x.max(axis=0))
    assert np.array_equal(np.minimum(a, b).min(axis=0), x.min(axis=0))


@settings(max_examples=60, deadline=None)
@given(samples_and_bins())
def test_the_pages_arrays_keep_each_couplers_max_and_min(case):
    # the same through the page's own data: forces in kN, deflections in mm, the
    # heatmaps the value of largest magnitude, the lines at the samples' own times
    f, bins = case
    n, k = f.shape
    t = 0.01 * np.arange(n)
    d = np.tanh(f / 1e6) * 0.08 + 1e-3 * np.sin(np.arange(n))[:, None]
    ds = xr.Dataset({"coupler_force": (("time", "coupler"), f),
                     "coupler_deflection": (("time", "coupler"), d)},
                    coords={"time": t, "coupler": np.arange(k)})
    data = PageData(ds, bins)
    top = np.maximum(data.force_a, data.force_b).max(axis=1) * 1e3
    low = np.minimum(data.force_a, data.force_b).min(axis=1) * 1e3
    np.testing.assert_allclose(top, f.max(axis=0), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(low, f.min(axis=0), rtol=1e-12, atol=1e-9)
    peak = np.abs(f).max(axis=0) / 1e3
    np.testing.assert_allclose(np.abs(data.force_map).max(axis=1), peak, rtol=1e-12)
    np.testing.assert_allclose(np.abs(data.defl_map).max(axis=1), np.abs(d).max(axis=0) * 1e3,
                               rtol=1e-12)
    # the deflections are those of the force's samples (a loop's points are pairs)
    np.testing.assert_allclose(data.defl_a * 1e-3,
                               np.take_along_axis(d, data.index_a.T, 0).T, rtol=1e-12)
    xs, ys = minmax_line(t, f[:, 0], data.edges)
    assert np.all(np.diff(xs) >= 0) and ys.max() == f[:, 0].max() and ys.min() == f[:, 0].min()
    assert np.array_equal(np.interp(xs, t, f[:, 0]), ys)  # each point a real sample


def test_the_page_stays_within_its_budget_for_any_train():
    for n_time, couplers in ((10, 4), (5001, 4), (21601, 213), (200_000, 2000), (10, 10_000)):
        bins = explorer.time_bins(n_time, couplers)
        assert 1 <= bins <= min(n_time, explorer.MAX_BINS)
        assert bins == 1 or explorer._ARRAYS * couplers * bins <= explorer.MAX_VALUES


def test_the_envelope_on_the_page_is_the_results_own(short_result):
    ds = short_result
    doc, data, _ = build_page(ds, "short.nc")
    env = doc.select_one({"name": "envelope"}).data
    assert list(env["coupler"]) == list(range(1, ds.sizes["coupler"] + 1))
    # the peaks the kernel tracked over every step (not the recorded samples)
    np.testing.assert_array_equal(env["tension_kN"],
                                  np.maximum(ds.max_coupler_force.values, 0.0) / 1e3)
    np.testing.assert_array_equal(env["compression_kN"],
                                  np.minimum(ds.min_coupler_force.values, 0.0) / 1e3)
    # and no recorded sample lies beyond them
    f = ds.coupler_force.values / 1e3
    assert np.all(f.max(axis=0) <= env["tension_kN"] + 1e-9)
    assert np.all(f.min(axis=0) >= env["compression_kN"] - 1e-9)
    # the heatmap's decimated samples reach the recorded peaks exactly
    assert data.bins < ds.sizes["time"]
    np.testing.assert_array_equal(np.abs(data.force_map).max(axis=1),
                                  np.abs(f).max(axis=0))


def test_a_result_recorded_without_some_variables_leaves_their_panels_out(tmp_path):
    sc = ltdsim.load_scenario(SHORT).with_overrides({"solver.t_end": 1.0,
                                                     "solver.record": ["coupler_force"]})
    ds = ltdsim.simulate(sc)
    path, data, notes = write_page(ds, tmp_path / "p.html", "sel.nc")
    text = path.read_text()
    for word in ("coupler_deflection", "velocity", "position", "brake-pipe"):
        assert any(word in n for n in notes), (word, notes)
        assert word in text
    assert "Not shown" in text and data.defl_a is None


def _browser(width: int, profile: Path):
    webdriver = pytest.importorskip("selenium.webdriver")
    chromium, driver_bin = shutil.which("chromium"), shutil.which("chromedriver")
    if chromium is None or driver_bin is None:
        pytest.skip("Debian chromium / chromium-driver not installed (.ci/run installs them)")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    opts.binary_location = chromium
    for flag in ("--headless", "--no-sandbox", "--disable-gpu",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", f"--window-size={width},1000",
                 "--hide-scrollbars", f"--user-data-dir={profile}"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver_bin), options=opts)


def _ready(browser, timeout: float = 30.0) -> float:
    """Wait until the page is drawn; its time from the navigation's start, ms."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        ms = browser.execute_script("return window.ltdsim_ready_ms || null;")
        if ms is not None:
            return float(ms)
        time.sleep(0.05)
    raise AssertionError("the page was not drawn")


MODEL = "return Bokeh.documents[0].get_model_by_name(arguments[0])"


def _data(browser, name: str, column: str) -> np.ndarray:
    return np.asarray(browser.execute_script(
        MODEL + ".data[arguments[1]].map(Number);", name, column))


#: every element matching a selector, in the shadow roots (Bokeh's) too, in page order
DEEP = """const deep = (root, sel) => {
  const out = [...root.querySelectorAll(sel)];
  for (const el of root.querySelectorAll('*')) {
    if (el.shadowRoot) { out.push(...deep(el.shadowRoot, sel)); }
  }
  return out;
};
"""


def _point(browser, figure: str, x: float, y: float) -> tuple[float, float]:
    """Where data point (x, y) of ``figure`` is in the window, px."""
    return browser.execute_script(
        "const m = Bokeh.documents[0].get_model_by_name(arguments[0]);"
        "const v = Bokeh.index.get_one(m); const r = v.el.getBoundingClientRect();"
        "return [r.left + v.frame.x_scale.compute(arguments[1]),"
        "        r.top + v.frame.y_scale.compute(arguments[2])];", figure, x, y)


def test_the_page_works_in_headless_chromium(tmp_path, short_result):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.action_builder import ActionBuilder

    ds = short_result
    page, data, notes = write_page(ds, tmp_path / "short.html", "short.nc")
    assert page.stat().st_size < 5e6
    shots = Path(os.environ.get("LTDSIM_SCREENSHOTS") or tmp_path)
    shots.mkdir(parents=True, exist_ok=True)
    for width in (1400, 900):
        browser = _browser(width, tmp_path / f"profile{width}")
        try:
            browser.get(page.as_uri())
            ready = _ready(browser)
            t_before = browser.execute_script(MODEL + ".value;", "time_cursor")
            before = _data(browser, "profile", "hi")
            # drag the time slider's handle to the left
            handle = browser.execute_script(DEEP + "return deep(document, '.noUi-handle')[0];")
            ActionChains(browser).drag_and_drop_by_offset(handle, -width // 5, 0).perform()
            t_after = browser.execute_script(MODEL + ".value;", "time_cursor")
            after = _data(browser, "profile", "hi")
            k = int(np.searchsorted(data.start, t_after, side="right")) - 1
            # click coupler 2's row of the force heatmap, at t = 1 s
            old = int(browser.execute_script(MODEL + ".value;", "coupler_cursor"))
            target = 2 if old != 2 else 3
            x, y = _point(browser, "force_map", 1.0, target)
            act = ActionBuilder(browser)
            act.pointer_action.move_to_location(int(round(x)), int(round(y))).click()
            act.perform()
            chosen = int(browser.execute_script(MODEL + ".value;", "coupler_cursor"))
            t_click = browser.execute_script(MODEL + ".value;", "time_cursor")
            hist_t = _data(browser, "history", "t")
            hist_f = _data(browser, "history", "force")
            title = browser.execute_script(MODEL + ".title.text;", "history_plot")
            loop_x = _data(browser, "loop", "deflection")
            act = ActionBuilder(browser)  # (the pointer off the plots: no tooltip shown)
            act.pointer_action.move_to_location(5, 5)
            act.perform()
            height = browser.execute_script("return document.documentElement.scrollHeight;")
            page_wide = browser.execute_script(
                "return document.documentElement.scrollWidth > window.innerWidth + 1;")
            browser.execute_cdp_cmd("Emulation.setDeviceMetricsOverride", {
                "width": width, "height": int(height), "deviceScaleFactor": 1,
                "mobile": False})
            time.sleep(0.5)
            shot = shots / f"viewer_{width}px.png"
            browser.save_screenshot(str(shot))
            errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        finally:
            browser.quit()
        assert ready < 10_000, f"drawn {ready:.0f} ms after the navigation started"
        # moving the time cursor changes the profile, to the new bin's largest forces
        assert t_after < t_before
        assert not np.array_equal(before, after)
        np.testing.assert_allclose(after, np.maximum(data.force_a[:, k], data.force_b[:, k]),
                                   rtol=1e-6, atol=1e-3)  # (float32 on the page)
        # the click chose that coupler and time, and the history shows its data
        assert chosen == target and abs(t_click - 1.0) < 0.05
        j = chosen - 1
        np.testing.assert_allclose(hist_f, np.stack([data.force_a[j], data.force_b[j]],
                                                    1).ravel(), rtol=1e-6, atol=1e-3)
        np.testing.assert_allclose(hist_t, np.stack([data.t[data.index_a[j]],
                                                     data.t[data.index_b[j]]], 1).ravel())
        np.testing.assert_allclose(loop_x, np.stack([data.defl_a[j], data.defl_b[j]],
                                                    1).ravel(), rtol=1e-6, atol=1e-4)
        assert title == f"coupler {chosen}: force history"
        assert not page_wide
        assert errors == []
        assert shot.stat().st_size > 10_000


def test_the_page_of_a_long_noisy_run_stays_a_few_megabytes(tmp_path):
    # 30,000 samples of 250 couplers of noise (what compresses worst), and velocities
    rng = np.random.default_rng(3)
    n, k = 30_000, 250
    t = 0.5 * np.arange(n)
    ds = xr.Dataset({"coupler_force": (("time", "coupler"), rng.normal(0, 3e5, (n, k))),
                     "coupler_deflection": (("time", "coupler"), rng.normal(0, 0.03, (n, k))),
                     "velocity": (("time", "vehicle"), rng.normal(15, 1, (n, k + 1)))},
                    coords={"time": t, "coupler": np.arange(k), "vehicle": np.arange(k + 1)})
    path, data, notes = write_page(ds, tmp_path / "noise.html", "noise.nc")
    assert data.bins < n and explorer._ARRAYS * k * data.bins <= explorer.MAX_VALUES
    assert path.stat().st_size < 5.5e6, path.stat().st_size
    assert any("track" in note for note in notes)  # (no positions: the panel left out)
