"""Lazy re-exports (PEP 562): a package names its public entry points in its `__init__` without importing the
numerics behind them until first use, so `import gnssatt.attitude` stays light."""
from __future__ import annotations

import importlib
from typing import Callable


def lazy_exports(package: str, exports: dict[str, str]) -> tuple[Callable[[str], object], Callable[[], list]]:
    """(__getattr__, __dir__) for `package` re-exporting name -> "module" (relative to the package) on first
    access; the value is cached in the package's namespace."""
    def __getattr__(name: str):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{exports[name]}"), name)
        setattr(importlib.import_module(package), name, value)
        return value

    def __dir__() -> list:
        return sorted(set(vars(importlib.import_module(package))) | set(exports))

    return __getattr__, __dir__
