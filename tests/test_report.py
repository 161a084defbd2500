"""The report model and its two emitters: Markdown and HTML are written from one list of blocks, so they show
the same tables (same headers, same rows) and the same figures, in the same order; text is escaped for each."""

import re
from html.parser import HTMLParser

import pytest

from xcheck.report.document import (
    Cell,
    Figure,
    Heading,
    Para,
    Table,
    Verdict,
    to_html,
    to_markdown,
)
from xcheck.report.render import write_report
from xcheck.scenario import resolve_scenario
from xcheck.study import run_study


class _Tables(HTMLParser):
    """Headers and row counts of every table, and every figure's caption, in document order."""

    def __init__(self):
        super().__init__()
        self.tables, self.figures, self._cell, self._in = [], [], None, None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append({"header": [], "rows": 0})
        elif tag == "tr" and self.tables:
            self.tables[-1]["rows"] += 1
        elif tag in ("th", "figcaption"):
            self._in, self._cell = tag, ""

    def handle_data(self, data):
        if self._in:
            self._cell += data

    def handle_endtag(self, tag):
        if tag == "th" and self._in == "th":
            self.tables[-1]["header"].append(self._cell)
        elif tag == "figcaption":
            self.figures.append(self._cell)
        if tag == self._in:
            self._in = None


def markdown_tables(md: str):
    lines = md.splitlines()
    out = []
    for i, line in enumerate(lines[:-1]):
        if line.startswith("| ") and lines[i + 1].startswith("|---"):
            # a header cell may be a link (the front matrix's scenarios): its text is what HTML shows
            header = [re.sub(r"^\[(.*)\]\(#[^)]*\)$", r"\1", h.strip()).replace("\\|", "|")
                      for h in line.strip("|").split(" | ")]
            rows = 1
            while i + 2 + rows - 1 < len(lines) and lines[i + 2 + rows - 1].startswith("| "):
                rows += 1
            out.append({"header": header, "rows": rows})
    return out


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    st = run_study(resolve_scenario("tumbler-intermediate-axis"), methods=["lie-rkmk4", "mujoco-rk4", "euler-rk4"],
                   steps=[0.125, 0.0625, 0.03125], workers=1)
    return write_report([st], tmp_path_factory.mktemp("r"), throughput=[
        {"engine": "xcheck", "method": "lie-rkmk4", "scenario": "tumbler-intermediate-axis", "batch": 1,
         "steps_per_second": 1e6}])


def test_markdown_and_html_show_the_same_tables_and_figures(report):
    md = (report / "report.md").read_text()
    parser = _Tables()
    parser.feed((report / "index.html").read_text())
    # front table, checks, methods, the tumbler's flips (issue 62), what a tolerance costs, throughput
    assert len(parser.tables) == 6
    assert markdown_tables(md) == parser.tables
    assert parser.tables[2]["header"] == ["method", "expected", "observed", "1/8 s", "1/16 s", "1/32 s", "steps/s",
                                          "consistent", "accurate at its finest step", "energy", "|L|", "L turned"]
    assert parser.tables[2]["rows"] == 4  # header + 3 methods
    assert parser.tables[3]["header"] == ["method", "at", "flips", "first [s]", "Δ first [s]", "every [s]",
                                          "Δ every [s]"]
    assert parser.tables[3]["rows"] == 4  # header + the 3 methods' flips
    assert parser.tables[4]["header"] == ["method", "within 1e-03 rad", "within 1e-06 rad", "within 1e-09 rad"]
    assert parser.tables[4]["rows"] == 4
    md_figures = re.findall(r"^!\[(.*)\]\(plots/(.*)\)$", md, flags=re.M)
    assert [caption for caption, _ in md_figures] == parser.figures and len(parser.figures) >= 3
    assert all((report / "plots" / file).is_file() for _, file in md_figures)


