"""A real InfluxDB 1.x (Debian's `influxd`) for the tests: started on 127.0.0.1 with a
config written here, its data in a temporary folder, every listener on loopback,
the continuous querier on a short run interval, and limits so that a bad query
cannot exhaust the machine."""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path
from typing import Any

CONFIG = """\
reporting-disabled = true
bind-address = "127.0.0.1:{rpc}"
[meta]
  dir = "{root}/meta"
  logging-enabled = false
[data]
  dir = "{root}/data"
  wal-dir = "{root}/wal"
  query-log-enabled = false
[coordinator]
  query-timeout = "60s"
  max-select-buckets = 1000000
  max-select-point = 10000000
[monitor]
  store-enabled = false
[subscriber]
  enabled = false
[http]
  bind-address = "127.0.0.1:{http}"
  log-enabled = false
  pprof-enabled = false
  max-body-size = 25000000
[ifql]
  enabled = false
[continuous_queries]
  log-enabled = false
  run-interval = "{run_interval}"
[logging]
  level = "warn"
  suppress-logo = true
"""


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


class Influxd:
    """One influxd process; `url` is its HTTP API."""

    def __init__(self, root: Path, run_interval: str = "1s") -> None:
        executable = shutil.which("influxd")
        if executable is None:
            raise RuntimeError("influxd is not installed: .ci/run installs Debian's influxdb")
        self.root = root
        self.port = free_port()
        config = root / "influxdb.conf"
        config.write_text(
            CONFIG.format(root=root, rpc=free_port(), http=self.port, run_interval=run_interval)
        )
        self.command = [executable, "-config", str(config)]
        self.url = f"http://127.0.0.1:{self.port}"
        self.start()

    def start(self) -> None:
        """Start influxd (again: its data stays in `root`)."""
        self.log = (self.root / "influxd.log").open("a")
        self.process = subprocess.Popen(self.command, stdout=self.log, stderr=subprocess.STDOUT)
        self._wait()

    def _wait(self) -> None:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"influxd exited: {self.logs()}")
            try:
                with urllib.request.urlopen(f"{self.url}/ping", timeout=1):
                    return
            except (urllib.error.URLError, ConnectionError):
                time.sleep(0.1)
        raise RuntimeError(f"influxd did not answer in 30 s: {self.logs()}")

    def logs(self) -> str:
        return (self.root / "influxd.log").read_text(errors="replace")[-3000:]

    def query(self, text: str, db: str | None = None, **params: str) -> list[dict[str, Any]]:
        """The statements' results; an error in either layer raises."""
        fields = {"q": text, **({"db": db} if db else {}), **params}
        data = urllib.parse.urlencode(fields).encode()
        try:
            with urllib.request.urlopen(f"{self.url}/query", data=data, timeout=60) as answer:
                body = json.load(answer)
        except urllib.error.HTTPError as error:
            raise AssertionError(f"{text}: HTTP {error.code}: {error.read().decode()}") from None
        for result in body.get("results", []):
            if "error" in result:
                raise AssertionError(f"{text}: {result['error']}")
        return list(body.get("results", []))

    def write(self, db: str, lines: list[str], rp: str | None = None) -> None:
        params = {"db": db, "precision": "n", **({"rp": rp} if rp else {})}
        url = f"{self.url}/write?{urllib.parse.urlencode(params)}"
        request = urllib.request.Request(url, data="\n".join(lines).encode(), method="POST")
        try:
            with urllib.request.urlopen(request, timeout=60):
                pass
        except urllib.error.HTTPError as error:
            raise AssertionError(f"write: HTTP {error.code}: {error.read().decode()}") from None

    def points(self, text: str, db: str) -> list[list[Any]]:
        """The rows of a query's first series (times in ns)."""
        results = self.query(text, db, epoch="ns")
        series = results[0].get("series", [])
        return [row for s in series for row in s["values"]]

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        self.log.close()
