"""Plots of a fusion run (PNG bytes): Euler angles with 1-sigma (seed 002 Figs. 4, 7), the fault flags (the full
processor's cost against its threshold, the isolated GPS faults, the delayed propagators' normalised residuals
against theirs; Figs. 2, 5) and the gyro drift estimate. With a reference attitude (e.g. a simulation's truth),
the errors of the fused and GPS solutions per axis (Fig. 7)."""
from __future__ import annotations

import io

import numpy as np

__all__ = ["fusion_plots"]


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


def _attitude_png(res, tab) -> bytes:
    import matplotlib.pyplot as plt

    t = (tab["time"] - res.gps.time[0]) / 60.0
    step = max(1, len(t) // 4000)
    fig, axes = plt.subplots(3, 2, figsize=(11, 7), sharex=True)
    for i, name in enumerate(("yaw", "pitch", "roll")):
        axes[i, 0].plot(t[::step], tab["euler"][::step, i], lw=0.6)
        axes[i, 0].set_ylabel(f"{name} (deg)")
        axes[i, 1].semilogy(t[::step], tab["sigma"][::step, i], lw=0.6)
        axes[i, 1].set_ylabel(f"sigma {name} (deg)")
    axes[2, 0].set_xlabel("minutes")
    axes[2, 1].set_xlabel("minutes")
    fig.suptitle("Fused attitude at the gyro rate (Euler angles to the orbital frame) and its 1-sigma")
    fig.tight_layout()
    return _png(fig)


def _faults_png(res) -> bytes:
    import matplotlib.pyplot as plt

    run = res.run
    t_ep = (res.gps.time - res.gps.time[0]) / 60.0
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    full = [(k, J / thr) for k, ref, ex, J, dof, thr in run.costs if ex == ""]
    if full:
        k, r = np.array(full).T
        a1.semilogy(t_ep[k.astype(int)], r, ".", ms=2, label="J / J* (all satellites)")
    det = [e[0] for e in run.gps_events]
    if det:
        a1.plot(t_ep[det], np.ones(len(det)), "rv", ms=4, label="GPS fault flagged")
    a1.axhline(1.0, color="k", lw=0.8)
    a1.set_ylabel("cost / threshold")
    a1.legend(fontsize=8)
    if run.gyro_tests:
        g = np.array(run.gyro_tests, float)
        for j in np.unique(g[:, 1]).astype(int):
            m = g[:, 1] == j
            a2.semilogy(t_ep[g[m, 0].astype(int)], g[m, 2:].max(axis=1), ".", ms=2, label=f"propagator {j}")
    a2.axhline(res.settings.gyro_fdi.threshold_sigma, color="k", lw=0.8)
    for e in run.gyro_events:
        a2.axvspan(t_ep[e.start], t_ep[e.end], color="r", alpha=0.15)
    a2.set_ylabel("max |r| / sigma")
    a2.set_xlabel("minutes")
    a2.legend(fontsize=7, ncol=3)
    fig.suptitle("Fault flags: exclusion bank (top), delayed propagators (bottom, gyro events shaded)")
    fig.tight_layout()
    return _png(fig)


def _bias_png(res) -> bytes:
    import matplotlib.pyplot as plt

    run = res.run
    t_ep = (res.gps.time - res.gps.time[0]) / 60.0
    ok = np.isfinite(run.bias[:, 0])
    s = np.sqrt(np.diagonal(run.bias_P, axis1=1, axis2=2))
    fig, ax = plt.subplots(figsize=(11, 3.5))
    for i, c in enumerate("xyz"):
        ax.plot(t_ep[ok], np.degrees(run.bias[ok, i]) * 3600, lw=0.8, label=f"{c}")
        ax.fill_between(t_ep[ok], np.degrees(run.bias[ok, i] - s[ok, i]) * 3600,
                        np.degrees(run.bias[ok, i] + s[ok, i]) * 3600, alpha=0.2)
    ax.set_ylabel("gyro drift (deg/h)")
    ax.set_xlabel("minutes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _png(fig)


def _errors_png(res, tab, reference) -> bytes | None:
    """Fused and GPS errors per body axis against a reference attitude (GCRF or ECEF quaternions at the same
    time tags, within 10 ms), seed 002 Fig. 7; None when no row matches."""
    import matplotlib.pyplot as plt

    from gnssatt.gnss import rotations as rot
    from gnssatt.gnss.frames import R_ecef_from_gcrf

    t_ref = reference.time - res.gps.time[0]
    q_ref = reference.q_body_from_frame.copy()
    ecef = reference.frame == "ECEF"
    if ecef.any():                                   # to GCRF -> body
        R = rot.quat_to_dcm(q_ref[ecef]) @ R_ecef_from_gcrf(reference.time[ecef])
        q_ref[ecef] = rot.dcm_to_quat(R)

    def match(t_s):
        j = np.clip(np.searchsorted(t_ref, t_s), 1, len(t_ref) - 1)
        j = np.where(np.abs(t_ref[j - 1] - t_s) < np.abs(t_ref[j] - t_s), j - 1, j)
        return j, np.abs(t_ref[j] - t_s) < 0.01

    t_f = tab["time"] - res.gps.time[0]
    j, ok = match(t_f)
    if not ok.any():
        return None
    e_f = np.degrees(rot.quat_to_rotvec(rot.quat_multiply(tab["qi"][ok], rot.quat_conjugate(q_ref[j[ok]]))))
    k = np.flatnonzero(np.isfinite(res.run.gps_q_body_from_ecef[:, 0]))
    q_g = rot.dcm_to_quat(rot.quat_to_dcm(res.run.gps_q_body_from_ecef[k]) @ R_ecef_from_gcrf(res.gps.time[k]))
    jg, okg = match(res.gps.time[k] - res.gps.time[0])
    e_g = np.degrees(rot.quat_to_rotvec(rot.quat_multiply(q_g[okg], rot.quat_conjugate(q_ref[jg[okg]]))))
    sig = tab["sigma"][ok][:, ::-1]                   # (roll, pitch, yaw) ~ body (x, y, z) near Earth pointing
    fig, axes = plt.subplots(3, 1, figsize=(11, 7), sharex=True)
    step = max(1, ok.sum() // 4000)
    for i, name in enumerate(("x (roll)", "y (pitch)", "z (yaw)")):
        ax = axes[i]
        ax.plot((res.gps.time[k][okg] - res.gps.time[0]) / 60, e_g[:, i], ".", ms=2, color="0.6", label="GPS")
        ax.plot(t_f[ok][::step] / 60, e_f[::step, i], lw=0.7, label="fused")
        ax.plot(t_f[ok][::step] / 60, sig[::step, i], "k:", lw=0.6, label="1 sigma")
        ax.plot(t_f[ok][::step] / 60, -sig[::step, i], "k:", lw=0.6)
        ax.set_ylabel(f"{name} error (deg)")
    axes[0].legend(fontsize=8, ncol=3)
    axes[2].set_xlabel("minutes")
    fig.suptitle("Errors against the reference attitude (body axes)")
    fig.tight_layout()
    return _png(fig)


def fusion_plots(res, tab: dict, reference=None) -> dict[str, bytes]:
    """{file name: PNG bytes}: attitude.png, faults.png, bias.png, and errors.png with a reference attitude
    (gnssatt.gnss.io.reference_attitude.ReferenceAttitude)."""
    import matplotlib

    matplotlib.use("Agg")
    out = {"attitude.png": _attitude_png(res, tab), "faults.png": _faults_png(res), "bias.png": _bias_png(res)}
    if reference is not None:
        png = _errors_png(res, tab, reference)
        if png is not None:
            out["errors.png"] = png
    return out
