"""One report model, two emitters: the report is a list of blocks (headings, paragraphs, tables, figures), built
once (:mod:`xcheck.report.render`) and written as Markdown (:func:`to_markdown`) and as HTML
(:func:`to_html`). Both emit every block, so the two cannot drift apart.

Cells and badges carry a verdict class (``pass``, ``fail``, ``expected``, ``inconclusive``, ``info``): a colour in HTML, a mark in
Markdown. Inline text is a string or a list of spans ``(text, style)`` with style ``None``, ``"b"``, ``"i"``,
``"code"`` or ``"mark"`` (the text is a verdict class: an emoji in Markdown, a coloured chip in HTML).
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["Heading", "Para", "Verdict", "Cell", "Table", "Figure", "Contents", "to_markdown", "to_html"]


@dataclass
class Heading:
    level: int
    text: str
    anchor: str | None = None
    badge: tuple[str, str] | None = None  # (text, verdict class)


@dataclass
class Para:
    spans: object  # str or [(text, style)]
    small: bool = False


@dataclass
class Verdict:
    """The verdict of the whole report: a badge."""

    text: str
    cls: str


@dataclass
class Cell:
    text: str = ""
    cls: str = ""  # verdict class, or "" for none
    title: str = ""  # a tooltip in HTML (e.g. why a run failed)
    num: bool = False
    link: str | None = None  # an anchor in the same document


@dataclass
class Table:
    header: list
    rows: list = field(default_factory=list)  # lists of Cell (or str)
    #: a long table folded under this summary in HTML (``<details>``), unfolded when a row fails; None: shown
    fold: str | None = None
    header_links: list | None = None  # per header cell, an anchor in the same document (or None)
    compact: bool = False  # one line a cell (the front matrix)


@dataclass
class Contents:
    """Links to the document's sections: ``[(text, anchor, verdict class or "")]``."""

    entries: list


@dataclass
class Figure:
    file: str  # in plots/
    caption: str


_MARK = {"pass": "✅", "fail": "❌", "expected": "⚠️", "inconclusive": "❔", "info": "ℹ️"}


def _spans(spans):
    return [(spans, None)] if isinstance(spans, str) else list(spans)


def _cell(c):
    return c if isinstance(c, Cell) else Cell(str(c))


# ------------------------------------------------------------------------------------------------
def to_markdown(blocks) -> str:
    out = []
    for b in blocks:
        if isinstance(b, Heading):
            badge = f" — {_MARK.get(b.badge[1], '')} {b.badge[0]}" if b.badge else ""
            out += ["#" * b.level + " " + b.text + badge, ""]
        elif isinstance(b, Para):
            style = {None: "{}", "b": "**{}**", "i": "*{}*", "code": "`{}`"}
            text = "".join(_MARK[t] if s == "mark" else style[s].format(t) if t else "" for t, s in _spans(b.spans))
            out += [text, ""]
        elif isinstance(b, Verdict):
            out += [f"{_MARK.get(b.cls, '')} **{b.text}**".strip(), ""]
        elif isinstance(b, Table):
            links = b.header_links or [None] * len(b.header)
            heads = [h.replace("|", "\\|") for h in b.header]  # a header's bar ("|L|") would split its cell
            out.append("| " + " | ".join(f"[{h}](#{a})" if a else h for h, a in zip(heads, links)) + " |")
            out.append("|" + "---|" * len(b.header))
            for row in b.rows:
                cells = []
                for c in map(_cell, row):
                    text = c.text.replace("|", "\\|").replace("\n", " ")
                    text = f"[{text}](#{c.link})" if c.link else text
                    cells.append(f"{_MARK[c.cls]} {text}".strip() if c.cls in _MARK else text)
                out.append("| " + " | ".join(cells) + " |")
            out.append("")
        elif isinstance(b, Figure):
            out += [f"![{b.caption}](plots/{b.file})", "", f"*{b.caption}*", ""]
        elif isinstance(b, Contents):
            out += [f"- {_MARK.get(cls, '')} [{text}](#{anchor})".replace("-  [", "- [") for text, anchor, cls
                    in b.entries] + [""]
        else:
            raise TypeError(f"not a report block: {b!r}")
    return "\n".join(out).rstrip() + "\n"


