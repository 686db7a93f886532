"""Fleet replay (docs/fleet.md): one spec over many recordings, made here with
rosbags in the three formats. Parallel processes and a real Dask LocalCluster
(on 127.0.0.1) give each recording the result sequential replay gives it, and
that result's records are the ones `rmv replay` prints for the recording alone;
a worker killed mid-run loses no recording; damaged, hanging and missing
recordings are reported and counted while the rest complete; Ctrl-C stops with
the partial results."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import fleet_recordings
import pytest
from conftest import RMV, ROOT, rmv_process

FLEET = 200


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """200 small recordings (40 messages each) and the spec, in one folder."""
    folder = tmp_path_factory.mktemp("fleet")
    fleet_recordings.fleet(folder / "runs", FLEET)
    (folder / "spec.rmv").write_text(fleet_recordings.SPEC, encoding="utf-8")
    return folder


def _results(out: str) -> dict[str, dict]:
    found = {}
    for line in out.splitlines():
        result = json.loads(line)
        found[Path(result.pop("path")).name] = result
    return found


def _comparable(result: dict) -> dict:
    """A result without what depends on the machine (how long it took)."""
    return {k: v for k, v in result.items() if k != "seconds"}


@pytest.fixture(scope="module")
def sequential(runs: Path) -> dict[str, dict]:
    done = rmv_process(["replay", "spec.rmv", "runs", "--jobs", "1", "--format", "jsonl"],
                       cwd=runs)  # fmt: skip
    assert done.code == 1, done.err  # some runs violate their properties
    return _results(done.out)


def test_the_recordings_are_found_in_folders_and_patterns(runs, sequential):
    names = set(sequential)
    assert len(names) == FLEET
    assert {n.rsplit("_", 1)[-1].rsplit(".", 1)[-1] for n in names} == {"bag", "db3", "mcap"}
    statuses = {r["status"] for r in sequential.values()}
    assert {"pass", "violations"} <= statuses
    pattern = rmv_process(["replay", "spec.rmv", "runs/*.bag", "--format", "jsonl"], cwd=runs)
    assert set(_results(pattern.out)) == {n for n in names if n.endswith(".bag")}


def test_parallel_processes_give_the_sequential_results(runs, sequential):
    parallel = rmv_process(["replay", "spec.rmv", "runs", "--jobs", "2", "--format", "jsonl"],
                           cwd=runs)  # fmt: skip
    assert parallel.code == 1, parallel.err
    found = _results(parallel.out)
    assert {k: _comparable(v) for k, v in found.items()} == {
        k: _comparable(v) for k, v in sequential.items()
    }


@pytest.mark.parametrize("name", ["run0000.bag", "run0001_db3", "run0002_mcap"])
def test_a_result_s_records_are_those_of_the_recording_alone(runs, sequential, name):
    alone = rmv_process(["replay", "spec.rmv", f"runs/{name}", "--format", "json"], cwd=runs)
    assert json.loads(alone.out)["records"] == sequential[name]["records"]


def test_a_dask_cluster_gives_the_sequential_results(runs, sequential, tmp_path):
    """A LocalCluster (processes=True, 2 workers, 127.0.0.1) in a process of its own:
    an existing cluster, as users have one, and none of Dask's threads in this one."""
    pytest.importorskip("distributed")
    cluster = subprocess.Popen([sys.executable, str(ROOT / "tests" / "fleet_cluster.py")],
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL, text=True)  # fmt: skip
    try:
        assert cluster.stdout is not None
        address = cluster.stdout.readline().strip()
        assert address.startswith("tcp://127.0.0.1:"), address
        found = rmv_process(["replay", "spec.rmv", "runs", "--scheduler", address,
                             "--format", "jsonl"], cwd=runs)  # fmt: skip
        assert found.code == 1, found.err
        env = {**os.environ, "RMV_DASK_SCHEDULER": address}
        named = rmv_process(["replay", "spec.rmv", "runs/run000*", "--dask", "--quiet"],
                            cwd=runs, env=env)  # fmt: skip
        # A recording that blocks its worker's thread (opening a FIFO): the task is
        # cancelled and the worker restarted, the retry goes to the other worker.
        (tmp_path / "hangs").mkdir()
        os.mkfifo(tmp_path / "hangs" / "hangs.bag")
        os.symlink(runs / "runs" / "run0003.bag", tmp_path / "hangs" / "run0003.bag")
        hanging = rmv_process(["replay", str(runs / "spec.rmv"), "hangs", "--scheduler", address,
                               "--timeout", "1", "--format", "jsonl", "--quiet"],
                              cwd=tmp_path)  # fmt: skip
        # Each 4 s recording in four 1 s chunks, a task each.
        chunked = rmv_process(["replay", "spec.rmv", "runs/run000*", "--scheduler", address,
                               "--chunk", "1", "--format", "jsonl", "--quiet"],
                              cwd=runs)  # fmt: skip
    finally:
        cluster.communicate("", timeout=60)
    assert {k: _comparable(v) for k, v in _results(found.out).items()} == {
        k: _comparable(v) for k, v in sequential.items()
    }
    assert named.code in (0, 1) and "10 recordings of 10 replayed" in named.out, named.err
    stuck = _results(hanging.out)
    assert "hangs.bag" in stuck, (hanging.code, hanging.out, hanging.err)
    assert stuck["hangs.bag"]["status"] == "failed", (stuck, hanging.err)
    assert stuck["hangs.bag"]["error"] == "took longer than --timeout 1 s, twice"
    assert _comparable(stuck["run0003.bag"]) == _comparable(sequential["run0003.bag"])
    joined = _results(chunked.out)
    assert len(joined) == 10 and {r["chunks"] for r in joined.values()} == {4}, chunked.err
    for name, result in joined.items():
        whole = sequential[name]
        texts = [sorted(json.dumps(r) for r in records)
                 for records in (result.pop("records"), whole["records"])]  # fmt: skip
        assert texts[0] == texts[1]
        assert {k: result[k] for k in ("status", "violations", "messages")} == {
            k: whole[k] for k in ("status", "violations", "messages")
        }


