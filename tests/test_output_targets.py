"""Nothing of the user's is ever lost: an output path is judged where it really is (``..`` and symbolic links resolved,
missing folders included) and refused if it is, or holds, an input; only a regular file or an agvctl output folder
is replaced, never a device, a FIFO or a socket; an empty value is refused; and only regular files of bounded size
are read, a FIFO or a device refused without blocking. Each refusal is one line, exit 2, nothing written or
deleted."""

from __future__ import annotations

import os
import shutil
import stat
import threading
from pathlib import Path
from typing import Any

import pytest
from cli_runs import one_line, run

from agvctl.cli import main
from agvctl.cli.staging import MARKER, Staging
from agvctl.config import MAX_FILE_BYTES, read_text
from agvctl.errors import ConfigError
from agvctl.fileio import atomic_open, real_path

ROOT = Path(__file__).resolve().parent.parent
TRAJECTORY = ROOT / "trajectories" / "line.toml"


def _tree(d: Path) -> dict[str, Any]:
    """Every entry under ``d``, without following links: what it is, and a regular file's bytes."""
    out: dict[str, Any] = {}
    for p in sorted(d.rglob("*")):
        st = p.lstat()
        out[str(p.relative_to(d))] = p.read_bytes() if stat.S_ISREG(st.st_mode) else (st.st_mode, st.st_rdev)
    return out


def _workspace(d: Path) -> Path:
    """A copy of the shipped experiments and trajectories under ``d``."""
    shutil.copytree(ROOT / "experiments", d / "experiments", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "trajectories", d / "trajectories")
    return d


def _device(d: Path, name: str, real: str) -> Path:
    """A character device like ``real`` (made in ``d`` when we may make device nodes, else ``real`` itself, which
    a user who cannot make one cannot replace either)."""
    node = d / name
    try:
        os.mknod(node, 0o666 | stat.S_IFCHR, os.stat(real).st_rdev)
    except PermissionError:
        return Path(real)
    return node


# -- output targets resolved on the real file system ---------------------------------------------------------------


def test_an_output_folder_named_through_a_missing_folder_and_dotdot_is_judged_where_it_really_is(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(_workspace(tmp_path))
    before = _tree(tmp_path)
    code, out, err = run(capsys, "run", "experiments/line.toml", "--no-plot", "--out", "sub/../experiments")
    assert code == 2 and out == ""
    one_line(err, "agvctl: --out: sub/../experiments holds experiments/line.toml, an input of this command")
    assert _tree(tmp_path) == before and not (tmp_path / "sub").exists()


def test_a_dotdot_after_a_missing_folder_cancels_it_and_the_folder_is_never_made(tmp_path: Path) -> None:
    assert real_path(tmp_path / "missing" / ".." / "x.csv") == tmp_path.resolve() / "x.csv"
    with atomic_open(tmp_path / "missing" / ".." / "x.csv") as fh:
        fh.write("written\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.csv"]


def test_a_symbolic_link_is_written_through_and_kept(tmp_path: Path) -> None:
    (tmp_path / "real.csv").write_text("old\n")
    (tmp_path / "link.csv").symlink_to("real.csv")
    with atomic_open(tmp_path / "link.csv") as fh:
        fh.write("new\n")
    assert (tmp_path / "link.csv").is_symlink() and (tmp_path / "real.csv").read_text() == "new\n"


def test_a_dotdot_after_a_file_is_refused_as_the_kernel_would(tmp_path: Path) -> None:
    (tmp_path / "afile").write_text("the user's\n")
    with pytest.raises(NotADirectoryError):
        real_path(tmp_path / "afile" / ".." / "x.csv")


def test_a_loop_of_symbolic_links_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "a").symlink_to("b")
    (tmp_path / "b").symlink_to("a")
    code, _, err = run(capsys, "plan", TRAJECTORY, "--out", tmp_path / "a" / "x.csv")
    assert code == 2
    one_line(err, "agvctl: --out: cannot write ", "Too many levels of symbolic links")


# -- only a regular file is replaced -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "flag", "device"),
    [
        (["plan", TRAJECTORY, "--out", "{dev}"], "--out", "/dev/full"),
        (["plan", TRAJECTORY, "--out", "{dev}"], "--out", "/dev/null"),
        (["plan", TRAJECTORY, "--plot", "{dev}"], "--plot", "/dev/full"),
        (["check", "{exp}", "--jobs", "1", "--junit", "{dev}"], "--junit", "/dev/full"),
        (["check", "{exp}", "--jobs", "1", "--html", "{dev}"], "--html", "/dev/full"),
    ],
    ids=["plan --out full", "plan --out null", "plan --plot full", "check --junit full", "check --html full"],
)
def test_an_output_onto_a_device_is_refused_and_the_device_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[Any], flag: str, device: str
) -> None:
    _workspace(tmp_path)
    dev = _device(tmp_path, "dev", device)
    before, node = _tree(tmp_path), os.lstat(dev)
    exp = tmp_path / "experiments" / "line.toml"
    code, out, err = run(capsys, *(str(a).format(dev=dev, exp=exp) for a in argv))
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {flag}: {dev} is a character device, not a regular file; refusing to replace it")
    after = os.lstat(dev)
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (node.st_ino, node.st_rdev)
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("command", ["plan", "run"])
def test_an_output_onto_a_fifo_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str) -> None:
    _workspace(tmp_path)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    before = _tree(tmp_path)
    argv = ["plan", TRAJECTORY] if command == "plan" else ["run", tmp_path / "experiments" / "line.toml", "--no-plot"]
    code, out, err = run(capsys, *argv, "--out", fifo)
    assert code == 2 and out == ""
    one_line(err, f"agvctl: --out: {fifo} is a FIFO (named pipe), not a ")
    assert _tree(tmp_path) == before and stat.S_ISFIFO(fifo.lstat().st_mode)


