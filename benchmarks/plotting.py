"""The plotting library of the benchmarks, when it is installed (the `bench` extra)."""
from __future__ import annotations

import sys


def pyplot():
    """matplotlib.pyplot drawing to files, or None (with a message) when matplotlib is absent."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no plot", file=sys.stderr)
        return None
    return plt
