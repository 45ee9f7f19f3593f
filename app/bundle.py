""""Download all": one zip of a job's products, its configuration and the versions of the software and of the
inputs (name, kind, size and SHA-256 of every file of every set the job read), so a result can be archived and
traced without the service."""
from __future__ import annotations

import importlib.metadata
import io
import json
import platform
import zipfile
from typing import Callable

#: distributions whose versions go into versions.json
_DISTS = ("gnssatt", "numpy", "scipy", "numba", "pyerfa", "matplotlib", "fastapi", "sqlalchemy", "huey")


def software_versions() -> dict[str, str | None]:
    out: dict[str, str | None] = {"python": platform.python_version()}
    for name in _DISTS:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def job_bundle(job, products, sets, blob_path: Callable[[str], object]) -> bytes:
    """Zip bytes: products/<name> for every product, config.json, versions.json (software, inputs, job)."""
    buf = io.BytesIO()
    inputs = [{"set_id": s.id, "set_name": s.name,
               "files": [{"name": f.name, "kind": f.kind, "size_bytes": f.size_bytes, "sha256": f.sha256}
                         for f in s.files]} for s in sets]
    versions = {"software": software_versions(), "inputs": inputs,
                "job": {"id": job.id, "type": job.type, "state": job.state,
                        "created_at": str(job.created_at), "finished_at": str(job.finished_at)},
                "products": [{"name": p.name, "media_type": p.media_type, "size_bytes": p.size_bytes,
                              "sha256": p.sha256} for p in products]}
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as z:
        for p in products:
            z.write(blob_path(p.sha256), f"products/{p.name}")
        z.writestr("config.json", json.dumps(job.config or {}, indent=2, sort_keys=True) + "\n")
        z.writestr("versions.json", json.dumps(versions, indent=2) + "\n")
    return buf.getvalue()
