"""Export and report cost against session length: the offline suite of ``gaitmon bench``.

Same as ``gaitmon bench --suite offline``: CSV / MAT / C3D export and the PDF report over
synthetic 1 min, 10 min, 1 h and 8 h sessions (cached under the temp folder), medians of fresh
processes, beside pyarrow's ``write_csv`` and scipy's ``savemat`` of the same data, with the
growth per hour and the peak memory (gaitmon/commands/bench_offline.py).

Run: python benchmarks/bench_export.py [--lengths 1min,1h,8h] [--repeat 3] [--skip csv_pyarrow]
"""

from __future__ import annotations

from gaitmon.commands.bench_offline import main

if __name__ == "__main__":
    raise SystemExit(main())
