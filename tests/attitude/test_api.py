"""The library entry points of gnssatt.attitude (gnssatt.attitude.api) and gnssatt.sim.simulate_set: the same
solution as the worker pipeline's two calls, the same product bytes as the service writes, and light imports."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from tests.attitude.conftest import set_files
from tests.conftest import REPO_ROOT
from gnssatt.attitude.process import InputProblem, load_inputs, process
from gnssatt.attitude.products import all_products
from gnssatt.attitude.settings import AttitudeSettings


@pytest.fixture(scope="module")
def short_set(tmp_path_factory):
    from gnssatt.sim import simulate_set

    return simulate_set("earth-pointing", tmp_path_factory.mktemp("api"), seed=3, duration_s=120.0)


def test_simulate_set_names_its_files(short_set):
    assert set(short_set.obs) == {"GPS-0", "GPS-1", "GPS-2"}
    for p in [*short_set.files, short_set.reference_attitude, short_set.truth_dir / "attitude.csv"]:
        assert p.is_file(), p
    with pytest.raises(ValueError, match="no_such_parameter"):
        from gnssatt.sim import simulate_set
        simulate_set("earth-pointing", short_set.dir / "x", no_such_parameter=1.0)


def test_solve_is_the_pipelines_two_calls(short_set):
    import gnssatt.attitude as attitude

    # files in any order, platform and nav given apart: kinds come from the content
    obs = list(short_set.obs.values())[::-1]
    sol = attitude.solve(obs + [short_set.platform_sp3], platform=short_set.platform, nav=short_set.nav)
    ref = process(load_inputs(set_files(short_set.dir, with_reference=False)), AttitudeSettings.preset("seed000"))
    assert np.array_equal(sol.att_epochs, ref.att_epochs) and np.array_equal(sol.att_fixed, ref.att_fixed)
    # same inputs and settings through the same code: equal to far below the 1e-6 deg of the issue
    assert np.abs(sol.euler_deg - ref.euler_deg).max() < 1e-9
    assert len(sol.time) == len(sol.euler_deg)


def test_write_products_writes_what_the_service_stores(short_set, tmp_path):
    import gnssatt.attitude as attitude
    from gnssatt.product_files import product_json     # the service's encoding too (worker.context.write_product)

    sol = attitude.solve(short_set.files, settings="seed000")
    written = sol.write_products(tmp_path / "products")
    expected = all_products(sol)
    assert set(written) == set(expected)
    for name, content in expected.items():
        if isinstance(content, dict):
            content = product_json(content)
        assert written[name].read_bytes() == content.encode(), name


def test_solve_refuses_a_set_without_a_platform(short_set):
    import gnssatt.attitude as attitude

    with pytest.raises(InputProblem, match="platform"):
        attitude.solve(list(short_set.obs.values()) + [short_set.nav])


def test_package_imports_stay_light():
    """`import gnssatt.attitude` / `gnssatt.gnss.io` names the entry points without importing the filter or the
    readers (PEP 562 lazy exports); the first use imports them."""
    code = ("import sys, gnssatt.attitude, gnssatt.gnss.io\n"
            "heavy = [m for m in ('numba', 'scipy', 'gnssatt.attitude.filter', 'gnssatt.gnss.io.rinex_obs') "
            "if m in sys.modules]\n"
            "from gnssatt.gnss.io import read_rinex_obs\n"
            "print(','.join(heavy), callable(gnssatt.attitude.solve), 'gnssatt.gnss.io.rinex_obs' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO_ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["True", "True"], out.stdout
