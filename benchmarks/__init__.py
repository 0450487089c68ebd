"""``mpc-bench``: benchmarks, sweeps and measurements of holonomic-mpc (see README)."""

import os

# One BLAS thread for the benchmark's process (set before NumPy loads it, as when
# mpc-bench starts): the fast path's matrices are a few hundred rows, where BLAS threads
# only add wake-up jitter (docs/design/blas-one-thread.md). A value already in the
# environment wins.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")
