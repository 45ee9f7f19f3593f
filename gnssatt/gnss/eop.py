"""Earth orientation parameters (polar motion, UT1 - UTC, celestial pole offsets) from an offline IERS table.

CONVENTIONS.md: EOP are taken as zero unless an IERS EOP file is supplied, and every product names the EOP
source used. So the default is `EopSource.zero()`; `EopSource.bundled()` reads the IERS finals2000A.all
(Bulletin A, with predictions) shipped inside the installed `astropy-iers-data` package (never fetched at run
time), and `EopSource.from_file(path)` reads a user's IERS file (finals2000A.all/.data/.daily, or EOP 20 C04).
`describe()` is the one line a product prints.

Interpolation: 4-point Lagrange (cubic) on the tabulated days; UT1 is interpolated as UT1 - TAI, which has no
leap-second jumps, and the Earth rotation rate is the derivative of that same interpolant (so the velocity
transform is consistent with the UT1 used). Epochs outside the table get NaN (not zero, not the end value),
flagged by `covered` and announced by one counted `EopWarning` per call.

Implements: IERS Conventions (2010) ch. 5 (xp, yp, UT1 - UTC, dX, dY w.r.t. IAU 2006/2000A), file layouts of
USNO `readme.finals2000A` and the IERS EOP 20 C04 header (`format(4(i4),f10.2,...)`).
Neglects: the diurnal/semidiurnal ocean-tide and libration terms of IERS Conventions 5.5.1-5.5.3 (< 0.1 mas in
pole, < 0.1 ms in UT1), which the tables do not include.
"""
from __future__ import annotations

import datetime as _dt
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gnssatt.gnss.constants import MJD_GPS_EPOCH, TAI_MINUS_GPS_S
from gnssatt.gnss.time import GpsTime, civil_from_days

ARCSEC_RAD = np.pi / 648000.0
MAS_RAD = ARCSEC_RAD * 1e-3
# Rate of the Earth rotation angle per UT1 second, d(ERA)/d(UT1) (IERS Conventions 2010 eq. 5.15):
# 2 pi * 1.00273781191135448 / 86400. Times (1 + d(UT1-TAI)/dTAI) it is the rate per SI second.
OMEGA_ERA_RAD_S = 2.0 * np.pi * 1.00273781191135448 / 86400.0
_GPS_EPOCH_MJD = int(MJD_GPS_EPOCH)
_MJD_UNIX_EPOCH = 40587


class EopWarning(UserWarning):
    """EOP asked for outside the table (values are NaN there), or only predicted there."""


@dataclass(frozen=True)
class EopValues:
    """EOP at a set of epochs (arrays of the epochs' shape).

    Fields: `xp_rad`, `yp_rad` (polar motion), `ut1_minus_utc_s`, `ut1_minus_tai_s` (continuous),
    `dx_rad`, `dy_rad` (celestial pole offsets w.r.t. IAU 2006/2000A; 0 where the table has none),
    `omega_earth_rad_s` (Earth rotation rate consistent with the UT1 interpolant, rad per SI second),
    `covered` (bool: inside the table), `predicted` (bool: nearest row is a prediction).
    """

    xp_rad: np.ndarray
    yp_rad: np.ndarray
    ut1_minus_utc_s: np.ndarray
    ut1_minus_tai_s: np.ndarray
    dx_rad: np.ndarray
    dy_rad: np.ndarray
    omega_earth_rad_s: np.ndarray
    covered: np.ndarray
    predicted: np.ndarray


def _mjd_to_iso(mjd: float) -> str:
    y, m, d = civil_from_days(int(np.floor(mjd)) - _MJD_UNIX_EPOCH)
    return f"{int(y):04d}-{int(m):02d}-{int(d):02d}"


