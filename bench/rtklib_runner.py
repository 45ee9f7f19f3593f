"""Run RTKLIB 2.4.3 b34 `postpos` (through the `pyrtklib` bindings) on RINEX files and read its `.pos` output.

The outside authority of the attitude benchmarks and real-data tests (issue 6): the same observation files go
through RTKLIB's relative positioning (kinematic, static or moving-base) and through gnssatt, and the baselines
are compared. Only `bench/` and `tests/` use this module; the product never imports pyrtklib.

    from bench.rtklib_runner import options_for, run_postpos
    opts = options_for("kinematic", **{"pos1-navsys": "1", "pos1-elmask": "15"})
    sol = run_postpos(rover_obs, base_obs, [nav], opts, out_pos="/tmp/x.pos")
    sol.azimuth_deg(), sol.elevation_deg(), sol.length_m(), sol.fixed

Options are RTKLIB configuration-file keys (`pos1-posmode`, `pos2-armode`, ...) with their text values, exactly as
an `rnx2rtkp -k file.conf` would read them; `options_text(opts)` gives that file. Every key and value is checked
through RTKLIB's own `searchopt`/`str2opt`, so a misspelt option raises instead of being silently ignored (RTKLIB's
`loadopts` only prints a warning and keeps the default).

Implements: RTKLIB 2.4.3 b34 `postpos()` (src/postpos.c: input files rover obs, base obs, navigation), option
table `sysopts` (src/options.c), solution format of `outsol()` (src/solution.c, `out-solformat` llh/xyz/enu).
Neglects: RTKLIB's solution-status (.stat) and trace outputs; the velocity columns (`out-outvel`) are not read.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["RTKLIB_VERSION", "PosSolution", "options_for", "options_text", "read_pos", "run_postpos"]

RTKLIB_VERSION = "2.4.3 b34 (pyrtklib)"

#: RTKLIB options common to every mode here: output in ENU of the baseline at the base (RTKLIB's `rtk.rb`),
#: time as GPS week + seconds with millisecond resolution (free-running clocks move the solution time tag).
_COMMON = {
    "pos1-frequency": "l1+2",
    "pos1-soltype": "forward",
    "pos1-elmask": "15",
    "pos1-dynamics": "off",
    "pos1-tidecorr": "off",
    "pos1-ionoopt": "brdc",
    "pos1-tropopt": "saas",
    "pos1-sateph": "brdc",
    "pos1-navsys": "1",
    "pos2-armode": "continuous",
    "pos2-gloarmode": "off",
    "pos2-arthres": "3",
    "out-solformat": "enu",
    "out-outhead": "on",
    "out-outopt": "on",
    "out-timesys": "gpst",
    "out-timeform": "tow",
    "out-timendec": "3",
}

#: Per mode: kinematic/static need the base position (`ant2-*`); moving-base computes it every epoch by SPP.
_MODES = {
    "kinematic": {"pos1-posmode": "kinematic"},
    "static": {"pos1-posmode": "static"},
    "movingbase": {"pos1-posmode": "movingbase", "ant2-postype": "single"},
}


def options_for(mode: str, **overrides: str) -> dict[str, str]:
    """RTKLIB option dict (config-file key -> text value) for `mode` (kinematic, static, movingbase).

    Keyword names may use `_` for the first `-` (`pos1_elmask="-90"`) or pass a dict with `**{"pos1-elmask": "-90"}`.
    """
    if mode not in _MODES:
        raise ValueError(f"unknown RTKLIB mode {mode!r}; one of {sorted(_MODES)}")
    opts = {"pos1-posmode": _MODES[mode]["pos1-posmode"], **_COMMON, **_MODES[mode]}
    for k, v in overrides.items():
        opts[k if "-" in k else k.replace("_", "-", 1)] = str(v)    # pos1_snrmask_r -> pos1-snrmask_r
    return opts


def options_text(options: dict[str, str]) -> str:
    """The options as an RTKLIB configuration file (what `rnx2rtkp -k` or RTKPOST would load)."""
    return "".join(f"{k:<18} ={v}\n" for k, v in options.items())


def _load_options(options: dict[str, str], workdir: Path):
    """(prcopt_t, solopt_t, filopt_t, effective config text) from RTKLIB's defaults plus `options`.

    The options go through RTKLIB's own loadopts (a config file in `workdir`); saveopts then writes back what
    RTKLIB understood, and every given key must be there with the given value (loadopts skips unknown keys
    silently and keeps the default on a bad value).
    """
    import pyrtklib as rtk

    conf = workdir / "rtklib_in.conf"
    conf.write_text(options_text(options))
    rtk.resetsysopts()
    if not rtk.loadopts(str(conf), rtk.sysopts.ptr):
        raise RuntimeError(f"RTKLIB loadopts failed on {conf}")
    saved = workdir / "rtklib_effective.conf"
    rtk.saveopts(str(saved), "w", "effective options", rtk.sysopts.ptr)
    text = saved.read_text()
    effective = {}
    for line in text.splitlines():
        if "=" in line and not line.startswith("#"):
            k, v = line.split("=", 1)
            effective[k.strip()] = v.split("#", 1)[0].strip()
    for key, value in options.items():
        if key not in effective:
            raise KeyError(f"RTKLIB has no option {key!r}")
        got, want = effective[key], str(value).strip()
        if got != want and not _same_number(got, want):
            raise ValueError(f"RTKLIB refuses {key} = {want!r} (kept {got!r})")
    popt, sopt, fopt = rtk.prcopt_t(), rtk.solopt_t(), rtk.filopt_t()
    rtk.getsysopts(popt, sopt, fopt)
    return popt, sopt, fopt, text


def _same_number(a: str, b: str) -> bool:
    try:
        return abs(float(a) - float(b)) <= 1e-9 * max(1.0, abs(float(b)))
    except ValueError:
        return False


@dataclass
class PosSolution:
    """An RTKLIB .pos file as arrays.

    gps_week, gps_sow: (n,) solution time (RTKLIB's receiver time corrected by its SPP clock estimate);
    vector_m: (n, 3) ENU baseline at the base (frame "enu"), rover ECEF position (frame "xyz") or
    latitude/longitude (deg) and height (m) (frame "llh"); sigma_m: (n, 3) the first three sigmas;
    q: (n,) quality (1 fix, 2 float, 5 single); ns: satellites; age_s: differential age; ratio: AR ratio.
    """

    gps_week: np.ndarray
    gps_sow: np.ndarray
    vector_m: np.ndarray
    frame: str
    q: np.ndarray
    ns: np.ndarray
    sigma_m: np.ndarray
    age_s: np.ndarray
    ratio: np.ndarray
    header: dict = field(default_factory=dict)
    elapsed_s: float = float("nan")              # postpos wall time (reading the files included)
    cpu_s: float = float("nan")                  # postpos CPU time of this process (robust on a loaded machine)
    effective_options: str = ""            # RTKLIB's saveopts of the options it ran with

    @property
    def fixed(self) -> np.ndarray:
        """(n,) bool, Q = 1."""
        return self.q == 1

    def _enu(self) -> np.ndarray:
        if self.frame != "enu":
            raise ValueError(f"azimuth/elevation need an ENU solution (out-solformat=enu), not {self.frame}")
        return self.vector_m

    def length_m(self) -> np.ndarray:
        return np.linalg.norm(self._enu(), axis=-1)

    def azimuth_deg(self) -> np.ndarray:
        """(n,) clockwise from north, 0-360."""
        e, n = self._enu()[:, 0], self._enu()[:, 1]
        return np.degrees(np.arctan2(e, n)) % 360.0

    def elevation_deg(self) -> np.ndarray:
        """(n,) up positive."""
        enu = self._enu()
        return np.degrees(np.arctan2(enu[:, 2], np.hypot(enu[:, 0], enu[:, 1])))

    def epoch_keys_ms(self) -> np.ndarray:
        """(n,) int64 GPS milliseconds since the GPS epoch, rounded to the whole second (1 Hz matching)."""
        s = self.gps_week.astype(np.int64) * 604800 + np.round(self.gps_sow).astype(np.int64)
        return s * 1000


def read_pos(path: str | Path) -> PosSolution:
    """PosSolution of an RTKLIB .pos file written with out-timeform=tow (`week sow`) or hms (`y/m/d h:m:s`).

    Implements: RTKLIB 2.4.3 solution.c outsol()/outsolheads() column layout (header line starting `%  GPST`).
    """
    header: dict[str, list[str]] = {}
    rows = []
    frame = None
    for line in Path(path).read_text().splitlines():
        if line.startswith("%"):
            body = line[1:].strip()
            if ":" in body and not body.startswith("("):
                k, v = body.split(":", 1)
                header.setdefault(k.strip(), []).append(v.strip())
            if body.startswith("GPST"):
                low = body.lower()
                frame = "enu" if "e-baseline" in low else "xyz" if "x-ecef" in low else "llh"
            continue
        if not line.strip():
            continue
        rows.append(line.split())
    if frame is None:
        raise ValueError(f"{path}: no RTKLIB column header (% GPST ...); was out-outhead off?")
    n = len(rows)
    tow = not rows or "/" not in rows[0][0]          # out-timeform=tow: "week sow", hms: "y/m/d h:m:s"
    if tow:
        week = np.array([int(r[0]) for r in rows], dtype=np.int64)
        sow = np.array([float(r[1]) for r in rows])
    else:
        week, sow = np.empty(n, np.int64), np.empty(n)
        for i, r in enumerate(rows):
            week[i], sow[i] = _hms_to_gps(r[0], r[1])
    vals = np.array([[float(x) for x in r[2:]] for r in rows]) if n else np.empty((0, 14))
    return PosSolution(gps_week=week, gps_sow=sow, vector_m=vals[:, 0:3], frame=frame,
                       q=vals[:, 3].astype(int), ns=vals[:, 4].astype(int), sigma_m=vals[:, 5:8],
                       age_s=vals[:, 11], ratio=vals[:, 12], header=header)


def _hms_to_gps(date: str, hms: str) -> tuple[int, float]:
    from datetime import datetime

    t = datetime.strptime(f"{date} {hms[:15]}", "%Y/%m/%d %H:%M:%S.%f")
    d = t - datetime(1980, 1, 6)
    s = d.days * 86400 + d.seconds + d.microseconds * 1e-6
    return int(s // 604800), s - 604800 * (s // 604800)


def run_postpos(rover_obs: str | Path, base_obs: str | Path, nav: list[str | Path] | str | Path,
                options: dict[str, str], out_pos: str | Path, *, start: tuple[int, float] | None = None,
                end: tuple[int, float] | None = None, interval_s: float = 0.0) -> PosSolution:
    """PosSolution of RTKLIB postpos on (rover, base, nav...) with `options`, written to `out_pos` and read back.

    start/end: (GPS week, seconds of week) bounds of the processed span (RTKLIB ts/te), None for all;
    interval_s: processing interval (0: every epoch). `elapsed_s` / `cpu_s` of the result are the postpos wall / CPU
    time (reading the RINEX files included); `effective_options` the full option set RTKLIB ran with. The option
    files rtklib_in.conf / rtklib_effective.conf are written beside `out_pos`.

    Implements: RTKLIB 2.4.3 b34 postpos(ts, te, ti, tu, popt, sopt, fopt, infile, n, outfile, rov, base).
    """
    import pyrtklib as rtk

    out_pos = Path(out_pos)
    out_pos.parent.mkdir(parents=True, exist_ok=True)
    popt, sopt, fopt, effective = _load_options(options, out_pos.parent)
    navs = [nav] if isinstance(nav, (str, Path)) else list(nav)
    infiles = [str(rover_obs), str(base_obs)] + [str(p) for p in navs]
    for f in infiles:
        if not Path(f).is_file():
            raise FileNotFoundError(f)
    ts = rtk.gpst2time(int(start[0]), float(start[1])) if start else rtk.gtime_t()
    te = rtk.gpst2time(int(end[0]), float(end[1])) if end else rtk.gtime_t()
    if out_pos.exists():
        out_pos.unlink()
    t0, c0 = time.perf_counter(), time.process_time()
    stat = rtk.postpos(ts, te, float(interval_s), 0.0, popt, sopt, fopt, infiles, len(infiles),
                       rtk.Arr1Dchar(str(out_pos)), "", "")
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    if stat != 0 or not out_pos.exists():
        raise RuntimeError(f"RTKLIB postpos failed (status {stat}) on {infiles}")
    sol = read_pos(out_pos)
    sol.elapsed_s, sol.cpu_s = elapsed, cpu
    sol.effective_options = effective
    return sol
