"""Render the committed benchmark results (``benchmarks/results/*.md``) as reStructuredText pages.

The documentation build calls :func:`render_all` from ``conf.py``: each results file becomes
``doc/results/<name>.rst``, so the results page shows what the benchmark scripts wrote,
never a copy that could drift.  The Markdown is the small subset those scripts write: headings,
paragraphs, bullet lists, pipe tables, fenced code and images.  Text is escaped for reST, so that
a ``|`` or a trailing ``_`` in a formula never turns into markup; inline code and bold survive.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
OUT = Path(__file__).resolve().parent / "results"  # generated, ignored by git
UNDERLINES = {1: "=", 2: "-", 3: "~", 4: "^"}
CODE = re.compile(r"(`+)(.+?)\1")
BOLD = re.compile(r"\\\*\\\*(\S(?:.*?\S)?)\\\*\\\*")
ITALIC = re.compile(r"(?<![\w\\])\\\*(\w(?:[^*]*?\w)?)\\\*(?!\w)")
LINK = re.compile(r"!?\[([^\]]*)\]\(([^)]*)\)")


def inline(text: str) -> str:
    """Markdown inline text to reST: code spans kept as literals, bold kept, everything else escaped."""
    text = text.replace("\\|", "|")  # Markdown's escaped pipe inside a table cell
    text = LINK.sub(lambda m: m.group(1) or m.group(2), text)
    out, last = "", 0
    for m in CODE.finditer(text):
        before = _escape(text[last:m.start()])
        code = m.group(2).strip()
        # reST ends a literal only before a space or punctuation: an escaped space joins it to a word
        glue = "\\ " if re.search(r"[\w)\]]$", out + before) else ""
        out += before + (glue + f"``{code}``" if code else "")
        last = m.end()
        if code and re.match(r"[\w(\[]", text[last:last + 1]):
            out += "\\ "
    return out + _escape(text[last:])


def _escape(text: str) -> str:
    text = re.sub(r"([\\*`|_<>\[\]])", r"\\\1", text)
    return ITALIC.sub(r"*\1*", BOLD.sub(r"**\1**", text))


def _table(rows: list[list[str]]) -> list[str]:
    width = max(len(r) for r in rows)
    out = [".. list-table::", "   :header-rows: 1", "   :class: results-table", ""]  # scrolls when wide (wrap.css)
    for row in rows:
        row = row + [""] * (width - len(row))
        out.append("   * - " + (inline(row[0]) or "\\ "))
        out += ["     - " + (inline(cell) or "\\ ") for cell in row[1:]]
    return out + [""]


def _cells(line: str) -> list[str]:
    line = line.strip().strip("|")
    return [c.strip() for c in re.split(r"(?<!\\)\|", line)]


def convert(markdown: str, images: Path | None = None) -> str:
    """reST for one Markdown results file (its first heading becomes the page title)."""
    lines = markdown.splitlines()
    out: list[str] = []
    i, top = 0, None
    while i < len(lines):
        line = lines[i]
        heading = re.match(r"^(#{1,4})\s+(.*)", line)
        if heading:
            level = len(heading.group(1))
            top = level if top is None else top
            title = inline(heading.group(2).strip())
            out += ["", title, UNDERLINES[min(level - top + 1, 4)] * max(len(title), 4), ""]
            i += 1
        elif line.startswith("```"):
            block, i = [], i + 1
            while i < len(lines) and not lines[i].startswith("```"):
                block.append(lines[i])
                i += 1
            out += ["", ".. code-block:: text", ""] + ["    " + b for b in block] + [""]  # printed output
            i += 1
        elif line.lstrip().startswith("|"):
            rows = []
            while i < len(lines) and lines[i].lstrip().startswith("|"):
                if not re.match(r"^\s*\|[\s:|-]+\|\s*$", lines[i]):  # the |---| separator
                    rows.append(_cells(lines[i]))
                i += 1
            out += [""] + _table(rows)
        elif re.match(r"^!\[", line.strip()) and images is not None:
            target = LINK.match(line.strip()).group(2)
            src = RESULTS / target
            if src.is_file():
                shutil.copy(src, images / src.name)
                out += ["", f".. image:: {src.name}", "   :width: 100%", ""]
            i += 1
        elif re.match(r"^\s*([-*]|\d+\.) ", line):
            out.append("")
            indent = "  "
            while i < len(lines) and lines[i].strip() and not lines[i].lstrip().startswith("|"):
                item = re.match(r"^\s*([-*]|\d+\.) (.*)", lines[i])
                if item:
                    indent = " " * (len(item.group(1)) + 1)
                    out.append(item.group(1) + " " + inline(item.group(2)))
                else:
                    out.append(indent + inline(lines[i].strip()))
                i += 1
            out.append("")
        elif not line.strip():
            out.append("")
            i += 1
        else:
            out.append(inline(line.strip()))
            i += 1
    text = "\n".join(out).strip() + "\n"
    return re.sub(r"\n{3,}", "\n\n", text)


def render_all(names: list[str]) -> list[str]:
    """Write ``_generated/results/<name>.rst`` for each results file; the names written."""
    OUT.mkdir(parents=True, exist_ok=True)
    written = []
    for name in names:
        src = RESULTS / f"{name}.md"
        if not src.is_file():
            continue
        rst = convert(src.read_text(), images=OUT)
        rst = (f".. This page is generated from benchmarks/results/{name}.md by doc/_results.py.\n\n"
               + rst + f"\n*Source:* ``benchmarks/results/{name}.md``"
               + (" (with its ``.json``).\n" if (RESULTS / f"{name}.json").is_file() else ".\n"))
        (OUT / f"{name}.rst").write_text(rst)
        written.append(name)
    return written


SNIPPETS = Path(__file__).resolve().parent / "_generated" / "snippets"


def _section(markdown: str, heading: str) -> str:
    """The part of a Markdown file under ``## heading``, its own sub-headings made plain bold lines."""
    lines, inside, out = markdown.splitlines(), False, []
    for line in lines:
        if line.startswith("## "):
            inside = line[3:].strip() == heading
            continue
        if inside:
            out.append(re.sub(r"^#{3,} (.*)", r"**\1**", line))
    return "\n".join(out)


