"""``python -m hopmatch.cli``: the ``hopmatch`` command."""

import sys

from . import main

if __name__ == "__main__":
    sys.exit(main())
