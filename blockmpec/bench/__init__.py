"""The comparator harness: isolated runs, comparison tables, study files, performance profiles and figures.

It sits on top of the library: it uses :func:`blockmpec.solve` and the public problem types, and nothing in the
library imports it (only :mod:`blockmpec.cli`).
"""
