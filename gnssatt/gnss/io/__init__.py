"""Readers of the GNSS file formats, at one import place (each imported on first use, PEP 562):

    from gnssatt.gnss.io import read_rinex_obs, read_rinex_nav, read_sp3, read_antex, identify

`read_rinex_obs(path) -> RinexObs`, `read_rinex_nav(path) -> NavData`, `read_sp3(path) -> Sp3Data`,
`read_antex(path) -> [AntennaPattern]`, `read_rinex_clock(path) -> ClockData`, `parse_platform(text)`,
`read_reference_attitude(text)`; `identify(path, name) -> (kind, summary)` tells a file's kind from its content as
the service does. Every reader raises `ParseError` naming the file and line. See docs/library.md.
"""
from gnssatt._lazy import lazy_exports

_EXPORTS = {"read_rinex_obs": "rinex_obs", "read_rinex_nav": "rinex_nav", "read_sp3": "sp3", "read_antex": "antex",
            "read_rinex_clock": "rinex_clock", "parse_platform": "platform",
            "read_reference_attitude": "reference_attitude", "identify": "sniff", "ParseError": "errors"}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
