"""What bench/bench_ttff.py and bench/bench_ttff_rtklib.py share: the simulated TTFF starts (the same payloads the
`ttff` job builds, so the same seed gives the same files), a set's files and the baselines reported. A module of
its own so that neither bench imports the other's command-line module in both directions."""
from __future__ import annotations

from pathlib import Path

__all__ = ["BASELINES", "set_files", "study_payloads"]

BASELINES = ("GPS-2>GPS-0", "GPS-2>GPS-1")


def set_files(d: Path) -> list:
    return ([(p.name, "rinex_obs", p) for p in sorted((d / "obs").glob("*.rnx"))]
            + [("brdc.rnx", "rinex_nav", d / "nav" / "brdc.rnx"), ("platform.sp3", "sp3", d / "platform.sp3"),
               ("platform.json", "platform", d / "platform.json"),
               ("reference_attitude.csv", "reference_attitude", d / "reference_attitude.csv")])


def study_payloads(count: int, seed: int, duration_s: float, realistic: bool = True,
                   methods: list | None = None) -> list[dict]:
    """The same payloads the `ttff` job builds for a `simulate` block (worker.pipelines.ttff.payloads)."""
    from types import SimpleNamespace

    from worker.jobs.ttff import TtffConfig
    from worker.pipelines.ttff import payloads

    cfg = TtffConfig.model_validate({"simulate": {"count": count, "seed": seed, "realistic": realistic},
                                     "duration_s": duration_s, **({"methods": methods} if methods else {})})
    return payloads(SimpleNamespace(sets=[]), cfg)
