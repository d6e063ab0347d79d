import atexit
import os
import sys

from orchestrate.cli import main

code = main()
if sys.orig_argv[1:3] == ["-m", "orchestrate"]:
    # The command is done and every file it wrote is closed: a process of its own ends without
    # Python's teardown of its modules (20 ms with numpy's, a tenth of a small
    # run), once the exit handlers have run and what it printed is out. (Run inside another
    # program, by runpy or a profiler, it returns to that program instead.)
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError) as error:  # a reader gone, a full disk: said, as Python says it
            code = code or 120
            if stream is sys.stdout:
                print(f"error: the output could not be written ({error})", file=sys.stderr, flush=True)
    os._exit(code)
raise SystemExit(code)
