"""An ambiguity covariance too ill-conditioned to decorrelate must give the documented AmbiguitySearchError
(the filter then leaves the epoch float), never an OverflowError escaping into the job (issue 7 note)."""
from __future__ import annotations

import numpy as np
import pytest

from gnssatt.estimation import lambda_search
from gnssatt.estimation.lambda_search import AmbiguitySearchError


@pytest.mark.parametrize("value", [np.inf, np.nan, 3.0e15])
def test_gauss_transform_refuses_non_finite_or_huge_multipliers(value):
    L = np.eye(3)
    L[2, 0] = value
    Z = np.eye(3, dtype=np.int64)
    with pytest.raises(AmbiguitySearchError):
        lambda_search._gauss(L, Z, Z.copy(), 2, 0)


def test_ordinary_transform_still_works():
    L = np.eye(2)
    L[1, 0] = 2.4
    Z = np.eye(2, dtype=np.int64)
    Zi = np.eye(2, dtype=np.int64)
    lambda_search._gauss(L, Z, Zi, 1, 0)
    assert abs(L[1, 0]) <= 0.5 and (Z @ Zi == np.eye(2)).all()