def test_an_atomic_write_onto_a_non_regular_file_is_refused_even_without_the_commands_checks(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "fifo")
    with pytest.raises(PermissionError, match="a FIFO"), atomic_open(tmp_path / "fifo") as fh:
        fh.write("never\n")
    assert [p.name for p in tmp_path.iterdir()] == ["fifo"] and stat.S_ISFIFO((tmp_path / "fifo").lstat().st_mode)


def test_a_folder_that_stopped_being_ours_before_the_swap_is_put_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / MARKER).write_text("an earlier run's\n")
    staging = Staging("run")
    (staging.directory("--out", out) / "log.csv").write_text("new\n")
    real_rename = os.rename

    def swapped_meanwhile(src: Any, dst: Any) -> None:
        # the user puts their own folder in place between the commit's checks and the move aside
        if Path(src) == out and ".old" in str(dst):
            real_rename(out, tmp_path / "earlier")
            out.mkdir()
            (out / "notes.txt").write_text("the user's own\n")
        real_rename(src, dst)

    monkeypatch.setattr(os, "rename", swapped_meanwhile)
    with pytest.raises(ConfigError, match="no longer an agvctl output"):
        staging.commit()
    staging.discard()
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert (out / "notes.txt").read_text() == "the user's own\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["earlier", "out"]


# -- empty and over-long values ------------------------------------------------------------------------------------


@pytest.mark.parametrize("command", ["run", "plan"])
def test_an_empty_output_is_refused_naming_the_flag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    monkeypatch.chdir(_workspace(tmp_path))
    before = _tree(tmp_path)
    target = "experiments/line.toml" if command == "run" else "trajectories/line.toml"
    code, out, err = run(capsys, command, target, "--out", "")
    assert code == 2 and out == ""
    one_line(err, f"agvctl {command}: argument --out: must not be empty")
    assert _tree(tmp_path) == before


@pytest.mark.parametrize("command", ["run", "plan"])
def test_an_output_name_longer_than_the_file_system_allows_names_the_flag(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    monkeypatch.chdir(_workspace(tmp_path))
    before = _tree(tmp_path)
    target = "experiments/line.toml" if command == "run" else "trajectories/line.toml"
    for out_path in ("x" * 300, f"new/{'x' * 300}"):
        code, out, err = run(capsys, command, target, "--no-plot" if command == "run" else "--json", "--out", out_path)
        assert code == 2 and out == ""
        one_line(err, "agvctl: --out: cannot write ")
        assert _tree(tmp_path) == before


# -- only regular files of bounded size are read ------------------------------------------------------------------


def _within(seconds: float, argv: list[Any]) -> int:
    """``main(argv)`` in a thread; fails (after unblocking it) if it does not return within ``seconds``."""
    result: list[int] = []
    worker = threading.Thread(target=lambda: result.append(main([str(a) for a in argv])), daemon=True)
    worker.start()
    worker.join(seconds)
    if worker.is_alive():
        for a in argv:  # open each FIFO for writing and close it: a reader blocked on it sees end of file
            if Path(str(a)).is_fifo():
                fd = os.open(str(a), os.O_WRONLY | os.O_NONBLOCK)
                os.close(fd)
        worker.join(10)
        pytest.fail(f"agvctl {' '.join(map(str, argv))} blocked reading a FIFO")
    return result[0]


@pytest.mark.parametrize(
    "argv",
    [
        ["plan", TRAJECTORY, "--vehicle", "{fifo}"],
        ["plan", "{fifo}"],
        ["simulate", "--duration", "0.2", "--input", "{fifo}"],
        ["identify", "umbmark", "--log", "{fifo}"],
    ],
    ids=["vehicle", "path file", "DA profile", "UMBmark log"],
)
def test_a_fifo_as_an_input_is_refused_without_blocking(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[Any]
) -> None:
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    code = _within(60, [str(a).format(fifo=fifo) for a in argv])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {fifo}: cannot read: a FIFO (named pipe), not a regular file")


def test_a_device_as_the_vehicle_is_refused_unread(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "plan", TRAJECTORY, "--vehicle", "/dev/zero")
    assert code == 2 and out == ""
    one_line(err, "agvctl: /dev/zero: cannot read: a character device, not a regular file")


def test_a_device_as_the_trajectory_is_refused_naming_the_experiment_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    exp = tmp_path / "e.toml"
    exp.write_text('name = "e"\ntrajectory = "/dev/zero"\n')
    code, out, err = run(capsys, "run", exp, "--no-plot", "--out", tmp_path / "out")
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {exp}: trajectory: /dev/zero: cannot read: a character device, not a regular file")
    assert [p.name for p in tmp_path.iterdir()] == ["e.toml"]


def test_a_vehicle_file_larger_than_the_bound_is_refused_unread(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    big = tmp_path / "vehicle.toml"
    with big.open("wb") as fh:
        fh.truncate(60 * 2**20)  # 60 MB (sparse: nothing to write)
    code, out, err = run(capsys, "plan", TRAJECTORY, "--vehicle", big)
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {big}: cannot read: 60.0 MiB, larger than the 4 MiB accepted")


def test_a_file_is_read_up_to_the_bound_whatever_size_it_reports(tmp_path: Path) -> None:
    assert "Name:" in read_text("/proc/self/status")  # /proc says 0 bytes: what is read counts
    at_bound = tmp_path / "v.toml"
    at_bound.write_text("x" * MAX_FILE_BYTES)
    assert len(read_text(at_bound)) == MAX_FILE_BYTES
    with at_bound.open("a") as fh:
        fh.write("x")
    with pytest.raises(ConfigError, match="larger than the 4 MiB accepted"):
        read_text(at_bound)
