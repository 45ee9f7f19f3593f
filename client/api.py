"""A small httpx client for the gnssatt API (imports neither app/ nor worker/)."""
from __future__ import annotations

import json
import mimetypes
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any, Callable, Iterator

import httpx


class ApiError(RuntimeError):
    """An RFC 9457 problem answered by the server."""

    def __init__(self, status: int, problem: dict[str, Any]):
        self.status = status
        self.problem = problem
        where = ""
        if problem.get("file"):
            where = f" [{problem['file']}" + (f", line {problem['line']}" if problem.get("line") else "") + "]"
        super().__init__(f"{status} {problem.get('title', 'error')}: {problem.get('detail', '')}{where}")


class GnssattClient:
    def __init__(self, url: str, key: str | None, *, timeout_s: float = 300.0, transport=None):
        headers = {"Authorization": f"Bearer {key}"} if key else {}
        self.http = httpx.Client(base_url=url.rstrip("/"), headers=headers, timeout=timeout_s,
                                 transport=transport)

    def close(self) -> None:
        self.http.close()

    def __enter__(self) -> "GnssattClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @staticmethod
    def _check(resp: httpx.Response) -> httpx.Response:
        if resp.status_code >= 400:
            try:
                problem = resp.json()
            except ValueError:
                problem = {"title": resp.reason_phrase, "detail": resp.text[:500]}
            raise ApiError(resp.status_code, problem)
        return resp

    # --- observation sets ------------------------------------------------------------------------
    def upload_set(self, paths: list[Path], name: str | None = None) -> dict:
        """Upload files (or one bundle) as a new observation set; streamed from disk."""
        with ExitStack() as stack:
            files = [("files", (Path(p).name, stack.enter_context(open(p, "rb")),
                                mimetypes.guess_type(str(p))[0] or "application/octet-stream")) for p in paths]
            data = {"name": name} if name else None
            return self._check(self.http.post("/v1/observation-sets", files=files, data=data)).json()

    def list_sets(self, limit: int = 50, offset: int = 0) -> dict:
        return self._check(self.http.get("/v1/observation-sets", params={"limit": limit, "offset": offset})).json()

    def get_set(self, set_id: str) -> dict:
        return self._check(self.http.get(f"/v1/observation-sets/{set_id}")).json()

    def delete_set(self, set_id: str) -> None:
        self._check(self.http.delete(f"/v1/observation-sets/{set_id}"))

    # --- jobs -----------------------------------------------------------------------------------
    def submit_job(self, job_type: str, set_ids: list[str], config: dict | None = None) -> dict:
        body = {"type": job_type, "observation_set_ids": set_ids, "config": config or {}}
        return self._check(self.http.post("/v1/jobs", json=body)).json()

    def get_job(self, job_id: str) -> dict:
        return self._check(self.http.get(f"/v1/jobs/{job_id}")).json()

    def list_jobs(self, state: str | None = None, job_type: str | None = None, limit: int = 50,
                  offset: int = 0) -> dict:
        params: dict[str, Any] = {"limit": limit, "offset": offset}
        if state:
            params["state"] = state
        if job_type:
            params["type"] = job_type
        return self._check(self.http.get("/v1/jobs", params=params)).json()

    def delete_job(self, job_id: str) -> None:
        self._check(self.http.delete(f"/v1/jobs/{job_id}"))

    def cancel_job(self, job_id: str) -> dict:
        return self._check(self.http.post(f"/v1/jobs/{job_id}/cancel")).json()

    def job_types(self) -> list[dict]:
        return self._check(self.http.get("/v1/job-types")).json()

    def events(self, job_id: str) -> Iterator[tuple[str, dict]]:
        """Server-Sent Events of a job: yields (event, job) until the job has finished."""
        with self.http.stream("GET", f"/v1/jobs/{job_id}/events", timeout=None) as resp:
            self._check(resp) if resp.status_code >= 400 else None
            event, data = "message", []
            for line in resp.iter_lines():
                if line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    data.append(line[5:].strip())
                elif line == "" and data:
                    yield event, json.loads("\n".join(data))
                    if event == "end":
                        return
                    event, data = "message", []

    def wait(self, job_id: str, on_update: Callable[[dict], None] | None = None,
             timeout_s: float = 3600.0) -> dict:
        """Follow a job until it finishes (SSE, falling back to polling); returns the final job."""
        deadline = time.monotonic() + timeout_s
        try:
            for _, job in self.events(job_id):
                if on_update:
                    on_update(job)
                if job["state"] in ("succeeded", "failed", "cancelled"):
                    return job
        except (httpx.HTTPError, ValueError):
            pass
        while time.monotonic() < deadline:
            job = self.get_job(job_id)
            if on_update:
                on_update(job)
            if job["state"] in ("succeeded", "failed", "cancelled"):
                return job
            time.sleep(0.5)
        raise TimeoutError(f"job {job_id} did not finish in {timeout_s} s")

    def products(self, job_id: str) -> list[dict]:
        return self._check(self.http.get(f"/v1/jobs/{job_id}/products")).json()

    def download_products(self, job_id: str, out_dir: Path) -> list[Path]:
        out_dir = Path(out_dir)
        out_dir.mkdir(parents=True, exist_ok=True)
        paths = []
        for prod in self.products(job_id):
            dest = out_dir / prod["name"]
            with self.http.stream("GET", f"/v1/jobs/{job_id}/products/{prod['name']}") as resp:
                self._check(resp) if resp.status_code >= 400 else None
                tmp = dest.with_suffix(dest.suffix + ".part")
                with open(tmp, "wb") as fh:
                    for chunk in resp.iter_bytes():
                        fh.write(chunk)
                tmp.replace(dest)
            paths.append(dest)
        return paths
