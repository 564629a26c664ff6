"""Whatever is in the way of an output, nothing the tool did not write is lost or changed, and nothing but a
regular file or an agvctl output folder is replaced: a property over random folders of the user's files and
folders, inputs, agvctl output folders, FIFOs, sockets, device nodes (as root) and symbolic links (dangling,
looping, up and out), and random output paths through them with ``..`` and missing folders, written the ways the
commands write (checked then written atomically, staged, or a whole folder swapped in) and by the writers alone."""

from __future__ import annotations

import os
import socket
import stat
import tempfile
from pathlib import Path
from typing import Any

from hypothesis import event, example, given, settings
from hypothesis import strategies as st

from agvctl.cli.outputs import Output, check_outputs, files_in
from agvctl.cli.staging import MARKER, check_replaceable, staged_outputs
from agvctl.errors import ConfigError
from agvctl.fileio import write_text

NAMES = ("a", "b", "c")
KINDS = (
    "missing",
    "file",
    "input",
    "folder",
    "empty",
    "ours",
    "ours-with-input",
    "ours-and-theirs",
    "fifo",
    "socket",
    "device",
    "link",
)
LINK_TARGETS = ("a", "b/e", "c", ".", "..", "../w/a", "../outside.txt", "missing/x", "a/../b", "loop")
COMPONENTS = ("a", "b", "c", "e", "..", "new", ".")
MODES = ("file", "staged file", "folder", "atomic write alone", "staged folder alone")
CAN_MAKE_DEVICES = os.geteuid() == 0
SCRATCH = "/dev/shm" if os.path.isdir("/dev/shm") and os.access("/dev/shm", os.W_OK) else None
"""Where the folders are made: a memory file system where there is one (each example makes and removes a dozen)."""


def _make(p: Path, kind: str, link: str, inputs: list[Path]) -> None:
    if kind in ("file", "input"):
        p.write_text(f"the user's {p.name}\n")
        if kind == "input":
            inputs.append(p)
    elif kind in ("folder", "ours", "ours-with-input", "ours-and-theirs"):
        p.mkdir()
        (p / "e").write_text("the user's e\n")
        if kind == "ours-and-theirs":  # an output that listed no files, into which the user put e since
            (p / MARKER).write_text("an earlier run's\nfiles 0\n")
        elif kind != "folder":
            (p / MARKER).write_text("an earlier run's\n")
        if kind == "ours-with-input":
            inputs.append(p / "e")
    elif kind == "empty":
        p.mkdir()
    elif kind == "fifo":
        os.mkfifo(p)
    elif kind == "socket":
        with socket.socket(socket.AF_UNIX) as s:
            s.bind(str(p))
    elif kind == "device":
        if CAN_MAKE_DEVICES:
            os.mknod(p, 0o600 | stat.S_IFCHR, os.makedev(1, 3))  # like /dev/null
        else:
            os.mkfifo(p)
    elif kind == "link":
        p.symlink_to(p.name if link == "loop" else link)


def _snapshot(root: Path) -> dict[str, Any]:
    """Every entry under ``root`` (links not followed): its kind and identity, a regular file's bytes."""
    out: dict[str, Any] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath, name)
            s = p.lstat()
            if stat.S_ISREG(s.st_mode):
                value: Any = ("file", p.read_bytes())
            elif stat.S_ISLNK(s.st_mode):
                value = ("link", os.readlink(p))
            else:
                value = (stat.S_IFMT(s.st_mode), s.st_ino, s.st_rdev)
            out[str(p.relative_to(root))] = value
    return out


def _allowed(root: Path, target: Path, mode: str, inputs: list[Path]) -> Path | None:
    """What the write may change: the real target (``os.path.realpath`` the oracle), when what is there may be
    replaced; None when nothing may change."""
    real = Path(os.path.realpath(target))
    if root not in real.parents:
        return None
    try:
        s = real.lstat()
    except OSError:  # missing (or under a file: the write must fail)
        return real
    if mode in ("file", "staged file", "atomic write alone"):
        is_input = any(real == p.resolve() for p in inputs) and mode != "atomic write alone"
        return real if stat.S_ISREG(s.st_mode) and not is_input else None
    if not stat.S_ISDIR(s.st_mode):
        return None
    marker = real / MARKER
    lists_files = marker.is_file() and "\nfiles " in "\n" + marker.read_text()
    only_marker = {p.name for p in real.iterdir()} <= {MARKER}
    ours = (marker.is_file() and (not lists_files or only_marker)) or not any(real.iterdir())
    holds_input = any(real in p.resolve().parents for p in inputs) and mode == "folder"
    return real if ours and not holds_input else None


