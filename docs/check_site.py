"""Open every page of the built site in headless Chromium; save a screenshot of each; fail on any problem.

A problem is a console error, an uncaught exception, a request that fails or answers 400 or more, an
image that does not load (``naturalWidth == 0``), a page that does not render (no ``h1`` in its
article, or an article of under 100 characters), or an internal link that does not resolve: to a file
missing from the site, or to an anchor that its page does not have. The site is served over HTTP from a local port (the
search index and the pages load as on a web server). The browser is the system's Chromium, driven by
Playwright (``pip install playwright``; its own browser download is not needed).

    python docs/check_site.py site --screenshots results/docs/screenshots [--chromium /usr/bin/chromium]

The screenshot of each page shows its first screen; those of the home page and of the first env page
(``home.png``, ``env.png``) show the whole page.

Exit status 0 when every page passes, 1 with one line per problem otherwise, 2 when Chromium is missing.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import os
import shutil
import sys
import threading
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urldefrag, urlsplit

#: Chromium's switches for a headless check on a machine without network or display, as root.
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-gpu",
]
INSTALL = (
    "the site check opens every page in Chromium: install it (`apt-get install -y chromium` on Debian/Ubuntu) "
    "or pass --chromium PATH (or set GYM4REAL_CHROMIUM) to a Chrome or Chromium binary"
)

_RENDERED = """() => {
  const article = document.querySelector("article");
  const broken = Array.from(document.images).filter(i => !i.complete || i.naturalWidth === 0).map(i => i.src);
  return {
    h1: !!(article && article.querySelector("h1")),
    text: article ? article.innerText.length : 0,
    images: document.images.length,
    broken: broken,
    links: Array.from(document.querySelectorAll("a[href]")).map(a => a.href),
    ids: Array.from(document.querySelectorAll("[id]")).map(e => e.id),
  };
}"""


def find_chromium(given: str | None) -> str | None:
    """The Chromium binary: ``given``, ``$GYM4REAL_CHROMIUM``, or ``chromium``/``chromium-browser`` on PATH."""
    for candidate in (given, os.environ.get("GYM4REAL_CHROMIUM"), "chromium", "chromium-browser", "google-chrome"):
        if candidate and (path := shutil.which(candidate)):
            return path
    return None


def _serve(root: Path) -> http.server.ThreadingHTTPServer:
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, format: str, *args: Any) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(root)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server


def pages(site: Path) -> list[str]:
    """The site's pages as paths relative to its root (``index.html``, ``envs/index.html``, ...)."""
    found = [p.relative_to(site).as_posix() for p in sorted(site.rglob("*.html")) if p.name != "404.html"]
    if not found:
        raise SystemExit(f"no HTML page under `{site}`; build the site first (`mkdocs build`)")
    return found


def _target(site: Path, path: str) -> str | None:
    """The file under ``site`` that a URL path names (``envs/`` -> ``envs/index.html``), or None."""
    rel = unquote(path).lstrip("/")
    for candidate in (rel, rel.rstrip("/") + "/index.html"):
        if candidate and (site / candidate).is_file():
            return Path(candidate).as_posix()
    return "index.html" if not rel else None


def broken_links(site: Path, base: str, links: dict[str, list[str]], ids: dict[str, set[str]]) -> list[str]:
    """The internal links that do not resolve: each page's ``links`` (absolute URLs) against the files of
    the site and the element ids of its pages (``ids``); links to other hosts are not checked."""
    problems = []
    for rel, urls in links.items():
        for url in urls:
            if not url.startswith(base):
                continue
            address, fragment = urldefrag(url)
            target = _target(site, urlsplit(address).path)
            if target is None:
                problems.append(f"{rel}: broken link: {url} (no such file in the site)")
            elif fragment and target in ids and unquote(fragment) not in ids[target]:
                problems.append(f"{rel}: broken link: {url} (no element with id `{unquote(fragment)}` on {target})")
    return sorted(set(problems))


def check(site: Path, screenshots: Path, chromium: str) -> list[str]:
    """Open every page; return the problems (empty when all pages pass)."""
    from playwright.sync_api import sync_playwright

    screenshots.mkdir(parents=True, exist_ok=True)
    server = _serve(site)
    base = f"http://127.0.0.1:{server.server_address[1]}/"
    problems: list[str] = []
    links: dict[str, list[str]] = {}
    ids: dict[str, set[str]] = {}
    found = pages(site)
    whole = {"index.html": "home.png"}
    envs = [rel for rel in found if rel.startswith("envs/") and rel != "envs/index.html"]
    if envs:
        whole[envs[0]] = "env.png"
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
            for rel in found:
                page = browser.new_page(viewport={"width": 1680, "height": 1050})
                seen: list[str] = []
                page.on(
                    "console",
                    lambda m, seen=seen: seen.append(f"console error: {m.text}") if m.type == "error" else None,
                )
                page.on("pageerror", lambda e, seen=seen: seen.append(f"uncaught exception: {e}"))
                page.on("requestfailed", lambda r, seen=seen: seen.append(f"request failed: {r.url} ({r.failure})"))
                page.on(
                    "response",
                    lambda r, seen=seen: seen.append(f"HTTP {r.status}: {r.url}") if r.status >= 400 else None,
                )
                page.goto(base + rel, wait_until="networkidle")
                state = page.evaluate(_RENDERED)
                page.screenshot(path=str(screenshots / (rel.replace("/", "_").removesuffix(".html") + ".png")))
                if rel in whole:
                    page.screenshot(path=str(screenshots / whole[rel]), full_page=True)
                page.close()
                links[rel], ids[rel] = state["links"], set(state["ids"])
                issues = seen + [f"broken image: {src}" for src in state["broken"]]
                if not state["h1"] or state["text"] < 100:
                    issues.append(f"page did not render (h1: {state['h1']}, {state['text']} characters of text)")
                problems += [f"{rel}: {issue}" for issue in issues]
                print(f"{'FAIL' if issues else 'ok  '} {rel} ({state['images']} images)")
            browser.close()
    finally:
        server.shutdown()
    return problems + broken_links(site, base, links, ids)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("site", type=Path, help="the built site (mkdocs' site_dir)")
    parser.add_argument("--screenshots", type=Path, required=True, help="folder of one PNG per page")
    parser.add_argument("--chromium", help="Chromium binary (default: $GYM4REAL_CHROMIUM, else on PATH)")
    args = parser.parse_args()
    chromium = find_chromium(args.chromium)
    if chromium is None:
        print(f"check_site: {INSTALL}", file=sys.stderr)
        return 2
    problems = check(args.site, args.screenshots, chromium)
    for problem in problems:
        print(problem, file=sys.stderr)
    print(f"{len(pages(args.site))} pages, {len(problems)} problems; screenshots in {args.screenshots}/")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
