#!/usr/bin/env python3
"""Runs the project's plot scripts (tools/plot_*.py) one after another in this one process, so that a batch of
plots (`iapsim regress`: two or three a flight) pays for starting Python and importing matplotlib once.

Protocol, one job a line on stdin: a JSON list [SCRIPT, ARG...]; for each, one line on stdout: "ok", or
"error " and why. The script runs as __main__ with sys.argv = [SCRIPT, ARG...]. Ends at end of input.
"""
import contextlib
import json
import runpy
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


def main():
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            job = json.loads(line)
        except json.JSONDecodeError as e:
            reply = f"error not a JSON job: {e}"
        else:
            reply = run(job) if isinstance(job, list) and job else "error a job is [SCRIPT, ARG...]"
        sys.stderr.flush()
        print(reply, flush=True)


if __name__ == "__main__":
    main()
