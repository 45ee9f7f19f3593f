"""Attitude plots read back: the data handed to the axes, labels and titles, against products with known answers."""
from __future__ import annotations

import numpy as np
import pytest
from matplotlib import dates as mdates

from tests.plots.builders import (SATS, attitude_case, baselines_case, events_case, residuals_case, sat_directions,
                                  times)
from gnssatt.plots import attitude as A
from gnssatt.plots.common import PlotContext, read_csv_table

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
CTX = PlotContext(set_name="sim earth-pointing", job_id="0123456789abcdef", config={"mode": "kinematic",
                                                                                    "frequencies": ["L1", "L2"]})


def _line(ax, label_start: str):
    hits = [ln for ln in ax.get_lines() if ln.get_label().startswith(label_start)]
    assert len(hits) == 1, [ln.get_label() for ln in ax.get_lines()]
    return hits[0]


@pytest.mark.parametrize("ref_kind", ["quaternion", "euler"])
def test_euler_errors_recover_injected_errors(ref_kind):
    att, ref_q, ref_e, _ = attitude_case(error_deg=(0.10, -0.20, 0.05))
    errors = A.euler_errors(att, ref_q if ref_kind == "quaternion" else ref_e)
    # estimate = truth + (0.10, -0.20, 0.05) deg exactly; yaw crosses +-180 deg inside the span
    for axis, want in (("yaw", 0.10), ("pitch", -0.20), ("roll", 0.05)):
        np.testing.assert_allclose(errors[f"{axis}_deg"], want, atol=1e-6)


def test_reference_from_quaternions_is_reference_euler():
    att, ref_q, _, truth = attitude_case()
    ref = A.reference_euler(att, ref_q)
    np.testing.assert_allclose(A.wrap_deg(ref["yaw_deg"] - truth["yaw"]), 0, atol=1e-6)
    np.testing.assert_allclose(ref["pitch_deg"], truth["pitch"], atol=1e-6)
    np.testing.assert_allclose(ref["roll_deg"], truth["roll"], atol=1e-6)


def test_reference_gap_and_outside_span_are_nan():
    att, _, ref_e, _ = attitude_case(n=120)
    lines = ref_e.splitlines()
    # keep rows 0..9 and 100..119 only: a 90 s gap (> MAX_REFERENCE_GAP_S) and nothing after 119
    kept = "\n".join([lines[0]] + lines[1:11] + lines[101:121]) + "\n"
    errors = A.euler_errors(att, kept)
    finite = np.isfinite(errors["yaw_deg"])
    assert finite[:10].all() and not finite[10:100].any() and finite[100:].all()


def test_euler_figure_data_labels_and_title():
    att, ref_q, _, truth = attitude_case(error_deg=(0.1, -0.2, 0.05), float_epochs=range(0, 10))
    fig = A.euler_figure(att, ref_q, CTX)
    top, bottom = fig.axes[:2]
    t_num = mdates.date2num(truth["time"])
    # top: estimates split into fixed and float epochs, reference lines through every epoch
    yaw_fixed = _line(top, "yaw (fixed)")
    np.testing.assert_allclose(mdates.date2num(yaw_fixed.get_xdata()), t_num[10:])
    np.testing.assert_allclose(A.wrap_deg(np.asarray(yaw_fixed.get_ydata()) - truth["yaw"][10:]), 0.1, atol=1e-6)
    assert len(_line(top, "yaw (float)").get_xdata()) == 10
    np.testing.assert_allclose(_line(top, "pitch reference").get_ydata(), truth["pitch"], atol=1e-6)
    # bottom: errors with the seed 000 offsets (roll +1.5, pitch -1.5), stats from fixed epochs in the label
    roll = _line(bottom, "roll error")
    np.testing.assert_allclose(np.asarray(roll.get_ydata()) - 1.5, 0.05, atol=1e-6)
    pitch = _line(bottom, "pitch error")
    np.testing.assert_allclose(np.asarray(pitch.get_ydata()) + 1.5, -0.2, atol=1e-6)
    assert "bias -0.200°" in pitch.get_label() and "std 0.000°" in pitch.get_label()
    assert top.get_ylabel() == "Euler angle [deg]" and "[deg]" in bottom.get_ylabel()
    assert bottom.get_xlabel() == "GPS time [hh:mm:ss] on 2018-06-06"
    title = fig.get_suptitle()
    assert "set sim earth-pointing" in title and "job 01234567" in title and "mode=kinematic" in title
    assert "frequencies=L1+L2" in title


def test_euler_without_reference_shows_formal_sigma():
    att, _, _, truth = attitude_case(n=30)
    fig = A.euler_figure(att)
    bottom = fig.axes[1]
    np.testing.assert_allclose(_line(bottom, "formal 1σ pitch").get_ydata(), 0.3)
    assert bottom.get_ylabel() == "formal 1σ [deg]"


def test_euler_plot_png_and_empty_input():
    att, ref_q, _, _ = attitude_case(n=20)
    png = A.euler_plot(att, ref_q, CTX)
    assert png.startswith(PNG_MAGIC) and len(png) > 10_000
    empty = A.euler_plot("time_gps,yaw_deg,pitch_deg,roll_deg,fixed\n")
    assert empty.startswith(PNG_MAGIC)


