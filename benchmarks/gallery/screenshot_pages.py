"""Screenshots of the built documentation at 1,280 px wide: what a reader sees on the pages a change touched.

Renders each page of a built HTML documentation (``sphinx-build -b html doc doc/_build/html``) to a JPEG,
1,280 px wide and as tall as the page, with ``wkhtmltoimage`` (Debian: ``apt-get install wkhtmltopdf``), into
``results/screenshots/``; ``results/screenshots.md`` lists each image with its height, the package commit the
documentation was built at and the machine.

Usage: python benchmarks/gallery/screenshot_pages.py [--html doc/_build/html] [--pages index results ...]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: the helpers
from helpers import RESULTS, write_results  # noqa: E402

PAGES = ("index", "getting_started", "results", "auto_examples/index", "auto_examples/pendulum/plot_pendulum",
         "auto_examples/getting_started/plot_quick_start", "user_guide/closed_loop", "user_guide/identifiability")
WIDTH = 1280


def shoot(html: Path, page: str, out: Path) -> int:
    """Render ``html/<page>.html`` to ``out`` (JPEG); returns the image's height in pixels."""
    from PIL import Image

    source = html / f"{page}.html"
    if not source.exists():
        raise FileNotFoundError(f"{source} does not exist: build the documentation first "
                                "(sphinx-build -b html doc doc/_build/html).")
    # local files: the page's stylesheets and images are files beside it
    subprocess.run(["wkhtmltoimage", "--quiet", "--enable-local-file-access", "--width", str(WIDTH),
                    "--format", "jpg", "--quality", "30", str(source), str(out)], check=False,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if not out.exists():
        raise RuntimeError(f"wkhtmltoimage made no image of {source}.")
    with Image.open(out) as image:
        return image.size[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--html", type=Path, default=Path("doc/_build/html"))
    parser.add_argument("--pages", nargs="*", default=list(PAGES))
    args = parser.parse_args()
    if shutil.which("wkhtmltoimage") is None:
        raise SystemExit("wkhtmltoimage is not installed (Debian: apt-get install wkhtmltopdf).")
    folder = RESULTS / "screenshots"
    folder.mkdir(exist_ok=True)
    rows = []
    for page in args.pages:
        out = folder / (page.replace("/", "__") + ".jpg")
        height = shoot(args.html, page, out)
        rows.append({"page": page, "image": f"screenshots/{out.name}", "height_px": height})
        print(f"{page}: {out} ({WIDTH} x {height} px)", flush=True)
    lines = ["# Screenshots of the built documentation", "",
             f"Each page of the documentation built from this commit, rendered {WIDTH} px wide as a reader sees "
             "it (`results/screenshots/`).", "", "| page | image | height (px) |", "|---|---|---|"]
    lines += [f"| {r['page']} | `{r['image']}` | {r['height_px']} |" for r in rows]
    write_results("screenshots", {"width_px": WIDTH, "pages": rows}, "\n".join(lines))


if __name__ == "__main__":
    main()
