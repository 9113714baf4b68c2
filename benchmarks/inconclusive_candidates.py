"""Which identification records stopped on a candidate the held-out test could not settle?

Each record of ``bench_identification.py`` ends with a selection step in which no candidate passed. A
candidate that lowered the held-out error by at least ``min_gain`` (5 %) with z above 2 but under the threshold
(3.85 standard errors for the 12 validation trajectories of the protocol) was neither supported nor ruled out:
more validation samples (``close_the_loop(cv=...)``, every trajectory judging) could accept it. This script lists
those records from their stored reports, so that a change towards more validation samples knows which records
it can change and which failures it might turn. The committed ``results/inconclusive_candidates.md`` was made from
the records before the second look (``close_the_loop(second_look=4)``, since 40847dc), and lists the 31 records
that were run again with it; run now, the script lists the records that still end on such a candidate.

    python benchmarks/inconclusive_candidates.py    # writes results/inconclusive_candidates.md
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_identification as bench  # noqa: E402
from _common import RESULTS  # noqa: E402

from sklearn_hybrid.diagnosis.stepwise import _SECOND_LOOK_Z as MIN_Z  # noqa: E402
from sklearn_hybrid.diagnosis.stepwise import _promising  # noqa: E402

MIN_GAIN = 0.05  # close_the_loop's min_gain, as the benchmark runs it


def _rows(report: str) -> list[list[str]]:
    """The selection table's rows as cells (an escaped ``\\|`` inside a term is not a separator)."""
    return [[c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            for line in report.splitlines() if re.match(r"\| \d+ \|", line)]


def inconclusive(record: dict) -> list[tuple[str, float, float]]:
    """(term, gain, z) of each candidate of the last step with gain >= MIN_GAIN and MIN_Z < z < its threshold."""
    threshold = re.search(r"by more than ([\d.]+) standard errors", record["report"])
    rows = _rows(record["report"])
    if not rows or threshold is None:
        return []
    last = max(int(row[0]) for row in rows)
    out = []
    for row in rows:
        step, term, gain, z, accepted = int(row[0]), row[2], row[-3], row[-2], row[-1]
        if step != last or accepted != "no" or not gain.endswith("%"):
            continue
        gain, z = float(gain.rstrip("%")) / 100, float(z)
        if _promising({"gain": gain, "z": z}, MIN_GAIN) and z < float(threshold.group(1)):
            out.append((term.replace("\\|", "|"), gain, z))
    return out


def main() -> None:
    records = bench.load(fast=False)
    hits = [(r, inconclusive(r)) for r in records]
    hits = [(r, c) for r, c in hits if c]
    failed = [r for r, _ in hits if r.get("identified") is False]
    failed_names = ", ".join(f"`{r['system']}` {r['noise']:g}" for r in failed)
    md = ["# Records whose last selection step held an inconclusive candidate", "",
          f"Of the {len(records)} records of `results/identification.md`, {len(hits)} end on a step where a candidate "
          f"lowered the held-out error by at least {MIN_GAIN:.0%} with z above {MIN_Z:g} but under the threshold; "
          f"{len(failed)} of them are failures of the benchmark ({failed_names}). "
          "A rule that judges such a candidate again on more validation samples (and only such a candidate: z "
          f"above {MIN_Z:g}) could change these records and no other: every earlier step accepted a term, so the "
          "rule would not have been asked there.", "",
          "| system | noise | score | identified | candidates (gain, z) |", "|---|---|---|---|---|"]
    for r, cands in hits:
        score = r.get("rel_err") if r.get("rel_err") is not None else r.get("control_err")
        md.append(f"| {r['system']} | {r['noise']:g} | {score:.3f} | {r.get('identified', 'control')} | "
                  + "; ".join(f"{t.replace('|', chr(92) + '|')} ({g:.0%}, {z:.1f})" for t, g, z in cands) + " |")
    md += ["", "Command: `python benchmarks/inconclusive_candidates.py` (reads the stored records only)."]
    (RESULTS / "inconclusive_candidates.md").write_text("\n".join(md) + "\n")
    print(f"{len(hits)} of {len(records)} records; {len(failed)} failures")


if __name__ == "__main__":
    main()