def test_emitters_escape_text(tmp_path):
    blocks = [Heading(2, "a <b> & c", anchor="x", badge=("ok", "pass")), Verdict("FAILED", "fail"),
              Para([("x|y ", None), ("<code>", "code"), ("fail", "mark")]),
              Table(["h|1", "h2"], [[Cell("1|2", "fail", title="it's <bad>"), "plain"]])]
    md = to_markdown(blocks)
    assert "## a <b> & c — ✅ ok" in md and "❌ **FAILED**" in md and "x|y `<code>`❌" in md
    assert "| h\\|1 | h2 |" in md and "| ❌ 1\\|2 | plain |" in md
    page = to_html(blocks, tmp_path, title="t")
    assert "<h2 id='x'>a &lt;b&gt; &amp; c — <span class='verdict pass'>ok</span></h2>" in page
    assert "<code>&lt;code&gt;</code><span class='chip fail'></span>" in page
    assert "<td class='fail' title='it&#x27;s &lt;bad&gt;'>1|2</td>" in page


def test_unknown_block_is_refused(tmp_path):
    with pytest.raises(TypeError, match="not a report block"):
        to_markdown(["text"])
    (tmp_path / "x.png").write_bytes(b"")
    with pytest.raises(TypeError, match="not a report block"):
        to_html([Figure("x.png", "c"), 3], tmp_path, title="t")


def test_cleanup_finishes_despite_an_interrupt():
    """A signal landing in the middle of the cleanup (the workers of a signalled process group die first) must
    not leave half a folder: each step runs to its end, then the interrupt goes on."""
    from xcheck.base.files import _finish_despite_interrupts

    done, calls = [], {"n": 0}

    def interrupted_once():
        calls["n"] += 1
        if calls["n"] == 1:
            raise KeyboardInterrupt
        done.append("stop")

    with pytest.raises(KeyboardInterrupt):
        _finish_despite_interrupts(interrupted_once, lambda: done.append("remove"))
    assert done == ["stop", "remove"] and calls["n"] == 2


def test_a_figure_keeps_the_reports_style_after_a_library_changed_matplotlibs():
    """Basilisk's scenario plot defaults (``Basilisk/utilities/simHelpers.py``, applied when a worker runs it) turn on
    matplotlib's autolayout for the whole process: every figure after it drew a tight layout (3 s of a quick report's
    CPU) and put its legend in the lower right. A report's figure is made with the report's style again: no layout
    engine, legends where they fit, tick labels at the report's size."""
    import matplotlib

    from xcheck.report.plots import subplots

    saved = dict(matplotlib.rcParams)
    try:
        matplotlib.rcParams.update({"figure.autolayout": True, "legend.loc": "lower right", "xtick.labelsize": 9})
        fig, _ = subplots(1, 2, size=(11.0, 4.6), legend_outside=True)
        assert fig.get_layout_engine() is None
        assert matplotlib.rcParams["legend.loc"] == "best" and matplotlib.rcParams["xtick.labelsize"] == "medium"
    finally:
        matplotlib.rcParams.update(saved)


def test_side_legend_names_every_line_beside_the_axes_within_the_figure():
    """The report's legend (placed once, not measured at every drawing): one label and one line in the handle's
    colour, style and marker for each line of the axes, in the order drawn, right of the axes and inside the
    figure; 40 lines on a 4.6 in figure still fit (the rows shrink)."""
    from xcheck.report.plots import side_legend, subplots

    fig, (ax, cost) = subplots(1, 2, size=(11.0, 4.6), legend_outside=True, sharey=True)
    for k in range(40):
        ax.plot([1, 2], [k, k + 1], "--" if k % 2 else "-", marker="os"[k % 2], color=f"C{k % 10}", label=f"m{k}")
    side_legend(cost, *ax.get_legend_handles_labels())
    texts = [t for t in fig.texts]
    assert [t.get_text() for t in texts] == [f"m{k}" for k in range(40)]
    from matplotlib.lines import Line2D

    lines = [a for a in fig.artists if isinstance(a, Line2D)]
    assert len(lines) == 40 and lines[3].get_linestyle() == "--" and lines[3].get_marker() == "s"
    assert lines[5].get_color() == "C5"
    right = cost.get_position().x1
    ys = [t.get_position()[1] for t in texts]
    assert all(right < t.get_position()[0] < 1 for t in texts) and all(0 < y < 1 for y in ys)
    assert ys == sorted(ys, reverse=True)