# ------------------------------------------------------------------------------------------------
_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em auto;max-width:1200px;
color:#222;line-height:1.4;padding:0 1em}
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ddd;padding-bottom:.2em}
table{border-collapse:collapse;margin:1em 0;font-size:.85em}
th,td{border:1px solid #ddd;padding:.25em .5em;text-align:left;vertical-align:top}
th{background:#f4f4f4}td.num{text-align:right;font-family:ui-monospace,Menlo,Consolas,monospace}
td.pass{background:#dff5e1}td.fail{background:#fbdada}td.expected{background:#fff0c8}td.info{background:#eef}
td.inconclusive{background:#e6e0f5}
.verdict{font-size:1.2em;padding:.5em 1em;display:inline-block;border-radius:4px}
.verdict.pass{background:#dff5e1}.verdict.fail{background:#fbdada}.verdict.expected{background:#fff0c8}
.verdict.inconclusive{background:#e6e0f5}
figure{margin:1em 0}figure img{max-width:100%}figcaption{font-size:.85em;color:#555}
.small{font-size:.85em;color:#555}
.chip{display:inline-block;width:.9em;height:.9em;border:1px solid #bbb;vertical-align:middle;margin:0 .15em}
.chip.pass{background:#dff5e1}.chip.fail{background:#fbdada}.chip.expected{background:#fff0c8}.chip.info{background:#eef}
.chip.inconclusive{background:#e6e0f5}
.scroll{overflow-x:auto;max-width:100%}.scroll table{margin:.5em 0}table.compact{font-size:.74em;line-height:1.2}table.compact td{white-space:nowrap;padding:0 .35em}
details{margin:1em 0}summary{cursor:pointer;font-size:.9em}
nav.contents ul{columns:3;list-style:none;padding-left:0;font-size:.9em}nav.contents li{margin:.1em 0}
"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _chip(cls: str) -> str:
    return f"<span class='chip {_e(cls)}'></span>" if cls else ""


def to_html(blocks, plot_dir: Path, *, title: str) -> str:
    """HTML beside its figures: each ``<img>`` links its PNG in ``plot_dir``, a folder next to the page."""
    parts = ["<!DOCTYPE html>", "<html lang='en'><head><meta charset='utf-8'>", f"<title>{_e(title)}</title>",
             f"<style>{_CSS}</style></head><body>"]
    for b in blocks:
        if isinstance(b, Heading):
            anchor = f" id='{_e(b.anchor)}'" if b.anchor else ""
            badge = f" — <span class='verdict {_e(b.badge[1])}'>{_e(b.badge[0])}</span>" if b.badge else ""
            parts.append(f"<h{b.level}{anchor}>{_e(b.text)}{badge}</h{b.level}>")
        elif isinstance(b, Para):
            tags = {None: "{}", "b": "<b>{}</b>", "i": "<i>{}</i>", "code": "<code>{}</code>",
                    "mark": "<span class='chip {}'></span>"}
            text = "".join(tags[s].format(_e(t)) for t, s in _spans(b.spans))
            parts.append(f"<p class='small'>{text}</p>" if b.small else f"<p>{text}</p>")
        elif isinstance(b, Verdict):
            parts.append(f"<p class='verdict {_e(b.cls)}'>{_e(b.text)}</p>")
        elif isinstance(b, Table):
            if b.fold is not None:  # folded, unless a row failed or could not decide
                failed = any(_cell(c).cls in ("fail", "inconclusive") for row in b.rows for c in row)
                parts.append(f"<details{' open' if failed else ''}><summary>{_e(b.fold)}</summary>")
            links = b.header_links or [None] * len(b.header)
            heads = "".join(f"<th><a href='#{_e(a)}'>{_e(h)}</a></th>" if a else f"<th>{_e(h)}</th>"
                            for h, a in zip(b.header, links))
            parts.append(f"<div class='scroll'><table{' class=compact' if b.compact else ''}><tr>{heads}</tr>")
            for row in b.rows:
                cells = []
                for c in map(_cell, row):
                    cls = " ".join(x for x in (c.cls, "num" if c.num else "") if x)
                    attrs = (f" class='{cls}'" if cls else "") + (f" title='{_e(c.title)}'" if c.title else "")
                    text = f"<a href='#{_e(c.link)}'>{_e(c.text)}</a>" if c.link else _e(c.text)
                    cells.append(f"<td{attrs}>{text}</td>")
                parts.append("<tr>" + "".join(cells) + "</tr>")
            parts.append("</table></div>" + ("</details>" if b.fold is not None else ""))
        elif isinstance(b, Contents):
            parts.append("<nav class='contents'><b>Contents</b><ul>" + "".join(
                f"<li>{_chip(cls)}<a href='#{_e(anchor)}'>{_e(text)}</a></li>" for text, anchor, cls in b.entries)
                + "</ul></nav>")
        elif isinstance(b, Figure):  # the folder's own PNG, beside the page (embedded, every image was there twice)
            if not (Path(plot_dir) / b.file).is_file():
                raise FileNotFoundError(f"{Path(plot_dir) / b.file}: a figure of the report is missing")
            src = f"{Path(plot_dir).name}/{b.file}"
            parts.append(f"<figure><img alt='{_e(b.caption)}' src='{_e(src)}'>"
                         f"<figcaption>{_e(b.caption)}</figcaption></figure>")
        else:
            raise TypeError(f"not a report block: {b!r}")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


