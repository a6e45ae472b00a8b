"""``python -m scripts.report [--out out] [--seed 0] ...``: the same as ``topomap run``."""

import sys

from scripts.cli import main

if __name__ == "__main__":
    sys.exit(main(["run", *sys.argv[1:]]))
