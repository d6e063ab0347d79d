import atexit
import os
import sys

from orchestrate.cli import main

code = main()
# The command is done and every file it wrote is closed: the process ends without Python's
# teardown of its modules (numpy's and pydantic's take 35 ms, a tenth of a small run's wall
# time), once the exit handlers have run and what it printed is out.
atexit._run_exitfuncs()
for stream in (sys.stdout, sys.stderr):
    try:
        stream.flush()
    except (OSError, ValueError):  # a reader that went away, a stream closed
        pass
os._exit(code)
