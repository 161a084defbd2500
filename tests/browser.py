"""A real browser for the report's tests (issue 26): Debian's Chromium, headless, driven from the command line
alone — no WebDriver, no Playwright. :func:`probe` loads a copy of a page with two scripts added (one first in
``<head>`` that records errors and ``console.error`` calls, one that measures the page once it has loaded) and
reads the measurements back from the DOM Chromium dumps; :func:`screenshot` saves what a window of a given
size shows. Where there is no Chromium the tests that need it skip, saying so (``.ci/run`` installs it where
the machine allows)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

CHROMIUM = next((shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)), None)
WHY_NOT = "no Chromium here (Debian: apt-get install chromium; .ci/run installs it where the machine allows)"
#: Chromium as the machine's probe runs it: no sandbox (root), no GPU, none of its background connections
#: (this machine's network is closed), a profile of its own.
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync", "--hide-scrollbars")

_FIRST = """<script>
window.__errors = [];
window.addEventListener('error', e => window.__errors.push('error: ' + (e.message || e.type)), true);
const __consoleError = console.error;
console.error = (...a) => { window.__errors.push('console.error: ' + a.join(' ')); __consoleError(...a); };
</script>"""
_LAST = """<script>
window.addEventListener('load', () => {
  const W = window.innerWidth, H = window.innerHeight;
  const top = el => el ? el.getBoundingClientRect().top + window.scrollY : null;
  const imgs = [...document.images];
  const links = [...document.querySelectorAll('a[href^="#"]')].map(a => a.getAttribute('href').slice(1));
  const wide = [...document.body.querySelectorAll('*')].filter(el => {
      const r = el.getBoundingClientRect(); return r.right > W + 1 && getComputedStyle(el).position !== 'fixed'
        && !el.closest('.scroll'); }).map(el => el.tagName.toLowerCase() + (el.className ? '.' + el.className : ''));
  const probe = {
    window: [W, H], scroll_width: document.documentElement.scrollWidth,
    images: imgs.length, images_broken: imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.alt),
    links: links.length, links_broken: links.filter(id => !document.getElementById(decodeURIComponent(id))),
    verdict_top: top(document.querySelector('.verdict')), matrix_top: top(document.querySelector('table')),
    matrix_bottom: (() => { const t = document.querySelector('table');
                            return t ? t.getBoundingClientRect().bottom + window.scrollY : null; })(),
    wide: wide.slice(0, 10), errors: window.__errors,
    details: document.querySelectorAll('details').length,
    details_open: document.querySelectorAll('details[open]').length,
  };
  const pre = document.createElement('pre'); pre.id = 'xcheck-probe'; pre.textContent = JSON.stringify(probe);
  document.body.appendChild(pre);
});
</script>"""


def _run(args, timeout=120):
    with tempfile.TemporaryDirectory() as profile:
        return subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *args], capture_output=True, text=True,
                              timeout=timeout)


def probe(page: Path, size=(1400, 900)) -> dict:
    """Measurements of ``page`` as Chromium shows it in a window of ``size``: images and how many failed to
    load, internal links and those that lead nowhere, the top [px] of the verdict and of the first table,
    elements wider than the window, errors (uncaught, or written with ``console.error``), ``<details>`` folded."""
    html = Path(page).read_text(encoding="utf-8")
    html = html.replace("<head>", "<head>" + _FIRST, 1).replace("</body>", _LAST + "</body>", 1)
    copy = Path(page).with_name(f".probe-{Path(page).name}")
    copy.write_text(html, encoding="utf-8")
    try:
        proc = _run([f"--window-size={size[0]},{size[1]}", "--virtual-time-budget=20000", "--dump-dom",
                     copy.resolve().as_uri()])
    finally:
        copy.unlink(missing_ok=True)
    found = re.search(r"<pre id=\"xcheck-probe\">(.*?)</pre>", proc.stdout, re.S)
    if not found:
        raise AssertionError(f"Chromium gave no measurements (exit {proc.returncode}): {proc.stderr[-2000:]}")
    import html as _html

    return json.loads(_html.unescape(found.group(1)))


def screenshot(page: Path, png: Path, size=(1400, 900)) -> Path:
    """What a ``size`` window shows of ``page``, as PNG."""
    proc = _run([f"--window-size={size[0]},{size[1]}", f"--screenshot={Path(png).resolve()}",
                 "--virtual-time-budget=10000", Path(page).resolve().as_uri()])
    if not Path(png).is_file():
        raise AssertionError(f"Chromium wrote no screenshot (exit {proc.returncode}): {proc.stderr[-2000:]}")
    return Path(png)
