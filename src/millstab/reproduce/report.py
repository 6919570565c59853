"""A small report builder: headings, paragraphs, tables and figures, rendered as Markdown and as a
self-contained HTML page (figures embedded), with every table also saved as CSV and every figure as
PNG next to it. Headline rows are collected for a summary: claims (our value, holds or not) and
comparisons (our value beside the paper's, with the ratio, no verdict).
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from millstab.io.results import atomic_write_text, ensure_folder, write_csv


#: kinds of headline rows: a claim that holds or not, or a value set beside the paper's with no verdict
KINDS = ("claim", "comparison")


@dataclass(frozen=True)
class Check:
    """One headline row: what is claimed (or compared), what we measured, and whether it holds.

    ``kind="comparison"`` rows put a value of ours beside the paper's; they have no pass/fail
    criterion (``ok`` is always True) and their verdict reads "compared", never "holds".
    """

    claim: str
    measured: str
    ok: bool
    kind: str = "claim"

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, not {self.kind!r}")

    @property
    def verdict(self) -> str:
        """What the summary table says: "holds", "DOES NOT HOLD" or "compared"."""
        if self.kind == "comparison":
            return "compared"
        return "holds" if self.ok else "DOES NOT HOLD"


def fmt(x: Any, digits: int = 5) -> str:
    """A number for a table: 5 significant digits (the paper prints e.g. 4103.4 Hz, 556.31 MPa),
    ints as ints, strings unchanged."""
    if isinstance(x, str):
        return x
    if isinstance(x, (bool, np.bool_)):  # numpy comparisons give np.bool_, which float() would print as 1
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if v != v:
        return "–"
    if v == 0:
        return "0"
    if abs(v) >= 1e5 or abs(v) < 1e-3:
        return f"{v:.3g}" if 1e-4 <= abs(v) < 1e-3 else f"{v:.2e}"
    return f"{v:.{digits}g}"


def comparison(what: str, ours: float, paper: float) -> Check:
    """A headline row setting a value of ours beside the paper's, with their ratio; no verdict ("compared")."""
    return Check(what, f"ours {fmt(ours, 3)}, paper {fmt(paper, 3)}: ours/paper = {ours / paper:.2f}", True,
                 "comparison")


#: what the verdicts of the summary table mean
SUMMARY_NOTE = ("A claim has a stated criterion, tested in this run: it holds or it does not. 'compared' sets one of "
                "our values beside the paper's, with their ratio: no criterion, no verdict.")


@dataclass
class ReportWriter:
    """The builder of a :class:`Report`: the steps add headings, paragraphs, tables, figures and headline rows
    as they run, each table and figure saved into ``out`` when added (a long run that stops keeps what it
    made); :meth:`report` gives the frozen report, :meth:`write` writes report.md and report.html and returns it.
    """

    out: Path
    title: str
    blocks: list[tuple[str, Any]] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.out = ensure_folder(self.out)

    def heading(self, text: str, level: int = 2) -> None:
        self.blocks.append(("h", (level, text)))

    def paragraph(self, text: str) -> None:
        self.blocks.append(("p", text))

    def table(self, name: str, header: Sequence[str], rows: Sequence[Sequence[Any]], caption: str) -> Path:
        """Add a table and save it as ``name.csv`` (raw values; the report shows rounded ones)."""
        path = self.out / f"{name}.csv"
        cols = [[r[i] for r in rows] for i in range(len(header))]
        write_csv(path, list(header), cols)
        self.files.append(path)
        self.blocks.append(("t", (caption, tuple(header), tuple(tuple(fmt(v) for v in r) for r in rows), path.name)))
        return path

    def figure(self, name: str, fig, caption: str) -> Path:
        """Add a figure and save it as ``name.png``.

        The caption is the figure's title in the report, so a figure-level title (the suptitle, or the
        title of a one-panel figure) is removed rather than said twice; panel titles stay.
        """
        from millstab.io.figures import save_figure

        if fig.get_suptitle():
            fig.suptitle("")
        if len(fig.axes) == 1:
            fig.axes[0].set_title("")
        path = save_figure(fig, self.out / f"{name}.png")
        self.files.append(path)
        self.blocks.append(("f", (caption, path)))
        return path

    def add(self, check: Check) -> Check:
        """Add a headline row made elsewhere (a step's checks computed from its result)."""
        self.checks.append(check)
        return check

    def check(self, claim: str, measured: str, ok: bool) -> Check:
        """A claim with a pass/fail criterion (``ok``)."""
        return self.add(Check(claim, measured, bool(ok)))

    def compare(self, what: str, ours: float, paper: float) -> Check:
        """A value of ours beside the paper's, with their ratio; no verdict (it reads "compared")."""
        return self.add(comparison(what, ours, paper))

    def report(self) -> Report:
        """The report as added so far, frozen."""
        return Report(self.out, self.title, tuple(self.blocks), tuple(self.checks), tuple(self.files))

    def write(self) -> Report:
        """Write report.md and report.html (:meth:`Report.write`); returns the frozen report."""
        rep = self.report()
        rep.write()
        return rep


