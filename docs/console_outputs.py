"""The command lines the guides show, run when the docs are built: each page includes what the command printed in
this build, so no number in those blocks is copied by hand.

Each command runs as ``agvctl`` (or, when its first word is ``python``, as a script of ``experiments/``) does, in a
scratch folder that holds ``experiments/`` and ``trajectories/`` (links to the repository's), so the paths it prints
are those a user in a checkout sees. ``conf.py`` calls :func:`write_outputs`; a page includes ``_generated/NAME.txt``
with ``literalinclude``. Each command costs the build a few seconds at most: a study too long for it is shown by a
smaller run of the same command, labelled as such where the page includes it.
"""

from __future__ import annotations

import glob
import os
import re
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
GENERATED = Path(__file__).resolve().parent / "_generated"

# name: (the arguments after `agvctl` (a shell's wildcards expanded) or `python` and a script, how many lines of the
# output to show: None for all, and a pattern of later lines shown too, after "...")
OUTPUTS: dict[str, tuple[list[str], int | None] | tuple[list[str], int | None, str]] = {
    "params": (["params"], None),
    "params_unknown_key": (["params", "--set", "wheels.left.radius=0.1"], None),
    "params_bad_friction": (["params", "--set", "motor.left.coulomb_friction_n_m=0.1"], None),
    "simulate": (["simulate", "--da-left", "2.0", "--da-right", "1.5", "--duration", "10", "--out", "log.csv"], None),
    "plan_figure8": (["plan", "trajectories/figure8.toml"], None),
    "run_figure8": (["run", "experiments/figure8.toml", "--no-plot"], 14),
    "tune": (["tune"], None),
    "identify_friction": (["identify", "friction", "--simulate"], 5),
    "identify_umbmark": (["identify", "umbmark", "--simulate"], None),
    "check_failing": (
        ["check", "experiments/*.toml", "tests/data/line_impossible.toml", "--jobs", "2", "--junit", "report.xml"],
        3,
        r"^(PASS|FAIL)  line_impossible|^    FAIL ",
    ),
    "params_com_behind_castor": (["params", "--set", "body.com_behind_axle_m=0.5"], None),
    "run_requirements": (["run", "experiments/requirements.toml", "--no-plot"], 0, r"^  requirement  "),
    # the acceptance fuzz's 500 scenarios take minutes: the guide shows its first 10
    "fuzz_acceptance_small": (
        ["fuzz", "experiments/fuzz/acceptance.toml", "--scenarios", "10", "--jobs", "2", "--no-plot"],
        None,
    ),
    "calibration_comparison": (["python", "experiments/calibration_comparison.py", "--seeds", "1"], None),
    "estimation_consistency": (["python", "experiments/estimation_consistency.py", "--runs", "2"], None),
    "model_comparison": (["python", "experiments/model_comparison.py"], None),
}


# progress lines a long command writes to standard error, which a page does not show
PROGRESS = re.compile(r"^fuzz(?: \S+)?: \d+ (?:of \d+ runs|runs on)")


def _command_line(argv: list[str]) -> str:
    return " ".join(argv) if argv[0] == "python" else " ".join(["agvctl", *argv])


def _shown(argv: list[str], text: str, lines: int | None, keep: str | None = None) -> str:
    out = text.rstrip("\n").splitlines()
    if lines is not None and len(out) > lines:
        later = [line for line in out[lines:] if keep is not None and re.search(keep, line)]
        out = [*out[:lines], "...", *later]
    return "\n".join([f"$ {_command_line(argv)}", *out]) + "\n"


def run_command(argv: list[str], lines: int | None = None, keep: str | None = None) -> str:
    """``$ agvctl ARGV`` (or ``$ python SCRIPT ARGS``) and what it printed (standard output, then standard error): its
    first ``lines`` lines and the later ones matching ``keep``."""
    env = {**os.environ, "MPLBACKEND": "Agg", "COLUMNS": "120"}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    with tempfile.TemporaryDirectory(prefix="agvctl-docs-") as scratch:
        for folder in ("experiments", "trajectories", "tests"):
            os.symlink(ROOT / folder, Path(scratch, folder), target_is_directory=True)
        expanded = [a for arg in argv for a in (sorted(glob.glob(arg, root_dir=scratch)) if "*" in arg else [arg])]
        done = subprocess.run(
            [sys.executable, *expanded[1:]] if argv[0] == "python" else [sys.executable, "-m", "agvctl", *expanded],
            cwd=scratch,
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
    stderr = "".join(line for line in done.stderr.splitlines(keepends=True) if not PROGRESS.match(line))
    text = (done.stdout + stderr).replace(str(ROOT / "agvctl" / "vehicles"), "...")
    return _shown(argv, text, lines, keep)


def write_outputs(folder: Path = GENERATED) -> list[Path]:
    """Run every command of :data:`OUTPUTS`, two at a time, and write each one's block as ``folder/NAME.txt``."""
    folder.mkdir(exist_ok=True)

    def write(name: str) -> Path:
        argv, lines, *keep = OUTPUTS[name]
        path = folder / f"{name}.txt"
        path.write_text(run_command(argv, lines, *keep), encoding="utf-8")
        return path

    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(write, OUTPUTS))


if __name__ == "__main__":
    for path in write_outputs():
        print(path.read_text(encoding="utf-8"))
