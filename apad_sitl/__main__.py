"""`python -m apad_sitl`: the same as `vil sitl`."""

from __future__ import annotations

import argparse
import sys

from apad_sitl.serve import add_arguments, run


def main() -> int:
    parser = argparse.ArgumentParser(
        prog="python -m apad_sitl", description="Run the SITL kinematic aPad as a MAVLink vehicle in real time."
    )
    add_arguments(parser)
    return run(parser.parse_args())


if __name__ == "__main__":
    sys.exit(main())
