"""Command line: ``sklearn-hybrid loop DATASET`` closes the loop on a named data set; ``demo`` runs the demo.

Examples
--------
::

    sklearn-hybrid loop silverbox            # measured Silverbox, under 2 minutes on 2 cores
    sklearn-hybrid loop pendulum --fast      # synthetic pendulum, seconds (pipeline check only)
    sklearn-hybrid loop tanks --method fsam --max-iter 500 --json tanks.json
    sklearn-hybrid loop silverbox --data-home /path/to/data   # measured files looked up there
    sklearn-hybrid demo
    sklearn-hybrid --version

Only argparse is imported at start: torch and the package load after the
arguments are parsed, so ``--help`` and ``--version`` answer at once.  A
bad argument ends with one line on stderr and exit status 2, a missing data
file with that line and where to put the file and get it (``--traceback``
shows the full error).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

__all__ = ["main"]

# the keys of recipes.CASES, written out so that ``--help`` need not import torch
DATASETS = ("silverbox", "tanks", "pendulum-freeswing", "hare-lynx", "pendulum", "duffing")


def _method_name(name: str) -> str:
    """``--method``, checked against the registry; read when the argument is parsed, so that ``--help``
    needs no torch (the methods import it)."""
    from .methods import METHODS

    if name not in METHODS:
        raise argparse.ArgumentTypeError(f"invalid choice: {name!r} (choose from {', '.join(METHODS)})")
    return name


def _parser() -> argparse.ArgumentParser:
    from . import __version__

    parser = argparse.ArgumentParser(prog="sklearn-hybrid", description="Hybrid models that estimate physics.")
    parser.add_argument("--version", action="version", version=f"sklearn-hybrid {__version__}")
    parser.add_argument("--traceback", action="store_true", help="show the full error instead of one line")
    sub = parser.add_subparsers(dest="command", required=True)
    loop = sub.add_parser("loop", help="fit -> diagnose the residual -> add the missing terms -> refit -> compare")
    loop.add_argument("dataset", choices=DATASETS, help="measured (silverbox, tanks, pendulum-freeswing, "
                                                        "hare-lynx) or synthetic (pendulum, duffing)")
    loop.add_argument("--method", default="erm", type=_method_name,
                      help="training method, a name of sklearn_hybrid.methods.METHODS (default: erm)")
    loop.add_argument("--max-iter", type=int, default=None, help="optimisation steps per fit (default per data set)")
    loop.add_argument("--fast", action="store_true", help="tiny data and few iterations: checks the pipeline only")
    loop.add_argument("--seed", type=int, default=0)
    loop.add_argument("--json", default=None, help="also write the before/after table to this JSON file")
    loop.add_argument("--n-jobs", type=int, default=2,
                      help="processes; with 2 (default) a second one scores the models on the test records "
                           "while the first selects terms and refits (1: one process)")
    loop.add_argument("--quiet", action="store_true", help="print the table only (no progress bars)")
    loop.add_argument("--data-home", default=None,
                      help="folder of the measured data (default: $SKLEARN_HYBRID_DATA, else ../shared/data beside "
                           "a source checkout when it exists, as for the tests and the docs, else "
                           "~/sklearn_hybrid_data)")
    sub.add_parser("demo", help="run sklearn_hybrid.demo (the README's Quick start: the pendulum fit and its verdict)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``sklearn-hybrid`` console script.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status, 0 on success.
    """
    args = _parser().parse_args(argv)
    try:
        return _run(args)
    except (FileNotFoundError, ValueError, OSError) as exc:
        if args.traceback:
            raise
        lines = str(exc).strip().splitlines() or [type(exc).__name__]
        first, rest = lines[0].rstrip(":"), []
        if isinstance(exc, FileNotFoundError):
            from .datasets import get_data_home

            first += (f" (data home: {get_data_home(getattr(args, 'data_home', None)).resolve()}; "
                      "pass --data-home DIR or set SKLEARN_HYBRID_DATA)")
            # a missing data file: where to put it and where to get it are the answer, not details
            rest = [line for line in lines[1:] if "Traceback" not in line]
        print("\n".join([f"sklearn-hybrid: error: {first}", *rest]), file=sys.stderr)
        return 2


def _run(args) -> int:
    if args.command == "demo":
        from . import demo

        demo.main()
        return 0
    import torch

    from .recipes import run_case

    torch.set_num_threads(1)  # small sequential models are fastest on one thread
    options = {} if args.data_home is None or args.dataset in ("pendulum", "duffing") else \
        {"data_home": args.data_home}
    out = run_case(args.dataset, fast=args.fast, method=args.method, max_iter=args.max_iter,
                   random_state=args.seed, verbose=not args.quiet, progress=not args.quiet,
                   n_jobs=args.n_jobs, **options)
    print(out.case.description)
    if args.quiet:
        print(out.report)
    print(f"({out.seconds:.0f} s)")
    if args.json:
        with open(args.json, "w") as fh:
            added = [{k: t[k] for k in ("output", "term", "kind", "coef", "param")} for t in out.added]
            json.dump({"dataset": args.dataset, "method": args.method, "table": out.table, "added": added,
                       "seconds": out.seconds}, fh, indent=2, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