def _write(target: Path, mode: str, inputs: list[Path]) -> None:
    """Write ``target`` the way a command does (refusals are the commands' one-line errors)."""
    if mode == "file":
        check_outputs([Output("--out", target)], inputs)
        write_text(target, "written\n")
    elif mode == "staged file":
        check_outputs([Output("--junit", target)], inputs)
        with staged_outputs("check") as staging:
            staging.write_text("--junit", target, "written\n")
    elif mode == "folder":
        check_outputs(files_in("--out", target, ["log.csv"]), inputs, [("--out", target)])
        check_replaceable("--out", target, inputs)
        with staged_outputs("run") as staging:
            (staging.directory("--out", target) / "log.csv").write_text("written\n")
    elif mode == "atomic write alone":
        write_text(target, "written\n")
    else:
        with staged_outputs("run") as staging:
            (staging.directory("--out", target) / "log.csv").write_text("written\n")


@settings(max_examples=1000)
@given(
    kinds=st.tuples(*(st.sampled_from(KINDS) for _ in NAMES)),
    links=st.tuples(*(st.sampled_from(LINK_TARGETS) for _ in NAMES)),
    inner=st.sampled_from(("file", "input", "fifo", "link", "empty")),
    components=st.lists(st.sampled_from(COMPONENTS), min_size=1, max_size=4),
    mode=st.sampled_from(MODES),
)
@example(  # a folder holding an input, named through a folder that does not exist yet and '..'
    kinds=("file", "ours-with-input", "empty"),
    links=("a", "a", "a"),
    inner="file",
    components=["new", "..", "b"],
    mode="folder",
)
def test_no_output_loses_or_changes_what_the_tool_did_not_write(
    kinds: tuple[str, ...], links: tuple[str, ...], inner: str, components: list[str], mode: str
) -> None:
    with tempfile.TemporaryDirectory(prefix="agvctl-targets-", dir=SCRATCH) as tmp:
        root = Path(tmp).resolve()
        base = root.joinpath("p", "q", "r", "s")  # deep enough that no path drawn climbs out of root
        base.mkdir(parents=True)
        (base / "outside.txt").write_text("the user's, beside the working folder\n")
        work = base / "w"
        work.mkdir()
        inputs: list[Path] = []
        for name, kind, link in zip(NAMES, kinds, links, strict=True):
            _make(work / name, kind, link, inputs)
        if kinds[1] == "folder":  # b/e: something inside a folder of the user's
            (work / "b" / "e").unlink()
            _make(work / "b" / "e", inner, "../a", inputs)
        target = work.joinpath(*components)
        allowed = _allowed(root, target, mode, inputs)
        before = _snapshot(root)
        try:
            _write(target, mode, inputs)
            wrote = True
        except (ConfigError, OSError):
            wrote = False
        after = _snapshot(root)
        event(f"{mode}: {'written' if wrote else 'refused'}")

        def may_change(rel: str) -> bool:
            p = root / rel
            return allowed is not None and (p == allowed or allowed in p.parents)

        def may_appear(rel: str) -> bool:  # the target, what is in it, and the folders made for it
            return may_change(rel) or (allowed is not None and root / rel in allowed.parents)

        assert wrote <= (allowed is not None), (target, mode)
        changed = [r for r, v in before.items() if after.get(r) != v and not may_change(r)]
        assert changed == [], (target, mode, changed)
        appeared = [r for r in after if r not in before and not may_appear(r)]
        assert appeared == [], (target, mode, appeared)
        left = [r for r in after if Path(r).name.startswith(".") and r.endswith((".tmp", ".old"))]
        assert left == [], left
        for r, v in before.items():  # nothing but a regular file or a folder is ever replaced
            if v[0] not in ("file", "link") and not stat.S_ISDIR(v[0]):
                assert after.get(r) == v, r
