#!/usr/bin/env python3
"""Runs the project's plot scripts (tools/plot_*.py) one after another in this one process, so that a batch of
plots (`iapsim regress`: two or three a flight) pays for starting Python and importing matplotlib once.

Protocol, one job a line on stdin: a JSON list [SCRIPT, ARG...]; for each, one line on stdout: "ok", or
"error " and why. The script runs as __main__ with sys.argv = [SCRIPT, ARG...]. Ends at end of input.

With --listen-fd N it serves the same jobs on connections to the listening unix socket N instead, one
connection at a time (each its jobs, one reply a line), of this user only: the runs that `iapsim regress` and
`iapsim sweep` fly side by side share it (tools/plot_script.h, SharedPlotServer); it ends at the end of stdin,
when the program that started it closes its end or dies.
"""
import contextlib
import json
import os
import runpy
import select
import socket
import struct
import sys
import traceback

import matplotlib

matplotlib.use("Agg")  # headless: CI and `make run` have no display
import matplotlib.pyplot as plt


def run(job):
    sys.argv = [str(word) for word in job]
    try:
        # what a script prints goes to stderr: stdout carries the replies
        with contextlib.redirect_stdout(sys.stderr):
            runpy.run_path(sys.argv[0], run_name="__main__")
        return "ok"
    except SystemExit as e:  # a script's sys.exit: 0 or None is success, anything else says why
        return "ok" if e.code in (0, None) else f"error {e.code}"
    except Exception:  # a script's failure must not end the server: the next plot is another script's
        return "error " + traceback.format_exc().replace("\n", " | ")
    finally:
        plt.close("all")


def reply_to(line):
    try:
        job = json.loads(line)
    except json.JSONDecodeError as e:
        return f"error not a JSON job: {e}"
    return run(job) if isinstance(job, list) and job else "error a job is [SCRIPT, ARG...]"


def serve(lines, out):
    for line in lines:
        if not line.strip():
            continue
        reply = reply_to(line)
        sys.stderr.flush()
        out.write(reply + "\n")
        out.flush()


def same_user(connection):
    """Whether the peer runs as this user: an abstract socket has no file permissions to keep others out."""
    _, uid, _ = struct.unpack("3i", connection.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, 12))
    if uid == os.getuid():
        return True
    print(f"plot_server: refused a connection of uid {uid}", file=sys.stderr)
    return False


def serve_connections(listener):
    while True:
        ready, _, _ = select.select([listener, sys.stdin], [], [])
        if sys.stdin in ready and not sys.stdin.readline():
            return  # the program that started this one is done, or gone
        if listener in ready:
            connection, _ = listener.accept()
            if not same_user(connection):
                connection.close()
                continue
            with connection, connection.makefile("r") as lines, connection.makefile("w") as out:
                try:
                    serve(lines, out)
                except OSError:  # the client went away before its reply: the next one is another's
                    pass


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--listen-fd":
        serve_connections(socket.socket(fileno=int(sys.argv[2])))
    else:
        serve(sys.stdin, sys.stdout)


if __name__ == "__main__":
    main()
