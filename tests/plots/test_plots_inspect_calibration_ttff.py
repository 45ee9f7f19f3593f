"""Inspect, calibration and ttff plots read back (data arrays, scales, table cells), and the HTML report."""
from __future__ import annotations

import base64
import csv
import io
import re
import subprocess
import sys

import numpy as np
import pytest

from gnssatt.sim.sample_set import obs_v3_text
from tests.conftest import REPO_ROOT
from tests.plots.builders import TABLE5_FIRST_ROWS, pcv_map, ttff_runs
from gnssatt.gnss.io.rinex_obs import read_rinex_obs
from gnssatt.plots import calibration as C
from gnssatt.plots import inspect as I
from gnssatt.plots import ttff as T
from gnssatt.report import html_report

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture
def receivers(tmp_path):
    out = []
    for i, marker in enumerate(("GPS-2", "GPS-0")):
        p = tmp_path / f"{marker}.rnx"
        p.write_text(obs_v3_text(marker, n_epochs=40, seed=i))
        obs = read_rinex_obs(p, name=p.name)
        if i == 1:
            obs.values[10:20, 1, :] = np.nan  # G05 lost for 10 epochs on GPS-0
            obs.values[:, 2, obs.codes.index("S1C")] = np.nan  # G12 without C/N0
        out.append((obs, I.tracking_arrays(obs)))
    return out


def test_tracking_arrays_and_series_csv(receivers):
    obs, rx = receivers[1]
    assert rx["name"] == "GPS-0" and rx["sats"] == ["G01", "G05", "G12", "G19"]
    assert rx["tracked"].shape == (40, 4) and not rx["tracked"][10:20, 1].any() and rx["tracked"][:10, 1].all()
    np.testing.assert_array_equal(rx["cn0_dbhz"][:, 0], obs.values[:, 0, obs.codes.index("S1C")])
    assert np.isnan(rx["cn0_dbhz"][:, 2]).all()
    assert str(rx["time"][0]) == "2024-06-24T08:20:00.000" and int(rx["gps_week"][0]) == 2320
    rows = list(csv.DictReader(io.StringIO(I.tracking_series_csv([r for _, r in receivers]))))
    assert len(rows) == 80 and rows[0]["receiver"] == "GPS-2" and rows[40]["receiver"] == "GPS-0"
    assert [int(r["n_sats"]) for r in rows[40:][10:20]] == [3] * 10 and rows[40]["n_sats"] == "4"
    k = 45  # GPS-0 epoch 5: C/N0 mean over G01, G05, G19 (G12 has none)
    want = np.mean([obs.values[5, j, obs.codes.index("S1C")] for j in (0, 1, 3)])
    assert float(rows[k]["mean_cn0_dbhz"]) == pytest.approx(want, abs=0.006)
    assert float(rows[k]["gps_sow"]) == pytest.approx(86400 + 8 * 3600 + 20 * 60 + 5)


def test_tracking_figure_mesh_holds_cn0_where_tracked(receivers):
    rx = [r for _, r in receivers]
    fig = I.tracking_figure(rx, {"set": "S", "job": "J" * 12, "config": {"gap_factor": 1.5}})
    ax = [a for a in fig.axes if a.get_ylabel().startswith("GPS-0")][0]
    grey, colour = ax.collections[:2]
    data = np.ma.filled(colour.get_array(), np.nan).reshape(4, 40)  # (satellites, epochs)
    want = np.where(rx[1]["tracked"], rx[1]["cn0_dbhz"], np.nan).T
    np.testing.assert_array_equal(data, want)
    # G12 tracked without C/N0 -> the grey layer; G05's 10-epoch gap blank in both
    g = np.ma.filled(grey.get_array(), np.nan).reshape(4, 40)
    assert np.isfinite(g[2]).all() and np.isnan(g[1, 10:20]).all() and np.isnan(data[1, 10:20]).all()
    assert [t.get_text() for t in ax.get_yticklabels()] == ["G01", "G05", "G12", "G19"]
    assert colour.get_clim() == fig.axes[0].collections[1].get_clim()  # one scale for all receivers
    assert any(a.get_ylabel() == "C/N0 [dB-Hz]" for a in fig.axes)
    assert "gap_factor=1.5" in fig.get_suptitle() and "set S" in fig.get_suptitle()
    assert I.tracking_plot(rx).startswith(PNG_MAGIC)


