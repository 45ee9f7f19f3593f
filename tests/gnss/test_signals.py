"""The one signal table (gnssatt.gnss.signals): frequencies as the ICDs define them, wavelengths c / f, every named
signal's RINEX 3 codes in its own band, and the modules that used to hold their own copies read this one."""
from __future__ import annotations

import pytest

from gnssatt.gnss import signals as sg
from gnssatt.gnss.constants import C_M_S

F0_HZ = 10.23e6  # fundamental frequency of GPS/QZSS/Galileo/BeiDou carriers (IS-GPS-200 sec. 3.3.1.1)


@pytest.mark.parametrize("name, multiple", [
    ("FREQ_GPS_L1_HZ", 154), ("FREQ_GPS_L2_HZ", 120), ("FREQ_GPS_L5_HZ", 115),      # IS-GPS-200 / -705
    ("FREQ_GAL_E1_HZ", 154), ("FREQ_GAL_E5A_HZ", 115), ("FREQ_GAL_E5B_HZ", 118),    # Galileo OS SIS ICD
    ("FREQ_GAL_E5_HZ", 116.5), ("FREQ_GAL_E6_HZ", 125),
    ("FREQ_BDS_B1I_HZ", 152.6), ("FREQ_BDS_B3I_HZ", 124), ("FREQ_BDS_B2I_HZ", 118),  # BDS ICDs
    ("FREQ_BDS_B1C_HZ", 154), ("FREQ_BDS_B2A_HZ", 115),
    ("FREQ_QZS_L1_HZ", 154), ("FREQ_QZS_L2_HZ", 120), ("FREQ_QZS_L5_HZ", 115), ("FREQ_QZS_L6_HZ", 125),
])
def test_carriers_are_the_icd_multiples_of_f0(name, multiple):
    # 1 mHz: the literal and multiple * 10.23e6 differ only by float rounding (~2e-7 Hz)
    assert getattr(sg, name) == pytest.approx(multiple * F0_HZ, abs=1e-3)


def test_wavelengths_are_c_over_f_and_named_signals_consistent():
    assert sg.WAVELENGTH_GPS_L1_M == C_M_S / sg.FREQ_GPS_L1_HZ
    assert sg.WAVELENGTH_GPS_L2_M == pytest.approx(0.244210213425, abs=1e-12)
    for name, spec in sg.SIGNALS.items():
        system = spec["system"]
        bands = {c[1] for c in spec["code"] + spec["phase"] + spec["snr"]}
        assert len(bands) == 1, name  # one carrier per named signal
        band = bands.pop()
        if "fdma_band" in spec:          # GLONASS FDMA: channel 0 of the band, each satellite its own (k)
            assert spec["freq_hz"] == sg.glonass_frequency_hz(int(band), 0) and spec["fdma_band"] == int(band), name
        else:
            assert spec["freq_hz"] == sg.FREQ_BY_SYSTEM_BAND_HZ[(system, band)], name
        assert sg.wavelength_m(name) == C_M_S / spec["freq_hz"], name
        assert [c[0] for c in spec["code"]] == ["C"] * len(spec["code"])
        assert [c[2:] for c in spec["code"]] == [c[2:] for c in spec["phase"]] == [c[2:] for c in spec["snr"]]
    for alias, name in sg.SIGNAL_ALIASES.items():
        assert sg.SIGNALS[alias] is sg.SIGNALS[name]
    assert all(n in sg.SIGNALS for pair in sg.SYSTEM_SIGNALS.values() for n in pair)


def test_glonass_and_antex_frequencies():
    assert sg.glonass_frequency_hz(1, -7) == pytest.approx(1598.0625e6, abs=1e-3)
    assert sg.glonass_frequency_hz(2, 6) == pytest.approx(1248.625e6, abs=1e-3)
    with pytest.raises(ValueError):
        sg.glonass_frequency_hz(3, 0)
    assert sg.antex_frequency_hz("G02") == sg.FREQ_GPS_L2_HZ
    assert sg.antex_frequency_hz("C02") == sg.FREQ_BDS_B1I_HZ
    assert sg.antex_frequency_hz("R01") == 1602.0e6 and sg.antex_frequency_hz("R02") == 1246.0e6
    assert sg.antex_frequency_hz("X99") is None


def test_former_copies_read_the_table():
    from gnssatt.attitude import settings
    from gnssatt.calibration import extract
    from gnssatt.gnss import positioning
    from gnssatt.sim import _constants as sim_constants
    from gnssatt.sim import observables

    assert settings.SIGNALS is sg.SIGNALS and settings.SIGNAL_ALIASES is sg.SIGNAL_ALIASES
    assert settings.SYSTEM_SIGNALS is sg.SYSTEM_SIGNALS
    assert extract.SIGNALS["L1"] is sg.SIGNALS["L1"] and extract.SIGNALS["L2"] is sg.SIGNALS["L2"]
    assert positioning.BAND_FREQ_HZ[("G", 2)] == sg.FREQ_GPS_L2_HZ
    assert observables.FREQS == {"L1": sg.FREQ_GPS_L1_HZ, "L2": sg.FREQ_GPS_L2_HZ}
    assert sim_constants.C_M_S == C_M_S


def test_glonass_fdma_wavelengths_per_channel():
    """GLONASS ICD 5.1 sec. 3.3.1.4: G1 1602 + 0.5625 k MHz; k = -7 gives 1598.0625 MHz, k = +6 1605.375 MHz."""
    assert sg.glonass_wavelength_m(1, -7) == pytest.approx(C_M_S / 1598.0625e6, rel=1e-15)
    assert sg.glonass_wavelength_m(2, 6) == pytest.approx(C_M_S / 1248.625e6, rel=1e-15)
    assert sg.is_fdma("R:G1") and sg.is_fdma("R:G2") and not sg.is_fdma("G:L1")
    assert sg.SYSTEM_SIGNALS["R"] == ("R:G1", "R:G2")
