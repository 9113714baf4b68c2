"""``python -m sklearn_hybrid``: the ``sklearn-hybrid`` command line (:func:`sklearn_hybrid.cli.main`).

For an environment where the console script is not on ``PATH`` (or not installed, as in a source
checkout on ``PYTHONPATH``); the arguments, the help and the exit status are the console script's.
"""

import sys

from .cli import main

if __name__ == "__main__":
    sys.exit(main())