def _children(pid: int) -> list[int]:
    """The processes whose parent is `pid` (from /proc/*/stat)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def test_a_worker_killed_mid_run_loses_no_recording(runs, sequential, tmp_path):
    """kill -9 of a worker while it replays: its recording is retried on a new
    worker, and every recording has the result it has alone."""
    slow = tmp_path / "slow"
    fleet_recordings.write(slow / "long", "mcap", fleet_recordings.speeds(7, 30_000))
    for name in ("run0000.bag", "run0001_db3", "run0002_mcap"):
        os.symlink(runs / "runs" / name, slow / name)
    process = subprocess.Popen([*RMV, "replay", str(runs / "spec.rmv"), str(slow), "--jobs", "2",
                                "--format", "jsonl"], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)  # fmt: skip
    killed = []
    deadline = time.monotonic() + 60
    # The worker that has the long recording open is replaying it: killed then. (A
    # pause before a kill assumed a replay of seconds; a faster replay had ended.)
    while not killed and time.monotonic() < deadline and process.poll() is None:
        for worker in (p for p in _children(process.pid) if _is_worker(p)):
            if any("long_mcap" in target for target in _open_files(worker)):
                with contextlib.suppress(ProcessLookupError):
                    os.kill(worker, signal.SIGKILL)
                    killed.append(worker)
        time.sleep(0.005)
    out, err = process.communicate(timeout=120)
    assert killed, f"no worker was seen replaying the long recording: {err}"
    found = _results(out)
    assert set(found) == {"long_mcap", "run0000.bag", "run0001_db3", "run0002_mcap"}, err
    assert all(r["status"] != "failed" for r in found.values()), found
    for name in ("run0000.bag", "run0001_db3", "run0002_mcap"):
        assert _comparable(found[name]) == _comparable(sequential[name])


def _open_files(pid: int) -> list[str]:
    """What the process's open descriptors name (/proc/PID/fd)."""
    found = []
    with contextlib.suppress(OSError):
        for descriptor in Path(f"/proc/{pid}/fd").iterdir():
            with contextlib.suppress(OSError):
                found.append(os.readlink(descriptor))
    return found


