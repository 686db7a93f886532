"""A stand-in for Kapacitor's task API on 127.0.0.1, for `rmv deploy`'s tests.
Kapacitor is not installable here; this server holds every request to the rules
of its documented API (client/API.md, "Tasks") and of its task store
(services/task_store/service.go): the task id's alphabet, a POST for a new task
only, a TICKscript that must parse (tests/kapacitor/tickscript.py), `dbrp` given in
the script or in the request but never in both, a status of enabled or disabled,
`{"error": ...}` with HTTP 400/404 for anything else. It records every request."""

from __future__ import annotations

import fnmatch
import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import parse_qs, unquote, urlparse

from kapacitor import tickscript

BASE = "/kapacitor/v1/tasks"
CREATE_KEYS = {"id", "template-id", "type", "dbrps", "script", "status", "vars"}


def valid_id(task_id: str) -> bool:
    """`^[-\\._\\p{L}0-9]+$`."""
    return bool(task_id) and all(c.isalpha() or c.isdigit() or c in "-._" for c in task_id)


def script_dbrps(script: str) -> list[dict[str, str]]:
    statements = tickscript.check(script)
    return [{"db": s[1], "rp": s[2]} for s in statements if s[0] == "dbrp"]


class Failure(Exception):
    def __init__(self, status: int, message: str) -> None:
        super().__init__(message)
        self.status = status


class Kapacitor:
    """The tasks, and the log of requests as (method, path, body)."""

    def __init__(self) -> None:
        self.tasks: dict[str, dict[str, Any]] = {}
        self.requests: list[tuple[str, str, Any]] = []
        self.authorizations: list[str | None] = []
        self.lock = threading.Lock()

    def create(self, body: Any) -> dict[str, Any]:
        if not isinstance(body, dict) or set(body) - CREATE_KEYS:
            raise Failure(400, "invalid JSON")
        task_id = body.get("id", "")
        if not valid_id(task_id):
            raise Failure(
                400, f"task ID must contain only letters, numbers, '-', '.' and '_'. {task_id!r}"
            )
        if task_id in self.tasks:
            raise Failure(400, f"task {task_id} already exists")
        script = body.get("script", "")
        if not script:
            raise Failure(400, "must provide TICKscript")
        dbrps = self._dbrps(script, body.get("dbrps") or [])
        status = body.get("status", "disabled")
        if status not in ("enabled", "disabled"):
            raise Failure(400, f"invalid status {status!r}")
        task = {"id": task_id, "type": _type(script), "dbrps": dbrps, "script": script,
                "status": status}  # fmt: skip
        self.tasks[task_id] = task
        return task

    def update(self, task_id: str, body: Any) -> dict[str, Any]:
        if task_id not in self.tasks:
            raise Failure(404, "task does not exist, cannot update")
        if not isinstance(body, dict) or set(body) - CREATE_KEYS:
            raise Failure(400, "invalid JSON")
        task = dict(self.tasks[task_id])
        if body.get("script"):
            task["script"] = body["script"]
        task["dbrps"] = (
            self._dbrps(task["script"], body.get("dbrps") or [], patch=True) or task["dbrps"]
        )
        task["type"] = _type(task["script"])
        if "status" in body:
            if body["status"] not in ("enabled", "disabled"):
                raise Failure(400, f"invalid status {body['status']!r}")
            task["status"] = body["status"]
        self.tasks[task_id] = task
        return task

    @staticmethod
    def _dbrps(script: str, given: list[Any], patch: bool = False) -> list[dict[str, str]]:
        try:
            implicit = script_dbrps(script)
        except tickscript.TickError as error:
            raise Failure(400, f"invalid TICKscript: {error}") from None
        if implicit and given:
            raise Failure(400, "cannot specify dbrp in both implicitly and explicitly")
        if not implicit and not given and not patch:
            raise Failure(400, "must specify dbrp")
        return implicit or list(given)


def _type(script: str) -> str:
    return "batch" if script.lstrip().startswith("batch") else "stream"


def _handler(state: Kapacitor) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args: Any) -> None:
            pass

        def _body(self) -> Any:
            length = int(self.headers.get("Content-Length") or 0)
            data = self.rfile.read(length) if length else b""
            try:
                return json.loads(data) if data else None
            except json.JSONDecodeError:
                return "not JSON"

        def _answer(self, status: int, body: Any = None) -> None:
            data = b"" if body is None else json.dumps(body).encode()
            self.send_response(status)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def _serve(self, method: str) -> None:
            url = urlparse(self.path)
            body = self._body() if method in ("POST", "PATCH") else None
            with state.lock:
                state.requests.append((method, url.path, body))
                state.authorizations.append(self.headers.get("Authorization"))
                try:
                    status, answer = self._route(method, url, body)
                except Failure as failure:
                    status, answer = failure.status, {"error": str(failure)}
            self._answer(status, answer)

        def _route(self, method: str, url: Any, body: Any) -> tuple[int, Any]:
            if url.path == BASE and method == "POST":
                return 200, state.create(body)
            if url.path == BASE and method == "GET":
                pattern = parse_qs(url.query).get("pattern", ["*"])[0]
                found = [
                    {"id": t, "link": {"rel": "self", "href": f"{BASE}/{t}"}}
                    for t in sorted(state.tasks)
                    if fnmatch.fnmatchcase(t, pattern)
                ]
                return 200, {"tasks": found}
            if not url.path.startswith(BASE + "/"):
                raise Failure(404, "not found")
            task_id = unquote(url.path[len(BASE) + 1 :])
            if method == "GET":
                if task_id not in state.tasks:
                    raise Failure(404, "no task exists")
                return 200, state.tasks[task_id]
            if method == "PATCH":
                return 200, state.update(task_id, body)
            if method == "DELETE":
                state.tasks.pop(task_id, None)
                return 204, None
            raise Failure(405, "method not allowed")

        def do_GET(self) -> None:
            self._serve("GET")

        def do_POST(self) -> None:
            self._serve("POST")

        def do_PATCH(self) -> None:
            self._serve("PATCH")

        def do_DELETE(self) -> None:
            self._serve("DELETE")

    return Handler


class Server:
    def __init__(self) -> None:
        self.state = Kapacitor()
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), _handler(self.state))
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)
        self.thread.start()

    def stop(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