def test_tracking_figure_block_averages_long_files():
    n = I.MAX_COLUMNS * 3 + 7
    t = np.datetime64("2024-01-01T00:00:00") + np.arange(n).astype("timedelta64[s]")
    cn0 = np.full((n, 1), 40.0)
    cn0[::2] = 50.0
    rx = {"name": "A", "time": t, "sats": ["G01"], "tracked": np.ones((n, 1), bool), "cn0_dbhz": cn0}
    mesh = I.tracking_figure([rx]).axes[0].collections[1]
    data = np.ma.filled(mesh.get_array(), np.nan).ravel()
    assert len(data) == int(np.ceil(n / 4)) and data[0] == pytest.approx(45.0)


def test_cn0_overview_bars_per_receiver():
    rows = "file,receiver,satellite,signal,epochs,first_epoch,last_epoch,mean_cn0_dbhz,gaps,loss_of_lock\n" + "".join(
        f"{rx}.rnx,{rx},{sat},{sig},10,a,b,{cn0},0,0\n"
        for rx, base in (("GPS-0", 45.0), ("GPS-2", 41.0))
        for sat, d in (("G01", 0.0), ("G07", 2.0))
        for sig, cn0 in (("1C", base + d), ("2W", "" if sat == "G07" and rx == "GPS-2" else base - 8 + d)))
    fig = I.cn0_overview_figure(rows, {"set": "S"})
    ax1, ax2 = fig.axes[:2]
    assert ax1.get_ylabel() == "1C: mean C/N0 [dB-Hz]" and ax2.get_ylabel() == "2W: mean C/N0 [dB-Hz]"
    heights = {c.get_label(): [p.get_height() for p in c] for c in ax1.containers}
    assert heights == {"GPS-0": [45.0, 47.0], "GPS-2": [41.0, 43.0]}
    h2 = {c.get_label(): [p.get_height() for p in c] for c in ax2.containers}
    assert h2["GPS-2"] == [33.0, 0.0]  # missing C/N0 -> empty bar, never invented
    assert [t.get_text() for t in ax1.get_xticklabels()] == ["G01", "G07"]


def test_pcv_maps_one_colour_scale_and_blank_bins():
    maps = [pcv_map(("GPS-2", "GPS-0"), "L1", 20.0), pcv_map(("GPS-2", "GPS-1"), "L1", 12.0),
            pcv_map(("GPS-2", "GPS-0"), "L2", 23.0), pcv_map(("GPS-2", "GPS-1"), "L2", 8.0)]
    fig = C.pcv_maps_figure(maps, context={"job": "abc"})
    polar = [a for a in fig.axes if a.name == "polar"]
    assert [a.get_title().split("\n")[0] for a in polar] == ["GPS-2/GPS-0 · L1", "GPS-2/GPS-1 · L1",
                                                             "GPS-2/GPS-0 · L2", "GPS-2/GPS-1 · L2"]
    clims = {a.collections[0].get_clim() for a in polar}
    assert clims == {(-25.0, 25.0)}  # the largest |value| (< 23 mm) rounded up to 5 mm, for all four maps
    mesh = polar[2].collections[0]
    arr = mesh.get_array().reshape(18, 36)
    _, _, grid = C.map_grid(maps[2])
    np.testing.assert_allclose(np.ma.filled(arr, np.nan), grid)
    assert arr.mask[:2].all() and not arr.mask[2:].any()  # null bins (el < 10 deg) left blank
    assert "576 bins filled" in polar[0].get_title()
    # radius is 90 - elevation: the innermost ring is the highest elevation bin
    theta, radius, _ = C.map_grid(maps[0])
    assert radius[0] == pytest.approx(90.0) and radius[-1] == pytest.approx(0.0)
    assert theta[0] == pytest.approx(0.0) and theta[-1] == pytest.approx(2 * np.pi)
    assert any("differential PCV [mm]" in a.get_ylabel() for a in fig.axes)
    assert C.pcv_maps_plot(maps, limit_mm=30).startswith(PNG_MAGIC)


def test_pcv_counts_and_shape_check():
    maps = [pcv_map(), pcv_map(frequency="L2")]
    polar = [a for a in C.pcv_maps_figure(maps, kind="count").axes if a.name == "polar"]
    assert polar[0].collections[0].get_clim() == (0.0, 61.0)
    bad = pcv_map()
    bad["values_mm"] = bad["values_mm"][:-1]
    with pytest.raises(ValueError, match="expected"):
        C.pcv_maps_figure([bad])
    assert C.pcv_counts_plot(maps).startswith(PNG_MAGIC)


def test_baselines_table():
    doc = {"platform": "P", "frames": "body", "baselines": [
        {"from": "GPS-2", "to": "GPS-0", "a_priori_m": [1.04653, -0.07191, 0.0],
         "calibrated_m": [1.0502, -0.0701, 0.0042], "sigma_m": [0.0002, 0.0003, 0.0005], "n_epochs": 6000}]}
    columns, rows = C.baselines_table(doc)
    assert rows[0] == ["GPS-2>GPS-0", "x", "1.0465", "1.0502", "+3.7", "0.20", "6000"]
    assert rows[2][4] == "+4.2" and rows[3][1] == "length"
    fig = C.baselines_table_figure(doc)
    cells = fig.axes[0].tables[0].get_celld()
    assert cells[(0, 4)].get_text().get_text().replace("\n", " ") == "difference [mm]"
    assert cells[(1, 4)].get_text().get_text() == "+3.7"