def _is_worker(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as handle:
            return b"rmvdsl.tools.fleet.serve" in handle.read()
    except OSError:
        return False


def test_damaged_and_hanging_recordings_are_reported_and_the_rest_complete(runs, tmp_path):
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for name in ("run0003.bag", "run0004_db3"):
        os.symlink(runs / "runs" / name, mixed / name)
    (mixed / "garbage.bag").write_bytes(b"#ROSBAG V2.0\n" + os.urandom(4000))
    good = (runs / "runs" / "run0005_mcap" / "run0005_mcap.mcap").read_bytes()
    (mixed / "truncated.mcap").write_bytes(good[: len(good) // 2])
    os.mkfifo(mixed / "hangs.bag")  # opening it blocks: a recording that never reads
    done = rmv_process(["replay", str(runs / "spec.rmv"), str(mixed), "--jobs", "2",
                        "--timeout", "1", "--format", "jsonl"], cwd=tmp_path)  # fmt: skip
    found = _results(done.out)
    assert set(found) == {"run0003.bag", "run0004_db3", "garbage.bag", "truncated.mcap",
                          "hangs.bag"}, done.err  # fmt: skip
    assert found["garbage.bag"]["status"] == "unreadable"
    assert found["truncated.mcap"]["status"] == "unreadable"
    assert found["garbage.bag"]["error"]
    hang = found["hangs.bag"]
    assert hang["status"] == "failed"
    assert hang["error"] == "took longer than --timeout 1 s, twice"
    assert found["run0003.bag"]["status"] in ("pass", "violations")
    assert done.code in (0, 1)


def test_exit_codes_and_what_is_missing(runs, tmp_path):
    (tmp_path / "a.bag").write_bytes(b"not a bag")
    (tmp_path / "b.bag").write_bytes(b"nor this")
    unreadable = rmv_process(["replay", str(runs / "spec.rmv"), "a.bag", "b.bag"], cwd=tmp_path)
    assert unreadable.code == 2
    assert "2 recordings unreadable" in unreadable.out
    empty = tmp_path / "empty"
    empty.mkdir()
    nothing = rmv_process(["replay", str(runs / "spec.rmv"), str(empty)], cwd=tmp_path)
    assert nothing.code == 2
    assert nothing.err.strip().endswith(
        "no recordings in it (.bag, .mcap or .db3 files, or rosbag2 folders)"
    )
    unmatched = rmv_process(["replay", str(runs / "spec.rmv"), "nowhere/*.bag"], cwd=tmp_path)
    assert (unmatched.code, unmatched.err.strip()) == (
        2, "rmv: error: nowhere/*.bag: no file or folder matches"
    )  # fmt: skip


def test_progress_on_a_log_and_quiet(runs):
    shown = rmv_process(["replay", "spec.rmv", "runs/run000*"], cwd=runs)
    assert shown.err.startswith("rmv replay: 10/10 recordings, "), shown.err
    assert " msg/s, " in shown.err and "left" in shown.err
    quiet = rmv_process(["replay", "spec.rmv", "runs/run000*", "--quiet"], cwd=runs)
    assert quiet.err == ""
    totals = [line for line in shown.out.splitlines() if not line.startswith(("pass ", "viol"))]
    assert totals[0].startswith("10 recordings of 10 replayed (400 messages): ")
    assert [line for line in quiet.out.splitlines() if line in totals] == totals


def test_the_fleet_report_is_one_page_with_every_recording(runs, sequential, tmp_path):
    report = tmp_path / "fleet.html"
    done = rmv_process(["replay", "spec.rmv", "runs", "--report", str(report), "--quiet"],
                       cwd=runs)  # fmt: skip
    assert done.code == 1
    page = report.read_text(encoding="utf-8")
    assert page.count("<tr><td>") == FLEET + 2  # every recording, and both properties
    failing = sum(r["status"] == "violations" for r in sequential.values())
    assert f"{failing} recordings with violations" in page
    assert page.count("<svg") == 5  # the five worst runs' timelines
    assert "NeverStops" in page and "NotFastLong" in page
    assert "http" not in page.replace("http://www.w3.org/2000/svg", "")  # nothing fetched
    assert "th.onclick" in page  # sortable


def test_ctrl_c_stops_and_prints_what_was_done(runs, tmp_path):
    report = tmp_path / "partial.html"
    process = subprocess.Popen([*RMV, "replay", "spec.rmv", "runs", "--jobs", "2", "--report",
                                str(report)], cwd=runs, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)  # fmt: skip
    assert process.stdout is not None
    first = process.stdout.readline()  # a first recording is done
    assert first.split()[0] in ("pass", "violations"), first
    process.send_signal(signal.SIGINT)
    out, _ = process.communicate(timeout=60)
    assert process.returncode == 130
    assert "interrupted: " in out
    assert report.is_file()
    assert not [p for p in _children_or_none(process.pid)]


def _children_or_none(pid: int) -> list[int]:
    try:
        return _children(pid)
    except OSError:
        return []


def test_scheduler_without_dask_says_how_to_install_it(runs):
    code = (
        "import sys; sys.modules['distributed'] = None; sys.modules['dask'] = None\n"
        "from rmvdsl.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, "replay", "spec.rmv", "runs", "--scheduler",
         "tcp://127.0.0.1:1"], cwd=runs, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "rmv: error: --scheduler needs Dask: pip install 'rmvdsl[fleet]'"
    )


def test_merge_reads_the_recordings_as_one(runs, tmp_path):
    """--merge: the recordings' messages in one time order (a bag split in parts)."""
    parts = [runs / "runs" / "run0000.bag", runs / "runs" / "run0003.bag"]
    merged = rmv_process(["replay", "spec.rmv", *map(str, parts), "--merge", "--format", "json"],
                         cwd=runs)  # fmt: skip
    assert "records" in json.loads(merged.out)
    assert ROOT.is_dir()


def test_a_retry_goes_to_another_worker():
    """A job whose try timed out in a worker that lives on is not given back to it
    while there is another worker; with one worker, it is."""
    from collections import deque

    from rmvdsl.tools.fleet.local import _take
    from rmvdsl.tools.fleet.sections import Job

    pending = deque([(0, Job("a.bag")), (1, Job("b.bag"))])
    assert _take(pending, 11, {0: 11}, 2) == (1, Job("b.bag"))
    assert _take(pending, 11, {0: 11}, 2) is None
    assert _take(pending, 12, {0: 11}, 2) == (0, Job("a.bag"))
    pending.append((0, Job("a.bag")))
    assert _take(pending, 11, {0: 11}, 1) == (0, Job("a.bag"))


def test_the_spec_is_sent_again_while_a_restarted_worker_refuses_it(monkeypatch):
    """After a stuck task's worker is restarted, sending the spec to every worker can
    meet it still starting: asked again a second later, the run goes on."""
    from rmvdsl.tools.fleet import cluster

    class Client:
        calls = 0

        def scatter(self, data, broadcast, hash):
            Client.calls += 1
            if Client.calls < 3:
                raise OSError("Timed out trying to connect to tcp://127.0.0.1:1")
            return "spec future"

    monkeypatch.setattr(cluster.time, "sleep", lambda seconds: None)
    tasks = cluster._Tasks(Client(), "{}", None, [])
    assert tasks.spec == "spec future" and Client.calls == 3
    Client.calls = -10  # every try refused: the error is the run's
    with pytest.raises(OSError):
        tasks.ship()
