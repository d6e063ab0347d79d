"""Research tools built on the package, not the package: the convergence, stability and Hertz
studies, the benchmark, their reports, and the gallery of shipped scenes. They import orchestrate's
modules; nothing in orchestrate/ imports them but the command line, which assembles their
commands (`python -m orchestrate study ...`, `bench`, `gallery`)."""
