"""More rows of benchmarks/fault_suite.py, one module per group of faults.

Each module here defines ``ROWS: dict[str, Callable[[argparse.Namespace], list[Row]]]``;
fault_suite.py finds every module of this folder and adds its rows after its own, in the
order of the modules' names. ``Row``, ``ROOT``, ``GAITMON`` and ``env()`` come from
``faults.common``.
"""
