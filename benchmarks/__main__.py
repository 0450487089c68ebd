"""``python -m benchmarks`` is ``mpc-bench``."""

import sys

from benchmarks.cli import main

sys.exit(main())
