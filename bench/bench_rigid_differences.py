"""Where `baseline_update` "rigid" and "additive" differ on seed 000 Fig. 6's slews (bench_attitude.SLEWS, clean,
dynamic mode, "all phases"; docs/BENCHMARKS.md "Rigid update: compiled kernels, the first fixed epoch and the
manoeuvre onset"). Print only.

--first-fix (simulator seeds --seeds, both slews): smoother_adaptive_noise's error at the first fixed epoch k0 with
additive, with rigid, and with the rigid forward filter but the last backward pass swapped: the linear RTS step
(gnssatt.attitude.smoother.rts_smooth), and the linear step with the rigid length rule (`linear_rigid_length`:
input radial = the length difference, output length |b_f| + r . delta); the baselines' length errors at k0 and the
chi-square of their 6 errors against the (unscaled) smoothed covariance, rigid and linear.

--onset (seeds --seeds, pitch manoeuvre): Table 1's forward filter, max error after the first 30 s of fixes and its
epoch, 95th percentile, mean after 30 s, additive and rigid; and the peak over t = 60-90 s (the pitch-up's onset)
with the retraction's two parts apart: the estimate additive with P turned (`turn_only`), the retraction without
the turn (`no_turn`); and the retraction with P <- J P J^T (`jacobian`), J = d(retraction)/d(x+) of the whole
state by central differences (identity outside the baselines' rows; the coupling of the baselines through the
common rotation included), against the code's per-baseline turn.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_rigid_differences.py --first-fix [--seeds 0-7]
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_rigid_differences.py --onset [--seeds 0-23]
    OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/bench_rigid_differences.py --onset-sigmas [--seeds 7]

--onset-sigmas: the forward filter's sigmas after each update through the pitch-up's onset, additive and rigid:
length (along the estimate b) and across b (rms of the two axes), mm, mean over the baselines, and omega (deg/s,
rms of the three axes), with the attitude error.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from bench.bench_attitude import CLEAN, SLEWS, files_of  # noqa: E402


def linear_rigid_length(x_post, P_post, x_prior, P_prior, Phi, start, n_bl):
    """The linear RTS step (smoother.rts_smooth) but for the lengths: the input's radial part replaced by the
    length difference |b_s| - |b_p| and the output's length set to |b_f| + r_f . delta (the rigid step's rule)."""
    from gnssatt.attitude.rts_links import rts_links

    r0 = x_post.shape[1] - 3 * n_bl
    xs, Ps = x_post.copy(), P_post.copy()
    for k, C in rts_links(x_post, P_post, x_prior, P_prior, Phi, start):
        j = k + 1
        d = xs[j] - x_prior[j]
        bs, bp, db = xs[j, r0:].reshape(n_bl, 3), x_prior[j, r0:].reshape(n_bl, 3), d[r0:].reshape(n_bl, 3)
        up = bp / np.linalg.norm(bp, axis=1, keepdims=True)
        radial = np.linalg.norm(bs, axis=1) - np.linalg.norm(bp, axis=1) - np.sum(db * up, 1)
        d[r0:] = (db + radial[:, None] * up).ravel()
        delta = C @ d
        xs[k] = x_post[k] + delta
        bf = x_post[k, r0:].reshape(n_bl, 3)
        L = np.linalg.norm(bf, axis=1) + np.sum(bf / np.linalg.norm(bf, axis=1, keepdims=True)
                                                * delta[r0:].reshape(n_bl, 3), 1)
        bn = xs[k, r0:].reshape(n_bl, 3)
        xs[k, r0:] = (bn / np.linalg.norm(bn, axis=1, keepdims=True) * L[:, None]).ravel()
        Ps[k] = P_post[k] + C @ (Ps[j] - P_prior[j]) @ C.T
    return xs, Ps


@contextlib.contextmanager
def last_backward_pass(step, keep: dict):
    """smoother.backward_pass with the rigid update's last call (the one smooth_filter_result makes; the first of
    smoother_adaptive_noise sets the noise profile) done by `step` (None: unchanged); keep["P"]: its covariance."""
    import gnssatt.attitude.smoother as SM

    orig, calls = SM.backward_pass, []

    def bp(sd, start, n_bl, settings=None):
        calls.append(1)
        if step is None or settings is None or settings.baseline_update != "rigid" or len(calls) == 1:
            out = orig(sd, start, n_bl, settings)
        else:
            out = step(sd["x_post"], sd["P_post"], sd["x_prior"], sd["P_prior"], sd["Phi"], start, n_bl)
        keep["P"] = out[1]
        return out

    SM.backward_pass = bp
    try:
        yield
    finally:
        SM.backward_pass = orig


def retraction_jacobian(b_m: np.ndarray, b_prior_m: np.ndarray, active: np.ndarray, h_m: float = 1e-6) -> np.ndarray:
    """(3 n_bl, 3 n_bl) d(retracted baselines)/d(baselines after the additive update) at b_m (n_bl, 3) by central
    differences of step h_m (baselines ~1 m: ~1e-9 relative truncation) of rigid_update.rigid_retract."""
    from gnssatt.attitude.rigid_update import rigid_retract

    n = b_prior_m.shape[0]
    idx = np.arange(3 * n).reshape(n, 3)

    def f(bvec):
        x = bvec.copy()
        rigid_retract(x, np.eye(3 * n), b_prior_m, idx, active)
        return x

    b = b_m.ravel()
    J = np.empty((3 * n, 3 * n))
    for i in range(3 * n):
        e = np.zeros(3 * n)
        e[i] = h_m
        J[:, i] = (f(b + e) - f(b - e)) / (2.0 * h_m)
    return J


@contextlib.contextmanager
def retraction(variant: str):
    """The forward filter's rigid retraction as given ("rigid"), without its turn of P ("no_turn"), only that
    turn with the additive estimate ("turn_only"), or with P <- J P J^T ("jacobian", retraction_jacobian)
    (gnssatt.attitude.boxes.measurement_update's reference to it)."""
    import gnssatt.attitude.boxes.measurement_update as MU
    from gnssatt.attitude.rigid_update import rigid_retract

    def no_turn(x, P, *a):
        P0 = P.copy()
        out = rigid_retract(x, P, *a)
        P[:] = P0
        return out

    def turn_only(x, P, *a):
        x0 = x.copy()
        out = rigid_retract(x, P, *a)
        x[:] = x0
        return out

    def jacobian(x, P, b_prior, b_idx, active):
        idx = b_idx.ravel()
        J = retraction_jacobian(x[idx].reshape(-1, 3), b_prior, active)
        out = rigid_retract(x, np.zeros_like(P), b_prior, b_idx, active)      # the estimate only
        P[idx, :] = J @ P[idx, :]
        P[:, idx] = P[:, idx] @ J.T
        return out

    MU.rigid_retract = {"rigid": rigid_retract, "no_turn": no_turn, "turn_only": turn_only,
                        "jacobian": jacobian}[variant]
    try:
        yield
    finally:
        MU.rigid_retract = rigid_retract


def run(d: Path, inputs, update: str, cfg: dict):
    from gnssatt.attitude.process import process
    from gnssatt.attitude.settings import AttitudeSettings
    from gnssatt.attitude.truth import attitude_errors_deg

    sol = process(inputs, AttitudeSettings.preset("all-phases", mode="dynamic", baseline_update=update, **cfg))
    ang, _ = attitude_errors_deg(d, sol)
    fi = np.flatnonzero(sol.att_fixed)
    t = np.asarray(sol.pobs.time - sol.pobs.time[0], float)[sol.att_epochs]
    return sol, ang, fi, t


def first_fix_line(d: Path, inputs) -> str:
    """Errors at k0 (deg) of additive / rigid / rigid + linear / rigid + linear_rigid_length, lengths (mm) and
    chi-square at k0 of rigid and rigid + linear."""
    from gnssatt.attitude.smoother import fixed_runs, rts_smooth
    from gnssatt.attitude.truth import truth_at
    from gnssatt.gnss import rotations as rot

    pl = json.loads((d / "platform.json").read_text())
    pos = {k: np.array(v["position_m"]) for k, v in pl["antennas"].items()}
    bb = np.array([pos[b] - pos[a] for a, b in pl["baselines"]])
    cfg = {"smoother": True, "smoother_adaptive_noise": True}
    err, extra = [], []
    lin = lambda *a: rts_smooth(*a[:6])  # noqa: E731
    for update, step in (("additive", None), ("rigid", None), ("rigid", lin), ("rigid", linear_rigid_length)):
        keep = {}
        with last_backward_pass(step, keep):
            sol, ang, fi, _ = run(d, inputs, update, cfg)
        err.append(f"{ang[fi[0]]:.3f}")
        if update == "rigid" and step in (None, lin):
            fr = sol.fr
            k0 = int(np.flatnonzero(fixed_runs(fr)[0])[0])
            q, _ = truth_at(d, sol)
            bt = bb @ rot.quat_to_dcm(q[int(np.flatnonzero(sol.att_epochs == k0)[0])])
            e = fr.b_ecef_m[k0].ravel() - bt.ravel()
            dl = (np.linalg.norm(fr.b_ecef_m[k0], axis=1) - np.linalg.norm(bb, axis=1)) * 1e3
            chi2 = float(e @ np.linalg.solve(keep["P"][k0, -6:, -6:], e))
            extra.append(f"L {dl[0]:+.2f} {dl[1]:+.2f} mm chi2 {chi2:.1f}")
    return ("k0 error additive / rigid / rigid+linear / rigid+linear-rigid-length " + " / ".join(err)
            + " deg\trigid " + extra[0] + "\trigid+linear " + extra[1])


def onset_line(d: Path, inputs) -> str:
    out = []
    for name, update, variant in (("additive", "additive", "rigid"), ("rigid", "rigid", "rigid"),
                                  ("turn_only", "rigid", "turn_only"), ("no_turn", "rigid", "no_turn"),
                                  ("jacobian", "rigid", "jacobian")):
        with retraction(variant):
            _, ang, fi, t = run(d, inputs, update, {})
        late = fi[t[fi] > t[fi[0]] + 30.0]
        onset = fi[(t[fi] > 60.0) & (t[fi] < 90.0)]
        km = late[np.argmax(ang[late])]
        s = f"{name}: onset peak {ang[onset].max():.3f}"
        if name in ("additive", "rigid", "jacobian"):
            s += (f" max after 30 s {ang[late].max():.3f} at t {t[km]:.0f} s p95 {np.percentile(ang[fi], 95):.3f} "
                  f"mean after 30 s {ang[late].mean():.4f}")
        out.append(s)
    return "\t".join(out)


@contextlib.contextmanager
def recorded_sigmas(rec: list):
    """gnssatt.attitude.filter's measurement_update followed by a record (t, length sigma mm, across-b sigma mm,
    omega sigma deg/s) once every baseline has been fixed."""
    import gnssatt.attitude.filter as F

    orig = F.measurement_update

    def wrap(run_, ep):
        orig(run_, ep)
        if run_.dynamic and run_.ever_fixed.all():
            x, P = run_.st.x, run_.st.P
            rad, across = [], []
            for ix in run_.b_idx:
                u, B = x[ix] / np.linalg.norm(x[ix]), P[np.ix_(ix, ix)]
                rad.append(u @ B @ u)
                across.append((np.trace(B) - u @ B @ u) / 2.0)
            rec.append((float(ep.t), 1e3 * np.mean(np.sqrt(rad)), 1e3 * np.mean(np.sqrt(across)),
                        float(np.degrees(np.sqrt(np.trace(P[:3, :3]) / 3.0)))))

    F.measurement_update = wrap
    try:
        yield
    finally:
        F.measurement_update = orig


def onset_sigmas_lines(d: Path, inputs) -> list[str]:
    """At t = 40-100 s: the attitude error and the recorded sigmas (recorded_sigmas) of additive and rigid
    (the filter's epoch time ep.t is seconds from the first epoch, as run's t)."""
    out = {}
    for update in ("additive", "rigid"):
        rec = []
        with recorded_sigmas(rec):
            _, ang, fi, t = run(d, inputs, update, {})
        out[update] = ang, fi, t, np.array(rec)
    lines = []
    for tq in (40, 60, 65, 70, 72, 75, 78, 81, 85, 90, 100):
        s = f"t {tq} s"
        for update, (ang, fi, t, rec) in out.items():
            i = fi[np.argmin(abs(t[fi] - tq))]
            r = rec[np.argmin(abs(rec[:, 0] - tq))]
            s += (f"\t{update}: error {ang[i]:.3f} deg (t {t[i]:.0f}), sigma length {r[1]:.4f} mm across {r[2]:.3f} "
                  f"mm omega {r[3]:.5f} deg/s (t {r[0]:.0f})")
        lines.append(s)
    return lines


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--first-fix", action="store_true")
    ap.add_argument("--onset", action="store_true")
    ap.add_argument("--onset-sigmas", action="store_true")
    ap.add_argument("--seeds", default="0-7", help="a-b or a,b,c")
    args = ap.parse_args()
    from gnssatt.attitude.process import load_inputs
    from gnssatt.sim import simulate_scenario

    a, _, b = args.seeds.partition("-")
    seeds = range(int(a), int(b) + 1) if b else [int(s) for s in args.seeds.split(",")]
    pitch = [("pitch manoeuvre (11 min)", SLEWS["pitch manoeuvre (11 min)"])]
    slews = pitch if (args.onset or args.onset_sigmas) else list(SLEWS.items()) if args.first_fix else []
    with tempfile.TemporaryDirectory() as tmp:
        for label, over in slews:
            for seed in seeds:
                d = Path(tmp) / f"{label[:3]}{seed}"
                simulate_scenario("slew", d, seed=seed, overrides={**over, **CLEAN})
                inputs = load_inputs(files_of(d))
                if args.onset_sigmas:
                    for line in onset_sigmas_lines(d, inputs):
                        print(f"{label}\t{seed}\t{line}", flush=True)
                    continue
                line = onset_line(d, inputs) if args.onset else first_fix_line(d, inputs)
                print(f"{label}\t{seed}\t{line}", flush=True)


if __name__ == "__main__":
    main()
