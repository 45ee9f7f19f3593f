"""A real HTTP webhook receiver on 127.0.0.1 for the tests: per job it answers 500 to the first `fail_first`
POSTs, then 204; with `hold` set it keeps the first POST open (no answer) until released."""
from __future__ import annotations

import json
import threading
import time
from collections import defaultdict
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer


class Receiver:
    def __init__(self, fail_first: int = 0, hold: bool = False):
        self.fail_first, self.hold = fail_first, hold
        self.calls: dict[str, list[tuple[float, dict]]] = defaultdict(list)  # job id -> (time, headers)
        self.lock = threading.Lock()
        self.first_arrived, self.release = threading.Event(), threading.Event()
        outer = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self):
                body = self.rfile.read(int(self.headers["Content-Length"]))
                job_id = json.loads(body)["job"]["id"]
                with outer.lock:
                    n = sum(len(c) for c in outer.calls.values())
                    outer.calls[job_id].append((time.monotonic(), dict(self.headers)))
                    k = len(outer.calls[job_id])
                if outer.hold and n == 0:
                    outer.first_arrived.set()
                    outer.release.wait(30)
                    return  # the sender was killed meanwhile: no answer
                self.send_response(500 if k <= outer.fail_first else 204)
                self.end_headers()

            def log_message(self, *a):
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.server.daemon_threads = True
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/hook"
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def count(self, job_id: str) -> int:
        with self.lock:
            return len(self.calls[job_id])

    def close(self):
        self.release.set()
        self.server.shutdown()
        self.server.server_close()
