"""Write the OpenAPI document the app serves: `python -m app.openapi_export openapi/openapi.json`."""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from app.main import create_app
from core.settings import Settings


def openapi_document() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        return create_app(Settings(data_dir=Path(tmp))).openapi()


def render() -> str:
    return json.dumps(openapi_document(), indent=2, sort_keys=True) + "\n"


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "openapi/openapi.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(render())
    print(out)


if __name__ == "__main__":
    main()
