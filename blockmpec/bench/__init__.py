"""The comparator harness: isolated runs, comparison tables, study files, performance profiles and figures.

It sits on top of the library and uses only its public API (:func:`blockmpec.solve`, :func:`blockmpec.run_solver`,
:func:`blockmpec.get_solver`, :mod:`blockmpec.cases`, :mod:`blockmpec.options`, :mod:`blockmpec.plot`, the result
and structure types, and :mod:`blockmpec.solvers.linalg.cpus` for the CPU share of parallel solves).  Nothing in
the library imports it; only :mod:`blockmpec.cli` does.

* :mod:`~blockmpec.bench.runner`: isolated solves in worker processes, under an outside wall-clock limit;
* :mod:`~blockmpec.bench.compare`: methods x cases into one table, references, signed errors, marks;
* :mod:`~blockmpec.bench.study`: the output folder (resume, lock) and study files;
* :mod:`~blockmpec.bench.profiles`: solved, budgets, performance profiles and the summary table;
* :mod:`~blockmpec.bench.plots`: the comparator's figures;
* :mod:`~blockmpec.bench.suite`: the built-in benchmark suite.
"""
