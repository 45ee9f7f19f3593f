"""Lazy re-exports (PEP 562): a package names its public entry points in its `__init__` without importing the
numerics behind them until first use, so `import gnssatt.attitude` stays light."""
from __future__ import annotations

import importlib
import sys


def lazy_exports(package: str, exports: dict[str, str]):
    """(__getattr__, __dir__) for `package` re-exporting name -> "module" (relative to the package) on first
    access; the value is then cached in the package's namespace."""
    def __getattr__(name: str):
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{exports[name]}"), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__
