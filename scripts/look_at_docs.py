"""Look at the documentation in a real browser: four pages at 1280 px, screenshots and overflows.

A table, code block or picture that is wider than the page is cut off for a reader even when
every link resolves, and only a browser's layout shows it. This script opens in headless
Chromium (through Playwright) the site's home page, the how-to "Put my structure in", the FMU
variable reference, and ``documentation/index.html`` of a built FMU, unzipped as a user would.
For each page it takes a full-page screenshot and measures:

- the page's ``scrollWidth`` against its ``clientWidth`` (wider: the reader scrolls sideways);
- every table, ``pre`` block and image of the text: whether its right edge passes the visible
  area of an ancestor that clips without scrolling, or the window (it is cut off);
- every scroll container among them that scrolls sideways while it is taller than the window
  (its scroll bar is out of sight while its top is read: a column looks cut off);
- every variable name (inline code in a table cell): whether it is broken over two lines or
  spills out of its cell.

It builds nothing: give it a built site (``mkdocs build --site-dir DIR``) and a built FMU
(``python build_fmu.py``); ``make look`` does all three. Exit status 0 when nothing is found,
1 on a finding, 2 when Chromium or Playwright is missing. Chromium is Debian's
(``apt-get install chromium``), Playwright the pip package; neither is a dependency of the
package.

    python scripts/look_at_docs.py SITE_DIR dist/IceImpact.fmu --shots out/docs-shots
"""

from __future__ import annotations

import argparse
import functools
import http.server
import shutil
import sys
import tempfile
import threading
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: Chromium's flags that run headless on a machine without a display, a GPU or a sandbox.
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]
CHROMIUM = "/usr/bin/chromium"
#: The site's pages looked at (path under the site) and the name of their screenshot.
SITE_PAGES = {"index": "index.html",
              "how-to-put-my-structure-in": "how-to/put-my-structure-in/index.html",
              "reference-fmu-variables": "reference/fmu-variables/index.html"}
FMU_PAGE = "documentation/index.html"
WIDTH, HEIGHT = 1280, 900

#: Measures one loaded page; returns the figures and findings (see the module's docstring).
MEASURE_JS = r"""
() => {
  const doc = document.documentElement;
  const root = document.querySelector('.md-content') || document.body;
  const winRight = doc.clientWidth;
  const label = el => {
    const text = (el.innerText || el.getAttribute('src') || '').trim().split('\n')[0];
    return el.tagName.toLowerCase() + ' "' + text.slice(0, 40) + '"';
  };
  const visible = el => {
    const r = el.getBoundingClientRect();
    return r.width > 0 && r.height > 0 && getComputedStyle(el).visibility !== 'hidden';
  };
  const scrolls = s => s.overflowX === 'auto' || s.overflowX === 'scroll';
  const findings = [];
  const counts = {table: 0, pre: 0, img: 0, names: 0, scrollers: 0};
  const boxes = [...root.querySelectorAll('table, pre, img')].filter(visible);
  for (const el of boxes) {
    counts[el.tagName.toLowerCase()] += 1;
    let right = el.getBoundingClientRect().right;
    const own = getComputedStyle(el);
    const wide = [el, ...el.querySelectorAll('*')];
    if (scrolls(own) && el.scrollWidth > el.clientWidth + 1) {
      counts.scrollers += 1;
      if (el.getBoundingClientRect().height > window.innerHeight) {
        findings.push(label(el) + ': scrolls sideways by ' + (el.scrollWidth - el.clientWidth)
                      + ' px and is taller than the window (its scroll bar is out of sight)');
      }
    }
    for (let a = el.parentElement; a && a !== document.body && a !== doc; a = a.parentElement) {
      const s = getComputedStyle(a);
      if (s.overflowX === 'visible') continue;
      const r = a.getBoundingClientRect();
      const edge = r.left + a.clientLeft + a.clientWidth;
      if (right > edge + 1) {
        if (scrolls(s)) {
          counts.scrollers += 1;
          if (r.height > window.innerHeight) {
            findings.push(label(el) + ': scrolls sideways by ' + Math.round(right - edge)
                          + ' px in a box taller than the window (its scroll bar is out of sight)');
          }
        } else {
          findings.push(label(el) + ': cut off by ' + Math.round(right - edge) + ' px ('
                        + a.tagName.toLowerCase() + '.' + a.className + ' clips)');
        }
        right = edge;
      }
    }
    if (right > winRight + 1) {
      findings.push(label(el) + ': ' + Math.round(right - winRight) + ' px past the window');
    }
  }
  for (const code of root.querySelectorAll('td code, th code')) {
    if (!visible(code)) continue;
    counts.names += 1;
    // a line may end at a space of the code; a word broken over two lines is a finding
    const walker = document.createTreeWalker(code, NodeFilter.SHOW_TEXT);
    for (let node = walker.nextNode(); node; node = walker.nextNode()) {
      for (const word of node.data.matchAll(/\S+/g)) {
        const range = document.createRange();
        range.setStart(node, word.index);
        range.setEnd(node, word.index + word[0].length);
        const tops = new Set([...range.getClientRects()].map(r => Math.round(r.top)));
        if (tops.size > 1) {
          findings.push('name "' + word[0] + '": broken over ' + tops.size + ' lines');
        }
      }
    }
    const cell = code.closest('td, th').getBoundingClientRect();
    const spill = code.getBoundingClientRect().right - cell.right;
    if (spill > 1) {
      findings.push('name "' + code.innerText + '": spills ' + Math.round(spill)
                    + ' px out of its cell');
    }
  }
  if (doc.scrollWidth > doc.clientWidth) {
    findings.push('page: ' + (doc.scrollWidth - doc.clientWidth) + ' px wider than the window');
  }
  return {scrollWidth: doc.scrollWidth, clientWidth: doc.clientWidth, counts, findings};
}
"""


