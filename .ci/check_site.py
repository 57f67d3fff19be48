"""Open pages of the built documentation site in headless Chromium and check that they render.

    python .ci/check_site.py docs/_build/html [--artifacts ci-artifacts/browser]

For each page, Chromium loads a small probe page that holds the site's page in an iframe and,
once the site's own scripts have run, reads the rendered document: its title, the search box
(the theme's search form with its query field), the images (each must have finished loading
with a non-zero natural size: a missing or broken figure fails) and, per page, what it must
show (the index: the headline figures; the API page: a signature and a Parameters list; the
notebook: its executed output figures).  A screenshot of each page is checked for being more
than a blank page.  On a failure the screenshots and the probe results stay in --artifacts
(printed); on success they are removed.  Exit status 0 when every check passes, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--window-size=1280,1600"]

# page (relative to the site) -> (words the title must contain, minimum number of loaded content
# images, CSS selectors that must each match at least one element)
PAGES = {
    "index.html": (["cwlidar_sim"], 2, ["article h1"]),
    "api/generated/cwlidar_sim.turbulence.generate_box.html":
        (["generate_box"], 0, ["dl.py.function dt.sig", "dl.field-list"]),
    "notebooks/a2012_transfer_function.html": (["A2012"], 5, ["div.cell_output img"]),
}

PROBE = """<!doctype html><html><body><pre id="result">pending</pre>
<iframe id="page" src="%(url)s" style="width:1280px;height:30000px;border:0"></iframe>
<script>
const frame = document.getElementById('page');
const out = document.getElementById('result');
frame.addEventListener('load', () => setTimeout(() => {
  let r;
  try {
    const d = frame.contentDocument;
    const content = d.querySelector('article') || d.body;
    const imgs = Array.from(content.querySelectorAll('img'));
    r = {
      title: d.title,
      search: !!d.querySelector('form[action$="search.html"] input[name="q"]'),
      images: imgs.map(i => ({src: i.getAttribute('src'), loaded: i.complete && i.naturalWidth > 0,
                              width: i.naturalWidth})),
      selectors: Object.fromEntries(%(selectors)s.map(s => [s, d.querySelectorAll(s).length])),
      text_chars: (content.innerText || '').length,
    };
  } catch (e) { r = {error: String(e)}; }
  out.textContent = JSON.stringify(r);
}, 1000));
</script></body></html>
"""


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    sys.exit("check_site: no chromium on PATH (Debian: apt-get install -y chromium)")


def run(browser: str, args: list[str], timeout: float = 90.0) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory(prefix="cwlidar_chromium_") as profile:
        return subprocess.run([browser, *FLAGS, f"--user-data-dir={profile}", *args], capture_output=True,
                              text=True, timeout=timeout)


def probe(browser: str, page: Path, selectors: list[str], workdir: Path) -> dict:
    probe_html = workdir / f"probe_{page.stem}.html"
    probe_html.write_text(PROBE % {"url": page.as_uri(), "selectors": json.dumps(selectors)}, encoding="utf-8")
    # file:// pages may read each other's documents only with this flag; virtual time lets the
    # page, its scripts and its images finish before the DOM is dumped
    res = run(browser, ["--allow-file-access-from-files", "--virtual-time-budget=20000", "--dump-dom",
                        probe_html.as_uri()])
    text = res.stdout
    start, end = text.find('<pre id="result">'), text.find("</pre>")
    if start < 0 or end < 0:
        return {"error": f"no probe result (chromium exit {res.returncode}): {res.stderr[-500:]}"}
    raw = text[start + len('<pre id="result">'):end]
    import html

    try:
        return json.loads(html.unescape(raw))
    except json.JSONDecodeError:
        return {"error": f"probe did not finish: {raw[:200]!r}"}


def screenshot_ok(path: Path) -> tuple[bool, str]:
    """A rendered page is not one flat colour: enough pixels differ from the background."""
    if not path.is_file() or path.stat().st_size == 0:
        return False, "no screenshot"
    try:
        import matplotlib.image as mpimg
        import numpy as np
    except ImportError:  # the check stays usable without numpy/matplotlib: size only
        return path.stat().st_size > 20_000, f"{path.stat().st_size} bytes"
    rgb = mpimg.imread(str(path))[..., :3]
    background = np.median(rgb.reshape(-1, 3), axis=0)
    differs = float(np.mean(np.abs(rgb - background).max(axis=-1) > 0.1))
    return differs > 0.02, f"{differs:.1%} of the pixels differ from the background"


def check(site: Path, artifacts: Path) -> list[str]:
    browser = chromium()
    artifacts = artifacts.resolve()  # the probe pages are opened by file:// URI
    artifacts.mkdir(parents=True, exist_ok=True)
    failures = []
    for rel, (title_words, min_images, selectors) in PAGES.items():
        page = site / rel
        if not page.is_file():
            failures.append(f"{rel}: not built")
            continue
        shot = artifacts / (rel.replace("/", "__").removesuffix(".html") + ".png")
        run(browser, ["--virtual-time-budget=20000", f"--screenshot={shot}", page.as_uri()])
        r = probe(browser, page.resolve(), selectors, artifacts)
        (artifacts / (shot.stem + ".json")).write_text(json.dumps(r, indent=2), encoding="utf-8")
        problems = []
        if "error" in r:
            problems.append(r["error"])
        else:
            if not all(w in r["title"] for w in title_words):
                problems.append(f"title {r['title']!r} lacks {title_words}")
            if not r["search"]:
                problems.append("no search box (form action=search.html with a q field)")
            broken = [i["src"] for i in r["images"] if not i["loaded"]]
            if broken:
                problems.append(f"images that did not load: {broken}")
            loaded = sum(i["loaded"] for i in r["images"])
            if loaded < min_images:
                problems.append(f"{loaded} figures loaded, expected at least {min_images}")
            missing = [s for s, n in r["selectors"].items() if n == 0]
            if missing:
                problems.append(f"nothing matches {missing}")
            if r["text_chars"] < 200:
                problems.append(f"only {r['text_chars']} characters of text")
        ok, why = screenshot_ok(shot)
        if not ok:
            problems.append(f"screenshot looks blank ({why})")
        status = "ok" if not problems else "FAILED: " + "; ".join(problems)
        print(f"check_site: {rel}: title {r.get('title')!r}, search box {r.get('search')}, "
              f"{sum(i['loaded'] for i in r.get('images', []))} figures loaded, screenshot {why}: {status}")
        failures += [f"{rel}: {p}" for p in problems]
    return failures


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("site", type=Path, help="the built site (the folder holding index.html)")
    ap.add_argument("--artifacts", type=Path, default=Path("ci-artifacts/browser"),
                    help="where screenshots and probe results are kept on failure")
    args = ap.parse_args(argv)
    failures = check(args.site.resolve(), args.artifacts)
    if failures:
        print("check_site: FAILED\n  " + "\n  ".join(failures), file=sys.stderr)
        print(f"check_site: screenshots and probe results kept in {args.artifacts.resolve()}", file=sys.stderr)
        return 1
    shutil.rmtree(args.artifacts, ignore_errors=True)
    print(f"check_site: {len(PAGES)} pages render (title, search box, figures, content)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
