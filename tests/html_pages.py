"""Reading back the HTML pages of ``check --html`` and ``fuzz --html`` in tests: their images and tables."""

from __future__ import annotations

import base64
import io
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import pytest
from cli_runs import run

ROOT = Path(__file__).resolve().parents[1]
PASSING = ROOT / "experiments" / "line.toml"
FAILING = ROOT / "tests" / "data" / "line_impossible.toml"


@dataclass
class Page:
    """What a page holds: the ``src`` of every image, every table's rows (cell texts) by table id, the ``<pre>``
    texts, the ids of the headings in order, and every ``href`` and script."""

    images: list[str] = field(default_factory=list)
    tables: dict[str, list[list[str]]] = field(default_factory=dict)
    pre: list[str] = field(default_factory=list)
    headings: list[str] = field(default_factory=list)
    links: list[str] = field(default_factory=list)
    scripts: int = 0
    text: str = ""


class _Reader(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.page = Page()
        self._table: str | None = None
        self._row: list[str] | None = None
        self._cell: list[str] | None = None
        self._pre: list[str] | None = None
        self._tables = 0
        self._chunks: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "img":
            self.page.images.append(a.get("src") or "")
        elif tag == "script":
            self.page.scripts += 1
        elif tag in ("a", "link") and a.get("href"):
            self.page.links.append(a["href"] or "")
        elif tag == "table":
            self._table = a.get("id") or f"table-{self._tables}"
            self._tables += 1
            self.page.tables[self._table] = []
        elif tag == "tr" and self._table is not None:
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []
        elif tag == "pre":
            self._pre = []
        elif tag == "h2" and a.get("id"):
            self.page.headings.append(a["id"] or "")

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append(" ".join("".join(self._cell).split()))
            self._cell = None
        elif tag == "tr" and self._row is not None and self._table is not None:
            self.page.tables[self._table].append(self._row)
            self._row = None
        elif tag == "table":
            self._table = None
        elif tag == "pre" and self._pre is not None:
            self.page.pre.append("".join(self._pre))
            self._pre = None

    def handle_data(self, data: str) -> None:
        self._chunks.append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._pre is not None:
            self._pre.append(data)


def read_page(text: str) -> Page:
    """The parts of an HTML page the tests look at."""
    reader = _Reader()
    reader.feed(text)
    reader.close()
    reader.page.text = " ".join("".join(reader._chunks).split())
    return reader.page


def png_size(src: str) -> tuple[int, int]:
    """The pixel size of an embedded ``data:image/png;base64,…`` image (it must decode as a PNG)."""
    from PIL import Image

    prefix = "data:image/png;base64,"
    assert src.startswith(prefix), src[:40]
    with Image.open(io.BytesIO(base64.b64decode(src[len(prefix) :], validate=True))) as image:
        assert image.format == "PNG"
        image.load()
        return image.size


FUZZ_CONFIG = """seed = 3
scenarios = 2
controllers = ["mpc", "ramsete"]
settle_s = 0.5

[limits]
cross_track_error_max_m = 0.001  # a millimetre: most random starts are further off, so runs fail
"""


@pytest.fixture(scope="session")
def pages(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The pages of a failing check (the failure given last), of a passing one and of a small failing fuzz run,
    each through the command line, with the JSON reports of the same runs."""
    d = tmp_path_factory.mktemp("pages")
    capsys = _NoCapture()
    codes = {
        "check_failing": run(
            capsys, "check", PASSING, FAILING, "--jobs", "1", "--html", d / "failing.html", "--json", d / "f.json"
        )[0],
        "check_passing": run(capsys, "check", PASSING, "--jobs", "1", "--html", d / "passing.html")[0],
    }
    (d / "fz.toml").write_text(FUZZ_CONFIG, encoding="utf-8")
    codes["fuzz"] = run(capsys, "fuzz", d / "fz.toml", "--jobs", "1", "--out", d / "fz", "--html", d / "fuzz.html")[0]
    return {"dir": d, "codes": codes}


class _NoCapture:
    """A stand-in for pytest's ``capsys`` in a session fixture (output is left to pytest's own capture)."""

    def readouterr(self) -> tuple[str, str]:
        return "", ""
