"""Independent re-computations for the simulator tests, written apart from gnssatt/sim (no shared code).

Broadcast orbit/clock per IS-GPS-200 Table 20-IV from records read back by the project's nav reader,
light time + Sagnac, bilinear PCV lookup, quaternion -> matrix per CONVENTIONS.md.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

MU = 3.986005e14
WE = 7.2921151467e-5
C = 299792458.0
F_REL = -4.442807633e-10
LAM = {"L1": C / 1575.42e6, "L2": C / 1227.60e6}
GAMMA = (1575.42 / 1227.60) ** 2


def eph_eval(k, j, t_week_s, t_sow):
    """ECEF position (n,3) and clock (n,) of record j of KeplerEphemeris k at GPS (week, sow) arrays."""
    tk = (t_week_s - k.week[j]) * 604800.0 + (t_sow - k.toe_sow[j])
    a = k.sqrt_a_sqrt_m[j] ** 2
    n = np.sqrt(MU / a ** 3) + k.delta_n_rad_s[j]
    M = k.m0_rad[j] + n * tk
    E = M.copy()
    for _ in range(20):
        E = M + k.e[j] * np.sin(E)
    v = np.arctan2(np.sqrt(1 - k.e[j] ** 2) * np.sin(E), np.cos(E) - k.e[j])
    phi = v + k.omega_rad[j]
    du = k.cus_rad[j] * np.sin(2 * phi) + k.cuc_rad[j] * np.cos(2 * phi)
    dr = k.crs_m[j] * np.sin(2 * phi) + k.crc_m[j] * np.cos(2 * phi)
    di = k.cis_rad[j] * np.sin(2 * phi) + k.cic_rad[j] * np.cos(2 * phi)
    u = phi + du
    r = a * (1 - k.e[j] * np.cos(E)) + dr
    i = k.i0_rad[j] + di + k.idot_rad_s[j] * tk
    Om = k.omega0_rad[j] + (k.omega_dot_rad_s[j] - WE) * tk - WE * k.toe_sow[j]
    x, y = r * np.cos(u), r * np.sin(u)
    pos = np.stack([x * np.cos(Om) - y * np.cos(i) * np.sin(Om), x * np.sin(Om) + y * np.cos(i) * np.cos(Om),
                    y * np.sin(i)], -1)
    tc = (t_week_s - k.week[j]) * 604800.0 + (t_sow - k.toe_sow[j])   # toc == toe here
    clk = k.af0_s[j] + k.af1_s_s[j] * tc + k.af2_s_s2[j] * tc ** 2 + F_REL * k.e[j] * k.sqrt_a_sqrt_m[j] * np.sin(E)
    return pos, clk


def nearest_record(k, sat, week, sow):
    idx = np.nonzero(k.sat == sat)[0]
    dt = (week - k.week[idx]) * 604800.0 + sow - k.toe_sow[idx]
    return idx[np.argmin(np.abs(dt))]


def sat_range(k, sat, week, sow_rx, r_rx):
    """Light-time iterated range, unit LOS, satellite clock at transmission (Sagnac rotation included)."""
    j = nearest_record(k, sat, int(np.atleast_1d(week)[0]), float(np.median(sow_rx)))
    tau = np.full(len(sow_rx), 0.07)
    for _ in range(4):
        p, clk = eph_eval(k, j, week, sow_rx - tau)
        th = WE * tau
        ps = np.stack([np.cos(th) * p[:, 0] + np.sin(th) * p[:, 1], -np.sin(th) * p[:, 0] + np.cos(th) * p[:, 1],
                       p[:, 2]], -1)
        d = ps - r_rx
        rho = np.linalg.norm(d, axis=1)
        tau = rho / C
    return rho, d / rho[:, None], clk


def R_from_q(q):
    """Passive R(q) = (w^2 - |u|^2) I + 2 u u^T - 2 w [u x] (CONVENTIONS.md), q (n,4)."""
    w, u = q[:, 0], q[:, 1:]
    ux = np.zeros((len(q), 3, 3))
    ux[:, 0, 1], ux[:, 0, 2], ux[:, 1, 2] = -u[:, 2], u[:, 1], -u[:, 0]
    ux = ux - np.swapaxes(ux, 1, 2)
    return ((w ** 2 - np.sum(u * u, 1))[:, None, None] * np.eye(3) + 2 * u[:, :, None] * u[:, None, :]
            - 2 * w[:, None, None] * ux)


def bilinear(grid, az_nodes, el_nodes, az, el):
    from scipy.interpolate import RegularGridInterpolator
    f = RegularGridInterpolator((np.asarray(el_nodes), np.asarray(az_nodes)), np.asarray(grid))
    return f(np.stack([el, np.mod(az, 360.0)], -1))


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def load_model(set_dir: Path) -> dict:
    return json.loads((set_dir / "truth" / "model.json").read_text())