def test_status_spans_split_on_change_and_gap():
    t = times(30)
    fixed = np.array([0] * 5 + [1] * 25, bool)
    keep = np.r_[0:15, 20:30]  # a 6 s gap
    spans = A.status_spans(t[keep], fixed[keep])
    assert [(str(a)[11:19], str(b)[11:19], f) for a, b, f in spans] == [
        ("12:20:00", "12:20:05", False), ("12:20:05", "12:20:15", True), ("12:20:20", "12:20:30", True)]


def test_fix_status_figure_lanes_counts_events():
    att, _, _, truth = attitude_case(n=60, float_epochs=range(0, 4))
    fig = A.fix_status_figure(att, baselines_case(n=50), events_case(), CTX)
    lanes, events, counts = fig.axes[:3]
    assert [t.get_text() for t in lanes.get_yticklabels()] == ["attitude", "baseline GPS-2>GPS-0",
                                                               "baseline GPS-2>GPS-1"]
    # the attitude lane: one float bar of 4 s then one fixed bar of 56 s (in days on the date axis)
    bars = lanes.collections[:2]
    widths = sorted(round(p.get_extents().width, 3) for c in bars for p in c.get_paths())
    assert len(widths) == 2
    np.testing.assert_allclose(_line(counts, "attitude").get_ydata(), truth["n_sats"])
    np.testing.assert_allclose(_line(counts, "baseline GPS-2>GPS-1").get_ydata(), 8)
    assert set(lanes.get_legend_handles_labels()[1]) == {"fixed", "float"}
    # events in their own rows, labelled with their counts, so the lanes stay readable
    assert {"fix (1)", "cycle_slip (2)", "clock_jump (1)"} <= {t.get_text() for t in events.get_yticklabels()}
    assert {"fix (1)", "cycle_slip (2)", "clock_jump (1)"} <= set(events.get_legend_handles_labels()[1])
    assert counts.get_ylabel() == "satellites used"


def test_dop_from_directions_known_geometry():
    # four satellites: zenith and three at 0 deg elevation 120 deg apart: closed form
    az = np.array([0.0, 0.0, 120.0, 240.0])
    el = np.array([90.0, 0.0, 0.0, 0.0])
    hdop, vdop = A.dop_from_directions(az, el)
    # G^T G = diag(1.5, 1.5, 1, 4) + coupling of z and clock (sum sin el = 1): [[1, 1], [1, 4]] block
    q_zc = np.linalg.inv(np.array([[1.0, 1.0], [1.0, 4.0]]))
    np.testing.assert_allclose(hdop, np.sqrt(2 / 1.5), rtol=1e-12)
    np.testing.assert_allclose(vdop, np.sqrt(q_zc[0, 0]), rtol=1e-12)
    # fewer than four satellites: no DOP
    assert np.isnan(A.dop_from_directions(az[:3], el[:3])[0]).all()


def test_dop_series_and_figure_from_residuals():
    res, _ = residuals_case(n=20, signals=("L1C", "L2W"))
    series = A.dop_series(res)
    assert set(series) == {"GPS-2>GPS-0", "GPS-2>GPS-1"}
    s = series["GPS-2>GPS-0"]
    dirs = sat_directions(20)
    used = [sat for sat in SATS if dirs[sat][1][7] > 0]
    want_h, want_v = A.dop_from_directions([dirs[x][0][7] for x in used], [dirs[x][1][7] for x in used])
    assert s["n_sats"][7] == len(used)  # one direction per satellite even with two signals
    np.testing.assert_allclose([s["hdop"][7], s["vdop"][7]], [want_h[0], want_v[0]], rtol=1e-3)
    fig = A.dop_figure(res, context=CTX)
    ax = fig.axes[0]
    np.testing.assert_allclose(_line(ax, "HDOP GPS-2>GPS-0").get_ydata(), s["hdop"])
    assert ax.get_ylabel() == "DOP [-]"


def test_dop_figure_prefers_attitude_columns():
    att, _, _, _ = attitude_case(n=10)
    lines = att.splitlines()
    att2 = "\n".join([lines[0] + ",hdop,vdop"] + [ln + f",1.{i},2.{i}" for i, ln in enumerate(lines[1:])]) + "\n"
    ax = A.dop_figure(None, att2).axes[0]
    np.testing.assert_allclose(_line(ax, "VDOP").get_ydata(), [2.0 + i / 10 for i in range(10)])