def test_table5_layout_and_statistics():
    t = T.table5(ttff_runs(never={(1, "L2", "GPS-1/GPS-2")}))
    assert t["columns"] == ["Yaw [°]", "Pitch [°]", "Roll [°]", "L1/L2 [s] GPS-0/GPS-2", "L1/L2 [s] GPS-1/GPS-2",
                            "L1 [s] GPS-0/GPS-2", "L1 [s] GPS-1/GPS-2", "L2 [s] GPS-0/GPS-2", "L2 [s] GPS-1/GPS-2"]
    assert t["rows"][0] == ["27.1", "42.1", "7.5", "0.0", "0.0", "0.0", "0.0", "2.0", "0.0"]
    assert t["rows"][1][-1] == "–"  # never fixed
    inst, mean, nofix = t["footer"]
    # seed 000 Table 5 cases 1-3: L1 0-2 TTFF 0, 1, 46 -> 33 % instant, mean non-zero 23.5 s
    assert inst[5] == "33" and mean[5] == "23.5"
    assert inst[8] == "67" and nofix[8] == "1"  # L2 1-2: 0, never, 0
    fig = T.ttff_table_figure(ttff_runs())
    cells = fig.axes[0].tables[0].get_celld()
    assert cells[(4, 0)].get_text().get_text() == "Instant fix [%]"
    assert cells[(1, 7)].get_text().get_text() == f"{TABLE5_FIRST_ROWS[0][7]:.1f}"


def test_ttff_histogram_counts():
    fig = T.ttff_histogram_figure(ttff_runs())
    axes = fig.axes
    assert [a.get_title() for a in axes] == ["L1/L2", "L1", "L2"]
    l1 = {c.get_label(): [p.get_height() for p in c] for c in axes[1].containers}
    # L1, GPS-0/GPS-2: TTFF 0, 1, 46 s in 1 s bins
    (label, heights), = [(k, v) for k, v in l1.items() if k.startswith("GPS-0/GPS-2")]
    assert heights[0] == 1 and heights[1] == 1 and heights[46] == 1 and sum(heights) == 3
    assert "33% instant" in label
    assert axes[-1].get_xlabel().startswith("time to first fix [s]")
    assert T.ttff_histogram_plot(ttff_runs()).startswith(PNG_MAGIC)


def test_html_report_self_contained():
    png = C.pcv_maps_plot([pcv_map()])
    tables = {"Table 5": T.table5(ttff_runs()), "runs": [{"set": "a<b", "ttff_s": 1.0}]}
    doc = html_report("Report <of> job & set", {"epochs": 6360, "fix_rate": 0.995, "ttff_s": {"GPS-2>GPS-0": 3.0},
                                                "note": None}, {"PCV maps": png}, tables)
    assert doc.startswith("<!DOCTYPE html>") and "Report &lt;of&gt; job &amp; set" in doc
    assert "<script" not in doc and "http://" not in doc and "https://" not in doc  # nothing fetched
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', doc)
    assert len(images) == 1 and base64.b64decode(images[0]) == png
    assert "ttff_s.GPS-2&gt;GPS-0" in doc and "0.995" in doc and "a&lt;b" in doc
    assert "<tfoot>" in doc and "Instant fix [%]" in doc


def test_plots_and_report_import_no_web_code():
    code = ("import sys, gnssatt.plots.attitude, gnssatt.plots.inspect, gnssatt.plots.calibration, "
            "gnssatt.plots.ttff, gnssatt.report\n"
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
            "('fastapi', 'starlette', 'sqlalchemy', 'huey', 'httpx', 'app'))\nprint(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == ""


def test_calibration_and_ttff_bundles():
    from gnssatt.plots.calibration import calibration_plots
    from gnssatt.plots.ttff import ttff_plots

    doc = {"platform": "P", "frames": "body", "baselines": [{"from": "A", "to": "B", "a_priori_m": [1, 0, 0],
                                                            "calibrated_m": [1.001, 0, 0], "sigma_m": [1e-4] * 3,
                                                            "n_epochs": 10}]}
    assert list(calibration_plots([pcv_map()], doc)) == ["pcv_maps.png", "pcv_counts.png", "baselines_table.png"]
    assert list(ttff_plots(ttff_runs())) == ["ttff_table.png", "ttff_histogram.png"]
