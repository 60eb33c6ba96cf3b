"""``python -m symrl COMMAND ...``: the same command line as the ``symrl`` script."""

import sys

from symrl.cli import main

if __name__ == "__main__":
    sys.exit(main())
