"""What the ROS 2 and ROS 1 soaks share, with no ROS in it (tests/ros2/drive_soak.py,
tests/ros1/drive_soak.py)."""

from __future__ import annotations

from pathlib import Path

START = 1_700_000_000 * 10**9
ROGUE_STAYS = 4.0  # seconds: a report later than the 2 s goal is measured, not missed


def rss_kib(pid: int) -> int:
    """A process's resident memory (KiB), 0 once it is gone."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0