def test_residuals_figure_per_baseline_and_signal():
    res, truth = residuals_case(n=30)
    fig = A.residuals_figure(res, CTX)
    phase_ax = [a for a in fig.axes if a.get_title().startswith("GPS-2>GPS-1 · phase")][0]
    code_ax = [a for a in fig.axes if a.get_title().startswith("GPS-2>GPS-0 · code")][0]
    l1 = _line(phase_ax, "L1C")
    np.testing.assert_allclose(l1.get_ydata(), truth["phase"][("GPS-2>GPS-1", "L1C")])
    rms = np.sqrt(np.mean(np.square(truth["phase"][("GPS-2>GPS-1", "L1C")])))
    assert f"RMS {rms:.3g} mm" in l1.get_label()
    np.testing.assert_allclose(_line(code_ax, "L2W").get_ydata(), truth["code"][("GPS-2>GPS-0", "L2W")])
    assert phase_ax.get_ylabel() == "phase residual [mm]" and code_ax.get_ylabel() == "code residual [m]"
    assert "rejected not shown" in phase_ax.get_title()  # satellites below the antenna plane


def test_skyplot_antenna_frame_and_cn0_colours():
    res, _ = residuals_case(n=40)
    fig = A.skyplot_figure(res, CTX)
    polar = [a for a in fig.axes if a.name == "polar"]
    assert len(polar) == 2
    sc = polar[0].collections[0]
    offsets = np.asarray(sc.get_offsets())
    assert len(offsets) == 40 * len(SATS)  # one point per epoch and satellite, not per signal
    table = read_csv_table(res)
    first = (table["baseline"] == "GPS-2>GPS-0") & (table["signal"] == "L1C")
    np.testing.assert_allclose(np.sort(offsets[:, 1]), np.sort(90.0 - table["elevation_deg"][first]))
    np.testing.assert_allclose(np.sort(sc.get_array()), np.sort(table["cn0_dbhz"][first]))
    assert polar[0].get_theta_direction() == -1 and polar[0].get_ylim()[1] > 90  # tracks below the plane shown
    assert any("C/N0 [dB-Hz]" == a.get_ylabel() for a in fig.axes)


def test_plots_accept_empty_products():
    for png in (A.residuals_plot("time_gps,baseline\n"), A.skyplot_plot(""), A.dop_plot(None),
                A.fix_status_plot()):
        assert png.startswith(PNG_MAGIC)


def _long_layout(wide_csv: str) -> str:
    """The wide builder rows rewritten as gnssatt/attitude writes residuals.csv: one row per observable
    (observable = code | phase, residual_m), sat / az_ant_deg / el_ant_deg column names."""
    table = read_csv_table(wide_csv)
    out = ["time_gps,gps_sow,baseline,sat,signal,observable,residual_m,az_ant_deg,el_ant_deg,cn0_dbhz,used,reason"]
    for i in range(len(table["time_gps"])):
        common = [table["time_gps"][i], f"{table['gps_sow'][i]:.3f}", table["baseline"][i], table["satellite"][i],
                  table["signal"][i]]
        tail = [f"{table['azimuth_deg'][i]:.3f}", f"{table['elevation_deg'][i]:.3f}", f"{table['cn0_dbhz'][i]:.1f}",
                f"{int(table['used'][i])}", table["reason"][i]]
        out.append(",".join(common + ["code", f"{table['code_residual_m'][i]:.4f}"] + tail))
        out.append(",".join(common + ["phase", f"{table['phase_residual_mm'][i] / 1000.0:.6f}"] + tail))
    return "\n".join(out) + "\n"


def test_long_residual_layout_of_the_attitude_job():
    wide, truth = residuals_case(n=20)
    long = _long_layout(wide)
    phase, code = A.residual_values(read_csv_table(long))
    assert np.isfinite(phase).sum() == np.isfinite(code).sum() == len(read_csv_table(wide)["time_gps"])
    fig = A.residuals_figure(long)
    ax = [a for a in fig.axes if a.get_title().startswith("GPS-2>GPS-0 · phase")][0]
    np.testing.assert_allclose(_line(ax, "L2W").get_ydata(), truth["phase"][("GPS-2>GPS-0", "L2W")], atol=1e-9)
    code_ax = [a for a in fig.axes if a.get_title().startswith("GPS-2>GPS-1 · code")][0]
    np.testing.assert_allclose(_line(code_ax, "L1C").get_ydata(), truth["code"][("GPS-2>GPS-1", "L1C")])
    sky = A.skyplot_figure(long).axes[0].collections[0]
    assert len(sky.get_offsets()) == 20 * len(SATS)
    assert set(A.dop_series(long)) == {"GPS-2>GPS-0", "GPS-2>GPS-1"}


def test_attitude_plots_bundle_and_report():
    from gnssatt.report import html_report

    att, ref_q, _, _ = attitude_case(n=40)
    res, _ = residuals_case(n=40)
    pngs = A.attitude_plots({"attitude.csv": att, "residuals.csv": res, "baselines.csv": baselines_case(n=40),
                             "events.csv": events_case()}, ref_q, CTX)
    assert list(pngs) == ["euler.png", "fix_status.png", "dop.png", "residuals.png", "skyplot.png", "elevation.png",
                          "skyplot_fix.png"]
    assert all(p.startswith(PNG_MAGIC) for p in pngs.values())
    one_baseline = A.attitude_plots({"baselines.csv": baselines_case(n=10, names=("A>B",))})
    assert list(one_baseline) == ["fix_status.png"]
    doc = html_report("Attitude", {"epochs": 40}, pngs)
    assert doc.count("data:image/png;base64,") == 7
