"""Test configuration: single-threaded BLAS (see app/main.py, robolobes.main), set before numpy is imported."""

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
