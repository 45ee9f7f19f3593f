"""Main -> auxiliary antenna baseline of a satellite from differential observations with the yaw known from an
attitude model (seed 004 sec. 2.1, Table 1), with the differential PCV map estimated with it (Fig. 3).

Model of row k (group g): d_k = k_geo e_body,k . b + pcv(nadir_k, az_k) + A_g + eps_k, linear in b, the map's
node values (bilinear in nadir and azimuth of the body frame, phase rows only) and the group constants A_g.
Bilinear, not bins: a bin's constant leaves the pattern's slope across the bin, and a nadir slope is what z
looks like (0.4 mm/deg at 8 deg nadir equals 0.17 m of z), so bins bias z by centimetres. Each row belongs to one
group, so the A_g are eliminated exactly (N - S^T W^-1 S with S the per-group sums: the Schur complement of
a diagonal block). A binned map also holds functions the constants and the baseline already explain
(1, cos(nadir), sin(nadir) cos(az), sin(nadir) sin(az)): four constraints keep the map orthogonal to them
(equal weight per node of the nadir rings observed at every azimuth node: a pattern orthogonal to them over
full circles of azimuth is then left to the map whatever the sampling), solved with the normal equations as
one KKT system. So b is the baseline
whose residual pattern has none of those parts, and its covariance includes the trade-off with the map
(z trades against cos(nadir), nearly constant over 0-9 deg: seed 004's 18-27 mm). This is the converged
result of seed 004's alternation between baseline and map. Sigmas: formal, times the a posteriori unit
weight and the AR(1) inflation of time-correlated residuals (gnssatt.satyaw.yaw_estimator.ar1_inflation).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gnssatt.satyaw.differential import DiffObs, SatGeometry, body_los, nadir_azimuth_deg
from gnssatt.satyaw.yaw_estimator import ar1_inflation

__all__ = ["BaselineOptions", "BaselineEstimate", "PcvMap", "estimate_baseline", "unobservable_basis",
           "bilinear_weights"]


@dataclass(frozen=True)
class BaselineOptions:
    """pcv_iterations: 0 = no map, > 0 = the map estimated with the baseline (the converged iteration);
    nadir_step_deg / azimuth_step_deg: map bins; max_nadir_deg: map extent
    (QZSS is seen from the ground within ~8.7 deg of nadir)."""

    pcv_iterations: int = 1
    nadir_step_deg: float = 1.0
    azimuth_step_deg: float = 15.0
    min_count: float = 30.0
    max_nadir_deg: float = 9.0


@dataclass
class PcvMap:
    """Differential PCV (aux minus main, mm) on grid nodes: nadir_deg (n_nadir,) from 0 and azimuth_deg (n_az,)
    from 0 (periodic), values_mm / count / sigma_mm (n_nadir, n_az), bilinear between nodes; NaN where a
    node has less than min_count rows' weight (count: the sum of the rows' interpolation weights)."""

    nadir_deg: np.ndarray
    azimuth_deg: np.ndarray
    values_mm: np.ndarray
    count: np.ndarray
    sigma_mm: np.ndarray

    def lookup_m(self, nadir_deg, azimuth_deg) -> np.ndarray:
        """Correction (m) per direction: bilinear in nadir and azimuth between the grid nodes; nodes without
        a value count as 0, and directions beyond the last nadir node get 0."""
        node, weight = bilinear_weights(nadir_deg, azimuth_deg, self.nadir_deg, self.azimuth_deg)
        vals = np.nan_to_num(self.values_mm.ravel(), nan=0.0)
        return np.sum(vals[node] * weight, axis=1) * 1e-3

    def to_dict(self) -> dict:
        def clean(a):
            return [[None if not np.isfinite(x) else round(float(x), 4) for x in row] for row in a]
        return {"nadir_deg": self.nadir_deg.tolist(), "azimuth_deg": self.azimuth_deg.tolist(),
                "values_mm": clean(self.values_mm), "count": self.count.astype(int).tolist(),
                "sigma_mm": clean(self.sigma_mm)}


@dataclass
class BaselineEstimate:
    """baseline_body_m (3,), sigma_m (3,), covariance_m2 (3, 3); offsets_m (n_groups,); residual_m (n,);
    sigma0; ar1_factor; dcb_m (mean code-group constant, aux minus main code) and dcb_sigma_m; pcv (PcvMap
    or None); n_rows, n_stations, n_epochs; warnings (text)."""

    baseline_body_m: np.ndarray
    sigma_m: np.ndarray
    covariance_m2: np.ndarray
    offsets_m: np.ndarray
    residual_m: np.ndarray
    sigma0: float
    ar1_factor: float
    dcb_m: float
    dcb_sigma_m: float
    pcv: PcvMap | None
    n_rows: int
    n_stations: int
    n_epochs: int
    warnings: list[str]


def unobservable_basis(nadir_deg, azimuth_deg) -> np.ndarray:
    """(n, 4) functions a PCV map shares with the arc constants and the baseline: 1, cos(nadir),
    sin(nadir) cos(az), sin(nadir) sin(az)."""
    n, a = np.radians(nadir_deg), np.radians(azimuth_deg)
    return np.stack([np.ones_like(n), np.cos(n), np.sin(n) * np.cos(a), np.sin(n) * np.sin(a)], axis=-1)


def _grid(opts: BaselineOptions) -> tuple[np.ndarray, np.ndarray]:
    nc = np.arange(0.0, opts.max_nadir_deg + 1e-9, opts.nadir_step_deg)
    ac = np.arange(0.0, 360.0 - 1e-9, opts.azimuth_step_deg)
    return nc, ac


def bilinear_weights(nadir_deg, azimuth_deg, nadir_nodes, azimuth_nodes) -> tuple[np.ndarray, np.ndarray]:
    """(node (n, 4) flat indices into (n_nadir, n_az), weight (n, 4)): bilinear interpolation on a grid
    regular in nadir (from nadir_nodes[0]) and periodic in azimuth; weight 0 beyond the last nadir node."""
    dn = nadir_nodes[1] - nadir_nodes[0]
    da = 360.0 / len(azimuth_nodes)
    na = len(azimuth_nodes)
    u = (np.asarray(nadir_deg, dtype=np.float64) - nadir_nodes[0]) / dn
    i0 = np.clip(np.floor(u).astype(np.int64), 0, len(nadir_nodes) - 2)
    fn = np.clip(u - i0, 0.0, 1.0)
    v = np.mod(np.asarray(azimuth_deg, dtype=np.float64), 360.0) / da
    j0 = np.floor(v).astype(np.int64) % na
    fa = v - np.floor(v)
    j1 = (j0 + 1) % na
    node = np.stack([i0 * na + j0, i0 * na + j1, (i0 + 1) * na + j0, (i0 + 1) * na + j1], axis=1)
    weight = np.stack([(1 - fn) * (1 - fa), (1 - fn) * fa, fn * (1 - fa), fn * fa], axis=1)
    outside = u > len(nadir_nodes) - 1
    return node, np.where(outside[:, None], 0.0, weight)


def _solve(obs: DiffObs, H, y, w, nodes, basis_c):
    """x = (b, map values at the used nodes), its covariance factor, group constants and residuals.

    nodes: (parameter index (n, 4), weight (n, 4)) of each row's map interpolation (weight 0: none);
    basis_c (k, n_nodes): the constraint rows C x_map = 0."""
    node, wt = nodes
    G = obs.n_groups
    nb = basis_c.shape[1]
    p = 3 + nb
    N = np.zeros((p, p))
    N[:3, :3] = np.einsum("n,ni,nj->ij", w, H, H)
    rhs = np.zeros(p)
    rhs[:3] = np.einsum("n,ni,n->i", w, H, y)
    W = np.maximum(np.bincount(obs.group, w, G), 1e-300)
    S = np.zeros((G, p))
    for i in range(3):
        S[:, i] = np.bincount(obs.group, w * H[:, i], G)
    if nb:
        for a in range(4):
            wa = w * wt[:, a]
            N[:3, 3:] += np.stack([np.bincount(node[:, a], wa * H[:, i], nb) for i in range(3)])
            rhs[3:] += np.bincount(node[:, a], wa * y, nb)
            np.add.at(S, (obs.group, 3 + node[:, a]), wa)
            for c in range(4):
                N[3:, 3:] += np.bincount(node[:, a] * nb + node[:, c], wa * wt[:, c], nb * nb).reshape(nb, nb)
        N[3:, :3] = N[:3, 3:].T
    Y = np.bincount(obs.group, w * y, G)
    N -= S.T @ (S / W[:, None])
    rhs -= S.T @ (Y / W)
    k = basis_c.shape[0]
    K = np.zeros((p + k, p + k))
    K[:p, :p] = N
    scale = float(np.mean(np.abs(np.diag(N)))) or 1.0   # constraint rows on the scale of N (pinv's cut-off)
    K[p:, 3:p] = basis_c * scale
    K[3:p, p:] = basis_c.T * scale
    K_inv = np.linalg.pinv(K, rcond=1e-13, hermitian=True)
    x = K_inv[:p, :p] @ rhs
    off = (Y - S @ x) / W
    pcv_rows = np.sum(x[3:][node] * wt, axis=1) if nb else np.zeros(len(y))
    r = y - H @ x[:3] - pcv_rows - off[obs.group]
    return x, K_inv[:p, :p], off, r


def estimate_baseline(obs: DiffObs, geom: SatGeometry, yaw_deg, options: BaselineOptions | None = None,
                      ) -> BaselineEstimate:
    """BaselineEstimate of one satellite from `obs` with the yaw (T,) known (seed 004 Table 1, Fig. 3).

    Phase and code rows share b; each group (station arc and type) has its own constant. With
    pcv_iterations > 0 the phase rows also carry the binned map (single-frequency rows only: seed 004
    applies no map to the triple-frequency ones).
    """
    opts = options or BaselineOptions()
    yaw_rows = np.asarray(yaw_deg, dtype=np.float64)[obs.epoch]
    e_body = body_los(geom.R_orbital_from_ecef[obs.epoch], yaw_rows, obs.los_ecef)
    H = obs.k * e_body
    w = 1.0 / obs.sigma_m ** 2
    nadir, az = nadir_azimuth_deg(e_body)
    phase = ~obs.is_code
    with_map = opts.pcv_iterations > 0 and obs.k == 1.0
    nc, ac = _grid(opts)
    n_nodes = len(nc) * len(ac)
    node, weight = bilinear_weights(nadir, az, nc, ac)
    weight = np.where((phase & with_map)[:, None], weight, 0.0)
    count = np.bincount(node.ravel(), weight.ravel(), n_nodes)
    used = np.flatnonzero(count >= opts.min_count) if with_map else np.zeros(0, dtype=np.int64)
    pos = np.full(n_nodes, -1)
    pos[used] = np.arange(len(used))
    node_p = pos[node]
    weight = np.where(node_p >= 0, weight, 0.0)
    NN, AA = np.meshgrid(nc, ac, indexing="ij")
    full_ring = np.repeat((count.reshape(len(nc), len(ac)) >= opts.min_count).all(axis=1), len(ac))[used]
    warnings: list[str] = []
    if with_map and full_ring.sum() < 3 * len(ac):
        warnings.append(f"PCV map not estimated: {int(full_ring.sum() // len(ac))} nadir ring(s) observed at every "
                        f"{opts.azimuth_step_deg:g} deg of azimuth, 3 needed (more days, stations or yaw motion)")
        with_map = False
        used = np.zeros(0, dtype=np.int64)
        weight = np.zeros_like(weight)
        node_p = np.zeros_like(node_p)
        full_ring = np.zeros(0, dtype=bool)
    basis_c = unobservable_basis(NN.ravel()[used], AA.ravel()[used]).T * full_ring
    x, C, off, r = _solve(obs, H, obs.value_m, w, (np.maximum(node_p, 0), weight), basis_c)
    dof = max(len(r) - 3 - len(used) + basis_c.shape[0] - obs.n_groups, 1)
    sigma0 = float(np.sqrt(np.sum(w * r * r) / dof))
    ar1 = ar1_inflation(r[phase], obs.group[phase], obs.epoch[phase])
    cov = C * sigma0 ** 2 * ar1 ** 2
    pcv = None
    if with_map:
        vals = np.full(n_nodes, np.nan)
        sig = np.full(n_nodes, np.nan)
        vals[used] = x[3:] * 1e3
        sig[used] = np.sqrt(np.maximum(np.diag(cov)[3:], 0.0)) * 1e3
        shape = (len(nc), len(ac))
        pcv = PcvMap(nc, ac, vals.reshape(shape), count.reshape(shape), sig.reshape(shape))
    code_groups = obs.group_is_code
    dcb = float(np.mean(off[code_groups])) if code_groups.any() else float("nan")
    dcb_sd = (float(np.std(off[code_groups]) / np.sqrt(max(code_groups.sum(), 1))) if code_groups.any()
              else float("nan"))
    return BaselineEstimate(x[:3], np.sqrt(np.diag(cov)[:3]), cov[:3, :3], off, r, sigma0, ar1, dcb, dcb_sd, pcv,
                            len(r), len(np.unique(obs.station)), len(np.unique(obs.epoch)), warnings)