@dataclass(frozen=True)
class Report:
    """A finished report (:meth:`ReportWriter.report`): its folder, title, blocks (kind, content), headline rows
    ``checks`` and the files saved; :meth:`markdown`/:meth:`html` render it, :meth:`write` writes report.md and
    report.html. Frozen, its sequences tuples (issue 26): what ``millstab reproduce`` prints and exits by."""

    out: Path
    title: str
    blocks: tuple[tuple[str, Any], ...] = ()
    checks: tuple[Check, ...] = ()
    files: tuple[Path, ...] = ()

    # --- rendering --------------------------------------------------------------------------------
    def _summary_rows(self) -> list[list[str]]:
        return [[c.claim, c.measured, c.verdict] for c in self.checks]

    def markdown(self) -> str:
        lines = [f"# {self.title}", ""]
        if self.checks:
            lines += ["## Headline claims and comparisons", "", SUMMARY_NOTE, "",
                      "| claim or comparison | ours | verdict |", "|---|---|---|"]
            lines += [f"| {a} | {b} | {c} |" for a, b, c in self._summary_rows()] + [""]
        for kind, val in self.blocks:
            if kind == "h":
                lines += ["#" * val[0] + " " + val[1], ""]
            elif kind == "p":
                lines += [val, ""]
            elif kind == "t":
                caption, header, rows, csv_name = val
                lines += [f"**{caption}** ([{csv_name}]({csv_name}))", "", "| " + " | ".join(header) + " |",
                          "|" + "---|" * len(header)]
                lines += ["| " + " | ".join(r) + " |" for r in rows] + [""]
            elif kind == "f":
                caption, path = val  # alt text: the file's name, so the caption is not printed twice
                lines += [f"![{path.stem}]({path.name})", "", f"*{caption}*", ""]
        return "\n".join(lines)

    def html(self) -> str:
        esc = html.escape
        parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(self.title)}</title>",
                 "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;line-height:1.45}"
                 "table{border-collapse:collapse;margin:.5em 0 1.5em}td,th{border:1px solid #bbb;padding:3px 8px;"
                 "text-align:right}th{background:#eee}td:first-child{text-align:left}img{max-width:100%}"
                 ".bad{color:#b00;font-weight:bold}.ok{color:#070}.cmp{color:#555}figcaption{font-style:italic}"
                 "</style></head><body>",
                 f"<h1>{esc(self.title)}</h1>"]
        if self.checks:
            parts.append(f"<h2>Headline claims and comparisons</h2><p>{esc(SUMMARY_NOTE)}</p><table><tr>"
                         "<th>claim or comparison</th><th>ours</th><th>verdict</th></tr>")
            for c in self.checks:
                cls = {"holds": "ok", "compared": "cmp"}.get(c.verdict, "bad")
                parts.append(f"<tr><td>{esc(c.claim)}</td><td>{esc(c.measured)}</td>"
                             f"<td class='{cls}'>{esc(c.verdict)}</td></tr>")
            parts.append("</table>")
        for kind, val in self.blocks:
            if kind == "h":
                parts.append(f"<h{val[0]}>{esc(val[1])}</h{val[0]}>")
            elif kind == "p":
                parts.append(f"<p>{esc(val)}</p>")
            elif kind == "t":
                caption, header, rows, csv_name = val
                parts.append(f"<p><b>{esc(caption)}</b> ({esc(csv_name)})</p><table><tr>"
                             + "".join(f"<th>{esc(h)}</th>" for h in header) + "</tr>")
                parts += ["<tr>" + "".join(f"<td>{esc(v)}</td>" for v in r) + "</tr>" for r in rows]
                parts.append("</table>")
            elif kind == "f":
                caption, path = val
                data = base64.b64encode(path.read_bytes()).decode()
                parts.append(f"<figure><img src='data:image/png;base64,{data}' alt='{esc(caption)}'>"
                             f"<figcaption>{esc(caption)}</figcaption></figure>")
        parts.append("</body></html>")
        return "\n".join(parts)

    def write(self) -> tuple[Path, Path]:
        """Write report.md and report.html; returns their paths."""
        md = atomic_write_text(self.out / "report.md", self.markdown())
        ht = atomic_write_text(self.out / "report.html", self.html())
        return md, ht