def _machine(payload: dict) -> str:
    m = payload.get("machine", {})
    return ", ".join(str(m[k]) for k in ("cpu", "date") if k in m)


def render_snippets() -> list[str]:
    """Committed full-run results for the gallery pages whose examples the build does not run.

    ``_generated/snippets/task_<task>.rst`` (from ``tasks.json``), ``varying_theta.rst`` and
    ``loop_silverbox.rst``; each says where it comes from and that it was not run by the build.
    """
    import json

    SNIPPETS.mkdir(parents=True, exist_ok=True)
    written = []
    tasks = json.loads((RESULTS / "tasks.json").read_text())
    note = (f"*Committed full run* of ``benchmarks/paper/bench_tasks.py`` ({_escape(_machine(tasks))}; "
            "``benchmarks/results/tasks.md``), not run during this documentation build.  theta error: RMSE to "
            "the true theta (light tunnel: cosine similarity, higher is better); best: the best value along "
            "training; y error: test RMSE.")
    for task in dict.fromkeys(r["task"] for r in tasks["rows"]):
        rows = [["method", "data", "n_train", "iterations", "theta", "theta error", "best", "y error"]]
        for r in (r for r in tasks["rows"] if r["task"] == task):
            theta = "; ".join(f"{k}={', '.join(f'{v:.4g}' for v in vals)}" for k, vals in r["theta"].items())
            rows.append([r["method"], r["source"], str(r["n_train"]), str(r["max_iter"]), theta,
                         f"{r['theta_error']:.4g}", f"{r['theta_error_best']:.4g}", f"{r['y_error']:.4g}"])
        (SNIPPETS / f"task_{task}.rst").write_text(note + "\n\n" + "\n".join(_table(rows)) + "\n"
                                                   + _gallery_figures(task))
        written.append(f"task_{task}")
    varying = (RESULTS / "varying_theta.md").read_text()
    table = [line for line in varying.splitlines() if line.startswith("|")]
    if (RESULTS / "varying_theta.png").is_file():
        shutil.copy(RESULTS / "varying_theta.png", SNIPPETS / "varying_theta.png")
    (SNIPPETS / "varying_theta.rst").write_text(
        "*Committed full run* of ``benchmarks/paper/bench_varying_theta.py`` "
        "(``benchmarks/results/varying_theta.md``), "
        "not run during this documentation build:\n\n" + convert("\n".join(table))
        + "\n.. image:: /_generated/snippets/varying_theta.png\n   :width: 100%\n")
    written.append("varying_theta")
    loop = (RESULTS / "closed_loop.md").read_text()
    payload = json.loads((RESULTS / "closed_loop.json").read_text())
    (SNIPPETS / "loop_silverbox.rst").write_text(
        f"*Committed full run* of ``benchmarks/measured/bench_closed_loop.py`` ({_escape(_machine(payload))}; "
        "``benchmarks/results/closed_loop.md``), not run during this documentation build:\n\n"
        + convert(_section(loop, "silverbox")) + _gallery_figures("silverbox_loop"))
    written.append("loop_silverbox")
    return written


def _gallery_figures(example: str) -> str:
    """The figures of a committed full run of a gallery example (``benchmarks/gallery/gallery_figures.py``), as rst.

    Empty where none was committed; otherwise the images (copied beside the snippets) under a line
    that says where and when they were made, as the numbers above them do.
    """
    import json

    path = RESULTS / "gallery.json"
    entry = json.loads(path.read_text())["examples"].get(example) if path.is_file() else None
    if not entry or not entry["figures"]:
        return ""
    out = ["", f"*Figures of a committed full run* of ``{entry['example']}`` ({_escape(entry['cpu'])}, "
               f"{entry['date']}, {entry['seconds']} s; ``benchmarks/gallery/gallery_figures.py``), not run during "
               "this "
               "documentation build:", ""]
    for name in entry["figures"]:
        shutil.copy(RESULTS / "gallery" / name, SNIPPETS / name)
        out += [f".. image:: /_generated/snippets/{name}", "   :width: 100%", ""]
    return "\n".join(out)
