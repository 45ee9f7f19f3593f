"""HTTP header values built from user data: Content-Disposition per RFC 6266 with RFC 5987/8187 encoding."""
from __future__ import annotations

import re
from urllib.parse import quote

_SAFE_ASCII = re.compile(r"[^A-Za-z0-9._+-]")


def content_disposition(filename: str, disposition: str = "attachment") -> str:
    """`attachment; filename="<ASCII fallback>"; filename*=UTF-8''<percent-encoded>` (RFC 6266 sec. 4.3).

    The fallback keeps letters, digits and `._+-` and turns everything else (quotes, backslashes, CR, LF, NUL,
    non-ASCII) into `_`, so no user-chosen name can end the header or inject another one."""
    fallback = _SAFE_ASCII.sub("_", filename)[:200] or "download"
    encoded = quote(filename, safe="")[:1000]
    return f"{disposition}; filename=\"{fallback}\"; filename*=UTF-8''{encoded}"
