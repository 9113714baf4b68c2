"""Command line: ``sklearn-hybrid loop DATASET`` closes the loop on a named data set; ``demo`` runs the demo.

Examples
--------
::

    sklearn-hybrid loop silverbox            # measured Silverbox, about 10 minutes on 2 cores
    sklearn-hybrid loop pendulum --fast      # synthetic pendulum, seconds (pipeline check only)
    sklearn-hybrid loop tanks --method fsam --max-iter 500 --json tanks.json
    sklearn-hybrid demo
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

__all__ = ["main"]

DATASETS = ("silverbox", "tanks", "pendulum-freeswing", "pendulum", "duffing")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sklearn-hybrid", description="Hybrid models that estimate physics.")
    sub = parser.add_subparsers(dest="command", required=True)
    loop = sub.add_parser("loop", help="fit -> diagnose the residual -> add the missing terms -> refit -> compare")
    loop.add_argument("dataset", choices=DATASETS, help="measured (silverbox, tanks, pendulum-freeswing) "
                                                        "or synthetic (pendulum, duffing)")
    loop.add_argument("--method", default="erm", choices=("erm", "p-reg", "f-reg", "sam", "asam", "fsam"))
    loop.add_argument("--max-iter", type=int, default=None, help="optimisation steps per fit (default per data set)")
    loop.add_argument("--fast", action="store_true", help="tiny data and few iterations: checks the pipeline only")
    loop.add_argument("--seed", type=int, default=0)
    loop.add_argument("--json", default=None, help="also write the before/after table to this JSON file")
    loop.add_argument("--quiet", action="store_true", help="print the table only")
    sub.add_parser("demo", help="run sklearn_hybrid.demo (erm vs Fisher SAM on the pendulum)")
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
    if args.command == "demo":
        from . import demo

        demo.main()
        return 0
    import torch

    from .diagnosis.cases import run_case

    torch.set_num_threads(1)  # small sequential models are fastest on one thread
    out = run_case(args.dataset, fast=args.fast, method=args.method, max_iter=args.max_iter,
                   random_state=args.seed, verbose=not args.quiet)
    print(out.case.description)
    if args.quiet:
        print(out.report)
    print(f"({out.seconds:.0f} s)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"dataset": args.dataset, "method": args.method, "table": out.table,
                       "equations": out.diagnosis.equations(), "seconds": out.seconds}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