def _lagrange4(x_nodes: np.ndarray, y_nodes: np.ndarray, x: np.ndarray):
    """(value, derivative) of the 4-point Lagrange interpolant of (x_nodes, y_nodes) at x (nodes increasing).

    The window is the 4 nodes around x (clamped at the ends); fewer than 4 nodes use all of them.
    """
    n = len(x_nodes)
    x = np.asarray(x, dtype=np.float64)
    k = min(4, n)
    i0 = np.clip(np.searchsorted(x_nodes, x, side="right") - k // 2, 0, n - k)
    idx = i0[..., None] + np.arange(k)
    xn = x_nodes[idx]
    yn = y_nodes[idx]
    val = np.zeros(x.shape)
    der = np.zeros(x.shape)
    for j in range(k):
        # basis l_j(x) = prod_{m != j} (x - x_m)/(x_j - x_m) and its derivative
        num = np.ones(x.shape)
        den = np.ones(x.shape)
        dnum = np.zeros(x.shape)
        for m in range(k):
            if m == j:
                continue
            f = x - xn[..., m]
            dnum = dnum * f + num
            num = num * f
            den = den * (xn[..., j] - xn[..., m])
        val += yn[..., j] * num / den
        der += yn[..., j] * dnum / den
    return val, der


@dataclass(frozen=True)
class EopSource:
    """A table of daily EOP and where it came from.

    Columns are per row `mjd_utc` (MJD of 0h UTC). Angles in arcsec, dX/dY in arcsec, UT1 - UTC in s;
    `tai_minus_utc_s` of each row (from the leap-second table) makes UT1 - TAI. NaN marks a missing value.
    `name` says where the table came from, `file_date` its last observed (non-predicted) day.
    """

    name: str
    file_date: str
    mjd_utc: np.ndarray = field(repr=False)
    xp_arcsec: np.ndarray = field(repr=False)
    yp_arcsec: np.ndarray = field(repr=False)
    ut1_minus_utc_s: np.ndarray = field(repr=False)
    dx_arcsec: np.ndarray = field(repr=False)
    dy_arcsec: np.ndarray = field(repr=False)
    predicted: np.ndarray = field(repr=False)
    is_zero: bool = False

    # --- construction --------------------------------------------------------------------------------
    @classmethod
    def zero(cls) -> "EopSource":
        """EOP taken as zero: xp = yp = 0, UT1 = UTC, dX = dY = 0 (CONVENTIONS.md default)."""
        empty = np.zeros(0)
        return cls("zero EOP (xp = yp = 0, UT1 - UTC = 0, dX = dY = 0)", "", empty, empty, empty, empty, empty,
                   empty, np.zeros(0, bool), True)

    @classmethod
    def bundled(cls) -> "EopSource":
        """IERS finals2000A.all (Bulletin A + predictions) shipped with the installed astropy-iers-data package."""
        import astropy_iers_data

        version = getattr(astropy_iers_data, "__version__", "?")
        path = Path(astropy_iers_data.IERS_A_FILE)
        return _parse_finals(path.read_text(), f"IERS finals2000A.all bundled in astropy-iers-data {version}")

    @classmethod
    def from_file(cls, path, name: str | None = None) -> "EopSource":
        """EOP from a user's IERS file: finals2000A (.all/.data/.daily, USNO layout) or EOP 20 C04.

        Raises gnssatt.gnss.io.errors.ParseError for any other layout.
        """
        path = Path(path)
        text = path.read_text(errors="replace")
        label = name or path.name
        lines = [ln for ln in text.splitlines() if ln.strip()]
        from gnssatt.gnss.io.errors import ParseError

        if not lines:
            raise ParseError(label, None, "an IERS finals2000A or EOP C04 file", "an empty file")
        if any(ln.startswith("#") and "C04" in ln for ln in lines[:10]) or lines[0].startswith("#"):
            return _parse_c04(text, label)
        return _parse_finals(text, label)

    # --- queries -------------------------------------------------------------------------------------
    def describe(self) -> str:
        """One line for products: the source, its last observed day and the predicted span, interpolation."""
        if self.is_zero:
            return "EOP: " + self.name
        last = _mjd_to_iso(self.mjd_utc[-1])
        pred = "no predictions" if not self.predicted.any() else f"predictions to {last}"
        return (f"EOP: {self.name}; observed values to {self.file_date}, {pred}; "
                f"4-point Lagrange interpolation (UT1 as UT1-TAI)")

    def span(self) -> tuple[str, str] | None:
        """(first day, last day) of the table, ISO dates; None for zero EOP."""
        if self.is_zero:
            return None
        return _mjd_to_iso(self.mjd_utc[0]), _mjd_to_iso(self.mjd_utc[-1])

    def at(self, t: GpsTime, warn: bool = True) -> EopValues:
        """EopValues at GPS times `t` (shape of t); NaN outside the table, with one counted EopWarning."""
        from gnssatt.gnss.leap_seconds import gps_minus_utc_s

        shape = np.shape(t.s)
        gmu = gps_minus_utc_s(t)
        tai_minus_utc = gmu + TAI_MINUS_GPS_S
        if self.is_zero:
            z = np.zeros(shape)
            return EopValues(z, z.copy(), z.copy(), -tai_minus_utc, z.copy(), z.copy(),
                             np.full(shape, OMEGA_ERA_RAD_S), np.ones(shape, bool), np.zeros(shape, bool))
        # Abscissa: MJD in TAI (continuous); the rows are at 0h UTC = MJD + (TAI-UTC)/86400 TAI.
        mjd_tai = _GPS_EPOCH_MJD + (t.s.astype(np.float64) + TAI_MINUS_GPS_S) / 86400.0 + t.frac / 86400.0
        from gnssatt.gnss.leap_seconds import TABLE

        row_tai_utc = _tai_minus_utc_at_mjd(self.mjd_utc, TABLE)
        rows_tai = self.mjd_utc + row_tai_utc / 86400.0

        def interp(col, default_nan=True):
            ok = np.isfinite(col)
            if ok.sum() == 0:
                return np.full(shape, np.nan if default_nan else 0.0), np.zeros(shape), np.zeros(shape, bool)
            xn, yn = rows_tai[ok], col[ok]
            val, der = _lagrange4(xn, yn, mjd_tai)
            inside = (mjd_tai >= xn[0]) & (mjd_tai <= xn[-1])
            fill = np.nan if default_nan else 0.0
            return np.where(inside, val, fill), np.where(inside, der, fill), inside

        xp, _, in_xp = interp(self.xp_arcsec)
        yp, _, in_yp = interp(self.yp_arcsec)
        ut1_tai, dut1_tai_dday, in_ut = interp(self.ut1_minus_utc_s - row_tai_utc)
        dx, _, _ = interp(self.dx_arcsec, default_nan=False)
        dy, _, _ = interp(self.dy_arcsec, default_nan=False)
        covered = in_xp & in_yp & in_ut
        nearest = np.clip(np.searchsorted(rows_tai, mjd_tai), 0, len(rows_tai) - 1)
        predicted = self.predicted[nearest] & covered
        if warn and not covered.all():
            n = int(np.count_nonzero(~covered))
            warnings.warn(EopWarning(f"{n} epoch(s) outside the EOP table {self.span()} of {self.name}: "
                                     "EOP are NaN there"), stacklevel=2)
        # d(UT1-TAI)/d(TAI) = derivative per day / 86400 s; omega = dERA/dUT1 * dUT1/dTAI
        omega = OMEGA_ERA_RAD_S * (1.0 + dut1_tai_dday / 86400.0)
        return EopValues(xp * ARCSEC_RAD, yp * ARCSEC_RAD, ut1_tai + tai_minus_utc, ut1_tai,
                         dx * ARCSEC_RAD, dy * ARCSEC_RAD, omega, covered, predicted)

    def coverage_warning(self, t: GpsTime) -> str | None:
        """A product warning when some of `t` is outside the table or uses predicted values, else None."""
        if self.is_zero:
            return None
        v = self.at(t, warn=False)
        parts = []
        n_out = int(np.count_nonzero(~v.covered))
        n_pred = int(np.count_nonzero(v.predicted))
        if n_out:
            parts.append(f"{n_out} epoch(s) outside the EOP table {self.span()}")
        if n_pred:
            parts.append(f"{n_pred} epoch(s) use predicted EOP (observed values end {self.file_date})")
        return "; ".join(parts) + f" ({self.name})" if parts else None


def _tai_minus_utc_at_mjd(mjd_utc: np.ndarray, table) -> np.ndarray:
    idx = np.clip(np.searchsorted(table.mjd_utc, np.floor(mjd_utc), side="right") - 1, 0, len(table.mjd_utc) - 1)
    return table.tai_minus_utc_s[idx].astype(np.float64)


def _field(line: str, a: int, b: int) -> float:
    """Float of the 1-based inclusive byte columns a..b, NaN when blank."""
    txt = line[a - 1:b].strip()
    return float(txt) if txt else np.nan


def _parse_finals(text: str, name: str) -> EopSource:
    """EopSource from a USNO/IERS finals2000A file (Bulletin A columns; layout of readme.finals2000A)."""
    from gnssatt.gnss.io.errors import ParseError

    layout = ("finals2000A fixed columns: MJD F8.2 in 8-15, flag in 17, PM-x F9.6 in 19-27, PM-y F9.6 in 38-46, "
              "UT1 flag in 58, UT1-UTC F10.7 in 59-68, dX/dY F9.3 mas in 98-106/117-125")
    mjd, xp, yp, dut, dx, dy, pred = [], [], [], [], [], [], []
    for line_no, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            m = _field(line, 8, 15)
            if not np.isfinite(m):
                raise ValueError("no MJD")
            x_ = _field(line, 19, 27)
            y_ = _field(line, 38, 46)
            u_ = _field(line, 59, 68)
            dx_ = _field(line, 98, 106)
            dy_ = _field(line, 117, 125)
        except ValueError:
            raise ParseError(name, line_no, layout, line) from None
        if np.isnan(x_) and np.isnan(u_):
            continue  # future rows without values
        mjd.append(m)
        xp.append(x_)
        yp.append(y_)
        dut.append(u_)
        dx.append(dx_ * 1e-3)
        dy.append(dy_ * 1e-3)
        pred.append(line[16:17] == "P" or line[57:58] == "P")
    if not mjd:
        raise ParseError(name, None, layout, "no EOP rows")
    return _make(name, mjd, xp, yp, dut, dx, dy, pred)


def _parse_c04(text: str, name: str) -> EopSource:
    """EopSource from an IERS EOP 20 C04 file ('#' header, then YR MM DD HH MJD x y UT1-UTC dX dY ...)."""
    from gnssatt.gnss.io.errors import ParseError

    layout = "EOP 20 C04 rows: YR MM DD HH MJD x(\") y(\") UT1-UTC(s) dX(\") dY(\") ..."
    mjd, xp, yp, dut, dx, dy = [], [], [], [], [], []
    for line_no, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.split()
        try:
            if len(parts) < 10:
                raise ValueError
            vals = [float(p) for p in parts[4:10]]
        except ValueError:
            raise ParseError(name, line_no, layout, line) from None
        mjd.append(vals[0])
        xp.append(vals[1])
        yp.append(vals[2])
        dut.append(vals[3])
        dx.append(vals[4])
        dy.append(vals[5])
    if not mjd:
        raise ParseError(name, None, layout, "no EOP rows")
    return _make(name, mjd, xp, yp, dut, dx, dy, [False] * len(mjd))


def _make(name, mjd, xp, yp, dut, dx, dy, pred) -> EopSource:
    from gnssatt.gnss.io.errors import ParseError

    mjd = np.asarray(mjd, dtype=np.float64)
    if np.any(np.diff(mjd) <= 0):
        raise ParseError(name, None, "EOP rows in increasing MJD order", "MJD not increasing")
    pred = np.asarray(pred, dtype=bool)
    observed = mjd[~pred]
    file_date = _mjd_to_iso(observed[-1]) if observed.size else "(predictions only)"
    arr = lambda v: np.asarray(v, dtype=np.float64)  # noqa: E731
    return EopSource(name, file_date, mjd, arr(xp), arr(yp), arr(dut), arr(dx), arr(dy), pred)


def bundled_file_date() -> _dt.date | None:
    """Release date of the installed astropy-iers-data (its version is 0.YYYY.MM.DD...), or None."""
    try:
        import astropy_iers_data

        _, y, m, d, *_ = astropy_iers_data.__version__.split(".")
        return _dt.date(int(y), int(m), int(d))
    except Exception:  # noqa: BLE001
        return None
