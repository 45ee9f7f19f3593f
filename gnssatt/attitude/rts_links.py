"""The links of the RTS backward recursion (Rauch, Tung & Striebel 1965): for k = n-2 .. 0, the epochs k that link to
k+1 and their gain C_k = P_k|k Phi_k+1^T P_k+1|k^-1. Shared by the linear step (gnssatt.attitude.smoother.rts_smooth)
and the rigid baselines' tangent-space step (gnssatt.attitude.rigid_smoother)."""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np

__all__ = ["rts_links"]


def rts_links(x_post: np.ndarray, P_post: np.ndarray, x_prior: np.ndarray, P_prior: np.ndarray, Phi: np.ndarray,
              start: np.ndarray) -> Iterator[tuple[int, np.ndarray]]:
    """(k, C_k) from the last epoch back, for every k that links to k+1: start[k+1] (n,) bool cuts the chain there,
    as do non-finite inputs at k or k+1 and a singular P_k+1|k (those k are left as filtered)."""
    fin_post = np.isfinite(x_post).all(1) & np.isfinite(P_post).all((1, 2))
    fin_prior = np.isfinite(x_prior).all(1) & np.isfinite(P_prior).all((1, 2)) & np.isfinite(Phi).all((1, 2))
    for k in range(x_post.shape[0] - 2, -1, -1):
        j = k + 1
        if start[j] or not (fin_post[k] and fin_post[j] and fin_prior[j]):
            continue
        try:
            C = np.linalg.solve(P_prior[j], Phi[j] @ P_post[k]).T      # P_k|k Phi^T P_prior^-1 (P symmetric)
        except np.linalg.LinAlgError:
            continue
        yield k, C
