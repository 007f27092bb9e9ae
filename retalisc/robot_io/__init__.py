"""Robot data in and out: ROS messages as Retalis events, bag replay, derived events back
into the robot's tools, and timeline pictures (docs/robot_io.md).

- `messages`: message <-> event term conversion, generic over the message types of a rosbags
  type store (the definitions embedded in a bag included), with a converter generated per
  type on first use; terms are the values of `retalisc.driver.values` (outputs come with their
  term as data, `OutputEvent.term`; text is read by `values.read_term`).
- `bags`: opening ROS 1 `.bag` files, ROS 2 sqlite3 folders and MCAP files; writing small
  bags (tests, examples).
- `replay`: `retalisc run PROGRAM --bag FILE`: feeding a recording to an Engine.
- `publish`: `--out-bag FILE.mcap` and `--foxglove [PORT]`: what the program derived, back
  into the robot's tools.
- `plot`: `retalisc plot OUTPUT.jsonl -o timeline.png`.
- `samples`: the sample recording of the NAO application (tests, benchmark, examples).

`rosbags`, `mcap` (writing MCAP), `foxglove-sdk` (the live server) and `matplotlib`
(timelines) are optional dependencies: the extra `ros` (`pip install 'retalisc[ros]'`).
`require()` turns their absence into a clear message.
"""
from __future__ import annotations

import importlib


class MissingDependency(Exception):
    """A package of the `ros` extra is not installed."""


def require(module: str, purpose: str):
    """Import `module` or raise MissingDependency naming the extra that installs it."""
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as error:
        if error.name and module.startswith(error.name.split(".")[0]):
            raise MissingDependency(
                f"{purpose} needs the Python package {module.split('.')[0]!r}: "
                f"pip install 'retalisc[ros]'") from None
        raise
