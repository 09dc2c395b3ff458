"""The study report end to end on a shortened scenario with two cases."""

import re

import numpy as np
import pandas as pd

from ltdsim.study import run_study

from conftest import PAPER


def short_paper(tmp_path, keep=("LHHL", "HHHH")):
    text = PAPER.read_text()
    head, _, cases = text.partition("[cases.")
    blocks = ("[cases." + cases).split("\n[cases.")
    kept = [b if b.startswith("[cases.") else "[cases." + b for b in blocks
            if any(b.removeprefix("[cases.").startswith(k) for k in keep)]
    p = tmp_path / "paper-short.toml"
    p.write_text(head + "\n".join(kept))
    return p


def test_the_report_has_every_table_and_figure_and_only_finite_numbers(tmp_path):
    scenario = short_paper(tmp_path)
    out = tmp_path / "report"
    index = run_study(scenario, out, overrides={"solver.t_end": 12.0}, reduction_maxiter=3,
                      workers=2)
    page = index.read_text()
    for title in ("Table 1", "Table 2", "Table 3", "Table 4", "Table 5", "Tables 6-7",
                  "Fig. 3a", "Fig. 3b", "Fig. 4", "Fig. 5", "Fig. 6", "Fig. 7", "Fig. 8",
                  "Fig. 9a", "Fig. 9b", "What to take away"):
        assert title in page, title
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', page)
    assert len(images) == 10 and all(len(i) > 1000 for i in images)  # Fig. 3a-9b
    assert "http://" not in page and "https://" not in page  # readable offline
    for csv in ("table1_reduction", "table2_speed_error", "table3_identification",
                "table4_step_response", "table5_phase_norms", "tables6_7_spectra",
                "traction_check", "modal_bands"):
        df = pd.read_csv(out / f"{csv}.csv")
        assert len(df) > 0, csv
        nums = df.select_dtypes("number").to_numpy(dtype=float)
        if csv == "table1_reduction":  # the study gives no fit % to compare with
            nums = nums[~np.isnan(nums)]
        assert np.all(np.isfinite(nums)), csv
    assert (out / "base_case.nc").is_file()
    # a second run reuses every finished stage
    before = {p: p.stat().st_mtime for p in out.glob("fig*.png")}
    run_study(scenario, out, overrides={"solver.t_end": 12.0}, reduction_maxiter=3, workers=2)
    assert before == {p: p.stat().st_mtime for p in out.glob("fig*.png")}


def test_the_report_renders_in_headless_chromium(tmp_path):
    import shutil

    import pytest

    webdriver = pytest.importorskip("selenium.webdriver")
    chromium, driver_bin = shutil.which("chromium"), shutil.which("chromedriver")
    if chromium is None or driver_bin is None:
        pytest.skip("Debian chromium / chromium-driver not installed (.ci/run installs them)")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    index = run_study(short_paper(tmp_path, keep=("LHHL",)), tmp_path / "report",
                      overrides={"solver.t_end": 12.0}, reduction=False, workers=1)
    opts = Options()
    opts.binary_location = chromium
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run",
                 "--window-size=1280,1024", f"--user-data-dir={tmp_path / 'profile'}"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    browser = webdriver.Chrome(service=Service(driver_bin), options=opts)
    try:
        browser.get(index.as_uri())
        sizes = browser.execute_script(
            "return Array.from(document.images).map(i => [i.complete, i.naturalWidth, "
            "i.getBoundingClientRect().width, i.getBoundingClientRect().height]);")
        shot = tmp_path / "report.png"
        browser.save_screenshot(str(shot))
        errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    finally:
        browser.quit()
    assert len(sizes) >= 8
    assert all(done and nat > 0 and w > 0 and h > 0 for done, nat, w, h in sizes), sizes
    assert errors == []
    assert shot.stat().st_size > 10_000
