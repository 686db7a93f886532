"""A Dask LocalCluster in a process of its own, for the fleet tests: two worker
processes of one thread, on 127.0.0.1, no dashboard. Prints the scheduler's
address, then serves until its standard input closes.

    python tests/fleet_cluster.py
"""

from __future__ import annotations

import sys

from distributed import LocalCluster


def main() -> int:
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:  # fmt: skip
        print(cluster.scheduler_address, flush=True)
        sys.stdin.read()
    return 0


if __name__ == "__main__":
    sys.exit(main())
