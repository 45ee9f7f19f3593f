"""The coarse search of the initial attitude (gnssatt/vector_phase/coarse_search.py): the right start for a
pattern without azimuthal symmetry, and the 180 deg twin of a harmonic-2 pattern flagged as ambiguous."""
from gnssatt.vector_phase.antenna import AsymmetricPatch
from gnssatt.vector_phase.coarse_search import coarse_search
from gnssatt.vector_phase.scenario import ScenarioSpec, simulate


def _search(harmonic):
    obs, truth, mount = simulate(ScenarioSpec(AsymmetricPatch(harmonic=harmonic), n_sats=10, n_epochs=30,
                                              sigma_phase_cyc=2e-3, yaw0_deg=100.0, yaw_rate_deg_s=1.0,
                                              pitch_amp_deg=0.0, roll_amp_deg=0.0))
    return coarse_search(obs, mount, truth.position_ecef_m, truth.R_ned_from_ecef, step_deg=45.0, n_epochs=30)


def test_coarse_search_finds_the_start_and_flags_a_symmetric_twin():
    found = _search(1)
    assert abs((found.euler_deg[0] - 100.0 + 180.0) % 360.0 - 180.0) <= 22.5     # the nearest grid yaw
    assert not found.ambiguous and found.n_candidates == 8
    twin = _search(2)                       # sin^2 e^{2 j phi}: a half turn about the boresight looks the same
    assert twin.ambiguous
    assert min(abs((twin.euler_deg[0] - y + 180.0) % 360.0 - 180.0) for y in (100.0, 280.0)) <= 22.5
