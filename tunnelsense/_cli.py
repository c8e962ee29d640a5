"""The ``tunnelsense`` command lives in :mod:`tunnelsense.cli`."""

import sys

from tunnelsense.cli import main

__all__ = ["main"]

if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
