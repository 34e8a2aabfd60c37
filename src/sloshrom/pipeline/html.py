"""Self-contained HTML report: figures embedded as base64 PNG, no external resources."""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from sloshrom.pipeline.cache import atomic_write_text


@dataclass
class Figure:
    """A figure of the report: a PNG file and its caption (``data``: the PNG's bytes, when
    the file is not written yet)."""
    path: Path
    caption: str
    data: bytes | None = None


class Markup(str):
    """A table cell written by the pipeline as HTML (not escaped): a verdict in bold, say."""


@dataclass
class Table:
    """A table of the report: header, rows and caption."""
    header: Sequence[str]
    rows: Sequence[Sequence[object]]
    caption: str = ""


@dataclass
class Section:
    """A section of the report: title, text (HTML), figures and tables."""
    title: str
    text: str = ""
    figures: list[Figure] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)


_CSS = """
body{font-family:system-ui,Segoe UI,Roboto,sans-serif;max-width:1100px;margin:2em auto;
padding:0 1em;color:#222;line-height:1.45}
h1{border-bottom:2px solid #345}h2{margin-top:2em;border-bottom:1px solid #ccc}
figure{margin:1.2em 0}figure img{max-width:100%;border:1px solid #ddd}
figcaption{font-size:.92em;color:#444}
table{border-collapse:collapse;margin:1em 0;font-size:.92em}
td,th{border:1px solid #bbb;padding:.25em .6em;text-align:left;vertical-align:top}
th{background:#eef}td.num{text-align:right}.miss{color:#b00020}
.note{background:#fff8e0;border-left:4px solid #e0b000;padding:.5em 1em}
code{background:#f3f3f3;padding:0 .2em}
"""


def _fmt(v: object) -> str:
    if isinstance(v, Markup):
        return str(v)
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


#: A cell that reads as a number (a figure, with its unit or interval after it): aligned right.
_NUMBER = re.compile(r"^[−+\-]?(\d|\.\d)")


def _cell(v: object) -> str:
    num = isinstance(v, int | float) and not isinstance(v, bool) or (
        isinstance(v, str) and not isinstance(v, Markup) and _NUMBER.match(v) is not None)
    return f"<td class='num'>{_fmt(v)}</td>" if num else f"<td>{_fmt(v)}</td>"


def render_table(t: Table) -> str:
    """The HTML ``<table>`` of ``t`` (cells escaped, but :class:`Markup`; numbers aligned
    right, text left)."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in t.header)
    body = "".join("<tr>" + "".join(_cell(c) for c in r) + "</tr>" for r in t.rows)
    cap = f"<caption>{html.escape(t.caption)}</caption>" if t.caption else ""
    return f"<table>{cap}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def render(title: str, intro: str, sections: Sequence[Section]) -> str:
    """The whole page as a string. ``text`` fields are trusted HTML written by the pipeline."""
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>{intro}",
    ]
    for s in sections:
        parts.append(f"<h2>{html.escape(s.title)}</h2>{s.text}")
        for t in s.tables:
            parts.append(render_table(t))
        for f in s.figures:
            png = f.data if f.data is not None else Path(f.path).read_bytes()
            data = base64.b64encode(png).decode("ascii")
            parts.append(
                f"<figure><img alt='{html.escape(Path(f.path).stem)}' "
                f"src='data:image/png;base64,{data}'><figcaption>{f.caption}</figcaption></figure>"
            )
    parts.append("</body></html>")
    return "".join(parts)


def write(path: str | Path, title: str, intro: str, sections: Sequence[Section]) -> Path:
    """Write the report page to ``path`` atomically; the path written."""
    p = Path(path)
    atomic_write_text(p, render(title, intro, sections))
    return p
