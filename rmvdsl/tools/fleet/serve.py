"""A worker process of `rmv replay --jobs`: `python -m rmvdsl.tools.fleet.serve
READ_FD WRITE_FD`. Reads the spec's JSON and the options once, then jobs (a
recording, or a section of one); writes one result per job; stops at end of input.
Started by local.py as its own program (not a fork of the command, nor a re-run of
its main module)."""

from __future__ import annotations

import signal
import sys
from multiprocessing.connection import Connection

from rmvdsl.tools.fleet.worker import replay_one


def main(argv: list[str]) -> int:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    incoming, outgoing = Connection(int(argv[0])), Connection(int(argv[1]))
    spec_json, options = incoming.recv()
    while True:
        try:
            index, job = incoming.recv()
        except EOFError:
            return 0
        outgoing.send((index, replay_one(spec_json, job, options)))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