@dataclass
class Look:
    """What one page measured."""

    name: str
    url: str
    shot: Path
    scroll_width: int = 0
    client_width: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    findings: list[str] = field(default_factory=list)


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:  # noqa: A002 (the base's name)
        pass


@contextmanager
def serve(folder: Path) -> Iterator[str]:
    """The folder served on a free local port, as a reader's browser gets a site; its URL."""
    handler = functools.partial(_QuietHandler, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


def _local_only(route: Any) -> None:
    """Pages are looked at offline: requests out (web fonts) are refused, as on a machine
    without a network, so that every run lays a page out the same."""
    url = route.request.url
    if url.startswith(("file:", "data:", "http://127.0.0.1:")):
        route.continue_()
    else:
        route.abort()


def look(pages: list[tuple[str, str]], shots: Path, chromium: str = CHROMIUM,
         width: int = WIDTH) -> list[Look]:
    """Open each (name, url) at ``width`` px, screenshot it into ``shots`` and measure it."""
    from playwright.sync_api import sync_playwright

    shots.mkdir(parents=True, exist_ok=True)
    looks = []
    with tempfile.TemporaryDirectory(prefix="look-profile-") as profile, sync_playwright() as pw:
        context = pw.chromium.launch_persistent_context(
            profile, executable_path=chromium, headless=True, args=CHROMIUM_ARGS,
            viewport={"width": width, "height": HEIGHT})
        try:
            page = context.new_page()
            page.route("**/*", _local_only)
            for name, url in pages:
                page.goto(url, wait_until="load")
                page.evaluate("document.fonts.ready")
                shot = shots / f"{name}.png"
                page.screenshot(path=str(shot), full_page=True)
                got = page.evaluate(MEASURE_JS)
                looks.append(Look(name, url, shot, got["scrollWidth"], got["clientWidth"],
                                  got["counts"], got["findings"]))
        finally:
            context.close()
    return looks


def report(looks: list[Look]) -> str:
    """The table of pages and what was found on each."""
    lines = [f"{'page':<28} {'scrollWidth/clientWidth':>24} {'tables':>7} {'pre':>5} "
             f"{'img':>5} {'names':>6} {'scroll':>7} {'findings':>9}"]
    for lk in looks:
        c = lk.counts
        lines.append(f"{lk.name:<28} {f'{lk.scroll_width}/{lk.client_width}':>24} "
                     f"{c.get('table', 0):>7} {c.get('pre', 0):>5} {c.get('img', 0):>5} "
                     f"{c.get('names', 0):>6} {c.get('scrollers', 0):>7} {len(lk.findings):>9}")
    for lk in looks:
        lines.append(f"\n{lk.name}: {lk.shot}")
        lines += [f"  {f}" for f in lk.findings[:40]] or ["  nothing cut off or broken"]
        if len(lk.findings) > 40:
            lines.append(f"  ... and {len(lk.findings) - 40} more")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Look at the site ``SITE_DIR`` and the page of ``FMU``; exit 1 on a finding."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("site", type=Path, help="a built site (mkdocs build --site-dir SITE)")
    parser.add_argument("fmu", type=Path, help="a built FMU carrying " + FMU_PAGE)
    parser.add_argument("--shots", type=Path, default=Path("out/docs-shots"),
                        help="folder of the screenshots (default: out/docs-shots)")
    parser.add_argument("--chromium", default=CHROMIUM, help=f"the browser (default: {CHROMIUM})")
    parser.add_argument("--width", type=int, default=WIDTH,
                        help=f"the window's width in px (default: {WIDTH})")
    args = parser.parse_args(argv)
    for page in SITE_PAGES.values():
        if not (args.site / page).is_file():
            parser.error(f"{args.site / page} is missing: build the site first (make docs)")
    if not args.fmu.is_file():
        parser.error(f"{args.fmu} is missing: build it first (python build_fmu.py)")
    if shutil.which(args.chromium) is None:
        print(f"look_at_docs: no browser at {args.chromium} (apt-get install chromium)",
              file=sys.stderr)
        return 2
    try:
        import playwright  # noqa: F401 (only its presence is checked here)
    except ImportError:
        print("look_at_docs: playwright is missing (pip install playwright)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="look-fmu-") as unzipped, serve(args.site) as url:
        with zipfile.ZipFile(args.fmu) as zf:
            if FMU_PAGE not in zf.namelist():
                print(f"look_at_docs: {args.fmu} has no {FMU_PAGE}", file=sys.stderr)
                return 1
            zf.extractall(unzipped)
        pages = [(name, url + path) for name, path in SITE_PAGES.items()]
        pages.append(("fmu-documentation", (Path(unzipped) / FMU_PAGE).as_uri()))
        looks = look(pages, args.shots, args.chromium, args.width)
    print(report(looks))
    return 1 if any(lk.findings for lk in looks) else 0


if __name__ == "__main__":
    raise SystemExit(main())
