"""The attitude filter's ambiguity states in readable numpy: adding new float ambiguities (uncorrelated, a
large initial variance) and removing states, with the index maps between (baseline, satellite, signal) and state
rows kept consistent.

This is the specification of the compiled kernels gnssatt.attitude.qc_kernels.add_states / drop_states /
take_square / grow_square, as gnssatt.attitude.filter's state uses them (tests/attitude/test_qc_kernels.py).
Plain numpy, no numba.

Implements: seed 000 sec. 2 (one float ambiguity per continuous phase arc, added at the first epoch of the arc,
removed at a slip or a gap).
"""
from __future__ import annotations

import numpy as np

__all__ = ["AmbiguityStates"]


class AmbiguityStates:
    """x (n,), P (n, n); the first n_fixed_part states are the fixed part (omega, baselines, clocks, biases), then
    one row a per ambiguity: amb_key[a] = (baseline, satellite, signal), amb_fixed, amb_last_t (s), amb_arc (arc
    number); amb_index (n_bl, n_sat, n_sig) = state index of each key (-1 none); arcs: [bl, sat, sig, ...]."""

    def __init__(self, x: np.ndarray, P: np.ndarray, n_fixed_part: int, shape: tuple[int, int, int]):
        self.x, self.P, self.n_fixed_part = x, P, n_fixed_part
        self.amb_index = np.full(shape, -1, dtype=np.int64)
        self.amb_key = np.zeros((0, 3), dtype=np.int64)
        self.amb_fixed = np.zeros(0, bool)
        self.amb_last_t = np.zeros(0)
        self.amb_arc = np.zeros(0, np.int64)
        self.arcs: list[list[int]] = []

    def add(self, keys: np.ndarray, values_cyc: np.ndarray, sigma0_cyc: float, t_s: float) -> None:
        """Append k ambiguities keys (k, 3) with float values, variance sigma0^2, uncorrelated, not fixed."""
        n0, k = self.x.size, keys.shape[0]
        self.x = np.concatenate([self.x, values_cyc])
        P = np.zeros((n0 + k, n0 + k))
        P[:n0, :n0] = self.P
        P[np.arange(n0, n0 + k), np.arange(n0, n0 + k)] = sigma0_cyc ** 2
        self.P = P
        self.amb_key = np.concatenate([self.amb_key, keys])
        self.amb_fixed = np.concatenate([self.amb_fixed, np.zeros(k, bool)])
        self.amb_last_t = np.concatenate([self.amb_last_t, np.full(k, t_s)])
        a0 = len(self.arcs)
        self.arcs.extend([int(b), int(s), int(f), 0, -1] for b, s, f in keys)
        self.amb_arc = np.concatenate([self.amb_arc, a0 + np.arange(k)])
        self.amb_index[keys[:, 0], keys[:, 1], keys[:, 2]] = n0 + np.arange(k)

    def remove(self, state_idx: np.ndarray) -> None:
        """Remove the ambiguity states state_idx (indices into x); the others keep their order."""
        keep = np.ones(self.x.size, bool)
        keep[state_idx] = False
        self.x = self.x[keep]
        self.P = self.P[np.ix_(keep, keep)]
        ka = keep[self.n_fixed_part:]
        gone = self.amb_key[~ka]
        self.amb_index[gone[:, 0], gone[:, 1], gone[:, 2]] = -1
        self.amb_key, self.amb_fixed = self.amb_key[ka], self.amb_fixed[ka]
        self.amb_last_t, self.amb_arc = self.amb_last_t[ka], self.amb_arc[ka]
        self.amb_index[self.amb_key[:, 0], self.amb_key[:, 1], self.amb_key[:, 2]] = \
            self.n_fixed_part + np.arange(self.amb_key.shape[0])
